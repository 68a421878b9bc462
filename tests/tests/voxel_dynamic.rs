//! The voxel method on changing objects, with no precomputation: a mesh deformed on the CPU
//! every frame is voxelized again (checked against the winding number of the deformed mesh),
//! and a mesh split into two pieces between frames (a new vertex and index buffer, bound again)
//! lights only the piece the light reaches. And the light entering a flat face: the injected n0
//! and the exit equal DESIGN section 2's q = E mu F_t(eta, mu) and M = (1 - F_dr) q.

mod voxel_common;

use glam::{DQuat, DVec3};
use translucent::frame::voxel::VoxelPasses;
use translucent::material::{fresnel, Material, MaterialField};
use translucent::mesh::shapes::Shape;
use translucent::scene::Light;
use translucent::solver::voxel::cpu::N_UNLIT;
use translucent::solver::voxel::{VoxelMesh, VoxelParams, VoxelResolution};
use translucent_tests::GpuTest;
use voxel_common::{compare_with_winding, mapped, run_frame, solid_mask, union, voxel_of};

/// As in voxel_voxelize.rs: centres within 1e-4 mm of the surface may round either way.
const BAND_MM: f64 = 1e-4;

/// The paper's model: its n and exit formulas are what these tests check.
fn params(n: u32) -> VoxelParams {
    VoxelParams {
        model: translucent::solver::voxel::VoxelModel::Paper,
        resolution: VoxelResolution::Fixed(n),
        ..VoxelParams::default()
    }
}

#[test]
fn a_deforming_mesh_is_voxelized_again_every_frame() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let rest = Shape::Capsule {
        half_length: 6.0,
        radius: 5.0,
    }
    .triangulate(32);
    let field = MaterialField::Homogeneous(Material::preset("marble").unwrap());
    let light: Light = "dir:0.3,-1,0.2:2,2,2".parse().unwrap();
    let mut mesh = VoxelMesh::new(ctx, &rest).unwrap();
    let mut method = VoxelPasses::new(ctx, &rest, &field, &params(24)).unwrap();
    method.bind_mesh(ctx, &mesh.surface(), false).unwrap();
    let mut heights = Vec::new();
    for frame in 0..4 {
        // A bend that grows every frame: twist about y, stretch along y, shear x with y.
        let t = f64::from(frame) * 0.3;
        let deformed = mapped(&rest, |p| {
            let q = DQuat::from_rotation_y(t * p.y / 6.0) * p;
            DVec3::new(q.x + 0.4 * t * q.y, q.y * (1.0 + t), q.z)
        });
        mesh.set_positions(&deformed.positions, &deformed.normals)
            .unwrap();
        method.set_lights(&[light], deformed.bounds()).unwrap();
        run_frame(ctx, &mut method, &mesh.surface());
        let (mask, grid) = solid_mask(ctx, &method);
        let (mismatches, solid, _) = compare_with_winding(&mask, &grid, &deformed, BAND_MM);
        println!(
            "frame {frame}: h {:.3} mm, {solid} solid, {mismatches} mismatches",
            grid.h()
        );
        assert_eq!(mismatches, 0, "frame {frame}");
        assert!(solid > 300, "frame {frame}: {solid}");
        let exitance = method.exitance(ctx).unwrap();
        assert!(exitance
            .iter()
            .flatten()
            .all(|v| v.is_finite() && *v >= 0.0));
        assert!(exitance.iter().filter(|m| m[3] == 1.0).count() > exitance.len() * 9 / 10);
        heights.push(grid.hi[1] - grid.lo[1]);
    }
    // The grid followed the stretch (fitted on the GPU): the object doubled its height.
    assert!(heights[3] > 1.8 * heights[0], "{heights:?}");
    drop((method, mesh));
    gpu.finish();
}

#[test]
fn a_mesh_split_in_two_between_frames_needs_no_rebake() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    // A bar along x; then the same bar cut in two pieces with a gap: light from +x.
    let bar = Shape::Box {
        half_extents: DVec3::new(12.0, 3.0, 3.0),
    }
    .triangulate(12);
    let piece = Shape::Box {
        half_extents: DVec3::new(5.0, 3.0, 3.0),
    }
    .triangulate(12);
    let pieces = union(
        &mapped(&piece, |p| p - DVec3::X * 7.0),
        &mapped(&piece, |p| p + DVec3::X * 7.0),
    );
    // Thin: the light crosses the bar (sigma_t' = 0.1 /mm: exp(-2.4) over 24 mm).
    let field = MaterialField::Homogeneous(Material::new([0.09; 3], [0.01; 3], 1.0).unwrap());
    let light: Light = "dir:-1,0,0:1,1,1".parse().unwrap();
    let mut method = VoxelPasses::new(ctx, &bar, &field, &params(32)).unwrap();
    let mut far_end = Vec::new();
    for (name, mesh) in [("bar", &bar), ("pieces", &pieces), ("bar again", &bar)] {
        let gpu_mesh = VoxelMesh::new(ctx, mesh).unwrap();
        method.bind_mesh(ctx, &gpu_mesh.surface(), false).unwrap();
        method.set_lights(&[light], mesh.bounds()).unwrap();
        run_frame(ctx, &mut method, &gpu_mesh.surface());
        let (mask, grid) = solid_mask(ctx, &method);
        let (mismatches, _, _) = compare_with_winding(&mask, &grid, mesh, BAND_MM);
        assert_eq!(mismatches, 0, "{name}");
        // The far (-x) end face's vertices: lit through the bar, dark once it is cut.
        let exitance = method.exitance(ctx).unwrap();
        let far: Vec<f32> = mesh
            .positions
            .iter()
            .zip(&exitance)
            .filter(|(p, _)| p.x < -11.99)
            .map(|(_, m)| m[0])
            .collect();
        assert!(!far.is_empty());
        let state = method.read_volume(ctx, &method.grid.state[0]).unwrap();
        let v = voxel_of(&grid, glam::Vec3::new(-11.0, 0.0, 0.0));
        let n_far = state[method.grid.dims.index(v)][0];
        println!(
            "{name}: far end exitance {:?}, n {n_far}",
            far.iter().fold(0.0f32, |a, &b| a.max(b))
        );
        far_end.push((far.iter().fold(0.0f32, |a, &b| a.max(b)), n_far));
    }
    assert!(far_end[0].0 > 1e-3, "{far_end:?}");
    assert_eq!(far_end[1], (0.0, N_UNLIT), "{far_end:?}");
    // Back to one piece: the same as the first frame, bit for bit.
    assert_eq!(far_end[2], far_end[0], "{far_end:?}");
    drop(method);
    gpu.finish();
}

#[test]
fn a_lit_flat_face_injects_the_transmitted_irradiance_and_emits_its_exitance() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let cube = Shape::Box {
        half_extents: DVec3::splat(10.0),
    }
    .triangulate(16);
    let eta = 1.3;
    let field = MaterialField::Homogeneous(Material::new([1.0; 3], [0.01; 3], eta).unwrap());
    // Only the top face (+y) is lit: the light comes down at 30 degrees from the normal.
    let direction = DVec3::new(0.5, -(3.0f64).sqrt() / 2.0, 0.0);
    let light = Light::Directional {
        direction,
        irradiance: [2.0, 1.0, 0.5],
    };
    let mesh = VoxelMesh::new(ctx, &cube).unwrap();
    let mut method = VoxelPasses::new(ctx, &cube, &field, &params(20)).unwrap();
    method.set_lights(&[light], cube.bounds()).unwrap();
    method.bind_mesh(ctx, &mesh.surface(), false).unwrap();
    run_frame(ctx, &mut method, &mesh.surface());
    let mu = (3.0f64).sqrt() / 2.0;
    let q: [f64; 3] = [2.0, 1.0, 0.5].map(|e| e * mu * fresnel::transmittance(eta, mu));
    // n0 of the top layer of voxels, away from the edges (the last 1.25 mm of the face has
    // interpolated normals that turn towards the edge's averaged normal, and the injection
    // averages the texels within 2 voxels, KERNEL_REACH_VOXELS: at most 8.3 mm from the centre).
    let seed = method.read_volume(ctx, &method.grid.seed).unwrap();
    let grid = method.grid.read_frame(ctx).unwrap();
    let mut checked = 0;
    for x in -6..=6 {
        for z in -6..=6 {
            let v = voxel_of(&grid, glam::Vec3::new(x as f32, 9.9, z as f32));
            let n0 = seed[method.grid.dims.index(v)];
            for c in 0..3 {
                let got = f64::from((-n0[c]).exp());
                // 1e-5: f32 arithmetic over ~10 texels per voxel.
                assert!(
                    (got - q[c]).abs() < 1e-5 * q[c],
                    "voxel {v:?}: {got} vs {}",
                    q[c]
                );
            }
            checked += 1;
        }
    }
    assert!(checked > 150, "{checked}");
    // M = (1 - F_dr) q at the face's inner vertices (paper model: n = n0 on a uniformly lit face).
    let f_dr = fresnel::diffuse_reflectance(eta);
    let exitance = method.exitance(ctx).unwrap();
    let mut vertices = 0;
    for (p, m) in cube.positions.iter().zip(&exitance) {
        if p.y > 9.99 && p.x.abs() < 6.0 && p.z.abs() < 6.0 {
            for c in 0..3 {
                let want = (1.0 - f_dr) * q[c];
                assert!((f64::from(m[c]) - want).abs() < 1e-5 * want, "{p}: {m:?}");
            }
            vertices += 1;
        } else if p.y < -9.99 && p.x > 5.0 {
            // This part of the bottom face is 15 mm or more from the lit top and -x faces:
            // exp(-1.01 * 15) ~ 3e-7 of their light.
            assert!(m[0] < 1e-6, "{p}: {m:?}");
        }
    }
    assert!(vertices > 20, "{vertices}");
    drop((method, mesh));
    gpu.finish();
}
