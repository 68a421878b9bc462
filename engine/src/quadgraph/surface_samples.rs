//! Interior sample points of the display mesh (issue 12 item 4): per display vertex, a point a
//! fixed depth inside along the vertex normal, the finest-level tetrahedron that contains it and
//! the weights that interpolate the inner nodes' phi there. The exit query reconstructs exitance
//! at the vertex from that interior value and the local 1D profile (`solver::transport::
//! profile_from_sample`) instead of interpolating the surface nodes' values, whose one-neighbour
//! differences draw the lattice on the surface (DESIGN 2.6).
//!
//! Interpolation: linear moving least squares over the `SAMPLE_NODES` inner nodes nearest to the
//! sample point among those within three rings of the graph around its tetrahedron (connected
//! through the material, so a sample never reads across a gap), weights (1 - (d / R)^2)^2 with R
//! just beyond the farthest of them. Exact for linear phi.
//!
//! ```
//! use translucent::mesh::shapes::Shape;
//! use translucent::quadgraph::BakeParams;
//! use translucent::QuadGraph;
//! let ball = Shape::Sphere { radius: 10.0 };
//! let params = BakeParams { resolution: 12, levels: 1, ..Default::default() };
//! let (graph, _) = QuadGraph::bake(&ball.triangulate(16), &ball, &params, &mut |_| {})?;
//! let samples = &graph.samples;
//! assert_eq!(samples.depth.len(), graph.surface.positions.len());
//! // Weights reproduce a constant (and any linear field).
//! assert!(samples.weights.iter().all(|w| (w.iter().sum::<f64>() - 1.0).abs() < 1e-9));
//! # Ok::<(), translucent::quadgraph::BakeError>(())
//! ```

use std::collections::HashSet;

use glam::{DMat4, DVec3, DVec4};
use kiddo::immutable::float::kdtree::ImmutableKdTree;
use kiddo::SquaredEuclidean;
use rayon::prelude::*;

use super::graph::{GraphLevel, NO_NODE};
use super::lateral::{lateral_stencils, LATERAL_SLOTS, LATERAL_SPACINGS};
use crate::mesh::{Solid, TriMesh};
use crate::solver::transport::SurfaceCurvature;

/// Inner nodes per sample point.
pub const SAMPLE_NODES: usize = 16;

/// The sample depth in finest lattice spacings, and at most this share of the wall thickness
/// below the vertex (so a sample stays in its own half of a thin wall). The 1D profile that
/// carries the sample to the surface (`solver::transport::curved_profile_from_sample`) has no
/// lateral term: where phi varies along the surface (Laplacian lambda phi across it) the exact
/// profile is phi'' = (s^2 - lambda) phi, and phi(0) read from depth d is off by about
/// -lambda d^2 (1/2 + d / (6 h)) / (1 + d / h): dark on an unlit side (a lateral minimum), bright
/// under the light. At 1.5 spacings (1.25 mm on a 20 mm object) that was the back-lit bunny's
/// unlit side at 0.91 of path tracing (lambda ~ 1 / (2 mm)^2: -8.8%); at 0.875 it is -3.5%
/// (measured: bunny side 10.9 -> 9.4%, front 8.3 -> 8.2%). Shallower, the 16 nodes' lattice
/// shows: 0.75 spacings side 9.3 / front 8.3%, but the environment-lit skin1 sphere of
/// `tests/surface_interior.rs` at 16 cells varies by 1.03% over its vertices (0.84% at 0.875,
/// 0.32% at 1.5; the bound is 1%); 1.0: 9.6 / 8.1%. benches/RESULTS.md, "The bunny, wave 10".
/// Kept at 1.5: at render's defaults (auto resolution, 64 px) skin1's blue under a constant
/// environment (`tools/tests/env_sphere_cli.rs`, the issue's 1% flatness) varies by 1.88% at
/// 0.875 and 1.67% at 1.0 spacings (lead, wave-10 merge). Since wave 11 the profile has the
/// lateral term ([`super::lateral`], `solver::transport::lateral_profile_from_sample`): bunny
/// side 10.7 -> 9.9% at this depth. Since wave 13 this is `BakeParams::sample_depth`'s default;
/// the CLI bakes 1.0 where the material's s * spacing <= 0.5 (`defaults::sample_depth_for`:
/// marble bunny front 8.02 -> 7.82%, side 9.80 -> 8.97% with the depth alone).
pub const DEPTH_SPACINGS: f64 = 1.5;
/// The sample depths (finest spacings) a bake accepts (`BakeParams::sample_depth`).
pub const DEPTH_RANGE: std::ops::RangeInclusive<f64> = 0.5..=4.0;
pub const DEPTH_WALL_SHARE: f64 = 0.4;

/// The direction a sample is taken in: the vertex normals averaged over this many finest
/// spacings around the vertex (weights (1 - (d / R)^2)^2, only normals within 90 degrees of
/// the vertex's own), so that geometric detail finer than the lattice (a scanned mesh's bumps)
/// does not move the sample points about (diffusion does not resolve it either). Measured on
/// the front-lit bunny against path tracing: 16.1% with the raw normals, 16.3% with these; the
/// bump texture came from the sources (see [`SOURCE_SPACINGS`]: 15.4% -> 11.6%).
pub const NORMAL_SPACINGS: f64 = 1.5;

/// The surface the samples hang from: the display surface smoothed over this many finest
/// spacings ([`smoothed_positions`]): a vertex on a scanned bump sits up to a few tenths of a
/// millimetre off the surface the lattice resolves, and near a lit surface phi changes by
/// several percent over that (measured on the front-lit bunny against path tracing: see
/// benches/RESULTS.md, "Interior surface, wave 5").
pub const SURFACE_SPACINGS: f64 = 1.5;

/// Vertices (the vertex included) within the smoothing radius that a quadric fit needs; with
/// fewer the vertex stays where it is.
const QUADRIC_POINTS: usize = 10;

/// Surface nodes per vertex whose sources the profile averages.
pub const SOURCE_NODES: usize = 16;

/// The sources q (and the collimated exit part) that the vertex's 1D profile reads: the surface
/// nodes within this many finest spacings of the smoothed surface point, weighted by their face
/// area times (1 - (d / R)^2)^2 (only nodes whose normal is within 90 degrees of the smoothed
/// normal), at most [`SOURCE_NODES`] nearest. Why: the profile passes its boundary source to the
/// exitance with a weight of about d / (d + h) (0.8 for marble at the default depth), so the
/// irradiance of each surface node (its cosine taken with the scan's own face normal there)
/// would show the scan's bumps as a Lambertian texture; the diffusion solution at the sample
/// depth averages the sources over about that depth, and so must the profile's boundary.
pub const SOURCE_SPACINGS: f64 = 1.5;

/// The mean curvature at a vertex: the normal curvature (n_j - n_v) . (x_j - x_v) / |x_j -
/// x_v|^2 towards each vertex j within this many finest spacings, averaged (weights (1 - (d /
/// R)^2)^2; the average over directions of the normal curvature is (k1 + k2) / 2), with the
/// smoothed normals and the smoothed surface points, so a scan's bumps finer than the lattice
/// (which diffusion does not resolve) do not enter. At least [`CURVATURE_NEIGHBOURS`] nearest
/// vertices where fewer lie within the radius (a display mesh coarser than the lattice).
pub const CURVATURE_SPACINGS: f64 = 2.0;
const CURVATURE_NEIGHBOURS: std::num::NonZero<usize> = match std::num::NonZero::new(8) {
    Some(n) => n,
    None => unreachable!(),
};

/// Graph rings searched around the sample's tetrahedron for candidates.
const RINGS: usize = 3;

/// Per display vertex: where exitance is reconstructed from the interior solution.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SurfaceSamples {
    /// Depth of the sample point below the vertex along its normal (mm).
    pub depth: Vec<f64>,
    /// Finest-level inner node ids ([`NO_NODE`] in unused slots)...
    pub nodes: Vec<[u32; SAMPLE_NODES]>,
    /// ...and their interpolation weights at the sample point (summing to 1).
    pub weights: Vec<[f64; SAMPLE_NODES]>,
    /// The finest-level tetrahedron (inner node) containing the sample point, or the nearest one
    /// where the point lies outside the tetrahedral mesh: where the local material is read.
    pub cell: Vec<u32>,
    /// Finest-level surface nodes (surface index `s`, [`NO_NODE`] in unused slots) whose sources
    /// the vertex's 1D profile reads...
    pub sources: Vec<[u32; SOURCE_NODES]>,
    /// ...and their weights (summing to 1): see [`SOURCE_SPACINGS`].
    pub source_weights: Vec<[f64; SOURCE_NODES]>,
    /// Mean curvature H = (k1 + k2) / 2 of the smoothed surface at the vertex (1/mm, positive
    /// where convex): the 1D profile's curvature term (`solver::transport::
    /// curved_profile_from_sample`); see [`CURVATURE_SPACINGS`].
    pub curvature: Vec<f64>,
    /// The sample nodes' second moments about the sample point, weighted by their weights:
    /// (sum_k w_k ((x_k - x) . n)^2, sum_k w_k |(x_k - x) x n|^2) in mm^2, n the sample's normal.
    /// The weights are exact for a linear field only; the profile's curvature
    /// (`solver::transport::sample_on_profile`) is read back out of the sample with these.
    pub spread: Vec<[f64; 2]>,
    /// The lateral stencil ([`super::lateral`]): vertex ids ([`NO_NODE`] in unused slots, the
    /// vertex itself first; all unused where the display mesh is too coarse for one)...
    pub lateral: Vec<[u32; LATERAL_SLOTS]>,
    /// ...and their weights (1/mm^2, summing to 0): sum_k w_k p_k is the along-surface
    /// Laplacian of the samples' values p at the vertex's sample point.
    pub lateral_weights: Vec<[f64; LATERAL_SLOTS]>,
}

impl SurfaceSamples {
    /// Per-surface-node values averaged with vertex `v`'s source weights.
    pub fn source_average(&self, v: usize, per_node: &[[f64; 3]]) -> [f64; 3] {
        let mut out = [0.0; 3];
        for (&s, &w) in self.sources[v].iter().zip(&self.source_weights[v]) {
            if s != NO_NODE {
                for c in 0..3 {
                    out[c] += w * per_node[s as usize][c];
                }
            }
        }
        out
    }

    /// The along-surface Laplacian at vertex `v`'s sample point of the per-vertex sample values
    /// `per_vertex` (its lateral stencil; zero where it has none).
    pub fn lateral_laplacian(&self, v: usize, per_vertex: &[[f64; 3]]) -> [f64; 3] {
        let mut out = [0.0; 3];
        let (Some(ids), Some(weights)) = (self.lateral.get(v), self.lateral_weights.get(v)) else {
            return out;
        };
        for (&u, &w) in ids.iter().zip(weights) {
            if let Some(p) = per_vertex.get(u as usize).filter(|_| u != NO_NODE) {
                for c in 0..3 {
                    out[c] += w * p[c];
                }
            }
        }
        out
    }

    /// phi interpolated at vertex `v`'s sample point from per-node values.
    pub fn interpolate(&self, v: usize, phi: &[[f64; 3]]) -> [f64; 3] {
        let mut out = [0.0; 3];
        for (&k, &w) in self.nodes[v].iter().zip(&self.weights[v]) {
            if k != NO_NODE {
                for c in 0..3 {
                    out[c] += w * phi[k as usize][c];
                }
            }
        }
        out
    }
}

fn barycentric(level: &GraphLevel, t: usize, p: DVec3) -> [f64; 4] {
    let [a, b, c, d] = level.tets.tets[t].map(|v| level.tets.vertices[v as usize]);
    let vol = |a: DVec3, b: DVec3, c: DVec3, d: DVec3| (b - a).dot((c - a).cross(d - a));
    let total = vol(a, b, c, d);
    [
        vol(p, b, c, d) / total,
        vol(a, p, c, d) / total,
        vol(a, b, p, d) / total,
        vol(a, b, c, p) / total,
    ]
}

/// The tetrahedron containing `p`, walking from `start` across the face opposite the most
/// negative barycentric coordinate (local face f is opposite local vertex f).
fn locate(level: &GraphLevel, start: usize, p: DVec3) -> Option<usize> {
    let inner = level.inner_count();
    let mut t = start;
    for _ in 0..256 {
        let b = barycentric(level, t, p);
        let (f, min) =
            b.iter().enumerate().fold(
                (0, f64::INFINITY),
                |acc, (i, &v)| if v < acc.1 { (i, v) } else { acc },
            );
        if min >= -1e-9 {
            return Some(t);
        }
        let next = level.neighbors[t][f] as usize;
        if next >= inner {
            return None; // the walk left the mesh through a boundary face
        }
        t = next;
    }
    None
}

/// Moving-least-squares weights (linear basis) of `nodes` at `p`; Shepard weights where the
/// nodes do not span 3D.
fn mls_weights(points: &[DVec3], p: DVec3) -> Vec<f64> {
    let radius = points.iter().map(|q| q.distance(p)).fold(0.0, f64::max) * 1.05 + 1e-12;
    let kernel: Vec<f64> = points
        .iter()
        .map(|q| {
            let r = q.distance(p) / radius;
            (1.0 - r * r).powi(2)
        })
        .collect();
    let basis = |q: DVec3| {
        let d = (q - p) / radius;
        DVec4::new(1.0, d.x, d.y, d.z)
    };
    let mut moment = DMat4::ZERO;
    for (q, w) in points.iter().zip(&kernel) {
        let b = basis(*q);
        moment += DMat4::from_cols(b * b.x, b * b.y, b * b.z, b * b.w) * *w;
    }
    let det = moment.determinant();
    // Relative to the scale of the moments (about the kernel sum to the fourth).
    let scale: f64 = kernel.iter().sum::<f64>().powi(4);
    if det.abs() > 1e-10 * scale {
        let inv = moment.inverse();
        // Row 0 of the inverse times w_k b_k: the value at p of the fitted linear function.
        let row = DVec4::new(inv.x_axis.x, inv.y_axis.x, inv.z_axis.x, inv.w_axis.x);
        points
            .iter()
            .zip(&kernel)
            .map(|(q, w)| w * row.dot(basis(*q)))
            .collect()
    } else {
        let inverse: Vec<f64> = points
            .iter()
            .map(|q| 1.0 / q.distance_squared(p).max(1e-18))
            .collect();
        let total: f64 = inverse.iter().sum();
        inverse.iter().map(|w| w / total).collect()
    }
}

/// Per vertex, the unit normals of the vertices within `radius` averaged (see [`NORMAL_SPACINGS`]).
fn smoothed_normals(
    tree: &ImmutableKdTree<f64, u32, 3, 32>,
    positions: &[DVec3],
    normals: &[DVec3],
    radius: f64,
) -> Vec<DVec3> {
    if positions.is_empty() || radius.is_nan() || radius <= 0.0 {
        return normals.to_vec();
    }
    positions
        .par_iter()
        .zip(normals)
        .map(|(p, &n)| {
            let n = n.normalize_or(DVec3::Y);
            let mut sum = DVec3::ZERO;
            for nb in tree.within_unsorted::<SquaredEuclidean>(&p.to_array(), radius * radius) {
                let m = normals[nb.item as usize].normalize_or(DVec3::ZERO);
                if m.dot(n) > 0.0 {
                    let r = nb.distance / (radius * radius);
                    sum += m * (1.0 - r).powi(2);
                }
            }
            sum.normalize_or(n)
        })
        .collect()
}

/// The display surface's relief finer than `radius` (mm): the area-weighted median over the
/// vertices of the angle, in degrees, between each vertex's normal (its faces' area-weighted
/// normal) and the normals averaged within `radius` around it ([`smoothed_normals`], the
/// interior samples' own smoothing). The median, not the mean: sharp edges between flat faces
/// (a CAD part) are relief on a small share of the area only. At 1.5 finest spacings (20 mm
/// objects, benches/RESULTS.md "The bunny, region by region"): a finely tessellated sphere or
/// torus < 0.2 degrees, the U-block and the plate 0, the fandisk 2.1, the cheburashka 5.4, the
/// Stanford bunny's scan 6.5 (whose bumps the surface nodes' cosines sample one point each,
/// `defaults::surface_for`). 0 for an empty mesh or a radius that is not positive.
pub fn surface_relief_degrees(mesh: &TriMesh, radius: f64) -> f64 {
    let count = mesh.positions.len();
    if count == 0 || radius.is_nan() || radius <= 0.0 {
        return 0.0;
    }
    let mut normals = vec![DVec3::ZERO; count];
    let mut areas = vec![0.0; count];
    for tri in &mesh.indices {
        // Faces with an index out of range are skipped (the mesh validation names them).
        let [Some(a), Some(b), Some(c)] = tri.map(|i| mesh.positions.get(i as usize).copied())
        else {
            continue;
        };
        let n = (b - a).cross(c - a);
        for &i in tri {
            normals[i as usize] += n;
            // A third of each face's area per corner.
            areas[i as usize] += n.length() / 6.0;
        }
    }
    let normals: Vec<DVec3> = normals.into_iter().map(|n| n.normalize_or_zero()).collect();
    let coords: Vec<[f64; 3]> = mesh.positions.iter().map(|p| p.to_array()).collect();
    let tree = ImmutableKdTree::new_from_slice(&coords);
    let smoothed = smoothed_normals(&tree, &mesh.positions, &normals, radius);
    let mut angles: Vec<(f64, f64)> = normals
        .iter()
        .zip(&smoothed)
        .zip(&areas)
        .filter(|((n, _), &a)| n.length_squared() > 0.0 && a > 0.0)
        .map(|((n, m), &a)| (n.dot(*m).clamp(-1.0, 1.0).acos().to_degrees(), a))
        .collect();
    angles.sort_by(|x, y| x.0.total_cmp(&y.0));
    let half = angles.iter().map(|&(_, a)| a).sum::<f64>() / 2.0;
    let mut below = 0.0;
    for &(angle, a) in &angles {
        below += a;
        if below >= half {
            return angle;
        }
    }
    0.0
}

/// Solves the `N` x `N` system `a x = b` by Gaussian elimination with partial pivoting; `None`
/// when a pivot is below `1e-12` of the largest diagonal entry (the points do not determine it).
fn solve_small<const N: usize>(mut a: [[f64; N]; N], mut b: [f64; N]) -> Option<[f64; N]> {
    let scale = (0..N).map(|i| a[i][i].abs()).fold(0.0, f64::max);
    if !(scale > 0.0 && scale.is_finite()) {
        return None;
    }
    for col in 0..N {
        let pivot = (col..N).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if a[pivot][col].abs() < 1e-12 * scale {
            return None;
        }
        a.swap(col, pivot);
        b.swap(col, pivot);
        let pivot_row = a[col];
        for row in col + 1..N {
            let f = a[row][col] / pivot_row[col];
            for (x, p) in a[row][col..].iter_mut().zip(&pivot_row[col..]) {
                *x -= f * p;
            }
            b[row] -= f * b[col];
        }
    }
    let mut x = [0.0; N];
    for row in (0..N).rev() {
        let rest: f64 = (row + 1..N).map(|k| a[row][k] * x[k]).sum();
        x[row] = (b[row] - rest) / a[row][row];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// The weighted least-squares height at the origin of the points `(u, v, w)` (weights `k`), w
/// fitted by a quadric in (u, v); 0 (the vertex itself) where too few points determine one
/// (a display mesh coarser than the lattice has no bumps finer than it to smooth away, and a
/// plane fit would pull a curved surface's vertex inwards).
fn fitted_height(points: &[(f64, f64, f64, f64)]) -> f64 {
    if points.len() < QUADRIC_POINTS {
        return 0.0;
    }
    let mut a = [[0.0; 6]; 6];
    let mut b = [0.0; 6];
    for &(u, v, w, k) in points {
        let q = [1.0, u, v, u * u, u * v, v * v];
        for i in 0..6 {
            for j in 0..6 {
                a[i][j] += k * q[i] * q[j];
            }
            b[i] += k * q[i] * w;
        }
    }
    solve_small(a, b).map_or(0.0, |x| x[0])
}

/// Per vertex, the point of the display surface smoothed over `radius` (see
/// [`SURFACE_SPACINGS`]): the vertex moved along its smoothed normal `normals[v]` to the height
/// of a weighted least-squares quadric through the vertices within `radius` (weights
/// (1 - (d / R)^2)^2, only vertices whose own normal is within 90 degrees), so that a scanned
/// mesh's bumps finer than the lattice do not move the sample points (exact for a smooth
/// surface sampled finely: a quadric through its own vertices has height 0).
fn smoothed_positions(
    tree: &ImmutableKdTree<f64, u32, 3, 32>,
    positions: &[DVec3],
    raw_normals: &[DVec3],
    normals: &[DVec3],
    radius: f64,
) -> Vec<DVec3> {
    if positions.is_empty() || radius.is_nan() || radius <= 0.0 {
        return positions.to_vec();
    }
    positions
        .par_iter()
        .zip(normals)
        .map(|(&x, &n)| {
            let (t, b) = crate::solver::transport::tangent_frame(n);
            let mut points = Vec::new();
            for nb in tree.within_unsorted::<SquaredEuclidean>(&x.to_array(), radius * radius) {
                let j = nb.item as usize;
                if raw_normals[j].dot(n) <= 0.0 {
                    continue; // the other side of a thin wall
                }
                let d = (positions[j] - x) / radius;
                let r = nb.distance / (radius * radius);
                points.push((d.dot(t), d.dot(b), d.dot(n), (1.0 - r).powi(2)));
            }
            let height = fitted_height(&points) * radius;
            let moved = x + n * height;
            if moved.is_finite() {
                moved
            } else {
                x
            }
        })
        .collect()
}

/// Per vertex (smoothed point `anchors[v]`, smoothed normal `normals[v]`), the surface nodes of
/// `finest` whose sources it reads and their weights (see [`SOURCE_SPACINGS`]); the nearest
/// surface node alone where none lies within `radius`.
fn source_weights(
    finest: &GraphLevel,
    anchors: &[DVec3],
    normals: &[DVec3],
    radius: f64,
) -> Vec<([u32; SOURCE_NODES], [f64; SOURCE_NODES])> {
    let inner = finest.inner_count();
    let surface = finest.surface_count();
    let mut out = vec![([NO_NODE; SOURCE_NODES], [0.0; SOURCE_NODES]); anchors.len()];
    if surface == 0 || radius.is_nan() || radius <= 0.0 {
        return out;
    }
    let coords: Vec<[f64; 3]> = finest.positions[inner..]
        .iter()
        .map(|p| p.to_array())
        .collect();
    let tree: ImmutableKdTree<f64, u32, 3, 32> = ImmutableKdTree::new_from_slice(&coords);
    let areas: Vec<f64> = finest
        .surface_faces
        .iter()
        .map(|&(t, f)| {
            let tet = finest.tets.tets[t as usize];
            let [a, b, c] =
                super::graph::TET_FACES[f as usize].map(|k| finest.tets.vertices[tet[k] as usize]);
            0.5 * (b - a).cross(c - a).length()
        })
        .collect();
    out.par_iter_mut()
        .zip(anchors.par_iter().zip(normals))
        .for_each(|(slot, (&x, &n))| {
            let mut near: Vec<(f64, u32)> = tree
                .within_unsorted::<SquaredEuclidean>(&x.to_array(), radius * radius)
                .into_iter()
                .filter(|nb| finest.surface_normals[nb.item as usize].dot(n) > 0.0)
                .map(|nb| (nb.distance, nb.item))
                .collect();
            near.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            near.truncate(SOURCE_NODES);
            let weights: Vec<f64> = near
                .iter()
                .map(|&(d2, s)| (1.0 - d2 / (radius * radius)).powi(2) * areas[s as usize])
                .collect();
            let total: f64 = weights.iter().sum();
            if near.is_empty() || !(total > 0.0 && total.is_finite()) {
                let nearest = tree.nearest_one::<SquaredEuclidean>(&x.to_array()).item;
                slot.0[0] = nearest;
                slot.1[0] = 1.0;
                return;
            }
            for (k, (&(_, s), w)) in near.iter().zip(&weights).enumerate() {
                slot.0[k] = s;
                slot.1[k] = w / total;
            }
        });
    out
}

/// Per vertex, the mean curvature of the smoothed surface (points `anchors`, unit normals
/// `normals`) over `radius` (see [`CURVATURE_SPACINGS`]); 0 where no neighbour determines it.
fn mean_curvatures(
    tree: &ImmutableKdTree<f64, u32, 3, 32>,
    positions: &[DVec3],
    anchors: &[DVec3],
    normals: &[DVec3],
    radius: f64,
) -> Vec<f64> {
    if positions.is_empty() || radius.is_nan() || radius <= 0.0 {
        return vec![0.0; positions.len()];
    }
    (0..positions.len())
        .into_par_iter()
        .map(|v| {
            let (x, n) = (anchors[v], normals[v]);
            let query = positions[v].to_array();
            let mut near: Vec<(f64, u32)> = tree
                .within_unsorted::<SquaredEuclidean>(&query, radius * radius)
                .into_iter()
                .map(|nb| (nb.distance, nb.item))
                .collect();
            if near.len() <= CURVATURE_NEIGHBOURS.get() {
                near = tree
                    .nearest_n::<SquaredEuclidean>(&query, CURVATURE_NEIGHBOURS.saturating_add(1))
                    .into_iter()
                    .map(|nb| (nb.distance, nb.item))
                    .collect();
            }
            let reach = near
                .iter()
                .map(|&(d2, _)| d2)
                .fold(radius * radius, f64::max);
            let (mut sum, mut total) = (0.0, 0.0);
            for (d2, j) in near {
                let j = j as usize;
                let dx = anchors[j] - x;
                let len2 = dx.length_squared();
                if j == v || normals[j].dot(n) <= 0.0 || len2 <= 0.0 || len2.is_nan() {
                    continue;
                }
                let w = (1.0 - d2 / (reach * 1.0001)).powi(2);
                sum += w * (normals[j] - n).dot(dx) / len2;
                total += w;
            }
            let h = sum / total;
            if total > 0.0 && h.is_finite() {
                h
            } else {
                0.0
            }
        })
        .collect()
}

/// Display vertices whose mean curvature a surface node takes ([`surface_node_curvatures`]).
pub const NODE_CURVATURE_VERTICES: usize = 4;

/// Per surface node of `level` (surface index `s`), the curvature of the display surface there
/// (`solver::transport::SurfaceCurvature`, 1/mm, convex > 0): the mean curvature H, the average
/// of [`SurfaceSamples::curvature`] over the [`NODE_CURVATURE_VERTICES`] nearest display vertices
/// (of `surface`, the baked display mesh) whose normal faces the node's within 90 degrees (0
/// where none does or the bake has no curvature), and the anisotropy from
/// [`node_anisotropy`]. What the upstream beam (`solver::transport::upstream_beam`) reads on the
/// GPU gather and on the CPU reference alike, baked once rather than probed per frame.
pub fn surface_node_curvatures(
    level: &GraphLevel,
    surface: &TriMesh,
    samples: &SurfaceSamples,
) -> Vec<SurfaceCurvature> {
    let inner = level.inner_count();
    let count = level.surface_count();
    if surface.positions.is_empty() || samples.curvature.len() != surface.positions.len() {
        return vec![SurfaceCurvature::default(); count];
    }
    let coords: Vec<[f64; 3]> = surface.positions.iter().map(|p| p.to_array()).collect();
    let tree: ImmutableKdTree<f64, u32, 3, 32> = ImmutableKdTree::new_from_slice(&coords);
    let k =
        std::num::NonZero::new(NODE_CURVATURE_VERTICES).unwrap_or(std::num::NonZero::<usize>::MIN);
    (0..count)
        .into_par_iter()
        .map(|s| {
            let (x, n) = (level.positions[inner + s], level.surface_normals[s]);
            let (mut sum, mut total) = (0.0, 0.0);
            for nb in tree.nearest_n::<SquaredEuclidean>(&x.to_array(), k) {
                let v = nb.item as usize;
                let facing = surface.normals.get(v).is_none_or(|m| m.dot(n) > 0.0);
                let h = samples.curvature[v];
                if facing && h.is_finite() {
                    sum += h;
                    total += 1.0;
                }
            }
            let mean = if total > 0.0 { sum / total } else { 0.0 };
            SurfaceCurvature {
                mean,
                anisotropy: node_anisotropy(
                    &tree,
                    surface,
                    x,
                    n,
                    CURVATURE_SPACINGS * level.spacing,
                ),
            }
        })
        .collect()
}

/// The anisotropy of the display surface's curvature at `x` (normal `n`): the normal curvatures
/// (n_j - n) . u / |u|^2 towards the display vertices j within `radius` (u the tangential part
/// of x_j - x; normals within 90 degrees of n; weights (1 - (d / R)^2)^2) fitted by least
/// squares with the second fundamental form a c^2 + 2 b c s + d s^2 ((c, s) the direction in
/// n's tangent frame), whose traceless part gives (k1 - k2) / 2 = sqrt(((a - d) / 2)^2 + b^2)
/// and e1 (`SurfaceCurvature::anisotropy` = e1 sqrt((k1 - k2) / 2)). Zero where fewer than
/// three directions determine it. The mean stays [`SurfaceSamples::curvature`]'s, so an umbilic
/// surface (the sphere) reads exactly what it read before.
fn node_anisotropy(
    tree: &ImmutableKdTree<f64, u32, 3, 32>,
    surface: &TriMesh,
    x: DVec3,
    n: DVec3,
    radius: f64,
) -> DVec3 {
    if radius.is_nan()
        || radius <= 0.0
        || !x.is_finite()
        || !n.is_finite()
        || surface.normals.len() != surface.positions.len()
    {
        return DVec3::ZERO;
    }
    let (t1, t2) = crate::solver::transport::tangent_frame(n);
    // Normal equations of the fit: m (a, b, d) = r.
    let mut m = [[0.0f64; 3]; 3];
    let mut r = [0.0f64; 3];
    let mut directions = 0usize;
    for nb in tree.within_unsorted::<SquaredEuclidean>(&x.to_array(), radius * radius) {
        let j = nb.item as usize;
        let (xj, nj) = (surface.positions[j], surface.normals[j]);
        let dx = xj - x;
        let (u1, u2) = (dx.dot(t1), dx.dot(t2));
        let len2 = u1 * u1 + u2 * u2;
        if nj.dot(n) <= 0.0 || len2.is_nan() || len2 <= 1e-6 * radius * radius {
            continue;
        }
        let k = (nj - n).dot(t1 * u1 + t2 * u2) / len2;
        let (c, s) = (u1 / len2.sqrt(), u2 / len2.sqrt());
        let w = (1.0 - nb.distance / (radius * radius * 1.0001)).powi(2);
        let row = [c * c, 2.0 * c * s, s * s];
        if !k.is_finite() {
            continue;
        }
        for i in 0..3 {
            for l in 0..3 {
                m[i][l] += w * row[i] * row[l];
            }
            r[i] += w * row[i] * k;
        }
        directions += 1;
    }
    if directions < 3 {
        return DVec3::ZERO;
    }
    let mat = glam::DMat3::from_cols_array_2d(&m).transpose();
    if mat.determinant().abs() < 1e-9 * mat.col(0).length().powi(3).max(1e-300) {
        return DVec3::ZERO;
    }
    let [a, b, d] = (mat.inverse() * DVec3::from_array(r)).to_array();
    let p = 0.5 * (a - d);
    let half_difference = p.hypot(b);
    let angle = 0.5 * b.atan2(p);
    let e1 = t1 * angle.cos() + t2 * angle.sin();
    let anisotropy = e1 * half_difference.sqrt();
    if anisotropy.is_finite() {
        anisotropy
    } else {
        DVec3::ZERO
    }
}

/// The distance from `x` along `-n` to where the ray first leaves `solid` (a crossing whose
/// outward normal faces along the ray), up to `reach`; crossings into the solid on the way (the
/// smoothed surface point `x` may lie just outside a scan's dimple) are stepped over.
fn wall_thickness(solid: &dyn Solid, x: DVec3, n: DVec3, reach: f64, spacing: f64) -> f64 {
    let step = 1e-4 * spacing;
    let mut travelled = 0.0;
    for _ in 0..8 {
        let origin = x - n * (travelled + step);
        match solid.ray_hit(origin, -n, reach - travelled) {
            None => return f64::INFINITY,
            Some((t, normal)) => {
                travelled += step + t;
                if normal.dot(-n) > 0.0 {
                    return travelled;
                }
            }
        }
        if travelled >= reach {
            break;
        }
    }
    f64::INFINITY
}

/// The sample points of `surface`'s vertices (outward unit normals in `surface.normals`, or
/// computed from the faces) in the finest level, inside `solid`, `depth_spacings` finest
/// spacings below the smoothed surface ([`DEPTH_SPACINGS`] by default).
pub fn surface_samples(
    surface: &TriMesh,
    finest: &GraphLevel,
    solid: &dyn Solid,
    depth_spacings: f64,
) -> SurfaceSamples {
    let normals: Vec<DVec3> = if surface.normals.len() == surface.positions.len() {
        surface.normals.clone()
    } else {
        let mut m = surface.clone();
        m.compute_normals();
        m.normals
    };
    let inner = finest.inner_count();
    let coords: Vec<[f64; 3]> = finest.positions[..inner]
        .iter()
        .map(|p| p.to_array())
        .collect();
    let tree: ImmutableKdTree<f64, u32, 3, 32> = ImmutableKdTree::new_from_slice(&coords);
    let h = finest.spacing;
    let vertex_coords: Vec<[f64; 3]> = surface.positions.iter().map(|p| p.to_array()).collect();
    let vertex_tree: ImmutableKdTree<f64, u32, 3, 32> =
        ImmutableKdTree::new_from_slice(&vertex_coords);
    let raw_normals: Vec<DVec3> = normals.iter().map(|n| n.normalize_or(DVec3::Y)).collect();
    let normals = smoothed_normals(
        &vertex_tree,
        &surface.positions,
        &raw_normals,
        NORMAL_SPACINGS * h,
    );
    let anchors = smoothed_positions(
        &vertex_tree,
        &surface.positions,
        &raw_normals,
        &normals,
        SURFACE_SPACINGS * h,
    );
    let sources = source_weights(finest, &anchors, &normals, SOURCE_SPACINGS * h);
    let curvature = mean_curvatures(
        &vertex_tree,
        &surface.positions,
        &anchors,
        &normals,
        CURVATURE_SPACINGS * h,
    );
    type Sample = (f64, [u32; SAMPLE_NODES], [f64; SAMPLE_NODES], u32, [f64; 2]);
    let per_vertex: Vec<Sample> = anchors
        .par_iter()
        .zip(&normals)
        .map(|(&x, &n)| {
            let n = n.normalize_or(DVec3::Y);
            let thickness = wall_thickness(solid, x, n, 4.0 * depth_spacings * h, h);
            let depth = (depth_spacings * h).min(DEPTH_WALL_SHARE * thickness);
            let p = x - n * depth;
            let nearest = tree.nearest_one::<SquaredEuclidean>(&p.to_array()).item as usize;
            let cell = locate(finest, nearest, p).unwrap_or(nearest);
            // Rings of inner neighbours around the cell.
            let mut seen: HashSet<u32> = HashSet::from([cell as u32]);
            let mut ring = vec![cell as u32];
            for _ in 0..RINGS {
                let mut next = Vec::new();
                for &t in &ring {
                    for &j in &finest.neighbors[t as usize] {
                        if (j as usize) < inner && seen.insert(j) {
                            next.push(j);
                        }
                    }
                }
                ring = next;
            }
            let mut candidates: Vec<u32> = seen.into_iter().collect();
            candidates.sort_by(|a, b| {
                let da = finest.positions[*a as usize].distance_squared(p);
                let db = finest.positions[*b as usize].distance_squared(p);
                da.total_cmp(&db).then(a.cmp(b))
            });
            candidates.truncate(SAMPLE_NODES);
            let points: Vec<DVec3> = candidates
                .iter()
                .map(|&k| finest.positions[k as usize])
                .collect();
            let w = mls_weights(&points, p);
            let mut spread = [0.0; 2];
            for (q, wk) in points.iter().zip(&w) {
                let dx = *q - p;
                let along = dx.dot(n);
                spread[0] += wk * along * along;
                spread[1] += wk * (dx.length_squared() - along * along);
            }
            let mut ids = [NO_NODE; SAMPLE_NODES];
            let mut weights = [0.0; SAMPLE_NODES];
            for (slot, (&k, &wk)) in candidates.iter().zip(&w).enumerate() {
                ids[slot] = k;
                weights[slot] = wk;
            }
            (depth, ids, weights, cell as u32, spread)
        })
        .collect();
    let mut out = SurfaceSamples {
        curvature,
        ..Default::default()
    };
    for (ids, w) in sources {
        out.sources.push(ids);
        out.source_weights.push(w);
    }
    let points: Vec<DVec3> = anchors
        .iter()
        .zip(&normals)
        .zip(&per_vertex)
        .map(|((&x, &n), sample)| x - n.normalize_or(DVec3::Y) * sample.0)
        .collect();
    let unit: Vec<DVec3> = normals.iter().map(|n| n.normalize_or(DVec3::Y)).collect();
    for (ids, w) in lateral_stencils(&points, &unit, LATERAL_SPACINGS * h) {
        out.lateral.push(ids);
        out.lateral_weights.push(w);
    }
    for (depth, ids, w, cell, spread) in per_vertex {
        out.spread.push(spread);
        out.depth.push(depth);
        out.nodes.push(ids);
        out.weights.push(w);
        out.cell.push(cell);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mls_is_exact_for_linear_fields() {
        let points: Vec<DVec3> = (0..16)
            .map(|i| {
                let f = i as f64;
                DVec3::new(
                    (f * 0.37).sin(),
                    (f * 1.3).cos(),
                    (f * 0.71).sin() * 0.5 + 0.1 * f,
                )
            })
            .collect();
        let p = DVec3::new(0.1, 0.2, 0.3);
        let w = mls_weights(&points, p);
        let field = |q: DVec3| 2.0 + 3.0 * q.x - q.y + 0.5 * q.z;
        let value: f64 = points.iter().zip(&w).map(|(q, w)| w * field(*q)).sum();
        assert!((value - field(p)).abs() < 1e-9, "{value}");
    }
}
