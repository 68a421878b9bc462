//! What each voxel pass declares about the resources it touches, and the barriers between two
//! declared states. [`State`] extends [`Access`] with the three states these passes need that
//! `vk::barrier` does not name yet: a storage image sampled by compute in GENERAL layout, a colour
//! image sampled by fragment and compute shaders, and indirect dispatch arguments.
//!
//! A pass records only the barriers inside itself (between its own dispatches); the barriers
//! between passes come from these declarations ([`super::VoxelMethod`] places them in phase 1, the
//! frame graph in phase 2).

use ash::vk;

use crate::vk::{barrier, Access, Buffer, Image};

/// A way a pass uses a resource: one of [`Access`], or a state `vk::barrier` lacks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum State {
    Vk(Access),
    // why: a storage image the same frame's compute passes also write, sampled (trilinear) by
    // compute in GENERAL layout: no layout change between the writer and the reader.
    ComputeSampledGeneral,
    // why: a colour image (reflective shadow map) or an uploaded volume sampled by compute and
    // fragment shaders in SHADER_READ_ONLY layout.
    ShaderSampled,
    // why: indirect dispatch arguments read by vkCmdDispatchIndirect.
    IndirectRead,
}

impl From<Access> for State {
    fn from(a: Access) -> State {
        State::Vk(a)
    }
}

impl State {
    /// (stage, access, layout).
    pub fn info(self) -> (vk::PipelineStageFlags2, vk::AccessFlags2, vk::ImageLayout) {
        use vk::AccessFlags2 as A;
        use vk::PipelineStageFlags2 as S;
        match self {
            State::Vk(a) => a.info(),
            State::ComputeSampledGeneral => (
                S::COMPUTE_SHADER,
                A::SHADER_SAMPLED_READ | A::SHADER_STORAGE_READ,
                vk::ImageLayout::GENERAL,
            ),
            State::ShaderSampled => (
                S::COMPUTE_SHADER | S::FRAGMENT_SHADER,
                A::SHADER_SAMPLED_READ,
                vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
            ),
            State::IndirectRead => (
                S::DRAW_INDIRECT,
                A::INDIRECT_COMMAND_READ,
                vk::ImageLayout::UNDEFINED,
            ),
        }
    }

    /// Whether the state writes (a following use needs a barrier even without a layout change).
    pub fn writes(self) -> bool {
        let (_, access, _) = self.info();
        access.intersects(
            vk::AccessFlags2::SHADER_STORAGE_WRITE
                | vk::AccessFlags2::COLOR_ATTACHMENT_WRITE
                | vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_WRITE
                | vk::AccessFlags2::TRANSFER_WRITE,
        )
    }
}

/// An image barrier `from -> to` on the whole image.
pub fn image_barrier(image: &Image, from: State, to: State) -> vk::ImageMemoryBarrier2<'static> {
    let (src_stage, src_access, old_layout) = from.info();
    let (dst_stage, dst_access, new_layout) = to.info();
    let template = barrier::image_barrier(image, Access::Undefined, Access::Undefined);
    template
        .src_stage_mask(src_stage)
        .src_access_mask(src_access)
        .dst_stage_mask(dst_stage)
        .dst_access_mask(dst_access)
        .old_layout(old_layout)
        .new_layout(new_layout)
}

/// A global memory barrier `from -> to`.
pub fn memory_barrier(from: State, to: State) -> vk::MemoryBarrier2<'static> {
    let (src_stage, src_access, _) = from.info();
    let (dst_stage, dst_access, _) = to.info();
    vk::MemoryBarrier2::default()
        .src_stage_mask(src_stage)
        .src_access_mask(src_access)
        .dst_stage_mask(dst_stage)
        .dst_access_mask(dst_access)
}

/// A resource a pass declares.
#[derive(Clone, Copy)]
pub enum Resource<'a> {
    Image(&'a Image),
    Buffer(&'a Buffer),
    /// A buffer the caller owns, by handle (a bound mesh's vertices or indices).
    RawBuffer(vk::Buffer, &'static str),
}

impl Resource<'_> {
    pub fn name(&self) -> &'static str {
        match self {
            Resource::Image(i) => i.name,
            Resource::Buffer(b) => b.name,
            Resource::RawBuffer(_, name) => name,
        }
    }

    /// The raw handle, as a number (identity of the resource).
    pub fn id(&self) -> u64 {
        use ash::vk::Handle;
        match self {
            Resource::Image(i) => i.raw.as_raw(),
            Resource::Buffer(b) => b.raw.as_raw(),
            Resource::RawBuffer(b, _) => b.as_raw(),
        }
    }
}

impl std::fmt::Debug for Resource<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// One resource a pass touches, and the state it must be in while the pass runs (for a write:
/// the state the pass leaves it in).
#[derive(Clone, Copy, Debug)]
pub struct ResourceUse<'a> {
    pub resource: Resource<'a>,
    pub state: State,
}

impl<'a> ResourceUse<'a> {
    pub fn image(image: &'a Image, state: impl Into<State>) -> Self {
        ResourceUse {
            resource: Resource::Image(image),
            state: state.into(),
        }
    }

    pub fn buffer(buffer: &'a Buffer, state: impl Into<State>) -> Self {
        ResourceUse {
            resource: Resource::Buffer(buffer),
            state: state.into(),
        }
    }

    pub fn raw_buffer(buffer: vk::Buffer, name: &'static str, state: impl Into<State>) -> Self {
        ResourceUse {
            resource: Resource::RawBuffer(buffer, name),
            state: state.into(),
        }
    }
}
