//! Which face a display vertex on a concave crease shades from (issue 12, the back-lit plate's
//! crease): where a thin wall stands on a thicker part (a plate on its base, a slot's floor),
//! the display vertices along the junction are shared by both faces and their averaged normal
//! agrees with both faces' surface nodes, so their Shepard weights took half from each. The
//! lattice separates the two faces' nodes there (a 2 mm plate is 1.6 cells thick) and they hold
//! very different values (the plate's foot 0.72, the base in front of it 0.37, in J+ units),
//! while the path-traced exitance is continuous across the corner at the plate's level: the
//! averaged vertex drew a dark line along the junction.
//!
//! Rule: a vertex whose adjacent faces fall into several normal groups (faces within
//! [`GROUP_COS`] of each other) with at least one sharp concave pair (one group's faces lie in
//! front of the other's plane, normals more than 60 degrees apart) takes its shading weights from one group only: the one over the
//! **thinnest** part of the solid (the distance from just inside that face, next to the
//! vertex, to where its inward normal leaves the solid), and only from surface nodes within 60
//! degrees of that group's normal ([`CREASE_MIN_COS`]). The thin wall is the part whose two faces
//! carry one diffusion value across it (the light crosses it); the thick part's nodes next to
//! the corner lie in its own shadow. Equal thicknesses (within [`SAME_THICKNESS`]) and convex
//! edges (a box's edges, silhouettes) keep the averaged normal and the plain rule.

use glam::DVec3;
use rayon::prelude::*;

use crate::mesh::{Solid, TriMesh};

/// Faces whose unit normals are closer than this (cos 30 degrees) form one group at a vertex.
pub const GROUP_COS: f64 = 0.866;
/// A crease vertex's surface nodes must lie within 60 degrees of the chosen group's normal.
pub const CREASE_MIN_COS: f64 = 0.5;
/// Groups whose thicknesses differ by less than this fraction are treated as equal (the vertex
/// keeps averaging them).
const SAME_THICKNESS: f64 = 0.1;

/// Per display vertex: the normal its shading candidates must agree with and the smallest
/// cosine accepted (`None`: the plain rule, the vertex's own normal and `n . n_node > 0`).
/// `normals` are the vertices' outward normals (a face is turned to agree with them, whatever
/// the winding). Vertices at one position (a display mesh split at sharp edges,
/// [`TriMesh::split_sharp_edges`]) are one vertex here: the rule looks at all their faces, with
/// their averaged normal ([`Welded`]), and every copy gets the same answer.
pub fn crease_normals(
    surface: &TriMesh,
    normals: &[DVec3],
    solid: &dyn Solid,
) -> Vec<Option<(DVec3, f64)>> {
    let n = surface.positions.len();
    let welded = Welded::new(surface, normals);
    let mut faces_of: Vec<Vec<u32>> = vec![Vec::new(); n];
    for (f, tri) in surface.indices.iter().enumerate() {
        for &v in tri {
            if let Some(&w) = welded.of.get(v as usize) {
                faces_of[w as usize].push(f as u32);
            }
        }
    }
    let per_weld: Vec<Option<(DVec3, f64)>> = (0..n)
        .into_par_iter()
        .map(|v| {
            if welded.of[v] as usize != v {
                return None;
            }
            let outward = welded.averaged[v];
            crease_normal(surface, solid, v, outward, &faces_of[v])
        })
        .collect();
    welded.of.iter().map(|&w| per_weld[w as usize]).collect()
}

/// The display vertices that share a position: a vertex split at a sharp edge has one copy per
/// smooth group of faces ([`TriMesh::split_sharp_edges`]).
pub struct Welded {
    /// Per vertex, the first vertex at its position (itself for a vertex that is not split).
    pub of: Vec<u32>,
    /// Per vertex, whether another vertex shares its position.
    pub split: Vec<bool>,
    /// Per vertex, the outward normal of the welded vertex: its own normal where it is not split,
    /// else the area-weighted normal of all the faces at its position (turned to agree with the
    /// copies' normals).
    pub averaged: Vec<DVec3>,
}

impl Welded {
    pub fn new(surface: &TriMesh, normals: &[DVec3]) -> Welded {
        let n = surface.positions.len();
        let of = crate::mesh::weld_by_position(&surface.positions);
        let mut copies = vec![0u32; n];
        for &w in &of {
            copies[w as usize] += 1;
        }
        let split: Vec<bool> = of.iter().map(|&w| copies[w as usize] > 1).collect();
        let own = |v: usize| normals.get(v).copied().unwrap_or(DVec3::ZERO);
        let mut sums = vec![DVec3::ZERO; n];
        let mut hint = vec![DVec3::ZERO; n];
        for v in (0..n).filter(|&v| split[v]) {
            hint[of[v] as usize] += own(v);
        }
        for tri in &surface.indices {
            let Some(c) = tri
                .iter()
                .map(|&i| surface.positions.get(i as usize).copied())
                .collect::<Option<Vec<DVec3>>>()
            else {
                continue;
            };
            let cross = (c[1] - c[0]).cross(c[2] - c[0]);
            for &v in tri {
                let w = of[v as usize] as usize;
                if split[w] {
                    sums[w] += cross;
                }
            }
        }
        let averaged = (0..n)
            .map(|v| {
                if !split[v] {
                    return own(v);
                }
                let w = of[v] as usize;
                let sum = sums[w].normalize_or_zero();
                // An inward-wound surface: the copies' normals say which way is out.
                if sum.dot(hint[w]) < 0.0 {
                    -sum
                } else {
                    sum
                }
            })
            .collect();
        Welded {
            of,
            split,
            averaged,
        }
    }
}

/// One normal group at a vertex: area-weighted normal and centroid of its faces, its shortest
/// edge at the vertex.
struct Group {
    normal: DVec3,
    area: f64,
    centroid: DVec3,
    shortest_edge: f64,
}

fn crease_normal(
    surface: &TriMesh,
    solid: &dyn Solid,
    v: usize,
    outward: DVec3,
    faces: &[u32],
) -> Option<(DVec3, f64)> {
    let p = surface.positions[v];
    if !outward.is_finite() || outward.length_squared() <= 0.0 {
        return None;
    }
    let mut groups: Vec<Group> = Vec::new();
    for &f in faces {
        let c = surface.indices[f as usize].map(|i| surface.positions[i as usize]);
        let cross = (c[1] - c[0]).cross(c[2] - c[0]);
        let area = 0.5 * cross.length();
        if !cross.is_finite() || area <= 0.0 {
            continue;
        }
        let nf = cross / (2.0 * area);
        let nf = if nf.dot(outward) < 0.0 { -nf } else { nf };
        let centroid = (c[0] + c[1] + c[2]) / 3.0;
        let edge = c
            .iter()
            .filter(|q| **q != p)
            .map(|q| (*q - p).length())
            .fold(f64::INFINITY, f64::min);
        match groups
            .iter_mut()
            .find(|g| g.normal.normalize_or_zero().dot(nf) > GROUP_COS)
        {
            Some(g) => {
                g.normal += nf * area;
                g.centroid = (g.centroid * g.area + centroid * area) / (g.area + area);
                g.area += area;
                g.shortest_edge = g.shortest_edge.min(edge);
            }
            None => groups.push(Group {
                normal: nf * area,
                area,
                centroid,
                shortest_edge: edge,
            }),
        }
    }
    if groups.len() < 2 {
        return None;
    }
    for g in &mut groups {
        g.normal = g.normal.normalize_or_zero();
    }
    // A sharp concave crease: some group's faces lie in front of another group's plane through
    // the vertex, and the two normals are more than 60 degrees apart (a scanned surface's
    // gentle folds keep the plain rule).
    let scale = groups.iter().map(|g| g.shortest_edge).fold(0.0, f64::max);
    let concave = groups.iter().any(|a| {
        groups.iter().any(|b| {
            a.normal.dot(b.normal) < CREASE_MIN_COS && a.normal.dot(b.centroid - p) > 1e-6 * scale
        })
    });
    if !concave {
        return None;
    }
    let thickness: Vec<f64> = groups.iter().map(|g| thickness(solid, p, g)).collect();
    let (best, &thin) = thickness
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(b.1))?;
    if !thin.is_finite()
        || thickness
            .iter()
            .enumerate()
            .any(|(k, &t)| k != best && t < thin * (1.0 + SAME_THICKNESS))
    {
        return None;
    }
    Some((groups[best].normal, CREASE_MIN_COS))
}

/// The solid's thickness under group `g` next to `p`: from a point a quarter of the group's
/// shortest edge into its faces and as far inside, along the inward normal to the boundary.
fn thickness(solid: &dyn Solid, p: DVec3, g: &Group) -> f64 {
    let into = g.centroid - p;
    let along = (into - g.normal * g.normal.dot(into)).normalize_or_zero();
    let delta = 0.25 * g.shortest_edge;
    if along == DVec3::ZERO || !delta.is_finite() || delta <= 0.0 || g.normal == DVec3::ZERO {
        return f64::INFINITY;
    }
    let start = p + along * delta - g.normal * delta;
    if !solid.contains(start) {
        return f64::INFINITY;
    }
    match solid.ray_hit(start, -g.normal, f64::INFINITY) {
        Some((t, _)) => t + delta,
        None => f64::INFINITY,
    }
}

#[cfg(test)]
mod tests {
    use std::collections::HashMap;

    use super::*;
    use crate::mesh::MeshSolid;
    use crate::quadgraph::BakeParams;
    use crate::QuadGraph;

    /// The boundary of a union of 1 mm voxels (`filled(i, j, k)` over `n`), welded by lattice
    /// index, wound outward.
    fn voxel_surface(n: [i32; 3], filled: impl Fn(i32, i32, i32) -> bool) -> TriMesh {
        let inside =
            |c: [i32; 3]| (0..3).all(|a| (0..n[a]).contains(&c[a])) && filled(c[0], c[1], c[2]);
        let mut mesh = TriMesh::default();
        let mut ids: HashMap<[i32; 3], u32> = HashMap::new();
        let mut vertex = |mesh: &mut TriMesh, key: [i32; 3]| {
            *ids.entry(key).or_insert_with(|| {
                mesh.positions.push(DVec3::new(
                    f64::from(key[0]),
                    f64::from(key[1]),
                    f64::from(key[2]),
                ));
                mesh.positions.len() as u32 - 1
            })
        };
        for i in 0..n[0] {
            for j in 0..n[1] {
                for k in 0..n[2] {
                    if !inside([i, j, k]) {
                        continue;
                    }
                    for axis in 0..3 {
                        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
                        for side in [0, 1] {
                            let mut next = [i, j, k];
                            next[axis] += 2 * side - 1;
                            if inside(next) {
                                continue;
                            }
                            let quad = [(0, 0), (1, 0), (1, 1), (0, 1)].map(|(du, dv)| {
                                let mut c = [i, j, k];
                                c[axis] += side;
                                c[u] += du;
                                c[v] += dv;
                                vertex(&mut mesh, c)
                            });
                            let [a, b, c, d] = quad;
                            if side == 1 {
                                mesh.indices.push([a, b, c]);
                                mesh.indices.push([a, c, d]);
                            } else {
                                mesh.indices.push([a, c, b]);
                                mesh.indices.push([a, d, c]);
                            }
                        }
                    }
                }
            }
        }
        mesh.compute_normals();
        mesh
    }

    /// tests/reference/pt/make_shapes.py's plate on a base (mm): base x [0, 30] y [0, 4]
    /// z [0, 16], a 2 mm plate x [5, 25] y [4, 20] z [7, 9].
    fn plate_on_base() -> TriMesh {
        voxel_surface([30, 20, 16], |i, j, k| {
            j < 4 || ((5..25).contains(&i) && (7..9).contains(&k))
        })
    }

    /// The front crease's vertices (y = 4, z = 9, strictly inside the plate's width).
    fn front_crease(mesh: &TriMesh) -> Vec<usize> {
        (0..mesh.positions.len())
            .filter(|&v| {
                let p = mesh.positions[v];
                p.y == 4.0 && p.z == 9.0 && p.x > 5.0 && p.x < 25.0
            })
            .collect()
    }

    #[test]
    fn a_concave_crease_shades_from_the_thin_wall_and_convex_edges_keep_the_average() {
        let mesh = plate_on_base();
        let solid = MeshSolid::new(mesh.clone()).expect("a closed solid");
        let creases = crease_normals(&mesh, &mesh.normals, &solid);
        let crease = front_crease(&mesh);
        assert_eq!(crease.len(), 19);
        for (v, &got) in creases.iter().enumerate() {
            let p = mesh.positions[v];
            let on_junction =
                p.y == 4.0 && (p.z == 7.0 || p.z == 9.0) && (5.0..=25.0).contains(&p.x);
            let on_foot_sides = p.y == 4.0 && (p.x == 5.0 || p.x == 25.0) && p.z > 7.0 && p.z < 9.0;
            if on_junction || on_foot_sides {
                let (n, min_cos) = got.unwrap_or_else(|| panic!("vertex {v} at {p} is a crease"));
                // The plate's faces stand on a 2 mm wall, the base's top on 4 mm, the plate's
                // ends on its 20 mm width.
                let want = if on_foot_sides {
                    DVec3::Y
                } else if p.z == 9.0 {
                    DVec3::Z
                } else {
                    -DVec3::Z
                };
                assert!(n.dot(want) > 0.999, "vertex {v} at {p}: {n}, want {want}");
                assert_eq!(min_cos, CREASE_MIN_COS);
            } else {
                // Flat faces, the base's and the plate's convex edges and corners: the plain rule.
                assert_eq!(got, None, "vertex {v} at {p}");
            }
        }
    }

    #[test]
    fn a_shading_point_on_the_plate_takes_no_weight_from_the_base_in_front() {
        let mesh = plate_on_base();
        let solid = MeshSolid::new(mesh.clone()).expect("a closed solid");
        // The auto resolution of the back-lit plate scene (1.25 mm over 30 mm): the plate is
        // 1.6 cells thick, the base's top nodes sit next to the plate's foot.
        let params = BakeParams {
            resolution: 24,
            levels: 1,
            ..Default::default()
        };
        let (graph, _) = QuadGraph::bake(&mesh, &solid, &params, &mut |_| {}).expect("bake");
        let finest = graph.finest();
        let crease = front_crease(&mesh);
        let mut base_nodes_near = 0;
        for &v in &crease {
            let (links, weights) = (graph.shading.links[v], graph.shading.weights[v]);
            let total: f64 = weights.iter().sum();
            assert!(
                (total - 1.0).abs() < 1e-9,
                "vertex {v}: weights sum to {total}"
            );
            for (&s, &w) in links.iter().zip(&weights) {
                if w == 0.0 {
                    continue;
                }
                let n = finest.surface_normals[s as usize];
                assert!(
                    n.dot(DVec3::Z) > CREASE_MIN_COS,
                    "crease vertex {v} takes {w} from surface node {s} (normal {n}): not the plate's face"
                );
            }
            // The base's top nodes in front of the plate are there to be taken (within reach).
            let p = mesh.positions[v];
            base_nodes_near += (0..finest.surface_count())
                .filter(|&s| {
                    let q = finest.positions[finest.inner_count() + s];
                    finest.surface_normals[s].dot(DVec3::Y) > 0.9
                        && q.z > 9.0
                        && (q - p).length() < 2.0 * finest.spacing
                })
                .count();
        }
        assert!(
            base_nodes_near > 0,
            "no base node next to the crease: the test sees nothing"
        );
        // The plain rule (the averaged normal, n . n_node > 0) does take base nodes there: the
        // assertions above are what the crease rule changes.
        let fi = finest.inner_count();
        let plain = super::super::shepard::ShepardIndex::new(
            &finest.positions[fi..],
            Some(&finest.surface_normals),
        );
        let mixed = crease.iter().any(|&v| {
            let (ids, w) = plain.weights::<4>(
                mesh.positions[v],
                Some(mesh.normals[v]),
                2.0 * finest.spacing,
                1e-3 * finest.spacing,
            );
            ids.iter()
                .zip(&w)
                .any(|(&s, &w)| w > 0.0 && finest.surface_normals[s as usize].dot(DVec3::Y) > 0.9)
        });
        assert!(
            mixed,
            "the averaged normal takes no base node: the test sees nothing"
        );
    }

    #[test]
    fn a_crease_vertex_sees_the_base_in_front_and_itself() {
        let mesh = plate_on_base();
        let links = crate::frame::bounce::BounceLinks::build(
            &mesh,
            &crate::frame::bounce::BounceParams::default(),
        )
        .expect("links");
        for v in front_crease(&mesh) {
            // From the plate's face the base in front (7 mm deep, 30 mm wide) fills most of the
            // lower half of the hemisphere (an infinite floor: 1/2); the rays that land next to
            // the vertex are its own exitance. Rays from the averaged normal started in the
            // base's plane and lost every ray towards it (form factor ~0).
            let f = links.form_factor(v);
            assert!((0.25..=0.55).contains(&f), "vertex {v}: form factor {f}");
            assert!(
                links
                    .incoming(v)
                    .iter()
                    .any(|&(y, w)| y as usize == v && w > 0.0),
                "vertex {v}: no self-link"
            );
        }
    }
}
