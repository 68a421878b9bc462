//! The host's side of a [`TranslucentObject`](super::TranslucentObject): what it passes to
//! [`record`](super::TranslucentObject::record) (its command buffer, frames and targets) and what
//! [`declare`](super::TranslucentObject::declare) tells a host graph about our use of them.

use ash::vk;

use crate::vk::{Context, GpuProfiler, ImageState};

/// The host's side of one [`TranslucentObject::record`].
pub struct RecordCtx<'a> {
    pub ctx: &'a Context,
    /// The host's command buffer, recording, outside a rendering scope.
    pub cb: vk::CommandBuffer,
    /// The frame being recorded (monotonic).
    pub frame: u64,
    /// The last frame the GPU has finished.
    pub completed_frame: u64,
    /// The host's profiler (its frame begun): our passes add named scopes.
    pub profiler: Option<&'a mut GpuProfiler>,
}

/// One host image we render into, with the state it comes in and must leave in.
#[derive(Clone, Copy, Debug)]
pub struct TargetImage {
    pub image: vk::Image,
    pub view: vk::ImageView,
    pub format: vk::Format,
    pub extent: vk::Extent2D,
    pub before: ImageState,
    pub after: ImageState,
}

/// Where [`TranslucentObject::record`] draws.
#[derive(Clone, Copy, Debug)]
pub struct Targets {
    /// Loaded (the host's background stays) and drawn over.
    pub color: TargetImage,
    /// The host's depth: we test against it and write ours. `None`: our own depth buffer.
    pub depth: Option<TargetImage>,
    /// The host placed the boundary barriers (from [`TranslucentObject::declare`]): the targets
    /// are already in the declared states and `before`/`after` are ignored.
    pub host_barriers: bool,
}

/// Which host resource a [`ResourceUse`] is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HostResource {
    /// [`Targets::color`].
    Color,
    /// [`Targets::depth`].
    Depth,
}

/// How our recorded work uses a host resource, for a host graph's barriers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ResourceUse {
    pub resource: HostResource,
    pub stage: vk::PipelineStageFlags2,
    pub access: vk::AccessFlags2,
    /// Images: the layout we use it in.
    pub layout: vk::ImageLayout,
    pub read: bool,
    pub write: bool,
}
