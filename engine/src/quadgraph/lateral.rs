//! The lateral stencil of the interior surface samples (wave 11, issue 12): per display vertex,
//! weights over its own sample and neighbouring vertices' samples whose sum over the samples'
//! values is the along-surface Laplacian of phi at the vertex's sample point. The 1D profile that
//! carries a sample to the surface reads lambda = that Laplacian / phi as its lateral term
//! (`solver::transport::lateral_profile_from_sample`: phi'' = (s^2 - lambda) phi).
//!
//! The neighbours: the sample points within [`LATERAL_SPACINGS`] finest spacings whose normal is
//! within 60 degrees of the vertex's, one per angular sector of two rings in the vertex's tangent
//! plane (the one nearest the ring's radius), so that a scan's dense vertices do not crowd the
//! stencil into a small disc where the lattice's noise in the samples would dominate the second
//! difference. The weights: least squares of a full quadratic in the tangent plane (six terms),
//! Laplacian = c_uu + c_vv; none (all zero) with fewer than [`LATERAL_MIN_POINTS`] points or an
//! ill-conditioned fit (a display mesh coarser than the lattice: no lateral term there).

use glam::DVec3;
use kiddo::immutable::float::kdtree::ImmutableKdTree;
use kiddo::SquaredEuclidean;
use rayon::prelude::*;

use super::graph::NO_NODE;

/// Vertices per lateral stencil, the vertex itself in the first slot.
pub const LATERAL_SLOTS: usize = 16;

/// The stencil's radius in finest spacings: the Laplacian is that of the samples smoothed over
/// about this scale (the lattice's noise in a second difference falls with the radius squared).
/// Measured on the side-lit bunny at render's defaults (benches/RESULTS.md, "The profile's
/// lateral term"): 1.5 spacings 10.95%, 2 10.68, **3 9.93**, 4 10.00 (no term: 10.72).
pub const LATERAL_SPACINGS: f64 = 3.0;

/// Points (the vertex included) a stencil needs.
pub const LATERAL_MIN_POINTS: usize = 8;

/// Angular sectors of the inner ring (radius 0.3 to 0.65 R) and the outer ring (0.65 to 1 R).
const INNER_SECTORS: usize = 7;
const OUTER_SECTORS: usize = 8;

/// Per vertex the stencil's vertex ids ([`NO_NODE`] in unused slots) and weights (1/mm^2) at
/// the sample points `points` with unit normals `normals`.
pub fn lateral_stencils(
    points: &[DVec3],
    normals: &[DVec3],
    radius: f64,
) -> Vec<([u32; LATERAL_SLOTS], [f64; LATERAL_SLOTS])> {
    let none = ([NO_NODE; LATERAL_SLOTS], [0.0; LATERAL_SLOTS]);
    if points.is_empty() || normals.len() != points.len() || radius.is_nan() || radius <= 0.0 {
        return vec![none; points.len()];
    }
    let coords: Vec<[f64; 3]> = points.iter().map(|p| p.to_array()).collect();
    let tree: ImmutableKdTree<f64, u32, 3, 32> = ImmutableKdTree::new_from_slice(&coords);
    (0..points.len())
        .into_par_iter()
        .map(|v| stencil(&tree, points, normals, v, radius).unwrap_or(none))
        .collect()
}

fn stencil(
    tree: &ImmutableKdTree<f64, u32, 3, 32>,
    points: &[DVec3],
    normals: &[DVec3],
    v: usize,
    radius: f64,
) -> Option<([u32; LATERAL_SLOTS], [f64; LATERAL_SLOTS])> {
    let (x, n) = (points[v], normals[v]);
    if !(x.is_finite() && n.is_finite()) {
        return None;
    }
    let (t1, t2) = crate::solver::transport::tangent_frame(n);
    // Per sector: (distance from the ring's radius, vertex, u1, u2), in units of the radius.
    let mut best: [Option<(f64, u32, f64, f64)>; INNER_SECTORS + OUTER_SECTORS] =
        [None; INNER_SECTORS + OUTER_SECTORS];
    for nb in tree.within_unsorted::<SquaredEuclidean>(&x.to_array(), radius * radius) {
        let j = nb.item as usize;
        if j == v || normals[j].dot(n) < 0.5 {
            continue;
        }
        let dx = (points[j] - x) / radius;
        let (u1, u2) = (dx.dot(t1), dx.dot(t2));
        let r = u1.hypot(u2);
        if !(0.3..=1.0).contains(&r) {
            continue;
        }
        let angle = u2.atan2(u1).rem_euclid(std::f64::consts::TAU) / std::f64::consts::TAU;
        let (slot, target) = if r < 0.65 {
            (
                ((angle * INNER_SECTORS as f64) as usize).min(INNER_SECTORS - 1),
                0.475,
            )
        } else {
            (
                INNER_SECTORS + ((angle * OUTER_SECTORS as f64) as usize).min(OUTER_SECTORS - 1),
                0.825,
            )
        };
        let key = (r - target).abs();
        if best[slot].is_none_or(|(k, id, _, _)| key < k || (key == k && (j as u32) < id)) {
            best[slot] = Some((key, j as u32, u1, u2));
        }
    }
    let mut ids = vec![v as u32];
    let mut uv = vec![(0.0, 0.0)];
    for (_, id, u1, u2) in best.iter().flatten() {
        ids.push(*id);
        uv.push((*u1, *u2));
    }
    if ids.len() < LATERAL_MIN_POINTS {
        return None;
    }
    // Normal equations of p = a + b1 u1 + b2 u2 + c11 u1^2 / 2 + c12 u1 u2 + c22 u2^2 / 2.
    let row = |(u1, u2): (f64, f64)| [1.0, u1, u2, 0.5 * u1 * u1, u1 * u2, 0.5 * u2 * u2];
    let mut m = [[0.0f64; 6]; 6];
    for &p in &uv {
        let a = row(p);
        for i in 0..6 {
            for k in 0..6 {
                m[i][k] += a[i] * a[k];
            }
        }
    }
    // Solve m y = e (e picks c11 + c22); the weights are y . row(point_k).
    let y = solve6(m, [0.0, 0.0, 0.0, 1.0, 0.0, 1.0])?;
    let mut out_ids = [NO_NODE; LATERAL_SLOTS];
    let mut out_w = [0.0; LATERAL_SLOTS];
    for (slot, (&id, &p)) in ids.iter().zip(&uv).enumerate() {
        let a = row(p);
        let w: f64 = (0..6).map(|i| y[i] * a[i]).sum::<f64>() / (radius * radius);
        if !w.is_finite() {
            return None;
        }
        out_ids[slot] = id;
        out_w[slot] = w;
    }
    Some((out_ids, out_w))
}

/// Gaussian elimination with partial pivoting of a 6 x 6 system; `None` when a pivot falls below
/// 1e-9 of the matrix's largest entry (the points do not determine a quadratic).
fn solve6(mut m: [[f64; 6]; 6], mut b: [f64; 6]) -> Option<[f64; 6]> {
    let scale = m.iter().flatten().fold(0.0f64, |a, &x| a.max(x.abs()));
    if !(scale > 0.0 && scale.is_finite()) {
        return None;
    }
    for col in 0..6 {
        let pivot = (col..6).max_by(|&a, &b| m[a][col].abs().total_cmp(&m[b][col].abs()))?;
        if m[pivot][col].abs() < 1e-9 * scale {
            return None;
        }
        m.swap(col, pivot);
        b.swap(col, pivot);
        for r in col + 1..6 {
            let f = m[r][col] / m[col][col];
            let pivot_row = m[col];
            for (x, p) in m[r].iter_mut().zip(pivot_row).skip(col) {
                *x -= f * p;
            }
            b[r] -= f * b[col];
        }
    }
    let mut y = [0.0; 6];
    for r in (0..6).rev() {
        let s: f64 = (r + 1..6).map(|k| m[r][k] * y[k]).sum();
        y[r] = (b[r] - s) / m[r][r];
    }
    Some(y)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_stencil_returns_the_laplacian_of_a_quadratic_and_nothing_for_a_linear_field() {
        // A jittered planar grid (normal +z), spacing 0.2 mm, radius 1 mm.
        let mut points = Vec::new();
        for i in -12..=12 {
            for j in -12..=12 {
                let (x, y) = (i as f64 * 0.2, j as f64 * 0.2);
                let jitter = 0.03 * ((i * 7 + j * 13) as f64).sin();
                points.push(DVec3::new(x + jitter, y - jitter, 0.0));
            }
        }
        let normals = vec![DVec3::Z; points.len()];
        let stencils = lateral_stencils(&points, &normals, 1.0);
        let centre = points
            .iter()
            .position(|p| p.truncate().length() < 1e-9)
            .unwrap();
        let (ids, w) = stencils[centre];
        assert!(ids.iter().filter(|&&i| i != NO_NODE).count() >= LATERAL_MIN_POINTS);
        let apply = |f: &dyn Fn(DVec3) -> f64| -> f64 {
            ids.iter()
                .zip(&w)
                .filter(|(i, _)| **i != NO_NODE)
                .map(|(&i, &w)| w * f(points[i as usize]))
                .sum()
        };
        let linear = apply(&|p| 2.0 + 0.5 * p.x - 0.3 * p.y);
        assert!(linear.abs() < 1e-9, "{linear}");
        // Laplacian of 0.7 x^2 + 0.2 x y - 0.4 y^2 is 0.6.
        let quadratic = apply(&|p| 0.7 * p.x * p.x + 0.2 * p.x * p.y - 0.4 * p.y * p.y);
        assert!((quadratic - 0.6).abs() < 1e-9, "{quadratic}");
        // A lone vertex has no stencil.
        let lone = lateral_stencils(&[DVec3::ZERO], &[DVec3::Z], 1.0);
        assert!(lone[0].0.iter().all(|&i| i == NO_NODE) && lone[0].1 == [0.0; LATERAL_SLOTS]);
    }
}
