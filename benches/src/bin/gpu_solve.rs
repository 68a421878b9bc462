//! GPU diffusion solve measurements for `benches/RESULTS.md` (gpu section):
//! 1. multi-level against single-level (paper Fig. 14): for a list of tolerances, the Jacobi
//!    iterations the GPU ran (its counter), GPU time (timestamps) and the J+ error against the exact
//!    f64 solve, for `levels = 3` and `levels = 1` bakes of the same finest level; CSV + PNG plot;
//! 2. per-pass GPU timings of one solve of spot and nefertiti (when the meshes are found).
//!
//! ```text
//! cargo run --release -p translucent-benches --bin gpu_solve -- [OUT_DIR] [RESOLUTION]
//! ```
//! Writes `OUT_DIR/gpu_multilevel.csv`, `OUT_DIR/gpu_multilevel.png` (default OUT_DIR
//! `benches/results`), prints markdown tables. `TRANSLUCENT_DEVICE` picks the Vulkan device.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use translucent::material::{Material, MaterialField};
use translucent::mesh::shapes::Shape;
use translucent::mesh::{MeshSolid, Solid, TriMesh, ValidateOptions};
use translucent::quadgraph::BakeParams;
use translucent::scene::{Environment, Scene};
use translucent::solver::gpu::{GpuDiffusion, GpuSolveParams, Precision};
use translucent::solver::{self, CpuSolveParams};
use translucent::vk::{Context, ContextDesc, GpuProfiler};
use translucent::QuadGraph;
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
    ms: f64,
    passes: BTreeMap<String, f64>,
    j_plus: Vec<[f32; 3]>,
}

fn run(
    ctx: &Context,
    graph: &QuadGraph,
    field: &MaterialField,
    params: &GpuSolveParams,
) -> Result<Run> {
    let q: Vec<Vec<[f32; 3]>> = graph
        .levels
        .iter()
        .map(|l| {
            scene()
                .surface_irradiance(l, field.eta(), None)
                .iter()
                .map(|v| v.map(|x| x as f32))
                .collect()
        })
        .collect();
    let mut gpu = GpuDiffusion::new(ctx, graph, field, params)?;
    gpu.set_q_scale(GpuDiffusion::exposure_for(q.iter().flatten()));
    for (h, q) in q.iter().enumerate() {
        gpu.upload_q(ctx, h, q)?;
    }
    let mut profiler = GpuProfiler::new(ctx, "gpu solve", 16384)?;
    let mut frame = 0;
    ctx.execute("gpu solve", |cb| {
        frame = ctx.frames().0;
        // SAFETY: `cb` is recording; `gpu` and `profiler` outlive the waited submission.
        unsafe {
            profiler.begin_frame(cb, frame);
            gpu.record(ctx, cb, Some(&mut profiler));
        }
        Ok(())
    })?;
    profiler.frame_completed(frame);
    let passes = profiler.latest().map(|t| t.passes()).unwrap_or_default();
    Ok(Run {
        iterations: gpu.iterations_run(ctx)?,
        ms: passes.values().sum(),
        passes,
        j_plus: gpu.read_j_plus(ctx)?,
    })
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

fn bake(mesh: &TriMesh, solid: &dyn Solid, resolution: u32, levels: u32) -> Result<QuadGraph> {
    let params = BakeParams {
        resolution,
        levels,
        ..Default::default()
    };
    Ok(QuadGraph::bake(mesh, solid, &params, &mut |_| {})?.0)
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
        let mut points = Vec::new();
        let mut work = Vec::new();
        let nodes: Vec<f64> = graph.levels.iter().map(|l| l.node_count() as f64).collect();
        for &tol in &tolerances {
            let params = GpuSolveParams {
                precision: Precision::Mixed,
                iterations: vec![20_000],
                tolerance: tol,
                ..Default::default()
            };
            let r = run(ctx, &graph, &field, &params)?;
            let err = rel_rms(&r.j_plus, &exact.j_plus_clamped);
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
            .map(|(i, (_, points))| Series {
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
            let gpu = GpuDiffusion::new(ctx, &graph, &field, &params)?;
            let (bytes, per_node) = gpu.bytes();
            drop(gpu);
            let r = run(ctx, &graph, &field, &params)?;
            let passes: Vec<String> = r
                .passes
                .iter()
                .map(|(k, v)| format!("{k} {v:.2}"))
                .collect();
            let err = rel_rms(&r.j_plus, &exact.j_plus_clamped);
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
