//! The numerical stress matrix (issue 6, DESIGN section 9), CI-sized, through the whole GPU frame a
//! host runs (`TranslucentObject`: shadow maps, irradiance gather with the `render::q_scale_for` exposure,
//! the solve, J+ into the displayed mesh) and a 16 x 16 render (sphere, 12 cells across, 2 levels), at every precision, against the
//! f64 CPU reference. The full matrix is `cargo run --release -p translucent-benches --bin stress`.
//!
//! Tolerances (stated once, used by every case):
//! - mixed and fp32 phi against the exact discrete solve: 5e-3 relative RMS (the gpu_diffusion
//!   bound; f32 weights and fp16 q rounding are far below it);
//! - fp16 (the paper's plain fp16 state) stalls where an update falls below half an ulp (DESIGN
//!   section 4): only finiteness and 20% are asserted, the bound the full matrix needs;
//! - the exact constant of sigma_a = 0: 2e-3 (a few fp16 ulps of q);
//! - linearity in the light: J+ / E within 1e-4 of J+ at E = 1 (the exposure makes the stored
//!   problem the same up to f32 rounding of q; the solve stops at a 1e-5 error estimate, possibly
//!   a block earlier or later); pixels within 5e-3 from E = 1e-4 to 1e4 (an RGBA16F target: its
//!   subnormals start at 6e-5 of radiance).

use glam::DVec3;
use translucent::material::{fresnel, Coefficients, Material, MaterialField, Procedural};
use translucent::mesh::shapes::Shape;
use translucent::quadgraph::BakeParams;
use translucent::scene::{Environment, Light, Scene};
use translucent::solver::gpu::{GpuSolveParams, Precision};
use translucent::solver::{self, rel_rms, CpuSolveParams};
use translucent::vk::Context;
use translucent::QuadGraph;
use translucent_tests::tol;
use translucent_tests::{multilevel_object, render_once, GpuTest};

const PRECISIONS: [Precision; 3] = [Precision::Mixed, Precision::Fp32, Precision::Fp16];

fn tolerance(p: Precision) -> f64 {
    if p == Precision::Fp16 {
        0.2
    } else {
        tol::GPU_VS_EXACT
    }
}

fn sphere(diameter: f64) -> QuadGraph {
    let shape = Shape::Sphere {
        radius: 0.5 * diameter,
    };
    // Two levels: a single one needs more than the cap across a 1e4 kappa jump (the GPU's own
    // error estimate said 4% after 2000 iterations, and was right).
    let params = BakeParams {
        resolution: 12,
        levels: 2,
        ..Default::default()
    };
    QuadGraph::bake(&shape.triangulate(16), &shape, &params, &mut |_| {})
        .expect("bake")
        .0
}

fn lit(e: f64) -> Scene {
    Scene {
        lights: vec![Light::Directional {
            direction: DVec3::new(-0.3, -1.0, 0.2).normalize(),
            irradiance: [e; 3],
        }],
        environment: Environment::Constant([0.1 * e; 3]),
    }
}

fn split(below: ([f64; 3], [f64; 3]), above: ([f64; 3], [f64; 3])) -> MaterialField {
    let c = |(s, a): ([f64; 3], [f64; 3])| Coefficients::new(s, a).unwrap();
    MaterialField::procedural(
        Procedural::Split {
            normal: DVec3::new(1.0, 0.3, 0.1).normalize(),
            offset: 0.0,
            below: c(below),
            above: c(above),
        },
        1.3,
    )
    .unwrap()
}

struct Frame {
    phi: Vec<[f32; 3]>,
    j_plus: Vec<[f32; 3]>,
    pixels: Vec<[f32; 4]>,
}

/// One GPU frame as the CLI records it; asserts every output is finite and J+ >= 0.
fn gpu_frame(
    ctx: &Context,
    graph: &QuadGraph,
    field: &MaterialField,
    scene: &Scene,
    precision: Precision,
) -> Frame {
    let params = GpuSolveParams {
        precision,
        iterations: vec![3000],
        tolerance: 1e-5,
        ..Default::default()
    };
    let mut object = multilevel_object(ctx, graph, field, scene, params);
    let (captured, _) = render_once(ctx, &mut object, 16, 16);
    let solve = object.quadgraph().expect("quadgraph").solve();
    let out = Frame {
        phi: solve.read_phi(ctx, graph.levels.len() - 1).unwrap(),
        j_plus: solve.read_j_plus(ctx).unwrap(),
        pixels: captured.image.pixels,
    };
    let vertex = solve.read_vertex_j_plus(ctx).unwrap();
    println!(
        "  {precision:?}: iterations {:?}",
        solve.iterations_run(ctx).unwrap()
    );
    let values = out
        .phi
        .iter()
        .chain(&out.j_plus)
        .chain(&vertex)
        .flatten()
        .chain(out.pixels.iter().flat_map(|p| &p[..3]));
    let bad = values.filter(|v| !v.is_finite()).count();
    assert_eq!(bad, 0, "{precision:?}: NaN/Inf in the GPU frame's outputs");
    assert!(
        out.j_plus
            .iter()
            .chain(&vertex)
            .flatten()
            .all(|&v| v >= 0.0),
        "{precision:?}: negative displayed J+"
    );
    out
}

fn cpu_phi(graph: &QuadGraph, field: &MaterialField, scene: &Scene) -> Vec<[f64; 3]> {
    let sol = solver::solve(graph, field, scene, None, &CpuSolveParams::default()).unwrap();
    assert!(sol.phi.iter().flatten().all(|v| v.is_finite()));
    assert!(sol.j_plus_clamped.iter().flatten().all(|&v| v >= 0.0));
    let e = sol.energy;
    for c in 0..3 {
        let imbalance = (e.transmitted_input[c] - e.exitance[c] - e.absorbed[c]).abs();
        assert!(imbalance <= 1e-8 * e.transmitted_input[c], "energy {e:?}");
    }
    sol.phi
}

/// sigma_a = 0 under uniform light: phi = 4q/(1 - F_dr) at every node, for any kappa(x), here
/// also across a 1e4 jump in kappa (the harmonic-mean face weights).
#[test]
fn no_absorption_gives_the_exact_constant_through_a_1e4_kappa_jump() {
    let gpu = GpuTest::new();
    let graph = sphere(20.0);
    let scene = Scene {
        lights: vec![],
        environment: Environment::Constant([1.0; 3]),
    };
    let q = std::f64::consts::PI * (1.0 - fresnel::external_diffuse_reflectance(1.3));
    let expected = 4.0 * q / (1.0 - fresnel::diffuse_reflectance(1.3));
    let fields = [
        MaterialField::Homogeneous(Material::new([1.0, 0.5, 2.0], [0.0; 3], 1.3).unwrap()),
        split(([0.1; 3], [0.0; 3]), ([1000.0; 3], [0.0; 3])),
    ];
    for field in &fields {
        let cpu = cpu_phi(&graph, field, &scene);
        let worst = |phi: &mut dyn Iterator<Item = f64>| {
            phi.map(|v| (v - expected).abs() / expected)
                .fold(0.0, f64::max)
        };
        assert!(worst(&mut cpu.iter().flatten().copied()) < 1e-8);
        for precision in PRECISIONS {
            let out = gpu_frame(&gpu.ctx, &graph, field, &scene, precision);
            let err = worst(&mut out.phi.iter().flatten().map(|&v| f64::from(v)));
            println!("sigma_a = 0, {precision:?}: max rel. error {err:.2e}");
            let bound = if precision == Precision::Fp16 {
                0.2
            } else {
                2e-3
            };
            assert!(err <= bound, "{precision:?}: {err}");
        }
    }
    gpu.finish();
}

/// sigma_a = 100 and 1e4 times sigma_s' (J+ < 0 wherever lit: clamped, never negative), and a
/// 1e4 contrast in kappa and mu between two neighbouring materials.
#[test]
fn strong_absorbers_and_a_1e4_contrast_match_the_exact_solve() {
    let gpu = GpuTest::new();
    let graph = sphere(20.0);
    let scene = lit(1.0);
    let fields = [
        (
            "sigma_a = 100 sigma_s'",
            MaterialField::Homogeneous(Material::new([1.0; 3], [100.0; 3], 1.3).unwrap()),
        ),
        (
            "sigma_a = 1e4 sigma_s'",
            MaterialField::Homogeneous(Material::new([1.0; 3], [1e4; 3], 1.3).unwrap()),
        ),
        (
            "contrast 1e4",
            split(([0.1; 3], [1e-3; 3]), ([1000.0; 3], [10.0; 3])),
        ),
    ];
    for (name, field) in &fields {
        let want = cpu_phi(&graph, field, &scene);
        for precision in PRECISIONS {
            let out = gpu_frame(&gpu.ctx, &graph, field, &scene, precision);
            let err = rel_rms(&out.phi, &want);
            println!("{name}, {precision:?}: phi rel. RMS {err:.2e}");
            assert!(err <= tolerance(precision), "{name} {precision:?}: {err}");
        }
    }
    gpu.finish();
}

/// Objects from 1 mm to 10 m with fixed coefficients (marble: 2 to 2e4 mean free paths): the GPU
/// frame against the exact discrete solve at each size.
#[test]
fn object_sizes_from_1_mm_to_10_m() {
    let gpu = GpuTest::new();
    let field = MaterialField::Homogeneous(Material::preset("marble").unwrap());
    for size in [1.0, 100.0, 1e4] {
        let graph = sphere(size);
        let want = cpu_phi(&graph, &field, &lit(1.0));
        for precision in [Precision::Mixed, Precision::Fp32] {
            let out = gpu_frame(&gpu.ctx, &graph, &field, &lit(1.0), precision);
            let err = rel_rms(&out.phi, &want);
            println!("{size} mm, {precision:?}: phi rel. RMS {err:.2e}");
            assert!(
                err <= tolerance(precision),
                "{size} mm {precision:?}: {err}"
            );
        }
    }
    gpu.finish();
}

/// Light from 1e-37 to 1e30 (fp16 overflows at 65504 and is subnormal below 6e-5): the exposure
/// keeps J+ linear in the light at every precision; pixels stay finite everywhere and linear
/// within 5e-3 over the 1e-4 .. 1e4 (outside it the RGBA16F target saturates or flushes).
#[test]
fn light_from_1e_minus_37_to_1e30_scales_linearly() {
    let gpu = GpuTest::new();
    let graph = sphere(20.0);
    let field = MaterialField::Homogeneous(Material::preset("marble").unwrap());
    // fp32 shares mixed's exposure path (the full matrix runs all three from 1e-8 to 1e8).
    for precision in [Precision::Mixed, Precision::Fp16] {
        let unit = gpu_frame(&gpu.ctx, &graph, &field, &lit(1.0), precision);
        // 1e-37 and 1e30: 2048 / q leaves f32 below ~6e-36, where `q_scale_for` used to fall
        // back to exposure 1 and q flushed to zero in fp16; it now clamps to f32::MAX.
        for e in [1e-37, 1e-4, 1e4, 1e30] {
            let out = gpu_frame(&gpu.ctx, &graph, &field, &lit(e), precision);
            let scaled: Vec<[f64; 3]> = out
                .j_plus
                .iter()
                .map(|v| v.map(|x| f64::from(x) / e))
                .collect();
            let err = rel_rms(&unit.j_plus, &scaled);
            let (mut d2, mut r2) = (0.0f64, 0.0f64);
            for (p, u) in out.pixels.iter().zip(&unit.pixels) {
                for c in 0..3 {
                    d2 += (f64::from(p[c]) / e - f64::from(u[c])).powi(2);
                    r2 += f64::from(u[c]).powi(2);
                }
            }
            let pixels = (d2 / r2).sqrt();
            println!("E = {e:e}, {precision:?}: J+ linearity {err:.1e}, pixels {pixels:.1e}");
            // At 1e-37 the environment term (1e-38) is an f32 subnormal on the GPU: 5e-3.
            let bound = if e < 1e-30 { 5e-3 } else { 1e-4 };
            assert!(err <= bound, "E = {e} {precision:?}: J+ / E off by {err}");
            if (1e-4..=1e4).contains(&e) {
                assert!(
                    pixels <= 5e-3,
                    "E = {e} {precision:?}: pixels / E off by {pixels}"
                );
            }
        }
    }
    gpu.finish();
}
