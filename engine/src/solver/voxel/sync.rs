//! What each voxel pass declares about the resources it touches: [`crate::vk::barrier::Use`]s,
//! from which the frame graph ([`crate::frame::FrameGraph`]) places the barriers between passes.
//! A pass records only the barriers inside itself (between its own dispatches), with
//! [`image_barrier`] (which keeps the image's tracked state, so the graph's next barrier knows
//! what the pass left).

use crate::vk::{barrier, Access, Image};

pub use crate::vk::barrier::Use as ResourceUse;

/// The state a pass uses a resource in (the named [`Access`] states).
pub type State = Access;

/// An image barrier `from -> to` on the whole image (its tracked state follows).
pub fn image_barrier(
    image: &Image,
    from: Access,
    to: Access,
) -> ash::vk::ImageMemoryBarrier2<'static> {
    barrier::image_barrier(image, from, to)
}
