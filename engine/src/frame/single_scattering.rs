//! [`SingleScatteringPass`]: single scattering (DESIGN 2.8) as a shared frame-graph pass between
//! the method's passes and the shading, so every method (quadgraph, voxel, dipole, a fixed
//! exitance) gets it. Per display vertex (as the f64 reference
//! [`crate::solver::single_scattering::vertex_single_scattering`], so the two compare vertex by
//! vertex), `single_scattering/march.comp` refracts the view ray, marches it at exponentially
//! stratified depths truncated at the far face, reads each light's entry point (and its normal,
//! from the depth's gradient) and writes X = pi S per vertex into [`SingleScatteringPass::buffer`],
//! which the shading reads as a second vertex stream and adds to the method's exitance
//! (`F_t (J+ + X) / (pi eta^2)`, never below zero).
//!
//! The depths come from the pass `single_scattering_depths` ([`PASS_SCATTER_DEPTHS`]) before the
//! march, into an atlas of its own: tile 0 the nearest back faces the eye sees (the far face:
//! where the refracted view ray leaves, exact at eta = 1), tile 1 + i shadow view i's projection
//! of the faces facing the light, rendered without the shadow pass's slope bias (the bias that keeps acne off shadow lookups
//! moves the entry point by up to 1.5 texels x tan(theta_i), which decides the terminator). The
//! flat-closed-form visibility still reads the shared (biased) shadow atlas, as the gather does.
//!
//! Why per vertex and a pass of its own, not in the fragment shader: the march needs the whole
//! scene's lights and shadow views (a storage buffer the shading does not have), costs
//! O(vertices x samples x lights) whatever the resolution, shows as its own profiler scope, and
//! is the f64 reference's quantity, so a test compares them directly.
//!
//! Double counting: [`ScatterMode::Difference`] (the default) adds the march minus the flat-surface
//! closed form of each light lighting the vertex directly (the diffusion's source already carries
//! the flat part: zero on flat lit regions, all of the march in back-lit crescents), as the CPU's
//! `SingleScattering::Difference`. [`ScatterMode::Full`] also adds the environment's single
//! scattering by the flat closed form (as the CPU's `SingleScattering::Full`).
//!
//! Material: a heterogeneous field is sampled on a [`MEDIUM_NODES`]^3 grid over the display
//! mesh's box (binding `medium`), and the march takes sigma_s' at each depth and the optical
//! depths of both legs through it (8 midpoints a leg, as the f64 reference); a homogeneous one
//! takes its coefficients from the push constants. Lights below the error budget
//! ([`DARK_LIGHT_FRACTION`]) are left out; with none left the march is skipped
//! ([`SkipReason::DarkLights`]), or in the whole mode with an environment only its closed form
//! is written ([`SingleScatteringPass::environment_only`]).
//!
//! ```no_run
//! # use translucent::frame::single_scattering::{ScatterParams, SingleScatteringPass};
//! # use translucent::render::{ShadowMaps, ShadowMapsDesc};
//! # fn f(ctx: &translucent::vk::Context, mesh: &translucent::mesh::GpuMesh) -> Result<(), translucent::Error> {
//! let shadows = ShadowMaps::new(ctx, &ShadowMapsDesc::default())?;
//! let pass = SingleScatteringPass::new(ctx, mesh.vertex_count(), &ScatterParams::default(), &shadows)?;
//! assert_eq!(pass.buffer().size, 16 * mesh.vertex_count() as u64);
//! # Ok(()) }
//! ```

use ash::vk;
use glam::{DVec3, Mat4, Vec3};

use crate::frame::SkipReason;
use crate::material::{Coefficients, MaterialField};
use crate::mesh::{GpuMesh, Vertex};
use crate::render::{
    GatherScene, RenderError, ShadowMaps, ShadowPush, ShadowView, MAX_SHADOW_VIEWS,
};
use crate::scene::{Environment, Light, Scene};
use crate::shader::{
    ComputePipeline, ComputePipelineDesc, DescriptorWrite, GraphicsPipeline, GraphicsPipelineDesc,
    VertexAttribute,
};
use crate::vk::barrier::Use;
use crate::vk::{
    barrier, Access, Buffer, BufferDesc, Context, Image, ImageDesc, MemoryUse, Sampler,
};
use crate::Error;

mod budget;
mod medium;

pub use budget::{
    marched_lights, peak_environment_irradiance, peak_irradiance, DARK_LIGHT_FRACTION,
    FRONT_LIT_COSINE,
};
use medium::medium_data;
pub use medium::{MediumHeader, MEDIUM_NODES};

/// The pass's name (graph pass, debug label, profiler scope).
pub const PASS_SINGLE_SCATTERING: &str = "single_scattering";
/// The depth pre-pass's name: the eye's back faces and the unbiased light views.
pub const PASS_SCATTER_DEPTHS: &str = "single_scattering_depths";
/// Format of the pass's depth atlas.
const DEPTHS_FORMAT: vk::Format = vk::Format::D32_SFLOAT;
/// Beyond this half-angle from the eye the bounding sphere needs a view too wide for one tile
/// (the eye is close to or inside the object): no far-face view, the march runs untruncated.
const MAX_EYE_HALF_ANGLE_DEG: f64 = 60.0;
/// The eye view's margin around the bounding sphere (as the shadow views').
const EYE_VIEW_MARGIN: f64 = 1.02;
/// Depths per view ray: DESIGN 2.8 asks for 4-16.
pub const SAMPLE_RANGE: std::ops::RangeInclusive<u32> = 4..=16;
/// The march starts this far below the vertex, relative to the object's bounding radius (as the
/// f64 reference's 1e-6 of its span, but above f32's resolution of a position).
const START_OFFSET: f64 = 1e-4;
/// The vertex's own visibility for the flat closed form: the gather's normal offset (texels).
const NORMAL_OFFSET_TEXELS: f32 = 1.5;

/// What the pass adds (see the module doc).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ScatterMode {
    /// The march minus the flat-surface closed form of each directly lighting light.
    #[default]
    Difference,
    /// The march whole (for a diffusion source without the once-scattered light).
    Full,
}

/// How [`SingleScatteringPass`] marches.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ScatterParams {
    /// Depths per view ray, in [`SAMPLE_RANGE`].
    pub samples: u32,
    pub mode: ScatterMode,
    /// Skip the march for front-lit views ([`FRONT_LIT_COSINE`]); `false`: march every frame.
    pub skip_front_lit: bool,
    /// [`ScatterMode::Full`] also adds the environment's single scattering (the flat closed
    /// form over the environment as beams, as the CPU's `SingleScattering::Full` with
    /// environment beams). Off by default: the GPU gather takes the environment as a boundary
    /// flux, whose diffusion already carries its once-scattered light (measured: the
    /// environment sphere at eta 1.3 goes from 1.4% to 8.7% against path tracing with it on,
    /// benches/RESULTS.md "Single scattering: dark lights, heterogeneous tau, environment").
    pub environment: bool,
}

impl Default for ScatterParams {
    fn default() -> Self {
        ScatterParams {
            samples: 8,
            mode: ScatterMode::Difference,
            skip_front_lit: true,
            environment: false,
        }
    }
}

/// Push constants of `single_scattering/march.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ScatterPush {
    /// xyz: the eye (object frame, mm).
    pub eye: [f32; 4],
    /// rgb: sigma_s' (1/mm); w: eta.
    pub sigma_s: [f32; 4],
    /// rgb: sigma_a (1/mm); w: the march's start below the vertex (mm).
    pub sigma_a: [f32; 4],
    pub vertex_count: u32,
    pub samples: u32,
    /// 0: zeros (a skipped march clears its last output); 1: difference to the flat closed
    /// form; 2: whole, with the environment's flat closed form; 3: the environment's alone
    /// ([`SingleScatteringPass::environment_only`]).
    pub mode: u32,
    pub normal_offset: f32,
    /// Tiles per row of the pass's depth atlas.
    pub columns: u32,
}

/// The `ExitView` storage buffer of `march.comp`: the eye's back-face view.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ExitView {
    pub view_proj: [f32; 16],
    /// xy: atlas origin (texels), z: tile size (0: no view, the march is not truncated).
    pub tile: [f32; 4],
    /// xyz: the object's bounding centre, w: its radius (mm).
    pub bounds: [f32; 4],
    /// Per shadow view, the inverse of its projection (the entry lookups' unprojection): once
    /// a frame here, in f64, rather than a 4x4 inverse per depth and light in the shader.
    pub entry_inverses: [[f32; 16]; MAX_SHADOW_VIEWS],
}

/// The march's pipeline, its output per vertex and its copy of the lights and shadow views.
pub struct SingleScatteringPass {
    pipeline: ComputePipeline<ScatterPush>,
    #[allow(dead_code, reason = "owned here: the descriptor set refers to it")]
    sampler: Sampler,
    scene: Buffer,
    /// The eye's nearest back faces (culls the faces the eye sees).
    back_faces: GraphicsPipeline<ShadowPush>,
    /// The light views' nearest faces facing the light, no bias.
    front_faces: GraphicsPipeline<ShadowPush>,
    /// Tile 0: the eye's back faces; tile 1 + i: shadow view i. Allocated by the first `bind`.
    depths: Option<Image>,
    exit_buffer: Buffer,
    exit_view: ExitView,
    tile: u32,
    columns: u32,
    views: Vec<ShadowView>,
    bounds: (DVec3, f64),
    lights: Vec<Light>,
    /// Per light, whether the march takes it ([`marched_lights`]).
    marched: Vec<bool>,
    environment: Environment,
    depths_written: bool,
    /// Whether the output holds a march (not zeros): a skipped frame must clear it first.
    live: bool,
    output: Buffer,
    vertex_count: usize,
    set: Option<vk::DescriptorSet>,
    bound_vertices: vk::Buffer,
    params: ScatterParams,
    scene_data: Box<GatherScene>,
    coefficients: Coefficients,
    /// The material grid's buffer (binding `medium`) and what the next upload writes.
    medium: Buffer,
    medium_data: Vec<[f32; 4]>,
    /// `medium_data` changed since the last upload; `upload_medium`: this frame's record
    /// uploads it (set by `bind`).
    medium_dirty: bool,
    upload_medium: bool,
    eta: f32,
    radius: f64,
}

fn invalid(what: &str, problem: String) -> Error {
    Error::Render(RenderError::Invalid {
        what: what.into(),
        problem,
    })
}

/// Bytes per vkCmdUpdateBuffer (its limit).
const UPDATE_CHUNK: usize = 65536;

/// Descriptor sets one pass may allocate: one per display vertex buffer it meets (a voxel
/// object's new topologies); beyond this a typed error.
const MAX_SETS: u32 = 16;

impl SingleScatteringPass {
    /// The pass for a display mesh of `vertex_count` vertices, its depth atlas sized for
    /// `shadows`' views plus the eye's; samples outside [`SAMPLE_RANGE`] are a typed error. The
    /// output starts at zero (what the shading adds when the pass is off).
    pub fn new(
        ctx: &Context,
        vertex_count: usize,
        params: &ScatterParams,
        shadows: &ShadowMaps,
    ) -> Result<SingleScatteringPass, Error> {
        if !SAMPLE_RANGE.contains(&params.samples) {
            return Err(invalid(
                "single-scattering samples",
                format!(
                    "{} depths per ray; DESIGN 2.8 takes {}..={}",
                    params.samples,
                    SAMPLE_RANGE.start(),
                    SAMPLE_RANGE.end()
                ),
            ));
        }
        let pipeline = ComputePipeline::new(
            ctx,
            &ComputePipelineDesc {
                name: "single scattering",
                shader: "single_scattering/march.comp",
                bindings: &[
                    "vertices",
                    "scattered",
                    "shadow_atlas",
                    "scene",
                    "depths",
                    "exit_view",
                    "medium",
                ],
                max_sets: MAX_SETS,
            },
        )?;
        let depth_pipeline = |name, cull_mode| {
            GraphicsPipeline::new(
                ctx,
                &GraphicsPipelineDesc {
                    name,
                    vertex: "shadow_map/depth_only.vert",
                    fragment: None,
                    vertex_stride: std::mem::size_of::<Vertex>() as u32,
                    vertex_attributes: &[VertexAttribute {
                        location: 0,
                        format: vk::Format::R32G32B32_SFLOAT,
                        offset: 0,
                    }],
                    extra_streams: &[],
                    color_formats: &[],
                    depth_format: Some(DEPTHS_FORMAT),
                    depth_bias: None,
                    cull_mode,
                    bindings: &[],
                    max_sets: 1,
                },
            )
        };
        // Outward counter-clockwise faces project clockwise through a y-up projection onto
        // Vulkan's y-down framebuffer: the faces a view sees from outside are the pipeline's
        // back faces. The eye's view culls BACK (keeps the far side); the light views cull
        // FRONT (keep the faces the light enters through: a light inside the object, or seeing
        // into a hole, enters nowhere there, as the f64 march's ray casts).
        let back_faces = depth_pipeline("scatter back faces", vk::CullModeFlags::BACK)?;
        let front_faces = depth_pipeline("scatter light depths", vk::CullModeFlags::FRONT)?;
        let exit_buffer = Buffer::new(
            ctx,
            &BufferDesc {
                name: "single scattering exit view",
                size: std::mem::size_of::<ExitView>() as u64,
                usage: vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
                memory: MemoryUse::GpuOnly,
            },
        )?;
        let tiles = shadows.max_views() + 1;
        let columns = (f64::from(tiles).sqrt().ceil() as u32).max(1);
        // texelFetch of raw depths (no compare), as the gather's.
        let info = vk::SamplerCreateInfo::default()
            .mag_filter(vk::Filter::NEAREST)
            .min_filter(vk::Filter::NEAREST)
            .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_w(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .max_lod(0.0);
        let sampler = Sampler::new(ctx, "single scattering atlas sampler", &info)?;
        let scene = Buffer::new(
            ctx,
            &BufferDesc {
                name: "single scattering scene",
                size: std::mem::size_of::<GatherScene>() as u64,
                usage: vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
                memory: MemoryUse::GpuOnly,
            },
        )?;
        let medium_bytes =
            std::mem::size_of::<MediumHeader>() as u64 + 32 * u64::from(MEDIUM_NODES).pow(3);
        let medium = Buffer::new(
            ctx,
            &BufferDesc {
                name: "single scattering medium",
                size: medium_bytes,
                usage: vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
                memory: MemoryUse::GpuOnly,
            },
        )?;
        Ok(SingleScatteringPass {
            pipeline,
            medium,
            medium_data: Vec::new(),
            medium_dirty: false,
            upload_medium: false,
            sampler,
            scene,
            back_faces,
            front_faces,
            depths: None,
            exit_buffer,
            exit_view: bytemuck::Zeroable::zeroed(),
            tile: shadows.tile_resolution(),
            columns,
            views: Vec::new(),
            bounds: (DVec3::ZERO, 1.0),
            lights: Vec::new(),
            marched: Vec::new(),
            environment: Environment::None,
            depths_written: false,
            live: false,
            output: Self::zeroed_output(ctx, vertex_count)?,
            vertex_count,
            set: None,
            bound_vertices: vk::Buffer::null(),
            params: *params,
            scene_data: Box::new(bytemuck::Zeroable::zeroed()),
            coefficients: Coefficients {
                sigma_s: [0.0; 3],
                sigma_a: [0.0; 3],
            },
            eta: 1.0,
            radius: 1.0,
        })
    }

    fn zeroed_output(ctx: &Context, vertex_count: usize) -> Result<Buffer, Error> {
        Ok(Buffer::with_data(
            ctx,
            "single scattering per vertex",
            // VERTEX: the shading reads it as a second vertex stream; STORAGE: the march writes it.
            // TRANSFER_SRC: read back for checks.
            vk::BufferUsageFlags::VERTEX_BUFFER
                | vk::BufferUsageFlags::STORAGE_BUFFER
                | vk::BufferUsageFlags::TRANSFER_SRC,
            &vec![[0.0f32; 4]; vertex_count.max(1)],
        )?)
    }

    /// X per vertex (rgb, w unused): the shading's second vertex stream.
    pub fn buffer(&self) -> &Buffer {
        &self.output
    }

    /// Reads X per vertex back (waits for the GPU): for tests and tools, after a frame completed.
    pub fn read(&self, ctx: &Context) -> Result<Vec<[f32; 3]>, Error> {
        let copy = Buffer::new(
            ctx,
            &BufferDesc {
                name: "single scattering read-back",
                size: self.output.size,
                usage: vk::BufferUsageFlags::TRANSFER_DST,
                memory: MemoryUse::Readback,
            },
        )?;
        ctx.execute("single scattering read-back", |cb| {
            // SAFETY: `cb` is recording; both buffers outlive the waited submission.
            unsafe {
                // why: the shading (or the march) of a finished frame used it; order the copy after.
                barrier::memory(ctx, cb, Access::VertexInput, Access::TransferSrc);
                barrier::memory(ctx, cb, Access::ComputeWrite, Access::TransferSrc);
                let region = [vk::BufferCopy {
                    src_offset: 0,
                    dst_offset: 0,
                    size: self.output.size,
                }];
                ctx.raw()
                    .cmd_copy_buffer(cb, self.output.raw, copy.raw, &region);
                // why: the CPU maps and reads the copy after the wait (RAW through the host).
                barrier::memory(ctx, cb, Access::TransferDst, Access::HostRead);
            }
            Ok(())
        })?;
        let values: &[[f32; 4]] = bytemuck::cast_slice(copy.read_bytes()?);
        Ok(values
            .iter()
            .take(self.vertex_count)
            .map(|v| [v[0], v[1], v[2]])
            .collect())
    }

    /// Why this frame's march may be skipped for the eye at `eye` (object frame, mm): no light
    /// above [`DARK_LIGHT_FRACTION`] ([`SkipReason::DarkLights`], whatever the mode: the march
    /// of such lights is below the error budget, of black ones exactly zero), or the
    /// lights are all in front of the object ([`FRONT_LIT_COSINE`]), with
    /// [`ScatterParams::skip_front_lit`]. A point or spot light inside the bounding sphere has no
    /// one direction: never skipped. [`ScatterMode::Full`] is never skipped: the rule bounds the
    /// difference to the flat closed form, while the whole march carries all once-scattered
    /// light (the second-collision source leaves it out of the diffusion).
    pub fn skip_reason(&self, eye: DVec3) -> Option<SkipReason> {
        if !self.marched.contains(&true) {
            // The whole mode still adds the environment's closed form (no march).
            return (!self.environment_only()).then_some(SkipReason::DarkLights);
        }
        let centre = self.bounds.0;
        let to_eye = (eye - centre).normalize_or_zero();
        if !self.params.skip_front_lit
            || self.params.mode == ScatterMode::Full
            || self.lights.is_empty()
            || to_eye == DVec3::ZERO
        {
            return None;
        }
        let marched = self.lights.iter().zip(&self.marched);
        let front = marched.filter(|(_, &m)| m).all(|(light, _)| {
            let to_light = match *light {
                Light::Directional { direction, .. } => -direction.normalize_or_zero(),
                Light::Point { position, .. } | Light::Spot { position, .. } => {
                    if position.distance(centre) <= self.bounds.1 {
                        return false;
                    }
                    (position - centre).normalize_or_zero()
                }
            };
            to_light.dot(to_eye) >= FRONT_LIT_COSINE
        });
        front.then_some(SkipReason::FrontLit)
    }

    /// Whether this frame's pass writes the environment's single scattering alone: the whole
    /// mode ([`ScatterMode::Full`]) with [`ScatterParams::environment`], an environment and no
    /// light above the error budget
    /// ([`DARK_LIGHT_FRACTION`]): the flat closed form per vertex, no march, no depth pre-pass
    /// (skipped as [`SkipReason::DarkLights`]).
    pub fn environment_only(&self) -> bool {
        self.params.mode == ScatterMode::Full
            && self.environment != Environment::None
            && !self.marched.contains(&true)
    }

    /// Whether a depth pre-pass was recorded since the atlas was allocated (the march's
    /// descriptor must read a written atlas even where it does not march).
    pub fn depths_written(&self) -> bool {
        self.depths_written
    }

    /// Notes that this frame records the depth pre-pass.
    pub fn set_depths_written(&mut self) {
        self.depths_written = true;
    }

    /// Whether the output holds a march (a skipped frame must clear it: [`Self::record_clear`]).
    pub fn live(&self) -> bool {
        self.live
    }

    /// Notes what the frame just recorded wrote: a march (`true`) or zeros.
    pub fn set_live(&mut self, live: bool) {
        self.live = live;
    }

    /// The march's parameters.
    pub fn params(&self) -> ScatterParams {
        self.params
    }

    /// A display mesh of a new vertex count (a voxel object's new topology): a zeroed output.
    pub fn resize(&mut self, ctx: &Context, vertex_count: usize) -> Result<(), Error> {
        if vertex_count != self.vertex_count {
            self.output = Self::zeroed_output(ctx, vertex_count)?;
            self.vertex_count = vertex_count;
            self.set = None;
        }
        Ok(())
    }

    /// The lights and shadow views (`shadows` fitted to `scene`'s lights), the object's bounding
    /// sphere (centre, radius in mm: the eye's view and the march's start offset).
    pub fn set_lights(
        &mut self,
        scene: &Scene,
        shadows: &ShadowMaps,
        bounds: (DVec3, f64),
    ) -> Result<(), Error> {
        *self.scene_data = GatherScene::new(scene, shadows)?;
        self.marched = marched_lights(scene, bounds);
        // Without the environment term the march's copy of the scene has no environment.
        self.environment = if self.params.environment {
            scene.environment
        } else {
            self.scene_data.counts[1] = 0;
            Environment::None
        };
        // The march's own copy of the lights: a light below the budget is black to it (the
        // shader skips black lights).
        for (light, &marched) in self.scene_data.lights.iter_mut().zip(&self.marched) {
            if !marched {
                light.colour[..3].fill(0.0);
            }
        }
        self.views = shadows.views().to_vec();
        self.lights = scene.lights.clone();
        self.radius = bounds.1;
        self.bounds = bounds;
        Ok(())
    }

    /// The material: `field`'s coefficients (homogeneous), or for a heterogeneous field the
    /// field on a grid of [`MEDIUM_NODES`]^3 over the bounding box of `positions` (the display
    /// vertices; uploaded by the next frame that marches) and, for the push constants, its
    /// mean over `positions`.
    pub fn set_material(&mut self, field: &MaterialField, positions: &[DVec3]) {
        self.eta = field.eta() as f32;
        self.medium_data = medium_data(field, positions);
        self.medium_dirty = true;
        self.coefficients = match field {
            MaterialField::Homogeneous(m) => m.coefficients(),
            _ => {
                let mut sum = Coefficients {
                    sigma_s: [0.0; 3],
                    sigma_a: [0.0; 3],
                };
                for p in positions {
                    let c = field.sample(*p);
                    for ch in 0..3 {
                        sum.sigma_s[ch] += c.sigma_s[ch] / positions.len().max(1) as f64;
                        sum.sigma_a[ch] += c.sigma_a[ch] / positions.len().max(1) as f64;
                    }
                }
                sum
            }
        };
    }

    /// What [`Self::record`] uses: the display mesh's vertices (positions, normals), the shadow
    /// atlas, the depth atlas, its own output (written). Only after [`Self::bind`].
    pub fn uses<'a>(&'a self, mesh: &'a GpuMesh, shadows: &'a ShadowMaps) -> Vec<Use<'a>> {
        let mut uses = vec![
            Use::buffer(mesh.vertex_buffer(), Access::ComputeRead),
            Use::image(&shadows.atlas, Access::DepthSampledShaders),
            Use::buffer(&self.output, Access::ComputeWrite),
        ];
        if let Some(depths) = &self.depths {
            uses.push(Use::image(depths, Access::DepthSampledShaders));
        }
        uses
    }

    /// What [`Self::record_depths`] uses: the depth atlas as attachment, `mesh`'s vertices.
    /// Only after [`Self::bind`].
    pub fn depth_uses<'a>(&'a self, mesh: &'a GpuMesh) -> Vec<Use<'a>> {
        let mut uses = vec![Use::buffer(mesh.vertex_buffer(), Access::VertexInput)];
        if let Some(depths) = &self.depths {
            uses.push(Use::image(depths, Access::DepthAttachmentWrite));
        }
        uses
    }

    /// The eye's view of the bounding sphere (a perspective view fitted to it, as a shadow
    /// view of a point light): `None` when the eye is too close for one tile.
    fn eye_view(&self, eye: DVec3) -> Option<Mat4> {
        let (centre, radius) = (self.bounds.0, self.bounds.1 * EYE_VIEW_MARGIN);
        let to_centre = centre - eye;
        let distance = to_centre.length();
        if !(distance > radius && radius > 0.0 && distance.is_finite()) {
            return None;
        }
        let half = (radius / distance).asin();
        if half > MAX_EYE_HALF_ANGLE_DEG.to_radians() {
            return None;
        }
        let axis = to_centre / distance;
        let far = distance + radius;
        // Depth precision falls with far/near; 1e-3 keeps D32F's steps far below a texel.
        let near = (distance - radius).max(far * 1e-3);
        let up = if axis.cross(DVec3::Y).length() < 1e-3 {
            DVec3::Z
        } else {
            DVec3::Y
        };
        let view = Mat4::look_at_rh(eye.as_vec3(), centre.as_vec3(), up.as_vec3());
        let proj = Mat4::perspective_rh((2.0 * half) as f32, 1.0, near as f32, far as f32);
        Some(proj * view)
    }

    /// Binds `mesh` and `shadows` (a new descriptor set when the vertex buffer changed) for the
    /// eye at `eye` (object frame, mm); the first call allocates the depth atlas.
    pub fn bind(
        &mut self,
        ctx: &Context,
        mesh: &GpuMesh,
        shadows: &ShadowMaps,
        eye: Vec3,
    ) -> Result<(), Error> {
        if mesh.vertex_count() != self.vertex_count {
            return Err(invalid(
                "single scattering",
                format!(
                    "sized for {} vertices, the mesh has {}: call resize",
                    self.vertex_count,
                    mesh.vertex_count()
                ),
            ));
        }
        if self.depths.is_none() {
            let rows = (shadows.max_views() + 1).div_ceil(self.columns);
            self.depths = Some(Image::new(
                ctx,
                &ImageDesc {
                    name: "single scattering depths",
                    width: self.columns * self.tile,
                    height: rows * self.tile,
                    format: DEPTHS_FORMAT,
                    usage: vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT
                        | vk::ImageUsageFlags::SAMPLED,
                },
            )?);
            self.set = None;
        }
        self.exit_view = match self.eye_view(eye.as_dvec3()) {
            Some(view_proj) => ExitView {
                view_proj: view_proj.to_cols_array(),
                tile: [0.0, 0.0, self.tile as f32, 0.0],
                bounds: [
                    self.bounds.0.x as f32,
                    self.bounds.0.y as f32,
                    self.bounds.0.z as f32,
                    (self.bounds.1 * EYE_VIEW_MARGIN) as f32,
                ],
                entry_inverses: [[0.0; 16]; MAX_SHADOW_VIEWS],
            },
            None => bytemuck::Zeroable::zeroed(),
        };
        for (inverse, view) in self.exit_view.entry_inverses.iter_mut().zip(&self.views) {
            *inverse = view
                .view_proj
                .as_dmat4()
                .inverse()
                .as_mat4()
                .to_cols_array();
        }
        let Some(depths) = &self.depths else {
            return Err(invalid("single scattering", "no depth atlas".into()));
        };
        if self.set.is_none() || self.bound_vertices != mesh.vertex_buffer().raw {
            self.set = Some(self.pipeline.allocate_set(
                ctx,
                &[
                    DescriptorWrite::StorageBuffer {
                        name: "vertices",
                        buffer: mesh.vertex_buffer(),
                    },
                    DescriptorWrite::StorageBuffer {
                        name: "scattered",
                        buffer: &self.output,
                    },
                    DescriptorWrite::SampledImage {
                        name: "shadow_atlas",
                        image: &shadows.atlas,
                        sampler: self.sampler.raw,
                        layout: vk::ImageLayout::DEPTH_READ_ONLY_OPTIMAL,
                    },
                    DescriptorWrite::StorageBuffer {
                        name: "scene",
                        buffer: &self.scene,
                    },
                    DescriptorWrite::SampledImage {
                        name: "depths",
                        image: depths,
                        sampler: self.sampler.raw,
                        layout: vk::ImageLayout::DEPTH_READ_ONLY_OPTIMAL,
                    },
                    DescriptorWrite::StorageBuffer {
                        name: "exit_view",
                        buffer: &self.exit_buffer,
                    },
                    DescriptorWrite::StorageBuffer {
                        name: "medium",
                        buffer: &self.medium,
                    },
                ],
            )?);
            self.bound_vertices = mesh.vertex_buffer().raw;
        }
        self.upload_medium = self.medium_dirty;
        self.medium_dirty = false;
        Ok(())
    }

    /// Records the depth pre-pass: the eye's back faces into tile 0 (when the eye has a view),
    /// the shadow views without bias into tiles 1 + i.
    ///
    /// # Safety
    /// `cb` must be recording outside a rendering scope, inside a frame-graph pass declaring
    /// [`Self::depth_uses`], after [`Self::bind`]; `mesh` and `self` must outlive it.
    pub unsafe fn record_depths(
        &self,
        ctx: &Context,
        cb: vk::CommandBuffer,
        mesh: &GpuMesh,
    ) -> Result<(), Error> {
        let Some(depths) = &self.depths else {
            return Err(invalid(
                "single scattering",
                "depths recorded before bind".into(),
            ));
        };
        let extent = depths.extent();
        // Only the tiles in use are cleared and drawn (the eye's and the views'): the atlas is
        // sized for the most views (49 tiles of 512^2 by default, 51 MB a clear), as the
        // shadow pass's. The march reads no other tile.
        let used = self.views.len() as u32 + 1;
        let area = vk::Extent2D {
            width: used.min(self.columns) * self.tile,
            height: used.div_ceil(self.columns) * self.tile,
        };
        let depth = vk::RenderingAttachmentInfo::default()
            .image_view(depths.view)
            .image_layout(vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL)
            .load_op(vk::AttachmentLoadOp::CLEAR)
            .store_op(vk::AttachmentStoreOp::STORE)
            .clear_value(vk::ClearValue {
                depth_stencil: vk::ClearDepthStencilValue {
                    depth: 1.0,
                    stencil: 0,
                },
            });
        let rendering = vk::RenderingInfo::default()
            .render_area(vk::Rect2D {
                offset: vk::Offset2D::default(),
                extent: area,
            })
            .layer_count(1)
            .depth_attachment(&depth);
        // The environment's closed form alone reads no depth: the atlas is only cleared.
        let draw = !self.environment_only();
        let eye = (draw && self.exit_view.tile[2] > 0.0).then(|| {
            (
                &self.back_faces,
                Mat4::from_cols_array(&self.exit_view.view_proj),
                0,
            )
        });
        let lights = self
            .views
            .iter()
            .enumerate()
            .filter(|_| draw)
            .map(|(i, v)| (&self.front_faces, v.view_proj, i as u32 + 1));
        // SAFETY: the caller's contract; the pipelines' formats match the rendering scope.
        unsafe {
            ctx.raw().cmd_begin_rendering(cb, &rendering);
            for (pipeline, view_proj, tile) in eye.into_iter().chain(lights) {
                let push = ShadowPush {
                    view_proj: view_proj.to_cols_array(),
                };
                pipeline.bind(ctx, cb, vk::DescriptorSet::null(), &push, extent);
                let origin = [
                    (tile % self.columns) * self.tile,
                    (tile / self.columns) * self.tile,
                ];
                ctx.raw().cmd_set_viewport(
                    cb,
                    0,
                    &[vk::Viewport {
                        x: origin[0] as f32,
                        y: origin[1] as f32,
                        width: self.tile as f32,
                        height: self.tile as f32,
                        min_depth: 0.0,
                        max_depth: 1.0,
                    }],
                );
                // The scissor keeps geometry clipped to this tile out of its neighbours.
                ctx.raw().cmd_set_scissor(
                    cb,
                    0,
                    &[vk::Rect2D {
                        offset: vk::Offset2D {
                            x: origin[0] as i32,
                            y: origin[1] as i32,
                        },
                        extent: vk::Extent2D {
                            width: self.tile,
                            height: self.tile,
                        },
                    }],
                );
                mesh.draw(ctx, cb);
            }
            ctx.raw().cmd_end_rendering(cb);
        }
        Ok(())
    }

    /// Records the march for the eye at `eye` (object frame, mm); `clear`: write zeros instead
    /// (the frame skips the march, and its last output must not stand).
    ///
    /// # Safety
    /// `cb` must be recording outside a rendering scope, inside a frame-graph pass declaring
    /// [`Self::uses`], after [`Self::bind`] with the same mesh and shadows; all of it must
    /// outlive the execution.
    pub unsafe fn record(
        &self,
        ctx: &Context,
        cb: vk::CommandBuffer,
        eye: Vec3,
        clear: bool,
    ) -> Result<(), Error> {
        let Some(set) = self.set else {
            return Err(invalid("single scattering", "recorded before bind".into()));
        };
        let c = self.coefficients;
        let f = |v: [f64; 3], w: f32| [v[0] as f32, v[1] as f32, v[2] as f32, w];
        let push = ScatterPush {
            eye: eye.extend(1.0).to_array(),
            sigma_s: f(c.sigma_s, self.eta),
            sigma_a: f(c.sigma_a, (START_OFFSET * self.radius) as f32),
            vertex_count: self.vertex_count as u32,
            samples: self.params.samples,
            mode: match (clear, self.params.mode) {
                (true, _) => 0,
                (false, ScatterMode::Difference) => 1,
                (false, ScatterMode::Full) if self.environment_only() => 3,
                (false, ScatterMode::Full) => 2,
            },
            normal_offset: NORMAL_OFFSET_TEXELS,
            columns: self.columns,
        };
        // SAFETY: the caller's contract; the scene buffer is under vkCmdUpdateBuffer's 65536 bytes.
        unsafe {
            // why: the last frame's march read the scene buffer before this update (WAR).
            barrier::memory(ctx, cb, Access::ComputeRead, Access::TransferDst);
            ctx.raw().cmd_update_buffer(
                cb,
                self.scene.raw,
                0,
                bytemuck::bytes_of(&*self.scene_data),
            );
            ctx.raw().cmd_update_buffer(
                cb,
                self.exit_buffer.raw,
                0,
                bytemuck::bytes_of(&self.exit_view),
            );
            if self.upload_medium {
                // vkCmdUpdateBuffer takes at most 65536 bytes a call.
                let bytes: &[u8] = bytemuck::cast_slice(&self.medium_data);
                for (i, chunk) in bytes.chunks(UPDATE_CHUNK).enumerate() {
                    let offset = (i * UPDATE_CHUNK) as u64;
                    ctx.raw()
                        .cmd_update_buffer(cb, self.medium.raw, offset, chunk);
                }
            }
            // why: the march reads the scene just written (RAW).
            barrier::memory(ctx, cb, Access::TransferDst, Access::ComputeRead);
            self.pipeline
                .dispatch(ctx, cb, set, &push, [self.vertex_count as u32, 1, 1]);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene(lights: &[&str], environment: Environment) -> Scene {
        Scene {
            lights: lights.iter().map(|l| l.parse().unwrap()).collect(),
            environment,
        }
    }

    const BOUNDS: (DVec3, f64) = (DVec3::ZERO, 10.0);

    #[test]
    fn black_and_dim_lights_are_not_marched() {
        // The environment sphere's placeholder: black, whatever the sky.
        let s = scene(&["dir:0,-1,0:0,0,0"], Environment::Constant([0.5; 3]));
        assert_eq!(marched_lights(&s, BOUNDS), [false]);
        let s = scene(&["dir:0,-1,0:0,0,0"], Environment::None);
        assert_eq!(marched_lights(&s, BOUNDS), [false]);
        // Against a sky of irradiance pi: just above and just below the budget.
        let sky = Environment::Constant([1.0; 3]);
        let bright = format!("dir:0,-1,0:{},0,0", 1.1e-3 * std::f64::consts::PI);
        let dim = format!("dir:0,-1,0:0,{},0", 0.9e-3 * std::f64::consts::PI);
        let s = scene(&[&bright, &dim], sky);
        assert_eq!(marched_lights(&s, BOUNDS), [true, false]);
        // A point light: intensity over the squared distance to the sphere's nearest point.
        let s = scene(&["point:0,0,30:400,400,400", "dir:0,-1,0:0.9,0.9,0.9"], sky);
        assert_eq!(marched_lights(&s, BOUNDS), [true, true]);
        let s = scene(&["point:0,0,30:0.3,0.3,0.3", "dir:0,-1,0:1000,0,0"], sky);
        assert_eq!(marched_lights(&s, BOUNDS), [false, true]);
        // Inside the bounding sphere: no bound, marched, and it darkens nothing else.
        let s = scene(&["point:0,0,1:1e-6,0,0", "dir:0,-1,0:0.01,0,0"], sky);
        assert_eq!(marched_lights(&s, BOUNDS), [true, true]);
    }

    #[test]
    fn the_medium_grid_holds_the_field_at_its_nodes() {
        use crate::material::{Coefficients, Procedural};
        let c = |s: f64, a: f64| Coefficients {
            sigma_s: [s; 3],
            sigma_a: [a; 3],
        };
        let field = MaterialField::procedural(
            Procedural::Split {
                normal: DVec3::Y,
                offset: 0.3,
                below: c(1.0, 0.01),
                above: c(2.0, 0.5),
            },
            1.3,
        )
        .unwrap();
        let positions = [DVec3::new(-2.0, -4.0, -1.0), DVec3::new(6.0, 4.0, 3.0)];
        let data = medium_data(&field, &positions);
        let n = MEDIUM_NODES as usize;
        assert_eq!(data.len(), 3 + 2 * n * n * n);
        let header: MediumHeader = bytemuck::cast_slice(&data[..3])[0];
        assert_eq!(header.nodes[..2], [MEDIUM_NODES, 1]);
        assert_eq!(header.origin[..3], [-2.0, -4.0, -1.0]);
        let spacing = DVec3::new(8.0, 8.0, 4.0) / (n - 1) as f64;
        for (i, j, k) in [(0, 0, 0), (n - 1, n - 1, n - 1), (5, 16, 7), (20, 17, 30)] {
            let p =
                DVec3::new(-2.0, -4.0, -1.0) + spacing * DVec3::new(i as f64, j as f64, k as f64);
            let node = (k * n + j) * n + i;
            let want = field.sample(p);
            assert_eq!(data[3 + 2 * node][..3], want.sigma_s.map(|v| v as f32));
            assert_eq!(data[3 + 2 * node + 1][..3], want.sigma_a.map(|v| v as f32));
        }
        // Homogeneous: the header alone, flagged off.
        let m = crate::material::Material::preset("marble").unwrap();
        let data = medium_data(&MaterialField::Homogeneous(m), &positions);
        assert_eq!(data.len(), 3);
        assert_eq!(
            bytemuck::cast_slice::<_, MediumHeader>(&data)[0].nodes[1],
            0
        );
    }

    #[test]
    fn an_sh_environment_bounds_its_irradiance() {
        // Radiance 1 + w_y: irradiance pi + 2 pi / 3 n_y, peak at +Y.
        let mut c = [[0.0; 3]; 9];
        c[0] = [1.0 / 0.282095; 3];
        c[1] = [1.0 / 0.488603; 3];
        let e = Environment::SphericalHarmonics(c);
        let exact = e.irradiance(DVec3::Y)[0];
        assert!((peak_environment_irradiance(&e) - exact).abs() < 1e-12 * exact);
    }
}
