//! [`VoxelizePass`]: solid voxelization of a triangle mesh on the GPU, every frame (DESIGN
//! section 6; paper section 2.1's "fast construction of the graph by solid voxelization").
//!
//! 1. `voxel/fit_grid.comp`: the mesh's bounds, reduced in one workgroup, fit the grid
//!    ([`super::GridFrame`]): nothing about the shape comes from the CPU.
//! 2. Per axis (x, y, z, or only z with `vote_axes = 1`): `voxel/rasterize_crossings.comp` adds
//!    every triangle's signed crossing to the voxel columns along the axis it covers (watertight
//!    edge functions); `voxel/count_votes.comp` sums each column from its low end, and a voxel
//!    with a non-zero winding number gets the axis's vote.
//! 3. `voxel/classify_voxels.comp`: solid = at least 2 of 3 votes (1 of 1), and the medium (the
//!    model's cost coefficient) sampled from the [`super::MaterialVolume`].
//!
//! **Holes** (the Stanford bunny has five in its base): a column whose line passes through a
//! hole misses one crossing, so from there on the winding number of that column is off by one:
//! with one axis, a streak of wrong voxels runs from the hole to the grid's end. With three axes
//! the streak has one wrong vote of three and is outvoted, unless the voxel also sees a hole
//! along a second axis (near the hole itself, where inside and outside are a guess anyway: the
//! generalized winding number of the CPU reference puts it half way). Measured on the bunny:
//! see `tests/tests/voxel_voxelize.rs` and benches/RESULTS.md, "Voxel method".
//! Inside-out meshes: the winding number is -1 inside, non-zero, solid. Overlapping parts (a
//! fracture's pieces touching): the union.

use ash::vk;

use super::grid::VoxelGrid;
use super::material::MaterialVolume;
use super::mesh::{SurfaceMesh, VERTEX_FLOATS};
use super::sync::ResourceUse;
use super::VoxelModel;
use crate::shader::{ComputePipeline, ComputePipelineDesc, DescriptorWrite, ShaderError};
use crate::vk::{barrier, Access, Buffer, BufferDesc, Context, GpuProfiler, MemoryUse};
use crate::Error;

/// Profiler scope and debug label of the pass.
pub const PASS_VOXELIZE: &str = "voxelize";
/// Names of the bound mesh's buffers in declarations.
pub const MESH_VERTICES: &str = "mesh vertices";
pub const MESH_INDICES: &str = "mesh indices";

/// Push constants of `voxel/fit_grid.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct FitPush {
    pub dims: [u32; 4],
    pub vertex_count: u32,
    /// Floats per vertex.
    pub stride: u32,
    /// The smallest voxel size (a mesh collapsed to a point), mm.
    pub min_h: f32,
    pub pad: f32,
}

/// Push constants of `voxel/rasterize_crossings.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct CrossingPush {
    pub triangle_count: u32,
    pub stride: u32,
    pub axis: u32,
    pub pad: u32,
}

/// Push constants of `voxel/count_votes.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct VotePush {
    pub dims: [u32; 4],
    pub axis: u32,
    pub pad: [u32; 3],
}

/// Push constants of `voxel/classify_voxels.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ClassifyPush {
    pub dims: [u32; 4],
    pub material_lo: [f32; 4],
    pub material_hi: [f32; 4],
    pub votes_needed: u32,
    /// 0: paper (sigma_t'), 1: diffusion (sigma_tr).
    pub model: u32,
    pub pad: [u32; 2],
}

/// The smallest voxel size the fit allows, relative to the rest pose's (a mesh collapsed to a
/// point still gets a finite, positive h).
const MIN_H_FRACTION: f64 = 1e-6;

fn fit_pipeline(ctx: &Context) -> Result<ComputePipeline<FitPush>, ShaderError> {
    ComputePipeline::new(
        ctx,
        &ComputePipelineDesc {
            name: "voxel fit grid",
            shader: "voxel/fit_grid.comp",
            bindings: &["vertices", "grid"],
            max_sets: 8,
        },
    )
}

fn rasterize_pipeline(ctx: &Context) -> Result<ComputePipeline<CrossingPush>, ShaderError> {
    ComputePipeline::new(
        ctx,
        &ComputePipelineDesc {
            name: "voxel rasterize crossings",
            shader: "voxel/rasterize_crossings.comp",
            bindings: &["vertices", "indices", "grid", "crossings"],
            max_sets: 8,
        },
    )
}

fn classify_pipeline(ctx: &Context) -> Result<ComputePipeline<ClassifyPush>, ShaderError> {
    ComputePipeline::new(
        ctx,
        &ComputePipelineDesc {
            name: "voxel classify",
            shader: "voxel/classify_voxels.comp",
            bindings: &[
                "votes",
                "grid",
                "sigma_s_volume",
                "sigma_a_volume",
                "medium",
                "transport",
            ],
            max_sets: 8,
        },
    )
}

/// Allocates a descriptor set; when the pipeline's pool is used up (a mesh or material bound
/// many times), builds the pipeline again (its old sets go with it: callers keep only the newest
/// set of these pipelines) and allocates from the new pool.
pub(super) fn allocate_rebuilding<P: bytemuck::Pod>(
    ctx: &Context,
    pipeline: &mut ComputePipeline<P>,
    make: fn(&Context) -> Result<ComputePipeline<P>, ShaderError>,
    writes: &[DescriptorWrite<'_>],
) -> Result<vk::DescriptorSet, Error> {
    match pipeline.allocate_set(ctx, writes) {
        Ok(set) => Ok(set),
        Err(ShaderError::Vk(_)) => {
            *pipeline = make(ctx)?;
            Ok(pipeline.allocate_set(ctx, writes)?)
        }
        Err(e) => Err(e.into()),
    }
}

/// The voxelization pass (see the module doc). Owns its pipelines and the per-voxel crossing
/// counts and votes (scratch, used only inside the pass).
pub struct VoxelizePass {
    fit: ComputePipeline<FitPush>,
    rasterize: ComputePipeline<CrossingPush>,
    votes: ComputePipeline<VotePush>,
    classify: ComputePipeline<ClassifyPush>,
    crossings: Buffer,
    vote_counts: Buffer,
    vote_sets: vk::DescriptorSet,
    mesh_sets: Option<(vk::DescriptorSet, vk::DescriptorSet)>,
    mesh_key: Option<(u64, u64, u32, u32)>,
    classify_set: Option<vk::DescriptorSet>,
    material_key: Option<(u64, u64)>,
    vote_axes: u32,
    model: VoxelModel,
    min_h: f32,
    vertex_count: u32,
    triangle_count: u32,
}

impl VoxelizePass {
    pub fn new(
        ctx: &Context,
        grid: &VoxelGrid,
        model: VoxelModel,
        vote_axes: u32,
    ) -> Result<VoxelizePass, Error> {
        let count = grid.dims.count() as u64;
        let scratch = |name| {
            Buffer::new(
                ctx,
                &BufferDesc {
                    name,
                    size: count * 4,
                    usage: vk::BufferUsageFlags::STORAGE_BUFFER
                        | vk::BufferUsageFlags::TRANSFER_DST,
                    memory: MemoryUse::GpuOnly,
                },
            )
        };
        let crossings = scratch("voxel crossings")?;
        let vote_counts = scratch("voxel votes")?;
        let votes = ComputePipeline::new(
            ctx,
            &ComputePipelineDesc {
                name: "voxel count votes",
                shader: "voxel/count_votes.comp",
                bindings: &["crossings", "votes"],
                max_sets: 1,
            },
        )?;
        let vote_sets = votes.allocate_set(
            ctx,
            &[
                DescriptorWrite::StorageBuffer {
                    name: "crossings",
                    buffer: &crossings,
                },
                DescriptorWrite::StorageBuffer {
                    name: "votes",
                    buffer: &vote_counts,
                },
            ],
        )?;
        Ok(VoxelizePass {
            fit: fit_pipeline(ctx)?,
            rasterize: rasterize_pipeline(ctx)?,
            votes,
            classify: classify_pipeline(ctx)?,
            crossings,
            vote_counts,
            vote_sets,
            mesh_sets: None,
            mesh_key: None,
            classify_set: None,
            material_key: None,
            vote_axes,
            model,
            min_h: (grid.dims.rest_h * MIN_H_FRACTION) as f32,
            vertex_count: 0,
            triangle_count: 0,
        })
    }

    /// Reads `mesh` from now on (new descriptor sets only when its buffers or counts changed).
    pub fn bind_mesh(
        &mut self,
        ctx: &Context,
        grid: &VoxelGrid,
        mesh: &SurfaceMesh<'_>,
    ) -> Result<(), Error> {
        mesh.validate()?;
        if self.mesh_key == Some(mesh.key()) {
            return Ok(());
        }
        let fit = allocate_rebuilding(
            ctx,
            &mut self.fit,
            fit_pipeline,
            &[
                DescriptorWrite::StorageBuffer {
                    name: "vertices",
                    buffer: mesh.vertices,
                },
                DescriptorWrite::StorageBuffer {
                    name: "grid",
                    buffer: &grid.frame,
                },
            ],
        )?;
        let rasterize = allocate_rebuilding(
            ctx,
            &mut self.rasterize,
            rasterize_pipeline,
            &[
                DescriptorWrite::StorageBuffer {
                    name: "vertices",
                    buffer: mesh.vertices,
                },
                DescriptorWrite::StorageBuffer {
                    name: "indices",
                    buffer: mesh.indices,
                },
                DescriptorWrite::StorageBuffer {
                    name: "grid",
                    buffer: &grid.frame,
                },
                DescriptorWrite::StorageBuffer {
                    name: "crossings",
                    buffer: &self.crossings,
                },
            ],
        )?;
        self.mesh_sets = Some((fit, rasterize));
        self.mesh_key = Some(mesh.key());
        self.vertex_count = mesh.vertex_count;
        self.triangle_count = mesh.triangle_count;
        Ok(())
    }

    /// Samples `material` from now on (new descriptor set only when its images changed).
    pub fn bind_material(
        &mut self,
        ctx: &Context,
        grid: &VoxelGrid,
        material: &MaterialVolume,
    ) -> Result<(), Error> {
        use ash::vk::Handle;
        let key = (material.sigma_s.raw.as_raw(), material.sigma_a.raw.as_raw());
        if self.material_key == Some(key) {
            return Ok(());
        }
        let set = allocate_rebuilding(
            ctx,
            &mut self.classify,
            classify_pipeline,
            &[
                DescriptorWrite::StorageBuffer {
                    name: "votes",
                    buffer: &self.vote_counts,
                },
                DescriptorWrite::StorageBuffer {
                    name: "grid",
                    buffer: &grid.frame,
                },
                DescriptorWrite::SampledImage {
                    name: "sigma_s_volume",
                    image: &material.sigma_s,
                    sampler: material.sampler.raw,
                    layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
                },
                DescriptorWrite::SampledImage {
                    name: "sigma_a_volume",
                    image: &material.sigma_a,
                    sampler: material.sampler.raw,
                    layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
                },
                DescriptorWrite::storage_image("medium", &grid.medium),
                DescriptorWrite::storage_image("transport", &grid.transport),
            ],
        )?;
        self.classify_set = Some(set);
        self.material_key = Some(key);
        Ok(())
    }

    /// Reads: the mesh's vertices and indices (compute), the material (sampled). Writes: the grid
    /// frame, the medium and the transport volume (compute; the frame is also read inside the
    /// pass).
    pub fn declare<'a>(
        &self,
        grid: &'a VoxelGrid,
        mesh: &SurfaceMesh<'a>,
        material: &'a MaterialVolume,
    ) -> Vec<ResourceUse<'a>> {
        let mut uses = vec![
            ResourceUse::buffer(mesh.vertices, Access::ComputeRead),
            ResourceUse::buffer(mesh.indices, Access::ComputeRead),
            ResourceUse::buffer(&grid.frame, Access::ComputeWrite),
            ResourceUse::image(&grid.medium, Access::ComputeWrite),
            // Written by the diffusion model; bound (a placeholder) either way.
            ResourceUse::image(&grid.transport, Access::ComputeWrite),
        ];
        uses.extend(material.declare_read());
        uses
    }

    /// Records the fit, the crossings and votes of every axis, and the classification.
    ///
    /// # Safety
    /// `cb` must be recording outside a rendering scope; the declared resources must be in their
    /// declared states, and everything bound must outlive the command buffer's execution.
    pub unsafe fn record(
        &self,
        ctx: &Context,
        cb: vk::CommandBuffer,
        grid: &VoxelGrid,
        material: &MaterialVolume,
        profiler: Option<&mut GpuProfiler>,
    ) -> Result<(), Error> {
        let (Some((fit_set, rasterize_set)), Some(classify_set)) =
            (self.mesh_sets, self.classify_set)
        else {
            return Err(
                super::bad_param("voxelize", "record before bind_mesh and bind_material").into(),
            );
        };
        let dims = grid.dims.push();
        let raw = ctx.raw();
        let mut profiler = profiler;
        // SAFETY: the caller's contract; every set's resources live in `self`, `grid`, the bound
        // mesh and material.
        unsafe {
            ctx.begin_label(cb, PASS_VOXELIZE);
            if let Some(p) = profiler.as_deref_mut() {
                p.begin_scope(cb, PASS_VOXELIZE);
            }
            self.fit.dispatch(
                ctx,
                cb,
                fit_set,
                &FitPush {
                    dims,
                    vertex_count: self.vertex_count,
                    stride: VERTEX_FLOATS,
                    min_h: self.min_h,
                    pad: 0.0,
                },
                [1, 1, 1],
            );
            // why: the votes are cleared after last frame's classification read them (WAR).
            barrier::memory(ctx, cb, Access::ComputeReadWrite, Access::TransferDst);
            raw.cmd_fill_buffer(cb, self.vote_counts.raw, 0, vk::WHOLE_SIZE, 0);
            let axes: &[u32] = if self.vote_axes == 3 {
                &[0, 1, 2]
            } else {
                &[2]
            };
            for &axis in axes {
                // why: the crossings are cleared after the previous axis's (or frame's) vote
                // counting read them (WAR).
                barrier::memory(ctx, cb, Access::ComputeReadWrite, Access::TransferDst);
                raw.cmd_fill_buffer(cb, self.crossings.raw, 0, vk::WHOLE_SIZE, 0);
                // why: the rasterization adds to the cleared crossings (RAW/WAW after the fill)
                // and reads the grid the fit wrote (RAW); the vote counting below adds to the
                // cleared votes.
                barrier::record(
                    ctx,
                    cb,
                    &[
                        barrier::memory_barrier(Access::TransferDst, Access::ComputeReadWrite),
                        barrier::memory_barrier(Access::ComputeWrite, Access::ComputeReadWrite),
                    ],
                    &[],
                );
                self.rasterize.dispatch(
                    ctx,
                    cb,
                    rasterize_set,
                    &CrossingPush {
                        triangle_count: self.triangle_count,
                        stride: VERTEX_FLOATS,
                        axis,
                        pad: 0,
                    },
                    [self.triangle_count, 1, 1],
                );
                // why: the vote counting reads the crossings just added (RAW).
                barrier::memory(ctx, cb, Access::ComputeWrite, Access::ComputeReadWrite);
                let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
                self.votes.dispatch(
                    ctx,
                    cb,
                    self.vote_sets,
                    &VotePush {
                        dims,
                        axis,
                        pad: [0; 3],
                    },
                    [dims[u as usize], dims[v as usize], 1],
                );
            }
            // why: the classification reads the votes (RAW).
            barrier::memory(ctx, cb, Access::ComputeWrite, Access::ComputeRead);
            self.classify.dispatch(
                ctx,
                cb,
                classify_set,
                &ClassifyPush {
                    dims,
                    material_lo: material.lo.extend(0.0).to_array(),
                    material_hi: material.hi.extend(0.0).to_array(),
                    votes_needed: if self.vote_axes == 3 { 2 } else { 1 },
                    model: match self.model {
                        VoxelModel::Paper => 0,
                        VoxelModel::Diffusion => 1,
                    },
                    pad: [0; 2],
                },
                [dims[0], dims[1], dims[2]],
            );
            if let Some(p) = profiler {
                p.end_scope(cb);
            }
            ctx.end_label(cb);
        }
        Ok(())
    }
}
