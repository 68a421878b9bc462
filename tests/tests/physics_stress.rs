//! Numerical stress and bad input for the CPU solver (DESIGN section 9): extreme coefficients, tiny
//! and huge objects, very bright and very dim lights: no NaN or Inf ever; malformed graphs, scenes and
//! parameters are typed errors.

use glam::DVec3;
use translucent::material::{Coefficients, Material, MaterialField, Procedural};
use translucent::quadgraph::graph::{ShadingWeights, ShepardLinks, NO_NODE};
use translucent::scene::{self, Environment, Scene};
use translucent::solver::{self, CpuSolution, CpuSolveParams, Scheme, SolverError};
use translucent::tet::TetMesh;
use translucent::{GraphLevel, QuadGraph};

fn cube(half: f64, n: usize) -> QuadGraph {
    let tets = TetMesh::bcc_box(DVec3::splat(-half), DVec3::splat(half), [n, n, n]);
    QuadGraph {
        levels: vec![GraphLevel::from_tets(
            tets,
            2.0 * half / n as f64,
            |c, nrm| (c, nrm),
        )],
        ..Default::default()
    }
}

fn all_finite(sol: &CpuSolution) -> bool {
    let e = sol.energy;
    sol.phi
        .iter()
        .chain(&sol.j_plus)
        .chain(&sol.q)
        .flatten()
        .all(|v| v.is_finite())
        && e.transmitted_input
            .iter()
            .chain(&e.exitance)
            .chain(&e.absorbed)
            .all(|v| v.is_finite())
        && sol.residual.iter().all(|v| v.is_finite())
}

#[test]
fn extreme_materials_sizes_and_lights_stay_finite() {
    let scene = |e: f64| Scene {
        lights: vec![format!("dir:0.3,-1,0.1:{e},{e},{e}").parse().unwrap()],
        environment: Environment::Constant([e * 0.1; 3]),
    };
    let contrast = {
        let a = Coefficients::new([1e-2, 1.0, 1e2], [0.0, 1e-3, 1e1]).unwrap();
        let b = Coefficients::new([1e2, 1e-2, 1.0], [1e1, 0.0, 1e-3]).unwrap();
        MaterialField::procedural(
            Procedural::Split {
                normal: DVec3::new(1.0, 0.2, 0.0),
                offset: 0.0,
                below: a,
                above: b,
            },
            1.5,
        )
        .unwrap()
    };
    let materials = [
        MaterialField::Homogeneous(Material::new([1.0; 3], [0.0; 3], 1.3).unwrap()),
        MaterialField::Homogeneous(Material::new([1e3, 1e-3, 1.0], [1e3, 1e-6, 0.0], 1.0).unwrap()),
        MaterialField::Homogeneous(Material::new([1.0; 3], [0.1; 3], 0.7).unwrap()),
        contrast,
    ];
    for half in [0.01, 5.0, 5000.0] {
        let graph = cube(half, 4);
        for (k, field) in materials.iter().enumerate() {
            for irradiance in [1e-30, 1.0, 1e30] {
                for scheme in [Scheme::Fv, Scheme::Paper] {
                    let params = CpuSolveParams {
                        scheme,
                        iterations: vec![50],
                        ..Default::default()
                    };
                    let sol =
                        solver::solve(&graph, field, &scene(irradiance), None, &params).unwrap();
                    assert!(
                        sol.exact
                            .is_some_and(|r| r.residual.iter().all(|&x| x < 1e-8)),
                        "{:?}",
                        sol.exact
                    );
                    assert!(
                        all_finite(&sol),
                        "half {half} material {k} E {irradiance} {scheme:?}"
                    );
                    assert!(sol.j_plus_clamped.iter().flatten().all(|&v| v >= 0.0));
                }
            }
        }
    }
}

#[test]
fn irradiance_beyond_the_supported_range_is_an_error_not_a_nan() {
    use translucent::scene::MAX_LIGHT_COLOUR;
    let field = MaterialField::Homogeneous(Material::preset("marble").unwrap());
    let graph = cube(5.0, 3);
    // Parsed lights above the bound are refused where they are parsed...
    for e in [1e31, 1e150, 1e300] {
        let parsed = format!("dir:0,-1,0:{e},{e},{e}").parse::<scene::Light>();
        assert!(
            matches!(parsed, Err(scene::SceneError::Invalid { .. })),
            "E = {e}: {parsed:?}"
        );
    }
    // ...and lights built by hand are refused by the solve, before any arithmetic.
    for e in [MAX_LIGHT_COLOUR * 2.0, 1e300] {
        let scene = Scene {
            lights: vec![scene::Light::Directional {
                direction: DVec3::NEG_Y,
                irradiance: [e; 3],
            }],
            environment: Environment::Constant([0.0; 3]),
        };
        let e = solver::solve(&graph, &field, &scene, None, &CpuSolveParams::default())
            .expect_err("refused");
        assert!(e.to_string().contains("above the supported"), "{e}");
    }
    let sh = Scene {
        lights: vec![],
        environment: Environment::SphericalHarmonics([[1e31; 3]; 9]),
    };
    assert!(matches!(
        solver::solve(&graph, &field, &sh, None, &CpuSolveParams::default()),
        Err(SolverError::Scene(_))
    ));
    // At the bound itself the solve is finite.
    let scene = Scene {
        lights: vec![format!("dir:0,-1,0:{MAX_LIGHT_COLOUR:e},0,1")
            .parse()
            .unwrap()],
        environment: Environment::None,
    };
    let sol = solver::solve(&graph, &field, &scene, None, &CpuSolveParams::default()).unwrap();
    assert!(all_finite(&sol));
}

#[test]
fn bad_graphs_scenes_and_parameters_are_typed_errors() {
    let field = MaterialField::Homogeneous(Material::preset("marble").unwrap());
    let scene = Scene {
        lights: vec![],
        environment: Environment::Constant([1.0; 3]),
    };
    let ok = CpuSolveParams::default();
    let run = |g: &QuadGraph, s: &Scene, p: &CpuSolveParams| solver::solve(g, &field, s, None, p);

    assert!(matches!(
        run(&QuadGraph::default(), &scene, &ok),
        Err(SolverError::EmptyGraph)
    ));

    let mut two = cube(2.0, 2);
    two.levels.push(cube(2.0, 4).levels.remove(0));
    assert!(matches!(
        run(&two, &scene, &ok),
        Err(SolverError::MissingLinks { level: 1 })
    ));
    two.levels[1].from_coarser = Some(ShepardLinks {
        links: vec![[
            9_999_999, NO_NODE, NO_NODE, NO_NODE, NO_NODE, NO_NODE, NO_NODE, NO_NODE,
        ]],
        weights: vec![[1.0; 8]],
    });
    assert!(matches!(
        run(&two, &scene, &ok),
        Err(SolverError::BadGraph { level: 1, .. })
    ));

    let mut nan = cube(2.0, 2);
    nan.levels[0].positions[3] = DVec3::NAN;
    assert!(matches!(
        run(&nan, &scene, &ok),
        Err(SolverError::BadGraph { level: 0, .. })
    ));

    let mut flat = cube(2.0, 2);
    let v = flat.levels[0].tets.tets[0][1] as usize;
    flat.levels[0].tets.vertices[v] =
        flat.levels[0].tets.vertices[flat.levels[0].tets.tets[0][0] as usize];
    assert!(matches!(
        run(&flat, &scene, &ok),
        Err(SolverError::DegenerateGeometry { level: 0, .. })
    ));

    let mut dangling = cube(2.0, 2);
    dangling.levels[0].neighbors[0][2] = 1 << 30;
    assert!(matches!(
        run(&dangling, &scene, &ok),
        Err(SolverError::BadGraph { .. })
    ));

    let mut shading = cube(2.0, 2);
    shading.shading = ShadingWeights {
        links: vec![[1 << 30, NO_NODE, NO_NODE, NO_NODE]],
        weights: vec![[1.0, 0.0, 0.0, 0.0]],
    };
    assert!(matches!(
        run(&shading, &scene, &ok),
        Err(SolverError::BadGraph { .. })
    ));

    let g = cube(2.0, 2);
    let bad_scene = Scene {
        lights: vec![],
        environment: Environment::Constant([f64::NAN, 0.0, 0.0]),
    };
    assert!(matches!(
        run(&g, &bad_scene, &ok),
        Err(SolverError::Scene(_))
    ));
    let negative = Scene {
        lights: vec![],
        environment: Environment::Constant([-1.0, 0.0, 0.0]),
    };
    assert!(matches!(
        run(&g, &negative, &ok),
        Err(SolverError::Scene(_))
    ));
    for p in [
        CpuSolveParams {
            tolerance: f64::NAN,
            ..Default::default()
        },
        CpuSolveParams {
            exact_tolerance: 0.0,
            ..Default::default()
        },
        CpuSolveParams {
            initial: Some(vec![[0.0; 3]; 3]),
            ..Default::default()
        },
    ] {
        assert!(
            matches!(run(&g, &scene, &p), Err(SolverError::BadParameter { .. })),
            "{p:?}"
        );
    }
    // A material field built by hand, bypassing validation, is caught where it is sampled.
    let hand_made = MaterialField::Homogeneous(Material {
        sigma_s: [0.0; 3],
        sigma_a: [0.0; 3],
        eta: 1.3,
        diffusion: Default::default(),
    });
    let e = solver::solve(&g, &hand_made, &scene, None, &ok).unwrap_err();
    assert!(matches!(e, SolverError::BadMaterialAt { .. }), "{e}");
    let bad_eta = MaterialField::Homogeneous(Material {
        sigma_s: [1.0; 3],
        sigma_a: [0.0; 3],
        eta: 5.0,
        diffusion: Default::default(),
    });
    let e = solver::solve(&g, &bad_eta, &scene, None, &ok).unwrap_err();
    assert!(matches!(e, SolverError::Material(_)), "{e}");
    assert!("paper".parse::<scene::RadianceMode>().unwrap() == scene::RadianceMode::Paper);
    assert!("phys".parse::<scene::RadianceMode>().is_err());
    assert!(
        "--scheme=fv".parse::<Scheme>().is_err()
            && "paper".parse::<Scheme>().unwrap() == Scheme::Paper
    );
}
