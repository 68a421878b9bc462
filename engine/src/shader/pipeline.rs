//! Compute and graphics pipelines whose layouts come from reflection, checked against the Rust
//! push-constant type `P` and the binding names the Rust side writes.

use std::marker::PhantomData;
use std::sync::Arc;

use ash::vk;

use super::{BindingInfo, Reflection, ShaderError};
use crate::vk::{Buffer, Context, Image, VkError};

/// For pipelines without push constants.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct NoPushConstants {
    _none: [u8; 0],
}

/// One vertex attribute of a single interleaved vertex buffer (binding 0).
#[derive(Clone, Copy, Debug)]
pub struct VertexAttribute {
    pub location: u32,
    pub format: vk::Format,
    pub offset: u32,
}

/// A resource written into a descriptor set, by the binding's name in the shader.
#[derive(Clone, Copy)]
pub enum DescriptorWrite<'a> {
    /// A storage image in GENERAL layout.
    StorageImage {
        name: &'a str,
        image: &'a Image,
    },
    /// A combined image sampler read in `layout`.
    SampledImage {
        name: &'a str,
        image: &'a Image,
        sampler: vk::Sampler,
        layout: vk::ImageLayout,
    },
    UniformBuffer {
        name: &'a str,
        buffer: &'a Buffer,
    },
    StorageBuffer {
        name: &'a str,
        buffer: &'a Buffer,
    },
    /// Bytes `[offset, offset + range)` of a storage buffer: a window of a buffer larger than the
    /// device's `maxStorageBufferRange`. `offset` must be a multiple of
    /// `minStorageBufferOffsetAlignment`, `range` at most `maxStorageBufferRange`, and the window
    /// inside the buffer ([`ShaderError::Unsupported`] otherwise).
    StorageBufferRange {
        name: &'a str,
        buffer: &'a Buffer,
        offset: u64,
        range: u64,
    },
    /// A uniform texel buffer (`samplerBuffer` / `usamplerBuffer`, read with `texelFetch`): a view
    /// the caller created and keeps alive while the set is used.
    UniformTexelBuffer {
        name: &'a str,
        view: vk::BufferView,
    },
}

impl<'a> DescriptorWrite<'a> {
    pub fn storage_image(name: &'a str, image: &'a Image) -> Self {
        DescriptorWrite::StorageImage { name, image }
    }

    fn name(&self) -> &'a str {
        match *self {
            DescriptorWrite::StorageImage { name, .. }
            | DescriptorWrite::SampledImage { name, .. }
            | DescriptorWrite::UniformBuffer { name, .. }
            | DescriptorWrite::StorageBuffer { name, .. }
            | DescriptorWrite::StorageBufferRange { name, .. }
            | DescriptorWrite::UniformTexelBuffer { name, .. } => name,
        }
    }

    fn descriptor_type(&self) -> vk::DescriptorType {
        match self {
            DescriptorWrite::StorageImage { .. } => vk::DescriptorType::STORAGE_IMAGE,
            DescriptorWrite::SampledImage { .. } => vk::DescriptorType::COMBINED_IMAGE_SAMPLER,
            DescriptorWrite::UniformBuffer { .. } => vk::DescriptorType::UNIFORM_BUFFER,
            DescriptorWrite::StorageBuffer { .. } | DescriptorWrite::StorageBufferRange { .. } => {
                vk::DescriptorType::STORAGE_BUFFER
            }
            DescriptorWrite::UniformTexelBuffer { .. } => vk::DescriptorType::UNIFORM_TEXEL_BUFFER,
        }
    }
}

/// Set layout, pipeline layout and a descriptor pool, built from the reflection of all stages.
struct Interface {
    name: &'static str,
    set_layout: vk::DescriptorSetLayout,
    layout: vk::PipelineLayout,
    pool: vk::DescriptorPool,
    bindings: Vec<(BindingInfo, vk::ShaderStageFlags)>,
    push_stages: vk::ShaderStageFlags,
    push_size: usize,
    ctx_device: Arc<crate::vk::device::Device>,
}

fn type_name(t: vk::DescriptorType) -> String {
    format!("{t:?}").to_lowercase().replace('_', " ")
}

impl Interface {
    fn new(
        ctx: &Context,
        name: &'static str,
        stages: &[Reflection],
        push_size: usize,
        binding_names: &[&str],
        max_sets: u32,
    ) -> Result<Interface, ShaderError> {
        // Merge the stages' bindings: the same (set, binding) must have the same name and type.
        let mut bindings: Vec<(BindingInfo, vk::ShaderStageFlags)> = Vec::new();
        for r in stages {
            for b in &r.bindings {
                if b.set != 0 {
                    return Err(ShaderError::Unsupported {
                        pipeline: name,
                        message: format!(
                            "binding {:?} uses set {}; only set 0 is supported",
                            b.name, b.set
                        ),
                    });
                }
                match bindings.iter_mut().find(|(x, _)| x.binding == b.binding) {
                    Some((x, stages))
                        if x.name == b.name && x.descriptor_type == b.descriptor_type =>
                    {
                        *stages |= r.stage
                    }
                    Some((x, _)) => {
                        return Err(ShaderError::Unsupported {
                            pipeline: name,
                            message: format!(
                                "binding {} is {:?} in one stage and {:?} in another",
                                b.binding, x.name, b.name
                            ),
                        })
                    }
                    None => bindings.push((b.clone(), r.stage)),
                }
            }
        }
        let declared: Vec<String> = bindings.iter().map(|(b, _)| b.name.clone()).collect();
        for wanted in binding_names {
            if !declared.iter().any(|d| d == wanted) {
                return Err(ShaderError::UnknownBinding {
                    pipeline: name,
                    name: (*wanted).into(),
                    declared,
                });
            }
        }
        if let Some(missing) = declared
            .iter()
            .find(|d| !binding_names.contains(&d.as_str()))
        {
            return Err(ShaderError::UnboundBinding {
                pipeline: name,
                name: missing.clone(),
            });
        }
        let mut push_stages = vk::ShaderStageFlags::empty();
        let mut reflected_push = 0;
        for r in stages {
            if let Some(size) = r.push_constant_size {
                push_stages |= r.stage;
                reflected_push = reflected_push.max(size);
            }
        }
        if reflected_push != push_size {
            let shader = stages
                .iter()
                .map(|r| r.shader.as_str())
                .collect::<Vec<_>>()
                .join(" + ");
            return Err(ShaderError::PushConstantSize {
                pipeline: name,
                shader,
                rust: push_size,
                reflected: reflected_push,
            });
        }
        let limit = ctx.limits().max_push_constants_size as usize;
        if push_size > limit {
            return Err(ShaderError::Unsupported {
                pipeline: name,
                message: format!("{push_size} bytes of push constants, device limit {limit}"),
            });
        }

        let raw = ctx.raw();
        let layout_bindings: Vec<_> = bindings
            .iter()
            .map(|(b, stages)| {
                vk::DescriptorSetLayoutBinding::default()
                    .binding(b.binding)
                    .descriptor_type(b.descriptor_type)
                    .descriptor_count(b.count)
                    .stage_flags(*stages)
            })
            .collect();
        let handle = ctx.device.clone();
        let mut interface = Interface {
            name,
            set_layout: vk::DescriptorSetLayout::null(),
            layout: vk::PipelineLayout::null(),
            pool: vk::DescriptorPool::null(),
            bindings,
            push_stages,
            push_size,
            ctx_device: handle,
        };
        // SAFETY: valid create infos on a live device; `interface`'s Drop destroys what was made.
        unsafe {
            interface.set_layout = raw
                .create_descriptor_set_layout(
                    &vk::DescriptorSetLayoutCreateInfo::default().bindings(&layout_bindings),
                    None,
                )
                .map_err(VkError::call("vkCreateDescriptorSetLayout"))?;
            let ranges = [vk::PushConstantRange::default()
                .stage_flags(push_stages)
                .offset(0)
                .size(push_size as u32)];
            let set_layouts = [interface.set_layout];
            let mut info = vk::PipelineLayoutCreateInfo::default().set_layouts(&set_layouts);
            if push_size > 0 {
                info = info.push_constant_ranges(&ranges);
            }
            interface.layout = raw
                .create_pipeline_layout(&info, None)
                .map_err(VkError::call("vkCreatePipelineLayout"))?;
            if !interface.bindings.is_empty() {
                let sizes: Vec<_> = interface
                    .bindings
                    .iter()
                    .map(|(b, _)| vk::DescriptorPoolSize {
                        ty: b.descriptor_type,
                        descriptor_count: b.count * max_sets.max(1),
                    })
                    .collect();
                let info = vk::DescriptorPoolCreateInfo::default()
                    .max_sets(max_sets.max(1))
                    .pool_sizes(&sizes);
                interface.pool = raw
                    .create_descriptor_pool(&info, None)
                    .map_err(VkError::call("vkCreateDescriptorPool"))?;
            }
        }
        ctx.set_name(interface.set_layout, name);
        ctx.set_name(interface.layout, name);
        Ok(interface)
    }

    fn allocate_set(
        &self,
        ctx: &Context,
        writes: &[DescriptorWrite<'_>],
    ) -> Result<vk::DescriptorSet, ShaderError> {
        let declared = || {
            self.bindings
                .iter()
                .map(|(b, _)| b.name.clone())
                .collect::<Vec<_>>()
        };
        let mut slots = Vec::new();
        for w in writes {
            let (b, _) = self
                .bindings
                .iter()
                .find(|(b, _)| b.name == w.name())
                .ok_or_else(|| ShaderError::UnknownBinding {
                    pipeline: self.name,
                    name: w.name().into(),
                    declared: declared(),
                })?;
            if b.descriptor_type != w.descriptor_type() {
                return Err(ShaderError::BindingType {
                    pipeline: self.name,
                    name: b.name.clone(),
                    declared: type_name(b.descriptor_type),
                    written: type_name(w.descriptor_type()),
                });
            }
            if let (DescriptorWrite::UniformBuffer { buffer, .. }, Some(size)) = (w, b.uniform_size)
            {
                if buffer.size != size as u64 {
                    return Err(ShaderError::UniformSize {
                        pipeline: self.name,
                        name: b.name.clone(),
                        rust: buffer.size,
                        reflected: size,
                    });
                }
            }
            if let DescriptorWrite::StorageBufferRange {
                buffer,
                offset,
                range,
                ..
            } = *w
            {
                let limits = ctx.limits();
                let align = limits.min_storage_buffer_offset_alignment.max(1);
                let max_range = u64::from(limits.max_storage_buffer_range);
                let inside = offset
                    .checked_add(range)
                    .is_some_and(|end| end <= buffer.size);
                if offset % align != 0 || range == 0 || range > max_range || !inside {
                    return Err(ShaderError::Unsupported {
                        pipeline: self.name,
                        message: format!(
                            "binding {:?}: bytes {offset}..+{range} of a {}-byte buffer (offset a \
                             multiple of {align}, range 1..={max_range}, inside the buffer)",
                            b.name, buffer.size
                        ),
                    });
                }
            }
            slots.push((b.binding, *w));
        }
        if let Some((b, _)) = self
            .bindings
            .iter()
            .find(|(b, _)| !writes.iter().any(|w| w.name() == b.name))
        {
            return Err(ShaderError::UnboundBinding {
                pipeline: self.name,
                name: b.name.clone(),
            });
        }
        let raw = ctx.raw();
        let layouts = [self.set_layout];
        let info = vk::DescriptorSetAllocateInfo::default()
            .descriptor_pool(self.pool)
            .set_layouts(&layouts);
        // SAFETY: the pool and layout are ours; running out of sets is reported as an error.
        let set = unsafe { raw.allocate_descriptor_sets(&info) }
            .map_err(VkError::call("vkAllocateDescriptorSets"))?[0];
        let image_infos: Vec<[vk::DescriptorImageInfo; 1]> = slots
            .iter()
            .map(|(_, w)| match *w {
                DescriptorWrite::StorageImage { image, .. } => [vk::DescriptorImageInfo::default()
                    .image_view(image.view)
                    .image_layout(vk::ImageLayout::GENERAL)],
                DescriptorWrite::SampledImage {
                    image,
                    sampler,
                    layout,
                    ..
                } => [vk::DescriptorImageInfo::default()
                    .image_view(image.view)
                    .sampler(sampler)
                    .image_layout(layout)],
                _ => [vk::DescriptorImageInfo::default()],
            })
            .collect();
        let buffer_infos: Vec<[vk::DescriptorBufferInfo; 1]> = slots
            .iter()
            .map(|(_, w)| match *w {
                DescriptorWrite::UniformBuffer { buffer, .. }
                | DescriptorWrite::StorageBuffer { buffer, .. } => {
                    [vk::DescriptorBufferInfo::default()
                        .buffer(buffer.raw)
                        .range(vk::WHOLE_SIZE)]
                }
                DescriptorWrite::StorageBufferRange {
                    buffer,
                    offset,
                    range,
                    ..
                } => [vk::DescriptorBufferInfo::default()
                    .buffer(buffer.raw)
                    .offset(offset)
                    .range(range)],
                _ => [vk::DescriptorBufferInfo::default()],
            })
            .collect();
        let texel_views: Vec<[vk::BufferView; 1]> = slots
            .iter()
            .map(|(_, w)| match *w {
                DescriptorWrite::UniformTexelBuffer { view, .. } => [view],
                _ => [vk::BufferView::null()],
            })
            .collect();
        let descriptor_writes: Vec<_> = slots
            .iter()
            .enumerate()
            .map(|(i, (binding, w))| {
                let write = vk::WriteDescriptorSet::default()
                    .dst_set(set)
                    .dst_binding(*binding)
                    .descriptor_type(w.descriptor_type());
                match w {
                    DescriptorWrite::StorageImage { .. } | DescriptorWrite::SampledImage { .. } => {
                        write.image_info(&image_infos[i])
                    }
                    DescriptorWrite::UniformTexelBuffer { .. } => {
                        write.texel_buffer_view(&texel_views[i])
                    }
                    _ => write.buffer_info(&buffer_infos[i]),
                }
            })
            .collect();
        // SAFETY: the set was just allocated; the infos reference live views and buffers.
        unsafe { raw.update_descriptor_sets(&descriptor_writes, &[]) };
        Ok(set)
    }
}

impl Drop for Interface {
    fn drop(&mut self) {
        use crate::vk::device::Retired as Retire;
        let d = &self.ctx_device;
        if self.pool != vk::DescriptorPool::null() {
            d.retire(Retire::DescriptorPool(self.pool));
        }
        if self.layout != vk::PipelineLayout::null() {
            d.retire(Retire::PipelineLayout(self.layout));
        }
        if self.set_layout != vk::DescriptorSetLayout::null() {
            d.retire(Retire::DescriptorSetLayout(self.set_layout));
        }
    }
}

fn shader_module(ctx: &Context, spirv: &super::Spirv) -> Result<vk::ShaderModule, ShaderError> {
    let info = vk::ShaderModuleCreateInfo::default().code(&spirv.words);
    // SAFETY: the words are SPIR-V produced by glslc (checked magic number).
    let module = unsafe { ctx.raw().create_shader_module(&info, None) }
        .map_err(VkError::call("vkCreateShaderModule"))?;
    ctx.set_name(module, &spirv.name);
    Ok(module)
}

/// How to create a [`ComputePipeline`].
#[derive(Clone, Debug)]
pub struct ComputePipelineDesc<'a> {
    pub name: &'static str,
    /// Embedded shader path, e.g. `"laplace/jacobi_step.comp"`.
    pub shader: &'a str,
    /// Every binding the Rust side writes, by name (must equal the shader's set).
    pub bindings: &'a [&'a str],
    /// Descriptor sets [`ComputePipeline::allocate_set`] may hand out.
    pub max_sets: u32,
}

/// A compute pipeline with push constants of type `P`.
pub struct ComputePipeline<P> {
    pub raw: vk::Pipeline,
    pub name: &'static str,
    pub workgroup_size: [u32; 3],
    interface: Interface,
    _push: PhantomData<P>,
}

/// One specialization constant (`layout(constant_id = id) const ...`): a 32-bit value (a GLSL
/// `bool` is a `VkBool32`, 0 or 1; `int`, `uint` and `float` their bits).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SpecConstant {
    pub id: u32,
    pub value: u32,
}

impl SpecConstant {
    pub fn bool(id: u32, value: bool) -> Self {
        SpecConstant {
            id,
            value: u32::from(value),
        }
    }
}

impl<P: bytemuck::Pod> ComputePipeline<P> {
    pub fn new(ctx: &Context, desc: &ComputePipelineDesc<'_>) -> Result<Self, ShaderError> {
        Self::new_specialized(ctx, desc, &[])
    }

    /// [`ComputePipeline::new`] with specialization constants (DESIGN section 5: one shader per
    /// pass, variants chosen at pipeline creation, e.g. `HOMOGENEOUS` removing per-node material
    /// reads). Every id must be declared by the shader (checked against reflection). A separate
    /// argument rather than a field of [`ComputePipelineDesc`], so that existing descriptor
    /// literals keep compiling.
    pub fn new_specialized(
        ctx: &Context,
        desc: &ComputePipelineDesc<'_>,
        constants: &[SpecConstant],
    ) -> Result<Self, ShaderError> {
        let spirv = super::load(ctx, desc.shader)?;
        let reflection = Reflection::new(&spirv)?;
        for c in constants {
            if !reflection.spec_constants.iter().any(|(_, id)| *id == c.id) {
                return Err(ShaderError::Invalid {
                    shader: desc.shader.into(),
                    message: format!(
                        "no specialization constant with id {} (declared: {:?})",
                        c.id, reflection.spec_constants
                    ),
                });
            }
        }
        let entries: Vec<vk::SpecializationMapEntry> = constants
            .iter()
            .enumerate()
            .map(|(i, c)| vk::SpecializationMapEntry {
                constant_id: c.id,
                offset: (i * 4) as u32,
                size: 4,
            })
            .collect();
        let data: Vec<u8> = constants
            .iter()
            .flat_map(|c| c.value.to_le_bytes())
            .collect();
        let specialization = vk::SpecializationInfo::default()
            .map_entries(&entries)
            .data(&data);
        let workgroup_size = reflection
            .workgroup_size
            .ok_or_else(|| ShaderError::Invalid {
                shader: desc.shader.into(),
                message: "no LocalSize execution mode".into(),
            })?;
        let interface = Interface::new(
            ctx,
            desc.name,
            std::slice::from_ref(&reflection),
            std::mem::size_of::<P>(),
            desc.bindings,
            desc.max_sets,
        )?;
        let module = shader_module(ctx, &spirv)?;
        let entry = std::ffi::CString::new(reflection.entry_point.clone()).unwrap_or_default();
        let stage = vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::COMPUTE)
            .module(module)
            .name(&entry);
        let stage = if constants.is_empty() {
            stage
        } else {
            stage.specialization_info(&specialization)
        };
        let info = vk::ComputePipelineCreateInfo::default()
            .stage(stage)
            .layout(interface.layout);
        // SAFETY: module and layout are live; the module may go right after creation.
        let created = unsafe {
            let r = ctx
                .raw()
                .create_compute_pipelines(vk::PipelineCache::null(), &[info], None);
            ctx.raw().destroy_shader_module(module, None);
            r
        };
        let raw = created.map_err(|(_, result)| VkError::Call {
            call: "vkCreateComputePipelines",
            result,
        })?[0];
        ctx.set_name(raw, desc.name);
        Ok(ComputePipeline {
            raw,
            name: desc.name,
            workgroup_size,
            interface,
            _push: PhantomData,
        })
    }

    /// A descriptor set with every binding written (checked by name and type).
    pub fn allocate_set(
        &self,
        ctx: &Context,
        writes: &[DescriptorWrite<'_>],
    ) -> Result<vk::DescriptorSet, ShaderError> {
        self.interface.allocate_set(ctx, writes)
    }

    /// Records bind + push + dispatch covering `extent` invocations (rounded up to workgroups).
    ///
    /// # Safety
    /// `cb` must be recording outside a rendering scope; `set` must come from this pipeline and
    /// its resources be alive and in the states the shader expects until `cb` completes.
    pub unsafe fn dispatch(
        &self,
        ctx: &Context,
        cb: vk::CommandBuffer,
        set: vk::DescriptorSet,
        push: &P,
        extent: [u32; 3],
    ) {
        let raw = ctx.raw();
        let groups: Vec<u32> = (0..3)
            .map(|i| extent[i].div_ceil(self.workgroup_size[i]))
            .collect();
        // SAFETY: the caller's contract; the layout matches the set and the push range.
        unsafe {
            raw.cmd_bind_pipeline(cb, vk::PipelineBindPoint::COMPUTE, self.raw);
            if set != vk::DescriptorSet::null() {
                raw.cmd_bind_descriptor_sets(
                    cb,
                    vk::PipelineBindPoint::COMPUTE,
                    self.interface.layout,
                    0,
                    &[set],
                    &[],
                );
            }
            if self.interface.push_size > 0 {
                raw.cmd_push_constants(
                    cb,
                    self.interface.layout,
                    self.interface.push_stages,
                    0,
                    bytemuck::bytes_of(push),
                );
            }
            raw.cmd_dispatch(cb, groups[0], groups[1], groups[2]);
        }
    }

    /// Records bind + push + an indirect dispatch whose group counts the GPU reads from `args` at
    /// `offset` (a `VkDispatchIndirectCommand`).
    ///
    /// # Safety
    /// As [`ComputePipeline::dispatch`]; `args` must have INDIRECT_BUFFER usage, hold the command
    /// at `offset` (a multiple of 4) and its writes be made visible to INDIRECT_COMMAND_READ.
    pub unsafe fn dispatch_indirect(
        &self,
        ctx: &Context,
        cb: vk::CommandBuffer,
        set: vk::DescriptorSet,
        push: &P,
        args: &Buffer,
        offset: u64,
    ) {
        let raw = ctx.raw();
        // SAFETY: the caller's contract; the layout matches the set and the push range.
        unsafe {
            raw.cmd_bind_pipeline(cb, vk::PipelineBindPoint::COMPUTE, self.raw);
            if set != vk::DescriptorSet::null() {
                raw.cmd_bind_descriptor_sets(
                    cb,
                    vk::PipelineBindPoint::COMPUTE,
                    self.interface.layout,
                    0,
                    &[set],
                    &[],
                );
            }
            if self.interface.push_size > 0 {
                raw.cmd_push_constants(
                    cb,
                    self.interface.layout,
                    self.interface.push_stages,
                    0,
                    bytemuck::bytes_of(push),
                );
            }
            raw.cmd_dispatch_indirect(cb, args.raw, offset);
        }
    }
}

impl<P> Drop for ComputePipeline<P> {
    fn drop(&mut self) {
        self.interface
            .ctx_device
            .retire(crate::vk::device::Retired::Pipeline(self.raw));
    }
}

/// How to create a [`GraphicsPipeline`] for dynamic rendering.
#[derive(Clone, Debug)]
pub struct GraphicsPipelineDesc<'a> {
    pub name: &'static str,
    pub vertex: &'a str,
    /// `None` for depth-only passes.
    pub fragment: Option<&'a str>,
    pub vertex_stride: u32,
    pub vertex_attributes: &'a [VertexAttribute],
    /// Further per-vertex streams (bindings 1, 2, ..): each its stride and attributes (e.g. the
    /// shading's single scattering and exit-lobe share per vertex); empty: one interleaved buffer.
    pub extra_streams: &'a [(u32, &'a [VertexAttribute])],
    pub color_formats: &'a [vk::Format],
    pub depth_format: Option<vk::Format>,
    /// (constant factor, slope factor) for shadow maps.
    pub depth_bias: Option<(f32, f32)>,
    pub cull_mode: vk::CullModeFlags,
    pub bindings: &'a [&'a str],
    pub max_sets: u32,
}

/// A graphics pipeline (dynamic viewport and scissor) with push constants of type `P`.
pub struct GraphicsPipeline<P> {
    pub raw: vk::Pipeline,
    pub name: &'static str,
    interface: Interface,
    _push: PhantomData<P>,
}

impl<P: bytemuck::Pod> GraphicsPipeline<P> {
    pub fn new(ctx: &Context, desc: &GraphicsPipelineDesc<'_>) -> Result<Self, ShaderError> {
        let mut spirvs = vec![super::load(ctx, desc.vertex)?];
        if let Some(f) = desc.fragment {
            spirvs.push(super::load(ctx, f)?);
        }
        let reflections = spirvs
            .iter()
            .map(Reflection::new)
            .collect::<Result<Vec<_>, _>>()?;
        let interface = Interface::new(
            ctx,
            desc.name,
            &reflections,
            std::mem::size_of::<P>(),
            desc.bindings,
            desc.max_sets,
        )?;
        let mut modules = Vec::new();
        for s in &spirvs {
            match shader_module(ctx, s) {
                Ok(m) => modules.push(m),
                Err(e) => {
                    // SAFETY: the modules were never used.
                    unsafe {
                        modules
                            .iter()
                            .for_each(|m| ctx.raw().destroy_shader_module(*m, None))
                    };
                    return Err(e);
                }
            }
        }
        let entries: Vec<_> = reflections
            .iter()
            .map(|r| std::ffi::CString::new(r.entry_point.clone()).unwrap_or_default())
            .collect();
        let stages: Vec<_> = reflections
            .iter()
            .zip(&modules)
            .zip(&entries)
            .map(|((r, m), e)| {
                vk::PipelineShaderStageCreateInfo::default()
                    .stage(r.stage)
                    .module(*m)
                    .name(e)
            })
            .collect();
        let mut vertex_bindings = vec![vk::VertexInputBindingDescription::default()
            .binding(0)
            .stride(desc.vertex_stride)
            .input_rate(vk::VertexInputRate::VERTEX)];
        let attribute = |binding: u32, a: &VertexAttribute| {
            vk::VertexInputAttributeDescription::default()
                .location(a.location)
                .binding(binding)
                .format(a.format)
                .offset(a.offset)
        };
        let mut attributes: Vec<_> = desc
            .vertex_attributes
            .iter()
            .map(|a| attribute(0, a))
            .collect();
        for (binding, (stride, stream)) in (1u32..).zip(desc.extra_streams) {
            vertex_bindings.push(
                vk::VertexInputBindingDescription::default()
                    .binding(binding)
                    .stride(*stride)
                    .input_rate(vk::VertexInputRate::VERTEX),
            );
            attributes.extend(stream.iter().map(|a| attribute(binding, a)));
        }
        let vertex_input = vk::PipelineVertexInputStateCreateInfo::default()
            .vertex_binding_descriptions(&vertex_bindings)
            .vertex_attribute_descriptions(&attributes);
        let input_assembly = vk::PipelineInputAssemblyStateCreateInfo::default()
            .topology(vk::PrimitiveTopology::TRIANGLE_LIST);
        let viewport = vk::PipelineViewportStateCreateInfo::default()
            .viewport_count(1)
            .scissor_count(1);
        let mut raster = vk::PipelineRasterizationStateCreateInfo::default()
            .polygon_mode(vk::PolygonMode::FILL)
            .cull_mode(desc.cull_mode)
            .front_face(vk::FrontFace::COUNTER_CLOCKWISE)
            .line_width(1.0);
        if let Some((constant, slope)) = desc.depth_bias {
            raster = raster
                .depth_bias_enable(true)
                .depth_bias_constant_factor(constant)
                .depth_bias_slope_factor(slope);
        }
        let multisample = vk::PipelineMultisampleStateCreateInfo::default()
            .rasterization_samples(vk::SampleCountFlags::TYPE_1);
        let depth = vk::PipelineDepthStencilStateCreateInfo::default()
            .depth_test_enable(desc.depth_format.is_some())
            .depth_write_enable(desc.depth_format.is_some())
            .depth_compare_op(vk::CompareOp::LESS);
        let blend_attachments: Vec<_> = desc
            .color_formats
            .iter()
            .map(|_| {
                vk::PipelineColorBlendAttachmentState::default()
                    .color_write_mask(vk::ColorComponentFlags::RGBA)
            })
            .collect();
        let blend =
            vk::PipelineColorBlendStateCreateInfo::default().attachments(&blend_attachments);
        let dynamic_states = [vk::DynamicState::VIEWPORT, vk::DynamicState::SCISSOR];
        let dynamic = vk::PipelineDynamicStateCreateInfo::default().dynamic_states(&dynamic_states);
        let mut rendering = vk::PipelineRenderingCreateInfo::default()
            .color_attachment_formats(desc.color_formats)
            .depth_attachment_format(desc.depth_format.unwrap_or(vk::Format::UNDEFINED));
        let info = vk::GraphicsPipelineCreateInfo::default()
            .stages(&stages)
            .vertex_input_state(&vertex_input)
            .input_assembly_state(&input_assembly)
            .viewport_state(&viewport)
            .rasterization_state(&raster)
            .multisample_state(&multisample)
            .depth_stencil_state(&depth)
            .color_blend_state(&blend)
            .dynamic_state(&dynamic)
            .layout(interface.layout)
            .push_next(&mut rendering);
        // SAFETY: all referenced state lives across the call; modules may go right after.
        let created = unsafe {
            let r = ctx
                .raw()
                .create_graphics_pipelines(vk::PipelineCache::null(), &[info], None);
            modules
                .iter()
                .for_each(|m| ctx.raw().destroy_shader_module(*m, None));
            r
        };
        let raw = created.map_err(|(_, result)| VkError::Call {
            call: "vkCreateGraphicsPipelines",
            result,
        })?[0];
        ctx.set_name(raw, desc.name);
        Ok(GraphicsPipeline {
            raw,
            name: desc.name,
            interface,
            _push: PhantomData,
        })
    }

    pub fn allocate_set(
        &self,
        ctx: &Context,
        writes: &[DescriptorWrite<'_>],
    ) -> Result<vk::DescriptorSet, ShaderError> {
        self.interface.allocate_set(ctx, writes)
    }

    /// Binds the pipeline and `set` (if not null), pushes `push`, sets viewport and scissor to
    /// `extent` (full target).
    ///
    /// # Safety
    /// `cb` must be recording inside a dynamic-rendering scope whose formats match this pipeline.
    pub unsafe fn bind(
        &self,
        ctx: &Context,
        cb: vk::CommandBuffer,
        set: vk::DescriptorSet,
        push: &P,
        extent: vk::Extent2D,
    ) {
        let raw = ctx.raw();
        let viewport = vk::Viewport {
            x: 0.0,
            y: 0.0,
            width: extent.width as f32,
            height: extent.height as f32,
            min_depth: 0.0,
            max_depth: 1.0,
        };
        // SAFETY: the caller's contract; layout matches set and push range.
        unsafe {
            raw.cmd_bind_pipeline(cb, vk::PipelineBindPoint::GRAPHICS, self.raw);
            if set != vk::DescriptorSet::null() {
                raw.cmd_bind_descriptor_sets(
                    cb,
                    vk::PipelineBindPoint::GRAPHICS,
                    self.interface.layout,
                    0,
                    &[set],
                    &[],
                );
            }
            if self.interface.push_size > 0 {
                raw.cmd_push_constants(
                    cb,
                    self.interface.layout,
                    self.interface.push_stages,
                    0,
                    bytemuck::bytes_of(push),
                );
            }
            raw.cmd_set_viewport(cb, 0, &[viewport]);
            raw.cmd_set_scissor(
                cb,
                0,
                &[vk::Rect2D {
                    offset: vk::Offset2D::default(),
                    extent,
                }],
            );
        }
    }
}

impl<P> Drop for GraphicsPipeline<P> {
    fn drop(&mut self) {
        self.interface
            .ctx_device
            .retire(crate::vk::device::Retired::Pipeline(self.raw));
    }
}
