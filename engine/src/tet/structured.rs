//! Structured tetrahedral meshes of an axis-aligned box: exact geometry for solver tests and
//! benchmarks (the slab, energy and convergence checks), independent of the isosurface-stuffing bake.
//!
//! - [`TetMesh::structured_box`]: every cell split into 6 tetrahedra around its main diagonal
//!   (Kuhn / Freudenthal), conforming across cells.
//! - [`TetMesh::bcc_box`]: body-centred cubic tetrahedra (the lattice the bake stuffs): for every
//!   face shared by two cells, 4 tetrahedra joining the two cell centres to the face's edges; a
//!   boundary face gets its centre as a vertex and 4 half tetrahedra. BCC tetrahedra are
//!   disphenoids, whose centroid is their circumcentre, so the `fv` two-point flux is consistent.
//!
//! ```
//! use glam::DVec3;
//! use translucent::{tet::{structured::signed_volume, TetMesh}, GraphLevel};
//! let tets = TetMesh::bcc_box(DVec3::ZERO, DVec3::new(4.0, 2.0, 2.0), [4, 2, 2]);
//! let volume: f64 = (0..tets.tets.len()).map(|t| signed_volume(&tets, t)).sum();
//! assert!((volume - 16.0).abs() < 1e-9);
//! // Surface nodes at the face centroids: exact for a box.
//! let level = GraphLevel::from_tets(tets, 1.0, |c, n| (c, n));
//! assert!(level.surface_count() > 0);
//! ```

use glam::DVec3;
use rayon::prelude::*;

use super::TetMesh;
use crate::quadgraph::graph::{GraphLevel, ShepardLinks, NO_NODE};

/// Signed volume of tetrahedron `t` of `mesh` (positive for a positively oriented one).
pub fn signed_volume(mesh: &TetMesh, t: usize) -> f64 {
    let [a, b, c, d] = mesh.tets[t].map(|v| mesh.vertices[v as usize]);
    (b - a).dot((c - a).cross(d - a)) / 6.0
}

impl TetMesh {
    /// Box `[min, max]` cut into `n` cells per axis, each split into 6 Kuhn tetrahedra.
    pub fn structured_box(min: DVec3, max: DVec3, n: [usize; 3]) -> TetMesh {
        let n = n.map(|k| k.max(1));
        let step = (max - min) / DVec3::new(n[0] as f64, n[1] as f64, n[2] as f64);
        let vid = |x: usize, y: usize, z: usize| ((z * (n[1] + 1) + y) * (n[0] + 1) + x) as u32;
        let mut mesh = TetMesh::default();
        for z in 0..=n[2] {
            for y in 0..=n[1] {
                for x in 0..=n[0] {
                    mesh.vertices
                        .push(min + DVec3::new(x as f64, y as f64, z as f64) * step);
                }
            }
        }
        // The 6 monotone paths from corner (0,0,0) to (1,1,1), one per axis permutation.
        const PERMS: [[usize; 3]; 6] = [
            [0, 1, 2],
            [0, 2, 1],
            [1, 0, 2],
            [1, 2, 0],
            [2, 0, 1],
            [2, 1, 0],
        ];
        for z in 0..n[2] {
            for y in 0..n[1] {
                for x in 0..n[0] {
                    for perm in PERMS {
                        let mut c = [x, y, z];
                        let mut tet = [vid(c[0], c[1], c[2]); 4];
                        for (k, &axis) in perm.iter().enumerate() {
                            c[axis] += 1;
                            tet[k + 1] = vid(c[0], c[1], c[2]);
                        }
                        mesh.push_oriented(tet);
                    }
                }
            }
        }
        mesh
    }

    /// Box `[min, max]` cut into `n` cells per axis, tetrahedralized as a BCC lattice (see the
    /// module doc). About 12 tetrahedra per cell.
    pub fn bcc_box(min: DVec3, max: DVec3, n: [usize; 3]) -> TetMesh {
        let n = n.map(|k| k.max(1));
        let step = (max - min) / DVec3::new(n[0] as f64, n[1] as f64, n[2] as f64);
        let corner = |x: usize, y: usize, z: usize| ((z * (n[1] + 1) + y) * (n[0] + 1) + x) as u32;
        let mut mesh = TetMesh::default();
        for z in 0..=n[2] {
            for y in 0..=n[1] {
                for x in 0..=n[0] {
                    mesh.vertices
                        .push(min + DVec3::new(x as f64, y as f64, z as f64) * step);
                }
            }
        }
        let centre_base = mesh.vertices.len() as u32;
        let centre = |c: [usize; 3]| centre_base + ((c[2] * n[1] + c[1]) * n[0] + c[0]) as u32;
        for z in 0..n[2] {
            for y in 0..n[1] {
                for x in 0..n[0] {
                    let c = DVec3::new(x as f64, y as f64, z as f64) + 0.5;
                    mesh.vertices.push(min + c * step);
                }
            }
        }
        // For each axis and each lattice plane across it, every cell face in that plane.
        for axis in 0..3 {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            for plane in 0..=n[axis] {
                for i in 0..n[u] {
                    for j in 0..n[v] {
                        let at = |a: usize, b: usize| {
                            let mut p = [0; 3];
                            p[axis] = plane;
                            p[u] = a;
                            p[v] = b;
                            corner(p[0], p[1], p[2])
                        };
                        let quad = [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)];
                        let cell = |k: usize| {
                            let mut c = [0; 3];
                            c[axis] = k;
                            c[u] = i;
                            c[v] = j;
                            centre(c)
                        };
                        let below = (plane > 0).then(|| cell(plane - 1));
                        let above = (plane < n[axis]).then(|| cell(plane));
                        let (p, q) = match (below, above) {
                            (Some(b), Some(a)) => (b, a),
                            (Some(c), None) | (None, Some(c)) => {
                                let fc = quad
                                    .iter()
                                    .map(|&k| mesh.vertices[k as usize])
                                    .sum::<DVec3>()
                                    / 4.0;
                                mesh.vertices.push(fc);
                                (c, mesh.vertices.len() as u32 - 1)
                            }
                            (None, None) => continue,
                        };
                        for e in 0..4 {
                            mesh.push_oriented([p, q, quad[e], quad[(e + 1) % 4]]);
                        }
                    }
                }
            }
        }
        mesh
    }

    /// A slab `|y| <= thickness / 2`, `|x|, |z| <= half_width`, cut from a BCC lattice rotated so
    /// that its {011} planes, which BCC tetrahedron faces tile exactly, are the slab's faces: every
    /// tetrahedron is a full disphenoid (no half tetrahedra at the faces), `layers` of them across the
    /// thickness (lattice spacing `thickness * sqrt(2) / layers`). The z faces are {011} planes too;
    /// the x faces are jagged (tetrahedra kept by centroid), within one spacing of `|x| = half_width`.
    /// This is the fixture on which the `fv` scheme is consistent up to the boundary.
    pub fn bcc_slab(half_width: f64, thickness: f64, layers: usize) -> TetMesh {
        let layers = layers.max(1);
        let h = thickness * std::f64::consts::SQRT_2 / layers as f64;
        let r = std::f64::consts::FRAC_1_SQRT_2;
        // Lattice frame (x, y, z) -> slab frame (x, (y + z)/sqrt 2 - offset, (y - z)/sqrt 2).
        // Offset: the slab spans lattice planes y + z = 0 .. layers * h.
        let offset = thickness / 2.0;
        let to_slab = |p: DVec3| DVec3::new(p.x, (p.y + p.z) * r - offset, (p.y - p.z) * r);
        let reach = (half_width + thickness) * r + 2.0 * h;
        let cells = |extent: f64| ((2.0 * extent / h).ceil() as usize).max(1);
        let (nx, nyz) = (cells(half_width + 2.0 * h), cells(reach));
        // Corners at integer multiples of h, so the planes y + z = n h hold corners and centres alike.
        let lo = DVec3::new(
            -((nx / 2) as f64) * h,
            -((nyz / 2) as f64) * h,
            -((nyz / 2) as f64) * h,
        );
        let hi = lo + DVec3::new(nx as f64, nyz as f64, nyz as f64) * h;
        let lattice = TetMesh::bcc_box(lo, hi, [nx, nyz, nyz]);
        let mut keep = Vec::new();
        for tet in &lattice.tets {
            let c = tet
                .iter()
                .map(|&v| to_slab(lattice.vertices[v as usize]))
                .sum::<DVec3>()
                / 4.0;
            if c.y.abs() < thickness / 2.0 && c.x.abs() < half_width && c.z.abs() < half_width {
                keep.push(*tet);
            }
        }
        let mut remap = vec![u32::MAX; lattice.vertices.len()];
        let mut mesh = TetMesh::default();
        for tet in &keep {
            let mapped = tet.map(|v| {
                if remap[v as usize] == u32::MAX {
                    remap[v as usize] = mesh.vertices.len() as u32;
                    mesh.vertices.push(to_slab(lattice.vertices[v as usize]));
                }
                remap[v as usize]
            });
            // The frame change is a rotation composed with a reflection; re-orient.
            mesh.push_oriented(mapped);
        }
        mesh
    }

    fn push_oriented(&mut self, mut tet: [u32; 4]) {
        self.tets.push(tet);
        let t = self.tets.len() - 1;
        if signed_volume(self, t) < 0.0 {
            tet.swap(2, 3);
            self.tets[t] = tet;
        }
    }
}

/// Shepard links (paper Eq. 10) from `coarse` into `fine` by brute-force nearest neighbours: for a
/// surface node the 4 nearest coarse surface nodes with agreeing normals, for an inner node the 8
/// nearest coarse inner nodes; weights 1 / max(d^2, eps^2), normalized. A fixture for multi-level
/// tests until the bake provides links; O(fine x coarse).
pub fn nearest_shepard_links(coarse: &GraphLevel, fine: &GraphLevel) -> ShepardLinks {
    let eps2 = (1e-6 * coarse.spacing.max(1e-12)).powi(2);
    let coarse_inner = coarse.inner_count();
    let nearest = |p: DVec3, normal: Option<DVec3>, k: usize| -> ([u32; 8], [f64; 8]) {
        let candidates: Box<dyn Iterator<Item = usize>> = match normal {
            None => Box::new(0..coarse_inner),
            Some(_) => Box::new(coarse_inner..coarse.node_count()),
        };
        let mut best: Vec<(f64, usize)> = Vec::with_capacity(k + 1);
        for c in candidates {
            if let Some(nf) = normal {
                if coarse.surface_normals[c - coarse_inner].dot(nf) <= 0.0 {
                    continue;
                }
            }
            let d2 = coarse.positions[c].distance_squared(p);
            if best.len() < k || d2 < best[best.len() - 1].0 {
                let at = best.partition_point(|&(d, _)| d <= d2);
                best.insert(at, (d2, c));
                best.truncate(k);
            }
        }
        let mut links = [NO_NODE; 8];
        let mut weights = [0.0; 8];
        for (slot, &(d2, c)) in best.iter().enumerate() {
            links[slot] = c as u32;
            weights[slot] = 1.0 / d2.max(eps2);
        }
        let total: f64 = weights.iter().sum();
        if total > 0.0 {
            weights.iter_mut().for_each(|w| *w /= total);
        }
        (links, weights)
    };
    let fine_inner = fine.inner_count();
    let (links, weights) = (0..fine.node_count())
        .into_par_iter()
        .map(|x| {
            if x < fine_inner {
                nearest(fine.positions[x], None, 8)
            } else {
                nearest(
                    fine.positions[x],
                    Some(fine.surface_normals[x - fine_inner]),
                    4,
                )
            }
        })
        .unzip();
    ShepardLinks { links, weights }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check_box(mesh: &TetMesh, volume: f64, boundary_area: f64) {
        let mut total = 0.0;
        for t in 0..mesh.tets.len() {
            let v = signed_volume(mesh, t);
            assert!(v > 0.0, "tet {t} is not positively oriented");
            total += v;
        }
        assert!(
            (total - volume).abs() < 1e-9 * volume,
            "{total} vs {volume}"
        );
        let level = GraphLevel::from_tets(mesh.clone(), 1.0, |c, n| (c, n));
        // Conforming: every face is shared by two tets or is on the box boundary.
        let area: f64 = (0..level.surface_count())
            .map(|s| {
                let (t, f) = level.surface_faces[s];
                let [a, b, c] = level.face_vertices(t as usize, f as usize);
                0.5 * (b - a).cross(c - a).length()
            })
            .sum();
        assert!(
            (area - boundary_area).abs() < 1e-9 * boundary_area,
            "{area} vs {boundary_area}"
        );
        for nb in &level.neighbors {
            assert!(nb.iter().all(|&j| j != NO_NODE));
        }
    }

    #[test]
    fn boxes_are_conforming_positive_and_exact() {
        let (min, max) = (DVec3::new(-1.0, 0.0, 2.0), DVec3::new(2.0, 1.0, 4.0));
        let (vol, area) = (6.0, 2.0 * (3.0 + 6.0 + 2.0));
        check_box(&TetMesh::structured_box(min, max, [3, 2, 4]), vol, area);
        check_box(&TetMesh::bcc_box(min, max, [3, 2, 4]), vol, area);
        assert_eq!(
            TetMesh::structured_box(min, max, [3, 2, 4]).tets.len(),
            6 * 24
        );
    }

    #[test]
    fn bcc_slab_faces_are_exact() {
        let (w, t) = (6.0, 2.0);
        let mesh = TetMesh::bcc_slab(w, t, 4);
        for t_id in 0..mesh.tets.len() {
            assert!(signed_volume(&mesh, t_id) > 0.0);
        }
        let level = GraphLevel::from_tets(mesh, 1.0, |c, n| (c, n));
        let (mut top, mut bottom) = (0.0, 0.0);
        for s in 0..level.surface_count() {
            let (tt, f) = level.surface_faces[s];
            let [a, b, c] = level.face_vertices(tt as usize, f as usize);
            let n = level.surface_normals[s];
            let area = 0.5 * (b - a).cross(c - a).length();
            if n.y > 0.999 {
                assert!((a.y - 1.0).abs() < 1e-9 && (b.y - 1.0).abs() < 1e-9);
                top += area;
            } else if n.y < -0.999 {
                assert!((a.y + 1.0).abs() < 1e-9);
                bottom += area;
            }
        }
        // x faces are jagged by up to a spacing; the top and bottom faces are planes.
        assert!(
            top > 0.6 * 4.0 * w * w && (top - bottom).abs() < 1e-9 * top,
            "{top} {bottom}"
        );
    }

    #[test]
    fn shepard_links_reproduce_constants_and_respect_kinds() {
        let (min, max) = (DVec3::ZERO, DVec3::splat(4.0));
        let coarse =
            GraphLevel::from_tets(TetMesh::bcc_box(min, max, [2, 2, 2]), 2.0, |c, n| (c, n));
        let fine = GraphLevel::from_tets(TetMesh::bcc_box(min, max, [4, 4, 4]), 1.0, |c, n| (c, n));
        let links = nearest_shepard_links(&coarse, &fine);
        assert_eq!(links.links.len(), fine.node_count());
        for (x, (l, w)) in links.links.iter().zip(&links.weights).enumerate() {
            assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-12);
            let inner = x < fine.inner_count();
            for &c in l.iter().filter(|&&c| c != NO_NODE) {
                assert_eq!(inner, (c as usize) < coarse.inner_count());
            }
        }
    }
}
