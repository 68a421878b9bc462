//! The QuadGraph bake (DESIGN section 3; paper sections 4.1, 4.3 and 5.1).

pub mod graph;

/// A bake that cannot proceed.
#[derive(Debug, thiserror::Error)]
pub enum BakeError {
    #[error("bake: {0}")]
    Invalid(String),
}
