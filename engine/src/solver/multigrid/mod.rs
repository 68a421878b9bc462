//! Multigrid over the QuadGraph levels (DESIGN section 5.1), in f64 on the CPU: the prototype and
//! the reference of the GPU schedule, operation for operation.
//!
//! Every level `l` holds the row-scaled system `K_l x = f_l` (`K = S A`, S the `fv` row scaling:
//! V_i on inner rows, A_f / (2A) on surface rows; symmetric positive definite for `fv`). The
//! prolongation `P_l` (level l - 1 -> l) is the bake's Shepard resampling (paper Eq. 10,
//! [`GraphLevel::from_coarser`]); the restriction is its transpose, `f_(l-1) = P_l^T r_l`, applied to
//! the scaled residual, so that `P^T K P` is the symmetric Galerkin product. In the unscaled Jacobi
//! form the GPU iterates, the same restriction reads `rhs_c = (1 / m_c) P^T (m r)` with `m = diag K`
//! the node's mass ([`Hierarchy::restrict_jacobi_residual`]).
//!
//! - Coarse operators ([`CoarseOperator`]): re-discretized (the bake's coarse graphs, 4 neighbours,
//!   the textures the GPU already has) or Galerkin (`P^T K P`, a wider sparse stencil).
//! - Smoothers ([`Smoother`]): damped Jacobi `x += omega D^-1 (f - K x)`, or Chebyshev-accelerated
//!   Jacobi on `[lower lambda_max, lambda_max]` of `D^-1 K`, lambda_max from power iterations at
//!   creation. Neither needs a reduction inside a sweep.
//! - Coarsest level: preconditioned CG to [`MultigridParams::coarse_tolerance`].
//! - Cold start: full multigrid (restrict the right-hand side to every level, solve the coarsest,
//!   then prolong and run one V-cycle per level going up), then V-cycles. Warm start: V-cycles from
//!   the given solution.
//! - Stopping rule (the GPU's): the true relative residual `max_c ||f - K x||_2 / ||f||_2` of the
//!   finest level after every cycle, below [`MultigridParams::tolerance`].
//! - Work is counted in node updates: a smoothing sweep, a residual, a restriction, a prolongation,
//!   a coarse CG iteration and a residual norm each cost one update per node of the level they run
//!   on; work units are node updates / finest nodes.
//!
//! ```
//! use glam::DVec3;
//! use translucent::material::{Material, MaterialField};
//! use translucent::mesh::shapes::Shape;
//! use translucent::quadgraph::BakeParams;
//! use translucent::solver::multigrid::{Hierarchy, MultigridParams, Start};
//! use translucent::scene::{Environment, Scene};
//! use translucent::solver::Scheme;
//! use translucent::QuadGraph;
//! let ball = Shape::Sphere { radius: 5.0 };
//! let bake = BakeParams { resolution: 16, levels: 2, ..Default::default() };
//! let (graph, _) = QuadGraph::bake(&ball.triangulate(24), &ball, &bake, &mut |_| {})?;
//! let field = MaterialField::Homogeneous(Material::preset("marble")?);
//! let params = MultigridParams::default();
//! let mg = Hierarchy::build(&graph, &field, Scheme::Fv, &params)?;
//! let scene = Scene { lights: vec![], environment: Environment::Constant([1.0; 3]) };
//! let q = scene.surface_irradiance(graph.finest(), 1.3, None);
//! let f = mg.scaled_rhs(&q);
//! let (phi, report) = mg.solve(&f, Start::Cold, &params, &mut |_, _| {});
//! assert!(report.converged && report.residual < params.tolerance);
//! assert_eq!(phi.len(), graph.finest().node_count());
//! println!("{} cycles, {:.1} work units, factors {:?}", report.cycles.len(), report.work_units,
//!     report.cycles.iter().map(|c| c.factor).collect::<Vec<_>>());
//! assert!(report.cycles.iter().skip(1).all(|c| c.factor < 1.0));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use glam::{DMat4, DVec3, DVec4};
use rayon::prelude::*;

use super::operator::{LevelOperator, Scheme};
use super::transport::ExitQuery;
use super::SolverError;
use crate::material::MaterialField;
use crate::quadgraph::graph::{GraphLevel, QuadGraph, ShepardLinks, NO_NODE};
use crate::quadgraph::shepard::ShepardIndex;

mod cycle_spec;
mod options;
mod prolongation;
mod smoothers;
mod sparse;
mod sparsify;

pub use options::{
    quantized_links, CoarseOperator, FinestOperator, Interpolation, LinkStorage, LocalRelaxation,
    OperatorStorage, UpdateStorage, VectorStorage, WarmStart, DIVERGED, LINK_WEIGHT_STEPS,
    LINK_WEIGHT_ZERO, MAX_WARM_CORRECTIONS,
};
pub use prolongation::{linear_links, mixed_links, Prolongation};
use smoothers::*;
pub use smoothers::{chebyshev_coefficients, eigenvalue_bounds, largest_eigenvalue, norm2};
pub use sparse::SparseOperator;
use sparse::*;
pub use sparsify::{Lumping, PATH_WEIGHT};

type Field = Vec<[f64; 3]>;
/// One row's off-diagonal entries: (column, value per channel).
type SparseRow = Vec<(u32, [f64; 3])>;

/// Safety factor on the Lanczos estimate of lambda_max (an estimate from below): a Chebyshev
/// smoother whose upper bound is below the true lambda_max amplifies the modes above it.
const LAMBDA_MARGIN: f64 = 1.05;

/// The smoother of every level but the coarsest.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub enum Smoother {
    /// `x += omega D^-1 (f - K x)`.
    Jacobi { omega: f64 },
    /// Chebyshev polynomial in `D^-1 K` on `[lower * lambda_max, lambda_max]`; one sweep = one
    /// degree (one matrix-vector product), so `pre_sweeps` is the pre-smoother's degree.
    Chebyshev { lower: f64 },
}

/// How a solve starts.
#[derive(Clone, Copy, Debug)]
pub enum Start<'a> {
    /// Full multigrid from nothing.
    Cold,
    /// V-cycles from a previous solution (finest level, node order).
    Warm(&'a [[f64; 3]]),
}

/// Parameters of a multigrid solve.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct MultigridParams {
    pub smoother: Smoother,
    /// Pre- and post-smoothing sweeps (nu1, nu2) per level and cycle.
    pub pre_sweeps: u32,
    pub post_sweeps: u32,
    /// Pre- and post-smoothing sweeps on the levels between the finest and the coarsest (the
    /// Galerkin levels, whose rows are the widest); `None`: `pre_sweeps` / `post_sweeps` there too.
    pub coarse_sweeps: Option<u32>,
    pub coarse: CoarseOperator,
    pub interpolation: Interpolation,
    /// Smooth each surface node together with its cell (a 2x2 block per pair; every tetrahedron
    /// has at most one surface face, so the pairs are disjoint) instead of point by point.
    pub surface_blocks: bool,
    /// Smoothed prolongation `P_s = (I - (s / lambda_max) B^-1 K) P` with this `s` (and its
    /// transpose as the restriction); `None`: plain P.
    pub smoothed_prolongation: Option<f64>,
    /// Galerkin only: the prolongation's weights after `steps` Jacobi steps `P -= (s / lambda_max)
    /// D^-1 K P` restricted to its links, constants kept ([`Prolongation::pattern_smoothed`]),
    /// as `(s, steps)`; the links, and so every buffer's size, unchanged. `None`: the weights of
    /// [`Self::interpolation`].
    pub pattern_smoothing: Option<(f64, u32)>,
    /// Galerkin coarse operators with their weak entries (`|K_ij| < theta sqrt(K_ii K_jj)`)
    /// dropped and lumped as [`Self::lumping`] says ([`SparseOperator::sparsified_with`] with
    /// this `theta`), level by level: the next coarser product is made from the sparsified one.
    /// Fewer entries per coarse row; row sums and symmetry kept. `None`: the exact Galerkin
    /// product.
    pub sparsify: Option<f64>,
    /// Where [`Self::sparsify`] moves a dropped entry (module `sparsify`).
    pub lumping: Lumping,
    /// [`Lumping::Paths`]: each path edge's multiple of its share of the dropped weight, 1 to 8
    /// ([`PATH_WEIGHT`] = 2 keeps the energy at least the Galerkin one's; from 1 on no diagonal
    /// decreases).
    pub path_weight: f64,
    /// The next coarser Galerkin product made from the exact (unsparsified) operator, each
    /// level sparsified on its own; `false`: from the sparsified one (fewer entries to multiply).
    pub sparsify_from_full: bool,
    /// How the GPU stores the coarse levels' off-diagonal entries (the CPU solve is f64 either way).
    pub coarse_storage: OperatorStorage,
    /// How the GPU stores the prolongation's links; [`LinkStorage::Packed`] also quantizes the
    /// hierarchy's weights (the CPU solve with these params applies the same prolongation).
    pub link_storage: LinkStorage,
    /// How the GPU stores its per-node vectors (the CPU solve is f64 either way).
    pub vector_storage: VectorStorage,
    /// Where the GPU's finest level reads its operator from (the CPU solve uses its rows).
    pub finest_operator: FinestOperator,
    /// How the GPU stores the smoother's update and the CG's last z (fp16 or as the vectors).
    pub update_storage: UpdateStorage,
    /// Accelerate the V-cycles with (flexible) conjugate gradients: one V-cycle preconditions
    /// each CG iteration. Two dot products per cycle, one more vector (the search direction).
    pub krylov: bool,
    /// Stop once the finest level's relative residual, max over channels of
    /// `||f - K x||_2 / ||f||_2`, is below this.
    pub tolerance: f64,
    /// V-cycles at most (after the full multigrid pass of a cold start).
    pub max_cycles: u32,
    /// Relative residual the coarsest level's CG reaches in every visit.
    pub coarse_tolerance: f64,
    /// V-cycles per level below the finest in the cold start's full multigrid pass (after each
    /// prolongation; the finest level gets one, the CG iterations after it are the better use
    /// of its work): the coarse levels are cheap, more cycles there start the finest closer.
    pub fmg_cycles: u32,
    /// Pre- and post-smoothing steps of the finest level's V-cycle in the cold start's full
    /// multigrid pass (the one V-cycle after the last prolongation); `None`: the cycle's
    /// (`pre_sweeps` / `post_sweeps`). Fewer there is a cheaper start: the CG iterations after it
    /// remove what the start leaves at a better rate per work unit.
    pub fmg_sweeps: Option<(u32, u32)>,
    /// Lanczos (CG) steps for lambda_max of `B^-1 K` (Chebyshev and the smoothed prolongation).
    pub power_iterations: u32,
    /// Where the GPU's warm start starts (the CPU solve takes its start from the caller).
    pub warm_start: WarmStart,
    /// The GPU's warm start relaxed locally where its residual exceeds the tolerance before the
    /// cycles (`None`: not; the CPU solve ignores it).
    pub local_relaxation: Option<LocalRelaxation>,
    /// Coarse-grid corrections (V(0,0) cycles) after the local relaxation, which runs again
    /// between two of them; 0: none; only where the local relaxation runs (the GPU's; the CPU
    /// solve ignores it). At most [`MAX_WARM_CORRECTIONS`].
    pub warm_corrections: u32,
}

impl Default for MultigridParams {
    fn default() -> Self {
        Self {
            smoother: Smoother::Chebyshev { lower: 0.25 },
            pre_sweeps: 2,
            post_sweeps: 2,
            coarse_sweeps: None,
            // why Galerkin + CG (benches/RESULTS.md, "Multigrid (CPU)"): on a 1e4 material
            // contrast the re-discretized coarse operator makes the V-cycle diverge; Galerkin
            // converges at 0.56 per V-cycle, 0.27 with CG, and is also the faster on the default
            // scene (80 against 94 work units to 1e-4 with CG, 142 against 166 without).
            coarse: CoarseOperator::Galerkin,
            interpolation: Interpolation::Shepard,
            surface_blocks: true,
            smoothed_prolongation: None,
            pattern_smoothing: None,
            sparsify: None,
            lumping: Lumping::Paths,
            // why 1, not the bounding 2: measured on the GPU at theta 0.02 (benches/RESULTS.md,
            // "Sparsified coarse operators (wave 8)"), a cycle fewer on the default scene and
            // the 1e4 contrast, the same on the agate.
            path_weight: 1.0,
            sparsify_from_full: false,
            coarse_storage: OperatorStorage::F32,
            link_storage: LinkStorage::F32,
            vector_storage: VectorStorage::Rgb,
            finest_operator: FinestOperator::Csr,
            update_storage: UpdateStorage::F32,
            krylov: true,
            tolerance: 1e-4,
            max_cycles: 100,
            coarse_tolerance: 1e-3,
            fmg_cycles: 1,
            fmg_sweeps: None,
            power_iterations: 20,
            warm_start: WarmStart::Last,
            local_relaxation: None,
            warm_corrections: 0,
        }
    }
}

impl MultigridParams {
    /// The GPU cycle's defaults (`solver::gpu::multigrid`, `translucent render`): [`Self::default`]
    /// with the coarsest level solved to 0.3 (6 Chebyshev steps instead of 21 on the default
    /// scene). Measured in benches/RESULTS.md, "Multigrid time per work unit (wave 5)":
    /// the same 6 CG entries to 1e-4 on the default scene for 41% fewer matrix entries read.
    ///
    /// Wave 6 (benches/RESULTS.md, "Smoother and cycle schedule (wave 6)"): Chebyshev degree 3 on
    /// the finest level (pre and post), degree 2 on the middle levels, on `[0.07, 1] lambda_max`:
    /// the CG factor per cycle 0.23 -> 0.10 on the default scene (0.28 -> 0.13 spot, 0.27 -> 0.11
    /// nefertiti), two CG iterations fewer on all three (6 -> 4 log entries); 63 -> 53-54 work
    /// units (73 before the two-pass CG iteration).
    ///
    /// The coarse levels' entries in fp16 ([`OperatorStorage::F16`]; benches/RESULTS.md, "Coarse
    /// operator and its storage (wave 6)"): the same cycles, work units and J+ to three digits on
    /// the default scene, spot, agate and the 1e4 contrast, 88-93 bytes per finest node less, and
    /// not slower on lavapipe.
    ///
    /// Wave 7 (benches/RESULTS.md, "Interpolation for the coarse correction (wave 7)"): the
    /// prolongation's inner nodes link to the 8 nearest coarse nodes of either kind with
    /// linear-exact weights ([`Interpolation::Mixed`]), then one Jacobi step `s = 1` on those
    /// weights restricted to their links (`pattern_smoothing`), and the Chebyshev interval
    /// `[0.11, 1] lambda_max`: the start residual 0.064 -> 0.021 and full multigrid + 2 CG
    /// iterations instead of + 3 on the default scene, spot and nefertiti (52.0 -> 39.8 work units
    /// on the default scene), the same buffers (2 bytes per node fewer).
    ///
    /// Wave 7 (benches/RESULTS.md, "Multigrid storage (wave 7)"): RGB vectors without a padding
    /// lane ([`VectorStorage::Rgb`]) and the restriction reading the prolongation's own links:
    /// the same cycles, work units and residual, ~100 bytes per finest node less, not measurably
    /// slower on lavapipe. The links stay f32: packed 8-bit weights over the mixed interpolation's
    /// range [-1, 2] (steps of 1/85) cost the default scene a third CG iteration (39.8 -> 51.8
    /// work units) for 37 bytes per node ([`LinkStorage::Packed`], `--link-storage packed`).
    ///
    /// Wave 8 (benches/RESULTS.md, "Matrix-free finest level (wave 8)"): the finest level's
    /// operator read from the cascade's graph textures ([`FinestOperator::Graph`]: 40 bytes per
    /// node less on the default scene, K x equal to the rows' to 1e-7) and the smoother's update
    /// and the CG's last z in fp16 ([`UpdateStorage::F16`]: 8.7 bytes less): the same cycles,
    /// work units and residual to 5 digits on the default scene, spot, nefertiti, marble and the
    /// 1e4 contrast; not measurably slower on lavapipe.
    pub fn gpu() -> Self {
        Self {
            smoother: Smoother::Chebyshev { lower: 0.11 },
            interpolation: Interpolation::Mixed,
            pattern_smoothing: Some((1.0, 1)),
            pre_sweeps: 3,
            post_sweeps: 3,
            coarse_sweeps: Some(2),
            coarse_tolerance: 0.3,
            coarse_storage: OperatorStorage::F16,
            vector_storage: VectorStorage::Rgb,
            finest_operator: FinestOperator::Graph,
            update_storage: UpdateStorage::F16,
            // Wave 8 (benches/RESULTS.md, "Local relaxation of the warm start"): a turning
            // light's warm frame on the default scene, 39.3 -> 29.3 work units (one CG
            // iteration fewer); cold frames do not run it.
            local_relaxation: Some(LocalRelaxation {
                rings: 4,
                sweeps: 16,
            }),
            ..Self::default()
        }
    }

    /// Pre- and post-smoothing sweeps on `level` of a hierarchy whose finest level is `finest`.
    pub fn sweeps_at(&self, level: usize, finest: usize) -> (u32, u32) {
        match self.coarse_sweeps {
            Some(n) if level > 0 && level < finest => (n, n),
            _ => (self.pre_sweeps, self.post_sweeps),
        }
    }

    /// Pre- and post-smoothing steps on `level` in the full multigrid pass
    /// ([`Self::fmg_sweeps`] on the finest level, [`Self::sweeps_at`] elsewhere).
    pub fn fmg_sweeps_at(&self, level: usize, finest: usize) -> (u32, u32) {
        match self.fmg_sweeps {
            Some(s) if level == finest => s,
            _ => self.sweeps_at(level, finest),
        }
    }

    /// V-cycles on `level` in the full multigrid pass of a hierarchy whose finest level is
    /// `finest` ([`Self::fmg_cycles`] below the finest, one on it).
    pub fn fmg_cycles_at(&self, level: usize, finest: usize) -> u32 {
        if level < finest {
            self.fmg_cycles
        } else {
            1
        }
    }

    pub fn validate(&self) -> Result<(), SolverError> {
        let bad = |name, problem: String| Err(SolverError::BadParameter { name, problem });
        options::check_warm_corrections(self.warm_corrections)?;
        match self.smoother {
            Smoother::Jacobi { omega } if !(omega > 0.0 && omega < 2.0) => {
                return bad("omega", format!("{omega} must lie in (0, 2)"));
            }
            Smoother::Chebyshev { lower } if !(lower > 0.0 && lower < 1.0) => {
                return bad("chebyshev lower", format!("{lower} must lie in (0, 1)"));
            }
            _ => {}
        }
        if self.pre_sweeps + self.post_sweeps == 0 || self.pre_sweeps.max(self.post_sweeps) > 64 {
            return bad(
                "sweeps",
                format!(
                    "{} pre + {} post: at least one, at most 64 each",
                    self.pre_sweeps, self.post_sweeps
                ),
            );
        }
        if let Some((s, steps)) = self.pattern_smoothing {
            if !(s > 0.0 && s < 2.0) || steps > 16 {
                return bad(
                    "pattern_smoothing",
                    format!("({s}, {steps}): s in (0, 2), at most 16 steps"),
                );
            }
        }
        if self.fmg_sweeps.is_some_and(|(a, b)| a.max(b) > 64) {
            return bad(
                "fmg_sweeps",
                format!("{:?}: at most 64 each", self.fmg_sweeps),
            );
        }
        if self.coarse_sweeps.is_some_and(|n| n == 0 || n > 64) {
            return bad(
                "coarse_sweeps",
                format!("{:?}: 1 to 64", self.coarse_sweeps),
            );
        }
        if !(self.tolerance.is_finite() && self.tolerance >= 0.0) {
            return bad("tolerance", format!("{} must be >= 0", self.tolerance));
        }
        if !(self.coarse_tolerance > 0.0 && self.coarse_tolerance < 1.0) {
            return bad(
                "coarse_tolerance",
                format!("{} must lie in (0, 1)", self.coarse_tolerance),
            );
        }
        if let Some(theta) = self.sparsify {
            if !(0.0..1.0).contains(&theta) {
                return bad("sparsify", format!("{theta} must lie in [0, 1)"));
            }
        }
        // why at least 1: each dropped edge changes its ends' diagonals by (path_weight - 1) w,
        // and below 1 a coarse diagonal can reach 0 (measured: the 1e4 contrast at 0.5).
        if !(1.0..=8.0).contains(&self.path_weight) {
            return bad(
                "path_weight",
                format!("{} must lie in [1, 8]", self.path_weight),
            );
        }
        if !(1..=8).contains(&self.fmg_cycles) {
            return bad("fmg_cycles", format!("{} must be 1 to 8", self.fmg_cycles));
        }
        if !(1..=1000).contains(&self.power_iterations) {
            return bad(
                "power_iterations",
                format!("{} must be 1 to 1000", self.power_iterations),
            );
        }
        Ok(())
    }
}

/// One level of the hierarchy.
#[derive(Clone, Debug)]
pub struct MultigridLevel {
    pub operator: SparseOperator,
    /// From the next coarser level (`None` on the coarsest).
    pub prolongation: Option<Prolongation>,
    /// Largest eigenvalue of `B^-1 K` per channel (Lanczos, times a 1.05 safety margin).
    pub lambda_max: [f64; 3],
}

impl MultigridLevel {
    pub fn node_count(&self) -> usize {
        self.operator.node_count()
    }

    /// Entries of one operator application: off-diagonals plus the diagonal.
    pub fn operator_entries(&self) -> u64 {
        (self.operator.cols.len() + self.operator.node_count()) as u64
    }

    /// Links of one prolongation or restriction from the coarser level (0 on the coarsest).
    pub fn link_entries(&self) -> u64 {
        self.prolongation
            .as_ref()
            .map_or(0, |p| p.t_fine.len() as u64)
    }
}

/// What one V-cycle (or the full multigrid pass) did.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct CycleReport {
    /// Relative residual of the finest level after the cycle (max over channels).
    pub residual: f64,
    /// `residual / previous residual` (the full multigrid pass: against the right-hand side).
    pub factor: f64,
    /// Work units of this cycle, its residual norm included.
    pub work_units: f64,
}

/// What a multigrid solve did.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct MultigridReport {
    /// Cycles after the start: the full multigrid pass (cold) counts as the first.
    pub cycles: Vec<CycleReport>,
    /// Final relative residual (max over channels).
    pub residual: f64,
    pub converged: bool,
    /// Total work units (node updates / finest nodes).
    pub work_units: f64,
    /// Matrix entries read / entries of one finest-level operator application: the cost in
    /// memory traffic, where a Galerkin coarse level's wide rows count in full.
    pub matvec_units: f64,
    /// Geometric mean of the V-cycles' factors (the full multigrid pass left out); `None` before two.
    pub mean_factor: Option<f64>,
    /// Coarsest-level CG iterations, all visits together.
    pub coarse_iterations: u64,
    /// Smoothing sweeps per level (coarsest first; 0 on the coarsest).
    pub sweeps: Vec<u64>,
}

/// The levels of one graph with one material, ready to solve (build once, solve every frame).
#[derive(Clone, Debug)]
pub struct Hierarchy {
    /// Coarsest first.
    pub levels: Vec<MultigridLevel>,
    /// The finest level's assembled system (its row scaling makes the right-hand side).
    pub finest: LevelOperator,
    pub coarse: CoarseOperator,
}

/// Node updates, counted per level.
#[derive(Default)]
struct Work {
    updates: u64,
    /// Matrix entries read (operator rows with their diagonal, prolongation links).
    entries: u64,
    coarse_iterations: u64,
    sweeps: Vec<u64>,
}

impl Hierarchy {
    /// Assembles the finest level's operator, and the coarse ones as `params.coarse` says.
    pub fn build(
        graph: &QuadGraph,
        material: &MaterialField,
        scheme: Scheme,
        params: &MultigridParams,
    ) -> Result<Self, SolverError> {
        Self::build_with(graph, material, scheme, ExitQuery::Classic, params)
    }

    /// [`Self::build`] with the boundary constants of `exit` on every level
    /// ([`LevelOperator::build_with`]).
    pub fn build_with(
        graph: &QuadGraph,
        material: &MaterialField,
        scheme: Scheme,
        exit: ExitQuery,
        params: &MultigridParams,
    ) -> Result<Self, SolverError> {
        params.validate()?;
        if graph.levels.is_empty() {
            return Err(SolverError::EmptyGraph);
        }
        let finest_index = graph.levels.len() - 1;
        let finest = LevelOperator::build_with(&graph.levels[finest_index], material, scheme, exit)
            .map_err(|e| e.at_level(finest_index))?;
        let mut prolongations: Vec<Option<Prolongation>> = Vec::with_capacity(graph.levels.len());
        for (h, level) in graph.levels.iter().enumerate() {
            prolongations.push(if h == 0 {
                None
            } else {
                let links = level
                    .from_coarser
                    .as_ref()
                    .ok_or(SolverError::MissingLinks { level: h })?;
                let links = match params.interpolation {
                    Interpolation::Shepard => links.clone(),
                    Interpolation::Linear => linear_links(links, level, &graph.levels[h - 1]),
                    Interpolation::Mixed => linear_links(
                        &mixed_links(level, &graph.levels[h - 1]),
                        level,
                        &graph.levels[h - 1],
                    ),
                };
                let links = match params.link_storage {
                    LinkStorage::F32 => links,
                    LinkStorage::Packed => quantized_links(&links).map_err(|e| e.at_level(h))?,
                };
                Some(
                    Prolongation::new(&links, level.node_count(), graph.levels[h - 1].node_count())
                        .map_err(|e| e.at_level(h))?,
                )
            });
        }
        let mut operators: Vec<SparseOperator> = Vec::with_capacity(graph.levels.len());
        match params.coarse {
            CoarseOperator::Rediscretized => {
                for (h, level) in graph.levels.iter().enumerate().take(finest_index) {
                    let op = LevelOperator::build_with(level, material, scheme, exit)
                        .map_err(|e| e.at_level(h))?;
                    operators.push(SparseOperator::from_level(&op));
                }
                operators.push(SparseOperator::from_level(&finest));
            }
            CoarseOperator::Galerkin => {
                let mut k = SparseOperator::from_level(&finest);
                let mut down = Vec::with_capacity(graph.levels.len());
                let mut level_own: Option<SparseOperator> = None;
                for p in prolongations.iter_mut().skip(1).rev().flatten() {
                    if let Some((s, steps)) = params.pattern_smoothing {
                        let lambda = largest_eigenvalue(&k, params.power_iterations);
                        *p = p.pattern_smoothed(&k, lambda.map(|l| s / l), steps)?;
                    }
                    // why two operators: with `sparsify_from_full` the next product is made
                    // from `k`, the exact one, while the level keeps its sparsified `own`.
                    let full = p.galerkin(&k);
                    let (next, own) = match params.sparsify {
                        Some(theta) => {
                            let sparse =
                                full.sparsified_with(theta, params.lumping, params.path_weight);
                            if params.sparsify_from_full {
                                (full, Some(sparse))
                            } else {
                                (sparse, None)
                            }
                        }
                        None => (full, None),
                    };
                    let fine = std::mem::replace(&mut k, next);
                    down.push(level_own.take().unwrap_or(fine));
                    level_own = own;
                }
                down.push(level_own.unwrap_or(k));
                down.reverse();
                operators = down;
            }
        }
        let levels = operators
            .into_iter()
            .zip(prolongations)
            .enumerate()
            .map(|(h, (mut operator, prolongation))| {
                if params.surface_blocks {
                    operator.pair_surface_nodes(&graph.levels[h]);
                }
                if operator
                    .diag
                    .iter()
                    .flatten()
                    .any(|&d| !(d > 0.0 && d.is_finite()))
                {
                    return Err(SolverError::NonFinite {
                        what: format!("level {h}: a multigrid operator's diagonal (must be > 0)"),
                    });
                }
                let lambda_max = if matches!(params.smoother, Smoother::Chebyshev { .. })
                    || params.smoothed_prolongation.is_some()
                {
                    largest_eigenvalue(&operator, params.power_iterations)
                        .map(|l| LAMBDA_MARGIN * l)
                } else {
                    [2.0; 3]
                };
                Ok(MultigridLevel {
                    operator,
                    prolongation,
                    lambda_max,
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Self {
            levels,
            finest,
            coarse: params.coarse,
        })
    }

    /// The finest level's scaled right-hand side `S b` for surface irradiance `q`.
    pub fn scaled_rhs(&self, q: &[[f64; 3]]) -> Field {
        self.scale(&self.finest.rhs(q))
    }

    /// `S b` of an unscaled right-hand side `b` of the finest level.
    pub fn scale(&self, b: &[[f64; 3]]) -> Field {
        b.iter()
            .zip(&self.finest.row_scale)
            .map(|(v, &s)| v.map(|x| x * s))
            .collect()
    }

    fn finest_count(&self) -> usize {
        self.levels.last().map_or(0, MultigridLevel::node_count)
    }

    /// Relative residual per channel of the finest level, `||f - K x||_2 / ||f||_2` (absolute
    /// where f = 0): the stopping rule.
    pub fn relative_residual(&self, x: &[[f64; 3]], f: &[[f64; 3]]) -> [f64; 3] {
        let Some(level) = self.levels.last() else {
            return [0.0; 3];
        };
        let mut r = vec![[0.0; 3]; x.len()];
        level.operator.residual(x, f, &mut r);
        let (rn, fn_) = (norm2(&r), norm2(f));
        std::array::from_fn(|c| if fn_[c] > 0.0 { rn[c] / fn_[c] } else { rn[c] })
    }

    /// Solves `K x = f` on the finest level (f scaled: [`Self::scaled_rhs`]). `observe` is called
    /// after every cycle with the current solution (for measurements; the solve does not read it).
    pub fn solve(
        &self,
        f: &[[f64; 3]],
        start: Start,
        params: &MultigridParams,
        observe: &mut dyn FnMut(&[[f64; 3]], &CycleReport),
    ) -> (Field, MultigridReport) {
        let n = self.finest_count();
        let top = self.levels.len() - 1;
        let mut work = Work {
            sweeps: vec![0; self.levels.len()],
            ..Work::default()
        };
        let mut cycles = Vec::new();
        let mut x: Field;
        let mut residual;
        let per = |updates: u64| updates as f64 / n.max(1) as f64;
        let mut counted = 0u64;
        match start {
            Start::Warm(previous) if previous.len() == n => {
                x = previous.to_vec();
                residual = max3(self.relative_residual(&x, f));
                work.updates += n as u64;
                work.entries += self.levels[top].operator_entries();
            }
            _ => {
                // Full multigrid: right-hand sides restricted down, coarsest solved, then one
                // V-cycle per level going up from the prolonged coarser solution.
                let mut rhs: Vec<Field> = vec![f.to_vec()];
                for l in (1..=top).rev() {
                    let Some(p) = self.levels[l].prolongation.as_ref() else {
                        break;
                    };
                    let mut coarse = vec![[0.0; 3]; p.coarse_count()];
                    p.restrict(&rhs[rhs.len() - 1], &mut coarse);
                    work.updates += self.levels[l].node_count() as u64;
                    work.entries += self.levels[l].link_entries();
                    rhs.push(coarse);
                }
                rhs.reverse();
                x = vec![[0.0; 3]; self.levels[0].node_count()];
                self.coarse_solve(&mut x, &rhs[0], params, &mut work);
                for (l, rhs_l) in rhs.iter().enumerate().skip(1) {
                    let mut up = vec![[0.0; 3]; self.levels[l].node_count()];
                    if let Some(p) = &self.levels[l].prolongation {
                        p.prolong_add(&x, &mut up);
                    }
                    work.updates += self.levels[l].node_count() as u64;
                    work.entries += self.levels[l].link_entries();
                    let sweeps = params.fmg_sweeps_at(l, top);
                    for _ in 0..params.fmg_cycles_at(l, top) {
                        self.v_cycle_with(l, &mut up, rhs_l, params, &mut work, sweeps);
                    }
                    x = up;
                }
                residual = max3(self.relative_residual(&x, f));
                work.updates += n as u64;
                work.entries += self.levels[top].operator_entries();
                let report = CycleReport {
                    residual,
                    factor: residual,
                    work_units: per(work.updates),
                };
                counted = work.updates;
                observe(&x, &report);
                cycles.push(report);
            }
        }
        let mut v_factors = Vec::new();
        let mut going = residual >= params.tolerance && params.max_cycles > cycles.len() as u32;
        let mut step = |x: &Field, next: f64, residual: &mut f64, work: &Work| -> bool {
            let factor = if *residual > 0.0 {
                next / *residual
            } else {
                0.0
            };
            v_factors.push(factor);
            let report = CycleReport {
                residual: next,
                factor,
                work_units: per(work.updates - counted),
            };
            counted = work.updates;
            observe(x, &report);
            cycles.push(report);
            *residual = next;
            next.is_finite()
                && next < DIVERGED
                && next >= params.tolerance
                && (cycles.len() as u32) < params.max_cycles
        };
        if params.krylov {
            // Flexible preconditioned CG with one V-cycle as the preconditioner (Notay 2000):
            // the V-cycle's slow modes are few, CG removes them.
            let fnorm = norm2(f).map(|v| if v > 0.0 { v } else { 1.0 });
            let k = &self.levels[top].operator;
            let mut r = vec![[0.0; 3]; n];
            k.residual(&x, f, &mut r);
            work.updates += n as u64;
            work.entries += self.levels[top].operator_entries();
            let mut z_old: Field = vec![[0.0; 3]; n];
            let mut p: Field = vec![[0.0; 3]; n];
            let mut rz_old = [0.0; 3];
            let mut kp = vec![[0.0; 3]; n];
            let mut first = true;
            while going {
                let mut z = vec![[0.0; 3]; n];
                self.v_cycle(top, &mut z, &r, params, &mut work);
                let rz = dot(&r, &z);
                let rdz = if first {
                    rz
                } else {
                    let mut dz = z.clone();
                    for (d, o) in dz.iter_mut().zip(&z_old) {
                        for c in 0..3 {
                            d[c] -= o[c];
                        }
                    }
                    dot(&r, &dz)
                };
                for (pi, zi) in p.iter_mut().zip(&z) {
                    for c in 0..3 {
                        let beta = if first || rz_old[c] == 0.0 {
                            0.0
                        } else {
                            rdz[c] / rz_old[c]
                        };
                        pi[c] = zi[c] + beta * pi[c];
                    }
                }
                first = false;
                k.apply(&p, &mut kp);
                let pkp = dot(&p, &kp);
                let alpha: [f64; 3] =
                    std::array::from_fn(|c| if pkp[c] > 0.0 { rz[c] / pkp[c] } else { 0.0 });
                for ((xi, ri), (pi, kpi)) in x.iter_mut().zip(r.iter_mut()).zip(p.iter().zip(&kp)) {
                    for c in 0..3 {
                        xi[c] += alpha[c] * pi[c];
                        ri[c] -= alpha[c] * kpi[c];
                    }
                }
                // K p, then one pass updating x, r and reducing the norms.
                work.updates += 2 * n as u64;
                work.entries += self.levels[top].operator_entries() + n as u64;
                rz_old = rz;
                z_old = z;
                let rn = norm2(&r);
                let next = max3(std::array::from_fn(|c| rn[c] / fnorm[c]));
                going = step(&x, next, &mut residual, &work);
            }
        } else {
            while going {
                self.v_cycle(top, &mut x, f, params, &mut work);
                let next = max3(self.relative_residual(&x, f));
                work.updates += n as u64;
                work.entries += self.levels[top].operator_entries();
                going = step(&x, next, &mut residual, &work);
            }
        }
        let mean_factor = (v_factors.len() >= 2).then(|| {
            let logs: f64 = v_factors.iter().map(|f| f.max(1e-300).ln()).sum();
            (logs / v_factors.len() as f64).exp()
        });
        let report = MultigridReport {
            cycles,
            residual,
            converged: residual < params.tolerance,
            work_units: per(work.updates),
            matvec_units: work.entries as f64 / self.levels[top].operator_entries().max(1) as f64,
            mean_factor,
            coarse_iterations: work.coarse_iterations,
            sweeps: work.sweeps,
        };
        (x, report)
    }

    /// One V-cycle on level `l` (gamma = 1).
    fn v_cycle(
        &self,
        l: usize,
        x: &mut Field,
        f: &[[f64; 3]],
        params: &MultigridParams,
        work: &mut Work,
    ) {
        let sweeps = params.sweeps_at(l, self.levels.len() - 1);
        self.v_cycle_with(l, x, f, params, work, sweeps);
    }

    /// [`Self::v_cycle`] with `(pre, post)` smoothing steps on level `l` (the levels below it
    /// keep the cycle's).
    fn v_cycle_with(
        &self,
        l: usize,
        x: &mut Field,
        f: &[[f64; 3]],
        params: &MultigridParams,
        work: &mut Work,
        (pre, post): (u32, u32),
    ) {
        if l == 0 {
            self.coarse_solve(x, f, params, work);
            return;
        }
        let level = &self.levels[l];
        let n = level.node_count();
        self.smooth(l, x, f, pre, params, work);
        let mut r = vec![[0.0; 3]; n];
        level.operator.residual(x, f, &mut r);
        let Some(p) = level.prolongation.as_ref() else {
            return;
        };
        let k = &level.operator;
        let smoothing = params
            .smoothed_prolongation
            .map(|s| level.lambda_max.map(|l| s / l));
        if let Some(omega) = smoothing {
            // P_s^T r = P^T (I - omega K B^-1) r.
            let mut z = vec![[0.0; 3]; n];
            k.precondition(&r, &mut z);
            let mut kz = vec![[0.0; 3]; n];
            k.apply(&z, &mut kz);
            for (ri, kzi) in r.iter_mut().zip(&kz) {
                for c in 0..3 {
                    ri[c] -= omega[c] * kzi[c];
                }
            }
            work.updates += n as u64;
            work.entries += level.operator_entries();
        }
        let mut fc = vec![[0.0; 3]; p.coarse_count()];
        p.restrict(&r, &mut fc);
        let mut xc = vec![[0.0; 3]; p.coarse_count()];
        work.updates += 2 * n as u64;
        work.entries += level.operator_entries() + level.link_entries();
        self.v_cycle(l - 1, &mut xc, &fc, params, work);
        match smoothing {
            None => p.prolong_add(&xc, x),
            Some(omega) => {
                // P_s e = (I - omega B^-1 K) P e.
                let mut e = vec![[0.0; 3]; n];
                p.prolong_add(&xc, &mut e);
                let mut ke = vec![[0.0; 3]; n];
                k.apply(&e, &mut ke);
                let mut z = vec![[0.0; 3]; n];
                k.precondition(&ke, &mut z);
                for ((xi, ei), zi) in x.iter_mut().zip(&e).zip(&z) {
                    for c in 0..3 {
                        xi[c] += ei[c] - omega[c] * zi[c];
                    }
                }
                work.updates += n as u64;
                work.entries += level.operator_entries();
            }
        }
        work.updates += n as u64;
        work.entries += level.link_entries();
        self.smooth(l, x, f, post, params, work);
    }

    /// `sweeps` smoothing sweeps on level `l` (damped Jacobi, or one Chebyshev polynomial of that
    /// degree).
    fn smooth(
        &self,
        l: usize,
        x: &mut Field,
        f: &[[f64; 3]],
        sweeps: u32,
        params: &MultigridParams,
        work: &mut Work,
    ) {
        if sweeps == 0 {
            return;
        }
        let level = &self.levels[l];
        let k = &level.operator;
        work.updates += u64::from(sweeps) * k.node_count() as u64;
        work.entries += u64::from(sweeps) * level.operator_entries();
        work.sweeps[l] += u64::from(sweeps);
        match params.smoother {
            Smoother::Jacobi { omega } => {
                let mut next = x.clone();
                for _ in 0..sweeps {
                    damped_jacobi_sweep(k, x, f, omega, &mut next);
                    std::mem::swap(x, &mut next);
                }
            }
            Smoother::Chebyshev { lower } => {
                let mut d = vec![[0.0; 3]; x.len()];
                let bounds = level.lambda_max.map(|hi| (lower * hi, hi));
                let mut next = x.clone();
                for step in 0..sweeps {
                    let c = chebyshev_coefficients(bounds, step);
                    chebyshev_sweep(k, x, f, &mut d, c, &mut next);
                    std::mem::swap(x, &mut next);
                }
            }
        }
    }

    /// Coarsest level: Jacobi-preconditioned CG from `x` to a relative residual of
    /// `params.coarse_tolerance`.
    fn coarse_solve(
        &self,
        x: &mut Field,
        f: &[[f64; 3]],
        params: &MultigridParams,
        work: &mut Work,
    ) {
        let k = &self.levels[0].operator;
        let iterations = pcg(
            k,
            f,
            x,
            params.coarse_tolerance,
            20 * k.node_count().max(10),
        );
        work.coarse_iterations += iterations as u64;
        work.updates += (iterations as u64 + 1) * k.node_count() as u64;
        work.entries += (iterations as u64 + 1) * self.levels[0].operator_entries();
    }

    /// The unscaled (GPU) form of the restriction: from the Jacobi residual `r_jac = D^-1 (b - A x)`
    /// of level `l` to the coarser level's Jacobi-form right-hand side
    /// `rhs_c = (1 / m_c) P^T (m r_jac)`, m = diag K the node masses. Equal to [`Prolongation::restrict`]
    /// of the scaled residual, divided by the coarse diagonal.
    pub fn restrict_jacobi_residual(&self, l: usize, r_jac: &[[f64; 3]]) -> Option<Field> {
        let level = self.levels.get(l)?;
        let p = level.prolongation.as_ref()?;
        let coarse = &self.levels[l - 1].operator;
        let scaled: Field = r_jac
            .iter()
            .zip(&level.operator.diag)
            .map(|(r, m)| std::array::from_fn(|c| r[c] * m[c]))
            .collect();
        let mut out = vec![[0.0; 3]; p.coarse_count()];
        p.restrict(&scaled, &mut out);
        for (o, m) in out.iter_mut().zip(&coarse.diag) {
            for c in 0..3 {
                o[c] /= m[c];
            }
        }
        Some(out)
    }

    /// One damped Jacobi sweep of level `l` in the unscaled (GPU) form, `x + omega (rhs_jac +
    /// sum_k w_ik x_k - x)` with `w = -K_ik / K_ii` and `rhs_jac = f / K_ii`.
    pub fn damped_sweep(&self, l: usize, x: &[[f64; 3]], f: &[[f64; 3]], omega: f64) -> Field {
        let mut out = x.to_vec();
        damped_jacobi_sweep(&self.levels[l].operator, x, f, omega, &mut out);
        out
    }
}
