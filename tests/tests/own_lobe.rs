//! The own-light exit lobe (`--exit-lobe chandra`, `translucent::scene::own_lobe`) on the GPU
//! shading: a sphere of uniform J+ at eta 1, lit along the view (mu0 = the view cosine) or from
//! the side, seen head on. Pixels across the disc must follow `solver::cpu::radiance_lit` (the
//! f64 formula, the light's mu0 at the exact sphere's hit point), and the own light's shape must
//! differ from the node lobe's Lambertian own light by far more than the tolerance (limb-darkened
//! at normal incidence), so the test fails if the shading ignores it. At diffused share 1 the
//! lobe is the node lobe's, and at eta 1.3 the lobe is the node lobe everywhere.

use glam::DVec3;
use translucent::headless::{FrameDesc, HeadlessRenderer};
use translucent::scene::own_lobe::OwnLight;
use translucent::scene::{Camera, ExitLobe, Light, RadianceMode, Scene};
use translucent::solver::cpu::radiance_lit;
use translucent_tests::{exitance_scene, GpuTest};

const SIZE: u32 = 64;
const FOVY_DEG: f64 = 30.0;
const EYE_Z: f64 = 200.0;
const DIAMETER_MM: f64 = 50.0;
/// fp16 J+ and colour storage (2^-11), the interpolated normals of the 64-segment sphere (the
/// limb pixels' normals are off the exact sphere's by up to ~1 degree: < 1% in the lobes there)
/// and the shader's f32 H function against the f64 one.
const PIXEL_TOL: f64 = 0.015;
/// The stand-in material of `HeadlessRenderer` (sigma_a 0): albedo 1.
const ALBEDO: [f64; 3] = [1.0; 3];

/// The exact sphere's hit point and normal at pixel (px, py) of the head-on camera.
fn hit(px: u32, py: u32) -> (DVec3, DVec3, f64) {
    let t = (0.5 * FOVY_DEG).to_radians().tan();
    let x = ((f64::from(px) + 0.5) / f64::from(SIZE) * 2.0 - 1.0) * t;
    let y = (1.0 - (f64::from(py) + 0.5) / f64::from(SIZE) * 2.0) * t;
    let d = DVec3::new(x, y, -1.0).normalize();
    let o = DVec3::new(0.0, 0.0, EYE_Z);
    let r = 0.5 * DIAMETER_MM;
    let b = o.dot(d);
    let s = -b - (b * b - (o.length_squared() - r * r)).sqrt();
    let p = o + s * d;
    let n = p.normalize();
    (p, n, n.dot(-d))
}

fn frame(lobe: ExitLobe) -> FrameDesc {
    FrameDesc {
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
    }
}

/// Centre, two limbs (left and right), above and below: cos theta_o from 1 to ~0.5.
const PIXELS: [(u32, u32); 6] = [(32, 32), (20, 32), (44, 32), (32, 20), (32, 44), (26, 38)];

#[test]
fn the_own_light_lobe_follows_the_cpu_formula() {
    let gpu = GpuTest::new();
    let j = [0.8f32, 0.4, 0.2];
    // Along the view (mu0 = view cosine: the strongest limb darkening) and from the upper left.
    for light in ["dir:0,0,-1:3,3,3", "dir:1,-1,-1:3,2,1"] {
        let light: Light = light.parse().expect("light");
        for eta in [1.0, 1.3] {
            let (mut mesh, scene) = exitance_scene("sphere", DIAMETER_MM, vec![light], eta);
            mesh.exitance = vec![j; mesh.mesh.positions.len()];
            let mut ratios = Vec::new();
            for lobe in [ExitLobe::Node, ExitLobe::Chandra] {
                let mut renderer =
                    HeadlessRenderer::new(&gpu.ctx, &mesh, &scene, &frame(lobe)).expect("new");
                for share in [0.0f32, 0.4, 1.0] {
                    renderer
                        .set_diffused_share(&gpu.ctx, &vec![share; mesh.mesh.positions.len()])
                        .expect("shares");
                    let image = renderer.render_frame(&gpu.ctx).expect("render").image;
                    for (px, py) in PIXELS {
                        let (p, n, cos_o) = hit(px, py);
                        let own = OwnLight::at(&scene, p, n);
                        let want = radiance_lit(
                            j.map(f64::from),
                            eta,
                            cos_o,
                            RadianceMode::Physical,
                            lobe,
                            f64::from(share),
                            &own,
                            ALBEDO,
                        );
                        let got = image.pixel(px, py);
                        for c in 0..3 {
                            assert!(
                                (f64::from(got[c]) / want[c] - 1.0).abs() < PIXEL_TOL,
                                "{lobe:?} eta {eta} share {share} pixel ({px}, {py}) channel \
                                 {c}: {} vs {}",
                                got[c],
                                want[c]
                            );
                        }
                    }
                    if share == 0.0 {
                        let r = |(px, py): (u32, u32)| f64::from(image.pixel(px, py)[0]);
                        ratios.push(r(PIXELS[0]) / r(PIXELS[1]));
                    }
                }
                drop(renderer);
                gpu.assert_no_messages();
            }
            // The own light's shape is told apart from Lambert at eta 1 (along the view:
            // g(1; 1) / g(0.55; 0.55) ~ 1.2), and is the node lobe at eta 1.3.
            let apart = ratios[1] / ratios[0] - 1.0;
            if eta == 1.0 && light_along_view(&scene) {
                assert!(apart > 4.0 * PIXEL_TOL, "{light:?}: {ratios:?}");
            } else if eta != 1.0 {
                assert!(apart.abs() < PIXEL_TOL, "eta {eta}: {ratios:?}");
            }
        }
    }
    gpu.finish();
}

fn light_along_view(scene: &Scene) -> bool {
    matches!(scene.lights[0], Light::Directional { direction, .. } if direction.x == 0.0)
}
