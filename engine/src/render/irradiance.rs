//! [`IrradiancePass`]: the irradiance gather of DESIGN section 5 (paper Eq. 3 and section 5). For
//! every surface-node texel of a level it writes the transmitted irradiance (DESIGN section 2)
//! `q = sum over lights of E max(0, n.l) F_t(eta, theta_l) visibility + E_env(n) (1 - F_dr,ext)`,
//! times `q_scale`, into an RGBA16F storage image. Visibility is 3x3 PCF in the light's
//! [`ShadowMaps`] view; the environment is constant (`E = pi L`) or order-2 spherical harmonics
//! (Ramamoorthi and Hanrahan 2001, Eq. 13), with no visibility, exactly as the f64 reference
//! [`crate::scene::Scene::surface_irradiance`].
//!
//! Interface with the solver (one set of images per level, texel (u, v) = `packing.texels`):
//! - `surface_position`: RGBA32F, rgb = node position (mm), a = 1 at a surface node, else 0;
//! - `surface_normal`: RGBA16F, rgb = outward unit normal;
//! - `q`: RGBA16F storage image in GENERAL, rgb = q * q_scale (written only where a = 1).
//!
//! [`IrradiancePass::uses`] declares the pass's resources to a [`crate::frame::FrameGraph`], which
//! places the barriers before and after it.
//! [`SurfaceImages::upload`] builds all three from a baked [`GraphLevel`].
//!
//! ```no_run
//! use translucent::render::{GatherScene, IrradiancePass, ShadowMaps, ShadowMapsDesc, SurfaceImages};
//! use translucent::scene::{Environment, Scene};
//! # fn f(ctx: &translucent::vk::Context, graph: &translucent::QuadGraph, cb: ash::vk::CommandBuffer,
//! #      caster: &translucent::mesh::GpuMesh) -> Result<(), translucent::Error> {
//! let scene = Scene { lights: vec!["dir:1,-1,0:3,3,3".parse()?], environment: Environment::Constant([0.1; 3]) };
//! let level = graph.finest();
//! let mut shadows = ShadowMaps::new(ctx, &ShadowMapsDesc::default())?;
//! shadows.set_lights(&scene.lights, level.bounding_sphere(), true)?;
//! let gather = IrradiancePass::new(ctx, 4)?;
//! let images = SurfaceImages::upload(ctx, level)?;
//! let set = gather.bind_level(ctx, &shadows, &images.position, &images.normal, &images.q, images.surface_rows)?;
//! let uniforms = GatherScene::new(&scene, &shadows)?;
//! let q_scale = translucent::render::q_scale_for(&scene, level, 1.3);
//! // The passes inside one frame graph: it places the atlas and q barriers from `uses`.
//! let mut frame = translucent::frame::FrameGraph::new(ctx);
//! frame.pass("shadow_map").uses(shadows.uses(caster)).record(|p| {
//!     // SAFETY: inside a pass declaring `shadows.uses`.
//!     unsafe { shadows.record(p.ctx, p.cb, caster) };
//!     Ok(())
//! });
//! frame
//!     .pass("gather_q")
//!     .uses(IrradiancePass::uses(&shadows, &images.position, &images.normal, &images.q))
//!     .record(|p| {
//!         // SAFETY: inside a pass declaring `IrradiancePass::uses`.
//!         unsafe {
//!             gather.record_scene(p.ctx, p.cb, &uniforms);
//!             gather.record(p.ctx, p.cb, &set, q_scale, 1.3)?;
//!         }
//!         Ok(())
//!     });
//! // SAFETY: `cb` is recording outside a rendering scope; everything outlives its execution.
//! unsafe { frame.execute(cb, None, false)? };
//! # Ok(()) }
//! ```

use ash::vk;
use glam::DVec3;

use super::shadow_maps::{ShadowMaps, MAX_LIGHTS, MAX_SHADOW_VIEWS};
use super::RenderError;
use crate::material::{fresnel, DiffusionCoefficient};
use crate::quadgraph::graph::GraphLevel;
use crate::scene::{Environment, Light, Scene};
use crate::shader::{ComputePipeline, ComputePipelineDesc, DescriptorWrite};
use crate::vk::barrier::Use;
use crate::vk::{
    barrier, Access, Buffer, BufferDesc, Context, Image, ImageDesc, MemoryUse, Sampler,
};

/// Format of `surface_position`.
pub const SURFACE_POSITION_FORMAT: vk::Format = vk::Format::R32G32B32A32_SFLOAT;
/// Format of `surface_normal`.
pub const SURFACE_NORMAL_FORMAT: vk::Format = vk::Format::R16G16B16A16_SFLOAT;
/// Format of `q`.
pub const Q_FORMAT: vk::Format = vk::Format::R16G16B16A16_SFLOAT;
/// Largest finite fp16: the gather saturates there.
pub const FP16_MAX: f32 = 65504.0;

/// Push constants of `irradiance/gather_q.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GatherPush {
    /// Texture width and the rows holding surface nodes.
    pub extent: [u32; 2],
    pub q_scale: f32,
    pub eta: f32,
    /// Normal offset of the shadow lookup, in shadow-map texels.
    pub normal_offset: f32,
    /// Fraction of a diffuse environment irradiance transmitted into the object: 1 - F_dr,ext
    /// (the flux-only query) or 1 - 2 C1(1/eta) (the moments query of DESIGN 2.6).
    pub env_transmittance: f32,
    /// 1: the collimated source reads each node's coefficients from the level's kappa and mu
    /// images (a heterogeneous material); 0: `beam_sigma_s` and `beam_sigma_a`.
    pub beam_local: f32,
    /// 1: a light the node's PCF sees partly occluded enters as the boundary flux
    /// ([`BeamSource::shadow_edge_flux`]).
    pub beam_edge: f32,
    /// rgb: sigma_s'; w: 1 for the collimated source (DESIGN 2.7), 0 for the boundary flux.
    pub beam_sigma_s: [f32; 4],
    /// rgb: sigma_a; w: the boundary constant A.
    pub beam_sigma_a: [f32; 4],
    /// x: (1 - 2 C1) / 4, y: (1 - 3 C2) / 2, z: the flux gain, w: 1 for the second-collision
    /// source.
    pub beam_exit: [f32; 4],
    /// rgb: the diffusion coefficient D of a homogeneous material; w: 1 for Grosjean's D (the
    /// gather inverts a heterogeneous level's kappa with it), 0 for 1 / (3 sigma_t').
    pub beam_kappa: [f32; 4],
    /// 1: a node facing away from a light gets the beam through the wall
    /// ([`BeamSource::continuation`]).
    pub beam_continuation: f32,
    /// 1: each lit node's beam taken from upstream on the curved surface
    /// ([`BeamSource::upstream`]), its mean curvature in the surface normal's w; 2: with the
    /// curved particular solution ([`BeamSource::curved`]).
    pub beam_upstream: f32,
}

/// The collimated source of DESIGN 2.7 (what the gather needs of the solver's boundary model,
/// DESIGN 2.6): the lights' beams enter as analytic particular solutions instead of a boundary
/// flux (see `gather_q.comp`). A heterogeneous material takes each node's own coefficients
/// (`local`, the level bound with its kappa and mu images).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BeamSource {
    /// Reduced scattering sigma_s' and absorption sigma_a per channel (1/mm).
    pub sigma_s: [f32; 3],
    pub sigma_a: [f32; 3],
    /// The diffusion coefficient D per channel (mm; unused when `local`) and its kind.
    pub kappa: [f32; 3],
    pub diffusion: DiffusionCoefficient,
    /// The boundary constant A = (1 + 3 C2) / (1 - 2 C1).
    pub a: f32,
    /// The exit query's weights of phi and of D dphi/dz_in: (1 - 2 C1) / 4 and (1 - 3 C2) / 2.
    pub exit_phi: f32,
    pub exit_flux: f32,
    /// The Robin rows' flux gain 4 / (1 - 2 C1): the beam's right-hand side is written into q
    /// divided by it.
    pub flux_gain: f32,
    /// The coefficients per node from the level's kappa and mu images (a heterogeneous
    /// material; `sigma_s`, `sigma_a` unused), where the level was bound with them.
    pub local: bool,
    /// The second-collision source (DESIGN 2.8's second option): the first-collision density
    /// times `transport::second_collision_ratio`, decaying with `transport::second_collision_fit`'s
    /// fitted depth (both moments of the true density); single scattering is then added whole.
    pub second_collision: bool,
    /// The shadow-edge fallback of DESIGN 2.7: a light the node's 3x3 PCF sees partly occluded
    /// (within about a shadow texel and a half of a shadow edge or the terminator) enters as the
    /// boundary flux.
    pub shadow_edge_flux: bool,
    /// Continuation through walls (the f64 reference's `Transport::continuation`): a node
    /// facing away from a light gets the particular solution of the beam that entered on the
    /// light's side, attenuated along the refracted path (the entry found in the light's shadow
    /// view, its face taken parallel: exact for a slab). Without it the far face of a thin wall
    /// knows nothing of the beam (T 1.06-2.3x too bright below 4 mean free paths,
    /// benches/thinwall/slab_rule.py).
    pub continuation: bool,
    /// The upstream beam (`solver::transport::upstream_beam`, issue 12's back-lit crescent): a
    /// beam travels about a mean free path along a curved surface before its first collision, so
    /// a node's incidence cosine is mu + c (1 - mu^2) and its irradiance factor mu + c (1 - 3
    /// mu^2), c = H / (eta sigma_t') with the node's mean curvature H (the surface normal's w);
    /// nodes just past the terminator get light, visibility tested a mean free path upstream.
    pub upstream: bool,
    /// With `upstream`: the curved particular solution (`solver::transport::curved_particular`:
    /// irradiance factor mu_up, the narrowing and the lateral terms in K); push constant 2.
    pub curved: bool,
}

/// One light as `gather_q.comp` reads it (std430, all vec4).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GatherLight {
    /// xyz: position, or direction of travel (directional); w: kind (0 dir, 1 point, 2 spot).
    pub position: [f32; 4],
    /// xyz: spot axis; w: cos(outer).
    pub direction: [f32; 4],
    /// rgb: irradiance or intensity; w: cos(inner).
    pub colour: [f32; 4],
    /// x: first shadow view, y: view count.
    pub views: [u32; 4],
}

/// One shadow view as `gather_q.comp` reads it.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GatherView {
    pub view_proj: [f32; 16],
    /// xy: atlas origin (texels), z: tile size, w: texel size in mm (orthographic).
    pub tile: [f32; 4],
    /// xyz: eye, w: texel size per mm of distance (perspective).
    pub eye: [f32; 4],
}

/// The `GatherScene` storage buffer of `gather_q.comp`: lights, environment, shadow views.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GatherScene {
    /// x: lights, y: environment (0 none, 1 constant, 2 SH).
    pub counts: [u32; 4],
    /// rgb: SH coefficients of radiance, or `sh[0]` the constant radiance.
    pub sh: [[f32; 4]; 9],
    pub lights: [GatherLight; MAX_LIGHTS],
    pub views: [GatherView; MAX_SHADOW_VIEWS],
}

fn invalid(what: &str, problem: impl Into<String>) -> RenderError {
    RenderError::Invalid {
        what: what.into(),
        problem: problem.into(),
    }
}

fn f4(v: DVec3, w: f32) -> [f32; 4] {
    [v.x as f32, v.y as f32, v.z as f32, w]
}

fn rgb(c: [f64; 3], w: f32) -> [f32; 4] {
    [c[0] as f32, c[1] as f32, c[2] as f32, w]
}

impl GatherScene {
    /// The lights and environment of `scene` with the shadow views of `shadows` (which must
    /// have been given the same lights). More than [`MAX_LIGHTS`] lights is a typed error.
    pub fn new(scene: &Scene, shadows: &ShadowMaps) -> Result<GatherScene, RenderError> {
        scene.validate()?;
        if scene.lights.len() > MAX_LIGHTS {
            return Err(invalid(
                "lights",
                format!(
                    "{} lights; the irradiance gather handles at most {MAX_LIGHTS}",
                    scene.lights.len()
                ),
            ));
        }
        let light_views = shadows.light_views();
        if light_views.len() != scene.lights.len() {
            return Err(invalid(
                "shadow maps",
                format!(
                    "fitted for {} lights, the scene has {}: call ShadowMaps::set_lights with the scene's lights",
                    light_views.len(),
                    scene.lights.len()
                ),
            ));
        }
        let mut out = GatherScene::zeroed();
        out.counts[0] = scene.lights.len() as u32;
        for ((slot, light), &(first, count)) in
            out.lights.iter_mut().zip(&scene.lights).zip(light_views)
        {
            let views = [first, count, 0, 0];
            *slot = match *light {
                Light::Directional {
                    direction,
                    irradiance,
                } => GatherLight {
                    position: f4(direction.normalize(), 0.0),
                    direction: [0.0; 4],
                    colour: rgb(irradiance, 0.0),
                    views,
                },
                Light::Point {
                    position,
                    intensity,
                } => GatherLight {
                    position: f4(position, 1.0),
                    direction: [0.0; 4],
                    colour: rgb(intensity, 0.0),
                    views,
                },
                Light::Spot {
                    position,
                    direction,
                    intensity,
                    inner_deg,
                    outer_deg,
                } => GatherLight {
                    position: f4(position, 2.0),
                    direction: f4(direction.normalize(), outer_deg.to_radians().cos() as f32),
                    colour: rgb(intensity, inner_deg.to_radians().cos() as f32),
                    views,
                },
            };
        }
        match scene.environment {
            Environment::None => {}
            Environment::Constant(l) => {
                out.counts[1] = 1;
                out.sh[0] = rgb(l, 0.0);
            }
            Environment::SphericalHarmonics(c) => {
                out.counts[1] = 2;
                for (dst, src) in out.sh.iter_mut().zip(c) {
                    *dst = rgb(src, 0.0);
                }
            }
        }
        for (dst, v) in out.views.iter_mut().zip(shadows.views()) {
            *dst = GatherView {
                view_proj: v.view_proj.to_cols_array(),
                tile: [
                    v.origin[0] as f32,
                    v.origin[1] as f32,
                    v.size as f32,
                    v.texel_mm,
                ],
                eye: [v.eye.x, v.eye.y, v.eye.z, v.texel_per_mm],
            };
        }
        Ok(out)
    }

    fn zeroed() -> GatherScene {
        bytemuck::Zeroable::zeroed()
    }
}

/// A q scale for fp16 storage: the largest unshadowed q over the level's surface nodes maps to
/// 2048, so phi (up to ~7 q) stays below fp16's 65504 and dim light keeps fp16's relative precision.
/// 1 when nothing is lit.
pub fn q_scale_for(scene: &Scene, level: &GraphLevel, eta: f64) -> f32 {
    let max_q = scene
        .surface_irradiance(level, eta, None)
        .iter()
        .flatten()
        .fold(0.0f64, |m, &v| m.max(v));
    if !(max_q > 0.0 && max_q.is_finite()) {
        return 1.0;
    }
    // Clamped to normal f32 rather than replaced by 1: an unrepresentable 2048 / max_q used to
    // fall back to exposure 1, under which q below 6e-8 (fp16's smallest subnormal) flushed to
    // zero (J+ = 0 for a light of 1e-37) and q above 65504 saturated. The upper clamp bites for
    // light dimmer than ~6e-36; the lower one, lights being bounded by
    // `solver::scene::MAX_LIGHT_COLOUR`, only for point lights almost touching the surface.
    (2048.0 / max_q).clamp(f64::from(f32::MIN_POSITIVE), f64::from(f32::MAX)) as f32
}

/// A descriptor set of the gather for one level's images.
#[derive(Debug)]
pub struct GatherLevel {
    set: vk::DescriptorSet,
    extent: [u32; 2],
    /// A `particular` image of its own is bound (zeroed when the lights are a boundary flux).
    particular: bool,
    /// The level's per-node kappa and mu images are bound (a heterogeneous material).
    material: bool,
}

/// The gather pipeline, its scene buffer and the shadow atlas sampler.
pub struct IrradiancePass {
    pipeline: ComputePipeline<GatherPush>,
    scene: Buffer,
    sampler: Sampler,
    /// Normal offset of shadow lookups in texels of the light's view (default 1.5).
    pub normal_offset: f32,
    /// Transmitted fraction of a diffuse environment irradiance; `None`: 1 - F_dr,ext(eta)
    /// (DESIGN section 2). The moments query (DESIGN 2.6) sets 1 - 2 C1(1/eta).
    pub env_transmittance: Option<f32>,
    /// The lights as the collimated source of DESIGN 2.7 (`None`: a boundary flux). Needs the
    /// levels bound with a `particular` image ([`Self::bind_level_with`]).
    pub beam: Option<BeamSource>,
}

impl IrradiancePass {
    /// The pass, with room for `max_levels` level descriptor sets.
    pub fn new(ctx: &Context, max_levels: u32) -> Result<IrradiancePass, RenderError> {
        let pipeline = ComputePipeline::new(
            ctx,
            &ComputePipelineDesc {
                name: "gather q",
                shader: "irradiance/gather_q.comp",
                bindings: &[
                    "surface_position",
                    "surface_normal",
                    "q",
                    "shadow_atlas",
                    "scene",
                    "particular",
                    "kappa",
                    "mu",
                    "surface_anisotropy",
                ],
                max_sets: max_levels.max(1),
            },
        )?;
        let scene = Buffer::new(
            ctx,
            &BufferDesc {
                name: "gather scene",
                size: std::mem::size_of::<GatherScene>() as u64,
                usage: vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
                memory: MemoryUse::GpuOnly,
            },
        )?;
        // texelFetch ignores filtering; nearest and no compare keep the depth values raw for the
        // shader's own comparison (PCF inside the tile, never across tiles).
        let info = vk::SamplerCreateInfo::default()
            .mag_filter(vk::Filter::NEAREST)
            .min_filter(vk::Filter::NEAREST)
            .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_w(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .max_lod(0.0);
        let sampler = Sampler::new(ctx, "shadow atlas sampler", &info)?;
        Ok(IrradiancePass {
            pipeline,
            scene,
            sampler,
            normal_offset: 1.5,
            env_transmittance: None,
            beam: None,
        })
    }

    /// A descriptor set for one level: checks the three images' formats, usages and sizes.
    /// `surface_rows`: rows of the level's textures that hold surface nodes (`packing.surface_rows`).
    pub fn bind_level(
        &self,
        ctx: &Context,
        shadows: &ShadowMaps,
        position: &Image,
        normal: &Image,
        q: &Image,
        surface_rows: u32,
    ) -> Result<GatherLevel, RenderError> {
        // No collimated source: `particular` is never written, q stands in for the binding, and
        // the anisotropy (read only by the collimated source's upstream beam) is the normal's.
        self.bind_level_with(
            ctx,
            shadows,
            position,
            normal,
            normal,
            q,
            q,
            None,
            surface_rows,
        )
    }

    /// [`Self::bind_level`] with the image the collimated source ([`Self::beam`]) writes its
    /// exit-query part into (rgba16f, pre-scaled like q, the same texels) and, for a
    /// heterogeneous material, the level's per-node kappa and mu (rgba32f, the same texels);
    /// `anisotropy` is the surface nodes' curvature anisotropy (rgba16f like the normal, the
    /// upstream beam's; `solver::gpu::GpuDiffusion::surface_anisotropy`).
    #[allow(clippy::too_many_arguments)]
    pub fn bind_level_with(
        &self,
        ctx: &Context,
        shadows: &ShadowMaps,
        position: &Image,
        normal: &Image,
        anisotropy: &Image,
        q: &Image,
        particular: &Image,
        material: Option<(&Image, &Image)>,
        surface_rows: u32,
    ) -> Result<GatherLevel, RenderError> {
        for (image, format, role) in [
            (position, SURFACE_POSITION_FORMAT, "surface_position"),
            (normal, SURFACE_NORMAL_FORMAT, "surface_normal"),
            (anisotropy, SURFACE_NORMAL_FORMAT, "surface_anisotropy"),
            (q, Q_FORMAT, "q"),
            (particular, Q_FORMAT, "particular"),
        ] {
            if image.format != format {
                return Err(invalid(
                    role,
                    format!(
                        "image {:?} is {:?}, the gather needs {format:?}",
                        image.name, image.format
                    ),
                ));
            }
            if !image.usage.contains(vk::ImageUsageFlags::STORAGE) {
                return Err(invalid(
                    role,
                    format!("image {:?} lacks STORAGE usage", image.name),
                ));
            }
            if image.width != q.width || image.height < surface_rows {
                return Err(invalid(
                    role,
                    format!(
                        "image {:?} is {}x{}; needs width {} and at least {surface_rows} rows",
                        image.name, image.width, image.height, q.width
                    ),
                ));
            }
        }
        // No per-node material: the position image (rgba32f, checked above as itself) stands in,
        // never read.
        let (kappa, mu) = material.unwrap_or((position, position));
        for (image, role) in [(kappa, "kappa"), (mu, "mu")] {
            if image.format != SURFACE_POSITION_FORMAT
                || !image.usage.contains(vk::ImageUsageFlags::STORAGE)
                || image.width != q.width
                || image.height < surface_rows
            {
                return Err(invalid(
                    role,
                    format!(
                        "image {:?} is {:?} {}x{}; the gather needs a {SURFACE_POSITION_FORMAT:?} \
                         storage image {} wide with at least {surface_rows} rows",
                        image.name, image.format, image.width, image.height, q.width
                    ),
                ));
            }
        }
        let set = self.pipeline.allocate_set(
            ctx,
            &[
                DescriptorWrite::storage_image("surface_position", position),
                DescriptorWrite::storage_image("surface_normal", normal),
                DescriptorWrite::storage_image("surface_anisotropy", anisotropy),
                DescriptorWrite::storage_image("q", q),
                DescriptorWrite::storage_image("particular", particular),
                DescriptorWrite::storage_image("kappa", kappa),
                DescriptorWrite::storage_image("mu", mu),
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
            ],
        )?;
        Ok(GatherLevel {
            set,
            extent: [q.width, surface_rows],
            particular: particular.raw != q.raw,
            material: material.is_some(),
        })
    }

    /// Writes the lights, environment and shadow views into the pass's buffer, in the command
    /// stream (once per frame, before the levels' [`IrradiancePass::record`]).
    ///
    /// # Safety
    /// `cb` must be recording outside a rendering scope; `self` must outlive its execution.
    pub unsafe fn record_scene(&self, ctx: &Context, cb: vk::CommandBuffer, scene: &GatherScene) {
        // SAFETY: the caller's contract; the size is the buffer's (< 65536, vkCmdUpdateBuffer's limit).
        unsafe {
            // why: earlier gathers' reads of the scene buffer must finish before the update (WAR).
            barrier::memory(ctx, cb, Access::ComputeRead, Access::TransferDst);
            ctx.raw()
                .cmd_update_buffer(cb, self.scene.raw, 0, bytemuck::bytes_of(scene));
            // why: the gather reads the scene just written (RAW).
            barrier::memory(ctx, cb, Access::TransferDst, Access::ComputeRead);
        }
    }

    /// What a gather of one level uses: the shadow atlas, the level's surface position and
    /// normal images, and its q image (written).
    pub fn uses<'a>(
        shadows: &'a ShadowMaps,
        position: &'a Image,
        normal: &'a Image,
        q: &'a Image,
    ) -> [Use<'a>; 4] {
        [
            Use::image(&shadows.atlas, Access::DepthSampledShaders),
            Use::image(position, Access::ComputeRead),
            Use::image(normal, Access::ComputeRead),
            Use::image(q, Access::ComputeWrite),
        ]
    }

    /// Gathers q for one level (bound by [`Self::bind_level`]). Bad `q_scale` or `eta` is a typed
    /// error (nothing recorded).
    ///
    /// # Safety
    /// `cb` must be recording outside a rendering scope, after [`IrradiancePass::record_scene`],
    /// inside a frame-graph pass declaring [`Self::uses`] of the level's images; all of it must
    /// outlive the execution.
    pub unsafe fn record(
        &self,
        ctx: &Context,
        cb: vk::CommandBuffer,
        level: &GatherLevel,
        q_scale: f32,
        eta: f32,
    ) -> Result<(), RenderError> {
        if !(q_scale.is_finite() && q_scale > 0.0) {
            return Err(invalid(
                "q scale",
                format!("{q_scale} is not finite and positive"),
            ));
        }
        let (lo, hi) = fresnel::ETA_RANGE;
        if !(f64::from(eta) >= lo && f64::from(eta) <= hi) {
            return Err(invalid("eta", format!("{eta} is outside [{lo}, {hi}]")));
        }
        let push = GatherPush {
            extent: level.extent,
            q_scale,
            eta,
            normal_offset: self.normal_offset,
            env_transmittance: self
                .env_transmittance
                .unwrap_or((1.0 - fresnel::external_diffuse_reflectance(f64::from(eta))) as f32),
            beam_local: match self.beam {
                Some(b) if b.local && level.material => 1.0,
                _ => 0.0,
            },
            beam_edge: match self.beam {
                Some(b) if b.shadow_edge_flux => 1.0,
                _ => 0.0,
            },
            // w: 1 beams, 0 a boundary flux (the level's particular image zeroed), -1 a boundary
            // flux with no particular image of its own (q stands in: never written).
            beam_sigma_s: match (self.beam, level.particular) {
                // A heterogeneous beam on a level bound without its material: the boundary flux.
                (Some(b), true) if b.local && !level.material => [0.0; 4],
                (Some(b), true) => [b.sigma_s[0], b.sigma_s[1], b.sigma_s[2], 1.0],
                (_, true) => [0.0; 4],
                (_, false) => [0.0, 0.0, 0.0, -1.0],
            },
            beam_sigma_a: self.beam.map_or([0.0; 4], |b| {
                [b.sigma_a[0], b.sigma_a[1], b.sigma_a[2], b.a]
            }),
            beam_exit: self.beam.map_or([0.0; 4], |b| {
                [
                    b.exit_phi,
                    b.exit_flux,
                    b.flux_gain,
                    if b.second_collision { 1.0 } else { 0.0 },
                ]
            }),
            beam_kappa: self.beam.map_or([0.0; 4], |b| {
                let grosjean = b.diffusion == DiffusionCoefficient::Grosjean;
                [
                    b.kappa[0],
                    b.kappa[1],
                    b.kappa[2],
                    if grosjean { 1.0 } else { 0.0 },
                ]
            }),
            beam_continuation: match self.beam {
                Some(b) if b.continuation => 1.0,
                _ => 0.0,
            },
            beam_upstream: match self.beam {
                Some(b) if b.upstream && b.curved => 2.0,
                Some(b) if b.upstream => 1.0,
                _ => 0.0,
            },
        };
        // SAFETY: the caller's contract.
        unsafe {
            self.pipeline.dispatch(
                ctx,
                cb,
                level.set,
                &push,
                [level.extent[0], level.extent[1], 1],
            );
        }
        Ok(())
    }
}

/// The gather's three images for one level, built from a baked [`GraphLevel`]: what the solver
/// creates per level, for hosts and tests that do not have it. Only the surface rows are stored.
pub struct SurfaceImages {
    pub position: Image,
    pub normal: Image,
    pub q: Image,
    pub surface_rows: u32,
}

impl SurfaceImages {
    /// Creates and fills `position` and `normal` (left in [`Access::ComputeRead`]); `q` is
    /// created undefined (usage STORAGE | TRANSFER_SRC). Headless contexts only (it submits).
    pub fn upload(ctx: &Context, level: &GraphLevel) -> Result<SurfaceImages, RenderError> {
        let packing = &level.packing;
        let (width, rows) = (packing.width, packing.surface_rows);
        let inner = level.inner_count();
        if width == 0 || rows == 0 || packing.texels.len() != level.positions.len() {
            return Err(invalid(
                "graph level",
                format!(
                    "not packed ({}x{} surface texels, {} texels for {} nodes)",
                    width,
                    rows,
                    packing.texels.len(),
                    level.positions.len()
                ),
            ));
        }
        let texels = (width * rows) as usize;
        let mut positions = vec![[0.0f32; 4]; texels];
        let mut normals = vec![[half::f16::ZERO; 4]; texels];
        for s in 0..level.surface_count() {
            let [u, v] = packing.texels[inner + s];
            if v >= rows || u >= width {
                return Err(invalid(
                    "graph level",
                    format!("surface node {s} packed at ({u}, {v}), outside the surface rows"),
                ));
            }
            let p = level.positions[inner + s];
            let n = level.surface_normals[s];
            let i = (v * width + u) as usize;
            positions[i] = [p.x as f32, p.y as f32, p.z as f32, 1.0];
            normals[i] = [
                half::f16::from_f64(n.x),
                half::f16::from_f64(n.y),
                half::f16::from_f64(n.z),
                half::f16::ZERO,
            ];
        }
        Self::from_texels(
            ctx,
            ["surface_position", "surface_normal", "q"],
            (width, rows),
            &positions,
            &normals,
        )
    }

    /// Creates the images from texels already packed (`width * rows` of each, row-major) and
    /// fills `position` and `normal` (left in [`Access::ComputeRead`]); `q` is created undefined
    /// (usage STORAGE | TRANSFER_SRC). `names`: position, normal, q. Headless contexts only (it
    /// submits). The dipole method packs its triangles' centroids this way.
    pub fn from_texels(
        ctx: &Context,
        names: [&'static str; 3],
        (width, rows): (u32, u32),
        positions: &[[f32; 4]],
        normals: &[[half::f16; 4]],
    ) -> Result<SurfaceImages, RenderError> {
        let texels = (width * rows) as usize;
        if positions.len() != texels || normals.len() != texels {
            return Err(invalid(
                "surface texels",
                format!(
                    "{} positions and {} normals for {width}x{rows} texels",
                    positions.len(),
                    normals.len()
                ),
            ));
        }
        let image = |name: &'static str, format, usage| {
            Image::new(
                ctx,
                &ImageDesc {
                    name,
                    width,
                    height: rows,
                    format,
                    usage,
                },
            )
        };
        let input = vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_DST;
        let position = image(names[0], SURFACE_POSITION_FORMAT, input)?;
        let normal = image(names[1], SURFACE_NORMAL_FORMAT, input)?;
        let q = image(
            names[2],
            Q_FORMAT,
            vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_SRC,
        )?;
        let staged_positions = Buffer::with_data(
            ctx,
            "surface_position upload",
            vk::BufferUsageFlags::TRANSFER_SRC,
            positions,
        )?;
        let normal_bits: Vec<u16> = normals.iter().flatten().map(|h| h.to_bits()).collect();
        let staged_normals = Buffer::with_data(
            ctx,
            "surface_normal upload",
            vk::BufferUsageFlags::TRANSFER_SRC,
            &normal_bits,
        )?;
        ctx.execute("upload surface images", |cb| {
            // SAFETY: `cb` is recording; images and staging buffers outlive the waited submission.
            unsafe {
                barrier::record(
                    ctx,
                    cb,
                    &[],
                    &[
                        // why: first use; the copies need TRANSFER_DST layout.
                        barrier::image_barrier(&position, Access::Undefined, Access::TransferDst),
                        barrier::image_barrier(&normal, Access::Undefined, Access::TransferDst),
                    ],
                );
                for (buffer, image) in [(&staged_positions, &position), (&staged_normals, &normal)]
                {
                    image.record_upload_from(ctx, cb, buffer);
                }
                barrier::record(
                    ctx,
                    cb,
                    &[],
                    &[
                        // why: the gather reads the uploaded texels (RAW), in GENERAL.
                        barrier::image_barrier(&position, Access::TransferDst, Access::ComputeRead),
                        barrier::image_barrier(&normal, Access::TransferDst, Access::ComputeRead),
                    ],
                );
            }
            Ok(())
        })?;
        Ok(SurfaceImages {
            position,
            normal,
            q,
            surface_rows: rows,
        })
    }

    /// Reads `q` back (headless) and returns q / `q_scale` per surface node (surface index order).
    pub fn read_q(
        &self,
        ctx: &Context,
        level: &GraphLevel,
        q_state: Access,
        q_scale: f32,
    ) -> Result<Vec<[f32; 3]>, RenderError> {
        let image = crate::vk::ImageReadback::capture(ctx, &self.q, q_state)?;
        let inner = level.inner_count();
        Ok((0..level.surface_count())
            .map(|s| {
                let [u, v] = level.packing.texels[inner + s];
                let t = image.pixel(u, v);
                [t[0] / q_scale, t[1] / q_scale, t[2] / q_scale]
            })
            .collect())
    }
}
