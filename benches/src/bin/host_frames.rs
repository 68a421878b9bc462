//! Host-frame measurements for `benches/RESULTS.md` ("Host frames: warm start and skipping"),
//! through `TranslucentObject` recorded into a headless host's command buffer:
//! (a) a light orbiting a few degrees per frame: iterations per level and GPU ms of each frame,
//!     warm start (the default skips: every level from its last solution, corrected by the
//!     coarser level's change) against a cold multi-level solve every frame (`skip = false`), and
//!     the warm J+ against the cold one;
//! (b) a static scene: GPU ms per frame with skipping on and off;
//! (c) the small-graph threshold: a cold solve iterating one level against all levels, for
//!     sphere bakes of growing resolution.
//!
//! ```text
//! cargo run --release -p translucent-benches --bin host_frames -- [RESOLUTION] [FRAMES] [DEGREES] [c]
//! ```
//! A fourth argument `a` runs part (a) only, `c` part (c) only (`-`: all); a fifth sets the
//! iterations per convergence block (default 8).
//! Defaults: torus resolution 24 (3 levels), 8 frames, 3 degrees per frame. Prints markdown
//! tables. `TRANSLUCENT_DEVICE` picks the Vulkan device; `TRANSLUCENT_VALIDATION=1` prints
//! validation messages.

use std::sync::Arc;

use translucent::headless::{Captured, HeadlessHost};
use translucent::material::{Material, MaterialField};
use translucent::mesh::shapes::Shape;
use translucent::quadgraph::BakeParams;
use translucent::scene::{Environment, Light, Scene};
use translucent::solver::gpu::GpuDiffusion;
use translucent::vk::{Context, ContextDesc};
use translucent::{ObjectParams, QuadGraph, TranslucentObject};

type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

fn scene(degrees: f64) -> Scene {
    let a = degrees.to_radians();
    Scene {
        // glam is not a dependency here: the light goes through its command-line form.
        lights: vec![format!("dir:{},-0.7,{}:3,3,3", a.sin(), -a.cos())
            .parse::<Light>()
            .expect("a finite direction")],
        environment: Environment::Constant([0.02; 3]),
    }
}

fn bake(shape: Shape, resolution: u32, levels: u32) -> Result<Arc<QuadGraph>> {
    let params = BakeParams {
        resolution,
        levels,
        ..Default::default()
    };
    Ok(Arc::new(
        QuadGraph::bake(&shape.triangulate(96), &shape, &params, &mut |_| {})?.0,
    ))
}

/// GPU ms of a frame's own passes: the frame graph's top-level scopes (`Captured::passes` also
/// holds the nested ones, summed by name), less the capture (the headless host's, not ours).
fn frame_ms(c: &Captured) -> f64 {
    c.timings.as_ref().map_or(f64::NAN, |t| {
        t.scopes
            .iter()
            .filter(|s| s.depth == 0 && s.name != "capture")
            .map(|s| s.duration_ms)
            .sum()
    })
}

fn shading_ms(c: &Captured) -> f64 {
    c.passes.get("shading").copied().unwrap_or(0.0)
}

/// Renders one frame; returns the capture and the iterations its solve ran (zeros: none).
fn frame(
    ctx: &Context,
    host: &mut HeadlessHost,
    object: &mut TranslucentObject,
    levels: usize,
) -> Result<(Captured, Vec<u32>)> {
    let (captured, _) = host.render(ctx, object)?;
    let its = object
        .completed_solves(ctx.frames().1)?
        .into_iter()
        .find(|s| s.frame == captured.frame)
        .map_or_else(|| vec![0; levels], |s| s.iterations());
    Ok((captured, its))
}

/// The object's diffusion solve (its read-backs).
fn solve(object: &TranslucentObject) -> Result<&GpuDiffusion> {
    Ok(object
        .quadgraph()
        .ok_or("the object's method is not the QuadGraph")?
        .solve())
}

fn max_relative(a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
    let peak = b.iter().flatten().fold(0.0f32, |m, v| m.max(v.abs()));
    a.iter()
        .flatten()
        .zip(b.iter().flatten())
        .map(|(x, y)| f64::from((x - y).abs() / peak.max(f32::MIN_POSITIVE)))
        .fold(0.0, f64::max)
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let resolution: u32 = args.first().map_or(Ok(24), |s| s.parse())?;
    let frames: u32 = args.get(1).map_or(Ok(8), |s| s.parse())?;
    let degrees: f64 = args.get(2).map_or(Ok(3.0), |s| s.parse())?;
    // `TRANSLUCENT_VALIDATION=1`: validation messages are printed as they come.
    let ctx = Context::headless(&ContextDesc {
        echo_validation: true,
        ..ContextDesc::default()
    })?;
    println!("device: {}", ctx.info().device_name);
    let field = MaterialField::Homogeneous(Material::preset("marble")?);
    let torus = Shape::Torus {
        major: 17.5,
        minor: 7.5,
    };
    let graph = bake(torus, resolution, 3)?;
    let nodes: Vec<usize> = graph.levels.iter().map(|l| l.node_count()).collect();
    let levels = nodes.len();
    println!("torus 50 mm, resolution {resolution}, nodes per level {nodes:?}");
    let mut host = HeadlessHost::new(&ctx, 128, 128)?;
    let only_c = args.get(3).is_some_and(|a| a == "c");
    let only_a = args.get(3).is_some_and(|a| a == "a");

    // (a) Moving light: warm (skips on) vs cold (skips off), same lights every frame.
    println!("\n(a) light orbiting {degrees} deg/frame, tolerance 1e-4, cap 2000 per level");
    println!("| frame | warm iterations | warm GPU ms | cold iterations | cold GPU ms | max |J+ warm - J+ cold| / max J+ | finest-only warm: iterations, GPU ms |");
    println!("|---|---|---|---|---|---|---|");
    let mut params = ObjectParams {
        single_level_nodes: 0,
        ..ObjectParams::default()
    };
    if let Some(block) = args.get(4) {
        params.solve.block = block.parse()?;
    }
    if only_c {
        return small_graphs(&ctx, &mut host, &field);
    }
    let mut warm = TranslucentObject::new(&ctx, graph.clone(), &field, &scene(0.0), &params)?;
    let mut cold = TranslucentObject::new(
        &ctx,
        graph.clone(),
        &field,
        &scene(0.0),
        &ObjectParams {
            skip: false,
            ..params.clone()
        },
    )?;
    // The previous warm start, for comparison: the finest level alone from its last solution
    // (the small-graph path; its first, cold frame iterates the finest level from zero).
    let mut finest = TranslucentObject::new(
        &ctx,
        graph.clone(),
        &field,
        &scene(0.0),
        &ObjectParams {
            single_level_nodes: usize::MAX,
            ..params.clone()
        },
    )?;
    let (mut warm_sum, mut cold_sum) = ((0u32, 0.0), (0u32, 0.0));
    let (mut warm_finest, mut cold_finest, mut finest_sum) = (0u32, 0u32, 0u32);
    for i in 0..frames {
        let lights = scene(degrees * f64::from(i));
        warm.set_lights(&lights)?;
        cold.set_lights(&lights)?;
        finest.set_lights(&lights)?;
        let (fc, fi) = frame(&ctx, &mut host, &mut finest, levels)?;
        let (wc, wi) = frame(&ctx, &mut host, &mut warm, levels)?;
        let wj = solve(&warm)?.read_vertex_j_plus(&ctx)?;
        let (cc, ci) = frame(&ctx, &mut host, &mut cold, levels)?;
        let cj = solve(&cold)?.read_vertex_j_plus(&ctx)?;
        let (wms, cms) = (frame_ms(&wc), frame_ms(&cc));
        if i > 0 {
            warm_finest += wi[levels - 1];
            cold_finest += ci[levels - 1];
            finest_sum += fi.iter().sum::<u32>();
            warm_sum.0 += wi.iter().sum::<u32>();
            warm_sum.1 += wms;
            cold_sum.0 += ci.iter().sum::<u32>();
            cold_sum.1 += cms;
        }
        println!(
            "| {i} | {wi:?} | {wms:.1} | {ci:?} | {cms:.1} | {:.2e} | {fi:?}, {:.1} |",
            max_relative(&wj, &cj),
            frame_ms(&fc)
        );
    }
    let n = f64::from(frames.saturating_sub(1).max(1));
    println!(
        "frames 1..{}: mean iterations warm {:.0}, cold {:.0}; mean GPU ms warm {:.1}, cold {:.1}",
        frames - 1,
        f64::from(warm_sum.0) / n,
        f64::from(cold_sum.0) / n,
        warm_sum.1 / n,
        cold_sum.1 / n
    );
    println!(
        "cold / warm: {:.2}x total iterations, {:.2}x finest level; finest-only warm: mean {:.0} iterations",
        f64::from(cold_sum.0) / f64::from(warm_sum.0.max(1)),
        f64::from(cold_finest) / f64::from(warm_finest.max(1)),
        f64::from(finest_sum) / n
    );
    drop((warm, cold, finest));
    if only_a {
        return Ok(());
    }

    // (b) Static scene: skipping on and off.
    println!("\n(b) static scene, {frames} frames");
    println!("| frame | skip on: GPU ms (shading ms) | skip off: GPU ms (shading ms) |");
    println!("|---|---|---|");
    let mut on = TranslucentObject::new(&ctx, graph.clone(), &field, &scene(0.0), &params)?;
    let mut off = TranslucentObject::new(
        &ctx,
        graph.clone(),
        &field,
        &scene(0.0),
        &ObjectParams {
            skip: false,
            ..params.clone()
        },
    )?;
    for i in 0..frames {
        let (a, _) = frame(&ctx, &mut host, &mut on, levels)?;
        let (b, _) = frame(&ctx, &mut host, &mut off, levels)?;
        println!(
            "| {i} | {:.2} ({:.2}) | {:.1} ({:.2}) |",
            frame_ms(&a),
            shading_ms(&a),
            frame_ms(&b),
            shading_ms(&b)
        );
    }
    drop((on, off));

    small_graphs(&ctx, &mut host, &field)
}

fn small_graphs(ctx: &Context, host: &mut HeadlessHost, field: &MaterialField) -> Result<()> {
    // (c) Small graphs: one level vs all levels, cold.
    println!("\n(c) cold solve of a 20 mm sphere: one level vs all levels");
    println!("| resolution, levels | finest nodes | all levels: iterations, GPU ms | finest only: iterations, GPU ms |");
    println!("|---|---|---|---|");
    for (r, levels) in [(8, 2), (12, 2), (16, 2), (16, 3), (24, 3)] {
        let g = bake(Shape::Sphere { radius: 10.0 }, r, levels)?;
        let lv = g.levels.len();
        let mut row = Vec::new();
        for threshold in [0, usize::MAX] {
            let mut o = TranslucentObject::new(
                ctx,
                g.clone(),
                field,
                &scene(0.0),
                &ObjectParams {
                    single_level_nodes: threshold,
                    ..ObjectParams::default()
                },
            )?;
            let (c, its) = frame(ctx, host, &mut o, lv)?;
            row.push(format!("{its:?}, {:.1}", frame_ms(&c)));
        }
        println!(
            "| {r}, {levels} | {} | {} | {} |",
            g.finest().node_count(),
            row[0],
            row[1]
        );
    }
    Ok(())
}
