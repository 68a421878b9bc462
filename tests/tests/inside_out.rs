//! An inside-out mesh (every face wound inward, normals pointing in) renders like its outward
//! twin (issue 12 item 5): the solid turns the display mesh's faces and normals outward
//! (`MeshSolid::mesh`), so the bake, the gather and the shading see the same surface. Before,
//! the display mesh kept its inward normals and the object rendered black.

use translucent::material::{Material, MaterialField};
use translucent::mesh::shapes::Shape;
use translucent::mesh::{MeshSolid, TriMesh};
use translucent::quadgraph::BakeParams;
use translucent::scene::{Environment, Scene};
use translucent::solver::gpu::GpuSolveParams;
use translucent::QuadGraph;
use translucent_tests::{multilevel_object, render_once, GpuTest};

/// The two renders differ by no more than this relative RMS over the image (the bound;
/// the meshes are the same surface, so only float round-off in the normals differs).
const TWINS_AGREE: f64 = 0.01;

/// The outward render's mean must be well above black (a broken twin would be ~0).
const NOT_BLACK: f64 = 1e-3;

fn inward(mut mesh: TriMesh) -> TriMesh {
    for tri in &mut mesh.indices {
        tri.swap(1, 2);
    }
    for n in &mut mesh.normals {
        *n = -*n;
    }
    mesh
}

fn render(gpu: &GpuTest, mesh: TriMesh) -> Vec<[f32; 4]> {
    let solid = MeshSolid::new(mesh).expect("solid");
    let params = BakeParams {
        resolution: 12,
        levels: 1,
        ..Default::default()
    };
    let graph = QuadGraph::bake(solid.mesh(), &solid, &params, &mut |_| {})
        .expect("bake")
        .0;
    let field = MaterialField::Homogeneous(Material::preset("marble").unwrap());
    let scene = Scene {
        lights: vec!["dir:0.5,-1,-0.5:4,4,4".parse().unwrap()],
        environment: Environment::Constant([0.1; 3]),
    };
    let mut object = multilevel_object(&gpu.ctx, &graph, &field, &scene, GpuSolveParams::default());
    let (captured, _) = render_once(&gpu.ctx, &mut object, 48, 48);
    gpu.assert_no_messages();
    captured.image.pixels
}

#[test]
fn inside_out_mesh_renders_like_its_outward_twin() {
    let gpu = GpuTest::new();
    let outward = Shape::Sphere { radius: 10.0 }.triangulate(24);
    let inside_out = inward(outward.clone());
    let solid = MeshSolid::new(inside_out.clone()).unwrap();
    assert!(solid.is_inverted());
    // The display surface winds outward and its normals point out of the sphere.
    let display = solid.mesh();
    assert!(display.signed_volume() > 0.0, "{}", display.signed_volume());
    for (p, n) in display.positions.iter().zip(&display.normals) {
        assert!(n.dot(p.normalize()) > 0.9, "vertex {p}: normal {n}");
    }
    let a = render(&gpu, outward);
    let b = render(&gpu, inside_out);
    let (mut d2, mut r2, mut sum) = (0.0, 0.0, 0.0);
    for (p, q) in a.iter().zip(&b) {
        for c in 0..3 {
            let (p, q) = (f64::from(p[c]), f64::from(q[c]));
            d2 += (p - q) * (p - q);
            r2 += p * p;
            sum += p;
        }
    }
    let mean = sum / (3 * a.len()) as f64;
    let err = (d2 / r2.max(f64::MIN_POSITIVE)).sqrt();
    println!("outward mean {mean:.4}, inside-out vs outward: rel RMS {err:.2e}");
    assert!(mean > NOT_BLACK, "the outward render is black: {mean}");
    assert!(err <= TWINS_AGREE, "relative RMS {err}");
    gpu.finish();
}
