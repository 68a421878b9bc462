//! Optical coefficients, presets and heterogeneous volumes (DESIGN section 2).

/// Bad material input.
#[derive(Debug, thiserror::Error)]
pub enum MaterialError {
    #[error("invalid material: {0}")]
    Invalid(String),
}
