//! Shadow edges at the shading point's own visibility (wave 13, issue 12's front-lit bunny;
//! `Transport::own_visibility`, `GpuSolveParams::own_visibility`, render `--own-visibility`): a
//! display vertex's lit beam sources (q and the collimated exit part P) are taken per unit
//! visibility from its source nodes and times the vertex's own visibility, so a cast shadow's
//! edge follows the display mesh rather than the nodes within 1.5 lattice spacings.
//! - the formula on hand-made nodes (`solver::cpu::own_visibility_sources`);
//! - a torus lit at a low angle, whose near tube casts a shadow onto the far tube's inner side:
//!   the GPU frame (the gather run at the display vertices, a shadow map) against the f64
//!   reference's same rule (rays), at the vertices the rule changes. The GPU without the rule is
//!   as far from the reference there as the rule moves them: the test fails without it.

use translucent::material::{Material, MaterialField};
use translucent::mesh::shapes::Shape;
use translucent::quadgraph::BakeParams;
use translucent::scene::{Environment, Scene};
use translucent::solver::cpu::{own_visibility_sources, OWN_VISIBILITY_LIT};
use translucent::solver::gpu::GpuSolveParams;
use translucent::solver::rel_rms;
use translucent::solver::transport::{ExitQuery, SurfaceReconstruction, Transport};
use translucent::solver::{self, CpuSolveParams};
use translucent::QuadGraph;
use translucent_tests::{multilevel_object, render_once, GpuTest};

/// A vertex the rule moves by more than this share of its value (f64 reference, rule on against
/// off) is a shadow-edge vertex.
const MOVED: f64 = 0.05;

/// GPU against the f64 reference with the rule, over the shadow-edge vertices, at most this share
/// of the GPU-without-the-rule's distance there. Measured: 146 edge vertices of 8192, GPU with the
/// rule 0.98 (relative RMS; mostly dark vertices, whose small values the shadow map's 3x3 PCF,
/// fractional within about a texel of the edge, and the CPU's one ray set differently), without
/// 2.65 (0.37 of it); 0.027 over every vertex.
const GPU_VS_CPU_EDGE: f64 = 0.5;

#[test]
fn own_visibility_takes_the_lit_beam_at_the_vertex_visibility() {
    // Two beam nodes (one lit, one in shadow: its q and P are 0) and one node whose sources do
    // not follow the light (a wall's continuation: visibility -1).
    let nodes = [
        (0.5, [2.0, 4.0, 6.0], [1.0, -1.0, 0.5], 1.0),
        (0.3, [0.0; 3], [0.0; 3], 0.0),
        (0.2, [1.0; 3], [3.0; 3], -1.0),
    ];
    let average = |own: f64| own_visibility_sources(nodes.into_iter(), own);
    // The lit beam per unit visibility: (0.5 q_0) / (0.5 * 1) per unit weight, times the beam
    // nodes' weight 0.8 and the vertex's visibility, where below the nodes' (0.5 / 0.8).
    let want = |own: f64| -> ([f64; 3], [f64; 3]) {
        let f = (own * 0.8 / 0.5).min(1.0);
        (
            std::array::from_fn(|c| 0.5 * nodes[0].1[c] * f + 0.2 * nodes[2].1[c]),
            std::array::from_fn(|c| 0.5 * nodes[0].2[c] * f + 0.2 * nodes[2].2[c]),
        )
    };
    for own in [1.0, 0.0, 4.0 / 9.0, 0.7] {
        let (q, p) = average(own);
        let (wq, wp) = want(own);
        for c in 0..3 {
            assert!((q[c] - wq[c]).abs() < 1e-12, "own {own}: q {q:?} vs {wq:?}");
            assert!((p[c] - wp[c]).abs() < 1e-12, "own {own}: P {p:?} vs {wp:?}");
        }
    }
    // The nodes' average where the vertex has no visibility of its own (facing away) or no beam
    // node is lit (their sources per unit visibility are unknown).
    let plain = (
        std::array::from_fn(|c| 0.5 * nodes[0].1[c] + 0.2 * nodes[2].1[c]),
        std::array::from_fn(|c| 0.5 * nodes[0].2[c] + 0.2 * nodes[2].2[c]),
    );
    let close = |(q, p): ([f64; 3], [f64; 3]), (wq, wp): ([f64; 3], [f64; 3])| {
        (0..3).all(|c| (q[c] - wq[c]).abs() < 1e-12 && (p[c] - wp[c]).abs() < 1e-12)
    };
    assert!(close(average(-1.0), plain), "{:?}", average(-1.0));
    let dark = [
        (0.5, [0.0; 3], [0.0; 3], OWN_VISIBILITY_LIT / 2.0),
        nodes[2],
    ];
    let got = own_visibility_sources(dark.into_iter(), 1.0);
    assert!(close(got, ([0.2; 3], [0.6; 3])), "{got:?}");
}

#[test]
fn gpu_follows_the_vertex_visibility_at_a_cast_shadow_edge() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let shape = Shape::Torus {
        major: 10.0,
        minor: 4.0,
    };
    let params = BakeParams {
        resolution: 32,
        levels: 2,
        ..Default::default()
    };
    let graph: QuadGraph = QuadGraph::bake(&shape.triangulate(64), &shape, &params, &mut |_| {})
        .expect("bake")
        .0;
    let mut marble = Material::preset("marble").expect("preset");
    marble.eta = 1.0;
    let field = MaterialField::Homogeneous(marble);
    // Low over the ring: the near tube shades the far tube's inner side.
    let scene = Scene {
        lights: vec!["dir:1,-0.15,0:4,4,4".parse().unwrap()],
        environment: Environment::None,
    };
    let cpu = |own_visibility: bool| -> Vec<[f64; 3]> {
        let params = CpuSolveParams {
            transport: Transport {
                surface: SurfaceReconstruction::Interior,
                own_visibility,
                ..Transport::gpu_collimated()
            },
            ..CpuSolveParams::default()
        };
        let s = solver::solve(&graph, &field, &scene, Some(&shape), &params).expect("cpu solve");
        s.vertex_j_plus.iter().map(|x| x.map(f64::from)).collect()
    };
    let gpu_run = |own_visibility: bool| -> Vec<[f64; 3]> {
        let params = GpuSolveParams {
            iterations: vec![4000],
            tolerance: 1e-6,
            exit: ExitQuery::Moments,
            collimated: true,
            surface: SurfaceReconstruction::Interior,
            own_visibility,
            ..Default::default()
        };
        let mut object = multilevel_object(ctx, &graph, &field, &scene, params);
        render_once(ctx, &mut object, 32, 32);
        let v = object
            .quadgraph()
            .expect("a QuadGraph object")
            .solve()
            .read_vertex_j_plus(ctx)
            .expect("vertex J+");
        v.iter().map(|x| x.map(f64::from)).collect()
    };
    let (cpu_on, cpu_off) = (cpu(true), cpu(false));
    let (gpu_on, gpu_off) = (gpu_run(true), gpu_run(false));
    gpu.assert_no_messages();
    for (name, v) in [
        ("gpu on", &gpu_on),
        ("gpu off", &gpu_off),
        ("cpu on", &cpu_on),
    ] {
        assert!(
            v.iter().flatten().all(|x| x.is_finite() && *x >= 0.0),
            "{name}: a value not finite or negative"
        );
    }
    let grey = |x: &[f64; 3]| x.iter().sum::<f64>();
    let edge: Vec<usize> = (0..cpu_on.len())
        .filter(|&v| {
            let (on, off) = (grey(&cpu_on[v]), grey(&cpu_off[v]));
            (on - off).abs() > MOVED * on.max(off)
        })
        .collect();
    let pick = |x: &[[f64; 3]]| edge.iter().map(|&i| x[i]).collect::<Vec<_>>();
    let with_rule = rel_rms(&pick(&gpu_on), &pick(&cpu_on));
    let without = rel_rms(&pick(&gpu_off), &pick(&cpu_on));
    let moved = rel_rms(&pick(&cpu_off), &pick(&cpu_on));
    let everywhere = rel_rms(&gpu_on, &cpu_on);
    println!(
        "{} shadow-edge vertices of {}: GPU with the rule vs CPU {with_rule:.3}, without {without:.3} \
         (the rule moves the CPU by {moved:.3}); everywhere {everywhere:.4}",
        edge.len(),
        cpu_on.len()
    );
    assert!(
        edge.len() >= 20,
        "too few shadow-edge vertices: {}",
        edge.len()
    );
    assert!(
        with_rule <= GPU_VS_CPU_EDGE * without,
        "GPU with the rule {with_rule} vs without {without} against the CPU's"
    );
}
