//! Live edits through the host API (issue 7 item 3): `TranslucentObject::set_material` and
//! `deform` take effect at the next `record` without a re-bake, run a solve (the shadow maps only
//! when the shape moved), and give the image a freshly built object of the edited scene gives.
//!
//! Scene: a 20 mm sphere baked at resolution 12 with 2 levels, one directional light, 24x24
//! pixels (lavapipe-sized).

use std::sync::Arc;

use glam::{DVec3, Mat4, Vec3};
use translucent::frame::quadgraph::PASS_GATHER;
use translucent::frame::PASS_SHADOW;
use translucent::headless::HeadlessHost;
use translucent::material::{Material, MaterialField, Procedural};
use translucent::mesh::shapes::Shape;
use translucent::quadgraph::BakeParams;
use translucent::scene::{Environment, Light, Scene};
use translucent::solver::gpu::Deformation;
use translucent::solver::gpu::PASS_SOLVE;
use translucent::vk::{Context, LinearImage};
use translucent::{ObjectParams, QuadGraph, SkipReason, TranslucentObject};
use translucent_tests::{relative_difference, GpuTest};

const SIZE: u32 = 24;
/// A warm-started solve against a cold one of the same scene, both stopped at an estimated
/// relative error of 1e-4, relative to the brightest channel (the estimate is not a bound; 1%
/// is the light-change skip test's tolerance too).
const WARM: f32 = 1e-2;

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

fn preset(name: &str) -> MaterialField {
    MaterialField::Homogeneous(Material::preset(name).expect("preset"))
}

/// Skim milk below the equator, skin1 above: per-node material (the heterogeneous variant).
fn split() -> MaterialField {
    let milk = Material::preset("skimmilk").expect("preset");
    let skin = Material::preset("skin1").expect("preset");
    MaterialField::procedural(
        Procedural::Split {
            normal: DVec3::Y,
            offset: 0.0,
            below: milk.coefficients(),
            above: skin.coefficients(),
        },
        milk.eta,
    )
    .expect("field")
}

fn scene() -> Scene {
    Scene {
        lights: vec![Light::Directional {
            direction: DVec3::new(0.3, -1.0, -0.6).normalize(),
            irradiance: [2.0; 3],
        }],
        environment: Environment::None,
    }
}

fn object(
    ctx: &Context,
    graph: &Arc<QuadGraph>,
    field: &MaterialField,
    skip: bool,
) -> TranslucentObject {
    let params = ObjectParams {
        skip,
        ..translucent_tests::cascade_params()
    };
    TranslucentObject::new(ctx, graph.clone(), field, &scene(), &params).expect("object")
}

/// Pixels the object covers (any non-zero channel; the background is black).
fn covered(image: &LinearImage) -> usize {
    image
        .pixels
        .iter()
        .filter(|p| p[..3].iter().any(|&v| v > 0.0))
        .count()
}

/// Marble -> skim milk / skin1 split -> skim milk: each edit solves (warm) without new shadow
/// maps, switches the material variant, and renders what a new object of that material renders.
#[test]
fn set_material_solves_warm_and_matches_a_fresh_object() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let graph = graph();
    let mut host = HeadlessHost::new(ctx, SIZE, SIZE).expect("host");
    let mut live = object(ctx, &graph, &preset("marble"), true);
    let (marble, report) = host.render(ctx, &mut live).expect("marble");
    assert_eq!(report.material_variant, "homogeneous");
    for (field, variant) in [
        (split(), "heterogeneous"),
        (preset("skimmilk"), "homogeneous"),
    ] {
        live.set_material(ctx, &field).expect("set_material");
        let (edited, report) = host.render(ctx, &mut live).expect("edited frame");
        assert_eq!(report.material_variant, variant);
        assert!(report.passes.contains(&PASS_SOLVE), "{:?}", report.passes);
        assert!(report.passes.contains(&PASS_GATHER), "{:?}", report.passes);
        assert!(!report.passes.contains(&PASS_SHADOW), "{:?}", report.passes);
        assert_eq!(
            report.skipped.get(PASS_SHADOW),
            Some(&SkipReason::ShadowsUnchanged)
        );
        assert!(report.warm_start, "a material edit warm-starts");
        let mut fresh = object(ctx, &graph, &field, false);
        let (reference, _) = host.render(ctx, &mut fresh).expect("fresh object");
        let d = relative_difference(&edited.image, &reference.image);
        let from_marble = relative_difference(&marble.image, &reference.image);
        eprintln!("{variant}: edited vs fresh {d:.2e}, marble vs fresh {from_marble:.2e}");
        assert!(d <= WARM, "edited vs fresh: {d}");
        // The edit must have changed the image (so the comparison above can fail).
        assert!(from_marble > 10.0 * d.max(1e-4), "{from_marble} vs {d}");
        drop(fresh);
    }
    drop((live, host));
    gpu.finish();
}

/// A uniform scale by 1.25 about the centre: the frame solves with new shadow maps, the object
/// covers more pixels (same automatic camera: it frames the rest pose), the image is the one an
/// unskipped object with the same deformation renders, and `Identity` restores the first image.
#[test]
fn deform_moves_the_object_solves_and_identity_restores_it() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let graph = graph();
    let field = preset("marble");
    let mut host = HeadlessHost::new(ctx, SIZE, SIZE).expect("host");
    let mut live = object(ctx, &graph, &field, true);
    let (rest, _) = host.render(ctx, &mut live).expect("rest pose");
    let scale = Deformation::Affine(Mat4::from_scale(Vec3::splat(1.25)));
    live.deform(ctx, &scale).expect("deform");
    let (scaled, report) = host.render(ctx, &mut live).expect("scaled");
    for pass in [PASS_SHADOW, PASS_GATHER, PASS_SOLVE] {
        assert!(report.passes.contains(&pass), "{pass}: {:?}", report.passes);
    }
    let (before, after) = (covered(&rest.image), covered(&scaled.image));
    eprintln!("covered pixels: rest {before}, scaled {after}");
    assert!(after as f64 > 1.2 * before as f64, "{before} -> {after}");

    let mut full = object(ctx, &graph, &field, false);
    full.deform(ctx, &scale).expect("deform");
    let (reference, _) = host.render(ctx, &mut full).expect("unskipped, scaled");
    let d = relative_difference(&scaled.image, &reference.image);
    eprintln!("scaled: live vs unskipped {d:.2e}");
    assert!(d <= WARM, "live vs unskipped: {d}");

    live.deform(ctx, &Deformation::Identity).expect("deform");
    let (restored, report) = host.render(ctx, &mut live).expect("identity");
    assert!(report.passes.contains(&PASS_SOLVE), "{:?}", report.passes);
    assert_eq!(covered(&restored.image), before);
    let d = relative_difference(&restored.image, &rest.image);
    eprintln!("restored vs rest {d:.2e}");
    assert!(d <= WARM, "restored vs rest: {d}");
    drop((live, full, host));
    gpu.finish();
}
