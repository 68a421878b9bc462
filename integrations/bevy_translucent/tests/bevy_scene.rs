//! The Bevy example (`examples/bevy_scene.rs`, included for its `run`) on lavapipe with the
//! Khronos layer and synchronization validation over the whole app: no validation message and no
//! plugin error; the frame after each change (cold solve, warm solve after the Bevy light moved,
//! shading only after the Bevy camera moved), in the FrameReports and in Bevy's diagnostics; and
//! the read-back image against the same scene rendered by our own host
//! (`headless::HeadlessHost`, the path `translucent render` runs on the GPU).

#[path = "../examples/bevy_scene.rs"]
mod bevy_scene;

use bevy_scene::*;
use translucent::headless::HeadlessHost;
use translucent::solver::gpu::PASS_SOLVE;
use translucent::SkipReason;
use translucent_tests::{test_output_dir, GpuTest};

/// Largest difference of an object pixel from our own host's render, relative to the reference's
/// brightest channel: the same solve and shaders into RGBA16F on both sides, so what is left is
/// the warm-started solve of frame 2 against the reference's cold one (both stopped at the 1e-4
/// estimated error) plus fp16 rounding (4.9e-4), as in the wgpu host's test; Bevy's tonemapping
/// (`None`) and upscaling copy the texels unchanged in fp16.
const OBJECT_TOLERANCE: f32 = 2e-3;

/// Pixels the object covers in one image and not in the other (edge pixels where the two camera
/// matrices, Bevy's f32 view and ours, round a triangle edge differently).
const EDGE_PIXELS: usize = 40;

/// A pixel covered by the object (our shading writes alpha 1, both clears 0).
fn covered(p: [f32; 4]) -> bool {
    p[3] > 0.5
}

fn reference() -> translucent::vk::LinearImage {
    let gpu = GpuTest::new();
    let mut object = our_object(&gpu.ctx, false).expect("object");
    let mut host = HeadlessHost::new(&gpu.ctx, WIDTH, HEIGHT).expect("host");
    let (captured, _) = host.render(&gpu.ctx, &mut object).expect("reference frame");
    drop((host, object));
    gpu.finish();
    captured.image
}

#[test]
fn bevy_app_draws_our_object_like_our_own_host_and_reports_warm_solves_and_shading_only() {
    if std::env::var("TRANSLUCENT_DEVICE").is_err() {
        std::env::set_var("TRANSLUCENT_DEVICE", "llvmpipe");
    }
    let out = test_output_dir().join("bevy_scene.png");
    let outcome = run(&out, true).expect("the Bevy app runs");
    assert!(
        outcome.validation.is_empty(),
        "validation messages:\n{}",
        outcome.validation.join("\n")
    );
    assert!(
        outcome.errors.is_empty(),
        "plugin errors: {:?}",
        outcome.errors
    );

    // The frame after each change.
    let s: Vec<_> = outcome.steps.iter().map(|f| &f.report).collect();
    assert!(
        s[0].passes.contains(&PASS_SOLVE) && !s[0].warm_start,
        "{:?}",
        s[0]
    );
    assert!(
        s[1].passes.contains(&PASS_SOLVE) && s[1].warm_start,
        "{:?}",
        s[1]
    );
    for r in &s[2..] {
        assert_eq!(r.passes, ["shading"], "{r:?}");
        assert_eq!(r.skipped.get(PASS_SOLVE), Some(&SkipReason::CameraOnly));
    }
    // The same in Bevy's diagnostics: one measurement per drawn frame, the four steps among them.
    let history = |name: &str| {
        outcome
            .diagnostics
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.clone())
            .unwrap_or_default()
    };
    let (solve, warm, shading) = (
        history("translucent/solve"),
        history("translucent/warm_start"),
        history("translucent/shading_only"),
    );
    assert_eq!(
        solve.len(),
        outcome.frames.len(),
        "one measurement per drawn frame (none dropped from the history)"
    );
    assert!(solve.len() >= 4, "{solve:?}");
    assert_eq!(solve.iter().sum::<f64>(), 2.0, "two solves: {solve:?}");
    assert_eq!(warm.iter().sum::<f64>(), 1.0, "one warm start: {warm:?}");
    assert_eq!(
        shading.iter().sum::<f64>(),
        (solve.len() - 2) as f64,
        "every other frame shading only: {shading:?}"
    );
    // Our GPU timestamps arrive for the drawn frames.
    assert!(
        outcome.frames.iter().filter(|f| f.gpu.is_some()).count() >= 2,
        "GPU timings of completed frames"
    );

    let reference = reference();
    reference
        .write_png(
            &test_output_dir().join("bevy_scene-reference.png"),
            EXPOSURE,
        )
        .expect("write");
    let peak = reference
        .pixels
        .iter()
        .flat_map(|p| p[..3].iter().copied())
        .fold(0.0f32, f32::max);
    assert!(peak > 0.0, "the reference is black");
    let (mut compared, mut edges, mut worst) = (0, 0, 0.0f32);
    for y in 0..HEIGHT {
        for x in 0..WIDTH {
            let r = reference.pixel(x, y);
            let a = outcome.image.pixel(x, y);
            assert!(a.iter().all(|v| v.is_finite()), "({x}, {y}): {a:?}");
            if covered(r) != covered(a) {
                edges += 1;
                continue;
            }
            if !covered(r) {
                assert_eq!(a, [0.0; 4], "({x}, {y}): Bevy's clear colour");
                continue;
            }
            worst = worst.max((0..3).map(|c| (a[c] - r[c]).abs()).fold(0.0, f32::max) / peak);
            compared += 1;
        }
    }
    println!(
        "{compared} object pixels compared (worst {worst:.2e} of the peak), {edges} edge pixels"
    );
    assert!(
        edges <= EDGE_PIXELS,
        "{edges} pixels covered in one image only"
    );
    assert!(
        worst <= OBJECT_TOLERANCE,
        "object pixels differ by {worst} of the peak (tolerance {OBJECT_TOLERANCE})"
    );
    assert!(compared > 1000, "only {compared} object pixels");
}
