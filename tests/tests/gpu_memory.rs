//! GPU memory of the QuadGraph solve (issue 13 item 4, benches/RESULTS.md "Bytes per node (wave
//! 5)"): the bytes every level allocates follow the layout of `solver::gpu::textures` (computed
//! here from the packing, not read from a print), the layout cuts stay below the old layout, and
//! the heterogeneous weights derived in the sweep give the stored weights' result (rest pose and
//! deformed). Validation (with synchronization validation) is on and any message fails.

use glam::DVec3;
use translucent::material::{Material, MaterialField, Procedural};
use translucent::mesh::shapes::Shape;
use translucent::quadgraph::BakeParams;
use translucent::scene::{Environment, Scene};
use translucent::solver::gpu::{
    Deformation, GpuDiffusion, GpuSolveParams, HeterogeneousWeights, SolveBytes,
};
use translucent::solver::multigrid::MultigridParams;
use translucent::solver::{rel_rms, Scheme};
use translucent::vk::Context;
use translucent::QuadGraph;
use translucent_tests::{solve_once, GpuTest};

const ITERATIONS: u32 = 48;

/// Derived and stored weights run the same fp32 operations in the same order (graph_weights.glsl
/// against edit/derive_weights.comp); the compiler may still contract a multiply-add differently
/// in the two shaders: a few ulps per sweep, far below the 0.5% GPU-vs-CPU tolerance.
const DERIVED_VS_STORED: f64 = 1e-5;

fn bake() -> QuadGraph {
    let shape = Shape::Sphere { radius: 10.0 };
    let params = BakeParams {
        resolution: 10,
        levels: 2,
        ..Default::default()
    };
    QuadGraph::bake(&shape.triangulate(24), &shape, &params, &mut |_| {})
        .expect("bake")
        .0
}

fn marble() -> MaterialField {
    MaterialField::Homogeneous(Material::preset("marble").unwrap())
}

fn split() -> MaterialField {
    MaterialField::procedural(
        Procedural::Split {
            normal: DVec3::Y,
            offset: 0.37,
            below: Material::preset("marble").unwrap().coefficients(),
            above: Material::preset("skin1").unwrap().coefficients(),
        },
        1.3,
    )
    .unwrap()
}

fn cascade(weights: HeterogeneousWeights) -> GpuSolveParams {
    GpuSolveParams {
        iterations: vec![ITERATIONS],
        tolerance: 0.0,
        heterogeneous_weights: weights,
        ..Default::default()
    }
}

fn solve(ctx: &Context, gpu: &mut GpuDiffusion, graph: &QuadGraph) -> Vec<[f32; 3]> {
    let scene = Scene {
        lights: vec!["dir:-0.3,-1,0.2:1,1,1".parse().unwrap()],
        environment: Environment::Constant([0.05; 3]),
    };
    let q: Vec<Vec<[f32; 3]>> = graph
        .levels
        .iter()
        .map(|l| {
            let q = scene.surface_irradiance(l, 1.3, None);
            q.iter().map(|q| q.map(|v| v as f32)).collect()
        })
        .collect();
    gpu.set_q_scale(GpuDiffusion::exposure_for(q.iter().flatten()));
    for (h, q) in q.iter().enumerate() {
        gpu.upload_q(ctx, h, q).expect("upload q");
    }
    solve_once(ctx, gpu, false);
    let j = gpu.read_j_plus(ctx).expect("read J+");
    assert!(j.iter().flatten().all(|v| v.is_finite()), "NaN/Inf in J+");
    j
}

fn wide(v: &[[f32; 3]]) -> Vec<[f64; 3]> {
    v.iter().map(|x| x.map(f64::from)).collect()
}

/// (texels, surface-row texels) of level `h`.
fn texels(graph: &QuadGraph, h: usize) -> (u64, u64) {
    let p = &graph.levels[h].packing;
    let w = u64::from(p.width);
    (
        w * u64::from(p.height),
        w * u64::from(p.surface_rows.max(1)),
    )
}

/// The level textures of the mixed-precision cascade, homogeneous, from the layout
/// (`solver::gpu::textures`): per texel ping-pong 2 x RGBA16F, phi and residual RGBA32F,
/// connectivity RGBA32UI, geometric factors RGBA32F, on coarse levels the saved phi RGBA32F, on
/// all but the coarsest 8 packed links (2 x RGBA32UI); q RGBA16F on surface rows only.
fn cascade_layout(graph: &QuadGraph) -> u64 {
    let top = graph.levels.len() - 1;
    (0..=top)
        .map(|h| {
            let (all, surface) = texels(graph, h);
            let per_texel =
                16 + 16 + 16 + 16 + 16 + if h < top { 16 } else { 0 } + if h > 0 { 32 } else { 0 };
            // The coarsest level's links are two 1x1 placeholders.
            let placeholders = if h == 0 { 2 * 16 } else { 0 };
            all * per_texel + surface * 8 + placeholders
        })
        .sum()
}

/// The layout before wave 5: the same plus 16 bytes of fp16 link weights per texel, links on the
/// coarsest level too, and q on every texel.
fn old_cascade_layout(graph: &QuadGraph) -> u64 {
    let top = graph.levels.len() - 1;
    (0..=top)
        .map(|h| texels(graph, h).0 * (136 + if h < top { 16 } else { 0 }))
        .sum()
}

#[test]
fn level_textures_follow_the_layout_and_stay_below_the_old_one() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let graph = bake();
    let all_texels: u64 = (0..graph.levels.len()).map(|h| texels(&graph, h).0).sum();
    let homogeneous = GpuDiffusion::new(ctx, &graph, &marble(), &cascade(Default::default()))
        .expect("homogeneous solve");
    let b = homogeneous.bytes_breakdown();
    assert_eq!(
        b.total(),
        homogeneous.bytes().0,
        "the parts add up to the total"
    );
    assert_eq!(b.textures(), cascade_layout(&graph), "{b:?}");
    assert!(b.textures() < old_cascade_layout(&graph));
    // Heterogeneous: fv fractions, kappa and mu (3 x RGBA32F) derived in the sweep; three more
    // RGBA32F of weights when stored.
    for (weights, extra) in [
        (HeterogeneousWeights::Derived, 48),
        (HeterogeneousWeights::Stored, 96),
    ] {
        let hetero = GpuDiffusion::new(ctx, &graph, &split(), &cascade(weights)).unwrap();
        let h = hetero.bytes_breakdown();
        assert_eq!(
            h.textures() - b.textures(),
            extra * all_texels,
            "{weights:?}"
        );
        assert_eq!(h.material, extra * all_texels, "{weights:?}");
    }
    drop(homogeneous);
    gpu.finish();
}

#[test]
fn the_multigrid_schedule_allocates_no_cascade_textures() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let graph = bake();
    let top = graph.levels.len() - 1;
    let params = GpuSolveParams {
        multigrid: Some(MultigridParams::default()),
        ..Default::default()
    };
    // What the schedule reads: phi and connectivity of the finest level, q on surface rows;
    // every other level texture is a 1x1 placeholder (at most 16 bytes each, fewer than 16 per
    // level: state, phi, residual, saved phi, graph, links, fractions, weights).
    let placeholders = 16 * 16 * graph.levels.len() as u64;
    let read = |extra_per_texel: u64| -> u64 {
        (0..=top)
            .map(|h| {
                let (all, surface) = texels(&graph, h);
                let finest = if h == top { 32 } else { 0 };
                all * (finest + extra_per_texel) + surface * 8
            })
            .sum::<u64>()
    };
    let mut last = None;
    for (field, material_per_texel) in [(marble(), 0), (split(), 32)] {
        let mut gpu_solve = GpuDiffusion::new(ctx, &graph, &field, &params).unwrap();
        let b: SolveBytes = gpu_solve.bytes_breakdown();
        let bound = read(material_per_texel) + placeholders;
        assert!(b.textures() <= bound, "{b:?} > {bound}");
        assert!(b.multigrid > 0, "{b:?}");
        // It still solves, and a coarse level's phi is refused, not read from a placeholder.
        let j = solve(ctx, &mut gpu_solve, &graph);
        assert!(j.iter().flatten().any(|&v| v > 0.0));
        assert!(gpu_solve.read_phi(ctx, 0).is_err());
        last = Some(gpu_solve);
    }
    drop(last);
    gpu.finish();
}

#[test]
fn derived_weights_give_the_stored_weights_result_at_rest_and_deformed() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let graph = bake();
    let twist = Deformation::Twist {
        radians_per_mm: 0.03,
    };
    let mut results = Vec::new();
    for weights in [HeterogeneousWeights::Stored, HeterogeneousWeights::Derived] {
        let mut s = GpuDiffusion::new(ctx, &graph, &split(), &cascade(weights)).unwrap();
        let rest = solve(ctx, &mut s, &graph);
        s.deform(ctx, &graph, &twist, &[]).unwrap();
        let twisted = solve(ctx, &mut s, &graph);
        assert_ne!(rest, twisted, "{weights:?}: the twist changed nothing");
        results.push((rest, twisted));
    }
    let (stored, derived) = (&results[0], &results[1]);
    for (name, a, b) in [
        ("rest", &stored.0, &derived.0),
        ("twisted", &stored.1, &derived.1),
    ] {
        let err = rel_rms(b, &wide(a));
        println!("{name}: derived vs stored weights, rel RMS {err:.2e}");
        assert!(err <= DERIVED_VS_STORED, "{name}: {err}");
    }
    // The paper scheme's derived form too.
    let paper = |weights| GpuSolveParams {
        scheme: Scheme::Paper,
        ..cascade(weights)
    };
    let mut a =
        GpuDiffusion::new(ctx, &graph, &split(), &paper(HeterogeneousWeights::Stored)).unwrap();
    let mut b =
        GpuDiffusion::new(ctx, &graph, &split(), &paper(HeterogeneousWeights::Derived)).unwrap();
    let err = rel_rms(
        &solve(ctx, &mut b, &graph),
        &wide(&solve(ctx, &mut a, &graph)),
    );
    assert!(err <= DERIVED_VS_STORED, "paper scheme: {err}");
    drop((a, b));
    gpu.finish();
}
