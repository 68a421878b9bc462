//! Optical coefficients, presets and heterogeneous volumes (DESIGN section 2).
//!
//! Units: millimetres and 1/mm. Per RGB channel a material has the reduced scattering coefficient
//! sigma_s', the absorption coefficient sigma_a and, for the whole object, the relative index of
//! refraction eta = n_inside / n_outside. The diffusion solvers read kappa = 1 / (3 sigma_t') and
//! mu = sigma_a (the paper prints kappa = [3 mu + sigma_s']^-1, a typo).
//!
//! ```
//! use translucent::material::{Material, MaterialField};
//! let marble = Material::preset("marble")?;
//! assert!((marble.kappa()[0] - 1.0 / (3.0 * (2.19 + 0.0021))).abs() < 1e-12);
//! let custom = Material::new([1.0, 1.0, 1.0], [0.01, 0.02, 0.03], 1.4)?;
//! let field = MaterialField::Homogeneous(custom);
//! let c = field.sample(glam::DVec3::ZERO);
//! assert_eq!(c.sigma_a, [0.01, 0.02, 0.03]);
//! assert!(Material::new([1.0, 1.0, 1.0], [-0.1, 0.0, 0.0], 1.3).is_err());
//! # Ok::<(), translucent::material::MaterialError>(())
//! ```

pub mod field;
pub mod fresnel;
pub mod noise;
pub mod presets;
pub mod vol;

use std::path::PathBuf;

pub use field::{Coefficients, MaterialField, Procedural};

/// Which diffusion coefficient D the diffusion methods use (render `--diffusion-coefficient`).
///
/// `Classical`: D = 1 / (3 sigma_t'), DESIGN section 2. `Grosjean`: D = (2 sigma_a + sigma_s') /
/// (3 sigma_t'^2) (Grosjean 1956; d'Eon and Irving 2011, "A quantized-diffusion model", Eq. 7),
/// the same at albedo 1 and up to twice as large as the albedo falls. Both give sigma_tr =
/// sqrt(sigma_a / D). benches/RESULTS.md "Diffusion coefficient at low albedo" measures them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum DiffusionCoefficient {
    /// D = 1 / (3 sigma_t').
    #[default]
    Classical,
    /// D = (2 sigma_a + sigma_s') / (3 sigma_t'^2).
    Grosjean,
}

impl DiffusionCoefficient {
    /// D (mm) of one channel with reduced scattering `sigma_s` and absorption `sigma_a` (1/mm,
    /// sigma_s + sigma_a > 0).
    pub fn d(self, sigma_s: f64, sigma_a: f64) -> f64 {
        let sigma_t = sigma_s + sigma_a;
        match self {
            Self::Classical => 1.0 / (3.0 * sigma_t),
            Self::Grosjean => (2.0 * sigma_a + sigma_s) / (3.0 * sigma_t * sigma_t),
        }
    }

    /// sigma_t' back from D and sigma_a (the GPU reads a heterogeneous level's kappa and mu):
    /// classical 1 / (3 D); Grosjean the positive root of 3 D sigma_t'^2 - sigma_t' - sigma_a = 0.
    pub fn sigma_t(self, d: f64, sigma_a: f64) -> f64 {
        match self {
            Self::Classical => 1.0 / (3.0 * d),
            Self::Grosjean => (1.0 + (1.0 + 12.0 * d * sigma_a).sqrt()) / (6.0 * d),
        }
    }

    /// The name `--diffusion-coefficient` and `--json` use.
    pub fn name(self) -> &'static str {
        match self {
            Self::Classical => "classical",
            Self::Grosjean => "grosjean",
        }
    }
}

impl std::str::FromStr for DiffusionCoefficient {
    type Err = MaterialError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "classical" => Ok(Self::Classical),
            "grosjean" => Ok(Self::Grosjean),
            other => Err(MaterialError::BadParameter {
                name: "diffusion coefficient",
                problem: format!("'{other}' is not classical or grosjean"),
            }),
        }
    }
}
pub use vol::{VolError, VolGrid};

/// Channel names used in error messages.
pub const CHANNELS: [&str; 3] = ["red", "green", "blue"];

/// Bad material input. Every variant names the field (and channel) at fault.
#[derive(Debug, thiserror::Error)]
pub enum MaterialError {
    #[error("material: {field} ({channel} channel) is {value}, not a finite number")]
    NonFinite {
        field: &'static str,
        channel: &'static str,
        value: f64,
    },
    #[error("material: {field} ({channel} channel) is {value}; coefficients cannot be negative")]
    Negative {
        field: &'static str,
        channel: &'static str,
        value: f64,
    },
    #[error(
        "material: sigma_t' = sigma_a + sigma_s' is 0 in the {channel} channel (no extinction: the \
         diffusion coefficient 1/(3 sigma_t') is infinite)"
    )]
    ZeroExtinction { channel: &'static str },
    #[error(
        "material: eta (relative index of refraction) is {0}; it must be finite and within \
         [0.3, 3.5], where the diffuse Fresnel fits hold"
    )]
    BadEta(f64),
    #[error("material: unknown preset '{name}' (known: {known})")]
    UnknownPreset { name: String, known: String },
    #[error("material: parameter {name}: {problem}")]
    BadParameter { name: &'static str, problem: String },
    #[error("material volume {path}: {problem}")]
    Vol {
        path: PathBuf,
        #[source]
        problem: VolError,
    },
}

/// A homogeneous material: per-channel reduced scattering and absorption (1/mm) and eta.
/// Construct with [`Material::new`] or [`Material::preset`]; both validate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    /// Reduced scattering coefficient sigma_s' per channel, 1/mm.
    pub sigma_s: [f64; 3],
    /// Absorption coefficient sigma_a per channel, 1/mm.
    pub sigma_a: [f64; 3],
    /// Relative index of refraction n_inside / n_outside.
    pub eta: f64,
    /// Which diffusion coefficient D [`Material::kappa`] gives (the classical one unless
    /// [`Material::with_diffusion`] says otherwise).
    pub diffusion: DiffusionCoefficient,
}

/// Checks one coefficient triple: finite and non-negative.
pub(crate) fn check_coefficients(field: &'static str, v: [f64; 3]) -> Result<(), MaterialError> {
    for (c, &value) in v.iter().enumerate() {
        let channel = CHANNELS[c];
        if !value.is_finite() {
            return Err(MaterialError::NonFinite {
                field,
                channel,
                value,
            });
        }
        if value < 0.0 {
            return Err(MaterialError::Negative {
                field,
                channel,
                value,
            });
        }
    }
    Ok(())
}

/// Checks a (sigma_s', sigma_a) pair: each valid and sigma_t' > 0 in every channel.
pub(crate) fn check_pair(sigma_s: [f64; 3], sigma_a: [f64; 3]) -> Result<(), MaterialError> {
    check_coefficients("sigma_s'", sigma_s)?;
    check_coefficients("sigma_a", sigma_a)?;
    for c in 0..3 {
        if sigma_s[c] + sigma_a[c] <= 0.0 {
            return Err(MaterialError::ZeroExtinction {
                channel: CHANNELS[c],
            });
        }
    }
    Ok(())
}

/// Checks eta: finite and inside [`fresnel::ETA_RANGE`] (where the F_dr fits hold).
pub fn check_eta(eta: f64) -> Result<(), MaterialError> {
    let (lo, hi) = fresnel::ETA_RANGE;
    if eta.is_finite() && (lo..=hi).contains(&eta) {
        Ok(())
    } else {
        Err(MaterialError::BadEta(eta))
    }
}

impl Material {
    /// A validated material: coefficients finite and >= 0, sigma_t' > 0 per channel, eta > 0.
    pub fn new(sigma_s: [f64; 3], sigma_a: [f64; 3], eta: f64) -> Result<Self, MaterialError> {
        check_pair(sigma_s, sigma_a)?;
        check_eta(eta)?;
        Ok(Self {
            sigma_s,
            sigma_a,
            eta,
            diffusion: DiffusionCoefficient::Classical,
        })
    }

    /// The same material with the diffusion coefficient `diffusion`.
    pub fn with_diffusion(self, diffusion: DiffusionCoefficient) -> Self {
        Self { diffusion, ..self }
    }

    /// A measured material of Jensen et al. 2001 by name (see [`presets::PRESETS`]).
    pub fn preset(name: &str) -> Result<Self, MaterialError> {
        let p = presets::find(name).ok_or_else(|| MaterialError::UnknownPreset {
            name: name.to_string(),
            known: presets::PRESETS
                .iter()
                .map(|p| p.name)
                .collect::<Vec<_>>()
                .join(", "),
        })?;
        Self::new(p.sigma_s, p.sigma_a, p.eta)
    }

    /// Reduced extinction sigma_t' = sigma_a + sigma_s'.
    pub fn sigma_t(&self) -> [f64; 3] {
        std::array::from_fn(|c| self.sigma_a[c] + self.sigma_s[c])
    }

    /// Diffusion coefficient kappa = D in mm: 1 / (3 sigma_t') (classical, the default) or
    /// Grosjean's, as [`Material::diffusion`] says.
    pub fn kappa(&self) -> [f64; 3] {
        self.kappa_with(self.diffusion)
    }

    /// Diffusion coefficient D per channel of the given kind, in mm.
    pub fn kappa_with(&self, kind: DiffusionCoefficient) -> [f64; 3] {
        self.coefficients().kappa_with(kind)
    }

    /// Absorption mu = sigma_a.
    pub fn mu(&self) -> [f64; 3] {
        self.sigma_a
    }

    /// Internal diffuse reflectance F_dr(eta).
    pub fn f_dr(&self) -> f64 {
        fresnel::diffuse_reflectance(self.eta)
    }

    /// Boundary constant A = (1 + F_dr) / (1 - F_dr).
    pub fn a(&self) -> f64 {
        fresnel::boundary_a(self.eta)
    }

    /// The coefficients without eta.
    pub fn coefficients(&self) -> Coefficients {
        Coefficients {
            sigma_s: self.sigma_s,
            sigma_a: self.sigma_a,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    // Hand values written as decimal quotients: a few f64 roundings apart.
    const HAND_TOLERANCE: f64 = 1e-12;

    #[test]
    fn grosjean_coefficient_matches_hand_values() {
        // Ketchup red: sigma_s' 0.18, sigma_a 0.061 (sigma_t' 0.241): classical 1 / 0.723 =
        // 1.383126 mm, Grosjean (0.122 + 0.18) / (3 * 0.058081) = 0.302 / 0.174243 = 1.733212 mm.
        let (s, a) = (0.18, 0.061);
        let classical = DiffusionCoefficient::Classical.d(s, a);
        let grosjean = DiffusionCoefficient::Grosjean.d(s, a);
        assert!((classical - 1.0 / 0.723).abs() < HAND_TOLERANCE);
        assert!((grosjean - 0.302 / 0.174243).abs() < HAND_TOLERANCE);
        assert!((grosjean - 1.733_212).abs() < 1e-6, "{grosjean}");
        // No absorption: both are 1 / (3 sigma_t'); no scattering: Grosjean is twice classical.
        assert_eq!(
            DiffusionCoefficient::Grosjean.d(2.0, 0.0),
            DiffusionCoefficient::Classical.d(2.0, 0.0)
        );
        let pure_absorber = DiffusionCoefficient::Grosjean.d(0.0, 1.5);
        assert!(
            (pure_absorber - 2.0 * DiffusionCoefficient::Classical.d(0.0, 1.5)).abs()
                < HAND_TOLERANCE
        );
        // sigma_t' comes back from (D, sigma_a) for both kinds.
        for kind in [
            DiffusionCoefficient::Classical,
            DiffusionCoefficient::Grosjean,
        ] {
            let t = kind.sigma_t(kind.d(s, a), a);
            assert!((t - 0.241).abs() < HAND_TOLERANCE, "{kind:?}: {t}");
            assert_eq!(kind.name().parse::<DiffusionCoefficient>().unwrap(), kind);
        }
        assert!("quantized".parse::<DiffusionCoefficient>().is_err());
        let m = Material::preset("ketchup").unwrap();
        assert_eq!(m.kappa_with(DiffusionCoefficient::Classical), m.kappa());
        assert!(m.kappa_with(DiffusionCoefficient::Grosjean)[2] > 1.9 * m.kappa()[2]);
        let g = m.with_diffusion(DiffusionCoefficient::Grosjean);
        assert_eq!(g.kappa(), m.kappa_with(DiffusionCoefficient::Grosjean));
        let field = MaterialField::Homogeneous(g);
        assert_eq!(field.diffusion(), DiffusionCoefficient::Grosjean);
        let p = glam::DVec3::ZERO;
        assert_eq!(field.kappa_at(p), g.kappa());
        let back = field.with_diffusion(DiffusionCoefficient::Classical);
        assert_eq!(back.kappa_at(p), m.kappa());
    }

    #[test]
    fn derived_quantities() {
        let m = Material::preset("skimmilk").unwrap();
        assert_eq!(m.sigma_s, [0.7, 1.22, 1.9]);
        assert!((m.kappa()[0] - 1.0 / (3.0 * 0.7014)).abs() < 1e-15);
        assert_eq!(m.mu(), m.sigma_a);
        assert!((m.a() - (1.0 + m.f_dr()) / (1.0 - m.f_dr())).abs() < 1e-15);
        assert!(
            Material::preset("Marble").is_ok(),
            "preset names are case-insensitive"
        );
    }

    #[test]
    fn bad_materials_are_typed_errors_naming_field_and_channel() {
        let ok = [1.0; 3];
        let e = Material::new([1.0, f64::NAN, 1.0], ok, 1.3).unwrap_err();
        assert!(
            matches!(
                e,
                MaterialError::NonFinite {
                    field: "sigma_s'",
                    channel: "green",
                    ..
                }
            ),
            "{e}"
        );
        let e = Material::new(ok, [0.0, 0.0, f64::INFINITY], 1.3).unwrap_err();
        assert!(
            matches!(
                e,
                MaterialError::NonFinite {
                    field: "sigma_a",
                    channel: "blue",
                    ..
                }
            ),
            "{e}"
        );
        let e = Material::new(ok, [-1e-9, 0.0, 0.0], 1.3).unwrap_err();
        assert!(
            matches!(
                e,
                MaterialError::Negative {
                    field: "sigma_a",
                    channel: "red",
                    ..
                }
            ),
            "{e}"
        );
        let e = Material::new([1.0, 0.0, 1.0], [0.1, 0.0, 0.1], 1.3).unwrap_err();
        assert!(
            matches!(e, MaterialError::ZeroExtinction { channel: "green" }),
            "{e}"
        );
        for eta in [0.0, -1.3, f64::NAN, f64::INFINITY, 0.1, 5.0] {
            assert!(matches!(
                Material::new(ok, ok, eta),
                Err(MaterialError::BadEta(_))
            ));
        }
        let e = Material::preset("unobtainium").unwrap_err();
        assert!(e.to_string().contains("marble"), "{e}");
    }
}
