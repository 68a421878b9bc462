//! The diffusion solvers: f64 CPU reference and (later) the GPU frame.

/// Solver failures.
#[derive(Debug, thiserror::Error)]
pub enum SolverError {
    #[error("solver: {0}")]
    Invalid(String),
}
