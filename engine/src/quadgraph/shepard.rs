//! Shepard interpolation weights (paper Eq. 10, DESIGN section 3 steps 8 and 9): between levels and
//! from the finest level's surface nodes to the display mesh's vertices.
//!
//! A fine node takes the `b` nearest candidate nodes (b = 4 surface nodes for a surface node, 8
//! inner nodes for an inner node) with `w = 1 / max(d^2, eps^2)`, normalized. Candidates must lie
//! within 2 spacings of the coarser level, and surface candidates must face the same way
//! (`n_x . n_y > 0`), so that weights do not reach across thin parts. If no candidate qualifies, the
//! nearest node is used alone: the set is never empty.
//!
//! ```
//! # use translucent::quadgraph::shepard::ShepardIndex;
//! # use glam::DVec3;
//! let points = [DVec3::ZERO, DVec3::X, DVec3::Y];
//! let normals = [DVec3::Z; 3];
//! let index = ShepardIndex::new(&points, Some(&normals));
//! let (ids, w) = index.weights::<4>(DVec3::new(0.1, 0.1, 0.0), Some(DVec3::Z), 2.0, 1e-6);
//! assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-12 && ids[0] == 0);
//! ```

use std::num::NonZero;

use glam::DVec3;
use kiddo::immutable::float::kdtree::ImmutableKdTree;
use kiddo::SquaredEuclidean;
use rayon::prelude::*;

use super::crease::{crease_normals, CREASE_MIN_COS};
use super::graph::{GraphLevel, ShadingWeights, ShepardLinks, NO_NODE};
use crate::mesh::{Solid, TriMesh};

/// How many nearest points are examined before the normal and distance filters (enough that 4
/// agreeing ones are found next to a thin part, where half the near points face the other way).
const CANDIDATES: usize = 24;

/// A k-d tree over points (with optional normals) answering filtered Shepard queries.
pub struct ShepardIndex<'a> {
    tree: ImmutableKdTree<f64, u32, 3, 32>,
    points: &'a [DVec3],
    normals: Option<&'a [DVec3]>,
}

impl<'a> ShepardIndex<'a> {
    pub fn new(points: &'a [DVec3], normals: Option<&'a [DVec3]>) -> Self {
        let coords: Vec<[f64; 3]> = points.iter().map(|p| p.to_array()).collect();
        Self {
            tree: ImmutableKdTree::new_from_slice(&coords),
            points,
            normals,
        }
    }

    /// Up to `B` point indices and normalized weights for `x` (unused slots: [`NO_NODE`], 0).
    /// `normal` is `x`'s normal where candidates must agree with it; `reach` the largest distance.
    pub fn weights<const B: usize>(
        &self,
        x: DVec3,
        normal: Option<DVec3>,
        reach: f64,
        eps: f64,
    ) -> ([u32; B], [f64; B]) {
        self.weights_within::<B>(x, normal.map(|n| (n, 0.0)), reach, eps)
    }

    /// [`ShepardIndex::weights`] with the agreement `n . n_y > min_cos` for `(n, min_cos)`.
    pub fn weights_within<const B: usize>(
        &self,
        x: DVec3,
        normal: Option<(DVec3, f64)>,
        reach: f64,
        eps: f64,
    ) -> ([u32; B], [f64; B]) {
        let mut ids = [NO_NODE; B];
        let mut w = [0.0; B];
        if self.points.is_empty() {
            return (ids, w);
        }
        let q = x.to_array();
        let near = self.tree.nearest_n::<SquaredEuclidean>(
            &q,
            NonZero::new(CANDIDATES.max(B)).unwrap_or(NonZero::<usize>::MIN),
        );
        let mut k = 0;
        for nb in &near {
            if k == B {
                break;
            }
            if nb.distance > reach * reach {
                break;
            }
            let agrees = match (normal, self.normals) {
                (Some((n, min_cos)), Some(ns)) => n.dot(ns[nb.item as usize]) > min_cos,
                _ => true,
            };
            if agrees {
                ids[k] = nb.item;
                w[k] = 1.0 / nb.distance.max(eps * eps);
                k += 1;
            }
        }
        if k == 0 {
            // Nothing qualifies (a lone sliver of surface): the nearest point alone, weight 1.
            let nearest = self.tree.nearest_one::<SquaredEuclidean>(&q);
            ids[0] = nearest.item;
            w[0] = 1.0;
            return (ids, w);
        }
        let total: f64 = w.iter().sum();
        for x in &mut w {
            *x /= total;
        }
        (ids, w)
    }
}

/// Links from `coarse` into `fine` (Eq. 10): b = 4 coarse surface nodes per fine surface node, b = 8
/// coarse inner nodes per fine inner node; ids are coarse node ids.
pub fn level_links(fine: &GraphLevel, coarse: &GraphLevel) -> ShepardLinks {
    let ci = coarse.inner_count();
    let inner_index = ShepardIndex::new(&coarse.positions[..ci], None);
    let surface_index = ShepardIndex::new(&coarse.positions[ci..], Some(&coarse.surface_normals));
    let reach = 2.0 * coarse.spacing;
    let eps = 1e-3 * fine.spacing;
    let fi = fine.inner_count();
    let per_node: Vec<([u32; 8], [f64; 8])> = (0..fine.node_count())
        .into_par_iter()
        .map(|node| {
            let x = fine.positions[node];
            if node < fi {
                inner_index.weights::<8>(x, None, reach, eps)
            } else {
                let (ids, w) = surface_index.weights::<4>(
                    x,
                    Some(fine.surface_normals[node - fi]),
                    reach,
                    eps,
                );
                let mut ids8 = [NO_NODE; 8];
                let mut w8 = [0.0; 8];
                for k in 0..4 {
                    if ids[k] != NO_NODE {
                        ids8[k] = ids[k] + ci as u32;
                        w8[k] = w[k];
                    }
                }
                (ids8, w8)
            }
        })
        .collect();
    let (links, weights) = per_node.into_iter().unzip();
    ShepardLinks { links, weights }
}

/// A vertex split at a sharp edge that is not a concave crease takes its shading weights at a
/// point this many finest spacings into its own face, away from the edge. The surface nodes of
/// the lattice cells along a convex edge are lit through both faces and stand out: at the edge
/// itself the U-block's lit front face read 0.91 where path tracing has 0.67 (green, the first
/// pixel row under the top edge; benches/RESULTS.md, "Split display vertices at sharp edges").
/// Measured on the U-block front / back and the plate (relative RMS %): 0 spacings 10.7 / 11.5 /
/// 10.3, 1.0: 9.4 / 11.1 / 10.1, 1.5: 9.2 / 11.1 / 10.2, 2.0: 9.1 / 11.2 / 10.2.
pub const SPLIT_INSET_SPACINGS: f64 = 1.5;

/// Shading weights of the display mesh's vertices into the finest level's surface nodes (surface
/// indices). Vertex normals come from `surface.normals` (recomputed from the faces when missing);
/// a vertex on a concave crease takes the nodes of its thinnest face group only
/// ([`super::crease`]), and a vertex split at a sharp edge ([`TriMesh::split_sharp_edges`]) the
/// nodes within 60 degrees of its own normal, around a point [`SPLIT_INSET_SPACINGS`] into its
/// face.
pub fn shading_weights(
    surface: &TriMesh,
    finest: &GraphLevel,
    solid: &dyn Solid,
) -> ShadingWeights {
    let normals: Vec<DVec3> = if surface.normals.len() == surface.positions.len() {
        surface.normals.clone()
    } else {
        let mut m = surface.clone();
        m.compute_normals();
        m.normals
    };
    let fi = finest.inner_count();
    let index = ShepardIndex::new(&finest.positions[fi..], Some(&finest.surface_normals));
    let reach = 2.0 * finest.spacing;
    let eps = 1e-3 * finest.spacing;
    let creases = crease_normals(surface, &normals, solid);
    let welded = super::crease::Welded::new(surface, &normals);
    let per_vertex: Vec<([u32; 4], [f64; 4])> = surface
        .positions
        .par_iter()
        .zip(&normals)
        .zip(&creases)
        .zip(welded.split.par_iter().zip(&welded.averaged))
        .map(|(((&p, &n), &crease), (&split, &averaged))| {
            // A vertex split at a sharp edge shades from its own face group's side only.
            let min_cos = if split { CREASE_MIN_COS } else { 0.0 };
            let agree = crease.or((n != DVec3::ZERO).then_some((n, min_cos)));
            let into_face = -(averaged - n * n.dot(averaged)).normalize_or_zero();
            let q = if split && crease.is_none() {
                p + into_face * SPLIT_INSET_SPACINGS * finest.spacing
            } else {
                p
            };
            index.weights_within::<4>(q, agree, reach, eps)
        })
        .collect();
    let (links, weights) = per_vertex.into_iter().unzip();
    ShadingWeights { links, weights }
}
