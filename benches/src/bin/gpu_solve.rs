//! GPU diffusion solve measurements for `benches/RESULTS.md` (gpu section), each solve one frame
//! of a `TranslucentObject` rendered by the headless host (shadow maps, irradiance gather, a cold
//! multi-level solve, exitance, shading): the frame the object ships, timed by its timestamps.
//! 1. multi-level against single-level (paper Fig. 14): for a list of tolerances, the Jacobi
//!    iterations the GPU ran (its counter), GPU time of the solve (the frame's `diffusion` and
//!    `exitance` passes) and the J+ error against the exact f64 solve (PCG) of the q the frame
//!    gathered, for `levels = 3` and `levels = 1` bakes of the same finest level; CSV + PNG plot;
//! 2. per-pass GPU timings of one frame of spot and nefertiti (when the meshes are found).
//!
//! ```text
//! cargo run --release -p translucent-benches --bin gpu_solve -- [OUT_DIR] [RESOLUTION]
//! ```
//! Writes `OUT_DIR/gpu_multilevel.csv`, `OUT_DIR/gpu_multilevel.png` (default OUT_DIR
//! `benches/results`), prints markdown tables. `TRANSLUCENT_DEVICE` picks the Vulkan device;
//! `TRANSLUCENT_VALIDATION=1` prints validation messages.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use translucent::headless::HeadlessHost;
use translucent::material::{Material, MaterialField};
use translucent::mesh::shapes::Shape;
use translucent::mesh::{MeshSolid, Solid, TriMesh, ValidateOptions};
use translucent::quadgraph::BakeParams;
use translucent::scene::{Environment, Scene};
use translucent::solver::gpu::{GpuSolveParams, Precision, PASS_EXITANCE, PASS_SOLVE};
use translucent::solver::krylov;
use translucent::solver::operator::LevelOperator;
use translucent::solver::{self, CpuSolveParams, Scheme};
use translucent::vk::{Access, Context, ContextDesc, ImageReadback};
use translucent::{ObjectParams, QuadGraph, TranslucentObject};
use translucent_benches::plot::{error_vs_time, palette, Panel, Series};

type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

fn scene() -> Scene {
    Scene {
        lights: vec!["dir:-0.3,-1,0.2:1,1,1".parse().expect("light")],
        environment: Environment::Constant([0.05; 3]),
    }
}

struct Run {
    iterations: Vec<u32>,
    /// GPU ms of the solve as the frame ships it: its `diffusion` and `exitance` passes.
    ms: f64,
    /// GPU ms per pass of the whole frame (nested scopes summed by name; the host's capture left
    /// out).
    passes: BTreeMap<String, f64>,
    j_plus: Vec<[f32; 3]>,
    /// The q the frame gathered at the finest surface nodes (unscaled): what the GPU solved.
    q: Vec<[f64; 3]>,
    bytes: (u64, f64),
}

/// The per-level iteration cap. The headless host's profiler holds 4096 scopes per frame and a
/// solve records two per block of `block` iterations (blocks after convergence are recorded but
/// dispatch nothing): 4000 iterations x 3 levels / 8 x 2 = 3000 scopes. The tolerances measured
/// here stop every level well below it (at most 2640 iterations, benches/RESULTS.md).
const CAP: u32 = 4000;

/// One frame of a `TranslucentObject` (shadow maps, gather, a cold multi-level solve on
/// `graph`'s levels, exitance, shading) rendered by the headless host: the frame the object
/// ships. Times its solve passes from the host's timestamps and reads back J+ and the gathered q.
fn run(
    ctx: &Context,
    graph: &Arc<QuadGraph>,
    field: &MaterialField,
    params: &GpuSolveParams,
) -> Result<Run> {
    let mut object = TranslucentObject::new(
        ctx,
        graph.clone(),
        field,
        &scene(),
        &ObjectParams {
            solve: params.clone(),
            // Every level iterates (the 1-level bake is the single-level comparison).
            single_level_nodes: 0,
            // A cold solve every frame.
            skip: false,
            ..ObjectParams::default()
        },
    )?;
    let mut host = HeadlessHost::new(ctx, 64, 64)?;
    let (captured, report) = host.render(ctx, &mut object)?;
    if report.warm_start || !report.passes.contains(&PASS_SOLVE) {
        return Err(format!("the frame did not run a cold solve: {report:?}").into());
    }
    let timings = captured
        .timings
        .as_ref()
        .ok_or("no GPU timestamps on this device: gpu_solve measures GPU time")?;
    // The capture is recorded last: without it the profiler ran out of scopes and the solve's
    // time would be short.
    if !captured.passes.contains_key("capture") {
        return Err("the frame profiler ran out of timestamp scopes (lower CAP)".into());
    }
    let ms = timings
        .scopes
        .iter()
        .filter(|s| s.depth == 0 && (s.name == PASS_SOLVE || s.name == PASS_EXITANCE))
        .map(|s| s.duration_ms)
        .sum();
    let mut passes = captured.passes;
    passes.remove("capture");
    let method = object
        .quadgraph()
        .ok_or("the QuadGraph method reports the solve")?;
    let solve = method.solve();
    let finest = graph.levels.len() - 1;
    let level = graph.finest();
    let gathered = ImageReadback::capture(
        ctx,
        solve.q_image(finest).ok_or("no q image")?,
        Access::ComputeReadWrite,
    )?;
    let unscale = 1.0 / f64::from(method.q_scale());
    let q = level.packing.texels[level.inner_count()..]
        .iter()
        .map(|&[u, v]| {
            let p = gathered.pixel(u, v);
            [p[0], p[1], p[2]].map(|x| f64::from(x) * unscale)
        })
        .collect();
    Ok(Run {
        iterations: solve.iterations_run(ctx)?,
        ms,
        passes,
        j_plus: solve.read_j_plus(ctx)?,
        q,
        bytes: solve.bytes(),
    })
}

/// The exact f64 J+ at the finest surface nodes for the gathered `q` (PCG to 1e-10 from `phi`),
/// clamped at 0 as the GPU's.
fn exact_for_q(
    graph: &QuadGraph,
    field: &MaterialField,
    scheme: Scheme,
    q: &[[f64; 3]],
    phi: &[[f64; 3]],
) -> Result<Vec<[f64; 3]>> {
    let level = graph.finest();
    let op = LevelOperator::build(level, field, scheme)?;
    let b = op.rhs(q);
    let mut phi = phi.to_vec();
    let report = krylov::solve(&op, &b, &mut phi, 1e-10, 100_000);
    if !report.converged {
        return Err(format!(
            "the exact solve did not converge (relative residual {:?})",
            report.residual
        )
        .into());
    }
    let inner = level.inner_count();
    Ok(q.iter()
        .enumerate()
        .map(|(s, q)| {
            std::array::from_fn(|c| {
                ((1.0 + 1.0 / op.a) * phi[inner + s][c] / 4.0 - q[c] / (1.0 + op.f_dr)).max(0.0)
            })
        })
        .collect())
}

fn rel_rms(gpu: &[[f32; 3]], exact: &[[f64; 3]]) -> f64 {
    let (mut d2, mut r2) = (0.0, 0.0);
    for (g, e) in gpu.iter().zip(exact) {
        for c in 0..3 {
            d2 += (f64::from(g[c]) - e[c]).powi(2);
            r2 += e[c] * e[c];
        }
    }
    (d2 / r2.max(f64::MIN_POSITIVE)).sqrt()
}

fn bake(mesh: &TriMesh, solid: &dyn Solid, resolution: u32, levels: u32) -> Result<Arc<QuadGraph>> {
    let params = BakeParams {
        resolution,
        levels,
        ..Default::default()
    };
    Ok(Arc::new(
        QuadGraph::bake(mesh, solid, &params, &mut |_| {})?.0,
    ))
}

fn multilevel(ctx: &Context, out: &Path, resolution: u32) -> Result<()> {
    let ball = Shape::Sphere { radius: 10.0 };
    let mesh = ball.triangulate(48);
    let field = MaterialField::Homogeneous(Material::preset("skin1")?);
    let tolerances = [3e-2f32, 1e-2, 3e-3, 1e-3, 3e-4, 1e-4];
    let mut csv = String::from("levels,tolerance,iterations,node_updates,gpu_ms,rel_rms_error\n");
    let mut series: Vec<(u32, Vec<(f64, f64)>)> = Vec::new();
    // Deterministic work measure (lavapipe timings move with the machine's load): node updates,
    // sum over levels of iterations x nodes.
    let mut work_series: Vec<(u32, Vec<(f64, f64)>)> = Vec::new();
    println!("| levels | tolerance | iterations per level (GPU counter) | node updates | GPU ms | J+ rel. RMS error vs exact |\n|---|---|---|---|---|---|");
    for levels in [1u32, 3] {
        let graph = bake(&mesh, &ball, resolution, levels)?;
        let exact = solver::solve(
            &graph,
            &field,
            &scene(),
            None,
            &CpuSolveParams {
                iterations: vec![0],
                ..Default::default()
            },
        )?;
        // The exact solution for the q the frame gathered (the same at every tolerance: same
        // lights, shadow maps and exposure).
        let mut same_q: Option<Vec<[f64; 3]>> = None;
        let mut points = Vec::new();
        let mut work = Vec::new();
        let nodes: Vec<f64> = graph.levels.iter().map(|l| l.node_count() as f64).collect();
        for &tol in &tolerances {
            let params = GpuSolveParams {
                precision: Precision::Mixed,
                iterations: vec![CAP],
                tolerance: tol,
                ..Default::default()
            };
            let r = run(ctx, &graph, &field, &params)?;
            if r.iterations.iter().any(|&i| i >= CAP) {
                println!("(levels {levels}, tolerance {tol:.0e}: a level reached the cap {CAP})");
            }
            let reference = match &same_q {
                Some(j) => j,
                None => same_q.insert(exact_for_q(
                    &graph,
                    &field,
                    params.scheme,
                    &r.q,
                    &exact.phi,
                )?),
            };
            let err = rel_rms(&r.j_plus, reference);
            let updates: f64 = r
                .iterations
                .iter()
                .zip(&nodes)
                .map(|(&i, n)| f64::from(i) * n)
                .sum();
            println!(
                "| {levels} | {tol:.0e} | {:?} | {:.2e} | {:.1} | {err:.2e} |",
                r.iterations, updates, r.ms
            );
            csv.push_str(&format!(
                "{levels},{tol},{},{updates},{:.3},{err:.4e}\n",
                r.iterations.iter().sum::<u32>(),
                r.ms
            ));
            points.push((r.ms.max(1e-3), err.max(1e-7)));
            work.push((updates.max(1.0), err.max(1e-7)));
        }
        series.push((levels, points));
        work_series.push((levels, work));
    }
    std::fs::write(out.join("gpu_multilevel.csv"), csv)?;
    plot(&out.join("gpu_multilevel.png"), &series)?;
    plot(&out.join("gpu_multilevel_work.png"), &work_series)?;
    Ok(())
}

/// One colour per level count, in the order of `series` (RESULTS.md names them).
fn plot(path: &Path, series: &[(u32, Vec<(f64, f64)>)]) -> Result<()> {
    let panel = Panel {
        series: series
            .iter()
            .enumerate()
            .map(|(i, (levels, points))| Series {
                name: format!("{levels} levels"),
                colour: palette(i),
                points: points.clone(),
            })
            .collect(),
        front: Vec::new(),
        floors: Vec::new(),
    };
    error_vs_time(path, &[panel])
}

fn per_pass(ctx: &Context, mesh_dir: &Path, resolution: u32) -> Result<()> {
    let field = MaterialField::Homogeneous(Material::preset("marble")?);
    for name in ["spot", "nefertiti"] {
        let path = mesh_dir.join(format!("{name}.obj"));
        if !path.exists() {
            println!("{name}: {} not found, skipped", path.display());
            continue;
        }
        let mut mesh = TriMesh::load_obj(&path)?;
        mesh.validate(&ValidateOptions::default())?;
        let (mut mesh, _) = mesh.normalized(50.0)?;
        mesh.compute_normals();
        let solid = MeshSolid::new(mesh.clone())?;
        let graph = bake(&mesh, &solid, resolution, 3)?;
        let nodes: Vec<usize> = graph.levels.iter().map(|l| l.node_count()).collect();
        let exact = solver::solve(
            &graph,
            &field,
            &scene(),
            None,
            &CpuSolveParams {
                iterations: vec![0],
                ..Default::default()
            },
        )?;
        for precision in [Precision::Mixed, Precision::Fp32, Precision::Fp16] {
            let params = GpuSolveParams {
                precision,
                iterations: vec![400],
                tolerance: 1e-3,
                ..Default::default()
            };
            let r = run(ctx, &graph, &field, &params)?;
            let (bytes, per_node) = r.bytes;
            let passes: Vec<String> = r
                .passes
                .iter()
                .map(|(k, v)| format!("{k} {v:.2}"))
                .collect();
            let reference = exact_for_q(&graph, &field, params.scheme, &r.q, &exact.phi)?;
            let err = rel_rms(&r.j_plus, &reference);
            println!(
                "| {name} | {nodes:?} | {precision:?} | {:?} | {err:.1e} | {:.1} | {} | {:.1} MB, {per_node:.0} B/node |",
                r.iterations,
                r.ms,
                passes.join(", "),
                bytes as f64 / 1e6
            );
        }
    }
    Ok(())
}

fn main() -> Result<()> {
    let mut args = std::env::args().skip(1);
    let out = PathBuf::from(args.next().unwrap_or_else(|| "benches/results".into()));
    let resolution: u32 = args.next().map(|s| s.parse()).transpose()?.unwrap_or(24);
    std::fs::create_dir_all(&out)?;
    let device = std::env::var("TRANSLUCENT_DEVICE")
        .ok()
        .filter(|d| !d.is_empty());
    let ctx = Context::headless(&ContextDesc {
        device_name: device,
        // `TRANSLUCENT_VALIDATION=1`: validation messages are printed as they come.
        echo_validation: true,
        ..ContextDesc::default()
    })?;
    println!("device: {}", ctx.info().device_name);
    multilevel(&ctx, &out, resolution)?;
    let mesh_dir = std::env::var_os("TRANSLUCENT_MESH_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("../shared/meshes"));
    println!("| mesh | nodes per level | precision | iterations | J+ error vs exact | GPU ms | passes (ms) | memory |\n|---|---|---|---|---|---|---|---|");
    per_pass(&ctx, &mesh_dir, resolution)?;
    Ok(())
}
