//! The CPU multigrid (`solver::multigrid`, DESIGN section 5.1) on baked QuadGraph levels: it
//! reaches the exact solve of the same system, a V-cycle reduces the residual by a bounded factor
//! (homogeneous and 1e4 material contrast, both coarse operators), a warm start after a 3 degree
//! light turn costs less than a cold full multigrid, extreme sizes converge without NaN, and bad
//! parameters are typed errors.

use glam::DQuat;
use translucent::material::{Material, MaterialField};
use translucent::mesh::shapes::Shape;
use translucent::quadgraph::BakeParams;
use translucent::scene::{Environment, Light, Scene};
use translucent::solver::multigrid::{
    CoarseOperator, Hierarchy, Interpolation, MultigridParams, MultigridReport, Start,
};
use translucent::solver::{self, CpuSolveParams, Schedule, Scheme, SolverError};
use translucent::QuadGraph;
use translucent_tests::kappa_contrast_field;

/// Multigrid and cascade + PCG both stop at relative residual 1e-10 (`exact_tolerance`); their J+
/// differ by that residual times the system's condition number (~1e4 here), with margin.
const MG_VS_EXACT: f64 = 1e-5;
/// The geometric mean of the cycles' residual reduction must be below this. Measured on this
/// graph: 0.52 plain V-cycles, 0.21 with CG; a broken restriction gives ~0.95 or diverges.
const MAX_MEAN_FACTOR: f64 = 0.7;
/// The 1e4 contrast (Galerkin: 0.60 V-cycles, 0.28 with CG) and the extreme sizes (0.24, 0.01).
const MAX_MEAN_FACTOR_CONTRAST: f64 = 0.85;
/// A warm start 3 degrees from the last solution must cost at most this share of a cold solve's
/// work units (measured 44 against 67: 0.66; equal work means the warm start is ignored).
const MAX_WARM_SHARE: f64 = 0.8;
/// Relative residual the convergence tests solve to.
const TOLERANCE: f64 = 1e-6;

fn torus(size: f64) -> Shape {
    Shape::Torus {
        major: 0.35 * size,
        minor: 0.15 * size,
    }
}

fn bake(shape: &Shape) -> QuadGraph {
    let params = BakeParams {
        resolution: 24,
        levels: 3,
        ..Default::default()
    };
    QuadGraph::bake(&shape.triangulate(48), shape, &params, &mut |_| {})
        .expect("bake")
        .0
}

fn lights() -> Vec<Light> {
    vec![
        "dir:0.2,-0.35,1:5,5,5".parse().unwrap(),
        "dir:-0.6,-0.7,-0.4:0.6,0.6,0.6".parse().unwrap(),
    ]
}

fn scene() -> Scene {
    Scene {
        lights: lights(),
        environment: Environment::Constant([0.05; 3]),
    }
}

fn skimmilk() -> MaterialField {
    MaterialField::Homogeneous(Material::preset("skimmilk").unwrap())
}

fn solve_mg(
    graph: &QuadGraph,
    field: &MaterialField,
    scene: &Scene,
    params: &MultigridParams,
    start: Start,
) -> (Vec<[f64; 3]>, MultigridReport) {
    let mg = Hierarchy::build(graph, field, Scheme::Fv, params).expect("hierarchy");
    let q = scene.surface_irradiance(graph.finest(), field.eta(), None);
    let f = mg.scaled_rhs(&q);
    mg.solve(&f, start, params, &mut |_, _| {})
}

fn check_converged(what: &str, report: &MultigridReport, max_factor: f64) {
    let factors: Vec<f64> = report.cycles.iter().map(|c| c.factor).collect();
    println!(
        "{what}: {} cycles, {:.1} work units, mean factor {:?}, factors {factors:.3?}",
        report.cycles.len(),
        report.work_units,
        report.mean_factor
    );
    assert!(
        report.converged && report.residual < TOLERANCE,
        "{what}: residual {:.2e} after {} cycles",
        report.residual,
        report.cycles.len()
    );
    let mean = report.mean_factor.expect("at least two V-cycles");
    assert!(
        mean < max_factor,
        "{what}: mean factor per cycle {mean:.3} >= {max_factor}"
    );
    assert!(report.cycles.iter().all(|c| c.residual.is_finite()));
}

#[test]
fn multigrid_reaches_the_exact_solve() {
    let graph = bake(&torus(50.0));
    let field = skimmilk();
    let exact = solver::solve(&graph, &field, &scene(), None, &CpuSolveParams::default()).unwrap();
    assert!(exact.exact.as_ref().unwrap().converged);
    let mg = solver::solve(
        &graph,
        &field,
        &scene(),
        None,
        &CpuSolveParams {
            schedule: Schedule::Multigrid(MultigridParams::default()),
            ..CpuSolveParams::default()
        },
    )
    .unwrap();
    let report = mg.multigrid.as_ref().expect("a multigrid report");
    assert!(report.converged, "{report:?}");
    let err = solver::rel_rms(&mg.j_plus, &exact.j_plus);
    println!(
        "multigrid vs cascade + PCG: J+ {err:.2e}, {} cycles, {:.1} work units",
        report.cycles.len(),
        report.work_units
    );
    assert!(err < MG_VS_EXACT, "J+ {err:.2e} from the exact solve");
    assert!(solver::rel_rms(&mg.phi, &exact.phi) < MG_VS_EXACT);
}

#[test]
fn a_cycle_reduces_the_residual_by_a_bounded_factor() {
    let graph = bake(&torus(50.0));
    for krylov in [false, true] {
        let params = MultigridParams {
            tolerance: TOLERANCE,
            krylov,
            ..MultigridParams::default()
        };
        let (phi, report) = solve_mg(&graph, &skimmilk(), &scene(), &params, Start::Cold);
        check_converged(
            &format!("skim milk, krylov {krylov}"),
            &report,
            MAX_MEAN_FACTOR,
        );
        assert!(phi.iter().flatten().all(|v| v.is_finite()));
    }
}

#[test]
fn contrast_1e4_converges_with_the_galerkin_coarse_operator() {
    let graph = bake(&torus(50.0));
    for krylov in [false, true] {
        let params = MultigridParams {
            tolerance: TOLERANCE,
            coarse: CoarseOperator::Galerkin,
            krylov,
            max_cycles: 200,
            ..MultigridParams::default()
        };
        let (phi, report) = solve_mg(
            &graph,
            &kappa_contrast_field(),
            &scene(),
            &params,
            Start::Cold,
        );
        check_converged(
            &format!("1e4 contrast, Galerkin, krylov {krylov}"),
            &report,
            MAX_MEAN_FACTOR_CONTRAST,
        );
        assert!(phi.iter().flatten().all(|v| v.is_finite()));
    }
}

#[test]
fn a_diverging_schedule_is_an_error_not_a_nan() {
    // The re-discretized coarse operator diverges on this contrast (measured, RESULTS.md): the
    // solve must end with a typed error (or, should it converge one day, finite values).
    let graph = bake(&torus(50.0));
    let params = MultigridParams {
        coarse: CoarseOperator::Rediscretized,
        krylov: false,
        max_cycles: 60,
        ..MultigridParams::default()
    };
    let result = solver::solve(
        &graph,
        &kappa_contrast_field(),
        &scene(),
        None,
        &CpuSolveParams {
            schedule: Schedule::Multigrid(params),
            ..CpuSolveParams::default()
        },
    );
    match result {
        Ok(sol) => {
            assert!(sol
                .phi
                .iter()
                .chain(&sol.j_plus)
                .flatten()
                .all(|v| v.is_finite()));
            println!(
                "re-discretized converged: {:?}",
                sol.multigrid.map(|m| m.residual)
            );
        }
        Err(e) => {
            println!("re-discretized: {e}");
            assert!(
                matches!(
                    e,
                    SolverError::NonFinite { .. } | SolverError::Diverged { .. }
                ),
                "{e}"
            );
        }
    }
}

#[test]
fn tiny_and_huge_objects_converge() {
    for size in [1.0, 1e4] {
        let graph = bake(&torus(size));
        let params = MultigridParams {
            tolerance: TOLERANCE,
            max_cycles: 200,
            ..MultigridParams::default()
        };
        let (phi, report) = solve_mg(&graph, &skimmilk(), &scene(), &params, Start::Cold);
        check_converged(
            &format!("{size} mm torus"),
            &report,
            MAX_MEAN_FACTOR_CONTRAST,
        );
        assert!(phi.iter().flatten().all(|v| v.is_finite()));
    }
}

#[test]
fn warm_start_costs_less_than_a_cold_solve() {
    let graph = bake(&torus(50.0));
    let field = skimmilk();
    let params = MultigridParams {
        tolerance: 1e-4,
        ..MultigridParams::default()
    };
    let (previous, _) = solve_mg(&graph, &field, &scene(), &params, Start::Cold);
    let turn = DQuat::from_rotation_y(3f64.to_radians());
    let turned = Scene {
        lights: lights().iter().map(|l| l.rotated(turn)).collect(),
        environment: Environment::Constant([0.05; 3]),
    };
    let (_, warm) = solve_mg(&graph, &field, &turned, &params, Start::Warm(&previous));
    let (_, cold) = solve_mg(&graph, &field, &turned, &params, Start::Cold);
    println!(
        "3 degrees: warm {} cycles {:.1} WU, cold {} cycles {:.1} WU",
        warm.cycles.len(),
        warm.work_units,
        cold.cycles.len(),
        cold.work_units
    );
    assert!(warm.converged && cold.converged);
    assert!(
        warm.work_units < MAX_WARM_SHARE * cold.work_units,
        "warm {:.1} WU against cold {:.1}",
        warm.work_units,
        cold.work_units
    );
}

#[test]
fn bad_parameters_are_typed_errors() {
    let graph = bake(&torus(50.0));
    let field = skimmilk();
    for params in [
        MultigridParams {
            pre_sweeps: 0,
            post_sweeps: 0,
            ..MultigridParams::default()
        },
        MultigridParams {
            tolerance: f64::NAN,
            ..MultigridParams::default()
        },
        MultigridParams {
            coarse_tolerance: 1.5,
            ..MultigridParams::default()
        },
    ] {
        let err = Hierarchy::build(&graph, &field, Scheme::Fv, &params).unwrap_err();
        assert!(matches!(err, SolverError::BadParameter { .. }), "{err}");
    }
    // A warm start of the wrong length names the problem.
    let err = solver::solve(
        &graph,
        &field,
        &scene(),
        None,
        &CpuSolveParams {
            schedule: Schedule::Multigrid(MultigridParams::default()),
            initial: Some(vec![[0.0; 3]; 7]),
            ..CpuSolveParams::default()
        },
    )
    .unwrap_err();
    assert!(
        matches!(
            err,
            SolverError::BadParameter {
                name: "initial",
                ..
            }
        ),
        "{err}"
    );
}

/// Chebyshev-accelerated block Jacobi (degree 2 per side) must beat damped block Jacobi (omega
/// 0.8, 2 sweeps per side, the same work) per V-cycle by at least this ratio of mean factors.
/// Measured on this graph: 0.525 against 0.578 (0.91); a wrong bound or coefficient makes it
/// equal, worse or divergent.
const CHEBYSHEV_OVER_JACOBI: f64 = 0.95;

#[test]
fn chebyshev_smoother_reduces_more_per_cycle_than_damped_jacobi() {
    let graph = bake(&torus(50.0));
    let run = |params: MultigridParams| {
        let params = MultigridParams {
            tolerance: TOLERANCE,
            krylov: false,
            max_cycles: 300,
            ..params
        };
        let (phi, report) = solve_mg(&graph, &skimmilk(), &scene(), &params, Start::Cold);
        assert!(phi.iter().flatten().all(|v| v.is_finite()));
        report
    };
    let jacobi = run(MultigridParams::default()
        .with_cycle_spec("jacobi=0.8")
        .unwrap());
    let chebyshev = run(MultigridParams::default());
    let cubic = run(MultigridParams::default()
        .with_cycle_spec("nu=3/3")
        .unwrap());
    check_converged("damped Jacobi 0.8, 2+2", &jacobi, 1.0);
    check_converged("Chebyshev degree 2+2", &chebyshev, MAX_MEAN_FACTOR);
    check_converged("Chebyshev degree 3+3", &cubic, MAX_MEAN_FACTOR);
    let (j, c, c3) = (
        jacobi.mean_factor.unwrap(),
        chebyshev.mean_factor.unwrap(),
        cubic.mean_factor.unwrap(),
    );
    assert!(
        c < CHEBYSHEV_OVER_JACOBI * j,
        "Chebyshev {c:.3} against damped Jacobi {j:.3} per cycle"
    );
    assert!(
        c3 < c,
        "degree 3 ({c3:.3}) must reduce more than degree 2 ({c:.3})"
    );
}

#[test]
fn more_full_multigrid_cycles_per_level_start_closer() {
    let graph = bake(&torus(50.0));
    let start = |fmg: u32| {
        let params = MultigridParams {
            fmg_cycles: fmg,
            max_cycles: 1,
            ..MultigridParams::default()
        };
        let (_, report) = solve_mg(&graph, &skimmilk(), &scene(), &params, Start::Cold);
        report.cycles[0]
    };
    let (one, two) = (start(1), start(2));
    println!("full multigrid start: 1 cycle per level {one:?}, 2 cycles {two:?}");
    assert!(two.residual < one.residual, "{two:?} against {one:?}");
    assert!(two.work_units > one.work_units);
}

#[test]
fn a_bad_cycle_spec_is_a_typed_error() {
    for spec in [
        "nu=3",
        "nu=0/0",
        "cheb=1.5",
        "jacobi=2",
        "fmg=0",
        "krylov=2",
        "speed=9",
        "nu",
        "interp=cubic",
        "psmooth=1",
        "psmooth=2.5/1",
        "psmooth=1/99",
        "fnu=1",
        "fnu=99/1",
    ] {
        let err = MultigridParams::gpu().with_cycle_spec(spec).unwrap_err();
        assert!(
            matches!(err, SolverError::BadParameter { .. }),
            "{spec}: {err}"
        );
    }
    let p = MultigridParams::gpu()
        .with_cycle_spec(" nu=3/1, cnu=2, cheb=0.1, ctol=0.2, fmg=2, krylov=0 ")
        .unwrap();
    assert_eq!(
        (p.pre_sweeps, p.post_sweeps, p.coarse_sweeps),
        (3, 1, Some(2))
    );
    assert_eq!(
        (p.fmg_cycles, p.krylov, p.coarse_tolerance),
        (2, false, 0.2)
    );
    let p = MultigridParams::gpu()
        .with_cycle_spec("interp=shepard,psmooth=0.5/2,fnu=1/3")
        .unwrap();
    assert_eq!(p.interpolation, Interpolation::Shepard);
    assert_eq!(
        (p.pattern_smoothing, p.fmg_sweeps),
        (Some((0.5, 2)), Some((1, 3)))
    );
}

/// The GPU cycle's interpolation (mixed links, linear weights, one pattern-restricted Jacobi
/// step) against the bake's Shepard weights, plain V-cycles with the GPU's smoother: measured on
/// this graph 0.178 against 0.274 per cycle (0.65), 7 against 9 cycles; the bound leaves room
/// for rounding, not for losing most of the gain.
const PATTERN_SMOOTHED_OVER_SHEPARD: f64 = 0.8;
/// Row sums of the prolongation kept by the pattern smoothing (f64 rounding of 8 weights).
const ROW_SUM_KEPT: f64 = 1e-12;

#[test]
fn pattern_smoothed_interpolation_keeps_links_and_constants_and_reduces_more_per_cycle() {
    let graph = bake(&torus(50.0));
    let gpu = MultigridParams {
        tolerance: TOLERANCE,
        krylov: false,
        max_cycles: 300,
        ..MultigridParams::gpu()
    };
    let unsmoothed = MultigridParams {
        pattern_smoothing: None,
        ..gpu.clone()
    };
    let shepard = MultigridParams {
        interpolation: Interpolation::Shepard,
        ..unsmoothed.clone()
    };
    let field = skimmilk();
    let smoothed_h = Hierarchy::build(&graph, &field, Scheme::Fv, &gpu).unwrap();
    let plain_h = Hierarchy::build(&graph, &field, Scheme::Fv, &unsmoothed).unwrap();
    for (l, (a, b)) in smoothed_h.levels.iter().zip(&plain_h.levels).enumerate() {
        let (Some(a), Some(b)) = (&a.prolongation, &b.prolongation) else {
            continue;
        };
        assert_eq!(a.links, b.links, "level {l}: the links must not move");
        assert_ne!(a.weights, b.weights, "level {l}: the weights must move");
        for (i, (wa, wb)) in a.weights.iter().zip(&b.weights).enumerate() {
            let (sa, sb): (f64, f64) = (wa.iter().sum(), wb.iter().sum());
            assert!(
                (sa - sb).abs() < ROW_SUM_KEPT,
                "level {l} node {i}: row sum {sa} against {sb}"
            );
        }
    }
    let run = |params: &MultigridParams| {
        let (phi, report) = solve_mg(&graph, &field, &scene(), params, Start::Cold);
        assert!(phi.iter().flatten().all(|v| v.is_finite()));
        report
    };
    let (smoothed, shepard) = (run(&gpu), run(&shepard));
    check_converged("mixed + pattern-smoothed", &smoothed, MAX_MEAN_FACTOR);
    check_converged("Shepard", &shepard, MAX_MEAN_FACTOR);
    let (a, b) = (smoothed.mean_factor.unwrap(), shepard.mean_factor.unwrap());
    assert!(
        a < PATTERN_SMOOTHED_OVER_SHEPARD * b,
        "pattern-smoothed {a:.3} against Shepard {b:.3} per cycle"
    );
}
