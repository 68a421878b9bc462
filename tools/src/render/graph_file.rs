//! `render --graph FILE.qgraph`: the graph `translucent bake` wrote, checked against the object
//! the options describe before any GPU work.

use std::path::{Path, PathBuf};

/// Why `render --graph FILE` cannot use FILE.
#[derive(Debug, thiserror::Error)]
pub enum GraphFileError {
    /// Not a readable QuadGraph file of this format version (the library's error says which).
    #[error("--graph: {source}")]
    Load {
        path: PathBuf,
        #[source]
        source: translucent::quadgraph::BakeError,
    },
    /// A graph baked from another surface than the one the object options describe.
    #[error(
        "--graph {path}: baked from another surface ({graph_vertices} vertices, {graph_triangles} triangles) than {object} ({vertices} vertices, {triangles} triangles); give the --mesh or --shape, --size-mm and --up that `translucent bake` was given"
    )]
    OtherSurface {
        path: PathBuf,
        object: String,
        graph_vertices: usize,
        graph_triangles: usize,
        vertices: usize,
        triangles: usize,
    },
    /// A method that does not read a QuadGraph.
    #[error(
        "--graph {path}: a QuadGraph is read by --method quadgraph only (--method {method} {why})"
    )]
    Method {
        path: PathBuf,
        method: String,
        why: &'static str,
    },
}

/// Loads `path` (`render --graph`) and checks that it is a bake of `object`'s surface: the
/// graph keeps the surface it was baked from, compared exactly (the cache file stores the f64
/// coordinates as they were).
pub fn load_graph_file(
    path: &Path,
    object: &crate::object_args::Object,
) -> Result<translucent::QuadGraph, GraphFileError> {
    let graph =
        translucent::QuadGraph::load(path, None).map_err(|source| GraphFileError::Load {
            path: path.to_path_buf(),
            source,
        })?;
    // The bake keeps the display mesh: the object's surface split at its sharp edges.
    let ours = &translucent::quadgraph::display_surface(&object.surface);
    let theirs = &graph.surface;
    if ours.positions != theirs.positions || ours.indices != theirs.indices {
        return Err(GraphFileError::OtherSurface {
            path: path.to_path_buf(),
            object: object.name.clone(),
            graph_vertices: theirs.positions.len(),
            graph_triangles: theirs.indices.len(),
            vertices: ours.positions.len(),
            triangles: ours.indices.len(),
        });
    }
    Ok(graph)
}
