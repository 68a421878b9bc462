//! Render passes: shadow map, irradiance gathering, final shading, tone mapping, capture.

mod laplace;

pub use laplace::{JacobiPush, LaplaceJacobiPass};

/// Bad scene or frame description, or a failing pass.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error("{what}: {problem}")]
    Invalid { what: String, problem: String },
    #[error(transparent)]
    Vk(#[from] crate::vk::VkError),
    #[error(transparent)]
    Shader(#[from] crate::shader::ShaderError),
}
