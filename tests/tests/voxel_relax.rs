//! The voxel method's shortest optical path (solver::voxel::RelaxPass) against a CPU Dijkstra on
//! the same grid: the GPU's medium (solid flags, per-voxel cost coefficients), seed and voxel
//! size are read back, `cpu::dijkstra` runs on them in f32, and every voxel's n must be the same
//! bits (the paper's hard minimum). Jacobi ping-pong and sweeping, homogeneous and heterogeneous
//! media, directional, spot and point lights. The diffusion model's sigma_tr costs choose paths by
//! their contribution at the exit (not additive): its n is bounded below by the Dijkstra.

mod voxel_common;

/// Reached voxels per seed at least (see the assertion).
const REACHED_PER_LIT: usize = 3;

use glam::DVec3;
use translucent::frame::voxel::VoxelPasses;
use translucent::material::{Material, MaterialField, Procedural};
use translucent::mesh::shapes::Shape;
use translucent::mesh::TriMesh;
use translucent::scene::Light;
use translucent::solver::voxel::cpu::{dijkstra, VoxelGraph, N_UNLIT};
use translucent::solver::voxel::{Relaxation, VoxelMesh, VoxelModel, VoxelParams, VoxelResolution};
use translucent_tests::GpuTest;
use voxel_common::run_frame;

struct Case {
    name: &'static str,
    mesh: TriMesh,
    field: MaterialField,
    light: &'static str,
    params: VoxelParams,
}

fn params(model: VoxelModel, relaxation: Relaxation) -> VoxelParams {
    VoxelParams {
        resolution: VoxelResolution::Fixed(24),
        model,
        relaxation,
        ..VoxelParams::default()
    }
}

/// Runs a frame and returns (GPU n, CPU Dijkstra n, lit seeds, iterations, converged).
fn relax(gpu: &GpuTest, case: &Case) -> (Vec<[f32; 3]>, Vec<[f32; 3]>, usize, u32, bool) {
    let ctx = &gpu.ctx;
    let mesh = VoxelMesh::new(ctx, &case.mesh).unwrap();
    let mut method = VoxelPasses::new(ctx, &case.mesh, &case.field, &case.params).unwrap();
    let light: Light = case.light.parse().unwrap();
    method.set_lights(&[light], case.mesh.bounds()).unwrap();
    method.bind_mesh(ctx, &mesh.surface(), false).unwrap();
    run_frame(ctx, &mut method, &mesh.surface());
    let report = method.report(ctx).unwrap();
    let medium = method.read_volume(ctx, &method.grid.medium).unwrap();
    let seed = method.read_volume(ctx, &method.grid.seed).unwrap();
    let state = method.read_volume(ctx, &method.grid.state[0]).unwrap();
    let rgb = |t: &[f32; 4]| [t[0], t[1], t[2]];
    let graph = VoxelGraph {
        dims: report.dims,
        h: report.grid.h(),
        solid: medium.iter().map(|t| t[3] != 0.0).collect(),
        sigma: medium.iter().map(rgb).collect(),
        seed: seed.iter().map(rgb).collect(),
    };
    let lit = graph
        .seed
        .iter()
        .filter(|s| s.iter().any(|&v| v < N_UNLIT))
        .count();
    (
        state.iter().map(rgb).collect(),
        dijkstra(&graph),
        lit,
        report.iterations,
        report.converged,
    )
}

#[test]
fn gpu_relaxation_equals_cpu_dijkstra_bit_for_bit() {
    let gpu = GpuTest::new();
    let marble = Material::preset("marble").unwrap();
    let skin = Material::preset("skin1").unwrap();
    let sphere = Shape::Sphere { radius: 10.0 }.triangulate(32);
    let torus = Shape::Torus {
        major: 7.0,
        minor: 3.0,
    }
    .triangulate(32);
    let split = MaterialField::procedural(
        Procedural::Split {
            normal: DVec3::new(0.3, 1.0, 0.0),
            offset: 0.0,
            below: marble.coefficients(),
            above: Material::new([0.05, 0.02, 0.01], [3.0, 5.0, 9.0], 1.3)
                .unwrap()
                .coefficients(),
        },
        1.3,
    )
    .unwrap();
    let cases = [
        Case {
            name: "marble sphere, directional, Jacobi",
            mesh: sphere.clone(),
            field: MaterialField::Homogeneous(marble),
            light: "dir:0.5,-1,-0.5:4,4,4",
            params: params(VoxelModel::Paper, Relaxation::Jacobi),
        },
        Case {
            name: "marble sphere, directional, sweeping",
            mesh: sphere.clone(),
            field: MaterialField::Homogeneous(marble),
            light: "dir:0.5,-1,-0.5:4,4,4",
            params: params(VoxelModel::Paper, Relaxation::Sweep),
        },
        Case {
            name: "split sphere (1e3 contrast), spot, Jacobi",
            mesh: sphere,
            field: split,
            light: "spot:0,40,10:0,-1,-0.2:4000,3000,2000:10,25",
            params: params(VoxelModel::Paper, Relaxation::Jacobi),
        },
        Case {
            name: "skin torus, point light in the hole, diffusion costs, Jacobi",
            mesh: torus.clone(),
            field: MaterialField::Homogeneous(skin),
            light: "point:0,1,0:50,50,50",
            params: params(VoxelModel::Diffusion, Relaxation::Jacobi),
        },
        Case {
            name: "skin torus, point light in the hole, sweeping",
            mesh: torus,
            field: MaterialField::Homogeneous(skin),
            light: "point:0,1,0:50,50,50",
            params: params(VoxelModel::Paper, Relaxation::Sweep),
        },
    ];
    for case in &cases {
        let (gpu_n, cpu_n, lit, iterations, converged) = relax(&gpu, case);
        let differing = gpu_n
            .iter()
            .zip(&cpu_n)
            .filter(|(a, b)| a.map(f32::to_bits) != b.map(f32::to_bits))
            .count();
        let reached = cpu_n.iter().filter(|n| n[0] < N_UNLIT).count();
        println!(
            "{}: {lit} lit voxels, {reached} reached, {iterations} iterations, converged {converged}, {differing} differ",
            case.name
        );
        assert!(converged, "{}", case.name);
        // The relaxation has work: most reached voxels are not seeds. The injection lights every
        // shell voxel within 2 voxels of a lit texel (`KERNEL_REACH_VOXELS` in frame/voxel/inject.rs), which on
        // the thin torus (point light in its hole) is over a quarter of the reached voxels.
        assert!(
            lit > 20 && reached > REACHED_PER_LIT * lit,
            "{}: {lit} lit, {reached} reached",
            case.name
        );
        if case.params.model == VoxelModel::Diffusion {
            // The diffusion model picks, per voxel, the neighbour whose path contributes most at
            // the exit, n - ln G(d) summed over the channels (d the path's length, not additive):
            // its n is some path's optical depth, never below the shortest one, and reaches the
            // same voxels.
            let below = gpu_n
                .iter()
                .zip(&cpu_n)
                .filter(|(g, c)| (0..3).any(|i| g[i] < c[i]))
                .count();
            let reach_differs = gpu_n
                .iter()
                .zip(&cpu_n)
                .filter(|(g, c)| (g[0] < N_UNLIT) != (c[0] < N_UNLIT))
                .count();
            assert_eq!((below, reach_differs), (0, 0), "{}", case.name);
        } else {
            assert_eq!(differing, 0, "{}", case.name);
        }
        assert!(gpu_n.iter().flatten().all(|v| v.is_finite()));
    }
    gpu.finish();
}
