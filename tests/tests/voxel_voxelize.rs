//! The voxel method's GPU solid voxelization (solver::voxel::VoxelizePass) against the CPU's
//! inside test, the generalized winding number of the same triangles (mesh::MeshSolid), at every
//! voxel centre. Exact shapes must agree everywhere except at centres within `BAND_MM` of the
//! surface; the Stanford bunny's holes are where the three-axis vote matters.

mod voxel_common;

use glam::{DQuat, DVec3};
use translucent::frame::voxel::VoxelPasses;
use translucent::material::{Material, MaterialField};
use translucent::mesh::shapes::Shape;
use translucent::mesh::{TriMesh, ValidateOptions};
use translucent::solver::voxel::{VoxelMesh, VoxelParams, VoxelResolution};
use translucent_tests::{test_mesh, GpuTest};
use voxel_common::{compare_with_winding, mapped, run_frame, solid_mask};

/// Centres this close to the surface may round either way (f32 crossings against the f64
/// winding number): 1e-4 mm, far below the 0.7 mm voxels.
const BAND_MM: f64 = 1e-4;

fn marble() -> MaterialField {
    MaterialField::Homogeneous(Material::preset("marble").unwrap())
}

fn voxelize(
    gpu: &GpuTest,
    mesh: &TriMesh,
    params: &VoxelParams,
) -> (Vec<bool>, translucent::solver::voxel::GridFrame) {
    let ctx = &gpu.ctx;
    let gpu_mesh = VoxelMesh::new(ctx, mesh).unwrap();
    let mut method = VoxelPasses::new(ctx, mesh, &marble(), params).unwrap();
    method
        .set_lights(&["dir:0,-1,0:1,1,1".parse().unwrap()], mesh.bounds())
        .unwrap();
    method.bind_mesh(ctx, &gpu_mesh.surface(), false).unwrap();
    run_frame(ctx, &mut method, &gpu_mesh.surface());
    solid_mask(ctx, &method)
}

#[test]
fn sphere_box_torus_and_an_inverted_sphere_match_the_winding_number() {
    let gpu = GpuTest::new();
    let params = VoxelParams {
        resolution: VoxelResolution::Fixed(32),
        ..VoxelParams::default()
    };
    let turn = DQuat::from_euler(glam::EulerRot::XYZ, 0.4, 0.7, -0.2);
    let sphere = Shape::Sphere { radius: 10.0 }.triangulate(40);
    let mut inverted = sphere.clone();
    for t in &mut inverted.indices {
        t.swap(1, 2);
    }
    let cases = [
        ("sphere", sphere),
        (
            "box",
            Shape::Box {
                half_extents: DVec3::new(10.0, 6.0, 4.0),
            }
            .triangulate(8),
        ),
        (
            "turned box",
            mapped(
                &Shape::Box {
                    half_extents: DVec3::new(10.0, 6.0, 4.0),
                }
                .triangulate(8),
                |p| turn * p,
            ),
        ),
        (
            "torus",
            Shape::Torus {
                major: 7.0,
                minor: 3.0,
            }
            .triangulate(48),
        ),
        ("inverted sphere", inverted),
    ];
    for (name, mesh) in cases {
        let (mask, frame) = voxelize(&gpu, &mesh, &params);
        let (mismatches, solid, checked) = compare_with_winding(&mask, &frame, &mesh, BAND_MM);
        println!("{name}: {solid} solid of {checked} checked, {mismatches} mismatches");
        assert!(solid > 1000, "{name}: {solid} solid voxels");
        assert_eq!(mismatches, 0, "{name}");
        // The grid was fitted on the GPU: N voxels along the longest side of the bounds.
        let (lo, hi) = mesh.bounds();
        let longest = (hi - lo).max_element() as f32;
        assert!(
            (frame.h() - longest / 32.0).abs() < 1e-5 * longest,
            "{name}: {frame:?}"
        );
    }
    gpu.finish();
}

#[test]
fn the_bunnys_holes_are_outvoted_by_three_axes() {
    let Some(path) = test_mesh("stanford-bunny.obj") else {
        return;
    };
    let gpu = GpuTest::new();
    let mut mesh = TriMesh::load_obj(&path).unwrap();
    mesh.validate(&ValidateOptions::default()).unwrap();
    let (mesh, _) = mesh.normalized(50.0).unwrap();
    let mut results = Vec::new();
    for vote_axes in [1, 3] {
        let params = VoxelParams {
            resolution: VoxelResolution::Fixed(48),
            vote_axes,
            ..VoxelParams::default()
        };
        let (mask, frame) = voxelize(&gpu, &mesh, &params);
        let (mismatches, solid, checked) = compare_with_winding(&mask, &frame, &mesh, BAND_MM);
        println!(
            "bunny, {vote_axes} axes: {solid} solid of {checked}, {mismatches} differ from the winding number ({:.3}% of solid)",
            100.0 * mismatches as f64 / solid as f64
        );
        results.push((mismatches, solid));
    }
    let (one, three) = (results[0], results[1]);
    // One axis: the holes in the base start streaks of wrong voxels (the test can fail this way).
    assert!(one.0 > 2 * three.0.max(1), "{results:?}");
    // Three axes: what is left sits at the holes (measured 69 of 22030, 0.31%, about half with
    // a winding number between 0.25 and 0.75), where inside is a guess for both tests.
    assert!((three.0 as f64) < 0.005 * three.1 as f64, "{results:?}");
    gpu.finish();
}
