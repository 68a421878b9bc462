//! Display vertices split at sharp edges (issue 12, the U-block's 90-degree edges): a vertex
//! shared by faces that meet at a sharp edge carries one exitance and one averaged normal, so the
//! lit face's exitance was interpolated down the dark face along the whole edge (benches/RESULTS.md,
//! "The Chandrasekhar exit lobe as the default"). [`TriMesh::split_sharp_edges`] gives each
//! smooth group of faces around a vertex its own copy of the vertex, with the group's normal; the
//! bake then gives each copy its own shading weights, surface sample and bounce links.
//!
//! ```
//! use translucent::mesh::{shapes::Shape, SHARP_EDGE_COS};
//!
//! let cube = Shape::Box { half_extents: glam::DVec3::splat(5.0) }.triangulate(4);
//! let (display, origin) = cube.split_sharp_edges(SHARP_EDGE_COS);
//! // A vertex on an edge gets a copy per face it touches, with that face's normal.
//! assert!(display.positions.len() > cube.positions.len());
//! assert!(display.normals.iter().all(|n| n.abs().max_element() == 1.0));
//! assert!(origin.iter().all(|&o| (o as usize) < cube.positions.len()));
//! ```

use std::collections::HashMap;

use glam::DVec3;

use super::TriMesh;

/// Faces meeting at an edge whose unit normals' cosine is below this (more than 60 degrees
/// apart) get their own display vertices along the edge. A scanned surface's gentle folds and a
/// finely tessellated smooth shape stay welded (a 32-segment sphere's neighbouring faces are 11
/// degrees apart).
pub const SHARP_EDGE_COS: f64 = 0.5;

/// Per vertex, the index of the first vertex at exactly the same position (itself if none):
/// the welded vertex of a split display mesh.
pub fn weld_by_position(positions: &[DVec3]) -> Vec<u32> {
    let mut first: HashMap<[u64; 3], u32> = HashMap::with_capacity(positions.len());
    positions
        .iter()
        .enumerate()
        .map(|(v, p)| {
            // -0.0 and 0.0 are one position.
            let key = (*p + DVec3::ZERO).to_array().map(f64::to_bits);
            *first.entry(key).or_insert(v as u32)
        })
        .collect()
}

fn root(parent: &mut [u32], mut i: u32) -> u32 {
    while parent[i as usize] != i {
        parent[i as usize] = parent[parent[i as usize] as usize];
        i = parent[i as usize];
    }
    i
}

impl TriMesh {
    /// The display mesh with each vertex split into one copy per smooth group of its faces:
    /// faces around a vertex are one group when they are joined through edges at the vertex whose
    /// two faces' normals have a cosine of at least `min_cos` (faces of zero area join any
    /// neighbour). A vertex with one group keeps its index and its normal (bit-identical for a
    /// smooth mesh); further groups are appended after the input's vertices, and every split
    /// vertex's copies take their group's area-weighted normal. Also returns, per output vertex,
    /// the input vertex it copies. Indices out of range are left as they are (nothing is split
    /// at them; [`TriMesh::check_structure`] reports them).
    pub fn split_sharp_edges(&self, min_cos: f64) -> (TriMesh, Vec<u32>) {
        let n = self.positions.len();
        let identity = || (self.clone(), (0..n as u32).collect());
        if self.indices.iter().flatten().any(|&i| i as usize >= n) {
            return identity();
        }
        let faces = self.indices.len();
        let cross: Vec<DVec3> = self
            .indices
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| self.positions[i as usize]);
                (b - a).cross(c - a)
            })
            .collect();
        let unit: Vec<DVec3> = cross.iter().map(|c| c.normalize_or_zero()).collect();
        // Union-find over face corners (3 f + k); corners of one vertex joined across smooth edges.
        let mut parent: Vec<u32> = (0..3 * faces as u32).collect();
        let mut uses: Vec<(u32, u32, u32)> = Vec::with_capacity(3 * faces);
        for (f, t) in self.indices.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                uses.push((a.min(b), a.max(b), f as u32));
            }
        }
        uses.sort_unstable();
        let corner = |f: u32, v: u32| {
            let k = self.indices[f as usize].iter().position(|&i| i == v);
            k.map(|k| 3 * f + k as u32)
        };
        for run in uses.chunk_by(|x, y| (x.0, x.1) == (y.0, y.1)) {
            for (i, &(a, b, f)) in run.iter().enumerate() {
                for &(_, _, g) in &run[i + 1..] {
                    let (nf, ng) = (unit[f as usize], unit[g as usize]);
                    let degenerate = nf == DVec3::ZERO || ng == DVec3::ZERO;
                    if !(degenerate || nf.dot(ng) >= min_cos) {
                        continue;
                    }
                    for v in [a, b] {
                        if let (Some(cf), Some(cg)) = (corner(f, v), corner(g, v)) {
                            let (rf, rg) = (root(&mut parent, cf), root(&mut parent, cg));
                            parent[rf as usize] = rg;
                        }
                    }
                }
            }
        }
        // Per vertex, its groups (corner roots) in order of first use.
        let mut groups: Vec<Vec<u32>> = vec![Vec::new(); n];
        let mut group_of = vec![0u32; 3 * faces];
        for (f, t) in self.indices.iter().enumerate() {
            for (k, &v) in t.iter().enumerate() {
                let c = 3 * f + k;
                let r = root(&mut parent, c as u32);
                let list = &mut groups[v as usize];
                group_of[c] = match list.iter().position(|&g| g == r) {
                    Some(i) => i as u32,
                    None => {
                        list.push(r);
                        list.len() as u32 - 1
                    }
                };
            }
        }
        if groups.iter().all(|g| g.len() <= 1) {
            return identity();
        }
        let mut normals = self.normals.clone();
        if normals.len() != n {
            let mut m = self.clone();
            m.compute_normals();
            normals = m.normals;
        }
        // First copy of each vertex: its own index; later copies appended.
        let mut copy_index: Vec<u32> = Vec::with_capacity(n);
        let mut origin: Vec<u32> = (0..n as u32).collect();
        let mut positions = self.positions.clone();
        for (v, g) in groups.iter().enumerate() {
            copy_index.push(positions.len() as u32);
            for _ in 1..g.len() {
                positions.push(self.positions[v]);
                origin.push(v as u32);
            }
        }
        let index = |v: u32, g: u32| match g {
            0 => v,
            g => copy_index[v as usize] + g - 1,
        };
        let mut indices = self.indices.clone();
        let mut sums = vec![DVec3::ZERO; positions.len()];
        for (f, t) in indices.iter_mut().enumerate() {
            for (k, v) in t.iter_mut().enumerate() {
                let g = group_of[3 * f + k];
                *v = index(*v, g);
                sums[*v as usize] += cross[f];
            }
        }
        normals.resize(positions.len(), DVec3::ZERO);
        for (v, sum) in sums.iter().enumerate() {
            if groups[origin[v] as usize].len() > 1 {
                let n = sum.normalize_or_zero();
                if n != DVec3::ZERO {
                    normals[v] = n;
                } else {
                    normals[v] = normals[origin[v] as usize];
                }
            }
        }
        let mesh = TriMesh {
            positions,
            normals,
            indices,
        };
        (mesh, origin)
    }
}

/// A box from `-half` to `half` with one vertex per corner (8) and two triangles per face, wound
/// outward (`Shape::Box` tessellates finer).
#[cfg(test)]
pub(crate) fn corner_box(half: DVec3) -> TriMesh {
    let mut mesh = TriMesh {
        positions: (0..8)
            .map(|i| {
                let bit = |k: u32| if i >> k & 1 == 1 { 1.0 } else { -1.0 };
                half * DVec3::new(bit(0), bit(1), bit(2))
            })
            .collect(),
        ..Default::default()
    };
    for axis in 0..3 {
        // (u, v, axis) cyclic, so u x v = +axis.
        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
        for side in [0u32, 1] {
            let [a, b, c, d] = [(0, 0), (1, 0), (1, 1), (0, 1)]
                .map(|(du, dv): (u32, u32)| side << axis | du << u | dv << v);
            if side == 0 {
                mesh.indices.extend([[a, c, b], [a, d, c]]);
            } else {
                mesh.indices.extend([[a, b, c], [a, c, d]]);
            }
        }
    }
    mesh.compute_normals();
    mesh
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::shapes::Shape;

    #[test]
    fn a_cube_splits_into_four_vertices_per_face_and_a_sphere_stays_as_it_is() {
        let cube = corner_box(DVec3::new(5.0, 3.0, 2.0));
        assert_eq!(cube.positions.len(), 8);
        assert!(cube.signed_volume() > 0.0, "wound outward");
        let (display, origin) = cube.split_sharp_edges(SHARP_EDGE_COS);
        assert_eq!(display.positions.len(), 24);
        assert_eq!(display.indices.len(), cube.indices.len());
        for (f, t) in display.indices.iter().enumerate() {
            let [a, b, c] = t.map(|i| display.positions[i as usize]);
            let face = (b - a).cross(c - a).normalize();
            for &v in t {
                assert_eq!(display.normals[v as usize], face, "face {f} vertex {v}");
                let o = origin[v as usize] as usize;
                assert_eq!(display.positions[v as usize], cube.positions[o]);
            }
        }
        let sphere = Shape::Sphere { radius: 10.0 }.triangulate(32);
        let (same, origin) = sphere.split_sharp_edges(SHARP_EDGE_COS);
        assert_eq!(same.positions, sphere.positions);
        assert_eq!(same.normals, sphere.normals);
        assert_eq!(same.indices, sphere.indices);
        assert!(origin.iter().enumerate().all(|(v, &o)| o as usize == v));
        let welded = weld_by_position(&display.positions);
        let distinct = welded.iter().enumerate().filter(|(v, &w)| *v == w as usize);
        assert_eq!(distinct.count(), 8);
    }
}
