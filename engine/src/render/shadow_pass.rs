//! [`ShadowPass`]: a depth-only pass rendering the mesh from one light into its own shadow map (the
//! shading pass's specular). For every light at once, in one atlas sampled by compute, see
//! [`super::ShadowMaps`]; both draw with `shadow_map/depth_only.vert`.

use ash::vk;

use super::mesh_pass::{GpuMesh, Vertex};
use super::RenderError;
use crate::shader::{GraphicsPipeline, GraphicsPipelineDesc, VertexAttribute};
use crate::vk::{barrier, Access, Context, GpuProfiler, Image, ImageDesc};

pub const SHADOW_FORMAT: vk::Format = vk::Format::D32_SFLOAT;

/// Push constants of `shadow_map/depth_only.vert` (the same layout as [`super::ShadowPush`]).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct DepthPush {
    pub light_view_proj: [f32; 16],
}

/// Owns the shadow map (D32, sampled by the shading pass) and the depth-only pipeline.
pub struct ShadowPass {
    pipeline: GraphicsPipeline<DepthPush>,
    pub map: Image,
    /// How the last recorded command used `map`.
    pub map_state: Access,
}

impl ShadowPass {
    pub fn new(ctx: &Context, resolution: u32) -> Result<ShadowPass, RenderError> {
        let pipeline = GraphicsPipeline::new(
            ctx,
            &GraphicsPipelineDesc {
                name: "shadow map",
                vertex: "shadow_map/depth_only.vert",
                fragment: None,
                vertex_stride: std::mem::size_of::<Vertex>() as u32,
                vertex_attributes: &[VertexAttribute {
                    location: 0,
                    format: vk::Format::R32G32B32_SFLOAT,
                    offset: 0,
                }],
                color_formats: &[],
                depth_format: Some(SHADOW_FORMAT),
                // Slope-scaled bias against self-shadowing acne.
                depth_bias: Some((1.0, 1.5)),
                cull_mode: vk::CullModeFlags::NONE,
                bindings: &[],
                max_sets: 1,
            },
        )?;
        let map = Image::new(
            ctx,
            &ImageDesc {
                name: "shadow map",
                width: resolution,
                height: resolution,
                format: SHADOW_FORMAT,
                // TRANSFER_SRC: the map can be captured for checks and debugging.
                usage: vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT
                    | vk::ImageUsageFlags::SAMPLED
                    | vk::ImageUsageFlags::TRANSFER_SRC,
            },
        )?;
        Ok(ShadowPass {
            pipeline,
            map,
            map_state: Access::Undefined,
        })
    }

    /// Renders `mesh`'s depth seen through `light_view_proj`; leaves the map ready for sampling
    /// in fragment shaders ([`Access::DepthSampledFragment`]).
    ///
    /// # Safety
    /// `cb` must be recording outside a rendering scope; `mesh` and `self` must outlive it.
    pub unsafe fn record(
        &mut self,
        ctx: &Context,
        cb: vk::CommandBuffer,
        mesh: &GpuMesh,
        light_view_proj: &glam::Mat4,
        profiler: Option<&mut GpuProfiler>,
    ) {
        let extent = self.map.extent();
        let depth = vk::RenderingAttachmentInfo::default()
            .image_view(self.map.view)
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
                extent,
            })
            .layer_count(1)
            .depth_attachment(&depth);
        let push = DepthPush {
            light_view_proj: light_view_proj.to_cols_array(),
        };
        let mut profiler = profiler;
        // SAFETY: the caller's contract; the pipeline's formats match the rendering scope.
        unsafe {
            ctx.begin_label(cb, "shadow map");
            if let Some(p) = profiler.as_deref_mut() {
                p.begin_scope(cb, "shadow_map");
            }
            // why: the depth writes must wait for last frame's shadow lookups (WAR) and need
            // DEPTH_ATTACHMENT layout; the old contents are cleared anyway.
            barrier::image(
                ctx,
                cb,
                &self.map,
                self.map_state,
                Access::DepthAttachmentWrite,
            );
            ctx.raw().cmd_begin_rendering(cb, &rendering);
            self.pipeline
                .bind(ctx, cb, vk::DescriptorSet::null(), &push, extent);
            mesh.draw(ctx, cb);
            ctx.raw().cmd_end_rendering(cb);
            // why: the shading pass samples the depth written here (RAW) in a read-only layout.
            barrier::image(
                ctx,
                cb,
                &self.map,
                Access::DepthAttachmentWrite,
                Access::DepthSampledFragment,
            );
            if let Some(p) = profiler {
                p.end_scope(cb);
            }
            ctx.end_label(cb);
        }
        self.map_state = Access::DepthSampledFragment;
    }

    /// Leaves the map sampleable without rendering (no light casts shadows): contents undefined,
    /// and the shading pass does not read them.
    ///
    /// # Safety
    /// As [`ShadowPass::record`].
    pub unsafe fn record_unused(&mut self, ctx: &Context, cb: vk::CommandBuffer) {
        if self.map_state == Access::Undefined {
            // why: the shading pass's descriptor needs the map in a read-only layout.
            // SAFETY: the caller's contract.
            unsafe {
                barrier::image(
                    ctx,
                    cb,
                    &self.map,
                    Access::Undefined,
                    Access::DepthSampledFragment,
                )
            };
            self.map_state = Access::DepthSampledFragment;
        }
    }
}
