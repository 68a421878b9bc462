//! Render passes: shadow map, final shading, capture; and headless rendering on top of them.
//!
//! A pass owns its pipelines and persistent images and has one `record` method with explicit
//! inputs and outputs; barriers inside a pass are its own, and each resource carries the
//! [`crate::vk::Access`] state it was left in for the next user.
//!
//! - [`ShadowMaps`]: a depth map per shadow-casting light (directional, spot, point cube) in one
//!   atlas; [`IrradiancePass`]: q at the surface nodes of a level from lights, shadows, environment.
//! - [`MeshPass`]: the final shading of DESIGN section 5 from per-vertex exitance J+; its
//!   specular shadow reads the same atlas (no separate depth pass).
//! - [`LaplaceJacobiPass`]: the ping-pong compute pattern on a problem with a known solution.
//!
//! Every pass declares its resources (`uses`) and records inside a pass of a
//! [`crate::frame::FrameGraph`], which places the barriers between passes. Nothing here knows
//! about the solvers; whole frames are composed in [`crate::TranslucentObject`] and rendered
//! headless by [`crate::headless`].

mod irradiance;
mod laplace;
mod mesh_pass;
mod shadow_maps;
mod target;

pub use irradiance::{
    q_scale_for, BeamSource, GatherLevel, GatherLight, GatherPush, GatherScene, GatherView,
    IrradiancePass, SurfaceImages, FP16_MAX, Q_FORMAT, SURFACE_NORMAL_FORMAT,
    SURFACE_POSITION_FORMAT,
};
pub use laplace::{JacobiPush, LaplaceJacobiPass};
pub use mesh_pass::{
    environment_sh, own_light_uniforms, MeshPass, ShadeAttachments, ShadePush, ShadeUniforms,
};
pub use shadow_maps::{
    LightViews, ShadowMaps, ShadowMapsDesc, ShadowPush, ShadowView, MAX_LIGHTS, MAX_SHADOW_VIEWS,
    SHADOW_ATLAS_FORMAT, SHADOW_SLOPE_BIAS,
};
pub use target::{OffscreenTarget, COLOR_FORMAT, DEPTH_FORMAT};

/// Bad scene or frame description, or a failing pass.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error("{what}: {problem}")]
    Invalid { what: String, problem: String },
    #[error(transparent)]
    Vk(#[from] crate::vk::VkError),
    #[error(transparent)]
    Shader(#[from] crate::shader::ShaderError),
    #[error(transparent)]
    Scene(#[from] crate::scene::SceneError),
}
