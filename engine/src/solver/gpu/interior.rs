//! The interior surface reconstruction's GPU data (DESIGN 2.6, [`super::GpuSolveParams::surface`]):
//! per display vertex the baked sample's inner nodes, weights, cell and depth in the finest
//! level's texel layout, and the descriptor sets of the `diffusion/vertex_interior*` pass.

use ash::vk;

use super::{bytes_of, image, upload_images, GpuDiffusion, GpuLevel};
use crate::quadgraph::graph::{Packing, QuadGraph, NO_NODE};
use crate::shader::DescriptorWrite;
use crate::solver::transport::SurfaceReconstruction;
use crate::solver::SolverError;
use crate::vk::{Buffer, Context, Image};
use crate::Error;

/// Per display vertex, where the interior reconstruction reads phi (see
/// [`super::GpuSolveParams::surface`]), and its descriptor sets: index `2 * mesh + heterogeneous`
/// (our own J+ buffer or the bound mesh's vertex buffer; push-constant or per-node material).
pub(crate) struct InteriorSamples {
    pub(super) sources: Buffer,
    pub(super) source_weights: Buffer,
    pub(super) nodes: Buffer,
    pub(super) weights: Buffer,
    pub(super) cells: Buffer,
    /// The lateral stencils (vertex ids, weights), 4 x 4 per vertex; zeros without one.
    pub(super) lateral_nodes: Buffer,
    pub(super) lateral_weights: Buffer,
    /// Per vertex its sample's phi (vec4), between the pass's two stages.
    pub(super) sample_phi: Buffer,
    /// The gather at the display vertices themselves (their own visibility, [`VertexGather`]).
    pub(super) vertex_gather: VertexGather,
    pub(super) sets: [Option<vk::DescriptorSet>; 4],
}

/// Texels per row of the [`VertexGather`] images: vertex `v` at `(v % width, v / width)`
/// (`VERTEX_GATHER_WIDTH` in `vertex_interior.glsl`).
pub(crate) const VERTEX_GATHER_WIDTH: u32 = 256;

/// The display vertices laid out as one more gather level (`irradiance/gather_q.comp`): their
/// positions, normals (w: the sample's mean curvature) and no anisotropy in, q and the collimated
/// part out (the particular image's alpha: the vertex's own light visibility where its part is
/// the lit beam's). The interior pass reads the particular image
/// ([`super::GpuSolveParams::particular_visibility`]).
pub(crate) struct VertexGather {
    pub position: Image,
    pub normal: Image,
    pub anisotropy: Image,
    pub q: Image,
    pub particular: Image,
    pub rows: u32,
}

impl VertexGather {
    fn new(ctx: &Context, graph: &QuadGraph) -> Result<Self, Error> {
        let surface = &graph.surface;
        let vertices = surface.positions.len();
        let rows = (vertices as u32).div_ceil(VERTEX_GATHER_WIDTH).max(1);
        let texels = (VERTEX_GATHER_WIDTH * rows) as usize;
        let packing = Packing {
            width: VERTEX_GATHER_WIDTH,
            height: rows,
            ..Packing::default()
        };
        let f16 = half::f16::from_f64;
        let mut position = vec![[0f32; 4]; texels];
        let mut normal = vec![[f16(0.0); 4]; texels];
        for v in 0..vertices {
            let (p, n) = (surface.positions[v], surface.normals[v]);
            let h = graph.samples.curvature.get(v).copied().unwrap_or(0.0);
            if !(p.is_finite() && n.is_finite() && h.is_finite()) {
                return Err(Error::from(SolverError::BadGraph {
                    level: graph.levels.len() - 1,
                    problem: format!(
                        "display vertex {v}: position, normal or curvature not finite"
                    ),
                }));
            }
            position[v] = [p.x as f32, p.y as f32, p.z as f32, 1.0];
            normal[v] = [f16(n.x), f16(n.y), f16(n.z), f16(h)];
        }
        use vk::Format as F;
        let gather = VertexGather {
            position: image(
                ctx,
                "vertex gather position",
                &packing,
                F::R32G32B32A32_SFLOAT,
            )?,
            normal: image(
                ctx,
                "vertex gather normal",
                &packing,
                F::R16G16B16A16_SFLOAT,
            )?,
            anisotropy: image(
                ctx,
                "vertex gather anisotropy",
                &packing,
                F::R16G16B16A16_SFLOAT,
            )?,
            q: image(ctx, "vertex gather q", &packing, F::R16G16B16A16_SFLOAT)?,
            particular: image(
                ctx,
                "vertex gather particular",
                &packing,
                F::R16G16B16A16_SFLOAT,
            )?,
            rows,
        };
        let zeros = vec![0u8; texels * 8];
        upload_images(
            ctx,
            "vertex gather upload",
            &[
                (&gather.position, bytes_of(&position)),
                (&gather.normal, bytes_of(&normal)),
                (&gather.anisotropy, zeros.clone()),
                (&gather.q, zeros.clone()),
                (&gather.particular, zeros),
            ],
        )?;
        Ok(gather)
    }
}

impl GpuDiffusion {
    /// The interior samples of `graph`'s display vertices in the finest level's texel layout;
    /// `None` when the graph has none (built by hand, not baked).
    pub(super) fn interior_samples(
        ctx: &Context,
        graph: &QuadGraph,
        finest: &GpuLevel,
    ) -> Result<Option<InteriorSamples>, Error> {
        let samples = &graph.samples;
        let vertices = graph.surface.positions.len();
        if vertices == 0 || samples.depth.len() != vertices || samples.sources.len() != vertices {
            return Ok(None);
        }
        let bad = |v: usize, what: &str| {
            Error::from(SolverError::BadGraph {
                level: graph.levels.len() - 1,
                problem: format!("vertex {v}'s interior sample: {what}"),
            })
        };
        let mut nodes: Vec<[u32; 4]> = Vec::with_capacity(4 * vertices);
        let mut weights: Vec<[f32; 4]> = Vec::with_capacity(4 * vertices);
        let mut cells: Vec<[u32; 4]> = Vec::with_capacity(vertices);
        let mut sources: Vec<[u32; 4]> = Vec::with_capacity(4 * vertices);
        let mut source_weights: Vec<[f32; 4]> = Vec::with_capacity(4 * vertices);
        let surface = graph.finest().surface_count();
        let mut lateral_nodes: Vec<[u32; 4]> = vec![[0; 4]; 4 * vertices];
        let mut lateral_weights: Vec<[f32; 4]> = vec![[0.0; 4]; 4 * vertices];
        for v in 0..vertices {
            let (Some(ids), Some(w)) = (samples.lateral.get(v), samples.lateral_weights.get(v))
            else {
                break;
            };
            for (slot, (&u, &wk)) in ids.iter().zip(w).enumerate() {
                if u == NO_NODE {
                    continue;
                }
                if u as usize >= vertices || !wk.is_finite() {
                    return Err(bad(
                        v,
                        "a lateral stencil vertex out of range or a weight not finite",
                    ));
                }
                lateral_nodes[4 * v + slot / 4][slot % 4] = u;
                lateral_weights[4 * v + slot / 4][slot % 4] = wk as f32;
            }
        }
        for v in 0..vertices {
            let (ids, w) = (&samples.sources[v], &samples.source_weights[v]);
            for g in 0..4 {
                let mut n = [0u32; 4];
                let mut wt = [0f32; 4];
                for k in 0..4 {
                    let (s, wk) = (ids[4 * g + k], w[4 * g + k]);
                    if s == NO_NODE {
                        continue;
                    }
                    if s as usize >= surface || !wk.is_finite() {
                        return Err(bad(v, "a source node out of range or a weight not finite"));
                    }
                    n[k] = finest
                        .packing
                        .linear_index((finest.inner_count + s as usize) as u32);
                    wt[k] = wk as f32;
                }
                sources.push(n);
                source_weights.push(wt);
            }
            let (ids, w) = (&samples.nodes[v], &samples.weights[v]);
            for g in 0..4 {
                let mut n = [0u32; 4];
                let mut wt = [0f32; 4];
                for k in 0..4 {
                    let (id, wk) = (ids[4 * g + k], w[4 * g + k]);
                    if id == NO_NODE {
                        continue;
                    }
                    if id as usize >= finest.inner_count || !wk.is_finite() {
                        return Err(bad(v, "an inner node out of range or a weight not finite"));
                    }
                    n[k] = finest.packing.linear_index(id);
                    wt[k] = wk as f32;
                }
                nodes.push(n);
                weights.push(wt);
            }
            let cell = samples.cell[v];
            let depth = samples.depth[v];
            let curvature = samples.curvature.get(v).copied().unwrap_or(0.0);
            if cell as usize >= finest.inner_count
                || !(depth.is_finite() && depth >= 0.0)
                || !curvature.is_finite()
            {
                return Err(bad(
                    v,
                    "its cell out of range or its depth or curvature not finite",
                ));
            }
            // The sample nodes' second moments (mm^2, well inside half precision's range),
            // two halves in one word as GLSL's unpackHalf2x16 reads them.
            let [m_nn, m_tt] = samples.spread.get(v).copied().unwrap_or_default();
            if !(m_nn.is_finite() && m_tt.is_finite()) {
                return Err(bad(v, "its sample spread not finite"));
            }
            let half = |x: f64| u32::from(half::f16::from_f64(x).to_bits());
            cells.push([
                finest.packing.linear_index(cell),
                (depth as f32).to_bits(),
                (curvature as f32).to_bits(),
                half(m_nn) | (half(m_tt) << 16),
            ]);
        }
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        Ok(Some(InteriorSamples {
            sources: Buffer::with_data(ctx, "diffusion source nodes", storage, &sources)?,
            source_weights: Buffer::with_data(
                ctx,
                "diffusion source weights",
                storage,
                &source_weights,
            )?,
            nodes: Buffer::with_data(ctx, "diffusion sample nodes", storage, &nodes)?,
            weights: Buffer::with_data(ctx, "diffusion sample weights", storage, &weights)?,
            cells: Buffer::with_data(ctx, "diffusion sample cells", storage, &cells)?,
            lateral_nodes: Buffer::with_data(
                ctx,
                "diffusion lateral stencil",
                storage,
                &lateral_nodes,
            )?,
            lateral_weights: Buffer::with_data(
                ctx,
                "diffusion lateral weights",
                storage,
                &lateral_weights,
            )?,
            sample_phi: Buffer::with_data(
                ctx,
                "diffusion sample phi",
                storage,
                &vec![[0f32; 4]; vertices],
            )?,
            vertex_gather: VertexGather::new(ctx, graph)?,
            sets: [None; 4],
        }))
    }

    /// Allocates the interior pass's descriptor sets that the current state needs (our buffer
    /// and the bound mesh's; push-constant material always, per-node material once its
    /// textures exist). Called after every material change and mesh binding.
    pub(crate) fn ensure_interior_sets(&mut self, ctx: &Context) -> Result<(), Error> {
        let Some(interior) = &mut self.interior else {
            return Ok(());
        };
        let finest = &self.levels[self.levels.len() - 1];
        for slot in 0..4 {
            let (mesh, heterogeneous) = (slot / 2 == 1, slot % 2 == 1);
            if interior.sets[slot].is_some() {
                continue;
            }
            let out = match (&self.mesh, mesh) {
                (_, false) => &self.vertex_j_plus,
                (Some((m, _)), true) => m.vertex_buffer(),
                (None, true) => continue,
            };
            let (kappa, mu) = match (&finest.material, heterogeneous) {
                (_, false) => (&self.poison, &self.poison),
                (Some([k, m]), true) => (k, m),
                (None, true) => continue,
            };
            interior.sets[slot] = Some(self.pipelines.interior.allocate_set(
                ctx,
                &[
                    DescriptorWrite::storage_image("phi", finest.result()),
                    DescriptorWrite::storage_image("q", &finest.q),
                    DescriptorWrite::storage_image("particular", &finest.particular),
                    DescriptorWrite::storage_image("kappa", kappa),
                    DescriptorWrite::storage_image("mu", mu),
                    DescriptorWrite::StorageBuffer {
                        name: "source_nodes",
                        buffer: &interior.sources,
                    },
                    DescriptorWrite::StorageBuffer {
                        name: "source_weights",
                        buffer: &interior.source_weights,
                    },
                    DescriptorWrite::StorageBuffer {
                        name: "sample_nodes",
                        buffer: &interior.nodes,
                    },
                    DescriptorWrite::StorageBuffer {
                        name: "sample_weights",
                        buffer: &interior.weights,
                    },
                    DescriptorWrite::StorageBuffer {
                        name: "sample_cells",
                        buffer: &interior.cells,
                    },
                    DescriptorWrite::StorageBuffer {
                        name: "vertex_j_plus",
                        buffer: out,
                    },
                    DescriptorWrite::StorageBuffer {
                        name: "sample_phi",
                        buffer: &interior.sample_phi,
                    },
                    DescriptorWrite::StorageBuffer {
                        name: "lateral_nodes",
                        buffer: &interior.lateral_nodes,
                    },
                    DescriptorWrite::StorageBuffer {
                        name: "lateral_weights",
                        buffer: &interior.lateral_weights,
                    },
                    DescriptorWrite::storage_image(
                        "vertex_particular",
                        &interior.vertex_gather.particular,
                    ),
                ],
            )?);
        }
        Ok(())
    }

    /// The display vertices' gather level ([`VertexGather`]), where the interior pass reads it
    /// ([`super::GpuSolveParams::own_visibility`] with a beam source; `None` otherwise: the
    /// frame then neither gathers nor declares it).
    pub(crate) fn vertex_gather(&self) -> Option<&VertexGather> {
        let wanted = self.params.collimated && self.params.own_visibility;
        self.interior
            .as_ref()
            .filter(|_| wanted)
            .map(|i| &i.vertex_gather)
    }

    /// How the display vertices get their exitance in this solve: `Interior` or `Shepard`
    /// (asked for, or a graph without interior samples).
    pub fn surface_reconstruction(&self) -> SurfaceReconstruction {
        if self.interior.is_some() {
            SurfaceReconstruction::Interior
        } else {
            SurfaceReconstruction::Shepard
        }
    }
}
