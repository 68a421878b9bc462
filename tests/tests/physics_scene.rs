//! Irradiance q at surface nodes: ray-cast visibility through the `Solid` trait, Fresnel
//! transmission, light falloff, environments.

use std::f64::consts::PI;

use glam::DVec3;
use translucent::material::fresnel;
use translucent::mesh::shapes::Shape;
use translucent::mesh::Solid;
use translucent::quadgraph::BakeParams;
use translucent::scene::{Environment, Light, Scene};
use translucent::QuadGraph;

#[test]
fn a_torus_shadows_its_own_inner_ring() {
    let torus = Shape::Torus {
        major: 10.0,
        minor: 4.0,
    };
    // Inner equator, facing the hole.
    let (p, n) = (DVec3::new(6.0, 0.0, 0.0), -DVec3::X);
    let eta = 1.3;
    let through_hole = Scene {
        lights: vec!["dir:1,0,0:2,2,2".parse().unwrap()],
        environment: Environment::None,
    };
    let over_the_rim = Scene {
        lights: vec!["dir:1,-1,0:2,2,2".parse().unwrap()],
        environment: Environment::None,
    };
    let solid: &dyn Solid = &torus;
    assert_eq!(
        through_hole.irradiance_at(p, n, eta, Some(solid), 1e-4),
        [0.0; 3],
        "the far side of the ring blocks the light"
    );
    let unshadowed = through_hole.irradiance_at(p, n, eta, None, 1e-4);
    assert!((unshadowed[0] - 2.0 * fresnel::transmittance(eta, 1.0)).abs() < 1e-12);
    let cos = std::f64::consts::FRAC_1_SQRT_2;
    let q = over_the_rim.irradiance_at(p, n, eta, Some(solid), 1e-4);
    assert!(
        (q[1] - 2.0 * cos * fresnel::transmittance(eta, cos)).abs() < 1e-12,
        "{q:?}"
    );
    // A point light inside the hole, in front of the node, is visible; one beyond the ring is not.
    let near: Light = "point:0,0,0:360,360,360".parse().unwrap();
    let far: Light = "point:-30,0,0:360,360,360".parse().unwrap();
    let q = Scene {
        lights: vec![near],
        environment: Environment::None,
    }
    .irradiance_at(p, n, eta, Some(solid), 1e-4);
    assert!(
        (q[0] - 10.0 * fresnel::transmittance(eta, 1.0)).abs() < 1e-9,
        "{q:?}"
    );
    let q = Scene {
        lights: vec![far],
        environment: Environment::None,
    }
    .irradiance_at(p, n, eta, Some(solid), 1e-4);
    assert_eq!(q, [0.0; 3]);
}

#[test]
fn a_convex_sphere_never_shadows_itself_and_environments_are_uniform() {
    let ball = Shape::Sphere { radius: 10.0 };
    let params = BakeParams {
        resolution: 12,
        levels: 1,
        ..Default::default()
    };
    let graph = QuadGraph::bake(&ball.triangulate(48), &ball, &params, &mut |_| {})
        .unwrap()
        .0;
    let level = graph.finest();
    let eta = 1.3;
    let scene = Scene {
        lights: vec![
            "dir:0.3,-1,0.2:1,2,3".parse().unwrap(),
            "spot:0,40,0:0,-1,0:1600,1600,1600:20,40".parse().unwrap(),
        ],
        environment: Environment::None,
    };
    let shadowed = scene.surface_irradiance(level, eta, Some(&ball));
    let free = scene.surface_irradiance(level, eta, None);
    let lit = free.iter().filter(|q| q[0] > 0.0).count();
    assert!(lit > level.surface_count() / 3, "{lit}");
    for (a, b) in shadowed.iter().zip(&free) {
        assert_eq!(a, b);
    }
    // Constant environment: q = pi L (1 - F_dr,ext) at every node, whatever the normal.
    let env = Scene {
        lights: vec![],
        environment: Environment::Constant([0.5, 1.0, 2.0]),
    };
    let expected = PI * (1.0 - fresnel::external_diffuse_reflectance(eta));
    for q in env.surface_irradiance(level, eta, Some(&ball)) {
        for (c, l) in [0.5, 1.0, 2.0].iter().enumerate() {
            assert!((q[c] - l * expected).abs() < 1e-12);
        }
    }
}
