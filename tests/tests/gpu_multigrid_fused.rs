//! The GPU multigrid's fused kernels (issue 13, time per work unit; benches/RESULTS.md "Time per
//! work unit (wave 9)"): the coarsest level solved by one workgroup (`multigrid/coarse.comp`) and
//! the smoothing steps as fused passes (`multigrid/relax.comp`, finest level or every level above
//! the coarsest; benches/RESULTS.md "Cheaper multigrid passes (wave 10)") do the arithmetic of
//! the split kernels (`residual.comp` + `smooth.comp` per step): the same residual after every
//! cycle to f32 rounding, the same work units, the same J+; and both reach the f64 exact solve.
//! Cold and warm solves, on the matrix-free finest level (the default) and on its compressed
//! rows. Validation (with synchronization validation) is on and any message fails.
//!
//! One test in this binary: the kernels are chosen by environment variables
//! (`TRANSLUCENT_MULTIGRID_COARSE=split` against the default one-workgroup coarsest solve,
//! `TRANSLUCENT_MULTIGRID_RELAX=fused|all` against the default split steps; read when the multigrid
//! is created), which no other test of this process may see.

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
/// The fused and split kernels' residual after each cycle: the same arithmetic in another order
/// (the coarsest Chebyshev coefficients in f32 instead of f64, sums in another order), so equal
/// to well below the factor of a cycle (~0.1); measured 6.5e-6 relative.
const SAME_RESIDUAL: f64 = 1e-3;
/// J+ of the fused against the split kernels: f32 rounding of the same cycles (measured 2.5e-7).
const SAME_J_PLUS: f64 = 1e-5;

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

/// The split kernels (`None`), or the one-workgroup coarsest solve with the fused relaxation on
/// `Some(levels)` (`fused`: the finest level, `all`: every level above the coarsest).
fn set_kernels(relax: Option<&str>) {
    match relax {
        None => {
            std::env::set_var("TRANSLUCENT_MULTIGRID_COARSE", "split");
            std::env::set_var("TRANSLUCENT_MULTIGRID_RELAX", "split");
        }
        Some(levels) => {
            std::env::remove_var("TRANSLUCENT_MULTIGRID_COARSE");
            std::env::set_var("TRANSLUCENT_MULTIGRID_RELAX", levels);
        }
    }
}

#[test]
fn fused_kernels_do_the_split_kernels_arithmetic() {
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
    // Every level's fused steps (`all`: level 1's Galerkin fp16 rows too) on the default finest
    // operator only (the test's time).
    for (finest, relax) in [
        (FinestOperator::Graph, "fused"),
        (FinestOperator::Csr, "fused"),
        (FinestOperator::Graph, "all"),
    ] {
        set_kernels(None);
        let split = solves(&t.ctx, &graph, &field, finest);
        set_kernels(Some(relax));
        let fused = solves(&t.ctx, &graph, &field, finest);
        for ((j_split, split), (j_fused, fused)) in split.iter().zip(&fused) {
            let what = format!("{finest:?}, {relax}, warm {}", split.warm);
            assert!(
                fused.converged && split.converged,
                "{what}: {fused:?} / {split:?}"
            );
            assert_eq!(fused.cycles.len(), split.cycles.len(), "{what}: cycles");
            assert!(
                (fused.work_units - split.work_units).abs() < 1e-9,
                "{what}: work units {} against {}",
                fused.work_units,
                split.work_units
            );
            for (a, b) in fused.cycles.iter().zip(&split.cycles) {
                let rel = (a.residual - b.residual).abs() / b.residual;
                assert!(
                    rel < SAME_RESIDUAL,
                    "{what}: residual {} against {} ({rel:.1e})",
                    a.residual,
                    b.residual
                );
            }
            let to64 =
                |v: &[[f32; 3]]| -> Vec<[f64; 3]> { v.iter().map(|p| p.map(f64::from)).collect() };
            let d = rel_rms(&to64(j_fused), &to64(j_split));
            assert!(
                d < SAME_J_PLUS,
                "{what}: J+ {d:.1e} from the split kernels'"
            );
        }
        // The cold solve reaches the f64 exact one (the warm one solves another light).
        let d = rel_rms(
            &fused[0]
                .0
                .iter()
                .map(|p| p.map(f64::from))
                .collect::<Vec<_>>(),
            &exact.j_plus_clamped,
        );
        assert!(
            d < tol::GPU_VS_EXACT,
            "{finest:?}, {relax}: J+ {d:.2e} from the f64 exact solve"
        );
    }
    t.finish();
}
