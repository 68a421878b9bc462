//! DESIGN section 5's skips, one test each, through the host API (`TranslucentObject` recording
//! into `HeadlessHost`'s command buffer, as into a host's). Each test proves the skip happened
//! (the `FrameReport` says which pass was left out and why, and the profiler has no scope for it)
//! and that the image stays within a stated tolerance of the render of the same frame with every
//! skip off (`ObjectParams::skip = false`: shadow maps, gather and a cold multi-level solve every
//! frame).
//!
//! Scene: a 20 mm marble sphere baked at resolution 12 with 2 levels, one directional light,
//! 24x24 pixels: small enough for lavapipe, big enough that the object covers most pixels.

use std::sync::Arc;

use glam::DVec3;
use translucent::frame::quadgraph::{
    PART_COARSE as PASS_COARSE, PART_INIT as PASS_INIT, PASS_EDITS, PASS_GATHER,
};
use translucent::frame::{PASS_SHADING, PASS_SHADOW};
use translucent::headless::HeadlessHost;
use translucent::material::{Material, MaterialField, Procedural};
use translucent::mesh::shapes::Shape;
use translucent::quadgraph::BakeParams;
use translucent::scene::Camera;
use translucent::scene::{Environment, Light, Scene};
use translucent::solver::gpu::{PASS_EXITANCE, PASS_SOLVE};
use translucent::vk::Context;
use translucent::{ObjectParams, QuadGraph, SkipReason, TranslucentObject};
use translucent_tests::{relative_difference, GpuTest};

const SIZE: u32 = 24;
/// Tolerance between two solves that both stopped at the tolerance (estimated relative error
/// 1e-4), relative to the brightest channel: 4 ulps of the RGBA16F colour target there (its ulp is
/// 2^-11 relative). Measured: 4.5e-5 to 7.2e-4.
const SOLVED: f32 = 4.0 / 2048.0;

fn graph() -> Arc<QuadGraph> {
    let ball = Shape::Sphere { radius: 10.0 };
    let params = BakeParams {
        resolution: 12,
        levels: 2,
        ..Default::default()
    };
    Arc::new(
        QuadGraph::bake(&ball.triangulate(32), &ball, &params, &mut |_| {})
            .expect("bake")
            .0,
    )
}

fn marble() -> MaterialField {
    MaterialField::Homogeneous(Material::preset("marble").expect("preset"))
}

fn light_at(degrees: f64) -> Scene {
    let a = degrees.to_radians();
    Scene {
        lights: vec![Light::Directional {
            direction: DVec3::new(a.sin(), -1.0, -a.cos()).normalize(),
            irradiance: [2.0; 3],
        }],
        environment: Environment::None,
    }
}

fn object(
    ctx: &Context,
    graph: &Arc<QuadGraph>,
    field: &MaterialField,
    scene: &Scene,
    tweak: impl FnOnce(&mut ObjectParams),
) -> TranslucentObject {
    let mut params = translucent_tests::cascade_params();
    tweak(&mut params);
    TranslucentObject::new(ctx, graph.clone(), field, scene, &params).expect("object")
}

fn assert_no_scopes(passes: &std::collections::BTreeMap<String, f64>, absent: &[&str]) {
    for name in absent {
        assert!(
            !passes.contains_key(*name),
            "profiler scope {name:?} present: {passes:?}"
        );
    }
}

/// Nothing changed: frame 2 records only the shading, and its image is the one the unskipped
/// object renders with a full cold solve (same solve, same commands: the difference is fp16 noise
/// of the colour target at most, tolerance 1e-3 of the brightest channel).
#[test]
fn unchanged_scene_records_only_the_shading() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let (graph, field, scene) = (graph(), marble(), light_at(0.0));
    let mut host = HeadlessHost::new(ctx, SIZE, SIZE).expect("host");
    let mut skipping = object(ctx, &graph, &field, &scene, |_| {});
    let mut full = object(ctx, &graph, &field, &scene, |p| p.skip = false);
    let (_, first) = host.render(ctx, &mut skipping).expect("frame 1");
    assert_eq!(
        first.passes,
        [
            PASS_SHADOW,
            PASS_GATHER,
            PASS_SOLVE,
            PASS_EXITANCE,
            PASS_SHADING
        ]
    );
    let (skipped, report) = host.render(ctx, &mut skipping).expect("frame 2");
    assert_eq!(report.passes, [PASS_SHADING]);
    for pass in [PASS_SHADOW, PASS_GATHER, PASS_SOLVE] {
        assert_eq!(
            report.skipped.get(pass),
            Some(&SkipReason::Unchanged),
            "{pass}"
        );
    }
    assert_no_scopes(
        &skipped.passes,
        &[
            "shadow_map",
            "gather_q",
            "diffusion jacobi",
            "diffusion init",
        ],
    );
    assert!(skipped.passes.is_empty() || skipped.passes.contains_key("shading"));
    // The first frame's solve is reported once it completed.
    assert_eq!(report.completed.len(), 1);
    host.render(ctx, &mut full).expect("full frame 1");
    let (reference, full_report) = host.render(ctx, &mut full).expect("full frame 2");
    // Skipping off skips nothing; only the edits pass is absent, with nothing staged to record.
    let skipped_work: Vec<_> = full_report
        .skipped
        .iter()
        .filter(|&(&pass, &why)| !(pass == PASS_EDITS && why == SkipReason::NoEdits))
        .collect();
    assert!(skipped_work.is_empty(), "{:?}", full_report.skipped);
    let d = relative_difference(&skipped.image, &reference.image);
    assert!(d <= 1e-3, "difference {d}");
    drop((skipping, full, host));
    gpu.finish();
}

/// Camera only: shading only, with the view-dependent Fresnel of the new view; same image as the
/// unskipped object's from that camera (tolerance as above).
#[test]
fn camera_move_records_only_the_shading() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let (graph, field, scene) = (graph(), marble(), light_at(0.0));
    let mut host = HeadlessHost::new(ctx, SIZE, SIZE).expect("host");
    let camera = Camera {
        eye: DVec3::new(40.0, 20.0, 30.0),
        target: DVec3::ZERO,
        fovy_deg: 40.0,
    };
    let mut skipping = object(ctx, &graph, &field, &scene, |_| {});
    host.render(ctx, &mut skipping).expect("frame 1");
    skipping.set_camera(Some(camera)).expect("camera");
    let (moved, report) = host.render(ctx, &mut skipping).expect("frame 2");
    assert_eq!(report.passes, [PASS_SHADING]);
    assert_eq!(
        report.skipped.get(PASS_SOLVE),
        Some(&SkipReason::CameraOnly)
    );
    assert_no_scopes(
        &moved.passes,
        &["shadow_map", "gather_q", "diffusion jacobi"],
    );
    let mut full = object(ctx, &graph, &field, &scene, |p| p.skip = false);
    full.set_camera(Some(camera)).expect("camera");
    let (reference, _) = host.render(ctx, &mut full).expect("full");
    let d = relative_difference(&moved.image, &reference.image);
    assert!(d <= 1e-3, "difference {d}");
    // A bad camera is a typed error and changes nothing.
    let bad = Camera {
        eye: DVec3::ZERO,
        target: DVec3::ZERO,
        fovy_deg: 40.0,
    };
    assert!(skipping.set_camera(Some(bad)).is_err());
    assert_eq!(skipping.camera(), Some(camera));
    drop((skipping, full, host));
    gpu.finish();
}

/// A light moving 5 degrees: shadow map, gather and a warm-started solve of every level (no
/// Shepard init: each level starts from its last solution, the finer one corrected by the coarser
/// level's change, the `diffusion warm correction` scope). Its image is within `SOLVED` of a cold
/// multi-level solve of the same lights, and it runs fewer iterations than that cold solve
/// (GPU counters; benches/RESULTS.md, "Host frames", has the ratio per step).
#[test]
fn light_change_warm_starts_every_level_with_the_coarse_correction() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let (graph, field) = (graph(), marble());
    let mut host = HeadlessHost::new(ctx, SIZE, SIZE).expect("host");
    let mut skipping = object(ctx, &graph, &field, &light_at(0.0), |_| {});
    host.render(ctx, &mut skipping).expect("frame 1");
    // A bad light is refused at once and leaves the pending change alone.
    let mut nan = light_at(5.0);
    nan.lights[0] = Light::Directional {
        direction: DVec3::new(f64::NAN, -1.0, 0.0),
        irradiance: [1.0; 3],
    };
    assert!(skipping.set_lights(&nan).is_err());
    skipping.set_lights(&light_at(5.0)).expect("lights");
    let (warm, report) = host.render(ctx, &mut skipping).expect("frame 2");
    assert_eq!(
        report.passes,
        [
            PASS_SHADOW,
            PASS_GATHER,
            PASS_SOLVE,
            PASS_EXITANCE,
            PASS_SHADING
        ]
    );
    assert!(report.warm_start);
    assert_eq!(report.levels_iterated, 2);
    assert_eq!(report.skipped.get(PASS_INIT), Some(&SkipReason::WarmStart));
    assert_eq!(report.skipped.get(PASS_COARSE), None);
    assert_no_scopes(&warm.passes, &["diffusion init"]);
    if !warm.passes.is_empty() {
        assert!(warm.passes.contains_key("diffusion warm correction"));
    }
    let warm_solve = skipping
        .completed_solves(ctx.frames().1)
        .expect("read")
        .pop()
        .expect("frame 2's solve");
    assert!(warm_solve.converged(), "{:?}", warm_solve.levels);
    assert!(warm_solve.levels.iter().all(|l| l.iterations > 0));

    let mut full = object(ctx, &graph, &field, &light_at(5.0), |p| p.skip = false);
    let (reference, _) = host.render(ctx, &mut full).expect("full");
    let cold_solve = full
        .completed_solves(ctx.frames().1)
        .expect("read")
        .pop()
        .expect("cold solve");
    let warm_total: u32 = warm_solve.iterations().iter().sum();
    let cold_total: u32 = cold_solve.iterations().iter().sum();
    eprintln!(
        "warm {:?} vs cold {:?}",
        warm_solve.iterations(),
        cold_solve.iterations()
    );
    assert!(
        warm_total < cold_total,
        "warm {:?} vs cold {:?}",
        warm_solve.iterations(),
        cold_solve.iterations()
    );
    let d = relative_difference(&warm.image, &reference.image);
    eprintln!("warm vs cold: {d:.2e}");
    assert!(d <= SOLVED, "difference {d}");

    // Below `single_level_nodes` the warm start stays on the finest level (no coarse solution
    // exists to correct from: the cold frame left the coarse level at zero).
    let mut small = object(ctx, &graph, &field, &light_at(0.0), |p| {
        p.single_level_nodes = 20_000;
    });
    host.render(ctx, &mut small).expect("small frame 1");
    small.set_lights(&light_at(5.0)).expect("lights");
    let (one, report) = host.render(ctx, &mut small).expect("small frame 2");
    assert!(report.warm_start);
    assert_eq!(report.levels_iterated, 1);
    assert_eq!(
        report.skipped.get(PASS_COARSE),
        Some(&SkipReason::SmallGraph)
    );
    assert_eq!(report.skipped.get(PASS_INIT), Some(&SkipReason::WarmStart));
    assert_no_scopes(
        &one.passes,
        &["diffusion init", "diffusion warm correction"],
    );
    let solve = small
        .completed_solves(ctx.frames().1)
        .expect("read")
        .pop()
        .expect("small solve");
    assert_eq!(solve.levels[0].iterations, 0, "{solve:?}");
    assert!(solve.converged(), "{solve:?}");
    let d = relative_difference(&one.image, &reference.image);
    eprintln!("one-level warm vs cold: {d:.2e}");
    assert!(d <= SOLVED, "difference {d}");
    drop((skipping, full, small, host));
    gpu.finish();
}

/// No shadow-casting light (a constant environment only; then a black directional light): no
/// shadow pass, and the image equals the unskipped object's (which has no shadow pass to run
/// either: the tolerance 1e-3 only covers the colour target's fp16).
#[test]
fn no_shadow_casting_light_records_no_shadow_pass() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let (graph, field) = (graph(), marble());
    let mut host = HeadlessHost::new(ctx, SIZE, SIZE).expect("host");
    let environment = Scene {
        lights: vec![],
        environment: Environment::Constant([0.3, 0.3, 0.3]),
    };
    let mut skipping = object(ctx, &graph, &field, &environment, |_| {});
    let (lit, report) = host.render(ctx, &mut skipping).expect("frame 1");
    assert_eq!(
        report.passes,
        [PASS_GATHER, PASS_SOLVE, PASS_EXITANCE, PASS_SHADING]
    );
    assert_eq!(
        report.skipped.get(PASS_SHADOW),
        Some(&SkipReason::NoShadowCaster)
    );
    assert_no_scopes(&lit.passes, &["shadow_map"]);
    let mut full = object(ctx, &graph, &field, &environment, |p| p.skip = false);
    let (reference, _) = host.render(ctx, &mut full).expect("full");
    let d = relative_difference(&lit.image, &reference.image);
    assert!(d <= 1e-3, "difference {d}");

    let mut black = environment.clone();
    black.lights.push(Light::Directional {
        direction: -DVec3::Y,
        irradiance: [0.0; 3],
    });
    skipping.set_lights(&black).expect("lights");
    let (_, report) = host.render(ctx, &mut skipping).expect("frame 2");
    assert!(!report.passes.contains(&PASS_SHADOW), "{report:?}");
    assert_eq!(
        report.skipped.get(PASS_SHADOW),
        Some(&SkipReason::NoShadowCaster)
    );
    drop((skipping, full, host));
    gpu.finish();
}

/// Converged: every level stops at the tolerance before its cap (GPU-side indirect dispatch);
/// the image is within `SOLVED` of the same solve run to the cap with tolerance 0 (never stops early).
#[test]
fn converged_levels_stop_iterating() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let (graph, field, scene) = (graph(), marble(), light_at(0.0));
    let mut host = HeadlessHost::new(ctx, SIZE, SIZE).expect("host");
    let cap = 1200;
    let mut early = object(ctx, &graph, &field, &scene, |p| {
        p.solve.iterations = vec![cap];
        p.single_level_nodes = 0;
    });
    let (stopped, _) = host.render(ctx, &mut early).expect("early");
    let solve = early
        .completed_solves(ctx.frames().1)
        .expect("read")
        .pop()
        .expect("solve");
    assert!(solve.converged(), "{:?}", solve.levels);
    assert!(solve.iterations().iter().all(|&n| n > 0 && n < cap));
    let mut to_cap = object(ctx, &graph, &field, &scene, |p| {
        p.solve.iterations = vec![cap];
        p.solve.tolerance = 0.0;
        p.single_level_nodes = 0;
        p.skip = false;
    });
    let (reference, _) = host.render(ctx, &mut to_cap).expect("to the cap");
    let full = to_cap
        .completed_solves(ctx.frames().1)
        .expect("read")
        .pop()
        .expect("solve");
    assert!(full.iterations().iter().all(|&n| n == cap), "{full:?}");
    let d = relative_difference(&stopped.image, &reference.image);
    eprintln!("converged vs to the cap: {d:.2e}");
    assert!(d <= SOLVED, "difference {d}");
    drop((early, to_cap, host));
    gpu.finish();
}

/// Small graph: a cold solve iterates only the finest level (the coarse level is left at zero:
/// its iteration counter stays 0); within `SOLVED` of the multi-level solve.
#[test]
fn small_graph_solves_one_level() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let (graph, field, scene) = (graph(), marble(), light_at(0.0));
    assert!(graph.finest().node_count() < 20_000);
    let mut host = HeadlessHost::new(ctx, SIZE, SIZE).expect("host");
    let mut one = object(ctx, &graph, &field, &scene, |p| {
        p.single_level_nodes = 20_000;
    });
    let (single, report) = host.render(ctx, &mut one).expect("one level");
    assert!(!report.warm_start);
    assert_eq!(report.levels_iterated, 1);
    assert_eq!(
        report.skipped.get(PASS_COARSE),
        Some(&SkipReason::SmallGraph)
    );
    let solve = one
        .completed_solves(ctx.frames().1)
        .expect("read")
        .pop()
        .expect("solve");
    assert_eq!(solve.levels[0].iterations, 0);
    assert!(solve.levels[1].iterations > 0 && solve.converged());
    let mut multi = object(ctx, &graph, &field, &scene, |p| p.skip = false);
    let (reference, report) = host.render(ctx, &mut multi).expect("multi-level");
    assert_eq!(report.levels_iterated, 2);
    let d = relative_difference(&single.image, &reference.image);
    eprintln!("one level vs all levels: {d:.2e}");
    assert!(d <= SOLVED, "difference {d}");
    drop((one, multi, host));
    gpu.finish();
}

/// A homogeneous material runs the homogeneous variant (kappa and mu from push constants, no
/// per-node material reads); the same coefficients as a heterogeneous field (a split of marble
/// and marble) run the per-node variant. Same physics, so the images agree within `SOLVED` (the
/// weights are the same numbers computed on two paths).
#[test]
fn homogeneous_material_runs_the_homogeneous_variant() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let (graph, scene) = (graph(), light_at(0.0));
    let material = Material::preset("marble").expect("preset");
    let split = MaterialField::procedural(
        Procedural::Split {
            normal: DVec3::Y,
            offset: 0.0,
            below: material.coefficients(),
            above: material.coefficients(),
        },
        material.eta,
    )
    .expect("field");
    let mut host = HeadlessHost::new(ctx, SIZE, SIZE).expect("host");
    let mut homogeneous = object(ctx, &graph, &marble(), &scene, |_| {});
    let (fast, report) = host.render(ctx, &mut homogeneous).expect("homogeneous");
    assert_eq!(report.material_variant, "homogeneous");
    let mut per_node = object(ctx, &graph, &split, &scene, |p| p.skip = false);
    let (reference, report) = host.render(ctx, &mut per_node).expect("heterogeneous");
    assert_eq!(report.material_variant, "heterogeneous");
    let d = relative_difference(&fast.image, &reference.image);
    eprintln!("homogeneous vs per-node variant: {d:.2e}");
    assert!(d <= SOLVED, "difference {d}");
    drop((homogeneous, per_node, host));
    gpu.finish();
}
