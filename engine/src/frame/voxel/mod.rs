//! [`VoxelMethod`]: the voxel method (DESIGN section 6; Ozawa et al., the pure solver parts in
//! [`crate::solver::voxel`]) behind the method seam. Every frame, with no precomputation: the
//! display mesh is voxelized again ([`PASS_VOXELIZE`]), its reflective shadow maps rendered
//! ([`PASS_RSM`]) and injected into the surface voxels ([`PASS_INJECT`]), the shortest optical
//! paths relaxed until nothing changes, decided on the GPU with indirect dispatches
//! ([`PASS_RELAX`]), and J+ read from the radiance volume at every display vertex
//! ([`PASS_EXIT`]). The shared shadow maps, shading, capture and report work unchanged.
//!
//! A deformation ([`Method::deform`]) rewrites the display mesh's positions and normals (an edit
//! pass, [`PASS_DEFORM`]); a topology change ([`VoxelMethod::set_mesh`], through
//! [`crate::TranslucentObject::set_mesh`]) swaps in a new display mesh. Neither bakes anything:
//! the next frame voxelizes what it is given.
//!
//! ```no_run
//! # use translucent::{TranslucentObject, ObjectParams, MethodDesc};
//! # use translucent::solver::voxel::VoxelParams;
//! # fn f(ctx: &translucent::vk::Context, mesh: translucent::mesh::TriMesh,
//! #      field: &translucent::material::MaterialField, scene: &translucent::scene::Scene)
//! #      -> Result<(), translucent::Error> {
//! let desc = MethodDesc::Voxel { mesh, params: VoxelParams::default() };
//! let object = TranslucentObject::with_method(ctx, desc, field, scene, &ObjectParams::default())?;
//! // frames through the headless host or a window host, as for the QuadGraph.
//! # let _ = object; Ok(()) }
//! ```

mod inject;
mod passes;
mod rsm;

pub use inject::{InjectPass, InjectPush, PASS_INJECT};
pub use passes::{VoxelPasses, VoxelReport, PASS_MATERIAL_UPLOAD, RSM_MAX_VIEWS};
pub use rsm::{ReflectiveShadowMaps, RsmDesc, RsmView, PASS_RSM};

use std::sync::Arc;

use ash::vk;
use glam::DVec3;

use super::graph::FrameGraph;
use super::method::{Method, MethodFrame};
use super::plan::MethodWork;
use super::report::CompletedSolve;
use crate::material::MaterialField;
use crate::mesh::{GpuMesh, TriMesh, Vertex};
use crate::render::ShadowMaps;
use crate::scene::Scene;
use crate::solver::gpu::{Deformation, LevelControl};
use crate::solver::voxel::{
    bad_param, MeshIndices, RelaxControl, SurfaceMesh, VoxelParams, PASS_EXIT, PASS_RELAX,
    PASS_VOXELIZE,
};
use crate::vk::barrier::Use;
use crate::vk::{Access, Buffer, BufferDesc, Context, MemoryUse};
use crate::Error;

/// The staged deformation's copy into the display mesh (before the shadow maps).
pub const PASS_DEFORM: &str = "voxel deform";

/// Frames whose relaxation counters can be in flight at once (host frames in flight + 1).
const REPORT_SLOTS: usize = 3;

/// One slot of the per-frame copies of the relaxation's control record.
struct ReportCopy {
    buffer: Buffer,
    frame: Option<u64>,
}

/// Buffers a recorded frame may still read, released once it completed.
struct Retired {
    frame: u64,
    _buffer: Option<Buffer>,
    _mesh: Option<(Arc<GpuMesh>, MeshIndices)>,
}

/// What [`Method::prepare`] decided for the frame being recorded.
#[derive(Default)]
struct Prepared {
    run: bool,
    deform: bool,
    upload: bool,
    slot: usize,
    frame: u64,
}

/// The voxel method of one object (see the module doc).
pub struct VoxelMethod {
    passes: VoxelPasses,
    mesh: Arc<GpuMesh>,
    indices: MeshIndices,
    /// The display mesh as given (a deformation maps these positions).
    rest: TriMesh,
    /// A deformation's vertices, copied into the display mesh by the next frame.
    staged: Option<Buffer>,
    /// The staged vertices being copied this frame.
    copying: Option<Buffer>,
    /// The frame that records the staged material's upload.
    upload_frame: Option<u64>,
    retired: Vec<Retired>,
    reports: Vec<ReportCopy>,
    prepared: Prepared,
    solved: bool,
    variant: &'static str,
    /// The lights, and the box around the display mesh's last staged shape (the reflective
    /// shadow maps' views cover its bounding sphere).
    lights: Vec<crate::scene::Light>,
    bounds: (DVec3, DVec3),
}

impl VoxelMethod {
    /// The method for the display mesh `mesh` (its rest pose fixes the grid's resolution), of
    /// material `field`, lit by `scene`. Returns the display mesh the object draws.
    pub fn new(
        ctx: &Context,
        mesh: &TriMesh,
        field: &MaterialField,
        scene: &Scene,
        params: &VoxelParams,
    ) -> Result<(VoxelMethod, Arc<GpuMesh>), Error> {
        let display = Arc::new(GpuMesh::new(
            ctx,
            mesh,
            &vec![[0.0; 3]; mesh.positions.len()],
        )?);
        let indices = MeshIndices::new(ctx, mesh)?;
        let mut passes = VoxelPasses::new(ctx, mesh, field, params)?;
        passes.bind_mesh(ctx, &surface(&display, &indices), true)?;
        passes.set_lights(&scene.lights, mesh.bounds())?;
        passes.set_environment(&scene.environment)?;
        let mut reports = Vec::new();
        for _ in 0..REPORT_SLOTS {
            reports.push(ReportCopy {
                buffer: Buffer::new(
                    ctx,
                    &BufferDesc {
                        name: "voxel relax report",
                        size: std::mem::size_of::<RelaxControl>() as u64,
                        usage: vk::BufferUsageFlags::TRANSFER_DST,
                        memory: MemoryUse::Readback,
                    },
                )?,
                frame: None,
            });
        }
        Ok((
            VoxelMethod {
                passes,
                mesh: display.clone(),
                indices,
                rest: mesh.clone(),
                staged: None,
                copying: None,
                upload_frame: None,
                retired: Vec::new(),
                reports,
                prepared: Prepared::default(),
                solved: false,
                variant: variant(field),
                lights: scene.lights.clone(),
                bounds: mesh.bounds(),
            },
            display,
        ))
    }

    /// The passes and volumes (grid, relaxation, exit read-backs after a completed frame).
    pub fn passes(&self) -> &VoxelPasses {
        &self.passes
    }

    /// A topology change (a fracture, a re-mesh): `mesh` replaces the display mesh from the next
    /// frame, nothing baked (the grid keeps its resolution and fits the new bounds). Returns the
    /// new display mesh and its bounding sphere. A bad mesh is a typed error and changes nothing.
    pub fn set_mesh(
        &mut self,
        ctx: &Context,
        mesh: &TriMesh,
    ) -> Result<(Arc<GpuMesh>, (DVec3, f64)), Error> {
        let display = Arc::new(GpuMesh::new(
            ctx,
            mesh,
            &vec![[0.0; 3]; mesh.positions.len()],
        )?);
        let indices = MeshIndices::new(ctx, mesh)?;
        self.passes.set_lights(&self.lights, mesh.bounds())?;
        self.passes
            .bind_mesh(ctx, &surface(&display, &indices), true)?;
        self.bounds = mesh.bounds();
        let old_mesh = std::mem::replace(&mut self.mesh, display.clone());
        let old_indices = std::mem::replace(&mut self.indices, indices);
        // The last recorded frame may still read the old buffers.
        self.retired.push(Retired {
            frame: self.prepared.frame,
            _buffer: self.staged.take(),
            _mesh: Some((old_mesh, old_indices)),
        });
        self.rest = mesh.clone();
        Ok((display, crate::mesh::bounding_sphere(&mesh.positions)))
    }

    fn surface(&self) -> SurfaceMesh<'_> {
        surface(&self.mesh, &self.indices)
    }
}

fn surface<'a>(display: &'a GpuMesh, indices: &'a MeshIndices) -> SurfaceMesh<'a> {
    SurfaceMesh {
        vertices: display.vertex_buffer(),
        vertex_count: display.vertex_count() as u32,
        indices: &indices.buffer,
        triangle_count: indices.triangle_count,
    }
}

fn variant(field: &MaterialField) -> &'static str {
    match field {
        MaterialField::Homogeneous(_) => "homogeneous",
        _ => "heterogeneous",
    }
}

impl Method for VoxelMethod {
    fn name(&self) -> &'static str {
        "voxel"
    }

    fn set_lights(&mut self, scene: &Scene, _shadows: &ShadowMaps) -> Result<(), Error> {
        self.passes.set_lights(&scene.lights, self.bounds)?;
        self.passes.set_environment(&scene.environment)?;
        self.lights = scene.lights.clone();
        Ok(())
    }

    fn set_material(&mut self, ctx: &Context, field: &MaterialField) -> Result<(), Error> {
        if let Some(frame) = self.upload_frame.take() {
            // The staged texels of a recorded upload stay alive until that frame completed.
            self.retired.push(Retired {
                frame,
                _buffer: self.passes.material.take_pending(),
                _mesh: None,
            });
        }
        self.passes.set_material(ctx, field)?;
        self.variant = variant(field);
        Ok(())
    }

    fn deform(&mut self, ctx: &Context, deformation: &Deformation) -> Result<(DVec3, f64), Error> {
        if matches!(deformation, Deformation::TetPositions(_)) {
            return Err(bad_param(
                "deformation",
                "tetrahedron positions belong to a QuadGraph; the voxel method takes an analytic map",
            )
            .into());
        }
        let mut moved = self.rest.clone();
        for p in &mut moved.positions {
            *p = deformation.map_point(*p).unwrap_or(*p);
        }
        moved.compute_normals();
        let vertices: Vec<Vertex> = moved
            .positions
            .iter()
            .zip(&moved.normals)
            .map(|(p, n)| Vertex {
                position: p.as_vec3().to_array(),
                normal: n.as_vec3().to_array(),
                exitance: [0.0; 3],
            })
            .collect();
        if vertices
            .iter()
            .any(|v| v.position.iter().chain(&v.normal).any(|x| !x.is_finite()))
        {
            return Err(bad_param("deformation", "a deformed vertex is not finite in f32").into());
        }
        let staging = Buffer::with_data(
            ctx,
            "voxel deformed vertices",
            vk::BufferUsageFlags::TRANSFER_SRC,
            &vertices,
        )?;
        let bounds = moved.bounds();
        self.passes.set_lights(&self.lights, bounds)?;
        self.bounds = bounds;
        if let Some(old) = self.staged.replace(staging) {
            // Not recorded yet: no frame reads it.
            drop(old);
        }
        Ok(crate::mesh::bounding_sphere(&moved.positions))
    }

    fn has_solution(&self) -> bool {
        self.solved
    }

    fn reads_shadows(&self) -> bool {
        // The reflective shadow maps are the method's own.
        false
    }

    fn material_variant(&self) -> &'static str {
        self.variant
    }

    fn prepare(&mut self, work: MethodWork, frame: u64) -> Result<MethodFrame, Error> {
        let mut out = MethodFrame {
            moves_mesh: self.staged.is_some(),
            ..MethodFrame::default()
        };
        if let Some(copied) = self.copying.take() {
            self.retired.push(Retired {
                frame: self.prepared.frame,
                _buffer: Some(copied),
                _mesh: None,
            });
        }
        if let Some(uploaded) = self.upload_frame.take() {
            self.retired.push(Retired {
                frame: uploaded,
                _buffer: self.passes.material.take_pending(),
                _mesh: None,
            });
        }
        self.copying = self.staged.take();
        let slot = (frame % REPORT_SLOTS as u64) as usize;
        self.prepared = Prepared {
            run: false,
            deform: self.copying.is_some(),
            upload: false,
            slot,
            frame,
        };
        if !self.prepared.deform {
            out.skipped
                .push((PASS_DEFORM, super::report::SkipReason::NoEdits));
        }
        match work {
            MethodWork::Skip(why) => {
                for pass in [PASS_VOXELIZE, PASS_RSM, PASS_INJECT, PASS_RELAX, PASS_EXIT] {
                    out.skipped.push((pass, why));
                }
            }
            MethodWork::Update(_) => {
                self.prepared.run = true;
                self.prepared.upload = self.passes.material.upload_pending();
                if self.prepared.upload {
                    self.upload_frame = Some(frame);
                }
                self.reports[slot].frame = Some(frame);
                self.solved = true;
                out.levels_iterated = 1;
            }
        }
        Ok(out)
    }

    fn add_edit_passes<'g>(&'g self, graph: &mut FrameGraph<'g>) {
        let Some(staging) = &self.copying else {
            return;
        };
        let target = self.mesh.vertex_buffer();
        graph
            .pass(PASS_DEFORM)
            .uses([
                Use::buffer(staging, Access::TransferSrc),
                Use::buffer(target, Access::TransferDst),
            ])
            .record(move |p| {
                // SAFETY: inside the graph's pass declaring the copy's buffers; both live in
                // `self` until the frame completed.
                unsafe {
                    p.ctx.raw().cmd_copy_buffer(
                        p.cb,
                        staging.raw,
                        target.raw,
                        &[vk::BufferCopy::default().size(staging.size.min(target.size))],
                    );
                }
                Ok(())
            });
    }

    fn add_passes<'g>(
        &'g self,
        graph: &mut FrameGraph<'g>,
        _shadows: &'g ShadowMaps,
    ) -> Result<(), Error> {
        if !self.prepared.run {
            return Ok(());
        }
        let report = &self.reports[self.prepared.slot].buffer;
        self.passes
            .add_passes(graph, self.surface(), self.prepared.upload, Some(report))
    }

    fn completed(&mut self, completed: u64) -> Result<Vec<CompletedSolve>, Error> {
        self.retired.retain(|r| r.frame > completed);
        let mut out = Vec::new();
        for slot in &mut self.reports {
            let Some(frame) = slot.frame.filter(|&f| f <= completed) else {
                continue;
            };
            slot.frame = None;
            let bytes = slot.buffer.read_bytes()?;
            let control: RelaxControl =
                bytemuck::pod_read_unaligned(&bytes[..std::mem::size_of::<RelaxControl>()]);
            out.push(CompletedSolve {
                frame,
                levels: vec![LevelControl {
                    groups: control.groups,
                    iterations: control.iterations,
                    blocks: control.blocks,
                    rel_previous: 0.0,
                    estimate: 0.0,
                    stopped_early: control.converged,
                }],
                multigrid: None,
                bounce: None,
            });
        }
        out.sort_by_key(|s| s.frame);
        Ok(out)
    }

    fn gpu_bytes(&self) -> u64 {
        self.passes.grid.bytes()
    }

    fn as_any(&self) -> &dyn std::any::Any {
        self
    }

    fn as_any_mut(&mut self) -> &mut dyn std::any::Any {
        self
    }
}
