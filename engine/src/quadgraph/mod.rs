//! The QuadGraph bake (DESIGN section 3; paper sections 4.1, 4.3 and 5.1): tetrahedralize the solid
//! at each level's lattice spacing, split tetrahedra with several boundary faces (Fig. 4), build the
//! 4-connected graph with surface nodes on the input surface, link the levels with Shepard weights
//! (Eq. 10), weight the display mesh's vertices, pack every level into texture blocks, and cache the
//! result on disk.
//!
//! ```
//! use translucent::mesh::{shapes::Shape, Solid};
//! use translucent::quadgraph::BakeParams;
//! use translucent::QuadGraph;
//!
//! let ball = Shape::Sphere { radius: 10.0 };
//! let params = BakeParams { resolution: 12, levels: 2, ..Default::default() };
//! let (graph, stats) = QuadGraph::bake(&ball.triangulate(32), &ball, &params, &mut |_| {}).unwrap();
//! assert_eq!(graph.levels.len(), 2);
//! assert!(stats.levels[1].surface_nodes > stats.levels[0].surface_nodes);
//! // Every inner node has 4 neighbours, every surface node sits on one inner node.
//! assert!(graph.finest().neighbors.iter().all(|n| n.iter().all(|&j| j != translucent::quadgraph::graph::NO_NODE)));
//! ```

pub mod build;
pub mod cache;
pub mod crease;
pub mod export;
pub mod graph;
pub mod lateral;
pub mod packing;
pub mod resolution;
pub mod shepard;
pub mod surface_samples;

use std::path::PathBuf;

pub use build::{display_surface, BakeParams, BakeProgress, BakeStats, LevelStats};
pub use graph::{BounceLinks, WallCrossing};

/// A bake that cannot proceed, or a cache file that cannot be used. Each variant names the problem
/// (and the file, where there is one).
#[derive(Debug, thiserror::Error)]
pub enum BakeError {
    #[error("bake: {0}")]
    Invalid(String),
    #[error("bake: bad parameter {name} = {value}: {reason}")]
    Parameter {
        name: &'static str,
        value: String,
        reason: &'static str,
    },
    #[error("bake: level {level} (lattice spacing {spacing_mm} mm) has no tetrahedra: the solid is thinner than the lattice; raise --resolution or lower --levels")]
    Empty { level: usize, spacing_mm: f64 },
    /// The I/O error is the [`std::error::Error::source`] (anyhow's `{:#}` prints it after this).
    #[error("bake: {path}: input/output error")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("bake cache {path}: not a QuadGraph cache file (bad magic bytes)")]
    CacheMagic { path: PathBuf },
    #[error("bake cache {path}: format version {found}, this build reads version {expected}")]
    CacheVersion {
        path: PathBuf,
        found: u32,
        expected: u32,
    },
    #[error("bake cache {path}: truncated ({len} bytes, expected {expected})")]
    CacheTruncated {
        path: PathBuf,
        len: u64,
        expected: u64,
    },
    #[error("bake cache {path}: checksum mismatch (file corrupt)")]
    CacheChecksum { path: PathBuf },
    #[error("bake cache {path}: stale (made for another mesh or other bake parameters)")]
    CacheStale { path: PathBuf },
    #[error("bake cache {path}: inconsistent content: {reason}")]
    CacheContent { path: PathBuf, reason: String },
    #[error("bake cache {path}: {source}")]
    CacheLimit {
        path: PathBuf,
        #[source]
        source: crate::limits::LimitExceeded,
    },
    /// A bake level would exceed a resource limit (lattice nodes, surface samples).
    #[error(
        "bake: level {level} (lattice spacing {spacing_mm} mm): {source}; or lower --resolution"
    )]
    Limit {
        level: usize,
        spacing_mm: f64,
        #[source]
        source: crate::limits::LimitExceeded,
    },
}

#[cfg(test)]
mod tests;
