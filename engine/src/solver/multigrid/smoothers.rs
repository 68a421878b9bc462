//! Smoothers (damped and Chebyshev-accelerated Jacobi), their spectral bounds (power and Lanczos
//! iterations), and the coarsest level's preconditioned CG, with the small vector helpers.

use super::*;

/// `out = x + omega B^-1 (f - K x)`.
pub(super) fn damped_jacobi_sweep(
    k: &SparseOperator,
    x: &[[f64; 3]],
    f: &[[f64; 3]],
    omega: f64,
    out: &mut [[f64; 3]],
) {
    let mut r = vec![[0.0; 3]; x.len()];
    k.residual(x, f, &mut r);
    out.par_iter_mut().enumerate().for_each(|(i, o)| {
        let z = k.block_solve(i, &r);
        *o = std::array::from_fn(|c| x[i][c] + omega * z[c]);
    });
}

/// Per channel, the coefficients `(alpha, beta)` of Chebyshev step `step`:
/// `d <- alpha d + beta B^-1 (f - K x)`, `x <- x + d` (Saad, Iterative Methods, Alg. 12.1, with
/// the (block) Jacobi preconditioner B; d = 0 before step 0). Constants per step: the GPU gets
/// them as push constants, no reduction.
pub fn chebyshev_coefficients(bounds: [(f64, f64); 3], step: u32) -> [(f64, f64); 3] {
    bounds.map(|(lo, hi)| {
        let theta = 0.5 * (hi + lo);
        let delta = 0.5 * (hi - lo);
        let sigma = theta / delta;
        // rho_k = 1 / (2 sigma - rho_(k-1)), rho_0 = 1 / sigma.
        let mut rho = 1.0 / sigma;
        if step == 0 {
            return (0.0, 1.0 / theta);
        }
        let mut alpha = 0.0;
        let mut beta = 0.0;
        for _ in 0..step {
            let next = 1.0 / (2.0 * sigma - rho);
            alpha = next * rho;
            beta = 2.0 * next / delta;
            rho = next;
        }
        (alpha, beta)
    })
}

/// One Chebyshev step: `d = alpha d + beta B^-1 (f - K x)`, `out = x + d`.
pub(super) fn chebyshev_sweep(
    k: &SparseOperator,
    x: &[[f64; 3]],
    f: &[[f64; 3]],
    d: &mut [[f64; 3]],
    coefficients: [(f64, f64); 3],
    out: &mut [[f64; 3]],
) {
    let mut r = vec![[0.0; 3]; x.len()];
    k.residual(x, f, &mut r);
    out.par_iter_mut()
        .zip(d.par_iter_mut())
        .enumerate()
        .for_each(|(i, (o, di))| {
            let z = k.block_solve(i, &r);
            for c in 0..3 {
                let (alpha, beta) = coefficients[c];
                di[c] = alpha * di[c] + beta * z[c];
                o[c] = x[i][c] + di[c];
            }
        });
}

/// Largest eigenvalue of `B^-1 K` per channel, from the Lanczos tridiagonal matrix of
/// `iterations` preconditioned CG steps on `K x = v` (v a fixed pseudo-random vector, so the
/// estimate is deterministic). Lanczos converges to the extreme eigenvalues much faster than power
/// iteration; it approaches from below, so callers add a margin.
pub fn largest_eigenvalue(k: &SparseOperator, iterations: u32) -> [f64; 3] {
    eigenvalue_bounds(k, iterations).map(|(_, hi)| hi)
}

/// Smallest and largest Ritz values of `B^-1 K` per channel (the Lanczos tridiagonal of
/// [`largest_eigenvalue`]): the smallest approaches lambda_min from above, the largest lambda_max
/// from below. The GPU's coarsest level runs a Chebyshev polynomial on this interval.
pub fn eigenvalue_bounds(k: &SparseOperator, iterations: u32) -> [(f64, f64); 3] {
    let n = k.node_count();
    let mut r: Field = (0..n)
        .map(|i| {
            let h = crate::material::noise::hash_u32(i as u32 ^ 0x5bd1_e995);
            let u = f64::from(h) / f64::from(u32::MAX) - 0.5;
            [u; 3]
        })
        .collect();
    let mut z = vec![[0.0; 3]; n];
    k.precondition(&r, &mut z);
    let mut p = z.clone();
    let mut kp = vec![[0.0; 3]; n];
    let mut rz = dot(&r, &z);
    // Per channel, the CG coefficients (alpha_j, beta_j).
    let mut coefficients: Vec<([f64; 3], [f64; 3])> = Vec::new();
    for _ in 0..iterations.min(n as u32) {
        k.apply(&p, &mut kp);
        let pkp = dot(&p, &kp);
        if pkp.iter().any(|&v| !(v > 0.0 && v.is_finite())) {
            break;
        }
        let alpha: [f64; 3] = std::array::from_fn(|c| rz[c] / pkp[c]);
        for (ri, kpi) in r.iter_mut().zip(&kp) {
            for c in 0..3 {
                ri[c] -= alpha[c] * kpi[c];
            }
        }
        k.precondition(&r, &mut z);
        let rz_new = dot(&r, &z);
        let beta: [f64; 3] = std::array::from_fn(|c| rz_new[c] / rz[c]);
        coefficients.push((alpha, beta));
        if rz_new.iter().any(|&v| !(v > 0.0 && v.is_finite())) {
            break;
        }
        rz = rz_new;
        for (pi, zi) in p.iter_mut().zip(&z) {
            for c in 0..3 {
                pi[c] = zi[c] + beta[c] * pi[c];
            }
        }
    }
    std::array::from_fn(|c| {
        // Lanczos: T_jj = 1/alpha_j + beta_(j-1)/alpha_(j-1), T_(j,j+1) = sqrt(beta_j)/alpha_j.
        let m = coefficients.len();
        let mut diag = vec![0.0; m];
        let mut off = vec![0.0; m.saturating_sub(1)];
        for j in 0..m {
            let (a, _) = coefficients[j];
            diag[j] = 1.0 / a[c];
            if j > 0 {
                let (ap, bp) = coefficients[j - 1];
                diag[j] += bp[c] / ap[c];
                off[j - 1] = bp[c].sqrt() / ap[c];
            }
        }
        (
            smallest_tridiagonal_eigenvalue(&diag, &off),
            largest_tridiagonal_eigenvalue(&diag, &off),
        )
    })
}

/// Smallest eigenvalue of the symmetric tridiagonal matrix (diag, off): the largest of its
/// negation.
pub(super) fn smallest_tridiagonal_eigenvalue(diag: &[f64], off: &[f64]) -> f64 {
    let d: Vec<f64> = diag.iter().map(|v| -v).collect();
    -largest_tridiagonal_eigenvalue(&d, off)
}

/// Largest eigenvalue of the symmetric tridiagonal matrix (diag, off) by Sturm-sequence
/// bisection inside its Gershgorin interval.
pub(super) fn largest_tridiagonal_eigenvalue(diag: &[f64], off: &[f64]) -> f64 {
    if diag.is_empty() {
        return 0.0;
    }
    let radius = |j: usize| {
        off.get(j).map_or(0.0, |v: &f64| v.abs()) + j.checked_sub(1).map_or(0.0, |i| off[i].abs())
    };
    let mut lo = (0..diag.len())
        .map(|j| diag[j] - radius(j))
        .fold(f64::INFINITY, f64::min);
    let mut hi = (0..diag.len())
        .map(|j| diag[j] + radius(j))
        .fold(f64::NEG_INFINITY, f64::max);
    // Eigenvalues greater than x: sign changes of the Sturm sequence.
    let above = |x: f64| {
        let mut count = 0;
        let mut d = 1.0;
        for j in 0..diag.len() {
            let o2 = if j > 0 { off[j - 1] * off[j - 1] } else { 0.0 };
            d = diag[j] - x - if j > 0 { o2 / d } else { 0.0 };
            if d == 0.0 {
                d = f64::EPSILON * (x.abs() + 1.0);
            }
            if d > 0.0 {
                count += 1;
            }
        }
        count
    };
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if above(mid) > 0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    hi
}

pub(super) fn add3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|c| a[c] + b[c])
}

pub(super) fn max3(v: [f64; 3]) -> f64 {
    v.into_iter()
        .fold(0.0, |a, b| if b.is_nan() { b } else { a.max(b) })
}

pub(super) fn dot(a: &[[f64; 3]], b: &[[f64; 3]]) -> [f64; 3] {
    a.par_iter()
        .zip(b)
        .map(|(x, y)| std::array::from_fn(|c| x[c] * y[c]))
        .reduce(|| [0.0; 3], add3)
}

/// 2-norm per channel.
pub fn norm2(a: &[[f64; 3]]) -> [f64; 3] {
    dot(a, a).map(f64::sqrt)
}

/// Jacobi-preconditioned CG on `K x = f` from `x`, per channel, to a relative residual of
/// `tolerance` (recursive residual); returns the iterations.
pub(super) fn pcg(
    k: &SparseOperator,
    f: &[[f64; 3]],
    x: &mut [[f64; 3]],
    tolerance: f64,
    max_iterations: usize,
) -> usize {
    let n = k.node_count();
    let fnorm = norm2(f).map(|v| if v > 0.0 { v } else { 1.0 });
    let mut r = vec![[0.0; 3]; n];
    k.residual(x, f, &mut r);
    let precondition = |r: &[[f64; 3]], z: &mut [[f64; 3]]| k.precondition(r, z);
    let mut z = vec![[0.0; 3]; n];
    precondition(&r, &mut z);
    let mut p = z.clone();
    let mut kp = vec![[0.0; 3]; n];
    let mut rz = dot(&r, &z);
    let mut rel: [f64; 3] = std::array::from_fn(|c| norm2(&r)[c] / fnorm[c]);
    let mut iterations = 0;
    while iterations < max_iterations && rel.iter().any(|&v| v >= tolerance) {
        iterations += 1;
        k.apply(&p, &mut kp);
        let pkp = dot(&p, &kp);
        let alpha: [f64; 3] = std::array::from_fn(|c| {
            if rel[c] >= tolerance && pkp[c] > 0.0 {
                rz[c] / pkp[c]
            } else {
                0.0
            }
        });
        for ((xi, ri), (pi, kpi)) in x.iter_mut().zip(r.iter_mut()).zip(p.iter().zip(&kp)) {
            for c in 0..3 {
                xi[c] += alpha[c] * pi[c];
                ri[c] -= alpha[c] * kpi[c];
            }
        }
        let nr = norm2(&r);
        rel = std::array::from_fn(|c| nr[c] / fnorm[c]);
        precondition(&r, &mut z);
        let rz_new = dot(&r, &z);
        let beta: [f64; 3] = std::array::from_fn(|c| {
            if rz[c] > 0.0 && alpha[c] != 0.0 {
                rz_new[c] / rz[c]
            } else {
                0.0
            }
        });
        rz = rz_new;
        for (pi, zi) in p.iter_mut().zip(&z) {
            for c in 0..3 {
                pi[c] = zi[c] + beta[c] * pi[c];
            }
        }
    }
    iterations
}
