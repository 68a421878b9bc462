//! Multigrid cycles on the GPU (DESIGN section 5.1): the schedule `--schedule multigrid` of the
//! GPU solve, operation for operation the f64 [`Hierarchy`] of `solver::multigrid` in f32.
//!
//! Built on the CPU at creation and on every material change ([`GpuDiffusion::set_material`]):
//! the [`Hierarchy`] (Galerkin coarse operators `P^T K P`, Lanczos bounds of `B^-1 K`), uploaded
//! as storage buffers, every level's vectors concatenated (level `l` at node offset `offset_l`):
//! - the operators in compressed rows (`row_start`, `cols`, `values` RGB f32 in three floats,
//!   `diag`), with the 2x2 surface-node/cell blocks of the smoother (`partner`,
//!   `partner_value`); the finest level's rows only with [`FinestOperator::Csr`]:
//!   [`FinestOperator::Graph`] (`multigrid/graph_operator.glsl`) reads its `K x` from the
//!   cascade's graph textures ([`FinestGraph`]); with [`OperatorStorage::F16`] (`--coarse-storage f16`) the coarse levels'
//!   entries are RGB fp16 in `values16`, relative to their row's scale in `diag`'s fourth lane,
//!   each row's rounding lumped onto its f32 diagonal (`pack_operators`); the coarse operators
//!   are Galerkin or the coarse graphs' own (`MultigridParams::coarse`, `--coarse-operator`);
//! - the prolongation as links (8 link slots per fine node: the bake's Shepard links or
//!   `MultigridParams::interpolation`'s, weights moved by `pattern_smoothing`; with
//!   [`LinkStorage::Packed`], `--link-storage packed`, one u32 `coarse node << 8 | code`
//!   each, weight `(code - 85) / 85`, the hierarchy built with the same quantized weights) and its transpose by coarse
//!   rows for the restriction (`t_start`, `t_link`: the slots of the links into each coarse node,
//!   whose weights it reads): both gathers;
//! - x, f, r and the Chebyshev direction d per node, RGB in three floats (so the CG's vectors
//!   and `partner_value`; four with `VectorStorage::Rgba`, `--vector-storage rgba`; d and the
//!   CG's `z_old` RGB fp16 in two u32 with [`UpdateStorage::F16`]); the finest node -> texel map
//!   (and back, `texel_node`, for the graph) and the right-hand side coefficients `S b / q` (row scale times q_gain on
//!   surface rows, one float).
//!
//! Per frame (kernels in `shaders-glsl/multigrid/`, one invocation per node, no reduction inside
//! a sweep): `rhs` (f from the gather's q image), then cold: full multigrid (f restricted to every
//! level, the coarsest solved by a Chebyshev polynomial on its Lanczos interval (one workgroup, `coarse`), then per level
//! going up: prolongation and one V-cycle) or warm: the last solution, or with
//! [`MultigridParams::warm_start`] the polynomial through the last two or three (`rhs` keeps the
//! earlier solutions of the finest level in `x_history`). Then V-cycles (smoother:
//! Chebyshev-accelerated block Jacobi, nu1/nu2 steps of `residual` + `smooth`; `restrict`,
//! `prolong`) until the relative residual of the finest level, `max_c ||f - K x|| / ||f||`, is
//! below the tolerance: after every cycle `norm` sums squares per workgroup and `check` (one
//! workgroup) logs the residual and, converged, diverged or at the cap, zeroes the indirect
//! dispatch arguments of every level, so the V-cycles recorded after it dispatch nothing.
//! With [`MultigridParams::krylov`] (the default) the V-cycles precondition a flexible CG
//! (Notay 2000; `krylov.comp`, as the CPU [`Hierarchy::solve`]): per iteration one V-cycle from
//! zero on the CG residual, then two finest-level passes: K z with the dot products `R . z`,
//! `R . z_old`, `z . K z`, `z . K dir_old` reduced per workgroup (summed by `check` into beta, alpha
//! and `dir . K dir` of the control record, K dir following from K z by the direction's
//! recurrence), and the step (direction, K dir, iterate, residual, `R . R`); no read-back; the same
//! convergence check on the CG residual. The CPU reads nothing inside the
//! frame; [`GpuMultigrid::report`] reads the log afterwards. `output` writes x into the finest
//! level's phi image, which the exitance pass reads as it reads the cascade's.
//!
//! Synchronization: one global memory barrier (compute write -> compute read|write) before every
//! dispatch (each reads what the one before wrote); after each `check` one barrier to the indirect
//! argument reads of the next cycle.
//!
//! ```no_run
//! # use translucent::solver::gpu::{GpuDiffusion, GpuSolveParams};
//! # use translucent::solver::multigrid::MultigridParams;
//! # fn f(ctx: &translucent::vk::Context, graph: &translucent::QuadGraph,
//! #      field: &translucent::material::MaterialField, q: &[[f32; 3]]) -> Result<(), translucent::Error> {
//! let params = GpuSolveParams { multigrid: Some(MultigridParams::gpu()), ..Default::default() };
//! let mut solve = GpuDiffusion::new(ctx, graph, field, &params)?;
//! solve.set_q_scale(GpuDiffusion::exposure_for(q.iter()));
//! solve.upload_q(ctx, graph.levels.len() - 1, q)?; // the finest level's q is the right-hand side
//! translucent::frame::quadgraph::solve_headless(ctx, &mut solve, false)?;
//! let report = solve.multigrid_report(ctx)?.expect("multigrid schedule");
//! println!("{} cycles, {:.1} work units, residual {:.1e}", report.cycles.len(), report.work_units, report.residual);
//! # Ok(()) }
//! ```

use std::cell::Cell;

use ash::vk;

use super::record::scope;
use crate::quadgraph::graph::{Packing, NO_NODE};
use crate::shader::{ComputePipeline, ComputePipelineDesc, DescriptorWrite, SpecConstant};
use crate::solver::multigrid::{
    chebyshev_coefficients, eigenvalue_bounds, CycleReport, FinestOperator, Hierarchy, LinkStorage,
    MultigridParams, OperatorStorage, Smoother, UpdateStorage, WarmStart, LINK_WEIGHT_STEPS,
    LINK_WEIGHT_ZERO,
};
use crate::solver::SolverError;
use crate::vk::barrier::{self, Use};
use crate::vk::{Access, Buffer, BufferDesc, Context, GpuProfiler, Image, MemoryUse};
use crate::Error;

/// Profiler scopes and debug labels of the cycle.
mod kernels;
mod local;
mod pack;
mod probe;
mod recorder;
mod report;
mod texels;

use kernels::*;
use pack::{pack_operators, packed_columns_from_env};
pub use probe::{FinestProducts, LevelMagnitudes};
use recorder::{Recorder, Start};
pub use report::{CycleState, GpuMultigridReport};

pub const PASS_MG_START: &str = "multigrid start";
pub const PASS_MG_CYCLES: &str = "multigrid v-cycles";
pub const PASS_MG_OUTPUT: &str = "multigrid output";

/// Levels the control record has indirect arguments for (`MAX_LEVELS` in `common.glsl`).
pub const MAX_LEVELS: usize = 8;
/// Residuals the control record logs (`MAX_LOG` in `common.glsl`).
pub const MAX_LOG: usize = 64;
/// V-cycles recorded per frame at most (after the start): the indirect arguments stop them early.
pub const MAX_RECORDED_CYCLES: u32 = 40;
/// Invocations per workgroup of every multigrid kernel (`local_size_x`).
const GROUP: u32 = 64;
/// Chebyshev steps of the coarsest level's solve at most (its interval's condition decides).
const MAX_COARSE_STEPS: u32 = 512;
/// Lanczos steps for the coarsest level's interval: its smallest Ritz value needs more than the
/// largest.
const COARSE_LANCZOS: u32 = 60;

/// The largest exposed q ([`super::GpuDiffusion::exposure_for`] maps the largest q to 512..1024).
const EXPOSED_Q_MAX: f64 = 1024.0;
/// Where the solve puts the bound of its solution (`q_gain` times the largest q, by the maximum
/// principle: every row is a convex combination of its neighbours and, on the surface, of
/// `q_gain q`): fp16 updates ([`UpdateStorage::F16`], max 65504) keep 32x of headroom above it
/// for the Chebyshev steps' overshoot and the coarse corrections (benches/RESULTS.md "Large
/// lattices: the fp16 update and the coarsest level": eta 3.5 puts phi at 1.8e5 unscaled).
const SOLUTION_BOUND: f64 = 2048.0;

/// The power of two the solve's vectors are scaled by ([`GpuMultigrid::solution_scale`]): the
/// largest whose solution bound `q_gain * EXPOSED_Q_MAX` stays at or below [`SOLUTION_BOUND`].
/// A power of two scales every f32 and fp16 value exactly: where no value left fp16's range
/// before, the solve is bit for bit the unscaled one.
pub fn solution_scale(q_gain: f64) -> f32 {
    let bound = q_gain.abs() * EXPOSED_Q_MAX;
    if !(bound.is_finite() && bound > 0.0) {
        return 1.0;
    }
    (SOLUTION_BOUND / bound)
        .log2()
        .floor()
        .clamp(-60.0, 60.0)
        .exp2() as f32
}

/// Push constants of every `multigrid/*.comp` kernel (`MultigridPush` in `common.glsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct MultigridPush {
    pub count: u32,
    pub offset: u32,
    pub mode: u32,
    pub width: u32,
    pub alpha: [f32; 4],
    pub beta: [f32; 4],
    pub tolerance: f32,
    pub max_log: u32,
    /// krylov: workgroup sums per block of `partials`.
    pub sums: u32,
    /// The finest level's graph ([`FinestGraph`]): texel rows of surface nodes, the homogeneous
    /// material's kappa (2A in the fourth lane) and mu (q_gain), as the cascade's `LevelPush`.
    pub surface_rows: u32,
    pub kappa: [f32; 4],
    pub mu_gain: [f32; 4],
    /// check: also converged below this fraction of the start's residual (0: off).
    pub start_tolerance: f32,
}

/// The finest level's graph textures, which [`FinestOperator::Graph`] reads its operator from
/// (`multigrid/graph_operator.glsl`): bound as the cascade's sweeps bind them.
pub struct FinestGraph<'a> {
    pub connectivity: &'a Image,
    /// `weight_geo`, `weight_r`, `weight_g`, `weight_b` (`diffusion/graph_weights.glsl`).
    pub weights: [&'a Image; 4],
    /// `graph_weights.glsl`'s HOMOGENEOUS, DERIVED and PAPER.
    pub homogeneous: bool,
    pub derived: bool,
    pub paper: bool,
    /// The push constants of the homogeneous path (kappa and 2A, mu and q_gain).
    pub kappa: [f32; 4],
    pub mu_gain: [f32; 4],
}

/// The control record the GPU writes (`MultigridControl` in `common.glsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct MultigridControl {
    pub args: [[u32; 4]; MAX_LEVELS],
    pub reference: [f32; 4],
    pub logged: u32,
    pub state: u32,
    /// Finest nodes the warm start's local relaxation listed (`multigrid/local.comp`).
    pub local_nodes: u32,
    /// The warm start's order (the host writes it with the record's reset): a record copied
    /// for a later report carries it (`--bounce source` runs a second solve of order 0 before
    /// the first's report is read).
    pub warm_order: u32,
    /// Conjugate gradients: `R . z` of the current direction, the step and the direction update.
    pub rz: [f32; 4],
    pub alpha: [f32; 4],
    pub beta: [f32; 4],
    /// `dir . K dir` of the current direction (the next iteration's recurrence reads it).
    pub dkd: [f32; 4],
    pub residual: [f32; MAX_LOG],
}

struct Level {
    offset: u32,
    count: u32,
    /// Chebyshev interval of `B^-1 K` per channel.
    bounds: [(f64, f64); 3],
    /// Matrix entries of one operator application (off-diagonals plus the diagonal).
    entries: u64,
    /// Links of one prolongation or restriction from the coarser level (0 on the coarsest).
    links: u64,
}

/// The GPU multigrid of one graph and material (see the module doc).
pub struct GpuMultigrid {
    params: MultigridParams,
    levels: Vec<Level>,
    coarse_steps: u32,
    width: u32,
    /// The finest level's graph push constants ([`MultigridPush::surface_rows`], `kappa`,
    /// `mu_gain`).
    surface_rows: u32,
    kappa: [f32; 4],
    mu_gain: [f32; 4],
    partials: u32,
    /// Texel views of `buffers` for the descriptor sets' `*_t` bindings (held; dropped first).
    _texel_views: texels::TexelViews,
    /// Where the residual, smoothing and CG kernels read from; whether the fp16 rows read their
    /// columns from the entries (`pack::PackedOperators::packed_columns`).
    reads: texels::Reads,
    packed_columns: bool,
    buffers: Vec<Buffer>,
    control: Buffer,
    /// The warm start's local relaxation: header, flag bits, list (`multigrid/local.comp`).
    local: Buffer,
    local_layout: local::LocalLayout,
    pipelines: Vec<(ComputePipeline<MultigridPush>, vk::DescriptorSet)>,
    /// The relaxation's second set (`relax.comp` from r into x; the first, in `pipelines`, from x
    /// into r).
    relax_back: vk::DescriptorSet,
    warm: Cell<bool>,
    /// Earlier solutions in `x_history` of the chain the finest x continues (0 after a cold
    /// start: its x was not warm-started from them).
    history: Cell<u32>,
    bytes: u64,
    /// Bytes per buffer, in [`BUFFER_NAMES`] order, then the control record.
    buffer_bytes: Vec<(&'static str, u64)>,
    /// The coarsest level's solve in one dispatch (`multigrid/coarse.comp`), else two per
    /// Chebyshev step (`TRANSLUCENT_MULTIGRID_COARSE=split`, for measurements).
    coarse_in_one_dispatch: bool,
    /// Profiler scopes per level and CG iteration inside the solve's three
    /// (`TRANSLUCENT_MULTIGRID_SCOPES=1`; each costs two timestamps, so off by default).
    fine_scopes: bool,
    /// The levels whose smoothing steps run as one fused pass each (`multigrid/relax.comp`).
    relax: RelaxLevels,
    /// The solve's vectors are `scale` times phi ([`solution_scale`] of the finest level's
    /// `q_gain`): folded into `rhs_coef`, divided out by `output.comp`.
    scale: f32,
}

fn rgb(v: [f64; 3]) -> [f32; 4] {
    [v[0] as f32, v[1] as f32, v[2] as f32, 0.0]
}

fn too_big(what: &str) -> Error {
    Error::Solver(SolverError::BadParameter {
        name: "multigrid",
        problem: format!("{what} exceeds 32-bit indices"),
    })
}

impl GpuMultigrid {
    /// Uploads `hierarchy` (built with `params`); `q` and `phi` are the finest level's q image
    /// (RGBA16F) and phi image (RGBA32F) laid out by `packing`, `graph` its graph textures (read
    /// under [`FinestOperator::Graph`], bound either way).
    pub fn new(
        ctx: &Context,
        hierarchy: &Hierarchy,
        params: &MultigridParams,
        packing: &Packing,
        q: &Image,
        phi: &Image,
        graph: &FinestGraph<'_>,
    ) -> Result<Self, Error> {
        let n_levels = hierarchy.levels.len();
        if n_levels == 0 || n_levels > MAX_LEVELS {
            return Err(Error::Solver(SolverError::BadParameter {
                name: "levels",
                problem: format!("{n_levels}: the GPU multigrid takes 1 to {MAX_LEVELS} levels"),
            }));
        }
        if phi.format != vk::Format::R32G32B32A32_SFLOAT {
            return Err(Error::Solver(SolverError::BadParameter {
                name: "precision",
                problem: "the multigrid schedule writes an fp32 phi: use precision mixed or fp32"
                    .into(),
            }));
        }
        let mut offsets = Vec::with_capacity(n_levels + 1);
        let mut total = 0usize;
        for l in &hierarchy.levels {
            offsets.push(total);
            total += l.node_count();
        }
        offsets.push(total);
        if total >= u32::MAX as usize {
            return Err(too_big("the node count"));
        }
        let graph_finest = params.finest_operator == FinestOperator::Graph;
        let ops = pack_operators(hierarchy, &offsets, params)?;
        let packed_columns = ops.packed_columns && packed_columns_from_env();
        let packed = params.link_storage == LinkStorage::Packed;
        if packed && total >= (NO_NODE >> 8) as usize {
            return Err(too_big("a packed link's node (24 bits)"));
        }
        // The prolongation: 8 link slots per node (slot `8 i + k`), every level (the coarsest's
        // empty); packed, one u32 `coarse node << 8 | code` (weight `(code - 85) / 85`) per slot, else the node
        // and an f32 weight.
        let mut links: Vec<u32> = Vec::with_capacity(8 * total);
        let mut link_weights: Vec<f32> = Vec::with_capacity(if packed { 0 } else { 8 * total });
        for (l, level) in hierarchy.levels.iter().enumerate() {
            let k = &level.operator;
            match (&level.prolongation, l.checked_sub(1)) {
                (Some(p), Some(coarse)) => {
                    let coarse_off = offsets[coarse] as u32;
                    for (lk, w) in p.links.iter().zip(&p.weights) {
                        for (&c, &wc) in lk.iter().zip(w) {
                            let global = if c == NO_NODE {
                                NO_NODE
                            } else {
                                c + coarse_off
                            };
                            if !packed {
                                links.push(global);
                                link_weights.push(wc as f32);
                            } else if global == NO_NODE {
                                links.push(NO_NODE);
                            } else {
                                // `quantized_links` made `wc` a whole number of steps in the
                                // 8-bit code's range.
                                let steps = (wc * f64::from(LINK_WEIGHT_STEPS)).round() as i64
                                    + i64::from(LINK_WEIGHT_ZERO);
                                links.push(global << 8 | steps.clamp(0, 255) as u32);
                            }
                        }
                    }
                }
                _ => {
                    links.extend(std::iter::repeat_n(NO_NODE, 8 * k.node_count()));
                    if !packed {
                        link_weights.extend(std::iter::repeat_n(0.0, 8 * k.node_count()));
                    }
                }
            }
        }
        // Restriction by coarse rows: level l's rows gather from level l + 1, each entry the
        // slot of the fine node's link to the row (the fine node is `slot / 8`, the weight the
        // link's): P^T without a copy of its weights.
        let mut t_start: Vec<u32> = Vec::with_capacity(total + 1);
        let mut t_link: Vec<u32> = Vec::new();
        for (l, level) in hierarchy.levels.iter().enumerate() {
            let finer = hierarchy
                .levels
                .get(l + 1)
                .and_then(|f| f.prolongation.as_ref());
            let base = t_link.len();
            match finer {
                Some(p) => {
                    for c in 0..level.node_count() {
                        t_start.push(
                            u32::try_from(base + p.t_start[c])
                                .map_err(|_| too_big("the restriction"))?,
                        );
                    }
                    let fine_off = offsets[l + 1];
                    for c in 0..level.node_count() {
                        // A fine node linking c twice comes twice, slots in order.
                        let mut last: Option<(usize, usize)> = None;
                        for e in p.t_start[c]..p.t_start[c + 1] {
                            let fine = p.t_fine[e] as usize;
                            let from = match last {
                                Some((f, k)) if f == fine => k + 1,
                                _ => 0,
                            };
                            let k = (from..8)
                                .find(|&k| p.links[fine][k] as usize == c)
                                .ok_or_else(|| {
                                    Error::Solver(SolverError::BadGraph {
                                        level: l + 1,
                                        problem: format!("node {fine} has no link to {c}"),
                                    })
                                })?;
                            last = Some((fine, k));
                            let slot = 8 * (fine_off + fine) + k;
                            t_link
                                .push(u32::try_from(slot).map_err(|_| too_big("the link slots"))?);
                        }
                    }
                }
                None => t_start.extend(std::iter::repeat_n(base as u32, level.node_count())),
            }
        }
        t_start.push(u32::try_from(t_link.len()).map_err(|_| too_big("the restriction"))?);
        // The finest level's texels and right-hand side coefficients.
        let top = n_levels - 1;
        let finest = &hierarchy.finest;
        let n_top = hierarchy.levels[top].node_count();
        if packing.texels.len() != n_top {
            return Err(Error::Solver(SolverError::BadGraph {
                level: top,
                problem: format!("{} texels for {n_top} nodes", packing.texels.len()),
            }));
        }
        let node_texel: Vec<u32> = packing
            .texels
            .iter()
            .map(|&[u, v]| v * packing.width + u)
            .collect();
        // The solve runs in units of `scale` phi (f = S b scale, x = phi scale; output.comp
        // divides): its fp16 updates stay in range whatever eta's q_gain.
        let scale = solution_scale(finest.q_gain);
        let rhs_coef: Vec<f32> = (0..n_top)
            .map(|i| {
                if i >= finest.inner_count {
                    (finest.row_scale[i] * finest.q_gain * f64::from(scale)) as f32
                } else {
                    0.0
                }
            })
            .collect();
        // The matrix-free finest level's map from its neighbours' texels back to nodes.
        let texel_node = if graph_finest {
            packing.texel_nodes()
        } else {
            Vec::new()
        };
        let partials = (n_top as u32).div_ceil(GROUP);
        // Every per-node RGB vector takes `stride` floats (`RGB` in `common.glsl`).
        let stride = params.vector_storage.floats();
        let zeros = vec![0.0f32; stride * total];
        // The conjugate gradients' vectors (finest level only; none without `krylov`).
        let krylov_zeros = vec![0.0f32; if params.krylov { stride * n_top } else { 0 }];
        // d and z_old: fp16 RGB in two u32 per node, or as the other vectors.
        let half_updates = params.update_storage == UpdateStorage::F16;
        let update_floats = if half_updates { 2 } else { stride };
        let d_zeros = vec![0.0f32; update_floats * total];
        let z_old_zeros = vec![
            0.0f32;
            if params.krylov {
                update_floats * n_top
            } else {
                0
            }
        ];
        // The warm start's earlier finest solutions (`WarmStart::history` vectors).
        let history_zeros = vec![0.0f32; stride * params.warm_start.history() as usize * n_top];
        let contents: [Vec<u8>; 24] = [
            bytemuck::cast_slice(&zeros).to_vec(),
            bytemuck::cast_slice(&zeros).to_vec(),
            bytemuck::cast_slice(&zeros).to_vec(),
            bytemuck::cast_slice(&d_zeros).to_vec(),
            bytemuck::cast_slice(&ops.row_start).to_vec(),
            bytemuck::cast_slice(ops.stored_cols(graph_finest && packed_columns)).to_vec(),
            bytemuck::cast_slice(&ops.values).to_vec(),
            bytemuck::cast_slice(&ops.diag).to_vec(),
            bytemuck::cast_slice(&ops.partner).to_vec(),
            bytemuck::cast_slice(&ops.partner_value).to_vec(),
            bytemuck::cast_slice(&links).to_vec(),
            bytemuck::cast_slice(&link_weights).to_vec(),
            bytemuck::cast_slice(&t_start).to_vec(),
            bytemuck::cast_slice(&t_link).to_vec(),
            bytemuck::cast_slice(&node_texel).to_vec(),
            bytemuck::cast_slice(&rhs_coef).to_vec(),
            // CG_SUMS blocks: the CG apply pass's k-th sum goes at `k * partials`.
            bytemuck::cast_slice(&vec![[0.0f32; 4]; CG_SUMS * partials as usize]).to_vec(),
            bytemuck::cast_slice(&krylov_zeros).to_vec(),
            bytemuck::cast_slice(&krylov_zeros).to_vec(),
            bytemuck::cast_slice(&z_old_zeros).to_vec(),
            bytemuck::cast_slice(&krylov_zeros).to_vec(),
            bytemuck::cast_slice(&ops.values16).to_vec(),
            bytemuck::cast_slice(&history_zeros).to_vec(),
            bytemuck::cast_slice(&texel_node).to_vec(),
        ];
        let mut buffers = Vec::with_capacity(BUFFER_NAMES.len());
        let mut bytes = 0u64;
        let mut buffer_bytes = Vec::with_capacity(BUFFER_NAMES.len() + 1);
        for (name, data) in BUFFER_NAMES.iter().zip(contents) {
            // An empty array (no off-diagonal entries, one level) still gets a buffer.
            let size = data.len().max(16) as u64;
            let mut buffer = Buffer::new(
                ctx,
                &BufferDesc {
                    name,
                    size,
                    // Texel views: the `*_t` bindings (`texels`); transfers: the finest x kept
                    // across `--bounce source`'s second solve (`Self::finest_x`).
                    usage: vk::BufferUsageFlags::STORAGE_BUFFER
                        | vk::BufferUsageFlags::UNIFORM_TEXEL_BUFFER
                        | vk::BufferUsageFlags::TRANSFER_SRC
                        | vk::BufferUsageFlags::TRANSFER_DST,
                    // why Upload: written once per material from the host; on lavapipe every
                    // heap is host memory (a discrete GPU would stage into GpuOnly).
                    memory: MemoryUse::Upload,
                },
            )?;
            if !data.is_empty() {
                buffer.write_bytes(0, &data)?;
            }
            bytes += size;
            buffer_bytes.push((*name, size));
            buffers.push(buffer);
        }
        let control = Buffer::new(
            ctx,
            &BufferDesc {
                name: "multigrid control",
                size: std::mem::size_of::<MultigridControl>() as u64,
                usage: vk::BufferUsageFlags::STORAGE_BUFFER
                    | vk::BufferUsageFlags::INDIRECT_BUFFER
                    | vk::BufferUsageFlags::TRANSFER_DST
                    // A frame's solve copies it for the host (`CompletedSolve::multigrid`).
                    | vk::BufferUsageFlags::TRANSFER_SRC,
                memory: MemoryUse::Readback,
            },
        )?;
        bytes += control.size;
        buffer_bytes.push(("control", control.size));
        let local_layout = local::LocalLayout::new(params, n_top);
        let local = local_layout.buffer(ctx)?;
        bytes += local.size;
        buffer_bytes.push(("local", local.size));
        let reads = texels::Reads::from_env();
        let texel_views = texels::TexelViews::new(
            ctx,
            &buffers,
            KERNELS.iter().flat_map(|k| k.2.iter().copied()),
        )?;
        let mut pipelines = Vec::with_capacity(KERNELS.len());
        let mut relax_back = vk::DescriptorSet::null();
        for (kernel, (name, shader, bindings)) in KERNELS.into_iter().enumerate() {
            // The operator readers learn where the fp16 entries end (`pack_operators`), the link
            // readers whether the links are packed, the vector readers the vectors' stride.
            let mut constants = Vec::new();
            if bindings.contains(&"values") {
                constants.push(SpecConstant {
                    id: 0,
                    value: ops.half_entries,
                });
            }
            if bindings.contains(&"links") {
                constants.push(SpecConstant {
                    id: 1,
                    value: u32::from(packed),
                });
            }
            if bindings.iter().any(|b| VECTORS.contains(b)) {
                constants.push(SpecConstant {
                    id: 2,
                    value: stride as u32,
                });
            }
            if bindings.contains(&"d") || bindings.contains(&"z_old") {
                constants.push(SpecConstant::bool(8, half_updates));
            }
            if bindings.contains(&"connectivity") {
                // graph_operator.glsl: graph_weights.glsl's three at 3, 4, 5, then the switch
                // and the finest level's offset.
                constants.extend([
                    SpecConstant::bool(3, graph.homogeneous),
                    SpecConstant::bool(4, graph.derived),
                    SpecConstant::bool(5, graph.paper),
                    SpecConstant::bool(6, graph_finest),
                    SpecConstant {
                        id: 7,
                        value: offsets[top] as u32,
                    },
                ]);
            }
            if bindings.contains(&"local") {
                constants.extend(local_layout.spec_constants());
            }
            if bindings.contains(&"values16") {
                constants.push(SpecConstant::bool(11, packed_columns));
            }
            if bindings.iter().any(|b| texels::viewed(b).is_some()) {
                constants.push(SpecConstant::bool(9, reads == texels::Reads::Texel));
            }
            let pipeline = ComputePipeline::new_specialized(
                ctx,
                &ComputePipelineDesc {
                    name,
                    shader,
                    bindings,
                    max_sets: if kernel == RELAX { 2 } else { 1 },
                },
                &constants,
            )?;
            // The relaxation's two sets: x -> r, then r -> x (`relax.comp`).
            let buffer_of = |name: &str, back: bool| {
                let name = match (name, back) {
                    ("x_out", false) | ("x", true) => "r",
                    ("x_out", true) => "x",
                    (other, _) => other,
                };
                let i = BUFFER_NAMES.iter().position(|&n| n == name).unwrap_or(0);
                (BUFFER_NAMES[i], &buffers[i])
            };
            if kernel == RELAX {
                let writes: Vec<DescriptorWrite<'_>> = bindings
                    .iter()
                    .map(|&b| match b {
                        "x" | "x_out" => DescriptorWrite::StorageBuffer {
                            name: b,
                            buffer: buffer_of(b, true).1,
                        },
                        "connectivity" => {
                            DescriptorWrite::storage_image("connectivity", graph.connectivity)
                        }
                        "weight_geo" => {
                            DescriptorWrite::storage_image("weight_geo", graph.weights[0])
                        }
                        "weight_r" => DescriptorWrite::storage_image("weight_r", graph.weights[1]),
                        "weight_g" => DescriptorWrite::storage_image("weight_g", graph.weights[2]),
                        "weight_b" => DescriptorWrite::storage_image("weight_b", graph.weights[3]),
                        other => {
                            let (name, buffer) = buffer_of(other, true);
                            DescriptorWrite::StorageBuffer { name, buffer }
                        }
                    })
                    .collect();
                relax_back = pipeline.allocate_set(ctx, &writes)?;
            }
            let writes: Vec<DescriptorWrite<'_>> = bindings
                .iter()
                .map(|&b| match (b, texel_views.get(b)) {
                    (name, Some(view)) => DescriptorWrite::UniformTexelBuffer { name, view },
                    (b, None) => match b {
                        "x_out" => DescriptorWrite::StorageBuffer {
                            name: "x_out",
                            buffer: buffer_of("x_out", false).1,
                        },
                        "q" => DescriptorWrite::storage_image("q", q),
                        "phi" => DescriptorWrite::storage_image("phi", phi),
                        "connectivity" => {
                            DescriptorWrite::storage_image("connectivity", graph.connectivity)
                        }
                        "weight_geo" => {
                            DescriptorWrite::storage_image("weight_geo", graph.weights[0])
                        }
                        "weight_r" => DescriptorWrite::storage_image("weight_r", graph.weights[1]),
                        "weight_g" => DescriptorWrite::storage_image("weight_g", graph.weights[2]),
                        "weight_b" => DescriptorWrite::storage_image("weight_b", graph.weights[3]),
                        "control" => DescriptorWrite::StorageBuffer {
                            name: "control",
                            buffer: &control,
                        },
                        "local" => DescriptorWrite::StorageBuffer {
                            name: "local",
                            buffer: &local,
                        },
                        other => {
                            let i = BUFFER_NAMES.iter().position(|&n| n == other).unwrap_or(0);
                            DescriptorWrite::StorageBuffer {
                                name: BUFFER_NAMES[i],
                                buffer: &buffers[i],
                            }
                        }
                    },
                })
                .collect();
            let set = pipeline.allocate_set(ctx, &writes)?;
            pipelines.push((pipeline, set));
        }
        let (levels, coarse_steps) = Self::intervals(hierarchy, params, &offsets);
        let single_level = levels.len() == 1;
        Ok(Self {
            params: params.clone(),
            levels,
            coarse_steps,
            width: packing.width,
            surface_rows: packing.surface_rows,
            kappa: graph.kappa,
            mu_gain: graph.mu_gain,
            partials,
            _texel_views: texel_views,
            reads,
            packed_columns,
            buffers,
            control,
            local,
            local_layout,
            pipelines,
            relax_back,
            warm: Cell::new(false),
            history: Cell::new(0),
            bytes,
            buffer_bytes,
            // Not on a single level: there the coarsest level is the matrix-free finest one,
            // whose rows `coarse.comp` cannot read (the 1-level render diverged).
            coarse_in_one_dispatch: !single_level
                && std::env::var("TRANSLUCENT_MULTIGRID_COARSE").as_deref() != Ok("split"),
            fine_scopes: std::env::var("TRANSLUCENT_MULTIGRID_SCOPES").as_deref() == Ok("1"),
            relax: RelaxLevels::from_env(),
            scale,
        })
    }

    /// Pre- and post-smoothing steps on level `l` ([`MultigridParams::sweeps_at`]).
    fn sweeps(&self, l: usize) -> (u32, u32) {
        self.params.sweeps_at(l, self.levels.len() - 1)
    }

    /// Chebyshev intervals: the smoother's on every level but the coarsest, the Lanczos
    /// interval (its smallest Ritz value) on the coarsest, whose polynomial is the solve; and the
    /// coarsest solve's steps.
    fn intervals(
        hierarchy: &Hierarchy,
        params: &MultigridParams,
        offsets: &[usize],
    ) -> (Vec<Level>, u32) {
        let lower = match params.smoother {
            Smoother::Chebyshev { lower } => lower,
            Smoother::Jacobi { .. } => 0.0,
        };
        // TRANSLUCENT_MULTIGRID_COARSE_LANCZOS: another step count, for measurements.
        let coarse_lanczos = std::env::var("TRANSLUCENT_MULTIGRID_COARSE_LANCZOS")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(COARSE_LANCZOS);
        let coarse_bounds = eigenvalue_bounds(&hierarchy.levels[0].operator, coarse_lanczos);
        let mut worst_condition: f64 = 1.0;
        let levels: Vec<Level> = hierarchy
            .levels
            .iter()
            .enumerate()
            .map(|(l, level)| {
                let bounds = if l == 0 {
                    std::array::from_fn(|c| {
                        let hi = level.lambda_max[c].max(coarse_bounds[c].1 * 1.05);
                        let lo = coarse_bounds[c].0.clamp(hi * 1e-8, hi * 0.5);
                        worst_condition = worst_condition.max(hi / lo);
                        (lo, hi)
                    })
                } else {
                    level.lambda_max.map(|hi| (lower * hi, hi))
                };
                Level {
                    offset: offsets[l] as u32,
                    count: level.node_count() as u32,
                    bounds,
                    entries: level.operator_entries(),
                    links: level.link_entries(),
                }
            })
            .collect();
        // Chebyshev on [lo, hi] reduces the error by 2 ((sqrt(k) - 1) / (sqrt(k) + 1))^m,
        // k = hi / lo: m = ln(2 / tol) sqrt(k) / 2 steps reach the coarse tolerance.
        let steps = (2.0 / params.coarse_tolerance).ln() * worst_condition.sqrt() * 0.5;
        let coarse_steps = (steps.ceil() as u32).clamp(4, MAX_COARSE_STEPS);
        (levels, coarse_steps)
    }

    /// What [`Self::record`] uses besides the finest level's q and phi images (the caller's).
    pub fn uses(&self) -> Vec<Use<'_>> {
        let mut uses = vec![
            Use::buffer_span(&self.control, Access::TransferDst, Access::ComputeReadWrite),
            Use::buffer_span(&self.local, Access::TransferDst, Access::ComputeReadWrite),
        ];
        for (name, b) in BUFFER_NAMES.iter().zip(&self.buffers) {
            let access = if WRITTEN.contains(name) {
                Access::ComputeReadWrite
            } else {
                Access::ComputeRead
            };
            uses.push(Use::buffer(b, access));
        }
        uses
    }

    fn top(&self) -> usize {
        self.levels.len() - 1
    }

    /// Records one solve (see the module doc): cold (full multigrid) or warm (from x). It
    /// converges below `tolerance` relative to ||f||, or (`start_tolerance > 0`) below
    /// `start_tolerance` times the start's relative residual: a warm solve of a small change of
    /// f converges relative to the change (`render --bounce source`'s second solve); such a
    /// solve starts from the last solution unextrapolated and keeps the warm start's history.
    ///
    /// # Safety
    /// `cb` must be recording outside a rendering scope, inside a frame-graph pass declaring
    /// [`Self::uses`] and the q (read) and phi (write) images; `self` must outlive its execution.
    pub unsafe fn record(
        &self,
        ctx: &Context,
        cb: vk::CommandBuffer,
        warm: bool,
        tolerance: f32,
        start_tolerance: f32,
        profiler: &mut Option<&mut GpuProfiler>,
    ) {
        use vk::AccessFlags2 as A;
        use vk::PipelineStageFlags2 as S;
        self.warm.set(warm);
        // The warm start's order: what the kept solutions allow; each warm solve keeps one more
        // (the oldest drops out), a cold one starts a new chain.
        let slots = self.params.warm_start.history();
        // A solve of an increment (`start_tolerance > 0`, warm) starts from the last solution as
        // it is (no extrapolation: the increment is this frame's, not the history's trend) and
        // leaves the kept solutions alone.
        let increment = warm && start_tolerance > 0.0;
        let order = if warm && !increment {
            self.history.get().min(slots)
        } else {
            0
        };
        if !increment {
            self.history.set(if warm {
                (self.history.get() + 1).min(slots)
            } else {
                0
            });
        }
        let top = self.top();
        let mut control: MultigridControl = bytemuck::Zeroable::zeroed();
        for (l, level) in self.levels.iter().enumerate() {
            control.args[l] = [level.count.div_ceil(GROUP), 1, 1, 0];
        }
        control.warm_order = order;
        let max_log = self.params.max_cycles.min(MAX_RECORDED_CYCLES) + 1;
        let base = MultigridPush {
            width: self.width,
            tolerance,
            start_tolerance,
            max_log,
            sums: self.partials,
            surface_rows: self.surface_rows,
            kappa: self.kappa,
            mu_gain: self.mu_gain,
            ..Default::default()
        };
        let rec = Recorder {
            mg: self,
            ctx,
            cb,
            base,
            profiler: std::cell::RefCell::new(profiler),
        };
        // SAFETY: the caller's contract; every set's resources live in `self` or are the
        // caller's images.
        unsafe {
            ctx.raw()
                .cmd_update_buffer(cb, self.control.raw, 0, bytemuck::bytes_of(&control));
            // Only after an extrapolated start: the last solution's residual is the smooth
            // change, spread over the level (benches/RESULTS.md "Local relaxation of the warm
            // start (wave 8)": the first warm frame of the default scene took 5 units more).
            let local_relaxation = self.params.local_relaxation.filter(|_| warm && order > 0);
            if local_relaxation.is_some() {
                // The list's header and flags start at zero (covered by the barrier below).
                self.local_layout.clear(ctx, cb, &self.local);
            }
            // why: the cycles read the reset control record (and the local relaxation its cleared
            // list) as indirect arguments and the kernels update them (RAW after the transfers).
            barrier::record(
                ctx,
                cb,
                &[super::raw_barrier(
                    S::COPY,
                    A::TRANSFER_WRITE,
                    S::DRAW_INDIRECT | S::COMPUTE_SHADER,
                    A::INDIRECT_COMMAND_READ | A::SHADER_STORAGE_READ | A::SHADER_STORAGE_WRITE,
                )],
                &[],
            );
            scope(&mut rec.profiler.borrow_mut(), ctx, cb, Some(PASS_MG_START));
            let n_top = self.levels[top].count;
            let rhs_mode = match (warm, slots) {
                (false, _) => RHS_COLD,
                (true, _) if increment => RHS_WARM,
                (true, 0) => RHS_WARM,
                (true, n) => RHS_EXTRAPOLATE + n - 1,
            };
            let c = WarmStart::coefficients(order).map(f64::from);
            rec.direct_with(RHS, top, rhs_mode, c, n_top);
            rec.direct(NORM, top, 1, n_top);
            rec.check(CHECK_REFERENCE);
            if let Some(relaxation) = local_relaxation {
                // Where the start's residual exceeds the tolerance (it needs ||f||).
                rec.local_relaxation(relaxation);
                // The smooth remainder: coarse-grid corrections (a V(0,0) cycle each), the local
                // relaxation again between two of them.
                for k in 0..self.params.warm_corrections {
                    if k > 0 {
                        rec.local_relaxation_again(relaxation);
                    }
                    // why: the cycle's indirect dispatches read the control record the local
                    // relaxation's last range pass wrote (its listed count), and its residual
                    // reads the x the sweeps wrote (RAW at DRAW_INDIRECT and in compute).
                    barrier::record(
                        ctx,
                        cb,
                        &[super::raw_barrier(
                            S::COMPUTE_SHADER,
                            A::SHADER_STORAGE_WRITE,
                            S::DRAW_INDIRECT | S::COMPUTE_SHADER,
                            A::INDIRECT_COMMAND_READ
                                | A::SHADER_STORAGE_READ
                                | A::SHADER_STORAGE_WRITE,
                        )],
                        &[],
                    );
                    rec.v_cycle_with(top, false, (0, 0));
                }
            }
            if !warm {
                for l in (1..=top).rev() {
                    rec.indirect(RESTRICT, l - 1, 1, [0.0; 3], [0.0; 3]);
                }
                rec.coarse();
                for l in 1..=top {
                    rec.indirect(PROLONG, l, 1, [0.0; 3], [0.0; 3]);
                    let sweeps = self.params.fmg_sweeps_at(l, top);
                    for _ in 0..self.params.fmg_cycles_at(l, top) {
                        rec.v_cycle_with(l, false, sweeps);
                    }
                }
            }
            let fused = self.fused_start();
            if fused {
                // The start's residual, its norm and the CG start in one pass; direct: converged
                // already, it still moves x into the iterate.
                rec.direct(KRYLOV, top, CG_START_RESIDUAL, n_top);
                rec.check(CHECK_RESIDUAL);
            } else {
                rec.residual_check();
            }
            scope(&mut rec.profiler.borrow_mut(), ctx, cb, None);
            scope(
                &mut rec.profiler.borrow_mut(),
                ctx,
                cb,
                Some(PASS_MG_CYCLES),
            );
            if self.params.krylov {
                if !fused {
                    // Direct: converged already, the start still moves x into the iterate.
                    rec.direct(KRYLOV, top, CG_START, n_top);
                }
                for _ in 1..max_log {
                    rec.krylov_iteration();
                }
                rec.direct(KRYLOV, top, CG_FINISH, n_top);
            } else {
                for _ in 1..max_log {
                    rec.v_cycle(top, false);
                    rec.residual_check();
                }
            }
            scope(&mut rec.profiler.borrow_mut(), ctx, cb, None);
            scope(
                &mut rec.profiler.borrow_mut(),
                ctx,
                cb,
                Some(PASS_MG_OUTPUT),
            );
            // alpha.x: 1 / scale, back to phi's units.
            let unscale = f64::from(self.scale).recip();
            rec.direct_with(OUTPUT, top, 0, [unscale; 3], n_top);
            scope(&mut rec.profiler.borrow_mut(), ctx, cb, None);
        }
    }
}
