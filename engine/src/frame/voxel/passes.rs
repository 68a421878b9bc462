//! [`VoxelPasses`]: the voxel method's passes and volumes for one object, added to a
//! [`FrameGraph`] in frame order ([`VoxelPasses::add_passes`]: material upload, voxelization,
//! reflective shadow maps, injection, relaxation, exit), the graph placing the barriers between
//! them from their declarations. [`super::VoxelMethod`] puts them behind the method seam;
//! [`VoxelPasses::record`] runs them alone (tests, read-backs of the volumes).

use ash::vk;
use glam::DVec3;

use super::inject::InjectPass;
use super::inject::PASS_INJECT;
use super::rsm::PASS_RSM;
use super::rsm::{ReflectiveShadowMaps, RsmDesc};
use crate::frame::FrameGraph;
use crate::material::MaterialField;
use crate::mesh::GpuMesh;
use crate::mesh::TriMesh;
use crate::scene::{Environment, Light};
use crate::solver::voxel::ExitPass;
use crate::solver::voxel::MaterialVolume;
use crate::solver::voxel::{auto_resolution, VoxelModel, VoxelParams, VoxelResolution};
use crate::solver::voxel::{GridDims, GridFrame, VoxelGrid};
use crate::solver::voxel::{MeshHandles, MeshIndices, SurfaceMesh};
use crate::solver::voxel::{RelaxControl, RelaxPass};
use crate::solver::voxel::{VoxelizePass, PASS_EXIT, PASS_RELAX, PASS_VOXELIZE};
use crate::vk::Buffer;
use crate::vk::{Context, GpuProfiler, Image};
use crate::Error;

/// The staged material's upload (when one is staged).
pub const PASS_MATERIAL_UPLOAD: &str = "voxel material upload";
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

/// The voxel method's passes and volumes for one object, composed into a frame.
pub struct VoxelPasses {
    pub params: VoxelParams,
    pub grid: VoxelGrid,
    pub material: MaterialVolume,
    pub voxelize: VoxelizePass,
    pub rsm: ReflectiveShadowMaps,
    pub inject: InjectPass,
    pub relax: RelaxPass,
    pub exit: ExitPass,
    rest_bounds: (DVec3, DVec3),
    write_mesh: bool,
    mesh: Option<MeshHandles>,
    eta: f64,
    /// The staged material texels of the last [`Self::record`] (alive until the next one).
    uploaded: Option<Buffer>,
}

impl VoxelPasses {
    /// The method for an object whose rest pose is `mesh` (its bounds fix the grid's dims;
    /// positions come from the GPU every frame), of material `field`.
    pub fn new(
        ctx: &Context,
        mesh: &TriMesh,
        field: &MaterialField,
        params: &VoxelParams,
    ) -> Result<VoxelPasses, Error> {
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
    ) -> Result<VoxelPasses, Error> {
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
        Ok(VoxelPasses {
            params: params.clone(),
            grid,
            material,
            voxelize,
            rsm,
            inject,
            relax,
            exit,
            rest_bounds: bounds,
            write_mesh: false,
            mesh: None,
            eta,
            uploaded: None,
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
        self.inject.set_environment(environment, self.eta)
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
    /// write J+ into its vertices' exitance field for the shading pass.
    pub fn bind_mesh(
        &mut self,
        ctx: &Context,
        mesh: &SurfaceMesh<'_>,
        write_mesh: bool,
    ) -> Result<(), Error> {
        if write_mesh && mesh.indices.raw == mesh.vertices.raw {
            return Err(crate::solver::voxel::bad_param(
                "mesh",
                "vertices and indices share a buffer",
            )
            .into());
        }
        self.voxelize.bind_mesh(ctx, &self.grid, mesh)?;
        self.exit.bind_mesh(ctx, &self.grid, mesh, write_mesh)?;
        self.write_mesh = write_mesh;
        self.mesh = Some(mesh.handles());
        Ok(())
    }

    /// Adds the method's passes to `graph`, in frame order, reading and (with `write_mesh`)
    /// writing `mesh` (the one bound with [`Self::bind_mesh`]): the material upload when one is
    /// staged and `upload`, voxelization, reflective shadow maps, injection, relaxation (its
    /// control record copied to `report` when given), exit.
    pub fn add_passes<'g>(
        &'g self,
        graph: &mut FrameGraph<'g>,
        mesh: SurfaceMesh<'g>,
        upload: bool,
        report: Option<&'g Buffer>,
    ) -> Result<(), Error> {
        if self.mesh != Some(mesh.handles()) {
            return Err(
                crate::solver::voxel::bad_param("voxel method", "record before bind_mesh").into(),
            );
        }
        if upload && self.material.upload_pending() {
            graph
                .pass(PASS_MATERIAL_UPLOAD)
                .uses(self.material.declare_upload())
                .record(move |p| {
                    // SAFETY: inside the graph's pass declaring the upload's uses; the staging
                    // buffer lives until the frame completed (the caller's `take_pending`).
                    unsafe { self.material.record_upload(p.ctx, p.cb) };
                    Ok(())
                });
        }
        graph
            .pass(PASS_VOXELIZE)
            .uses(self.voxelize.declare(&self.grid, &mesh, &self.material))
            .record(move |p| {
                // SAFETY: inside the graph's pass declaring the voxelization's uses.
                unsafe {
                    self.voxelize
                        .record(p.ctx, p.cb, &self.grid, &self.material, None)
                }
            });
        let handles = mesh.handles();
        graph
            .pass(PASS_RSM)
            .uses(self.rsm.declare(&mesh))
            .record(move |p| {
                // SAFETY: inside the graph's pass declaring the maps' uses; the mesh outlives
                // the frame (the caller's).
                unsafe { self.rsm.record(p.ctx, p.cb, &handles, None) };
                Ok(())
            });
        graph
            .pass(PASS_INJECT)
            .uses(self.inject.declare(&self.grid, &self.rsm))
            .record(move |p| {
                // SAFETY: inside the graph's pass declaring the injection's uses.
                unsafe { self.inject.record(p.ctx, p.cb, &self.grid, &self.rsm, None) };
                Ok(())
            });
        graph
            .pass(PASS_RELAX)
            .uses(self.relax.declare(&self.grid, report))
            .record(move |p| {
                // SAFETY: inside the graph's pass declaring the relaxation's uses.
                unsafe { self.relax.record(p.ctx, p.cb, &self.grid, report, None) };
                Ok(())
            });
        graph
            .pass(PASS_EXIT)
            .uses(self.exit.declare(&self.grid, &mesh, &self.material))
            .record(move |p| {
                // SAFETY: inside the graph's pass declaring the exit's uses.
                unsafe {
                    self.exit
                        .record(p.ctx, p.cb, &self.grid, &self.material, None)
                }
            });
        Ok(())
    }

    /// Records a whole frame of the method alone (its own frame graph): the passes of
    /// [`Self::add_passes`].
    ///
    /// # Safety
    /// `cb` must be recording outside a rendering scope; `mesh` (the bound one) and `self` must
    /// outlive its execution, and the previous record's submission must have completed (its
    /// staged material is released here).
    pub unsafe fn record(
        &mut self,
        ctx: &Context,
        cb: vk::CommandBuffer,
        mesh: SurfaceMesh<'_>,
        profiler: Option<&mut GpuProfiler>,
    ) -> Result<(), Error> {
        self.uploaded = None;
        {
            let mut graph = FrameGraph::new(ctx);
            self.add_passes(&mut graph, mesh, true, None)?;
            // SAFETY: the caller's contract.
            unsafe { graph.execute(cb, profiler, false)? };
        }
        self.uploaded = self.material.take_pending();
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
        self.grid.read_volume(ctx, image)
    }
}
