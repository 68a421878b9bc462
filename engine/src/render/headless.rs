//! Headless rendering: [`HeadlessRenderer`] records shadow map, shading and capture into one
//! command buffer per frame, submits, waits and returns the linear image and per-pass GPU times.
//! [`HeadlessRenderer::render_object`] does the same for a [`crate::TranslucentObject`], which
//! records into the renderer's command buffer and target exactly as into a host's.

use std::collections::BTreeMap;

use glam::Vec3;

use super::mesh_pass::{environment_sh, MeshPass, ShadePush, ShadeUniforms};
use super::scene::{FrameDesc, Scene};
use super::shadow_maps::{ShadowMaps, ShadowMapsDesc};
use super::target::{OffscreenTarget, COLOR_FORMAT, DEPTH_FORMAT};
use super::RenderError;
use crate::mesh::GpuMesh;
use crate::scene::{Camera, RadianceMode};
use crate::vk::{Access, Context, FrameTimings, GpuProfiler, ImageReadback, LinearImage};

// Only the specular term reads it; 512 keeps lavapipe (CI) fast.
const SHADOW_RESOLUTION: u32 = 512;

/// One rendered frame.
#[derive(Clone, Debug)]
pub struct Captured {
    /// Linear radiance, row 0 at the top; background 0.
    pub image: LinearImage,
    /// GPU milliseconds per pass of this frame (absent: skipped, or no timestamps on the device).
    pub passes: BTreeMap<String, f64>,
    /// The frame's timestamp scopes (for [`crate::vk::FrameTimings::chrome_trace`]).
    pub timings: Option<FrameTimings>,
    pub frame: u64,
}

/// Persistent passes and target for rendering a [`Scene`] repeatedly, as a host would.
pub struct HeadlessRenderer {
    mesh: GpuMesh,
    /// One view: the specular light's (the shading pass's shadow lookup).
    shadow: ShadowMaps,
    shading: MeshPass,
    target: OffscreenTarget,
    readback: ImageReadback,
    profiler: GpuProfiler,
    uniforms: ShadeUniforms,
    push: ShadePush,
    /// The displayed mesh, kept for [`HeadlessRenderer::set_exitance`].
    surface: crate::mesh::TriMesh,
    /// `FrameDesc::specular`: also gates the environment's mirror reflection.
    specular: bool,
}

impl HeadlessRenderer {
    pub fn new(
        ctx: &Context,
        scene: &Scene,
        frame: &FrameDesc,
    ) -> Result<HeadlessRenderer, RenderError> {
        let invalid = |what: &str, problem: String| RenderError::Invalid {
            what: what.into(),
            problem,
        };
        if !(scene.eta.is_finite() && scene.eta > 0.0) {
            return Err(invalid(
                "eta",
                format!("{} is not a positive index ratio", scene.eta),
            ));
        }
        if !(frame.roughness.is_finite() && frame.roughness > 0.0 && frame.roughness <= 1.0) {
            return Err(invalid(
                "roughness",
                format!("{} is not in (0, 1]", frame.roughness),
            ));
        }
        for light in &scene.lights {
            light.validate()?;
        }
        let aspect = f64::from(frame.width) / f64::from(frame.height.max(1));
        let (centre, radius) = scene.bounding_sphere();
        let camera = frame
            .camera
            .unwrap_or_else(|| Camera::framing(centre, radius, aspect));
        camera.validate()?;
        let target = OffscreenTarget::new(ctx, frame.width, frame.height)?;
        let mesh = GpuMesh::new(ctx, &scene.mesh, &scene.exitance)?;
        let mut shadow = ShadowMaps::new(
            ctx,
            &ShadowMapsDesc {
                tile_resolution: SHADOW_RESOLUTION,
                max_views: 1,
            },
        )?;
        let shading = MeshPass::new(ctx, &shadow.atlas, COLOR_FORMAT, DEPTH_FORMAT)?;
        let readback = ImageReadback::new(ctx, &target.color)?;
        // Room for a GPU solve recorded before the frame (scopes per Jacobi block).
        let profiler = GpuProfiler::new(ctx, "headless frame", 4096)?;

        // Only the specular light casts a shadow here: the first directional one.
        let light = scene
            .lights
            .iter()
            .find(|l| matches!(l, crate::scene::Light::Directional { .. }))
            .filter(|_| frame.specular);
        let specular_light: Vec<crate::scene::Light> = light.into_iter().cloned().collect();
        shadow.set_lights(&specular_light, scene.bounding_sphere(), true)?;
        let view = shadow.atlas_view_proj(0);
        let (light_view_proj, light_dir, irradiance) = match (light, view) {
            (
                Some(crate::scene::Light::Directional {
                    direction,
                    irradiance,
                }),
                Some(m),
            ) => (
                m,
                direction.normalize().as_vec3().extend(1.0),
                irradiance.map(|e| e as f32),
            ),
            _ => (glam::Mat4::IDENTITY, Vec3::ZERO.extend(0.0), [0.0; 3]),
        };
        let uniforms = ShadeUniforms {
            view_proj: camera.view_proj(aspect, centre, radius).to_cols_array(),
            light_view_proj: light_view_proj.to_cols_array(),
            camera_pos: camera.eye.as_vec3().extend(1.0).to_array(),
            light_dir: light_dir.to_array(),
            light_irradiance: [irradiance[0], irradiance[1], irradiance[2], 0.0],
            env_sh: [[0.0; 4]; 9],
        };
        let push = ShadePush {
            eta: scene.eta as f32,
            radiance_mode: match frame.radiance {
                RadianceMode::Physical => 0,
                RadianceMode::Paper => 1,
            },
            roughness: frame.roughness,
            specular: u32::from(view.is_some()),
        };
        Ok(HeadlessRenderer {
            mesh,
            shadow,
            shading,
            target,
            readback,
            profiler,
            uniforms,
            push,
            surface: scene.mesh.clone(),
            specular: frame.specular,
        })
    }

    /// Draws the mirror reflection of `environment` (F_r(eta, theta_o) L_env(r), r the view ray
    /// reflected about the normal; an SH environment's order-2 radiance) from the next frame on,
    /// unless the frame was created without specular. Without this call nothing is reflected.
    pub fn set_environment(
        &mut self,
        environment: &crate::scene::Environment,
    ) -> Result<(), RenderError> {
        environment.validate()?;
        self.uniforms.env_sh = match self.specular {
            true => environment_sh(environment),
            false => [[0.0; 4]; 9],
        };
        Ok(())
    }

    /// Replaces the per-vertex exitance J+ (one per vertex of the scene's mesh), e.g. with a
    /// solver's output. The old vertex buffer is released once the frames using it completed.
    pub fn set_exitance(
        &mut self,
        ctx: &Context,
        exitance: &[[f32; 3]],
    ) -> Result<(), RenderError> {
        self.mesh = GpuMesh::new(ctx, &self.surface, exitance)?;
        Ok(())
    }

    /// Renders one frame, waits for it and reads it back.
    pub fn render_frame(&mut self, ctx: &Context) -> Result<Captured, RenderError> {
        self.render_frame_after(ctx, |_, _| {})
    }

    /// The displayed mesh on the GPU (e.g. for `GpuDiffusion::bind_mesh`).
    pub fn mesh(&self) -> &GpuMesh {
        &self.mesh
    }

    /// [`Self::render_frame`], with `before(cb, profiler)` recorded first in the same command
    /// buffer (e.g. the GPU diffusion solve writing the mesh's exitance; it must leave its writes
    /// visible to vertex input).
    pub fn render_frame_after(
        &mut self,
        ctx: &Context,
        before: impl FnOnce(ash::vk::CommandBuffer, &mut GpuProfiler),
    ) -> Result<Captured, RenderError> {
        let submission = ctx.submit("headless frame", |cb| {
            let (frame, _) = ctx.frames();
            let p = &mut self.profiler;
            // SAFETY: `cb` is recording; every resource is owned by `self`, which outlives the
            // waited submission.
            unsafe {
                p.begin_frame(cb, frame);
                before(cb, p);
                // No specular light: no pass (and absent from the timings), only the first
                // frame's layout change.
                self.shadow.record(ctx, cb, &self.mesh, Some(p));
                self.shading
                    .record(
                        ctx,
                        cb,
                        &self.mesh,
                        &mut self.target,
                        &self.uniforms,
                        &self.push,
                        Some(p),
                    )
                    .map_err(|e| crate::vk::VkError::invalid("shading", e.to_string()))?;
                p.begin_scope(cb, "capture");
                self.readback
                    .record(ctx, cb, &self.target.color, self.target.color_state);
                p.end_scope(cb);
            }
            Ok(())
        })?;
        let frame = submission.frame();
        submission.wait()?;
        self.profiler.frame_completed(frame);
        let timings = self.profiler.latest().filter(|t| t.frame == frame).cloned();
        let passes = timings.as_ref().map(|t| t.passes()).unwrap_or_default();
        let image = self.readback.read()?;
        Ok(Captured {
            image,
            passes,
            timings,
            frame,
        })
    }
}

/// Renders `scene` once, headless.
///
/// ```no_run
/// use translucent::render::{render_headless, FrameDesc, Scene};
/// use translucent::scene::Light;
/// # fn f(ctx: &translucent::vk::Context) -> Result<(), translucent::render::RenderError> {
/// let scene = Scene::procedural("sphere", 50.0, vec![Light::default_light()], 1.3)?;
/// let captured = render_headless(ctx, &scene, &FrameDesc::default())?;
/// captured.image.write_png(std::path::Path::new("sphere.png"), 1.0)?;
/// # Ok(()) }
/// ```
pub fn render_headless(
    ctx: &Context,
    scene: &Scene,
    frame: &FrameDesc,
) -> Result<Captured, RenderError> {
    HeadlessRenderer::new(ctx, scene, frame)?.render_frame(ctx)
}

/// A minimal host for a [`crate::TranslucentObject`]: owns a colour target, and per frame clears
/// it to black, lets the object record into the same command buffer exactly as into a host's
/// (colour handed over from a transfer clear, our own depth), submits, waits and reads back.
///
/// ```no_run
/// # fn f(ctx: &translucent::vk::Context, object: &mut translucent::TranslucentObject)
/// #      -> Result<(), translucent::Error> {
/// let mut host = translucent::render::HeadlessHost::new(ctx, 64, 64)?;
/// let (captured, report) = host.render(ctx, object)?; // first frame: solves
/// let (_, report) = host.render(ctx, object)?; // nothing changed: shading only
/// assert!(report.skipped.contains_key("solve"));
/// # Ok(()) }
/// ```
pub struct HeadlessHost {
    target: OffscreenTarget,
    readback: ImageReadback,
    profiler: GpuProfiler,
}

impl HeadlessHost {
    pub fn new(ctx: &Context, width: u32, height: u32) -> Result<HeadlessHost, RenderError> {
        if width == 0 || height == 0 {
            return Err(RenderError::Invalid {
                what: "target".into(),
                problem: format!("{width}x{height} has no pixels"),
            });
        }
        let target = OffscreenTarget::new(ctx, width, height)?;
        let readback = ImageReadback::new(ctx, &target.color)?;
        // Room for a whole solve (scopes per Jacobi block) per frame.
        let profiler = GpuProfiler::new(ctx, "headless host frame", 4096)?;
        Ok(HeadlessHost {
            target,
            readback,
            profiler,
        })
    }

    /// Renders one frame of `object`, waits, reads back.
    pub fn render(
        &mut self,
        ctx: &Context,
        object: &mut crate::TranslucentObject,
    ) -> Result<(Captured, crate::FrameReport), crate::Error> {
        use ash::vk;
        let mut result = None;
        let submission = ctx.submit("headless host frame", |cb| {
            let (frame, completed) = ctx.frames();
            let p = &mut self.profiler;
            let color = &self.target.color;
            // SAFETY: `cb` is recording; the target, read-back and `object` outlive the waited
            // submission.
            unsafe {
                p.begin_frame(cb, frame);
                // why: the clear overwrites what the last frame's capture read (WAR), in
                // TRANSFER_DST layout.
                crate::vk::barrier::image(
                    ctx,
                    cb,
                    color,
                    self.target.color_state,
                    Access::TransferDst,
                );
                ctx.raw().cmd_clear_color_image(
                    cb,
                    color.raw,
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                    &vk::ClearColorValue { float32: [0.0; 4] },
                    &[vk::ImageSubresourceRange {
                        aspect_mask: vk::ImageAspectFlags::COLOR,
                        base_mip_level: 0,
                        level_count: 1,
                        base_array_layer: 0,
                        layer_count: 1,
                    }],
                );
                let targets = crate::object::Targets {
                    color: crate::object::TargetImage {
                        image: color.raw,
                        view: color.view,
                        format: color.format,
                        extent: color.extent(),
                        before: Access::TransferDst.into(),
                        after: Access::TransferSrc.into(),
                    },
                    depth: None,
                    host_barriers: false,
                };
                let report = object.record(
                    &mut crate::object::RecordCtx {
                        ctx,
                        cb,
                        frame,
                        completed_frame: completed,
                        profiler: Some(p),
                    },
                    &targets,
                );
                let ok = report.is_ok();
                result = Some(report);
                if ok {
                    p.begin_scope(cb, "capture");
                    self.readback.record(ctx, cb, color, Access::TransferSrc);
                    p.end_scope(cb);
                }
            }
            Ok(())
        })?;
        let frame = submission.frame();
        submission.wait()?;
        self.target.color_state = Access::TransferSrc;
        self.profiler.frame_completed(frame);
        let report = result.ok_or_else(|| RenderError::Invalid {
            what: "frame".into(),
            problem: "not recorded".into(),
        })??;
        let timings = self.profiler.latest().filter(|t| t.frame == frame).cloned();
        let passes = timings.as_ref().map(|t| t.passes()).unwrap_or_default();
        let image = self.readback.read()?;
        Ok((
            Captured {
                image,
                passes,
                timings,
                frame,
            },
            report,
        ))
    }

    /// Solves that completed by the last waited frame (their iterations), for the last frame's
    /// report: a frame's own solve is only known once it completed.
    pub fn completed_solves(
        &self,
        ctx: &Context,
        object: &mut crate::TranslucentObject,
    ) -> Result<Vec<crate::object::CompletedSolve>, crate::Error> {
        object.completed_solves(ctx.frames().1)
    }
}
