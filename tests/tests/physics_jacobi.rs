//! Jacobi (paper Eqs. 8/9, DESIGN's fv update) against the exact solve of the same system, and the
//! multi-level initialisation of paper section 4.3 against a single level.

use glam::DVec3;
use translucent::material::{Material, MaterialField};
use translucent::scene::{Environment, Scene};
use translucent::solver::{self, CpuSolveParams, Scheme};
use translucent::tet::structured::nearest_shepard_links;
use translucent::tet::TetMesh;
use translucent::{GraphLevel, QuadGraph};

fn level(n: usize) -> GraphLevel {
    let tets = TetMesh::bcc_box(DVec3::splat(-8.0), DVec3::splat(8.0), [n, n, n]);
    GraphLevel::from_tets(tets, 16.0 / n as f64, |c, nrm| (c, nrm))
}

fn two_levels() -> QuadGraph {
    let coarse = level(4);
    let mut fine = level(8);
    fine.from_coarser = Some(nearest_shepard_links(&coarse, &fine));
    QuadGraph {
        levels: vec![coarse, fine],
        ..Default::default()
    }
}

fn scene() -> Scene {
    Scene {
        lights: vec![
            "dir:-0.3,-1,0.2:1,1,1".parse().unwrap(),
            "point:20,5,0:400,300,200".parse().unwrap(),
        ],
        environment: Environment::Constant([0.05; 3]),
    }
}

fn max_rel_diff(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    let scale = b.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    a.iter()
        .flatten()
        .zip(b.iter().flatten())
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
        / scale
}

#[test]
fn jacobi_converges_to_the_exact_solve() {
    let fine = QuadGraph {
        levels: vec![level(8)],
        ..Default::default()
    };
    let field = MaterialField::Homogeneous(Material::preset("skin2").unwrap());
    for scheme in [Scheme::Fv, Scheme::Paper] {
        let exact = solver::solve(
            &fine,
            &field,
            &scene(),
            None,
            &CpuSolveParams {
                scheme,
                iterations: vec![0],
                ..Default::default()
            },
        )
        .unwrap();
        assert!(
            exact.exact.unwrap().converged,
            "{scheme:?}: {:?}",
            exact.exact
        );
        let mut diffs = Vec::new();
        for iterations in [25, 100, 400, 1600, 6400] {
            let params = CpuSolveParams {
                scheme,
                iterations: vec![iterations],
                tolerance: 0.0,
                exact: false,
                ..Default::default()
            };
            let sol = solver::solve(&fine, &field, &scene(), None, &params).unwrap();
            // Jacobi stops early only at an exact fixed point (an update of exactly zero).
            let run = sol.levels[0].jacobi_iterations;
            assert!(
                run == iterations
                    || (run < iterations && sol.levels[0].jacobi_error_estimate == Some(0.0))
            );
            diffs.push(max_rel_diff(&sol.phi, &exact.phi));
        }
        println!("{scheme:?}: relative difference to the exact solve after 25..6400 iterations: {diffs:?}");
        // Once Jacobi has converged, the difference is the exact solve's own error: its
        // residual tolerance (1e-10, BiCGSTAB for `paper`) leaves ~1e-10 in phi, not 1e-12.
        let floor = 1e-9;
        assert!(
            diffs.windows(2).all(|w| w[1] < w[0] || w[1] < floor),
            "{scheme:?}: {diffs:?}"
        );
        assert!(diffs[diffs.len() - 1] < 1e-6, "{scheme:?}: {diffs:?}");
    }
}

#[test]
fn multi_level_needs_fewer_fine_iterations_than_single_level() {
    let graph = two_levels();
    let single = QuadGraph {
        levels: vec![graph.levels[1].clone()],
        ..Default::default()
    };
    let field = MaterialField::Homogeneous(Material::preset("marble").unwrap());
    let exact = solver::solve(
        &single,
        &field,
        &scene(),
        None,
        &CpuSolveParams {
            iterations: vec![0],
            ..Default::default()
        },
    )
    .unwrap();
    let params = CpuSolveParams {
        iterations: vec![200_000],
        tolerance: 1e-4,
        exact: false,
        ..Default::default()
    };
    let one = solver::solve(&single, &field, &scene(), None, &params).unwrap();
    let multi = solver::solve(&graph, &field, &scene(), None, &params).unwrap();
    let (n1, n2) = (
        one.levels[0].jacobi_iterations,
        multi.levels[1].jacobi_iterations,
    );
    let (e1, e2) = (
        max_rel_diff(&one.phi, &exact.phi),
        max_rel_diff(&multi.phi, &exact.phi),
    );
    println!(
        "fine-level iterations to 1e-4: single level {n1} (error {e1:.1e}), two levels {n2} after {} coarse (error {e2:.1e})",
        multi.levels[0].jacobi_iterations
    );
    assert!(n2 < n1, "multi-level {n2} vs single-level {n1}");
    // The stopping rule's error estimate is honest to within a small factor.
    assert!(e1 < 1e-3 && e2 < 1e-3, "{e1} {e2}");
}

/// A warm start (last frame's phi as the initial guess, DESIGN section 5): an unchanged scene needs
/// no work, a slightly changed one fewer Jacobi iterations than a cold start.
#[test]
fn warm_start_from_the_last_frame() {
    let fine = QuadGraph {
        levels: vec![level(8)],
        ..Default::default()
    };
    let field = MaterialField::Homogeneous(Material::preset("skin2").unwrap());
    let first = solver::solve(
        &fine,
        &field,
        &scene(),
        None,
        &CpuSolveParams {
            iterations: vec![0],
            ..Default::default()
        },
    )
    .unwrap();
    let again = CpuSolveParams {
        iterations: vec![0],
        initial: Some(first.phi.clone()),
        ..Default::default()
    };
    let same = solver::solve(&fine, &field, &scene(), None, &again).unwrap();
    assert!(same.exact.unwrap().iterations <= 1, "{:?}", same.exact);
    let mut moved = scene();
    moved.lights[0] = "dir:-0.25,-1,0.2:1,1,1".parse().unwrap();
    let jacobi = |initial: Option<Vec<[f64; 3]>>| {
        let params = CpuSolveParams {
            iterations: vec![100_000],
            tolerance: 1e-5,
            exact: false,
            initial,
            ..Default::default()
        };
        solver::solve(&fine, &field, &moved, None, &params)
            .unwrap()
            .levels[0]
            .jacobi_iterations
    };
    let (cold, warm) = (jacobi(None), jacobi(Some(first.phi.clone())));
    println!("Jacobi iterations to 1e-5 after a small light move: cold {cold}, warm {warm}");
    assert!(warm < cold, "warm {warm} vs cold {cold}");
}
