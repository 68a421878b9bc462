//! The texel arrays of one QuadGraph level (DESIGN section 4), built on the CPU from the f64
//! operator ([`LevelOperator`]) and uploaded as textures by [`super::GpuDiffusion`].
//!
//! One node = one texel at `packing.texels[node]`; padding texels point to themselves with weight 0
//! (how reductions recognise and skip them: no node is its own neighbour). Per texel:
//!
//! | texture | format | channels |
//! |---|---|---|
//! | `connectivity` | RGBA32UI | the 4 neighbours' linear texel indices `v * width + u` (one 32-bit index instead of a (u, v) pair: half the bytes of the paper's two textures, no 16-bit limit on the width) |
//! | `weight_r/g/b` | RGBA32F | per channel, the Jacobi weights `off_ik / diag_i` of the 4 neighbours (f64 on the CPU, then f32); a surface node has one neighbour (slot 0) and keeps its source gain `q_gain / diag_s` (`4/(1 - F_dr)` over the Robin diagonal, DESIGN's corrected Eq. 9) in slot 1 |
//! | `weight_geo` | RGBA32F | homogeneous material only, instead of `weight_r/g/b`: the geometric factors `off_ik / kappa` (`A_f / (V_i d_ij)` for fv, `1 / d_ij^2` for the paper scheme, `2 A / d_sk` on surface rows); the shader rebuilds the weights with kappa and mu from push constants |
//! | `links_lo/hi` | RGBA32UI | 8 linear texel indices into the coarser level (paper Eq. 10) |
//! | `link_weights_lo/hi` | RGBA16F | their Shepard weights (renormalized on the GPU) |
//! | `surface_position` | RGBA32F | rgb: surface node position (mm), a: 1 on surface nodes |
//! | `surface_normal` | RGBA16F | rgb: outward unit normal of surface nodes |
//!
//! Why three weight textures (heterogeneous) and no material textures: with a heterogeneous material, the `fv`
//! weights `A_f kappa_ij / (V_i d_ij)` use a harmonic kappa per channel, so they differ per channel;
//! folding material, geometry and the diagonal (with mu) into f64-computed weights keeps one
//! multiply-add per neighbour and channel and makes the GPU iteration the CPU reference's
//! `LevelOperator::jacobi_sweep` up to f32 rounding. Editing the material re-uploads these weights.
//!
//! ```
//! use glam::DVec3;
//! use translucent::material::{Material, MaterialField};
//! use translucent::solver::gpu::textures::LevelTexels;
//! use translucent::solver::operator::{LevelOperator, Scheme};
//! use translucent::{tet::TetMesh, GraphLevel};
//! let level = GraphLevel::from_tets(TetMesh::bcc_box(DVec3::ZERO, DVec3::splat(4.0), [3, 3, 3]), 1.0, |c, n| (c, n));
//! let op = LevelOperator::build(&level, &MaterialField::Homogeneous(Material::preset("marble")?), Scheme::Fv)?;
//! let t = LevelTexels::build(&level, &op, None, None)?;
//! let width = t.packing.width;
//! for (node, &[u, v]) in t.packing.texels.iter().enumerate() {
//!     let texel = (v * width + u) as usize;
//!     let surface = node >= level.inner_count();
//!     assert_eq!(surface, v < t.packing.surface_rows); // the node type is a row test
//!     let row_sum: f32 = (0..if surface { 1 } else { 4 }).map(|k| t.weights[0][texel][k]).sum();
//!     assert!(row_sum < 1.0); // Jacobi weights a_ik / a_ii of an M-matrix row
//!     if surface {
//!         assert!(t.weights[0][texel][1] > 0.0); // the source gain, Eq. 9
//!     }
//! }
//! // Padding texels point to themselves with weight 0.
//! let used: std::collections::HashSet<u32> = t.packing.texels.iter().map(|&[u, v]| v * width + u).collect();
//! for texel in (0..t.texel_count() as u32).filter(|x| !used.contains(x)) {
//!     assert_eq!(t.connectivity[texel as usize], [texel; 4]);
//!     assert!(t.weights.iter().all(|w| w[texel as usize] == [0.0; 4]));
//! }
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use half::f16;

use crate::quadgraph::graph::{GraphLevel, Packing, NO_NODE};
use crate::quadgraph::packing;
use crate::solver::operator::LevelOperator;
use crate::solver::SolverError;

/// One material everywhere: the GPU computes the weights from one RGBA32F of geometric factors and
/// these constants (`diffusion/graph_weights.glsl`), 32 bytes per texel less than three weight sets.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HomogeneousMaterial {
    pub kappa: [f64; 3],
    pub mu: [f64; 3],
}

/// Block size of the packing used when a level comes without one (test fixtures).
pub const FALLBACK_BLOCK: u32 = 32;

/// The CPU-side contents of one level's textures, row-major, `width * height` texels each.
#[derive(Clone, Debug)]
pub struct LevelTexels {
    pub packing: Packing,
    pub connectivity: Vec<[u32; 4]>,
    pub weights: [Vec<[f32; 4]>; 3],
    /// Homogeneous material only: the geometric factors `off_ik / kappa` (see [`HomogeneousMaterial`]).
    pub weight_geo: Option<Vec<[f32; 4]>>,
    pub links: [Vec<[u32; 4]>; 2],
    pub link_weights: [Vec<[f16; 4]>; 2],
    pub surface_position: Vec<[f32; 4]>,
    pub surface_normal: Vec<[f16; 4]>,
}

/// The level's packing, or a breadth-first one when the level was never packed.
pub fn packing_of(level: &GraphLevel) -> Packing {
    if level.packing.texels.len() == level.node_count() && level.packing.width > 0 {
        level.packing.clone()
    } else {
        packing::pack(level, FALLBACK_BLOCK, false)
    }
}

fn bad(problem: String) -> SolverError {
    SolverError::BadGraph {
        level: usize::MAX,
        problem,
    }
}

impl LevelTexels {
    /// Builds the texels of `level` from its operator; `coarse` is the coarser level's packing
    /// (for the Shepard links), `None` on the coarsest level.
    pub fn build(
        level: &GraphLevel,
        op: &LevelOperator,
        coarse: Option<&Packing>,
        homogeneous: Option<HomogeneousMaterial>,
    ) -> Result<Self, SolverError> {
        let packing = packing_of(level);
        let (w, h) = (packing.width as usize, packing.height as usize);
        let texels = w * h;
        if texels == 0 || packing.texels.len() != level.node_count() {
            return Err(bad(format!(
                "packing has {} texels for {} nodes",
                packing.texels.len(),
                level.node_count()
            )));
        }
        let linear: Vec<u32> = (0..level.node_count() as u32)
            .map(|n| packing.linear_index(n))
            .collect();
        if let Some(&t) = linear.iter().find(|&&t| t as usize >= texels) {
            return Err(bad(format!("texel {t} outside the {w}x{h} texture")));
        }
        let inner = level.inner_count();
        let surface_rows = packing.surface_rows as usize * w;
        let mut out = LevelTexels {
            connectivity: (0..texels as u32).map(|t| [t; 4]).collect(),
            weights: std::array::from_fn(|_| vec![[0.0; 4]; texels]),
            weight_geo: homogeneous.map(|_| vec![[0.0; 4]; texels]),
            links: std::array::from_fn(|_| vec![[0; 4]; texels]),
            link_weights: std::array::from_fn(|_| vec![[f16::ZERO; 4]; texels]),
            surface_position: vec![[0.0; 4]; texels],
            surface_normal: vec![[f16::ZERO; 4]; texels],
            packing,
        };
        for node in 0..level.node_count() {
            let t = linear[node] as usize;
            let is_surface = node >= inner;
            // The node type is a row test on the GPU (DESIGN section 3 step 10).
            if is_surface != (t < surface_rows) {
                return Err(bad(format!(
                    "node {node} ({}) is packed in the wrong rows",
                    if is_surface { "surface" } else { "inner" }
                )));
            }
            let diag = op.diag[node];
            for (k, &j) in op.neighbors[node].iter().enumerate() {
                if j == NO_NODE {
                    continue;
                }
                out.connectivity[t][k] = linear[j as usize];
                for (c, weights) in out.weights.iter_mut().enumerate() {
                    weights[t][k] = (op.off[node][k][c] / diag[c]) as f32;
                }
            }
            if let (Some(m), Some(geo)) = (homogeneous, out.weight_geo.as_mut()) {
                // g_ik = off_ik / kappa; the shader rebuilds a_ii from g, kappa and mu: check here
                // that this reproduces the f64 operator in every channel.
                let mut g = [0.0f64; 4];
                for (k, gk) in g.iter_mut().enumerate() {
                    *gk = op.off[node][k][0] / m.kappa[0];
                }
                for (c, &d) in diag.iter().enumerate() {
                    let rebuilt = if is_surface {
                        1.0 + m.kappa[c] * g[0]
                    } else {
                        m.kappa[c] * g.iter().sum::<f64>() + m.mu[c]
                    };
                    let off_ok = (0..4).all(|k| {
                        (m.kappa[c] * g[k] - op.off[node][k][c]).abs()
                            <= 1e-9 * op.off[node][k][c].abs()
                    });
                    if !off_ok || (rebuilt - d).abs() > 1e-9 * d.abs() {
                        return Err(bad(format!(
                            "node {node}: the operator is not that of the homogeneous material"
                        )));
                    }
                }
                geo[t] = g.map(|v| v as f32);
            }
            if is_surface {
                let s = node - inner;
                if op.neighbors[node][1..].iter().any(|&j| j != NO_NODE) {
                    return Err(bad(format!("surface node {s} has more than one neighbour")));
                }
                // Surface rows use slot 0 only; slot 1 carries the source gain (Eq. 9).
                for (c, weights) in out.weights.iter_mut().enumerate() {
                    weights[t][1] = (op.q_gain / diag[c]) as f32;
                }
                let p = level.positions[node];
                let n = level.surface_normals[s];
                out.surface_position[t] = [p.x as f32, p.y as f32, p.z as f32, 1.0];
                out.surface_normal[t] = [n.x, n.y, n.z, 0.0].map(f16::from_f64);
            }
        }
        if let (Some(coarse), Some(links)) = (coarse, level.from_coarser.as_ref()) {
            if links.links.len() != level.node_count() {
                return Err(bad(format!(
                    "{} Shepard links for {} nodes",
                    links.links.len(),
                    level.node_count()
                )));
            }
            for (node, (l, wt)) in links.links.iter().zip(&links.weights).enumerate() {
                let t = linear[node] as usize;
                for (slot, (&c, &wc)) in l.iter().zip(wt).enumerate() {
                    if c == NO_NODE || wc == 0.0 {
                        continue;
                    }
                    let ct = coarse.linear_index(c);
                    if ct == NO_NODE || !wc.is_finite() || wc < 0.0 {
                        return Err(bad(format!(
                            "Shepard link {slot} of node {node} ({c}, weight {wc}) is invalid"
                        )));
                    }
                    out.links[slot / 4][t][slot % 4] = ct;
                    out.link_weights[slot / 4][t][slot % 4] = f16::from_f64(wc);
                }
            }
        }
        let finite = out
            .weights
            .iter()
            .flatten()
            .chain(out.weight_geo.iter().flatten())
            .flatten()
            .all(|v| v.is_finite());
        if !finite {
            return Err(SolverError::NonFinite {
                what: "GPU weights (an f64 coefficient overflows f32)".into(),
            });
        }
        Ok(out)
    }

    pub fn texel_count(&self) -> usize {
        self.packing.width as usize * self.packing.height as usize
    }
}
