//! The angular shape of the radiance leaving a translucent surface (the exit lobe).
//!
//! DESIGN 2.6 draws the exitance M with a Lambertian lobe seen through the boundary:
//! `L_o = M F_t(theta_o) / (pi (1 - 2 C1(1/eta)))`. Light leaving a scattering medium is not
//! Lambertian inside: the P1 radiance just inside the boundary is `phi/4pi (1 + 3 D phi'/phi mu_i)`,
//! and with the Robin condition phi = 2 A D phi' its slope is `b = 3 / (2 A)` (1.5 at eta 1).
//! Every lobe here has the form
//!
//! `L_o = L_lambert(theta_o) (1 + b mu_i) / (1 + b K(eta))`,
//!
//! mu_i the cosine of the refracted (inside) direction, and the normalization
//! `K(eta) = int T mu_i mu_o dmu_o / int T mu_o dmu_o = (1/3 - C2(eta)) / (1/2 - C1(eta))`
//! (the substitution mu_o dmu_o = eta^2 mu_i dmu_i, T equal both ways by reciprocity), so that the
//! lobe integrates to the same M over the outgoing hemisphere as the Lambertian one (tested
//! numerically below for eta 1, 1.3, 1.5).
//!
//! - [`ExitLobe::Lambert`]: b = 0, DESIGN 2.6.
//! - [`ExitLobe::P1`]: b = 3 / (2 A(eta)), the full P1 lobe (too steep for reflected light,
//!   about right for light transmitted from deep inside: the Milne problem's H(mu)).
//! - [`ExitLobe::Fitted`]: b = [`FITTED_SLOPE_SHARE`] times the P1 slope, fitted on the
//!   half-space and slab Monte Carlo (benches/exit_lobe/lobe_mc.py; benches/RESULTS.md "Exit lobe").
//!
//! ```
//! use translucent::scene::ExitLobe;
//! let lobe: ExitLobe = "p1".parse()?;
//! // At eta 1 the P1 lobe is (1 + 1.5 mu) / 2: twice as bright at normal view as at grazing.
//! let ratio = lobe.factor(1.0, 1.0) / lobe.factor(1.0, 0.0);
//! assert!((ratio - 2.5).abs() < 1e-9);
//! assert_eq!(ExitLobe::Lambert.factor(1.3, 0.4), 1.0);
//! # Ok::<(), translucent::scene::SceneError>(())
//! ```

use super::SceneError;
use crate::material::fresnel;

/// The fitted lobe's slope as a share of the P1 slope 3 / (2 A): the least relative RMS over the
/// half-space and slab Monte Carlo cases of benches/exit_lobe/lobe_mc.py (RESULTS "Exit lobe").
pub const FITTED_SLOPE_SHARE: f64 = 0.5;

/// The angular shape of the exitance's radiance (CLI `--exit-lobe`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ExitLobe {
    /// Lambertian inside, F_t(theta_o) outside (DESIGN 2.6).
    #[default]
    Lambert,
    /// The P1 radiance's slope, b = 3 / (2 A(eta)).
    P1,
    /// b = [`FITTED_SLOPE_SHARE`] of the P1 slope.
    Fitted,
}

impl ExitLobe {
    /// The names `--exit-lobe` takes and `--json` reports.
    pub const NAMES: [&'static str; 3] = ["lambert", "p1", "fitted"];

    pub fn name(self) -> &'static str {
        match self {
            Self::Lambert => Self::NAMES[0],
            Self::P1 => Self::NAMES[1],
            Self::Fitted => Self::NAMES[2],
        }
    }

    /// The slope b of `1 + b mu_i` at relative index `eta`.
    pub fn slope(self, eta: f64) -> f64 {
        let p1 = || {
            let a = (1.0 + 3.0 * fresnel::moment2(eta)) / (1.0 - 2.0 * fresnel::moment1(eta));
            3.0 / (2.0 * a)
        };
        match self {
            Self::Lambert => 0.0,
            Self::P1 => p1(),
            Self::Fitted => FITTED_SLOPE_SHARE * p1(),
        }
    }

    /// `(b, 1 / (1 + b K(eta)))`: what the shading needs per frame (`shade_mesh.frag`'s push
    /// constants `lobe_slope`, `lobe_scale`).
    pub fn shading_constants(self, eta: f64) -> (f64, f64) {
        let b = self.slope(eta);
        if b == 0.0 {
            return (0.0, 1.0);
        }
        let k = (1.0 / 3.0 - fresnel::moment2(eta)) / (0.5 - fresnel::moment1(eta));
        (b, 1.0 / (1.0 + b * k))
    }

    /// The factor this lobe puts on the Lambertian radiance toward `cos_o` (outside cosine to
    /// the normal, clamped to [0, 1]); 1 for [`ExitLobe::Lambert`].
    pub fn factor(self, eta: f64, cos_o: f64) -> f64 {
        let (b, scale) = self.shading_constants(eta);
        if b == 0.0 {
            return 1.0;
        }
        (1.0 + b * inside_cosine(eta, cos_o)) * scale
    }
}

/// Cosine of the refracted direction inside for a ray leaving at `cos_o` outside (0 where it
/// would be totally reflected, eta < 1).
pub fn inside_cosine(eta: f64, cos_o: f64) -> f64 {
    let c = cos_o.clamp(0.0, 1.0);
    (1.0 - (1.0 - c * c) / (eta * eta)).max(0.0).sqrt()
}

impl std::str::FromStr for ExitLobe {
    type Err = SceneError;
    /// `lambert`, `p1` or `fitted` (the CLI's `--exit-lobe`).
    fn from_str(s: &str) -> Result<Self, SceneError> {
        match s {
            "lambert" => Ok(Self::Lambert),
            "p1" => Ok(Self::P1),
            "fitted" => Ok(Self::Fitted),
            _ => Err(SceneError::Invalid {
                what: "exit lobe".into(),
                problem: format!("'{s}' (expected {})", Self::NAMES.join(", ")),
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The midpoint rule's error on these smooth integrands at 20000 steps (the Fresnel kink at
    /// grazing is integrable and small).
    const QUADRATURE_TOL: f64 = 1e-6;

    /// int_0^1 F_t(eta, mu_o) g(mu_o) mu_o dmu_o by the midpoint rule: the exitance a lobe g
    /// (times the Lambertian radiance) carries, up to the common 2 pi / (pi (1 - 2 C1)) factor.
    fn exitance(eta: f64, g: impl Fn(f64) -> f64) -> f64 {
        const STEPS: usize = 20_000;
        (0..STEPS)
            .map(|i| {
                let mu = (i as f64 + 0.5) / STEPS as f64;
                fresnel::transmittance(eta, mu) * g(mu) * mu / STEPS as f64
            })
            .sum()
    }

    #[test]
    fn every_lobe_carries_the_lambertian_exitance() {
        for eta in [1.0, 1.3, 1.5] {
            let lambert = exitance(eta, |_| 1.0);
            for lobe in [ExitLobe::P1, ExitLobe::Fitted] {
                // factor() recomputes the Fresnel moments per call: take them once here.
                let (b, scale) = lobe.shading_constants(eta);
                let g = |mu: f64| (1.0 + b * inside_cosine(eta, mu)) * scale;
                for mu in [0.0, 0.3, 1.0] {
                    assert_eq!(g(mu), lobe.factor(eta, mu));
                }
                let m = exitance(eta, g);
                assert!(
                    (m / lambert - 1.0).abs() < QUADRATURE_TOL,
                    "{lobe:?} at eta {eta}: {m} vs {lambert}"
                );
                // And it is a lobe: brighter toward the normal than at grazing.
                assert!(lobe.factor(eta, 1.0) > lobe.factor(eta, 0.05), "{lobe:?}");
            }
        }
    }

    #[test]
    fn the_p1_slope_at_eta_one_is_three_halves() {
        // A(1) = 1: the Robin condition phi = 2 D phi' and b = 3 D phi' / phi.
        assert!((ExitLobe::P1.slope(1.0) - 1.5).abs() < QUADRATURE_TOL);
        // A grows with eta, the slope falls.
        assert!(ExitLobe::P1.slope(1.5) < ExitLobe::P1.slope(1.3));
    }

    #[test]
    fn names_round_trip_and_bad_ones_are_named() {
        for name in ExitLobe::NAMES {
            assert_eq!(name.parse::<ExitLobe>().expect("a name").name(), name);
        }
        let e = "cosine".parse::<ExitLobe>().expect_err("unknown");
        assert!(e.to_string().contains("cosine"));
    }
}
