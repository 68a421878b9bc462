//! Live edits of a [`GpuFrame`] without a re-bake (paper section 6.4; DESIGN sections 4 and 5):
//! a new material (homogeneous or heterogeneous) and a deformation of the object. The per-node
//! weights, node positions and normals follow on the GPU.
//!
//! SKELETON: the signatures are the contract between the object API (`TranslucentObject`) and the
//! GPU edit passes; the bodies are being written (branch `gpuedit`).

use glam::Mat4;

use super::{GpuFrame, SolverError};
use crate::material::MaterialField;
use crate::render::GpuMesh;
use crate::vk::Context;
use crate::{Error, QuadGraph};

/// A deformation of the object, in its normalized frame (mm). Applied to the rest pose the bake
/// produced (not accumulated): `deform(Identity)` restores the baked shape.
#[derive(Clone, Debug, PartialEq)]
pub enum Deformation {
    /// The baked shape.
    Identity,
    /// An affine map of every position (normals by its inverse transpose). Must be invertible.
    Affine(Mat4),
    /// A twist about the +Y axis through the origin: `radians_per_mm * y` radians at height y.
    Twist { radians_per_mm: f32 },
    /// New positions of every level's tetrahedron vertices (outer index: level, coarsest first).
    TetPositions(Vec<Vec<[f32; 3]>>),
}

impl GpuFrame {
    /// Replaces the material: per-node kappa and mu (sampled from `field` at the rest-pose node
    /// positions) and the weights derived from them. The next solve warm-starts.
    pub fn set_material(
        &mut self,
        _ctx: &Context,
        _graph: &QuadGraph,
        _field: &MaterialField,
    ) -> Result<(), Error> {
        Err(SolverError::Invalid("set_material: not built yet".into()).into())
    }

    /// Deforms the object: node positions, normals and weights of every level, and the vertices
    /// of `meshes` (the display mesh and the shadow caster), recomputed on the GPU.
    pub fn deform(
        &mut self,
        _ctx: &Context,
        _graph: &QuadGraph,
        _deformation: &Deformation,
        _meshes: &[&GpuMesh],
    ) -> Result<(), Error> {
        Err(SolverError::Invalid("deform: not built yet".into()).into())
    }
}
