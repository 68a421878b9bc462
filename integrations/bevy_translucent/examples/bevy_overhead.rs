//! The cost of drawing through Bevy against our own host, on the scene of `bevy_scene`:
//!
//! ```text
//! cargo run --release -p bevy_translucent --example bevy_overhead [FRAMES]   # default 20 per kind
//! ```
//!
//! Each host draws one cold frame, then FRAMES frames whose light alternates between two directions
//! (warm-started solves), then FRAMES frames whose camera alternates (shading only). Printed per
//! kind, medians: our passes' GPU ms (our timestamps, same passes on both hosts; our host's
//! read-back `capture` scope left out) and the wall ms of one frame (Bevy: one `App::update`,
//! which also runs Bevy's own passes and does not wait for the GPU; ours: record, submit, wait,
//! read back). Validation off.

#[path = "bevy_scene.rs"]
#[allow(dead_code)]
mod bevy_scene;

use std::collections::BTreeMap;
use std::time::Instant;

use bevy_scene::*;
use bevy_translucent::diagnostics::gpu_ms;
use translucent::headless::HeadlessHost;
use translucent::solver::gpu::PASS_SOLVE;
use translucent::vk::{Context, ContextDesc, FrameTimings};
use translucent::FrameReport;

#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Debug)]
enum Kind {
    WarmSolve,
    ShadingOnly,
}

fn kind(r: &FrameReport) -> Option<Kind> {
    if r.passes.contains(&PASS_SOLVE) && r.warm_start {
        Some(Kind::WarmSolve)
    } else if r.passes == ["shading"] {
        Some(Kind::ShadingOnly)
    } else {
        None
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Per kind: GPU ms of our passes, wall ms per frame.
type Samples = BTreeMap<Kind, (Vec<f64>, Vec<f64>)>;

fn ours_without_capture(t: &FrameTimings) -> f64 {
    gpu_ms(t)
        - t.scopes
            .iter()
            .filter(|s| s.depth == 0 && s.name == "capture")
            .map(|s| s.duration_ms)
            .sum::<f64>()
}

fn bevy(frames: usize) -> Result<Samples, Box<dyn std::error::Error>> {
    let (mut app, _) = app(false)?;
    let mut update_ms = Vec::new();
    let mut reports: BTreeMap<u64, Kind> = BTreeMap::new();
    let mut wall = Samples::new();
    let mut record =
        |f: bevy_translucent::ObjectFrame, ms: f64, reports: &mut BTreeMap<u64, Kind>| {
            if let Some(k) = kind(&f.report) {
                reports.insert(f.report.frame, k);
                wall.entry(k).or_default().1.push(ms);
            }
        };
    step(&mut app, &mut update_ms)?; // cold
    for i in 0..frames {
        set_light(&mut app, i % 2 == 1); // starts turned: every frame changes it
        let f = step(&mut app, &mut update_ms)?;
        record(f, *update_ms.last().unwrap_or(&f64::NAN), &mut reports);
    }
    for i in 0..frames {
        set_camera(&mut app, i % 2 == 0);
        let f = step(&mut app, &mut update_ms)?;
        record(f, *update_ms.last().unwrap_or(&f64::NAN), &mut reports);
    }
    for _ in 0..4 {
        app.update(); // the last frames' timestamps
    }
    let frames = app
        .world()
        .resource::<bevy_translucent::TranslucentFrames>()
        .frames
        .clone();
    let mut gpu: BTreeMap<u64, f64> = BTreeMap::new();
    for f in frames {
        if let Some(t) = f.gpu {
            gpu.insert(t.frame, gpu_ms(&t));
        }
    }
    for (frame, ms) in gpu {
        if let Some(k) = reports.get(&frame) {
            wall.entry(*k).or_default().0.push(ms);
        }
    }
    Ok(wall)
}

fn ours(frames: usize) -> Result<Samples, Box<dyn std::error::Error>> {
    let ctx = Context::headless(&ContextDesc {
        validation: false,
        ..ContextDesc::default()
    })?;
    let mut object = our_object(&ctx, true)?;
    let mut host = HeadlessHost::new(&ctx, WIDTH, HEIGHT)?;
    let mut samples = Samples::new();
    host.render(&ctx, &mut object)?; // cold
    let mut frame = |object: &mut translucent::TranslucentObject,
                     samples: &mut Samples|
     -> Result<(), Box<dyn std::error::Error>> {
        let t = Instant::now();
        let (captured, report) = host.render(&ctx, object)?;
        let ms = t.elapsed().as_secs_f64() * 1e3;
        if let (Some(k), Some(timings)) = (kind(&report), captured.timings.as_ref()) {
            let e = samples.entry(k).or_default();
            e.0.push(ours_without_capture(timings));
            e.1.push(ms);
        }
        Ok(())
    };
    for i in 0..frames {
        object.set_lights(&our_scene(i % 2 == 1))?;
        frame(&mut object, &mut samples)?;
    }
    for i in 0..frames {
        object.set_camera(Some(our_camera(i % 2 == 0)))?;
        frame(&mut object, &mut samples)?;
    }
    drop((host, object));
    Ok(samples)
}

fn main() {
    let frames = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(20);
    let run = || -> Result<(), Box<dyn std::error::Error>> {
        let ours = ours(frames)?;
        let bevy = bevy(frames)?;
        println!("{frames} frames per kind, medians (ms)");
        println!("kind          host    our passes GPU  frame wall  samples");
        for (name, samples) in [("ours", &ours), ("bevy", &bevy)] {
            for (k, (gpu, wall)) in samples {
                println!(
                    "{:<13} {name:<7} {:>14.2}  {:>10.2}  {}/{}",
                    format!("{k:?}"),
                    median(gpu.clone()),
                    median(wall.clone()),
                    gpu.len(),
                    wall.len()
                );
            }
        }
        Ok(())
    };
    if let Err(e) = run() {
        eprintln!("bevy_overhead: {e}");
        std::process::exit(1);
    }
}
