//! [`TranslucentObject`]: one translucent object as a host render graph embeds it (DESIGN sections
//! 5 and 7). It owns the GPU frame (shadow atlas, irradiance gather, multi-level Jacobi solve), the
//! display mesh (which also casts the shadows) and the shading pipeline, and records all of it into
//! the HOST's command buffer: it never begins, ends or submits a command buffer, never waits and
//! never destroys a host object.
//!
//! Changes only mark what is dirty ([`TranslucentObject::set_lights`], `set_material`, `deform`,
//! `set_camera`); [`TranslucentObject::record`] then records only the work they require (DESIGN
//! section 5) and says in its [`FrameReport`] what ran and, per skipped pass, why:
//! - nothing changed: no shadow map, gather or solve, only the shading;
//! - camera only: the same (the view-dependent Fresnel term is in the shading);
//! - lights, material or shape changed: a warm-started solve: every level from its own last
//!   solution, each finer level first corrected by the coarser level's change (the smooth part
//!   of the change, which the finest level's Jacobi damps slowest; one level on a small graph);
//! - no shadow-casting light: no shadow pass;
//! - converged: no more iterations (decided on the GPU; [`CompletedSolve::converged`]);
//! - a small graph: a cold solve iterates one level;
//! - homogeneous material: the solve's homogeneous variant ([`FrameReport::material_variant`]).
//!
//! [`ObjectParams::skip`] `= false` turns every skip off (every frame a cold full solve).
//!
//! Frames: `RecordCtx::frame` is the host's frame number (monotonic), `completed_frame` the last
//! one the GPU finished; objects we drop are released once their frame completed, and the
//! iterations a solve ran come back in the report of a later frame ([`FrameReport::completed`]).
//!
//! Boundary: our pass LOADs the host's colour (its background stays) and depth-tests against the
//! host's depth if given. By default we record the barriers from each target's `before` state and
//! to its `after` state; a host graph that places them itself reads [`TranslucentObject::declare`]
//! and sets [`Targets::host_barriers`].
//!
//! ```no_run
//! use std::sync::Arc;
//! use translucent::object::{ObjectParams, RecordCtx, TargetImage, Targets, TranslucentObject};
//! use translucent::vk::Access;
//! # fn f(ctx: &translucent::vk::Context, graph: Arc<translucent::QuadGraph>,
//! #      field: &translucent::material::MaterialField, scene: &translucent::scene::Scene,
//! #      cb: ash::vk::CommandBuffer, color: ash::vk::Image, view: ash::vk::ImageView)
//! #      -> Result<(), translucent::Error> {
//! let mut object = TranslucentObject::new(ctx, graph, field, scene, &ObjectParams::default())?;
//! let targets = Targets {
//!     color: TargetImage {
//!         image: color,
//!         view,
//!         format: translucent::render::COLOR_FORMAT,
//!         extent: ash::vk::Extent2D { width: 640, height: 480 },
//!         before: Access::ColorAttachmentWrite.into(),
//!         after: Access::FragmentSampled.into(),
//!     },
//!     depth: None,
//!     host_barriers: false,
//! };
//! object.set_lights(scene)?; // e.g. a light moved: the next frame warm-starts
//! // SAFETY: `cb` is recording outside a rendering scope; the object and the images outlive it.
//! let report = unsafe {
//!     object.record(&mut RecordCtx { ctx, cb, frame: 7, completed_frame: 5, profiler: None }, &targets)?
//! };
//! println!("{:?} skipped {:?}", report.passes, report.skipped);
//! # Ok(()) }
//! ```

use std::collections::BTreeMap;
use std::sync::Arc;

use ash::vk;

use crate::material::MaterialField;
use crate::render::{
    environment_sh, MeshPass, RenderError, ShadeAttachments, ShadePush, ShadeUniforms,
    COLOR_FORMAT, DEPTH_FORMAT,
};

use crate::mesh::GpuMesh;
use crate::scene::{Camera, Light, RadianceMode, Scene};
use crate::solver::gpu::frame::{FrameParts, SolvePlan};
use crate::solver::gpu::{Deformation, GpuFrame, GpuSolveParams};
use crate::vk::{barrier, Access, Context, GpuProfiler, Image, ImageDesc, ImageState};
use crate::{Error, QuadGraph};

pub use crate::solver::gpu::frame::CompletedSolve;

/// Pass names of [`FrameReport::passes`] and [`FrameReport::skipped`].
pub const PASS_SHADOW: &str = "shadow_map";
pub const PASS_GATHER: &str = "gather_q";
pub const PASS_SOLVE: &str = "solve";
/// Sub-parts of the solve that a warm start (the Shepard init) or a small graph (the coarse
/// levels) leaves out.
pub const PASS_INIT: &str = "diffusion init";
pub const PASS_COARSE: &str = "coarse levels";
pub const PASS_SHADING: &str = "shading";

/// Below this many finest-level nodes a cold solve iterates the finest level only. Chosen by
/// measurement (benches/RESULTS.md, "Host frames", part (c), lavapipe): a one-level cold solve of
/// a sphere was faster at 4248 finest nodes (307 vs 363 ms), even at 11952 and 2x-5x slower from
/// 26592 up, and it always runs more iterations (dispatches), which a GPU with per-dispatch cost
/// pays for: the threshold stays below the smallest graph where it was measured to win.
pub const SINGLE_LEVEL_NODES: usize = 4096;

/// How to build a [`TranslucentObject`].
#[derive(Clone, Debug)]
pub struct ObjectParams {
    pub solve: GpuSolveParams,
    /// The host colour target's format (the shading pipeline is built for it).
    pub color_format: vk::Format,
    /// The depth format: the host's depth target's, or of our own depth buffer when the host
    /// gives none.
    pub depth_format: vk::Format,
    /// Cook-Torrance specular of the first directional light, shadowed by its atlas tile.
    pub specular: bool,
    /// GGX roughness (alpha = roughness^2), in (0, 1].
    pub roughness: f32,
    pub radiance: RadianceMode,
    /// `false`: every frame records everything with a cold solve (for comparisons).
    pub skip: bool,
    /// Finest-level node count below which a cold solve iterates one level.
    pub single_level_nodes: usize,
}

impl Default for ObjectParams {
    fn default() -> Self {
        ObjectParams {
            solve: GpuSolveParams {
                iterations: vec![2000],
                ..GpuSolveParams::default()
            },
            color_format: COLOR_FORMAT,
            depth_format: DEPTH_FORMAT,
            specular: true,
            roughness: 0.35,
            radiance: RadianceMode::Physical,
            skip: true,
            single_level_nodes: SINGLE_LEVEL_NODES,
        }
    }
}

/// The host's side of one [`TranslucentObject::record`].
pub struct RecordCtx<'a> {
    pub ctx: &'a Context,
    /// The host's command buffer, recording, outside a rendering scope.
    pub cb: vk::CommandBuffer,
    /// The frame being recorded (monotonic).
    pub frame: u64,
    /// The last frame the GPU has finished.
    pub completed_frame: u64,
    /// The host's profiler (its frame begun): our passes add named scopes.
    pub profiler: Option<&'a mut GpuProfiler>,
}

/// One host image we render into, with the state it comes in and must leave in.
#[derive(Clone, Copy, Debug)]
pub struct TargetImage {
    pub image: vk::Image,
    pub view: vk::ImageView,
    pub format: vk::Format,
    pub extent: vk::Extent2D,
    pub before: ImageState,
    pub after: ImageState,
}

/// Where [`TranslucentObject::record`] draws.
#[derive(Clone, Copy, Debug)]
pub struct Targets {
    /// Loaded (the host's background stays) and drawn over.
    pub color: TargetImage,
    /// The host's depth: we test against it and write ours. `None`: our own depth buffer.
    pub depth: Option<TargetImage>,
    /// The host placed the boundary barriers (from [`TranslucentObject::declare`]): the targets
    /// are already in the declared states and `before`/`after` are ignored.
    pub host_barriers: bool,
}

/// Which host resource a [`ResourceUse`] is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HostResource {
    /// [`Targets::color`].
    Color,
    /// [`Targets::depth`].
    Depth,
}

/// How our recorded work uses a host resource, for a host graph's barriers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ResourceUse {
    pub resource: HostResource,
    pub stage: vk::PipelineStageFlags2,
    pub access: vk::AccessFlags2,
    /// Images: the layout we use it in.
    pub layout: vk::ImageLayout,
    pub read: bool,
    pub write: bool,
}

/// Why a pass did not run this frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SkipReason {
    /// Nothing changed since the last solve.
    Unchanged,
    /// Only the camera changed: the view-dependent part is in the shading.
    CameraOnly,
    /// No light casts a shadow (environment only, or the lights are black).
    NoShadowCaster,
    /// The lights and the shape did not change (the last shadow maps still hold).
    ShadowsUnchanged,
    /// Started from the last solution (no Shepard initialisation).
    WarmStart,
    /// The finest level has fewer than [`ObjectParams::single_level_nodes`] nodes.
    SmallGraph,
}

impl std::fmt::Display for SkipReason {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            SkipReason::Unchanged => "nothing changed",
            SkipReason::CameraOnly => "camera only",
            SkipReason::NoShadowCaster => "no shadow-casting light",
            SkipReason::ShadowsUnchanged => "lights and shape unchanged",
            SkipReason::WarmStart => "warm start",
            SkipReason::SmallGraph => "small graph: one level",
        })
    }
}

/// What one [`TranslucentObject::record`] recorded.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameReport {
    pub frame: u64,
    /// Passes recorded, in order (names: the `PASS_*` constants; the profiler's scopes are
    /// `shadow_map`, `gather_q`, `diffusion *` and `shading`).
    pub passes: Vec<&'static str>,
    /// Per pass not recorded, why.
    pub skipped: BTreeMap<&'static str, SkipReason>,
    /// The solve started from the last solution.
    pub warm_start: bool,
    /// Levels the solve iterated (0 without a solve).
    pub levels_iterated: u32,
    /// `homogeneous` (kappa, mu from push constants) or `heterogeneous` (per-node weights).
    pub material_variant: &'static str,
    /// Solves of earlier frames that completed since the last report (iterations, convergence).
    pub completed: Vec<CompletedSolve>,
}

/// What changed since the last recorded frame.
#[derive(Clone, Debug, Default)]
struct Pending {
    lights: Option<Scene>,
    material: Option<MaterialField>,
    deformation: Option<Deformation>,
    camera: bool,
}

/// Our own depth buffer when the host gives none.
struct OwnDepth {
    image: Image,
    state: Access,
}

/// A translucent object recorded into a host's frames (see the module doc).
pub struct TranslucentObject {
    graph: Arc<QuadGraph>,
    frame: GpuFrame,
    /// The display mesh: J+ written in place by the solve; it also casts the shadows.
    mesh: GpuMesh,
    shading: MeshPass,
    params: ObjectParams,
    lights: Vec<Light>,
    /// The rest pose's bounding sphere: what the automatic camera frames (computed once: it
    /// walks every finest-level node).
    framing: (glam::DVec3, f64),
    /// The environment's mirror reflection in the shading's basis (zero without specular).
    env_sh: [[f32; 4]; 9],
    eta: f32,
    camera: Option<Camera>,
    pending: Pending,
    own_depth: Option<OwnDepth>,
    last_frame: Option<u64>,
}

fn invalid(what: &str, problem: String) -> Error {
    Error::Render(RenderError::Invalid {
        what: what.into(),
        problem,
    })
}

impl TranslucentObject {
    /// Builds the GPU frame for `graph` with `field` lit by `scene`, the display mesh and the
    /// shading pipeline for `params`' formats. Uploads run at creation (see
    /// [`Context::from_host`] for hosts).
    pub fn new(
        ctx: &Context,
        graph: Arc<QuadGraph>,
        field: &MaterialField,
        scene: &Scene,
        params: &ObjectParams,
    ) -> Result<TranslucentObject, Error> {
        if !(params.roughness.is_finite() && params.roughness > 0.0 && params.roughness <= 1.0) {
            return Err(invalid(
                "roughness",
                format!("{} is not in (0, 1]", params.roughness),
            ));
        }
        let mut frame = GpuFrame::new(ctx, &graph, field, scene, &params.solve)?;
        let vertices = graph.surface.positions.len();
        let mesh = GpuMesh::new(ctx, &graph.surface, &vec![[0.0; 3]; vertices])?;
        frame.solve.bind_mesh(ctx, &mesh)?;
        let shading = MeshPass::new(
            ctx,
            &frame.shadows().atlas,
            params.color_format,
            params.depth_format,
        )?;
        Ok(TranslucentObject {
            framing: graph.finest().bounding_sphere(),
            eta: field.eta() as f32,
            graph,
            frame,
            mesh,
            shading,
            params: params.clone(),
            lights: scene.lights.clone(),
            env_sh: environment_sh(&scene.environment),
            camera: None,
            pending: Pending::default(),
            own_depth: None,
            last_frame: None,
        })
    }

    /// New lights and environment; applied (shadow views refitted) at the next record. A bad
    /// light or environment, or more than [`crate::render::MAX_LIGHTS`], is a typed error here and changes
    /// nothing.
    pub fn set_lights(&mut self, scene: &Scene) -> Result<(), Error> {
        if scene.lights.len() > crate::render::MAX_LIGHTS {
            return Err(invalid(
                "lights",
                format!(
                    "{} lights; at most {} are supported",
                    scene.lights.len(),
                    crate::render::MAX_LIGHTS
                ),
            ));
        }
        scene.validate()?;
        self.pending.lights = Some(scene.clone());
        Ok(())
    }

    /// A new material (homogeneous or heterogeneous); applied on the GPU at the next record.
    pub fn set_material(&mut self, field: &MaterialField) {
        self.pending.material = Some(field.clone());
    }

    /// A new shape (relative to the baked rest pose); applied on the GPU at the next record.
    pub fn deform(&mut self, deformation: &Deformation) {
        self.pending.deformation = Some(deformation.clone());
    }

    /// A new camera; `None` frames the object automatically. Checked here.
    pub fn set_camera(&mut self, camera: Option<Camera>) -> Result<(), Error> {
        if let Some(c) = &camera {
            c.validate()?;
        }
        if self.camera != camera {
            self.camera = camera;
            self.pending.camera = true;
        }
        Ok(())
    }

    /// The camera set last (`None`: framed automatically).
    pub fn camera(&self) -> Option<Camera> {
        self.camera
    }

    /// The GPU frame (for reports: residual, energy, read-backs).
    pub fn gpu_frame(&self) -> &GpuFrame {
        &self.frame
    }

    /// The baked graph.
    pub fn graph(&self) -> &QuadGraph {
        &self.graph
    }

    /// Solves whose frame is `<= completed_frame` not reported yet (a frame's [`FrameReport`]
    /// carries those of earlier frames; this reads the last one's once it completed).
    pub fn completed_solves(&mut self, completed_frame: u64) -> Result<Vec<CompletedSolve>, Error> {
        self.frame.completed_solves(completed_frame)
    }

    /// How [`TranslucentObject::record`] uses the host's targets, for a host graph that places
    /// the boundary barriers itself ([`Targets::host_barriers`]): before the record, the colour
    /// must be in `COLOR_ATTACHMENT_OPTIMAL` with earlier writes available to colour-attachment
    /// reads and writes, the depth likewise in `DEPTH_ATTACHMENT_OPTIMAL`; after it, our writes
    /// are at these stages. Everything else we record touches only our own resources.
    pub fn declare(&self) -> Vec<ResourceUse> {
        let color: ImageState = Access::ColorAttachmentWrite.into();
        let depth: ImageState = Access::DepthAttachmentWrite.into();
        vec![
            ResourceUse {
                resource: HostResource::Color,
                stage: color.stage,
                access: color.access,
                layout: color.layout,
                read: true,
                write: true,
            },
            ResourceUse {
                resource: HostResource::Depth,
                stage: depth.stage,
                access: depth.access,
                layout: depth.layout,
                read: true,
                write: true,
            },
        ]
    }

    fn check_targets(&self, targets: &Targets) -> Result<(), Error> {
        let (color_format, depth_format) = self.shading.formats();
        let c = &targets.color;
        if c.extent.width == 0 || c.extent.height == 0 {
            return Err(invalid(
                "colour target",
                format!("{}x{} has no pixels", c.extent.width, c.extent.height),
            ));
        }
        if c.format != color_format {
            return Err(invalid(
                "colour target",
                format!(
                    "format {:?}, but the object was built for {color_format:?} (ObjectParams::color_format)",
                    c.format
                ),
            ));
        }
        if c.image == vk::Image::null() || c.view == vk::ImageView::null() {
            return Err(invalid("colour target", "null image or view".into()));
        }
        if let Some(d) = &targets.depth {
            if d.format != depth_format {
                return Err(invalid(
                    "depth target",
                    format!(
                        "format {:?}, but the object was built for {depth_format:?} (ObjectParams::depth_format)",
                        d.format
                    ),
                ));
            }
            if d.extent != c.extent {
                return Err(invalid(
                    "depth target",
                    format!(
                        "{}x{}, the colour target is {}x{}",
                        d.extent.width, d.extent.height, c.extent.width, c.extent.height
                    ),
                ));
            }
            if d.image == vk::Image::null() || d.view == vk::ImageView::null() {
                return Err(invalid("depth target", "null image or view".into()));
            }
        }
        if !targets.host_barriers {
            for (name, state) in [("colour target", &c.after)]
                .into_iter()
                .chain(targets.depth.as_ref().map(|d| ("depth target", &d.after)))
            {
                if state.layout == vk::ImageLayout::UNDEFINED
                    || state.layout == vk::ImageLayout::PREINITIALIZED
                {
                    return Err(invalid(
                        name,
                        format!("cannot leave it in {:?}", state.layout),
                    ));
                }
            }
        }
        Ok(())
    }

    /// Applies the pending changes to the GPU frame; returns (lights, material, shape) changed.
    fn apply_pending(&mut self, ctx: &Context) -> Result<(bool, bool, bool), Error> {
        let pending = std::mem::take(&mut self.pending);
        let lights = pending.lights.is_some();
        let material = pending.material.is_some();
        let shape = pending.deformation.is_some();
        if let Some(scene) = pending.lights {
            self.frame.set_lights(&self.graph, &scene)?;
            self.env_sh = environment_sh(&scene.environment);
            self.lights = scene.lights;
        }
        if let Some(field) = pending.material {
            self.frame.set_material(ctx, &self.graph, &field)?;
            self.eta = field.eta() as f32;
        }
        if let Some(d) = pending.deformation {
            self.frame.deform(ctx, &self.graph, &d, &[&self.mesh])?;
        }
        Ok((lights, material, shape))
    }

    /// The shading uniforms for an `extent` target: camera, and the first directional light's
    /// atlas tile for the specular shadow.
    fn uniforms(&self, extent: vk::Extent2D) -> (ShadeUniforms, bool) {
        let aspect = f64::from(extent.width) / f64::from(extent.height.max(1));
        let (centre, radius) = self.framing;
        let camera = self
            .camera
            .unwrap_or_else(|| Camera::framing(centre, radius, aspect));
        let shadows = self.frame.shadows();
        let specular = self
            .params
            .specular
            .then(|| {
                self.lights.iter().enumerate().find_map(|(i, l)| match *l {
                    Light::Directional {
                        direction,
                        irradiance,
                    } => Some((i, direction, irradiance)),
                    _ => None,
                })
            })
            .flatten()
            .and_then(|(i, direction, irradiance)| {
                let &(first, count) = shadows.light_views().get(i)?;
                let m = (count > 0)
                    .then(|| shadows.atlas_view_proj(first as usize))
                    .flatten()?;
                Some((m, direction, irradiance))
            });
        let (light_view_proj, light_dir, irradiance) = match specular {
            Some((m, d, e)) => (m, d.normalize().as_vec3().extend(1.0), e.map(|v| v as f32)),
            None => (glam::Mat4::IDENTITY, glam::Vec4::ZERO, [0.0; 3]),
        };
        (
            ShadeUniforms {
                view_proj: camera.view_proj(aspect, centre, radius).to_cols_array(),
                light_view_proj: light_view_proj.to_cols_array(),
                camera_pos: camera.eye.as_vec3().extend(1.0).to_array(),
                light_dir: light_dir.to_array(),
                light_irradiance: [irradiance[0], irradiance[1], irradiance[2], 0.0],
                env_sh: match self.params.specular {
                    true => self.env_sh,
                    false => [[0.0; 4]; 9],
                },
            },
            specular.is_some(),
        )
    }

    /// Records this frame's work into the host's command buffer: what the changes since the last
    /// frame require (see the module doc), then the shading into `targets`.
    ///
    /// # Safety
    /// `rc.cb` must be recording, outside a rendering scope, on a queue with graphics and compute;
    /// the targets' images and views must be valid, in their `before` states (or the declared
    /// ones with `host_barriers`), and outlive the command buffer's execution, as must `self`;
    /// `rc.frame` must be the frame being recorded and `rc.completed_frame` truly completed.
    pub unsafe fn record(
        &mut self,
        rc: &mut RecordCtx<'_>,
        targets: &Targets,
    ) -> Result<FrameReport, Error> {
        let ctx = rc.ctx;
        let cb = rc.cb;
        self.check_targets(targets)?;
        if self.last_frame.is_some_and(|f| rc.frame < f) || rc.completed_frame >= rc.frame {
            return Err(invalid(
                "frame",
                format!(
                    "frame {} (completed {}): frames must not go back and the recorded one cannot be complete",
                    rc.frame, rc.completed_frame
                ),
            ));
        }
        ctx.begin_frame(rc.frame);
        ctx.frame_completed(rc.completed_frame);
        let completed = self.frame.completed_solves(rc.completed_frame)?;
        let camera_changed = self.pending.camera;
        let (lights, material, shape) = self.apply_pending(ctx)?;

        let mut skipped = BTreeMap::new();
        let mut passes = Vec::new();
        let first = !self.frame.has_solution();
        let small = self.frame.finest_nodes() < self.params.single_level_nodes;
        let parts = if !self.params.skip {
            FrameParts::ALL
        } else if first {
            FrameParts {
                shadows: true,
                gather: true,
                solve: Some(SolvePlan {
                    warm: false,
                    finest_only: small,
                }),
            }
        } else if lights || material || shape {
            FrameParts {
                shadows: lights || shape,
                gather: true,
                solve: Some(SolvePlan {
                    warm: true,
                    finest_only: small,
                }),
            }
        } else {
            let reason = if camera_changed {
                SkipReason::CameraOnly
            } else {
                SkipReason::Unchanged
            };
            skipped.insert(PASS_SHADOW, reason);
            skipped.insert(PASS_GATHER, reason);
            skipped.insert(PASS_SOLVE, reason);
            FrameParts {
                shadows: false,
                gather: false,
                solve: None,
            }
        };
        if parts.shadows && !self.frame.shadows().any_shadows() {
            skipped.insert(PASS_SHADOW, SkipReason::NoShadowCaster);
        } else if !parts.shadows && parts.gather {
            skipped.insert(PASS_SHADOW, SkipReason::ShadowsUnchanged);
        }

        // Our own depth buffer, sized to the target (an old one is released after its frames).
        if targets.depth.is_none() {
            let extent = targets.color.extent;
            let fits = self
                .own_depth
                .as_ref()
                .is_some_and(|d| d.image.extent() == extent);
            if !fits {
                self.own_depth = Some(OwnDepth {
                    image: Image::new(
                        ctx,
                        &ImageDesc {
                            name: "object depth",
                            width: extent.width,
                            height: extent.height,
                            format: self.params.depth_format,
                            usage: vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT,
                        },
                    )?,
                    state: Access::Undefined,
                });
            }
        }

        let (uniforms, specular) = self.uniforms(targets.color.extent);
        let push = ShadePush {
            eta: self.eta,
            radiance_mode: match self.params.radiance {
                RadianceMode::Physical => 0,
                RadianceMode::Paper => 1,
            },
            roughness: self.params.roughness,
            specular: u32::from(specular),
        };
        let mut profiler = rc.profiler.as_deref_mut();
        // SAFETY: the caller's contract; every resource of ours lives in `self`.
        let done = unsafe {
            self.frame.record_parts(
                ctx,
                cb,
                &self.mesh,
                &parts,
                rc.frame,
                profiler.as_deref_mut(),
            )?
        };
        if done.shadows {
            passes.push(PASS_SHADOW);
        }
        if done.gather {
            passes.push(PASS_GATHER);
        }
        if done.solve {
            passes.push(PASS_SOLVE);
            if done.warm {
                skipped.insert(PASS_INIT, SkipReason::WarmStart);
            }
            if done.levels_iterated < self.graph.levels.len() as u32 {
                // Only a small graph leaves the coarse levels out (cold or warm): a warm start
                // iterates them for the finer levels' correction.
                skipped.insert(PASS_COARSE, SkipReason::SmallGraph);
            }
        }

        // Boundary barriers: host states -> attachment states.
        let color_state: ImageState = Access::ColorAttachmentWrite.into();
        let depth_state: ImageState = Access::DepthAttachmentWrite.into();
        let mut into = Vec::new();
        if !targets.host_barriers {
            into.push(host_barrier(
                &targets.color,
                targets.color.before,
                color_state,
            ));
            if let Some(d) = &targets.depth {
                into.push(host_barrier(d, d.before, depth_state));
            }
        }
        if let Some(own) = self.own_depth.as_mut().filter(|_| targets.depth.is_none()) {
            // Cleared every frame: the old contents may go (from UNDEFINED the first time).
            into.push(barrier::image_barrier(
                &own.image,
                own.state,
                Access::DepthAttachmentWrite,
            ));
            own.state = Access::DepthAttachmentWrite;
        }
        // SAFETY: the caller's contract.
        unsafe {
            if !into.is_empty() {
                // why: our draws load and write the colour and test/write depth after the host's
                // last use (RAW for its background, WAW/WAR otherwise), in attachment layouts.
                barrier::record(ctx, cb, &[], &into);
            }
            let (depth_view, host_depth) = match (&targets.depth, &self.own_depth) {
                (Some(d), _) => (d.view, true),
                (None, Some(own)) => (own.image.view, false),
                (None, None) => return Err(invalid("depth", "no depth buffer".into())),
            };
            self.shading.record_into(
                ctx,
                cb,
                &self.mesh,
                &ShadeAttachments {
                    color: targets.color.view,
                    load_color: true,
                    depth: depth_view,
                    load_depth: host_depth,
                    store_depth: host_depth,
                    extent: targets.color.extent,
                },
                &uniforms,
                &push,
                profiler,
            )?;
            passes.push(PASS_SHADING);
            if !targets.host_barriers {
                let mut out = vec![host_barrier(
                    &targets.color,
                    color_state,
                    targets.color.after,
                )];
                if let Some(d) = &targets.depth {
                    out.push(host_barrier(d, depth_state, d.after));
                }
                // why: hand the targets back in the states the host asked for, our writes
                // available to its next use (RAW/WAR, layout).
                barrier::record(ctx, cb, &[], &out);
            }
        }
        self.last_frame = Some(rc.frame);
        Ok(FrameReport {
            frame: rc.frame,
            passes,
            skipped,
            warm_start: done.warm,
            levels_iterated: done.levels_iterated,
            material_variant: self.frame.material_variant(),
            completed,
        })
    }
}

/// A whole-image barrier on a host image between two states.
fn host_barrier(
    target: &TargetImage,
    from: ImageState,
    to: ImageState,
) -> vk::ImageMemoryBarrier2<'static> {
    barrier::raw_image_barrier(target.image, target.format, from, to)
}
