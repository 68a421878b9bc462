//! [`ReflectiveShadowMaps`]: per light view, the surface the light sees (Dachsbacher and
//! Stamminger 2005), rendered in one pass with its depth:
//!
//! | image | format | texel |
//! |---|---|---|
//! | `shadows.atlas` (depth) | D32_SFLOAT | the shadow map: the same atlas, views and slope-scaled bias as `render::ShadowMaps` |
//! | `position` | RGBA32F | rgb world position (mm), a = 1 (0: no surface) |
//! | `normal` | RGBA16F | rgb unit shading normal, a = mu_i = max(0, n.l) |
//! | `irradiance` | RGBA32F | rgb E T_i (irradiance on a surface facing the light times F_t(eta, theta_i)), a = A_perp (mm^2) |
//!
//! E T_i A_perp is the flux the texel transmits into the object, the voxel method's injection
//! (paper Eqs. 2-3); single scattering (DESIGN section 2.8) reads depth, normal and E T_i of the
//! same maps, so this is meant to become the frame's one shadow pass (phase 2): its depth IS the
//! shadow atlas the irradiance gather and the shading read.
//!
//! Views: [`ShadowMaps::set_lights`] fits them (an orthographic view per directional light, one
//! perspective view per spot or point light, six cube faces for a light near or inside the
//! object), each a tile of the atlas; the colour maps are atlases of the same layout.
//!
//! ```no_run
//! use translucent::frame::voxel::{ReflectiveShadowMaps, RsmDesc};
//! # fn f(ctx: &translucent::vk::Context, surface: &translucent::solver::voxel::MeshHandles,
//! #      cb: ash::vk::CommandBuffer) -> Result<(), translucent::Error> {
//! let mut rsm = ReflectiveShadowMaps::new(ctx, &RsmDesc::default())?;
//! rsm.set_lights(&["spot:0,60,0:0,-1,0:4000,4000,4000:20,30".parse()?], (glam::DVec3::ZERO, 25.0), 1.3)?;
//! // The images must be in the states `rsm.declare(..)` names (attachments): inside a frame
//! // graph pass declaring them (`frame::voxel::VoxelPasses::add_passes`).
//! // SAFETY: `cb` is recording outside a rendering scope; everything outlives its execution.
//! unsafe { rsm.record(ctx, cb, surface, None) };
//! # Ok(()) }
//! ```

use ash::vk;
use glam::{DVec3, Vec3};

use crate::mesh::Vertex;
use crate::render::{ShadowMaps, ShadowMapsDesc, ShadowView, MAX_SHADOW_VIEWS};
use crate::scene::Light;
use crate::shader::{DescriptorWrite, GraphicsPipeline, GraphicsPipelineDesc, VertexAttribute};
use crate::solver::voxel::sync::{ResourceUse, State};
use crate::solver::voxel::MeshHandles;
use crate::solver::voxel::SurfaceMesh;
use crate::vk::{
    barrier, Access, Buffer, BufferDesc, Context, GpuProfiler, Image, ImageDesc, MemoryUse,
};
use crate::Error;

/// Profiler scope and debug label of the pass.
pub const PASS_RSM: &str = "rsm";
/// Formats of the colour maps.
pub const RSM_POSITION_FORMAT: vk::Format = vk::Format::R32G32B32A32_SFLOAT;
pub const RSM_NORMAL_FORMAT: vk::Format = vk::Format::R16G16B16A16_SFLOAT;
pub const RSM_IRRADIANCE_FORMAT: vk::Format = vk::Format::R32G32B32A32_SFLOAT;

const KIND_DIRECTIONAL: f32 = 0.0;
const KIND_POINT: f32 = 1.0;
const KIND_SPOT: f32 = 2.0;

/// One view as the shaders read it (std430, `include/rsm_view.glsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct RsmView {
    pub view_proj: [f32; 16],
    /// xyz: eye (perspective); w: 1 perspective, 0 orthographic.
    pub eye: [f32; 4],
    /// xyz: view axis (perspective); w: texel size (mm, orthographic; per mm of distance on the
    /// unit image plane, perspective).
    pub axis: [f32; 4],
    /// xyz: position, or direction of travel (directional); w: kind (0 dir, 1 point, 2 spot).
    pub light_position: [f32; 4],
    /// xyz: spot axis (unit); w: cos(outer).
    pub light_axis: [f32; 4],
    /// rgb: irradiance (directional) or intensity; w: cos(inner).
    pub colour: [f32; 4],
    /// xy: atlas texel origin, z: tile size, w: light index.
    pub tile: [u32; 4],
}

/// Push constants of `rsm/draw_rsm.{vert,frag}`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct RsmPush {
    pub view: u32,
    pub eta: f32,
    pub min_cos: f32,
    pub pad: f32,
}

/// How to create [`ReflectiveShadowMaps`].
#[derive(Clone, Debug)]
pub struct RsmDesc {
    /// Texels across one view's tile.
    pub tile_resolution: u32,
    /// Tiles in the atlas (a cube light takes 6).
    pub max_views: u32,
}

impl Default for RsmDesc {
    fn default() -> Self {
        RsmDesc {
            tile_resolution: 256,
            max_views: 8,
        }
    }
}

/// The maps, their depth (a [`ShadowMaps`] atlas) and the pipeline that renders them.
pub struct ReflectiveShadowMaps {
    pipeline: GraphicsPipeline<RsmPush>,
    set: vk::DescriptorSet,
    /// Fits the views and owns the depth atlas (which the RSM renders).
    pub shadows: ShadowMaps,
    pub position: Image,
    pub normal: Image,
    pub irradiance: Image,
    /// The views, updated in the command stream at each record.
    pub views_buffer: Buffer,
    views: Vec<RsmView>,
    eta: f32,
}

fn invalid(problem: impl Into<String>) -> Error {
    crate::solver::voxel::bad_param("reflective shadow maps", problem).into()
}

/// The view's axis: from the eye to where the tile's centre unprojects.
fn view_axis(v: &ShadowView) -> Vec3 {
    let centre = v
        .view_proj
        .inverse()
        .project_point3(Vec3::new(0.0, 0.0, 0.5));
    (centre - v.eye).normalize_or_zero()
}

impl ReflectiveShadowMaps {
    pub fn new(ctx: &Context, desc: &RsmDesc) -> Result<ReflectiveShadowMaps, Error> {
        if desc.max_views as usize > MAX_SHADOW_VIEWS {
            return Err(invalid(format!(
                "{} views: at most {MAX_SHADOW_VIEWS}",
                desc.max_views
            )));
        }
        let shadows = ShadowMaps::new(
            ctx,
            &ShadowMapsDesc {
                tile_resolution: desc.tile_resolution,
                max_views: desc.max_views,
            },
        )?;
        let (width, height) = (shadows.atlas.width, shadows.atlas.height);
        let map = |name, format| {
            Image::new(
                ctx,
                &ImageDesc {
                    name,
                    width,
                    height,
                    format,
                    // TRANSFER_SRC: the maps can be captured for checks.
                    usage: vk::ImageUsageFlags::COLOR_ATTACHMENT
                        | vk::ImageUsageFlags::SAMPLED
                        | vk::ImageUsageFlags::TRANSFER_SRC,
                },
            )
        };
        let pipeline = GraphicsPipeline::new(
            ctx,
            &GraphicsPipelineDesc {
                name: "reflective shadow maps",
                vertex: "rsm/draw_rsm.vert",
                fragment: Some("rsm/draw_rsm.frag"),
                vertex_stride: std::mem::size_of::<Vertex>() as u32,
                vertex_attributes: &[
                    VertexAttribute {
                        location: 0,
                        format: vk::Format::R32G32B32_SFLOAT,
                        offset: std::mem::offset_of!(Vertex, position) as u32,
                    },
                    VertexAttribute {
                        location: 1,
                        format: vk::Format::R32G32B32_SFLOAT,
                        offset: std::mem::offset_of!(Vertex, normal) as u32,
                    },
                ],
                extra_streams: &[],
                color_formats: &[
                    RSM_POSITION_FORMAT,
                    RSM_NORMAL_FORMAT,
                    RSM_IRRADIANCE_FORMAT,
                ],
                depth_format: Some(crate::render::SHADOW_ATLAS_FORMAT),
                // The shadow maps' bias: the depth is the shared shadow atlas.
                depth_bias: Some((1.0, 1.5)),
                cull_mode: vk::CullModeFlags::NONE,
                bindings: &["rsm"],
                max_sets: 1,
            },
        )?;
        let views_buffer = Buffer::new(
            ctx,
            &BufferDesc {
                name: "rsm views",
                size: (std::mem::size_of::<RsmView>() * MAX_SHADOW_VIEWS) as u64,
                usage: vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
                memory: MemoryUse::GpuOnly,
            },
        )?;
        let set = pipeline.allocate_set(
            ctx,
            &[DescriptorWrite::StorageBuffer {
                name: "rsm",
                buffer: &views_buffer,
            }],
        )?;
        Ok(ReflectiveShadowMaps {
            pipeline,
            set,
            position: map("rsm position", RSM_POSITION_FORMAT)?,
            normal: map("rsm normal", RSM_NORMAL_FORMAT)?,
            irradiance: map("rsm irradiance", RSM_IRRADIANCE_FORMAT)?,
            shadows,
            views_buffer,
            views: Vec::new(),
            eta: 1.0,
        })
    }

    /// Fits the views of `lights` around the bounding sphere `bounds` (centre, radius; mm) and
    /// records each light's parameters; `eta` sets the maps' Fresnel transmittance. A bad light
    /// or eta, or too many views, is a typed error and keeps the previous views.
    pub fn set_lights(
        &mut self,
        lights: &[Light],
        bounds: (DVec3, f64),
        eta: f64,
    ) -> Result<(), Error> {
        if !(eta.is_finite() && eta > 0.0) {
            return Err(invalid(format!("eta {eta} is not a positive index ratio")));
        }
        let previous = (
            self.shadows.views().to_vec(),
            self.shadows.light_views().to_vec(),
        );
        // On an error ShadowMaps keeps its previous views.
        self.shadows.set_lights(lights, bounds, true)?;
        let mut views = Vec::new();
        for (light_index, (light, &(first, count))) in
            lights.iter().zip(self.shadows.light_views()).enumerate()
        {
            let f = |c: [f64; 3]| [c[0] as f32, c[1] as f32, c[2] as f32];
            let (position, axis_w, colour, cos_inner, kind) = match *light {
                Light::Directional {
                    direction,
                    irradiance,
                } => (
                    direction.normalize().as_vec3(),
                    (0.0, Vec3::ZERO),
                    f(irradiance),
                    0.0,
                    KIND_DIRECTIONAL,
                ),
                Light::Point {
                    position,
                    intensity,
                } => (
                    position.as_vec3(),
                    (0.0, Vec3::ZERO),
                    f(intensity),
                    0.0,
                    KIND_POINT,
                ),
                Light::Spot {
                    position,
                    direction,
                    intensity,
                    inner_deg,
                    outer_deg,
                } => (
                    position.as_vec3(),
                    (
                        outer_deg.to_radians().cos() as f32,
                        direction.normalize().as_vec3(),
                    ),
                    f(intensity),
                    inner_deg.to_radians().cos() as f32,
                    KIND_SPOT,
                ),
            };
            for v in &self.shadows.views()[first as usize..(first + count) as usize] {
                let perspective = v.texel_mm == 0.0;
                let axis = view_axis(v);
                views.push(RsmView {
                    view_proj: v.view_proj.to_cols_array(),
                    eye: v.eye.extend(if perspective { 1.0 } else { 0.0 }).to_array(),
                    axis: axis
                        .extend(if perspective {
                            v.texel_per_mm
                        } else {
                            v.texel_mm
                        })
                        .to_array(),
                    light_position: position.extend(kind).to_array(),
                    light_axis: axis_w.1.extend(axis_w.0).to_array(),
                    colour: [colour[0], colour[1], colour[2], cos_inner],
                    tile: [v.origin[0], v.origin[1], v.size, light_index as u32],
                });
            }
        }
        if views.iter().any(|v| {
            !bytemuck::cast_slice::<_, f32>(&v.view_proj)
                .iter()
                .all(|x| x.is_finite())
        }) {
            self.shadows.restore(previous);
            return Err(invalid("a light view is not finite"));
        }
        self.views = views;
        self.eta = eta as f32;
        Ok(())
    }

    /// The views of the current lights, in atlas order (a light's views are consecutive).
    pub fn views(&self) -> &[RsmView] {
        &self.views
    }

    /// The depth atlas's format and size and the colour maps'.
    pub fn extent(&self) -> vk::Extent2D {
        self.position.extent()
    }

    /// Reads: the mesh (vertex input). Writes: the depth atlas (depth attachment) and the three
    /// colour maps (colour attachments). Readers then sample the maps in
    /// [`Access::ShadersSampled`] and the depth in `Access::DepthSampledShaders`.
    pub fn declare<'a>(&'a self, mesh: &SurfaceMesh<'a>) -> Vec<ResourceUse<'a>> {
        vec![
            ResourceUse::buffer(mesh.vertices, Access::VertexInput),
            ResourceUse::buffer(mesh.indices, Access::VertexInput),
            ResourceUse::image(&self.shadows.atlas, Access::DepthAttachmentWrite),
            ResourceUse::image(&self.position, Access::ColorAttachmentWrite),
            ResourceUse::image(&self.normal, Access::ColorAttachmentWrite),
            ResourceUse::image(&self.irradiance, Access::ColorAttachmentWrite),
            // Updated inside the pass (with its own barriers), then read by the injection.
            ResourceUse::buffer_span(&self.views_buffer, Access::TransferDst, Access::ComputeRead),
        ]
    }

    /// The state a reader of the colour maps declares.
    pub const READ_STATE: State = Access::ShadersSampled;

    /// Clears the used tiles and draws `mesh` into every view (no view: nothing but the clear,
    /// which marks every texel empty).
    ///
    /// # Safety
    /// `cb` must be recording outside a rendering scope, the declared resources in their declared
    /// states; `mesh` and `self` must outlive its execution.
    pub unsafe fn record(
        &self,
        ctx: &Context,
        cb: vk::CommandBuffer,
        mesh: &MeshHandles,
        profiler: Option<&mut GpuProfiler>,
    ) {
        let extent = self.extent();
        let clear = |c: [f32; 4]| vk::ClearValue {
            color: vk::ClearColorValue { float32: c },
        };
        let attachment = |image: &Image| {
            vk::RenderingAttachmentInfo::default()
                .image_view(image.view)
                .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
                .load_op(vk::AttachmentLoadOp::CLEAR)
                .store_op(vk::AttachmentStoreOp::STORE)
                .clear_value(clear([0.0; 4]))
        };
        let colour = [
            attachment(&self.position),
            attachment(&self.normal),
            attachment(&self.irradiance),
        ];
        let depth = vk::RenderingAttachmentInfo::default()
            .image_view(self.shadows.atlas.view)
            .image_layout(vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL)
            .load_op(vk::AttachmentLoadOp::CLEAR)
            .store_op(vk::AttachmentStoreOp::STORE)
            .clear_value(vk::ClearValue {
                depth_stencil: vk::ClearDepthStencilValue {
                    depth: 1.0,
                    stencil: 0,
                },
            });
        // The whole atlas is cleared (a reader may look at any tile; unused ones read as empty).
        let rendering = vk::RenderingInfo::default()
            .render_area(vk::Rect2D {
                offset: vk::Offset2D::default(),
                extent,
            })
            .layer_count(1)
            .color_attachments(&colour)
            .depth_attachment(&depth);
        let mut profiler = profiler;
        // SAFETY: the caller's contract; the pipeline's formats match the rendering scope.
        unsafe {
            ctx.begin_label(cb, PASS_RSM);
            if let Some(p) = profiler.as_deref_mut() {
                p.begin_scope(cb, PASS_RSM);
            }
            if !self.views.is_empty() {
                // why: last frame's shader reads of the views must finish before the update (WAR).
                barrier::record(
                    ctx,
                    cb,
                    &[vk::MemoryBarrier2::default()
                        .src_stage_mask(
                            vk::PipelineStageFlags2::VERTEX_SHADER
                                | vk::PipelineStageFlags2::FRAGMENT_SHADER
                                | vk::PipelineStageFlags2::COMPUTE_SHADER,
                        )
                        .dst_stage_mask(vk::PipelineStageFlags2::COPY)
                        .dst_access_mask(vk::AccessFlags2::TRANSFER_WRITE)],
                    &[],
                );
                ctx.raw().cmd_update_buffer(
                    cb,
                    self.views_buffer.raw,
                    0,
                    bytemuck::cast_slice(&self.views),
                );
                // why: the vertex and fragment stages (and the injection after the pass) read the
                // views just written (RAW).
                barrier::record(
                    ctx,
                    cb,
                    &[vk::MemoryBarrier2::default()
                        .src_stage_mask(vk::PipelineStageFlags2::COPY)
                        .src_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
                        .dst_stage_mask(
                            vk::PipelineStageFlags2::VERTEX_SHADER
                                | vk::PipelineStageFlags2::FRAGMENT_SHADER
                                | vk::PipelineStageFlags2::COMPUTE_SHADER,
                        )
                        .dst_access_mask(vk::AccessFlags2::SHADER_STORAGE_READ)],
                    &[],
                );
            }
            ctx.raw().cmd_begin_rendering(cb, &rendering);
            for (i, v) in self.views.iter().enumerate() {
                let push = RsmPush {
                    view: i as u32,
                    eta: self.eta,
                    min_cos: 0.0,
                    pad: 0.0,
                };
                self.pipeline.bind(ctx, cb, self.set, &push, extent);
                let tile = vk::Rect2D {
                    offset: vk::Offset2D {
                        x: v.tile[0] as i32,
                        y: v.tile[1] as i32,
                    },
                    extent: vk::Extent2D {
                        width: v.tile[2],
                        height: v.tile[2],
                    },
                };
                ctx.raw().cmd_set_viewport(
                    cb,
                    0,
                    &[vk::Viewport {
                        x: v.tile[0] as f32,
                        y: v.tile[1] as f32,
                        width: v.tile[2] as f32,
                        height: v.tile[2] as f32,
                        min_depth: 0.0,
                        max_depth: 1.0,
                    }],
                );
                // The scissor keeps geometry clipped to this tile out of its neighbours.
                ctx.raw().cmd_set_scissor(cb, 0, &[tile]);
                mesh.draw(ctx, cb);
            }
            ctx.raw().cmd_end_rendering(cb);
            if let Some(p) = profiler {
                p.end_scope(cb);
            }
            ctx.end_label(cb);
        }
    }
}
