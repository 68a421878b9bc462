//! [`MeshPass`]: the final-shading pass of DESIGN section 5. Draws a [`GpuMesh`] (positions,
//! normals, per-vertex exitance J+) into an [`OffscreenTarget`] with
//! `L_o = F_t(eta, theta_o) J+ / (pi eta^2)` (or the paper's `F_t J+ / pi`), plus optional
//! Cook-Torrance specular of one directional light, shadowed by that light's tile of the
//! [`super::ShadowMaps`] atlas (the one the irradiance gather samples: no second depth pass).
//!
//! [`MeshPass::record`] draws into an [`OffscreenTarget`] (cleared); [`MeshPass::record_into`]
//! draws into any colour/depth views (a host's), loading or clearing them, with the attachment
//! barriers left to the caller.

use ash::vk;

use super::shadow_maps::ShadowMaps;
use super::RenderError;
use crate::mesh::{GpuMesh, Vertex};
use crate::scene::Environment;
use crate::shader::{DescriptorWrite, GraphicsPipeline, GraphicsPipelineDesc, VertexAttribute};
use crate::vk::barrier::Use;
use crate::vk::{barrier, Access, Buffer, BufferDesc, Context, Image, MemoryUse, Sampler};

/// The `ShadeUniforms` block of `mesh/shade_mesh.{vert,frag}` (std140).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ShadeUniforms {
    pub view_proj: [f32; 16],
    /// The specular light's view onto the whole shadow atlas ([`super::ShadowMaps::atlas_view_proj`]).
    pub light_view_proj: [f32; 16],
    pub camera_pos: [f32; 4],
    /// xyz: direction the light travels (unit); w: 1 if there is a specular light.
    pub light_dir: [f32; 4],
    pub light_irradiance: [f32; 4],
    /// Environment radiance as order-2 SH (rgb, w unused) for its mirror reflection
    /// F_r(eta, theta_o) L_env(r); zero: none. See [`environment_sh`].
    pub env_sh: [[f32; 4]; 9],
    /// The own-light lobe ([`crate::scene::ExitLobe::Chandra`], [`crate::scene::own_lobe`]): rgb
    /// the albedo per channel, w 1 where it applies (0: the node lobe's own light, Lambert).
    pub own_albedo: [f32; 4],
    /// Per light three vec4 ([`own_light_uniforms`]): (direction to it or position, kind 0 none,
    /// 1 directional, 2 point, 3 spot), (irradiance or intensity rgb, spot cos inner), (spot axis,
    /// spot cos outer).
    pub own_lights: [[f32; 4]; 3 * super::MAX_LIGHTS],
    /// The environment's radiance SH for the own light's Lambertian part (irradiance weight),
    /// whether or not the specular reflection draws it; zero: none.
    pub own_env_sh: [[f32; 4]; 9],
    /// The diffusion's tangential flux toward the view (`render --tangential-flux`): rgb
    /// [`crate::solver::transport::Boundary::tangential_flux_factor`] times D per channel (mm),
    /// w 1 where it applies (screen derivatives, each triangle's own gradient), 2 where the
    /// vertex stream carries f D grad X ([`crate::frame::TangentialPass`], smooth); zero: off.
    pub tangential: [f32; 4],
}

/// [`ShadeUniforms::own_lights`] of `lights` (at most [`super::MAX_LIGHTS`]; more are ignored
/// here, the object refuses them).
pub fn own_light_uniforms(lights: &[crate::scene::Light]) -> [[f32; 4]; 3 * super::MAX_LIGHTS] {
    use crate::scene::Light;
    let mut out = [[0.0; 4]; 3 * super::MAX_LIGHTS];
    for (i, light) in lights.iter().take(super::MAX_LIGHTS).enumerate() {
        let v = |d: glam::DVec3, w: f32| [d.x as f32, d.y as f32, d.z as f32, w];
        let c = |e: [f64; 3], w: f32| [e[0] as f32, e[1] as f32, e[2] as f32, w];
        let (a, b, axis) = match *light {
            Light::Directional {
                direction,
                irradiance,
            } => (v(-direction.normalize(), 1.0), c(irradiance, 0.0), [0.0; 4]),
            Light::Point {
                position,
                intensity,
            } => (v(position, 2.0), c(intensity, 0.0), [0.0; 4]),
            Light::Spot {
                position,
                direction,
                intensity,
                inner_deg,
                outer_deg,
            } => (
                v(position, 3.0),
                c(intensity, inner_deg.to_radians().cos() as f32),
                v(direction.normalize(), outer_deg.to_radians().cos() as f32),
            ),
        };
        out[3 * i] = a;
        out[3 * i + 1] = b;
        out[3 * i + 2] = axis;
    }
    out
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
    /// The exit lobe ([`crate::scene::ExitLobe::shading_push`]): the slope b at diffused share 1,
    /// K(eta), and the share of b a node of diffused share 0 keeps (the vertex stream's share s
    /// gives b (own + (1 - own) s)); 0, K, 1 for the Lambertian lobe of DESIGN 2.6.
    pub lobe_slope: f32,
    pub lobe_k: f32,
    pub lobe_own: f32,
    /// 1: the exit lobe shapes only the exitance the method wrote (the share stream's rgb); what
    /// the bounce added to it ([`crate::frame::bounce`]: light that arrived diffusely from the
    /// surface elsewhere) leaves with the Lambertian lobe
    /// ([`crate::scene::ExitLobe::with_bounce`]). 0: the lobe shapes the whole exitance.
    pub lobe_bounce: u32,
}

/// Where [`MeshPass::record_into`] draws: views already in attachment layouts.
#[derive(Clone, Copy, Debug)]
pub struct ShadeAttachments {
    pub color: vk::ImageView,
    /// Keep the colour's contents (a host background) or clear to black.
    pub load_color: bool,
    pub depth: vk::ImageView,
    /// Depth-test against the depth's contents (a host's) or clear to 1.
    pub load_depth: bool,
    /// Keep our depth writes (a host reads them later) or let them go.
    pub store_depth: bool,
    pub extent: vk::Extent2D,
}

/// The shading pipeline, its uniform buffer, the shadow sampler and descriptor set.
pub struct MeshPass {
    pipeline: GraphicsPipeline<ShadePush>,
    uniforms: Buffer,
    #[allow(dead_code, reason = "owned here: the descriptor set refers to it")]
    sampler: Sampler,
    set: vk::DescriptorSet,
    color_format: vk::Format,
    depth_format: vk::Format,
}

impl MeshPass {
    /// The pass for colour and depth attachments of these formats, reading `shadow_atlas`
    /// (a [`super::ShadowMaps`] atlas, sampled in [`Access::DepthSampledShaders`]) for the
    /// specular term's shadow.
    pub fn new(
        ctx: &Context,
        shadow_atlas: &Image,
        color_format: vk::Format,
        depth_format: vk::Format,
    ) -> Result<MeshPass, RenderError> {
        let renderable = ctx.format_supports(
            color_format,
            vk::FormatFeatureFlags::COLOR_ATTACHMENT
                | vk::FormatFeatureFlags::COLOR_ATTACHMENT_BLEND,
        );
        if !renderable {
            return Err(RenderError::Invalid {
                what: "colour format".into(),
                problem: format!(
                    "{color_format:?} is not a colour attachment format on this device"
                ),
            });
        }
        if !ctx.format_supports(
            depth_format,
            vk::FormatFeatureFlags::DEPTH_STENCIL_ATTACHMENT,
        ) {
            return Err(RenderError::Invalid {
                what: "depth format".into(),
                problem: format!(
                    "{depth_format:?} is not a depth attachment format on this device"
                ),
            });
        }
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
                // Single scattering per vertex (DESIGN 2.8, `frame::SingleScatteringPass`): X
                // added to J+ (zero while the pass is off); then the per-node exit lobe's
                // diffused share (`frame::Method::exit_share`: the 4th float of 16 bytes; the
                // first three the exitance before the bounce, read with `ShadePush::lobe_bounce`).
                extra_streams: &[
                    (
                        16,
                        &[VertexAttribute {
                            location: 3,
                            format: vk::Format::R32G32B32A32_SFLOAT,
                            offset: 0,
                        }],
                    ),
                    (
                        16,
                        &[VertexAttribute {
                            location: 4,
                            format: vk::Format::R32G32B32A32_SFLOAT,
                            offset: 0,
                        }],
                    ),
                    // The tangential flux's f D grad X per vertex (`frame::TangentialPass`, 3 x
                    // vec3; without the pass the mesh's own vertices stand in, unread).
                    (
                        36,
                        &[
                            VertexAttribute {
                                location: 5,
                                format: vk::Format::R32G32B32_SFLOAT,
                                offset: 0,
                            },
                            VertexAttribute {
                                location: 6,
                                format: vk::Format::R32G32B32_SFLOAT,
                                offset: 12,
                            },
                            VertexAttribute {
                                location: 7,
                                format: vk::Format::R32G32B32_SFLOAT,
                                offset: 24,
                            },
                        ],
                    ),
                ],
                color_formats: &[color_format],
                depth_format: Some(depth_format),
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
            shadow_atlas.format,
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
            // Outside the atlas is the far plane: lit.
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
                    image: shadow_atlas,
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
            color_format,
            depth_format,
        })
    }

    /// The attachment formats the pipeline was built for.
    pub fn formats(&self) -> (vk::Format, vk::Format) {
        (self.color_format, self.depth_format)
    }

    /// What [`Self::record_into`] uses besides the attachments: `mesh`'s vertices, the single
    /// scattering per vertex, the exit lobe's share per vertex (`None`: read from `scattered`,
    /// whose 4th float is 0) and the shadow atlas (sampled for the specular term).
    pub fn uses<'a>(
        &'a self,
        mesh: &'a GpuMesh,
        scattered: &'a Buffer,
        share: Option<&'a Buffer>,
        gradient: Option<&'a Buffer>,
        shadows: &'a ShadowMaps,
    ) -> Vec<Use<'a>> {
        let mut uses = vec![
            Use::buffer(mesh.vertex_buffer(), Access::VertexInput),
            Use::buffer(scattered, Access::VertexInput),
            Use::image(&shadows.atlas, Access::DepthSampledShaders),
        ];
        if let Some(share) = share {
            uses.push(Use::buffer(share, Access::VertexInput));
        }
        if let Some(gradient) = gradient {
            uses.push(Use::buffer(gradient, Access::VertexInput));
        }
        uses
    }

    /// Updates the uniforms in the command stream, then draws `mesh` with `scattered` (single
    /// scattering per vertex, 16 bytes each, at least as many as `mesh` has) and `share` (the exit
    /// lobe's diffused share in the 4th float of 16 bytes per vertex; `None`: `scattered`'s 4th
    /// float, 0) and `gradient` (the tangential flux's f D grad X per vertex, 36 bytes each;
    /// `None`: the mesh's vertices stand in, and the uniforms' tangential w must not be 2) into
    /// `attachments` (in
    /// `COLOR_ATTACHMENT_OPTIMAL` / `DEPTH_ATTACHMENT_OPTIMAL`, their earlier uses ordered by the
    /// frame graph).
    ///
    /// # Safety
    /// `cb` must be recording outside a rendering scope, inside a frame-graph pass declaring
    /// [`Self::uses`] and the attachments; the views' images, `mesh` and `self` must outlive
    /// its execution; the views must have this pass's formats.
    #[allow(
        clippy::too_many_arguments,
        reason = "the draw's inputs (mesh, its single-scattering stream) and the frame's (attachments, uniforms, push) are distinct things"
    )]
    pub unsafe fn record_into(
        &self,
        ctx: &Context,
        cb: vk::CommandBuffer,
        mesh: &GpuMesh,
        scattered: &Buffer,
        share: Option<&Buffer>,
        gradient: Option<&Buffer>,
        attachments: &ShadeAttachments,
        uniforms: &ShadeUniforms,
        push: &ShadePush,
    ) -> Result<(), RenderError> {
        let extent = attachments.extent;
        if extent.width == 0 || extent.height == 0 {
            return Err(RenderError::Invalid {
                what: "shading extent".into(),
                problem: format!("{}x{} has no pixels", extent.width, extent.height),
            });
        }
        let load = |keep: bool| {
            if keep {
                vk::AttachmentLoadOp::LOAD
            } else {
                vk::AttachmentLoadOp::CLEAR
            }
        };
        let color = [vk::RenderingAttachmentInfo::default()
            .image_view(attachments.color)
            .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
            .load_op(load(attachments.load_color))
            .store_op(vk::AttachmentStoreOp::STORE)
            .clear_value(vk::ClearValue {
                color: vk::ClearColorValue { float32: [0.0; 4] },
            })];
        let depth = vk::RenderingAttachmentInfo::default()
            .image_view(attachments.depth)
            .image_layout(vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL)
            .load_op(load(attachments.load_depth))
            .store_op(if attachments.store_depth {
                vk::AttachmentStoreOp::STORE
            } else {
                vk::AttachmentStoreOp::DONT_CARE
            })
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
        // SAFETY: the caller's contract; the pipeline's formats match the rendering scope.
        unsafe {
            // why: last frame's vertex/fragment uniform reads must finish before the update (WAR).
            barrier::memory(ctx, cb, Access::GraphicsUniformRead, Access::TransferDst);
            ctx.raw()
                .cmd_update_buffer(cb, self.uniforms.raw, 0, bytemuck::bytes_of(uniforms));
            // why: the shaders read the uniforms just written (RAW).
            barrier::memory(ctx, cb, Access::TransferDst, Access::GraphicsUniformRead);
            ctx.raw().cmd_begin_rendering(cb, &rendering);
            self.pipeline.bind(ctx, cb, self.set, push, extent);
            ctx.raw().cmd_bind_vertex_buffers(
                cb,
                1,
                &[
                    scattered.raw,
                    share.unwrap_or(scattered).raw,
                    gradient.unwrap_or(mesh.vertex_buffer()).raw,
                ],
                &[0, 0, 0],
            );
            mesh.draw(ctx, cb);
            ctx.raw().cmd_end_rendering(cb);
        }
        Ok(())
    }
}
