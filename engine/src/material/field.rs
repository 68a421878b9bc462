//! Heterogeneous materials: (sigma_s', sigma_a) per channel at a point of the object (mm, in the
//! normalized object frame). eta is one number for the whole object (it sets the boundary condition).
//!
//! ```
//! use glam::DVec3;
//! use translucent::material::{Material, MaterialField, Procedural};
//! let marble = Material::preset("marble")?.coefficients();
//! let jade = Material::new([0.9, 1.2, 1.0], [0.02, 0.004, 0.015], 1.3)?.coefficients();
//! let split = MaterialField::procedural(
//!     Procedural::Split { normal: DVec3::Y, offset: 0.0, below: marble, above: jade },
//!     1.3,
//! )?;
//! assert_eq!(split.sample(DVec3::new(0.0, -1.0, 0.0)), marble);
//! assert_eq!(split.sample(DVec3::new(0.0, 1.0, 0.0)), jade);
//! # Ok::<(), translucent::material::MaterialError>(())
//! ```
//!
//! The sampling functions are plain arithmetic over an enum (no trait objects), so each arm ports to
//! one GLSL function with the same parameters.

use std::f64::consts::PI;

use glam::DVec3;

use super::{check_eta, check_pair, noise, DiffusionCoefficient, Material, MaterialError, VolGrid};

/// Optical coefficients at a point (1/mm).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Coefficients {
    /// Reduced scattering sigma_s'.
    pub sigma_s: [f64; 3],
    /// Absorption sigma_a.
    pub sigma_a: [f64; 3],
}

impl Coefficients {
    /// Validated coefficients (finite, >= 0, sigma_t' > 0 per channel).
    pub fn new(sigma_s: [f64; 3], sigma_a: [f64; 3]) -> Result<Self, MaterialError> {
        check_pair(sigma_s, sigma_a)?;
        Ok(Self { sigma_s, sigma_a })
    }

    /// Diffusion coefficient kappa = 1 / (3 (sigma_a + sigma_s')).
    pub fn kappa(&self) -> [f64; 3] {
        self.kappa_with(DiffusionCoefficient::Classical)
    }

    /// Diffusion coefficient D per channel of the given kind (mm).
    pub fn kappa_with(&self, kind: DiffusionCoefficient) -> [f64; 3] {
        std::array::from_fn(|c| kind.d(self.sigma_s[c], self.sigma_a[c]))
    }

    /// Absorption mu = sigma_a.
    pub fn mu(&self) -> [f64; 3] {
        self.sigma_a
    }

    /// Linear blend `a (1 - t) + b t`; a convex blend of valid coefficients is valid.
    pub fn mix(a: &Self, b: &Self, t: f64) -> Self {
        let t = t.clamp(0.0, 1.0);
        Self {
            sigma_s: std::array::from_fn(|c| a.sigma_s[c] + (b.sigma_s[c] - a.sigma_s[c]) * t),
            sigma_a: std::array::from_fn(|c| a.sigma_a[c] + (b.sigma_a[c] - a.sigma_a[c]) * t),
        }
    }
}

/// Procedural patterns (lengths in mm).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Procedural {
    /// Marble veins: sin(x / scale + turbulence) sharpened into thin veins (Perlin 1985).
    VeinedMarble {
        base: Coefficients,
        vein: Coefficients,
        /// Distance between veins, about pi * scale mm.
        scale_mm: f64,
        /// Octaves of turbulence (1..=8 is sensible).
        octaves: u32,
        seed: u32,
    },
    /// Agate: concentric bands around the Y axis, warped by gradient noise.
    Agate {
        a: Coefficients,
        b: Coefficients,
        /// Band period in mm.
        band_mm: f64,
        /// Warp amplitude in band periods.
        warp: f64,
        seed: u32,
    },
    /// Two materials split by the plane `normal . p = offset`.
    Split {
        normal: DVec3,
        offset: f64,
        below: Coefficients,
        above: Coefficients,
    },
}

/// What the solvers sample: a material as a function of position.
#[derive(Clone, Debug)]
pub enum MaterialField {
    Homogeneous(Material),
    Procedural {
        pattern: Procedural,
        eta: f64,
        /// Which D [`MaterialField::kappa_at`] gives.
        diffusion: DiffusionCoefficient,
    },
    /// A `.vol` grid (6 channels) sampled trilinearly; outside its box the border value repeats.
    Grid {
        grid: VolGrid,
        eta: f64,
        /// Which D [`MaterialField::kappa_at`] gives.
        diffusion: DiffusionCoefficient,
    },
}

impl MaterialField {
    /// A validated procedural field.
    pub fn procedural(pattern: Procedural, eta: f64) -> Result<Self, MaterialError> {
        check_eta(eta)?;
        let positive = |name: &'static str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(MaterialError::BadParameter {
                    name,
                    problem: format!("{v} must be finite and > 0"),
                })
            }
        };
        match pattern {
            Procedural::VeinedMarble {
                base,
                vein,
                scale_mm,
                ..
            } => {
                check_pair(base.sigma_s, base.sigma_a)?;
                check_pair(vein.sigma_s, vein.sigma_a)?;
                positive("scale_mm", scale_mm)?;
            }
            Procedural::Agate {
                a,
                b,
                band_mm,
                warp,
                ..
            } => {
                check_pair(a.sigma_s, a.sigma_a)?;
                check_pair(b.sigma_s, b.sigma_a)?;
                positive("band_mm", band_mm)?;
                if !warp.is_finite() {
                    return Err(MaterialError::BadParameter {
                        name: "warp",
                        problem: format!("{warp} is not finite"),
                    });
                }
            }
            Procedural::Split {
                normal,
                offset,
                below,
                above,
            } => {
                check_pair(below.sigma_s, below.sigma_a)?;
                check_pair(above.sigma_s, above.sigma_a)?;
                if !(normal.is_finite() && normal.length() > 0.0 && offset.is_finite()) {
                    return Err(MaterialError::BadParameter {
                        name: "normal",
                        problem: format!("plane {normal} . p = {offset} is not a valid plane"),
                    });
                }
            }
        }
        Ok(Self::Procedural {
            pattern,
            eta,
            diffusion: DiffusionCoefficient::Classical,
        })
    }

    /// A validated grid field.
    pub fn grid(grid: VolGrid, eta: f64) -> Result<Self, MaterialError> {
        check_eta(eta)?;
        Ok(Self::Grid {
            grid,
            eta,
            diffusion: DiffusionCoefficient::Classical,
        })
    }

    /// The object's relative index of refraction.
    pub fn eta(&self) -> f64 {
        match self {
            Self::Homogeneous(m) => m.eta,
            Self::Procedural { eta, .. } | Self::Grid { eta, .. } => *eta,
        }
    }

    /// Which diffusion coefficient D the diffusion methods use for this material (classical unless
    /// [`MaterialField::with_diffusion`] set another).
    pub fn diffusion(&self) -> DiffusionCoefficient {
        match self {
            Self::Homogeneous(m) => m.diffusion,
            Self::Procedural { diffusion, .. } | Self::Grid { diffusion, .. } => *diffusion,
        }
    }

    /// The same field with the diffusion coefficient `kind`.
    pub fn with_diffusion(self, kind: DiffusionCoefficient) -> Self {
        match self {
            Self::Homogeneous(m) => Self::Homogeneous(m.with_diffusion(kind)),
            Self::Procedural { pattern, eta, .. } => Self::Procedural {
                pattern,
                eta,
                diffusion: kind,
            },
            Self::Grid { grid, eta, .. } => Self::Grid {
                grid,
                eta,
                diffusion: kind,
            },
        }
    }

    /// The diffusion coefficient D at `p` (mm), of the field's [`MaterialField::diffusion`].
    pub fn kappa_at(&self, p: DVec3) -> [f64; 3] {
        self.sample(p).kappa_with(self.diffusion())
    }

    /// Whether the coefficients are the same everywhere.
    pub fn is_homogeneous(&self) -> bool {
        matches!(self, Self::Homogeneous(_))
    }

    /// Coefficients at `p` (mm).
    pub fn sample(&self, p: DVec3) -> Coefficients {
        match self {
            Self::Homogeneous(m) => m.coefficients(),
            Self::Procedural { pattern, .. } => sample_procedural(pattern, p),
            Self::Grid { grid, .. } => grid.sample(p),
        }
    }
}

/// One procedural pattern at `p`.
pub fn sample_procedural(pattern: &Procedural, p: DVec3) -> Coefficients {
    match *pattern {
        Procedural::VeinedMarble {
            base,
            vein,
            scale_mm,
            octaves,
            seed,
        } => {
            let q = p / scale_mm;
            let t = noise::turbulence(q * 0.5, octaves, seed);
            let s = 0.5 + 0.5 * (q.x + q.y * 0.3 + 6.0 * t).sin();
            // Raising to a power keeps only the crests: veins thin compared to their spacing.
            Coefficients::mix(&base, &vein, s.powi(8))
        }
        Procedural::Agate {
            a,
            b,
            band_mm,
            warp,
            seed,
        } => {
            let r = (p.x * p.x + p.z * p.z).sqrt() / band_mm;
            let w = warp * noise::gradient(p / (4.0 * band_mm), seed);
            let t = 0.5 + 0.5 * (2.0 * PI * (r + w)).cos();
            Coefficients::mix(&a, &b, t)
        }
        Procedural::Split {
            normal,
            offset,
            below,
            above,
        } => {
            if normal.dot(p) < offset {
                below
            } else {
                above
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn procedural_fields_stay_between_their_materials_and_vary() {
        let a = Material::preset("marble").unwrap().coefficients();
        let b = Material::preset("ketchup").unwrap().coefficients();
        let patterns = [
            Procedural::VeinedMarble {
                base: a,
                vein: b,
                scale_mm: 2.0,
                octaves: 5,
                seed: 1,
            },
            Procedural::Agate {
                a,
                b,
                band_mm: 1.5,
                warp: 0.7,
                seed: 2,
            },
            Procedural::Split {
                normal: DVec3::X,
                offset: 0.2,
                below: a,
                above: b,
            },
        ];
        for pattern in patterns {
            let field = MaterialField::procedural(pattern, 1.3).unwrap();
            let (mut lo, mut hi) = (f64::MAX, f64::MIN);
            for k in 0..4000 {
                let p = DVec3::new((k % 20) as f64, ((k / 20) % 20) as f64, (k / 400) as f64) * 0.7
                    - DVec3::splat(7.0);
                let c = field.sample(p);
                check_pair(c.sigma_s, c.sigma_a).unwrap();
                for ch in 0..3 {
                    let (x, y) = (
                        a.sigma_a[ch].min(b.sigma_a[ch]),
                        a.sigma_a[ch].max(b.sigma_a[ch]),
                    );
                    assert!(c.sigma_a[ch] >= x - 1e-15 && c.sigma_a[ch] <= y + 1e-15);
                }
                lo = lo.min(c.sigma_a[1]);
                hi = hi.max(c.sigma_a[1]);
            }
            assert!(
                hi - lo > 0.5 * (b.sigma_a[1] - a.sigma_a[1]),
                "{pattern:?} barely varies"
            );
        }
        let bad = Procedural::Split {
            normal: DVec3::ZERO,
            offset: 0.0,
            below: a,
            above: b,
        };
        assert!(MaterialField::procedural(bad, 1.3).is_err());
        let bad = Procedural::Agate {
            a,
            b,
            band_mm: 0.0,
            warp: 0.0,
            seed: 0,
        };
        assert!(MaterialField::procedural(bad, 1.3).is_err());
    }
}
