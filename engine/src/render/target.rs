//! [`OffscreenTarget`]: an RGBA16F color image and a D32 depth buffer, with the state each is in.

use ash::vk;

use super::RenderError;
use crate::vk::{Access, Context, Image, ImageDesc};

/// Linear radiance goes to RGBA16F: range to 65504 and half the bandwidth of RGBA32F.
pub const COLOR_FORMAT: vk::Format = vk::Format::R16G16B16A16_SFLOAT;
pub const DEPTH_FORMAT: vk::Format = vk::Format::D32_SFLOAT;

/// An offscreen color + depth target. `color_state` / `depth_state` say how the last recorded
/// command used each image, so the next user knows which barrier to record.
pub struct OffscreenTarget {
    pub color: Image,
    pub depth: Image,
    pub color_state: Access,
    pub depth_state: Access,
}

impl OffscreenTarget {
    pub fn new(ctx: &Context, width: u32, height: u32) -> Result<OffscreenTarget, RenderError> {
        let color = Image::new(
            ctx,
            &ImageDesc {
                name: "offscreen color",
                width,
                height,
                format: COLOR_FORMAT,
                // TRANSFER_DST: a host-style frame clears it before an object draws over it.
                usage: vk::ImageUsageFlags::COLOR_ATTACHMENT
                    | vk::ImageUsageFlags::TRANSFER_SRC
                    | vk::ImageUsageFlags::TRANSFER_DST
                    | vk::ImageUsageFlags::SAMPLED,
            },
        )?;
        let depth = Image::new(
            ctx,
            &ImageDesc {
                name: "offscreen depth",
                width,
                height,
                format: DEPTH_FORMAT,
                // TRANSFER_DST: a host-style frame may clear it before an object tests against it.
                usage: vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT
                    | vk::ImageUsageFlags::TRANSFER_DST,
            },
        )?;
        Ok(OffscreenTarget {
            color,
            depth,
            color_state: Access::Undefined,
            depth_state: Access::Undefined,
        })
    }

    pub fn extent(&self) -> vk::Extent2D {
        self.color.extent()
    }
}
