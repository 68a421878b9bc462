//! The bounced light as a source of the solve (`render --bounce source`, [`BounceMode::Source`]):
//! the bounce pass ([`super`]) gathers, per display vertex, the irradiance E_b that light leaving
//! the surface elsewhere brings to it; the local model re-emits it where it entered (R) or through
//! the wall (T), so it never travels inside: the base's front face under a back-lit plate stays
//! dark where the reference shows the light that entered the base's top 1-5 mm away.
//!
//! With this source, E_b at each finest surface node ([`NodeGather`]: the inverse-distance average
//! of its nearest display vertices that face its way) enters the node's q as the environment's
//! diffuse light does (gather_q.comp): q += q_scale T_d E_b, T_d the boundary's diffuse
//! transmittance ([`crate::solver::transport::Boundary::diffuse_transmittance`]); a second solve,
//! warm-started from the first, carries it inside, and the exitance pass writes its J+ to the
//! display mesh only (the solver's own per-vertex J+ keeps the first solve's, so the shading draws
//! what the source added with the bounce's Lambertian lobe, as it draws the local re-emission:
//! [`crate::scene::ExitLobe::with_bounce`]; the direct light keeps its own lobe and share). That
//! J+ replaces the local re-emission (nothing is counted twice): the bounce
//! iterations still run with R and T to get the interreflected E_b (X = X_0 + (R + T P) F X), and
//! the last gather's E_b = F X is what the solve takes. On a thick flat part with a uniform E_b the
//! solve re-emits R_d E_b, what the local model gave ([`super::diffuse_reflectance`] is the same
//! Robin row and exit query); a convex object has no links, E_b = 0 and q is unchanged.
//!
//! The f64 reference of the source is [`NodeGather::node_sources`] of
//! [`BounceLinks::last_irradiance`]: the same average, the same gain.
//!
//! [`BounceMode::Source`]: super::BounceMode::Source

use ash::vk;
use glam::DVec3;
use kiddo::immutable::float::kdtree::ImmutableKdTree;
use kiddo::SquaredEuclidean;
use rayon::prelude::*;

use super::invalid;
use crate::quadgraph::BounceLinks;
use crate::shader::{ComputePipeline, ComputePipelineDesc, DescriptorWrite};
use crate::vk::barrier::Use;
use crate::vk::{Access, Buffer, Context, Image};
use crate::{Error, QuadGraph};

/// The pass's name: q += q_scale T_d E_b at the finest surface nodes.
pub const PASS_BOUNCE_SOURCE: &str = "bounce source";
/// The second solve's pass, and its exitance's.
pub const PASS_BOUNCE_SOLVE: &str = "bounce solve";
pub const PASS_BOUNCE_EXITANCE: &str = "bounce exitance";
/// The first solve's finest x kept before the second solve, and put back before the next
/// frame's first solve (which continues it, not the second's sum).
pub const PASS_BOUNCE_KEEP: &str = "bounce keep";
pub const PASS_BOUNCE_RESTORE: &str = "bounce restore";

/// Display vertices examined per surface node.
const CANDIDATES: usize = 8;
/// Vertices a node averages.
const TAKEN: usize = 4;
/// A vertex faces the node's way when their normals' cosine is above this (a crease vertex's
/// averaged normal is 0.71 from either face).
const FACING: f64 = 0.5;

/// Per finest surface node, the display vertices whose E_b it takes and their weights (summing to
/// 1; none where no vertex nearby faces the node's way).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NodeGather {
    /// Entries of surface node s: `entries[offsets[s]..offsets[s + 1]]`.
    pub offsets: Vec<u32>,
    pub entries: Vec<(u32, f32)>,
}

impl NodeGather {
    /// The gather of `graph`'s finest surface nodes from its display surface: among the
    /// [`CANDIDATES`] nearest display vertices, the [`TAKEN`] nearest whose normal is within
    /// 60 degrees of the node's, weighted by 1 / (d^2 + (spacing / 10)^2).
    pub fn build(graph: &QuadGraph) -> NodeGather {
        let level = graph.finest();
        let inner = level.inner_count();
        let surface = &graph.surface;
        let coords: Vec<[f64; 3]> = surface.positions.iter().map(|p| p.to_array()).collect();
        if coords.is_empty() {
            return NodeGather {
                offsets: vec![0; level.positions.len() - inner + 1],
                entries: Vec::new(),
            };
        }
        let tree: ImmutableKdTree<f64, u32, 3, 32> = ImmutableKdTree::new_from_slice(&coords);
        let soft = (0.1 * level.spacing).powi(2);
        let per_node: Vec<Vec<(u32, f32)>> = (inner..level.positions.len())
            .into_par_iter()
            .map(|node| {
                let (x, n) = (level.positions[node], level.surface_normals[node - inner]);
                let near = tree.nearest_n::<SquaredEuclidean>(
                    &x.to_array(),
                    std::num::NonZero::new(CANDIDATES).unwrap_or(std::num::NonZero::<usize>::MIN),
                );
                let taken: Vec<(u32, f64)> = near
                    .iter()
                    .filter(|c| {
                        let vn: DVec3 = surface.normals[c.item as usize];
                        vn.is_finite() && vn.normalize_or_zero().dot(n) > FACING
                    })
                    .take(TAKEN)
                    .map(|c| (c.item, 1.0 / (c.distance + soft)))
                    .collect();
                let sum: f64 = taken.iter().map(|t| t.1).sum();
                if !(sum > 0.0 && sum.is_finite()) {
                    return Vec::new();
                }
                taken
                    .into_iter()
                    .map(|(v, w)| (v, (w / sum) as f32))
                    .collect()
            })
            .collect();
        let mut offsets = Vec::with_capacity(per_node.len() + 1);
        let mut entries = Vec::new();
        offsets.push(0u32);
        for e in per_node {
            entries.extend(e);
            offsets.push(entries.len() as u32);
        }
        NodeGather { offsets, entries }
    }

    pub fn node_count(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// Surface nodes that take light (have entries).
    pub fn covered(&self) -> usize {
        self.offsets.windows(2).filter(|w| w[1] > w[0]).count()
    }

    /// The f64 reference of the pass: per finest surface node, the q it adds (exposure 1, the
    /// boundary's diffuse transmittance `t_d`) for the display vertices' E_b `irradiance`:
    /// t_d sum_k w_k max(E_b(v_k), 0).
    pub fn node_sources(&self, irradiance: &[[f64; 3]], t_d: f64) -> Vec<[f64; 3]> {
        (0..self.node_count())
            .map(|s| {
                let (a, b) = (self.offsets[s] as usize, self.offsets[s + 1] as usize);
                let mut e = [0.0f64; 3];
                for &(v, w) in &self.entries[a..b] {
                    for (c, ec) in e.iter_mut().enumerate() {
                        *ec += f64::from(w) * irradiance[v as usize][c].max(0.0);
                    }
                }
                e.map(|x| t_d * x)
            })
            .collect()
    }
}

impl BounceLinks {
    /// The irradiance the last of `bounces` gathers reads (E_b = F X_{bounces - 1}, X after
    /// `bounces - 1` re-emissions of [`Self::apply_bounces`]): what [`BounceMode::Source`] adds
    /// to the solve, as the GPU pass leaves it in its irradiance buffer.
    ///
    /// [`BounceMode::Source`]: super::BounceMode::Source
    pub fn last_irradiance(
        &self,
        exitance: &[[f32; 3]],
        optics: &super::WallOptics,
        bounces: u32,
    ) -> Vec<[f64; 3]> {
        let x = if bounces > 1 {
            self.apply_bounces(exitance, optics, bounces - 1)
        } else {
            exitance.to_vec()
        };
        (0..self.vertex_count())
            .map(|v| {
                let mut e = [0.0f64; 3];
                for &(y, w) in self.incoming(v) {
                    for (c, ec) in e.iter_mut().enumerate() {
                        *ec += f64::from(w) * f64::from(x[y as usize][c]).max(0.0);
                    }
                }
                e
            })
            .collect()
    }
}

/// Push constants of `bounce/bounce_source.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct BounceSourcePush {
    pub count: u32,
    /// The finest level's texel rows' width.
    pub width: u32,
    /// q_scale T_d.
    pub gain: f32,
    pub pad: u32,
}

/// The pass: q += q_scale T_d E_b at the finest level's surface nodes.
pub struct BounceSourcePass {
    pipeline: ComputePipeline<BounceSourcePush>,
    offsets: Buffer,
    entries: Buffer,
    texels: Buffer,
    set: vk::DescriptorSet,
    count: u32,
    width: u32,
    covered: usize,
}

impl BounceSourcePass {
    /// GPU bytes of the pass's own buffers (the gather's offsets and entries, the texels).
    pub fn bytes(&self) -> u64 {
        self.offsets.size + self.entries.size + self.texels.size
    }

    /// The pass adding the bounce pass's `irradiance` (E_b per display vertex, vec4) to `q` (the
    /// finest level's q image) through `gather`; `texels` the linear texel index of each finest
    /// surface node, `width` the image's row width.
    pub fn new(
        ctx: &Context,
        gather: &NodeGather,
        texels: &[u32],
        width: u32,
        irradiance: &Buffer,
        q: &Image,
        vertices: usize,
    ) -> Result<BounceSourcePass, Error> {
        if texels.len() != gather.node_count()
            || gather.entries.iter().any(|&(v, w)| {
                v as usize >= vertices || !w.is_finite() || !(0.0..=1.0).contains(&w)
            })
            || irradiance.size < (vertices * 16) as u64
        {
            return Err(invalid(
                "bounce",
                format!(
                    "the source's gather of {} nodes ({} texels) from {vertices} vertices is \
                     out of range",
                    gather.node_count(),
                    texels.len()
                ),
            ));
        }
        let pipeline = ComputePipeline::new(
            ctx,
            &ComputePipelineDesc {
                name: "bounce source",
                shader: "bounce/bounce_source.comp",
                bindings: &["irradiance", "offsets", "entries", "texels", "q"],
                max_sets: 1,
            },
        )?;
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let offsets = Buffer::with_data(ctx, "bounce source offsets", storage, &gather.offsets)?;
        let mut packed: Vec<[u32; 2]> = gather
            .entries
            .iter()
            .map(|&(v, w)| [v, w.to_bits()])
            .collect();
        if packed.is_empty() {
            packed.push([0, 0]);
        }
        let entries = Buffer::with_data(ctx, "bounce source entries", storage, &packed)?;
        let texel_data = if texels.is_empty() {
            vec![0u32]
        } else {
            texels.to_vec()
        };
        let texels_buffer = Buffer::with_data(ctx, "bounce source texels", storage, &texel_data)?;
        let set = pipeline.allocate_set(
            ctx,
            &[
                DescriptorWrite::StorageBuffer {
                    name: "irradiance",
                    buffer: irradiance,
                },
                DescriptorWrite::StorageBuffer {
                    name: "offsets",
                    buffer: &offsets,
                },
                DescriptorWrite::StorageBuffer {
                    name: "entries",
                    buffer: &entries,
                },
                DescriptorWrite::StorageBuffer {
                    name: "texels",
                    buffer: &texels_buffer,
                },
                DescriptorWrite::storage_image("q", q),
            ],
        )?;
        Ok(BounceSourcePass {
            pipeline,
            offsets,
            entries,
            texels: texels_buffer,
            set,
            count: gather.node_count() as u32,
            width,
            covered: gather.covered(),
        })
    }

    /// Surface nodes that take light.
    pub fn covered(&self) -> usize {
        self.covered
    }

    /// What [`Self::record`] uses, with the bounce pass's `irradiance` and the finest `q`.
    pub fn uses<'a>(&'a self, irradiance: &'a Buffer, q: &'a Image) -> Vec<Use<'a>> {
        vec![
            Use::buffer(irradiance, Access::ComputeRead),
            Use::buffer(&self.offsets, Access::ComputeRead),
            Use::buffer(&self.entries, Access::ComputeRead),
            Use::buffer(&self.texels, Access::ComputeRead),
            Use::image(q, Access::ComputeReadWrite),
        ]
    }

    /// Records q += `gain` E_b (`gain` = q_scale T_d).
    ///
    /// # Safety
    /// `cb` must be recording outside a rendering scope, inside a frame-graph pass declaring
    /// [`Self::uses`] of the buffers given to [`Self::new`]; `self` must outlive its execution.
    pub unsafe fn record(&self, ctx: &Context, cb: vk::CommandBuffer, gain: f32) {
        let push = BounceSourcePush {
            count: self.count,
            width: self.width,
            gain,
            pad: 0,
        };
        // SAFETY: the caller's contract; the set's resources live in `self` and the caller's.
        unsafe {
            self.pipeline
                .dispatch(ctx, cb, self.set, &push, [self.count.max(1), 1, 1]);
        }
    }
}
