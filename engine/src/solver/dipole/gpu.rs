//! [`DipoleGatherPass`]: the dipole method's per-frame link evaluation on the GPU (render mode,
//! paper section 5.5), as one pass a frame graph places.
//!
//! Reads the leaf irradiance buffer (one vec4 per triangle: rgb transmitted irradiance E T_i, w
//! unused) and writes the vertex exitance buffer (one vec4 per display vertex: rgb radiant
//! exitance M, w = 0). Inside, in order, with the barriers between its own dispatches:
//! 1. pull: one dispatch per merge round of the hierarchy, bottom-up (`dipole/pull_irradiance.comp`);
//! 2. gather: one dispatch over all nodes, summing form factor x source irradiance over each
//!    node's links (`dipole/gather_links.comp`);
//! 3. push: one dispatch per merge round, top-down, then one over the leaves
//!    (`dipole/push_exitance.comp`);
//! 4. vertices: the area-weighted mean of the triangles around each vertex, times the texture
//!    factor (`dipole/vertex_exitance.comp`).
//!
//! The caller (the frame graph) orders the writes of the leaf irradiance before
//! [`DipoleGatherPass::record`] (compute or host write -> compute read) and the vertex exitance's
//! readers after it (compute write -> vertex attribute read, or host read). Links, hierarchy
//! weights and the texture factor live in host-visible buffers that [`DipoleGatherPass::set_links`],
//! [`DipoleGatherPass::refit`] and [`DipoleGatherPass::write_leaf_irradiance`] rewrite: call them
//! only when no submitted frame still uses the pass (phase 2 of issue 15 moves these uploads into
//! the frame).
//!
//! The link buffer is bound to the gather as [`LINK_WINDOWS`] storage-buffer windows of
//! [`device_link_window`] links (each within the device's `maxStorageBufferRange`); more links
//! than they hold is [`DipoleError::TooManyLinks`], before any GPU object is made.
//!
//! ```no_run
//! use translucent::material::Material;
//! use translucent::mesh::shapes::Shape;
//! use translucent::solver::dipole::{BoundaryModel, DipoleGatherPass, DipoleProfile, FaceClusterHierarchy, LinkParams, LinkSet};
//! use translucent::vk::{barrier, Access, Context, ContextDesc};
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let ctx = Context::headless(&ContextDesc::default())?;
//! let mesh = Shape::Sphere { radius: 10.0 }.triangulate(16);
//! let (tree, _) = FaceClusterHierarchy::build(&mesh)?;
//! let dipole = DipoleProfile::new(&Material::preset("marble")?, BoundaryModel::Moments);
//! let (links, _) = LinkSet::build(&tree, &dipole, &LinkParams::default());
//! let mut pass = DipoleGatherPass::new(&ctx, &tree, &links, None)?;
//! pass.write_leaf_irradiance(&vec![[1.0; 3]; tree.leaf_count()])?;
//! ctx.execute("dipole", |cb| {
//!     // SAFETY: `cb` is recording; the pass outlives the waited submission.
//!     unsafe {
//!         pass.record(&ctx, cb, None);
//!         // why: the CPU reads what the vertex dispatch wrote.
//!         barrier::memory(&ctx, cb, Access::ComputeWrite, Access::HostRead);
//!     }
//!     Ok(())
//! })?;
//! let m = pass.read_vertex_exitance()?; // one [r, g, b, 0] per vertex
//! # Ok(()) }
//! ```

use std::ops::Range;

use ash::vk;

use super::hierarchy::{FaceClusterHierarchy, NO_NODE};
use super::links::{child_weights, vertex_weights, Link, LinkSet};
use super::DipoleError;
use crate::scene::MAX_LIGHT_COLOUR;
use crate::shader::{ComputePipeline, ComputePipelineDesc, DescriptorWrite};
use crate::vk::{barrier, Access, Buffer, BufferDesc, Context, GpuProfiler, MemoryUse};

/// The pass's profiler scope and debug label.
pub const PASS_NAME: &str = "dipole gather";

/// Push constants of `dipole/pull_irradiance.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct PullPush {
    pub first_node: u32,
    pub count: u32,
    pub leaf_count: u32,
    pub pad: u32,
}

/// Push constants of `dipole/gather_links.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GatherPush {
    pub node_count: u32,
    pub leaf_count: u32,
    /// Links per window binding (`links_0..3`): link k is element k % window of binding k / window.
    pub link_window: u32,
}

/// Push constants of `dipole/push_exitance.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct PushDownPush {
    pub first_node: u32,
    pub count: u32,
}

/// Push constants of `dipole/vertex_exitance.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct VertexPush {
    pub vertex_count: u32,
    /// Floats per vertex of the output and the first float written.
    pub stride: u32,
    pub offset: u32,
    /// Multiplies the exitance (1 for M; 1 / (1 - F_dr) for J+).
    pub scale: f32,
}

/// Where the vertex step writes: the pass's own vec4 buffer of M, or a display mesh's vertex
/// buffer (see [`DipoleGatherPass::bind_mesh_output`]).
#[derive(Clone, Copy, Debug)]
struct VertexOutput {
    set: vk::DescriptorSet,
    stride: u32,
    offset: u32,
    scale: f32,
}

/// `ClusterChildren` of the pull shader (std430, 16 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
struct GpuCluster {
    children: [u32; 2],
    weights: [f32; 2],
}

/// `VertexFace` of the vertex shader (std430, 8 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
struct GpuVertexFace {
    face: u32,
    weight: f32,
}

/// The dipole method's GPU gather (module doc).
pub struct DipoleGatherPass {
    pull: ComputePipeline<PullPush>,
    gather: ComputePipeline<GatherPush>,
    push_down: ComputePipeline<PushDownPush>,
    vertices: ComputePipeline<VertexPush>,
    leaf_irradiance: Buffer,
    node_irradiance: Buffer,
    clusters: Buffer,
    /// Bound in the push's descriptor set, never touched after creation.
    _node_parent: Buffer,
    receiver_offsets: Buffer,
    links: Buffer,
    node_exitance: Buffer,
    /// Bound in the vertex descriptor set, never touched after creation.
    _vertex_face_offsets: Buffer,
    vertex_faces: Buffer,
    /// Bound in the vertex descriptor set, never touched after creation.
    _vertex_modulation: Buffer,
    vertex_exitance: Buffer,
    pull_set: vk::DescriptorSet,
    gather_set: vk::DescriptorSet,
    push_set: vk::DescriptorSet,
    vertex_set: vk::DescriptorSet,
    /// Set by [`DipoleGatherPass::bind_mesh_output`]: the vertex step writes there instead.
    mesh_output: Option<VertexOutput>,
    rounds: Vec<Range<u32>>,
    leaf_count: u32,
    node_count: u32,
    vertex_count: u32,
    link_capacity: usize,
    /// Links per window binding of the gather (see [`LINK_WINDOWS`]).
    link_window: usize,
}

/// Bindings of the one link buffer in the gather (`links_0..3` in `dipole/gather_links.comp`),
/// each a window of at most the device's `maxStorageBufferRange` bytes: a whole-buffer binding
/// of a large link set (the sphere's 11.5M links, 184 MB) exceeds lavapipe's 128 MiB. No
/// descriptor indexing on lavapipe, so the shader branches over separate bindings.
pub const LINK_WINDOWS: usize = 4;

/// The gather's window bindings, by name in the shader.
const LINK_WINDOW_NAMES: [&str; LINK_WINDOWS] = ["links_0", "links_1", "links_2", "links_3"];

/// Bytes of one [`Link`] on the GPU (std430 `Link` of the gather shader).
const LINK_BYTES: usize = std::mem::size_of::<Link>();

/// Links per window on `ctx`'s device: the most whose bytes fit `maxStorageBufferRange` and are a
/// multiple of `minStorageBufferOffsetAlignment` (the next window's offset).
pub fn device_link_window(ctx: &Context) -> usize {
    let limits = ctx.limits();
    let step = link_window_step(ctx);
    let most = limits.max_storage_buffer_range as usize / LINK_BYTES;
    (most / step * step).max(step)
}

/// Window sizes must be multiples of this many links (the offset alignment in links).
pub fn link_window_step(ctx: &Context) -> usize {
    let align = (ctx.limits().min_storage_buffer_offset_alignment as usize).max(1);
    // lcm(LINK_BYTES, align) / LINK_BYTES; both are powers of two in practice.
    let gcd = |mut a: usize, mut b: usize| {
        while b != 0 {
            (a, b) = (b, a % b);
        }
        a
    };
    align / gcd(LINK_BYTES, align)
}

/// Re-allocations of the link buffer (each doubles it) before the gather's descriptor pool is spent.
const GATHER_SETS: u32 = 32;

fn storage(
    ctx: &Context,
    name: &'static str,
    bytes: usize,
    memory: MemoryUse,
) -> Result<Buffer, DipoleError> {
    Ok(Buffer::new(
        ctx,
        &BufferDesc {
            name,
            // Vulkan buffers cannot be empty: a one-triangle mesh has no clusters, a link set may be empty.
            size: bytes.max(16) as u64,
            usage: vk::BufferUsageFlags::STORAGE_BUFFER,
            memory,
        },
    )?)
}

fn upload<T: bytemuck::Pod>(
    ctx: &Context,
    name: &'static str,
    data: &[T],
) -> Result<Buffer, DipoleError> {
    let mut b = storage(ctx, name, std::mem::size_of_val(data), MemoryUse::Upload)?;
    b.write_bytes(0, bytemuck::cast_slice(data))?;
    Ok(b)
}

fn sb<'a>(name: &'a str, buffer: &'a Buffer) -> DescriptorWrite<'a> {
    DescriptorWrite::StorageBuffer { name, buffer }
}

impl DipoleGatherPass {
    /// Creates the pipelines and buffers for `tree` and uploads its links and the per-vertex
    /// texture factor (`None`: 1). The leaf irradiance starts at zero.
    ///
    /// More links than [`LINK_WINDOWS`] windows of [`device_link_window`] hold is
    /// [`DipoleError::TooManyLinks`], before any GPU object is made.
    pub fn new(
        ctx: &Context,
        tree: &FaceClusterHierarchy,
        links: &LinkSet,
        modulation: Option<&[[f64; 3]]>,
    ) -> Result<DipoleGatherPass, DipoleError> {
        Self::with_link_window(ctx, tree, links, modulation, None)
    }

    /// [`Self::new`] with `window` links per window binding instead of the device's
    /// ([`device_link_window`]): for tests, so a small mesh exercises several windows. `window`
    /// must be > 0, a multiple of [`link_window_step`] and at most the device's window.
    #[doc(hidden)]
    pub fn with_link_window(
        ctx: &Context,
        tree: &FaceClusterHierarchy,
        links: &LinkSet,
        modulation: Option<&[[f64; 3]]>,
        window: Option<usize>,
    ) -> Result<DipoleGatherPass, DipoleError> {
        let (t, n) = (tree.leaf_count(), tree.nodes.len());
        let v = tree.vertex_face_offsets.len() - 1;
        links.check(n)?;
        let device_window = device_link_window(ctx);
        let link_window = match window {
            None => device_window,
            Some(w) => {
                let step = link_window_step(ctx);
                if w == 0 || w % step != 0 || w > device_window {
                    return Err(DipoleError::Parameter {
                        name: "link window",
                        problem: format!(
                            "{w} links: must be > 0, a multiple of {step} and at most {device_window}"
                        ),
                    });
                }
                w
            }
        };
        check_link_count(ctx, links.len(), link_window)?;
        if let Some(m) = modulation {
            if m.len() != v || m.iter().flatten().any(|x| !(x.is_finite() && *x >= 0.0)) {
                return Err(DipoleError::Invalid(format!(
                    "texture factors: {} values for {v} vertices, each finite and >= 0",
                    m.len()
                )));
            }
        }
        let pipeline =
            |name, shader, bindings: &'static [&'static str], max_sets| ComputePipelineDesc {
                name,
                shader,
                bindings,
                max_sets,
            };
        let pull = ComputePipeline::new(
            ctx,
            &pipeline(
                "dipole pull",
                "dipole/pull_irradiance.comp",
                &["leaf_irradiance", "node_irradiance", "clusters"],
                1,
            ),
        )?;
        let gather = ComputePipeline::new(
            ctx,
            &pipeline(
                "dipole links",
                "dipole/gather_links.comp",
                &[
                    "leaf_irradiance",
                    "node_irradiance",
                    "receiver_offsets",
                    "node_exitance",
                    LINK_WINDOW_NAMES[0],
                    LINK_WINDOW_NAMES[1],
                    LINK_WINDOW_NAMES[2],
                    LINK_WINDOW_NAMES[3],
                ],
                GATHER_SETS,
            ),
        )?;
        let push_down = ComputePipeline::new(
            ctx,
            &pipeline(
                "dipole push",
                "dipole/push_exitance.comp",
                &["node_exitance", "node_parent"],
                1,
            ),
        )?;
        let vertices = ComputePipeline::new(
            ctx,
            &pipeline(
                "dipole vertices",
                "dipole/vertex_exitance.comp",
                &[
                    "node_exitance",
                    "vertex_face_offsets",
                    "vertex_faces",
                    "vertex_modulation",
                    "vertex_exitance",
                ],
                2,
            ),
        )?;
        let leaf_irradiance = upload(ctx, "dipole leaf irradiance", &vec![[0.0f32; 4]; t])?;
        let node_irradiance = storage(
            ctx,
            "dipole node irradiance",
            (n - t) * 16,
            MemoryUse::GpuOnly,
        )?;
        let clusters = upload(ctx, "dipole clusters", &cluster_table(tree))?;
        let parents: Vec<u32> = tree.nodes.iter().map(|x| x.parent).collect();
        let node_parent = upload(ctx, "dipole node parents", &parents)?;
        let receiver_offsets = upload(ctx, "dipole receiver offsets", &links.receiver_offsets)?;
        let link_capacity = links.len().max(1);
        let link_buffer = storage(ctx, "dipole links", link_capacity * 16, MemoryUse::Upload)?;
        let node_exitance = storage(ctx, "dipole node exitance", n * 16, MemoryUse::GpuOnly)?;
        let vertex_face_offsets =
            upload(ctx, "dipole vertex face offsets", &tree.vertex_face_offsets)?;
        let vertex_faces = upload(ctx, "dipole vertex faces", &vertex_face_table(tree))?;
        let factors: Vec<[f32; 4]> = match modulation {
            Some(m) => m
                .iter()
                .map(|x| [x[0] as f32, x[1] as f32, x[2] as f32, 1.0])
                .collect(),
            None => vec![[1.0; 4]; v],
        };
        let vertex_modulation = upload(ctx, "dipole vertex texture", &factors)?;
        let mut vertex_exitance = Buffer::new(
            ctx,
            &BufferDesc {
                name: "dipole vertex exitance",
                size: (v.max(1) * 16) as u64,
                usage: vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::VERTEX_BUFFER,
                memory: MemoryUse::Readback,
            },
        )?;
        vertex_exitance.write_bytes(0, &vec![0u8; v.max(1) * 16])?;
        let pull_set = pull.allocate_set(
            ctx,
            &[
                sb("leaf_irradiance", &leaf_irradiance),
                sb("node_irradiance", &node_irradiance),
                sb("clusters", &clusters),
            ],
        )?;
        let push_set = push_down.allocate_set(
            ctx,
            &[
                sb("node_exitance", &node_exitance),
                sb("node_parent", &node_parent),
            ],
        )?;
        let vertex_set = vertices.allocate_set(
            ctx,
            &[
                sb("node_exitance", &node_exitance),
                sb("vertex_face_offsets", &vertex_face_offsets),
                sb("vertex_faces", &vertex_faces),
                sb("vertex_modulation", &vertex_modulation),
                sb("vertex_exitance", &vertex_exitance),
            ],
        )?;
        let mut pass = DipoleGatherPass {
            pull,
            gather,
            push_down,
            vertices,
            leaf_irradiance,
            node_irradiance,
            clusters,
            _node_parent: node_parent,
            receiver_offsets,
            links: link_buffer,
            node_exitance,
            _vertex_face_offsets: vertex_face_offsets,
            vertex_faces,
            _vertex_modulation: vertex_modulation,
            vertex_exitance,
            pull_set,
            gather_set: vk::DescriptorSet::null(),
            push_set,
            vertex_set,
            mesh_output: None,
            rounds: tree.rounds.clone(),
            leaf_count: t as u32,
            node_count: n as u32,
            vertex_count: v as u32,
            link_capacity,
            link_window,
        };
        pass.gather_set = pass.allocate_gather_set(ctx)?;
        pass.links
            .write_bytes(0, bytemuck::cast_slice(&links.links))?;
        Ok(pass)
    }

    fn allocate_gather_set(&self, ctx: &Context) -> Result<vk::DescriptorSet, DipoleError> {
        let window_bytes = (self.link_window * LINK_BYTES) as u64;
        let size = self.links.size;
        let mut writes = vec![
            sb("leaf_irradiance", &self.leaf_irradiance),
            sb("node_irradiance", &self.node_irradiance),
            sb("receiver_offsets", &self.receiver_offsets),
            sb("node_exitance", &self.node_exitance),
        ];
        for (i, name) in LINK_WINDOW_NAMES.into_iter().enumerate() {
            let start = i as u64 * window_bytes;
            // A window past the buffer's end is never read (link k < capacity): bind its start,
            // a valid range.
            let offset = if start < size { start } else { 0 };
            writes.push(DescriptorWrite::StorageBufferRange {
                name,
                buffer: &self.links,
                offset,
                range: window_bytes.min(size - offset),
            });
        }
        Ok(self.gather.allocate_set(ctx, &writes)?)
    }

    /// From now on the vertex step writes rgb `M * scale` at floats `[v * stride + offset, +3)` of
    /// `buffer` (a display mesh's interleaved vertices: the exitance field in place, J+ with
    /// `scale = 1 / (1 - F_dr)`) instead of the pass's own buffer. `buffer` must have STORAGE
    /// usage, hold every vertex and outlive the pass's recordings.
    pub fn bind_mesh_output(
        &mut self,
        ctx: &Context,
        buffer: &Buffer,
        stride: u32,
        offset: u32,
        scale: f32,
    ) -> Result<(), DipoleError> {
        let floats = u64::from(self.vertex_count) * u64::from(stride);
        if self.mesh_output.is_some() {
            return Err(DipoleError::Invalid(
                "the mesh output is already bound (one per pass)".into(),
            ));
        }
        if offset + 3 > stride || buffer.size < floats * 4 {
            return Err(DipoleError::Invalid(format!(
                "mesh output: {} bytes, stride {stride} and offset {offset} floats for {} vertices",
                buffer.size, self.vertex_count
            )));
        }
        if !(scale.is_finite() && scale > 0.0) {
            return Err(DipoleError::Invalid(format!(
                "mesh output scale {scale} must be finite and > 0"
            )));
        }
        let set = self.vertices.allocate_set(
            ctx,
            &[
                sb("node_exitance", &self.node_exitance),
                sb("vertex_face_offsets", &self._vertex_face_offsets),
                sb("vertex_faces", &self.vertex_faces),
                sb("vertex_modulation", &self._vertex_modulation),
                sb("vertex_exitance", buffer),
            ],
        )?;
        self.mesh_output = Some(VertexOutput {
            set,
            stride,
            offset,
            scale,
        });
        Ok(())
    }

    /// Rewrites the per-vertex texture factor (`None`: 1), e.g. after a material change. Same
    /// contract as [`Self::set_links`]: no submitted frame may still use the pass.
    pub fn set_modulation(&mut self, modulation: Option<&[[f64; 3]]>) -> Result<(), DipoleError> {
        let v = self.vertex_count as usize;
        let factors: Vec<[f32; 4]> = match modulation {
            Some(m) => {
                if m.len() != v || m.iter().flatten().any(|x| !(x.is_finite() && *x >= 0.0)) {
                    return Err(DipoleError::Invalid(format!(
                        "texture factors: {} values for {v} vertices, each finite and >= 0",
                        m.len()
                    )));
                }
                m.iter()
                    .map(|x| [x[0] as f32, x[1] as f32, x[2] as f32, 1.0])
                    .collect()
            }
            None => vec![[1.0; 4]; v],
        };
        self._vertex_modulation
            .write_bytes(0, bytemuck::cast_slice(&factors))?;
        Ok(())
    }

    /// Changes the scale of the mesh output (after a material change: 1 / (1 - F_dr)); no-op
    /// without one.
    pub fn set_output_scale(&mut self, scale: f32) {
        if let Some(out) = &mut self.mesh_output {
            out.scale = scale;
        }
    }

    /// Bytes of the pass's GPU buffers.
    pub fn bytes(&self) -> u64 {
        [
            &self.leaf_irradiance,
            &self.node_irradiance,
            &self.clusters,
            &self._node_parent,
            &self.receiver_offsets,
            &self.links,
            &self.node_exitance,
            &self._vertex_face_offsets,
            &self.vertex_faces,
            &self._vertex_modulation,
            &self.vertex_exitance,
        ]
        .iter()
        .map(|b| b.size)
        .sum()
    }

    /// Triangles (leaves) of the hierarchy.
    pub fn leaf_count(&self) -> u32 {
        self.leaf_count
    }

    /// Links the buffer holds without reallocating.
    pub fn link_capacity(&self) -> usize {
        self.link_capacity
    }

    /// Links per window binding of the gather ([`LINK_WINDOWS`] of them).
    pub fn link_window(&self) -> usize {
        self.link_window
    }

    /// Window bindings the links in the buffer span now (1..=[`LINK_WINDOWS`]).
    pub fn link_windows_used(&self) -> usize {
        self.link_capacity.div_ceil(self.link_window).max(1)
    }

    /// [`Self::set_links`] without reallocation: a set larger than [`Self::link_capacity`] is an
    /// error (nothing written).
    pub fn write_links(&mut self, links: &LinkSet) -> Result<(), DipoleError> {
        links.check(self.node_count as usize)?;
        if links.len() > self.link_capacity {
            return Err(DipoleError::Invalid(format!(
                "{} links do not fit the buffer's {}",
                links.len(),
                self.link_capacity
            )));
        }
        self.links
            .write_bytes(0, bytemuck::cast_slice(&links.links))?;
        self.receiver_offsets
            .write_bytes(0, bytemuck::cast_slice(&links.receiver_offsets))?;
        Ok(())
    }

    /// Replaces the links (after incremental updates or a relink). A larger set than the buffer
    /// holds reallocates it (doubling, up to what the window bindings hold: more is
    /// [`DipoleError::TooManyLinks`], nothing written).
    pub fn set_links(&mut self, ctx: &Context, links: &LinkSet) -> Result<(), DipoleError> {
        self.set_links_reserving(ctx, links, 0)
    }

    /// [`Self::set_links`] with room for at least `reserve` links (capped at what the window
    /// bindings hold): incremental relinking then writes its growing sets with
    /// [`Self::write_links`], which needs no context.
    pub fn set_links_reserving(
        &mut self,
        ctx: &Context,
        links: &LinkSet,
        reserve: usize,
    ) -> Result<(), DipoleError> {
        links.check(self.node_count as usize)?;
        let max_links = LINK_WINDOWS * self.link_window;
        let wanted = links.len().max(reserve.min(max_links));
        if wanted > self.link_capacity {
            check_link_count(ctx, links.len(), self.link_window)?;
            let capacity = wanted.max((2 * self.link_capacity).min(max_links));
            self.links = storage(ctx, "dipole links", capacity * 16, MemoryUse::Upload)?;
            self.link_capacity = capacity;
            self.gather_set = self.allocate_gather_set(ctx)?;
        }
        self.links
            .write_bytes(0, bytemuck::cast_slice(&links.links))?;
        self.receiver_offsets
            .write_bytes(0, bytemuck::cast_slice(&links.receiver_offsets))?;
        Ok(())
    }

    /// Rewrites the area weights of the pull and of the vertex average after
    /// [`FaceClusterHierarchy::refit`] (same topology).
    pub fn refit(&mut self, tree: &FaceClusterHierarchy) -> Result<(), DipoleError> {
        if tree.nodes.len() != self.node_count as usize {
            return Err(DipoleError::Invalid(
                "refit with another hierarchy: create a new pass for a new topology".into(),
            ));
        }
        self.clusters
            .write_bytes(0, bytemuck::cast_slice(&cluster_table(tree)))?;
        self.vertex_faces
            .write_bytes(0, bytemuck::cast_slice(&vertex_face_table(tree)))?;
        Ok(())
    }

    /// Writes the transmitted irradiance of every leaf (triangle), rgb, finite, >= 0 and at most
    /// [`MAX_LIGHT_COLOUR`] (the f32 sums of the gather stay finite).
    pub fn write_leaf_irradiance(&mut self, irradiance: &[[f64; 3]]) -> Result<(), DipoleError> {
        if irradiance.len() != self.leaf_count as usize {
            return Err(DipoleError::Invalid(format!(
                "{} leaf irradiance values for {} triangles",
                irradiance.len(),
                self.leaf_count
            )));
        }
        if let Some(i) = irradiance.iter().position(|e| {
            e.iter()
                .any(|x| !(x.is_finite() && (0.0..=MAX_LIGHT_COLOUR).contains(x)))
        }) {
            return Err(DipoleError::Invalid(format!(
                "leaf {i}: irradiance {:?} must be finite, >= 0 and <= {MAX_LIGHT_COLOUR:e}",
                irradiance[i]
            )));
        }
        let data: Vec<[f32; 4]> = irradiance
            .iter()
            .map(|e| [e[0] as f32, e[1] as f32, e[2] as f32, 0.0])
            .collect();
        self.leaf_irradiance
            .write_bytes(0, bytemuck::cast_slice(&data))?;
        Ok(())
    }

    /// Input: one vec4 per triangle (rgb E T_i). Written by the host or by a gather pass.
    pub fn leaf_irradiance(&self) -> &Buffer {
        &self.leaf_irradiance
    }

    /// Output: one vec4 per display vertex (rgb M).
    pub fn vertex_exitance(&self) -> &Buffer {
        &self.vertex_exitance
    }

    /// Reads the output (host-visible; the caller waited for the frame and made the writes
    /// host-visible).
    pub fn read_vertex_exitance(&self) -> Result<Vec<[f32; 4]>, DipoleError> {
        let bytes = self.vertex_exitance.read_bytes()?;
        let n = self.vertex_count as usize;
        Ok(bytemuck::cast_slice::<u8, [f32; 4]>(&bytes[..n * 16]).to_vec())
    }

    /// Dispatches: pull rounds + gather + push rounds + leaves + vertices.
    pub fn dispatch_count(&self) -> usize {
        2 * self.rounds.len() + 3
    }

    /// Records the pass (module doc): only binds, pushes, dispatches and the barriers between its
    /// own dispatches. Reads [`Self::leaf_irradiance`] (compute shader storage read), writes
    /// [`Self::vertex_exitance`] (compute shader storage write).
    ///
    /// # Safety
    /// `cb` must be recording outside a rendering scope on `ctx`'s device; the leaf irradiance's
    /// writes must be made visible to compute reads before it; the pass must outlive `cb`'s
    /// execution.
    pub unsafe fn record(
        &self,
        ctx: &Context,
        cb: vk::CommandBuffer,
        mut profiler: Option<&mut GpuProfiler>,
    ) {
        // SAFETY: the caller's contract (recording `cb`, live pass and buffers).
        unsafe {
            ctx.begin_label(cb, PASS_NAME);
            if let Some(p) = profiler.as_deref_mut() {
                p.begin_scope(cb, PASS_NAME);
            }
            self.record_dispatches(ctx, cb);
            if let Some(p) = profiler {
                p.end_scope(cb);
            }
            ctx.end_label(cb);
        }
    }

    /// [`Self::record`] without its debug label and profiler scope: for a frame-graph pass, which
    /// names and times itself.
    ///
    /// # Safety
    /// As [`Self::record`]; inside a frame-graph pass, the pass must declare the leaf irradiance
    /// (compute read) and the output buffer (compute write).
    pub unsafe fn record_dispatches(&self, ctx: &Context, cb: vk::CommandBuffer) {
        let t = self.leaf_count;
        // SAFETY: the caller's contract (recording `cb`, live pass and buffers).
        unsafe {
            // why: the pass's own buffers (node irradiance, node exitance) were read and written by
            // this pass in the previous frame: WAR/WAW against this frame's pull and gather.
            barrier::memory(ctx, cb, Access::ComputeReadWrite, Access::ComputeReadWrite);
            for round in &self.rounds {
                let push = PullPush {
                    first_node: round.start,
                    count: round.end - round.start,
                    leaf_count: t,
                    pad: 0,
                };
                self.pull
                    .dispatch(ctx, cb, self.pull_set, &push, [push.count, 1, 1]);
                // why: the next round (and the gather) read the clusters this round wrote (RAW).
                barrier::memory(ctx, cb, Access::ComputeWrite, Access::ComputeRead);
            }
            let push = GatherPush {
                node_count: self.node_count,
                leaf_count: t,
                link_window: self.link_window as u32,
            };
            self.gather
                .dispatch(ctx, cb, self.gather_set, &push, [self.node_count, 1, 1]);
            // why: the push reads and adds to the exitance the gather wrote (RAW, then WAW).
            barrier::memory(ctx, cb, Access::ComputeWrite, Access::ComputeReadWrite);
            let rounds = self.rounds.iter().rev().cloned();
            for range in rounds.chain(std::iter::once(0..t)) {
                let push = PushDownPush {
                    first_node: range.start,
                    count: range.end - range.start,
                };
                self.push_down
                    .dispatch(ctx, cb, self.push_set, &push, [push.count, 1, 1]);
                // why: the next (finer) round reads its parents' exitance this round completed
                // (RAW); after the leaves, the vertex average reads them.
                barrier::memory(ctx, cb, Access::ComputeWrite, Access::ComputeReadWrite);
            }
            let out = self.mesh_output.unwrap_or(VertexOutput {
                set: self.vertex_set,
                stride: 4,
                offset: 0,
                scale: 1.0,
            });
            let push = VertexPush {
                vertex_count: self.vertex_count,
                stride: out.stride,
                offset: out.offset,
                scale: out.scale,
            };
            self.vertices
                .dispatch(ctx, cb, out.set, &push, [self.vertex_count, 1, 1]);
        }
    }
}

/// [`DipoleError::TooManyLinks`] unless `links` fit [`LINK_WINDOWS`] windows of `window` links.
fn check_link_count(ctx: &Context, links: usize, window: usize) -> Result<(), DipoleError> {
    let max_links = LINK_WINDOWS * window;
    if links <= max_links {
        return Ok(());
    }
    Err(DipoleError::TooManyLinks {
        links,
        windows: LINK_WINDOWS,
        window,
        window_bytes: (window * LINK_BYTES) as u64,
        max_range: ctx.limits().max_storage_buffer_range,
        max_links,
    })
}

/// Children and area shares of every internal node, for the pull.
fn cluster_table(tree: &FaceClusterHierarchy) -> Vec<GpuCluster> {
    let t = tree.leaf_count();
    tree.nodes[t..]
        .iter()
        .map(|n| {
            let [a, b] = n.children;
            debug_assert!(a != NO_NODE && b != NO_NODE);
            let w = child_weights(&tree.geometry[a as usize], &tree.geometry[b as usize]);
            GpuCluster {
                children: [a, b],
                weights: [w[0] as f32, w[1] as f32],
            }
        })
        .collect()
}

/// (triangle, weight) around each vertex, for the vertex average.
fn vertex_face_table(tree: &FaceClusterHierarchy) -> Vec<GpuVertexFace> {
    tree.vertex_faces
        .iter()
        .zip(vertex_weights(tree))
        .map(|(&face, w)| GpuVertexFace {
            face,
            weight: w as f32,
        })
        .collect()
}

// The GPU layouts of the links and the tables above (std430 sizes the shaders declare).
const _: () = assert!(std::mem::size_of::<Link>() == 16);
const _: () = assert!(std::mem::size_of::<GpuCluster>() == 16);
const _: () = assert!(std::mem::size_of::<GpuVertexFace>() == 8);
