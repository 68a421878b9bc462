//! The viewer's own pass after the object: the HDR image -> exposure, tone map, sRGB -> the
//! swapchain image, with a backdrop and the text overlay (`shaders-glsl/viewer/present.*`).
//! It is a host's pass, built on raw ash like `engine/examples/host_graph.rs`'s tone map, so its
//! pipeline can be rebuilt from recompiled SPIR-V (hot reload, [`super::reload`]); the push
//! constants and bindings are still checked against the shaders' reflection.

use anyhow::{bail, Context as _};
use ash::vk;
use translucent::shader::{Reflection, Spirv};
use translucent::vk::{Buffer, BufferDesc, Context, Image, MemoryUse, Sampler};

/// `viewer/present.frag`'s push constants.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct PresentPush {
    pub size: [i32; 2],
    pub grid: [i32; 2],
    pub exposure: f32,
    pub encode_srgb: u32,
    pub text_scale: u32,
    pub overlay: u32,
}

/// Shader paths under `shaders-glsl/`.
pub const VERTEX_SHADER: &str = "viewer/present.vert";
pub const FRAGMENT_SHADER: &str = "viewer/present.frag";
/// The fragment shader's bindings, in binding order.
const BINDINGS: [(&str, vk::DescriptorType); 3] = [
    ("hdr", vk::DescriptorType::COMBINED_IMAGE_SAMPLER),
    ("font", vk::DescriptorType::STORAGE_BUFFER),
    ("text", vk::DescriptorType::STORAGE_BUFFER),
];

/// The present pass: pipeline for one swapchain format, a descriptor set and a text buffer per
/// frame in flight.
pub struct PresentPass {
    device: ash::Device,
    set_layout: vk::DescriptorSetLayout,
    layout: vk::PipelineLayout,
    pipeline: vk::Pipeline,
    pool: vk::DescriptorPool,
    sets: Vec<vk::DescriptorSet>,
    sampler: Sampler,
    font: Buffer,
    text: Vec<Buffer>,
    /// Cells each text buffer holds.
    text_cells: usize,
    color_format: vk::Format,
}

/// Checks `spirv`'s push-constant size and bindings against the Rust side.
fn check_interface(vertex: &Spirv, fragment: &Spirv) -> anyhow::Result<()> {
    let v = Reflection::new(vertex)?;
    let f = Reflection::new(fragment)?;
    if !v.bindings.is_empty() {
        bail!("{}: the vertex stage binds nothing", v.shader);
    }
    let push = std::mem::size_of::<PresentPush>();
    if f.push_constant_size != Some(push) {
        bail!(
            "{}: push constants of {:?} bytes, PresentPush has {push}",
            f.shader,
            f.push_constant_size
        );
    }
    let declared: Vec<(&str, u32, vk::DescriptorType)> = f
        .bindings
        .iter()
        .map(|b| (b.name.as_str(), b.binding, b.descriptor_type))
        .collect();
    let expected: Vec<(&str, u32, vk::DescriptorType)> = BINDINGS
        .iter()
        .enumerate()
        .map(|(i, (n, t))| (*n, i as u32, *t))
        .collect();
    if declared != expected || f.bindings.iter().any(|b| b.set != 0) {
        bail!(
            "{}: bindings {declared:?}, the present pass writes {expected:?} in set 0",
            f.shader
        );
    }
    Ok(())
}

impl PresentPass {
    /// The pass for `color_format` targets with `slots` frames in flight, from the context's
    /// shaders (the embedded ones unless hot reload installed others).
    pub fn new(
        ctx: &Context,
        device: &ash::Device,
        color_format: vk::Format,
        slots: usize,
    ) -> anyhow::Result<PresentPass> {
        let vertex = translucent::shader::load(ctx, VERTEX_SHADER)?;
        let fragment = translucent::shader::load(ctx, FRAGMENT_SHADER)?;
        check_interface(&vertex, &fragment)?;
        let bindings: Vec<vk::DescriptorSetLayoutBinding> = BINDINGS
            .iter()
            .enumerate()
            .map(|(i, (_, ty))| {
                vk::DescriptorSetLayoutBinding::default()
                    .binding(i as u32)
                    .descriptor_type(*ty)
                    .descriptor_count(1)
                    .stage_flags(vk::ShaderStageFlags::FRAGMENT)
            })
            .collect();
        let sampler = Sampler::new(
            ctx,
            "viewer hdr sampler",
            &vk::SamplerCreateInfo::default()
                .mag_filter(vk::Filter::NEAREST)
                .min_filter(vk::Filter::NEAREST)
                .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_EDGE)
                .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_EDGE)
                .address_mode_w(vk::SamplerAddressMode::CLAMP_TO_EDGE),
        )?;
        let font = Buffer::with_data(
            ctx,
            "viewer font",
            vk::BufferUsageFlags::STORAGE_BUFFER,
            &super::overlay::font_words(),
        )?;
        let mut pass = PresentPass {
            device: device.clone(),
            set_layout: vk::DescriptorSetLayout::null(),
            layout: vk::PipelineLayout::null(),
            pipeline: vk::Pipeline::null(),
            pool: vk::DescriptorPool::null(),
            sets: Vec::new(),
            sampler,
            font,
            text: Vec::new(),
            text_cells: 0,
            color_format,
        };
        // SAFETY: valid create infos on a live device; every object is destroyed in `Drop`
        // (null handles included, which Vulkan allows) if a later step fails.
        unsafe {
            pass.set_layout = device
                .create_descriptor_set_layout(
                    &vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings),
                    None,
                )
                .context("vkCreateDescriptorSetLayout")?;
            let ranges = [vk::PushConstantRange::default()
                .stage_flags(vk::ShaderStageFlags::FRAGMENT)
                .size(std::mem::size_of::<PresentPush>() as u32)];
            let set_layouts = [pass.set_layout];
            pass.layout = device
                .create_pipeline_layout(
                    &vk::PipelineLayoutCreateInfo::default()
                        .set_layouts(&set_layouts)
                        .push_constant_ranges(&ranges),
                    None,
                )
                .context("vkCreatePipelineLayout")?;
            let sizes = [
                vk::DescriptorPoolSize {
                    ty: vk::DescriptorType::COMBINED_IMAGE_SAMPLER,
                    descriptor_count: slots as u32,
                },
                vk::DescriptorPoolSize {
                    ty: vk::DescriptorType::STORAGE_BUFFER,
                    descriptor_count: 2 * slots as u32,
                },
            ];
            pass.pool = device
                .create_descriptor_pool(
                    &vk::DescriptorPoolCreateInfo::default()
                        .max_sets(slots as u32)
                        .pool_sizes(&sizes),
                    None,
                )
                .context("vkCreateDescriptorPool")?;
            let layouts = vec![pass.set_layout; slots];
            pass.sets = device
                .allocate_descriptor_sets(
                    &vk::DescriptorSetAllocateInfo::default()
                        .descriptor_pool(pass.pool)
                        .set_layouts(&layouts),
                )
                .context("vkAllocateDescriptorSets")?;
        }
        pass.pipeline = pass.build_pipeline(&vertex, &fragment)?;
        let font_info = [vk::DescriptorBufferInfo::default()
            .buffer(pass.font.raw)
            .range(vk::WHOLE_SIZE)];
        for &set in &pass.sets {
            let write = vk::WriteDescriptorSet::default()
                .dst_set(set)
                .dst_binding(1)
                .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                .buffer_info(&font_info);
            // SAFETY: the set and the buffer are live; no frame uses the set yet.
            unsafe { device.update_descriptor_sets(&[write], &[]) };
        }
        Ok(pass)
    }

    fn build_pipeline(&self, vertex: &Spirv, fragment: &Spirv) -> anyhow::Result<vk::Pipeline> {
        let device = &self.device;
        // SAFETY: the SPIR-V words come from glslc (build time or hot reload: a module the device can reject
        // with an error, not crash on); the modules are destroyed right after pipeline creation.
        unsafe {
            let vs = device
                .create_shader_module(
                    &vk::ShaderModuleCreateInfo::default().code(&vertex.words),
                    None,
                )
                .context("vkCreateShaderModule (present.vert)")?;
            let fs = match device.create_shader_module(
                &vk::ShaderModuleCreateInfo::default().code(&fragment.words),
                None,
            ) {
                Ok(m) => m,
                Err(e) => {
                    device.destroy_shader_module(vs, None);
                    return Err(e).context("vkCreateShaderModule (present.frag)");
                }
            };
            let stages = [
                vk::PipelineShaderStageCreateInfo::default()
                    .stage(vk::ShaderStageFlags::VERTEX)
                    .module(vs)
                    .name(c"main"),
                vk::PipelineShaderStageCreateInfo::default()
                    .stage(vk::ShaderStageFlags::FRAGMENT)
                    .module(fs)
                    .name(c"main"),
            ];
            let vertex_input = vk::PipelineVertexInputStateCreateInfo::default();
            let assembly = vk::PipelineInputAssemblyStateCreateInfo::default()
                .topology(vk::PrimitiveTopology::TRIANGLE_LIST);
            let viewport = vk::PipelineViewportStateCreateInfo::default()
                .viewport_count(1)
                .scissor_count(1);
            let raster = vk::PipelineRasterizationStateCreateInfo::default()
                .polygon_mode(vk::PolygonMode::FILL)
                .cull_mode(vk::CullModeFlags::NONE)
                .line_width(1.0);
            let multisample = vk::PipelineMultisampleStateCreateInfo::default()
                .rasterization_samples(vk::SampleCountFlags::TYPE_1);
            let blend_attachments = [vk::PipelineColorBlendAttachmentState::default()
                .color_write_mask(vk::ColorComponentFlags::RGBA)];
            let blend =
                vk::PipelineColorBlendStateCreateInfo::default().attachments(&blend_attachments);
            let dynamic_states = [vk::DynamicState::VIEWPORT, vk::DynamicState::SCISSOR];
            let dynamic =
                vk::PipelineDynamicStateCreateInfo::default().dynamic_states(&dynamic_states);
            let formats = [self.color_format];
            let mut rendering =
                vk::PipelineRenderingCreateInfo::default().color_attachment_formats(&formats);
            let info = vk::GraphicsPipelineCreateInfo::default()
                .stages(&stages)
                .vertex_input_state(&vertex_input)
                .input_assembly_state(&assembly)
                .viewport_state(&viewport)
                .rasterization_state(&raster)
                .multisample_state(&multisample)
                .color_blend_state(&blend)
                .dynamic_state(&dynamic)
                .layout(self.layout)
                .push_next(&mut rendering);
            let created =
                device.create_graphics_pipelines(vk::PipelineCache::null(), &[info], None);
            device.destroy_shader_module(vs, None);
            device.destroy_shader_module(fs, None);
            let pipeline = created
                .map_err(|(_, e)| e)
                .context("vkCreateGraphicsPipelines")?[0];
            Ok(pipeline)
        }
    }

    /// Rebuilds the pipeline from the context's shaders (after hot reload installed new ones).
    /// On any error the old pipeline stays.
    ///
    /// The GPU must be done with the old pipeline (the viewer waits for idle first).
    pub fn reload(&mut self, ctx: &Context) -> anyhow::Result<()> {
        let vertex = translucent::shader::load(ctx, VERTEX_SHADER)?;
        let fragment = translucent::shader::load(ctx, FRAGMENT_SHADER)?;
        check_interface(&vertex, &fragment)?;
        let pipeline = self.build_pipeline(&vertex, &fragment)?;
        // SAFETY: the caller's contract: no pending frame uses the old pipeline.
        unsafe { self.device.destroy_pipeline(self.pipeline, None) };
        self.pipeline = pipeline;
        Ok(())
    }

    /// Points every set's `hdr` binding at `hdr` (after a resize made a new one).
    ///
    /// No pending frame may use the sets (the viewer waits for idle before it resizes).
    pub fn set_source(&mut self, hdr: &Image) {
        let info = [vk::DescriptorImageInfo::default()
            .sampler(self.sampler.raw)
            .image_view(hdr.view)
            .image_layout(vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL)];
        for &set in &self.sets {
            let write = vk::WriteDescriptorSet::default()
                .dst_set(set)
                .dst_binding(0)
                .descriptor_type(vk::DescriptorType::COMBINED_IMAGE_SAMPLER)
                .image_info(&info);
            // SAFETY: the caller's contract; the image view and sampler are live.
            unsafe { self.device.update_descriptor_sets(&[write], &[]) };
        }
    }

    /// Makes every text buffer hold at least `cells` cells.
    ///
    /// No pending frame may use the sets (the viewer waits for idle before it resizes).
    pub fn reserve_text(&mut self, ctx: &Context, cells: usize) -> anyhow::Result<()> {
        if cells <= self.text_cells && !self.text.is_empty() {
            return Ok(());
        }
        let cells = cells.max(1);
        self.text.clear();
        for &set in &self.sets {
            let buffer = Buffer::new(
                ctx,
                &BufferDesc {
                    name: "viewer text",
                    size: (cells * 4) as u64,
                    usage: vk::BufferUsageFlags::STORAGE_BUFFER,
                    memory: MemoryUse::Upload,
                },
            )?;
            let info = [vk::DescriptorBufferInfo::default()
                .buffer(buffer.raw)
                .range(vk::WHOLE_SIZE)];
            let write = vk::WriteDescriptorSet::default()
                .dst_set(set)
                .dst_binding(2)
                .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                .buffer_info(&info);
            // SAFETY: the caller's contract; the buffer is live.
            unsafe { self.device.update_descriptor_sets(&[write], &[]) };
            self.text.push(buffer);
        }
        self.text_cells = cells;
        Ok(())
    }

    /// Writes the overlay cells of frame slot `slot` (its last frame has completed).
    pub fn write_text(&mut self, slot: usize, cells: &[u32]) -> anyhow::Result<()> {
        let cells = &cells[..cells.len().min(self.text_cells)];
        self.text[slot].write_bytes(0, bytemuck::cast_slice(cells))?;
        Ok(())
    }

    /// Records the pass into `target` (in `COLOR_ATTACHMENT_OPTIMAL`; the caller's barriers put
    /// it there and the HDR image in `SHADER_READ_ONLY_OPTIMAL`).
    ///
    /// # Safety
    /// `cb` is recording outside a rendering scope; the set of `slot`, `target` and the HDR
    /// image stay alive until the command buffer completes.
    pub unsafe fn record(
        &self,
        cb: vk::CommandBuffer,
        slot: usize,
        target: vk::ImageView,
        extent: vk::Extent2D,
        push: &PresentPush,
    ) {
        let d = &self.device;
        let attachments = [vk::RenderingAttachmentInfo::default()
            .image_view(target)
            .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
            .load_op(vk::AttachmentLoadOp::DONT_CARE)
            .store_op(vk::AttachmentStoreOp::STORE)];
        let area = vk::Rect2D {
            offset: vk::Offset2D::default(),
            extent,
        };
        // SAFETY: the caller's contract.
        unsafe {
            d.cmd_begin_rendering(
                cb,
                &vk::RenderingInfo::default()
                    .render_area(area)
                    .layer_count(1)
                    .color_attachments(&attachments),
            );
            d.cmd_bind_pipeline(cb, vk::PipelineBindPoint::GRAPHICS, self.pipeline);
            d.cmd_bind_descriptor_sets(
                cb,
                vk::PipelineBindPoint::GRAPHICS,
                self.layout,
                0,
                &[self.sets[slot]],
                &[],
            );
            d.cmd_push_constants(
                cb,
                self.layout,
                vk::ShaderStageFlags::FRAGMENT,
                0,
                bytemuck::bytes_of(push),
            );
            d.cmd_set_viewport(
                cb,
                0,
                &[vk::Viewport {
                    x: 0.0,
                    y: 0.0,
                    width: extent.width as f32,
                    height: extent.height as f32,
                    min_depth: 0.0,
                    max_depth: 1.0,
                }],
            );
            d.cmd_set_scissor(cb, 0, &[area]);
            d.cmd_draw(cb, 3, 1, 0, 0);
            d.cmd_end_rendering(cb);
        }
    }
}

impl Drop for PresentPass {
    fn drop(&mut self) {
        // SAFETY: the viewer drops the pass after the device went idle; destroying null
        // handles (a pass whose creation failed half way) is allowed.
        unsafe {
            self.device.destroy_pipeline(self.pipeline, None);
            self.device.destroy_descriptor_pool(self.pool, None);
            self.device.destroy_pipeline_layout(self.layout, None);
            self.device
                .destroy_descriptor_set_layout(self.set_layout, None);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_embedded_shaders_match_the_push_constants_and_bindings() {
        let v = translucent::shader::embedded(VERTEX_SHADER).expect("embedded");
        let f = translucent::shader::embedded(FRAGMENT_SHADER).expect("embedded");
        check_interface(&v, &f).expect("interface");
        // The check can fail: the fragment stage declares bindings the vertex stage does not.
        assert!(check_interface(&f, &f).is_err());
    }
}
