//! The material options of `render` (DESIGN section 8): a measured preset, explicit coefficients, a
//! procedural heterogeneous pattern, or a `.vol` grid.

use std::path::PathBuf;

use anyhow::{bail, Context as _};
use glam::DVec3;
use translucent::material::presets::{self, PRESETS};
use translucent::material::{Coefficients, Material, MaterialField, Procedural, VolGrid};

/// The procedural patterns `--material` accepts besides the measured presets.
pub const PROCEDURAL: [&str; 3] = ["veined-marble", "agate", "split"];

#[derive(clap::Args, Debug, Clone)]
pub struct MaterialArgs {
    /// Default: skimmilk. A measured preset (apple, chicken1, chicken2, cream, ketchup, marble, potato, skimmilk,
    /// skin1, skin2, spectralon, wholemilk) or a procedural pattern (veined-marble, agate, split).
    #[arg(long, conflicts_with_all = ["sigma_a", "sigma_s", "volume"])]
    pub material: Option<String>,
    /// Absorption sigma_a R,G,B in 1/mm (with --sigma-s).
    #[arg(
        long,
        value_name = "R,G,B",
        requires = "sigma_s",
        allow_hyphen_values = true
    )]
    pub sigma_a: Option<String>,
    /// Reduced scattering sigma_s' R,G,B in 1/mm (with --sigma-a).
    #[arg(
        long,
        value_name = "R,G,B",
        requires = "sigma_a",
        allow_hyphen_values = true
    )]
    pub sigma_s: Option<String>,
    /// Relative index of refraction n_inside / n_outside (default: the preset's, else 1.3).
    #[arg(long, allow_negative_numbers = true)]
    pub eta: Option<f64>,
    /// A heterogeneous volume: `.vol` grid with sigma_s' RGB and sigma_a RGB per voxel (1/mm).
    #[arg(long, value_name = "FILE.vol", conflicts_with_all = ["sigma_a", "sigma_s"])]
    pub volume: Option<PathBuf>,
}

fn rgb(option: &str, text: &str) -> anyhow::Result<[f64; 3]> {
    let values: Vec<f64> = text
        .split(',')
        .map(|v| {
            v.trim()
                .parse::<f64>()
                .with_context(|| format!("{option} {text:?}: {v:?} is not a number"))
        })
        .collect::<anyhow::Result<_>>()?;
    values.try_into().map_err(|v: Vec<f64>| {
        anyhow::anyhow!("{option} {text:?}: expected 3 numbers, got {}", v.len())
    })
}

fn preset(name: &str) -> anyhow::Result<Coefficients> {
    let p = presets::find(name).with_context(|| format!("no preset {name:?}"))?;
    Ok(Coefficients::new(p.sigma_s, p.sigma_a)?)
}

/// The procedural patterns, scaled to an object of longest side `size_mm`.
fn procedural(name: &str, size_mm: f64) -> anyhow::Result<Procedural> {
    Ok(match name {
        // White marble with thin, more absorbing grey-green veins.
        "veined-marble" => Procedural::VeinedMarble {
            base: preset("marble")?,
            vein: Coefficients::new([1.2, 1.4, 1.6], [0.08, 0.06, 0.07])?,
            scale_mm: size_mm / 12.0,
            octaves: 5,
            seed: 7,
        },
        // Bands of a milky and a reddish translucent stone around the Y axis.
        "agate" => Procedural::Agate {
            a: preset("wholemilk")?,
            b: Coefficients::new([0.9, 0.5, 0.4], [0.01, 0.09, 0.2])?,
            band_mm: size_mm / 10.0,
            warp: 0.6,
            seed: 3,
        },
        // Skim milk below the plane y = 0, skin above: a 1e1-1e2 contrast in absorption.
        "split" => Procedural::Split {
            normal: DVec3::Y,
            offset: 0.0,
            below: preset("skimmilk")?,
            above: preset("skin1")?,
        },
        other => bail!("unknown procedural pattern {other:?}"),
    })
}

impl MaterialArgs {
    /// The material field (`default` when nothing is given).
    /// Whether the material varies in space (`--volume`, or a procedural `--material`).
    pub fn is_heterogeneous(&self) -> bool {
        self.volume.is_some()
            || (self.sigma_a.is_none()
                && self
                    .material
                    .as_deref()
                    .is_some_and(|m| PROCEDURAL.contains(&m)))
    }

    pub fn field(&self, size_mm: f64, default: &str) -> anyhow::Result<MaterialField> {
        if let Some(path) = &self.volume {
            let grid = VolGrid::read(path)?;
            return Ok(MaterialField::grid(grid, self.eta.unwrap_or(1.3))?);
        }
        if let (Some(a), Some(s)) = (&self.sigma_a, &self.sigma_s) {
            let material = Material::new(
                rgb("--sigma-s", s)?,
                rgb("--sigma-a", a)?,
                self.eta.unwrap_or(1.3),
            )
            .context("--sigma-a/--sigma-s/--eta")?;
            return Ok(MaterialField::Homogeneous(material));
        }
        let name = self.material.as_deref().unwrap_or(default);
        if PROCEDURAL.contains(&name) {
            let field =
                MaterialField::procedural(procedural(name, size_mm)?, self.eta.unwrap_or(1.3))
                    .with_context(|| format!("--material {name}"))?;
            return Ok(field);
        }
        if presets::find(name).is_none() {
            let known: Vec<&str> = PRESETS.iter().map(|p| p.name).chain(PROCEDURAL).collect();
            bail!("--material {name:?}: unknown (known: {})", known.join(", "));
        }
        let mut material = Material::preset(name)?;
        if let Some(eta) = self.eta {
            material = Material::new(material.sigma_s, material.sigma_a, eta).context("--eta")?;
        }
        Ok(MaterialField::Homogeneous(material))
    }
}
