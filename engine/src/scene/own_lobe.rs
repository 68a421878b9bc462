//! The exit lobe of a node's own light from Chandrasekhar's half-space reflection
//! ([`super::ExitLobe::Chandra`]).
//!
//! An isotropic, index-matched half-space of albedo omega lit by a parallel beam of flux pi F at
//! incidence cosine mu0 reflects (Chandrasekhar, *Radiative Transfer*, 1950, ch. IV eq. 31)
//!
//! `I(mu, mu0) = (omega F / 4) mu0 / (mu + mu0) H(mu) H(mu0)`.
//!
//! Its single scattering is the "1" of `H(mu) H(mu0)` (our single-scattering pass draws that),
//! so the multiple-scattered light the diffusion carries has the shape
//!
//! `g(mu; mu0, omega) = c (H(mu) H(mu0) - 1) / (mu + mu0)`,
//!
//! c normalizing it to the Lambertian lobe's exitance, `2 int_0^1 g mu dmu = 1` (8-point
//! Gauss-Legendre, [`own_lobe`]; 3e-5 from a 200-point rule, benches/exit_lobe/chandra.py). At
//! normal incidence it is limb-darkened (omega 1: g(0.9) / g(0.3) = 1.26), at grazing incidence
//! nearly flat (1.03 at mu0 = 0.3): the half-space Monte Carlo's shape (benches/RESULTS.md
//! "Own-light lobe"). H is Hapke's approximation ([`h_function`], within 1% of the exact H).
//!
//! Several lights: each light's shape weighted by its irradiance `E mu0` at the point; an
//! environment adds a Lambertian part ([`OwnLight`]), exact for isotropic light on a
//! conservative half-space. Shadows are not tested: on a convex object `n.l > 0` is lit.
//!
//! ```
//! use translucent::scene::own_lobe;
//! // Normal incidence, albedo 0.999: brighter toward the normal, normalized like Lambert.
//! let g = |mu| own_lobe::own_lobe(mu, 1.0, 0.999);
//! assert!(g(0.9) / g(0.3) > 1.2);
//! // Grazing incidence: nearly flat.
//! let g = |mu| own_lobe::own_lobe(mu, 0.3, 0.999);
//! assert!((g(0.9) / g(0.3) - 1.0).abs() < 0.05);
//! ```

use glam::DVec3;

use super::{Light, Scene};
use crate::material::MaterialField;

/// Gauss-Legendre nodes on [0, 1] (the 8-point rule on [-1, 1], halved and shifted).
pub const GAUSS_NODES: [f64; 8] = [
    0.019_855_071_751_231_856,
    0.101_666_761_293_186_6,
    0.237_233_795_041_835_5,
    0.408_282_678_752_175_1,
    0.591_717_321_247_825,
    0.762_766_204_958_164_5,
    0.898_333_238_706_813_4,
    0.980_144_928_248_768_2,
];
/// Their weights (summing to 1).
pub const GAUSS_WEIGHTS: [f64; 8] = [
    0.050_614_268_145_188_13,
    0.111_190_517_226_687_24,
    0.156_853_322_938_943_64,
    0.181_341_891_689_181,
    0.181_341_891_689_181,
    0.156_853_322_938_943_64,
    0.111_190_517_226_687_24,
    0.050_614_268_145_188_13,
];

/// Cosines below this are clamped in [`h_function`] (x ln(1/x) -> 0 there; H(0) = 1).
const MIN_COSINE: f64 = 1e-6;

/// Chandrasekhar's H function for isotropic scattering at albedo `omega` (clamped to [0, 1]),
/// Hapke's approximation (Icarus 157, 2002, eq. 13):
/// `H(x) = 1 / (1 - omega x (r0 + (1 - 2 r0 x) / 2 ln((1 + x) / x)))`, r0 = (1 - g) / (1 + g),
/// g = sqrt(1 - omega); within 1% of the exact H for every albedo (benches/exit_lobe/chandra.py).
pub fn h_function(x: f64, omega: f64) -> f64 {
    let omega = if omega.is_nan() {
        0.0
    } else {
        omega.clamp(0.0, 1.0)
    };
    let x = x.clamp(MIN_COSINE, 1.0);
    let g = (1.0 - omega).sqrt();
    let r0 = (1.0 - g) / (1.0 + g);
    1.0 / (1.0 - omega * x * (r0 + 0.5 * (1.0 - 2.0 * r0 * x) * ((1.0 + x) / x).ln()))
}

/// The own-light lobe `g(mu; mu0, omega)` (module doc), a factor on the Lambertian radiance:
/// `2 int_0^1 g mu dmu = 1`. `mu` the view cosine, `mu0` the light's, both clamped to [0, 1].
/// 1 (Lambert) where the shape vanishes (omega 0: no multiple scattering).
pub fn own_lobe(mu: f64, mu0: f64, omega: f64) -> f64 {
    let mu = mu.clamp(0.0, 1.0);
    let mu0 = mu0.clamp(0.0, 1.0);
    let h0 = h_function(mu0, omega);
    let norm: f64 = 2.0
        * GAUSS_NODES
            .iter()
            .zip(GAUSS_WEIGHTS)
            .map(|(&x, w)| w * x * (h_function(x, omega) * h0 - 1.0) / (x + mu0))
            .sum::<f64>();
    if norm.is_finite() && norm > 0.0 {
        // mu + mu0 = 0 only at grazing view and grazing light: the clamped cosines keep it
        // finite there.
        let denominator = (mu + mu0).max(MIN_COSINE);
        ((h_function(mu, omega) * h0 - 1.0) / denominator / norm).max(0.0)
    } else {
        1.0
    }
}

/// What lights a surface point's own light, for [`ExitLobe::Chandra`](super::ExitLobe::Chandra):
/// per light its incidence cosine and irradiance `E mu0` (the weight of its shape), and the
/// environment's irradiance (a Lambertian part). `shade_mesh.frag` computes the same per
/// fragment.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct OwnLight {
    /// (mu0, irradiance E mu0 per channel) of each light above the surface.
    pub lights: Vec<(f64, [f64; 3])>,
    /// The environment's irradiance per channel.
    pub environment: [f64; 3],
}

impl OwnLight {
    /// The lights of `scene` at point `p` with outward unit normal `n` (no shadow test).
    pub fn at(scene: &Scene, p: DVec3, n: DVec3) -> OwnLight {
        let lights = scene
            .lights
            .iter()
            .filter_map(|light: &Light| {
                let (e, l, _) = light.arriving(p);
                let mu0 = n.dot(l);
                (mu0 > 0.0).then(|| (mu0, e.map(|v| v.max(0.0) * mu0)))
            })
            .collect();
        OwnLight {
            lights,
            environment: scene.environment.irradiance(n),
        }
    }

    /// The own light's factor on the Lambertian radiance toward view cosine `mu` per channel
    /// (albedo `omega` per channel): the lights' lobes weighted by their irradiance, the
    /// environment's Lambertian; 1 where nothing lights the point.
    pub fn factor(&self, mu: f64, omega: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|c| {
            let mut sum = self.environment[c].max(0.0);
            let mut weight = sum;
            for &(mu0, e) in &self.lights {
                sum += e[c] * own_lobe(mu, mu0, omega[c]);
                weight += e[c];
            }
            if weight > 0.0 && sum.is_finite() && weight.is_finite() {
                sum / weight
            } else {
                1.0
            }
        })
    }
}

/// The reduced albedo sigma_s' / (sigma_s' + sigma_a) per channel the own-light lobe uses: the
/// material's, or for a heterogeneous field the mean over `positions` (the surface vertices).
pub fn surface_albedo(field: &MaterialField, positions: &[DVec3]) -> [f64; 3] {
    let albedo = |p: DVec3| {
        let k = field.sample(p);
        std::array::from_fn::<f64, 3, _>(|c| {
            let t = k.sigma_s[c] + k.sigma_a[c];
            if t > 0.0 {
                (k.sigma_s[c] / t).clamp(0.0, 1.0)
            } else {
                0.0
            }
        })
    };
    if field.is_homogeneous() || positions.is_empty() {
        return albedo(DVec3::ZERO);
    }
    let mut sum = [0.0; 3];
    for &p in positions {
        let a = albedo(p);
        for c in 0..3 {
            sum[c] += a[c];
        }
    }
    sum.map(|s| s / positions.len() as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The midpoint rule's error at 20000 steps on these smooth integrands.
    const QUADRATURE_TOL: f64 = 1e-4;
    /// Hapke's H against the exact H (benches/exit_lobe/chandra.py: worst 0.97% over albedos).
    const HAPKE_TOL: f64 = 0.01;

    /// Exact H at omega 1 (Chandrasekhar 1950, table V): H(0.5) and H(1).
    const H_CONSERVATIVE: [(f64, f64); 2] = [(0.5, 2.0128), (1.0, 2.9078)];
    /// Exact H at omega 0.9 (from its integral form, benches/exit_lobe/chandra.py).
    const H_0_9_AT_1: f64 = 1.8501;

    #[test]
    fn hapke_h_is_within_a_percent_of_the_exact_h() {
        for (mu, h) in H_CONSERVATIVE {
            assert!((h_function(mu, 1.0) / h - 1.0).abs() < HAPKE_TOL, "{mu}");
        }
        assert!((h_function(1.0, 0.9) / H_0_9_AT_1 - 1.0).abs() < HAPKE_TOL);
        // H(0) = 1 up to the clamp at MIN_COSINE (omega x ln(1 / x) ~ 1e-5 there).
        assert!((h_function(0.0, 0.999) - 1.0).abs() < QUADRATURE_TOL);
        assert!(h_function(0.5, f64::NAN).is_finite());
    }

    /// 2 int_0^1 g mu dmu by the midpoint rule.
    fn exitance(g: impl Fn(f64) -> f64) -> f64 {
        const STEPS: usize = 20_000;
        2.0 * (0..STEPS)
            .map(|i| {
                let mu = (i as f64 + 0.5) / STEPS as f64;
                g(mu) * mu / STEPS as f64
            })
            .sum::<f64>()
    }

    #[test]
    fn the_own_lobe_carries_the_lambertian_exitance() {
        for omega in [0.3, 0.9, 0.9926, 0.999, 1.0] {
            for mu0 in [0.0, 0.05, 0.2, 0.5, 1.0] {
                let m = exitance(|mu| own_lobe(mu, mu0, omega));
                assert!(
                    (m - 1.0).abs() < QUADRATURE_TOL,
                    "omega {omega} mu0 {mu0}: {m}"
                );
            }
        }
        assert_eq!(own_lobe(0.5, 1.0, 0.0), 1.0, "no scattering: Lambert");
    }

    /// g(0.9) / g(0.3) at omega 1 from the exact H (benches/exit_lobe/chandra.py): the law the
    /// lead quoted, 1.26 at normal incidence, 1.03 at mu0 = 0.3.
    const RATIO_EXACT: [(f64, f64); 2] = [(1.0, 1.2575), (0.3, 1.0263)];
    /// Hapke's H moves the ratio by well under 1%.
    const RATIO_TOL: f64 = 0.01;

    #[test]
    fn the_lobe_follows_the_h_function_law() {
        for (mu0, want) in RATIO_EXACT {
            let r = own_lobe(0.9, mu0, 1.0) / own_lobe(0.3, mu0, 1.0);
            assert!(
                (r / want - 1.0).abs() < RATIO_TOL,
                "mu0 {mu0}: {r} vs {want}"
            );
        }
    }

    #[test]
    fn own_light_weights_its_lights_by_irradiance() {
        let scene = Scene {
            lights: vec![
                "dir:0,-1,0:2,2,2".parse().unwrap(),
                "dir:-1,0,0:1,0,0".parse().unwrap(),
                "dir:0,1,0:5,5,5".parse().unwrap(), // below the surface: no part
            ],
            environment: super::super::Environment::Constant([0.1; 3]),
        };
        let own = OwnLight::at(&scene, DVec3::ZERO, DVec3::Y);
        assert_eq!(own.lights.len(), 1);
        let omega = [0.999; 3];
        let f = own.factor(0.7, omega);
        let e_env = std::f64::consts::PI * 0.1;
        let want = (2.0 * own_lobe(0.7, 1.0, 0.999) + e_env) / (2.0 + e_env);
        assert!((f[0] - want).abs() < 1e-12);
        // Nothing lighting: Lambert.
        assert_eq!(OwnLight::default().factor(0.3, omega), [1.0; 3]);
        // Mixed lobes keep the exitance.
        let two = OwnLight {
            lights: vec![(1.0, [1.0; 3]), (0.3, [0.5; 3])],
            environment: [0.2; 3],
        };
        assert!((exitance(|mu| two.factor(mu, omega)[1]) - 1.0).abs() < QUADRATURE_TOL);
    }
}
