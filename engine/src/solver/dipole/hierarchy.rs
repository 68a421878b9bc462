//! The face-cluster hierarchy (paper section 5.1.1; Garland, Willmott and Heckbert 2001): a binary
//! tree whose leaves are the mesh's triangles and whose every node is a connected patch of them.
//!
//! Built bottom-up in merge rounds on the dual graph (clusters are nodes, shared edges are dual
//! edges). In each round every dual edge gets the cost of the cluster its contraction would make,
//! Garland's shape irregularity P^2 / (4 pi A) (perimeter P, area A: 1 for a disc), and the edges are
//! contracted greedily in order of cost, each cluster at most once per round (a matching), so each
//! round roughly halves the cluster count and the tree stays about log2(T) rounds deep. Like the
//! paper (and unlike Garland's planarity term) the cost ignores curvature: planarity is checked at
//! linking time, where the geometry may have changed ([`NodeGeometry::planarity`]). Components that
//! share no edge (separate shells) are finally paired by proximity along a Morton curve.
//!
//! Node numbering: leaf `f` is triangle `f` (`0..T`); internal nodes follow in creation order, so
//! the nodes of merge round `k` are the contiguous range `rounds[k]`: a GPU pull can process round
//! by round (children always come from earlier rounds) and a push in reverse.
//!
//! The topology (tree, cluster boundaries, vertex-to-face table) depends on the mesh's triangles
//! only; [`FaceClusterHierarchy::refit`] recomputes the geometry (areas, centroids, normals,
//! planarity, bounding spheres) for new vertex positions without rebuilding (the paper's
//! deformation path).
//!
//! ```
//! use translucent::mesh::shapes::Shape;
//! use translucent::solver::dipole::FaceClusterHierarchy;
//! let mesh = Shape::Sphere { radius: 10.0 }.triangulate(16);
//! let (mut tree, stats) = FaceClusterHierarchy::build(&mesh)?;
//! assert_eq!(tree.nodes.len(), 2 * mesh.indices.len() - 1); // binary
//! let root = tree.root();
//! assert!((tree.geometry[root as usize].area - mesh.surface_area()).abs() < 1e-9);
//! let moved: Vec<_> = mesh.positions.iter().map(|p| *p * 2.0).collect();
//! let report = tree.refit(&moved)?;
//! assert_eq!(report.changed_nodes, tree.nodes.len());
//! assert!((tree.geometry[root as usize].area - 4.0 * mesh.surface_area()).abs() < 1e-6);
//! # let _ = stats;
//! # Ok::<(), translucent::solver::dipole::DipoleError>(())
//! ```

use std::ops::Range;

use glam::DVec3;
use rayon::prelude::*;

use super::DipoleError;
use crate::mesh::TriMesh;

/// "No node": the parent of the root, the children of a leaf.
pub const NO_NODE: u32 = u32::MAX;

/// One node's links in the tree.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ClusterNode {
    /// The two merged clusters; [`NO_NODE`] for a leaf (a triangle).
    pub children: [u32; 2],
    pub parent: u32,
}

impl ClusterNode {
    pub fn is_leaf(&self) -> bool {
        self.children[0] == NO_NODE
    }
}

/// A node's geometry for the current vertex positions.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct NodeGeometry {
    /// Area-weighted centroid (the cluster's "midpoint", where it receives), mm.
    pub centroid: DVec3,
    /// Total triangle area A, mm^2.
    pub area: f64,
    /// Sum of area x unit normal: its length is the area A' projected onto the average plane.
    pub vector_area: DVec3,
    /// Unit average normal (vector_area normalized; +Y when it vanishes).
    pub normal: DVec3,
    /// A'/A in [0, 1]: 1 for a planar cluster (the paper's curvature measure, section 5.1.1).
    pub planarity: f64,
    /// Radius of a sphere about `centroid` holding every triangle of the cluster, mm.
    pub radius: f64,
    /// Second moment of the cluster's area about `centroid`, int (x - c)(x - c)^T dA (mm^4), as
    /// xx, yy, zz, xy, xz, yz: what the second-order point sample needs.
    pub second_moment: [f64; 6],
}

/// x x^T scaled, as xx, yy, zz, xy, xz, yz.
fn outer(x: DVec3, w: f64) -> [f64; 6] {
    [
        w * x.x * x.x,
        w * x.y * x.y,
        w * x.z * x.z,
        w * x.x * x.y,
        w * x.x * x.z,
        w * x.y * x.z,
    ]
}

/// Counts and times of a build.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct HierarchyStats {
    pub triangles: usize,
    pub nodes: usize,
    /// Merge rounds on the dual graph, then proximity rounds joining separate components.
    pub rounds: usize,
    pub component_rounds: usize,
    /// Longest leaf-to-root path (edges).
    pub depth: usize,
    /// Directed boundary edges stored over all internal nodes.
    pub boundary_edges: usize,
    pub seconds: f64,
}

/// What [`FaceClusterHierarchy::refit`] changed.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RefitReport {
    pub moved_vertices: usize,
    /// Nodes with a moved vertex in their subtree (their links need new form factors).
    pub changed_nodes: usize,
    /// Per node: whether it changed.
    pub changed: Vec<bool>,
}

/// The face-cluster hierarchy of one triangle mesh (module doc).
#[derive(Clone, Debug, PartialEq)]
pub struct FaceClusterHierarchy {
    /// The mesh's triangles (the leaves' topology).
    pub indices: Vec<[u32; 3]>,
    /// Current vertex positions (mm).
    pub positions: Vec<DVec3>,
    /// Leaves `0..T` (triangle index), then internal nodes in creation order; the root is last.
    pub nodes: Vec<ClusterNode>,
    /// Internal node ranges per round, bottom-up.
    pub rounds: Vec<Range<u32>>,
    /// For internal node `T + i`: its boundary edges are `boundary_edges[offsets[i]..offsets[i+1]]`.
    pub boundary_offsets: Vec<u32>,
    /// Directed boundary edges (vertex pairs) in the winding of their triangle.
    pub boundary_edges: Vec<[u32; 2]>,
    /// Vertex `v`'s triangles are `vertex_faces[vertex_face_offsets[v]..vertex_face_offsets[v+1]]`.
    pub vertex_face_offsets: Vec<u32>,
    pub vertex_faces: Vec<u32>,
    /// Per node, for `positions`.
    pub geometry: Vec<NodeGeometry>,
}

/// The structural checks the hierarchy needs (faces, index range, finite coordinates, and a size
/// the u32 node numbering holds).
pub(crate) fn check_mesh(mesh: &TriMesh) -> Result<(), DipoleError> {
    mesh.check_structure()?;
    if mesh.indices.len() >= (u32::MAX / 2) as usize {
        return Err(DipoleError::Invalid(format!(
            "{} triangles: more than the hierarchy's u32 node numbering holds",
            mesh.indices.len()
        )));
    }
    Ok(())
}

/// Irregularity of a cluster of perimeter `p` and area `a` (Garland et al. 2001, E_shape).
fn irregularity(p: f64, a: f64) -> f64 {
    p * p / (4.0 * std::f64::consts::PI * a.max(1e-300))
}

fn morton(p: DVec3, lo: DVec3, extent: f64) -> u64 {
    let spread = |x: f64| -> u64 {
        let mut v = ((x.clamp(0.0, 1.0)) * 1_048_575.0) as u64; // 20 bits
        v = (v | (v << 32)) & 0x1f00000000ffff;
        v = (v | (v << 16)) & 0x1f0000ff0000ff;
        v = (v | (v << 8)) & 0x100f00f00f00f00f;
        v = (v | (v << 4)) & 0x10c30c30c30c30c3;
        (v | (v << 2)) & 0x1249249249249249
    };
    let q = (p - lo) / extent.max(1e-300);
    spread(q.x) | (spread(q.y) << 1) | (spread(q.z) << 2)
}

/// Merges two sorted boundary lists, cancelling edges traversed both ways (interior edges of the
/// merged cluster).
fn merge_boundaries(a: &[[u32; 2]], b: &[[u32; 2]]) -> Vec<[u32; 2]> {
    let mut all: Vec<[u32; 2]> = a.iter().chain(b).copied().collect();
    let key = |e: &[u32; 2]| (e[0].min(e[1]), e[0].max(e[1]), e[0]);
    all.sort_unstable_by_key(key);
    let mut out = Vec::with_capacity(all.len());
    let mut i = 0;
    while i < all.len() {
        let e = all[i];
        if i + 1 < all.len() && all[i + 1] == [e[1], e[0]] {
            i += 2;
            continue;
        }
        out.push(e);
        i += 1;
    }
    out
}

/// Sorted adjacency (neighbour, shared edge length) with duplicates summed and `skip` removed.
fn normalize_adjacency(mut v: Vec<(u32, f64)>, skip: [u32; 2]) -> Vec<(u32, f64)> {
    v.retain(|(n, _)| !skip.contains(n));
    v.sort_unstable_by_key(|&(n, _)| n);
    let mut out: Vec<(u32, f64)> = Vec::with_capacity(v.len());
    for (n, l) in v {
        match out.last_mut() {
            Some((m, s)) if *m == n => *s += l,
            _ => out.push((n, l)),
        }
    }
    out
}

impl FaceClusterHierarchy {
    /// Builds the hierarchy of `mesh` (any triangle mesh: open, with holes, several components;
    /// zero-area triangles are leaves of zero area). Fails only on structurally bad input.
    pub fn build(mesh: &TriMesh) -> Result<(FaceClusterHierarchy, HierarchyStats), DipoleError> {
        let start = std::time::Instant::now();
        check_mesh(mesh)?;
        let t = mesh.indices.len();
        let pos = &mesh.positions;
        let mut nodes: Vec<ClusterNode> = vec![
            ClusterNode {
                children: [NO_NODE; 2],
                parent: NO_NODE,
            };
            t
        ];
        let mut area: Vec<f64> = Vec::with_capacity(2 * t);
        let mut perimeter: Vec<f64> = Vec::with_capacity(2 * t);
        let mut centroid: Vec<DVec3> = Vec::with_capacity(2 * t);
        let leaf: Vec<(f64, f64, DVec3)> = mesh
            .indices
            .par_iter()
            .map(|&[a, b, c]| {
                let (a, b, c) = (pos[a as usize], pos[b as usize], pos[c as usize]);
                let p = (b - a).length() + (c - b).length() + (a - c).length();
                (0.5 * (b - a).cross(c - a).length(), p, (a + b + c) / 3.0)
            })
            .collect();
        for (a, p, c) in leaf {
            area.push(a);
            perimeter.push(p);
            centroid.push(c);
        }
        // Dual edges of the leaves: triangles sharing an undirected mesh edge.
        let mut edge_faces: Vec<(u64, u32)> = mesh
            .indices
            .par_iter()
            .enumerate()
            .flat_map_iter(|(f, tri)| {
                (0..3).map(move |k| {
                    let (u, v) = (tri[k], tri[(k + 1) % 3]);
                    (((u.min(v) as u64) << 32) | u.max(v) as u64, f as u32)
                })
            })
            .collect();
        edge_faces.par_sort_unstable();
        let mut adjacency: Vec<Vec<(u32, f64)>> = vec![Vec::new(); t];
        let mut i = 0;
        while i < edge_faces.len() {
            let mut j = i + 1;
            while j < edge_faces.len() && edge_faces[j].0 == edge_faces[i].0 {
                j += 1;
            }
            if j - i >= 2 {
                let key = edge_faces[i].0;
                let (u, v) = ((key >> 32) as usize, (key & 0xffff_ffff) as usize);
                let len = (pos[u] - pos[v]).length();
                for x in i..j {
                    for y in i..j {
                        let (fx, fy) = (edge_faces[x].1, edge_faces[y].1);
                        if fx != fy {
                            adjacency[fx as usize].push((fy, len));
                        }
                    }
                }
            }
            i = j;
        }
        drop(edge_faces);
        adjacency
            .par_iter_mut()
            .enumerate()
            .for_each(|(f, adj)| *adj = normalize_adjacency(std::mem::take(adj), [f as u32; 2]));
        let leaf_boundary = |f: usize| -> Vec<[u32; 2]> {
            let [a, b, c] = mesh.indices[f];
            let mut v = vec![[a, b], [b, c], [c, a]];
            v.sort_unstable_by_key(|e| (e[0].min(e[1]), e[0].max(e[1]), e[0]));
            v
        };
        let mut boundaries: Vec<Vec<[u32; 2]>> = Vec::new(); // internal nodes
        let boundary_of = |n: u32, boundaries: &Vec<Vec<[u32; 2]>>| -> Vec<[u32; 2]> {
            if (n as usize) < t {
                leaf_boundary(n as usize)
            } else {
                boundaries[n as usize - t].clone()
            }
        };

        let mut active: Vec<u32> = (0..t as u32).collect();
        let mut rounds: Vec<Range<u32>> = Vec::new();
        let mut merge_rounds = 0;
        // Merge rounds on the dual graph.
        loop {
            let mut candidates: Vec<(f64, u32, u32)> = active
                .par_iter()
                .flat_map_iter(|&c| {
                    let adj = &adjacency[c as usize];
                    let (pc, ac) = (perimeter[c as usize], area[c as usize]);
                    let (perimeter, area) = (&perimeter, &area);
                    adj.iter()
                        .filter(move |(d, _)| *d > c)
                        .map(move |&(d, len)| {
                            let p = pc + perimeter[d as usize] - 2.0 * len;
                            (irregularity(p, ac + area[d as usize]), c, d)
                        })
                })
                .collect();
            if candidates.is_empty() {
                break;
            }
            candidates.par_sort_unstable_by(|a, b| {
                a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2))
            });
            let mut matched = vec![false; nodes.len()];
            let mut pairs: Vec<(u32, u32, f64)> = Vec::new();
            for &(_, c, d) in &candidates {
                if !matched[c as usize] && !matched[d as usize] {
                    matched[c as usize] = true;
                    matched[d as usize] = true;
                    let shared = adjacency[c as usize]
                        .binary_search_by_key(&d, |&(n, _)| n)
                        .map_or(0.0, |k| adjacency[c as usize][k].1);
                    pairs.push((c, d, shared));
                }
            }
            drop(candidates);
            let first = nodes.len() as u32;
            // Where each old cluster goes: its new parent, or itself.
            let mut target: Vec<u32> = (0..nodes.len() as u32).collect();
            for (k, &(c, d, _)) in pairs.iter().enumerate() {
                let id = first + k as u32;
                target[c as usize] = id;
                target[d as usize] = id;
                nodes[c as usize].parent = id;
                nodes[d as usize].parent = id;
                nodes.push(ClusterNode {
                    children: [c, d],
                    parent: NO_NODE,
                });
                let (ac, ad) = (area[c as usize], area[d as usize]);
                let a = ac + ad;
                area.push(a);
                perimeter.push(perimeter[c as usize] + perimeter[d as usize] - 2.0 * pairs[k].2);
                centroid.push(if a > 0.0 {
                    (centroid[c as usize] * ac + centroid[d as usize] * ad) / a
                } else {
                    0.5 * (centroid[c as usize] + centroid[d as usize])
                });
            }
            // Boundaries of the new clusters.
            let new_boundaries: Vec<Vec<[u32; 2]>> = pairs
                .par_iter()
                .map(|&(c, d, _)| {
                    merge_boundaries(&boundary_of(c, &boundaries), &boundary_of(d, &boundaries))
                })
                .collect();
            boundaries.extend(new_boundaries);
            // Adjacency of the next round's clusters, remapped through `target`.
            let remap = |adj: &[(u32, f64)]| -> Vec<(u32, f64)> {
                adj.iter().map(|&(n, l)| (target[n as usize], l)).collect()
            };
            let merged: Vec<Vec<(u32, f64)>> = pairs
                .par_iter()
                .enumerate()
                .map(|(k, &(c, d, _))| {
                    let mut v = remap(&adjacency[c as usize]);
                    v.extend(remap(&adjacency[d as usize]));
                    let id = first + k as u32;
                    normalize_adjacency(v, [id, id])
                })
                .collect();
            let survivors: Vec<u32> = active
                .iter()
                .copied()
                .filter(|&c| !matched[c as usize])
                .collect();
            let remapped: Vec<Vec<(u32, f64)>> = survivors
                .par_iter()
                .map(|&c| normalize_adjacency(remap(&adjacency[c as usize]), [c, c]))
                .collect();
            for (c, adj) in survivors.iter().zip(remapped) {
                adjacency[*c as usize] = adj;
            }
            for &(c, d, _) in &pairs {
                adjacency[c as usize] = Vec::new();
                adjacency[d as usize] = Vec::new();
            }
            adjacency.extend(merged);
            rounds.push(first..nodes.len() as u32);
            merge_rounds += 1;
            active = survivors;
            active.extend(first..nodes.len() as u32);
        }
        drop(adjacency);
        // Separate components: pair neighbours along a Morton curve of the centroids.
        let mut component_rounds = 0;
        while active.len() > 1 {
            let (lo, hi) = active.iter().fold(
                (DVec3::splat(f64::MAX), DVec3::splat(f64::MIN)),
                |(lo, hi), &n| (lo.min(centroid[n as usize]), hi.max(centroid[n as usize])),
            );
            let extent = (hi - lo).max_element();
            active.sort_by_key(|&n| (morton(centroid[n as usize], lo, extent), n));
            let first = nodes.len() as u32;
            let mut next = Vec::with_capacity(active.len() / 2 + 1);
            for pair in active.chunks(2) {
                let [c, d] = match pair {
                    [c, d] => [*c, *d],
                    _ => {
                        next.push(pair[0]);
                        continue;
                    }
                };
                let id = nodes.len() as u32;
                nodes[c as usize].parent = id;
                nodes[d as usize].parent = id;
                nodes.push(ClusterNode {
                    children: [c, d],
                    parent: NO_NODE,
                });
                let (ac, ad) = (area[c as usize], area[d as usize]);
                area.push(ac + ad);
                centroid.push(if ac + ad > 0.0 {
                    (centroid[c as usize] * ac + centroid[d as usize] * ad) / (ac + ad)
                } else {
                    0.5 * (centroid[c as usize] + centroid[d as usize])
                });
                perimeter.push(perimeter[c as usize] + perimeter[d as usize]);
                let mut b = boundary_of(c, &boundaries);
                b.extend(boundary_of(d, &boundaries));
                boundaries.push(b);
                next.push(id);
            }
            rounds.push(first..nodes.len() as u32);
            component_rounds += 1;
            active = next;
        }
        let mut boundary_offsets = Vec::with_capacity(boundaries.len() + 1);
        boundary_offsets.push(0u32);
        let total: usize = boundaries.iter().map(Vec::len).sum();
        if total >= u32::MAX as usize {
            return Err(DipoleError::Invalid(format!(
                "{total} cluster boundary edges overflow the u32 offsets"
            )));
        }
        let mut boundary_edges = Vec::with_capacity(total);
        for b in &boundaries {
            boundary_edges.extend_from_slice(b);
            boundary_offsets.push(boundary_edges.len() as u32);
        }
        drop(boundaries);
        let (vertex_face_offsets, vertex_faces) =
            vertex_face_table(mesh.positions.len(), &mesh.indices);
        let mut tree = FaceClusterHierarchy {
            indices: mesh.indices.clone(),
            positions: Vec::new(),
            nodes,
            rounds,
            boundary_offsets,
            boundary_edges,
            vertex_face_offsets,
            vertex_faces,
            geometry: Vec::new(),
        };
        tree.refit(&mesh.positions)?;
        let stats = HierarchyStats {
            triangles: t,
            nodes: tree.nodes.len(),
            rounds: merge_rounds,
            component_rounds,
            depth: tree.depth(),
            boundary_edges: tree.boundary_edges.len(),
            seconds: start.elapsed().as_secs_f64(),
        };
        Ok((tree, stats))
    }

    /// Number of leaves (triangles).
    pub fn leaf_count(&self) -> usize {
        self.indices.len()
    }

    /// The root node (the last one).
    pub fn root(&self) -> u32 {
        self.nodes.len() as u32 - 1
    }

    /// Longest leaf-to-root path.
    pub fn depth(&self) -> usize {
        let mut depth = vec![0usize; self.nodes.len()];
        // Parents come after their children: one reverse sweep gives each node's depth.
        for n in (0..self.nodes.len()).rev() {
            let p = self.nodes[n].parent;
            if p != NO_NODE {
                depth[n] = depth[p as usize] + 1;
            }
        }
        depth.into_iter().max().unwrap_or(0)
    }

    /// The directed boundary edges of node `n`, as vertex pairs.
    pub fn boundary(&self, n: u32) -> &[[u32; 2]] {
        let t = self.leaf_count();
        if (n as usize) < t {
            &[]
        } else {
            let i = n as usize - t;
            let (a, b) = (self.boundary_offsets[i], self.boundary_offsets[i + 1]);
            &self.boundary_edges[a as usize..b as usize]
        }
    }

    /// Node `n`'s boundary as position pairs (a leaf's three edges; a cluster's outline).
    pub fn boundary_segments(&self, n: u32) -> Vec<(DVec3, DVec3)> {
        let p = &self.positions;
        if (n as usize) < self.leaf_count() {
            let [a, b, c] = self.indices[n as usize].map(|i| p[i as usize]);
            vec![(a, b), (b, c), (c, a)]
        } else {
            self.boundary(n)
                .iter()
                .map(|&[u, v]| (p[u as usize], p[v as usize]))
                .collect()
        }
    }

    /// The corners of triangle `f`.
    pub fn triangle(&self, f: usize) -> [DVec3; 3] {
        self.indices[f].map(|i| self.positions[i as usize])
    }

    /// Recomputes every node's geometry for new vertex positions (same count and order as at
    /// build); the tree is kept. Reports which nodes have a moved vertex below them.
    pub fn refit(&mut self, positions: &[DVec3]) -> Result<RefitReport, DipoleError> {
        let vertex_count = self.vertex_face_offsets.len().saturating_sub(1);
        if positions.len() != vertex_count {
            return Err(DipoleError::Invalid(format!(
                "refit with {} positions for a mesh of {vertex_count} vertices (a topology change \
                 needs a new hierarchy)",
                positions.len()
            )));
        }
        if let Some(v) = positions.iter().position(|p| !p.is_finite()) {
            return Err(DipoleError::Invalid(format!(
                "refit: vertex {v} is not finite ({})",
                positions[v]
            )));
        }
        let moved: Vec<bool> = if self.positions.len() == positions.len() {
            positions
                .par_iter()
                .zip(&self.positions)
                .map(|(a, b)| a != b)
                .collect()
        } else {
            vec![true; positions.len()]
        };
        self.positions = positions.to_vec();
        let t = self.leaf_count();
        let mut geometry = vec![NodeGeometry::default(); self.nodes.len()];
        let mut changed = vec![false; self.nodes.len()];
        let pos = &self.positions;
        geometry[..t]
            .par_iter_mut()
            .zip(changed[..t].par_iter_mut())
            .zip(self.indices.par_iter())
            .for_each(|((g, ch), tri)| {
                let [a, b, c] = tri.map(|i| pos[i as usize]);
                let n2 = (b - a).cross(c - a) * 0.5;
                let area = n2.length();
                let centroid = (a + b + c) / 3.0;
                let radius = [a, b, c]
                    .iter()
                    .map(|p| (*p - centroid).length())
                    .fold(0.0, f64::max);
                // A triangle's second moment about its centroid: (A/12) sum d_i d_i^T.
                let mut second_moment = [0.0; 6];
                for p in [a, b, c] {
                    let o = outer(p - centroid, area / 12.0);
                    (0..6).for_each(|k| second_moment[k] += o[k]);
                }
                *g = NodeGeometry {
                    centroid,
                    area,
                    vector_area: n2,
                    normal: if area > 0.0 { n2 / area } else { DVec3::Y },
                    planarity: 1.0,
                    radius,
                    second_moment,
                };
                *ch = tri.iter().any(|&i| moved[i as usize]);
            });
        for round in &self.rounds {
            let (done, todo) = geometry.split_at_mut(round.start as usize);
            let (changed_done, changed_todo) = changed.split_at_mut(round.start as usize);
            let nodes = &self.nodes[round.start as usize..round.end as usize];
            todo[..nodes.len()]
                .par_iter_mut()
                .zip(changed_todo[..nodes.len()].par_iter_mut())
                .zip(nodes.par_iter())
                .for_each(|((g, ch), node)| {
                    let [x, y] = node.children.map(|c| &done[c as usize]);
                    *ch = node.children.iter().any(|&c| changed_done[c as usize]);
                    *g = combine(x, y);
                });
        }
        self.geometry = geometry;
        let changed_nodes = changed.iter().filter(|&&c| c).count();
        Ok(RefitReport {
            moved_vertices: moved.iter().filter(|&&m| m).count(),
            changed_nodes,
            changed,
        })
    }

    /// Ancestors of `n` including itself, bottom-up.
    pub fn ancestors(&self, n: u32) -> impl Iterator<Item = u32> + '_ {
        std::iter::successors(Some(n), |&m| {
            let p = self.nodes[m as usize].parent;
            (p != NO_NODE).then_some(p)
        })
    }
}

/// The geometry of the union of two clusters.
fn combine(x: &NodeGeometry, y: &NodeGeometry) -> NodeGeometry {
    let area = x.area + y.area;
    let centroid = if area > 0.0 {
        (x.centroid * x.area + y.centroid * y.area) / area
    } else {
        0.5 * (x.centroid + y.centroid)
    };
    let vector_area = x.vector_area + y.vector_area;
    let projected = vector_area.length();
    let radius = ((x.centroid - centroid).length() + x.radius)
        .max((y.centroid - centroid).length() + y.radius);
    // Parallel axis theorem: each child's moment moved to the parent's centroid.
    let mut second_moment = [0.0; 6];
    for g in [x, y] {
        let o = outer(g.centroid - centroid, g.area);
        (0..6).for_each(|k| second_moment[k] += g.second_moment[k] + o[k]);
    }
    NodeGeometry {
        centroid,
        area,
        vector_area,
        normal: if projected > 0.0 {
            vector_area / projected
        } else {
            DVec3::Y
        },
        planarity: if area > 0.0 {
            (projected / area).min(1.0)
        } else {
            1.0
        },
        radius,
        second_moment,
    }
}

/// CSR of the triangles around each vertex.
fn vertex_face_table(vertices: usize, indices: &[[u32; 3]]) -> (Vec<u32>, Vec<u32>) {
    let mut count = vec![0u32; vertices + 1];
    for tri in indices {
        for &v in tri {
            count[v as usize + 1] += 1;
        }
    }
    for v in 0..vertices {
        count[v + 1] += count[v];
    }
    let mut fill = count.clone();
    let mut faces = vec![0u32; count[vertices] as usize];
    for (f, tri) in indices.iter().enumerate() {
        for &v in tri {
            faces[fill[v as usize] as usize] = f as u32;
            fill[v as usize] += 1;
        }
    }
    (count, faces)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::shapes::Shape;

    #[test]
    fn every_cluster_is_a_connected_patch_with_the_right_outline() {
        let mesh = Shape::Torus {
            major: 10.0,
            minor: 3.0,
        }
        .triangulate(24);
        let (tree, stats) = FaceClusterHierarchy::build(&mesh).unwrap();
        let t = mesh.indices.len();
        assert_eq!(tree.nodes.len(), 2 * t - 1);
        assert_eq!(stats.component_rounds, 0, "a torus is one component");
        // log-depth: a balanced binary tree has ceil(log2 T); greedy matching leaves some slack.
        let balanced = (t as f64).log2().ceil() as usize;
        assert!(
            stats.depth <= 2 * balanced,
            "depth {} for {t} leaves",
            stats.depth
        );
        // Leaves below each node, and their boundary recomputed from scratch.
        let mut leaves: Vec<Vec<u32>> = vec![Vec::new(); tree.nodes.len()];
        for n in 0..tree.nodes.len() {
            if tree.nodes[n].is_leaf() {
                leaves[n].push(n as u32);
            } else {
                let [a, b] = tree.nodes[n].children;
                let mut v = leaves[a as usize].clone();
                v.extend(&leaves[b as usize]);
                leaves[n] = v;
            }
        }
        for (n, faces) in leaves.iter().enumerate().skip(t) {
            let mut edges: Vec<[u32; 2]> = Vec::new();
            for &f in faces {
                let [a, b, c] = mesh.indices[f as usize];
                edges.extend([[a, b], [b, c], [c, a]]);
            }
            let mut outline: Vec<[u32; 2]> = edges
                .iter()
                .copied()
                .filter(|&[u, v]| !edges.contains(&[v, u]))
                .collect();
            let mut stored = tree.boundary(n as u32).to_vec();
            outline.sort_unstable();
            stored.sort_unstable();
            assert_eq!(outline, stored, "node {n}");
            let g = &tree.geometry[n];
            let area: f64 = faces.iter().map(|&f| tree.geometry[f as usize].area).sum();
            assert!((g.area - area).abs() < 1e-9 * area);
            for &f in faces {
                for p in tree.triangle(f as usize) {
                    assert!((p - g.centroid).length() <= g.radius * (1.0 + 1e-12));
                }
            }
            assert!((0.0..=1.0).contains(&g.planarity));
            // The combined second moment against a direct sum over the leaves (about g's centroid).
            let mut direct = [0.0; 6];
            for &f in &leaves[n] {
                let l = &tree.geometry[f as usize];
                let o = outer(l.centroid - g.centroid, l.area);
                (0..6).for_each(|k| direct[k] += l.second_moment[k] + o[k]);
            }
            let scale = g.second_moment[..3].iter().sum::<f64>();
            for (k, d) in direct.iter().enumerate() {
                assert!((d - g.second_moment[k]).abs() <= 1e-9 * scale, "node {n}");
            }
        }
        // The root covers the closed torus: its outline is empty, its net normal ~0.
        assert!(tree.boundary(tree.root()).is_empty());
        assert!(tree.geometry[tree.root() as usize].planarity < 1e-9);
        // Rounds are contiguous, children always from earlier rounds.
        for r in &tree.rounds {
            for n in r.clone() {
                for c in tree.nodes[n as usize].children {
                    assert!(c < r.start);
                }
            }
        }
    }

    #[test]
    fn separate_components_and_degenerate_faces_are_joined() {
        let a = Shape::Sphere { radius: 2.0 }.triangulate(6);
        let mut mesh = a.clone();
        let offset = a.positions.len() as u32;
        mesh.positions
            .extend(a.positions.iter().map(|p| *p + DVec3::X * 10.0));
        mesh.indices
            .extend(a.indices.iter().map(|t| t.map(|i| i + offset)));
        // A zero-area sliver sharing a vertex.
        mesh.indices.push([0, 0, 1]);
        let (tree, stats) = FaceClusterHierarchy::build(&mesh).unwrap();
        assert!(stats.component_rounds >= 1);
        assert_eq!(tree.nodes.len(), 2 * mesh.indices.len() - 1);
        let root = tree.geometry[tree.root() as usize];
        assert!((root.area - 2.0 * a.surface_area()).abs() < 1e-9);
        assert!(tree
            .geometry
            .iter()
            .all(|g| g.centroid.is_finite() && g.radius.is_finite()));
    }

    #[test]
    fn refit_reports_the_moved_subtrees_only_and_refuses_a_new_topology() {
        let mesh = Shape::Sphere { radius: 5.0 }.triangulate(12);
        let (mut tree, _) = FaceClusterHierarchy::build(&mesh).unwrap();
        let before = tree.clone();
        let report = tree.refit(&mesh.positions).unwrap();
        assert_eq!(report.moved_vertices, 0);
        assert_eq!(report.changed_nodes, 0);
        assert_eq!(tree, before);
        let mut moved = mesh.positions.clone();
        moved[0] += DVec3::Y;
        let report = tree.refit(&moved).unwrap();
        let faces = mesh.indices.iter().filter(|t| t.contains(&0)).count();
        assert!(report.changed_nodes > faces && report.changed_nodes < tree.nodes.len() / 4);
        assert!(report.changed[tree.root() as usize]);
        assert!(tree.refit(&moved[1..]).is_err());
        moved[3] = DVec3::NAN;
        assert!(tree.refit(&moved).is_err());
    }
}
