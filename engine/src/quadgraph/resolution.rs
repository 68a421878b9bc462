//! `--resolution auto` (DESIGN 5.1, last bullet): the finest lattice spacing chosen from the
//! material and the image, the coarser of
//! - what the material needs: per channel, a few cells per diffusion length `1 / sigma_tr`
//!   (`sigma_tr = sqrt(3 sigma_a sigma_t')`, the scale on which the fluence varies), but never
//!   finer than one transport mean free path `1 / sigma_t'` (below it the diffusion model itself
//!   is wrong, so finer cells buy no accuracy); the finest channel decides; a heterogeneous field
//!   is judged by its range (the finest spacing any of its coefficients needs);
//! - what the image can show: [`PIXELS_PER_NODE`] pixel footprints of the object (a host that
//!   zooms, like the viewer, gives none);
//!
//! clamped to [`AUTO_RESOLUTION`] cells across the object's longest side (the lower end keeps the
//! shape; benches/RESULTS.md: resolution 24, 48 and 64 give the same error against path tracing).
//!
//! ```
//! use translucent::material::{Material, MaterialField};
//! use translucent::quadgraph::resolution::{choose, material_spacing_mm, Bound};
//!
//! let marble = MaterialField::Homogeneous(Material::preset("marble")?);
//! let lo = glam::DVec3::splat(-25.0);
//! let hi = glam::DVec3::splat(25.0);
//! let choice = choose(50.0, material_spacing_mm(&marble, lo, hi), None);
//! assert_eq!(choice.bound, Bound::Material);
//! assert!((24..=48).contains(&choice.resolution));
//! # Ok::<(), translucent::material::MaterialError>(())
//! ```

use glam::DVec3;
use serde::Serialize;

use crate::material::MaterialField;
use crate::scene::Camera;

/// Lattice cells per diffusion length: the fluence falls by e over one diffusion length, and two
/// cells resolve that exponential to the discretization's floor (measured: the error against path
/// tracing is the same at resolution 24, 48 and 64 for marble and skim milk, benches/RESULTS.md).
pub const CELLS_PER_DIFFUSION_LENGTH: f64 = 2.0;

/// Nodes no closer than this many pixel footprints of the object for a single render: the shading
/// interpolates exitance between nodes, so finer nodes than about two pixels are not seen.
pub const PIXELS_PER_NODE: f64 = 2.0;

/// The cells across the longest side `auto` may choose: 24 is the coarsest at which every
/// reference scene keeps its error (benches/RESULTS.md); 128 bounds the bake (~10^6 nodes).
pub const AUTO_RESOLUTION: std::ops::RangeInclusive<u32> = 24..=128;

/// Procedural fields are judged from this many samples per axis of their box.
const PROCEDURAL_SAMPLES: u32 = 16;

/// Which bound decided the spacing.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Bound {
    /// The material's diffusion length or transport mean free path.
    Material,
    /// The pixel footprint of the object.
    Image,
    /// The coarsest lattice that keeps the shape ([`AUTO_RESOLUTION`]'s start).
    Minimum,
    /// The finest lattice `auto` bakes ([`AUTO_RESOLUTION`]'s end).
    Maximum,
}

impl std::fmt::Display for Bound {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::Material => "the material",
            Self::Image => "the pixel footprint",
            Self::Minimum => "the coarsest lattice that keeps the shape",
            Self::Maximum => "the finest lattice auto bakes",
        })
    }
}

/// What `auto` chose.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ResolutionChoice {
    /// Lattice cells across the longest side at the finest level ([`super::BakeParams::resolution`]).
    pub resolution: u32,
    /// The finest level's lattice spacing, mm (longest side / resolution).
    pub spacing_mm: f64,
    /// The bound that decided it.
    pub bound: Bound,
    /// The material's spacing (mm), and the image's where there is one.
    pub material_spacing_mm: f64,
    pub image_spacing_mm: Option<f64>,
}

/// The spacing one channel needs: `max(L_d / CELLS_PER_DIFFUSION_LENGTH, 1 / sigma_t')`, mm
/// (infinite for a channel with no absorption: its fluence has no decay length).
pub fn channel_spacing_mm(sigma_s: f64, sigma_a: f64) -> f64 {
    let sigma_t = sigma_s + sigma_a;
    let sigma_tr = (3.0 * sigma_a * sigma_t).sqrt();
    let diffusion = if sigma_tr > 0.0 {
        1.0 / (sigma_tr * CELLS_PER_DIFFUSION_LENGTH)
    } else {
        f64::INFINITY
    };
    let mean_free_path = if sigma_t > 0.0 {
        1.0 / sigma_t
    } else {
        f64::INFINITY
    };
    diffusion.max(mean_free_path)
}

/// The finest spacing any coefficient of `field` needs in the box (`lo`, `hi`), mm: the
/// homogeneous material's, every voxel of a `.vol` grid, or a procedural pattern sampled at
/// 16^3 points of the box. Infinite when no channel absorbs (then the image or the minimum
/// decides).
pub fn material_spacing_mm(field: &MaterialField, lo: DVec3, hi: DVec3) -> f64 {
    let mut finest = f64::INFINITY;
    let mut consider = |s: [f64; 3], a: [f64; 3]| {
        for c in 0..3 {
            finest = finest.min(channel_spacing_mm(s[c], a[c]));
        }
    };
    match field {
        MaterialField::Homogeneous(m) => consider(m.sigma_s, m.sigma_a),
        MaterialField::Grid { grid, .. } => {
            for cell in grid.data.chunks_exact(crate::material::vol::VOL_CHANNELS) {
                let f = |i: usize| f64::from(cell[i]);
                consider([f(0), f(1), f(2)], [f(3), f(4), f(5)]);
            }
        }
        MaterialField::Procedural { .. } => {
            let n = PROCEDURAL_SAMPLES;
            for i in 0..n.pow(3) {
                let cell = DVec3::new(
                    f64::from(i % n),
                    f64::from((i / n) % n),
                    f64::from(i / (n * n)),
                );
                let c = field.sample(lo + (hi - lo) * (cell + 0.5) / f64::from(n));
                consider(c.sigma_s, c.sigma_a);
            }
        }
    }
    finest
}

/// The image's spacing: [`PIXELS_PER_NODE`] times the size of one pixel at `centre` for `camera`
/// drawing `height` pixels (mm).
pub fn image_spacing_mm(camera: &Camera, height: u32, centre: DVec3) -> f64 {
    let distance = (camera.eye - centre).length();
    let view_height = 2.0 * distance * (camera.fovy_deg.to_radians() * 0.5).tan();
    PIXELS_PER_NODE * view_height / f64::from(height.max(1))
}

/// The rule: the coarser of the material's and the image's spacing, as cells across
/// `longest_mm`, clamped to [`AUTO_RESOLUTION`].
pub fn choose(
    longest_mm: f64,
    material_spacing_mm: f64,
    image_spacing_mm: Option<f64>,
) -> ResolutionChoice {
    let image = image_spacing_mm.filter(|s| s.is_finite() && *s > 0.0);
    let (spacing, mut bound) = match image {
        Some(i) if i > material_spacing_mm => (i, Bound::Image),
        _ => (material_spacing_mm, Bound::Material),
    };
    let wanted = longest_mm / spacing;
    let (lo, hi) = (*AUTO_RESOLUTION.start(), *AUTO_RESOLUTION.end());
    let resolution = if !(wanted.is_finite()) || wanted <= f64::from(lo) {
        bound = Bound::Minimum;
        lo
    } else if wanted > f64::from(hi) {
        bound = Bound::Maximum;
        hi
    } else {
        wanted.ceil() as u32
    };
    ResolutionChoice {
        resolution,
        spacing_mm: longest_mm / f64::from(resolution),
        bound,
        material_spacing_mm,
        image_spacing_mm: image,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::{Material, VolGrid};

    fn preset(name: &str) -> MaterialField {
        MaterialField::Homogeneous(Material::preset(name).expect("preset"))
    }

    const BOX: (DVec3, DVec3) = (DVec3::splat(-25.0), DVec3::splat(25.0));

    #[test]
    fn absorbing_materials_get_finer_lattices_than_clear_ones() {
        let spacing = |name| material_spacing_mm(&preset(name), BOX.0, BOX.1);
        // Marble (blue diffusion length ~4 mm) needs ~2 mm; skin1 and ketchup (diffusion length
        // below a mean free path in blue) stop at their mean free path, ~0.67 mm.
        let marble = spacing("marble");
        let skin = spacing("skin1");
        let ketchup = spacing("ketchup");
        assert!(marble > 1.5 && marble < 2.5, "marble {marble}");
        for (name, s) in [("skin1", skin), ("ketchup", ketchup)] {
            assert!(s > 0.5 && s < 0.8, "{name} {s}");
        }
        let skin1 = Material::preset("skin1").unwrap();
        assert_eq!(
            skin,
            1.0 / skin1.sigma_t()[2],
            "the mean free path floor decides"
        );
        // A 50 mm object: marble gets about the old default's half, skin1 finer than it.
        assert!(choose(50.0, marble, None).resolution < 48);
        assert!(choose(50.0, skin, None).resolution > 48);
    }

    #[test]
    fn the_coarser_bound_wins_and_the_range_clamps() {
        let c = choose(50.0, 0.5, Some(1.0));
        assert_eq!((c.resolution, c.bound), (50, Bound::Image));
        let c = choose(50.0, 1.0, Some(0.5));
        assert_eq!((c.resolution, c.bound), (50, Bound::Material));
        assert!((c.spacing_mm - 1.0).abs() < 1e-12);
        // A 1 mm object needs no more than the minimum, a 10 m one is capped.
        let c = choose(1.0, 0.5, None);
        assert_eq!((c.resolution, c.bound), (24, Bound::Minimum));
        let c = choose(1e4, 0.5, None);
        assert_eq!((c.resolution, c.bound), (128, Bound::Maximum));
        // No absorption anywhere: the minimum.
        assert_eq!(channel_spacing_mm(1.0, 0.0), f64::INFINITY);
        assert_eq!(choose(50.0, f64::INFINITY, None).bound, Bound::Minimum);
    }

    #[test]
    fn a_heterogeneous_field_is_judged_by_its_finest_part() {
        let milk = Material::preset("skimmilk").unwrap();
        let ketchup = Material::preset("ketchup").unwrap();
        let grid = VolGrid::from_fn([2, 2, 2], BOX.0, BOX.1, |p| {
            let m = if p.y > 0.0 { ketchup } else { milk };
            (m.sigma_s, m.sigma_a)
        })
        .unwrap();
        let field = MaterialField::grid(grid, 1.0).unwrap();
        let split = material_spacing_mm(&field, BOX.0, BOX.1);
        let alone = material_spacing_mm(&preset("ketchup"), BOX.0, BOX.1);
        assert!((split - alone).abs() < 1e-6 * alone, "{split} vs {alone}");
        assert!(split < material_spacing_mm(&preset("skimmilk"), BOX.0, BOX.1));
    }

    #[test]
    fn the_image_spacing_is_two_pixels_at_the_object() {
        let camera = Camera {
            eye: DVec3::new(0.0, 0.0, 100.0),
            target: DVec3::ZERO,
            fovy_deg: 90.0,
        };
        // 200 mm seen over 100 px: 2 mm per pixel, two pixels per node.
        let s = image_spacing_mm(&camera, 100, DVec3::ZERO);
        assert!((s - 2.0 * PIXELS_PER_NODE).abs() < 1e-9, "{s}");
    }
}
