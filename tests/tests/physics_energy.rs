//! Conservation checks of DESIGN section 2 on exact box geometry with heterogeneous kappa:
//! - sigma_a = 0 and uniform q: phi = 4q/(1 - F_dr) at every node, for any kappa(x), exactly;
//!   exitance equals the transmitted input;
//! - a directional light on a heterogeneous field: transmitted_input = exitance + absorbed, and with
//!   sigma_a = 0, exitance = transmitted input.

use glam::DVec3;
use translucent::material::{Coefficients, Material, MaterialField, Procedural};
use translucent::scene::{Environment, Scene};
use translucent::solver::{self, CpuSolveParams};
use translucent::tet::TetMesh;
use translucent::{GraphLevel, QuadGraph};

fn box_graph() -> QuadGraph {
    let tets = TetMesh::bcc_box(
        DVec3::new(-8.0, -5.0, -6.0),
        DVec3::new(8.0, 5.0, 6.0),
        [8, 5, 6],
    );
    QuadGraph {
        levels: vec![GraphLevel::from_tets(tets, 2.0, |c, n| (c, n))],
        ..Default::default()
    }
}

/// Agate bands of strongly different sigma_s' (kappa contrast 40x), no absorption.
fn banded_field(sigma_a: [f64; 3]) -> MaterialField {
    let a = Coefficients::new([0.5, 1.0, 2.0], sigma_a).unwrap();
    let b = Coefficients::new([20.0, 10.0, 5.0], sigma_a).unwrap();
    MaterialField::procedural(
        Procedural::Agate {
            a,
            b,
            band_mm: 3.0,
            warp: 0.5,
            seed: 9,
        },
        1.4,
    )
    .unwrap()
}

#[test]
fn no_absorption_uniform_light_gives_constant_phi_for_any_kappa() {
    let graph = box_graph();
    let field = banded_field([0.0; 3]);
    let scene = Scene {
        lights: vec![],
        environment: Environment::Constant([0.5, 1.0, 2.0]),
    };
    let sol = solver::solve(&graph, &field, &scene, None, &CpuSolveParams::default()).unwrap();
    let f_dr = sol.operator.f_dr;
    let q = sol.q[0];
    assert!(
        sol.q.iter().all(|qs| qs == &q),
        "a constant environment gives uniform q"
    );
    let expected = q.map(|v| 4.0 * v / (1.0 - f_dr));
    let mut worst: f64 = 0.0;
    for phi in &sol.phi {
        for c in 0..3 {
            worst = worst.max((phi[c] / expected[c] - 1.0).abs());
        }
    }
    assert!(worst < 1e-8, "phi departs from 4q/(1 - F_dr) by {worst:e}");
    let e = sol.energy;
    for c in 0..3 {
        assert!(
            (e.exitance[c] / e.transmitted_input[c] - 1.0).abs() < 1e-8,
            "{e:?}"
        );
        assert_eq!(e.absorbed[c], 0.0);
    }
}

#[test]
fn energy_balances_under_a_directional_light_on_heterogeneous_kappa() {
    let graph = box_graph();
    let scene = Scene {
        lights: vec!["dir:-1,-2,-0.5:3,2,1".parse().unwrap()],
        environment: Environment::None,
    };
    for sigma_a in [[0.0; 3], [0.01, 0.05, 0.2]] {
        let field = banded_field(sigma_a);
        let sol = solver::solve(&graph, &field, &scene, None, &CpuSolveParams::default()).unwrap();
        let e = sol.energy;
        for c in 0..3 {
            assert!(e.transmitted_input[c] > 0.0);
            let balance = (e.exitance[c] + e.absorbed[c]) / e.transmitted_input[c] - 1.0;
            // The brief asks for 0.5%; fv conserves energy to the solver's residual.
            assert!(
                balance.abs() < 1e-7,
                "sigma_a {sigma_a:?} channel {c}: {e:?}"
            );
            if sigma_a[c] == 0.0 {
                assert!((e.exitance[c] / e.transmitted_input[c] - 1.0).abs() < 0.005);
            } else {
                assert!(e.absorbed[c] > 0.01 * e.transmitted_input[c]);
            }
        }
        assert!(sol
            .phi
            .iter()
            .flatten()
            .all(|v| v.is_finite() && *v >= -1e-12));
    }
}

#[test]
fn homogeneous_and_procedural_fields_agree_when_the_materials_do() {
    let graph = box_graph();
    let m = Material::preset("potato").unwrap();
    let c = m.coefficients();
    let split = MaterialField::procedural(
        Procedural::Split {
            normal: DVec3::X,
            offset: 0.0,
            below: c,
            above: c,
        },
        m.eta,
    )
    .unwrap();
    let scene = Scene {
        lights: vec!["dir:0,-1,0:1,1,1".parse().unwrap()],
        environment: Environment::None,
    };
    let a = solver::solve(
        &graph,
        &MaterialField::Homogeneous(m),
        &scene,
        None,
        &CpuSolveParams::default(),
    )
    .unwrap();
    let b = solver::solve(&graph, &split, &scene, None, &CpuSolveParams::default()).unwrap();
    // Equal up to the order of parallel reductions.
    for (x, y) in a.phi.iter().zip(&b.phi) {
        for c in 0..3 {
            assert!(
                (x[c] - y[c]).abs() <= 1e-9 * x[c].abs().max(1e-12),
                "{x:?} vs {y:?}"
            );
        }
    }
}

/// End to end on a baked, non-convex shape: a `.vol` grid material (through a file), a directional
/// light shadowed by the torus itself, three levels: energy balances, nothing is NaN.
#[test]
fn vol_material_on_a_baked_torus_with_self_shadowing_balances() {
    use translucent::material::VolGrid;
    use translucent::mesh::shapes::Shape;
    use translucent::quadgraph::BakeParams;
    let torus = Shape::Torus {
        major: 10.0,
        minor: 4.0,
    };
    let params = BakeParams {
        resolution: 24,
        levels: 2,
        ..Default::default()
    };
    let graph = QuadGraph::bake(&torus.triangulate(48), &torus, &params, &mut |_| {})
        .unwrap()
        .0;
    let grid = VolGrid::from_fn(
        [8, 4, 8],
        DVec3::new(-14.0, -4.0, -14.0),
        DVec3::new(14.0, 4.0, 14.0),
        |p| {
            let t = 0.5 + 0.5 * (p.x * 0.4).sin() * (p.z * 0.3).cos();
            ([0.5 + 4.0 * t, 1.0, 2.0 - t], [0.002 + 0.05 * t, 0.01, 0.0])
        },
    )
    .unwrap();
    let path = std::env::temp_dir().join(format!(
        "translucent-physics-torus-{}.vol",
        std::process::id()
    ));
    grid.write(&path).unwrap();
    let field = MaterialField::grid(VolGrid::read(&path).unwrap(), 1.3).unwrap();
    std::fs::remove_file(&path).unwrap();
    // Light travelling along +x, slightly down: the ring shadows part of itself.
    let scene = Scene {
        lights: vec!["dir:1,-0.3,0:2,2,2".parse().unwrap()],
        environment: Environment::None,
    };
    let params = CpuSolveParams {
        iterations: vec![300, 100],
        ..Default::default()
    };
    let shadowed = solver::solve(&graph, &field, &scene, Some(&torus), &params).unwrap();
    let open = solver::solve(&graph, &field, &scene, None, &params).unwrap();
    let (es, eo) = (shadowed.energy, open.energy);
    assert!(
        es.transmitted_input[0] < 0.95 * eo.transmitted_input[0],
        "no self-shadowing: {es:?} vs {eo:?}"
    );
    for e in [es, eo] {
        for c in 0..3 {
            let balance = (e.exitance[c] + e.absorbed[c]) / e.transmitted_input[c] - 1.0;
            assert!(balance.abs() < 1e-7, "channel {c}: {e:?}");
        }
        assert_eq!(e.absorbed[2], 0.0);
    }
    assert!(shadowed.phi.iter().flatten().all(|v| v.is_finite()));
    assert_eq!(shadowed.levels.len(), 2);
    assert_eq!(shadowed.vertex_j_plus.len(), graph.surface.positions.len());
}
