//! GPU profiler: nested named scopes on real dispatches, results read without waiting (when the
//! host reports a frame complete, or when its slot comes round), Chrome trace export.

use translucent::render::LaplaceJacobiPass;
use translucent::vk::{FrameTimings, GpuProfiler};
use translucent_tests::GpuTest;

fn record_frame(gpu: &GpuTest, profiler: &mut GpuProfiler, pass: &mut LaplaceJacobiPass) -> u64 {
    let ctx = &gpu.ctx;
    let submission = ctx
        .submit("profiled frame", |cb| {
            let (current, _) = ctx.frames();
            // SAFETY: `cb` is recording; the pass and profiler outlive the waited submission.
            unsafe {
                profiler.begin_frame(cb, current);
                profiler.begin_scope(cb, "frame");
                pass.record(ctx, cb, 50, Some(profiler));
                profiler.end_scope(cb);
            }
            Ok(())
        })
        .expect("submit");
    let frame = submission.frame();
    submission.wait().expect("wait");
    frame
}

#[test]
fn nested_scopes_of_a_real_frame_are_timed_and_exported() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let mut profiler = GpuProfiler::new(ctx, "test profiler", 8).expect("profiler");
    assert!(profiler.enabled(), "lavapipe supports timestamps");
    let mut pass = LaplaceJacobiPass::new(ctx, 64, 64).expect("pass");
    pass.upload(ctx, &vec![[0.5; 4]; 64 * 64]).expect("upload");

    let frame = record_frame(&gpu, &mut profiler, &mut pass);
    assert!(
        profiler.latest().is_none(),
        "nothing is read before the host reports the frame complete"
    );
    profiler.frame_completed(frame);
    let timings = profiler.latest().expect("results after completion").clone();
    assert_eq!(timings.frame, frame);
    let names: Vec<_> = timings
        .scopes
        .iter()
        .map(|s| (s.name.as_str(), s.depth))
        .collect();
    assert_eq!(names, [("frame", 0), ("jacobi", 1)]);
    let (outer, inner) = (&timings.scopes[0], &timings.scopes[1]);
    for s in &timings.scopes {
        assert!(
            s.duration_ms.is_finite() && s.duration_ms >= 0.0 && s.start_ms >= 0.0,
            "{s:?}"
        );
    }
    assert!(
        inner.duration_ms > 0.0,
        "50 dispatches take time: {inner:?}"
    );
    assert!(
        inner.start_ms >= outer.start_ms
            && inner.start_ms + inner.duration_ms <= outer.start_ms + outer.duration_ms + 1e-9
    );
    assert_eq!(timings.passes().len(), 2);

    let trace = FrameTimings::chrome_trace(&[timings]);
    let events = trace["traceEvents"].as_array().expect("events");
    assert_eq!(events.len(), 2);
    assert_eq!(events[1]["name"], "jacobi");
    assert_eq!(events[1]["ph"], "X");
    drop(pass);
    drop(profiler);
    gpu.finish();
}

#[test]
fn a_frame_is_read_when_its_slot_comes_round_without_host_reports() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    // frames_in_flight = 2: frame f's slot is reused by frame f + 2.
    let mut profiler = GpuProfiler::new(ctx, "slot profiler", 4).expect("profiler");
    let mut pass = LaplaceJacobiPass::new(ctx, 16, 16).expect("pass");
    pass.upload(ctx, &vec![[0.5; 4]; 16 * 16]).expect("upload");
    let frames: Vec<u64> = (0..3)
        .map(|_| record_frame(&gpu, &mut profiler, &mut pass))
        .collect();
    let read = profiler.take_results();
    assert_eq!(
        read.iter().map(|t| t.frame).collect::<Vec<_>>(),
        [frames[0]],
        "frame 0 is read when frame 2 reuses its slot"
    );
    drop(pass);
    drop(profiler);
    gpu.finish();
}

#[test]
fn a_disabled_profiler_records_nothing_and_reports_nothing() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    // The same state `GpuProfiler::new` falls back to where timestampValidBits == 0 or
    // timestampComputeAndGraphics is false.
    let mut profiler = GpuProfiler::disabled(ctx, "off").expect("profiler");
    assert!(!profiler.enabled());
    let mut pass = LaplaceJacobiPass::new(ctx, 16, 16).expect("pass");
    pass.upload(ctx, &vec![[0.5; 4]; 16 * 16]).expect("upload");
    let frame = record_frame(&gpu, &mut profiler, &mut pass);
    profiler.frame_completed(frame);
    assert!(profiler.latest().is_none());
    assert!(profiler.take_results().is_empty());
    drop(pass);
    drop(profiler);
    gpu.finish();
}
