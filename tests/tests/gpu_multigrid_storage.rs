//! The GPU multigrid's storage (issue 13 item 4; benches/RESULTS.md "Multigrid storage (wave
//! 7)"): packed prolongation links (`LinkStorage::Packed`, one u32 per link with an 8-bit weight,
//! the hierarchy built with the same quantized weights) reach the f64 exact solve in the cycles of
//! f32 links on the hard cases (a 1e4 material contrast, skim milk); the restriction reads the
//! prolongation's own links (no transposed copy of the weights); the bytes per buffer follow the
//! layout computed here from the CPU hierarchy. `quantized_links` keeps each node's weights on
//! 1/255 steps summing to one and refuses weights that do not pack. Validation (with
//! synchronization validation) is on and any message fails.

use translucent::material::{Material, MaterialField};
use translucent::mesh::shapes::Shape;
use translucent::quadgraph::graph::{ShepardLinks, NO_NODE};
use translucent::quadgraph::BakeParams;
use translucent::scene::{Environment, Light, Scene};
use translucent::solver::gpu::multigrid::{CycleState, GpuMultigridReport};
use translucent::solver::gpu::{GpuDiffusion, GpuSolveParams};
use translucent::solver::multigrid::{
    quantized_links, FinestOperator, Hierarchy, LinkStorage, MultigridParams, UpdateStorage,
    VectorStorage, LINK_WEIGHT_STEPS,
};
use translucent::solver::{self, rel_rms, CpuSolveParams};
use translucent::vk::Context;
use translucent::QuadGraph;
use translucent_tests::{kappa_contrast_field, solve_once, tol, GpuTest};

/// Relative residual the GPU cycles stop at (as tests/tests/gpu_multigrid_coarse.rs).
const TOLERANCE: f32 = 1e-5;
/// Cycles at most: the 1e4 contrast needs ~10 with CG; a broken restriction hits the cap.
const MAX_CYCLES: u32 = 40;
/// Link slots per node (the bake's 8 Shepard links).
const SLOTS: u64 = 8;
/// A buffer is never smaller than this (an empty array still gets a buffer).
const MIN_BUFFER: u64 = 16;
/// The two vector layouts run the same f32 operations: J+ equal up to f32 noise.
const SAME_OPERATIONS: f64 = 1e-6;
/// One rounding of a weight to 1/255 steps, with the node's sum kept: at most one step.
const QUANTIZATION: f64 = 1.0 / LINK_WEIGHT_STEPS as f64;

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

fn multigrid(links: LinkStorage) -> MultigridParams {
    MultigridParams {
        link_storage: links,
        vector_storage: VectorStorage::Rgb,
        // The finest rows and f32 updates: the layout these tests check.
        finest_operator: FinestOperator::Csr,
        update_storage: UpdateStorage::F32,
        max_cycles: MAX_CYCLES,
        ..MultigridParams::gpu()
    }
}

fn params(mg: MultigridParams) -> GpuSolveParams {
    GpuSolveParams {
        tolerance: TOLERANCE,
        multigrid: Some(mg),
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

/// Cold solves with f32 and packed links: both converge to the exact solve, packed in at most one
/// more cycle.
fn packed_links_match_f32_links(what: &str, field: &MaterialField) {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let graph = bake();
    let s =
        solver::solve(&graph, field, &scene(), None, &CpuSolveParams::default()).expect("exact");
    assert!(s.exact.as_ref().is_some_and(|e| e.converged));
    let exact = s.j_plus_clamped;
    let mut cycles = Vec::new();
    for links in [LinkStorage::F32, LinkStorage::Packed] {
        let mut solve =
            GpuDiffusion::new(ctx, &graph, field, &params(multigrid(links))).expect("solve");
        let (j, report) = cold_solve(ctx, &mut solve, &graph, field);
        let err = rel_rms(&j, &exact);
        println!(
            "{what}, {links:?} links: J+ vs exact {err:.2e}; {} cycles, {:.1} work units, residual {:.2e}, {} bytes",
            report.cycles.len(),
            report.work_units,
            report.residual,
            solve.bytes_breakdown().multigrid,
        );
        assert!(j.iter().flatten().all(|v| v.is_finite()), "{what}: NaN");
        assert_eq!(report.state, CycleState::Converged, "{what}: {report:?}");
        assert!(err <= tol::GPU_VS_EXACT, "{what} {links:?}: J+ {err:.2e}");
        cycles.push(report.cycles.len());
        drop(solve);
    }
    assert!(cycles[1] <= cycles[0] + 1, "{what}: cycles {cycles:?}");
    gpu.finish();
}

#[test]
fn packed_links_reach_the_exact_solve_on_the_1e4_contrast() {
    packed_links_match_f32_links("1e4 contrast", &kappa_contrast_field());
}

#[test]
fn packed_links_reach_the_exact_solve_in_skim_milk() {
    let field = MaterialField::Homogeneous(Material::preset("skimmilk").unwrap());
    packed_links_match_f32_links("skim milk", &field);
}

/// The per-node vectors take three floats per node with [`VectorStorage::Rgb`], four with
/// [`VectorStorage::Rgba`], and give the same solve.
#[test]
fn rgb_vectors_take_three_floats_and_solve_as_rgba() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let graph = bake();
    let field = MaterialField::Homogeneous(Material::preset("marble").unwrap());
    let mut results = Vec::new();
    for (vectors, floats) in [(VectorStorage::Rgba, 4u64), (VectorStorage::Rgb, 3)] {
        let mg = MultigridParams {
            vector_storage: vectors,
            ..multigrid(LinkStorage::Packed)
        };
        let h = Hierarchy::build(&graph, &field, solver::Scheme::Fv, &mg).expect("cpu");
        let nodes: u64 = h.levels.iter().map(|l| l.node_count() as u64).sum();
        let finest = h.levels.last().unwrap().node_count() as u64;
        let mut solve = GpuDiffusion::new(ctx, &graph, &field, &params(mg)).expect("solve");
        let by_buffer = solve.multigrid_bytes_by_buffer();
        for (name, n) in [
            ("x", nodes),
            ("d", nodes),
            ("partner_value", nodes),
            ("dir", finest),
        ] {
            let got = by_buffer.iter().find(|&&(b, _)| b == name).map(|&(_, b)| b);
            assert_eq!(got, Some(4 * floats * n), "{vectors:?}: {name}");
        }
        let (j, report) = cold_solve(ctx, &mut solve, &graph, &field);
        assert_eq!(
            report.state,
            CycleState::Converged,
            "{vectors:?}: {report:?}"
        );
        results.push((j, report.cycles.len()));
        drop(solve);
    }
    // The same f32 operations in either layout.
    assert_eq!(results[0].1, results[1].1, "cycles");
    let diff = rel_rms(
        &results[1].0,
        &results[0]
            .0
            .iter()
            .map(|v| v.map(f64::from))
            .collect::<Vec<_>>(),
    );
    assert!(diff <= SAME_OPERATIONS, "rgb against rgba: {diff:.2e}");
    gpu.finish();
}

/// The link and restriction buffers from the CPU hierarchy: 8 slots per node of every level
/// (packed: one u32; f32: a u32 node and an f32 weight), the restriction one u32 slot per
/// transposed link and a start per coarse row, the right-hand side one float per finest node,
/// the finest operator's entries three floats each; no transposed weights.
#[test]
fn link_and_restriction_bytes_follow_the_slots() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let graph = bake();
    let field = MaterialField::Homogeneous(Material::preset("marble").unwrap());
    let mut totals = Vec::new();
    for links in [LinkStorage::F32, LinkStorage::Packed] {
        let mg = multigrid(links);
        let solve = GpuDiffusion::new(ctx, &graph, &field, &params(mg.clone())).expect("solve");
        let by_buffer = solve.multigrid_bytes_by_buffer();
        let h = Hierarchy::build(&graph, &field, solver::Scheme::Fv, &mg).expect("cpu");
        let nodes: u64 = h.levels.iter().map(|l| l.node_count() as u64).sum();
        let transposed: u64 = h
            .levels
            .iter()
            .filter_map(|l| l.prolongation.as_ref())
            .map(|p| p.t_fine.len() as u64)
            .sum();
        let finest = h.levels.last().unwrap();
        let at_least = |b: u64| b.max(MIN_BUFFER);
        let expected = [
            ("links", at_least(4 * SLOTS * nodes)),
            (
                "link_weights",
                at_least(match links {
                    LinkStorage::F32 => 4 * SLOTS * nodes,
                    LinkStorage::Packed => 0,
                }),
            ),
            ("t_start", at_least(4 * (nodes + 1))),
            ("t_link", at_least(4 * transposed)),
            ("rhs_coef", at_least(4 * finest.node_count() as u64)),
            ("values", at_least(12 * finest.operator.cols.len() as u64)),
        ];
        for (name, bytes) in expected {
            let got = by_buffer.iter().find(|&&(n, _)| n == name).map(|&(_, b)| b);
            assert_eq!(got, Some(bytes), "{links:?}: {name}");
        }
        for gone in ["t_fine", "t_weight"] {
            assert!(by_buffer.iter().all(|&(n, _)| n != gone), "{gone} stored");
        }
        totals.push(by_buffer.iter().map(|&(_, b)| b).sum::<u64>());
        drop(solve);
    }
    assert!(totals[1] < totals[0], "{totals:?}");
    gpu.finish();
}

#[test]
fn quantized_links_keep_each_nodes_sum_on_whole_steps() {
    let graph = bake();
    let links = graph.finest().from_coarser.as_ref().expect("links");
    let q = quantized_links(links).expect("Shepard weights pack");
    let steps = f64::from(LINK_WEIGHT_STEPS);
    for (node, ((l, w), wq)) in links
        .links
        .iter()
        .zip(&links.weights)
        .zip(&q.weights)
        .enumerate()
    {
        let mut sum = 0.0;
        let mut sum_q = 0.0;
        for k in 0..8 {
            if l[k] == NO_NODE {
                continue;
            }
            let s = wq[k] * steps;
            assert!((s - s.round()).abs() < 1e-9, "node {node}: {s} steps");
            assert!(
                (wq[k] - w[k]).abs() <= QUANTIZATION + 1e-12,
                "node {node}: {} -> {}",
                w[k],
                wq[k]
            );
            sum += w[k];
            sum_q += wq[k];
        }
        assert!(
            ((sum * steps).round() - sum_q * steps).abs() < 1e-9,
            "node {node}: sum {sum} -> {sum_q}"
        );
    }
    let negative = ShepardLinks {
        links: vec![[0, 1, NO_NODE, NO_NODE, NO_NODE, NO_NODE, NO_NODE, NO_NODE]],
        weights: vec![[2.5, -1.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]],
    };
    let err = quantized_links(&negative).expect_err("a weight outside [-1, 2] does not pack");
    assert!(err.to_string().contains("link_storage"), "{err}");
}
