//! The baked QuadGraph: the data contract between the bake (which fills it) and the solvers (which
//! read it). Fields may be added; the meaning of the ones here is fixed.
//!
//! Node numbering on every level: inner node `i` in `0..inner_count()` is tetrahedron `i` of
//! [`GraphLevel::tets`]; surface node `s` has node id `inner_count() + s` and sits on the boundary face
//! [`GraphLevel::surface_faces`]`[s]`. Every inner node has exactly 4 neighbours (one across each
//! face), every surface node exactly 1 (the tetrahedron it sits on).

use std::collections::HashMap;

use glam::DVec3;
use rayon::prelude::*;

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
/// ordered so that their normal `(b - a) x (c - a)` points out of a positively oriented tetrahedron
/// (`(v1 - v0) . ((v2 - v0) x (v3 - v0)) > 0`, as [`TetMesh`] requires). The first version of this
/// table had every face reversed (inward normals); face `f` and its vertex set are unchanged.
pub const TET_FACES: [[usize; 3]; 4] = [[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]];

/// Shepard interpolation links from a coarser level into this one: for every node of this level, up to
/// 8 nodes of the coarser level and their normalized weights (unused slots: [`NO_NODE`], weight 0).
/// Surface nodes link to coarse surface nodes (node ids), inner nodes to coarse inner nodes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ShepardLinks {
    pub links: Vec<[u32; 8]>,
    pub weights: Vec<[f64; 8]>,
}

/// One level of the QuadGraph.
#[derive(Clone, Debug, Default, PartialEq)]
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
    /// Where each node lives in the level's 2D textures (paper section 5.1; empty until packed).
    pub packing: Packing,
}

/// The texture layout of one level: a `width x height` texture cut into `block x block` blocks,
/// surface nodes in rows `[0, surface_rows)`, inner nodes in rows `[surface_rows, height)`; both
/// multiples of `block`. Texels no node maps to are padding.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Packing {
    pub width: u32,
    pub height: u32,
    pub surface_rows: u32,
    pub block: u32,
    /// Texel `(u, v)` of each node (node id order).
    pub texels: Vec<[u32; 2]>,
}

impl Packing {
    /// Row-major linear texel index `v * width + u` of `node` (what the GPU's level links hold), or
    /// [`NO_NODE`] for [`NO_NODE`].
    pub fn linear_index(&self, node: u32) -> u32 {
        match self.texels.get(node as usize) {
            Some(&[u, v]) => v * self.width + u,
            None => NO_NODE,
        }
    }

    /// Per texel (row-major), the node stored there, or [`NO_NODE`] for padding.
    pub fn texel_nodes(&self) -> Vec<u32> {
        let mut out = vec![NO_NODE; self.width as usize * self.height as usize];
        for (node, &[u, v]) in self.texels.iter().enumerate() {
            out[v as usize * self.width as usize + u as usize] = node as u32;
        }
        out
    }
}

/// Per render-mesh vertex, up to 4 surface nodes of the finest level (surface index `s`, not node id)
/// and normalized weights.
#[derive(Clone, Debug, Default, PartialEq)]
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
    /// Interior sample points of `surface`'s vertices in the finest level (the exit query's
    /// depth-sampled reconstruction; empty for graphs built without a bake).
    pub samples: super::surface_samples::SurfaceSamples,
    /// One bounce's form factors between `surface`'s vertices, when a render built them
    /// (`crate::frame::BounceLinks::build`): stored with the bake so that the next render of the
    /// same mesh casts no ray. `None` after a bake.
    pub bounce: Option<BounceLinks>,
}

/// Sparse form factors between display vertices (`crate::frame::bounce`): vertex v receives
/// from `links[offsets[v]..offsets[v + 1]]`, each (source vertex, form factor).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BounceLinks {
    pub offsets: Vec<u32>,
    pub links: Vec<(u32, f32)>,
    /// The rays per vertex and the links kept per vertex they were built with: a render asking
    /// for others builds them again.
    pub rays: u32,
    pub max_links: u32,
    /// Per vertex, where its inward normal leaves the object again ([`WallCrossing`]): the far
    /// face of a thin wall, through which light that re-entered at one face leaves at the other.
    /// Empty for a convex object (no links, nothing to carry).
    pub across: Vec<WallCrossing>,
}

/// Where the ray from a display vertex along its inward normal leaves the object: the far
/// triangle's three vertices, the hit's barycentric weights and the distance in mm (the wall's
/// thickness there). `thickness` is infinite (and the weights zero) where the ray never leaves.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WallCrossing {
    pub vertices: [u32; 3],
    pub weights: [f32; 3],
    pub thickness: f32,
}

impl WallCrossing {
    /// No far face: nothing crosses.
    pub const NONE: WallCrossing = WallCrossing {
        vertices: [0; 3],
        weights: [0.0; 3],
        thickness: f32::INFINITY,
    };
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
    /// The bounding sphere (centre, radius in mm) of the level's nodes (see
    /// [`crate::mesh::bounding_sphere`]).
    pub fn bounding_sphere(&self) -> (glam::DVec3, f64) {
        crate::mesh::bounding_sphere(&self.positions)
    }

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
        let mut level = Self::connect(tets, spacing);
        let inner = level.inner_count();
        for s in 0..level.surface_count() {
            let (c, n) = level.face_frame(s);
            let (p, nrm) = place_surface_node(c, n);
            level.positions[inner + s] = p;
            level.surface_normals[s] = nrm;
        }
        level
    }

    /// [`Self::from_tets`] with the surface nodes placed in parallel;
    /// `place_surface_node(face_centroid, face_normal, depth)` also gets the distance of the
    /// tetrahedron's centroid (its inner node) behind the face plane.
    pub fn from_tets_par(
        tets: TetMesh,
        spacing: f64,
        place_surface_node: impl Fn(DVec3, DVec3, f64) -> (DVec3, DVec3) + Sync,
    ) -> Self {
        let mut level = Self::connect(tets, spacing);
        let placed: Vec<(DVec3, DVec3)> = (0..level.surface_count())
            .into_par_iter()
            .map(|s| {
                let (c, n) = level.face_frame(s);
                let inner = level.positions[level.surface_faces[s].0 as usize];
                place_surface_node(c, n, n.dot(c - inner))
            })
            .collect();
        let inner = level.inner_count();
        for (s, (p, n)) in placed.into_iter().enumerate() {
            level.positions[inner + s] = p;
            level.surface_normals[s] = n;
        }
        level
    }

    /// Centroid and outward unit normal of the boundary face of surface node `s`.
    pub fn face_frame(&self, s: usize) -> (DVec3, DVec3) {
        let (t, f) = self.surface_faces[s];
        let [a, b, c] = self.face_vertices(t as usize, f as usize);
        ((a + b + c) / 3.0, (b - a).cross(c - a).normalize_or_zero())
    }

    /// Matches faces: neighbours, boundary faces; surface nodes provisionally at face centroids.
    fn connect(tets: TetMesh, spacing: f64) -> Self {
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
            positions.push((a + b + c) / 3.0);
            surface_normals.push((b - a).cross(c - a).normalize_or_zero());
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
            packing: Packing::default(),
        }
    }
}

/// Splits every tetrahedron with 2, 3 or 4 boundary faces at its centroid into 4 (paper Fig. 4), so
/// that each tetrahedron has at most one boundary face. Orientation is kept.
pub fn split_multi_boundary(mesh: TetMesh) -> (TetMesh, usize) {
    let mut count: HashMap<[u32; 3], u8> = HashMap::with_capacity(2 * mesh.tets.len());
    let key = |t: &[u32; 4], f: usize| {
        let mut k = TET_FACES[f].map(|l| t[l]);
        k.sort_unstable();
        k
    };
    for t in &mesh.tets {
        for f in 0..4 {
            *count.entry(key(t, f)).or_insert(0) += 1;
        }
    }
    let TetMesh { mut vertices, tets } = mesh;
    let mut out = Vec::with_capacity(tets.len());
    let mut split = 0;
    for t in tets {
        let boundary = (0..4).filter(|&f| count[&key(&t, f)] == 1).count();
        if boundary < 2 {
            out.push(t);
            continue;
        }
        split += 1;
        let c = vertices.len() as u32;
        vertices.push(t.iter().map(|&v| vertices[v as usize]).sum::<DVec3>() / 4.0);
        // Replacing vertex f by the centroid keeps the orientation and leaves face f outside.
        for f in 0..4 {
            let mut sub = t;
            sub[f] = c;
            out.push(sub);
        }
    }
    (
        TetMesh {
            vertices,
            tets: out,
        },
        split,
    )
}
