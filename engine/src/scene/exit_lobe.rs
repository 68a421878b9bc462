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
//! - [`ExitLobe::Node`]: a slope per surface node, `b = b_P1 (o + (1 - o) s)`, o =
//!   [`OWN_SOURCE_SLOPE_SHARE`], s the node's diffused share ([`diffused_share`]): the P1 slope of
//!   the light that diffused in from elsewhere (s = 1 on unlit nodes: the slab's far face), the
//!   Lambertian lobe where the node's light is its own source (s = 0 on a lit half-space). The share is
//!   the P1 radiance's own: inside the boundary L(mu) ~ phi + 3 D phi' mu with, from the node's
//!   Robin row, D phi' = (phi - rhs) / (2A), so the homogeneous field's slope is b_P1 (1 - rhs /
//!   phi); the particular solution of a collimated source (DESIGN 2.7) is own light.
//! - [`ExitLobe::Chandra`]: the node lobe with the own light drawn by Chandrasekhar's half-space
//!   law ([`super::own_lobe`]): per channel `node(s) + (1 - s) (g_own(mu; mu0, omega) - 1)`,
//!   g_own the lights' lobes weighted by irradiance (limb-darkened at normal incidence, flat at
//!   grazing), so the exitance is the node lobe's. At eta != 1 it is the node lobe: the law is
//!   the index-matched half-space's (the references at eta 1.3 are environment-lit, where the own
//!   light is Lambertian anyway), see [`ExitLobe::own_light_applies`].
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

/// [`ExitLobe::Node`]'s slope share for a node's own (lit) light: 0, DESIGN 2.6's Lambertian
/// lobe. The half-space reflection alone prefers 0.2 at eta 1 (benches/exit_lobe/lobe_mc.py), but
/// on the references the lit parts lose by it: the back-lit sphere's lit crescent, seen at grazing
/// angles, is already 20% short in exitance and 0.2 took it 0.80 -> 0.75 of the reference (18.4%
/// -> 23.0% overall); the front-lit milk, split and skin spheres are best at 0 (RESULTS "Exit
/// lobe" sweep).
pub const OWN_SOURCE_SLOPE_SHARE: f64 = 0.0;

/// The angular shape of the exitance's radiance (CLI `--exit-lobe`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ExitLobe {
    /// Lambertian inside, F_t(theta_o) outside (DESIGN 2.6); [`crate::ObjectParams::default`]'s.
    #[default]
    Lambert,
    /// The P1 radiance's slope, b = 3 / (2 A(eta)).
    P1,
    /// b = [`FITTED_SLOPE_SHARE`] of the P1 slope.
    Fitted,
    /// A slope per surface node from its diffused share (see the module doc).
    Node,
    /// [`ExitLobe::Node`] with the own light's shape from its incidence cosine (module doc); the
    /// real-time default ([`crate::defaults::EXIT_LOBE`]).
    Chandra,
}

impl ExitLobe {
    /// The names `--exit-lobe` takes and `--json` reports.
    pub const NAMES: [&'static str; 5] = ["lambert", "p1", "fitted", "node", "chandra"];

    pub fn name(self) -> &'static str {
        match self {
            Self::Lambert => Self::NAMES[0],
            Self::P1 => Self::NAMES[1],
            Self::Fitted => Self::NAMES[2],
            Self::Node => Self::NAMES[3],
            Self::Chandra => Self::NAMES[4],
        }
    }

    /// The slope b of `1 + b mu_i` at relative index `eta` ([`ExitLobe::Node`]: the P1 slope its
    /// per-node slopes are shares of).
    pub fn slope(self, eta: f64) -> f64 {
        let p1 = || {
            let a = (1.0 + 3.0 * fresnel::moment2(eta)) / (1.0 - 2.0 * fresnel::moment1(eta));
            3.0 / (2.0 * a)
        };
        match self {
            Self::Lambert => 0.0,
            Self::P1 | Self::Node | Self::Chandra => p1(),
            Self::Fitted => FITTED_SLOPE_SHARE * p1(),
        }
    }

    /// `(b, 1 / (1 + b K(eta)))`: the lobe's slope and scale at a node of diffused share 1
    /// (every node for the lobes other than [`ExitLobe::Node`]).
    pub fn shading_constants(self, eta: f64) -> (f64, f64) {
        let b = self.slope(eta);
        if b == 0.0 {
            return (0.0, 1.0);
        }
        (b, 1.0 / (1.0 + b * normalization(eta)))
    }

    /// What the shading needs per frame (`shade_mesh.frag`'s push constants `lobe_slope`,
    /// `lobe_k`, `lobe_own`): the slope at share 1, K(eta), and the share of the slope a node of
    /// diffused share 0 keeps (1 for the lobes that ignore the share).
    pub fn shading_push(self, eta: f64) -> [f64; 3] {
        let own = match self {
            Self::Node | Self::Chandra => OWN_SOURCE_SLOPE_SHARE,
            _ => 1.0,
        };
        [self.slope(eta), normalization(eta), own]
    }

    /// The slope at a node of diffused share `share` (clamped to [0, 1]; ignored but by
    /// [`ExitLobe::Node`]).
    pub fn slope_at(self, eta: f64, share: f64) -> f64 {
        let [b, _, own] = self.shading_push(eta);
        let s = if share.is_nan() {
            0.0
        } else {
            share.clamp(0.0, 1.0)
        };
        b * (own + (1.0 - own) * s)
    }

    /// The factor this lobe puts on the Lambertian radiance toward `cos_o` (outside cosine to
    /// the normal, clamped to [0, 1]) at a node of diffused share 1; 1 for [`ExitLobe::Lambert`].
    pub fn factor(self, eta: f64, cos_o: f64) -> f64 {
        self.factor_at(eta, cos_o, 1.0)
    }

    /// Whether the node's diffused share reaches the shading (the per-node lobes).
    pub fn reads_share(self) -> bool {
        matches!(self, Self::Node | Self::Chandra)
    }

    /// Whether the own light's Chandrasekhar shape applies ([`ExitLobe::Chandra`] at eta 1:
    /// the law is the index-matched half-space's; elsewhere the lobe is [`ExitLobe::Node`]'s).
    pub fn own_light_applies(self, eta: f64) -> bool {
        self == Self::Chandra && eta == 1.0
    }

    /// The factor on the Lambertian radiance per channel toward `cos_o` at a node of diffused
    /// share `share` lit by `own` (albedo `omega` per channel): [`Self::factor_at`], plus for
    /// [`ExitLobe::Chandra`] at eta 1 the own light's shape, `(1 - s) (g_own - 1)`
    /// (`shade_mesh.frag`'s formula in f64).
    pub fn factor_lit(
        self,
        eta: f64,
        cos_o: f64,
        share: f64,
        own: &super::own_lobe::OwnLight,
        omega: [f64; 3],
    ) -> [f64; 3] {
        let node = self.factor_at(eta, cos_o, share);
        if !self.own_light_applies(eta) {
            return [node; 3];
        }
        let s = if share.is_nan() {
            0.0
        } else {
            share.clamp(0.0, 1.0)
        };
        let g = own.factor(cos_o, omega);
        g.map(|g| (node + (1.0 - s) * (g - 1.0)).max(0.0))
    }

    /// The factor per channel on the Lambertian radiance of an exitance `after` of which the
    /// method wrote `before` and the bounce between surface points ([`crate::frame::bounce`])
    /// added the rest: `lobe` (this lobe's factor, e.g. [`Self::factor_lit`]) on the method's
    /// part, Lambert on the bounce's, `w lobe + (1 - w)` with `w = before / after` per channel
    /// (`shade_mesh.frag` with `lobe_bounce`). The bounce's light re-entered from the hemisphere the
    /// surface sees: own light under diffuse incidence, which a half-space reflects flat
    /// (Chandrasekhar's law for isotropic illumination, `1 - sqrt(1 - omega) H(mu)`: within 2.2%
    /// of Lambert at omega 0.999, the P1 lobe 26% off). The node's diffused share, from the
    /// solve, does not know that light: without this the bounce on a shadowed floor took the P1
    /// lobe of share 1 (benches/RESULTS.md, "The Chandrasekhar exit lobe as the default").
    /// Keeps the exitance: each part's lobe carries its own.
    pub fn with_bounce(lobe: [f64; 3], before: [f64; 3], after: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|c| {
            let x = if after[c].is_nan() {
                0.0
            } else {
                after[c].max(0.0)
            };
            let w = if x > 0.0 {
                let solved = if before[c].is_nan() {
                    0.0
                } else {
                    before[c].clamp(0.0, x)
                };
                solved / x
            } else {
                1.0
            };
            w * lobe[c] + (1.0 - w)
        })
    }

    /// [`Self::factor`] at a node of diffused share `share` ([`diffused_share`]).
    pub fn factor_at(self, eta: f64, cos_o: f64, share: f64) -> f64 {
        let b = self.slope_at(eta, share);
        if b == 0.0 {
            return 1.0;
        }
        (1.0 + b * inside_cosine(eta, cos_o)) / (1.0 + b * normalization(eta))
    }
}

/// K(eta) = (1/3 - C2) / (1/2 - C1): the normalization of `1 + b mu_i` (module doc).
fn normalization(eta: f64) -> f64 {
    (1.0 / 3.0 - fresnel::moment2(eta)) / (0.5 - fresnel::moment1(eta))
}

/// The diffused share of a surface node for [`ExitLobe::Node`], in [0, 1]: per channel, the
/// homogeneous field's P1 share `1 - rhs / phi` (phi the solved remainder at the node, rhs its
/// Robin row's right side, both in the same units) weighted by that field's exitance
/// `m_homogeneous` against the node's `m` (the rest, the particular solution's part, is own
/// light), summed over the channels with positive exitance. 0 where nothing leaves. The GPU's
/// `j_plus.glsl` computes the same from phi, q (rhs = flux_gain q) and `particular`.
pub fn diffused_share(phi: [f64; 3], rhs: [f64; 3], m: [f64; 3], m_homogeneous: [f64; 3]) -> f64 {
    let (mut diffused, mut total) = (0.0, 0.0);
    for c in 0..3 {
        let p1 = if phi[c] > 0.0 {
            (1.0 - rhs[c] / phi[c]).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let m_c = m[c].max(0.0);
        diffused += p1 * m_homogeneous[c].clamp(0.0, m_c);
        total += m_c;
    }
    if total > 0.0 && diffused.is_finite() && total.is_finite() {
        (diffused / total).clamp(0.0, 1.0)
    } else {
        0.0
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
    /// `lambert`, `p1`, `fitted`, `node` or `chandra` (the CLI's `--exit-lobe`).
    fn from_str(s: &str) -> Result<Self, SceneError> {
        match s {
            "lambert" => Ok(Self::Lambert),
            "p1" => Ok(Self::P1),
            "fitted" => Ok(Self::Fitted),
            "node" => Ok(Self::Node),
            "chandra" => Ok(Self::Chandra),
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
                    // The same formula up to rounding (a product here, a quotient there).
                    assert!((g(mu) - lobe.factor(eta, mu)).abs() < 1e-12);
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

    /// View-bin centres (cosine outside = inside at eta 1) of benches/exit_lobe/lobe_mc.npz.
    const MC_MU: [f64; 9] = [
        0.05555556, 0.16666667, 0.27777778, 0.38888889, 0.5, 0.61111111, 0.72222222, 0.83333333,
        0.94444444,
    ];
    /// lobe_mc.npz `t_8.0`: radiance leaving the far face of an 8 mfp slab (eta 1, albedo 0.999,
    /// lit normally from behind, unscattered beam excluded), Monte Carlo, per view bin.
    const MC_SLAB_8: [f64; 9] = [
        0.02701375, 0.03359688, 0.03778919, 0.04162668, 0.04801902, 0.0507981, 0.0564928,
        0.06018897, 0.06661705,
    ];
    /// lobe_mc.npz `r_0.999_1.0_30`: a half space (eta 1, albedo 0.999, lit at 30 degrees):
    /// the Monte Carlo's reflected radiance, the diffusion's Lambertian radiance (render's
    /// second-collision source, DESIGN 2.6's exitance) and the exact single scattering.
    const MC_HALF_SPACE: [f64; 9] = [
        0.24085286, 0.27163007, 0.27510968, 0.28308864, 0.29138066, 0.2980531, 0.2957284,
        0.29518221, 0.30035021,
    ];
    const DIFFUSION_HALF_SPACE: f64 = 0.24383543;
    const SINGLE_HALF_SPACE: [f64; 9] = [
        0.08626252, 0.07698122, 0.06950312, 0.06334926, 0.0581965, 0.05381892, 0.05005384,
        0.04678111, 0.04391009,
    ];
    /// The node lobe's relative RMS against the slab's Monte Carlo shape: the best slope reaches
    /// 1.5% (RESULTS "Exit lobe"), ~1% noise per bin; Lambert is at 30%.
    const SLAB_SHAPE_TOL: f64 = 0.03;
    /// Against the half-space reflection (the node lobe is Lambertian there): Lambert 8.9%, P1
    /// 9.9%, the best slope 2.2%.
    const HALF_SPACE_TOL: f64 = 0.092;
    /// P1 is this much further from the half space's Monte Carlo than Lambert (measured 1.0
    /// points): a share read as diffused there fails.
    const LOBES_APART: f64 = 0.005;

    /// Relative RMS over the view bins 80..19 degrees (the grazing-most bin is noisy; as
    /// lobe_mc.py's fit).
    fn rel_rms(model: impl Fn(usize) -> f64, mc: &[f64; 9]) -> f64 {
        let e: Vec<f64> = (1..9).map(|i| model(i) / mc[i] - 1.0).collect();
        (e.iter().map(|x| x * x).sum::<f64>() / e.len() as f64).sqrt()
    }

    #[test]
    fn the_node_lobe_follows_the_slab_and_half_space_monte_carlo() {
        let eta = 1.0;
        let boundary_h = 2.0 / 3.0; // h = 2 A D at eta 1, D = 1/3 in mean free paths
                                    // The slab's far face: unlit (rhs 0), its light all diffused from the lit face.
        let (phi_far, m_far) = (0.1, 0.04);
        let far = diffused_share([phi_far; 3], [0.0; 3], [m_far; 3], [m_far; 3]);
        // The lit half space's surface node: phi_h = rhs / (1 + h s) (s = sqrt(3 sigma_a
        // sigma_t') at albedo 0.999), its exitance mostly the particular solution's.
        let s = (3.0f64 * 0.001).sqrt();
        let rhs = 1.0;
        let phi_lit = rhs / (1.0 + boundary_h * s);
        let lit = diffused_share([phi_lit; 3], [rhs; 3], [0.3; 3], [0.1; 3]);
        assert_eq!((far, lit), (1.0, 0.0));

        // Slab, shape only (scaled to the Monte Carlo's exitance over the bins, as the fit).
        let slab = |lobe: ExitLobe, share: f64| {
            let g = |i: usize| lobe.factor_at(eta, MC_MU[i], share);
            let scale = (1..9).map(|i| MC_SLAB_8[i] * MC_MU[i]).sum::<f64>()
                / (1..9).map(|i| g(i) * MC_MU[i]).sum::<f64>();
            rel_rms(|i| scale * g(i), &MC_SLAB_8)
        };
        let (node, lambert) = (slab(ExitLobe::Node, far), slab(ExitLobe::Lambert, far));
        assert!(
            node < SLAB_SHAPE_TOL,
            "slab: node {node} (lambert {lambert})"
        );
        assert!(
            lambert > 5.0 * SLAB_SHAPE_TOL,
            "the case tells lobes apart: {lambert}"
        );

        // Half space: the lobe on the diffusion's part, the single scattering added.
        let half = |lobe: ExitLobe, share: f64| {
            rel_rms(
                |i| {
                    DIFFUSION_HALF_SPACE * lobe.factor_at(eta, MC_MU[i], share)
                        + SINGLE_HALF_SPACE[i]
                },
                &MC_HALF_SPACE,
            )
        };
        let node = half(ExitLobe::Node, lit);
        let (lambert, p1) = (half(ExitLobe::Lambert, lit), half(ExitLobe::P1, lit));
        assert!(node < HALF_SPACE_TOL, "half space: node {node}");
        assert!(
            node <= lambert + QUADRATURE_TOL && node < p1 - LOBES_APART,
            "node {node}, lambert {lambert}, p1 {p1}"
        );
    }

    #[test]
    fn the_node_lobe_keeps_the_exitance_and_never_goes_negative() {
        for eta in [1.0, 1.3, 1.5] {
            let lambert = exitance(eta, |_| 1.0);
            for share in [0.0, 0.37, 1.0, -2.0, 7.0, f64::NAN] {
                let m = exitance(eta, |mu| ExitLobe::Node.factor_at(eta, mu, share));
                assert!(
                    (m / lambert - 1.0).abs() < QUADRATURE_TOL,
                    "eta {eta} share {share}: {m} vs {lambert}"
                );
                for mu in [0.0, 0.5, 1.0] {
                    assert!(ExitLobe::Node.factor_at(eta, mu, share) >= 0.0);
                }
            }
            // The share only steepens the lobe between the own-light and the P1 slopes.
            let p1 = ExitLobe::P1.slope(eta);
            assert!((ExitLobe::Node.slope_at(eta, 1.0) - p1).abs() < 1e-12);
            assert!(
                (ExitLobe::Node.slope_at(eta, 0.0) - OWN_SOURCE_SLOPE_SHARE * p1).abs() < 1e-12
            );
            assert!(ExitLobe::Node.slope_at(eta, 0.5) > ExitLobe::Node.slope_at(eta, 0.0));
            // The other lobes ignore it.
            assert_eq!(ExitLobe::P1.slope_at(eta, 0.0), p1);
        }
        // Nothing leaving, or nothing but own light, is share 0; NaN never comes out.
        assert_eq!(diffused_share([0.0; 3], [0.0; 3], [0.0; 3], [0.0; 3]), 0.0);
        assert_eq!(diffused_share([1.0; 3], [2.0; 3], [1.0; 3], [1.0; 3]), 0.0);
        assert_eq!(
            diffused_share([f64::NAN; 3], [0.0; 3], [1.0; 3], [1.0; 3]),
            0.0
        );
        // Half diffused in every channel.
        let half = diffused_share([1.0, 2.0, 4.0], [0.5, 1.0, 2.0], [1.0; 3], [1.0; 3]);
        assert!((half - 0.5).abs() < 1e-12);
    }

    /// Chandrasekhar's diffuse reflection of unit isotropic radiance by an isotropic,
    /// index-matched half space of albedo `omega` toward view cosine `mu`, single scattering
    /// included: `I(mu) = (omega / 2) H(mu) int_0^1 mu0 H(mu0) / (mu + mu0) dmu0` (ch. IV eq. 31
    /// summed over the incident hemisphere; midpoint rule), the shape of the light the bounce
    /// adds.
    fn isotropic_reflection(mu: f64, omega: f64) -> f64 {
        use super::super::own_lobe::h_function;
        const STEPS: usize = 2000;
        let integral: f64 = (0..STEPS)
            .map(|i| {
                let mu0 = (i as f64 + 0.5) / STEPS as f64;
                mu0 * h_function(mu0, omega) / (mu + mu0) / STEPS as f64
            })
            .sum();
        0.5 * omega * h_function(mu, omega) * integral
    }

    /// The bounce's lobe (Lambert) against Chandrasekhar's isotropic illumination at marble's
    /// albedo: relative RMS 2.2% at omega 0.999 (Hapke's H); the P1 lobe of share 1 (what the
    /// shading drew for bounced light before) 26%.
    const BOUNCE_SHAPE_TOL: f64 = 0.03;
    const BOUNCE_P1_MIN: f64 = 0.2;

    #[test]
    fn bounced_light_leaves_with_the_isotropic_illumination_shape() {
        const BINS: usize = 100;
        let eta = 1.0;
        let omega = 0.999;
        let mus: Vec<f64> = (0..BINS).map(|i| (i as f64 + 0.5) / BINS as f64).collect();
        let reflected: Vec<f64> = mus
            .iter()
            .map(|&mu| isotropic_reflection(mu, omega))
            .collect();
        // Normalized like a lobe: 2 int I mu dmu = 1.
        let norm = 2.0 * mus.iter().zip(&reflected).map(|(m, r)| m * r).sum::<f64>() / BINS as f64;
        let rms = |lobe: &dyn Fn(f64) -> f64| {
            let e2: f64 = mus
                .iter()
                .zip(&reflected)
                .map(|(&mu, r)| (lobe(mu) / (r / norm) - 1.0).powi(2))
                .sum();
            (e2 / BINS as f64).sqrt()
        };
        // A vertex whose exitance is all the bounce's, shaded with the node lobe of share 1.
        let all_bounce = |mu: f64| {
            ExitLobe::with_bounce(
                [ExitLobe::Node.factor_at(eta, mu, 1.0); 3],
                [0.0; 3],
                [2.0; 3],
            )[0]
        };
        let solved_only = |mu: f64| {
            ExitLobe::with_bounce(
                [ExitLobe::Node.factor_at(eta, mu, 1.0); 3],
                [2.0; 3],
                [2.0; 3],
            )[0]
        };
        let (bounce, p1) = (rms(&all_bounce), rms(&solved_only));
        assert!(bounce < BOUNCE_SHAPE_TOL, "bounce lobe {bounce}");
        assert!(p1 > BOUNCE_P1_MIN, "the case tells the lobes apart: {p1}");

        // A mixed vertex keeps the exitance, per channel; nothing negative or NaN comes out.
        let lambert = exitance(eta, |_| 1.0);
        for (before, after) in [([1.0, 0.5, 0.0], [2.0, 0.5, 1.0]), ([3.0; 3], [1.0; 3])] {
            for c in 0..3 {
                let g = |mu: f64| {
                    ExitLobe::with_bounce([ExitLobe::P1.factor(eta, mu); 3], before, after)[c]
                };
                let m = exitance(eta, g);
                assert!(
                    (m / lambert - 1.0).abs() < QUADRATURE_TOL,
                    "{before:?} {after:?} {c}"
                );
            }
        }
        let odd = ExitLobe::with_bounce([0.5; 3], [f64::NAN, -1.0, 1.0], [1.0, f64::NAN, -2.0]);
        assert!(odd.iter().all(|f| f.is_finite() && *f >= 0.0), "{odd:?}");
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
