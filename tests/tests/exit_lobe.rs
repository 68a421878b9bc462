//! The exit lobe (`--exit-lobe`, `translucent::scene::ExitLobe`) on the GPU shading: a sphere of
//! uniform J+ seen head on, its centre pixel against a pixel near the limb. With the Lambertian
//! lobe their ratio is F_t(0) / F_t(theta_o); with a lobe of slope b it grows by
//! (1 + b) / (1 + b mu_i). The pixels must follow `solver::cpu::radiance_with_lobe` (the f64
//! formula) for every lobe, and the lobes must differ by far more than the tolerance, so the test
//! fails if the shading ignores the lobe.

use glam::DVec3;
use translucent::headless::{render_headless, FrameDesc};
use translucent::scene::{Camera, ExitLobe, Light, RadianceMode};
use translucent::solver::cpu::radiance_with_lobe;
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
    }
    gpu.finish();
}
