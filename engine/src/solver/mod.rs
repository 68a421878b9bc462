//! The diffusion solvers: the f64 CPU reference (this module) and, later, the GPU frame.
//!
//! - [`analytic`]: closed-form solutions (sphere, slab, semi-infinite medium), the oracles.
//! - [`operator`]: the assembled linear system of one level (`fv` or `paper` scheme).
//! - [`krylov`]: exact solves (PCG, BiCGSTAB) of that system.
//! - [`multigrid`]: V-cycles and full multigrid over the levels (DESIGN section 5.1), the f64
//!   prototype of the GPU schedule.
//! - [`cpu`]: the entry point: multi-level Jacobi (paper section 4.3) and/or an exact solve,
//!   outgoing current J+, radiance, energy balance.
//! - [`transport`], [`sources`], [`single_scattering`], [`bounce`]: the terms beyond the
//!   boundary-flux model (DESIGN sections 2.5-2.8, issue 12): the exit query from the Fresnel
//!   moments, the collimated and second-collision sources, single scattering, one bounce.
//! - [`dipole`]: the third method, hierarchical boundary elements with the dipole BSSRDF
//!   (Mertens et al. 2003).

pub mod analytic;
pub mod bounce;
pub mod cpu;
pub mod dipole;
pub mod gpu;
pub mod krylov;
pub mod multigrid;
pub mod operator;
pub mod single_scattering;
pub mod sources;
pub mod transport;
pub mod voxel;

pub use cpu::{solve, CpuSolution, CpuSolveParams, Energy, Schedule};
pub use operator::Scheme;

/// Solver failures: bad graphs, materials, scenes or parameters, each naming the problem.
#[derive(Debug, thiserror::Error)]
pub enum SolverError {
    #[error("solver: {0}")]
    Invalid(String),
    #[error("solver: the QuadGraph has no levels")]
    EmptyGraph,
    #[error("solver: level {level}: {problem}")]
    BadGraph { level: usize, problem: String },
    #[error("solver: level {level}, node {node}: degenerate geometry: {problem}")]
    DegenerateGeometry {
        level: usize,
        node: usize,
        problem: String,
    },
    #[error("solver: material at node {node} ({position}): {source}")]
    BadMaterialAt {
        node: usize,
        position: glam::DVec3,
        #[source]
        source: crate::material::MaterialError,
    },
    #[error("solver: {0}")]
    Material(#[from] crate::material::MaterialError),
    #[error("solver: {0}")]
    Scene(#[from] crate::scene::SceneError),
    #[error("solver: parameter {name}: {problem}")]
    BadParameter { name: &'static str, problem: String },
    #[error("solver: level {level} has no Shepard links from the coarser level (the bake must provide them for multi-level solves)")]
    MissingLinks { level: usize },
    #[error("solver: {what} is not finite")]
    NonFinite { what: String },
    #[error("solver: multigrid diverged: relative residual {residual:.2e} after {cycles} cycles ({hint})")]
    Diverged {
        residual: f64,
        cycles: usize,
        hint: &'static str,
    },
    /// The GPU multigrid's cycles stopped Diverged: a relative residual above the divergence
    /// bound, or a non-finite one (`multigrid/check.comp` logs NaN/Inf as the float maximum).
    #[error("solver: GPU multigrid diverged: relative residual {} after {cycles} cycles (start {}) on {levels} levels, coarsest level {coarsest_nodes} nodes, caught by the finest level's residual check; no image is written: use --schedule cascade, or more --levels so the coarsest level is small", describe_residual(*residual), describe_residual(*start_residual))]
    GpuDiverged {
        residual: f64,
        start_residual: f64,
        cycles: usize,
        levels: usize,
        coarsest_nodes: usize,
    },
    #[error(transparent)]
    Dipole(#[from] dipole::DipoleError),
}

/// A relative residual for an error message: `non-finite` where `multigrid/check.comp` logged
/// a NaN/Inf as the float maximum.
fn describe_residual(r: f64) -> String {
    // why: check.comp writes 3.4e38 for NaN/Inf; no finite relative residual comes near it.
    const NON_FINITE_MARK: f64 = 3.0e38;
    if !r.is_finite() || r >= NON_FINITE_MARK {
        "non-finite (NaN/Inf)".to_string()
    } else {
        format!("{r:.2e}")
    }
}

impl SolverError {
    /// Fills in the level of a per-level error.
    pub(crate) fn at_level(mut self, at: usize) -> Self {
        match &mut self {
            Self::BadGraph { level, .. } | Self::DegenerateGeometry { level, .. } => *level = at,
            _ => {}
        }
        self
    }
}

/// Relative RMS difference `||got - want|| / ||want||` over every channel of every node (the
/// absolute RMS norm of the difference when `want` is all zero). Lengths must match.
///
/// ```
/// let got = [[1.1f32, 2.0, 0.0]];
/// let want = [[1.0, 2.0, 0.0]];
/// let e = translucent::solver::rel_rms(&got, &want);
/// assert!((e - 0.1 / 5f64.sqrt()).abs() < 1e-6);
/// ```
pub fn rel_rms<A: Copy + Into<f64>>(got: &[[A; 3]], want: &[[f64; 3]]) -> f64 {
    assert_eq!(got.len(), want.len(), "rel_rms of different lengths");
    let (mut d2, mut r2) = (0.0, 0.0);
    for (g, w) in got.iter().zip(want) {
        for c in 0..3 {
            let g: f64 = g[c].into();
            d2 += (g - w[c]).powi(2);
            r2 += w[c] * w[c];
        }
    }
    if r2 > 0.0 {
        (d2 / r2).sqrt()
    } else {
        d2.sqrt()
    }
}
