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
//! - [`HeadlessRenderer`] / [`render_headless`]: a whole frame into an [`OffscreenTarget`],
//!   read back with per-pass GPU times. Until the diffusion solver exists, J+ comes from
//!   [`lambert_exitance`]; a solver's per-vertex J+ goes into [`Scene::exitance`].
//! - [`LaplaceJacobiPass`]: the ping-pong compute pattern on a problem with a known solution.
//!
//! ```no_run
//! use translucent::render::{FrameDesc, HeadlessRenderer, Scene};
//! use translucent::scene::Light;
//! use translucent::vk::{Context, ContextDesc};
//! # fn main() -> Result<(), translucent::Error> {
//! let ctx = Context::headless(&ContextDesc::default())?;
//! let mut scene = Scene::procedural("sphere", 50.0, vec![Light::default_light()], 1.3)?;
//! // scene.exitance = solver_output; // one [r, g, b] J+ per vertex of scene.mesh
//! let mut renderer = HeadlessRenderer::new(&ctx, &scene, &FrameDesc::default())?;
//! let frame = renderer.render_frame(&ctx)?;
//! println!("{:?}", frame.passes); // {"capture": .., "shading": .., "shadow_map": ..}
//! frame.image.write_exr(std::path::Path::new("sphere.exr"))?;
//! # Ok(()) }
//! ```

mod irradiance;
mod laplace;
mod mesh_pass;
mod shadow_maps;
mod target;

pub use irradiance::{
    q_scale_for, GatherLevel, GatherLight, GatherPush, GatherScene, GatherView, IrradiancePass,
    SurfaceImages, FP16_MAX, Q_FORMAT, SURFACE_NORMAL_FORMAT, SURFACE_POSITION_FORMAT,
};
pub use laplace::{JacobiPush, LaplaceJacobiPass};
pub use mesh_pass::{environment_sh, MeshPass, ShadeAttachments, ShadePush, ShadeUniforms};
pub use shadow_maps::{
    LightViews, ShadowMaps, ShadowMapsDesc, ShadowPush, ShadowView, MAX_LIGHTS, MAX_SHADOW_VIEWS,
    SHADOW_ATLAS_FORMAT,
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
