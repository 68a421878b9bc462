//! [`VoxelMethod`]: the voxel method's passes composed into one frame, for phase 1 (tests,
//! benches, rendering through `render::HeadlessRenderer`) until the frame graph's method seam
//! takes them. It places the barriers between the passes from their declarations
//! ([`super::sync::ResourceUse`]) with a small state tracker, which the frame graph replaces.

use std::collections::HashMap;

use ash::vk;
use glam::DVec3;

use super::exit::ExitPass;
use super::grid::{GridDims, GridFrame, VoxelGrid};
use super::inject::InjectPass;
use super::material::MaterialVolume;
use super::mesh::{MeshHandles, MeshIndices, SurfaceMesh};
use super::relax::{RelaxControl, RelaxPass};
use super::rsm::{ReflectiveShadowMaps, RsmDesc};
use super::sync::{Resource, ResourceUse, State};
use super::voxelize::{VoxelizePass, MESH_VERTICES};
use super::{auto_resolution, VoxelModel, VoxelParams, VoxelResolution};
use crate::material::MaterialField;
use crate::mesh::TriMesh;
use crate::render::GpuMesh;
use crate::solver::{Environment, Light};
use crate::vk::{barrier, Access, Context, GpuProfiler, Image};
use crate::Error;

/// Views the reflective shadow maps hold: a point light inside the object takes 6.
pub const RSM_MAX_VIEWS: u32 = 8;
/// `rsm_tile: None`: about this many texels per voxel across the light's view of the object.
const RSM_TEXELS_PER_VOXEL: f64 = 3.0;

/// What a frame did, read after it completed.
#[derive(Clone, Debug, PartialEq)]
pub struct VoxelReport {
    /// Voxels per axis and along the rest pose's longest side.
    pub dims: [u32; 3],
    pub voxels: u32,
    /// The grid the GPU fitted this frame.
    pub grid: GridFrame,
    /// Relaxation iterations (Jacobi) or sweeps run, from the GPU counter.
    pub iterations: u32,
    /// Whether the relaxation reached its fixed point before the cap.
    pub converged: bool,
    /// The most iterations (sweeps) a frame records.
    pub cap: u32,
    /// GPU memory of the volumes, bytes.
    pub bytes: u64,
}

#[derive(Clone, Debug, Default)]
struct Tracked {
    /// The last writing state (or layout transition), if any since creation.
    last_write: Option<State>,
    /// States that read since the last write and were made visible.
    readers: Vec<State>,
    layout: vk::ImageLayout,
}

/// Barriers between passes from their declared uses: a read waits for the last write (once per
/// reading state); a write or a layout change waits for the last write and every read since.
#[derive(Default)]
struct Tracker {
    resources: HashMap<u64, Tracked>,
}

impl Tracker {
    /// Records the barriers `uses` need and notes the new states.
    ///
    /// # Safety
    /// `cb` must be recording outside a rendering scope.
    unsafe fn transition(&mut self, ctx: &Context, cb: vk::CommandBuffer, uses: &[ResourceUse<'_>]) {
        let mut memory = Vec::new();
        let mut images = Vec::new();
        for u in uses {
            let t = self.resources.entry(u.resource.id()).or_default();
            let (dst_stage, dst_access, new_layout) = u.state.info();
            let is_image = matches!(u.resource, Resource::Image(_));
            let layout_change = is_image && t.layout != new_layout;
            let writes = u.state.writes() || layout_change;
            let mut src_stage = vk::PipelineStageFlags2::NONE;
            let mut src_access = vk::AccessFlags2::NONE;
            let mut need = layout_change;
            if let Some(w) = t.last_write {
                let (s, a, _) = w.info();
                if writes || !t.readers.contains(&u.state) {
                    src_stage |= s;
                    src_access |= a;
                    need = true;
                }
            }
            if writes {
                for r in &t.readers {
                    src_stage |= r.info().0;
                    need = true;
                }
            }
            if need {
                match u.resource {
                    Resource::Image(image) => {
                        let template = super::sync::image_barrier(
                            image,
                            State::Vk(Access::Undefined),
                            u.state,
                        );
                        images.push(
                            template
                                .src_stage_mask(src_stage)
                                .src_access_mask(src_access)
                                .dst_stage_mask(dst_stage)
                                .dst_access_mask(dst_access)
                                .old_layout(t.layout)
                                .new_layout(new_layout),
                        );
                    }
                    Resource::Buffer(_) | Resource::RawBuffer(..) => memory.push(
                        vk::MemoryBarrier2::default()
                            .src_stage_mask(src_stage)
                            .src_access_mask(src_access)
                            .dst_stage_mask(dst_stage)
                            .dst_access_mask(dst_access),
                    ),
                }
            }
            if writes {
                t.last_write = Some(u.state);
                t.readers.clear();
            } else if !t.readers.contains(&u.state) {
                t.readers.push(u.state);
            }
            if is_image {
                t.layout = new_layout;
            }
        }
        if !memory.is_empty() || !images.is_empty() {
            // SAFETY: the caller's contract.
            // why: each entry orders one declared use after the resource's last write (RAW) or
            // after its last write and reads (WAR/WAW, layout changes).
            unsafe { barrier::record(ctx, cb, &memory, &images) };
        }
    }

    /// The state an image is in now (for read-backs).
    fn state_of(&self, image: &Image) -> State {
        use ash::vk::Handle;
        match self.resources.get(&image.raw.as_raw()) {
            Some(t) if t.layout != vk::ImageLayout::UNDEFINED => {
                t.last_write.unwrap_or(State::Vk(Access::Undefined))
            }
            _ => State::Vk(Access::Undefined),
        }
    }
}

/// The voxel method's passes and volumes for one object, composed into a frame.
pub struct VoxelMethod {
    pub params: VoxelParams,
    pub grid: VoxelGrid,
    pub material: MaterialVolume,
    pub voxelize: VoxelizePass,
    pub rsm: ReflectiveShadowMaps,
    pub inject: InjectPass,
    pub relax: RelaxPass,
    pub exit: ExitPass,
    tracker: Tracker,
    rest_bounds: (DVec3, DVec3),
    write_mesh: bool,
    mesh: Option<MeshHandles>,
    eta: f64,
}

impl VoxelMethod {
    /// The method for an object whose rest pose is `mesh` (its bounds fix the grid's dims;
    /// positions come from the GPU every frame), of material `field`.
    pub fn new(
        ctx: &Context,
        mesh: &TriMesh,
        field: &MaterialField,
        params: &VoxelParams,
    ) -> Result<VoxelMethod, Error> {
        params.validate()?;
        let bounds = mesh.bounds();
        let voxels = match params.resolution {
            VoxelResolution::Fixed(n) => n,
            VoxelResolution::Auto => auto_resolution(field, params.model, bounds.0, bounds.1),
        };
        let material = MaterialVolume::new(ctx, field, bounds, params.material_resolution)?;
        Self::with_material(ctx, bounds, voxels, material, field.eta(), params)
    }

    /// As [`Self::new`] with a prepared [`MaterialVolume`] (e.g. raw coefficients with
    /// sigma_t' = 0) and an explicit voxel count.
    pub fn with_material(
        ctx: &Context,
        bounds: (DVec3, DVec3),
        voxels: u32,
        material: MaterialVolume,
        eta: f64,
        params: &VoxelParams,
    ) -> Result<VoxelMethod, Error> {
        params.validate()?;
        let dims = GridDims::new(bounds.0, bounds.1, voxels)?;
        let grid = VoxelGrid::new(ctx, dims, params.model == VoxelModel::Diffusion)?;
        let mut voxelize = VoxelizePass::new(ctx, &grid, params.model, params.vote_axes)?;
        voxelize.bind_material(ctx, &grid, &material)?;
        let tile = params.rsm_tile.unwrap_or_else(|| {
            // A view covers the bounding sphere (diameter: the box's diagonal).
            let diagonal = (bounds.1 - bounds.0).length();
            let texels = RSM_TEXELS_PER_VOXEL * f64::from(voxels) * diagonal
                / (bounds.1 - bounds.0).max_element();
            (texels.ceil() as u32).next_power_of_two().clamp(64, 1024)
        });
        let rsm = ReflectiveShadowMaps::new(
            ctx,
            &RsmDesc {
                tile_resolution: tile,
                max_views: RSM_MAX_VIEWS,
            },
        )?;
        let inject = InjectPass::new(ctx, &grid, &rsm)?;
        let relax = RelaxPass::new(ctx, &grid, params, eta)?;
        let mut exit = ExitPass::new(ctx, params.model, eta)?;
        exit.bind_material(ctx, &grid, &material)?;
        Ok(VoxelMethod {
            params: params.clone(),
            grid,
            material,
            voxelize,
            rsm,
            inject,
            relax,
            exit,
            tracker: Tracker::default(),
            rest_bounds: bounds,
            write_mesh: false,
            mesh: None,
            eta,
        })
    }

    /// Lights for the next frames; `bounds` is a box around the mesh now (the light views cover
    /// its bounding sphere). Bad lights are a typed error and change nothing.
    pub fn set_lights(&mut self, lights: &[Light], bounds: (DVec3, DVec3)) -> Result<(), Error> {
        let (lo, hi) = bounds;
        let centre = (lo + hi) * 0.5;
        let radius = ((hi - lo).length() * 0.5).max(1e-6);
        self.rsm.set_lights(lights, (centre, radius), self.eta)
    }

    /// The environment (constant only, see [`InjectPass::set_environment`]).
    pub fn set_environment(&mut self, environment: &Environment) -> Result<(), Error> {
        self.inject
            .set_environment(environment, self.eta)
    }

    /// A new material: staged, uploaded at the next record (no re-voxelization, no bake).
    pub fn set_material(&mut self, ctx: &Context, field: &MaterialField) -> Result<(), Error> {
        crate::material::check_eta(field.eta())?;
        self.material.set_field(
            ctx,
            field,
            self.rest_bounds,
            self.params.material_resolution,
        )?;
        self.voxelize
            .bind_material(ctx, &self.grid, &self.material)?;
        self.exit.bind_material(ctx, &self.grid, &self.material)?;
        self.exit.set_eta(field.eta())?;
        self.relax.set_eta(field.eta());
        self.eta = field.eta();
        Ok(())
    }

    /// The display mesh (`render::GpuMesh`, positions moved by a GPU deformation or not) with its
    /// triangles uploaded once more for compute ([`MeshIndices`]).
    pub fn surface<'a>(&self, display: &'a GpuMesh, indices: &'a MeshIndices) -> SurfaceMesh<'a> {
        SurfaceMesh {
            vertices: display.vertex_buffer(),
            vertex_count: display.vertex_count() as u32,
            indices: &indices.buffer,
            triangle_count: indices.triangle_count,
        }
    }

    /// Reads `mesh` from now on (again after a topology change: new buffers); `write_mesh`: also
    /// write J+ into its vertices' exitance field for today's shading pass.
    pub fn bind_mesh(
        &mut self,
        ctx: &Context,
        mesh: &SurfaceMesh<'_>,
        write_mesh: bool,
    ) -> Result<(), Error> {
        if write_mesh && mesh.indices.raw == mesh.vertices.raw {
            return Err(super::bad_param("mesh", "vertices and indices share a buffer").into());
        }
        self.voxelize.bind_mesh(ctx, &self.grid, mesh)?;
        self.exit.bind_mesh(ctx, &self.grid, mesh, write_mesh)?;
        self.write_mesh = write_mesh;
        self.mesh = Some(mesh.handles());
        Ok(())
    }

    /// Records a whole frame of the method: material upload (when staged), voxelization,
    /// reflective shadow maps, injection, relaxation, exit, with the barriers between them; with
    /// `write_mesh`, leaves the mesh's vertices visible to vertex input (the shading draw).
    ///
    /// # Safety
    /// `cb` must be recording outside a rendering scope; the bound mesh's buffers and `self` must
    /// be alive and outlive the command buffer's execution.
    pub unsafe fn record(
        &mut self,
        ctx: &Context,
        cb: vk::CommandBuffer,
        profiler: Option<&mut GpuProfiler>,
    ) -> Result<(), Error> {
        let Some(mesh) = self.mesh else {
            return Err(super::bad_param("voxel method", "record before bind_mesh").into());
        };
        let mesh = &mesh;
        let mut profiler = profiler;
        // SAFETY: the caller's contract; each pass's declared resources are put in their
        // declared states by the tracker first.
        unsafe {
            if self.material.upload_pending() {
                let uses = self.material.declare_upload();
                self.tracker.transition(ctx, cb, &uses);
                self.material.record_upload(ctx, cb);
            }
            let uses = self.voxelize.declare(&self.grid, mesh, &self.material);
            self.tracker.transition(ctx, cb, &uses);
            self.voxelize.record(
                ctx,
                cb,
                &self.grid,
                &self.material,
                profiler.as_deref_mut(),
            )?;
            let uses = self.rsm.declare(mesh);
            self.tracker.transition(ctx, cb, &uses);
            self.rsm.record(ctx, cb, mesh, profiler.as_deref_mut());
            let uses = self.inject.declare(&self.grid, &self.rsm);
            self.tracker.transition(ctx, cb, &uses);
            self.inject
                .record(ctx, cb, &self.grid, &self.rsm, profiler.as_deref_mut());
            let uses = self.relax.declare(&self.grid);
            self.tracker.transition(ctx, cb, &uses);
            self.relax
                .record(ctx, cb, &self.grid, profiler.as_deref_mut());
            let uses = self.exit.declare(&self.grid, mesh, &self.material);
            self.tracker.transition(ctx, cb, &uses);
            self.exit
                .record(ctx, cb, &self.grid, &self.material, profiler)?;
            if self.write_mesh {
                // The shading draw fetches the exitance just written.
                self.tracker.transition(
                    ctx,
                    cb,
                    &[ResourceUse::raw_buffer(
                        mesh.vertices,
                        MESH_VERTICES,
                        Access::VertexInput,
                    )],
                );
            }
        }
        Ok(())
    }

    /// Headless, after the frame completed: the grid, iterations, convergence, memory.
    pub fn report(&self, ctx: &Context) -> Result<VoxelReport, Error> {
        let control: RelaxControl = self.relax.control(ctx)?;
        Ok(VoxelReport {
            dims: self.grid.dims.dims,
            voxels: self.grid.dims.voxels,
            grid: self.grid.read_frame(ctx)?,
            iterations: control.iterations,
            converged: control.converged != 0,
            cap: self.relax.cap(),
            bytes: self.grid.bytes(),
        })
    }

    /// Headless, after the frame completed: (M rgb, covered) per display vertex.
    pub fn exitance(&self, ctx: &Context) -> Result<Vec<[f32; 4]>, Error> {
        self.exit.read_exitance(ctx)
    }

    /// Headless, after the frame completed: one of the grid's volumes, texel by texel.
    pub fn read_volume(&self, ctx: &Context, image: &Image) -> Result<Vec<[f32; 4]>, Error> {
        self.grid
            .read_volume(ctx, image, self.tracker.state_of(image))
    }
}
