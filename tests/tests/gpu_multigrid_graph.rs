//! The GPU multigrid's matrix-free finest level (issue 13 item 4; benches/RESULTS.md
//! "Matrix-free finest level (wave 8)"): with `FinestOperator::Graph` the finest `K x` of the
//! residual pass and of the CG's `K z` is read from the cascade's graph textures (connectivity,
//! Jacobi weights, the multigrid's diagonal) instead of the finest compressed rows, which are no
//! longer uploaded. Checked here: both passes equal the CSR's (and the f64 operator's) on a random
//! vector for a homogeneous material, a heterogeneous one with derived weights and one with
//! stored weights; converged solves give the CSR path's J+ in the same cycles and reach the f64
//! exact solve; the finest rows' bytes are gone. fp16 `d` and `z_old` (`UpdateStorage::F16`)
//! take 8 bytes per node and solve in the same cycles. Validation (with synchronization validation) is
//! on and any message fails.

use translucent::material::{Material, MaterialField};
use translucent::mesh::shapes::Shape;
use translucent::quadgraph::BakeParams;
use translucent::scene::{Environment, Light, Scene};
use translucent::solver::gpu::multigrid::{CycleState, FinestProducts, GpuMultigridReport};
use translucent::solver::gpu::{GpuDiffusion, GpuSolveParams, HeterogeneousWeights};
use translucent::solver::multigrid::{FinestOperator, Hierarchy, MultigridParams, UpdateStorage};
use translucent::solver::{self, rel_rms, CpuSolveParams};
use translucent::vk::Context;
use translucent::QuadGraph;
use translucent_tests::{kappa_contrast_field, solve_once, tol, GpuTest};

/// Relative residual the GPU cycles stop at (as tests/tests/gpu_multigrid_storage.rs).
const TOLERANCE: f32 = 1e-5;
/// Cycles at most: the 1e4 contrast needs ~10 with CG; a wrong operator hits the cap.
const MAX_CYCLES: u32 = 40;
/// `K x` of the graph against the CSR's, relative RMS: both are f32 sums of the same four
/// products, the graph's entries `K_ii * w_ik` rounded twice instead of once (a few ulps); a
/// wrong weight, neighbour or row scale is an O(1) difference (measured 6e-8 to 8e-8).
const SAME_OPERATOR: f64 = 1e-6;
/// Converged J+ of the two finest operators: both stop below a 1e-5 relative residual, so the
/// solutions differ by at most that order (measured 4e-7 marble, 1.8e-6 on the 1e4 contrast).
const SAME_SOLVE: f64 = 1e-5;

fn bake() -> QuadGraph {
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

fn scene() -> Scene {
    let light: Light = "dir:0.2,-0.35,1:5,5,5".parse().unwrap();
    Scene {
        lights: vec![light],
        environment: Environment::Constant([0.05; 3]),
    }
}

fn multigrid(finest: FinestOperator) -> MultigridParams {
    MultigridParams {
        finest_operator: finest,
        max_cycles: MAX_CYCLES,
        ..MultigridParams::gpu()
    }
}

fn params(finest: FinestOperator, weights: HeterogeneousWeights) -> GpuSolveParams {
    GpuSolveParams {
        tolerance: TOLERANCE,
        multigrid: Some(multigrid(finest)),
        heterogeneous_weights: weights,
        ..Default::default()
    }
}

fn cold_solve(
    ctx: &Context,
    gpu: &mut GpuDiffusion,
    graph: &QuadGraph,
    field: &MaterialField,
) -> (Vec<[f32; 3]>, GpuMultigridReport) {
    let q: Vec<[f32; 3]> = scene()
        .surface_irradiance(graph.finest(), field.eta(), None)
        .iter()
        .map(|v| v.map(|x| x as f32))
        .collect();
    gpu.set_q_scale(GpuDiffusion::exposure_for(q.iter()));
    gpu.upload_q(ctx, graph.levels.len() - 1, &q)
        .expect("upload q");
    solve_once(ctx, gpu, false);
    let report = gpu
        .multigrid_report(ctx)
        .expect("report")
        .expect("the multigrid schedule");
    (gpu.read_j_plus(ctx).expect("J+"), report)
}

/// A reproducible vector with entries in [-1, 1] (xorshift).
fn random_vector(n: usize, seed: u64) -> Vec<[f32; 3]> {
    let mut state = seed | 1;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    (0..n)
        .map(|_| [next() as f32, next() as f32, next() as f32])
        .collect()
}

fn widen(v: &[[f32; 3]]) -> Vec<[f64; 3]> {
    v.iter().map(|c| c.map(f64::from)).collect()
}

/// Per finest operator: a cold solve (J+, its report, the finest rows' bytes) and the two
/// passes' products on one random vector.
struct Run {
    j_plus: Vec<[f32; 3]>,
    report: GpuMultigridReport,
    row_bytes: u64,
    products: FinestProducts,
}

fn run(
    ctx: &Context,
    graph: &QuadGraph,
    field: &MaterialField,
    finest: FinestOperator,
    weights: HeterogeneousWeights,
    x: &[[f32; 3]],
    f: &[[f32; 3]],
) -> Run {
    let mut solve = GpuDiffusion::new(ctx, graph, field, &params(finest, weights)).expect("solve");
    // The solve first: a heterogeneous material's weights are derived by its first frame.
    let (j_plus, report) = cold_solve(ctx, &mut solve, graph, field);
    let row_bytes = solve
        .multigrid_bytes_by_buffer()
        .iter()
        .filter(|(name, _)| matches!(*name, "row_start" | "cols" | "values"))
        .map(|&(_, b)| b)
        .sum();
    let products = solve
        .multigrid_apply_finest(ctx, x, f)
        .expect("apply")
        .expect("the multigrid schedule");
    Run {
        j_plus,
        report,
        row_bytes,
        products,
    }
}

fn graph_matches_csr(what: &str, field: &MaterialField, weights: HeterogeneousWeights) {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let graph = bake();
    let mg = multigrid(FinestOperator::Csr);
    let exit = GpuSolveParams::default().exit;
    let h = Hierarchy::build_with(&graph, field, solver::Scheme::Fv, exit, &mg).expect("cpu");
    let k = &h.levels.last().expect("levels").operator;
    let n = k.node_count();
    let (x, f) = (random_vector(n, 0x5eed), random_vector(n, 0xf00d));
    let mut kx = vec![[0.0; 3]; n];
    k.apply(&widen(&x), &mut kx);
    let f_minus_kx: Vec<[f64; 3]> = widen(&f)
        .iter()
        .zip(&kx)
        .map(|(a, b)| std::array::from_fn(|c| a[c] - b[c]))
        .collect();
    let exact = solver::solve(&graph, field, &scene(), None, &CpuSolveParams::default())
        .expect("exact")
        .j_plus_clamped;
    let csr = run(ctx, &graph, field, FinestOperator::Csr, weights, &x, &f);
    let mat_free = run(ctx, &graph, field, FinestOperator::Graph, weights, &x, &f);
    for (name, r) in [("csr", &csr), ("graph", &mat_free)] {
        let product = rel_rms(&r.products.product, &kx);
        let residual = rel_rms(&r.products.residual, &f_minus_kx);
        let err = rel_rms(&r.j_plus, &exact);
        println!(
            "{what}, {name}: K x vs f64 {product:.2e}, f - K x vs f64 {residual:.2e}; J+ vs exact \
             {err:.2e}; {} cycles, {:.1} work units, residual {:.2e}; finest+coarse rows {} bytes",
            r.report.cycles.len(),
            r.report.work_units,
            r.report.residual,
            r.row_bytes,
        );
        assert!(product <= SAME_OPERATOR, "{what} {name}: K x {product:.2e}");
        assert!(
            residual <= SAME_OPERATOR,
            "{what} {name}: f - K x {residual:.2e}"
        );
        assert_eq!(r.report.state, CycleState::Converged, "{what} {name}");
        assert!(err <= tol::GPU_VS_EXACT, "{what} {name}: J+ {err:.2e}");
    }
    let kz = rel_rms(&mat_free.products.product, &widen(&csr.products.product));
    assert!(kz <= SAME_OPERATOR, "{what}: graph K z vs CSR {kz:.2e}");
    let same = rel_rms(&mat_free.j_plus, &widen(&csr.j_plus));
    println!("{what}: graph vs csr K z {kz:.2e}, J+ {same:.2e}");
    assert!(same <= SAME_SOLVE, "{what}: J+ graph vs csr {same:.2e}");
    assert_eq!(
        mat_free.report.cycles.len(),
        csr.report.cycles.len(),
        "{what}: cycles"
    );
    // The finest rows are not uploaded: at least their columns (one u32 per off-diagonal entry)
    // and a row start per finest node fewer.
    let finest_rows = 4 * (k.cols.len() + n) as u64;
    assert!(
        mat_free.row_bytes + finest_rows <= csr.row_bytes,
        "{what}: rows {} against {}",
        mat_free.row_bytes,
        csr.row_bytes
    );
    gpu.finish();
}

#[test]
fn graph_operator_equals_the_csr_in_marble() {
    let field = MaterialField::Homogeneous(Material::preset("marble").unwrap());
    graph_matches_csr("marble", &field, HeterogeneousWeights::default());
}

#[test]
fn graph_operator_equals_the_csr_on_the_1e4_contrast_with_derived_weights() {
    graph_matches_csr(
        "1e4 contrast, derived",
        &kappa_contrast_field(),
        HeterogeneousWeights::Derived,
    );
}

#[test]
fn graph_operator_equals_the_csr_on_the_1e4_contrast_with_stored_weights() {
    graph_matches_csr(
        "1e4 contrast, stored",
        &kappa_contrast_field(),
        HeterogeneousWeights::Stored,
    );
}

/// fp16 updates against f32 ones: the same cycles (the measured rule for keeping them, benches/
/// RESULTS.md "Matrix-free finest level (wave 8)"), both at the exact solve, 8 bytes per node.
fn half_updates_keep_the_cycles(what: &str, field: &MaterialField) {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let graph = bake();
    let exact = solver::solve(&graph, field, &scene(), None, &CpuSolveParams::default())
        .expect("exact")
        .j_plus_clamped;
    let mut cycles = Vec::new();
    for updates in [UpdateStorage::F32, UpdateStorage::F16] {
        let mg = MultigridParams {
            update_storage: updates,
            ..multigrid(FinestOperator::Graph)
        };
        let h = Hierarchy::build(&graph, field, solver::Scheme::Fv, &mg).expect("cpu");
        let nodes: u64 = h.levels.iter().map(|l| l.node_count() as u64).sum();
        let p = GpuSolveParams {
            multigrid: Some(mg),
            ..params(FinestOperator::Graph, HeterogeneousWeights::default())
        };
        let mut solve = GpuDiffusion::new(ctx, &graph, field, &p).expect("solve");
        let d = solve
            .multigrid_bytes_by_buffer()
            .iter()
            .find(|&&(b, _)| b == "d")
            .map(|&(_, b)| b);
        let per_node = if updates == UpdateStorage::F16 { 8 } else { 12 };
        assert_eq!(d, Some(per_node * nodes), "{what} {updates:?}: d");
        let (j, report) = cold_solve(ctx, &mut solve, &graph, field);
        let err = rel_rms(&j, &exact);
        println!(
            "{what}, {updates:?} updates: J+ vs exact {err:.2e}; {} cycles, {:.1} work units, residual {:.2e}",
            report.cycles.len(),
            report.work_units,
            report.residual,
        );
        assert_eq!(report.state, CycleState::Converged, "{what} {updates:?}");
        assert!(err <= tol::GPU_VS_EXACT, "{what} {updates:?}: J+ {err:.2e}");
        cycles.push(report.cycles.len());
    }
    assert_eq!(cycles[0], cycles[1], "{what}: cycles f32, f16");
    gpu.finish();
}

#[test]
fn half_updates_keep_the_cycles_in_marble() {
    let field = MaterialField::Homogeneous(Material::preset("marble").unwrap());
    half_updates_keep_the_cycles("marble", &field);
}

#[test]
fn half_updates_keep_the_cycles_on_the_1e4_contrast() {
    half_updates_keep_the_cycles("1e4 contrast", &kappa_contrast_field());
}
