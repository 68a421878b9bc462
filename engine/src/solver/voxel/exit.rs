//! [`ExitPass`]: from optical depths to the exitance the shading reads (paper section 2.2).
//!
//! 1. `voxel/exit_volume.comp`: per solid voxel J+ (the model's exit, see the module doc of
//!    [`super`]) into the radiance volume, premultiplied by coverage (a = 1 solid, 0 empty).
//! 2. `voxel/vertex_exitance.comp`: the volume read with trilinear filtering at every display
//!    vertex, divided by the filtered coverage: `exitance[v] = vec4(M, covered)` with
//!    M = (1 - F_dr) J+, the radiant exitance into air (the method seam's output; a shading pass
//!    applies the angular lobe F_t(eta, theta_o) / (pi eta^2 ...)). Optionally it also writes
//!    J+ = M / (1 - F_dr) into the display mesh's [`crate::mesh::Vertex`] exitance field, which
//!    today's shading pass reads.
//!
//! The paper reads the 3D texture per fragment; per vertex is the seam's contract today. A
//! per-fragment lookup is a phase 2 option if it measures better.

use ash::vk;

use super::grid::{host_sync, VoxelGrid};
use super::material::MaterialVolume;
use super::mesh::{SurfaceMesh, EXITANCE_OFFSET, VERTEX_FLOATS};
use super::sync::{image_barrier, ResourceUse};
use super::voxelize::allocate_rebuilding;
use super::VoxelModel;
use crate::shader::{ComputePipeline, ComputePipelineDesc, DescriptorWrite, ShaderError};
use crate::vk::{barrier, Access, Buffer, BufferDesc, Context, GpuProfiler, MemoryUse};
use crate::Error;

/// Profiler scope and debug label of the pass.
pub const PASS_EXIT: &str = "voxel exit";

/// Push constants of `voxel/exit_volume.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ExitPush {
    pub dims: [u32; 4],
    pub material_lo: [f32; 4],
    pub material_hi: [f32; 4],
    /// 0: paper, 1: diffusion.
    pub model: u32,
    pub eta: f32,
    pub pad: [u32; 2],
}

/// Push constants of `voxel/vertex_exitance.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct VertexExitPush {
    pub count: u32,
    pub stride: u32,
    pub mesh_offset: u32,
    pub write_mesh: u32,
    pub eta: f32,
    pub pad: [f32; 3],
}

fn volume_pipeline(ctx: &Context) -> Result<ComputePipeline<ExitPush>, ShaderError> {
    ComputePipeline::new(
        ctx,
        &ComputePipelineDesc {
            name: "voxel exit volume",
            shader: "voxel/exit_volume.comp",
            bindings: &[
                "grid",
                "medium",
                "state",
                "path",
                "sigma_s_volume",
                "sigma_a_volume",
                "exit_volume",
            ],
            max_sets: 8,
        },
    )
}

fn vertex_pipeline(ctx: &Context) -> Result<ComputePipeline<VertexExitPush>, ShaderError> {
    ComputePipeline::new(
        ctx,
        &ComputePipelineDesc {
            name: "voxel vertex exitance",
            shader: "voxel/vertex_exitance.comp",
            bindings: &[
                "vertices",
                "grid",
                "exit_volume",
                "exitance",
                "mesh_exitance",
            ],
            max_sets: 8,
        },
    )
}

/// The exit pass (see the module doc). Owns the per-vertex exitance buffer.
pub struct ExitPass {
    volume: ComputePipeline<ExitPush>,
    volume_set: Option<vk::DescriptorSet>,
    material_key: Option<(u64, u64)>,
    vertex: ComputePipeline<VertexExitPush>,
    vertex_set: Option<vk::DescriptorSet>,
    mesh_key: Option<((u64, u64, u32, u32), bool)>,
    /// vec4 per display vertex: rgb M, a = 1 where a solid voxel was near (host-visible).
    pub exitance: Buffer,
    /// Bound as `mesh_exitance` when the mesh is not written.
    placeholder: Buffer,
    model: VoxelModel,
    eta: f32,
    write_mesh: bool,
    vertex_count: u32,
}

impl ExitPass {
    pub fn new(ctx: &Context, model: VoxelModel, eta: f64) -> Result<ExitPass, Error> {
        if !(eta.is_finite() && eta > 0.0) {
            return Err(
                super::bad_param("eta", format!("{eta} is not a positive index ratio")).into(),
            );
        }
        let storage = |name, size| {
            Buffer::new(
                ctx,
                &BufferDesc {
                    name,
                    size,
                    usage: vk::BufferUsageFlags::STORAGE_BUFFER,
                    memory: MemoryUse::Readback,
                },
            )
        };
        Ok(ExitPass {
            volume: volume_pipeline(ctx)?,
            volume_set: None,
            material_key: None,
            vertex: vertex_pipeline(ctx)?,
            vertex_set: None,
            mesh_key: None,
            exitance: storage("voxel vertex exitance", 16)?,
            placeholder: storage("voxel exitance placeholder", 16)?,
            model,
            eta: eta as f32,
            write_mesh: false,
            vertex_count: 0,
        })
    }

    /// Changes eta (the diffuse Fresnel of the exit and the model's albedo).
    pub fn set_eta(&mut self, eta: f64) -> Result<(), Error> {
        if !(eta.is_finite() && eta > 0.0) {
            return Err(
                super::bad_param("eta", format!("{eta} is not a positive index ratio")).into(),
            );
        }
        self.eta = eta as f32;
        Ok(())
    }

    /// Reads `material` from now on.
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
        let sampled = |name, image| DescriptorWrite::SampledImage {
            name,
            image,
            sampler: material.sampler.raw,
            layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
        };
        let set = allocate_rebuilding(
            ctx,
            &mut self.volume,
            volume_pipeline,
            &[
                DescriptorWrite::StorageBuffer {
                    name: "grid",
                    buffer: &grid.frame,
                },
                DescriptorWrite::storage_image("medium", &grid.medium),
                DescriptorWrite::storage_image("state", &grid.state[0]),
                DescriptorWrite::storage_image("path", &grid.path[0]),
                sampled("sigma_s_volume", &material.sigma_s),
                sampled("sigma_a_volume", &material.sigma_a),
                DescriptorWrite::storage_image("exit_volume", &grid.exit),
            ],
        )?;
        self.volume_set = Some(set);
        self.material_key = Some(key);
        Ok(())
    }

    /// Samples at `mesh`'s vertices from now on; `write_mesh`: also write J+ into its vertex
    /// buffer's exitance field (the buffer needs STORAGE usage, as `render::GpuMesh` has).
    pub fn bind_mesh(
        &mut self,
        ctx: &Context,
        grid: &VoxelGrid,
        mesh: &SurfaceMesh<'_>,
        write_mesh: bool,
    ) -> Result<(), Error> {
        mesh.validate()?;
        if self.mesh_key == Some((mesh.key(), write_mesh)) {
            return Ok(());
        }
        if mesh.vertex_count != self.vertex_count {
            self.exitance = Buffer::new(
                ctx,
                &BufferDesc {
                    name: "voxel vertex exitance",
                    size: u64::from(mesh.vertex_count) * 16,
                    usage: vk::BufferUsageFlags::STORAGE_BUFFER,
                    memory: MemoryUse::Readback,
                },
            )?;
        }
        let set = allocate_rebuilding(
            ctx,
            &mut self.vertex,
            vertex_pipeline,
            &[
                DescriptorWrite::StorageBuffer {
                    name: "vertices",
                    buffer: mesh.vertices,
                },
                DescriptorWrite::StorageBuffer {
                    name: "grid",
                    buffer: &grid.frame,
                },
                DescriptorWrite::SampledImage {
                    name: "exit_volume",
                    image: &grid.exit,
                    sampler: grid.sampler.raw,
                    layout: vk::ImageLayout::GENERAL,
                },
                DescriptorWrite::StorageBuffer {
                    name: "exitance",
                    buffer: &self.exitance,
                },
                DescriptorWrite::StorageBuffer {
                    name: "mesh_exitance",
                    buffer: if write_mesh {
                        mesh.vertices
                    } else {
                        &self.placeholder
                    },
                },
            ],
        )?;
        self.vertex_set = Some(set);
        self.mesh_key = Some((mesh.key(), write_mesh));
        self.write_mesh = write_mesh;
        self.vertex_count = mesh.vertex_count;
        Ok(())
    }

    /// Reads: the grid frame, medium, final state and path, the material (sampled), the mesh's
    /// positions. Writes: the radiance volume (then sampled inside the pass), the exitance
    /// buffer, and with `write_mesh` the mesh's exitance field (the mesh buffer read-write).
    pub fn declare<'a>(
        &'a self,
        grid: &'a VoxelGrid,
        mesh: &SurfaceMesh<'a>,
        material: &'a MaterialVolume,
    ) -> Vec<ResourceUse<'a>> {
        let mut uses = vec![
            ResourceUse::buffer(&grid.frame, Access::ComputeRead),
            ResourceUse::image(&grid.medium, Access::ComputeRead),
            ResourceUse::image(&grid.state[0], Access::ComputeRead),
            // Written, then sampled by the vertices inside the pass.
            ResourceUse::image_span(&grid.exit, Access::ComputeWrite, Access::ComputeSampled),
            ResourceUse::buffer(&self.exitance, Access::ComputeWrite),
            ResourceUse::buffer(
                mesh.vertices,
                if self.write_mesh {
                    Access::ComputeReadWrite
                } else {
                    Access::ComputeRead
                },
            ),
        ];
        // Bound either way (a placeholder without paths): GENERAL.
        uses.push(ResourceUse::image(&grid.path[0], Access::ComputeRead));
        uses.extend(material.declare_read());
        uses
    }

    /// Records the radiance volume and the per-vertex exitance.
    ///
    /// # Safety
    /// `cb` must be recording outside a rendering scope, the declared resources in their declared
    /// states and alive until it completes.
    pub unsafe fn record(
        &self,
        ctx: &Context,
        cb: vk::CommandBuffer,
        grid: &VoxelGrid,
        material: &MaterialVolume,
        profiler: Option<&mut GpuProfiler>,
    ) -> Result<(), Error> {
        let (Some(volume_set), Some(vertex_set)) = (self.volume_set, self.vertex_set) else {
            return Err(super::bad_param(
                "voxel exit",
                "record before bind_mesh and bind_material",
            )
            .into());
        };
        let dims = grid.dims.push();
        let mut profiler = profiler;
        // SAFETY: the caller's contract; the sets' resources live in `self`, `grid`, the bound
        // mesh and material.
        unsafe {
            ctx.begin_label(cb, PASS_EXIT);
            if let Some(p) = profiler.as_deref_mut() {
                p.begin_scope(cb, PASS_EXIT);
            }
            self.volume.dispatch(
                ctx,
                cb,
                volume_set,
                &ExitPush {
                    dims,
                    material_lo: material.lo.extend(0.0).to_array(),
                    material_hi: material.hi.extend(0.0).to_array(),
                    model: match self.model {
                        VoxelModel::Paper => 0,
                        VoxelModel::Diffusion => 1,
                    },
                    eta: self.eta,
                    pad: [0; 2],
                },
                [dims[0], dims[1], dims[2]],
            );
            // why: the vertices sample the radiance volume just written (RAW), as a sampled image.
            barrier::record(
                ctx,
                cb,
                &[],
                &[image_barrier(
                    &grid.exit,
                    Access::ComputeWrite,
                    Access::ComputeSampled,
                )],
            );
            self.vertex.dispatch(
                ctx,
                cb,
                vertex_set,
                &VertexExitPush {
                    count: self.vertex_count,
                    stride: VERTEX_FLOATS,
                    mesh_offset: EXITANCE_OFFSET,
                    write_mesh: u32::from(self.write_mesh),
                    eta: self.eta,
                    pad: [0.0; 3],
                },
                [self.vertex_count, 1, 1],
            );
            if let Some(p) = profiler {
                p.end_scope(cb);
            }
            ctx.end_label(cb);
        }
        Ok(())
    }

    /// Headless, after the frame's submission completed: (M rgb, covered) per vertex.
    pub fn read_exitance(&self, ctx: &Context) -> Result<Vec<[f32; 4]>, Error> {
        host_sync(ctx)?;
        let bytes = self.exitance.read_bytes()?;
        Ok(bytes
            .chunks_exact(16)
            .take(self.vertex_count as usize)
            .map(bytemuck::pod_read_unaligned::<[f32; 4]>)
            .collect())
    }
}
