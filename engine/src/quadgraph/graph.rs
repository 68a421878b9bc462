//! The baked QuadGraph: the data contract between the bake (which fills it) and the solvers (which
//! read it). Fields may be added; the meaning of the ones here is fixed.
//!
//! Node numbering on every level: inner node `i` in `0..inner_count()` is tetrahedron `i` of
//! [`GraphLevel::tets`]; surface node `s` has node id `inner_count() + s` and sits on the boundary face
//! [`GraphLevel::surface_faces`]`[s]`. Every inner node has exactly 4 neighbours (one across each
//! face), every surface node exactly 1 (the tetrahedron it sits on).

use std::collections::HashMap;

use glam::DVec3;

use crate::tet::TetMesh;

/// Marks "no node" in a neighbour or link slot.
pub const NO_NODE: u32 = u32::MAX;

/// The two kinds of node.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NodeKind {
    /// One per tetrahedron, at its centroid.
    Inner,
    /// One per boundary face, on the input surface.
    Surface,
}

/// Local face `f` of a tetrahedron is the face opposite its local vertex `f`; these are its vertices,
/// ordered so that their normal `(b - a) x (c - a)` points out of a positively oriented tetrahedron.
pub const TET_FACES: [[usize; 3]; 4] = [[1, 3, 2], [0, 2, 3], [0, 3, 1], [0, 1, 2]];

/// Shepard interpolation links from a coarser level into this one: for every node of this level, up to
/// 8 nodes of the coarser level and their normalized weights (unused slots: [`NO_NODE`], weight 0).
/// Surface nodes link to coarse surface nodes (node ids), inner nodes to coarse inner nodes.
#[derive(Clone, Debug, Default)]
pub struct ShepardLinks {
    pub links: Vec<[u32; 8]>,
    pub weights: Vec<[f64; 8]>,
}

/// One level of the QuadGraph.
#[derive(Clone, Debug, Default)]
pub struct GraphLevel {
    /// The tetrahedra of this level (after the split of paper Fig. 4), positively oriented, in mm.
    pub tets: TetMesh,
    /// Node positions in mm: inner nodes (tet centroids, unless relaxed) then surface nodes.
    pub positions: Vec<DVec3>,
    /// Per inner node, the node across local face `f` (an inner or a surface node id).
    pub neighbors: Vec<[u32; 4]>,
    /// Per surface node: the tetrahedron it sits on and the local face index.
    pub surface_faces: Vec<(u32, u8)>,
    /// Per surface node: outward unit normal of the input surface there.
    pub surface_normals: Vec<DVec3>,
    /// Lattice spacing of this level in mm (the edge scale of its surface tetrahedra).
    pub spacing: f64,
    /// Links from the next coarser level (`None` on the coarsest level).
    pub from_coarser: Option<ShepardLinks>,
}

/// Per render-mesh vertex, up to 4 surface nodes of the finest level (surface index `s`, not node id)
/// and normalized weights.
#[derive(Clone, Debug, Default)]
pub struct ShadingWeights {
    pub links: Vec<[u32; 4]>,
    pub weights: Vec<[f64; 4]>,
}

/// A baked QuadGraph: levels ordered coarsest first (level `h + 1` has about 4x the surface nodes of
/// level `h`); the last level is the full-resolution graph.
#[derive(Clone, Debug, Default)]
pub struct QuadGraph {
    pub levels: Vec<GraphLevel>,
    /// The normalized input surface (what is displayed).
    pub surface: crate::mesh::TriMesh,
    /// Shading weights of `surface`'s vertices into the finest level.
    pub shading: ShadingWeights,
}

impl QuadGraph {
    /// The finest (full-resolution) level.
    pub fn finest(&self) -> &GraphLevel {
        self.levels
            .last()
            .expect("a QuadGraph has at least one level")
    }
}

impl GraphLevel {
    pub fn inner_count(&self) -> usize {
        self.tets.tets.len()
    }
    pub fn surface_count(&self) -> usize {
        self.surface_faces.len()
    }
    pub fn node_count(&self) -> usize {
        self.inner_count() + self.surface_count()
    }
    pub fn kind(&self, node: u32) -> NodeKind {
        if (node as usize) < self.inner_count() {
            NodeKind::Inner
        } else {
            NodeKind::Surface
        }
    }
    /// Node id of surface node `s`.
    pub fn surface_node_id(&self, s: usize) -> u32 {
        (self.inner_count() + s) as u32
    }
    /// The three vertex positions of local face `f` of tetrahedron `t`, outward ordered.
    pub fn face_vertices(&self, t: usize, f: usize) -> [DVec3; 3] {
        let tet = self.tets.tets[t];
        TET_FACES[f].map(|l| self.tets.vertices[tet[l] as usize])
    }

    /// Builds the dual graph of a tetrahedral mesh. `place_surface_node(face_centroid, face_normal)`
    /// returns the position and outward unit normal of the surface node of a boundary face (the bake
    /// casts a ray to the input surface; a fixture may return the face centroid itself).
    /// Inner node positions are the tetrahedron centroids.
    pub fn from_tets(
        tets: TetMesh,
        spacing: f64,
        mut place_surface_node: impl FnMut(DVec3, DVec3) -> (DVec3, DVec3),
    ) -> Self {
        let n = tets.tets.len();
        let mut neighbors = vec![[NO_NODE; 4]; n];
        let mut open: HashMap<[u32; 3], (u32, u8)> = HashMap::with_capacity(2 * n);
        for (t, tet) in tets.tets.iter().enumerate() {
            for (f, face) in TET_FACES.iter().enumerate() {
                let mut key = face.map(|l| tet[l]);
                key.sort_unstable();
                if let Some((u, g)) = open.remove(&key) {
                    neighbors[t][f] = u;
                    neighbors[u as usize][g as usize] = t as u32;
                } else {
                    open.insert(key, (t as u32, f as u8));
                }
            }
        }
        let mut surface_faces: Vec<(u32, u8)> = open.into_values().collect();
        surface_faces.sort_unstable();
        let mut positions: Vec<DVec3> = tets
            .tets
            .iter()
            .map(|t| t.iter().map(|&v| tets.vertices[v as usize]).sum::<DVec3>() / 4.0)
            .collect();
        let mut surface_normals = Vec::with_capacity(surface_faces.len());
        for (s, &(t, f)) in surface_faces.iter().enumerate() {
            let tet = tets.tets[t as usize];
            let [a, b, c] = TET_FACES[f as usize].map(|l| tets.vertices[tet[l] as usize]);
            let normal = (b - a).cross(c - a).normalize();
            let (p, nrm) = place_surface_node((a + b + c) / 3.0, normal);
            positions.push(p);
            surface_normals.push(nrm);
            neighbors[t as usize][f as usize] = (n + s) as u32;
        }
        Self {
            tets,
            positions,
            neighbors,
            surface_faces,
            surface_normals,
            spacing,
            from_coarser: None,
        }
    }
}
