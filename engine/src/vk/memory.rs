//! [`Buffer`] and [`Image`]: each owns its gpu-allocator allocation; dropping one queues it for
//! release after the frame being recorded completes.

use std::sync::{Arc, Mutex};

use ash::vk;
use gpu_allocator::vulkan::Allocation;
use gpu_allocator::MemoryLocation;

use super::barrier::Tracked;
use super::device::{Device, Retired};
use super::{Context, VkError};

/// Where a resource's memory lives, by how the CPU uses it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MemoryUse {
    /// Device-local, no CPU access.
    GpuOnly,
    /// CPU writes, GPU reads (uploads, per-frame constants, small vertex buffers).
    Upload,
    /// GPU writes, CPU reads (captures, query copies).
    Readback,
}

impl MemoryUse {
    fn location(self) -> MemoryLocation {
        match self {
            MemoryUse::GpuOnly => MemoryLocation::GpuOnly,
            MemoryUse::Upload => MemoryLocation::CpuToGpu,
            MemoryUse::Readback => MemoryLocation::GpuToCpu,
        }
    }
}

/// How to create a [`Buffer`].
#[derive(Clone, Debug)]
pub struct BufferDesc {
    pub name: &'static str,
    pub size: u64,
    pub usage: vk::BufferUsageFlags,
    pub memory: MemoryUse,
}

/// A buffer and its memory.
pub struct Buffer {
    pub raw: vk::Buffer,
    pub size: u64,
    pub name: &'static str,
    allocation: Option<Allocation>,
    device: Arc<Device>,
    /// How the GPU last used it, for the frame graph's barriers (`crate::frame`).
    tracked: Mutex<Tracked>,
}

impl Buffer {
    pub fn new(ctx: &Context, desc: &BufferDesc) -> Result<Buffer, VkError> {
        if desc.size == 0 {
            return Err(VkError::invalid(desc.name, "buffer size is 0"));
        }
        let device = ctx.device.clone();
        let info = vk::BufferCreateInfo::default()
            .size(desc.size)
            .usage(desc.usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE);
        // SAFETY: valid create info on a live device.
        let raw = unsafe { device.raw().create_buffer(&info, None) }
            .map_err(VkError::call("vkCreateBuffer"))?;
        // SAFETY: `raw` was just created.
        let requirements = unsafe { device.raw().get_buffer_memory_requirements(raw) };
        let allocation =
            match device.allocate(desc.name, requirements, desc.memory.location(), true) {
                Ok(a) => a,
                Err(e) => {
                    // SAFETY: never used.
                    unsafe { device.raw().destroy_buffer(raw, None) };
                    return Err(e);
                }
            };
        // SAFETY: the allocation satisfies `requirements` and is not bound elsewhere.
        if let Err(result) = unsafe {
            device
                .raw()
                .bind_buffer_memory(raw, allocation.memory(), allocation.offset())
        } {
            device.retire(Retired::Buffer(raw, allocation));
            return Err(VkError::Call {
                call: "vkBindBufferMemory",
                result,
            });
        }
        device.set_name(raw, desc.name);
        Ok(Buffer {
            raw,
            size: desc.size,
            name: desc.name,
            allocation: Some(allocation),
            device,
            tracked: Mutex::new(Tracked::UNUSED),
        })
    }

    /// A host-visible buffer holding `data`.
    pub fn with_data<T: bytemuck::Pod>(
        ctx: &Context,
        name: &'static str,
        usage: vk::BufferUsageFlags,
        data: &[T],
    ) -> Result<Buffer, VkError> {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let mut buffer = Buffer::new(
            ctx,
            &BufferDesc {
                name,
                size: bytes.len() as u64,
                usage,
                memory: MemoryUse::Upload,
            },
        )?;
        buffer.write_bytes(0, bytes)?;
        Ok(buffer)
    }

    /// Writes into a host-visible buffer (the caller orders it against GPU use).
    pub fn write_bytes(&mut self, offset: usize, bytes: &[u8]) -> Result<(), VkError> {
        let name = self.name;
        let slice = self
            .allocation
            .as_mut()
            .and_then(|a| a.mapped_slice_mut())
            .ok_or_else(|| VkError::invalid(name, "buffer is not host-visible"))?;
        let end = offset
            .checked_add(bytes.len())
            .filter(|&e| e <= slice.len());
        let end = end.ok_or_else(|| {
            VkError::invalid(
                name,
                format!("write of {} bytes at {offset} overflows", bytes.len()),
            )
        })?;
        slice[offset..end].copy_from_slice(bytes);
        Ok(())
    }

    /// How the GPU last used the buffer (what the frame graph's next barrier starts from).
    pub fn tracked(&self) -> Tracked {
        *self.tracked.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Records how the GPU last used the buffer (the frame graph after each pass).
    pub fn set_tracked(&self, tracked: Tracked) {
        *self.tracked.lock().unwrap_or_else(|e| e.into_inner()) = tracked;
    }

    /// The contents of a host-visible buffer (the caller has waited for the GPU writes).
    pub fn read_bytes(&self) -> Result<&[u8], VkError> {
        let slice = self.allocation.as_ref().and_then(|a| a.mapped_slice());
        let slice =
            slice.ok_or_else(|| VkError::invalid(self.name, "buffer is not host-visible"))?;
        Ok(&slice[..self.size as usize])
    }
}

impl Drop for Buffer {
    fn drop(&mut self) {
        if let Some(allocation) = self.allocation.take() {
            self.device.retire(Retired::Buffer(self.raw, allocation));
        }
    }
}

/// How to create an [`Image`] (2D, one mip, one layer, optimal tiling).
#[derive(Clone, Debug)]
pub struct ImageDesc {
    pub name: &'static str,
    pub width: u32,
    pub height: u32,
    pub format: vk::Format,
    pub usage: vk::ImageUsageFlags,
}

/// How to create a 3D [`Image`] (a volume: one mip, one layer, optimal tiling), e.g. the voxel
/// method's grids ([`crate::solver::voxel`]).
#[derive(Clone, Debug)]
pub struct VolumeDesc {
    pub name: &'static str,
    /// Width, height, depth in texels.
    pub extent: [u32; 3],
    pub format: vk::Format,
    pub usage: vk::ImageUsageFlags,
}

/// A 2D image (or a 3D volume, [`Image::new_volume`]), its memory and a view of the whole image.
pub struct Image {
    pub raw: vk::Image,
    pub view: vk::ImageView,
    pub format: vk::Format,
    pub width: u32,
    pub height: u32,
    /// Texels along z: 1 for a 2D image.
    pub depth: u32,
    pub usage: vk::ImageUsageFlags,
    pub name: &'static str,
    allocation: Option<Allocation>,
    device: Arc<Device>,
    /// Layout and last use, for the frame graph's barriers (`crate::frame`); barriers recorded
    /// through [`super::barrier::image`] keep it current too.
    tracked: Mutex<Tracked>,
}

/// The aspect a format's view and barriers use.
pub fn aspect_of(format: vk::Format) -> vk::ImageAspectFlags {
    match format {
        vk::Format::D16_UNORM | vk::Format::D32_SFLOAT | vk::Format::X8_D24_UNORM_PACK32 => {
            vk::ImageAspectFlags::DEPTH
        }
        vk::Format::D24_UNORM_S8_UINT
        | vk::Format::D32_SFLOAT_S8_UINT
        | vk::Format::D16_UNORM_S8_UINT => {
            vk::ImageAspectFlags::DEPTH | vk::ImageAspectFlags::STENCIL
        }
        _ => vk::ImageAspectFlags::COLOR,
    }
}

impl Image {
    /// Records a copy of tightly packed texels from `buffer` into the whole image (color aspect,
    /// mip 0, layer 0). The caller's barriers put the image in TRANSFER_DST first.
    ///
    /// # Safety
    /// `cb` is recording, on `ctx`'s device; `buffer` holds at least `width * height * depth` texels of the
    /// image's format and outlives the command buffer's execution.
    pub unsafe fn record_upload_from(&self, ctx: &Context, cb: vk::CommandBuffer, buffer: &Buffer) {
        let region = vk::BufferImageCopy::default()
            .image_subresource(
                vk::ImageSubresourceLayers::default()
                    .aspect_mask(vk::ImageAspectFlags::COLOR)
                    .layer_count(1),
            )
            .image_extent(vk::Extent3D {
                width: self.width,
                height: self.height,
                depth: self.depth,
            });
        // SAFETY: the caller guarantees a recording command buffer and a large enough buffer.
        unsafe {
            ctx.raw().cmd_copy_buffer_to_image(
                cb,
                buffer.raw,
                self.raw,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &[region],
            );
        }
    }

    pub fn new(ctx: &Context, desc: &ImageDesc) -> Result<Image, VkError> {
        let limit = ctx.limits().max_image_dimension2_d;
        if desc.width == 0 || desc.height == 0 || desc.width > limit || desc.height > limit {
            return Err(VkError::invalid(
                desc.name,
                format!(
                    "image size {}x{} outside 1..={limit}",
                    desc.width, desc.height
                ),
            ));
        }
        Self::create(
            ctx,
            desc.name,
            vk::ImageType::TYPE_2D,
            [desc.width, desc.height, 1],
            desc.format,
            desc.usage,
        )
    }

    /// A 3D image (one mip, one layer) with a 3D view of the whole volume.
    pub fn new_volume(ctx: &Context, desc: &VolumeDesc) -> Result<Image, VkError> {
        let limit = ctx.limits().max_image_dimension3_d;
        if desc.extent.iter().any(|&e| e == 0 || e > limit) {
            return Err(VkError::invalid(
                desc.name,
                format!(
                    "volume size {}x{}x{} outside 1..={limit}",
                    desc.extent[0], desc.extent[1], desc.extent[2]
                ),
            ));
        }
        Self::create(
            ctx,
            desc.name,
            vk::ImageType::TYPE_3D,
            desc.extent,
            desc.format,
            desc.usage,
        )
    }

    fn create(
        ctx: &Context,
        name: &'static str,
        image_type: vk::ImageType,
        extent: [u32; 3],
        format: vk::Format,
        usage: vk::ImageUsageFlags,
    ) -> Result<Image, VkError> {
        let device = ctx.device.clone();
        let info = vk::ImageCreateInfo::default()
            .image_type(image_type)
            .format(format)
            .extent(vk::Extent3D {
                width: extent[0],
                height: extent[1],
                depth: extent[2],
            })
            .mip_levels(1)
            .array_layers(1)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        // SAFETY: valid create info on a live device.
        let raw = unsafe { device.raw().create_image(&info, None) }
            .map_err(VkError::call("vkCreateImage"))?;
        // SAFETY: `raw` was just created.
        let requirements = unsafe { device.raw().get_image_memory_requirements(raw) };
        let allocation = match device.allocate(name, requirements, MemoryLocation::GpuOnly, false) {
            Ok(a) => a,
            Err(e) => {
                // SAFETY: never used.
                unsafe { device.raw().destroy_image(raw, None) };
                return Err(e);
            }
        };
        // SAFETY: the allocation satisfies `requirements`.
        if let Err(result) = unsafe {
            device
                .raw()
                .bind_image_memory(raw, allocation.memory(), allocation.offset())
        } {
            device.retire(Retired::Image(raw, vk::ImageView::null(), allocation));
            return Err(VkError::Call {
                call: "vkBindImageMemory",
                result,
            });
        }
        let view_type = if image_type == vk::ImageType::TYPE_3D {
            vk::ImageViewType::TYPE_3D
        } else {
            vk::ImageViewType::TYPE_2D
        };
        let view_info = vk::ImageViewCreateInfo::default()
            .image(raw)
            .view_type(view_type)
            .format(format)
            .subresource_range(full_range(format));
        // SAFETY: `raw` is bound to memory; the range covers its only mip and layer.
        let view = match unsafe { device.raw().create_image_view(&view_info, None) } {
            Ok(v) => v,
            Err(result) => {
                device.retire(Retired::Image(raw, vk::ImageView::null(), allocation));
                return Err(VkError::Call {
                    call: "vkCreateImageView",
                    result,
                });
            }
        };
        device.set_name(raw, name);
        device.set_name(view, name);
        Ok(Image {
            raw,
            view,
            format,
            width: extent[0],
            height: extent[1],
            depth: extent[2],
            usage,
            name,
            allocation: Some(allocation),
            device,
            tracked: Mutex::new(Tracked::UNUSED),
        })
    }

    /// The image's layout and how the GPU last used it.
    pub fn tracked(&self) -> Tracked {
        *self.tracked.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Records the image's layout and last use (the frame graph after each pass).
    pub fn set_tracked(&self, tracked: Tracked) {
        *self.tracked.lock().unwrap_or_else(|e| e.into_inner()) = tracked;
    }

    pub fn extent(&self) -> vk::Extent2D {
        vk::Extent2D {
            width: self.width,
            height: self.height,
        }
    }

    pub fn aspect(&self) -> vk::ImageAspectFlags {
        aspect_of(self.format)
    }
}

/// The whole (one mip, one layer) subresource range of an image of `format`.
pub fn full_range(format: vk::Format) -> vk::ImageSubresourceRange {
    vk::ImageSubresourceRange::default()
        .aspect_mask(aspect_of(format))
        .level_count(1)
        .layer_count(1)
}

impl Drop for Image {
    fn drop(&mut self) {
        if let Some(allocation) = self.allocation.take() {
            self.device
                .retire(Retired::Image(self.raw, self.view, allocation));
        }
    }
}

/// A sampler, released through the context like every other object.
pub struct Sampler {
    pub raw: vk::Sampler,
    device: Arc<Device>,
}

impl Sampler {
    pub fn new(
        ctx: &Context,
        name: &'static str,
        info: &vk::SamplerCreateInfo<'_>,
    ) -> Result<Sampler, VkError> {
        // SAFETY: valid create info on a live device.
        let raw = unsafe { ctx.raw().create_sampler(info, None) }
            .map_err(VkError::call("vkCreateSampler"))?;
        ctx.set_name(raw, name);
        Ok(Sampler {
            raw,
            device: ctx.device.clone(),
        })
    }
}

impl Drop for Sampler {
    fn drop(&mut self) {
        self.device.retire(Retired::Sampler(self.raw));
    }
}

/// A texel view of a [`Buffer`] (a uniform texel buffer's descriptor), released through the
/// context like every other object. The buffer must outlive it and carry
/// `UNIFORM_TEXEL_BUFFER` usage.
pub struct BufferView {
    pub raw: vk::BufferView,
    device: Arc<Device>,
}

impl BufferView {
    /// The whole of `buffer` as texels of `format` (`texel_bytes` each). A buffer of more texels
    /// than the device's `maxTexelBufferElements` is an error, not a view.
    pub fn new(
        ctx: &Context,
        buffer: &Buffer,
        format: vk::Format,
        texel_bytes: u64,
    ) -> Result<BufferView, VkError> {
        let texels = buffer.size / texel_bytes.max(1);
        let limit = u64::from(ctx.limits().max_texel_buffer_elements);
        if texels > limit {
            return Err(VkError::invalid(
                buffer.name,
                format!("{texels} texels in a texel view, device limit {limit}"),
            ));
        }
        let info = vk::BufferViewCreateInfo::default()
            .buffer(buffer.raw)
            .format(format)
            .offset(0)
            .range(texels * texel_bytes);
        // SAFETY: valid create info on a live device; the range lies inside the buffer.
        let raw = unsafe { ctx.raw().create_buffer_view(&info, None) }
            .map_err(VkError::call("vkCreateBufferView"))?;
        ctx.set_name(raw, buffer.name);
        Ok(BufferView {
            raw,
            device: ctx.device.clone(),
        })
    }
}

impl Drop for BufferView {
    fn drop(&mut self) {
        self.device.retire(Retired::BufferView(self.raw));
    }
}
