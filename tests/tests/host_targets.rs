//! The host boundary of `TranslucentObject::record`: bad targets and frames are typed errors that
//! record nothing; a host that places the boundary barriers itself from `declare()`
//! (`host_barriers: true`) and gives its own depth gets the same image as the default path, with
//! validation and synchronization validation silent.

use std::sync::Arc;

use ash::vk;
use glam::DVec3;
use translucent::headless::HeadlessHost;
use translucent::material::{Material, MaterialField};
use translucent::mesh::shapes::Shape;
use translucent::object::{HostResource, RecordCtx, TargetImage, Targets};
use translucent::quadgraph::BakeParams;
use translucent::render::{OffscreenTarget, COLOR_FORMAT};
use translucent::scene::{Environment, Light, Scene};
use translucent::vk::ImageState;
use translucent::vk::{barrier, Access, ImageReadback};
use translucent::{Error, ObjectParams, QuadGraph, TranslucentObject};
use translucent_tests::GpuTest;

const SIZE: u32 = 24;

fn setup(ctx: &translucent::vk::Context) -> TranslucentObject {
    let ball = Shape::Sphere { radius: 10.0 };
    let params = BakeParams {
        resolution: 12,
        levels: 1,
        ..Default::default()
    };
    let graph = QuadGraph::bake(&ball.triangulate(32), &ball, &params, &mut |_| {})
        .expect("bake")
        .0;
    let scene = Scene {
        lights: vec![Light::Directional {
            direction: DVec3::new(0.3, -1.0, -0.5).normalize(),
            irradiance: [2.0; 3],
        }],
        environment: Environment::None,
    };
    let field = MaterialField::Homogeneous(Material::preset("marble").expect("preset"));
    TranslucentObject::new(
        ctx,
        Arc::new(graph),
        &field,
        &scene,
        &ObjectParams::default(),
    )
    .expect("object")
}

fn color_target(target: &OffscreenTarget) -> TargetImage {
    TargetImage {
        image: target.color.raw,
        view: target.color.view,
        format: target.color.format,
        extent: target.extent(),
        before: Access::ColorAttachmentWrite.into(),
        after: Access::TransferSrc.into(),
    }
}

#[test]
fn bad_targets_and_frames_are_typed_errors() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let mut object = setup(ctx);
    let target = OffscreenTarget::new(ctx, SIZE, SIZE).expect("target");
    let good = color_target(&target);
    let wrong_format = TargetImage {
        format: vk::Format::R8G8B8A8_UNORM,
        ..good
    };
    let zero = TargetImage {
        extent: vk::Extent2D {
            width: 0,
            height: SIZE,
        },
        ..good
    };
    let bad_depth = TargetImage {
        format: vk::Format::D32_SFLOAT,
        extent: vk::Extent2D {
            width: SIZE,
            height: SIZE + 1,
        },
        image: target.depth.raw,
        view: target.depth.view,
        ..good
    };
    let undefined_after = TargetImage {
        after: Access::Undefined.into(),
        ..good
    };
    let cases: [(Targets, u64, u64, &str); 5] = [
        (targets(wrong_format, None), 2, 1, "format"),
        (targets(zero, None), 2, 1, "no pixels"),
        (targets(good, Some(bad_depth)), 2, 1, "25"),
        (targets(undefined_after, None), 2, 1, "UNDEFINED"),
        (targets(good, None), 2, 2, "cannot be complete"),
    ];
    ctx.execute("bad targets", |cb| {
        for (t, frame, completed, needle) in &cases {
            // SAFETY: `cb` is recording; a refused record records nothing.
            let r = unsafe {
                object.record(
                    &mut RecordCtx {
                        ctx,
                        cb,
                        frame: *frame,
                        completed_frame: *completed,
                        profiler: None,
                    },
                    t,
                )
            };
            match r {
                Err(Error::Render(e)) => {
                    assert!(e.to_string().contains(needle), "{needle}: {e}")
                }
                other => panic!("{needle}: {other:?}"),
            }
        }
        Ok(())
    })
    .expect("submit");
    drop((object, target));
    gpu.finish();
}

fn targets(color: TargetImage, depth: Option<TargetImage>) -> Targets {
    Targets {
        color,
        depth,
        host_barriers: false,
    }
}

#[test]
fn host_placed_barriers_from_declare_give_the_same_image() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let mut object = setup(ctx);
    let uses = object.declare();
    let color_use = uses
        .iter()
        .find(|u| u.resource == HostResource::Color)
        .expect("colour use");
    let depth_use = uses
        .iter()
        .find(|u| u.resource == HostResource::Depth)
        .expect("depth use");
    assert_eq!(color_use.layout, vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL);
    assert_eq!(depth_use.layout, vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL);
    assert!(color_use.read && color_use.write && depth_use.write);

    // The reference: the default path (we record the boundary barriers, our own depth).
    let mut host = HeadlessHost::new(ctx, SIZE, SIZE).expect("host");
    let (reference, _) = host.render(ctx, &mut object).expect("reference");
    drop(host);

    // A host graph: clears colour and depth itself, places the declared barriers, records us.
    let target = OffscreenTarget::new(ctx, SIZE, SIZE).expect("target");
    assert_eq!(target.color.format, COLOR_FORMAT);
    let readback = ImageReadback::new(ctx, &target.color).expect("readback");
    let declared = |u: &translucent::object::ResourceUse| ImageState {
        stage: u.stage,
        access: u.access,
        layout: u.layout,
    };
    let mut result = None;
    ctx.execute("host graph frame", |cb| {
        let (frame, completed) = ctx.frames();
        // SAFETY: `cb` is recording; everything outlives the waited submission.
        unsafe {
            let raw = ctx.raw();
            // why: the clears need TRANSFER_DST layout (first use).
            barrier::record(
                ctx,
                cb,
                &[],
                &[
                    barrier::image_barrier(&target.color, Access::Undefined, Access::TransferDst),
                    barrier::image_barrier(&target.depth, Access::Undefined, Access::TransferDst),
                ],
            );
            let color_range = vk::ImageSubresourceRange {
                aspect_mask: vk::ImageAspectFlags::COLOR,
                base_mip_level: 0,
                level_count: 1,
                base_array_layer: 0,
                layer_count: 1,
            };
            raw.cmd_clear_color_image(
                cb,
                target.color.raw,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &vk::ClearColorValue { float32: [0.0; 4] },
                &[color_range],
            );
            let depth_range = vk::ImageSubresourceRange {
                aspect_mask: vk::ImageAspectFlags::DEPTH,
                ..color_range
            };
            raw.cmd_clear_depth_stencil_image(
                cb,
                target.depth.raw,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &vk::ClearDepthStencilValue {
                    depth: 1.0,
                    stencil: 0,
                },
                &[depth_range],
            );
            let transfer: ImageState = Access::TransferDst.into();
            let to = |img: &translucent::vk::Image, d: ImageState, aspect| {
                vk::ImageMemoryBarrier2::default()
                    .src_stage_mask(transfer.stage)
                    .src_access_mask(transfer.access)
                    .dst_stage_mask(d.stage)
                    .dst_access_mask(d.access)
                    .old_layout(transfer.layout)
                    .new_layout(d.layout)
                    .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                    .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                    .image(img.raw)
                    .subresource_range(vk::ImageSubresourceRange {
                        aspect_mask: aspect,
                        ..color_range
                    })
            };
            // why: the host graph's boundary barriers, from declare(): our pass loads and writes
            // the cleared colour and depth (RAW/WAW) in attachment layouts.
            barrier::record(
                ctx,
                cb,
                &[],
                &[
                    to(
                        &target.color,
                        declared(color_use),
                        vk::ImageAspectFlags::COLOR,
                    ),
                    to(
                        &target.depth,
                        declared(depth_use),
                        vk::ImageAspectFlags::DEPTH,
                    ),
                ],
            );
            let t = Targets {
                color: color_target(&target),
                depth: Some(TargetImage {
                    image: target.depth.raw,
                    view: target.depth.view,
                    format: target.depth.format,
                    extent: target.extent(),
                    before: Access::Undefined.into(), // ignored: host_barriers
                    after: Access::Undefined.into(),
                }),
                host_barriers: true,
            };
            result = Some(object.record(
                &mut RecordCtx {
                    ctx,
                    cb,
                    frame,
                    completed_frame: completed,
                    profiler: None,
                },
                &t,
            ));
            // The host's exit barrier: our colour writes to its read-back (RAW).
            readback.record(ctx, cb, &target.color, Access::ColorAttachmentWrite);
        }
        Ok(())
    })
    .expect("frame");
    let report = result.expect("recorded").expect("record");
    assert_eq!(
        report.passes,
        ["shading"],
        "nothing changed since the reference frame"
    );
    let image = readback.read().expect("read");
    let peak = reference
        .image
        .pixels
        .iter()
        .flat_map(|p| p[..3].to_vec())
        .fold(0.0f32, f32::max);
    assert!(peak > 0.0);
    // Same solve, same draw, same clear values: equal up to nothing (1e-6 of the peak).
    for (a, b) in image.pixels.iter().zip(&reference.image.pixels) {
        for c in 0..3 {
            assert!((a[c] - b[c]).abs() <= 1e-6 * peak, "{a:?} vs {b:?}");
        }
    }
    drop((object, target, readback));
    gpu.finish();
}

/// A target of another size: our own depth buffer is re-made and the old one released only once
/// the frame that used it completed (validation would report a destroyed image in use); nothing
/// leaks (`finish` checks the device is gone).
#[test]
fn a_resized_target_remakes_our_depth_and_releases_the_old_one_after_its_frame() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let mut object = setup(ctx);
    let mut small = HeadlessHost::new(ctx, SIZE, SIZE).expect("host");
    let mut large = HeadlessHost::new(ctx, 2 * SIZE, SIZE).expect("host");
    let (a, _) = small.render(ctx, &mut object).expect("small");
    let (b, report) = large.render(ctx, &mut object).expect("large");
    assert_eq!((a.image.width, b.image.width), (SIZE, 2 * SIZE));
    assert_eq!(report.passes, ["shading"]);
    assert!(b.image.pixels.iter().any(|p| p[0] > 0.0), "object drawn");
    let (c, _) = small.render(ctx, &mut object).expect("small again");
    assert_eq!(c.image.pixels, a.image.pixels, "same frame, same image");
    ctx.frame_completed(ctx.frames().0);
    assert_eq!(ctx.pending_releases(), 0);
    drop((object, small, large));
    gpu.finish();
}
