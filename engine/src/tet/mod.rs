//! Tetrahedral meshing by isosurface stuffing (Labelle and Shewchuk 2007).

/// A tetrahedral mesh. Every tetrahedron is positively oriented:
/// `(v1 - v0) . ((v2 - v0) x (v3 - v0)) > 0`.
#[derive(Clone, Debug, Default)]
pub struct TetMesh {
    /// Vertex positions in millimetres (normalized object frame).
    pub vertices: Vec<glam::DVec3>,
    /// Four vertex indices per tetrahedron.
    pub tets: Vec<[u32; 4]>,
}
pub mod structured;
