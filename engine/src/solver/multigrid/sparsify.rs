//! Non-Galerkin coarse operators: the Galerkin product `P^T K P` with its weak entries dropped and
//! their weight moved where it keeps the operator's action on constants, its symmetry and its
//! positive definiteness (Falgout & Schroder, "Non-Galerkin coarse grids for algebraic
//! multigrid", 2014; Treister & Yavneh, "Non-Galerkin multigrid based on sparsified smoothed
//! aggregation", 2015).
//!
//! An entry `K_ij` is weak when `|K_ij| < theta sqrt(K_ii K_jj)` in every channel (a symmetric
//! test, so `K_ij` and `K_ji` go together). Dropping it and moving it onto the diagonals
//! ([`Lumping::Diagonal`]) adds `K_ij (e_i - e_j)(e_i - e_j)^T`: for a negative (diffusive)
//! entry that LOWERS the energy, so the coarse correction overshoots (measured: 2 more CG
//! iterations on the default scene, divergence on the agate at theta 0.02). [`Lumping::Paths`]
//! moves a negative entry onto the paths `i - k - j` through the strong neighbours `k` the two
//! share, each path's two edges at twice the share of the dropped weight: with `w = -K_ij > 0`,
//! `w (x_i - x_j)^2 <= 2 w (x_i - x_k)^2 + 2 w (x_k - x_j)^2`, so the sparsified operator is at
//! least the Galerkin one in energy (Treister & Yavneh's condition for a stable coarse
//! correction) and still exact for constants. A positive entry goes onto the diagonals (that adds
//! energy). A weak negative pair with no shared strong neighbour keeps its entry.
//!
//! ```
//! use translucent::solver::multigrid::{Lumping, SparseOperator, PATH_WEIGHT};
//! // A triangle 0-1-2 with a weak 0-2 edge: it moves onto the path 0-1-2.
//! let k = SparseOperator {
//!     row_start: vec![0, 2, 4, 6],
//!     cols: vec![1, 2, 0, 2, 0, 1],
//!     values: vec![[-1.0; 3], [-0.01; 3], [-1.0; 3], [-1.0; 3], [-0.01; 3], [-1.0; 3]],
//!     diag: vec![[2.01; 3], [2.0; 3], [2.01; 3]],
//!     ..SparseOperator::default()
//! };
//! let s = k.sparsified_with(0.1, Lumping::Paths, PATH_WEIGHT);
//! assert_eq!(s.cols, vec![1, 0, 2, 1]);
//! assert!(s.symmetry_defect() < 1e-15);
//! ```

use super::*;

/// Where a dropped weak entry of a coarse operator goes (`--multigrid-cycle lump=`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub enum Lumping {
    /// Onto the two diagonals (wave 5): row sums and symmetry kept, but a dropped negative entry
    /// lowers the operator's energy.
    Diagonal,
    /// A negative entry onto the paths through shared strong neighbours (twice its weight), a
    /// positive one onto the diagonals: row sums and symmetry kept, the energy never lowered.
    #[default]
    Paths,
}

impl std::str::FromStr for Lumping {
    type Err = SolverError;
    fn from_str(s: &str) -> Result<Self, SolverError> {
        match s {
            "diagonal" => Ok(Self::Diagonal),
            "paths" => Ok(Self::Paths),
            _ => Err(SolverError::BadParameter {
                name: "lumping",
                problem: format!("'{s}' (expected diagonal or paths)"),
            }),
        }
    }
}

/// Each edge of a path `i - k - j` takes this multiple of its share of a dropped weight `w`
/// (`MultigridParams::path_weight`'s default): `(a - b)^2 <= 2 (a - c)^2 + 2 (c - b)^2`, so 2 is
/// the smallest factor for which the path bounds the dropped edge's energy for every vector (and
/// it is exact for a linear function through a midpoint `k`).
pub const PATH_WEIGHT: f64 = 2.0;

impl SparseOperator {
    /// The operator with its weak entries (threshold `theta`) dropped and lumped as `lumping`
    /// says (see the module doc).
    /// `path_weight` is [`PATH_WEIGHT`] for the energy bound (smaller: closer to the Galerkin
    /// energy on smooth vectors, no bound).
    pub fn sparsified_with(
        &self,
        theta: f64,
        lumping: Lumping,
        path_weight: f64,
    ) -> SparseOperator {
        match lumping {
            Lumping::Diagonal => self.sparsified(theta),
            Lumping::Paths => self.sparsified_by_paths(theta, path_weight),
        }
    }

    fn weak_entry(&self, i: usize, e: usize, theta: f64) -> bool {
        let j = self.cols[e] as usize;
        let v = self.values[e];
        (0..3).all(|c| v[c].abs() < theta * (self.diag[i][c] * self.diag[j][c]).abs().sqrt())
    }

    fn sparsified_by_paths(&self, theta: f64, path_weight: f64) -> SparseOperator {
        let n = self.node_count();
        // The strong pattern, rows sorted by column; the weak pairs (i < j) to move.
        let mut strong: Vec<Vec<(u32, [f64; 3])>> = vec![Vec::new(); n];
        let mut weak: Vec<(usize, usize, [f64; 3])> = Vec::new();
        // why the upper entries only: K is symmetric up to rounding, and one decision (and one
        // value) per pair keeps the result exactly symmetric.
        for i in 0..n {
            for e in self.row_start[i]..self.row_start[i + 1] {
                let j = self.cols[e] as usize;
                if j <= i {
                    continue;
                }
                if self.weak_entry(i, e, theta) {
                    weak.push((i, j, self.values[e]));
                } else {
                    strong[i].push((j as u32, self.values[e]));
                    strong[j].push((i as u32, self.values[e]));
                }
            }
        }
        for row in &mut strong {
            row.sort_unstable_by_key(|e| e.0);
        }
        let original = strong.clone();
        let mut diag = self.diag.clone();
        let mut kept: Vec<(usize, usize, [f64; 3])> = Vec::new();
        let add = |rows: &mut [Vec<(u32, [f64; 3])>], a: usize, b: usize, v: f64, c: usize| {
            let row = &mut rows[a];
            if let Ok(p) = row.binary_search_by_key(&(b as u32), |e| e.0) {
                row[p].1[c] += v;
            }
        };
        for (i, j, v) in weak {
            let shared = shared_neighbours(&original[i], &original[j]);
            if shared.is_empty() && v.iter().any(|&x| x < 0.0) {
                kept.push((i, j, v));
                continue;
            }
            for c in 0..3 {
                if v[c] >= 0.0 {
                    diag[i][c] += v[c];
                    diag[j][c] += v[c];
                    continue;
                }
                // Shares by the path's weaker edge (uniform where every path is 0 here).
                let strength: Vec<f64> = shared
                    .iter()
                    .map(|&(_, a, b)| a[c].abs().min(b[c].abs()))
                    .collect();
                let total: f64 = strength.iter().sum();
                let w = -v[c];
                diag[i][c] += (path_weight - 1.0) * w;
                diag[j][c] += (path_weight - 1.0) * w;
                for (&(k, _, _), &s) in shared.iter().zip(&strength) {
                    let beta = if total > 0.0 {
                        s / total
                    } else {
                        1.0 / shared.len() as f64
                    };
                    let edge = path_weight * beta * w;
                    let k = k as usize;
                    add(&mut strong, i, k, -edge, c);
                    add(&mut strong, k, i, -edge, c);
                    add(&mut strong, j, k, -edge, c);
                    add(&mut strong, k, j, -edge, c);
                    diag[k][c] += 2.0 * edge;
                }
            }
        }
        for (i, j, v) in kept {
            strong[i].push((j as u32, v));
            strong[j].push((i as u32, v));
        }
        let mut out = SparseOperator {
            row_start: Vec::with_capacity(n + 1),
            diag,
            ..SparseOperator::default()
        };
        out.row_start.push(0);
        for row in strong {
            for (col, v) in merge_columns(row) {
                out.cols.push(col);
                out.values.push(v);
            }
            out.row_start.push(out.cols.len());
        }
        out
    }

    /// Off-diagonal entries of the fullest row.
    pub fn max_row_entries(&self) -> usize {
        self.row_start
            .windows(2)
            .map(|w| w[1] - w[0])
            .max()
            .unwrap_or(0)
    }

    /// `sum_j K_ij` per row and channel (the operator's action on constants).
    pub fn row_sums(&self) -> Vec<[f64; 3]> {
        (0..self.node_count())
            .map(|i| {
                let mut s = self.diag[i];
                for e in self.row_start[i]..self.row_start[i + 1] {
                    for (sc, vc) in s.iter_mut().zip(self.values[e]) {
                        *sc += vc;
                    }
                }
                s
            })
            .collect()
    }
}

/// The columns two sorted rows share, with each row's value there.
fn shared_neighbours(
    a: &[(u32, [f64; 3])],
    b: &[(u32, [f64; 3])],
) -> Vec<(u32, [f64; 3], [f64; 3])> {
    let (mut p, mut q) = (0, 0);
    let mut out = Vec::new();
    while p < a.len() && q < b.len() {
        match a[p].0.cmp(&b[q].0) {
            std::cmp::Ordering::Less => p += 1,
            std::cmp::Ordering::Greater => q += 1,
            std::cmp::Ordering::Equal => {
                out.push((a[p].0, a[p].1, b[q].1));
                p += 1;
                q += 1;
            }
        }
    }
    out
}
