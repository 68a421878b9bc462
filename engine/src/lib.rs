//! # Translucent
//!
//! Real-time rendering of heterogeneous translucent objects (marble, jade, wax, milk, skin) on Vulkan.
//! Every frame solves the light diffusion equation inside the object on a volumetric graph (the
//! QuadGraph of Wang et al. 2010), so lights, materials and shape can change at run time.
//!
//! The pieces, in data-flow order:
//! - [`mesh`]: triangle meshes (OBJ, procedural shapes), validation, inside/outside, ray queries.
//! - [`tet`]: tetrahedral meshing by isosurface stuffing.
//! - [`quadgraph`]: the QuadGraph bake (nodes, levels, Shepard weights, packing, cache).
//! - [`material`]: optical coefficients, presets, heterogeneous volumes.
//! - [`solver`]: the diffusion solvers (f64 CPU reference, GPU).
//! - [`vk`]: a thin owning layer over ash that knows nothing about translucency.
//! - [`shader`]: embedded SPIR-V and its reflection.
//! - [`render`]: passes (shadow map, shading, tone mapping, capture).
//! - [`object`]: [`TranslucentObject`], the whole frame recorded into a host's command buffer,
//!   skipping what the scene's changes do not need.

pub mod limits;
pub mod material;
pub mod mesh;
pub mod object;
pub mod quadgraph;
pub mod render;
pub mod shader;
pub mod solver;
pub mod tet;
pub mod vk;

pub use object::{
    FrameReport, ObjectParams, RecordCtx, SkipReason, TargetImage, Targets, TranslucentObject,
};
pub use quadgraph::graph::{GraphLevel, NodeKind, QuadGraph};

/// Every error the library returns. Each module has its own typed error; this wraps them.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error(transparent)]
    Vk(#[from] vk::VkError),
    #[error(transparent)]
    Mesh(#[from] mesh::MeshError),
    #[error(transparent)]
    Bake(#[from] quadgraph::BakeError),
    #[error(transparent)]
    Material(#[from] material::MaterialError),
    #[error(transparent)]
    Solver(#[from] solver::SolverError),
    #[error(transparent)]
    Shader(#[from] shader::ShaderError),
    #[error(transparent)]
    Render(#[from] render::RenderError),
}

/// Result with the crate's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;
