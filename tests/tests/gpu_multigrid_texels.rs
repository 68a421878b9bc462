//! The GPU multigrid's residual and smoothing kernels reading their read-only inputs through
//! uniform texel views (`TRANSLUCENT_MULTIGRID_READS=texel`, `TEXEL_READS` in
//! `multigrid/residual.comp` and `multigrid/smooth.comp`; benches/RESULTS.md "Fewer bytes per
//! finest pass (wave 11)") do the storage-buffer reads' solve: the same residual after every cycle,
//! the same work units, the same J+; and both reach the f64 exact solve. Cold and warm solves, on
//! the matrix-free finest level (the default) and on its compressed rows (where level 1's fp16
//! Galerkin rows and the finest f32 rows are read through `values16_t` and `values_t`).
//! Validation (with synchronization validation) is on and any message fails.
//!
//! One test in this binary: the reads are chosen by an environment variable read when the
//! multigrid is created, which no other test of this process may see.

use translucent::material::{Material, MaterialField};
use translucent::mesh::shapes::Shape;
use translucent::quadgraph::BakeParams;
use translucent::scene::{Environment, Light, Scene};
use translucent::solver::gpu::multigrid::GpuMultigridReport;
use translucent::solver::gpu::{GpuDiffusion, GpuSolveParams};
use translucent::solver::multigrid::{FinestOperator, MultigridParams};
use translucent::solver::{self, rel_rms, CpuSolveParams};
use translucent::vk::Context;
use translucent::QuadGraph;
use translucent_tests::{solve_once, tol, GpuTest};

/// Relative residual the GPU cycles stop at (as tests/tests/gpu_multigrid.rs).
const TOLERANCE: f32 = 1e-5;
/// The texel and the storage-buffer reads' residual after each cycle: the same values read, the
/// same operations in the same order, so equal to f32 rounding at most (measured: identical).
const SAME_RESIDUAL: f64 = 1e-6;
/// J+ of the texel against the storage-buffer reads (measured: identical).
const SAME_J_PLUS: f64 = 1e-7;

fn graph() -> QuadGraph {
    let shape = Shape::Torus {
        major: 17.5,
        minor: 7.5,
    };
    let params = BakeParams {
        resolution: 20,
        levels: 3,
        ..Default::default()
    };
    QuadGraph::bake(&shape.triangulate(40), &shape, &params, &mut |_| {})
        .expect("bake")
        .0
}

fn scene(light: &str) -> Scene {
    Scene {
        lights: vec![light.parse::<Light>().unwrap()],
        environment: Environment::Constant([0.05; 3]),
    }
}

/// A cold solve of the first light, then a warm one of the second: J+ and the report of each.
fn solves(
    ctx: &Context,
    graph: &QuadGraph,
    field: &MaterialField,
    finest: FinestOperator,
) -> Vec<(Vec<[f32; 3]>, GpuMultigridReport)> {
    let params = GpuSolveParams {
        tolerance: TOLERANCE,
        multigrid: Some(MultigridParams {
            finest_operator: finest,
            ..MultigridParams::gpu()
        }),
        ..Default::default()
    };
    let mut gpu = GpuDiffusion::new(ctx, graph, field, &params).expect("gpu multigrid");
    let mut out = Vec::new();
    for (light, warm) in [
        ("dir:0.2,-0.35,1:5,5,5", false),
        ("dir:0.25,-0.3,1:5,5,5", true),
    ] {
        let q: Vec<[f32; 3]> = scene(light)
            .surface_irradiance(graph.finest(), field.eta(), None)
            .iter()
            .map(|v| v.map(|x| x as f32))
            .collect();
        if !warm {
            gpu.set_q_scale(GpuDiffusion::exposure_for(q.iter()));
        }
        gpu.upload_q(ctx, graph.levels.len() - 1, &q)
            .expect("upload q");
        solve_once(ctx, &mut gpu, warm);
        let report = gpu
            .multigrid_report(ctx)
            .expect("report")
            .expect("the multigrid schedule");
        assert_eq!(report.warm, warm, "{finest:?}: the planned start");
        out.push((gpu.read_j_plus(ctx).expect("J+"), report));
    }
    out
}

#[test]
fn texel_reads_give_the_storage_buffer_reads_solve() {
    let t = GpuTest::new();
    let graph = graph();
    let field = MaterialField::Homogeneous(Material::preset("skimmilk").unwrap());
    let exact = solver::solve(
        &graph,
        &field,
        &scene("dir:0.2,-0.35,1:5,5,5"),
        None,
        &CpuSolveParams::default(),
    )
    .expect("exact");
    for finest in [FinestOperator::Graph, FinestOperator::Csr] {
        std::env::set_var("TRANSLUCENT_MULTIGRID_READS", "buffer");
        let buffer = solves(&t.ctx, &graph, &field, finest);
        std::env::set_var("TRANSLUCENT_MULTIGRID_READS", "texel");
        let texel = solves(&t.ctx, &graph, &field, finest);
        for ((j_buffer, buffer), (j_texel, texel)) in buffer.iter().zip(&texel) {
            let what = format!("{finest:?}, warm {}", buffer.warm);
            // The switch reached the kernels.
            assert!(
                texel.texel_reads && !buffer.texel_reads,
                "{what}: texel reads {} / {}",
                texel.texel_reads,
                buffer.texel_reads
            );
            assert!(
                texel.converged && buffer.converged,
                "{what}: {texel:?} / {buffer:?}"
            );
            assert_eq!(texel.cycles.len(), buffer.cycles.len(), "{what}: cycles");
            assert!(
                (texel.work_units - buffer.work_units).abs() < 1e-9,
                "{what}: work units {} against {}",
                texel.work_units,
                buffer.work_units
            );
            let logs = [
                (texel.start_residual, buffer.start_residual),
                (texel.residual, buffer.residual),
            ];
            let cycles = texel.cycles.iter().zip(&buffer.cycles);
            for (a, b) in logs
                .into_iter()
                .chain(cycles.map(|(a, b)| (a.residual, b.residual)))
            {
                let rel = (a - b).abs() / b;
                assert!(
                    rel <= SAME_RESIDUAL,
                    "{what}: residual {a} against {b} ({rel:.1e})"
                );
            }
            let to64 =
                |v: &[[f32; 3]]| -> Vec<[f64; 3]> { v.iter().map(|p| p.map(f64::from)).collect() };
            let d = rel_rms(&to64(j_texel), &to64(j_buffer));
            assert!(
                d <= SAME_J_PLUS,
                "{what}: J+ {d:.1e} from the storage-buffer reads'"
            );
        }
        // The cold solve reaches the f64 exact one (the warm one solves another light).
        let d = rel_rms(
            &texel[0]
                .0
                .iter()
                .map(|p| p.map(f64::from))
                .collect::<Vec<_>>(),
            &exact.j_plus_clamped,
        );
        assert!(
            d < tol::GPU_VS_EXACT,
            "{finest:?}: J+ {d:.2e} from the f64 exact solve"
        );
    }
    t.finish();
}
