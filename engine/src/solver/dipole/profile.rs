//! The dipole diffuse reflectance R_d (Jensen et al. 2001; the paper's section 2.2, Table 1) with
//! the boundary constants of DESIGN section 2 and 2.6.
//!
//! A unit of power entering a homogeneous half-space at x_i is replaced by a real point source at
//! depth z_r = 1/sigma_t' and a negative virtual source at height z_v = z_r + 4 A D above the
//! surface. The fluence they make is (DESIGN 2: D = 1/(3 sigma_t'), sigma_tr = sqrt(3 sigma_a sigma_t'))
//!
//! ```text
//! phi(x) = alpha' / (4 pi D) [exp(-sigma_tr s_r) / s_r - exp(-sigma_tr s_v) / s_v]
//! ```
//!
//! and what leaves the surface at distance r (s_r = sqrt(r^2 + z_r^2), s_v = sqrt(r^2 + z_v^2)) is
//! one of two exit queries ([`BoundaryModel`]):
//! - [`BoundaryModel::Jensen`] (the paper): the flux term alone, R_d = D dphi/dz_in
//!   = alpha'/(4 pi) [z_r (1 + sigma_tr s_r) e^(-sigma_tr s_r)/s_r^3 + z_v (1 + sigma_tr s_v) e^(-sigma_tr s_v)/s_v^3],
//!   with A = (1 + F_dr)/(1 - F_dr) (DESIGN 2).
//! - [`BoundaryModel::Moments`] (DESIGN 2.6, pbrt's `BeamDiffusionMS` with the classical D): A =
//!   (1 + 3 C2)/(1 - 2 C1) and R_d = (1 - 2 C1)/4 phi + (1 - 3 C2)/2 D dphi/dz_in.
//!
//! Both are radiant exitance into air per unit of power transmitted into the object (W/mm^2 per W):
//! the method's output M = sum E T_i R_d dA is what the shading turns into radiance.
//!
//! R_d is evaluated by distance only (the positions of the two sources relative to the *receiver's*
//! tangent plane, as in Jensen and Buhler 2002): on a curved or folded surface the paper's form
//! x_r = x_i - z_r N_i can put a source on the plane of another triangle, where the point-to-triangle
//! integral diverges; the distance form is finite everywhere and exact for the plane.
//!
//! ```
//! use translucent::material::Material;
//! use translucent::solver::dipole::{BoundaryModel, DipoleProfile};
//! let marble = Material::preset("marble")?;
//! let dipole = DipoleProfile::new(&marble, BoundaryModel::Jensen);
//! // Total diffuse reflectance (the integral of R_d over the plane) against its closed form.
//! let total = dipole.total_reflectance();
//! assert!(total[0] > 0.8 && total[0] < 0.95, "{total:?}");
//! assert!(dipole.r_d(0, 1.0) > dipole.r_d(0, 2.0));
//! # Ok::<(), translucent::material::MaterialError>(())
//! ```

use std::f64::consts::PI;

use crate::material::{fresnel, Material};

/// Which boundary constant and exit query the dipole uses (module doc).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum BoundaryModel {
    /// Jensen et al. 2001 as printed in the paper: A from F_dr, flux term only.
    Jensen,
    /// DESIGN 2.6: A from the Fresnel moments, exitance from fluence and flux.
    #[default]
    Moments,
}

impl BoundaryModel {
    /// The name used in reports and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            BoundaryModel::Jensen => "jensen",
            BoundaryModel::Moments => "moments",
        }
    }
}

/// The Fresnel moments C1 = int_0^1 F_r mu dmu and C2 = int_0^1 F_r mu^2 dmu of light arriving at
/// the boundary from inside (DESIGN 2.6 conventions: F_dr = 2 C1), integrated numerically from the
/// exact Fresnel reflectance ([`fresnel::reflectance`]), not from a polynomial fit.
///
/// Inside angles beyond the critical angle are totally reflected (eta > 1); the rest maps to the
/// outside cosine c by eta^2 mu dmu = c dc (Snell), where the integrand is smooth, so Simpson's rule
/// on c converges fast.
pub fn fresnel_moments(eta: f64) -> (f64, f64) {
    let eta2 = eta * eta;
    // Cosine (inside) of the critical angle; 0 when eta <= 1 (no total internal reflection).
    let mu_c = if eta > 1.0 {
        (1.0 - 1.0 / eta2).sqrt()
    } else {
        0.0
    };
    // Outside cosine reached by the inside grazing ray (eta < 1: light leaves within a cone).
    let c_min = (1.0 - eta2).max(0.0).sqrt();
    let (mut c1, mut c2) = (mu_c * mu_c / 2.0, mu_c * mu_c * mu_c / 3.0);
    // why 2048: Simpson on a smooth integrand; 1e-12 against 4096 intervals.
    const INTERVALS: usize = 2048;
    let h = (1.0 - c_min) / INTERVALS as f64;
    let (mut s1, mut s2) = (0.0, 0.0);
    for i in 0..=INTERVALS {
        let c = c_min + h * i as f64;
        let weight = if i == 0 || i == INTERVALS {
            1.0
        } else if i % 2 == 1 {
            4.0
        } else {
            2.0
        };
        let f = fresnel::reflectance(eta, c);
        let mu = (1.0 - (1.0 - c * c) / eta2).max(0.0).sqrt();
        s1 += weight * f * c;
        s2 += weight * f * c * mu;
    }
    c1 += s1 * h / 3.0 / eta2;
    c2 += s2 * h / 3.0 / eta2;
    (c1, c2)
}

/// The dipole of one colour channel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChannelDipole {
    /// Effective transport coefficient sigma_tr = sqrt(3 sigma_a sigma_t'), 1/mm.
    pub sigma_tr: f64,
    /// Reduced extinction sigma_t', 1/mm.
    pub sigma_t: f64,
    /// Depth of the real source z_r = 1/sigma_t', mm.
    pub z_r: f64,
    /// Height of the virtual source z_v = z_r + 4 A D, mm.
    pub z_v: f64,
    /// Reduced albedo alpha' = sigma_s'/sigma_t'.
    pub albedo: f64,
    /// Diffusion coefficient D = 1/(3 sigma_t'), mm.
    pub d: f64,
    /// Weight of the flux term D dphi/dz_in in the exitance.
    pub c_flux: f64,
    /// Weight of the fluence term phi in the exitance.
    pub c_phi: f64,
}

impl ChannelDipole {
    /// Exitance weight of the flux term of one source (the paper's Eq. 8 integrand factor):
    /// alpha'/(4 pi) c_flux.
    pub fn flux_scale(&self) -> f64 {
        self.albedo / (4.0 * PI) * self.c_flux
    }

    /// Exitance weight of the fluence term of one source: alpha'/(4 pi D) c_phi.
    pub fn phi_scale(&self) -> f64 {
        self.albedo / (4.0 * PI * self.d) * self.c_phi
    }

    /// R_d at planar distance `r` (mm) between entry and exit points (mm^-2).
    pub fn r_d(&self, r: f64) -> f64 {
        let r2 = r * r;
        let s_r = (r2 + self.z_r * self.z_r).sqrt();
        let s_v = (r2 + self.z_v * self.z_v).sqrt();
        let (e_r, e_v) = ((-self.sigma_tr * s_r).exp(), (-self.sigma_tr * s_v).exp());
        let flux = self.z_r * (1.0 + self.sigma_tr * s_r) * e_r / (s_r * s_r * s_r)
            + self.z_v * (1.0 + self.sigma_tr * s_v) * e_v / (s_v * s_v * s_v);
        let phi = e_r / s_r - e_v / s_v;
        self.flux_scale() * flux + self.phi_scale() * phi
    }

    /// The derivative dR_d/dr at planar distance `r` (mm^-3): each source term's d/ds times ds/dr =
    /// r/s; flux: d/ds[z (1 + sigma s) e^(-sigma s)/s^3] = -z e^(-sigma s)(sigma^2/s^2 + 3(1 + sigma s)/s^4),
    /// fluence: d/ds[e^(-sigma s)/s] = -e^(-sigma s)(1 + sigma s)/s^2.
    pub fn r_d_slope(&self, r: f64) -> f64 {
        let k = self.sigma_tr;
        let term = |z: f64, sign: f64| {
            let s = (r * r + z * z).sqrt();
            let e = (-k * s).exp();
            let (s2, s4) = (s * s, s * s * s * s);
            let flux = -z * e * (k * k / s2 + 3.0 * (1.0 + k * s) / s4);
            let phi = -e * (1.0 + k * s) / s2;
            (r / s) * (self.flux_scale() * flux + sign * self.phi_scale() * phi)
        };
        term(self.z_r, 1.0) + term(self.z_v, -1.0)
    }

    /// R_d, dR_d/dr divided by r, and d^2R_d/dr^2 at planar distance `r` (finite at r = 0): what the
    /// second-order point sample needs (the Hessian of R_d(|x - x_o|) is
    /// R_d'' u u^T + (R_d'/r)(I - u u^T), u the unit direction).
    pub fn r_d_derivatives(&self, r: f64) -> (f64, f64, f64) {
        let k = self.sigma_tr;
        let (mut value, mut slope_over_r, mut curvature) = (0.0, 0.0, 0.0);
        for (z, sign) in [(self.z_r, 1.0), (self.z_v, -1.0)] {
            let s = (r * r + z * z).sqrt();
            let e = (-k * s).exp();
            let (s2, s3, s4, s5) = (s * s, s * s * s, s * s * s * s, s * s * s * s * s);
            let (fs, ps) = (self.flux_scale(), sign * self.phi_scale());
            // f(s), f'(s), f''(s) of the flux and fluence terms of this source.
            let f = fs * z * (1.0 + k * s) * e / s3 + ps * e / s;
            let d1 =
                -fs * z * e * (k * k / s2 + 3.0 * (1.0 + k * s) / s4) - ps * e * (1.0 + k * s) / s2;
            let d2 = fs * z * e * (k * k * k / s2 + 5.0 * k * k / s3 + 12.0 * k / s4 + 12.0 / s5)
                + ps * e * (k * k / s + 2.0 * k / s2 + 2.0 / s3);
            // d/dr = (r/s) d/ds: R' = (r/s) f', R'' = f'/s + r^2 (f'' s - f') / s^3.
            value += f;
            slope_over_r += d1 / s;
            curvature += d1 / s + r * r * (d2 * s - d1) / s3;
        }
        (value, slope_over_r, curvature)
    }

    /// The integral of R_d over the whole plane, in closed form: the flux term of one source
    /// integrates to 2 pi e^(-sigma_tr z), the fluence term to 2 pi e^(-sigma_tr z)/sigma_tr
    /// (real minus virtual: 2 pi (z_v - z_r) as sigma_tr -> 0). For the Jensen model this is
    /// (alpha'/2)(1 + e^(-4/3 A sqrt(3(1 - alpha')))) e^(-sqrt(3(1 - alpha'))) (Jensen 2001, Eq. 15's total).
    pub fn total_reflectance(&self) -> f64 {
        let (e_r, e_v) = (
            (-self.sigma_tr * self.z_r).exp(),
            (-self.sigma_tr * self.z_v).exp(),
        );
        let flux = 2.0 * PI * (e_r + e_v);
        let phi = 2.0 * PI * exp_difference_over(self.sigma_tr, self.z_r, self.z_v);
        self.flux_scale() * flux + self.phi_scale() * phi
    }
}

/// (e^(-k a) - e^(-k b)) / k, finite as k -> 0 (then b - a).
pub(crate) fn exp_difference_over(k: f64, a: f64, b: f64) -> f64 {
    if k * b.max(a) < 1e-8 {
        return b - a;
    }
    ((-k * a).exp() - (-k * b).exp()) / k
}

/// The dipole of a homogeneous material, per RGB channel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DipoleProfile {
    pub channels: [ChannelDipole; 3],
    pub model: BoundaryModel,
    /// Relative index of refraction n_inside / n_outside.
    pub eta: f64,
    /// The boundary constant A of `model`.
    pub a: f64,
}

impl DipoleProfile {
    /// The dipole of `material` (already validated: sigma_t' > 0, eta in range).
    pub fn new(material: &Material, model: BoundaryModel) -> DipoleProfile {
        let eta = material.eta;
        let (c1, c2) = fresnel_moments(eta);
        let (a, c_flux, c_phi) = match model {
            BoundaryModel::Jensen => (fresnel::boundary_a(eta), 1.0, 0.0),
            BoundaryModel::Moments => (
                (1.0 + 3.0 * c2) / (1.0 - 2.0 * c1),
                0.5 * (1.0 - 3.0 * c2),
                0.25 * (1.0 - 2.0 * c1),
            ),
        };
        let channels = std::array::from_fn(|c| {
            let sigma_t = material.sigma_a[c] + material.sigma_s[c];
            let d = 1.0 / (3.0 * sigma_t);
            let z_r = 1.0 / sigma_t;
            ChannelDipole {
                sigma_tr: (3.0 * material.sigma_a[c] * sigma_t).sqrt(),
                sigma_t,
                z_r,
                z_v: z_r + 4.0 * a * d,
                albedo: material.sigma_s[c] / sigma_t,
                d,
                c_flux,
                c_phi,
            }
        });
        DipoleProfile {
            channels,
            model,
            eta,
            a,
        }
    }

    /// R_d of channel `c` at distance `r` mm.
    pub fn r_d(&self, c: usize, r: f64) -> f64 {
        self.channels[c].r_d(r)
    }

    /// R_d of all channels at distance `r` mm.
    pub fn r_d_rgb(&self, r: f64) -> [f64; 3] {
        std::array::from_fn(|c| self.channels[c].r_d(r))
    }

    /// d ln R_d / dr per channel at distance `r` mm (0 where R_d vanishes).
    pub fn log_slope_rgb(&self, r: f64) -> [f64; 3] {
        std::array::from_fn(|c| {
            let ch = &self.channels[c];
            let v = ch.r_d(r);
            if v > 0.0 {
                ch.r_d_slope(r) / v
            } else {
                0.0
            }
        })
    }

    /// Total diffuse reflectance per channel (closed form, [`ChannelDipole::total_reflectance`]).
    pub fn total_reflectance(&self) -> [f64; 3] {
        std::array::from_fn(|c| self.channels[c].total_reflectance())
    }

    /// The largest sigma_tr over the channels (the steepest falloff), 1/mm.
    pub fn max_sigma_tr(&self) -> f64 {
        self.channels.iter().map(|c| c.sigma_tr).fold(0.0, f64::max)
    }

    /// The smallest real-source depth z_r over the channels, mm.
    pub fn min_z_r(&self) -> f64 {
        self.channels
            .iter()
            .map(|c| c.z_r)
            .fold(f64::INFINITY, f64::min)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// pbrt-v3's polynomial fits of the same moments (FresnelMoment1/2), eta >= 1 branch.
    fn pbrt_moments(e: f64) -> (f64, f64) {
        let (e2, e3, e4, e5) = (e * e, e * e * e, e.powi(4), e.powi(5));
        let c1 = -4.61686 + 11.1136 * e - 10.4646 * e2 + 5.11455 * e3 - 1.27198 * e4 + 0.12746 * e5;
        let r = 1.0 / e;
        let c2 = -547.033 + 45.3087 * r * r * r - 218.725 * r * r + 458.843 * r + 404.557 * e
            - 189.519 * e2
            + 54.9327 * e3
            - 9.00603 * e4
            + 0.63942 * e5;
        (c1, c2)
    }

    #[test]
    fn fresnel_moments_match_the_fits_and_f_dr() {
        // why 2e-3: the polynomial fits' own error (pbrt and DESIGN's F_dr), not ours.
        const FIT: f64 = 2e-3;
        for eta in [1.1, 1.3, 1.5, 2.0] {
            let (c1, c2) = fresnel_moments(eta);
            let (p1, p2) = pbrt_moments(eta);
            assert!((c1 - p1).abs() < FIT, "eta {eta}: C1 {c1} vs pbrt {p1}");
            assert!((c2 - p2).abs() < FIT, "eta {eta}: C2 {c2} vs pbrt {p2}");
            let f_dr = fresnel::diffuse_reflectance(eta);
            assert!(
                (2.0 * c1 - f_dr).abs() < 3.0 * FIT,
                "eta {eta}: {c1} {f_dr}"
            );
        }
        // Index-matched: nothing reflects.
        let (c1, c2) = fresnel_moments(1.0);
        assert!(c1.abs() < 1e-12 && c2.abs() < 1e-12, "{c1} {c2}");
        // eta < 1: no total internal reflection from inside, small moments, still finite.
        let (c1, c2) = fresnel_moments(0.8);
        assert!(c1 > 0.0 && c1 < 0.1 && c2 > 0.0 && c2 < c1, "{c1} {c2}");
    }

    /// The closed-form total against a numerical integral of R_d over the plane, both models.
    #[test]
    fn total_reflectance_is_the_plane_integral_of_r_d() {
        for model in [BoundaryModel::Jensen, BoundaryModel::Moments] {
            for name in ["marble", "skin1", "ketchup", "spectralon"] {
                let m = Material::preset(name).unwrap();
                let p = DipoleProfile::new(&m, model);
                for c in 0..3 {
                    let ch = &p.channels[c];
                    // int_0^inf R_d(r) 2 pi r dr with r = z_r sinh(u) (dense near 0, long tail).
                    let n = 200_000;
                    let u_max = (4000.0 / ch.z_r).asinh();
                    let du = u_max / n as f64;
                    let mut sum = 0.0;
                    for i in 0..n {
                        let u = (i as f64 + 0.5) * du;
                        let r = ch.z_r * u.sinh();
                        sum += ch.r_d(r) * 2.0 * PI * r * ch.z_r * u.cosh() * du;
                    }
                    let total = ch.total_reflectance();
                    // why 1e-4: midpoint rule error at this density (the tail beyond 4000 mm of a
                    // sigma_a = 0 material is ~1e-4 of the total for spectralon's flux term).
                    assert!(
                        ((sum - total) / total).abs() < 1e-4,
                        "{name} {model:?} channel {c}: {sum} vs {total}"
                    );
                    if model == BoundaryModel::Jensen {
                        let s = (3.0 * (1.0 - ch.albedo)).sqrt();
                        let jensen =
                            0.5 * ch.albedo * (1.0 + (-4.0 / 3.0 * p.a * s).exp()) * (-s).exp();
                        assert!((jensen - total).abs() < 1e-12 * total, "{jensen} {total}");
                    }
                }
            }
        }
    }

    #[test]
    fn the_slope_is_the_derivative_of_r_d() {
        for model in [BoundaryModel::Jensen, BoundaryModel::Moments] {
            let p = DipoleProfile::new(&Material::preset("skin1").unwrap(), model);
            for ch in &p.channels {
                // R_d is even in r: its slope at 0 is exactly 0.
                assert_eq!(ch.r_d_slope(0.0), 0.0, "{model:?}");
                for r in [0.05f64, 0.3, 1.0, 4.0, 20.0] {
                    let h = 1e-5 * r.min(1.0);
                    let numeric = (ch.r_d(r + h) - ch.r_d(r - h)) / (2.0 * h);
                    let slope = ch.r_d_slope(r);
                    // why 1e-6: the central difference's own h^2 error, relative to the largest slope.
                    assert!(
                        (numeric - slope).abs()
                            <= 1e-6 * ch.r_d_slope(0.5 * ch.z_r).abs().max(slope.abs()),
                        "{model:?} r {r}: {numeric} vs {slope}"
                    );
                }
            }
        }
    }

    #[test]
    fn derivatives_match_finite_differences() {
        let p = DipoleProfile::new(
            &Material::preset("ketchup").unwrap(),
            BoundaryModel::Moments,
        );
        for ch in &p.channels {
            for r in [0.0, 0.1, 0.7, 3.0, 12.0] {
                let (v, slope_over_r, curvature) = ch.r_d_derivatives(r);
                assert!((v - ch.r_d(r)).abs() <= 1e-14 * v);
                let h = 1e-4 * (ch.z_r + r);
                let second = (ch.r_d(r + h) - 2.0 * ch.r_d(r) + ch.r_d((r - h).abs())) / (h * h);
                // why 1e-5: the second difference's round-off (eps / h^2 relative) and h^2 error.
                assert!(
                    (second - curvature).abs() <= 1e-5 * curvature.abs().max(v / (ch.z_r * ch.z_r)),
                    "r {r}: {second} vs {curvature}"
                );
                if r > 0.0 {
                    assert!(
                        (slope_over_r * r - ch.r_d_slope(r)).abs() <= 1e-12 * ch.r_d_slope(r).abs()
                    );
                } else {
                    // At 0 both are R_d''(0) (R_d is even in r).
                    assert!((slope_over_r - curvature).abs() <= 1e-12 * curvature.abs());
                }
            }
        }
    }

    #[test]
    fn the_models_differ_only_through_the_boundary() {
        let m = Material::preset("skimmilk").unwrap();
        let j = DipoleProfile::new(&m, BoundaryModel::Jensen);
        let k = DipoleProfile::new(&m, BoundaryModel::Moments);
        assert_eq!(j.channels[0].z_r, k.channels[0].z_r);
        assert!(
            k.a > 1.0 && j.a > 1.0 && (k.a - j.a).abs() > 0.05,
            "{} {}",
            k.a,
            j.a
        );
        // eta = 1: no reflection, A = 1 in both, and the moments model's exitance is phi/4 + D dphi/dz / 2.
        let m1 = Material::new(m.sigma_s, m.sigma_a, 1.0).unwrap();
        let (j1, k1) = (
            DipoleProfile::new(&m1, BoundaryModel::Jensen),
            DipoleProfile::new(&m1, BoundaryModel::Moments),
        );
        assert!((j1.a - 1.0).abs() < 0.01 && (k1.a - 1.0).abs() < 1e-9);
        assert!((k1.channels[0].c_phi - 0.25).abs() < 1e-12);
    }
}
