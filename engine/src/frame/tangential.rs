//! [`TangentialPass`]: the smooth surface gradient of the exitance per display vertex for the
//! diffusion's tangential flux toward the view (`render --tangential-flux`,
//! [`crate::solver::transport::Boundary::tangential_flux_factor`]; benches/RESULTS.md, "The
//! front-lit spheres, term by term (wave 9)" and "A smooth tangential flux (wave 9)").
//!
//! The gradient of a display vertex is the area-weighted mean of its incident triangles'
//! gradients of the linear interpolant, a sparse linear operator of the exitance
//! ([`GradientOperator::area_weighted`], built once on the host from the mesh's rest positions);
//! a compute pass applies it after the exitance is written and multiplies by f D per vertex
//! (D of the material at the vertex: heterogeneous fields get their local D). The shading
//! interpolates the three vec3 per vertex and takes grad X . v: continuous across triangles,
//! where each triangle's own gradient (screen derivatives) showed the facets.
//!
//! ```no_run
//! # use translucent::frame::tangential::GradientOperator;
//! # let mesh = translucent::mesh::shapes::Shape::Sphere { radius: 10.0 }.triangulate(16);
//! let op = GradientOperator::area_weighted(&mesh.positions, &mesh.indices);
//! // The gradient of x at vertex 0 of a sphere: the tangent part of (1, 0, 0).
//! let x: Vec<f64> = mesh.positions.iter().map(|p| p.x).collect();
//! let g = op.apply(0, &x);
//! ```

use ash::vk;
use glam::DVec3;

use crate::mesh::{GpuMesh, Vertex};
use crate::render::RenderError;
use crate::shader::{ComputePipeline, ComputePipelineDesc, DescriptorWrite};
use crate::vk::barrier::Use;
use crate::vk::{Access, Buffer, Context};
use crate::Error;

/// Profiler scope and debug label of the pass.
pub const PASS_TANGENTIAL: &str = "tangential gradient";

/// Bytes per display vertex of the gradient stream the shading reads (3 channels x vec3).
pub const GRADIENT_BYTES_PER_VERTEX: usize = 36;

/// grad X(v) = sum over `weights[offsets[v]..offsets[v + 1]]` of w X(u): per vertex v the pairs
/// (neighbour u, vec3 weight w), v itself included.
#[derive(Clone, Debug, Default)]
pub struct GradientOperator {
    pub offsets: Vec<u32>,
    pub weights: Vec<(u32, DVec3)>,
}

impl GradientOperator {
    /// The area-weighted mean of the incident triangles' gradients: a triangle of area A with
    /// unit normal n gives the barycentric gradient grad lambda_k = n x (p_{k+2} - p_{k+1}) / (2 A)
    /// (the winding cancels: both factors flip), so its share of vertex v's weight for u is
    /// n x e / 2 over v's total incident area. Degenerate triangles are skipped; a vertex with
    /// none gets no weights (gradient 0). Indices out of range are skipped.
    pub fn area_weighted(positions: &[DVec3], indices: &[[u32; 3]]) -> GradientOperator {
        let n = positions.len();
        let mut area = vec![0.0f64; n];
        let mut rows: Vec<Vec<(u32, DVec3)>> = vec![Vec::new(); n];
        for t in indices {
            if t.iter().any(|&i| i as usize >= n) {
                continue;
            }
            let p = t.map(|i| positions[i as usize]);
            let cross = (p[1] - p[0]).cross(p[2] - p[0]);
            let twice_area = cross.length();
            if twice_area <= 1e-30 || !twice_area.is_finite() {
                continue;
            }
            let normal = cross / twice_area;
            // A_T grad lambda_k = n x (p_{k+2} - p_{k+1}) / 2.
            let w: [DVec3; 3] =
                std::array::from_fn(|k| normal.cross(p[(k + 2) % 3] - p[(k + 1) % 3]) * 0.5);
            for &v in t {
                area[v as usize] += 0.5 * twice_area;
                for k in 0..3 {
                    let row = &mut rows[v as usize];
                    match row.iter_mut().find(|(u, _)| *u == t[k]) {
                        Some((_, acc)) => *acc += w[k],
                        None => row.push((t[k], w[k])),
                    }
                }
            }
        }
        let mut offsets = Vec::with_capacity(n + 1);
        let mut weights = Vec::new();
        offsets.push(0);
        for (row, a) in rows.into_iter().zip(area) {
            if a > 0.0 {
                weights.extend(row.into_iter().map(|(u, w)| (u, w / a)));
            }
            offsets.push(weights.len() as u32);
        }
        GradientOperator { offsets, weights }
    }

    pub fn vertex_count(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// grad X at vertex `v` of the per-vertex values `x` (host check of the pass).
    pub fn apply(&self, v: usize, x: &[f64]) -> DVec3 {
        let range = self.offsets[v] as usize..self.offsets[v + 1] as usize;
        self.weights[range]
            .iter()
            .map(|&(u, w)| w * x[u as usize])
            .sum()
    }
}

/// Push constants of `mesh/tangential_gradient.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct TangentialPush {
    pub count: u32,
    /// Floats per [`Vertex`] and the exitance's offset in floats.
    pub stride: u32,
    pub offset: u32,
    /// [`crate::solver::transport::Boundary::tangential_flux_factor`].
    pub factor: f32,
}

/// The pass: the operator's buffers, D per vertex, and the gradient stream the shading reads.
pub struct TangentialPass {
    pipeline: ComputePipeline<TangentialPush>,
    #[allow(dead_code, reason = "owned here: the descriptor set refers to it")]
    offsets: Buffer,
    #[allow(dead_code, reason = "owned here: the descriptor set refers to it")]
    weights: Buffer,
    diffusion: Buffer,
    gradient: Buffer,
    set: vk::DescriptorSet,
    vertex_count: u32,
    bytes: u64,
    factor: f32,
}

fn invalid(what: &str, problem: String) -> Error {
    Error::Render(RenderError::Invalid {
        what: what.into(),
        problem,
    })
}

impl TangentialPass {
    /// The pass for `mesh` (whose display vertices are `positions`, triangles `indices`), D per
    /// vertex `diffusion` (mm, rgb) and the factor f.
    pub fn new(
        ctx: &Context,
        mesh: &GpuMesh,
        positions: &[DVec3],
        indices: &[[u32; 3]],
        diffusion: &[[f32; 3]],
        factor: f32,
    ) -> Result<TangentialPass, Error> {
        let n = mesh.vertex_count();
        if positions.len() != n || diffusion.len() != n {
            return Err(invalid(
                "tangential flux",
                format!(
                    "{} positions and {} D values; the mesh has {n} vertices",
                    positions.len(),
                    diffusion.len()
                ),
            ));
        }
        let op = GradientOperator::area_weighted(positions, indices);
        let pipeline = ComputePipeline::new(
            ctx,
            &ComputePipelineDesc {
                name: "tangential gradient",
                shader: "mesh/tangential_gradient.comp",
                bindings: &["vertices", "offsets", "weights", "diffusion", "gradient"],
                max_sets: 1,
            },
        )?;
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let offsets = Buffer::with_data(ctx, "tangential offsets", storage, &op.offsets)?;
        let mut packed: Vec<[f32; 4]> = op
            .weights
            .iter()
            .map(|&(u, w)| [w.x as f32, w.y as f32, w.z as f32, f32::from_bits(u)])
            .collect();
        // A zero-length buffer is not allowed: one unused weight.
        if packed.is_empty() {
            packed.push([0.0; 4]);
        }
        let weights = Buffer::with_data(ctx, "tangential weights", storage, &packed)?;
        let diffusion = Buffer::with_data(
            ctx,
            "tangential diffusion",
            storage,
            &Self::padded(diffusion)?,
        )?;
        let gradient = Buffer::with_data(
            ctx,
            "tangential gradient",
            storage | vk::BufferUsageFlags::VERTEX_BUFFER,
            &vec![0.0f32; 9 * n.max(1)],
        )?;
        let set = pipeline.allocate_set(
            ctx,
            &[
                DescriptorWrite::StorageBuffer {
                    name: "vertices",
                    buffer: mesh.vertex_buffer(),
                },
                DescriptorWrite::StorageBuffer {
                    name: "offsets",
                    buffer: &offsets,
                },
                DescriptorWrite::StorageBuffer {
                    name: "weights",
                    buffer: &weights,
                },
                DescriptorWrite::StorageBuffer {
                    name: "diffusion",
                    buffer: &diffusion,
                },
                DescriptorWrite::StorageBuffer {
                    name: "gradient",
                    buffer: &gradient,
                },
            ],
        )?;
        let bytes = (4 * op.offsets.len()
            + 16 * packed.len()
            + 16 * n.max(1)
            + GRADIENT_BYTES_PER_VERTEX * n.max(1)) as u64;
        Ok(TangentialPass {
            pipeline,
            offsets,
            weights,
            diffusion,
            gradient,
            set,
            vertex_count: n as u32,
            bytes,
            factor,
        })
    }

    fn padded(diffusion: &[[f32; 3]]) -> Result<Vec<[f32; 4]>, Error> {
        if diffusion
            .iter()
            .flatten()
            .any(|d| !d.is_finite() || *d < 0.0)
        {
            return Err(invalid(
                "tangential flux",
                "a diffusion coefficient negative or not finite".into(),
            ));
        }
        let mut out: Vec<[f32; 4]> = diffusion.iter().map(|d| [d[0], d[1], d[2], 0.0]).collect();
        if out.is_empty() {
            out.push([0.0; 4]);
        }
        Ok(out)
    }

    /// New D per vertex and factor f (a material change). Host-visible: call between frames,
    /// after the last frame that read it completed.
    pub fn set_diffusion(&mut self, diffusion: &[[f32; 3]], factor: f32) -> Result<(), Error> {
        if diffusion.len() != self.vertex_count as usize {
            return Err(invalid(
                "tangential flux",
                format!(
                    "{} D values for {} vertices",
                    diffusion.len(),
                    self.vertex_count
                ),
            ));
        }
        let padded = Self::padded(diffusion)?;
        self.diffusion
            .write_bytes(0, bytemuck::cast_slice(&padded))?;
        self.factor = factor;
        Ok(())
    }

    /// The stream the shading reads: f D grad X per vertex, 3 x vec3 (rgb channels).
    pub fn gradient(&self) -> &Buffer {
        &self.gradient
    }

    /// GPU bytes of the pass's buffers.
    pub fn bytes(&self) -> u64 {
        self.bytes
    }

    /// What [`Self::record`] uses.
    pub fn uses<'a>(&'a self, mesh: &'a GpuMesh) -> Vec<Use<'a>> {
        vec![
            Use::buffer(mesh.vertex_buffer(), Access::ComputeRead),
            Use::buffer(&self.offsets, Access::ComputeRead),
            Use::buffer(&self.weights, Access::ComputeRead),
            Use::buffer(&self.diffusion, Access::ComputeRead),
            Use::buffer(&self.gradient, Access::ComputeWrite),
        ]
    }

    /// Records the gradient of the mesh's exitance.
    ///
    /// # Safety
    /// `cb` must be recording outside a rendering scope, inside a frame-graph pass declaring
    /// [`Self::uses`] of the mesh given to [`Self::new`]; `self` must outlive its execution.
    pub unsafe fn record(&self, ctx: &Context, cb: vk::CommandBuffer) {
        let floats = |bytes: usize| (bytes / std::mem::size_of::<f32>()) as u32;
        let push = TangentialPush {
            count: self.vertex_count,
            stride: floats(std::mem::size_of::<Vertex>()),
            offset: floats(std::mem::offset_of!(Vertex, exitance)),
            factor: self.factor,
        };
        // SAFETY: the caller's contract; the set's buffers live in `self` and the mesh.
        unsafe {
            self.pipeline
                .dispatch(ctx, cb, self.set, &push, [self.vertex_count.max(1), 1, 1]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::shapes::Shape;

    /// The area-weighted gradient of a linear field on a closed sphere's vertices against the
    /// exact tangential gradient: second order in the edge length; 24 segments on a radius of 10
    /// have edges of ~2.6: a few percent of the gradient.
    const SPHERE_GRADIENT_TOL: f64 = 0.05;

    #[test]
    fn gradient_of_a_linear_field_on_a_plane_is_exact() {
        // A 3 x 3 grid of vertices in z = 0, two triangles per cell.
        let positions: Vec<DVec3> = (0..9)
            .map(|i| DVec3::new((i % 3) as f64, (i / 3) as f64 * 1.3, 0.0))
            .collect();
        let mut indices = Vec::new();
        for y in 0..2u32 {
            for x in 0..2u32 {
                let a = y * 3 + x;
                indices.push([a, a + 1, a + 4]);
                indices.push([a, a + 4, a + 3]);
            }
        }
        let op = GradientOperator::area_weighted(&positions, &indices);
        let x: Vec<f64> = positions
            .iter()
            .map(|p| 2.0 * p.x - 3.0 * p.y + 1.0)
            .collect();
        for v in 0..9 {
            let g = op.apply(v, &x);
            assert!(
                (g - DVec3::new(2.0, -3.0, 0.0)).length() < 1e-12,
                "{v}: {g}"
            );
        }
    }

    #[test]
    fn gradient_on_a_sphere_matches_the_tangent_part() {
        let mesh = Shape::Sphere { radius: 10.0 }.triangulate(24);
        let op = GradientOperator::area_weighted(&mesh.positions, &mesh.indices);
        let a = DVec3::new(0.3, -0.5, 0.8);
        let x: Vec<f64> = mesh.positions.iter().map(|p| a.dot(*p)).collect();
        let mut worst = 0.0f64;
        for (v, p) in mesh.positions.iter().enumerate() {
            let n = p.normalize();
            let exact = a - n * a.dot(n);
            let g = op.apply(v, &x);
            let g_t = g - n * g.dot(n);
            worst = worst.max((g_t - exact).length() / a.length());
        }
        assert!(worst < SPHERE_GRADIENT_TOL, "worst relative error {worst}");
        // A faceted gradient (one incident triangle's, what the screen derivatives gave) misses
        // the same bound: the facet's tilt against the vertex's tangent plane.
        let mut faceted = 0.0f64;
        for t in &mesh.indices {
            let single = GradientOperator::area_weighted(&mesh.positions, &[*t]);
            let v = t[0] as usize;
            let n = mesh.positions[v].normalize();
            let exact = a - n * a.dot(n);
            let g = single.apply(v, &x);
            faceted = faceted.max((g - n * g.dot(n) - exact).length() / a.length());
        }
        assert!(faceted > SPHERE_GRADIENT_TOL, "faceted error {faceted}");
    }
}
