//! The Shepard prolongation `P` between levels and its transpose (the restriction), with the
//! bake's links or linear (barycentric) weights.

use super::*;

/// The Shepard prolongation of one level (coarser -> this level) and its transpose.
#[derive(Clone, Debug, Default)]
pub struct Prolongation {
    /// Per fine node, up to 8 coarse nodes and weights (the bake's links).
    pub links: Vec<[u32; 8]>,
    pub weights: Vec<[f64; 8]>,
    /// Per coarse node, the fine nodes linking to it and their weights (`P^T` by rows).
    pub t_start: Vec<usize>,
    pub t_fine: Vec<u32>,
    pub t_weight: Vec<f64>,
}

impl Prolongation {
    /// From the bake's links into a level of `fine_nodes` nodes from one of `coarse_nodes`.
    pub fn new(
        links: &ShepardLinks,
        fine_nodes: usize,
        coarse_nodes: usize,
    ) -> Result<Self, SolverError> {
        if links.links.len() != fine_nodes || links.weights.len() != fine_nodes {
            return Err(SolverError::BadGraph {
                level: usize::MAX,
                problem: format!("{} Shepard links for {fine_nodes} nodes", links.links.len()),
            });
        }
        let mut count = vec![0usize; coarse_nodes + 1];
        for (x, (l, w)) in links.links.iter().zip(&links.weights).enumerate() {
            for (&c, &wc) in l.iter().zip(w) {
                if c == NO_NODE {
                    continue;
                }
                if c as usize >= coarse_nodes || !wc.is_finite() {
                    return Err(SolverError::BadGraph {
                        level: usize::MAX,
                        problem: format!("Shepard link of node {x} is out of range or not finite"),
                    });
                }
                count[c as usize + 1] += 1;
            }
        }
        for c in 0..coarse_nodes {
            count[c + 1] += count[c];
        }
        let t_start = count.clone();
        let mut t_fine = vec![0u32; t_start[coarse_nodes]];
        let mut t_weight = vec![0.0; t_start[coarse_nodes]];
        let mut next = count;
        for (x, (l, w)) in links.links.iter().zip(&links.weights).enumerate() {
            for (&c, &wc) in l.iter().zip(w) {
                if c != NO_NODE {
                    let slot = &mut next[c as usize];
                    t_fine[*slot] = x as u32;
                    t_weight[*slot] = wc;
                    *slot += 1;
                }
            }
        }
        Ok(Self {
            links: links.links.clone(),
            weights: links.weights.clone(),
            t_start,
            t_fine,
            t_weight,
        })
    }

    pub fn coarse_count(&self) -> usize {
        self.t_start.len() - 1
    }

    /// `x_fine += P e_coarse` (paper Eq. 10 applied to a correction).
    pub fn prolong_add(&self, e_coarse: &[[f64; 3]], x_fine: &mut [[f64; 3]]) {
        x_fine
            .par_iter_mut()
            .zip(self.links.par_iter().zip(&self.weights))
            .for_each(|(x, (l, w))| {
                for (&c, &wc) in l.iter().zip(w) {
                    if c != NO_NODE {
                        for ch in 0..3 {
                            x[ch] += wc * e_coarse[c as usize][ch];
                        }
                    }
                }
            });
    }

    /// `r_coarse = P^T r_fine`.
    pub fn restrict(&self, r_fine: &[[f64; 3]], r_coarse: &mut [[f64; 3]]) {
        r_coarse.par_iter_mut().enumerate().for_each(|(c, out)| {
            let mut acc = [0.0; 3];
            for e in self.t_start[c]..self.t_start[c + 1] {
                let r = r_fine[self.t_fine[e] as usize];
                for ch in 0..3 {
                    acc[ch] += self.t_weight[e] * r[ch];
                }
            }
            *out = acc;
        });
    }

    /// The prolongation after `steps` Jacobi steps on its weights restricted to its own links
    /// (energy-minimizing interpolation on a fixed pattern; Wan, Chan & Smith 1999, Mandel,
    /// Brezina & Vanek 1999): per step `P -= omega D^-1 K P` on the linked entries only, the
    /// update of each row made mean-free over its links so that `P 1` (constants) is kept.
    /// `omega` per channel (`s / lambda_max` of `D^-1 K`); the channels' updates are averaged
    /// (one weight per link serves all three). The links (and so the memory of P, P^T and of the
    /// Galerkin product's rows) are unchanged: only the weights move toward the operator's.
    pub fn pattern_smoothed(
        &self,
        k: &SparseOperator,
        omega: [f64; 3],
        steps: u32,
    ) -> Result<Self, SolverError> {
        let mut weights = self.weights.clone();
        for _ in 0..steps {
            let next: Vec<[f64; 8]> = (0..k.node_count())
                .into_par_iter()
                .map(|i| {
                    let links = &self.links[i];
                    let w = &weights[i];
                    // (K P)_ic for the linked c, per channel.
                    let mut kp = [[0.0f64; 3]; 8];
                    let mut add = |j: usize, v: [f64; 3]| {
                        for (slot, &c) in links.iter().enumerate() {
                            if c == NO_NODE {
                                continue;
                            }
                            if let Some(q) = self.links[j].iter().position(|&cj| cj == c) {
                                let wj = weights[j][q];
                                for ch in 0..3 {
                                    kp[slot][ch] += v[ch] * wj;
                                }
                            }
                        }
                    };
                    add(i, k.diag[i]);
                    for e in k.row_start[i]..k.row_start[i + 1] {
                        add(k.cols[e] as usize, k.values[e]);
                    }
                    let mut update = [0.0f64; 8];
                    let mut used = 0usize;
                    let mut mean = 0.0;
                    for (slot, &c) in links.iter().enumerate() {
                        if c == NO_NODE {
                            continue;
                        }
                        let u: f64 = (0..3)
                            .map(|ch| {
                                let d = k.diag[i][ch];
                                if d > 0.0 {
                                    omega[ch] * kp[slot][ch] / d
                                } else {
                                    0.0
                                }
                            })
                            .sum::<f64>()
                            / 3.0;
                        update[slot] = u;
                        mean += u;
                        used += 1;
                    }
                    if used > 0 {
                        mean /= used as f64;
                    }
                    let mut out = *w;
                    for (slot, &c) in links.iter().enumerate() {
                        if c != NO_NODE {
                            out[slot] -= update[slot] - mean;
                        }
                    }
                    out
                })
                .collect();
            weights = next;
        }
        Self::new(
            &ShepardLinks {
                links: self.links.clone(),
                weights,
            },
            self.links.len(),
            self.coarse_count(),
        )
    }

    /// `P^T K P`: the Galerkin coarse operator of `k` (this level's fine operator).
    pub fn galerkin(&self, k: &SparseOperator) -> SparseOperator {
        let nc = self.coarse_count();
        // Row i of K P (fine rows, coarse columns), merged by column.
        let kp: Vec<Vec<(u32, [f64; 3])>> = (0..k.node_count())
            .into_par_iter()
            .map(|i| {
                let mut row: Vec<(u32, [f64; 3])> = Vec::with_capacity(48);
                let mut push = |j: usize, v: [f64; 3]| {
                    for (&c, &w) in self.links[j].iter().zip(&self.weights[j]) {
                        if c != NO_NODE && w != 0.0 {
                            row.push((c, v.map(|x| x * w)));
                        }
                    }
                };
                // A decoupled row of a coarser Galerkin level (below) is not part of the
                // operator: its unit diagonal must not leak into the next coarser level.
                if !is_decoupled(k, i) {
                    push(i, k.diag[i]);
                }
                for e in k.row_start[i]..k.row_start[i + 1] {
                    push(k.cols[e] as usize, k.values[e]);
                }
                merge_columns(row)
            })
            .collect();
        let rows: Vec<(SparseRow, [f64; 3])> = (0..nc)
            .into_par_iter()
            .map(|c| {
                let mut row: Vec<(u32, [f64; 3])> = Vec::new();
                for e in self.t_start[c]..self.t_start[c + 1] {
                    let w = self.t_weight[e];
                    for &(col, v) in &kp[self.t_fine[e] as usize] {
                        row.push((col, v.map(|x| x * w)));
                    }
                }
                let merged = merge_columns(row);
                if merged.iter().all(|(_, v)| *v == [0.0; 3]) {
                    // why: no fine node interpolates from this coarse node (the Shepard links
                    // pick the nearest coarse nodes, and a box's coarse corner nodes can be
                    // nobody's nearest), so its row and column of P^T K P are empty. It gets a
                    // unit diagonal: its restricted residual is always 0, so its correction
                    // stays 0 and nothing reads it, and the smoothers never divide by 0.
                    return (Vec::new(), DECOUPLED_DIAGONAL);
                }
                let diag = merged
                    .iter()
                    .find(|(col, _)| *col as usize == c)
                    .map_or([0.0; 3], |&(_, v)| v);
                let off = merged
                    .into_iter()
                    .filter(|(col, _)| *col as usize != c)
                    .collect();
                (off, diag)
            })
            .collect();
        let mut out = SparseOperator {
            row_start: Vec::with_capacity(nc + 1),
            ..SparseOperator::default()
        };
        out.row_start.push(0);
        for (off, diag) in rows {
            for (col, v) in off {
                out.cols.push(col);
                out.values.push(v);
            }
            out.row_start.push(out.cols.len());
            out.diag.push(diag);
        }
        out
    }
}

/// The diagonal of a Galerkin row no fine node interpolates from ([`Prolongation::galerkin`]).
const DECOUPLED_DIAGONAL: [f64; 3] = [1.0; 3];

/// Whether row `i` of `k` is a decoupled Galerkin row: no off-diagonal entry and the unit diagonal
/// (an assembled level's rows always have neighbours).
fn is_decoupled(k: &SparseOperator, i: usize) -> bool {
    k.row_start[i] == k.row_start[i + 1] && k.diag[i] == DECOUPLED_DIAGONAL
}

/// Shepard links in which inner nodes link to the 8 nearest coarse nodes of either kind
/// ([`Interpolation::Mixed`]); surface nodes keep the bake's rule (4 coarse surface nodes).
pub fn mixed_links(fine: &GraphLevel, coarse: &GraphLevel) -> ShepardLinks {
    let all = ShepardIndex::new(&coarse.positions, None);
    let mut links = crate::quadgraph::shepard::level_links(fine, coarse);
    let reach = 2.0 * coarse.spacing;
    let eps = 1e-3 * fine.spacing;
    let fi = fine.inner_count();
    let inner: Vec<([u32; 8], [f64; 8])> = (0..fi)
        .into_par_iter()
        .map(|i| all.weights::<8>(fine.positions[i], None, reach, eps))
        .collect();
    for (i, (l, w)) in inner.into_iter().enumerate() {
        links.links[i] = l;
        links.weights[i] = w;
    }
    links
}

/// The links of `links` with weights exact for linear functions ([`Interpolation::Linear`]).
pub fn linear_links(links: &ShepardLinks, fine: &GraphLevel, coarse: &GraphLevel) -> ShepardLinks {
    let fi = fine.inner_count();
    let weights = links
        .links
        .par_iter()
        .zip(&links.weights)
        .enumerate()
        .map(|(node, (l, w))| {
            let x = fine.positions[node];
            let normal = (node >= fi).then(|| fine.surface_normals[node - fi]);
            let r = linear_weights(x, l, w, &coarse.positions, normal, coarse.spacing);
            if r.is_none() && std::env::var_os("MG_DEBUG").is_some() {
                eprintln!("fallback node {node} surface {}", normal.is_some());
            }
            r.unwrap_or(*w)
        })
        .collect();
    ShepardLinks {
        links: links.links.clone(),
        weights,
    }
}

/// Weights `c_k = w_k (lambda . v_k)`, `v_k = (1, (x_k - x) / h)` (tangential components only when
/// `normal` is given), with `lambda` such that `sum c_k v_k = (1, 0)`: constants and linear
/// functions are reproduced. `None` when the moment matrix is singular or the weights would
/// extrapolate wildly (sum |c| > 3).
fn linear_weights(
    x: DVec3,
    links: &[u32; 8],
    w: &[f64; 8],
    positions: &[DVec3],
    normal: Option<DVec3>,
    h: f64,
) -> Option<[f64; 8]> {
    let mut out = [0.0; 8];
    let frame = normal.map(|n| {
        let n = n.normalize_or_zero();
        let t1 = n.any_orthonormal_vector();
        (t1, n.cross(t1))
    });
    let v = |k: usize| -> DVec4 {
        let d = (positions[links[k] as usize] - x) / h;
        match frame {
            Some((t1, t2)) => DVec4::new(1.0, d.dot(t1), d.dot(t2), 0.0),
            None => DVec4::new(1.0, d.x, d.y, d.z),
        }
    };
    let used: Vec<usize> = (0..8)
        .filter(|&k| links[k] != NO_NODE && w[k] > 0.0)
        .collect();
    let dims: i32 = if frame.is_some() { 3 } else { 4 };
    if used.len() < dims as usize {
        return None;
    }
    let mut m = DMat4::ZERO;
    for &k in &used {
        let vk = v(k);
        m += DMat4::from_cols(vk * vk.x, vk * vk.y, vk * vk.z, vk * vk.w) * w[k];
    }
    if frame.is_some() {
        // The unused 4th dimension: identity, so the matrix stays invertible.
        m.w_axis.w = 1.0;
    }
    let det = m.determinant();
    if !(det.is_finite() && det.abs() > 1e-9 * m.x_axis.x.powi(dims)) {
        return None;
    }
    let lambda = m.inverse() * DVec4::X;
    let mut total = 0.0;
    for &k in &used {
        out[k] = w[k] * lambda.dot(v(k));
        total += out[k].abs();
    }
    (total.is_finite() && total <= 3.0).then_some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 1D chain of 3 fine nodes, K = tridiag(-1, 2, -1) per channel.
    fn chain() -> SparseOperator {
        SparseOperator {
            row_start: vec![0, 1, 3, 4],
            cols: vec![1, 0, 2, 1],
            values: vec![[-1.0; 3]; 4],
            diag: vec![[2.0; 3]; 3],
            ..SparseOperator::default()
        }
    }

    fn link(to: &[(u32, f64)]) -> ([u32; 8], [f64; 8]) {
        let mut l = [NO_NODE; 8];
        let mut w = [0.0; 8];
        for (k, &(c, wc)) in to.iter().enumerate() {
            l[k] = c;
            w[k] = wc;
        }
        (l, w)
    }

    #[test]
    fn a_coarse_node_no_fine_node_links_to_is_decoupled_not_singular() {
        // Coarse node 1 is nobody's Shepard neighbour (a box's coarse corner was): before, its
        // Galerkin diagonal was 0 and `render --shape box` stopped with "diagonal not finite".
        let (l, w): (Vec<_>, Vec<_>) = [
            link(&[(0, 1.0)]),
            link(&[(0, 0.5), (2, 0.5)]),
            link(&[(2, 1.0)]),
        ]
        .into_iter()
        .unzip();
        let p = Prolongation::new(
            &ShepardLinks {
                links: l,
                weights: w,
            },
            3,
            3,
        )
        .unwrap();
        let coarse = p.galerkin(&chain());
        assert_eq!(coarse.diag[1], DECOUPLED_DIAGONAL);
        assert!(is_decoupled(&coarse, 1));
        // The coupled rows are the true P^T K P: diag = p0^T K p0 with p0 = (1, 0.5, 0).
        assert_eq!(coarse.diag[0], [2.0 - 2.0 * 0.5 + 0.5; 3]);
        assert!(coarse.diag.iter().flatten().all(|&d| d > 0.0));
        // One level further, the decoupled row leaves no trace: a prolongation onto the coupled
        // node 0 alone gives exactly coarse.diag[0], not coarse.diag[0] + 1.
        let (l2, w2): (Vec<_>, Vec<_>) = [link(&[(0, 1.0)]), link(&[(0, 1.0)]), link(&[])]
            .into_iter()
            .unzip();
        let p2 = Prolongation::new(
            &ShepardLinks {
                links: l2,
                weights: w2,
            },
            3,
            1,
        )
        .unwrap();
        let coarser = p2.galerkin(&coarse);
        assert_eq!(coarser.diag[0], coarse.diag[0]);
    }
}
