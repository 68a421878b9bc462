//! The GPU multigrid's coarse levels (issue 13 items 1 and 4) for `benches/RESULTS.md`, section
//! "Coarse operator and its storage (wave 6)": per scene and variant (Galerkin f32, Galerkin with
//! fp16 coarse entries, Galerkin with weak entries dropped, re-discretized) one cold GPU solve to
//! 1e-4: cycles, work units, matvec units, the multigrid's bytes per finest node, wall ms of the
//! solve (median of 3 after a warm-up, `COARSE_REPEATS=N` for N; lavapipe runs the submission on
//! the CPU) and the J+ error
//! against the f64 exact solve (PCG to 1e-10) of the same graph and q.
//!
//! ```text
//! cargo run --release -p translucent-benches --bin coarse_operator -- [SCENE...]
//! COARSE_VARIANTS='drop=0;drop=0.05' cargo run --release -p translucent-benches --bin coarse_operator -- contrast
//! ```
//! SCENE: `default` (torus 50 mm, skim milk), `spot` (50 mm, marble), `agate` (torus, the
//! procedural agate of `--material agate`), `contrast` (torus, sigma_s' 0.1 / 1000 across a plane,
//! no absorption); default: all. Resolution 29 (render's auto choice for these), 3 levels.

use std::time::Instant;

use glam::DVec3;
use translucent::material::{Coefficients, Material, MaterialField, Procedural};
use translucent::mesh::shapes::Shape;
use translucent::mesh::{MeshSolid, TriMesh, ValidateOptions};
use translucent::quadgraph::BakeParams;
use translucent::scene::{Environment, Light, Scene};
use translucent::solver::gpu::{GpuDiffusion, GpuSolveParams};
use translucent::solver::multigrid::{CoarseOperator, Lumping, MultigridParams, OperatorStorage};
use translucent::solver::{self, rel_rms, CpuSolveParams};
use translucent::vk::{Context, ContextDesc};
use translucent::QuadGraph;

type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

/// Render's auto resolution for the default scene, spot and the agate torus (29).
const RESOLUTION: u32 = 29;
const TOLERANCE: f64 = 1e-4;
/// Timed solves per variant (after one warm-up); `COARSE_REPEATS` overrides.
const REPEATS: usize = 3;

fn bake(surface: &TriMesh, solid: &dyn translucent::mesh::Solid) -> Result<QuadGraph> {
    let params = BakeParams {
        resolution: RESOLUTION,
        levels: 3,
        ..Default::default()
    };
    Ok(QuadGraph::bake(surface, solid, &params, &mut |_| {})?.0)
}

fn torus() -> Shape {
    Shape::Torus {
        major: 17.5,
        minor: 7.5,
    }
}

fn scene_of(name: &str) -> Result<(QuadGraph, MaterialField)> {
    let preset =
        |n: &str| -> Result<MaterialField> { Ok(MaterialField::Homogeneous(Material::preset(n)?)) };
    Ok(match name {
        "default" => (
            bake(&torus().triangulate(64), &torus())?,
            preset("skimmilk")?,
        ),
        "spot" => {
            let dir = std::env::var("TRANSLUCENT_MESH_DIR").unwrap_or("../shared/meshes".into());
            let (solid, _, _) = MeshSolid::load(
                std::path::Path::new(&dir).join("spot.obj"),
                50.0,
                &ValidateOptions::default(),
            )?;
            let surface = solid.mesh().clone();
            (bake(&surface, &solid)?, preset("marble")?)
        }
        "agate" => {
            let field = MaterialField::procedural(
                Procedural::Agate {
                    a: Material::preset("wholemilk")?.coefficients(),
                    b: Coefficients::new([0.9, 0.5, 0.4], [0.01, 0.09, 0.2])?,
                    band_mm: 5.0,
                    warp: 0.6,
                    seed: 3,
                },
                1.3,
            )?;
            (bake(&torus().triangulate(64), &torus())?, field)
        }
        "contrast" => {
            let c = |s: f64| Coefficients::new([s; 3], [0.0; 3]);
            let field = MaterialField::procedural(
                Procedural::Split {
                    normal: DVec3::new(1.0, 0.3, 0.1).normalize(),
                    offset: 0.0,
                    below: c(0.1)?,
                    above: c(1000.0)?,
                },
                1.3,
            )?;
            (bake(&torus().triangulate(64), &torus())?, field)
        }
        other => return Err(format!("unknown scene {other}").into()),
    })
}

fn scene() -> Scene {
    let lights: Vec<Light> = vec![
        "dir:0.2,-0.35,1:5,5,5".parse().expect("light"),
        "dir:-0.6,-0.7,-0.4:0.6,0.6,0.6".parse().expect("light"),
    ];
    Scene {
        lights,
        environment: Environment::Constant([0.05; 3]),
    }
}

fn variants() -> Result<Vec<(String, MultigridParams)>> {
    let f16 = MultigridParams::gpu();
    // `COARSE_VARIANTS`: `;`-separated `--multigrid-cycle` specs over the GPU defaults (wave 8:
    // `drop=0.05,lump=paths`); unset: the wave-6 list.
    if let Ok(specs) = std::env::var("COARSE_VARIANTS") {
        return specs
            .split(';')
            .map(|spec| Ok((spec.to_string(), f16.with_cycle_spec(spec)?)))
            .collect();
    }
    let f32 = MultigridParams {
        coarse_storage: OperatorStorage::F32,
        ..f16.clone()
    };
    let diagonal = |params: &MultigridParams| MultigridParams {
        sparsify: Some(0.02),
        lumping: Lumping::Diagonal,
        ..params.clone()
    };
    Ok(vec![
        ("galerkin f32 (wave 5)".into(), f32.clone()),
        ("galerkin f16 (default)".into(), f16.clone()),
        ("galerkin drop 0.02".into(), diagonal(&f32)),
        ("galerkin drop 0.02 + f16".into(), diagonal(&f16)),
        (
            "rediscretized".into(),
            MultigridParams {
                coarse: CoarseOperator::Rediscretized,
                ..f32
            },
        ),
    ])
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let scenes: Vec<&str> = if args.is_empty() {
        vec!["default", "spot", "agate", "contrast"]
    } else {
        args.iter().map(String::as_str).collect()
    };
    let repeats: usize = match std::env::var("COARSE_REPEATS") {
        Ok(v) => v.parse()?,
        Err(_) => REPEATS,
    };
    let ctx = Context::headless(&ContextDesc::default())?;
    println!("| scene | variant | finest nodes | multigrid B/node | total B/node | cycles | WU | matvec units | residual | ms (median of {repeats}) | J+ vs f64 exact |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    for name in scenes {
        let (graph, field) = scene_of(name)?;
        let sc = scene();
        let q64 = sc.surface_irradiance(graph.finest(), field.eta(), None);
        let q: Vec<[f32; 3]> = q64.iter().map(|v| v.map(|x| x as f32)).collect();
        let exact = solver::solve(&graph, &field, &sc, None, &CpuSolveParams::default())?;
        let finest = graph.finest().node_count();
        for (what, mg) in variants()? {
            let params = GpuSolveParams {
                tolerance: TOLERANCE as f32,
                multigrid: Some(MultigridParams {
                    tolerance: TOLERANCE,
                    ..mg
                }),
                ..Default::default()
            };
            let mut gpu = GpuDiffusion::new(&ctx, &graph, &field, &params)?;
            gpu.set_q_scale(GpuDiffusion::exposure_for(q.iter()));
            gpu.upload_q(&ctx, graph.levels.len() - 1, &q)?;
            let mut ms = Vec::new();
            for _ in 0..=repeats {
                let start = Instant::now();
                translucent::frame::quadgraph::solve_headless(&ctx, &mut gpu, false)?;
                ms.push(start.elapsed().as_secs_f64() * 1e3);
            }
            ms.remove(0); // the warm-up compiles the pipelines
            ms.sort_by(f64::total_cmp);
            let report = gpu.multigrid_report(&ctx)?.ok_or("no multigrid report")?;
            let j = gpu.read_j_plus(&ctx)?;
            let err = rel_rms(&j, &exact.j_plus_clamped);
            let bytes = gpu.bytes_breakdown();
            let per = |b: u64| b as f64 / finest as f64;
            println!(
                "| {name} | {what} | {finest} | {:.0} | {:.0} | {} | {:.1} | {:.1} | {:.1e} ({:?}) | {:.0} | {:.2e} |",
                per(bytes.multigrid),
                per(bytes.total()),
                report.cycles.len(),
                report.work_units,
                report.matvec_units,
                report.residual,
                report.state,
                ms[ms.len() / 2],
                err
            );
        }
    }
    Ok(())
}
