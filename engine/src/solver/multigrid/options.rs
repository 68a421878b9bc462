//! The multigrid's options that are not cycle parameters: how the coarse operators are made and
//! stored, how the prolongation's links and the per-node vectors are stored (with the 8-bit link
//! code's quantization), the prolongation's weights and the warm start.

use crate::quadgraph::graph::{ShepardLinks, NO_NODE};
use crate::solver::SolverError;

/// A relative residual (against the right-hand side) above this means the cycles diverge: the
/// solve stops there instead of running to `max_cycles` (a cold start begins at <= 1).
pub const DIVERGED: f64 = 1e3;

/// The most coarse-grid corrections of a warm start (`MultigridParams::warm_corrections`;
/// wave 13, benches/RESULTS.md "One CG iteration per warm frame": after the local relaxation,
/// the finest residual restricted, one V-cycle on the levels below, prolonged and added, the
/// local relaxation again between two of them; the smooth remainder the extrapolation misses,
/// which the local sweeps do not reach).
pub const MAX_WARM_CORRECTIONS: u32 = 4;

/// `warm_corrections` within [`MAX_WARM_CORRECTIONS`].
pub(super) fn check_warm_corrections(n: u32) -> Result<(), SolverError> {
    if n > MAX_WARM_CORRECTIONS {
        return Err(SolverError::BadParameter {
            name: "warm corrections",
            problem: format!("{n} (at most {MAX_WARM_CORRECTIONS})"),
        });
    }
    Ok(())
}

/// How the coarse levels' operators are made.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub enum CoarseOperator {
    /// Each level's own `fv` discretization (today's coarse graphs and textures). Diverges on a
    /// 1e4 material contrast (measured): the coarse problem is not the fine one restricted.
    Rediscretized,
    /// `K_(l-1) = P_l^T K_l P_l` from the finest level down (the default): ~130 entries per
    /// row on the second level of the default scene, against 4-5 re-discretized.
    #[default]
    Galerkin,
}

impl std::str::FromStr for CoarseOperator {
    type Err = SolverError;
    fn from_str(s: &str) -> Result<Self, SolverError> {
        match s {
            "galerkin" => Ok(Self::Galerkin),
            "rediscretized" => Ok(Self::Rediscretized),
            _ => Err(SolverError::BadParameter {
                name: "coarse_operator",
                problem: format!("'{s}' (expected galerkin or rediscretized)"),
            }),
        }
    }
}

/// How the GPU stores the off-diagonal entries of the coarse levels' operators (the finest
/// level's stay f32: they define the solution; the coarse levels only precondition it).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub enum OperatorStorage {
    /// RGB f32 per entry (16 bytes with the unused fourth lane).
    #[default]
    F32,
    /// RGB fp16 per entry (8 bytes) relative to a per-row scale kept in the f32 diagonal's fourth
    /// lane; the rounding lumped onto the f32 diagonal so every row still sums as before.
    F16,
}

impl std::str::FromStr for OperatorStorage {
    type Err = SolverError;
    fn from_str(s: &str) -> Result<Self, SolverError> {
        match s {
            "f32" => Ok(Self::F32),
            "f16" => Ok(Self::F16),
            _ => Err(SolverError::BadParameter {
                name: "coarse_storage",
                problem: format!("'{s}' (expected f32 or f16)"),
            }),
        }
    }
}

/// How the GPU stores the prolongation's links (and so the restriction, which reads them).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub enum LinkStorage {
    /// A u32 coarse node and an f32 weight per link (8 bytes).
    #[default]
    F32,
    /// One u32 per link, `coarse node << 8 | code` (weight `(code - 85) / 85`, from -1 to 2: the
    /// mixed interpolation's smoothed weights reach -0.95 and 1.96) (4 bytes), as the cascade's
    /// packed links; the hierarchy's weights are quantized to the same 1/85 steps (each node's
    /// steps summing to its rounded sum, so constants are still prolongated exactly) before the
    /// Galerkin product, so the coarse operators are those of the prolongation the GPU applies.
    Packed,
}

impl std::str::FromStr for LinkStorage {
    type Err = SolverError;
    fn from_str(s: &str) -> Result<Self, SolverError> {
        match s {
            "f32" => Ok(Self::F32),
            "packed" => Ok(Self::Packed),
            _ => Err(SolverError::BadParameter {
                name: "link_storage",
                problem: format!("'{s}' (expected f32 or packed)"),
            }),
        }
    }
}

/// Where the GPU multigrid's finest level reads its operator `K = S A` from (the residual and the
/// CG's `K z`; the coarse levels keep their compressed rows).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub enum FinestOperator {
    /// Its own compressed rows (`row_start`, `cols`, `values`: ~62 bytes per finest node).
    #[default]
    Csr,
    /// Matrix-free from the cascade's graph textures (connectivity and weights, which the
    /// Jacobi sweeps read already) and the diagonal: `(K x)_i = K_ii (x_i - sum_k w_ik x_nbr)`
    /// (`shaders-glsl/multigrid/graph_operator.glsl`); one u32 per texel maps the neighbours'
    /// texels back to nodes.
    Graph,
}

impl std::str::FromStr for FinestOperator {
    type Err = SolverError;
    fn from_str(s: &str) -> Result<Self, SolverError> {
        match s {
            "csr" => Ok(Self::Csr),
            "graph" => Ok(Self::Graph),
            _ => Err(SolverError::BadParameter {
                name: "finest_operator",
                problem: format!("'{s}' (expected csr or graph)"),
            }),
        }
    }
}

/// How the GPU stores the per-node vectors that tolerate fp16: the smoother's update `d` (every
/// level) and the CG's last preconditioned residual `z_old` (read only by the flexible CG's
/// `R . z_old`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub enum UpdateStorage {
    /// As the other vectors ([`VectorStorage`]).
    #[default]
    F32,
    /// RGB fp16 in two u32 per node (8 bytes).
    F16,
}

impl std::str::FromStr for UpdateStorage {
    type Err = SolverError;
    fn from_str(s: &str) -> Result<Self, SolverError> {
        match s {
            "f32" => Ok(Self::F32),
            "f16" => Ok(Self::F16),
            _ => Err(SolverError::BadParameter {
                name: "update_storage",
                problem: format!("'{s}' (expected f32 or f16)"),
            }),
        }
    }
}

/// How the GPU stores its per-node RGB vectors (x, f, r, d, the CG's, `partner_value`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub enum VectorStorage {
    /// Three floats per node (12 bytes).
    #[default]
    Rgb,
    /// Four floats per node, the fourth unused (16 bytes).
    Rgba,
}

impl VectorStorage {
    /// Floats per node (`VECTOR_STRIDE` in `shaders-glsl/multigrid/common.glsl`).
    pub fn floats(self) -> usize {
        match self {
            Self::Rgb => 3,
            Self::Rgba => 4,
        }
    }
}

impl std::str::FromStr for VectorStorage {
    type Err = SolverError;
    fn from_str(s: &str) -> Result<Self, SolverError> {
        match s {
            "rgb" => Ok(Self::Rgb),
            "rgba" => Ok(Self::Rgba),
            _ => Err(SolverError::BadParameter {
                name: "vector_storage",
                problem: format!("'{s}' (expected rgb or rgba)"),
            }),
        }
    }
}

/// Steps per unit of a packed link weight: an 8-bit code `c` is the weight
/// `(c - LINK_WEIGHT_ZERO) / LINK_WEIGHT_STEPS`, so weights from -1 to 2 pack (the mixed
/// interpolation's pattern-smoothed weights reach -0.95 and 1.96 on the default scene, spot and
/// nefertiti) and a node's sum stays on whole steps.
pub const LINK_WEIGHT_STEPS: u32 = 85;
/// The code of a zero link weight (see [`LINK_WEIGHT_STEPS`]).
pub const LINK_WEIGHT_ZERO: u32 = 85;

/// `links` with every node's weights rounded to multiples of `1 / LINK_WEIGHT_STEPS`, the steps
/// of a node summing to the rounded sum of its weights (largest remainders first); an error for a
/// weight the 8-bit code cannot hold (below `-LINK_WEIGHT_ZERO / LINK_WEIGHT_STEPS` or above
/// `(255 - LINK_WEIGHT_ZERO) / LINK_WEIGHT_STEPS`).
pub fn quantized_links(links: &ShepardLinks) -> Result<ShepardLinks, SolverError> {
    let steps = f64::from(LINK_WEIGHT_STEPS);
    let lowest = -f64::from(LINK_WEIGHT_ZERO);
    let highest = f64::from(255 - LINK_WEIGHT_ZERO);
    let mut weights = Vec::with_capacity(links.weights.len());
    for (node, (l, w)) in links.links.iter().zip(&links.weights).enumerate() {
        let mut q = [0.0f64; 8];
        let mut remainder = [0.0f64; 8];
        let mut sum = 0.0;
        for k in 0..8 {
            if l[k] == NO_NODE {
                continue;
            }
            let scaled = w[k] * steps;
            if !(lowest - 1e-9..=highest - 1.0 + 1e-9).contains(&scaled) {
                return Err(SolverError::BadParameter {
                    name: "link_storage",
                    problem: format!(
                        "node {node}'s link weight {} is outside [{:.3}, {:.3}]: packed links \
                         do not hold it (use link_storage f32)",
                        w[k],
                        lowest / steps,
                        (highest - 1.0) / steps
                    ),
                });
            }
            q[k] = scaled.floor();
            remainder[k] = scaled - q[k];
            sum += w[k];
        }
        let target = (sum * steps).round();
        let mut order: Vec<usize> = (0..8).filter(|&k| l[k] != NO_NODE).collect();
        order.sort_by(|&a, &b| remainder[b].total_cmp(&remainder[a]));
        let mut missing = target - q.iter().sum::<f64>();
        for &k in order.iter().cycle().take(8 * order.len()) {
            if missing < 0.5 {
                break;
            }
            if q[k] < highest {
                q[k] += 1.0;
                missing -= 1.0;
            }
        }
        weights.push(q.map(|v| v / steps));
    }
    Ok(ShepardLinks {
        links: links.links.clone(),
        weights,
    })
}

/// The weights of the prolongation's links.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub enum Interpolation {
    /// The bake's Shepard weights (paper Eq. 10): exact for constants only.
    #[default]
    Shepard,
    /// The same links, weights made exact for linear functions (in 3D for inner nodes, in the
    /// surface's tangent plane for surface nodes): the smallest change of the Shepard weights, in
    /// their own weighting, that reproduces `x` (moving least squares); Shepard where the links
    /// cannot (coplanar or collinear coarse nodes).
    Linear,
    /// Links made here, not the bake's: inner nodes take the 8 nearest coarse nodes of either
    /// kind (a fine cell under the surface is nearer the coarse surface nodes than the coarse
    /// cells), linear weights as [`Self::Linear`].
    Mixed,
}

/// Where a warm-started GPU solve starts (`--multigrid-cycle warm=last|linear|quadratic`): the
/// last solution, or a polynomial in time through the last two or three solutions (a light moving
/// steadily changes the solution smoothly: the last solution's error is first order in the step,
/// the linear extrapolation's second, the quadratic's third). Each order keeps one more finest
/// vector (12 bytes per finest node, RGB); with fewer solutions since the last cold start (the first
/// warm frames) the order drops to what there is. Measured in benches/RESULTS.md, "Warm start
/// from extrapolated solutions (wave 7)".
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub enum WarmStart {
    /// x_{n-1}.
    #[default]
    Last,
    /// 2 x_{n-1} - x_{n-2}.
    Linear,
    /// 3 x_{n-1} - 3 x_{n-2} + x_{n-3}.
    Quadratic,
}

impl WarmStart {
    /// Earlier solutions kept besides the last (the history vectors).
    pub fn history(self) -> u32 {
        match self {
            Self::Last => 0,
            Self::Linear => 1,
            Self::Quadratic => 2,
        }
    }

    /// The extrapolation's coefficients of x_{n-1}, x_{n-2}, x_{n-3} (Newton's backward
    /// differences) for `order` (0: the last solution).
    pub fn coefficients(order: u32) -> [f32; 3] {
        match order {
            0 => [1.0, 0.0, 0.0],
            1 => [2.0, -1.0, 0.0],
            _ => [3.0, -3.0, 1.0],
        }
    }
}

/// Local relaxation of a warm start (GPU only; `--multigrid-cycle local=RINGSxSWEEPS`, Rüde's
/// fully adaptive multigrid on the finest level): a light turning by a few degrees moves shadow
/// edges by whole shadow-map texels, so the extrapolated start's residual sits on a few dozen
/// surface nodes (93% of its square on 10 nodes of the default scene, benches/RESULTS.md "Local
/// relaxation of the warm start (wave 8)"). One pass marks the finest nodes whose residual alone
/// exceeds the tolerance (`|r_i| > tol ||f||` in any channel), `rings` passes over the marked list
/// add their neighbours, then `sweeps` damped block-Jacobi sweeps run on the listed nodes only
/// (node updates counted: one per listed node per sweep and per ring, plus the marking pass).
/// Only after an extrapolated start (`WarmStart` order 1 or 2): the last solution's residual is
/// the smooth change, spread over the level, which local sweeps do not remove.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct LocalRelaxation {
    /// Neighbour rings added around the marked nodes.
    pub rings: u32,
    /// Jacobi sweeps over the marked nodes and their rings.
    pub sweeps: u32,
}

impl LocalRelaxation {
    /// The most rings or sweeps a spec may ask for (each is a pass over the list).
    pub const MAX_PASSES: u32 = 64;
}

impl std::str::FromStr for LocalRelaxation {
    type Err = SolverError;

    /// `RINGSxSWEEPS`, e.g. `4x16`.
    fn from_str(s: &str) -> Result<Self, SolverError> {
        let bad = || SolverError::BadParameter {
            name: "local_relaxation",
            problem: format!(
                "'{s}' (expected RINGSxSWEEPS, each 0-{}, sweeps at least 1)",
                Self::MAX_PASSES
            ),
        };
        let (rings, sweeps) = s.split_once('x').ok_or_else(bad)?;
        let rings: u32 = rings.trim().parse().map_err(|_| bad())?;
        let sweeps: u32 = sweeps.trim().parse().map_err(|_| bad())?;
        if rings > Self::MAX_PASSES || sweeps == 0 || sweeps > Self::MAX_PASSES {
            return Err(bad());
        }
        Ok(Self { rings, sweeps })
    }
}

impl std::str::FromStr for WarmStart {
    type Err = SolverError;

    fn from_str(s: &str) -> Result<Self, SolverError> {
        match s {
            "last" => Ok(Self::Last),
            "linear" => Ok(Self::Linear),
            "quadratic" => Ok(Self::Quadratic),
            _ => Err(SolverError::BadParameter {
                name: "warm_start",
                problem: format!("'{s}' (expected last, linear or quadratic)"),
            }),
        }
    }
}
