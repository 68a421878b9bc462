//! Shared by the voxel method's tests: one recorded frame, and the solid mask and grid read back.
#![allow(dead_code, reason = "each test file uses a different part")]

use glam::{DVec3, Vec3};
use translucent::frame::voxel::VoxelPasses;
use translucent::mesh::{MeshSolid, TriMesh};
use translucent::solver::voxel::{GridFrame, SurfaceMesh};
use translucent::vk::Context;

/// Records and runs one frame of `method` on `mesh`, waiting for it.
pub fn run_frame(ctx: &Context, method: &mut VoxelPasses, mesh: &SurfaceMesh<'_>) {
    let mut failed = None;
    ctx.execute("voxel test frame", |cb| {
        // SAFETY: `cb` is recording; the method and its bound mesh outlive the waited submission.
        failed = unsafe { method.record(ctx, cb, *mesh, None) }.err();
        Ok(())
    })
    .expect("submit");
    assert!(failed.is_none(), "{failed:?}");
}

/// The solid flag of every voxel (x fastest) and the grid the GPU fitted.
pub fn solid_mask(ctx: &Context, method: &VoxelPasses) -> (Vec<bool>, GridFrame) {
    let medium = method
        .read_volume(ctx, &method.grid.medium)
        .expect("read medium");
    let frame = method.grid.read_frame(ctx).expect("read grid");
    (medium.iter().map(|t| t[3] != 0.0).collect(), frame)
}

/// Voxels whose GPU solid flag differs from the CPU's generalized winding number at the voxel
/// centre, leaving out centres within `band` mm of the surface (where f32 rounding of the GPU's
/// crossing and the f64 winding number may disagree): (mismatches, solid voxels, checked).
pub fn compare_with_winding(
    mask: &[bool],
    frame: &GridFrame,
    mesh: &TriMesh,
    band: f64,
) -> (usize, usize, usize) {
    let solid = MeshSolid::new(mesh.clone()).expect("solid");
    let dims = [frame.dims[0], frame.dims[1], frame.dims[2]];
    let centres: Vec<DVec3> = (0..mask.len())
        .map(|i| {
            let v = [
                (i % dims[0] as usize) as u32,
                ((i / dims[0] as usize) % dims[1] as usize) as u32,
                (i / (dims[0] * dims[1]) as usize) as u32,
            ];
            frame.centre(v).as_dvec3()
        })
        .collect();
    let inside = solid.contains_many(&centres);
    let (mut mismatches, mut checked) = (0, 0);
    let mut far: f64 = 0.0;
    let mut ambiguous = 0;
    for ((p, &gpu), &cpu) in centres.iter().zip(mask).zip(&inside) {
        if gpu != cpu {
            let distance = solid.closest_point(*p).map_or(f64::MAX, |c| c.distance);
            if distance < band {
                continue;
            }
            far = far.max(distance);
            let w = solid.winding_number(*p).abs();
            if (0.25..0.75).contains(&w) {
                ambiguous += 1;
            }
            mismatches += 1;
        }
        checked += 1;
    }
    if mismatches > 0 {
        println!(
            "  mismatches: farthest {far:.3} mm from the surface (h = {:.3}), {ambiguous} with |winding number| in [0.25, 0.75)",
            frame.h()
        );
    }
    (mismatches, mask.iter().filter(|&&s| s).count(), checked)
}

/// The voxel containing `p` in `frame`.
pub fn voxel_of(frame: &GridFrame, p: Vec3) -> [u32; 3] {
    let o = Vec3::from_slice(&frame.origin[..3]);
    let v = ((p - o) / frame.h()).floor();
    [v.x as u32, v.y as u32, v.z as u32]
}

/// A mesh moved by `f` (positions), normals recomputed.
pub fn mapped(mesh: &TriMesh, f: impl Fn(DVec3) -> DVec3) -> TriMesh {
    let mut out = TriMesh {
        positions: mesh.positions.iter().map(|&p| f(p)).collect(),
        normals: mesh.normals.clone(),
        indices: mesh.indices.clone(),
    };
    out.compute_normals();
    out
}

/// Two meshes as one (the second's indices shifted).
pub fn union(a: &TriMesh, b: &TriMesh) -> TriMesh {
    let shift = a.positions.len() as u32;
    TriMesh {
        positions: a.positions.iter().chain(&b.positions).copied().collect(),
        normals: a.normals.iter().chain(&b.normals).copied().collect(),
        indices: a
            .indices
            .iter()
            .copied()
            .chain(b.indices.iter().map(|t| t.map(|i| i + shift)))
            .collect(),
    }
}
