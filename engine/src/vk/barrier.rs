//! Barriers through synchronization2, from named states.
//!
//! A barrier is a pair of [`Access`] states: everything the GPU did to a resource in the `from`
//! state must be finished (and its writes visible) before it is used in the `to` state. Each
//! state fixes its pipeline stage, access mask and (for images) layout, so a call site reads as
//! `Access::ComputeWrite -> Access::ComputeRead` and carries one `// why:` naming the hazard.
//!
//! ```no_run
//! # use translucent::vk::{barrier, Access, Context, Image};
//! # unsafe fn f(ctx: &Context, cb: ash::vk::CommandBuffer, color: &Image) {
//! // why: the copy reads what the color attachment wrote (RAW) and needs TRANSFER_SRC layout.
//! unsafe { barrier::image(ctx, cb, color, Access::ColorAttachmentWrite, Access::TransferSrc) };
//! # }
//! ```

use ash::vk;

use super::memory::full_range;
use super::{Context, Image};

/// A named way the GPU uses a resource.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Access {
    // why: contents are discarded; only valid as a `from` state (first use of an image).
    Undefined,
    // why: storage images stay in GENERAL so a ping-pong loop needs memory barriers only, no layout changes.
    ComputeRead,
    // why: compute shader storage writes; GENERAL as above.
    ComputeWrite,
    // why: a dispatch that both reads and writes (or a later one that may do either).
    ComputeReadWrite,
    // why: as ComputeReadWrite, for dispatches that may also read the buffers through uniform
    // texel views (the multigrid's `*_t` bindings: SHADER_SAMPLED_READ in synchronization2).
    ComputeReadWriteTexels,
    // why: color attachment written by a dynamic-rendering pass (load op clear/load counts as write).
    ColorAttachmentWrite,
    // why: depth tests read and write the attachment in early and late fragment tests.
    DepthAttachmentWrite,
    // why: a finished depth map sampled by fragment shaders (shadow lookups).
    DepthSampledFragment,
    // why: a color image sampled by fragment shaders.
    FragmentSampled,
    // why: a finished depth map sampled by fragment and compute shaders (shadow lookups of the
    // shading pass and of the irradiance gather).
    DepthSampledShaders,
    // why: source of a copy (capture read-back).
    TransferSrc,
    // why: destination of a copy, clear or vkCmdUpdateBuffer.
    TransferDst,
    // why: a uniform buffer read by the vertex and fragment stages.
    GraphicsUniformRead,
    // why: vertex and index fetch of draws.
    VertexInput,
    // why: the CPU reads memory after the fence; makes GPU writes host-visible.
    HostRead,
    // why: indirect dispatch/draw arguments read by the command processor (DRAW_INDIRECT covers
    // dispatches too), and the compute passes that read or update them.
    IndirectArgs,
    // why: a storage image the same frame's compute passes also write, sampled (trilinear) by
    // compute in GENERAL layout: no layout change between the writer and the reader (voxel
    // method).
    ComputeSampled,
    // why: a colour image (reflective shadow map) or an uploaded volume sampled by compute and
    // fragment shaders in SHADER_READ_ONLY layout (voxel method).
    ShadersSampled,
}

impl Access {
    /// (stage, access, layout) of this state.
    pub fn info(self) -> (vk::PipelineStageFlags2, vk::AccessFlags2, vk::ImageLayout) {
        use vk::AccessFlags2 as A;
        use vk::ImageLayout as L;
        use vk::PipelineStageFlags2 as S;
        match self {
            Access::Undefined => (S::NONE, A::NONE, L::UNDEFINED),
            Access::ComputeRead => (S::COMPUTE_SHADER, A::SHADER_STORAGE_READ, L::GENERAL),
            Access::ComputeWrite => (S::COMPUTE_SHADER, A::SHADER_STORAGE_WRITE, L::GENERAL),
            Access::ComputeReadWrite => (
                S::COMPUTE_SHADER,
                A::SHADER_STORAGE_READ | A::SHADER_STORAGE_WRITE,
                L::GENERAL,
            ),
            Access::ComputeReadWriteTexels => (
                S::COMPUTE_SHADER,
                A::SHADER_SAMPLED_READ | A::SHADER_STORAGE_READ | A::SHADER_STORAGE_WRITE,
                L::GENERAL,
            ),
            Access::ColorAttachmentWrite => (
                S::COLOR_ATTACHMENT_OUTPUT,
                A::COLOR_ATTACHMENT_WRITE | A::COLOR_ATTACHMENT_READ,
                L::COLOR_ATTACHMENT_OPTIMAL,
            ),
            Access::DepthAttachmentWrite => (
                S::EARLY_FRAGMENT_TESTS | S::LATE_FRAGMENT_TESTS,
                A::DEPTH_STENCIL_ATTACHMENT_READ | A::DEPTH_STENCIL_ATTACHMENT_WRITE,
                L::DEPTH_ATTACHMENT_OPTIMAL,
            ),
            Access::DepthSampledFragment => (
                S::FRAGMENT_SHADER,
                A::SHADER_SAMPLED_READ,
                L::DEPTH_READ_ONLY_OPTIMAL,
            ),
            Access::DepthSampledShaders => (
                S::FRAGMENT_SHADER | S::COMPUTE_SHADER,
                A::SHADER_SAMPLED_READ,
                L::DEPTH_READ_ONLY_OPTIMAL,
            ),
            Access::FragmentSampled => (
                S::FRAGMENT_SHADER,
                A::SHADER_SAMPLED_READ,
                L::SHADER_READ_ONLY_OPTIMAL,
            ),
            Access::TransferSrc => (S::COPY, A::TRANSFER_READ, L::TRANSFER_SRC_OPTIMAL),
            Access::TransferDst => (
                S::COPY | S::CLEAR,
                A::TRANSFER_WRITE,
                L::TRANSFER_DST_OPTIMAL,
            ),
            Access::GraphicsUniformRead => (
                S::VERTEX_SHADER | S::FRAGMENT_SHADER,
                A::UNIFORM_READ,
                L::UNDEFINED,
            ),
            Access::VertexInput => (
                S::VERTEX_INPUT,
                A::VERTEX_ATTRIBUTE_READ | A::INDEX_READ,
                L::UNDEFINED,
            ),
            Access::HostRead => (S::HOST, A::HOST_READ, L::GENERAL),
            Access::IndirectArgs => (
                S::DRAW_INDIRECT | S::COMPUTE_SHADER,
                A::INDIRECT_COMMAND_READ | A::SHADER_STORAGE_READ | A::SHADER_STORAGE_WRITE,
                L::UNDEFINED,
            ),
            Access::ComputeSampled => (
                S::COMPUTE_SHADER,
                A::SHADER_SAMPLED_READ | A::SHADER_STORAGE_READ,
                L::GENERAL,
            ),
            Access::ShadersSampled => (
                S::COMPUTE_SHADER | S::FRAGMENT_SHADER,
                A::SHADER_SAMPLED_READ,
                L::SHADER_READ_ONLY_OPTIMAL,
            ),
        }
    }
}

impl Access {
    /// Whether this state writes (a barrier after it makes the writes available).
    pub fn writes(self) -> bool {
        self.info().1.intersects(WRITE_ACCESS)
    }
}

/// A synchronization2 state of an image owned by someone else (a host's target): stage, access and
/// layout, as it comes in or must leave. Our own resources use the named [`Access`] states.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImageState {
    pub stage: vk::PipelineStageFlags2,
    pub access: vk::AccessFlags2,
    pub layout: vk::ImageLayout,
}

impl From<Access> for ImageState {
    fn from(a: Access) -> Self {
        let (stage, access, layout) = a.info();
        ImageState {
            stage,
            access,
            layout,
        }
    }
}

/// A whole-image barrier on a raw image (e.g. a host's) of `format` between two states.
pub fn raw_image_barrier(
    image: vk::Image,
    format: vk::Format,
    from: ImageState,
    to: ImageState,
) -> vk::ImageMemoryBarrier2<'static> {
    vk::ImageMemoryBarrier2::default()
        .src_stage_mask(from.stage)
        .src_access_mask(from.access)
        .dst_stage_mask(to.stage)
        .dst_access_mask(to.access)
        .old_layout(from.layout)
        .new_layout(to.layout)
        .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .image(image)
        .subresource_range(full_range(format))
}

/// The access bits that write (a barrier after them must make them available).
pub const WRITE_ACCESS: vk::AccessFlags2 = vk::AccessFlags2::from_raw(
    vk::AccessFlags2::SHADER_STORAGE_WRITE.as_raw()
        | vk::AccessFlags2::SHADER_WRITE.as_raw()
        | vk::AccessFlags2::COLOR_ATTACHMENT_WRITE.as_raw()
        | vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_WRITE.as_raw()
        | vk::AccessFlags2::TRANSFER_WRITE.as_raw()
        | vk::AccessFlags2::HOST_WRITE.as_raw()
        | vk::AccessFlags2::MEMORY_WRITE.as_raw(),
);

/// How the GPU last used a resource, kept with every [`Image`] and [`super::Buffer`] across
/// frames: the frame graph (`crate::frame`) derives the next barrier from it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Tracked {
    /// The image's layout (UNDEFINED for a buffer, or an image never used).
    pub layout: vk::ImageLayout,
    /// The last write (or layout transition): its stages and write accesses.
    pub write_stage: vk::PipelineStageFlags2,
    pub write_access: vk::AccessFlags2,
    /// Stages and accesses already ordered after that write (a read there needs no barrier).
    pub visible_stage: vk::PipelineStageFlags2,
    pub visible_access: vk::AccessFlags2,
    /// Stages that read since that write (a later write waits for them: WAR).
    pub read_stage: vk::PipelineStageFlags2,
    /// Who wrote last (a pass name), for the generated "why" of the next barrier.
    pub writer: &'static str,
}

impl Tracked {
    /// A resource the GPU never used.
    pub const UNUSED: Tracked = Tracked {
        layout: vk::ImageLayout::UNDEFINED,
        write_stage: vk::PipelineStageFlags2::NONE,
        write_access: vk::AccessFlags2::NONE,
        visible_stage: vk::PipelineStageFlags2::NONE,
        visible_access: vk::AccessFlags2::NONE,
        read_stage: vk::PipelineStageFlags2::NONE,
        writer: "",
    };

    /// The state after a use in `state` by `by`, treated as a write unless it only reads in an
    /// unchanged layout: what a barrier into `state` followed by that use leaves.
    pub fn after(state: ImageState, by: &'static str) -> Tracked {
        Tracked {
            layout: state.layout,
            write_stage: state.stage,
            write_access: state.access & WRITE_ACCESS,
            visible_stage: vk::PipelineStageFlags2::NONE,
            visible_access: vk::AccessFlags2::NONE,
            read_stage: vk::PipelineStageFlags2::NONE,
            writer: by,
        }
    }
}

/// An image barrier from `from` to `to` on the whole image; the image's [`Tracked`] state becomes
/// `to` (the use the barrier prepares).
pub fn image_barrier(image: &Image, from: Access, to: Access) -> vk::ImageMemoryBarrier2<'static> {
    let (src_stage, src_access, old_layout) = from.info();
    let (dst_stage, dst_access, new_layout) = to.info();
    image.set_tracked(Tracked::after(
        to.into(),
        "a barrier recorded outside the frame graph",
    ));
    vk::ImageMemoryBarrier2::default()
        .src_stage_mask(src_stage)
        .src_access_mask(src_access)
        .dst_stage_mask(dst_stage)
        .dst_access_mask(dst_access)
        .old_layout(old_layout)
        .new_layout(new_layout)
        .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .image(image.raw)
        .subresource_range(full_range(image.format))
}

/// A global memory barrier from `from` to `to` (no layout change).
pub fn memory_barrier(from: Access, to: Access) -> vk::MemoryBarrier2<'static> {
    let (src_stage, src_access, _) = from.info();
    let (dst_stage, dst_access, _) = to.info();
    vk::MemoryBarrier2::default()
        .src_stage_mask(src_stage)
        .src_access_mask(src_access)
        .dst_stage_mask(dst_stage)
        .dst_access_mask(dst_access)
}

/// Records the given barriers in one `vkCmdPipelineBarrier2`.
///
/// # Safety
/// `cb` must be recording, outside a rendering scope, and the images alive until it completes.
pub unsafe fn record(
    ctx: &Context,
    cb: vk::CommandBuffer,
    memory: &[vk::MemoryBarrier2],
    images: &[vk::ImageMemoryBarrier2],
) {
    let dep = vk::DependencyInfo::default()
        .memory_barriers(memory)
        .image_memory_barriers(images);
    // SAFETY: the caller guarantees `cb` is recording; the barrier structs are complete.
    unsafe { ctx.raw().cmd_pipeline_barrier2(cb, &dep) };
}

/// One image barrier `from -> to`.
///
/// # Safety
/// As [`record`].
pub unsafe fn image(ctx: &Context, cb: vk::CommandBuffer, image: &Image, from: Access, to: Access) {
    // SAFETY: forwarded contract.
    unsafe { record(ctx, cb, &[], &[image_barrier(image, from, to)]) };
}

/// One global memory barrier `from -> to`.
///
/// # Safety
/// As [`record`].
pub unsafe fn memory(ctx: &Context, cb: vk::CommandBuffer, from: Access, to: Access) {
    // SAFETY: forwarded contract.
    unsafe { record(ctx, cb, &[memory_barrier(from, to)], &[]) };
}

/// One of our resources a pass uses.
#[derive(Clone, Copy)]
pub enum Resource<'a> {
    Image(&'a Image),
    Buffer(&'a super::Buffer),
}

impl Resource<'_> {
    /// The raw handle (identity in the frame graph).
    pub fn handle(&self) -> u64 {
        use vk::Handle;
        match self {
            Resource::Image(i) => i.raw.as_raw(),
            Resource::Buffer(b) => b.raw.as_raw(),
        }
    }
    /// The debug name.
    pub fn name(&self) -> &'static str {
        match self {
            Resource::Image(i) => i.name,
            Resource::Buffer(b) => b.name,
        }
    }
    pub fn tracked(&self) -> Tracked {
        match self {
            Resource::Image(i) => i.tracked(),
            Resource::Buffer(b) => b.tracked(),
        }
    }
    pub fn set_tracked(&self, t: Tracked) {
        match self {
            Resource::Image(i) => i.set_tracked(t),
            Resource::Buffer(b) => b.set_tracked(t),
        }
    }
}

impl std::fmt::Debug for Resource<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{:?}", self.name())
    }
}

/// How a pass uses one resource (a pass's declaration, read by the frame graph): the state of its
/// first use, which the graph's barrier in front of the pass prepares, and of its last use, which
/// the next user's barrier starts from. They differ when the pass moves the resource between
/// states itself (with barriers inside the pass).
///
/// ```no_run
/// # use translucent::vk::{barrier::Use, Access, Image, Buffer};
/// # fn f(q: &Image, phi: &Image, control: &Buffer) {
/// let uses = [
///     Use::image(q, Access::ComputeRead),                     // read only
///     Use::image(phi, Access::ComputeReadWrite),              // ping-pong inside the pass
///     Use::buffer_span(control, Access::TransferDst, Access::IndirectArgs), // reset, then args
/// ];
/// # }
/// ```
#[derive(Clone, Copy, Debug)]
pub struct Use<'a> {
    pub resource: Resource<'a>,
    pub first: Access,
    pub last: Access,
}

impl<'a> Use<'a> {
    pub fn image(image: &'a Image, access: Access) -> Use<'a> {
        Use::image_span(image, access, access)
    }
    pub fn image_span(image: &'a Image, first: Access, last: Access) -> Use<'a> {
        Use {
            resource: Resource::Image(image),
            first,
            last,
        }
    }
    pub fn buffer(buffer: &'a super::Buffer, access: Access) -> Use<'a> {
        Use::buffer_span(buffer, access, access)
    }
    pub fn buffer_span(buffer: &'a super::Buffer, first: Access, last: Access) -> Use<'a> {
        Use {
            resource: Resource::Buffer(buffer),
            first,
            last,
        }
    }
}
