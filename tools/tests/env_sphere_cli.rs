//! Issue 12 item 4's must-show through `translucent render` at its defaults (surface, source,
//! exit query, diffusion coefficient, resolution, supersampling): a sphere of marble, skin1 and
//! ketchup (R = 10 mm, the presets' eta 1.3) under a constant environment has a constant exact
//! exitance, so the albedo of every pixel, L_o / (F_t(eta, theta_o) L_env), must be flat and equal
//! to the model's closed form on the sphere (DESIGN 2, 2.5-2.6: phi = alpha sinh(s r) / r, the
//! Robin condition and the exit query of the render's boundary). The shepard surface fails both
//! (its blotches follow the lattice: per-pixel CV 5-26% on skin1's green and blue).
//! Ketchup's green and blue have a negative closed-form J+ (the model's limit): they must
//! display 0. `tools/env_sphere_exr.py` prints the same numbers for any image.

mod common;

use std::path::Path;

use common::{json_of, scratch, translucent};
use translucent::material::{DiffusionCoefficient, Material};
use translucent::solver::transport::{Boundary, ExitQuery, Optics};

/// Sphere radius (mm), the camera (eye on +z at this distance, 30 degrees) and the image size.
const RADIUS: f64 = 10.0;
const EYE_Z: f64 = 60.0;
const FOVY_DEG: f64 = 30.0;
const PIXELS: usize = 64;

/// Pixels whose view cosine is below this are left out: the grazing band, where F_t falls
/// steeply to 0 and the display mesh's interpolated normals and the supersampled silhouette
/// differ from the exact sphere (it alone holds the per-pixel CV at ~1% on marble at eta 1.3;
/// above it marble is flat to 0.06%).
const MIN_COS: f64 = 0.3;

/// The bounds: per-pixel coefficient of variation and albedo against the closed form,
/// on every channel whose closed form is positive. Measured (64 px, lavapipe): CV marble
/// 0.23-0.58%, skin1 0.14 / 0.23 / 0.55%, ketchup red 0.17%; albedo marble -0.1%, skin1 -0.25 /
/// -0.17 / +0.51%, ketchup red -0.19%. Skin1's blue (albedo 0.048, a small difference of the
/// exit query's two terms: 1% on phi(0) is 12% on it) was +2.85% before the interior sample was
/// read back onto its profile (`solver::transport::sample_on_profile`).
const FLAT: f64 = 0.01;
const ALBEDO: f64 = 0.01;

/// The model's sphere albedo M / q for channel `c` (render's default exit query: the moments
/// query with the second-collision source; its default D: Grosjean's).
fn closed_form(m: &Material, c: usize) -> f64 {
    let o = Optics {
        sigma_s: m.sigma_s[c],
        sigma_a: m.sigma_a[c],
        diffusion: DiffusionCoefficient::Grosjean,
    };
    let boundary = Boundary::new(m.eta, ExitQuery::Moments);
    let (d, s) = (o.d(), o.s());
    let g = s / (s * RADIUS).tanh() - 1.0 / RADIUS;
    let q = 1.0;
    let phi = boundary.flux_gain * q / (1.0 + boundary.h(o) * g);
    boundary.exitance(d, phi, -g * phi, q) / q
}

/// Per pixel (row-major, y down) rgb, alpha of `exr`.
fn read(exr: &Path) -> Vec<([f32; 3], f32)> {
    let image = exr::prelude::read_first_rgba_layer_from_file(
        exr,
        |res, _| {
            (
                res.width(),
                vec![([0.0f32; 3], 0.0f32); res.width() * res.height()],
            )
        },
        |(w, px): &mut (usize, Vec<([f32; 3], f32)>), pos, (r, g, b, a): (f32, f32, f32, f32)| {
            px[pos.y() * *w + pos.x()] = ([r, g, b], a)
        },
    )
    .unwrap_or_else(|e| panic!("{}: {e}", exr.display()));
    image.layer_data.channel_data.pixels.1
}

/// cos theta_o of the camera ray through pixel (x, y) where it meets the sphere, if it does.
fn view_cosine(x: usize, y: usize) -> Option<f64> {
    let t = (FOVY_DEG.to_radians() / 2.0).tan();
    let nx = (2.0 * (x as f64 + 0.5) / PIXELS as f64 - 1.0) * t;
    let ny = (1.0 - 2.0 * (y as f64 + 0.5) / PIXELS as f64) * t;
    let d = glam::DVec3::new(nx, ny, -1.0).normalize();
    let eye = glam::DVec3::new(0.0, 0.0, EYE_Z);
    let b = d.dot(eye);
    let disc = b * b - (eye.length_squared() - RADIUS * RADIUS);
    (disc > 0.0).then(|| {
        let hit = eye + d * (-b - disc.sqrt());
        -d.dot(hit) / RADIUS
    })
}

#[test]
fn environment_spheres_are_flat_and_match_the_closed_form_at_the_defaults() {
    let dir = scratch("env-sphere");
    let camera = format!("0,0,{EYE_Z}:0,0,0:{FOVY_DEG}");
    let size = PIXELS.to_string();
    for preset in ["marble", "skin1", "ketchup"] {
        let m = Material::preset(preset).expect("preset");
        let exr = dir.join(format!("{preset}.exr"));
        let out = translucent(
            &[
                "render",
                "--shape",
                "sphere",
                "--size-mm",
                &(2.0 * RADIUS).to_string(),
                "--material",
                preset,
                "--env-constant",
                "1,1,1",
                "--light",
                "dir:0,-1,0:0,0,0",
                "--no-specular",
                "--camera",
                &camera,
                "--width",
                &size,
                "--height",
                &size,
                "--json",
                "--out",
                exr.to_str().expect("utf-8 path"),
            ],
            &dir,
        );
        assert!(
            out.status.success(),
            "{preset}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        // `--surface auto` resolves per material: the interior reconstruction where the lattice
        // would show (skin1, ketchup), Shepard for marble.
        let expected = if preset == "marble" {
            "shepard"
        } else {
            "interior"
        };
        assert_eq!(
            json_of(&out)["surface"],
            expected,
            "{preset}: --surface auto"
        );
        let pixels = read(&exr);
        let mut albedo: [Vec<f64>; 3] = Default::default();
        for (i, (rgb, alpha)) in pixels.iter().enumerate() {
            let Some(cos_o) = view_cosine(i % PIXELS, i / PIXELS) else {
                continue;
            };
            if cos_o < MIN_COS || *alpha < 0.999 {
                continue;
            }
            let f_t = translucent::material::fresnel::transmittance(m.eta, cos_o);
            for c in 0..3 {
                albedo[c].push(f64::from(rgb[c]) / f_t);
            }
        }
        assert!(
            albedo[0].len() > PIXELS * PIXELS / 8,
            "{preset}: too few sphere pixels"
        );
        for (c, values) in albedo.iter().enumerate() {
            let n = values.len() as f64;
            let mean = values.iter().sum::<f64>() / n;
            let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n;
            let cv = if mean > 0.0 { var.sqrt() / mean } else { 0.0 };
            let exact = closed_form(&m, c);
            println!(
                "{preset} channel {c}: per-pixel CV {:.2}%, albedo {mean:.4}, closed form {exact:.4} ({:+.2}%)",
                100.0 * cv,
                100.0 * (mean / exact - 1.0)
            );
            assert!(
                values.iter().all(|v| v.is_finite() && *v >= 0.0),
                "{preset} channel {c}: a pixel is negative or not finite"
            );
            assert!(cv <= FLAT, "{preset} channel {c}: per-pixel CV {cv}");
            if exact > 0.0 {
                assert!(
                    (mean / exact - 1.0).abs() <= ALBEDO,
                    "{preset} channel {c}: albedo {mean} against the closed form {exact}"
                );
            } else {
                assert!(
                    mean == 0.0,
                    "{preset} channel {c}: negative J+ not displayed as 0"
                );
            }
        }
    }
}
