//! R and T of the bounce ([`super`]): how the light re-entering the object at a display vertex
//! leaves again, in the model's own terms (boundary, exit query and Fresnel transmission in and
//! out): the half-space's total diffuse reflectance R_d, and a slab's R and T where the vertex's
//! inward normal leaves the object within a wall ([`WallCrossing`]).
//!
//! ```
//! use translucent::frame::bounce::{diffuse_reflectance, slab_reflectance_transmittance};
//! use translucent::material::DiffusionCoefficient;
//! use translucent::solver::transport::{Boundary, ExitQuery, Optics};
//! let b = Boundary::new(1.0, ExitQuery::Moments);
//! let marble_red = Optics { sigma_s: 2.19, sigma_a: 0.0021, diffusion: DiffusionCoefficient::Grosjean };
//! let (r, t) = slab_reflectance_transmittance(&b, marble_red, 2.0);
//! assert!(r < diffuse_reflectance(&b, marble_red) && t > 0.2);
//! ```

use glam::DVec3;
use rayon::prelude::*;

use crate::material::MaterialField;
use crate::quadgraph::WallCrossing;
use crate::solver::transport::{Boundary, ExitQuery, Optics};

/// Total diffuse reflectance of a half-space of `optics` for diffuse incidence, in the model's
/// own terms: the transmitted flux q = T_d E (T_d = [`Boundary::diffuse_transmittance`]) drives
/// the Robin row (rhs = flux gain q), phi = rhs exp(-s z) / (1 + h s), and the exit query gives
/// the exitance M ([`Boundary::half_space_exitance`]); R_d = M / E. Clamped to [0, 1].
pub fn diffuse_reflectance(boundary: &Boundary, optics: Optics) -> f64 {
    let q = boundary.diffuse_transmittance();
    let m = boundary.half_space_exitance(optics, q, 0.0, 0.0, boundary.flux_gain * q);
    if m.is_finite() {
        m.clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// Diffuse reflectance R and transmittance T of a slab `thickness` mm thick lit diffusely on one
/// face, in the model's own terms: the transmitted flux q = T_d E drives the lit face's Robin row
/// (rhs = flux gain q), the far face's row has no source, the exit query reads both faces. With
/// s = sqrt(sigma_a / D), h = 2 A D and t = tanh(s L) / s (L as s -> 0):
///   phi(0) = rhs / (1 + h (1 + h s^2 t) / (t + h)), dphi/dz_in(0) = -phi(0) (1 + h s^2 t) / (t + h),
///   phi(L) = phi(0) h / (cosh(s L) (t + h)), its inward derivative phi(L) / h.
/// An infinite (or non-finite) thickness is the half-space: ([`diffuse_reflectance`], 0). Both
/// clamped to [0, 1].
pub fn slab_reflectance_transmittance(
    boundary: &Boundary,
    optics: Optics,
    thickness: f64,
) -> (f64, f64) {
    if !thickness.is_finite() {
        return (diffuse_reflectance(boundary, optics), 0.0);
    }
    let l = thickness.max(0.0);
    let (s, h, d) = (optics.s(), boundary.h(optics), optics.d());
    let sl = s * l;
    let t = if sl < 1e-8 { l } else { sl.tanh() / s };
    let slope = (1.0 + h * s * s * t) / (t + h);
    let q = boundary.diffuse_transmittance();
    let phi0 = boundary.flux_gain * q / (1.0 + h * slope);
    let r = boundary.exitance(d, phi0, -phi0 * slope, q);
    // 1 / cosh, zero where cosh overflows (a wall hundreds of diffusion lengths thick).
    let sech = if sl > 700.0 { 0.0 } else { 1.0 / sl.cosh() };
    let phi_l = phi0 * h * sech / (t + h);
    let tr = boundary.exitance(d, phi_l, phi_l / h, 0.0);
    let clean = |x: f64| {
        if x.is_finite() {
            x.clamp(0.0, 1.0)
        } else {
            0.0
        }
    };
    (clean(r), clean(tr))
}

/// What the pass multiplies the gathered irradiance by per display vertex: R on the face where
/// it entered, T on the far face of the wall ([`slab_reflectance_transmittance`] at each
/// vertex's [`WallCrossing`] thickness; the half-space's R_d and T = 0 without one).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct WallOptics {
    pub reflectance: Vec<[f32; 3]>,
    pub transmittance: Vec<[f32; 3]>,
}

impl WallOptics {
    /// The half-space's R per vertex and no transmission.
    pub fn half_space(reflectance: Vec<[f32; 3]>) -> WallOptics {
        let transmittance = vec![[0.0; 3]; reflectance.len()];
        WallOptics {
            reflectance,
            transmittance,
        }
    }
}

/// [`WallOptics`] per display vertex of `positions` for `field` (the coefficients at each
/// vertex), the exit query `exit` and the wall crossings `across` ([`BounceLinks::across`];
/// a vertex without one: the half-space).
pub fn vertex_wall_optics(
    field: &MaterialField,
    exit: ExitQuery,
    positions: &[DVec3],
    across: &[WallCrossing],
) -> WallOptics {
    let boundary = Boundary::new(field.eta(), exit);
    let diffusion = field.diffusion();
    let homogeneous = match field {
        MaterialField::Homogeneous(m) => Some(m.coefficients()),
        _ => None,
    };
    let (reflectance, transmittance) = positions
        .par_iter()
        .enumerate()
        .map(|(v, &p)| {
            let c = homogeneous.unwrap_or_else(|| field.sample(p));
            let thickness = f64::from(across.get(v).unwrap_or(&WallCrossing::NONE).thickness);
            let rt: [(f64, f64); 3] = std::array::from_fn(|ch| {
                slab_reflectance_transmittance(
                    &boundary,
                    Optics::channel_with(&c, ch, diffusion),
                    thickness,
                )
            });
            (rt.map(|x| x.0 as f32), rt.map(|x| x.1 as f32))
        })
        .unzip();
    WallOptics {
        reflectance,
        transmittance,
    }
}

/// R_d per display vertex of `positions` for `field` (the coefficients at each vertex) and the
/// exit query `exit`.
pub fn vertex_reflectance(
    field: &MaterialField,
    exit: ExitQuery,
    positions: &[DVec3],
) -> Vec<[f32; 3]> {
    let boundary = Boundary::new(field.eta(), exit);
    let diffusion = field.diffusion();
    let one = |c: &crate::material::Coefficients| -> [f32; 3] {
        std::array::from_fn(|ch| {
            diffuse_reflectance(&boundary, Optics::channel_with(c, ch, diffusion)) as f32
        })
    };
    match field {
        MaterialField::Homogeneous(m) => vec![one(&m.coefficients()); positions.len()],
        _ => positions.iter().map(|&p| one(&field.sample(p))).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::DiffusionCoefficient;

    /// F_dr's polynomial is 0.0016 (not 0) at eta = 1: the classic boundary keeps that much.
    const NO_ABSORPTION_TOL: f64 = 3e-3;

    /// The half-space's R_d at sigma_a = 0 reflects everything.
    #[test]
    fn reflectance_without_absorption_is_one() {
        for exit in [ExitQuery::Classic, ExitQuery::Moments] {
            let b = Boundary::new(1.0, exit);
            let r = diffuse_reflectance(
                &b,
                Optics {
                    sigma_s: 2.0,
                    sigma_a: 0.0,
                    diffusion: DiffusionCoefficient::Classical,
                },
            );
            assert!((r - 1.0).abs() < NO_ABSORPTION_TOL, "{exit:?}: {r}");
        }
    }

    #[test]
    fn reflectance_falls_with_absorption() {
        let b = Boundary::new(1.3, ExitQuery::Moments);
        let r = |a| {
            diffuse_reflectance(
                &b,
                Optics {
                    sigma_s: 1.0,
                    sigma_a: a,
                    diffusion: DiffusionCoefficient::Classical,
                },
            )
        };
        assert!(r(0.001) > r(0.01) && r(0.01) > r(0.1) && r(0.1) > 0.0);
    }

    /// The slab's T and the closed form of DESIGN section 2 are the same formula in two
    /// algebras (f64 rounding only).
    const SLAB_CLOSED_FORM_TOL: f64 = 1e-9;

    /// With the classic query and D = 1 / (3 sigma_t'), T / T_d (per transmitted flux q) is
    /// [`crate::solver::analytic::Homogeneous::slab_transmittance`], written independently.
    #[test]
    fn slab_transmittance_is_the_closed_form() {
        use crate::material::Material;
        use crate::solver::analytic::Homogeneous;
        for name in ["marble", "skimmilk", "skin1"] {
            let m = Material::preset(name).unwrap();
            for eta in [1.0, 1.3] {
                let b = Boundary::new(eta, ExitQuery::Classic);
                for ch in 0..3 {
                    let o = Optics::channel(&m.coefficients(), ch);
                    let exact = Homogeneous::new(m.sigma_s[ch], m.sigma_a[ch], eta);
                    for l in [0.5, 2.0, 4.0, 10.0, 40.0] {
                        let (_, t) = slab_reflectance_transmittance(&b, o, l);
                        let want = exact.slab_transmittance(l) * b.diffuse_transmittance();
                        assert!(
                            (t - want).abs() <= SLAB_CLOSED_FORM_TOL * want.max(1e-12),
                            "{name} eta {eta} channel {ch} L {l}: {t} against {want}"
                        );
                    }
                }
            }
        }
    }

    /// A thick slab reflects as the half-space and transmits nothing; without absorption
    /// everything that enters leaves by one face or the other; a thinner wall reflects less and
    /// transmits more.
    #[test]
    fn slab_tends_to_the_half_space_and_conserves_without_absorption() {
        for exit in [ExitQuery::Classic, ExitQuery::Moments] {
            let b = Boundary::new(1.0, exit);
            let marble_red = Optics {
                sigma_s: 2.19,
                sigma_a: 0.0021,
                diffusion: DiffusionCoefficient::Grosjean,
            };
            let half = diffuse_reflectance(&b, marble_red);
            let (r, t) = slab_reflectance_transmittance(&b, marble_red, 1e4);
            assert!(
                (r - half).abs() < 1e-12 && t < 1e-12,
                "{exit:?}: {r} {t} {half}"
            );
            assert_eq!(
                slab_reflectance_transmittance(&b, marble_red, f64::INFINITY),
                (half, 0.0)
            );
            let (r2, t2) = slab_reflectance_transmittance(&b, marble_red, 2.0);
            let (r8, t8) = slab_reflectance_transmittance(&b, marble_red, 8.0);
            assert!(r2 < r8 && r8 < half && t2 > t8 && t8 > 0.0, "{exit:?}");
            let clear = Optics {
                sigma_a: 0.0,
                ..marble_red
            };
            for l in [0.1, 2.0, 20.0] {
                let (r, t) = slab_reflectance_transmittance(&b, clear, l);
                assert!(
                    (r + t - b.diffuse_transmittance()).abs() < NO_ABSORPTION_TOL,
                    "{exit:?} L {l}: R {r} + T {t}"
                );
            }
        }
    }
}
