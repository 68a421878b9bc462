//! A deforming object with the dipole method (issue 15, item 3): `TranslucentObject::deform`
//! refits the face-cluster hierarchy, relinks it and copies the moved vertices into the display
//! mesh and the leaf images (`dipole_deform`) under Khronos + synchronization validation. The
//! deformed frame's J+ must be what the CPU evaluates on the deformed hierarchy with its links,
//! differ from the rest pose's, and come back to it under `Deformation::Identity`.

use std::sync::Arc;

use glam::{DVec3, Mat4, Vec3};
use translucent::frame::dipole::{DipoleParams, Relink, PASS_DEFORM, PASS_LINKS};
use translucent::frame::DipoleMethod;
use translucent::material::{Material, MaterialField};
use translucent::mesh::shapes::Shape;
use translucent::mesh::Vertex;
use translucent::object::MethodDesc;
use translucent::scene::{Environment, Scene};
use translucent::solver::dipole::{irradiance, links, FaceClusterHierarchy};
use translucent::solver::gpu::Deformation;
use translucent::{ObjectParams, TranslucentObject};
use translucent_tests::{render_once, GpuTest};

const SIZE: u32 = 24;
/// GPU J+ against the f64 evaluation of the same links (as dipole_object.rs): fp16 leaf
/// irradiance (2^-11 relative) and f32 sums.
const GPU_VS_CPU: f64 = 2e-3;
/// The display mesh's positions against the f64 map, mm: f32 round-off at 20 mm.
const POSITION: f32 = 1e-4;
/// Squashing the 10 mm sphere to a 5 mm thick disc must change the exitance by more than this
/// relative RMS (printed): top and bottom come within marble's diffusion length (8.5 mm red).
const MIN_CHANGE: f64 = 0.02;

/// Incremental relinking against relinking from scratch, relative RMS of J+: both sets meet the
/// oracle, whose error against the brute-force sum is bounded by 1e-2 (links.rs's
/// HIERARCHY_VS_BRUTE_FORCE).
const INCREMENTAL_VS_FULL: f64 = 1e-2;
/// Form factors per frame in the incremental test: a few frames for the test sphere's links.
const BUDGET: u64 = 40_000;
/// Frames the incremental test waits for the queue to drain.
const MAX_FRAMES: usize = 100;

fn squash() -> Deformation {
    Deformation::Affine(Mat4::from_scale(Vec3::new(1.2, 0.25, 1.2)))
}

fn stretch() -> Deformation {
    Deformation::Affine(Mat4::from_scale(Vec3::new(1.0, 1.6, 1.0)))
}

/// (display J+, CPU J+ of the method's own hierarchy and links), per vertex.
fn exitance(object: &TranslucentObject, scene: &Scene) -> (Vec<[f32; 3]>, Vec<[f64; 3]>) {
    let method = object
        .method()
        .as_any()
        .downcast_ref::<DipoleMethod>()
        .expect("dipole");
    let tree = method.hierarchy();
    let material = method.material();
    let e = irradiance::leaf_irradiance(tree, scene, material.base.eta, None).expect("E");
    let node = links::pull(tree, &e);
    let received = links::gather(tree, &material.profile, method.links().0, &node);
    let leaf = links::push_constant(tree, &received);
    let f_dr = material.base.f_dr();
    let want: Vec<[f64; 3]> = links::to_vertices(tree, &leaf, None)
        .iter()
        .map(|m| m.map(|x| x / (1.0 - f_dr)))
        .collect();
    (
        display(object, std::mem::offset_of!(Vertex, exitance)),
        want,
    )
}

fn wide(v: &[[f32; 3]]) -> Vec<[f64; 3]> {
    v.iter().map(|x| x.map(f64::from)).collect()
}

/// Three floats per display vertex at byte `offset` of each vertex.
fn display(object: &TranslucentObject, offset: usize) -> Vec<[f32; 3]> {
    let bytes = object.mesh().vertex_buffer().read_bytes().expect("read");
    let stride = std::mem::size_of::<Vertex>();
    let float = |at: usize| f32::from_le_bytes(bytes[at..at + 4].try_into().expect("4 bytes"));
    (0..object.mesh().vertex_count())
        .map(|v| std::array::from_fn(|c| float(v * stride + offset + 4 * c)))
        .collect()
}

fn sphere_object(
    ctx: &translucent::vk::Context,
    field: &MaterialField,
    scene: &Scene,
    relink: Relink,
) -> TranslucentObject {
    let mesh = Shape::Sphere { radius: 10.0 }.triangulate(10);
    let (tree, _) = FaceClusterHierarchy::build(&mesh).expect("hierarchy");
    TranslucentObject::with_method(
        ctx,
        MethodDesc::Dipole {
            mesh,
            hierarchy: Arc::new(tree),
            params: DipoleParams {
                relink,
                ..DipoleParams::default()
            },
        },
        field,
        scene,
        &ObjectParams::default(),
    )
    .expect("object")
}

/// Renders until the incremental queue drained; returns the frames it took. Checks every step
/// stayed within its budget (a split may add one form factor).
fn drain(ctx: &translucent::vk::Context, object: &mut TranslucentObject) -> usize {
    for frame in 1..=MAX_FRAMES {
        render_once(ctx, object, SIZE, SIZE);
        let method = object
            .method()
            .as_any()
            .downcast_ref::<DipoleMethod>()
            .expect("dipole");
        let (step, pending) = method.incremental_step().expect("incremental mode");
        assert!(step.form_factors <= BUDGET + 2, "{step:?}");
        if pending == 0 {
            return frame;
        }
    }
    panic!("the incremental queue did not drain in {MAX_FRAMES} frames");
}

#[test]
fn incremental_relinking_spreads_bounded_work_over_frames_and_meets_a_full_relink() {
    let gpu = GpuTest::new();
    let scene = Scene {
        lights: vec![],
        environment: Environment::Constant([0.5, 0.4, 0.3]),
    };
    let marble = MaterialField::Homogeneous(Material::preset("marble").expect("preset"));
    let incremental = Relink::Incremental {
        form_factors_per_frame: BUDGET,
    };
    let mut object = sphere_object(&gpu.ctx, &marble, &scene, incremental);
    let mut full = sphere_object(&gpu.ctx, &marble, &scene, Relink::Full);
    render_once(&gpu.ctx, &mut object, SIZE, SIZE);

    // A deformation: refit now, relink over the next frames.
    object.deform(&gpu.ctx, &stretch()).expect("deform");
    full.deform(&gpu.ctx, &stretch()).expect("deform");
    let frames = drain(&gpu.ctx, &mut object);
    render_once(&gpu.ctx, &mut full, SIZE, SIZE);
    let (got, want) = exitance(&object, &scene);
    let (reference, _) = exitance(&full, &scene);
    let error = translucent::solver::rel_rms(&got, &want);
    let against_full = translucent::solver::rel_rms(&got, &wide(&reference));
    println!("deformation: drained in {frames} frames; GPU vs CPU {error:.2e}, against a full relink {against_full:.2e}");
    assert!(frames > 1, "the budget did not spread the work over frames");
    assert!(error < GPU_VS_CPU, "{error}");
    assert!(against_full < INCREMENTAL_VS_FULL, "{against_full}");

    // A material change: every link stale, re-evaluated over the next frames.
    let milk = MaterialField::Homogeneous(Material::preset("skimmilk").expect("preset"));
    object.set_material(&gpu.ctx, &milk).expect("material");
    full.set_material(&gpu.ctx, &milk)
        .expect("material (a larger link set)");
    let frames = drain(&gpu.ctx, &mut object);
    render_once(&gpu.ctx, &mut full, SIZE, SIZE);
    let (got, _) = exitance(&object, &scene);
    let (reference, _) = exitance(&full, &scene);
    let against_full = translucent::solver::rel_rms(&got, &wide(&reference));
    println!("material: drained in {frames} frames; against a full relink {against_full:.2e}");
    assert!(frames > 1, "the budget did not spread the work over frames");
    assert!(against_full < INCREMENTAL_VS_FULL, "{against_full}");
    drop((object, full));
    gpu.finish();
}

#[test]
fn a_deformed_dipole_object_is_relinked_and_gathers_on_its_new_shape() {
    let gpu = GpuTest::new();
    let scene = Scene {
        lights: vec![],
        environment: Environment::Constant([0.5, 0.4, 0.3]),
    };
    let mesh = Shape::Sphere { radius: 10.0 }.triangulate(10);
    let rest: Vec<DVec3> = mesh.positions.clone();
    let (tree, _) = FaceClusterHierarchy::build(&mesh).expect("hierarchy");
    let field = MaterialField::Homogeneous(Material::preset("marble").expect("preset"));
    let mut object = TranslucentObject::with_method(
        &gpu.ctx,
        MethodDesc::Dipole {
            mesh,
            hierarchy: Arc::new(tree),
            params: DipoleParams::default(),
        },
        &field,
        &scene,
        &ObjectParams::default(),
    )
    .expect("object");
    render_once(&gpu.ctx, &mut object, SIZE, SIZE);
    let (rest_jplus, _) = exitance(&object, &scene);

    // Tetrahedron positions are a QuadGraph's: a typed error that changes nothing.
    let e = object
        .deform(&gpu.ctx, &Deformation::TetPositions(vec![]))
        .expect_err("tet positions");
    assert!(e.to_string().contains("analytic"), "{e}");

    object.deform(&gpu.ctx, &squash()).expect("deform");
    let (_, report) = render_once(&gpu.ctx, &mut object, SIZE, SIZE);
    for pass in [PASS_DEFORM, PASS_LINKS] {
        assert!(report.passes.contains(&pass), "{:?}", report.passes);
    }
    let positions = display(&object, std::mem::offset_of!(Vertex, position));
    for (p, r) in positions.iter().zip(&rest) {
        let want = squash().map_point(*r).expect("analytic").as_vec3();
        assert!(
            (Vec3::from(*p) - want).abs().max_element() < POSITION,
            "{p:?} vs {want}"
        );
    }
    let (got, want) = exitance(&object, &scene);
    let error = translucent::solver::rel_rms(&got, &want);
    let change = translucent::solver::rel_rms(&got, &wide(&rest_jplus));
    let method = object
        .method()
        .as_any()
        .downcast_ref::<DipoleMethod>()
        .expect("dipole");
    println!(
        "squashed: GPU vs CPU {error:.2e}, change from the rest pose {change:.3}, {} links",
        method.links().0.len()
    );
    assert!(
        error < GPU_VS_CPU,
        "GPU vs CPU J+ after deformation: {error}"
    );
    assert!(
        change > MIN_CHANGE,
        "the squash changed J+ by only {change}"
    );
    // The hierarchy follows the shape: the root's area is the squashed surface's (smaller).
    let root = &method.hierarchy().geometry[method.hierarchy().root() as usize];
    let sphere_area = 4.0 * std::f64::consts::PI * 100.0;
    assert!(root.area < 0.9 * sphere_area, "root area {}", root.area);

    // Back to the rest pose: the rest pose's exitance again (relinked from scratch: same links).
    object
        .deform(&gpu.ctx, &Deformation::Identity)
        .expect("identity");
    let (_, report) = render_once(&gpu.ctx, &mut object, SIZE, SIZE);
    assert!(report.passes.contains(&PASS_DEFORM), "{:?}", report.passes);
    let (back, _) = exitance(&object, &scene);
    let error = translucent::solver::rel_rms(&back, &wide(&rest_jplus));
    assert!(error < GPU_VS_CPU, "identity after the squash: {error}");
    drop(object);
    gpu.finish();
}
