//! The wgpu host (`examples/wgpu_host.rs`, included for its `run`) on lavapipe with the Khronos
//! layer and synchronization validation: no validation message and no wgpu error; the frames'
//! reports (cold solve, warm solve after the light moved, shading only after camera moves); and its
//! last frame against the same scene rendered by our own host (`headless::HeadlessHost`, the path
//! `translucent render` runs on the GPU), pixel by pixel where the object is visible, where the
//! host's pillar hides it, and where the host's overlay is blended over it.

#[path = "../examples/wgpu_host.rs"]
mod wgpu_host;

use std::sync::Arc;

use translucent::headless::HeadlessHost;
use translucent::render::{COLOR_FORMAT, DEPTH_FORMAT};
use translucent::solver::gpu::PASS_SOLVE;
use translucent::{SkipReason, TranslucentObject};
use translucent_tests::{test_output_dir, GpuTest};
use wgpu_host::*;

/// Largest difference of an object pixel from our own host's render, relative to the reference's
/// brightest channel: both draw the same solve with the same shaders into RGBA16F, so what is
/// left is the warm-started solve of frame 2 against the reference's cold one (both stopped at
/// `TOLERANCE` on the estimated error; measured 1.7e-4) plus fp16 rounding (4.9e-4 relative).
const OBJECT_TOLERANCE: f32 = 2e-3;

/// A pixel covered by the object in the reference (our shading writes alpha 1, the clear 0).
fn covered(p: [f32; 4]) -> bool {
    p[3] > 0.5
}

fn near(a: [f32; 3], b: [f32; 3], tolerance: f32) -> bool {
    (0..3).all(|c| (a[c] - b[c]).abs() <= tolerance)
}

#[test]
fn wgpu_host_draws_our_object_between_its_passes_like_our_own_host() {
    if std::env::var("TRANSLUCENT_DEVICE").is_err() {
        std::env::set_var("TRANSLUCENT_DEVICE", "llvmpipe");
    }
    let out = test_output_dir().join("wgpu_host.png");
    let outcome = run(&out, true).expect("the wgpu host runs");
    assert!(
        outcome.validation.is_empty(),
        "validation messages:\n{}",
        outcome.validation.join("\n")
    );
    assert!(
        outcome.wgpu_errors.is_empty(),
        "wgpu errors:\n{}",
        outcome.wgpu_errors.join("\n")
    );

    // The reports: cold, warm after the light moved, then shading only for camera moves.
    let r = &outcome.reports;
    assert_eq!(r.len(), 4);
    assert!(
        r[0].passes.contains(&PASS_SOLVE) && !r[0].warm_start,
        "{:?}",
        r[0]
    );
    assert!(
        r[1].passes.contains(&PASS_SOLVE) && r[1].warm_start,
        "{:?}",
        r[1]
    );
    for report in &r[2..] {
        assert_eq!(report.passes, ["shading"], "{report:?}");
        assert_eq!(
            report.skipped.get(PASS_SOLVE),
            Some(&SkipReason::CameraOnly)
        );
    }
    let solved: Vec<u64> = outcome.solves.iter().map(|s| s.frame).collect();
    assert_eq!(solved, [1, 2], "the two solves completed and were reported");
    let shading_ms = outcome
        .timings
        .iter()
        .filter_map(|(_, passes)| passes.get("shading"))
        .count();
    assert_eq!(shading_ms, 4, "GPU timestamps of every frame's shading");

    // The reference: the same scene through our own host, cold-solved.
    let gpu = GpuTest::new();
    let mut object = TranslucentObject::new(
        &gpu.ctx,
        Arc::new(graph().expect("bake")),
        &material(),
        &scene(false),
        &object_params(COLOR_FORMAT, DEPTH_FORMAT),
    )
    .expect("object");
    object.set_camera(Some(camera(false))).expect("camera");
    let mut host = HeadlessHost::new(&gpu.ctx, WIDTH, HEIGHT).expect("host");
    let (reference, _) = host.render(&gpu.ctx, &mut object).expect("reference frame");
    let reference = reference.image;
    drop((host, object));
    gpu.finish();
    reference
        .write_png(&test_output_dir().join("wgpu_host-reference.png"), EXPOSURE)
        .expect("write");

    let peak = reference
        .pixels
        .iter()
        .flat_map(|p| p[..3].iter().copied())
        .fold(0.0f32, f32::max);
    assert!(peak > 0.0, "the reference is black");
    let (mut compared, mut hidden, mut overlaid, mut worst) = (0, 0, 0, 0.0f32);
    for y in 0..HEIGHT {
        for x in 0..WIDTH {
            let r = reference.pixel(x, y);
            let a = outcome.image.pixel(x, y);
            assert!(a.iter().all(|v| v.is_finite()), "({x}, {y}): {a:?}");
            if !covered(r) {
                continue;
            }
            let (r3, a3) = ([r[0], r[1], r[2]], [a[0], a[1], a[2]]);
            if OVERLAY_ROWS.contains(&y) {
                // The overlay pass came after ours: white blended over the object.
                let expected = r3.map(|v| v * (1.0 - OVERLAY_ALPHA) + OVERLAY_ALPHA);
                // Where the host's pillar is nearer, the overlay is blended over the pillar.
                let over_pillar = PILLAR.map(|v| v * (1.0 - OVERLAY_ALPHA) + OVERLAY_ALPHA);
                if near(a3, over_pillar, 1e-3) {
                    hidden += 1;
                    continue;
                }
                assert!(
                    near(a3, expected, OBJECT_TOLERANCE * peak + 2e-3),
                    "overlay at ({x}, {y}): {a3:?}, expected {expected:?}"
                );
                overlaid += 1;
            } else if near(a3, PILLAR, 1e-3) {
                hidden += 1; // the host's pillar is nearer: our depth test against its depth
            } else {
                worst = worst.max((0..3).map(|c| (a3[c] - r3[c]).abs()).fold(0.0, f32::max) / peak);
                compared += 1;
            }
        }
    }
    println!(
        "{compared} object pixels compared (worst {worst:.2e} of the peak), {hidden} hidden by the pillar, {overlaid} under the overlay"
    );
    assert!(
        worst <= OBJECT_TOLERANCE,
        "object pixels differ by {worst} of the peak (tolerance {OBJECT_TOLERANCE})"
    );
    // The torus covers about a tenth of the frame; the pillar and the band cross it.
    assert!(compared > 1000, "only {compared} object pixels");
    assert!(hidden > 50, "the pillar hid only {hidden} object pixels");
    assert!(
        overlaid > 100,
        "the overlay covered only {overlaid} object pixels"
    );
}
