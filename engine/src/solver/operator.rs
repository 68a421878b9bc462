//! The discrete diffusion system of one QuadGraph level, assembled once so that Jacobi and the
//! exact solvers share it (DESIGN section 2).
//!
//! Every node has one row `diag_i phi_i - sum_k off_ik phi_nbr(i,k) = b_i` per channel, with
//! `off >= 0`. Inner rows have `b = 0`; surface rows are normalized so that `b_s = 4 q_s / (1 - F_dr)`.
//! Multiplying row i by `row_scale[i]` (V_i for inner rows, A_f / (2A) for surface rows) makes the
//! `fv` matrix symmetric (and positive definite): that is the form conjugate gradient solves.
//!
//! ```
//! use glam::DVec3;
//! use translucent::material::{Material, MaterialField};
//! use translucent::solver::operator::{LevelOperator, Scheme};
//! use translucent::{tet::TetMesh, GraphLevel};
//! let level = GraphLevel::from_tets(TetMesh::bcc_box(DVec3::ZERO, DVec3::splat(4.0), [4, 4, 4]), 1.0, |c, n| (c, n));
//! let field = MaterialField::Homogeneous(Material::preset("marble")?);
//! let op = LevelOperator::build(&level, &field, Scheme::Fv)?;
//! assert_eq!(op.diag.len(), level.node_count());
//! assert!(op.symmetry_defect() < 1e-12);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use glam::DVec3;
use rayon::prelude::*;

use super::transport::{Boundary, ExitQuery};
use super::SolverError;
use crate::material::{check_pair, fresnel, Coefficients, MaterialField};
use crate::quadgraph::graph::{GraphLevel, NO_NODE};
use crate::tet::structured::signed_volume;

/// How the diffusion equation becomes a linear system on the 4-neighbour graph.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Scheme {
    /// Cell-centred finite volumes on the tetrahedra (DESIGN section 2): consistent, conservative.
    #[default]
    Fv,
    /// The paper's Eqs. 5/6 (with Eq. 9's constant corrected to 4/(1 - F_dr)); for comparison only.
    Paper,
}

impl std::str::FromStr for Scheme {
    type Err = SolverError;
    fn from_str(s: &str) -> Result<Self, SolverError> {
        match s {
            "fv" => Ok(Self::Fv),
            "paper" => Ok(Self::Paper),
            _ => Err(SolverError::BadParameter {
                name: "scheme",
                problem: format!("'{s}' (expected fv or paper)"),
            }),
        }
    }
}

/// The assembled system of one level. Arrays are indexed by node id (inner nodes, then surface).
#[derive(Clone, Debug)]
pub struct LevelOperator {
    pub scheme: Scheme,
    pub inner_count: usize,
    /// Per node, the neighbours the off-diagonal coefficients refer to ([`NO_NODE`] in unused slots;
    /// a surface node uses slot 0 only).
    pub neighbors: Vec<[u32; 4]>,
    pub diag: Vec<[f64; 3]>,
    pub off: Vec<[[f64; 3]; 4]>,
    /// Row scaling that symmetrizes the `fv` system: V_i for inner rows, A_f / (2A) for surface rows.
    pub row_scale: Vec<f64>,
    /// b_s = q_gain * q_s on surface rows: 4 / (1 - F_dr) (paper Eq. 6, DESIGN's corrected Eq. 9).
    pub q_gain: f64,
    /// Tetrahedron volumes (inner nodes), mm^3.
    pub volumes: Vec<f64>,
    /// Boundary face areas (surface nodes, by surface index), mm^2.
    pub areas: Vec<f64>,
    /// Absorption mu at inner nodes.
    pub mu: Vec<[f64; 3]>,
    pub f_dr: f64,
    pub a: f64,
}

/// Diagonal and the 4 off-diagonal coefficients of one inner row.
type InnerRow = ([f64; 3], [[f64; 3]; 4]);

/// `v > min`, false for NaN (written out so that NaN fails every check).
fn above(v: f64, min: f64) -> bool {
    v.is_finite() && v > min
}

fn degenerate(node: usize, problem: String) -> SolverError {
    SolverError::DegenerateGeometry {
        level: usize::MAX,
        node,
        problem,
    }
}

impl LevelOperator {
    /// Assembles the system of `level` for `material` with `scheme`. Fails on degenerate geometry
    /// (zero-volume tetrahedra, zero-area faces, coincident nodes) and on invalid sampled coefficients.
    pub fn build(
        level: &GraphLevel,
        material: &MaterialField,
        scheme: Scheme,
    ) -> Result<Self, SolverError> {
        Self::build_with(level, material, scheme, ExitQuery::Classic)
    }

    /// [`Self::build`] with the boundary constant A and the flux gain of `exit`'s boundary model
    /// (DESIGN 2.6: A = (1 + 3 C2) / (1 - 2 C1), b_s = 4 q / (1 - 2 C1) for a diffuse flux q).
    pub fn build_with(
        level: &GraphLevel,
        material: &MaterialField,
        scheme: Scheme,
        exit: ExitQuery,
    ) -> Result<Self, SolverError> {
        let inner = level.inner_count();
        let nodes = level.node_count();
        check_level(level)?;
        let eta = material.eta();
        let boundary = Boundary::new(eta, exit);
        let (f_dr, a) = (fresnel::diffuse_reflectance(eta), boundary.a);
        let coeffs: Vec<Coefficients> = level
            .positions
            .par_iter()
            .map(|&p| material.sample(p))
            .collect();
        for (node, c) in coeffs.iter().enumerate() {
            check_pair(c.sigma_s, c.sigma_a).map_err(|source| SolverError::BadMaterialAt {
                node,
                position: level.positions[node],
                source,
            })?;
        }
        // D of the material's kind (classical 1 / (3 sigma_t') unless Grosjean's was chosen).
        let diffusion = material.diffusion();
        let kappa: Vec<[f64; 3]> = coeffs.iter().map(|c| c.kappa_with(diffusion)).collect();
        let volumes: Vec<f64> = (0..inner)
            .into_par_iter()
            .map(|t| signed_volume(&level.tets, t))
            .collect();
        if let Some(t) = volumes.iter().position(|v| !(v.is_finite() && *v > 0.0)) {
            return Err(degenerate(
                t,
                format!("tetrahedron volume {} (must be > 0)", volumes[t]),
            ));
        }
        let face = |t: usize, f: usize| {
            let [p0, p1, p2] = level.face_vertices(t, f);
            let n2 = (p1 - p0).cross(p2 - p0);
            (0.5 * n2.length(), n2.normalize_or_zero(), p0)
        };
        let areas: Vec<f64> = level
            .surface_faces
            .iter()
            .map(|&(t, f)| face(t as usize, f as usize).0)
            .collect();

        let mut neighbors = vec![[NO_NODE; 4]; nodes];
        let mut diag = vec![[0.0; 3]; nodes];
        let mut off = vec![[[0.0; 3]; 4]; nodes];
        let mut row_scale = vec![0.0; nodes];

        // Inner rows, in parallel: each writes only its own entries.
        let inner_rows: Vec<Result<InnerRow, SolverError>> = (0..inner)
            .into_par_iter()
            .map(|i| {
                let xi = level.positions[i];
                let (mut d, mut o) = ([0.0; 3], [[0.0; 3]; 4]);
                for (f, of) in o.iter_mut().enumerate() {
                    let j = level.neighbors[i][f] as usize;
                    let xj = level.positions[j];
                    let (area, n, p0) = face(i, f);
                    if !above(area, 0.0) {
                        return Err(degenerate(i, format!("face {f} has zero area")));
                    }
                    match scheme {
                        Scheme::Fv => {
                            let dij = n.dot(xj - xi).abs();
                            if !above(dij, 1e-12 * level.spacing.max(1e-9)) {
                                return Err(degenerate(
                                    i,
                                    format!("neighbour {j} lies in the plane of face {f}"),
                                ));
                            }
                            let di = n.dot(xi - p0).abs();
                            let dj = n.dot(xj - p0).abs();
                            for c in 0..3 {
                                // Harmonic kappa across the face (DESIGN section 2); the surface
                                // node carries no material of its own: the cell's kappa_k.
                                let k = if j < inner {
                                    (di + dj) / (di / kappa[i][c] + dj / kappa[j][c])
                                } else {
                                    kappa[i][c]
                                };
                                of[c] = area * k / (volumes[i] * dij);
                            }
                        }
                        Scheme::Paper => {
                            let d2 = xj.distance_squared(xi);
                            if !above(d2, 0.0) {
                                return Err(degenerate(
                                    i,
                                    format!("neighbour {j} coincides with the node"),
                                ));
                            }
                            // Eq. 5: weights 1/d_ij^2 with kappa at the neighbour.
                            for c in 0..3 {
                                of[c] = kappa[j][c] / d2;
                                d[c] += kappa[i][c] / d2;
                            }
                        }
                    }
                }
                for c in 0..3 {
                    if scheme == Scheme::Fv {
                        d[c] = o.iter().map(|r| r[c]).sum::<f64>();
                    }
                    d[c] += coeffs[i].sigma_a[c];
                }
                Ok((d, o))
            })
            .collect();
        for (i, row) in inner_rows.into_iter().enumerate() {
            let (d, o) = row?;
            diag[i] = d;
            off[i] = o;
            neighbors[i] = level.neighbors[i];
            row_scale[i] = volumes[i];
        }

        for (s, &(t, f)) in level.surface_faces.iter().enumerate() {
            let (k, node) = (t as usize, inner + s);
            let (xs, xk) = (level.positions[node], level.positions[k]);
            let (_, n, _) = face(k, f as usize);
            let (dsk, kap) = match scheme {
                Scheme::Fv => (n.dot(xs - xk).abs(), kappa[k]),
                // Eq. 6: Euclidean edge length, kappa sampled at the surface node.
                Scheme::Paper => (xs.distance(xk), kappa[node]),
            };
            if !above(dsk, 1e-12 * level.spacing.max(1e-9)) {
                return Err(degenerate(
                    node,
                    format!("surface node at distance {dsk} from its cell's centroid"),
                ));
            }
            for c in 0..3 {
                // Robin boundary, paper Eq. 6 divided by d_sk: (1 + 2 A kappa / d) phi_s - (2 A kappa / d) phi_k = 4q/(1 - F_dr).
                let g = 2.0 * a * kap[c] / dsk;
                diag[node][c] = 1.0 + g;
                off[node][0][c] = g;
            }
            neighbors[node][0] = t;
            row_scale[node] = areas[s] / (2.0 * a);
        }
        let mu = coeffs[..inner].iter().map(Coefficients::mu).collect();
        let op = Self {
            scheme,
            inner_count: inner,
            neighbors,
            diag,
            off,
            row_scale,
            q_gain: boundary.flux_gain,
            volumes,
            areas,
            mu,
            f_dr,
            a,
        };
        if op
            .diag
            .iter()
            .flatten()
            .chain(op.off.iter().flatten().flatten())
            .any(|v| !v.is_finite())
        {
            return Err(SolverError::NonFinite {
                what: "assembled operator coefficients".into(),
            });
        }
        Ok(op)
    }

    pub fn node_count(&self) -> usize {
        self.diag.len()
    }

    /// Right-hand side from surface irradiance `q` (by surface index).
    pub fn rhs(&self, q: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let mut b = vec![[0.0; 3]; self.node_count()];
        for (s, qs) in q.iter().enumerate() {
            b[self.inner_count + s] = qs.map(|v| self.q_gain * v);
        }
        b
    }

    /// `sum_k off_ik x_nbr(i,k)` for row i.
    #[inline]
    pub fn gather(&self, i: usize, x: &[[f64; 3]]) -> [f64; 3] {
        let mut acc = [0.0; 3];
        for (k, &j) in self.neighbors[i].iter().enumerate() {
            if j != NO_NODE {
                let xj = x[j as usize];
                for c in 0..3 {
                    acc[c] += self.off[i][k][c] * xj[c];
                }
            }
        }
        acc
    }

    /// `out = S A x` (the row-scaled operator, symmetric for `fv`).
    pub fn apply_scaled(&self, x: &[[f64; 3]], out: &mut [[f64; 3]]) {
        out.par_iter_mut().enumerate().for_each(|(i, o)| {
            let g = self.gather(i, x);
            let s = self.row_scale[i];
            *o = std::array::from_fn(|c| s * (self.diag[i][c] * x[i][c] - g[c]));
        });
    }

    /// One Jacobi sweep (paper Eqs. 8/9 for `paper`; DESIGN's update for `fv`): `out_i = (b_i +
    /// sum off x_j) / diag_i`. Returns, per channel, max |out - x| and max |out|.
    pub fn jacobi_sweep(
        &self,
        b: &[[f64; 3]],
        x: &[[f64; 3]],
        out: &mut [[f64; 3]],
    ) -> ([f64; 3], [f64; 3]) {
        out.par_iter_mut()
            .enumerate()
            .map(|(i, o)| {
                let g = self.gather(i, x);
                *o = std::array::from_fn(|c| (b[i][c] + g[c]) / self.diag[i][c]);
                let delta: [f64; 3] = std::array::from_fn(|c| (o[c] - x[i][c]).abs());
                (delta, o.map(f64::abs))
            })
            .reduce(
                || ([0.0; 3], [0.0; 3]),
                |(d1, m1), (d2, m2)| {
                    (
                        std::array::from_fn(|c| d1[c].max(d2[c])),
                        std::array::from_fn(|c| m1[c].max(m2[c])),
                    )
                },
            )
    }

    /// Relative residual per channel, ||S (b - A x)|| / ||S b|| (2-norms; absolute where b = 0).
    pub fn residual(&self, x: &[[f64; 3]], b: &[[f64; 3]]) -> [f64; 3] {
        let (r2, b2) = (0..self.node_count())
            .into_par_iter()
            .map(|i| {
                let g = self.gather(i, x);
                let s = self.row_scale[i];
                let r: [f64; 3] = std::array::from_fn(|c| {
                    let v = s * (b[i][c] - (self.diag[i][c] * x[i][c] - g[c]));
                    v * v
                });
                (r, b[i].map(|v| (s * v) * (s * v)))
            })
            .reduce(
                || ([0.0; 3], [0.0; 3]),
                |(a1, b1), (a2, b2)| {
                    (
                        std::array::from_fn(|c| a1[c] + a2[c]),
                        std::array::from_fn(|c| b1[c] + b2[c]),
                    )
                },
            );
        std::array::from_fn(|c| {
            if b2[c] > 0.0 {
                (r2[c] / b2[c]).sqrt()
            } else {
                r2[c].sqrt()
            }
        })
    }

    /// Largest relative asymmetry |S_i A_ij - S_j A_ji| / max of the two over all edges (0 for `fv`).
    pub fn symmetry_defect(&self) -> f64 {
        let mut worst: f64 = 0.0;
        for i in 0..self.node_count() {
            for (k, &j) in self.neighbors[i].iter().enumerate() {
                if j == NO_NODE {
                    continue;
                }
                let j = j as usize;
                let Some(back) = self.neighbors[j].iter().position(|&m| m as usize == i) else {
                    return f64::INFINITY;
                };
                for c in 0..3 {
                    let (u, v) = (
                        self.row_scale[i] * self.off[i][k][c],
                        self.row_scale[j] * self.off[j][back][c],
                    );
                    worst = worst.max((u - v).abs() / u.abs().max(v.abs()).max(f64::MIN_POSITIVE));
                }
            }
        }
        worst
    }
}

/// Structural checks of the data contract the operator relies on.
pub fn check_level(level: &GraphLevel) -> Result<(), SolverError> {
    let inner = level.inner_count();
    let nodes = level.node_count();
    let bad = |problem: String| SolverError::BadGraph {
        level: usize::MAX,
        problem,
    };
    if level.positions.len() != nodes
        || level.neighbors.len() != inner
        || level.surface_normals.len() != level.surface_count()
    {
        return Err(bad(format!(
            "array lengths disagree: {} positions, {} neighbour rows, {} normals for {} inner + {} surface nodes",
            level.positions.len(),
            level.neighbors.len(),
            level.surface_normals.len(),
            inner,
            level.surface_count()
        )));
    }
    if inner == 0 {
        return Err(bad("no inner nodes".into()));
    }
    for (i, nb) in level.neighbors.iter().enumerate() {
        if let Some(&j) = nb.iter().find(|&&j| j as usize >= nodes) {
            return Err(bad(format!(
                "inner node {i} has neighbour {j} (only {nodes} nodes)"
            )));
        }
    }
    for (s, &(t, f)) in level.surface_faces.iter().enumerate() {
        if t as usize >= inner
            || f >= 4
            || level.neighbors[t as usize][f as usize] as usize != inner + s
        {
            return Err(bad(format!(
                "surface node {s} is not linked to tetrahedron {t} face {f}"
            )));
        }
    }
    if let Some(p) = level.positions.iter().find(|p| !p.is_finite()) {
        return Err(bad(format!("node position {p} is not finite")));
    }
    if level.tets.vertices.iter().any(|v: &DVec3| !v.is_finite()) {
        return Err(bad("a tetrahedron vertex is not finite".into()));
    }
    if level
        .tets
        .tets
        .iter()
        .flatten()
        .any(|&v| v as usize >= level.tets.vertices.len())
    {
        return Err(bad("a tetrahedron refers to a missing vertex".into()));
    }
    Ok(())
}
