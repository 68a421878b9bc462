//! [`GpuMesh`]: a triangle mesh on the GPU as every pass reads it: interleaved [`Vertex`]es
//! (position, normal, per-vertex exitance) and 32-bit indices. The shadow pass draws it, the
//! shading pass draws and shades it, a method writes its exitance field in place and a
//! deformation rewrites its positions and normals.
//!
//! ```no_run
//! # fn f(ctx: &translucent::vk::Context) -> Result<(), translucent::vk::VkError> {
//! use translucent::mesh::{shapes::Shape, GpuMesh};
//! let sphere = Shape::Sphere { radius: 10.0 }.triangulate(32);
//! let mesh = GpuMesh::new(ctx, &sphere, &vec![[0.0; 3]; sphere.positions.len()])?;
//! assert_eq!(mesh.vertex_count(), sphere.positions.len());
//! # Ok(()) }
//! ```

use ash::vk;

use super::TriMesh;
use crate::vk::{Buffer, Context, VkError};

/// One vertex as the shaders read it (f32; the mesh is f64 on the CPU).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Vertex {
    pub position: [f32; 3],
    pub normal: [f32; 3],
    /// Outgoing partial current J+ (linear RGB).
    pub exitance: [f32; 3],
}

/// A mesh on the GPU: interleaved vertices and 32-bit indices (host-visible memory).
pub struct GpuMesh {
    vertices: Buffer,
    indices: Buffer,
    index_count: u32,
}

impl GpuMesh {
    /// Uploads `mesh` with one exitance per vertex; rejects mismatched lengths, out-of-range
    /// indices and non-finite values.
    pub fn new(ctx: &Context, mesh: &TriMesh, exitance: &[[f32; 3]]) -> Result<GpuMesh, VkError> {
        let invalid = |problem: String| VkError::invalid("mesh", problem);
        let n = mesh.positions.len();
        if n == 0 || mesh.indices.is_empty() {
            return Err(invalid("no vertices or no triangles".into()));
        }
        if mesh.normals.len() != n || exitance.len() != n {
            return Err(invalid(format!(
                "{n} positions, {} normals, {} exitance values",
                mesh.normals.len(),
                exitance.len()
            )));
        }
        if let Some(t) = mesh
            .indices
            .iter()
            .position(|t| t.iter().any(|&i| i as usize >= n))
        {
            return Err(invalid(format!(
                "triangle {t} indexes past the {n} vertices"
            )));
        }
        let mut vertices = Vec::with_capacity(n);
        for (i, ((p, nrm), e)) in mesh
            .positions
            .iter()
            .zip(&mesh.normals)
            .zip(exitance)
            .enumerate()
        {
            let v = Vertex {
                position: p.as_vec3().to_array(),
                normal: nrm.as_vec3().to_array(),
                exitance: *e,
            };
            if v.position
                .iter()
                .chain(&v.normal)
                .chain(&v.exitance)
                .any(|x| !x.is_finite())
            {
                return Err(invalid(format!("vertex {i} is not finite in f32")));
            }
            vertices.push(v);
        }
        let indices: Vec<u32> = mesh.indices.iter().flatten().copied().collect();
        Ok(GpuMesh {
            vertices: Buffer::with_data(
                ctx,
                "mesh vertices",
                // STORAGE: the GPU diffusion solve writes the exitance field in place
                // (the methods' per-vertex exitance passes), so the solved J+ never visits the CPU.
                // TRANSFER_DST: a deformation copies new positions and normals in
                // (deformation edits).
                vk::BufferUsageFlags::VERTEX_BUFFER
                    | vk::BufferUsageFlags::STORAGE_BUFFER
                    | vk::BufferUsageFlags::TRANSFER_DST,
                &vertices,
            )?,
            index_count: indices.len() as u32,
            indices: Buffer::with_data(
                ctx,
                "mesh indices",
                vk::BufferUsageFlags::INDEX_BUFFER,
                &indices,
            )?,
        })
    }

    /// The interleaved [`Vertex`] buffer (for passes that write the exitance on the GPU).
    pub fn vertex_buffer(&self) -> &Buffer {
        &self.vertices
    }

    /// Vertices in [`Self::vertex_buffer`].
    pub fn vertex_count(&self) -> usize {
        (self.vertices.size / std::mem::size_of::<Vertex>() as u64) as usize
    }

    /// Binds the buffers and draws every triangle.
    ///
    /// # Safety
    /// `cb` must be recording inside a rendering scope with a pipeline bound whose vertex layout
    /// is [`Vertex`]; the mesh must outlive `cb`'s execution.
    pub unsafe fn draw(&self, ctx: &Context, cb: vk::CommandBuffer) {
        // SAFETY: the caller's contract.
        unsafe {
            ctx.raw()
                .cmd_bind_vertex_buffers(cb, 0, &[self.vertices.raw], &[0]);
            ctx.raw()
                .cmd_bind_index_buffer(cb, self.indices.raw, 0, vk::IndexType::UINT32);
            ctx.raw().cmd_draw_indexed(cb, self.index_count, 1, 0, 0, 0);
        }
    }
}
