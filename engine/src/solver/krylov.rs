//! Exact solves of an assembled level system, all three channels at once (each with its own
//! scalars): preconditioned conjugate gradient on the symmetrized `fv` system, BiCGSTAB for the
//! non-symmetric `paper` system. Both work on the row-scaled form `S A x = S b` with a diagonal
//! (Jacobi) preconditioner; "converged" means ||S (b - A x)|| / ||S b|| below the tolerance
//! (1e-10 by default), the same residual [`LevelOperator::residual`] reports.
//!
//! ```
//! use glam::DVec3;
//! use translucent::material::{Material, MaterialField};
//! use translucent::solver::{krylov, operator::{LevelOperator, Scheme}};
//! use translucent::{tet::TetMesh, GraphLevel};
//! let level = GraphLevel::from_tets(TetMesh::bcc_box(DVec3::ZERO, DVec3::splat(4.0), [3, 3, 3]), 1.0, |c, n| (c, n));
//! let op = LevelOperator::build(&level, &MaterialField::Homogeneous(Material::preset("skin1")?), Scheme::Fv)?;
//! let b = op.rhs(&vec![[1.0; 3]; level.surface_count()]);
//! let mut phi = vec![[0.0; 3]; op.node_count()];
//! let report = krylov::solve(&op, &b, &mut phi, 1e-10, 10_000);
//! assert!(report.converged && report.residual.iter().all(|&r| r < 1e-10));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use rayon::prelude::*;

use super::operator::{LevelOperator, Scheme};

/// What an exact solve did.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct KrylovReport {
    pub iterations: usize,
    /// Final relative residual per channel.
    pub residual: [f64; 3],
    pub converged: bool,
}

type V = Vec<[f64; 3]>;

fn dot(a: &[[f64; 3]], b: &[[f64; 3]]) -> [f64; 3] {
    a.par_iter()
        .zip(b)
        .map(|(x, y)| std::array::from_fn(|c| x[c] * y[c]))
        .reduce(
            || [0.0; 3],
            |u: [f64; 3], v| std::array::from_fn(|c| u[c] + v[c]),
        )
}

fn norm(a: &[[f64; 3]]) -> [f64; 3] {
    dot(a, a).map(f64::sqrt)
}

/// `y[i][c] = a[i][c] + k[c] * b[i][c]` in place on `a`.
fn axpy(a: &mut [[f64; 3]], k: [f64; 3], b: &[[f64; 3]]) {
    a.par_iter_mut().zip(b).for_each(|(x, y)| {
        for c in 0..3 {
            x[c] += k[c] * y[c];
        }
    });
}

/// Solves `A x = b` from the initial `x` with the method that fits the operator's scheme.
pub fn solve(
    op: &LevelOperator,
    b: &[[f64; 3]],
    x: &mut [[f64; 3]],
    tolerance: f64,
    max_iterations: usize,
) -> KrylovReport {
    // The recursively updated residual drifts from the true one on badly conditioned systems
    // (contrasts of 1e4 and more); when the true residual is still too large, restart from the
    // current x with a freshly computed residual.
    let mut total = 0;
    let mut report;
    loop {
        let budget = max_iterations - total;
        report = match op.scheme {
            Scheme::Fv => pcg(op, b, x, tolerance, budget),
            Scheme::Paper => bicgstab(op, b, x, tolerance, budget),
        };
        total += report.iterations;
        if report.converged || report.iterations == 0 || total >= max_iterations {
            break;
        }
    }
    report.iterations = total;
    report
}

fn scaled_rhs(op: &LevelOperator, b: &[[f64; 3]]) -> (V, [f64; 3]) {
    let sb: V = b
        .par_iter()
        .zip(&op.row_scale)
        .map(|(v, &s)| v.map(|e| e * s))
        .collect();
    let nb = norm(&sb).map(|n| if n > 0.0 { n } else { 1.0 });
    (sb, nb)
}

fn precondition(op: &LevelOperator, r: &[[f64; 3]], z: &mut [[f64; 3]]) {
    z.par_iter_mut().enumerate().for_each(|(i, zi)| {
        *zi = std::array::from_fn(|c| r[i][c] / (op.row_scale[i] * op.diag[i][c]));
    });
}

/// Jacobi-preconditioned conjugate gradient on `S A x = S b` (symmetric positive definite for `fv`).
pub fn pcg(
    op: &LevelOperator,
    b: &[[f64; 3]],
    x: &mut [[f64; 3]],
    tolerance: f64,
    max_iterations: usize,
) -> KrylovReport {
    let n = op.node_count();
    let (sb, nb) = scaled_rhs(op, b);
    let mut r = vec![[0.0; 3]; n];
    op.apply_scaled(x, &mut r);
    r.par_iter_mut()
        .zip(&sb)
        .for_each(|(ri, bi)| *ri = std::array::from_fn(|c| bi[c] - ri[c]));
    let mut z = vec![[0.0; 3]; n];
    precondition(op, &r, &mut z);
    let mut p = z.clone();
    let mut ap = vec![[0.0; 3]; n];
    let mut rz = dot(&r, &z);
    let mut rel: [f64; 3] = std::array::from_fn(|c| norm(&r)[c] / nb[c]);
    let mut iterations = 0;
    while iterations < max_iterations && rel.iter().any(|&v| v >= tolerance) {
        iterations += 1;
        op.apply_scaled(&p, &mut ap);
        let pap = dot(&p, &ap);
        // A converged channel stops moving (alpha = 0) while the others continue.
        let alpha: [f64; 3] = std::array::from_fn(|c| {
            if rel[c] >= tolerance && pap[c] > 0.0 {
                rz[c] / pap[c]
            } else {
                0.0
            }
        });
        axpy(x, alpha, &p);
        axpy(&mut r, alpha.map(|a| -a), &ap);
        let nr = norm(&r);
        rel = std::array::from_fn(|c| nr[c] / nb[c]);
        precondition(op, &r, &mut z);
        let rz_new = dot(&r, &z);
        let beta: [f64; 3] = std::array::from_fn(|c| {
            if rz[c] > 0.0 && alpha[c] != 0.0 {
                rz_new[c] / rz[c]
            } else {
                0.0
            }
        });
        rz = rz_new;
        p.par_iter_mut()
            .zip(&z)
            .for_each(|(pi, zi)| *pi = std::array::from_fn(|c| zi[c] + beta[c] * pi[c]));
    }
    finish(op, b, x, tolerance, iterations)
}

/// Recomputes the true residual (the recursive one drifts) and reports.
fn finish(
    op: &LevelOperator,
    b: &[[f64; 3]],
    x: &[[f64; 3]],
    tolerance: f64,
    iterations: usize,
) -> KrylovReport {
    let residual = op.residual(x, b);
    KrylovReport {
        iterations,
        residual,
        // A recursive residual can pass while the true one is a little above; allow 10x.
        converged: residual.iter().all(|&r| r < 10.0 * tolerance),
    }
}

/// Right-preconditioned BiCGSTAB (van der Vorst 1992) on `S A x = S b`, restarted on breakdown.
pub fn bicgstab(
    op: &LevelOperator,
    b: &[[f64; 3]],
    x: &mut [[f64; 3]],
    tolerance: f64,
    max_iterations: usize,
) -> KrylovReport {
    let n = op.node_count();
    let (sb, nb) = scaled_rhs(op, b);
    let residual_of = |x: &[[f64; 3]], r: &mut V| {
        op.apply_scaled(x, r);
        r.par_iter_mut()
            .zip(&sb)
            .for_each(|(ri, bi)| *ri = std::array::from_fn(|c| bi[c] - ri[c]));
    };
    let mut r = vec![[0.0; 3]; n];
    residual_of(x, &mut r);
    let mut r_hat = r.clone();
    let (mut rho, mut alpha, mut omega) = ([1.0; 3], [1.0; 3], [1.0; 3]);
    let (mut v, mut p) = (vec![[0.0; 3]; n], vec![[0.0; 3]; n]);
    let (mut y, mut z, mut s, mut t) = (
        vec![[0.0; 3]; n],
        vec![[0.0; 3]; n],
        vec![[0.0; 3]; n],
        vec![[0.0; 3]; n],
    );
    let mut rel: [f64; 3] = std::array::from_fn(|c| norm(&r)[c] / nb[c]);
    let mut iterations = 0;
    while iterations < max_iterations && rel.iter().any(|&v| v >= tolerance) {
        iterations += 1;
        let active: [bool; 3] = std::array::from_fn(|c| rel[c] >= tolerance);
        let finite_or_zero = |v: f64, ok: bool| if ok && v.is_finite() { v } else { 0.0 };
        let rho_new = dot(&r_hat, &r);
        let beta: [f64; 3] = std::array::from_fn(|c| {
            finite_or_zero((rho_new[c] / rho[c]) * (alpha[c] / omega[c]), active[c])
        });
        p.par_iter_mut().zip(&r).zip(&v).for_each(|((pi, ri), vi)| {
            *pi = std::array::from_fn(|c| ri[c] + beta[c] * (pi[c] - omega[c] * vi[c]));
        });
        precondition(op, &p, &mut y);
        op.apply_scaled(&y, &mut v);
        let rv = dot(&r_hat, &v);
        alpha = std::array::from_fn(|c| finite_or_zero(rho_new[c] / rv[c], active[c]));
        s.par_iter_mut()
            .zip(&r)
            .zip(&v)
            .for_each(|((si, ri), vi)| *si = std::array::from_fn(|c| ri[c] - alpha[c] * vi[c]));
        precondition(op, &s, &mut z);
        op.apply_scaled(&z, &mut t);
        let (ts, tt) = (dot(&t, &s), dot(&t, &t));
        omega = std::array::from_fn(|c| finite_or_zero(ts[c] / tt[c], active[c]));
        axpy(x, alpha, &y);
        axpy(x, omega, &z);
        // Inactive channels have alpha = omega = 0, so their r stays as it is.
        r.par_iter_mut()
            .zip(&s)
            .zip(&t)
            .for_each(|((ri, si), ti)| *ri = std::array::from_fn(|c| si[c] - omega[c] * ti[c]));
        rho = rho_new;
        for c in 0..3 {
            if active[c] && (alpha[c] == 0.0 || omega[c] == 0.0 || rho_new[c] == 0.0) {
                // Breakdown: restart from the current residual as the new shadow residual.
                for ((h, ri), (pi, vi)) in
                    r_hat.iter_mut().zip(&r).zip(p.iter_mut().zip(v.iter_mut()))
                {
                    h[c] = ri[c];
                    pi[c] = 0.0;
                    vi[c] = 0.0;
                }
                (rho[c], alpha[c], omega[c]) = (1.0, 1.0, 1.0);
            }
        }
        let nr = norm(&r);
        rel = std::array::from_fn(|c| nr[c] / nb[c]);
    }
    finish(op, b, x, tolerance, iterations)
}
