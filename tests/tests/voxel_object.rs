//! The voxel method behind the method seam (`MethodDesc::Voxel`, `frame::VoxelMethod`): an object
//! renders through the frame graph, the shared shading and the headless host with validation and
//! synchronization validation silent; it deforms every frame and changes topology (a bar cut in
//! two) with no bake; a method with a bake refuses a new topology with a typed error.

use glam::{DVec3, Mat4, Vec3};
use translucent::frame::VoxelMethod;
use translucent::headless::HeadlessHost;
use translucent::material::{Material, MaterialField};
use translucent::mesh::shapes::Shape;
use translucent::mesh::TriMesh;
use translucent::scene::{Environment, Light, Scene};
use translucent::solver::gpu::Deformation;
use translucent::solver::voxel::{VoxelModel, VoxelParams, VoxelResolution};
use translucent::vk::Context;
use translucent::{MethodDesc, ObjectParams, TranslucentObject};
use translucent_tests::GpuTest;

/// The voxel method's passes, in frame order (the frame graph's names).
const VOXEL_PASSES: [&str; 5] = [
    "voxelize",
    "rsm",
    "voxel inject",
    "voxel relax",
    "voxel exit",
];

/// Small frames: the test is about the composition, not the image.
const SIZE: u32 = 48;

fn object(
    ctx: &Context,
    mesh: &TriMesh,
    field: &MaterialField,
    light: &str,
    n: u32,
) -> TranslucentObject {
    TranslucentObject::with_method(
        ctx,
        MethodDesc::Voxel {
            mesh: mesh.clone(),
            params: VoxelParams {
                resolution: VoxelResolution::Fixed(n),
                model: VoxelModel::Diffusion,
                ..VoxelParams::default()
            },
        },
        field,
        &Scene {
            lights: vec![light.parse::<Light>().unwrap()],
            environment: Environment::None,
        },
        &ObjectParams::default(),
    )
    .expect("voxel object")
}

fn voxel(object: &TranslucentObject) -> &VoxelMethod {
    object
        .method()
        .as_any()
        .downcast_ref::<VoxelMethod>()
        .expect("the voxel method")
}

/// (M rgb, covered) per display vertex, after a completed frame.
fn exitance(ctx: &Context, object: &TranslucentObject) -> Vec<[f32; 4]> {
    voxel(object).passes().exitance(ctx).expect("exitance")
}

#[test]
fn a_voxel_object_renders_through_the_frame_graph_and_then_skips() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let sphere = Shape::Sphere { radius: 10.0 }.triangulate(16);
    let field = MaterialField::Homogeneous(Material::preset("marble").unwrap());
    let mut object = object(ctx, &sphere, &field, "dir:0.5,-1,-0.5:4,4,4", 16);
    let mut host = HeadlessHost::new(ctx, SIZE, SIZE).unwrap();
    let (captured, report) = host.render(ctx, &mut object).unwrap();
    assert_eq!(report.method, "voxel");
    for pass in VOXEL_PASSES {
        assert!(
            report.passes.contains(&pass),
            "{pass} in {:?}",
            report.passes
        );
    }
    assert!(report.passes.contains(&"shading"));
    // The object covers the frame's centre and is lit.
    let lit = captured
        .image
        .pixels
        .iter()
        .filter(|p| p[..3].iter().any(|&c| c > 0.0))
        .count();
    assert!(lit > (SIZE * SIZE / 8) as usize, "{lit} lit pixels");
    assert!(captured
        .image
        .pixels
        .iter()
        .flatten()
        .all(|c| c.is_finite()));
    let m = exitance(ctx, &object);
    assert!(m.iter().flatten().all(|v| v.is_finite() && *v >= 0.0));
    // The lit side (towards -light direction, i.e. +y) emits more than the far side.
    let side = |up: bool| -> f32 {
        sphere
            .positions
            .iter()
            .zip(&m)
            .filter(|(p, _)| (p.y > 5.0) == up && p.y.abs() > 5.0)
            .map(|(_, m)| m[0] + m[1] + m[2])
            .sum::<f32>()
    };
    assert!(
        side(true) > 2.0 * side(false),
        "{} vs {}",
        side(true),
        side(false)
    );
    // The relaxation's counters came back (GPU-decided stop, no read-back in the frame).
    let solves = object.completed_solves(ctx.frames().1).unwrap();
    let solve = solves.last().expect("a completed relaxation");
    assert!(solve.iterations()[0] > 0 && solve.converged(), "{solve:?}");
    gpu.assert_no_messages();

    // Nothing changed: the voxel passes are skipped, the exitance stands.
    let (_, report) = host.render(ctx, &mut object).unwrap();
    for pass in VOXEL_PASSES {
        assert!(report.skipped.contains_key(pass), "{pass}: {report:?}");
    }
    drop((host, object));
    gpu.finish();
}

#[test]
fn a_voxel_object_deforms_every_frame_and_splits_with_no_rebake() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    // A bar along x lit from +x through its length (thin: sigma_t' = 0.1 /mm).
    let bar = Shape::Box {
        half_extents: DVec3::new(12.0, 3.0, 3.0),
    }
    .triangulate(12);
    let field = MaterialField::Homogeneous(Material::new([0.09; 3], [0.01; 3], 1.0).unwrap());
    let mut object = object(ctx, &bar, &field, "dir:-1,0,0:1,1,1", 32);
    let mut host = HeadlessHost::new(ctx, SIZE, SIZE).unwrap();

    // A stretch along y that grows every frame: the grid the GPU fits follows it.
    let mut heights = Vec::new();
    for frame in 0..3 {
        let stretch = 1.0 + 0.5 * frame as f32;
        object
            .deform(
                ctx,
                &Deformation::Affine(Mat4::from_scale(Vec3::new(1.0, stretch, 1.0))),
            )
            .unwrap();
        let (_, report) = host.render(ctx, &mut object).unwrap();
        for pass in VOXEL_PASSES {
            assert!(report.passes.contains(&pass), "frame {frame}: {pass}");
        }
        let grid = voxel(&object).passes().grid.read_frame(ctx).unwrap();
        heights.push(grid.hi[1] - grid.lo[1]);
        let m = exitance(ctx, &object);
        assert!(m.iter().flatten().all(|v| v.is_finite() && *v >= 0.0));
    }
    assert!(heights[2] > 1.8 * heights[0], "{heights:?}");
    object.deform(ctx, &Deformation::Identity).unwrap();

    // The far (-x) end: lit through the whole bar, dark once the bar is cut in two.
    let far_end = |object: &TranslucentObject, mesh: &TriMesh| -> f32 {
        let m = exitance(ctx, object);
        mesh.positions
            .iter()
            .zip(&m)
            .filter(|(p, _)| p.x < -11.99)
            .map(|(_, m)| m[0])
            .fold(0.0, f32::max)
    };
    host.render(ctx, &mut object).unwrap();
    let whole = far_end(&object, &bar);
    let piece = Shape::Box {
        half_extents: DVec3::new(5.0, 3.0, 3.0),
    }
    .triangulate(12);
    let shifted = |dx: f64| TriMesh {
        positions: piece.positions.iter().map(|&p| p + DVec3::X * dx).collect(),
        ..piece.clone()
    };
    let (a, b) = (shifted(-7.0), shifted(7.0));
    let pieces = TriMesh {
        positions: a.positions.iter().chain(&b.positions).copied().collect(),
        normals: a.normals.iter().chain(&b.normals).copied().collect(),
        indices: a
            .indices
            .iter()
            .copied()
            .chain(
                b.indices
                    .iter()
                    .map(|t| t.map(|i| i + a.positions.len() as u32)),
            )
            .collect(),
    };
    object.set_mesh(ctx, &pieces).unwrap();
    let (_, report) = host.render(ctx, &mut object).unwrap();
    assert!(report.passes.contains(&"voxelize"));
    assert_eq!(object.mesh().vertex_count(), pieces.positions.len());
    let cut = far_end(&object, &pieces);
    println!("far end: whole bar {whole}, cut in two {cut}");
    assert!(whole > 0.0);
    // The gap (4 mm of air) lets no light across: the far piece is lit only from its own faces,
    // which face away from the light (-x, +-y, +-z are parallel or opposite to it).
    assert!(cut < 0.1 * whole, "whole {whole}, cut {cut}");
    gpu.assert_no_messages();
    drop((host, object));
    gpu.finish();
}

#[test]
fn a_baked_method_refuses_a_new_topology() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let sphere = Shape::Sphere { radius: 10.0 }.triangulate(8);
    let field = MaterialField::Homogeneous(Material::preset("marble").unwrap());
    let mut object = TranslucentObject::with_method(
        ctx,
        MethodDesc::Exitance {
            mesh: sphere.clone(),
            exitance: vec![[0.1; 3]; sphere.positions.len()],
        },
        &field,
        &Scene {
            lights: vec![],
            environment: Environment::None,
        },
        &ObjectParams::default(),
    )
    .unwrap();
    let err = object.set_mesh(ctx, &sphere).unwrap_err().to_string();
    assert!(err.contains("voxel"), "{err}");
    drop(object);
    gpu.finish();
}
