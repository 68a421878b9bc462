//! The dipole method (issue 15) through the host API: a `TranslucentObject` with
//! `MethodDesc::Dipole` rendered into `HeadlessHost` under Khronos + synchronization validation.
//! Checks that its passes run and are skipped as DESIGN section 5 says, that the display mesh's
//! J+ is what the CPU evaluation of the same links gives (the GPU gather against the f64 one),
//! and that a heterogeneous material is a typed error unless texture-only is asked for.

use std::sync::Arc;

use translucent::frame::dipole::{DipoleParams, PASS_IRRADIANCE, PASS_LINKS};
use translucent::frame::DipoleMethod;
use translucent::material::{Material, MaterialField, Procedural};
use translucent::mesh::shapes::Shape;
use translucent::mesh::Vertex;
use translucent::object::MethodDesc;
use translucent::scene::{Environment, Scene};
use translucent::solver::dipole::{irradiance, links, FaceClusterHierarchy, HeterogeneousPolicy};
use translucent::{ObjectParams, SkipReason, TranslucentObject};
use translucent_tests::{render_once, GpuTest};

const SIZE: u32 = 24;
/// GPU J+ against the f64 evaluation of the same links, relative RMS over the vertices: the leaf
/// irradiance passes through fp16 (2^-11 relative) and the gather sums in f32.
const GPU_VS_CPU: f64 = 2e-3;

fn marble() -> MaterialField {
    MaterialField::Homogeneous(Material::preset("marble").expect("preset"))
}

fn sphere() -> (translucent::mesh::TriMesh, Arc<FaceClusterHierarchy>) {
    let mesh = Shape::Sphere { radius: 10.0 }.triangulate(10);
    let (tree, _) = FaceClusterHierarchy::build(&mesh).expect("hierarchy");
    (mesh, Arc::new(tree))
}

fn dipole_object(
    ctx: &translucent::vk::Context,
    field: &MaterialField,
    scene: &Scene,
    params: DipoleParams,
) -> Result<TranslucentObject, translucent::Error> {
    let (mesh, tree) = sphere();
    TranslucentObject::with_method(
        ctx,
        MethodDesc::Dipole {
            mesh,
            hierarchy: tree,
            params,
        },
        field,
        scene,
        &ObjectParams::default(),
    )
}

#[test]
fn a_dipole_object_renders_its_gather_on_the_gpu_and_skips_it_when_nothing_changed() {
    let gpu = GpuTest::new();
    // A constant environment: no visibility, so the GPU gather and the CPU irradiance agree.
    let scene = Scene {
        lights: vec![],
        environment: Environment::Constant([0.5, 0.4, 0.3]),
    };
    let field = marble();
    let mut object =
        dipole_object(&gpu.ctx, &field, &scene, DipoleParams::default()).expect("object");
    let (captured, report) = render_once(&gpu.ctx, &mut object, SIZE, SIZE);
    assert_eq!(report.method, "dipole");
    for pass in [PASS_IRRADIANCE, PASS_LINKS] {
        assert!(report.passes.contains(&pass), "{:?}", report.passes);
    }
    let lit = captured
        .image
        .pixels
        .iter()
        .filter(|p| p[0] > 0.0 && p.iter().all(|c| c.is_finite()))
        .count();
    assert!(lit > (SIZE * SIZE / 4) as usize, "{lit} lit pixels");

    // The display mesh's J+ against the CPU: the same links, f64 irradiance, the GPU's push.
    let method = object
        .method()
        .as_any()
        .downcast_ref::<DipoleMethod>()
        .expect("dipole");
    let tree = method.hierarchy();
    let material = method.material();
    let e = irradiance::leaf_irradiance(tree, &scene, material.base.eta, None).expect("E");
    let node = links::pull(tree, &e);
    let received = links::gather(tree, &material.profile, method.links().0, &node);
    let leaf = links::push_constant(tree, &received);
    let f_dr = material.base.f_dr();
    let want: Vec<[f64; 3]> = links::to_vertices(tree, &leaf, None)
        .iter()
        .map(|m| m.map(|x| x / (1.0 - f_dr)))
        .collect();
    let bytes = object.mesh().vertex_buffer().read_bytes().expect("read");
    let stride = std::mem::size_of::<Vertex>();
    let offset = std::mem::offset_of!(Vertex, exitance);
    let float = |at: usize| f32::from_le_bytes(bytes[at..at + 4].try_into().expect("4 bytes"));
    let got: Vec<[f32; 3]> = (0..want.len())
        .map(|v| std::array::from_fn(|c| float(v * stride + offset + 4 * c)))
        .collect();
    let error = translucent::solver::rel_rms(&got, &want);
    assert!(error < GPU_VS_CPU, "GPU vs CPU J+: {error}");

    // Nothing changed: the method's passes are skipped, with the reason.
    let (_, report) = render_once(&gpu.ctx, &mut object, SIZE, SIZE);
    for pass in [PASS_IRRADIANCE, PASS_LINKS] {
        assert!(!report.passes.contains(&pass), "{:?}", report.passes);
        assert_eq!(report.skipped.get(pass), Some(&SkipReason::Unchanged));
    }
    // A material change relinks and gathers again.
    object
        .set_material(
            &gpu.ctx,
            &MaterialField::Homogeneous(Material::preset("skimmilk").expect("preset")),
        )
        .expect("material");
    let (_, report) = render_once(&gpu.ctx, &mut object, SIZE, SIZE);
    assert!(report.passes.contains(&PASS_LINKS), "{:?}", report.passes);
    drop(object);
    gpu.finish();
}

#[test]
fn a_heterogeneous_material_is_refused_or_rendered_texture_only() {
    let gpu = GpuTest::new();
    let scene = Scene {
        lights: vec!["dir:0,-1,0:3,3,3".parse().expect("light")],
        environment: Environment::None,
    };
    let split = MaterialField::procedural(
        Procedural::Split {
            normal: glam::DVec3::Y,
            offset: 0.0,
            below: Material::preset("skimmilk").expect("preset").coefficients(),
            above: Material::preset("skin1").expect("preset").coefficients(),
        },
        1.0,
    )
    .expect("field");
    match dipole_object(&gpu.ctx, &split, &scene, DipoleParams::default()) {
        Err(e) => {
            let text = e.to_string();
            assert!(text.contains("quadgraph"), "{text}");
        }
        Ok(_) => panic!("a heterogeneous material must be refused by default"),
    }
    let params = DipoleParams {
        heterogeneous: HeterogeneousPolicy::TextureOnly,
        ..DipoleParams::default()
    };
    let mut object = dipole_object(&gpu.ctx, &split, &scene, params).expect("texture only");
    let (_, report) = render_once(&gpu.ctx, &mut object, SIZE, SIZE);
    assert_eq!(report.material_variant, "texture only");
    drop(object);
    gpu.finish();
}
