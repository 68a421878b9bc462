//! The level operator `K = S A` in compressed rows, and merging duplicate columns of a row.

use super::*;

/// A sparse symmetric level operator `K` in compressed rows, the diagonal apart.
#[derive(Clone, Debug, Default)]
pub struct SparseOperator {
    /// Row `i`'s off-diagonal entries are `cols[row_start[i]..row_start[i + 1]]`.
    pub row_start: Vec<usize>,
    pub cols: Vec<u32>,
    pub values: Vec<[f64; 3]>,
    /// `K_ii`: the node's mass (V_i times the Jacobi diagonal on inner rows, A_f / (2A) times it
    /// on surface rows).
    pub diag: Vec<[f64; 3]>,
    /// The 2x2 blocks of the smoother ([`MultigridParams::surface_blocks`]): per node its partner
    /// (a surface node's cell, a surface cell's surface node; [`NO_NODE`] for the others) and
    /// `K_(i, partner)`. Empty: point Jacobi.
    pub partner: Vec<u32>,
    pub partner_value: Vec<[f64; 3]>,
}

impl SparseOperator {
    /// `K = S A` of an assembled level.
    pub fn from_level(op: &LevelOperator) -> Self {
        let n = op.node_count();
        let mut out = Self {
            row_start: Vec::with_capacity(n + 1),
            cols: Vec::with_capacity(4 * n),
            values: Vec::with_capacity(4 * n),
            diag: Vec::with_capacity(n),
            ..Self::default()
        };
        out.row_start.push(0);
        for i in 0..n {
            let s = op.row_scale[i];
            for (k, &j) in op.neighbors[i].iter().enumerate() {
                if j != NO_NODE {
                    out.cols.push(j);
                    out.values.push(op.off[i][k].map(|v| -s * v));
                }
            }
            out.row_start.push(out.cols.len());
            out.diag.push(op.diag[i].map(|v| s * v));
        }
        out
    }

    /// The operator with its weak off-diagonal entries lumped into the diagonal (a non-Galerkin
    /// coarse operator, Falgout & Schroder 2014): `K_ij` is dropped when
    /// `max_c |K_ij| / sqrt(K_ii K_jj) < theta` (a symmetric test, so both `K_ij` and `K_ji` go)
    /// and added to `K_ii`. Each drop adds `K_ij (e_i - e_j)(e_i - e_j)^T`, so row sums,
    /// symmetry and (for a diagonally dominant K) positive definiteness are kept.
    pub fn sparsified(&self, theta: f64) -> SparseOperator {
        let n = self.node_count();
        let weak = |i: usize, e: usize| {
            let j = self.cols[e] as usize;
            let v = self.values[e];
            (0..3).all(|c| v[c].abs() < theta * (self.diag[i][c] * self.diag[j][c]).abs().sqrt())
        };
        // A row whose diagonal would lose more than half to the lumping keeps its entries, and
        // its neighbours keep theirs to it (symmetry): the diagonal stays well positive.
        let keeps_all: Vec<bool> = (0..n)
            .map(|i| {
                let mut d = self.diag[i];
                for e in self.row_start[i]..self.row_start[i + 1] {
                    if weak(i, e) {
                        for (dc, vc) in d.iter_mut().zip(self.values[e]) {
                            *dc += vc;
                        }
                    }
                }
                (0..3).any(|c| d[c] < 0.5 * self.diag[i][c])
            })
            .collect();
        let mut out = SparseOperator {
            row_start: Vec::with_capacity(n + 1),
            diag: self.diag.clone(),
            ..SparseOperator::default()
        };
        out.row_start.push(0);
        for i in 0..n {
            for e in self.row_start[i]..self.row_start[i + 1] {
                let j = self.cols[e] as usize;
                let v = self.values[e];
                if keeps_all[i] || keeps_all[j] || !weak(i, e) {
                    out.cols.push(self.cols[e]);
                    out.values.push(v);
                } else {
                    for (dc, vc) in out.diag[i].iter_mut().zip(v) {
                        *dc += vc;
                    }
                }
            }
            out.row_start.push(out.cols.len());
        }
        out
    }

    /// Pairs each surface node of `level` with its cell as one block of the smoother.
    pub fn pair_surface_nodes(&mut self, level: &GraphLevel) {
        let n = self.node_count();
        self.partner = vec![NO_NODE; n];
        self.partner_value = vec![[0.0; 3]; n];
        let inner = level.inner_count();
        for (s, &(cell, _)) in level.surface_faces.iter().enumerate() {
            let (a, b) = (cell as usize, inner + s);
            if a >= n || b >= n {
                continue;
            }
            let value = (self.row_start[b]..self.row_start[b + 1])
                .find(|&e| self.cols[e] as usize == a)
                .map(|e| self.values[e]);
            if let Some(v) = value {
                self.partner[a] = b as u32;
                self.partner[b] = a as u32;
                self.partner_value[a] = v;
                self.partner_value[b] = v;
            }
        }
    }

    /// `(B^-1 r)_i`, B the block diagonal: `r_i / K_ii`, or the 2x2 solve with the partner.
    #[inline]
    pub fn block_solve(&self, i: usize, r: &[[f64; 3]]) -> [f64; 3] {
        match self.partner.get(i) {
            Some(&p) if p != NO_NODE => {
                let p = p as usize;
                let b = self.partner_value[i];
                std::array::from_fn(|c| {
                    let (a, d) = (self.diag[i][c], self.diag[p][c]);
                    (d * r[i][c] - b[c] * r[p][c]) / (a * d - b[c] * b[c])
                })
            }
            _ => std::array::from_fn(|c| r[i][c] / self.diag[i][c]),
        }
    }

    /// `z = B^-1 r`.
    pub fn precondition(&self, r: &[[f64; 3]], z: &mut [[f64; 3]]) {
        z.par_iter_mut()
            .enumerate()
            .for_each(|(i, zi)| *zi = self.block_solve(i, r));
    }

    pub fn node_count(&self) -> usize {
        self.diag.len()
    }

    /// Off-diagonal entries per row on average (the stencil's width).
    pub fn mean_row_entries(&self) -> f64 {
        self.cols.len() as f64 / self.node_count().max(1) as f64
    }

    /// `sum_(j != i) K_ij x_j`.
    #[inline]
    fn off_product(&self, i: usize, x: &[[f64; 3]]) -> [f64; 3] {
        let mut acc = [0.0; 3];
        for e in self.row_start[i]..self.row_start[i + 1] {
            let xj = x[self.cols[e] as usize];
            let v = self.values[e];
            for c in 0..3 {
                acc[c] += v[c] * xj[c];
            }
        }
        acc
    }

    /// `r = f - K x`.
    pub fn residual(&self, x: &[[f64; 3]], f: &[[f64; 3]], r: &mut [[f64; 3]]) {
        r.par_iter_mut().enumerate().for_each(|(i, ri)| {
            let o = self.off_product(i, x);
            *ri = std::array::from_fn(|c| f[i][c] - self.diag[i][c] * x[i][c] - o[c]);
        });
    }

    /// `y = K x`.
    pub fn apply(&self, x: &[[f64; 3]], y: &mut [[f64; 3]]) {
        y.par_iter_mut().enumerate().for_each(|(i, yi)| {
            let o = self.off_product(i, x);
            *yi = std::array::from_fn(|c| self.diag[i][c] * x[i][c] + o[c]);
        });
    }

    /// Largest relative asymmetry |K_ij - K_ji| / max(|K_ij|, |K_ji|) (0 for `fv` and Galerkin).
    pub fn symmetry_defect(&self) -> f64 {
        let n = self.node_count();
        (0..n)
            .into_par_iter()
            .map(|i| {
                let mut worst: f64 = 0.0;
                for e in self.row_start[i]..self.row_start[i + 1] {
                    let j = self.cols[e] as usize;
                    let back = (self.row_start[j]..self.row_start[j + 1])
                        .find(|&b| self.cols[b] as usize == i);
                    let Some(b) = back else {
                        return f64::INFINITY;
                    };
                    for c in 0..3 {
                        let (u, v) = (self.values[e][c], self.values[b][c]);
                        worst =
                            worst.max((u - v).abs() / u.abs().max(v.abs()).max(f64::MIN_POSITIVE));
                    }
                }
                worst
            })
            .reduce(|| 0.0, f64::max)
    }
}

/// Sums entries of equal column (the result sorted by column).
pub(super) fn merge_columns(mut row: Vec<(u32, [f64; 3])>) -> Vec<(u32, [f64; 3])> {
    row.sort_unstable_by_key(|e| e.0);
    let mut out: Vec<(u32, [f64; 3])> = Vec::with_capacity(row.len());
    for (c, v) in row {
        match out.last_mut() {
            Some((lc, lv)) if *lc == c => {
                for ch in 0..3 {
                    lv[ch] += v[ch];
                }
            }
            _ => out.push((c, v)),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 3-node chain with one weak link (1 - 2): the weak entry goes into both diagonals (row
    /// sums and symmetry kept), the strong ones stay; a node whose diagonal would halve keeps all.
    #[test]
    fn sparsified_lumps_weak_entries_and_keeps_row_sums() {
        let k = SparseOperator {
            row_start: vec![0, 1, 3, 4],
            cols: vec![1, 0, 2, 1],
            values: vec![[-1.0; 3], [-1.0; 3], [-0.01; 3], [-0.01; 3]],
            diag: vec![[2.0; 3], [2.0; 3], [1.0; 3]],
            ..SparseOperator::default()
        };
        let row_sums = |k: &SparseOperator| -> Vec<f64> {
            (0..k.node_count())
                .map(|i| {
                    k.diag[i][0]
                        + k.values[k.row_start[i]..k.row_start[i + 1]]
                            .iter()
                            .map(|v| v[0])
                            .sum::<f64>()
                })
                .collect()
        };
        let s = k.sparsified(0.1);
        assert_eq!(
            s.cols,
            vec![1, 0],
            "the weak 1-2 link dropped, the strong 0-1 kept"
        );
        assert_eq!(row_sums(&s), row_sums(&k));
        assert_eq!(s.symmetry_defect(), 0.0);
        // Node 2's only entry is weak but its diagonal 0.011 would fall below half: kept.
        let small = SparseOperator {
            diag: vec![[2.0; 3], [2.0; 3], [0.011; 3]],
            ..k.clone()
        };
        let s = small.sparsified(0.5);
        assert_eq!(
            s.cols, small.cols,
            "a row that would lose half its diagonal keeps all"
        );
    }
}
