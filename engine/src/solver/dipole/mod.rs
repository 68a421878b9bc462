//! The third method: hierarchical boundary elements with the dipole BSSRDF (Mertens, Kautz,
//! Bekaert, Seidel and Van Reeth 2003; `../shared/papers/mertens2003-hierarchical-dipole.md`).
//!
//! The exitance at a surface point is the surface integral of the transmitted irradiance times the
//! dipole's diffuse reflectance R_d (the paper's Eq. 4). The surface is the display mesh; a
//! face-cluster hierarchy over its triangles lets distant parts interact through clusters, so the
//! integral costs O(T log T) links instead of T^2 form factors:
//!
//! - [`profile`]: R_d per channel with the boundary constant and exit query of DESIGN 2 / 2.6.
//! - [`form_factor`]: the semi-analytic point-to-polygon form factor (section 4), point sampling,
//!   and a slow reference cubature.
//! - [`hierarchy`]: the face-cluster tree (section 5.1.1), built once per topology, refitted on
//!   deformation; [`cache`] keeps it on disk.
//! - [`links`]: the refinement oracle (section 5.2), link building, render mode (pull, gather, push)
//!   and on-the-fly mode on the CPU; [`incremental`]: incremental mode (section 5.5).
//! - [`material`]: homogeneous materials; heterogeneous ones refused or "texture only".
//! - [`irradiance`]: per-leaf transmitted irradiance from a [`crate::scene::Scene`] on the CPU.
//! - [`gpu`]: [`DipoleGatherPass`], the per-frame link evaluation on the GPU.
//!
//! Output contract (for the shared shading): per display vertex, the rgb radiant exitance M
//! (W/mm^2 leaving into air, integrated over the hemisphere), as one vec4 per vertex on the GPU.
//! For DESIGN's `physical` radiance, L_o = F_t(eta, theta_o) M / (pi eta^2 (1 - F_dr)), which
//! integrates to M; today's mesh pass, which shades F_t J+ / (pi eta^2), draws it with J+ = M / (1 - F_dr).
//!
//! ```
//! use translucent::material::Material;
//! use translucent::mesh::shapes::Shape;
//! use translucent::solver::dipole::{self, BoundaryModel, DipoleMaterial, FaceClusterHierarchy, LinkParams, LinkSet};
//! use translucent::scene::Scene;
//!
//! let mesh = Shape::Sphere { radius: 10.0 }.triangulate(16); // normalized, mm
//! let (tree, _) = FaceClusterHierarchy::build(&mesh)?; // once per topology (or dipole::cache)
//! let material = DipoleMaterial::homogeneous(&Material::preset("marble")?, BoundaryModel::Moments);
//! let (links, stats) = LinkSet::build(&tree, &material.profile, &LinkParams::default());
//! let scene = Scene { lights: vec!["dir:0,-1,0:3,3,3".parse()?], ..Default::default() };
//! let irradiance = dipole::irradiance::leaf_irradiance(&tree, &scene, material.base.eta, None)?;
//! let m = dipole::links::render(&tree, &material.profile, &links, &irradiance, material.modulation.as_deref());
//! let top = mesh.positions.iter().position(|p| p.y > 9.99).unwrap();
//! assert!(m.vertex[top][0] > 0.0); // lit from above
//! println!("{} links, {:.1} per triangle", stats.links, stats.links as f64 / tree.leaf_count() as f64);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod cache;
pub mod form_factor;
pub mod gpu;
pub mod hierarchy;
pub mod incremental;
pub mod irradiance;
pub mod links;
pub mod material;
pub mod profile;

use std::path::PathBuf;

pub use gpu::DipoleGatherPass;
pub use hierarchy::{FaceClusterHierarchy, HierarchyStats, NodeGeometry, RefitReport};
pub use incremental::{IncrementalLinks, StepReport};
pub use links::{Exitance, Link, LinkParams, LinkSet, LinkStats, NearField, ReceiverCriterion};
pub use material::{DipoleMaterial, HeterogeneousPolicy};
pub use profile::{BoundaryModel, DipoleProfile};

/// Failures of the dipole method, each naming the problem (and the file, where there is one).
#[derive(Debug, thiserror::Error)]
pub enum DipoleError {
    #[error("dipole: {0}")]
    Invalid(String),
    #[error("dipole: parameter {name}: {problem}")]
    Parameter { name: &'static str, problem: String },
    #[error(
        "dipole: the material is {kind}; the dipole BSSRDF models one homogeneous material. Use \
         --method quadgraph (or voxel) for heterogeneous materials, or the dipole's texture-only \
         mode (the field modulates the exitance like a texture; light is transported through the \
         field's mean)"
    )]
    Heterogeneous { kind: &'static str },
    #[error(
        "dipole: {links} links do not fit the GPU gather: it binds at most {windows} windows of \
         {window} links ({window_bytes} bytes each, the device's maxStorageBufferRange is \
         {max_range} bytes), {max_links} links in all. Raise --link-tolerance (fewer, coarser links) \
         or use a coarser mesh"
    )]
    TooManyLinks {
        links: usize,
        windows: usize,
        window: usize,
        window_bytes: u64,
        max_range: u32,
        max_links: usize,
    },
    #[error("dipole: {0}")]
    Mesh(#[from] crate::mesh::MeshError),
    #[error("dipole: {0}")]
    Material(#[from] crate::material::MaterialError),
    #[error("dipole: scene: {0}")]
    Scene(#[source] Box<crate::solver::SolverError>),
    #[error("dipole: {0}")]
    SceneDesc(#[from] crate::scene::SceneError),
    #[error("dipole: {0}")]
    Vk(#[from] crate::vk::VkError),
    #[error("dipole: {0}")]
    Shader(#[from] crate::shader::ShaderError),
    /// The I/O error is the [`std::error::Error::source`].
    #[error("dipole cache {path}: input/output error")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("dipole cache {path}: not a dipole hierarchy cache file (bad magic bytes)")]
    CacheMagic { path: PathBuf },
    #[error("dipole cache {path}: format version {found}, this build reads version {expected}")]
    CacheVersion {
        path: PathBuf,
        found: u32,
        expected: u32,
    },
    #[error("dipole cache {path}: truncated ({len} bytes, expected {expected})")]
    CacheTruncated {
        path: PathBuf,
        len: u64,
        expected: u64,
    },
    #[error("dipole cache {path}: checksum mismatch (file corrupt)")]
    CacheChecksum { path: PathBuf },
    #[error("dipole cache {path}: stale (made for another mesh)")]
    CacheStale { path: PathBuf },
    #[error("dipole cache {path}: inconsistent content: {reason}")]
    CacheContent { path: PathBuf, reason: String },
}

impl From<crate::solver::SolverError> for DipoleError {
    fn from(e: crate::solver::SolverError) -> Self {
        DipoleError::Scene(Box::new(e))
    }
}
