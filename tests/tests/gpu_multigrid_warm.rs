//! The GPU multigrid's warm start extrapolated through the last solutions
//! (`MultigridParams::warm_start`, `--multigrid-cycle warm=last|linear|quadratic`): for a light
//! turning steadily 3 degrees per frame, the linear and quadratic starts begin closer to the
//! frame's solution than the last solution and reach the same error against the f64 exact solve
//! in fewer work units; the first warm frame (one solution kept) falls back to the last solution;
//! a light jump after steady frames still converges to the exact solve; nothing is NaN.
//! Validation (with synchronization validation) is on and any message fails.

use glam::{DQuat, DVec3};
use translucent::material::{Material, MaterialField};
use translucent::mesh::shapes::Shape;
use translucent::quadgraph::BakeParams;
use translucent::scene::{Environment, Light, Scene};
use translucent::solver::gpu::multigrid::{CycleState, GpuMultigridReport};
use translucent::solver::gpu::{GpuDiffusion, GpuSolveParams};
use translucent::solver::multigrid::{MultigridParams, WarmStart};
use translucent::solver::{self, rel_rms, CpuSolveParams};
use translucent::vk::Context;
use translucent::QuadGraph;
use translucent_tests::{solve_once, tol, GpuTest};

/// Relative residual the GPU cycles stop at (as `gpu_multigrid.rs`: above f32's floor, below
/// the fp16 q rounding that dominates the error against the exact solve).
const TOLERANCE: f32 = 1e-5;
/// Degrees the light turns per frame (the warm-start protocol).
const STEP: f64 = 3.0;
/// Relative RMS between a warm and the cold J+ of the same frame, both converged to
/// [`TOLERANCE`] from the same q (measured 6e-7 to 2e-6 on skim milk): a start that changed the
/// converged answer (history slots mixed up, a stale exposure) differs by the frame's change.
const WARM_VS_COLD: f64 = 1e-4;
/// Steady frames before the measured one: a cold frame, then warm ones, so the quadratic start
/// has its three solutions.
const FRAMES: u32 = 4;

fn bake() -> QuadGraph {
    let shape = Shape::Torus {
        major: 17.5,
        minor: 7.5,
    };
    let params = BakeParams {
        resolution: 20,
        levels: 3,
        ..Default::default()
    };
    QuadGraph::bake(&shape.triangulate(40), &shape, &params, &mut |_| {})
        .expect("bake")
        .0
}

fn scene(turn_degrees: f64) -> Scene {
    let turn = DQuat::from_axis_angle(DVec3::Z, turn_degrees.to_radians());
    let light: Light = "dir:0.2,-0.35,1:5,5,5".parse().unwrap();
    Scene {
        lights: vec![light.rotated(turn)],
        environment: Environment::Constant([0.05; 3]),
    }
}

fn params(warm_start: WarmStart) -> GpuSolveParams {
    GpuSolveParams {
        tolerance: TOLERANCE,
        multigrid: Some(MultigridParams {
            warm_start,
            ..MultigridParams::gpu()
        }),
        ..Default::default()
    }
}

/// Uploads the finest level's q of `scene` and solves (cold or warm); J+ per surface node.
fn run_solve(
    ctx: &Context,
    gpu: &mut GpuDiffusion,
    graph: &QuadGraph,
    field: &MaterialField,
    scene: &Scene,
    warm: bool,
) -> (Vec<[f32; 3]>, GpuMultigridReport) {
    let top = graph.levels.len() - 1;
    let q: Vec<[f32; 3]> = scene
        .surface_irradiance(graph.finest(), field.eta(), None)
        .iter()
        .map(|v| v.map(|x| x as f32))
        .collect();
    if !warm {
        gpu.set_q_scale(GpuDiffusion::exposure_for(q.iter()));
    }
    gpu.upload_q(ctx, top, &q).expect("upload q");
    let (plan, _) = solve_once(ctx, gpu, warm);
    assert_eq!(plan.warm, warm, "the plan's start");
    let report = gpu
        .multigrid_report(ctx)
        .expect("report")
        .expect("the multigrid schedule");
    (gpu.read_j_plus(ctx).expect("J+"), report)
}

fn exact(graph: &QuadGraph, field: &MaterialField, scene: &Scene) -> Vec<[f64; 3]> {
    let s = solver::solve(graph, field, scene, None, &CpuSolveParams::default()).expect("exact");
    assert!(s.exact.as_ref().is_some_and(|e| e.converged));
    s.j_plus_clamped
}

/// Converged, finite, within the GPU tolerance of the exact solve; the relative error.
fn check(what: &str, j: &[[f32; 3]], exact: &[[f64; 3]], report: &GpuMultigridReport) -> f64 {
    let err = rel_rms(j, exact);
    println!(
        "{what}: order {}, start residual {:.2e}, {} cycles, {:.1} work units, residual {:.2e}, J+ vs exact {err:.2e}",
        report.warm_order,
        report.start_residual,
        report.cycles.len(),
        report.work_units,
        report.residual
    );
    assert!(
        j.iter().flatten().all(|v| v.is_finite()),
        "{what}: NaN in J+"
    );
    assert!(report.start_residual.is_finite(), "{what}: {report:?}");
    assert_eq!(report.state, CycleState::Converged, "{what}: {report:?}");
    assert!(report.residual < f64::from(TOLERANCE), "{what}: {report:?}");
    assert!(
        err <= tol::GPU_VS_EXACT,
        "{what}: J+ {err:.2e} from the exact solve"
    );
    err
}

/// Frames 0, 3, 6, 9 degrees (cold, then warm) with `warm_start`; the last frame's J+ and report,
/// and the orders the warm frames used.
fn steady_turn(
    ctx: &Context,
    graph: &QuadGraph,
    field: &MaterialField,
    warm_start: WarmStart,
) -> (Vec<[f32; 3]>, GpuMultigridReport, Vec<u32>) {
    let mut solve = GpuDiffusion::new(ctx, graph, field, &params(warm_start)).expect("solve");
    let mut orders = Vec::new();
    let mut last = None;
    for frame in 0..FRAMES {
        let (j, report) = run_solve(
            ctx,
            &mut solve,
            graph,
            field,
            &scene(STEP * f64::from(frame)),
            frame > 0,
        );
        assert_eq!(report.state, CycleState::Converged, "{report:?}");
        if frame > 0 {
            orders.push(report.warm_order);
        }
        last = Some((j, report));
    }
    let (j, report) = last.expect("frames");
    (j, report, orders)
}

#[test]
fn extrapolated_warm_start_reaches_the_same_error_in_fewer_work_units() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let graph = bake();
    let field = MaterialField::Homogeneous(Material::preset("marble").unwrap());
    let last_scene = scene(STEP * f64::from(FRAMES - 1));
    let exact = exact(&graph, &field, &last_scene);
    let mut fresh = GpuDiffusion::new(ctx, &graph, &field, &params(WarmStart::Linear)).unwrap();
    let (j_cold, cold) = run_solve(ctx, &mut fresh, &graph, &field, &last_scene, false);
    check("cold", &j_cold, &exact, &cold);
    drop(fresh);
    let mut runs = Vec::new();
    for warm_start in [WarmStart::Last, WarmStart::Linear, WarmStart::Quadratic] {
        let (j, report, orders) = steady_turn(ctx, &graph, &field, warm_start);
        check(&format!("{warm_start:?}, frame 3"), &j, &exact, &report);
        let cold64: Vec<[f64; 3]> = j_cold.iter().map(|v| v.map(f64::from)).collect();
        let diff = rel_rms(&j, &cold64);
        assert!(
            diff <= WARM_VS_COLD,
            "{warm_start:?}: {diff:.2e} from the cold J+"
        );
        // The first warm frame has one solution: every start falls back to it; then each
        // frame keeps one more, up to the start's history.
        let expected: Vec<u32> = (0..FRAMES - 1)
            .map(|k| k.min(warm_start.history()))
            .collect();
        assert_eq!(
            orders, expected,
            "{warm_start:?}: orders of the warm frames"
        );
        runs.push(report);
    }
    let (last, linear, quadratic) = (&runs[0], &runs[1], &runs[2]);
    for (name, r) in [("linear", linear), ("quadratic", quadratic)] {
        assert!(
            r.start_residual < last.start_residual,
            "{name} start residual {:.2e}, last solution's {:.2e}",
            r.start_residual,
            last.start_residual
        );
        assert!(
            r.work_units < last.work_units,
            "{name} {:.1} work units, last solution's {:.1}",
            r.work_units,
            last.work_units
        );
    }
    assert!(
        linear.work_units < cold.work_units,
        "linear {:.1} work units, cold {:.1}",
        linear.work_units,
        cold.work_units
    );
    gpu.finish();
}

/// Steady frames, then the light jumps 60 degrees: the extrapolation through the kept solutions
/// points the wrong way, and the solve still converges to the exact solve of the new frame.
#[test]
fn a_light_jump_after_steady_frames_still_converges() {
    /// Degrees of the jump: far beyond a frame's step.
    const JUMP: f64 = 60.0;
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let graph = bake();
    let field = MaterialField::Homogeneous(Material::preset("marble").unwrap());
    let mut solve =
        GpuDiffusion::new(ctx, &graph, &field, &params(WarmStart::Quadratic)).expect("solve");
    for frame in 0..FRAMES {
        let warm = frame > 0;
        let s = scene(STEP * f64::from(frame));
        run_solve(ctx, &mut solve, &graph, &field, &s, warm);
    }
    let jumped = scene(JUMP);
    let (j, report) = run_solve(ctx, &mut solve, &graph, &field, &jumped, true);
    assert_eq!(report.warm_order, 2, "{report:?}");
    check(
        "quadratic, light jump",
        &j,
        &exact(&graph, &field, &jumped),
        &report,
    );
    drop(solve);
    gpu.finish();
}
