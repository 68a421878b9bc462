//! The viewer's own images and text grid: the HDR target, the overlay's cells, raw barriers on
//! the swapchain images.

use super::*;

/// Text pixels per font pixel: 2 on large windows.
pub(super) fn text_scale(extent: vk::Extent2D) -> u32 {
    if extent.width >= 1600 {
        2
    } else {
        1
    }
}

/// Font pixels of a text cell (the 8x8 glyph and two rows of line spacing) and the margin in
/// screen pixels per text scale: `viewer/present.frag`'s `CELL` and `TEXT_MARGIN`.
pub(super) const TEXT_CELL: [u32; 2] = [8, 10];
pub(super) const TEXT_MARGIN: u32 = 4;

/// Columns and rows of text cells that fit `extent`.
pub(super) fn text_grid(extent: vk::Extent2D) -> (usize, usize) {
    let s = text_scale(extent);
    let fit = |pixels: u32, cell: u32| (pixels.saturating_sub(TEXT_MARGIN * s) / (cell * s)).max(1);
    (
        fit(extent.width, TEXT_CELL[0]) as usize,
        fit(extent.height, TEXT_CELL[1]) as usize,
    )
}

pub(super) fn hdr_image(ctx: &Context, extent: vk::Extent2D) -> anyhow::Result<Image> {
    Ok(Image::new(
        ctx,
        &ImageDesc {
            name: "viewer hdr",
            width: extent.width,
            height: extent.height,
            format: COLOR_FORMAT,
            // Cleared each frame, drawn by the object, sampled by the present pass, copied out
            // for screenshots.
            usage: vk::ImageUsageFlags::COLOR_ATTACHMENT
                | vk::ImageUsageFlags::SAMPLED
                | vk::ImageUsageFlags::TRANSFER_DST
                | vk::ImageUsageFlags::TRANSFER_SRC,
        },
    )?)
}

pub(super) fn raw_barrier(
    image: vk::Image,
    src: (vk::PipelineStageFlags2, vk::AccessFlags2),
    dst: (vk::PipelineStageFlags2, vk::AccessFlags2),
    old: vk::ImageLayout,
    new: vk::ImageLayout,
) -> vk::ImageMemoryBarrier2<'static> {
    vk::ImageMemoryBarrier2::default()
        .src_stage_mask(src.0)
        .src_access_mask(src.1)
        .dst_stage_mask(dst.0)
        .dst_access_mask(dst.1)
        .old_layout(old)
        .new_layout(new)
        .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .image(image)
        .subresource_range(
            vk::ImageSubresourceRange::default()
                .aspect_mask(vk::ImageAspectFlags::COLOR)
                .level_count(1)
                .layer_count(1),
        )
}
