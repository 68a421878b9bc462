//! The exit lobe (`--exit-lobe`, `translucent::scene::ExitLobe`) on the GPU shading: a sphere of
//! uniform J+ seen head on, its centre pixel against a pixel near the limb. With the Lambertian
//! lobe their ratio is F_t(0) / F_t(theta_o); with a lobe of slope b it grows by
//! (1 + b) / (1 + b mu_i). The pixels must follow `solver::cpu::radiance_with_lobe` (the f64
//! formula) for every lobe, and the lobes must differ by far more than the tolerance, so the test
//! fails if the shading ignores the lobe.

use glam::DVec3;
use translucent::headless::{render_headless, FrameDesc, HeadlessRenderer};
use translucent::scene::{Camera, ExitLobe, Light, RadianceMode};
use translucent::solver::cpu::{radiance_with_lobe, radiance_with_lobe_at};
use translucent_tests::{exitance_scene, GpuTest};

const SIZE: u32 = 64;
const FOVY_DEG: f64 = 30.0;
const EYE_Z: f64 = 200.0;
const DIAMETER_MM: f64 = 50.0;
/// Pixels right of the centre for the limb sample: cos theta_o about 0.55 there.
const LIMB_OFFSET: u32 = 12;
/// fp16 J+ and colour storage (2^-11) plus the interpolated normals of the 64-segment sphere
/// (the limb pixel's normal is off the exact sphere's by up to ~1 degree: ~2% in cos theta_o
/// there, which moves F_t and the lobe by < 1%).
const PIXEL_TOL: f64 = 0.01;

/// cos theta_o at pixel (px, py) of the head-on camera: the exact sphere's normal at the hit.
fn view_cosine(px: u32, py: u32) -> f64 {
    let t = (0.5 * FOVY_DEG).to_radians().tan();
    let x = ((f64::from(px) + 0.5) / f64::from(SIZE) * 2.0 - 1.0) * t;
    let y = (1.0 - (f64::from(py) + 0.5) / f64::from(SIZE) * 2.0) * t;
    let d = DVec3::new(x, y, -1.0).normalize();
    let o = DVec3::new(0.0, 0.0, EYE_Z);
    let r = 0.5 * DIAMETER_MM;
    // |o + s d| = r, the nearer root.
    let b = o.dot(d);
    let s = -b - (b * b - (o.length_squared() - r * r)).sqrt();
    let n = (o + s * d).normalize();
    n.dot(-d)
}

#[test]
fn centre_to_limb_radiance_follows_the_exit_lobe() {
    let gpu = GpuTest::new();
    let j = [0.8f32, 0.4, 0.2];
    let (cx, cy) = (SIZE / 2, SIZE / 2);
    let limb = (SIZE / 2 + LIMB_OFFSET, SIZE / 2);
    for eta in [1.0, 1.3] {
        let (mut mesh, scene) =
            exitance_scene("sphere", DIAMETER_MM, vec![Light::default_light()], eta);
        mesh.exitance = vec![j; mesh.mesh.positions.len()];
        let mut ratios = Vec::new();
        for lobe in [ExitLobe::Lambert, ExitLobe::P1, ExitLobe::Fitted] {
            let frame = FrameDesc {
                width: SIZE,
                height: SIZE,
                camera: Some(Camera {
                    eye: DVec3::new(0.0, 0.0, EYE_Z),
                    target: DVec3::ZERO,
                    fovy_deg: FOVY_DEG,
                }),
                specular: false,
                exit_lobe: lobe,
                ..FrameDesc::default()
            };
            let image = render_headless(&gpu.ctx, &mesh, &scene, &frame)
                .expect("render")
                .image;
            let want = |(px, py): (u32, u32)| {
                radiance_with_lobe(
                    j.map(f64::from),
                    eta,
                    view_cosine(px, py),
                    RadianceMode::Physical,
                    lobe,
                )
            };
            for (px, py) in [(cx, cy), limb] {
                let got = image.pixel(px, py);
                let w = want((px, py));
                for c in 0..3 {
                    assert!(
                        (f64::from(got[c]) / w[c] - 1.0).abs() < PIXEL_TOL,
                        "{lobe:?} eta {eta} pixel ({px}, {py}) channel {c}: {} vs {}",
                        got[c],
                        w[c]
                    );
                }
            }
            let ratio =
                f64::from(image.pixel(cx, cy)[0]) / f64::from(image.pixel(limb.0, limb.1)[0]);
            ratios.push(ratio);
        }
        // The lobes are told apart: each slope raises the centre-to-limb ratio above the
        // Lambertian one by far more than the pixels' tolerance (P1 at eta 1: (1 + 1.5) /
        // (1 + 1.5 * 0.55), ~37%; the fitted lobe at eta 1.3, the smallest: ~6%).
        for steeper in &ratios[1..] {
            assert!(*steeper > ratios[0] * (1.0 + 4.0 * PIXEL_TOL), "{ratios:?}");
        }
        assert!(ratios[1] > ratios[2], "P1 is the steeper lobe: {ratios:?}");

        // The per-node lobe follows the vertex stream's diffused share: 0 (own light: Lambert, also
        // what a method without shares gives) and 1 (light diffused from elsewhere: P1).
        let frame = FrameDesc {
            width: SIZE,
            height: SIZE,
            camera: Some(Camera {
                eye: DVec3::new(0.0, 0.0, EYE_Z),
                target: DVec3::ZERO,
                fovy_deg: FOVY_DEG,
            }),
            specular: false,
            exit_lobe: ExitLobe::Node,
            ..FrameDesc::default()
        };
        let mut renderer = HeadlessRenderer::new(&gpu.ctx, &mesh, &scene, &frame).expect("new");
        let mut node_ratios = Vec::new();
        for share in [0.0f32, 1.0] {
            renderer
                .set_diffused_share(&gpu.ctx, &vec![share; mesh.mesh.positions.len()])
                .expect("shares");
            let image = renderer.render_frame(&gpu.ctx).expect("render").image;
            for (px, py) in [(cx, cy), limb] {
                let w = radiance_with_lobe_at(
                    j.map(f64::from),
                    eta,
                    view_cosine(px, py),
                    RadianceMode::Physical,
                    ExitLobe::Node,
                    f64::from(share),
                );
                let got = image.pixel(px, py);
                for c in 0..3 {
                    assert!(
                        (f64::from(got[c]) / w[c] - 1.0).abs() < PIXEL_TOL,
                        "node share {share} eta {eta} pixel ({px}, {py}) channel {c}: {} vs {}",
                        got[c],
                        w[c]
                    );
                }
            }
            node_ratios.push(
                f64::from(image.pixel(cx, cy)[0]) / f64::from(image.pixel(limb.0, limb.1)[0]),
            );
        }
        assert!(
            node_ratios[1] > node_ratios[0] * (1.0 + 4.0 * PIXEL_TOL),
            "the share steepens the lobe: {node_ratios:?}"
        );
        // Bad shares are refused by name.
        let bad = renderer.set_diffused_share(&gpu.ctx, &vec![1.5; mesh.mesh.positions.len()]);
        assert!(bad.is_err_and(|e| e.to_string().contains("diffused share")));
        drop(renderer);
    }
    gpu.finish();
}

/// The per-node lobe's diffused share (`scene::diffused_share`) on the GPU frame against the f64
/// CPU reference, per surface node and per display vertex, with render's second-collision source
/// and with the boundary flux: a marble sphere lit from one side. The f32 solve, fp16 q and the
/// shadow maps' PCF at the terminator against the CPU's exact n.l are the differences (measured
/// 6e-5 per node, 3e-5 per vertex); the share is in [0, 1], so this is an absolute mean.
const SHARE_GPU_VS_CPU: f64 = 1e-3;

#[test]
fn node_shares_match_the_cpu_reference() {
    use translucent::material::{Material, MaterialField};
    use translucent::mesh::shapes::Shape;
    use translucent::quadgraph::BakeParams;
    use translucent::scene::{Environment, Scene};
    use translucent::solver::gpu::GpuSolveParams;
    use translucent::solver::transport::{ExitQuery, Source, Transport};
    use translucent::solver::{self, CpuSolveParams};
    use translucent::QuadGraph;
    use translucent_tests::{multilevel_object, render_once};

    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let shape = Shape::Sphere { radius: 10.0 };
    let params = BakeParams {
        resolution: 16,
        levels: 2,
        ..Default::default()
    };
    let graph = QuadGraph::bake(&shape.triangulate(32), &shape, &params, &mut |_| {})
        .expect("bake")
        .0;
    let field = MaterialField::Homogeneous(Material::preset("marble").unwrap());
    let scene = Scene {
        lights: vec!["dir:0.5,-1,-0.5:4,4,4".parse().unwrap()],
        environment: Environment::None,
    };
    let mean_abs = |a: &[f32], b: &[f64]| {
        assert_eq!(a.len(), b.len());
        a.iter()
            .zip(b)
            .map(|(&x, &y)| (f64::from(x) - y).abs())
            .sum::<f64>()
            / a.len() as f64
    };
    for (name, collimated) in [("second collision", true), ("boundary flux", false)] {
        let transport = if collimated {
            Transport {
                source: Source::SecondCollision,
                ..Transport::gpu_collimated()
            }
        } else {
            Transport {
                exit: ExitQuery::Moments,
                ..Transport::default()
            }
        };
        let cpu_params = CpuSolveParams {
            transport,
            ..CpuSolveParams::default()
        };
        let reference = solver::solve(&graph, &field, &scene, None, &cpu_params).unwrap();
        let gpu_params = GpuSolveParams {
            iterations: vec![4000],
            tolerance: 1e-6,
            exit: ExitQuery::Moments,
            collimated,
            second_collision: collimated,
            ..Default::default()
        };
        let mut object = multilevel_object(ctx, &graph, &field, &scene, gpu_params);
        render_once(ctx, &mut object, 32, 32);
        let solve = object.quadgraph().expect("a QuadGraph object").solve();
        let nodes = solve.read_diffused_share(ctx).expect("node shares");
        let vertices = solve
            .read_vertex_diffused_share(ctx)
            .expect("vertex shares");
        let node_err = mean_abs(&nodes, &reference.diffused_share);
        let want: Vec<f64> = reference
            .vertex_diffused_share
            .iter()
            .map(|&s| f64::from(s))
            .collect();
        let vertex_err = mean_abs(&vertices, &want);
        // The share must tell the sides apart: the unlit side diffused, the lit side its own.
        let n = reference.diffused_share.len() as f64;
        let diffused = reference
            .diffused_share
            .iter()
            .filter(|&&s| s > 0.9)
            .count() as f64
            / n;
        let own = reference
            .diffused_share
            .iter()
            .filter(|&&s| s < 0.1)
            .count() as f64
            / n;
        println!(
            "{name}: share GPU vs CPU nodes {node_err:.2e}, vertices {vertex_err:.2e}; \
             diffused {diffused:.2}, own {own:.2}"
        );
        assert!(node_err <= SHARE_GPU_VS_CPU, "{name}: nodes {node_err}");
        assert!(
            vertex_err <= SHARE_GPU_VS_CPU,
            "{name}: vertices {vertex_err}"
        );
        assert!(diffused > 0.3 && own > 0.2, "{name}: {diffused} / {own}");
        drop(object);
        gpu.assert_no_messages();
    }
    gpu.finish();
}
