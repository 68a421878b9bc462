//! The formulas of DESIGN sections 2.6-2.8 (`solver::transport`) against a Monte Carlo of the
//! half-space they are derived for: a homogeneous medium with a smooth dielectric boundary of
//! index ratio eta, isotropic phase, lit by a collimated beam; the exiting radiance binned by view
//! angle, the single-scattered part kept apart (the Rust twin of
//! `../shared/research/halfspace-mc/mc.py`, with exact reflected paths).
//!
//! What is checked, each against the Monte Carlo (relative RMS over the view-angle bins from 80 to
//! 19 degrees, as DESIGN quotes; the most grazing bin is left out as there):
//! - the exit query of 2.6 with the collimated source of 2.7: marble-like albedo 0.999 at eta 1.5
//!   and milk-like at 1.3 (DESIGN: 0.6% and 0.9%), against the flux-only query with the F_dr
//!   boundary constant (10% and 7.1%), which must fail the same bound;
//! - the single-scattering closed form of 2.8 against the Monte Carlo's first-order bins;
//! - the second-collision source with single scattering added whole (2.8's second option),
//!   including at eta = 1 and grazing incidence, where the collimated source alone fails.

use std::f64::consts::PI;

use translucent::material::{fresnel, DiffusionCoefficient};
use translucent::solver::transport::{
    beam_particular, flat_single_scattering, refracted_cosine, second_collision_fit, Boundary,
    ExitQuery, Optics, Refraction,
};

/// View-angle bins over cos theta_o (outside), as mc.py.
const BINS: usize = 9;

/// splitmix64: small, deterministic, good enough for a Monte Carlo test.
struct Rng(u64);
impl Rng {
    fn uniform(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Exiting radiance per bin per unit surface irradiance: (all orders, single scattering).
struct Tally {
    centres: [f64; BINS],
    all: [f64; BINS],
    single: [f64; BINS],
}

/// Photons of a beam arriving at `mu_i` (outside) on a half-space of unit sigma_t' and `albedo`,
/// followed up to `max_order` collisions.
fn monte_carlo(
    albedo: f64,
    eta: f64,
    mu_i: f64,
    photons: usize,
    seed: u64,
    max_order: u32,
) -> Tally {
    let mut rng = Rng(seed);
    let t_i = fresnel::transmittance(eta, mu_i);
    let mu_t = refracted_cosine(eta, mu_i);
    let (mut all, mut single) = ([0.0; BINS], [0.0; BINS]);
    for _ in 0..photons {
        // mu: cosine of the direction to the inward normal (+z), z the depth.
        let (mut z, mut mu, mut w, mut order) = (0.0f64, mu_t, t_i, 0u32);
        loop {
            let mut step = -(1.0 - rng.uniform()).ln();
            // Travel, reflecting off the boundary from inside, until the next collision or an exit.
            let exited = loop {
                let z_next = z + mu * step;
                if z_next >= 0.0 {
                    z = z_next;
                    break false;
                }
                // Reaches z = 0 after z / -mu, at internal cosine -mu.
                let travelled = z / -mu;
                let cos_inside = -mu;
                if rng.uniform() >= fresnel::reflectance(1.0 / eta, cos_inside) {
                    let cos_out = (1.0 - eta * eta * (1.0 - mu * mu)).max(0.0).sqrt();
                    let bin = ((cos_out * BINS as f64) as usize).min(BINS - 1);
                    all[bin] += w;
                    if order == 1 {
                        single[bin] += w;
                    }
                    break true;
                }
                step -= travelled;
                z = 0.0;
                mu = -mu;
            };
            if exited {
                break;
            }
            order += 1;
            if order > max_order {
                break;
            }
            w *= albedo;
            mu = 2.0 * rng.uniform() - 1.0;
            if w < 1e-4 {
                if rng.uniform() < 0.5 {
                    break;
                }
                w *= 2.0;
            }
        }
    }
    let mut centres = [0.0; BINS];
    let norm = |acc: [f64; BINS], centres: &[f64; BINS]| {
        std::array::from_fn(|b| acc[b] / (photons as f64 * 2.0 * PI * centres[b] / BINS as f64))
    };
    for (b, c) in centres.iter_mut().enumerate() {
        *c = (b as f64 + 0.5) / BINS as f64;
    }
    Tally {
        all: norm(all, &centres),
        single: norm(single, &centres),
        centres,
    }
}

/// The bins DESIGN quotes (view angles 80 to 19 degrees): all but the most grazing one.
fn rms(model: &[f64; BINS], reference: &[f64; BINS]) -> f64 {
    let e: f64 = (1..BINS)
        .map(|b| (model[b] / reference[b] - 1.0).powi(2))
        .sum();
    (e / (BINS - 1) as f64).sqrt()
}

/// Diffusion radiance per bin for a beam at `mu_i` with unit surface irradiance: the collimated
/// source (gain 1) or the second-collision one, read with `exit`.
fn diffusion(albedo: f64, eta: f64, mu_i: f64, exit: ExitQuery, second: bool) -> [f64; BINS] {
    diffusion_with(
        albedo,
        eta,
        mu_i,
        exit,
        second,
        DiffusionCoefficient::Classical,
    )
}

/// [`diffusion`] with the diffusion coefficient `kind`.
fn diffusion_with(
    albedo: f64,
    eta: f64,
    mu_i: f64,
    exit: ExitQuery,
    second: bool,
    kind: DiffusionCoefficient,
) -> [f64; BINS] {
    let b = Boundary::new(eta, exit);
    let o = Optics {
        sigma_s: albedo,
        sigma_a: 1.0 - albedo,
        diffusion: kind,
    };
    let r = Refraction::new(eta, mu_i);
    // The second-collision source as render uses it: fitted to both moments (its reflectance
    // moment is r's exactly).
    let (gain, r) = if second {
        let f = second_collision_fit(o, r.mu_t, eta, b.h(o));
        (f.gain, Refraction { mu_t: f.mu_e, ..r })
    } else {
        (1.0, r)
    };
    let (k, beta) = beam_particular(o, r, 1.0, gain);
    let m = b.half_space_exitance(o, 0.0, k, -beta * k, -(k + b.h(o) * beta * k));
    std::array::from_fn(|bin| {
        let cos_o = (bin as f64 + 0.5) / BINS as f64;
        b.radiance(m, cos_o)
    })
}

/// Single scattering per bin (closed form, with the exit factor T_o / eta^2).
fn single_scattering(albedo: f64, eta: f64, mu_i: f64) -> [f64; BINS] {
    let r = Refraction::new(eta, mu_i);
    std::array::from_fn(|bin| {
        let cos_o = (bin as f64 + 0.5) / BINS as f64;
        let t_o = fresnel::transmittance(eta, cos_o);
        t_o / (eta * eta) * flat_single_scattering(albedo, r, refracted_cosine(eta, cos_o), 1.0)
    })
}

/// The flux-only query with the F_dr constant that DESIGN 2.6 compares against: M = D dphi/dz_in,
/// L = F_t M / pi.
fn flux_only(albedo: f64, eta: f64, mu_i: f64) -> [f64; BINS] {
    let b = Boundary::new(eta, ExitQuery::Classic);
    let o = Optics {
        sigma_s: albedo,
        sigma_a: 1.0 - albedo,
        diffusion: Default::default(),
    };
    let (k, beta) = beam_particular(o, Refraction::new(eta, mu_i), 1.0, 1.0);
    let s = o.s();
    let phi_h = -(k + b.h(o) * beta * k) / (1.0 + b.h(o) * s);
    let m = o.d() * (-s * phi_h - beta * k);
    std::array::from_fn(|bin| {
        let cos_o = (bin as f64 + 0.5) / BINS as f64;
        fresnel::transmittance(eta, cos_o) * m / PI
    })
}

const PHOTONS: usize = 300_000;
/// Relative RMS noise of the first-order bins at 2M photons (about 10% of them exit after one
/// collision, 20k per bin): the single-scattering closed form is exact, so this is its bound.
const SS_NOISE: f64 = 0.015;
/// Relative RMS the Monte Carlo's own noise adds at 300k photons (per bin ~0.5-0.7% at albedo
/// 0.999, measured between seeds): bounds are the model's error in DESIGN plus this.
const MC_NOISE: f64 = 0.007;

#[test]
fn exit_query_with_the_collimated_source_matches_the_monte_carlo() {
    let mu_i = 30f64.to_radians().cos();
    // (eta, DESIGN's error of the moments query, of the flux-only query)
    for (eta, moments, flux) in [(1.5, 0.006, 0.10), (1.3, 0.009, 0.071)] {
        let mc = monte_carlo(0.999, eta, mu_i, PHOTONS, 7, u32::MAX);
        let ours = rms(
            &diffusion(0.999, eta, mu_i, ExitQuery::Moments, false),
            &mc.all,
        );
        let old = rms(&flux_only(0.999, eta, mu_i), &mc.all);
        println!("eta {eta}: moments query {ours:.4}, flux-only {old:.4}");
        assert!(ours < moments + MC_NOISE, "eta {eta}: {ours}");
        // The comparison DESIGN quotes: the flux-only query is an order of magnitude worse.
        assert!(
            old > flux - 2.0 * MC_NOISE && old > 5.0 * ours,
            "eta {eta}: {old}"
        );
    }
}

#[test]
fn single_scattering_closed_form_matches_first_order() {
    for (albedo, eta, deg) in [(0.999, 1.3, 30.0), (0.9, 1.0, 60.0), (0.5, 1.5, 0.0)] {
        let mu_i = f64::to_radians(deg).cos();
        // First order only: every photon stops at its second collision.
        let mc = monte_carlo(albedo, eta, mu_i, 2_000_000, 11, 1);
        let ss = single_scattering(albedo, eta, mu_i);
        let err = rms(&ss, &mc.single);
        println!("albedo {albedo} eta {eta} {deg} deg: single scattering {err:.4}");
        // The closed form is exact: what is left is the noise of 2M photons (1-2% per bin).
        assert!(err < SS_NOISE, "{albedo} {eta} {deg}: {err}");
    }
    assert!((monte_carlo(0.9, 1.0, 0.5, 1000, 1, 1).centres[0] - 0.5 / BINS as f64).abs() < 1e-12);
}

#[test]
fn second_collision_source_with_single_scattering_matches_the_monte_carlo() {
    // (albedo, eta, incidence in degrees, bound): the half-space numbers of this model (DESIGN:
    // 1.3% marble, 4.2-4.4% at albedo 0.95), and eta = 1 at grazing incidence, where the
    // collimated source alone (the flat part of the difference option) is 16% off.
    for (albedo, eta, deg, bound) in [
        (0.999, 1.5, 30.0, 0.025),
        (0.95, 1.3, 30.0, 0.045),
        (0.999, 1.0, 80.0, 0.03),
        (0.95, 1.0, 60.0, 0.03),
    ] {
        let mu_i = f64::to_radians(deg).cos();
        let mc = monte_carlo(albedo, eta, mu_i, PHOTONS, 3, u32::MAX);
        let diff = diffusion(albedo, eta, mu_i, ExitQuery::Moments, true);
        let ss = single_scattering(albedo, eta, mu_i);
        let total: [f64; BINS] = std::array::from_fn(|b| diff[b] + ss[b]);
        let err = rms(&total, &mc.all);
        let collimated = rms(
            &diffusion(albedo, eta, mu_i, ExitQuery::Moments, false),
            &mc.all,
        );
        println!("albedo {albedo} eta {eta} {deg} deg: second collision + single {err:.4}, collimated {collimated:.4}");
        assert!(err < bound + MC_NOISE, "{albedo} {eta} {deg}: {err}");
        if eta == 1.0 && deg == 80.0 {
            assert!(collimated > 0.1, "collimated at grazing: {collimated}");
        }
    }
}

/// Low albedo (ketchup's and skin's absorbing channels), both diffusion coefficients: with the
/// second-collision source and single scattering whole the model stays within a few percent of
/// the Monte Carlo whichever D (diffusion carries little there; benches/RESULTS.md "Diffusion
/// coefficient at low albedo"), and Grosjean's D cuts the collimated (first-collision) source's
/// excess at eta 1.3 (classical 1.26-1.30x, Grosjean 1.19-1.20x in the Python twin).
#[test]
fn low_albedo_second_collision_holds_with_either_diffusion_coefficient() {
    let mu_i = 30f64.to_radians().cos();
    // Bounds: the largest error of the Python twin over both kinds at these points (eta 1:
    // 1.4-2.3%, eta 1.3: 2.2-4.4% at albedo 0.02-0.2, view bins 80-19 degrees), plus MC_NOISE.
    // This test measured 1.9-2.0% (0.067, eta 1), 2.5-2.9% (0.2, eta 1), 3.8-4.2% (0.2, eta 1.3).
    for (albedo, eta, bound) in [(0.067, 1.0, 0.025), (0.2, 1.0, 0.03), (0.2, 1.3, 0.05)] {
        let mc = monte_carlo(albedo, eta, mu_i, PHOTONS, 5, u32::MAX);
        let ss = single_scattering(albedo, eta, mu_i);
        let mut first = [0.0; 2];
        for (i, kind) in [
            DiffusionCoefficient::Classical,
            DiffusionCoefficient::Grosjean,
        ]
        .into_iter()
        .enumerate()
        {
            let diff = diffusion_with(albedo, eta, mu_i, ExitQuery::Moments, true, kind);
            let total: [f64; BINS] = std::array::from_fn(|b| diff[b] + ss[b]);
            let err = rms(&total, &mc.all);
            let collimated = diffusion_with(albedo, eta, mu_i, ExitQuery::Moments, false, kind);
            first[i] =
                (1..BINS).map(|b| collimated[b] / mc.all[b]).sum::<f64>() / (BINS - 1) as f64;
            println!(
                "albedo {albedo} eta {eta} {kind:?}: second + single {err:.4}, collimated mean ratio {:.3}",
                first[i]
            );
            assert!(err < bound + MC_NOISE, "{albedo} {eta} {kind:?}: {err}");
        }
        if eta > 1.0 {
            // The collimated source's excess at low albedo is smaller with Grosjean's D.
            assert!(first[1] < first[0] - 0.03, "{first:?}");
        }
    }
}
