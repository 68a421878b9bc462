//! Soak (issue 6 item 4): N frames in which every frame changes the light, the material and the
//! shape of a sphere: a `TranslucentObject` recorded by the headless host
//! (`HeadlessHost::render`, the frame the object ships: edits, shadow maps from its own display
//! mesh, gather, warm-started solve, exitance, shading), the same schedule as `tests/tests/soak.rs`
//! (which runs 100 frames in CI). Per frame: `set_lights` (a directional light turning
//! 0.2 rad/frame, brightness 1 +- 0.5), `set_material` (drifting marble coefficients; every 4th
//! frame a heterogeneous split with eta 1.4), `deform` (twist of 0.03 sin(0.07 i) rad/mm; every
//! 10th frame the identity, every 10th an affine squash). Every `--check-every` frames and at the
//! end: J+ of surface nodes and display vertices and the image read back and checked finite,
//! validation messages counted. Prints the allocator's (allocations, bytes, block bytes) at frame
//! 10 and at the end, wall time and the median GPU ms of the frame's passes, and exits non-zero on
//! a NaN, a message or allocator growth.
//!
//! ```text
//! cargo run --release -p translucent-benches --bin soak -- [--frames 10000] [--resolution 10]
//!     [--segments 24] [--check-every 100] [--no-validation]
//! ```

use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::Instant;

use translucent::headless::HeadlessHost;
use translucent::mesh::shapes::Shape;
use translucent::quadgraph::BakeParams;
use translucent::solver::gpu::{GpuDiffusion, GpuSolveParams};
use translucent::vk::{Context, ContextDesc};
use translucent::{ObjectParams, QuadGraph, TranslucentObject};
use translucent_benches::soak::{deformation_at, material_at, scene_at, SCHEDULE_PERIOD};

type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

fn arg<T: std::str::FromStr>(args: &[String], name: &str, default: T) -> Result<T> {
    match args.iter().position(|a| a == name) {
        Some(k) => args
            .get(k + 1)
            .and_then(|v| v.parse().ok())
            .ok_or_else(|| format!("{name} needs a value").into()),
        None => Ok(default),
    }
}

/// The object's diffusion solve (its read-backs).
fn solve(object: &TranslucentObject) -> Result<&GpuDiffusion> {
    Ok(object
        .quadgraph()
        .ok_or("the object's method is not the QuadGraph")?
        .solve())
}

fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let frames: usize = arg(&args, "--frames", 10_000)?;
    let resolution: u32 = arg(&args, "--resolution", 10)?;
    // Segments of the triangulated display sphere (its vertex count: the mesh copies).
    let segments: u32 = arg(&args, "--segments", 24)?;
    let check_every: usize = arg(&args, "--check-every", 100)?.max(1);
    let validation = !args.iter().any(|a| a == "--no-validation");
    let ctx = Context::headless(&ContextDesc {
        validation,
        echo_validation: true,
        ..ContextDesc::default()
    })?;
    let log = ctx.validation_log();
    let shape = Shape::Sphere { radius: 10.0 };
    let bake = BakeParams {
        resolution,
        levels: 2,
        ..Default::default()
    };
    let graph =
        Arc::new(QuadGraph::bake(&shape.triangulate(segments), &shape, &bake, &mut |_| {})?.0);
    let params = ObjectParams {
        solve: GpuSolveParams {
            iterations: vec![48],
            tolerance: 1e-4,
            ..Default::default()
        },
        ..ObjectParams::default()
    };
    let field = material_at(0)?;
    let scene = scene_at(0);
    let n = graph.surface.positions.len();
    let mut object = TranslucentObject::new(&ctx, graph.clone(), &field, &scene, &params)?;
    let mut host = HeadlessHost::new(&ctx, 48, 48)?;
    let nodes: usize = (0..graph.levels.len())
        .map(|h| solve(&object).map(|s| s.node_count(h)))
        .sum::<Result<usize>>()?;
    println!(
        "soak: {frames} frames, sphere r = 10 mm, resolution {resolution}, {} levels, {nodes} nodes, {n} display vertices, validation {validation}",
        graph.levels.len()
    );
    let texels: u64 = graph
        .levels
        .iter()
        .map(|l| u64::from(l.packing.width) * u64::from(l.packing.height))
        .sum();
    let (b0, per_node0) = solve(&object)?.bytes();
    println!(
        "GPU bytes at start (homogeneous, rest pose): {b0} = {per_node0:.1} B/node ({texels} texels for {nodes} nodes)"
    );
    let start = Instant::now();
    let mut at_frame_10 = ctx.allocator_usage();
    let at_start = at_frame_10;
    // What the object holds depends on the schedule's phase (a heterogeneous material's textures
    // are freed when it turns homogeneous again): growth is the end against the first frame from
    // 10 on in the same phase (`SCHEDULE_PERIOD`).
    let phase_frame = (10..frames).find(|i| i % SCHEDULE_PERIOD == (frames - 1) % SCHEDULE_PERIOD);
    let mut at_phase = None;
    let mut messages = 0usize;
    let mut passes: BTreeMap<String, Vec<f64>> = BTreeMap::new();
    let mut warm = 0usize;
    for i in 0..frames {
        object.set_lights(&scene_at(i))?;
        object.set_material(&ctx, &material_at(i)?)?;
        object.deform(&ctx, &deformation_at(i))?;
        let (captured, report) = host
            .render(&ctx, &mut object)
            .map_err(|e| format!("frame {i}: {e}"))?;
        warm += usize::from(report.warm_start);
        for (name, ms) in &captured.passes {
            passes.entry(name.clone()).or_default().push(*ms);
        }
        if i % check_every == check_every - 1 || i + 1 == frames {
            let j = solve(&object)?.read_j_plus(&ctx)?;
            let v = solve(&object)?.read_vertex_j_plus(&ctx)?;
            let finite = j.iter().flatten().all(|x| x.is_finite() && *x >= 0.0)
                && v.iter().flatten().all(|x| x.is_finite())
                && captured
                    .image
                    .pixels
                    .iter()
                    .flatten()
                    .all(|x| x.is_finite());
            messages += log.take().len();
            if !finite {
                return Err(format!("frame {i}: NaN or Inf in J+ or the image").into());
            }
            println!(
                "frame {:6}: {:8.1} s, allocator {:?}, messages {messages}, iterations {:?}",
                i + 1,
                start.elapsed().as_secs_f64(),
                ctx.allocator_usage(),
                solve(&object)?.iterations_run(&ctx)?
            );
        }
        if i == 10 {
            at_frame_10 = ctx.allocator_usage();
        }
        if Some(i) == phase_frame {
            at_phase = Some(ctx.allocator_usage());
        }
    }
    let wall = start.elapsed().as_secs_f64();
    let (b1, per_node1) = solve(&object)?.bytes();
    println!(
        "GPU bytes at the end (heterogeneous textures and deformation data allocated): {b1} = {per_node1:.1} B/node"
    );
    let end = ctx.allocator_usage();
    println!(
        "\n| frames | wall s | ms/frame | allocator at start | at frame 10 | at end | validation messages | NaN/Inf |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    println!(
        "| {frames} | {wall:.0} | {:.1} | {at_start:?} | {at_frame_10:?} | {end:?} | {messages} | none |",
        1e3 * wall / frames.max(1) as f64
    );
    println!("\n{warm} of {frames} frames warm-started the solve");
    println!("median GPU ms per pass (over the frames it ran in):");
    for (name, v) in passes {
        println!(
            "  {name:28} {:8.3} ms ({} frames)",
            median(v.clone()),
            v.len()
        );
    }
    drop((object, host));
    match (phase_frame, at_phase) {
        (Some(f), Some(then)) if f + 1 < frames => {
            println!(
                "allocator at frame {} (the end's schedule phase): {then:?}",
                f + 1
            );
            if end != then {
                return Err(
                    format!("allocator grew: {then:?} at frame {} -> {end:?}", f + 1).into(),
                );
            }
        }
        _ => println!(
            "allocator growth not checked: needs more than {} frames",
            10 + SCHEDULE_PERIOD
        ),
    }
    if messages > 0 {
        return Err(format!("{messages} validation messages").into());
    }
    Ok(())
}
