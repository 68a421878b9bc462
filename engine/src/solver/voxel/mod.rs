//! The second method (DESIGN section 6; Ozawa et al., "Real-time rendering of heterogeneous
//! translucent materials with dynamic programming"): the shortest optical path through a voxel
//! grid, every frame on the GPU, with no precomputation, so a deforming, fractured or re-meshed
//! object renders without a bake.
//!
//! The passes of a frame, each an object that owns its pipelines and records bind + push +
//! dispatch with only the barriers inside itself, declaring what it reads and writes
//! ([`sync::ResourceUse`]) so a frame graph places the barriers between them:
//! 1. [`VoxelizePass`]: fits the grid to the mesh's bounds (GPU), then solid voxelization by signed
//!    crossings along voxel columns, one vote per axis, majority of three (robust to the Stanford
//!    bunny's holes, see the pass), and the per-voxel medium from a [`MaterialVolume`].
//! 2. [`crate::frame::voxel::ReflectiveShadowMaps`]: per light view (the views of `render::ShadowMaps`), world position,
//!    normal and transmitted irradiance E T_i per texel, and the depth into the shared shadow atlas
//!    (Dachsbacher and Stamminger 2005). Designed to be shared with single scattering (DESIGN 2.8).
//! 3. [`crate::frame::voxel::InjectPass`]: the surface voxels start at n0 = -ln(q), q the transmitted irradiance in the
//!    voxel (paper Eqs. 2-3, per colour channel).
//! 4. [`RelaxPass`]: the shortest optical path over the 26-neighbourhood, edge cost = the per-voxel
//!    coefficient times the edge length: min-plus Jacobi iterations in ping-pong (or sweeps),
//!    stopped on the GPU when nothing changes (indirect dispatch), exactly equal to a CPU Dijkstra
//!    ([`cpu::dijkstra`]).
//! 5. [`ExitPass`]: the radiance volume (a 3D texture) read with trilinear filtering at every
//!    display vertex: a vec4 per vertex, rgb the radiant exitance M leaving into air.
//!
//! **How the paper's L maps to M.** The paper's Eq. 1 gives L = F_t exp(-n) with exp(-n0) = F_t P,
//! the light arriving in a surface voxel, in the units of the light (it fixes no radiance
//! constant). We read exp(-n) as the outgoing partial current J+ of DESIGN section 2, so the
//! shading's L_o = F_t(eta, theta_o) J+ / (pi eta^2) and M = (1 - F_dr) exp(-n): a lit flat surface
//! returns (1 - F_dr) of its transmitted irradiance, all of it where it entered (the paper's model
//! has no absorption but the extinction along the path). The literal Eq. 1 is pi eta^2 times
//! brighter (it is `--radiance paper`'s F_t J+ / pi with J+ = pi exp(-n)).
//!
//! **Beyond the paper** ([`VoxelModel::Diffusion`], measured against path tracing in
//! benches/RESULTS.md, "Voxel method"): the cost along the path is the diffusion's effective
//! transport coefficient sigma_tr = sqrt(3 sigma_a sigma_t'), and the exit is DESIGN section 2's
//! diffusion closed forms along the path: M = q exp(-integral of sigma_tr) G(d) with
//! G(d) = P(d) + (R - P(0)) exp(-d / 4AD) - B(d), R the semi-infinite albedo (a uniformly lit flat
//! face returns R q), P(d) exp(-sigma_tr d) the transmittance of a slab as thick as the path is long
//! (the far face of a lit slab returns T q; for sigma_tr d << 1 it falls as 4D / (2h + d): the 1/d
//! spreading), B(d) exp(-sigma_tr d) = exp(-sigma_t' d) (1 - exp(-d / 4AD)) its unscattered part,
//! which no path through the voxels carries to the eye (without it ketchup's green and blue were
//! 10x and 33x the path-traced exitance), `voxel/exit_volume.comp`, `diffusion_profile.glsl`. (min(R, P(d)) before took
//! P(0) = 1 / (1 + F_dr), equal in all channels, on every lit face at eta > 1: grey, issue 14.)
//! The hard minimum keeps one path per voxel for the three channels (their summed contribution).
//! [`VoxelParams::soft_beta`] > 0 replaces the minimum over neighbours with a log-sum-exp soft
//! minimum, so several paths add.
//!
//! The passes that draw (reflective shadow maps, injection) and the frame composition live in
//! [`crate::frame::voxel`] (they use the shared render passes); this module holds what needs no
//! renderer: the grid, voxelization, relaxation, exit, the material volume and the CPU Dijkstra.
//!
//! ```
//! use translucent::solver::voxel::{VoxelModel, VoxelParams, VoxelResolution};
//! let params = VoxelParams {
//!     resolution: "64".parse::<VoxelResolution>()?,
//!     model: "diffusion".parse::<VoxelModel>()?,
//!     ..VoxelParams::default()
//! };
//! params.validate()?;
//! assert!("3".parse::<VoxelResolution>().is_err()); // below 4 voxels
//! # Ok::<(), translucent::solver::SolverError>(())
//! ```

pub mod cpu;
mod exit;
mod grid;
mod material;
mod mesh;
mod relax;
pub mod sync;
mod voxelize;

pub use exit::{ExitPass, ExitPush, VertexExitPush, PASS_EXIT};
pub use grid::{host_sync, GridDims, GridFrame, VoxelGrid, GRID_FORMAT};
pub use material::MaterialVolume;
pub use mesh::{MeshHandles, MeshIndices, SurfaceMesh, VoxelMesh};
pub use relax::{RelaxControl, RelaxPass, RelaxPush, SweepPush, PASS_RELAX};
pub use voxelize::{
    ClassifyPush, CrossingPush, FitPush, VotePush, VoxelizePass, MESH_INDICES, MESH_VERTICES,
    PASS_VOXELIZE,
};

use std::str::FromStr;

use glam::DVec3;

use super::SolverError;
use crate::material::MaterialField;

/// Which light transport the optical path stands for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum VoxelModel {
    /// The paper: cost sigma_t' per mm, J+ = exp(-n) (`--voxel-model paper`).
    Paper,
    /// Cost sigma_tr per mm, the diffusion closed forms of a slab as thick as the path is long at
    /// the exit (its 1/d spreading); the default: closer to path tracing on every reference but
    /// one (benches/RESULTS.md, "Voxel method").
    #[default]
    Diffusion,
}

impl FromStr for VoxelModel {
    type Err = SolverError;
    fn from_str(s: &str) -> Result<Self, SolverError> {
        match s {
            "paper" => Ok(VoxelModel::Paper),
            "diffusion" => Ok(VoxelModel::Diffusion),
            other => Err(bad_param(
                "voxel model",
                format!("{other:?}: expected paper or diffusion"),
            )),
        }
    }
}

/// How the shortest paths are relaxed on the GPU.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Relaxation {
    /// Jacobi min-plus iterations in ping-pong (every voxel, every iteration).
    #[default]
    Jacobi,
    /// Sweeps slice by slice along +-x, +-y, +-z, in place (hard minimum only).
    Sweep,
}

/// Voxels along the grid's longest side (`--voxels N|auto`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum VoxelResolution {
    Fixed(u32),
    /// From the material's coefficients and the object's size: [`auto_resolution`].
    #[default]
    Auto,
}

impl FromStr for VoxelResolution {
    type Err = SolverError;
    fn from_str(s: &str) -> Result<Self, SolverError> {
        if s == "auto" {
            return Ok(VoxelResolution::Auto);
        }
        let n: u32 = s.parse().map_err(|_| {
            bad_param(
                "voxels",
                format!("{s:?}: expected a number of voxels or auto"),
            )
        })?;
        check_voxels(n)?;
        Ok(VoxelResolution::Fixed(n))
    }
}

/// The fewest and most voxels along the longest side: below 4 nothing is inside a margin; above
/// 256 one RGBA32F volume is 275 MB and the seven of a frame do not fit lavapipe's 2 GiB heap.
pub const VOXELS_RANGE: std::ops::RangeInclusive<u32> = 4..=256;
/// The `auto` rule's bounds: below 32 voxels the geometry of a scan is lost, above 128 the grid
/// costs more than the image shows at the default 512 px (about 4 px per voxel).
pub const AUTO_VOXELS: std::ops::RangeInclusive<u32> = 32..=128;
/// The largest soft temperature factor: a step gains at most tau ln 27 (27 candidates), which
/// must stay below the cheapest edge's cost, so no cycle of the graph can gain.
pub const MAX_SOFT_BETA: f32 = 0.30;

/// Settings of the voxel method.
#[derive(Clone, Debug, PartialEq)]
pub struct VoxelParams {
    pub resolution: VoxelResolution,
    pub model: VoxelModel,
    pub relaxation: Relaxation,
    /// Soft minimum temperature per unit of a voxel's cheapest edge cost: 0 = the hard minimum
    /// (exact shortest paths), up to [`MAX_SOFT_BETA`]. Jacobi only.
    pub soft_beta: f32,
    /// Soft minimum: a change of n below this (in optical depth; 1e-4 = 0.01% of the light) counts
    /// as converged.
    pub soft_tolerance: f32,
    /// Iterations per GPU convergence decision (even: the result stays in the first state image).
    pub block: u32,
    /// The most Jacobi iterations (or sweeps) a frame records; `None`: 2 (nx + ny + nz) Jacobi
    /// iterations, or 16 rounds of 6 sweeps.
    pub max_iterations: Option<u32>,
    /// Axes that vote in the voxelization: 3 (majority of x, y, z columns) or 1 (z columns only).
    pub vote_axes: u32,
    /// Texels across one reflective-shadow-map view; `None`: about 3 texels per voxel.
    pub rsm_tile: Option<u32>,
    /// Cells along the longest side at which a procedural material is sampled into its volume.
    pub material_resolution: u32,
}

impl Default for VoxelParams {
    fn default() -> Self {
        VoxelParams {
            resolution: VoxelResolution::Auto,
            model: VoxelModel::Diffusion,
            relaxation: Relaxation::Jacobi,
            soft_beta: 0.0,
            soft_tolerance: 1e-4,
            block: 8,
            max_iterations: None,
            vote_axes: 3,
            rsm_tile: None,
            material_resolution: 64,
        }
    }
}

/// A [`SolverError::BadParameter`] naming `name`.
pub fn bad_param(name: &'static str, problem: impl Into<String>) -> SolverError {
    SolverError::BadParameter {
        name,
        problem: problem.into(),
    }
}

fn check_voxels(n: u32) -> Result<(), SolverError> {
    if VOXELS_RANGE.contains(&n) {
        Ok(())
    } else {
        Err(bad_param(
            "voxels",
            format!(
                "{n} voxels along the longest side: need {}..={}",
                VOXELS_RANGE.start(),
                VOXELS_RANGE.end()
            ),
        ))
    }
}

impl VoxelParams {
    /// Checks every setting; a bad one is a typed error naming it.
    pub fn validate(&self) -> Result<(), SolverError> {
        if let VoxelResolution::Fixed(n) = self.resolution {
            check_voxels(n)?;
        }
        if !(self.soft_beta.is_finite() && (0.0..=MAX_SOFT_BETA).contains(&self.soft_beta)) {
            return Err(bad_param(
                "soft_beta",
                format!(
                    "{} is outside 0..={MAX_SOFT_BETA} (above it a cycle of the graph can gain light)",
                    self.soft_beta
                ),
            ));
        }
        if self.soft_beta > 0.0 && self.relaxation == Relaxation::Sweep {
            return Err(bad_param(
                "relaxation",
                "the soft minimum needs Jacobi iterations (a sweep sees only one side of a voxel)",
            ));
        }
        if !(self.soft_tolerance.is_finite() && self.soft_tolerance > 0.0) {
            return Err(bad_param(
                "soft_tolerance",
                format!("{} must be finite and > 0", self.soft_tolerance),
            ));
        }
        if self.block == 0 || self.block % 2 != 0 || self.block > 64 {
            return Err(bad_param(
                "block",
                format!(
                    "{} iterations per block: need an even number in 2..=64",
                    self.block
                ),
            ));
        }
        if self.max_iterations == Some(0) {
            return Err(bad_param("max_iterations", "0 iterations relax nothing"));
        }
        if !matches!(self.vote_axes, 1 | 3) {
            return Err(bad_param(
                "vote_axes",
                format!("{}: need 1 (z) or 3 (majority of x, y, z)", self.vote_axes),
            ));
        }
        if let Some(t) = self.rsm_tile {
            if !(16..=4096).contains(&t) {
                return Err(bad_param("rsm_tile", format!("{t} texels: need 16..=4096")));
            }
        }
        if !(1..=256).contains(&self.material_resolution) {
            return Err(bad_param(
                "material_resolution",
                format!("{}: need 1..=256", self.material_resolution),
            ));
        }
        Ok(())
    }
}

/// The per-mm cost coefficient the model puts on the edges for coefficients (sigma_s', sigma_a):
/// sigma_t' (paper) or sigma_tr = sqrt(3 sigma_a sigma_t') (diffusion).
pub fn cost_coefficient(model: VoxelModel, sigma_s: f64, sigma_a: f64) -> f64 {
    let sigma_t = sigma_s + sigma_a;
    match model {
        VoxelModel::Paper => sigma_t,
        VoxelModel::Diffusion => (3.0 * sigma_a * sigma_t).sqrt(),
    }
}

/// `--voxels auto` (DESIGN section 5.1's rule for the QuadGraph, applied to the grid): one unit of
/// optical depth per voxel at most, at the largest cost coefficient of the material anywhere in
/// the box (`lo`, `hi`) (paper: one transport mean free path per voxel; diffusion: one diffusion
/// length), so a step's attenuation exp(-cost) stays above 1/e; clamped to [`AUTO_VOXELS`] (the
/// geometry below, the image above).
pub fn auto_resolution(field: &MaterialField, model: VoxelModel, lo: DVec3, hi: DVec3) -> u32 {
    let longest = (hi - lo).max_element();
    let mut largest: f64 = 0.0;
    let mut consider = |s: [f64; 3], a: [f64; 3]| {
        for c in 0..3 {
            largest = largest.max(cost_coefficient(model, s[c], a[c]));
        }
    };
    match field {
        MaterialField::Homogeneous(m) => consider(m.sigma_s, m.sigma_a),
        MaterialField::Grid { grid, .. } => {
            for cell in grid.data.chunks_exact(6) {
                let f = |i: usize| f64::from(cell[i]);
                consider([f(0), f(1), f(2)], [f(3), f(4), f(5)]);
            }
        }
        MaterialField::Procedural { .. } => {
            // The pattern's extremes over 16^3 cell centres of the box.
            const SAMPLES: u32 = 16;
            for i in 0..SAMPLES.pow(3) {
                let cell = DVec3::new(
                    f64::from(i % SAMPLES),
                    f64::from((i / SAMPLES) % SAMPLES),
                    f64::from(i / (SAMPLES * SAMPLES)),
                );
                let p = lo + (hi - lo) * (cell + 0.5) / f64::from(SAMPLES);
                let c = field.sample(p);
                consider(c.sigma_s, c.sigma_a);
            }
        }
    }
    let wanted = (longest * largest).ceil();
    if wanted.is_finite() {
        (wanted as u32).clamp(*AUTO_VOXELS.start(), *AUTO_VOXELS.end())
    } else {
        *AUTO_VOXELS.end()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::Material;

    #[test]
    fn auto_resolution_follows_the_mean_free_path_within_its_bounds() {
        let marble = MaterialField::Homogeneous(Material::preset("marble").unwrap());
        let (lo, hi) = (DVec3::splat(-10.0), DVec3::splat(10.0));
        // Marble's largest sigma_t' is 3.0071 /mm (blue): 20 mm need 61 voxels.
        assert_eq!(auto_resolution(&marble, VoxelModel::Paper, lo, hi), 61);
        // Its sigma_tr is 0.25 /mm: 5 voxels, raised to the geometry's floor.
        assert_eq!(
            auto_resolution(&marble, VoxelModel::Diffusion, lo, hi),
            *AUTO_VOXELS.start()
        );
        let big = (DVec3::splat(-100.0), DVec3::splat(100.0));
        assert_eq!(
            auto_resolution(&marble, VoxelModel::Paper, big.0, big.1),
            *AUTO_VOXELS.end()
        );
    }

    #[test]
    fn parameters_and_names_are_checked() {
        assert!(VoxelParams::default().validate().is_ok());
        assert_eq!(
            "auto".parse::<VoxelResolution>().unwrap(),
            VoxelResolution::Auto
        );
        assert_eq!(
            "48".parse::<VoxelResolution>().unwrap(),
            VoxelResolution::Fixed(48)
        );
        assert!("3".parse::<VoxelResolution>().is_err());
        assert!("lots".parse::<VoxelResolution>().is_err());
        assert_eq!(
            "diffusion".parse::<VoxelModel>().unwrap(),
            VoxelModel::Diffusion
        );
        assert!("dipole".parse::<VoxelModel>().is_err());
        for bad in [
            VoxelParams {
                soft_beta: 0.5,
                ..VoxelParams::default()
            },
            VoxelParams {
                soft_beta: 0.1,
                relaxation: Relaxation::Sweep,
                ..VoxelParams::default()
            },
            VoxelParams {
                block: 7,
                ..VoxelParams::default()
            },
            VoxelParams {
                vote_axes: 2,
                ..VoxelParams::default()
            },
            VoxelParams {
                soft_tolerance: f32::NAN,
                ..VoxelParams::default()
            },
            VoxelParams {
                resolution: VoxelResolution::Fixed(1000),
                ..VoxelParams::default()
            },
        ] {
            assert!(
                matches!(bad.validate(), Err(SolverError::BadParameter { .. })),
                "{bad:?}"
            );
        }
    }
}
