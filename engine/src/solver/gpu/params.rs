//! What a GPU solve is asked for: storage precision and [`GpuSolveParams`].

use super::*;

/// How phi is stored (DESIGN section 4).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Precision {
    /// phi RGBA32F, correction sweeps in RGBA16F against the fp32 residual (the default).
    #[default]
    Mixed,
    /// phi RGBA16F ping-pong (the paper's state; stalls on fine levels).
    Fp16,
    /// phi RGBA32F ping-pong.
    Fp32,
}

impl std::str::FromStr for Precision {
    type Err = SolverError;
    fn from_str(s: &str) -> Result<Self, SolverError> {
        match s {
            "mixed" => Ok(Self::Mixed),
            "fp16" => Ok(Self::Fp16),
            "fp32" => Ok(Self::Fp32),
            _ => Err(SolverError::BadParameter {
                name: "precision",
                problem: format!("'{s}' (expected mixed, fp16 or fp32)"),
            }),
        }
    }
}

/// Parameters of [`GpuDiffusion`].
#[derive(Clone, Debug)]
pub struct GpuSolveParams {
    pub scheme: Scheme,
    pub precision: Precision,
    /// Iteration cap per level, coarsest first; the last entry repeats. Rounded up to whole blocks.
    pub iterations: Vec<u32>,
    /// Iterations per block (even, >= 2): the convergence test runs after each block.
    pub block: u32,
    /// Stop a level once (max|dphi| / max|phi|) / (1 - rho) is below this (0: never early).
    pub tolerance: f32,
    /// Start every level from the previous solve's phi instead of Shepard resampling (DESIGN
    /// section 5: light or material changes), each finer level corrected by the coarser level's
    /// change, phi_h += P(phi_(h-1),new - phi_(h-1),prev) (`shepard/warm_correct.glsl`); the first
    /// solve, and the first after [`GpuDiffusion::set_q_scale`], still initialises. The skipped
    /// init is absent from the profiler output; the correction is [`PASS_WARM`].
    pub warm_start: bool,
}

impl Default for GpuSolveParams {
    fn default() -> Self {
        Self {
            scheme: Scheme::Fv,
            precision: Precision::Mixed,
            iterations: vec![200],
            block: 8,
            tolerance: 1e-4,
            warm_start: false,
        }
    }
}
