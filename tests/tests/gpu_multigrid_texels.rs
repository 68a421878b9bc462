//! The GPU multigrid's residual and smoothing kernels reading their read-only inputs through
//! uniform texel views (`TRANSLUCENT_MULTIGRID_READS=texel`, `TEXEL_READS` in
//! `multigrid/residual.comp` and `multigrid/smooth.comp`; benches/RESULTS.md "Fewer bytes per
//! finest pass (wave 11)") do the storage-buffer reads' solve: the same residual after every cycle,
//! the same work units, the same J+; and both reach the f64 exact solve. Cold and warm solves, on
//! the matrix-free finest level (the default) and on its compressed rows (where level 1's fp16
//! Galerkin rows and the finest f32 rows are read through `values16_t` and `values_t`). Likewise
//! the coarse levels' fp16 rows reading each entry's column from the entry's top 16 bits
//! (`TRANSLUCENT_MULTIGRID_COLUMNS`, the default) instead of from `cols`.
//! Validation (with synchronization validation) is on and any message fails.
//!
//! One test in this binary: the reads are chosen by environment variables read when the
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
/// A variant's and the reference's residual after each cycle: the same values read, the
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
fn texel_reads_and_packed_columns_give_the_same_solve() {
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
        // The storage-buffer reads with `cols` are the reference.
        std::env::set_var("TRANSLUCENT_MULTIGRID_READS", "buffer");
        std::env::set_var("TRANSLUCENT_MULTIGRID_COLUMNS", "cols");
        let reference = solves(&t.ctx, &graph, &field, finest);
        for (reads, columns) in [("texel", "cols"), ("buffer", "packed"), ("texel", "packed")] {
            std::env::set_var("TRANSLUCENT_MULTIGRID_READS", reads);
            std::env::set_var("TRANSLUCENT_MULTIGRID_COLUMNS", columns);
            let variant = solves(&t.ctx, &graph, &field, finest);
            let what = format!("{finest:?}, {reads} reads, {columns}");
            for (a, b) in variant.iter().zip(&reference) {
                same_solve(a, b, reads == "texel", columns == "packed", &what);
            }
            // The cold solve reaches the f64 exact one (the warm one solves another light).
            let d = rel_rms(&to64(&variant[0].0), &exact.j_plus_clamped);
            assert!(
                d < tol::GPU_VS_EXACT,
                "{what}: J+ {d:.2e} from the f64 exact solve"
            );
        }
    }
    t.finish();
}

fn to64(v: &[[f32; 3]]) -> Vec<[f64; 3]> {
    v.iter().map(|p| p.map(f64::from)).collect()
}

/// One solve of a variant (`texel` reads, `packed` columns) against the reference's.
fn same_solve(
    (j_variant, variant): &(Vec<[f32; 3]>, GpuMultigridReport),
    (j_reference, reference): &(Vec<[f32; 3]>, GpuMultigridReport),
    texel: bool,
    packed: bool,
    what: &str,
) {
    let what = format!("{what}, warm {}", reference.warm);
    // The switches reached the kernels (the bake's coarse levels have < 65536 nodes).
    assert_eq!(
        (variant.texel_reads, variant.packed_columns),
        (texel, packed),
        "{what}: the variant's switches"
    );
    assert!(
        !reference.texel_reads && !reference.packed_columns,
        "{what}: the reference's switches"
    );
    assert!(
        variant.converged && reference.converged,
        "{what}: {variant:?} / {reference:?}"
    );
    assert_eq!(
        variant.cycles.len(),
        reference.cycles.len(),
        "{what}: cycles"
    );
    assert!(
        (variant.work_units - reference.work_units).abs() < 1e-9,
        "{what}: work units {} against {}",
        variant.work_units,
        reference.work_units
    );
    let logs = [
        (variant.start_residual, reference.start_residual),
        (variant.residual, reference.residual),
    ];
    let cycles = variant.cycles.iter().zip(&reference.cycles);
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
    let d = rel_rms(&to64(j_variant), &to64(j_reference));
    assert!(d <= SAME_J_PLUS, "{what}: J+ {d:.1e} from the reference's");
}
