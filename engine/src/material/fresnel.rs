//! Fresnel terms of a smooth dielectric boundary (DESIGN section 2).
//!
//! `eta = n_inside / n_outside`. All angles are measured outside the object (the side of the light
//! or the viewer); transmittance is the same for the reciprocal direction, so one function serves
//! both the incoming light (q) and the outgoing radiance (L_o).
//!
//! ```
//! use translucent::material::fresnel;
//! let f_dr = fresnel::diffuse_reflectance(1.3);
//! assert!((f_dr - 0.4448).abs() < 1e-4);
//! assert!((fresnel::transmittance(1.0, 0.3) - 1.0).abs() < 1e-12); // index-matched: no reflection
//! ```

/// The range of eta over which the F_dr fits below stay physical (0 <= F_dr < 1, A > 0); outside it
/// they extrapolate to nonsense (F_dr < 0 or > 1, a negative boundary constant A), so materials
/// refuse such an eta.
pub const ETA_RANGE: (f64, f64) = (0.3, 3.5);

/// Internal diffuse Fresnel reflectance F_dr(eta): for eta >= 1 the polynomial fit of DESIGN
/// section 2 (Jensen et al. 2001; 0.4448 at eta = 1.3); for eta < 1, where that polynomial goes
/// negative, the companion fit of Egan and Hilgeman (1979) that Jensen et al. also quote.
/// Valid over [`ETA_RANGE`].
pub fn diffuse_reflectance(eta: f64) -> f64 {
    if eta >= 1.0 {
        -1.440 / (eta * eta) + 0.710 / eta + 0.668 + 0.0636 * eta
    } else {
        -0.4399 + 0.7099 / eta - 0.3319 / (eta * eta) + 0.0636 / (eta * eta * eta)
    }
}

/// The boundary constant A = (1 + F_dr) / (1 - F_dr) of the Robin condition (paper Eq. 2).
pub fn boundary_a(eta: f64) -> f64 {
    let f = diffuse_reflectance(eta);
    (1.0 + f) / (1.0 - f)
}

/// External diffuse reflectance by reciprocity: F_dr,ext = 1 - eta^2 (1 - F_dr) (about 0.06 at 1.3).
pub fn external_diffuse_reflectance(eta: f64) -> f64 {
    1.0 - eta * eta * (1.0 - diffuse_reflectance(eta))
}

/// Fresnel reflectance of an unpolarized ray arriving from outside at `cos_outside` (cosine to the
/// normal, clamped to [0, 1]). Total internal reflection (possible when eta < 1) gives 1.
pub fn reflectance(eta: f64, cos_outside: f64) -> f64 {
    let cos_i = cos_outside.clamp(0.0, 1.0);
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r = 0.5 * (rs * rs + rp * rp);
    // Grazing incidence with eta = 1 gives 0/0 above; an index-matched boundary reflects nothing.
    if r.is_finite() {
        r.clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// Fresnel transmittance F_t(eta, theta) = 1 - reflectance.
pub fn transmittance(eta: f64, cos_outside: f64) -> f64 {
    1.0 - reflectance(eta, cos_outside)
}

/// Fresnel moment C_k(eta) = int_0^1 F_r mu^k dmu of the reflectance *seen from inside* a medium
/// of relative index `eta` (light inside arriving at the boundary at cosine mu to the normal;
/// total internal reflection where eta > 1 and mu is below the critical cosine). DESIGN section
/// 2.5: C1 and C2 set the boundary constant A = (1 + 3 C2) / (1 - 2 C1) and the exit query of
/// section 2.6; 2 C1 is the internal diffuse reflectance (the F_dr polynomial fits it). Called with
/// `1/eta` it gives the moments of the reflectance seen from outside. Computed by quadrature of the
/// exact unpolarized Fresnel formula (pbrt-v3's `FresnelMoment1/2` are polynomial fits of these).
pub fn moment(eta: f64, k: i32) -> f64 {
    // Inside, the relative index of the far side is 1/eta; above the critical cosine the
    // reflectance is smooth except for a square-root kink at the critical cosine itself, which the
    // substitution mu = mu_c + (1 - mu_c) u^2 removes.
    let rel = 1.0 / eta;
    let mu_c = if rel < 1.0 {
        (1.0 - rel * rel).sqrt()
    } else {
        0.0
    };
    // int_0^mu_c mu^k dmu with F_r = 1 (total internal reflection).
    let tir = mu_c.powi(k + 1) / f64::from(k + 1);
    const STEPS: usize = 256;
    let mut sum = 0.0;
    for i in 0..STEPS {
        // Gauss-Legendre 2 points per interval: exact enough (1e-12) for this smooth integrand.
        for g in [-1.0 / 3f64.sqrt(), 1.0 / 3f64.sqrt()] {
            let u = (i as f64 + 0.5 + 0.5 * g) / STEPS as f64;
            let mu = mu_c + (1.0 - mu_c) * u * u;
            let jacobian = 2.0 * (1.0 - mu_c) * u;
            sum += 0.5 / STEPS as f64 * reflectance(rel, mu) * mu.powi(k) * jacobian;
        }
    }
    tir + sum
}

/// The first Fresnel moment C1(eta) (see [`moment`]).
pub fn moment1(eta: f64) -> f64 {
    moment(eta, 1)
}

/// The second Fresnel moment C2(eta) (see [`moment`]).
pub fn moment2(eta: f64) -> f64 {
    moment(eta, 2)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_incidence_matches_closed_form() {
        for eta in [0.7f64, 1.0, 1.3, 1.5, 2.4] {
            let r0 = ((eta - 1.0) / (eta + 1.0)).powi(2);
            assert!((reflectance(eta, 1.0) - r0).abs() < 1e-14, "eta {eta}");
        }
    }

    #[test]
    fn grazing_and_total_internal_reflection() {
        assert!((reflectance(1.3, 0.0) - 1.0).abs() < 1e-12);
        // eta = 0.5: critical angle 30 degrees from the normal; beyond it everything reflects.
        let beyond = (60f64).to_radians().cos();
        assert_eq!(reflectance(0.5, beyond), 1.0);
        assert!(reflectance(0.5, 1.0) < 1.0);
        for i in 0..=100 {
            let c = i as f64 / 100.0;
            for eta in [0.5, 1.0, 1.3] {
                let t = transmittance(eta, c);
                assert!(
                    (0.0..=1.0).contains(&t) && t.is_finite(),
                    "eta {eta} cos {c}: {t}"
                );
            }
        }
    }

    /// The polynomial F_dr approximates the cosine-weighted hemispherical average of the Fresnel
    /// reflectance seen from inside; for eta > 1 inside-to-outside that is
    /// 1 - (1/eta^2) * 2 * integral of F_t(eta, mu) mu dmu (reciprocity); check within the fit's error.
    #[test]
    fn diffuse_reflectance_agrees_with_the_integral() {
        let eta = 1.3;
        let n = 20000;
        let mut t = 0.0;
        for i in 0..n {
            let mu = (i as f64 + 0.5) / n as f64;
            t += transmittance(eta, mu) * mu / n as f64;
        }
        let f_dr_integral = 1.0 - 2.0 * t / (eta * eta);
        assert!(
            (diffuse_reflectance(eta) - f_dr_integral).abs() < 0.01,
            "{f_dr_integral}"
        );
        assert!((diffuse_reflectance(1.3) - 0.4448).abs() < 1e-4);
        // Both fits meet at eta = 1 and stay physical over the accepted range.
        assert!((diffuse_reflectance(1.0) - diffuse_reflectance(1.0 - 1e-12)).abs() < 1e-3);
        let (lo, hi) = ETA_RANGE;
        for i in 0..=1000 {
            let eta = lo + (hi - lo) * i as f64 / 1000.0;
            let f = diffuse_reflectance(eta);
            assert!(
                (0.0..1.0).contains(&f) && boundary_a(eta) >= 1.0,
                "eta {eta}: F_dr {f}"
            );
        }
        // eta < 1 fit against the integral too.
        let eta = 0.8;
        let mut t = 0.0;
        for i in 0..n {
            let mu = (i as f64 + 0.5) / n as f64;
            t += transmittance(eta, mu) * mu / n as f64;
        }
        let integral = 1.0 - 2.0 * t / (eta * eta);
        assert!(
            (diffuse_reflectance(eta) - integral).abs() < 0.02,
            "{} vs {integral}",
            diffuse_reflectance(eta)
        );
        assert!(
            (external_diffuse_reflectance(1.3) - (1.0 - 1.69 * (1.0 - 0.444_762_840))).abs() < 1e-8
        );
    }

    /// The moments against pbrt-v3's polynomial fits (accurate to ~1e-3 there), their eta = 1
    /// value (no reflection) and reciprocity: 1 - 2 C1(eta) = (1 - 2 C1(1/eta)) / eta^2 (what
    /// leaves through the boundary from inside equals, per unit radiance, what enters from outside,
    /// divided by eta^2).
    #[test]
    fn moments_match_pbrt_fits_and_reciprocity() {
        let pbrt_c1 = |e: f64| {
            -4.61686 + 11.1136 * e - 10.4646 * e * e + 5.11455 * e.powi(3) - 1.27198 * e.powi(4)
                + 0.12746 * e.powi(5)
        };
        let pbrt_c2 = |e: f64| {
            let r = 1.0 / e;
            -547.033 + 45.3087 * r.powi(3) - 218.725 * r * r + 458.843 * r + 404.557 * e
                - 189.519 * e * e
                + 54.9327 * e.powi(3)
                - 9.00603 * e.powi(4)
                + 0.63942 * e.powi(5)
        };
        for eta in [1.2, 1.3, 1.4, 1.5] {
            assert!(
                (moment1(eta) - pbrt_c1(eta)).abs() < 3e-3,
                "C1({eta}) {}",
                moment1(eta)
            );
            assert!(
                (moment2(eta) - pbrt_c2(eta)).abs() < 3e-3,
                "C2({eta}) {}",
                moment2(eta)
            );
        }
        assert!(moment1(1.0).abs() < 1e-12 && moment2(1.0).abs() < 1e-12);
        for eta in [0.7, 1.0, 1.3, 1.5, 2.4] {
            let lhs = 1.0 - 2.0 * moment1(eta);
            let rhs = (1.0 - 2.0 * moment1(1.0 / eta)) / (eta * eta);
            assert!((lhs - rhs).abs() < 1e-9, "eta {eta}: {lhs} vs {rhs}");
            // The polynomial F_dr fits 2 C1 within its stated accuracy.
            assert!(
                (diffuse_reflectance(eta) - 2.0 * moment1(eta)).abs() < 0.02,
                "eta {eta}"
            );
        }
    }
}
