//! Environment maps: an equirectangular (latitude-longitude) radiance image projected onto the
//! order-2 spherical harmonics of [`Environment::SphericalHarmonics`], whose irradiance the solvers
//! evaluate (Ramamoorthi and Hanrahan 2001: nine coefficients per channel capture irradiance to a
//! few percent).
//!
//! Texel convention (the one Mitsuba 3's `envmap` uses, so path-traced references agree): texel
//! `(x, y)` of a `width x height` map, `(0, 0)` top-left, holds the radiance arriving from direction
//! `d` with `u = atan2(d.x, -d.z) / 2 pi` (wrapped to [0, 1)) and `v = acos(d.y) / pi`, `u = (x + 0.5)
//! / width`, `v = (y + 0.5) / height`: +Y (up) is the top row.
//!
//! ```
//! use translucent::scene::Environment;
//! // A uniform sky of radiance 2: the projection gives irradiance pi * 2 on every normal.
//! let env = Environment::from_equirect(64, 32, &vec![[2.0; 3]; 64 * 32]).unwrap();
//! let e = env.irradiance(glam::DVec3::X);
//! assert!((e[0] - std::f64::consts::PI * 2.0).abs() < 1e-3);
//! ```

use std::f64::consts::PI;
use std::path::Path;

use glam::DVec3;

use super::{Environment, SceneError};

/// The nine real SH basis functions in the order of [`Environment::SphericalHarmonics`].
fn sh_basis(d: DVec3) -> [f64; 9] {
    let (x, y, z) = (d.x, d.y, d.z);
    [
        0.282095,
        0.488603 * y,
        0.488603 * z,
        0.488603 * x,
        1.092548 * x * y,
        1.092548 * y * z,
        0.315392 * (3.0 * z * z - 1.0),
        1.092548 * x * z,
        0.546274 * (x * x - y * y),
    ]
}

/// The direction a texel centre of an equirectangular map looks at (module convention).
pub fn equirect_direction(x: usize, y: usize, width: usize, height: usize) -> DVec3 {
    let phi = 2.0 * PI * (x as f64 + 0.5) / width as f64;
    let theta = PI * (y as f64 + 0.5) / height as f64;
    DVec3::new(
        theta.sin() * phi.sin(),
        theta.cos(),
        -theta.sin() * phi.cos(),
    )
}

fn bad(problem: String) -> SceneError {
    SceneError::Invalid {
        what: "environment map".into(),
        problem,
    }
}

impl Environment {
    /// Projects an equirectangular radiance map (row-major, `width * height` texels of linear RGB)
    /// onto order-2 spherical harmonics. Negative or non-finite texels are an error.
    pub fn from_equirect(
        width: usize,
        height: usize,
        texels: &[[f32; 3]],
    ) -> Result<Environment, SceneError> {
        if width < 2 || height < 1 || texels.len() != width * height {
            return Err(bad(format!(
                "{} texels for a {width} x {height} map (need at least 2 x 1)",
                texels.len()
            )));
        }
        if let Some(i) = texels
            .iter()
            .position(|t| t.iter().any(|v| !(v.is_finite() && *v >= 0.0)))
        {
            return Err(bad(format!(
                "texel ({}, {}) is {:?}: radiance must be finite and >= 0",
                i % width,
                i / width,
                texels[i]
            )));
        }
        let mut c = [[0.0f64; 3]; 9];
        let d_phi = 2.0 * PI / width as f64;
        let d_theta = PI / height as f64;
        for y in 0..height {
            let theta = PI * (y as f64 + 0.5) / height as f64;
            // Solid angle of a texel of this row.
            let d_omega = d_phi * d_theta * theta.sin();
            for x in 0..width {
                let basis = sh_basis(equirect_direction(x, y, width, height));
                let l = texels[y * width + x];
                for (coeff, b) in c.iter_mut().zip(basis) {
                    for ch in 0..3 {
                        coeff[ch] += f64::from(l[ch]) * b * d_omega;
                    }
                }
            }
        }
        Ok(Environment::SphericalHarmonics(c))
    }

    /// Reads an equirectangular EXR (first RGBA layer, linear radiance) and projects it with
    /// [`Environment::from_equirect`]. Errors name the file.
    pub fn load_exr(path: &Path) -> Result<Environment, SceneError> {
        let image = exr::prelude::read_first_rgba_layer_from_file(
            path,
            |res, _| (res.width(), vec![[0.0f32; 3]; res.width() * res.height()]),
            |(w, buf), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
                buf[pos.y() * *w + pos.x()] = [r, g, b]
            },
        )
        .map_err(|e| bad(format!("{}: {e}", path.display())))?;
        let size = image.layer_data.size;
        let (_, texels) = &image.layer_data.channel_data.pixels;
        Environment::from_equirect(size.width(), size.height(), texels)
            .map_err(|e| bad(format!("{}: {e}", path.display())))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sky whose radiance is linear in the direction, L(d) = a + b . d, is represented exactly by
    /// orders 0 and 1, and its irradiance is pi a + (2 pi / 3) b . n.
    #[test]
    fn a_linear_sky_projects_to_its_exact_irradiance() {
        let (w, h) = (256, 128);
        let (a, b) = (1.0, DVec3::new(0.3, 0.6, -0.2));
        let texels: Vec<[f32; 3]> = (0..w * h)
            .map(|i| {
                let d = equirect_direction(i % w, i / w, w, h);
                [(a + b.dot(d)) as f32, a as f32, 0.0]
            })
            .collect();
        let env = Environment::from_equirect(w, h, &texels).expect("valid map");
        for n in [
            DVec3::X,
            DVec3::Y,
            -DVec3::Z,
            DVec3::new(1.0, 2.0, 3.0).normalize(),
        ] {
            let e = env.irradiance(n);
            let exact = PI * a + 2.0 * PI / 3.0 * b.dot(n);
            assert!(
                (e[0] - exact).abs() < 2e-3 * exact,
                "{n}: {} vs {exact}",
                e[0]
            );
            assert!((e[1] - PI * a).abs() < 1e-3 * PI * a);
            assert!(e[2].abs() < 1e-12);
        }
    }

    #[test]
    fn the_top_row_looks_up_and_u_follows_mitsuba() {
        let up = equirect_direction(0, 0, 64, 32);
        assert!(up.y > 0.99);
        // u = 0.5 looks along +z in Mitsuba's convention (atan2(x, -z) = pi).
        let d = equirect_direction(31, 15, 64, 32);
        assert!(d.z > 0.99, "{d}");
    }

    #[test]
    fn bad_maps_are_typed_errors_and_exr_files_round_trip() {
        assert!(Environment::from_equirect(4, 2, &[[1.0; 3]; 7]).is_err());
        let mut t = vec![[1.0f32; 3]; 8];
        t[5] = [f32::NAN, 0.0, 0.0];
        let e = Environment::from_equirect(4, 2, &t).expect_err("NaN texel");
        assert!(e.to_string().contains("(1, 1)"), "{e}");
        t[5] = [-1.0, 0.0, 0.0];
        assert!(Environment::from_equirect(4, 2, &t).is_err());

        let dir = std::env::temp_dir().join(format!("translucent-env-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let path = dir.join("sky.exr");
        exr::prelude::write_rgb_file(&path, 32, 16, |_, _| (0.5f32, 0.25f32, 1.0f32))
            .expect("write exr");
        let env = Environment::load_exr(&path).expect("load");
        let e = env.irradiance(DVec3::Y);
        assert!(
            (e[0] - PI * 0.5).abs() < 1e-2 && (e[2] - PI).abs() < 2e-2,
            "{e:?}"
        );
        let missing = Environment::load_exr(&dir.join("missing.exr")).expect_err("missing file");
        assert!(missing.to_string().contains("missing.exr"));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
