//! Bounces of exitance between display vertices (issue 12 item 5, `frame::bounce`): the GPU
//! pass `bounce` against its f64 reference (`BounceLinks::apply_bounces`) on two facing boxes,
//! several bounces solving their interreflection, applied once per new exitance (a frame with no new exitance skips it and keeps the sum), zero on a
//! convex sphere, finite everywhere, and on a baked QuadGraph object through the frame graph;
//! light re-entering a thin wall leaving by its far face (the facing boxes are 2 mm walls).

use glam::DVec3;
use translucent::frame::bounce::{vertex_wall_optics, WallOptics};
use translucent::frame::{BounceLinks, BounceParams, CompletedSolve, SkipReason, PASS_BOUNCE};
use translucent::material::{Material, MaterialField};
use translucent::mesh::shapes::Shape;
use translucent::mesh::{TriMesh, Vertex};
use translucent::quadgraph::BakeParams;
use translucent::scene::{Camera, Environment, Scene};
use translucent::solver::gpu::GpuSolveParams;
use translucent::{MethodDesc, ObjectParams, QuadGraph, TranslucentObject};
use translucent_tests::{quadgraph_object, render_once, GpuTest};

fn marble() -> MaterialField {
    MaterialField::Homogeneous(Material::preset("marble").expect("marble"))
}

/// Two boxes facing each other across a 4 mm gap (10 x 10 mm facing squares, 2 mm thick).
fn facing_boxes() -> TriMesh {
    let one = Shape::Box {
        half_extents: DVec3::new(5.0, 1.0, 5.0),
    }
    .triangulate(10);
    let mut mesh = TriMesh::default();
    for dy in [-3.0, 3.0] {
        let base = mesh.positions.len() as u32;
        mesh.positions
            .extend(one.positions.iter().map(|p| *p + DVec3::Y * dy));
        mesh.normals.extend(&one.normals);
        mesh.indices
            .extend(one.indices.iter().map(|t| t.map(|i| i + base)));
    }
    mesh
}

fn scene() -> Scene {
    Scene {
        lights: vec!["dir:0.5,-1,-0.5:4,4,4".parse().unwrap()],
        environment: Environment::None,
    }
}

fn read_exitance(gpu: &GpuTest, object: &TranslucentObject) -> Vec<[f32; 3]> {
    let _ = gpu;
    let bytes = object
        .mesh()
        .vertex_buffer()
        .read_bytes()
        .expect("read back");
    bytes
        .chunks_exact(std::mem::size_of::<Vertex>())
        .map(|c| {
            let at = std::mem::offset_of!(Vertex, exitance);
            std::array::from_fn(|k| {
                let b = &c[at + 4 * k..at + 4 * k + 4];
                f32::from_le_bytes([b[0], b[1], b[2], b[3]])
            })
        })
        .collect()
}

fn fixed_object(gpu: &GpuTest, mesh: &TriMesh) -> TranslucentObject {
    let mut object = TranslucentObject::with_method(
        &gpu.ctx,
        MethodDesc::Exitance {
            mesh: mesh.clone(),
            exitance: vec![[0.0; 3]; mesh.positions.len()],
        },
        &marble(),
        &scene(),
        &ObjectParams {
            specular: false,
            ..ObjectParams::default()
        },
    )
    .expect("object");
    object
        .set_camera(Some(Camera {
            eye: DVec3::new(30.0, 10.0, 40.0),
            target: DVec3::ZERO,
            fovy_deg: 35.0,
        }))
        .expect("camera");
    object
}

/// A smooth, varied exitance per vertex (a different value per channel).
fn pattern(mesh: &TriMesh) -> Vec<[f32; 3]> {
    mesh.positions
        .iter()
        .map(|p| {
            [
                (1.0 + 0.05 * p.x) as f32,
                (0.5 + 0.03 * p.z.abs()) as f32,
                (0.2 + 0.1 * (p.y > 0.0) as u8 as f64) as f32,
            ]
        })
        .collect()
}

#[test]
fn facing_boxes_match_the_f64_bounce_once_per_exitance() {
    let gpu = GpuTest::new();
    let mesh = facing_boxes();
    let links = BounceLinks::build(&mesh, &BounceParams::default()).expect("links");
    assert!(links.link_count() > 0);
    let field = marble();
    let r = vertex_wall_optics(
        &field,
        ObjectParams::default().solve.exit,
        &mesh.positions,
        &links.across,
    );
    assert!(r.reflectance.iter().flatten().all(|&x| x > 0.0 && x < 1.0));
    let mut object = fixed_object(&gpu, &mesh);
    object
        .set_bounce(&gpu.ctx, Some(&links), &field)
        .expect("bounce");
    let x = pattern(&mesh);
    object.set_exitance(&gpu.ctx, &x).expect("exitance");
    let (captured, report) = render_once(&gpu.ctx, &mut object, 48, 48);
    assert!(report.passes.contains(&PASS_BOUNCE), "{:?}", report.passes);
    let got = read_exitance(&gpu, &object);
    // The object's default bounces per exitance.
    let expected = links.apply_bounces(&x, &r, translucent::defaults::BOUNCES);
    let mut raised = 0;
    for (v, (g, e)) in got.iter().zip(&expected).enumerate() {
        for c in 0..3 {
            assert!(g[c].is_finite(), "vertex {v}: {g:?}");
            assert!(
                (g[c] - e[c]).abs() <= GPU_VS_F64_BOUNCES * e[c].max(1.0),
                "vertex {v} channel {c}: GPU {} against f64 {}",
                g[c],
                e[c]
            );
        }
        if g[0] > x[v][0] * 1.01 {
            raised += 1;
        }
    }
    // The facing faces receive; the outer faces do not.
    assert!(raised > 0);
    for (v, p) in mesh.positions.iter().enumerate() {
        if p.y.abs() > 3.9 {
            assert_eq!(links.incoming(v).len(), 0, "outer face vertex {v}");
        }
    }
    assert!(captured
        .image
        .pixels
        .iter()
        .flatten()
        .all(|v| v.is_finite()));
    // No new exitance: the pass is skipped and the sum is not added twice.
    let (_, again) = render_once(&gpu.ctx, &mut object, 48, 48);
    assert!(!again.passes.contains(&PASS_BOUNCE), "{:?}", again.passes);
    assert_eq!(again.skipped.get(PASS_BOUNCE), Some(&SkipReason::Unchanged));
    assert_eq!(read_exitance(&gpu, &object), got);
    drop(object);
    gpu.finish();
}

fn bake(shape: &Shape) -> QuadGraph {
    let params = BakeParams {
        resolution: 16,
        levels: 2,
        ..Default::default()
    };
    QuadGraph::bake(&shape.triangulate(24), shape, &params, &mut |_| {})
        .expect("bake")
        .0
}

/// The exitance a QuadGraph object of `graph` writes in one frame, with the bounce `links` or
/// without, and the frame's passes.
fn quadgraph_exitance(
    gpu: &GpuTest,
    graph: &QuadGraph,
    links: Option<&BounceLinks>,
) -> (Vec<[f32; 3]>, Vec<&'static str>) {
    let field = marble();
    let mut object = quadgraph_object(&gpu.ctx, graph, &field, &scene(), GpuSolveParams::default());
    if links.is_some() {
        object.set_bounce(&gpu.ctx, links, &field).expect("bounce");
    }
    let (captured, report) = render_once(&gpu.ctx, &mut object, 32, 32);
    assert!(captured
        .image
        .pixels
        .iter()
        .flatten()
        .all(|v| v.is_finite()));
    (read_exitance(gpu, &object), report.passes)
}

/// Two GPU solves of the same graph (deterministic on one device), the bounce applied to one,
/// against the f64 bounce of the other's exitance.
const SOLVE_REPEAT: f32 = 1e-4;

#[test]
fn a_convex_sphere_gets_nothing_and_a_torus_hole_gets_the_f64_bounce() {
    let gpu = GpuTest::new();
    let r = |graph: &QuadGraph, links: &BounceLinks| {
        vertex_wall_optics(
            &marble(),
            GpuSolveParams::default().exit,
            &graph.surface.positions,
            &links.across,
        )
    };
    // Sphere: no links; the pass runs and changes nothing.
    let sphere = bake(&Shape::Sphere { radius: 8.0 });
    let links = BounceLinks::build(&sphere.surface, &BounceParams::default()).expect("links");
    assert_eq!(links.link_count(), 0);
    let (plain, _) = quadgraph_exitance(&gpu, &sphere, None);
    let (bounced, passes) = quadgraph_exitance(&gpu, &sphere, Some(&links));
    assert!(passes.contains(&PASS_BOUNCE), "{passes:?}");
    for (a, b) in plain.iter().zip(&bounced) {
        for c in 0..3 {
            assert!(
                (a[c] - b[c]).abs() <= SOLVE_REPEAT * a[c].max(1e-3),
                "{a:?} {b:?}"
            );
        }
    }
    // Torus: the hole's vertices see the other side of the ring.
    let torus = bake(&Shape::Torus {
        major: 8.0,
        minor: 3.0,
    });
    let links = BounceLinks::build(&torus.surface, &BounceParams::default()).expect("links");
    assert!(links.link_count() > 0);
    let (plain, passes) = quadgraph_exitance(&gpu, &torus, None);
    assert!(!passes.contains(&PASS_BOUNCE), "{passes:?}");
    let (bounced, _) = quadgraph_exitance(&gpu, &torus, Some(&links));
    let expected = links.apply_bounces(&plain, &r(&torus, &links), translucent::defaults::BOUNCES);
    let mut raised = 0;
    for (v, (g, e)) in bounced.iter().zip(&expected).enumerate() {
        for c in 0..3 {
            assert!(g[c].is_finite() && g[c] >= 0.0);
            assert!(
                (g[c] - e[c]).abs() <= SOLVE_REPEAT * e[c].max(1e-2),
                "vertex {v} channel {c}: GPU {} against f64 {}",
                g[c],
                e[c]
            );
        }
        raised += usize::from(g[0] > plain[v][0] * 1.001);
    }
    assert!(raised > 0);
    gpu.finish();
}

/// Form factor from a point to a parallel rectangle at distance `c` whose corner lies on the
/// point's normal, sides `a` and `b` (the differential-area-to-rectangle closed form).
fn corner_form_factor(a: f64, b: f64, c: f64) -> f64 {
    let (x, y) = (a / c, b / c);
    let (sx, sy) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
    (x / sx * (y / sx).atan() + y / sy * (x / sy).atan()) / (2.0 * std::f64::consts::PI)
}

/// Stratified cosine-weighted rays: 1024 rays estimate the centre's form factor (0.659) to a few 1e-3.
const FORM_FACTOR_TOL: f64 = 0.01;

#[test]
fn facing_plates_link_with_the_closed_form_factor() {
    let mesh = facing_boxes();
    // The facing squares: half-side 5 mm, 4 mm apart (faces at y = -2 and y = 2).
    let (half, gap) = (5.0, 4.0);
    let params = BounceParams {
        rays: 1024,
        max_links: 256,
    };
    let links = BounceLinks::build(&mesh, &params).expect("links");
    let centre = DVec3::new(0.0, -0.5 * gap, 0.0);
    let v = (0..mesh.positions.len())
        .min_by(|&a, &b| {
            mesh.positions[a]
                .distance(centre)
                .total_cmp(&mesh.positions[b].distance(centre))
        })
        .expect("a vertex");
    assert!(mesh.positions[v].distance(centre) < 1e-9);
    let expected = 4.0 * corner_form_factor(half, half, gap);
    let got = links.form_factor(v);
    assert!(
        (got - expected).abs() < FORM_FACTOR_TOL,
        "form factor {got} against the closed form {expected}"
    );
    // Every link points at the other box.
    for &(y, w) in links.incoming(v) {
        assert!(mesh.positions[y as usize].y > 0.0 && w > 0.0);
    }
    // The cap keeps the sum.
    let capped = BounceLinks::build(
        &mesh,
        &BounceParams {
            rays: 1024,
            max_links: 8,
        },
    )
    .expect("links");
    assert!(capped.incoming(v).len() <= 8);
    assert!((capped.form_factor(v) - got).abs() < 1e-6);
}

/// The per-vertex form factors of the facing plates' inner vertices with `params`: the rms and the
/// largest error against the closed form (four corner rectangles about the vertex's foot).
fn plate_form_factor_errors(params: &BounceParams) -> (f64, f64) {
    let mesh = facing_boxes();
    let (half, gap) = (5.0, 4.0);
    let links = BounceLinks::build(&mesh, params).expect("links");
    let mut errors = Vec::new();
    for (v, p) in mesh.positions.iter().enumerate() {
        // The lower box's facing square, a millimetre in from its edges.
        if (p.y + 0.5 * gap).abs() > 1e-9 || p.x.abs() > half - 1.0 || p.z.abs() > half - 1.0 {
            continue;
        }
        let expected: f64 = [half - p.x, half + p.x]
            .iter()
            .flat_map(|&a| [half - p.z, half + p.z].map(|b| corner_form_factor(a, b, gap)))
            .sum();
        errors.push(links.form_factor(v) - expected);
    }
    assert!(errors.len() >= 49, "{} inner vertices", errors.len());
    let rms = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt();
    (rms, errors.iter().fold(0.0, |m: f64, e| m.max(e.abs())))
}

/// The default links' ray noise: the inner vertices of the facing plates get their form factors
/// within 0.015 rms (the default's 256 rays: 0.0095; 64, the default before wave 11: 0.022, which
/// fails it; benches/RESULTS.md "The front-lit bunny (wave 11)").
#[test]
fn the_default_rays_give_each_plate_vertex_its_closed_form_factor() {
    let (rms, worst) = plate_form_factor_errors(&BounceParams::default());
    let (rms_64, worst_64) = plate_form_factor_errors(&BounceParams {
        rays: 64,
        ..BounceParams::default()
    });
    eprintln!(
        "form factor error rms {rms:.4} (worst {worst:.4}); at 64 rays {rms_64:.4} ({worst_64:.4})"
    );
    assert!(
        rms < 0.015,
        "form factor error rms {rms} (worst {worst}); at 64 rays {rms_64} ({worst_64})"
    );
}

#[test]
fn a_convex_sphere_has_no_links_and_bad_parameters_are_typed_errors() {
    let mesh = Shape::Sphere { radius: 10.0 }.triangulate(16);
    let links = BounceLinks::build(&mesh, &BounceParams::default()).expect("links");
    assert_eq!(links.vertex_count(), mesh.positions.len());
    assert_eq!(links.link_count(), 0);
    for (rays, max_links) in [(0, 8), (64, 0), (100_000, 8)] {
        let err = BounceLinks::build(&mesh, &BounceParams { rays, max_links });
        assert!(
            matches!(err, Err(translucent::Error::Render(_))),
            "{rays} {max_links}"
        );
    }
    assert!("solve".parse::<translucent::frame::BounceMode>().is_err());
}

/// The links are stored with the bake: a cache file round trip keeps them bit for bit, and a
/// file whose links index past the display vertices is refused with a typed error.
#[test]
fn links_survive_the_bake_cache_and_bad_links_are_refused() {
    let torus = Shape::Torus {
        major: 8.0,
        minor: 3.0,
    };
    let mut graph = bake(&torus);
    assert!(graph.bounce.is_none(), "a bake carries no links");
    let params = BounceParams {
        rays: 16,
        max_links: 8,
    };
    let links = BounceLinks::build(&graph.surface, &params).expect("links");
    assert!(links.link_count() > 0 && links.built_with(&params));
    assert!(!links.built_with(&BounceParams::default()));
    graph.bounce = Some(links.clone());
    let key = 7;
    let path = std::path::Path::new("torus.qgraph");
    let back = QuadGraph::from_cache_bytes(&graph.to_cache_bytes(key), path, Some(key))
        .expect("round trip");
    assert_eq!(back.bounce.as_ref(), Some(&links));
    // Without links: None again.
    graph.bounce = None;
    let back = QuadGraph::from_cache_bytes(&graph.to_cache_bytes(key), path, Some(key))
        .expect("round trip");
    assert!(back.bounce.is_none());
    // A link to a vertex the surface does not have.
    let mut bad = links.clone();
    bad.links[0].0 = graph.surface.positions.len() as u32;
    graph.bounce = Some(bad);
    let err = QuadGraph::from_cache_bytes(&graph.to_cache_bytes(key), path, Some(key));
    assert!(
        matches!(&err, Err(e) if e.to_string().contains("bounce link")),
        "{err:?}"
    );
    // A negative form factor.
    let mut bad = links;
    bad.links[0].1 = -1.0;
    graph.bounce = Some(bad);
    assert!(QuadGraph::from_cache_bytes(&graph.to_cache_bytes(key), path, Some(key)).is_err());
}

/// The convex early-out on the meshes the bounce meets: the sphere is convex (no links, no ray
/// cast), the torus and the U-block-like facing boxes are not.
#[test]
fn the_sphere_is_convex_and_the_torus_is_not() {
    use translucent::frame::bounce::is_convex;
    let sphere = bake(&Shape::Sphere { radius: 8.0 });
    assert!(is_convex(&sphere.surface));
    let torus = bake(&Shape::Torus {
        major: 8.0,
        minor: 3.0,
    });
    assert!(!is_convex(&torus.surface));
    assert!(!is_convex(&facing_boxes()));
}

/// f32 sums over several bounces (each re-reads the last one's f32 exitance) against the f64
/// recurrence, relative to the value.
const GPU_VS_F64_BOUNCES: f32 = 1e-4;
/// Relative residual of X = X_0 + R_d F X the interreflection must reach: R_d F is ~0.55 at
/// the facing squares' centres, so 16 bounces leave 0.55^16 ~ 1e-4 of it.
const FIXED_POINT_TOL: f64 = 1e-3;
/// What one bounce leaves of that residual at the centres (R_d F)^2 / (1 + R_d F) ~ 0.2: a pass
/// that bounces once fails [`FIXED_POINT_TOL`] by far.
const ONE_BOUNCE_RESIDUAL: f64 = 0.1;

/// The largest relative residual of X = X_0 + (R + T P) F max(X, 0) over the vertices that
/// receive (P: the far face of each vertex's wall, through its crossing's weights).
fn interreflection_residual(
    links: &BounceLinks,
    first: &[[f32; 3]],
    optics: &WallOptics,
    x: &[[f32; 3]],
) -> f64 {
    let gathered: Vec<[f64; 3]> = (0..links.vertex_count())
        .map(|v| {
            std::array::from_fn(|c| {
                links
                    .incoming(v)
                    .iter()
                    .map(|&(y, w)| f64::from(w) * f64::from(x[y as usize][c].max(0.0)))
                    .sum()
            })
        })
        .collect();
    let mut worst = 0.0f64;
    for v in 0..links.vertex_count() {
        let wall = links.crossing(v);
        for c in 0..3 {
            let far: f64 = (0..3)
                .map(|k| f64::from(wall.weights[k]) * gathered[wall.vertices[k] as usize][c])
                .sum();
            let added = f64::from(optics.reflectance[v][c]) * gathered[v][c]
                + f64::from(optics.transmittance[v][c]) * far;
            if added == 0.0 {
                continue;
            }
            let want = f64::from(first[v][c]) + added;
            worst = worst.max((f64::from(x[v][c]) - want).abs() / want.max(1e-6));
        }
    }
    worst
}

/// Several bounces (issue 12, the back-lit plate's foot: light that left the plate enters the
/// base, leaves it and enters the plate again): the GPU pass's recurrence equals the f64
/// reference's, and enough bounces solve the interreflection X = X_0 + R_d F X between the
/// facing boxes, which one bounce does not; a count outside the range is a typed error.
#[test]
fn facing_boxes_interreflect_over_several_bounces_as_the_f64_reference() {
    use translucent::frame::bounce::BOUNCE_RANGE;
    let gpu = GpuTest::new();
    let mesh = facing_boxes();
    let links = BounceLinks::build(&mesh, &BounceParams::default()).expect("links");
    let field = marble();
    let r = vertex_wall_optics(
        &field,
        ObjectParams::default().solve.exit,
        &mesh.positions,
        &links.across,
    );
    let x = pattern(&mesh);
    // The f64 recurrence: 16 bounces reach the fixed point, one does not.
    let once = links.apply(&x, &r);
    let many = links.apply_bounces(&x, &r, *BOUNCE_RANGE.end());
    let one_residual = interreflection_residual(&links, &x, &r, &once);
    let many_residual = interreflection_residual(&links, &x, &r, &many);
    assert!(
        one_residual > ONE_BOUNCE_RESIDUAL,
        "one bounce: {one_residual}"
    );
    assert!(
        many_residual < FIXED_POINT_TOL,
        "{} bounces: {many_residual}",
        BOUNCE_RANGE.end()
    );
    // The GPU pass, four bounces set after the links.
    let bounces = 4;
    let mut object = fixed_object(&gpu, &mesh);
    object
        .set_bounce(&gpu.ctx, Some(&links), &field)
        .expect("bounce");
    object.set_bounces(bounces).expect("bounces");
    assert_eq!(object.bounce().map(|b| b.bounces()), Some(bounces));
    object.set_exitance(&gpu.ctx, &x).expect("exitance");
    let (captured, report) = render_once(&gpu.ctx, &mut object, 48, 48);
    assert!(report.passes.contains(&PASS_BOUNCE), "{:?}", report.passes);
    let got = read_exitance(&gpu, &object);
    let expected = links.apply_bounces(&x, &r, bounces);
    let mut above_once = 0;
    for (v, (g, e)) in got.iter().zip(&expected).enumerate() {
        for c in 0..3 {
            assert!(
                g[c].is_finite() && (g[c] - e[c]).abs() <= GPU_VS_F64_BOUNCES * e[c].max(1.0),
                "vertex {v} channel {c}: GPU {} against f64 {}",
                g[c],
                e[c]
            );
        }
        above_once += usize::from(g[0] > once[v][0] * 1.01);
    }
    assert!(above_once > 0, "four bounces add nothing to one");
    assert!(captured
        .image
        .pixels
        .iter()
        .flatten()
        .all(|v| v.is_finite()));
    for bad in [0, BOUNCE_RANGE.end() + 1] {
        assert!(
            matches!(object.set_bounces(bad), Err(translucent::Error::Render(_))),
            "{bad}"
        );
    }
    assert_eq!(object.bounce().map(|b| b.bounces()), Some(bounces));
    drop(object);
    gpu.finish();
}

/// The wall crossing's thickness against the facing boxes' 2 mm (f32 storage of an f64 cast).
const THICKNESS_TOL: f32 = 1e-4;
/// One bounce in f64 against T E_b computed here (f32 storage of the values).
const F64_TRANSMISSION_TOL: f64 = 1e-5;

/// A thin wall (issue 12, the back-lit plate on its base: light that the lit base throws onto
/// the plate's back face shows on its front face). The facing boxes are 2 mm thick and their
/// outer faces see nothing through the air, so after one bounce an outer vertex gains exactly
/// T(2 mm) E_b of the facing vertex across the wall, a pass without transmission nothing; the
/// GPU pass adds the same as the f64 reference at every vertex.
#[test]
fn a_thin_wall_passes_re_entering_light_to_its_far_face() {
    let gpu = GpuTest::new();
    let mesh = facing_boxes();
    let links = BounceLinks::build(&mesh, &BounceParams::default()).expect("links");
    let field = marble();
    let optics = vertex_wall_optics(
        &field,
        ObjectParams::default().solve.exit,
        &mesh.positions,
        &links.across,
    );
    let x = pattern(&mesh);
    let once = links.apply(&x, &optics);
    let at = |p: DVec3| {
        mesh.positions
            .iter()
            .position(|q| (*q - p).length() < 1e-9)
            .expect("a vertex there")
    };
    let (outer, facing) = (at(DVec3::new(0.0, 4.0, 0.0)), at(DVec3::new(0.0, 2.0, 0.0)));
    assert!(links.incoming(outer).is_empty());
    let wall = links.crossing(outer);
    assert!((wall.thickness - 2.0).abs() < THICKNESS_TOL, "{wall:?}");
    let on_facing: f32 = (0..3)
        .filter(|&k| wall.vertices[k] as usize == facing)
        .map(|k| wall.weights[k])
        .sum();
    assert!((on_facing - 1.0).abs() < THICKNESS_TOL, "{wall:?}");
    for c in 0..3 {
        let t = f64::from(optics.transmittance[outer][c]);
        // Marble's 2 mm wall passes a good part of diffuse light, and reflects less than the
        // half-space would.
        assert!(
            t > 0.1 && t < f64::from(optics.reflectance[facing][c]),
            "T {t}"
        );
        let e: f64 = links
            .incoming(facing)
            .iter()
            .map(|&(y, w)| f64::from(w) * f64::from(x[y as usize][c]))
            .sum();
        let gain = f64::from(once[outer][c]) - f64::from(x[outer][c]);
        assert!(
            (gain - t * e).abs() <= F64_TRANSMISSION_TOL * (t * e).max(1.0)
                && gain > 0.05 * f64::from(x[outer][c]),
            "channel {c}: gain {gain} against T E_b {}",
            t * e
        );
    }
    let mut object = fixed_object(&gpu, &mesh);
    object
        .set_bounce(&gpu.ctx, Some(&links), &field)
        .expect("bounce");
    object.set_bounces(1).expect("bounces");
    object.set_exitance(&gpu.ctx, &x).expect("exitance");
    let (_, report) = render_once(&gpu.ctx, &mut object, 48, 48);
    assert!(report.passes.contains(&PASS_BOUNCE), "{:?}", report.passes);
    let got = read_exitance(&gpu, &object);
    for (v, (g, e)) in got.iter().zip(&once).enumerate() {
        for c in 0..3 {
            assert!(
                g[c].is_finite() && (g[c] - e[c]).abs() <= GPU_VS_F64_BOUNCES * e[c].max(1.0),
                "vertex {v} channel {c}: GPU {} against f64 {}",
                g[c],
                e[c]
            );
        }
    }
    drop(object);
    gpu.finish();
}

/// q is stored in fp16 (a relative step of 2^-11 on q, twice: with and without the source).
const Q_FP16: f32 = 2e-3;

/// `--bounce source` (issue 12, the back-lit plate's base front): the bounced light is a source of
/// a second solve. (1) The finest surface nodes' q grows by exactly the f64 reference's
/// T_d E_b (`NodeGather::node_sources` of `BounceLinks::last_irradiance` of the exitance without
/// bounce) at the solve's exposure; (2) light that re-entered the torus's hole travels inside:
/// vertices that see nothing (no links, E_b = 0: the local bounce leaves them as they were) get
/// brighter only with the source (the tube's top and bottom: nothing reaches them or their
/// wall's far side through the air).
#[test]
fn the_bounce_source_adds_the_f64_node_sources_and_carries_light_inside() {
    use translucent::frame::bounce::{
        NodeGather, PASS_BOUNCE_EXITANCE, PASS_BOUNCE_SOLVE, PASS_BOUNCE_SOURCE,
    };
    use translucent::frame::{BounceMode, QuadGraphMethod};
    let gpu = GpuTest::new();
    let field = marble();
    let torus = bake(&Shape::Torus {
        major: 8.0,
        minor: 3.0,
    });
    let links = BounceLinks::build(&torus.surface, &BounceParams::default()).expect("links");
    let object = |mode: BounceMode| {
        let mut object = marble_object(&gpu, &torus, &links, mode);
        let (captured, report) = render_once(&gpu.ctx, &mut object, 32, 32);
        assert!(captured
            .image
            .pixels
            .iter()
            .flatten()
            .all(|v| v.is_finite()));
        let method = object
            .method()
            .as_any()
            .downcast_ref::<QuadGraphMethod>()
            .expect("quadgraph");
        let q = method.solve().read_q(&gpu.ctx).expect("q");
        (read_exitance(&gpu, &object), q, report.passes)
    };
    let (plain, q_plain, _) = object(BounceMode::Off);
    let (local, q_local, passes) = object(BounceMode::Local);
    assert!(!passes.contains(&PASS_BOUNCE_SOURCE), "{passes:?}");
    assert_eq!(q_local, q_plain);
    let (source, q_source, passes) = object(BounceMode::Source);
    for pass in [
        PASS_BOUNCE,
        PASS_BOUNCE_SOURCE,
        PASS_BOUNCE_SOLVE,
        PASS_BOUNCE_EXITANCE,
    ] {
        assert!(passes.contains(&pass), "{pass}: {passes:?}");
    }
    // (1) q grows by the f64 source.
    let optics = vertex_wall_optics(
        &field,
        ObjectParams::default().solve.exit,
        &torus.surface.positions,
        &links.across,
    );
    let e_b = links.last_irradiance(&plain, &optics, translucent::defaults::BOUNCES);
    let t_d = translucent::solver::transport::Boundary::new(
        field.eta(),
        ObjectParams::default().solve.exit,
    )
    .diffuse_transmittance();
    let gather = NodeGather::build(&torus);
    assert_eq!(
        gather.covered(),
        gather.node_count(),
        "every node takes E_b"
    );
    let want = gather.node_sources(&e_b, t_d);
    assert_eq!(q_plain.len(), want.len());
    let top = q_plain.iter().flatten().fold(0.0f32, |m, &v| m.max(v));
    let mut lit = 0;
    for (s, w) in want.iter().enumerate() {
        for c in 0..3 {
            let got = q_source[s][c] - q_plain[s][c];
            assert!(
                (f64::from(got) - w[c]).abs() <= f64::from(Q_FP16 * q_source[s][c].max(1e-3 * top)),
                "surface node {s} channel {c}: q grew by {got}, the f64 source is {}",
                w[c]
            );
        }
        lit += usize::from(w[0] > 1e-2 * f64::from(top));
    }
    assert!(lit > 0, "no node takes a bounce worth testing");
    // (2) Vertices that see nothing: the local bounce leaves them, the source lights them.
    let mut raised = 0;
    for v in 0..plain.len() {
        assert!(source[v].iter().all(|x| x.is_finite() && *x >= 0.0));
        // Nothing arrives here or at the wall's far side (the tube's top and bottom).
        let wall = links.crossing(v);
        let far_dark = (0..3).all(|k| {
            wall.weights[k] <= 0.0 || links.incoming(wall.vertices[k] as usize).is_empty()
        });
        if !links.incoming(v).is_empty() || !far_dark {
            continue;
        }
        assert!(
            (local[v][0] - plain[v][0]).abs() <= SOLVE_REPEAT * plain[v][0].max(1e-3),
            "vertex {v}: {local:?} {plain:?}",
            local = local[v],
            plain = plain[v]
        );
        raised += usize::from(source[v][0] > plain[v][0] * 1.001 + 1e-6);
    }
    assert!(raised > 0, "no vertex without links got light from inside");
    gpu.finish();
}

/// A marble object of `graph` without single scattering, with the bounce `mode` (its `links`
/// set unless off).
fn marble_object(
    gpu: &GpuTest,
    graph: &QuadGraph,
    links: &BounceLinks,
    mode: translucent::frame::BounceMode,
) -> TranslucentObject {
    let field = marble();
    let mut object = TranslucentObject::new(
        &gpu.ctx,
        std::sync::Arc::new(graph.clone()),
        &field,
        &scene(),
        &ObjectParams {
            single_scattering: None,
            diffusion: field.diffusion(),
            bounce: mode,
            ..ObjectParams::default()
        },
    )
    .expect("object");
    if mode != translucent::frame::BounceMode::Off {
        object
            .set_bounce(&gpu.ctx, Some(links), &field)
            .expect("bounce");
    }
    object
}

/// `--bounce source`'s second solve converged relative to its start (the bounce's share of q,
/// [`translucent::frame::QuadGraphMethod::set_bounce_tolerance`]) against the full second solve
/// (relative tolerance 0: the solve's own tolerance) on the torus: (0) the frame reports both
/// solves, the first as the frame without the source ran it; (1) the cheap solve stops
/// below its tolerance times its start residual, in no more V-cycles than the full solve's mean
/// factor needs for that reduction (+1), and does less work than the full solve; (2) its
/// exitance is within the tolerance times what the source adds (the full solve's exitance minus
/// the one without bounce) of the full solve's, at every display vertex; (3) a tolerance outside
/// [0, 1) is a typed error.
#[test]
fn the_cheap_bounce_solve_converges_on_its_increment_and_keeps_the_full_solves_exitance() {
    use translucent::frame::BounceMode;
    use translucent::solver::gpu::multigrid::GpuMultigridReport;
    let gpu = GpuTest::new();
    let field = marble();
    let torus = bake(&Shape::Torus {
        major: 8.0,
        minor: 3.0,
    });
    let links = BounceLinks::build(&torus.surface, &BounceParams::default()).expect("links");
    let object = |mode: BounceMode, tolerance: f32| {
        let mut object = marble_object(&gpu, &torus, &links, mode);
        object.set_bounce_tolerance(tolerance).expect("tolerance");
        let (captured, _) = render_once(&gpu.ctx, &mut object, 32, 32);
        assert!(captured
            .image
            .pixels
            .iter()
            .flatten()
            .all(|v| v.is_finite()));
        let solve = object
            .completed_solves(u64::MAX)
            .expect("solves")
            .pop()
            .expect("a completed solve");
        (read_exitance(&gpu, &object), solve)
    };
    let tolerance = translucent::defaults::BOUNCE_TOLERANCE;
    let (plain, plain_solve) = object(BounceMode::Off, tolerance);
    let (full, full_solve) = object(BounceMode::Source, 0.0);
    let (cheap, cheap_solve) = object(BounceMode::Source, tolerance);
    // (0) The frame reports both solves: the first as the frame without the source ran it (the
    // same q), the second on its own.
    let first = |s: &CompletedSolve| -> GpuMultigridReport {
        s.multigrid.clone().expect("the first solve's report")
    };
    assert!(plain_solve.bounce.is_none(), "{plain_solve:?}");
    for s in [&full_solve, &cheap_solve] {
        let (f, p) = (first(s), first(&plain_solve));
        assert!(!f.warm && f.converged, "{f:?}");
        assert_eq!(
            (f.cycles.len(), f.work_units),
            (p.cycles.len(), p.work_units),
            "the first solve of a --bounce source frame against the frame without it"
        );
    }
    let full_report = full_solve
        .bounce
        .clone()
        .expect("the bounce solve's report");
    let cheap_report = cheap_solve
        .bounce
        .clone()
        .expect("the bounce solve's report");
    println!("full: {full_report:?}\ncheap: {cheap_report:?}");
    // (1) Converged on the increment, in the cycles the full solve's factor allows.
    for r in [&full_report, &cheap_report] {
        assert!(r.warm && r.converged, "{r:?}");
        assert!(
            r.residual.is_finite() && r.start_residual.is_finite(),
            "{r:?}"
        );
    }
    assert!(
        cheap_report.residual <= f64::from(tolerance) * cheap_report.start_residual
            || cheap_report.residual <= f64::from(ObjectParams::default().solve.tolerance),
        "{cheap_report:?}"
    );
    let rho = full_report
        .mean_factor
        .expect("the full solve runs two cycles or more");
    assert!(rho > 0.0 && rho < 1.0, "{full_report:?}");
    let allowed = (f64::from(tolerance).ln() / rho.ln()).ceil() as usize + 1;
    assert!(
        cheap_report.cycles.len() <= allowed,
        "{} cycles, the full solve's factor {rho:.3} reaches {tolerance} in {allowed}",
        cheap_report.cycles.len()
    );
    assert!(
        cheap_report.work_units < full_report.work_units,
        "cheap {} work units, full {}",
        cheap_report.work_units,
        full_report.work_units
    );
    // (2) The exitance: within the tolerance times the source's share of the full solve's.
    let share = full
        .iter()
        .zip(&plain)
        .flat_map(|(f, p)| (0..3).map(move |c| (f[c] - p[c]).abs()))
        .fold(0.0f32, f32::max);
    assert!(share > 0.0, "the source added nothing");
    let worst = cheap
        .iter()
        .zip(&full)
        .flat_map(|(c, f)| (0..3).map(move |k| (c[k] - f[k]).abs()))
        .fold(0.0f32, f32::max);
    println!("cheap - full: at most {worst}, the source's share at most {share}");
    for (v, (c, f)) in cheap.iter().zip(&full).enumerate() {
        for k in 0..3 {
            assert!(c[k].is_finite(), "vertex {v}: {c:?}");
            assert!(
                (c[k] - f[k]).abs() <= tolerance * share,
                "vertex {v} channel {k}: cheap {} full {} (the source's share {share})",
                c[k],
                f[k]
            );
        }
    }
    // (3) Bad tolerances are typed errors.
    let mut object = quadgraph_object(
        &gpu.ctx,
        &torus,
        &field,
        &scene(),
        ObjectParams::default().solve,
    );
    for bad in [-0.1, 1.0, f32::NAN, f32::INFINITY] {
        assert!(object.set_bounce_tolerance(bad).is_err(), "{bad}");
    }
    drop(object);
    gpu.finish();
}

/// `--bounce source` on warm frames (the light turning 3 degrees a frame, as a host's frames):
/// each frame's first solve is the solve of the frame without the source, to its cycles, work
/// units and residual, because it continues the last first solution, kept across the second
/// solve; and the frame reports both solves. (Before the kept solution, a warm first solve
/// started from the second's sum, a whole bounce away: on the default scene 51.3 work units
/// against 29.7.)
#[test]
fn a_warm_frame_with_the_bounce_source_solves_first_as_the_frame_without_it() {
    use translucent::frame::BounceMode;
    let gpu = GpuTest::new();
    let torus = bake(&Shape::Torus {
        major: 8.0,
        minor: 3.0,
    });
    let links = BounceLinks::build(&torus.surface, &BounceParams::default()).expect("links");
    let frames = |mode: BounceMode| -> Vec<CompletedSolve> {
        let mut object = marble_object(&gpu, &torus, &links, mode);
        let mut solves = Vec::new();
        for k in 0..4 {
            let angle = (3.0 * f64::from(k)).to_radians();
            let direction = glam::DMat3::from_rotation_y(angle) * DVec3::new(0.5, -1.0, -0.5);
            let lit = Scene {
                lights: vec![translucent::scene::Light::Directional {
                    direction: direction.normalize(),
                    irradiance: [4.0; 3],
                }],
                environment: Environment::None,
            };
            object.set_lights(&lit).expect("lights");
            let _ = render_once(&gpu.ctx, &mut object, 32, 32);
            solves.extend(object.completed_solves(u64::MAX).expect("solves"));
        }
        solves
    };
    let plain = frames(BounceMode::Off);
    let source = frames(BounceMode::Source);
    assert_eq!(plain.len(), 4, "{plain:?}");
    assert_eq!(source.len(), 4, "{source:?}");
    for (k, (p, s)) in plain.iter().zip(&source).enumerate() {
        let (p1, s1) = (
            p.multigrid.as_ref().expect("multigrid"),
            s.multigrid.as_ref().expect("multigrid"),
        );
        assert_eq!(s1.warm, k > 0, "frame {k}");
        assert_eq!(
            (s1.cycles.len(), s1.work_units, s1.warm_order),
            (p1.cycles.len(), p1.work_units, p1.warm_order),
            "frame {k}: the first solve with the source against the frame without it"
        );
        let rel = (s1.residual - p1.residual).abs() / p1.residual;
        assert!(
            rel < 1e-3,
            "frame {k}: residual {} against {}",
            s1.residual,
            p1.residual
        );
        assert!(p.bounce.is_none(), "frame {k}");
        let b = s.bounce.as_ref().expect("the bounce solve's report");
        assert!(
            b.warm && b.converged && b.work_units > 0.0,
            "frame {k}: {b:?}"
        );
    }
    gpu.finish();
}
