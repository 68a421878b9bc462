//! The upstream beam's curvature along the beam's direction (issue 12, the back-lit torus;
//! benches/RESULTS.md "The back-lit torus, region by region"): the baked anisotropy per surface
//! node against the torus's closed-form principal curvatures, and the GPU gather's use of it
//! against the f64 CPU reference's.

use glam::DVec3;
use translucent::material::{Material, MaterialField};
use translucent::mesh::shapes::Shape;
use translucent::quadgraph::surface_samples::surface_node_curvatures;
use translucent::quadgraph::BakeParams;
use translucent::scene::{Environment, Scene};
use translucent::solver::gpu::GpuSolveParams;
use translucent::solver::rel_rms;
use translucent::solver::transport::{ExitQuery, Source, Transport};
use translucent::solver::{self, CpuSolveParams};
use translucent::QuadGraph;
use translucent_tests::{multilevel_object, render_once, GpuTest};

const MAJOR: f64 = 7.0;
const MINOR: f64 = 3.0;

const TORUS: Shape = Shape::Torus {
    major: MAJOR,
    minor: MINOR,
};

fn torus_graph(resolution: u32) -> QuadGraph {
    let torus = TORUS;
    let params = BakeParams {
        resolution,
        levels: 2,
        ..Default::default()
    };
    QuadGraph::bake(&torus.triangulate(96), &torus, &params, &mut |_| {})
        .expect("bake")
        .0
}

/// The torus's normal curvature along unit tangent `t` at the surface point nearest `x` (axis
/// +Y): 1 / minor around the tube, cos(theta) / rho along the ring (Euler between them).
fn torus_curvature_along(x: DVec3, n: DVec3, t: DVec3) -> f64 {
    let rho = x.x.hypot(x.z).max(1e-9);
    let radial = DVec3::new(x.x, 0.0, x.z) / rho;
    let ring = DVec3::new(-x.z, 0.0, x.x) / rho;
    let tube = n.cross(ring).normalize();
    t.dot(tube).powi(2) / MINOR + n.dot(radial) / rho * t.dot(ring).powi(2)
}

/// Mean absolute error of the baked normal curvature along the tube and along the ring over the
/// finest surface nodes, relative to 1 / minor. Measured 0.008 at resolution 16 (the fit over
/// display vertices within two spacings, the mean the smoothed surface's); the bound leaves
/// room for the fit's weights and radius, not for a wrong direction.
const CURVATURE_ALONG_ERROR: f64 = 0.03;
/// Without the anisotropy (k_t = H) the same error is 0.51: a fit that lost it fails.
const UMBILIC_ERROR_ABOVE: f64 = 0.3;

#[test]
fn baked_curvature_along_the_tube_and_the_ring_matches_the_torus() {
    let graph = torus_graph(16);
    let level = graph.finest();
    let curvatures = surface_node_curvatures(level, &graph.surface, &graph.samples);
    let inner = level.inner_count();
    let (mut err, mut umbilic_err, mut count) = (0.0, 0.0, 0usize);
    for (s, k) in curvatures.iter().enumerate() {
        let (x, n) = (level.positions[inner + s], level.surface_normals[s]);
        let ring = DVec3::new(-x.z, 0.0, x.x).normalize();
        let tube = n.cross(ring).normalize();
        for t in [ring, tube] {
            let want = torus_curvature_along(x, n, t);
            err += (k.along(t) - want).abs();
            umbilic_err += (k.mean - want).abs();
            count += 1;
        }
    }
    let (err, umbilic_err) = (
        err * MINOR / count as f64,
        umbilic_err * MINOR / count as f64,
    );
    println!("curvature along: mean error {err:.3} (umbilic {umbilic_err:.3}) of 1 / minor");
    assert!(err <= CURVATURE_ALONG_ERROR, "{err}");
    assert!(umbilic_err >= UMBILIC_ERROR_ABOVE, "{umbilic_err}");
}

/// GPU vertex J+ against the f64 CPU's with the upstream beam on the marble torus lit from
/// straight above (second-collision source, the same baked curvature): the beam runs around the
/// tube everywhere (k_t = 1 / minor, H 0.04-0.22), and no part of the torus shadows another, so
/// the CPU needs no shadow rays where the GPU reads its shadow map (back-lit, the far side's
/// shadow edge on the inner wall alone differs by 7.8e-3). Measured 4.25e-4 (f32, fp16
/// anisotropy, the PCF at the terminator).
const TORUS_UPSTREAM_GPU_VS_CPU: f64 = 2e-3;
/// The upstream beam moves the vertex J+ away from the planar beam by more than this (measured
/// 0.092): a GPU ignoring the option fails.
const UPSTREAM_DIFFERS: f64 = 0.02;

#[test]
fn gpu_upstream_beam_along_the_beam_matches_the_cpu_reference_on_a_torus() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let graph = torus_graph(16);
    let marble = Material::preset("marble").unwrap();
    let field =
        MaterialField::Homogeneous(Material::new(marble.sigma_s, marble.sigma_a, 1.0).unwrap());
    let scene = Scene {
        lights: vec!["dir:0,-1,0:5,5,5".parse().unwrap()],
        environment: Environment::None,
    };
    let cpu_vertex = |upstream_beam: bool| -> Vec<[f64; 3]> {
        let params = CpuSolveParams {
            transport: Transport {
                source: Source::SecondCollision,
                upstream_beam,
                ..Transport::gpu_collimated()
            },
            ..CpuSolveParams::default()
        };
        solver::solve(&graph, &field, &scene, None, &params)
            .unwrap()
            .vertex_j_plus
            .iter()
            .map(|x| x.map(f64::from))
            .collect()
    };
    let (want, planar) = (cpu_vertex(true), cpu_vertex(false));
    let params = GpuSolveParams {
        iterations: vec![4000],
        tolerance: 1e-6,
        exit: ExitQuery::Moments,
        collimated: true,
        second_collision: true,
        upstream_beam: true,
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
    let err = rel_rms(&v, &want);
    let apart = rel_rms(&v, &planar);
    println!("upstream beam on the torus: GPU vs CPU {err:.2e}, vs the planar beam {apart:.3}");
    drop(object);
    gpu.assert_no_messages();
    gpu.finish();
    assert!(err <= TORUS_UPSTREAM_GPU_VS_CPU, "relative RMS {err}");
    assert!(apart > UPSTREAM_DIFFERS, "{apart}");
}
