//! The texel arrays of one QuadGraph level (DESIGN section 4), built on the CPU from the f64
//! operator ([`LevelOperator`]) and uploaded as textures by [`super::GpuDiffusion`].
//!
//! One node = one texel at `packing.texels[node]`; padding texels point to themselves with weight 0
//! (how reductions recognise and skip them: no node is its own neighbour). Per texel:
//!
//! | texture | format | channels |
//! |---|---|---|
//! | `connectivity` | RGBA32UI | the 4 neighbours' linear texel indices `v * width + u` (one 32-bit index instead of a (u, v) pair: half the bytes of the paper's two textures, no 16-bit limit on the width) |
//! | `weight_geo` | RGBA32F | per slot the geometric factor `g_ik` (`A_f / (V_i d_ij)` for fv, `1 / d_ij^2` for the paper scheme, `1 / d_sk` in slot 0 of surface rows): the material-free half of the weights, recomputed on the GPU by a deformation |
//! | `weight_frac` | RGBA32F | heterogeneous or deformed only, fv: per slot `t_ij = delta_i / (delta_i + delta_j)` (1 towards a surface node), which turns the two kappas into the harmonic face kappa |
//! | `kappa`, `mu` | RGBA32F | heterogeneous only ([`MaterialTexels`]): per node kappa and mu (rgb) |
//! | `weight_r/g/b` | RGBA32F | heterogeneous with [`super::HeterogeneousWeights::Stored`] only: per channel, the Jacobi weights `a_ik / a_ii` of the 4 neighbours, derived on the GPU from the rows above (`edit/derive_weights.comp`); a surface node has one neighbour (slot 0) and keeps its source gain `q_gain / a_ss` (`4/(1 - F_dr)` over the Robin diagonal, DESIGN's corrected Eq. 9) in slot 1 |
//! | `links_lo/hi` | RGBA32UI | 8 Shepard links into the coarser level (paper Eq. 10), each packed in one u32 ([`pack_link`]): the coarse linear texel index << 8 and the weight in 1/255 (renormalized on the GPU); the coarsest level has none |
//! | `q` | RGBA16F | surface rows only: the gather's irradiance term (pre-scaled by the exposure) |
//! | `surface_position` | RGBA32F | surface rows only; rgb: surface node position (mm), a: 1 on surface nodes |
//! | `surface_normal` | RGBA16F | surface rows only; rgb: outward unit normal of surface nodes, w: their mean curvature H (1/mm) |
//! | `surface_anisotropy` | RGBA16F | surface rows only; rgb: the curvature's anisotropy e1 sqrt((k1 - k2) / 2) (`solver::transport::SurfaceCurvature`, mm^-1/2), the upstream beam's curvature along its direction |
//!
//! A heterogeneous material's weights are, by default, derived in every sweep from the fractions,
//! kappa and mu ([`super::HeterogeneousWeights::Derived`], `diffusion/graph_weights.glsl`): 8
//! texel reads per node and sweep instead of 3, 48 bytes per texel less; measured not slower on
//! lavapipe (benches/RESULTS.md, "Bytes per node (wave 5)"). Either way a material edit or a
//! deformation costs no f64 re-bake and no upload of weights. A homogeneous material reads
//! `weight_geo` only, with kappa and mu in push constants.
//! kappa and mu are fp32, not the paper's fp16: kappa = 1/(3 sigma_t') of a dense medium (3e-5 mm
//! at sigma_t' = 1e4/mm) is below fp16's normal range (6.1e-5).
//!
//! ```
//! use glam::DVec3;
//! use translucent::material::{Material, MaterialField};
//! use translucent::solver::gpu::textures::LevelTexels;
//! use translucent::solver::operator::{LevelOperator, Scheme};
//! use translucent::{tet::TetMesh, GraphLevel};
//! let level = GraphLevel::from_tets(TetMesh::bcc_box(DVec3::ZERO, DVec3::splat(4.0), [3, 3, 3]), 1.0, |c, n| (c, n));
//! let marble = Material::preset("marble")?;
//! let op = LevelOperator::build(&level, &MaterialField::Homogeneous(marble.clone()), Scheme::Fv)?;
//! let t = LevelTexels::build(&level, Scheme::Fv, None)?;
//! let kappa = marble.coefficients().kappa()[0];
//! let width = t.packing.width;
//! for (node, &[u, v]) in t.packing.texels.iter().enumerate() {
//!     let texel = (v * width + u) as usize;
//!     let surface = node >= level.inner_count();
//!     assert_eq!(surface, v < t.packing.surface_rows); // the node type is a row test
//!     // The geometric factors times the material give the f64 operator back.
//!     let scale = if surface { 2.0 * op.a * kappa } else { kappa };
//!     for k in 0..if surface { 1 } else { 4 } {
//!         let off = op.off[node][k][0];
//!         assert!((scale * f64::from(t.geo[texel][k]) - off).abs() <= 1e-6 * off);
//!     }
//! }
//! // Padding texels point to themselves with weight 0.
//! let used: std::collections::HashSet<u32> = t.packing.texels.iter().map(|&[u, v]| v * width + u).collect();
//! for texel in (0..t.texel_count() as u32).filter(|x| !used.contains(x)) {
//!     assert_eq!(t.connectivity[texel as usize], [texel; 4]);
//!     assert_eq!(t.geo[texel as usize], [0.0; 4]);
//! }
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use glam::DVec3;
use half::f16;

use crate::material::{check_pair, MaterialField};
use crate::quadgraph::graph::{GraphLevel, Packing, NO_NODE};
use crate::quadgraph::packing;
use crate::solver::operator::Scheme;
use crate::solver::SolverError;

/// One material everywhere: the GPU computes the weights from `weight_geo` and these constants
/// (`diffusion/graph_weights.glsl`, specialization constant `HOMOGENEOUS`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HomogeneousMaterial {
    pub kappa: [f64; 3],
    pub mu: [f64; 3],
}

/// Block size of the packing used when a level comes without one (test fixtures).
pub const FALLBACK_BLOCK: u32 = 32;

/// The CPU-side contents of one level's geometry and graph textures, row-major, `width * height`
/// texels each (material-free: see [`MaterialTexels`]).
#[derive(Clone, Debug)]
pub struct LevelTexels {
    pub packing: Packing,
    pub connectivity: Vec<[u32; 4]>,
    /// Geometric factors `g_ik` (module table).
    pub geo: Vec<[f32; 4]>,
    /// fv harmonic-mean fractions `t_ik` (module table; 0 for the paper scheme).
    pub frac: Vec<[f32; 4]>,
    /// Packed Shepard links ([`pack_link`]), all 0 on the coarsest level.
    pub links: [Vec<[u32; 4]>; 2],
    pub surface_position: Vec<[f32; 4]>,
    pub surface_normal: Vec<[f16; 4]>,
    pub surface_anisotropy: Vec<[f16; 4]>,
}

/// Per-node kappa and mu of a heterogeneous material, in the level's texel layout (rgb; padding 0).
#[derive(Clone, Debug)]
pub struct MaterialTexels {
    pub kappa: Vec<[f32; 4]>,
    pub mu: Vec<[f32; 4]>,
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

fn degenerate(node: usize, problem: String) -> SolverError {
    SolverError::DegenerateGeometry {
        level: usize::MAX,
        node,
        problem,
    }
}

/// `v > min`, false for NaN.
fn above(v: f64, min: f64) -> bool {
    v.is_finite() && v > min
}

/// Per node, the geometric factors and the fv fractions of its 4 slots.
pub type NodeFactors = ([f64; 4], [f64; 4]);

/// The geometric factors and fv fractions of every node of `level` (node order), in f64: the
/// material-free part of `LevelOperator::build`'s coefficients, with the same degeneracy checks.
pub fn geometric_factors(
    level: &GraphLevel,
    scheme: Scheme,
) -> Result<Vec<NodeFactors>, SolverError> {
    let inner = level.inner_count();
    let face = |t: usize, f: usize| {
        let [p0, p1, p2] = level.face_vertices(t, f);
        let n2 = (p1 - p0).cross(p2 - p0);
        (0.5 * n2.length(), n2.normalize_or_zero(), p0)
    };
    let min_d = 1e-12 * level.spacing.max(1e-9);
    let mut out = vec![([0.0; 4], [0.0; 4]); level.node_count()];
    for (i, row) in out.iter_mut().enumerate().take(inner) {
        let volume = crate::tet::structured::signed_volume(&level.tets, i);
        if !above(volume, 0.0) {
            return Err(degenerate(
                i,
                format!("tetrahedron volume {volume} (must be > 0)"),
            ));
        }
        let xi = level.positions[i];
        for f in 0..4 {
            let j = level.neighbors[i][f] as usize;
            let xj: DVec3 = level.positions[j];
            let (area, n, p0) = face(i, f);
            if !above(area, 0.0) {
                return Err(degenerate(i, format!("face {f} has zero area")));
            }
            match scheme {
                Scheme::Fv => {
                    let dij = n.dot(xj - xi).abs();
                    if !above(dij, min_d) {
                        return Err(degenerate(
                            i,
                            format!("neighbour {j} lies in the plane of face {f}"),
                        ));
                    }
                    let (di, dj) = (n.dot(xi - p0).abs(), n.dot(xj - p0).abs());
                    row.0[f] = area / (volume * dij);
                    row.1[f] = if j < inner { di / (di + dj) } else { 1.0 };
                }
                Scheme::Paper => {
                    let d2 = xj.distance_squared(xi);
                    if !above(d2, 0.0) {
                        return Err(degenerate(
                            i,
                            format!("neighbour {j} coincides with the node"),
                        ));
                    }
                    row.0[f] = 1.0 / d2;
                }
            }
        }
    }
    for (s, &(t, f)) in level.surface_faces.iter().enumerate() {
        let (k, node) = (t as usize, inner + s);
        let (xs, xk) = (level.positions[node], level.positions[k]);
        let (_, n, _) = face(k, f as usize);
        let dsk = match scheme {
            Scheme::Fv => n.dot(xs - xk).abs(),
            Scheme::Paper => xs.distance(xk),
        };
        if !above(dsk, min_d) {
            return Err(degenerate(
                node,
                format!("surface node at distance {dsk} from its cell's centroid"),
            ));
        }
        out[node].0[0] = 1.0 / dsk;
    }
    Ok(out)
}

/// Largest coarse texel index a packed link holds (24 bits).
pub const MAX_LINK_TEXEL: u32 = (1 << 24) - 1;

/// One Shepard link as the GPU reads it (`shaders-glsl/shepard/links.glsl`): `texel << 8 | round(255
/// weight)`, `weight` in [0, 1] (normalized over the node's links). `None` when the texel needs
/// more than 24 bits. A weight rounding to 0 drops the link (the reader renormalizes).
///
/// ```
/// use translucent::solver::gpu::textures::{pack_link, unpack_link};
/// let link = pack_link(1234, 0.5).unwrap();
/// assert_eq!(unpack_link(link), (1234, 128.0 / 255.0)); // 8 bits: within 1/510
/// assert!(pack_link(1 << 24, 1.0).is_none());
/// ```
pub fn pack_link(texel: u32, weight: f64) -> Option<u32> {
    (texel <= MAX_LINK_TEXEL).then(|| texel << 8 | (weight.clamp(0.0, 1.0) * 255.0).round() as u32)
}

/// The (texel, weight) of a packed link ([`pack_link`]).
pub fn unpack_link(link: u32) -> (u32, f32) {
    (link >> 8, (link & 255) as f32 / 255.0)
}

impl LevelTexels {
    /// Builds the texels of `level`; `coarse` is the coarser level's packing (for the Shepard
    /// links), `None` on the coarsest level.
    pub fn build(
        level: &GraphLevel,
        scheme: Scheme,
        coarse: Option<&Packing>,
    ) -> Result<Self, SolverError> {
        crate::solver::operator::check_level(level)?;
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
        let factors = geometric_factors(level, scheme)?;
        let inner = level.inner_count();
        let surface_rows = packing.surface_rows as usize * w;
        let mut out = LevelTexels {
            connectivity: (0..texels as u32).map(|t| [t; 4]).collect(),
            geo: vec![[0.0; 4]; texels],
            frac: vec![[0.0; 4]; texels],
            links: std::array::from_fn(|_| vec![[0; 4]; texels]),
            surface_position: vec![[0.0; 4]; texels],
            surface_normal: vec![[f16::ZERO; 4]; texels],
            surface_anisotropy: vec![[f16::ZERO; 4]; texels],
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
            let (g, fr) = factors[node];
            out.geo[t] = g.map(|v| v as f32);
            out.frac[t] = fr.map(|v| v as f32);
            if is_surface {
                let s = node - inner;
                let (k, _) = level.surface_faces[s];
                out.connectivity[t][0] = linear[k as usize];
                let p = level.positions[node];
                let n = level.surface_normals[s];
                out.surface_position[t] = [p.x as f32, p.y as f32, p.z as f32, 1.0];
                out.surface_normal[t] = [n.x, n.y, n.z, 0.0].map(f16::from_f64);
            } else {
                for (k, &j) in level.neighbors[node].iter().enumerate() {
                    if j != NO_NODE {
                        out.connectivity[t][k] = linear[j as usize];
                    }
                }
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
                // Normalized before the 8-bit rounding, so the largest weight keeps 1/255 steps.
                let sum: f64 = wt.iter().filter(|w| w.is_finite() && **w > 0.0).sum();
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
                    out.links[slot / 4][t][slot % 4] =
                        pack_link(ct, wc / sum).ok_or_else(|| {
                            bad(format!(
                            "coarse texel {ct} of node {node} does not fit a packed link (< 2^24)"
                        ))
                        })?;
                }
            }
        }
        if !out.geo.iter().flatten().all(|v| v.is_finite()) {
            return Err(SolverError::NonFinite {
                what: "GPU geometric factors (an f64 factor overflows f32)".into(),
            });
        }
        Ok(out)
    }

    pub fn texel_count(&self) -> usize {
        self.packing.width as usize * self.packing.height as usize
    }
}

impl MaterialTexels {
    /// Samples `field` at every node of `level` (rest positions) into `packing`'s layout. Invalid
    /// coefficients are a typed error naming the node; values that overflow f32 too.
    pub fn build(
        level: &GraphLevel,
        packing: &Packing,
        field: &MaterialField,
    ) -> Result<Self, SolverError> {
        let texels = packing.width as usize * packing.height as usize;
        let mut out = MaterialTexels {
            kappa: vec![[0.0; 4]; texels],
            mu: vec![[0.0; 4]; texels],
        };
        for (node, &p) in level.positions.iter().enumerate() {
            let c = field.sample(p);
            check_pair(c.sigma_s, c.sigma_a).map_err(|source| SolverError::BadMaterialAt {
                node,
                position: p,
                source,
            })?;
            let t = packing.linear_index(node as u32) as usize;
            if t >= texels {
                return Err(bad(format!("node {node} outside the level's texture")));
            }
            let (k, m) = (c.kappa_with(field.diffusion()), c.mu());
            out.kappa[t] = [k[0] as f32, k[1] as f32, k[2] as f32, 0.0];
            out.mu[t] = [m[0] as f32, m[1] as f32, m[2] as f32, 0.0];
            let ok = |v: &[f32; 4]| v.iter().all(|x| x.is_finite());
            if !(ok(&out.kappa[t]) && ok(&out.mu[t]) && out.kappa[t][..3].iter().all(|&x| x > 0.0))
            {
                return Err(SolverError::NonFinite {
                    what: format!("material at node {node} ({p}) in f32"),
                });
            }
        }
        Ok(out)
    }
}
