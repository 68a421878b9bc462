//! The triangle mesh the voxel passes read on the GPU: vertex positions (and normals, for the
//! reflective shadow maps) in the display mesh's [`Vertex`] layout, and a u32 index buffer that a
//! compute shader can read.
//!
//! The display mesh's own [`crate::mesh::GpuMesh`] vertex buffer is readable by compute (a
//! deformation or a GPU solve writes it in place); its index buffer is not (INDEX_BUFFER usage
//! only, and private), so [`MeshIndices`] uploads the same triangles once more. A topology change
//! (a fracture, a re-mesh) is a new [`MeshIndices`] and a new vertex buffer, bound again with
//! `bind_mesh`; nothing is baked.

use ash::vk;
use glam::DVec3;

use super::bad_param;
use crate::mesh::TriMesh;
use crate::mesh::Vertex;
use crate::vk::{Buffer, Context};
use crate::Error;

/// Floats per [`Vertex`]; the position is the first three, the normal the next three.
pub const VERTEX_FLOATS: u32 = (std::mem::size_of::<Vertex>() / 4) as u32;
/// Float offset of [`Vertex::exitance`].
pub const EXITANCE_OFFSET: u32 = (std::mem::offset_of!(Vertex, exitance) / 4) as u32;

/// A mesh on the GPU as the voxel passes read it (borrowed: the caller owns the buffers).
#[derive(Clone, Copy)]
pub struct SurfaceMesh<'a> {
    /// [`Vertex`] records; STORAGE_BUFFER usage (compute reads positions, the exit pass may write
    /// the exitance field) and VERTEX_BUFFER (the shadow maps draw it).
    pub vertices: &'a Buffer,
    pub vertex_count: u32,
    /// Three u32 per triangle; STORAGE_BUFFER and INDEX_BUFFER usage.
    pub indices: &'a Buffer,
    pub triangle_count: u32,
}

impl std::fmt::Debug for SurfaceMesh<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "SurfaceMesh({} vertices, {} triangles)",
            self.vertex_count, self.triangle_count
        )
    }
}

impl SurfaceMesh<'_> {
    /// Identity of the bound buffers and counts: a pass re-allocates its descriptor sets only
    /// when this changes.
    pub fn key(&self) -> (u64, u64, u32, u32) {
        use ash::vk::Handle;
        (
            self.vertices.raw.as_raw(),
            self.indices.raw.as_raw(),
            self.vertex_count,
            self.triangle_count,
        )
    }

    /// Checks the buffers hold the counts.
    pub fn validate(&self) -> Result<(), Error> {
        if self.vertex_count == 0 || self.triangle_count == 0 {
            return Err(bad_param("mesh", "no vertices or no triangles").into());
        }
        let need_v = u64::from(self.vertex_count) * std::mem::size_of::<Vertex>() as u64;
        let need_i = u64::from(self.triangle_count) * 12;
        if self.vertices.size < need_v || self.indices.size < need_i {
            return Err(bad_param(
                "mesh",
                format!(
                    "{} vertices and {} triangles need {need_v} and {need_i} bytes; the buffers have {} and {}",
                    self.vertex_count, self.triangle_count, self.vertices.size, self.indices.size
                ),
            )
            .into());
        }
        Ok(())
    }

    /// The raw handles a recording pass keeps (no borrow: the caller keeps the buffers alive).
    pub fn handles(&self) -> MeshHandles {
        MeshHandles {
            vertices: self.vertices.raw,
            indices: self.indices.raw,
            vertex_count: self.vertex_count,
            triangle_count: self.triangle_count,
        }
    }
}

/// A bound mesh's buffers as raw handles, kept by the passes between `bind_mesh` and `record`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MeshHandles {
    pub vertices: vk::Buffer,
    pub indices: vk::Buffer,
    pub vertex_count: u32,
    pub triangle_count: u32,
}

impl MeshHandles {
    /// Binds the buffers and draws every triangle.
    ///
    /// # Safety
    /// `cb` must be recording inside a rendering scope with a pipeline bound whose vertex layout
    /// is [`Vertex`]; the buffers must be alive and outlive its execution.
    pub unsafe fn draw(&self, ctx: &Context, cb: vk::CommandBuffer) {
        // SAFETY: the caller's contract.
        unsafe {
            ctx.raw()
                .cmd_bind_vertex_buffers(cb, 0, &[self.vertices], &[0]);
            ctx.raw()
                .cmd_bind_index_buffer(cb, self.indices, 0, vk::IndexType::UINT32);
            ctx.raw()
                .cmd_draw_indexed(cb, 3 * self.triangle_count, 1, 0, 0, 0);
        }
    }
}

/// A mesh's triangles in a buffer compute shaders read (and draws index).
pub struct MeshIndices {
    pub buffer: Buffer,
    pub triangle_count: u32,
    pub vertex_count: u32,
}

impl MeshIndices {
    /// Uploads `mesh`'s triangles; an index past the vertices is a typed error.
    pub fn new(ctx: &Context, mesh: &TriMesh) -> Result<MeshIndices, Error> {
        let n = mesh.positions.len();
        if mesh.indices.is_empty() || n == 0 {
            return Err(bad_param("mesh", "no vertices or no triangles").into());
        }
        if let Some(t) = mesh
            .indices
            .iter()
            .position(|t| t.iter().any(|&i| i as usize >= n))
        {
            return Err(bad_param(
                "mesh",
                format!("triangle {t} indexes past the {n} vertices"),
            )
            .into());
        }
        let flat: Vec<u32> = mesh.indices.iter().flatten().copied().collect();
        Ok(MeshIndices {
            buffer: Buffer::with_data(
                ctx,
                "voxel mesh indices",
                vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::INDEX_BUFFER,
                &flat,
            )?,
            triangle_count: mesh.indices.len() as u32,
            vertex_count: n as u32,
        })
    }
}

/// A mesh whose vertices the CPU rewrites between frames (host-visible): a deformation computed
/// on the CPU, or tests. The display mesh of a host is a [`crate::mesh::GpuMesh`] instead.
pub struct VoxelMesh {
    pub vertices: Buffer,
    pub indices: MeshIndices,
}

impl VoxelMesh {
    pub fn new(ctx: &Context, mesh: &TriMesh) -> Result<VoxelMesh, Error> {
        let indices = MeshIndices::new(ctx, mesh)?;
        let vertices = vertex_records(mesh)?;
        Ok(VoxelMesh {
            vertices: Buffer::with_data(
                ctx,
                "voxel mesh vertices",
                vk::BufferUsageFlags::VERTEX_BUFFER | vk::BufferUsageFlags::STORAGE_BUFFER,
                &vertices,
            )?,
            indices,
        })
    }

    /// Rewrites positions and normals (same vertex count). The caller makes sure no frame that
    /// reads the buffer is still running (headless: after the wait).
    pub fn set_positions(&mut self, positions: &[DVec3], normals: &[DVec3]) -> Result<(), Error> {
        let n = self.indices.vertex_count as usize;
        if positions.len() != n || normals.len() != n {
            return Err(bad_param(
                "mesh",
                format!(
                    "{} positions and {} normals for {n} vertices",
                    positions.len(),
                    normals.len()
                ),
            )
            .into());
        }
        let mesh = TriMesh {
            positions: positions.to_vec(),
            normals: normals.to_vec(),
            indices: Vec::new(),
        };
        let vertices = vertex_records(&mesh)?;
        self.vertices
            .write_bytes(0, bytemuck::cast_slice(&vertices))?;
        Ok(())
    }

    pub fn surface(&self) -> SurfaceMesh<'_> {
        SurfaceMesh {
            vertices: &self.vertices,
            vertex_count: self.indices.vertex_count,
            indices: &self.indices.buffer,
            triangle_count: self.indices.triangle_count,
        }
    }
}

fn vertex_records(mesh: &TriMesh) -> Result<Vec<Vertex>, Error> {
    if mesh.normals.len() != mesh.positions.len() {
        return Err(bad_param(
            "mesh",
            format!(
                "{} positions, {} normals",
                mesh.positions.len(),
                mesh.normals.len()
            ),
        )
        .into());
    }
    mesh.positions
        .iter()
        .zip(&mesh.normals)
        .enumerate()
        .map(|(i, (p, n))| {
            let v = Vertex {
                position: p.as_vec3().to_array(),
                normal: n.as_vec3().to_array(),
                exitance: [0.0; 3],
            };
            if v.position.iter().chain(&v.normal).all(|x| x.is_finite()) {
                Ok(v)
            } else {
                Err(bad_param("mesh", format!("vertex {i} is not finite in f32")).into())
            }
        })
        .collect()
}
