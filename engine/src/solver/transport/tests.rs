use super::*;

/// The second-collision ratio's limits: albedo 1, eta 1, normal incidence: r = 1 - (1 - ln 2)/2
/// is the share of once-scattered light that collides again (1/2 E2 escapes on average).
#[test]
fn second_collision_ratio_limits() {
    let o = Optics {
        sigma_s: 1.0,
        sigma_a: 0.0,
        diffusion: DiffusionCoefficient::Classical,
    };
    let r = second_collision_ratio(o, 1.0, 1.0);
    let exact = 0.5 * (1.0 + std::f64::consts::LN_2);
    assert!((r - exact).abs() < 1e-4, "{r} vs {exact}");
    // Internal reflection keeps light in: more collides again.
    assert!(second_collision_ratio(o, 1.0, 1.5) > r);
    // Grazing beams scatter near the surface: less collides again.
    assert!(second_collision_ratio(o, 0.2, 1.0) < r);
}

/// team/backlit/moments.py's discretized E1 kernel differs from the closed form by this much.
const DEEP_RATIO_TOLERANCE: f64 = 0.005;

#[test]
fn deep_ratio_matches_the_half_space_moments() {
    // Albedo 1, eta 1, z_b = 2/3 mfp: team/backlit/moments.py's r_T column.
    let o = Optics {
        sigma_s: 1.0,
        sigma_a: 0.0,
        diffusion: Default::default(),
    };
    for (mu_t, expected) in [(1.0, 0.999), (0.6, 0.994), (0.2, 0.971), (0.1, 0.949)] {
        let r_t = second_collision_deep_ratio(o, mu_t, 1.0, 2.0 / 3.0);
        assert!(
            (r_t - expected).abs() < DEEP_RATIO_TOLERANCE,
            "mu_t {mu_t}: {r_t}"
        );
        // The deep moment keeps more than the power (the escaping light is shallow).
        assert!(r_t > second_collision_ratio(o, mu_t, 1.0));
    }
    // Normal incidence: 1/beta' = 1.295 mfp (FINDINGS.md).
    let mu_e = second_collision_fit(o, 1.0, 1.0, 2.0 / 3.0).mu_e;
    assert!((mu_e - 1.295).abs() < 0.02, "{mu_e}");
}

/// Transmitted exitance phi(L) / 2 of a slab of thickness `l` (A = 1, eta 1: Robin rows
/// phi -/+ 2 D phi' = 0 on both faces) with the source K exp(-beta z) (its particular solution).
fn slab_transmission(o: Optics, k: f64, beta: f64, l: f64) -> f64 {
    let (d, s) = (o.d(), o.s());
    let h = 2.0 * d;
    // phi = a e^{s z} + b e^{-s z} + K e^{-beta z}.
    let (m00, m01, r0) = (1.0 - h * s, 1.0 + h * s, -k * (1.0 + h * beta));
    let (es, ems, eb) = ((s * l).exp(), (-s * l).exp(), (-beta * l).exp());
    let (m10, m11, r1) = (
        (1.0 + h * s) * es,
        (1.0 - h * s) * ems,
        -k * eb * (1.0 - h * beta),
    );
    let det = m00 * m11 - m01 * m10;
    let a = (r0 * m11 - m01 * r1) / det;
    let b = (m00 * r1 - r0 * m10) / det;
    (a * es + b * ems + k * eb) / 2.0
}

/// The fit's 1D slab transmission within this of the true second-collision density's
/// (team/backlit/slab_diffusion.py measured -4/-3/-2%).
const SLAB_FIT_TOLERANCE: f64 = 0.06;
/// The plain scaling (first collision x r) misses at least this much (measured -15..-17%).
const SLAB_SCALED_DEFICIT: f64 = 0.12;

#[test]
fn fitted_second_collision_crosses_a_thin_slab() {
    // 2 mm marble lit at mu_i 0.9275, eta 1 (FINDINGS.md "Plate"): the true second-collision
    // density's transmitted exitance per unit irradiance, from slab_diffusion.py (E1 kernel).
    let cases = [
        (2.19, 0.0021, 0.2573),
        (2.62, 0.0041, 0.2274),
        (3.0, 0.0071, 0.2013),
    ];
    let r = Refraction::new(1.0, 0.9275);
    for (sigma_s, sigma_a, truth) in cases {
        let o = Optics {
            sigma_s,
            sigma_a,
            diffusion: Default::default(),
        };
        let f = second_collision_fit(o, r.mu_t, 1.0, 2.0 * o.d());
        let (k, beta) = beam_particular(o, Refraction { mu_t: f.mu_e, ..r }, 1.0, f.gain);
        let fit = slab_transmission(o, k, beta, 2.0);
        assert!(
            (fit / truth - 1.0).abs() < SLAB_FIT_TOLERANCE,
            "fit {fit} vs {truth}"
        );
        let (k, beta) = beam_particular(o, r, 1.0, f.ratio);
        let scaled = slab_transmission(o, k, beta, 2.0);
        assert!(
            scaled / truth < 1.0 - SLAB_SCALED_DEFICIT,
            "scaled {scaled} vs {truth}"
        );
    }
}

#[test]
fn particular_solution_solves_the_ode_and_avoids_the_resonance() {
    // Ketchup blue; Grosjean's D (0.446 against 0.225 mm) moves the resonance
    // sigma_a mu_t^2 = D sigma_t'^2 from mu_t = 0.577 to 0.821.
    for (diffusion, resonance) in [
        (DiffusionCoefficient::Classical, 0.577_350_269_189_625_8),
        (
            DiffusionCoefficient::Grosjean,
            (2.93f64 / (3.0 * 1.45)).sqrt(),
        ),
    ] {
        particular_solution_at(diffusion, resonance);
    }
}

fn particular_solution_at(diffusion: DiffusionCoefficient, resonance: f64) {
    let o = Optics {
        sigma_s: 0.03,
        sigma_a: 1.45,
        diffusion,
    };
    for mu_t in [1.0, 0.6, resonance, 0.3] {
        let r = Refraction {
            mu_i: mu_t,
            t_i: 1.0,
            mu_t,
        };
        let (k, beta) = beam_particular(o, r, 1.0, 1.0);
        assert!(k.is_finite() && beta.is_finite());
        // D K beta^2 - sigma_a K = -Q0 (up to the guard's shift).
        let q0 = o.sigma_s / mu_t;
        let residual = o.d() * k * beta * beta - o.sigma_a * k + q0;
        assert!(
            residual.abs() < 1e-3 * q0.max(k.abs() * o.sigma_a),
            "{residual}"
        );
    }
}

#[test]
fn flux_factors_are_the_exit_query_with_the_robin_derivative() {
    for exit in [ExitQuery::Classic, ExitQuery::Moments] {
        for eta in [1.0, 1.3, 1.5] {
            let b = Boundary::new(eta, exit);
            let o = Optics {
                sigma_s: 2.0,
                sigma_a: 0.01,
                diffusion: DiffusionCoefficient::Classical,
            };
            let (phi, q) = (3.0, 0.4);
            let rhs = b.flux_gain * q;
            let dphi = (phi - rhs) / b.h(o);
            let m = b.exitance(o.d(), phi, dphi, q);
            assert!((b.flux_exitance(phi, q) - m).abs() < 1e-12 * m.abs().max(1.0));
            let (f_phi, f_q) = b.flux_shading_factors();
            let x = b.shading_input(m);
            assert!((f_phi * phi - f_q * q - x).abs() < 1e-12 * x.abs().max(1.0));
        }
    }
}

/// P1 at eta 1 (A = 1, C1 = C2 = 0): phi = 2 M, so the tangential term is -(3/2) D grad_t M . w;
/// the two queries agree there. With a boundary (eta 1.3) M per phi drops and the shading
/// input's eta^2 / (1 - 2 C1(1/eta)) makes up for it: 1.50031, checked against phi / X
/// computed directly from the Robin row and the exit query.
#[test]
fn tangential_flux_factor_is_p1() {
    for exit in [ExitQuery::Classic, ExitQuery::Moments] {
        // The F_dr polynomial is 0.0016 at eta 1, not 0: the classic query is 2e-3 off.
        let f = Boundary::new(1.0, exit).tangential_flux_factor();
        assert!((f - 1.5).abs() < 3e-3, "{exit:?}: {f}");
    }
    let b = Boundary::new(1.3, ExitQuery::Moments);
    let f = b.tangential_flux_factor();
    // Direct: phi / X from a source-free half-space's Robin row and the exit query.
    let o = Optics {
        sigma_s: 2.0,
        sigma_a: 0.0,
        diffusion: DiffusionCoefficient::Classical,
    };
    let phi = 1.0;
    let m = b.exitance(o.d(), phi, phi / b.h(o), 0.0);
    let direct = 3.0 * phi / (4.0 * b.shading_input(m) * 1.3);
    assert!(
        (f - direct).abs() < 1e-12 && (f - 1.5).abs() < 0.01,
        "{f} vs {direct}"
    );
}

#[test]
fn diffuse_quadrature_integrates_the_cosine_weight() {
    let q = diffuse_quadrature();
    let total: f64 = q.iter().map(|(_, w)| w).sum();
    assert!((total - 1.0).abs() < 1e-12);
    // E[mu^2] under the cosine weight 2 mu dmu is 1/2; E[mu^4] = 1/3.
    let m2: f64 = q.iter().map(|(mu, w)| w * mu * mu).sum();
    let m4: f64 = q.iter().map(|(mu, w)| w * mu.powi(4)).sum();
    assert!((m2 - 0.5).abs() < 1e-12 && (m4 - 1.0 / 3.0).abs() < 1e-12);
}

#[test]
fn refraction_is_snell() {
    let n = DVec3::Y;
    let d = DVec3::new(0.6, -0.8, 0.0);
    let t = refract_inward(d, n, 1.5);
    let sin_i = 0.6;
    let sin_t = (t - n * t.dot(n)).length();
    assert!((sin_t - sin_i / 1.5).abs() < 1e-12 && t.dot(n) < 0.0);
}

/// The plane keeps the planar beam; on a sphere the upstream beam lights the unlit side within
/// about c of the terminator and nothing beyond, its irradiance factor is mu_up (the first
/// collisions' density per volume at eta 1 does not depend on the slope) and its particular
/// solution's curvature H / sigma_t' (clamped).
#[test]
fn upstream_beam_keeps_the_plane_and_lights_past_the_terminator() {
    for mu in [-0.5, -0.01, 0.0, 0.3, 1.0] {
        let b = upstream_beam(mu, SurfaceCurvature::default(), DVec3::X, 2.6, 1.3);
        assert_eq!(b.mu_up, mu);
        assert_eq!(b.irradiance, f64::max(mu, 0.0));
        assert_eq!(b.curvature, 0.0);
    }
    // Marble red on a 10 mm sphere (c = 0.046), a 2 mm sphere (0.23, clamped to the limit).
    for (radius, sigma_t) in [(10.0_f64, 2.1921_f64), (10.0, 3.0071), (2.0, 2.1921)] {
        let c = (1.0 / (radius * sigma_t)).min(UPSTREAM_SHIFT_LIMIT);
        let sphere = SurfaceCurvature::umbilic(1.0 / radius);
        for eta in [1.0, 1.3] {
            let b = upstream_beam(0.5, sphere, DVec3::X, sigma_t, eta);
            assert!((b.irradiance - b.mu_up).abs() < 1e-15);
            // The particular solution's curvature is geometric: eta does not enter it.
            assert!((b.curvature - c).abs() < 1e-12, "{b:?} vs {c}");
        }
        assert!(upstream_beam(-0.5 * c, sphere, DVec3::X, sigma_t, 1.0).irradiance > 0.0);
        let beyond = upstream_beam(-2.0 * c, sphere, DVec3::X, sigma_t, 1.0);
        assert_eq!((beyond.irradiance, beyond.curvature), (0.0, 0.0));
    }
    // Never NaN, never negative, for any input.
    for h in [f64::NAN, f64::INFINITY, -1e9, 1e9] {
        let k = SurfaceCurvature {
            mean: h,
            anisotropy: DVec3::splat(h),
        };
        let b = upstream_beam(0.5, k, DVec3::X, 2.0, 1.0);
        assert!(b.mu_up.is_finite() && b.irradiance >= 0.0);
        assert!(b.curvature.abs() <= UPSTREAM_SHIFT_LIMIT);
    }
}

/// The curved particular solution K e^(-beta (R - r)) of [`beam_particular_curved`] solves
/// D (phi'' + 2 phi' / r) - sigma_a phi = -Q0 e^(-beta (R - r)) (the radial diffusion equation
/// inside a sphere of radius R) at the surface r = R, to the finite difference's error; the planar
/// K leaves 2 D beta K / R there, about -2 / (R beta) = -2 mu / (R sigma_t') of the source (skim
/// milk red, mu 0.5: -0.14), and a concave surface (R < 0, a cavity) the opposite.
#[test]
fn curved_particular_solution_solves_the_diffusion_below_a_sphere() {
    let o = Optics {
        sigma_s: 0.7,
        sigma_a: 0.0014,
        diffusion: DiffusionCoefficient::Classical,
    };
    let beam = Refraction {
        mu_i: 0.5,
        t_i: 1.0,
        mu_t: 0.5,
    };
    let q0 = o.sigma_s / beam.mu_t;
    for radius in [10.0_f64, 5.0, -10.0] {
        let curvature = 1.0 / (radius.abs() * o.sigma_t());
        let curvature = if radius > 0.0 { curvature } else { -curvature };
        // The residual of the radial equation at the surface, relative to the source Q0; the
        // sphere's centre at distance |R| below (R > 0) or above (R < 0) the surface.
        let residual = |k: f64, beta: f64| {
            let phi = |z: f64| k * (-beta * z).exp();
            let r = |z: f64| radius - z;
            let step = 1e-3;
            let d2 = (phi(step) - 2.0 * phi(0.0) + phi(-step)) / (step * step);
            // d/dr = -d/dz; the Laplacian's first-order term 2 phi_r / r.
            let d1 = -(phi(step) - phi(-step)) / (2.0 * step);
            (o.d() * (d2 + 2.0 * d1 / r(0.0)) - o.sigma_a * phi(0.0) + q0) / q0
        };
        let (k, beta) = beam_particular_curved(o, beam, 1.0, 1.0, curvature);
        let (k_planar, beta_planar) = beam_particular(o, beam, 1.0, 1.0);
        let (curved, planar) = (residual(k, beta), residual(k_planar, beta_planar));
        // Negative: the planar K's source exceeds Q0 under a convex surface.
        let b2 = o.d() * beta_planar * beta_planar;
        let expected = 2.0 * o.d() * beta_planar / (radius * (o.sigma_a - b2));
        assert!(curved.abs() < 1e-4, "R {radius}: curved {curved}");
        assert!(expected.abs() > 0.05 && (expected < 0.0) == (radius > 0.0));
        assert!(
            (planar - expected).abs() < 1e-3 * expected.abs(),
            "R {radius}: planar {planar} vs {expected}"
        );
        assert!(k.is_finite() && beta == beta_planar);
    }
}

/// A cylinder of radius r along y (k1 = 1 / r around it, k2 = 0 along it): a beam whose
/// tangent runs around it turns as on a sphere of radius r, one running along the axis
/// does not turn (mu_up = mu). The curved mode's share ([`SurfaceCurvature::umbilic_share`]) is
/// 0 there: wave 8's area factor (narrowing by the mean curvature 1 / (2 r) in it), no narrowing
/// in K; in full on the sphere; (2/3)^[`UMBILIC_SHARE_POWER`] where k1 = 2 k2, blended linearly.
#[test]
fn upstream_beam_on_a_cylinder_turns_only_around_it() {
    let (r, sigma_t) = (3.0, 2.62);
    let cylinder = SurfaceCurvature {
        mean: 0.5 / r,
        anisotropy: DVec3::X * (0.5 / r).sqrt(),
    };
    assert!((cylinder.along(DVec3::X) - 1.0 / r).abs() < 1e-12);
    assert!(cylinder.along(DVec3::Y).abs() < 1e-12);
    let diagonal = DVec3::new(1.0, 1.0, 0.0).normalize();
    assert!((cylinder.along(diagonal) - 0.5 / r).abs() < 1e-12);
    let (c, mu) = (1.0 / (r * sigma_t), 0.3);
    let around = upstream_beam(mu, cylinder, DVec3::X, sigma_t, 1.0);
    assert!((around.mu_up - (mu + c * (1.0 - mu * mu))).abs() < 1e-12);
    let sphere = upstream_beam(
        mu,
        SurfaceCurvature::umbilic(1.0 / r),
        DVec3::X,
        sigma_t,
        1.0,
    );
    assert_eq!(cylinder.umbilic_share(), 0.0);
    assert_eq!(SurfaceCurvature::umbilic(1.0 / r).umbilic_share(), 1.0);
    assert_eq!(SurfaceCurvature::default().umbilic_share(), 1.0);
    // The sphere's: the whole turn as the irradiance factor, the narrowing c in K.
    assert!((sphere.irradiance - sphere.mu_up).abs() < 1e-12);
    assert!((sphere.curvature - c).abs() < 1e-12);
    // The cylinder's: the area factor, as upstream_beam_with(.., false) (share 0).
    let area = |t: DVec3| upstream_beam_with(mu, cylinder, t, sigma_t, 1.0, false);
    assert_eq!(around, area(DVec3::X));
    let area_factor = mu + c * (1.0 - mu * mu) - 2.0 * 0.5 * c * mu * mu;
    assert!((around.irradiance - area_factor).abs() < 1e-12);
    assert!(around.irradiance < around.mu_up);
    let along = upstream_beam(mu, cylinder, DVec3::Y, sigma_t, 1.0);
    assert_eq!(along, area(DVec3::Y));
    assert_eq!(along.mu_up, mu);
    // k1 = 2 / r, k2 = 1 / r: 1 - 1 / 3 to the power.
    let oblate = SurfaceCurvature {
        mean: 1.5 / r,
        anisotropy: DVec3::X * (0.5 / r).sqrt(),
    };
    let share = (2.0f64 / 3.0).powi(UMBILIC_SHARE_POWER);
    assert!((oblate.umbilic_share() - share).abs() < 1e-12);
    let (full, planar) = (
        upstream_beam(mu, oblate, DVec3::Y, sigma_t, 1.0),
        upstream_beam_with(mu, oblate, DVec3::Y, sigma_t, 1.0, false),
    );
    let want = share * full.mu_up + (1.0 - share) * planar.irradiance;
    assert!((full.irradiance - want).abs() < 1e-12);
    assert!((full.curvature - share * 1.5 / (r * sigma_t)).abs() < 1e-12);
}

/// Wave 8's area factor (`upstream_beam_with(.., false)`, the default): the sphere's lit power is
/// 1/2 (per 2 pi R^2 E) up to c^2 / 2, and the particular solution stays planar.
#[test]
fn upstream_area_factor_keeps_the_sphere_lit_power() {
    for (radius, sigma_t) in [(10.0_f64, 2.1921_f64), (10.0, 3.0071), (2.0, 2.1921)] {
        let c = (1.0 / (radius * sigma_t)).min(UPSTREAM_SHIFT_LIMIT);
        let sphere = SurfaceCurvature::umbilic(1.0 / radius);
        const N: usize = 200_000;
        let beam = |mu: f64| upstream_beam_with(mu, sphere, DVec3::X, sigma_t, 1.0, false);
        let power: f64 = (0..N)
            .map(|i| -1.0 + 2.0 * (i as f64 + 0.5) / N as f64)
            .map(|mu| beam(mu).irradiance * 2.0 / N as f64)
            .sum();
        assert!((power - 0.5).abs() <= c * c, "R {radius}: power {power}");
        assert_eq!(beam(0.5).curvature, 0.0);
        // The curved factor mu_up alone carries 2c/3 more (its narrowing is in K).
        let curved: f64 = (0..N)
            .map(|i| -1.0 + 2.0 * (i as f64 + 0.5) / N as f64)
            .map(|mu| upstream_beam(mu, sphere, DVec3::X, sigma_t, 1.0).irradiance * 2.0 / N as f64)
            .sum();
        assert!(
            (curved - 0.5 - 2.0 * c / 3.0).abs() <= c * c,
            "R {radius}: {curved}"
        );
    }
}

/// [`lateral_correction`] on K(mu) = mu^2 with beta constant (beta' = 0): lat = L[K] / beta =
/// (2 - 6 mu^2) / beta, dK = D g (2 - 6 mu^2) / (sigma_a - D beta^2 (1 + 2 c sigma_t' / beta)),
/// faded in below n.l [`LATERAL_FULL_ABOVE`]; nothing where a neighbour is unlit.
#[test]
fn lateral_correction_matches_its_closed_form() {
    let o = Optics {
        sigma_s: 0.7,
        sigma_a: 0.0014,
        diffusion: DiffusionCoefficient::Classical,
    };
    let (beta, c, g) = (1.5, 0.1, 0.01);
    for mu in [0.6, 0.8, 0.95] {
        let got = lateral_correction(o, mu, c, (g, g), |m| (m * m, beta));
        let m = mu.min(1.0 - LATERAL_STEP);
        let denom = o.sigma_a - o.d() * beta * beta * (1.0 + 2.0 * c * o.sigma_t() / beta);
        let want = o.d() * g * (2.0 - 6.0 * m * m) / denom;
        assert!(
            (got - want).abs() < 1e-6 * want.abs(),
            "mu {mu}: {got} vs {want}"
        );
    }
    let faded = lateral_correction(o, 0.25, c, (g, g), |m| (m * m, beta));
    let full = o.d() * g * (2.0 - 6.0 * 0.0625)
        / (o.sigma_a - o.d() * beta * beta * (1.0 + 2.0 * c * o.sigma_t() / beta));
    assert!((faded - 0.5 * full).abs() < 1e-6 * full.abs());
    assert_eq!(
        lateral_correction(o, 0.0, c, (g, g), |m| (m * m, beta)),
        0.0
    );
    assert_eq!(
        lateral_correction(o, 0.5, c, (g, g), |m| if m < 0.5 {
            (0.0, 0.0)
        } else {
            (m, beta)
        }),
        0.0
    );
    assert_eq!(
        lateral_correction(o, 0.5, c, (f64::NAN, f64::NAN), |m| (m * m, beta)),
        0.0
    );
}

/// [`lateral_correction`] on a cylinder of radius 10 mm (k1 = 1/10 across the axis e1, k2 = 0):
/// |grad mu|^2 = |S l_t|^2 is k1^2 (1 - mu^2) for a beam whose tangent crosses the axis and 0 for
/// one along it, while Lap(mu) = -(k1^2 + k2^2) mu either way. With K = mu^2, beta constant:
/// lat = (2 r (1 - mu^2) - 4 mu^2) / beta, r = g_t / g = 2 across, 0 along (a sphere's mean, r = 1,
/// gives 2 - 6 mu^2 for both). [`SurfaceCurvature::squared_along`] gives those g_t.
#[test]
fn lateral_correction_follows_the_beam_across_an_anisotropic_surface() {
    let o = Optics {
        sigma_s: 0.7,
        sigma_a: 0.0014,
        diffusion: DiffusionCoefficient::Classical,
    };
    let (beta, c, mu, radius) = (1.5, 0.05, 0.7, 10.0);
    let cylinder = SurfaceCurvature {
        mean: 0.5 / radius,
        anisotropy: DVec3::X * (0.5 / radius).sqrt(),
    };
    let g = cylinder.squared();
    assert!((g - 0.5 / (radius * radius)).abs() < 1e-12, "{g}");
    let (across, along) = (
        cylinder.squared_along(DVec3::X),
        cylinder.squared_along(DVec3::Z),
    );
    assert!((across - 1.0 / (radius * radius)).abs() < 1e-12, "{across}");
    assert!(along.abs() < 1e-12, "{along}");
    let sphere = SurfaceCurvature::umbilic(1.0 / radius);
    let g_sphere = sphere.squared();
    assert!((sphere.squared_along(DVec3::Y) - g_sphere).abs() < 1e-15);
    let denom = o.sigma_a - o.d() * beta * beta * (1.0 + 2.0 * c * o.sigma_t() / beta);
    let closed = |r: f64| o.d() * g * (2.0 * r * (1.0 - mu * mu) - 4.0 * mu * mu) / denom;
    for (g_t, r) in [(across, 2.0), (along, 0.0), (g, 1.0)] {
        let got = lateral_correction(o, mu, c, (g, g_t), |m| (m * m, beta));
        let want = closed(r);
        assert!(
            want != 0.0 && (got - want).abs() < 1e-6 * want.abs(),
            "r {r}: {got} vs {want}"
        );
    }
    // Across and along differ in sign here (2 (1 - 0.49) 2 = 2.04 > 1.96; 0 < 1.96).
    assert!(closed(2.0) * closed(0.0) < 0.0);
}

/// [`lateral_correction`]'s guard ([`LATERAL_GUARD_FROM`]): in full where the unclamped
/// curvature sqrt(g) / sigma_t' is below 0.15 (skim-milk red on the 10 mm sphere, 0.143),
/// half at 0.175 (the smoothstep's middle), none from the clamp [`UPSTREAM_SHIFT_LIMIT`] on
/// (ketchup red on the same sphere, sigma_t' 0.241/mm: 0.415, where the term took the 20 mm
/// ketchup sphere's red from 16 to 26% relative RMS). Against the closed form of
/// [`lateral_correction_matches_its_closed_form`] without the guard.
#[test]
fn lateral_correction_is_guarded_where_the_curvature_reaches_the_clamp() {
    let (beta, c, mu) = (1.5, 0.1, 0.8);
    let closed = |o: Optics, g: f64| {
        let g = g.min((UPSTREAM_SHIFT_LIMIT * o.sigma_t()).powi(2));
        let denom = o.sigma_a - o.d() * beta * beta * (1.0 + 2.0 * c * o.sigma_t() / beta);
        o.d() * g * (2.0 - 6.0 * mu * mu) / denom
    };
    let milk = Optics {
        sigma_s: 0.7,
        sigma_a: 0.0014,
        diffusion: DiffusionCoefficient::Classical,
    };
    let ketchup = Optics {
        sigma_s: 0.18,
        sigma_a: 0.061,
        diffusion: DiffusionCoefficient::Classical,
    };
    let g_sphere = 0.01; // 1 / R^2, R = 10 mm
    let lateral = |o: Optics, g: f64| lateral_correction(o, mu, c, (g, g), |m| (m * m, beta));
    let full = lateral(milk, g_sphere);
    let want = closed(milk, g_sphere);
    assert!(
        want != 0.0 && (full - want).abs() < 1e-6 * want.abs(),
        "{full} vs {want}"
    );
    let middle = ((LATERAL_GUARD_FROM + UPSTREAM_SHIFT_LIMIT) / 2.0 * milk.sigma_t()).powi(2);
    let half = lateral(milk, middle);
    let want = 0.5 * closed(milk, middle);
    assert!((half - want).abs() < 1e-6 * want.abs(), "{half} vs {want}");
    assert!(closed(ketchup, g_sphere) != 0.0);
    assert_eq!(lateral(ketchup, g_sphere), 0.0);
    let at_clamp = (UPSTREAM_SHIFT_LIMIT * milk.sigma_t()).powi(2);
    assert_eq!(lateral(milk, at_clamp), 0.0);
}
