//! Light arriving from every direction: none, constant, or order-2 spherical harmonics (an
//! environment map projected by [`Environment::from_equirect`] / [`Environment::load_exr`]).
//!
//! Environments carry no visibility: exact for a convex object (nothing of itself hides the sky),
//! an over-estimate in the concavities of a non-convex one (no ambient occlusion).

use glam::DVec3;

use super::light::{bad, check_colour, MAX_LIGHT_COLOUR};
use super::SceneError;

/// Light arriving from every direction.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum Environment {
    #[default]
    None,
    /// Constant radiance L: q = pi L (1 - F_dr,ext).
    Constant([f64; 3]),
    /// Radiance as real spherical harmonics up to order 2, 9 coefficients per channel, ordered
    /// (l, m) = (0,0), (1,-1), (1,0), (1,1), (2,-2), (2,-1), (2,0), (2,1), (2,2), in the basis of
    /// Ramamoorthi and Hanrahan 2001 written in our object frame (Y_1-1 ~ y, Y_10 ~ z, Y_11 ~ x).
    SphericalHarmonics([[f64; 3]; 9]),
}

impl Environment {
    pub fn validate(&self) -> Result<(), SceneError> {
        match self {
            Environment::None => Ok(()),
            Environment::Constant(l) => check_colour("constant environment", *l),
            Environment::SphericalHarmonics(c) => {
                if c.iter()
                    .flatten()
                    .all(|v| v.is_finite() && v.abs() <= MAX_LIGHT_COLOUR)
                {
                    Ok(())
                } else {
                    Err(bad(
                        "SH environment",
                        format!("coefficients must be finite and within +-{MAX_LIGHT_COLOUR:e}"),
                    ))
                }
            }
        }
    }

    /// Irradiance E(n) arriving on a surface with outward normal `n`, before Fresnel transmission.
    /// For SH: Ramamoorthi and Hanrahan 2001, Eq. 13 (clamped at 0: a truncated expansion can dip
    /// below zero where the environment is dark).
    pub fn irradiance(&self, n: DVec3) -> [f64; 3] {
        match self {
            Environment::None => [0.0; 3],
            Environment::Constant(l) => l.map(|v| std::f64::consts::PI * v),
            Environment::SphericalHarmonics(c) => {
                const C1: f64 = 0.429043;
                const C2: f64 = 0.511664;
                const C3: f64 = 0.743125;
                const C4: f64 = 0.886227;
                const C5: f64 = 0.247708;
                let (x, y, z) = (n.x, n.y, n.z);
                std::array::from_fn(|ch| {
                    let l = |i: usize| c[i][ch];
                    let e = C1 * l(8) * (x * x - y * y) + C3 * l(6) * z * z + C4 * l(0) - C5 * l(6)
                        + 2.0 * C1 * (l(4) * x * y + l(7) * x * z + l(5) * y * z)
                        + 2.0 * C2 * (l(3) * x + l(1) * y + l(2) * z);
                    e.max(0.0)
                })
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn sh_irradiance_is_exact_for_constant_and_linear_radiance() {
        // L(w) = a + b w_y: E(n) = pi a + (2 pi / 3) b n_y.
        let (a, b) = (0.7, 0.3);
        let mut c = [[0.0; 3]; 9];
        c[0] = [a * 2.0 * PI.sqrt(); 3];
        c[1] = [b / 0.488603; 3];
        let env = Environment::SphericalHarmonics(c);
        for n in [
            DVec3::Y,
            -DVec3::Y,
            DVec3::X,
            DVec3::new(0.3, 0.5, -0.2).normalize(),
        ] {
            let e = env.irradiance(n)[1];
            let exact = PI * a + 2.0 * PI / 3.0 * b * n.y;
            assert!((e - exact).abs() < 1e-5 * exact, "{n}: {e} vs {exact}");
        }
        let constant = Environment::Constant([a; 3]).irradiance(DVec3::Z)[0];
        let sh_const = Environment::SphericalHarmonics({
            let mut c = [[0.0; 3]; 9];
            c[0] = [a * 2.0 * PI.sqrt(); 3];
            c
        })
        .irradiance(DVec3::Z)[0];
        assert!((constant - sh_const).abs() < 1e-6);
    }
}
