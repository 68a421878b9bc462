//! Soak (issue 6 item 4): N frames in which every frame changes the light, the material and the
//! shape of a sphere, recorded as a host would (`HeadlessRenderer::render_frame_after` around
//! `GpuFrame::record`), the same schedule as `tests/tests/soak.rs` (which runs 100 frames in CI).
//! Per frame: `set_lights` (a directional light turning 0.2 rad/frame, brightness 1 +- 0.5),
//! `set_material` (drifting marble coefficients; every 4th frame a heterogeneous split with
//! eta 1.4), `deform` (twist of 0.03 sin(0.07 i) rad/mm; every 10th frame the identity, every 10th
//! an affine squash). Every `--check-every` frames and at the end: J+ of surface nodes and display
//! vertices and the image read back and checked finite, validation messages counted. Prints the
//! allocator's (allocations, bytes, block bytes) at frame 10 and at the end, wall time and the
//! median GPU ms of the edit passes, and exits non-zero on a NaN, a message or allocator growth.
//!
//! ```text
//! cargo run --release -p translucent-benches --bin soak -- [--frames 10000] [--resolution 10]
//!     [--segments 24] [--check-every 100] [--no-validation]
//! ```

use std::collections::BTreeMap;
use std::time::Instant;

use translucent::mesh::shapes::Shape;
use translucent::mesh::GpuMesh;
use translucent::quadgraph::BakeParams;
use translucent::render::{FrameDesc, HeadlessRenderer};
use translucent::solver::gpu::{GpuFrame, GpuSolveParams};
use translucent::vk::{Context, ContextDesc};
use translucent::QuadGraph;
use translucent_benches::soak::{deformation_at, material_at, scene_at};

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
    let graph: QuadGraph =
        QuadGraph::bake(&shape.triangulate(segments), &shape, &bake, &mut |_| {})?.0;
    let params = GpuSolveParams {
        iterations: vec![48],
        tolerance: 1e-4,
        warm_start: true,
        ..Default::default()
    };
    let field = material_at(0)?;
    let scene = scene_at(0);
    let n = graph.surface.positions.len();
    let mut renderer = HeadlessRenderer::new(
        &ctx,
        &translucent::render::Scene {
            mesh: graph.surface.clone(),
            exitance: vec![[0.0; 3]; n],
            lights: scene.lights.clone(),
            eta: field.eta(),
        },
        &FrameDesc {
            width: 48,
            height: 48,
            ..Default::default()
        },
    )?;
    let mut frame = GpuFrame::new(&ctx, &graph, &field, &scene, &params)?;
    frame.solve.bind_mesh(&ctx, renderer.mesh())?;
    let caster = GpuMesh::new(&ctx, &graph.surface, &vec![[0.0; 3]; n])?;
    let nodes: usize = (0..graph.levels.len())
        .map(|h| frame.solve.node_count(h))
        .sum();
    println!(
        "soak: {frames} frames, sphere r = 10 mm, resolution {resolution}, {} levels, {nodes} nodes, {n} display vertices, validation {validation}",
        graph.levels.len()
    );
    let texels: u64 = graph
        .levels
        .iter()
        .map(|l| u64::from(l.packing.width) * u64::from(l.packing.height))
        .sum();
    let (b0, per_node0) = frame.solve.bytes();
    println!(
        "GPU bytes at start (homogeneous, rest pose): {b0} = {per_node0:.1} B/node ({texels} texels for {nodes} nodes)"
    );
    let start = Instant::now();
    let mut at_frame_10 = ctx.allocator_usage();
    let at_start = at_frame_10;
    let mut messages = 0usize;
    let mut passes: BTreeMap<String, Vec<f64>> = BTreeMap::new();
    for i in 0..frames {
        frame.set_lights(&graph, &scene_at(i))?;
        frame.set_material(&ctx, &graph, &material_at(i)?)?;
        frame.deform(
            &ctx,
            &graph,
            &deformation_at(i),
            &[renderer.mesh(), &caster],
        )?;
        let mut failed = None;
        let captured = renderer.render_frame_after(&ctx, |cb, profiler| {
            // SAFETY: `cb` is recording; frame and caster outlive the waited frame.
            failed = unsafe { frame.record(&ctx, cb, &caster, Some(profiler)) }.err();
        })?;
        if let Some(e) = failed {
            return Err(format!("frame {i}: {e}").into());
        }
        for (name, ms) in &captured.passes {
            passes.entry(name.clone()).or_default().push(*ms);
        }
        if i % check_every == check_every - 1 || i + 1 == frames {
            let j = frame.solve.read_j_plus(&ctx)?;
            let v = frame.solve.read_vertex_j_plus(&ctx)?;
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
                frame.solve.iterations_run(&ctx)?
            );
        }
        if i == 10 {
            at_frame_10 = ctx.allocator_usage();
        }
    }
    let wall = start.elapsed().as_secs_f64();
    let (b1, per_node1) = frame.solve.bytes();
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
    println!("\nmedian GPU ms per pass (over the frames it ran in):");
    for (name, v) in passes {
        println!(
            "  {name:28} {:8.3} ms ({} frames)",
            median(v.clone()),
            v.len()
        );
    }
    drop((frame, caster, renderer));
    if end != at_frame_10 && frames > 10 {
        return Err(format!("allocator grew: {at_frame_10:?} -> {end:?}").into());
    }
    if messages > 0 {
        return Err(format!("{messages} validation messages").into());
    }
    Ok(())
}
