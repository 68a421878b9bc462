//! The example host (`engine/examples/host_graph.rs`, included here for its `run`): its own
//! instance and device with validation and synchronization validation, a render graph of its own
//! (background, our object, tone-map post pass) with two frames in flight and a light moving every
//! frame. Passes when the layer reported nothing, every frame solved (after the first, warm-started:
//! every level from its last solution), and the written image holds more than the background.

#[path = "../../engine/examples/host_graph.rs"]
mod host_graph;

use translucent_tests::test_output_dir;

#[test]
fn host_graph_example_runs_clean_under_validation_and_draws_the_object() {
    if std::env::var("TRANSLUCENT_DEVICE").is_err() {
        // The example picks by name like the tests do.
        std::env::set_var("TRANSLUCENT_DEVICE", "llvmpipe");
    }
    let out = test_output_dir().join("host_graph.png");
    let _ = std::fs::remove_file(&out);
    let outcome = host_graph::run(&out, true).expect("host graph");
    assert_eq!(outcome.messages, 0, "validation messages (printed above)");
    // The torus covers about a sixth of the 160x120 frame (less the pillar in front of it).
    assert!(
        outcome.object_pixels > 160 * 120 / 20,
        "only {} pixels differ from the background",
        outcome.object_pixels
    );
    let frames: Vec<u64> = outcome.iterations.iter().map(|(f, _)| *f).collect();
    assert_eq!(frames, (1..=6).collect::<Vec<_>>(), "one solve per frame");
    for (frame, its) in &outcome.iterations {
        // The warm start iterates every level (the coarse one gives the finer its correction).
        assert!(its.iter().all(|&n| n > 0), "frame {frame}: {its:?}");
    }
    let png = image::open(&out).expect("the PNG was written").to_rgb8();
    assert_eq!(png.dimensions(), (160, 120));
}
