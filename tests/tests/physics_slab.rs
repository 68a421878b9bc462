//! A wide thin box (100 x 100 x 10 mm, skim milk) lit uniformly from above: the transmittance in the
//! centre of its far face against the slab formula of DESIGN section 2.
//!
//! Fixture: `TetMesh::bcc_slab`, a BCC lattice whose tetrahedron faces tile the slab's faces exactly
//! (no cut tetrahedra), surface nodes at the face centroids.

use glam::DVec3;
use translucent::material::{fresnel, Material, MaterialField};
use translucent::scene::{Environment, Scene};
use translucent::solver::analytic::Homogeneous;
use translucent::solver::{self, CpuSolution, CpuSolveParams, Scheme};
use translucent::tet::TetMesh;
use translucent::{GraphLevel, QuadGraph};

fn slab(layers: usize) -> QuadGraph {
    let spacing = 10.0 * std::f64::consts::SQRT_2 / layers as f64;
    let level = GraphLevel::from_tets(TetMesh::bcc_slab(50.0, 10.0, layers), spacing, |c, n| {
        (c, n)
    });
    QuadGraph {
        levels: vec![level],
        ..Default::default()
    }
}

/// Area-weighted mean of (1 - F_dr) J+ / q_top over the bottom face within 5 mm of the axis.
fn centre_transmittance(graph: &QuadGraph, sol: &CpuSolution, f_dr: f64, q_top: f64) -> [f64; 3] {
    let level = graph.finest();
    let inner = level.inner_count();
    let (mut acc, mut area) = ([0.0; 3], 0.0);
    for s in 0..level.surface_count() {
        let p: DVec3 = level.positions[inner + s];
        if level.surface_normals[s].y < -0.999 && p.x.hypot(p.z) < 5.0 {
            let a = sol.operator.areas[s];
            area += a;
            for (c, t) in acc.iter_mut().enumerate() {
                *t += (1.0 - f_dr) * sol.j_plus[s][c] * a / q_top;
            }
        }
    }
    assert!(area > 0.0, "no bottom surface nodes near the axis");
    acc.map(|v| v / area)
}

#[test]
fn skim_milk_slab_transmittance_matches_the_slab_formula() {
    let milk = Material::preset("skimmilk").unwrap();
    let field = MaterialField::Homogeneous(milk);
    let scene = Scene {
        lights: vec!["dir:0,-1,0:2,2,2".parse().unwrap()],
        environment: Environment::None,
    };
    let q_top = 2.0 * fresnel::transmittance(milk.eta, 1.0);
    let exact: [f64; 3] =
        std::array::from_fn(|c| Homogeneous::channel(&milk, c).slab_transmittance(10.0));
    assert!((exact[0] - 0.2090).abs() < 1e-4);
    let mut errors = Vec::new();
    for layers in [4, 6] {
        let graph = slab(layers);
        let mut report = String::new();
        for scheme in [Scheme::Fv, Scheme::Paper] {
            let params = CpuSolveParams {
                scheme,
                iterations: vec![0],
                ..Default::default()
            };
            let sol = solver::solve(&graph, &field, &scene, None, &params).unwrap();
            assert!(sol.exact.unwrap().converged && sol.residual.iter().all(|&r| r < 1e-9));
            let t = centre_transmittance(&graph, &sol, milk.f_dr(), q_top);
            let err: [f64; 3] = std::array::from_fn(|c| t[c] / exact[c] - 1.0);
            report += &format!("{layers} layers {scheme:?}: T = {t:.4?}, exact {exact:.4?}, rel. error {err:.4?}\n");
            if scheme == Scheme::Fv {
                // The brief asks for 3%; the fv scheme on this fixture is within 0.5%.
                assert!(err.iter().all(|e| e.abs() < 0.005), "{report}");
                errors.push(err.iter().fold(0.0f64, |m, e| m.max(e.abs())));
            }
        }
        print!("{report}");
    }
    assert!(
        errors[1] < errors[0],
        "fv error does not shrink under refinement: {errors:?}"
    );
}
