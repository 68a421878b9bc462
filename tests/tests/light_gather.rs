//! The GPU irradiance gather and shadow maps against the f64 CPU reference
//! (`scene::Scene::surface_irradiance`, exact ray-cast visibility through the `Solid` trait).
//!
//! Tolerances. Where a node is lit and unshadowed, the GPU q differs from the reference only by
//! fp32 arithmetic and the final fp16 store: one fp16 ulp, relative 2^-10 = 9.8e-4 (Vulkan lets
//! the float-to-half conversion round toward zero, and lavapipe does), so we allow 1e-3 relative
//! plus 1e-6 of the brightest node (for nodes at the edge of a spot cone). Measured: 6.5e-4 to
//! 9.7e-4 for the lights, 1.7e-8 for the constant environment.
//! The reference is evaluated at the inputs the GPU actually gets (positions rounded to f32,
//! normals rounded to fp16 and renormalized), since those roundings are the interface's, not the
//! gather's. Shadow-map visibility is a sampled approximation of ray casting: it must agree on at
//! least 98% of surface nodes (a node counts as visible on the GPU when its PCF visibility > 1/2).

use std::collections::BTreeMap;
use std::f64::consts::PI;

use glam::DVec3;
use translucent::frame::quadgraph::PASS_GATHER;
use translucent::frame::{FrameGraph, PASS_SHADOW};
use translucent::mesh::shapes::Shape;
use translucent::mesh::GpuMesh;
use translucent::mesh::{MeshSolid, Solid, TriMesh, ValidateOptions};
use translucent::quadgraph::BakeParams;
use translucent::render::{
    q_scale_for, GatherLevel, GatherScene, IrradiancePass, ShadowMaps, ShadowMapsDesc,
    SurfaceImages, MAX_LIGHTS,
};
use translucent::scene::{Environment, Light, Scene};
use translucent::vk::{Access, Context, GpuProfiler, VkError};
use translucent::{GraphLevel, QuadGraph};
use translucent_tests::GpuTest;

const ETA: f64 = 1.3;
const RELATIVE_TOLERANCE: f64 = 1e-3;

/// What one gather returned.
struct Gathered {
    /// q per surface node (unscaled).
    q: Vec<[f32; 3]>,
    /// GPU ms per pass name.
    passes: BTreeMap<String, f64>,
    q_scale: f32,
}

/// (centre, radius) around the displayed mesh: what the shadow views must cover.
fn mesh_bounds(mesh: &TriMesh) -> (DVec3, f64) {
    let (lo, hi) = mesh.bounds();
    let centre = (lo + hi) * 0.5;
    let radius = mesh
        .positions
        .iter()
        .map(|p| p.distance(centre))
        .fold(0.0, f64::max);
    (centre, radius)
}

/// Shadow maps + gather for `scene` on the finest level of `graph`, one frame, read back.
fn gather(
    ctx: &Context,
    graph: &QuadGraph,
    scene: &Scene,
    cast_shadows: bool,
    tile: u32,
    q_scale: Option<f32>,
) -> Gathered {
    let level = graph.finest();
    let caster = GpuMesh::new(
        ctx,
        &graph.surface,
        &vec![[0.0; 3]; graph.surface.positions.len()],
    )
    .expect("caster mesh");
    let mut shadows = ShadowMaps::new(
        ctx,
        &ShadowMapsDesc {
            tile_resolution: tile,
            max_views: 12,
        },
    )
    .expect("shadow maps");
    shadows
        .set_lights(&scene.lights, mesh_bounds(&graph.surface), cast_shadows)
        .expect("lights fit");
    let pass = IrradiancePass::new(ctx, 1).expect("gather pass");
    let images = SurfaceImages::upload(ctx, level).expect("surface images");
    let set = pass
        .bind_level(
            ctx,
            &shadows,
            &images.position,
            &images.normal,
            &images.q,
            images.surface_rows,
        )
        .expect("descriptor set");
    let uniforms = GatherScene::new(scene, &shadows).expect("gather scene");
    let q_scale = q_scale.unwrap_or_else(|| q_scale_for(scene, level, ETA));
    let mut profiler = GpuProfiler::new(ctx, "light test", 8).expect("profiler");
    let submission = ctx
        .submit("gather q", |cb| {
            let (frame, _) = ctx.frames();
            // SAFETY: `cb` is recording; everything lives until the submission is waited on below.
            unsafe {
                profiler.begin_frame(cb, frame);
                record_gather(
                    ctx,
                    cb,
                    Some(&mut profiler),
                    &shadows,
                    &caster,
                    &pass,
                    &uniforms,
                    &[(&set, &images)],
                    q_scale,
                )
            }
        })
        .expect("submit");
    let frame = submission.frame();
    submission.wait().expect("wait");
    profiler.frame_completed(frame);
    let passes = profiler.latest().map(|t| t.passes()).unwrap_or_default();
    let q = images
        .read_q(ctx, level, Access::ComputeWrite, q_scale)
        .expect("read q");
    Gathered { q, passes, q_scale }
}

/// Records the shadow maps (when a light casts a shadow) and the gather of `levels` as the frame
/// graph's passes [`PASS_SHADOW`] and [`PASS_GATHER`], the graph placing the barriers.
///
/// # Safety
/// `cb` is recording outside a rendering scope; everything outlives its execution.
#[allow(clippy::too_many_arguments)]
unsafe fn record_gather(
    ctx: &Context,
    cb: ash::vk::CommandBuffer,
    profiler: Option<&mut GpuProfiler>,
    shadows: &ShadowMaps,
    caster: &GpuMesh,
    pass: &IrradiancePass,
    uniforms: &GatherScene,
    levels: &[(&GatherLevel, &SurfaceImages)],
    q_scale: f32,
) -> Result<(), VkError> {
    let mut graph = FrameGraph::new(ctx);
    if shadows.any_shadows() {
        graph
            .pass(PASS_SHADOW)
            .uses(shadows.uses(caster))
            .record(move |p| {
                // SAFETY: inside the pass declaring the shadow maps' uses.
                unsafe { shadows.record(p.ctx, p.cb, caster) };
                Ok(())
            });
    }
    // The atlas once, then every level's images (a pass declares each resource once).
    let uses = levels.iter().enumerate().flat_map(|(h, (_, i))| {
        IrradiancePass::uses(shadows, &i.position, &i.normal, &i.q)
            .into_iter()
            .skip(usize::from(h > 0))
    });
    graph.pass(PASS_GATHER).uses(uses).record(move |p| {
        // SAFETY: inside the pass declaring every level's gather uses.
        unsafe {
            pass.record_scene(p.ctx, p.cb, uniforms);
            for (set, _) in levels {
                pass.record(p.ctx, p.cb, set, q_scale, ETA as f32)
                    .map_err(|e| VkError::InvalidArgument {
                        what: "gather".into(),
                        problem: e.to_string(),
                    })?;
            }
        }
        Ok(())
    });
    // SAFETY: the caller's contract.
    unsafe { graph.execute(cb, profiler, false) }.map_err(|e| VkError::InvalidArgument {
        what: "frame graph".into(),
        problem: e.to_string(),
    })?;
    Ok(())
}

/// `level` as the GPU sees it: positions rounded to f32, normals to fp16 and renormalized.
fn as_uploaded(level: &GraphLevel) -> GraphLevel {
    let mut out = level.clone();
    for p in &mut out.positions {
        *p = p.as_vec3().as_dvec3();
    }
    for n in &mut out.surface_normals {
        let h = n
            .to_array()
            .map(|c| f64::from(half::f16::from_f64(c).to_f32()));
        *n = DVec3::from_array(h).normalize();
    }
    out
}

fn sphere_graph() -> (QuadGraph, Shape) {
    let ball = Shape::Sphere { radius: 10.0 };
    let params = BakeParams {
        resolution: 12,
        levels: 1,
        ..Default::default()
    };
    let graph = QuadGraph::bake(&ball.triangulate(48), &ball, &params, &mut |_| {})
        .expect("bake")
        .0;
    (graph, ball)
}

fn torus_graph() -> (QuadGraph, Shape) {
    let torus = Shape::Torus {
        major: 10.0,
        minor: 4.0,
    };
    let params = BakeParams {
        resolution: 20,
        levels: 1,
        ..Default::default()
    };
    let graph = QuadGraph::bake(&torus.triangulate(64), &torus, &params, &mut |_| {})
        .expect("bake")
        .0;
    (graph, torus)
}

/// Compares one single-light or environment scene on a convex object, where nothing is shadowed:
/// nodes facing the light within `min_cos` are checked at fp16 precision; the returned count is
/// nodes closer to the terminator where PCF dimmed the light (the faceted caster's silhouette).
fn check_matches_reference(
    gpu: &GpuTest,
    graph: &QuadGraph,
    solid: &dyn Solid,
    scene: &Scene,
    min_cos: f64,
) -> usize {
    let level = graph.finest();
    let uploaded = as_uploaded(level);
    let reference = scene.surface_irradiance(&uploaded, ETA, Some(solid));
    let got = gather(&gpu.ctx, graph, scene, true, 512, None);
    assert_eq!(got.q.len(), reference.len());
    let max_q = reference.iter().flatten().fold(0.0f64, |m, &v| m.max(v));
    assert!(max_q > 0.0, "{scene:?} lights nothing");
    let inner = level.inner_count();
    let (mut checked, mut dimmed, mut worst) = (0, 0, 0.0f64);
    for (s, (g, r)) in got.q.iter().zip(&reference).enumerate() {
        let p = uploaded.positions[inner + s];
        let n = uploaded.surface_normals[s];
        let facing = scene
            .lights
            .iter()
            .all(|l| n.dot(l.arriving(p).1) >= min_cos);
        for c in 0..3 {
            let (g, r) = (f64::from(g[c]), r[c]);
            assert!(g.is_finite() && g >= 0.0, "node {s}: q {g}");
            let err = (g - r).abs();
            // An absolute floor for nodes the light barely reaches (spot falloff): fp16 of the
            // scaled value, relative to the brightest node.
            let allowed = RELATIVE_TOLERANCE * r + 1e-6 * max_q;
            if facing {
                worst = worst.max(err / r.max(1e-6 * max_q));
                assert!(
                    err <= allowed,
                    "{scene:?}\nnode {s} channel {c}: GPU {g}, CPU {r} (relative error {})",
                    err / r.max(1e-30)
                );
            } else if err > allowed {
                // Near the terminator only shadowing may differ, and only by darkening.
                assert!(g <= r + allowed, "node {s}: GPU {g} brighter than CPU {r}");
                dimmed += 1;
            }
        }
        checked += usize::from(facing);
    }
    assert!(checked >= 30, "{checked} nodes checked");
    gpu.assert_no_messages();
    eprintln!(
        "{checked} of {} nodes checked, largest relative error {worst:.2e}",
        level.surface_count()
    );
    dimmed
}

#[test]
fn gathered_q_matches_the_cpu_reference_for_every_light_and_environment() {
    let gpu = GpuTest::new();
    let (graph, ball) = sphere_graph();
    let mut sh = [[0.0; 3]; 9];
    // A sky brighter above, bluish, with some quadratic terms: every coefficient is used.
    let coefficients = [1.2, 0.4, -0.2, 0.3, 0.1, -0.15, 0.2, 0.05, -0.1];
    for (k, c) in coefficients.iter().enumerate() {
        sh[k] = [c * 0.8, c * 1.0, c * 1.3];
    }
    let cases: [(&str, Scene); 7] = [
        ("directional", single("dir:0.3,-1,0.2:1,2,3")),
        ("point", single("point:30,20,10:900,1200,1500")),
        // A point light close to the sphere: the six cube faces.
        ("point cube", single("point:0,11,0:100,120,150")),
        // The cone edge crosses the sphere: the smoothstep falloff is exercised.
        ("spot", single("spot:3,30,0:0,-1,0:1600,1500,1400:5,15")),
        (
            "constant environment",
            Scene {
                lights: vec![],
                environment: Environment::Constant([0.5, 1.0, 2.0]),
            },
        ),
        (
            "SH environment",
            Scene {
                lights: vec![],
                environment: Environment::SphericalHarmonics(sh),
            },
        ),
        (
            "two lights and an environment",
            Scene {
                lights: vec![
                    "dir:-1,-0.5,0:2,2,2".parse().expect("light"),
                    "spot:0,-40,0:0,1,0:3000,3000,3000:10,20"
                        .parse()
                        .expect("light"),
                ],
                environment: Environment::Constant([0.1, 0.1, 0.1]),
            },
        ),
    ];
    for (name, scene) in &cases {
        let dimmed = check_matches_reference(&gpu, &graph, &ball, scene, 0.2);
        eprintln!("{name}: {dimmed} node channels near the terminator dimmed by PCF");
    }
    // The constant environment is pi L (1 - F_dr,ext) everywhere, whatever the normal: exact.
    let env = Scene {
        lights: vec![],
        environment: Environment::Constant([0.5, 1.0, 2.0]),
    };
    let got = gather(&gpu.ctx, &graph, &env, true, 64, None);
    let t = PI * (1.0 - translucent::material::fresnel::external_diffuse_reflectance(ETA));
    for q in &got.q {
        for (c, l) in [0.5, 1.0, 2.0].iter().enumerate() {
            assert!((f64::from(q[c]) - l * t).abs() <= RELATIVE_TOLERANCE * l * t);
        }
    }
    gpu.finish();
}

fn single(light: &str) -> Scene {
    Scene {
        lights: vec![light.parse().expect("light")],
        environment: Environment::None,
    }
}

/// Share of surface nodes where the GPU's shadow-map visibility agrees with exact ray casting,
/// for one light: (agreeing, total, lit by the CPU).
fn visibility_agreement(
    gpu: &GpuTest,
    graph: &QuadGraph,
    solid: &dyn Solid,
    light: &str,
    cast_shadows: bool,
) -> (usize, usize, usize) {
    let level = graph.finest();
    let uploaded = as_uploaded(level);
    let scene = single(light);
    let shadowed = scene.surface_irradiance(&uploaded, ETA, Some(solid));
    let free = scene.surface_irradiance(&uploaded, ETA, None);
    let got = gather(&gpu.ctx, graph, &scene, cast_shadows, 1024, None);
    let (mut agree, mut lit) = (0, 0);
    let inner = level.inner_count();
    for (i, ((g, s), f)) in got.q.iter().zip(&shadowed).zip(&free).enumerate() {
        // The channel with the most light decides; visibility is the same for all three.
        let c = (0..3).max_by(|&a, &b| f[a].total_cmp(&f[b])).unwrap_or(0);
        let cpu_visible = s[c] > 0.0;
        let gpu_visible = f[c] > 0.0 && f64::from(g[c]) > 0.5 * f[c];
        lit += usize::from(cpu_visible);
        agree += usize::from(cpu_visible == gpu_visible);
        // LIGHT_DEBUG=1 lists the disagreeing nodes (where, how grazing, PCF fraction).
        if cpu_visible != gpu_visible && std::env::var_os("LIGHT_DEBUG").is_some() {
            let p = uploaded.positions[inner + i];
            let n = uploaded.surface_normals[i];
            let (_, l, _) = scene.lights[0].arriving(p);
            eprintln!(
                "  cpu {cpu_visible} gpu {:.3} free {:.4} cos {:.3} at {p:.2}",
                f64::from(g[c]) / f[c],
                f[c],
                n.dot(l)
            );
        }
    }
    gpu.assert_no_messages();
    (agree, got.q.len(), lit)
}

#[test]
fn shadow_maps_agree_with_ray_casting_on_a_self_shadowing_torus() {
    let gpu = GpuTest::new();
    let (graph, torus) = torus_graph();
    // Grazing: 10 degrees above the ring's plane, the near side of the ring shadows the far
    // inner side; the spot and the point light skim it from the side; the centred point light
    // (inside the bounding sphere: six cube faces) lights the inner ring through the hole.
    for light in [
        "dir:1,-0.18,0.3:1,1,1",
        "spot:-40,6,0:1,-0.15,0:2000,2000,2000:20,40",
        "point:30,7,20:2000,2000,2000",
        "point:0,0,0:200,200,200",
    ] {
        let (agree, total, lit) = visibility_agreement(&gpu, &graph, &torus, light, true);
        let share = agree as f64 / total as f64;
        eprintln!(
            "torus, {light}: shadow-map visibility agrees with ray casting on {agree}/{total} \
             surface nodes ({:.2}%), {lit} lit",
            100.0 * share
        );
        assert!(lit > total / 10, "{light}: only {lit} nodes lit");
        assert!(share >= 0.98, "{light}: agreement {share}");
    }
    // The check can fail: without shadow maps the grazing light's agreement drops well below.
    let (agree, total, _) =
        visibility_agreement(&gpu, &graph, &torus, "dir:1,-0.18,0.3:1,1,1", false);
    eprintln!("torus, no shadow maps: {agree}/{total}");
    assert!((agree as f64) < 0.95 * total as f64, "{agree}/{total}");
    gpu.finish();
}

#[test]
fn shadow_maps_agree_with_ray_casting_on_the_rocker_arm() {
    let Some(path) = translucent_tests::test_mesh("rocker-arm.obj") else {
        return;
    };
    let (solid, _, _) =
        MeshSolid::load(&path, 50.0, &ValidateOptions::default()).expect("rocker arm loads");
    let params = BakeParams {
        resolution: 24,
        levels: 1,
        ..Default::default()
    };
    let graph = QuadGraph::bake(solid.mesh(), &solid, &params, &mut |_| {})
        .expect("bake")
        .0;
    let gpu = GpuTest::new();
    for light in [
        "dir:1,-0.2,0.4:1,1,1",
        "spot:0,60,10:0,-1,-0.1:9000,9000,9000:25,45",
    ] {
        let (agree, total, lit) = visibility_agreement(&gpu, &graph, &solid, light, true);
        let share = agree as f64 / total as f64;
        eprintln!(
            "rocker arm, {light}: agreement {agree}/{total} ({:.2}%), {lit} lit",
            100.0 * share
        );
        assert!(share >= 0.98, "{light}: agreement {share}");
    }
    gpu.finish();
}

#[test]
fn no_shadow_casting_light_records_no_shadow_pass() {
    let gpu = GpuTest::new();
    let (graph, _) = sphere_graph();
    let scene = single("dir:0,-1,0:1,1,1");
    let with = gather(&gpu.ctx, &graph, &scene, true, 64, None);
    let without = gather(&gpu.ctx, &graph, &scene, false, 64, None);
    let env_only = gather(
        &gpu.ctx,
        &graph,
        &Scene {
            lights: vec![],
            environment: Environment::Constant([1.0; 3]),
        },
        true,
        64,
        None,
    );
    // The test device (lavapipe) has timestamps; a device without them would make the pass
    // checks below vacuous, so it fails here unless the user chose such a device.
    let chosen_device = std::env::var("TRANSLUCENT_DEVICE").is_ok_and(|d| !d.is_empty());
    assert!(
        gpu.ctx.info().timestamps || chosen_device,
        "the default test device must report timestamps"
    );
    if gpu.ctx.info().timestamps {
        assert!(with.passes.contains_key("shadow_map"), "{:?}", with.passes);
        for g in [&with, &without, &env_only] {
            assert!(g.passes.contains_key("gather_q"), "{:?}", g.passes);
        }
        assert!(
            !without.passes.contains_key("shadow_map"),
            "{:?}",
            without.passes
        );
        assert!(
            !env_only.passes.contains_key("shadow_map"),
            "{:?}",
            env_only.passes
        );
    } else {
        eprintln!("skipped the profiler check: the device has no timestamps");
    }
    // A sphere never shadows itself: the same q either way.
    assert!(
        with.q == without.q,
        "shadow maps changed q on a convex sphere"
    );
    gpu.finish();
}

#[test]
fn extreme_lights_give_finite_q_at_the_chosen_scale() {
    let gpu = GpuTest::new();
    let (graph, ball) = sphere_graph();
    let level = graph.finest();
    let uploaded = as_uploaded(level);
    for e in [1e-4, 1.0, 1e4] {
        let scene = Scene {
            lights: vec![
                Light::Directional {
                    direction: DVec3::new(0.2, -1.0, 0.1),
                    irradiance: [e, 0.5 * e, 0.0],
                },
                Light::Point {
                    position: DVec3::new(0.0, 0.0, 10.05),
                    intensity: [e; 3],
                },
            ],
            environment: Environment::Constant([e * 1e-3; 3]),
        };
        let got = gather(&gpu.ctx, &graph, &scene, true, 256, None);
        let reference = scene.surface_irradiance(&uploaded, ETA, Some(&ball));
        let max_ref = reference.iter().flatten().fold(0.0f64, |m, &v| m.max(v));
        let max_got = got.q.iter().flatten().fold(0.0f32, |m, &v| m.max(v));
        assert!(
            got.q.iter().flatten().all(|v| v.is_finite() && *v >= 0.0),
            "light {e}: NaN, Inf or negative q"
        );
        // The scale maps the brightest node near 2048: far from fp16's overflow and underflow.
        let top = f64::from(max_got * got.q_scale);
        assert!(
            (1000.0..=2100.0).contains(&top),
            "light {e}: max scaled q {top}"
        );
        assert!(
            (f64::from(max_got) - max_ref).abs() <= 2e-3 * max_ref,
            "light {e}: max q {max_got} vs {max_ref}"
        );
    }
    // A 1e4 light with a careless scale of 100 saturates at fp16's largest value, never Inf.
    let scene = single("dir:0,-1,0:1e4,1e4,1e4");
    let q_scale = 100.0;
    let got = gather(&gpu.ctx, &graph, &scene, true, 64, Some(q_scale));
    assert!(got.q.iter().flatten().all(|v| v.is_finite()));
    assert!(got
        .q
        .iter()
        .flatten()
        .any(|&v| (v * q_scale - translucent::render::FP16_MAX).abs() < 1.0));
    gpu.finish();
}

#[test]
fn bad_gather_input_is_a_typed_error() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let (graph, _) = sphere_graph();
    let level = graph.finest();
    let lights: Vec<Light> = (0..=MAX_LIGHTS)
        .map(|i| format!("dir:0,-1,{i}:1,1,1").parse().expect("light"))
        .collect();
    let mut shadows = ShadowMaps::new(ctx, &ShadowMapsDesc::default()).expect("shadow maps");
    let bounds = mesh_bounds(&graph.surface);
    let e = shadows.set_lights(&lights, bounds, true).unwrap_err();
    assert!(e.to_string().contains("at most 8"), "{e}");
    // Eight cube lights need 48 views; the default atlas holds 8.
    let cubes: Vec<Light> = (0..2)
        .map(|_| "point:0,0,0:1,1,1".parse().expect("light"))
        .collect();
    assert!(shadows.set_lights(&cubes, bounds, true).is_err());
    assert!(shadows
        .set_lights(&lights[..2], (DVec3::ZERO, f64::NAN), true)
        .is_err());
    let scene = Scene {
        lights: lights.clone(),
        environment: Environment::None,
    };
    assert!(GatherScene::new(&scene, &shadows).is_err(), "9 lights");
    shadows
        .set_lights(&lights[..1], bounds, true)
        .expect("one light");
    let two = Scene {
        lights: lights[..2].to_vec(),
        environment: Environment::None,
    };
    assert!(GatherScene::new(&two, &shadows).is_err(), "lights differ");
    assert!(ShadowMaps::new(
        ctx,
        &ShadowMapsDesc {
            tile_resolution: 512,
            max_views: 49
        }
    )
    .is_err());
    // Wrong image formats are refused when binding.
    let pass = IrradiancePass::new(ctx, 2).expect("pass");
    let images = SurfaceImages::upload(ctx, level).expect("images");
    let e = pass
        .bind_level(
            ctx,
            &shadows,
            &images.normal,
            &images.position,
            &images.q,
            images.surface_rows,
        )
        .unwrap_err();
    assert!(e.to_string().contains("surface_position"), "{e}");
    drop((images, pass, shadows));
    gpu.finish();
}

/// Per-pass GPU times of a spot-lit bake (run on demand; numbers go to benches/RESULTS.md):
/// `cargo test --release -p translucent-tests --test light_gather -- --ignored --nocapture`
#[test]
#[ignore = "timing, not a check: run on demand"]
fn light_pass_timings() {
    let gpu = GpuTest::new();
    let torus = Shape::Torus {
        major: 17.5,
        minor: 7.5,
    };
    let params = BakeParams {
        resolution: 48,
        levels: 1,
        ..Default::default()
    };
    let graph = QuadGraph::bake(&torus.triangulate(96), &torus, &params, &mut |_| {})
        .expect("bake")
        .0;
    let scene = single("spot:0,60,30:0,-1,-0.5:20000,20000,20000:20,35");
    eprintln!(
        "torus 50 mm, resolution 48: {} surface nodes, {} display triangles",
        graph.finest().surface_count(),
        graph.surface.indices.len()
    );
    for tile in [512, 1024, 2048] {
        let mut rows = Vec::new();
        for _ in 0..9 {
            rows.push(gather(&gpu.ctx, &graph, &scene, true, tile, None).passes);
        }
        let median = |name: &str| {
            let mut v: Vec<f64> = rows.iter().filter_map(|p| p.get(name).copied()).collect();
            v.sort_by(f64::total_cmp);
            v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
        };
        eprintln!(
            "tile {tile}: shadow_map {:.3} ms, gather_q {:.3} ms (median of 9)",
            median("shadow_map"),
            median("gather_q")
        );
    }
    gpu.finish();
}

/// Every level of a multi-level bake gathered in one command buffer, twice (two frames: the
/// second frame's shadow pass and scene update must wait for the first frame's reads), each level
/// against the reference; synchronization validation must stay silent.
#[test]
fn every_level_is_gathered_in_one_frame() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let ball = Shape::Sphere { radius: 10.0 };
    let params = BakeParams {
        resolution: 16,
        levels: 2,
        ..Default::default()
    };
    let graph = QuadGraph::bake(&ball.triangulate(48), &ball, &params, &mut |_| {})
        .expect("bake")
        .0;
    assert_eq!(graph.levels.len(), 2);
    let scene = Scene {
        lights: vec![
            "dir:0.3,-1,0.2:1,2,3".parse().expect("light"),
            "point:0,0,25:500,500,500".parse().expect("light"),
        ],
        environment: Environment::Constant([0.05; 3]),
    };
    let caster = GpuMesh::new(
        ctx,
        &graph.surface,
        &vec![[0.0; 3]; graph.surface.positions.len()],
    )
    .expect("caster");
    let mut shadows = ShadowMaps::new(ctx, &ShadowMapsDesc::default()).expect("shadow maps");
    shadows
        .set_lights(&scene.lights, mesh_bounds(&graph.surface), true)
        .expect("lights");
    let pass = IrradiancePass::new(ctx, 2).expect("pass");
    let images: Vec<SurfaceImages> = graph
        .levels
        .iter()
        .map(|l| SurfaceImages::upload(ctx, l).expect("images"))
        .collect();
    let sets: Vec<_> = images
        .iter()
        .map(|i| {
            pass.bind_level(ctx, &shadows, &i.position, &i.normal, &i.q, i.surface_rows)
                .expect("set")
        })
        .collect();
    let uniforms = GatherScene::new(&scene, &shadows).expect("scene");
    let finest = graph.finest();
    let q_scale = q_scale_for(&scene, finest, ETA);
    for _frame in 0..2 {
        ctx.execute("gather all levels", |cb| {
            let levels: Vec<_> = sets.iter().zip(&images).collect();
            // SAFETY: `cb` is recording; everything outlives the waited submission.
            unsafe {
                record_gather(
                    ctx, cb, None, &shadows, &caster, &pass, &uniforms, &levels, q_scale,
                )
            }
        })
        .expect("frame");
    }
    for (level, img) in graph.levels.iter().zip(&images) {
        let uploaded = as_uploaded(level);
        let reference = scene.surface_irradiance(&uploaded, ETA, Some(&ball));
        let got = img
            .read_q(ctx, level, Access::ComputeWrite, q_scale)
            .expect("read");
        let max_q = reference.iter().flatten().fold(0.0f64, |m, &v| m.max(v));
        let inner = level.inner_count();
        let mut checked = 0;
        for (s, (g, r)) in got.iter().zip(&reference).enumerate() {
            let p = uploaded.positions[inner + s];
            let n = uploaded.surface_normals[s];
            if scene.lights.iter().any(|l| {
                let c = n.dot(l.arriving(p).1);
                c > 0.0 && c < 0.2
            }) {
                continue; // terminator: PCF may dim it
            }
            checked += 1;
            for c in 0..3 {
                let err = (f64::from(g[c]) - r[c]).abs();
                assert!(
                    err <= RELATIVE_TOLERANCE * r[c] + 1e-6 * max_q,
                    "level with {} nodes, node {s}: GPU {} CPU {}",
                    level.surface_count(),
                    g[c],
                    r[c]
                );
            }
        }
        assert!(checked > level.surface_count() / 3, "{checked}");
    }
    drop((sets, images, pass, shadows, caster));
    gpu.finish();
}

/// The atlas projection of a view lands each point in the view's tile, at the texel the gather
/// computes from the view's own projection.
#[test]
fn atlas_projection_lands_in_the_views_tile() {
    let gpu = GpuTest::new();
    let mut shadows = ShadowMaps::new(
        &gpu.ctx,
        &ShadowMapsDesc {
            tile_resolution: 64,
            max_views: 12,
        },
    )
    .expect("shadow maps");
    let lights: Vec<Light> = ["dir:0,-1,0:1,1,1", "point:0,0,0:1,1,1"]
        .iter()
        .map(|l| l.parse().expect("light"))
        .collect();
    shadows
        .set_lights(&lights, (DVec3::ZERO, 10.0), true)
        .expect("lights");
    assert_eq!(shadows.light_views(), &[(0, 1), (1, 6)]);
    let (w, h) = (shadows.atlas.width as f32, shadows.atlas.height as f32);
    let mut checked = 0;
    for (i, v) in shadows.views().iter().enumerate() {
        let m = shadows.atlas_view_proj(i).expect("view");
        for p in [
            DVec3::new(1.0, -2.0, 3.0),
            DVec3::new(-4.0, 1.0, 0.5),
            DVec3::new(0.5, 0.3, -6.0),
        ] {
            let clip = v.view_proj * p.as_vec3().extend(1.0);
            let own = clip.truncate() / clip.w;
            if clip.w <= 0.0 || own.x.abs() > 1.0 || own.y.abs() > 1.0 {
                continue; // not in this view (another cube face)
            }
            let atlas = m * p.as_vec3().extend(1.0);
            let atlas = atlas.truncate() / atlas.w;
            let texel = [(atlas.x * 0.5 + 0.5) * w, (atlas.y * 0.5 + 0.5) * h];
            let expected = [
                v.origin[0] as f32 + (own.x * 0.5 + 0.5) * v.size as f32,
                v.origin[1] as f32 + (own.y * 0.5 + 0.5) * v.size as f32,
            ];
            assert!(
                (texel[0] - expected[0]).abs() < 1e-3 && (texel[1] - expected[1]).abs() < 1e-3,
                "view {i}: {texel:?} vs {expected:?}"
            );
            assert!((atlas.z - own.z).abs() < 1e-6);
            checked += 1;
        }
    }
    // Each point is in the directional view and in at least one cube face.
    assert!(checked >= 6, "{checked}");
    assert!(shadows.atlas_view_proj(7).is_none());
    drop(shadows);
    gpu.finish();
}
