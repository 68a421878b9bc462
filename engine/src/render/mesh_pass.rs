//! [`MeshPass`]: the final-shading pass of DESIGN section 5. Draws a [`GpuMesh`] (positions,
//! normals, per-vertex exitance J+) into an [`OffscreenTarget`] with
//! `L_o = F_t(eta, theta_o) J+ / (pi eta^2)` (or the paper's `F_t J+ / pi`), plus optional
//! Cook-Torrance specular of one directional light, shadowed by the [`ShadowPass`] map.

use ash::vk;

use super::shadow_pass::ShadowPass;
use super::target::{OffscreenTarget, COLOR_FORMAT, DEPTH_FORMAT};
use super::RenderError;
use crate::mesh::TriMesh;
use crate::shader::{DescriptorWrite, GraphicsPipeline, GraphicsPipelineDesc, VertexAttribute};
use crate::solver::Environment;
use crate::vk::{barrier, Access, Buffer, BufferDesc, Context, GpuProfiler, MemoryUse, Sampler};

/// One vertex as the shaders read it (f32; the mesh is f64 on the CPU).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Vertex {
    pub position: [f32; 3],
    pub normal: [f32; 3],
    /// Outgoing partial current J+ (linear RGB).
    pub exitance: [f32; 3],
}

/// A mesh on the GPU: interleaved vertices and 32-bit indices (host-visible memory).
pub struct GpuMesh {
    vertices: Buffer,
    indices: Buffer,
    index_count: u32,
}

impl GpuMesh {
    /// Uploads `mesh` with one exitance per vertex; rejects mismatched lengths, out-of-range
    /// indices and non-finite values.
    pub fn new(
        ctx: &Context,
        mesh: &TriMesh,
        exitance: &[[f32; 3]],
    ) -> Result<GpuMesh, RenderError> {
        let invalid = |problem: String| RenderError::Invalid {
            what: "mesh".into(),
            problem,
        };
        let n = mesh.positions.len();
        if n == 0 || mesh.indices.is_empty() {
            return Err(invalid("no vertices or no triangles".into()));
        }
        if mesh.normals.len() != n || exitance.len() != n {
            return Err(invalid(format!(
                "{n} positions, {} normals, {} exitance values",
                mesh.normals.len(),
                exitance.len()
            )));
        }
        if let Some(t) = mesh
            .indices
            .iter()
            .position(|t| t.iter().any(|&i| i as usize >= n))
        {
            return Err(invalid(format!(
                "triangle {t} indexes past the {n} vertices"
            )));
        }
        let mut vertices = Vec::with_capacity(n);
        for (i, ((p, nrm), e)) in mesh
            .positions
            .iter()
            .zip(&mesh.normals)
            .zip(exitance)
            .enumerate()
        {
            let v = Vertex {
                position: p.as_vec3().to_array(),
                normal: nrm.as_vec3().to_array(),
                exitance: *e,
            };
            if v.position
                .iter()
                .chain(&v.normal)
                .chain(&v.exitance)
                .any(|x| !x.is_finite())
            {
                return Err(invalid(format!("vertex {i} is not finite in f32")));
            }
            vertices.push(v);
        }
        let indices: Vec<u32> = mesh.indices.iter().flatten().copied().collect();
        Ok(GpuMesh {
            vertices: Buffer::with_data(
                ctx,
                "mesh vertices",
                // STORAGE: the GPU diffusion solve writes the exitance field in place
                // (solver::gpu::GpuDiffusion::bind_mesh), so the solved J+ never visits the CPU.
                vk::BufferUsageFlags::VERTEX_BUFFER | vk::BufferUsageFlags::STORAGE_BUFFER,
                &vertices,
            )?,
            index_count: indices.len() as u32,
            indices: Buffer::with_data(
                ctx,
                "mesh indices",
                vk::BufferUsageFlags::INDEX_BUFFER,
                &indices,
            )?,
        })
    }

    /// The interleaved [`Vertex`] buffer (for passes that write the exitance on the GPU).
    pub fn vertex_buffer(&self) -> &Buffer {
        &self.vertices
    }

    /// Vertices in [`Self::vertex_buffer`].
    pub fn vertex_count(&self) -> usize {
        (self.vertices.size / std::mem::size_of::<Vertex>() as u64) as usize
    }

    /// Binds the buffers and draws every triangle.
    ///
    /// # Safety
    /// `cb` must be recording inside a rendering scope with a pipeline bound whose vertex layout
    /// is [`Vertex`]; the mesh must outlive `cb`'s execution.
    pub unsafe fn draw(&self, ctx: &Context, cb: vk::CommandBuffer) {
        // SAFETY: the caller's contract.
        unsafe {
            ctx.raw()
                .cmd_bind_vertex_buffers(cb, 0, &[self.vertices.raw], &[0]);
            ctx.raw()
                .cmd_bind_index_buffer(cb, self.indices.raw, 0, vk::IndexType::UINT32);
            ctx.raw().cmd_draw_indexed(cb, self.index_count, 1, 0, 0, 0);
        }
    }
}

/// The `ShadeUniforms` block of `mesh/shade_mesh.{vert,frag}` (std140).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ShadeUniforms {
    pub view_proj: [f32; 16],
    pub light_view_proj: [f32; 16],
    pub camera_pos: [f32; 4],
    /// xyz: direction the light travels (unit); w: 1 if there is a specular light.
    pub light_dir: [f32; 4],
    pub light_irradiance: [f32; 4],
    /// Environment radiance as order-2 SH (rgb, w unused) for its mirror reflection
    /// F_r(eta, theta_o) L_env(r); zero: none. See [`environment_sh`].
    pub env_sh: [[f32; 4]; 9],
}

/// The [`ShadeUniforms::env_sh`] of an environment: its radiance in the basis and order of
/// [`Environment::SphericalHarmonics`] (a constant radiance L is c_00 = L / Y_00).
pub fn environment_sh(environment: &Environment) -> [[f32; 4]; 9] {
    let mut sh = [[0.0; 4]; 9];
    match environment {
        Environment::None => {}
        Environment::Constant(l) => {
            // Y_00 = 1 / sqrt(4 pi) = 0.282095, the constant the shader multiplies c_00 by.
            sh[0] = [
                (l[0] / 0.282095) as f32,
                (l[1] / 0.282095) as f32,
                (l[2] / 0.282095) as f32,
                0.0,
            ];
        }
        Environment::SphericalHarmonics(c) => {
            for (out, c) in sh.iter_mut().zip(c) {
                *out = [c[0] as f32, c[1] as f32, c[2] as f32, 0.0];
            }
        }
    }
    sh
}

/// Push constants of `mesh/shade_mesh.frag`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ShadePush {
    pub eta: f32,
    /// 0: physical `F_t J+ / (pi eta^2)`; 1: paper `F_t J+ / pi`.
    pub radiance_mode: u32,
    pub roughness: f32,
    /// 1: add Cook-Torrance specular.
    pub specular: u32,
}

/// The shading pipeline, its uniform buffer, the shadow sampler and descriptor set.
pub struct MeshPass {
    pipeline: GraphicsPipeline<ShadePush>,
    uniforms: Buffer,
    #[allow(dead_code, reason = "owned here: the descriptor set refers to it")]
    sampler: Sampler,
    set: vk::DescriptorSet,
}

impl MeshPass {
    /// The pass, reading `shadow`'s map for the specular term.
    pub fn new(ctx: &Context, shadow: &ShadowPass) -> Result<MeshPass, RenderError> {
        let pipeline = GraphicsPipeline::new(
            ctx,
            &GraphicsPipelineDesc {
                name: "shade mesh",
                vertex: "mesh/shade_mesh.vert",
                fragment: Some("mesh/shade_mesh.frag"),
                vertex_stride: std::mem::size_of::<Vertex>() as u32,
                vertex_attributes: &[
                    VertexAttribute {
                        location: 0,
                        format: vk::Format::R32G32B32_SFLOAT,
                        offset: 0,
                    },
                    VertexAttribute {
                        location: 1,
                        format: vk::Format::R32G32B32_SFLOAT,
                        offset: 12,
                    },
                    VertexAttribute {
                        location: 2,
                        format: vk::Format::R32G32B32_SFLOAT,
                        offset: 24,
                    },
                ],
                color_formats: &[COLOR_FORMAT],
                depth_format: Some(DEPTH_FORMAT),
                depth_bias: None,
                // Closed meshes only show front faces anyway; no culling keeps either winding working.
                cull_mode: vk::CullModeFlags::NONE,
                bindings: &["frame", "shadow_map"],
                max_sets: 1,
            },
        )?;
        let uniforms = Buffer::new(
            ctx,
            &BufferDesc {
                name: "shade uniforms",
                size: std::mem::size_of::<ShadeUniforms>() as u64,
                usage: vk::BufferUsageFlags::UNIFORM_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
                memory: MemoryUse::GpuOnly,
            },
        )?;
        let linear = ctx.format_supports(
            shadow.map.format,
            vk::FormatFeatureFlags::SAMPLED_IMAGE_FILTER_LINEAR,
        );
        let filter = if linear {
            vk::Filter::LINEAR
        } else {
            vk::Filter::NEAREST
        };
        let info = vk::SamplerCreateInfo::default()
            .mag_filter(filter)
            .min_filter(filter)
            .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_BORDER)
            .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_BORDER)
            .address_mode_w(vk::SamplerAddressMode::CLAMP_TO_BORDER)
            // Outside the map is the far plane: lit.
            .border_color(vk::BorderColor::FLOAT_OPAQUE_WHITE)
            .compare_enable(true)
            .compare_op(vk::CompareOp::LESS_OR_EQUAL)
            .max_lod(0.0);
        let sampler = Sampler::new(ctx, "shadow sampler", &info)?;
        let set = pipeline.allocate_set(
            ctx,
            &[
                DescriptorWrite::UniformBuffer {
                    name: "frame",
                    buffer: &uniforms,
                },
                DescriptorWrite::SampledImage {
                    name: "shadow_map",
                    image: &shadow.map,
                    sampler: sampler.raw,
                    layout: vk::ImageLayout::DEPTH_READ_ONLY_OPTIMAL,
                },
            ],
        )?;
        Ok(MeshPass {
            pipeline,
            uniforms,
            sampler,
            set,
        })
    }

    /// Updates the uniforms in the command stream, then draws `mesh` into `target` (cleared to
    /// black, depth to 1). `shadow` must be in [`Access::DepthSampledFragment`]. Leaves the color
    /// in [`Access::ColorAttachmentWrite`].
    ///
    /// # Safety
    /// `cb` must be recording outside a rendering scope; everything passed in and `self` must
    /// outlive its execution; `shadow` must be the pass given to [`MeshPass::new`].
    #[allow(clippy::too_many_arguments)]
    pub unsafe fn record(
        &mut self,
        ctx: &Context,
        cb: vk::CommandBuffer,
        mesh: &GpuMesh,
        target: &mut OffscreenTarget,
        shadow: &ShadowPass,
        uniforms: &ShadeUniforms,
        push: &ShadePush,
        profiler: Option<&mut GpuProfiler>,
    ) {
        debug_assert_eq!(shadow.map_state, Access::DepthSampledFragment);
        let extent = target.extent();
        let color = [vk::RenderingAttachmentInfo::default()
            .image_view(target.color.view)
            .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
            .load_op(vk::AttachmentLoadOp::CLEAR)
            .store_op(vk::AttachmentStoreOp::STORE)
            .clear_value(vk::ClearValue {
                color: vk::ClearColorValue { float32: [0.0; 4] },
            })];
        let depth = vk::RenderingAttachmentInfo::default()
            .image_view(target.depth.view)
            .image_layout(vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL)
            .load_op(vk::AttachmentLoadOp::CLEAR)
            .store_op(vk::AttachmentStoreOp::DONT_CARE)
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
            .color_attachments(&color)
            .depth_attachment(&depth);
        let mut profiler = profiler;
        // SAFETY: the caller's contract; the pipeline's formats match the rendering scope.
        unsafe {
            ctx.begin_label(cb, "shade mesh");
            if let Some(p) = profiler.as_deref_mut() {
                p.begin_scope(cb, "shading");
            }
            // why: last frame's vertex/fragment uniform reads must finish before the update (WAR).
            barrier::memory(ctx, cb, Access::GraphicsUniformRead, Access::TransferDst);
            ctx.raw()
                .cmd_update_buffer(cb, self.uniforms.raw, 0, bytemuck::bytes_of(uniforms));
            barrier::record(
                ctx,
                cb,
                // why: the shaders read the uniforms just written (RAW).
                &[barrier::memory_barrier(
                    Access::TransferDst,
                    Access::GraphicsUniformRead,
                )],
                &[
                    // why: the clear and draws write color after whatever used it last (WAW/WAR),
                    // in COLOR_ATTACHMENT layout.
                    barrier::image_barrier(
                        &target.color,
                        target.color_state,
                        Access::ColorAttachmentWrite,
                    ),
                    // why: same for depth (cleared, so old contents may be discarded).
                    barrier::image_barrier(
                        &target.depth,
                        target.depth_state,
                        Access::DepthAttachmentWrite,
                    ),
                ],
            );
            ctx.raw().cmd_begin_rendering(cb, &rendering);
            self.pipeline.bind(ctx, cb, self.set, push, extent);
            mesh.draw(ctx, cb);
            ctx.raw().cmd_end_rendering(cb);
            if let Some(p) = profiler {
                p.end_scope(cb);
            }
            ctx.end_label(cb);
        }
        target.color_state = Access::ColorAttachmentWrite;
        target.depth_state = Access::DepthAttachmentWrite;
    }
}
