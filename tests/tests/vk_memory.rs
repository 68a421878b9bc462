//! Memory: nothing leaks (allocator empty and the validation layer silent at device destruction)
//! and nothing is freed early (a resource dropped while its frame is in flight lives until that
//! frame is reported complete).

use ash::vk;
use translucent::vk::{Buffer, BufferDesc, Image, ImageDesc, MemoryUse};
use translucent_tests::GpuTest;

fn readback_buffer(ctx: &translucent::vk::Context, name: &'static str) -> Buffer {
    Buffer::new(
        ctx,
        &BufferDesc {
            name,
            size: 4096,
            usage: vk::BufferUsageFlags::TRANSFER_DST,
            memory: MemoryUse::Readback,
        },
    )
    .expect("buffer")
}

#[test]
fn dropped_resources_are_released_and_nothing_leaks() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    assert_eq!(ctx.live_allocations(), 0);
    let image = Image::new(
        ctx,
        &ImageDesc {
            name: "leak test image",
            width: 64,
            height: 32,
            format: vk::Format::R16G16B16A16_SFLOAT,
            usage: vk::ImageUsageFlags::STORAGE,
        },
    )
    .expect("image");
    let buffers: Vec<Buffer> = (0..5)
        .map(|_| readback_buffer(ctx, "leak test buffer"))
        .collect();
    assert_eq!(ctx.live_allocations(), 6);
    drop(image);
    drop(buffers);
    // No frame in flight: released at once.
    assert_eq!(ctx.pending_releases(), 0);
    assert_eq!(ctx.live_allocations(), 0);
    // The layer reports any Vulkan object still alive at vkDestroyDevice as an error.
    gpu.finish();
}

#[test]
fn a_buffer_dropped_while_its_frame_is_in_flight_lives_until_the_frame_completes() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let buffer = readback_buffer(ctx, "in flight");
    let raw = buffer.raw;
    let submission = ctx
        .submit("fill", |cb| {
            // SAFETY: `cb` is recording; the buffer's release waits for this frame.
            unsafe {
                ctx.raw()
                    .cmd_fill_buffer(cb, raw, 0, vk::WHOLE_SIZE, 0x3f80_0000)
            };
            Ok(())
        })
        .expect("submit");
    let frame = submission.frame();
    drop(buffer);
    assert_eq!(
        ctx.pending_releases(),
        1,
        "destroyed while the GPU may still write it"
    );
    assert_eq!(ctx.live_allocations(), 1);
    assert_eq!(
        ctx.frame_completed(frame - 1),
        0,
        "an older frame completing must not release it"
    );
    assert_eq!(ctx.live_allocations(), 1);
    submission.wait().expect("wait"); // reports `frame` complete
    assert_eq!(ctx.pending_releases(), 0);
    assert_eq!(ctx.live_allocations(), 0);
    gpu.finish();
}

#[test]
fn host_frame_numbers_drive_release() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    ctx.begin_frame(10);
    let buffer = readback_buffer(ctx, "host frame 10");
    drop(buffer);
    ctx.begin_frame(11);
    let later = readback_buffer(ctx, "host frame 11");
    drop(later);
    assert_eq!(ctx.pending_releases(), 2);
    assert_eq!(ctx.frame_completed(9), 0);
    assert_eq!(ctx.frame_completed(10), 1);
    assert_eq!(ctx.live_allocations(), 1);
    assert_eq!(ctx.frame_completed(11), 1);
    assert_eq!(ctx.live_allocations(), 0);
    gpu.finish();
}

#[test]
fn dropping_the_context_with_pending_releases_leaks_nothing() {
    let gpu = GpuTest::new();
    gpu.ctx.begin_frame(5);
    drop(readback_buffer(&gpu.ctx, "pending at shutdown"));
    assert_eq!(gpu.ctx.pending_releases(), 1);
    gpu.finish(); // the device drains the queue; the layer would report a leaked buffer or memory
}

#[test]
fn bad_sizes_are_typed_errors() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let zero = Buffer::new(
        ctx,
        &BufferDesc {
            name: "zero",
            size: 0,
            usage: vk::BufferUsageFlags::TRANSFER_DST,
            memory: MemoryUse::Upload,
        },
    );
    assert!(zero.is_err());
    let huge = Image::new(
        ctx,
        &ImageDesc {
            name: "huge",
            width: 1 << 20,
            height: 1,
            format: vk::Format::R8G8B8A8_UNORM,
            usage: vk::ImageUsageFlags::SAMPLED,
        },
    );
    assert!(huge.err().is_some_and(|e| e.to_string().contains("huge")));
    let storage_only = Image::new(
        ctx,
        &ImageDesc {
            name: "no transfer",
            width: 4,
            height: 4,
            format: vk::Format::R16G16B16A16_SFLOAT,
            usage: vk::ImageUsageFlags::STORAGE,
        },
    )
    .expect("image");
    let capture = translucent::vk::ImageReadback::new(ctx, &storage_only);
    assert!(capture
        .err()
        .is_some_and(|e| e.to_string().contains("TRANSFER_SRC")));
    drop(storage_only);
    let mut small = readback_buffer(ctx, "small");
    assert!(small.write_bytes(4090, &[0; 8]).is_err());
    drop(small);
    gpu.finish();
}
