//! The GPU diffusion solve of a baked QuadGraph (paper sections 4.3 and 5; DESIGN sections 4 and 5):
//! per level, coarsest first, Shepard initialisation from the coarser level (Eq. 10) or, warm
//! ([`GpuDiffusion::plan`] with `warm`: what the object's plan asks for when the lights, material
//! or shape changed), the level's last solution plus the Shepard-prolonged change
//! of the coarser level's solution (`shepard/warm_correct.glsl`), pure Jacobi
//! ping-pong (Eqs. 8/9 in the `fv` or `paper` form, surface and inner nodes in one dispatch, told
//! apart by their row), convergence decided on the GPU with indirect dispatch; then J+ at the
//! surface nodes (clamped at 0, counted) and per display vertex through the shading weights.
//!
//! Precision ([`Precision`]): `Mixed` (default) keeps phi in RGBA32F and iterates, inside each block
//! of `k` iterations, a correction delta in RGBA16F ping-pong against the fp32 residual
//! (residual pass = iteration 1, `k - 1` correction sweeps, then phi += delta); `Fp32` and `Fp16`
//! are plain phi ping-pong in that format (benchmark modes; `Fp16` is the paper's and stalls).
//! All state is stored times the exposure [`GpuDiffusion::q_scale`] (q is RGBA16F; fp16 overflows at
//! 65504 and phi reaches ~7 q) and unscaled in fp32 when read (J+ pass, read-backs).
//!
//! Convergence: iterations are recorded in blocks of an even `k`, up to the per-level cap; after each
//! block one workgroup reduces max|delta phi| / max|phi|, estimates rho from successive blocks,
//! divides by (1 - rho) and, below the tolerance, zeroes the indirect dispatch arguments of the
//! following blocks. The CPU never reads anything inside a frame; [`GpuDiffusion::iterations_run`]
//! reads the GPU's counters afterwards. Even `k` keeps a level's result in a known image.
//!
//! Synchronization: every image stays in GENERAL; exactly one global memory barrier (compute write
//! -> compute read|write) before every dispatch of the loop (in `Mixed` a block of k iterations has
//! k + 1 dispatches: residual, k - 1 sweeps, apply); around each convergence reduction one barrier
//! before it (compute write -> read) and one after it (compute write -> indirect read); one before
//! each init or warm correction (it reads the coarser level's result, rewrites this level's phi).
//! The counts are in [`GpuDiffusion::record_stats`]; synchronization validation checks they suffice.
//!
//! Interface with the irradiance gather (part B, `render::irradiance`): per level,
//! [`GpuDiffusion::surface_position`] (RGBA32F, rgb = surface node position in mm in the object
//! frame, a = 1 on surface-node texels, 0 on padding; the same width as the level's textures but
//! only its `surface_rows` rows, [`GpuDiffusion::surface_rows`]), [`GpuDiffusion::surface_normal`]
//! (RGBA16F, rgb = outward unit normal) and [`GpuDiffusion::q_image`] (RGBA16F storage image in
//! GENERAL, rgb = q * [`GpuDiffusion::q_scale`], to be written where position.a = 1). The gather
//! and the solve are passes of one [`crate::frame::FrameGraph`] ([`GpuDiffusion::solve_uses`]
//! declares what the solve reads and writes, so the graph places the barrier between them); the
//! QuadGraph method ([`crate::frame::quadgraph`]) composes them. Tests and the CPU-q path use
//! [`GpuDiffusion::upload_q`] and [`crate::frame::quadgraph::solve_headless`] instead.
//!
//! ```no_run
//! # use translucent::solver::gpu::{GpuDiffusion, GpuSolveParams};
//! # fn f(ctx: &translucent::vk::Context, graph: &translucent::QuadGraph,
//! #      field: &translucent::material::MaterialField, q: &[Vec<[f32; 3]>]) -> Result<(), translucent::Error> {
//! let mut solve = GpuDiffusion::new(ctx, graph, field, &GpuSolveParams::default())?;
//! solve.set_q_scale(GpuDiffusion::exposure_for(q.iter().flatten()));
//! for (level, q) in q.iter().enumerate() {
//!     solve.upload_q(ctx, level, q)?;
//! }
//! translucent::frame::quadgraph::solve_headless(ctx, &mut solve, false)?; // submits and waits
//! let j_plus = solve.read_j_plus(ctx)?; // per surface node of the finest level
//! let iterations = solve.iterations_run(ctx)?; // per level, from the GPU counter
//! # Ok(()) }
//! ```

mod bytes;
pub mod edit;
mod interior;
pub mod multigrid;
mod params;
mod ping_pong;
mod pipelines;
mod push;
mod readback;
pub mod record;
pub mod textures;
mod upload;

pub use bytes::SolveBytes;
pub use edit::Deformation;
pub(crate) use interior::InteriorSamples;
pub use params::{GpuSolveParams, HeterogeneousWeights, Precision};
pub use ping_pong::PingPong;
pub use push::*;
pub use record::{SolvePlan, PASS_EXITANCE, PASS_SOLVE};

use std::sync::Arc;

use ash::vk;
use half::f16;

use self::textures::{HomogeneousMaterial, LevelTexels};
use super::operator::{LevelOperator, Scheme};
use super::transport::SurfaceReconstruction;
use super::SolverError;
use crate::material::MaterialField;
use crate::mesh::GpuMesh;
use crate::quadgraph::graph::{Packing, QuadGraph, NO_NODE};
use crate::shader::{ComputePipeline, ComputePipelineDesc, DescriptorWrite, SpecConstant};
use crate::solver::multigrid::FinestOperator;
use crate::vk::{
    barrier, Access, Buffer, BufferDesc, Context, Image, ImageDesc, ImageReadback, MemoryUse,
};
use crate::Error;

/// Pass names: profiler scopes and debug labels.
pub const PASS_INIT: &str = "diffusion init";
/// The warm start's coarse-change correction (and save of a coarse level's previous phi).
pub const PASS_WARM: &str = "diffusion warm correction";
pub const PASS_JACOBI: &str = "diffusion jacobi";
pub const PASS_CONVERGENCE: &str = "diffusion convergence";
pub const PASS_J_PLUS: &str = "diffusion j+";
pub const PASS_VERTEX_J_PLUS: &str = "diffusion vertex j+";

const STORAGE_IMAGE: vk::ImageUsageFlags = vk::ImageUsageFlags::from_raw(
    vk::ImageUsageFlags::STORAGE.as_raw()
        | vk::ImageUsageFlags::TRANSFER_DST.as_raw()
        | vk::ImageUsageFlags::TRANSFER_SRC.as_raw(),
);

/// One level's textures and descriptor sets.
pub struct GpuLevel {
    pub packing: Packing,
    pub node_count: usize,
    pub inner_count: usize,
    /// Ping-pong state: phi (Fp32, Fp16) or the correction delta (Mixed, RGBA16F).
    state: [Image; 2],
    /// Mixed: phi (RGBA32F) and the fp32 residual.
    phi: Option<Image>,
    residual: Option<Image>,
    q: Image,
    pub(crate) connectivity: Image,
    /// Geometric factors (`textures.rs` table): read by the homogeneous iteration and by the
    /// weight derivation.
    pub(crate) geo: Image,
    /// fv fractions of the harmonic face kappa: heterogeneous or deformed levels only.
    pub(crate) frac: Option<Image>,
    /// Heterogeneous only: per-node kappa and mu.
    pub(crate) material: Option<[Image; 2]>,
    /// Heterogeneous only: per-channel Jacobi weights derived on the GPU.
    pub(crate) weights: Option<[Image; 3]>,
    links: [Image; 2],
    pub(crate) surface_position: Image,
    pub(crate) surface_normal: Image,
    /// The curvature's anisotropy (rgb) per surface node (`textures` module table).
    pub(crate) surface_anisotropy: Image,
    /// The collimated source's part of the exit query per surface node (surface rows only).
    pub(crate) particular: Image,
    /// Per material variant (0 heterogeneous, 1 homogeneous), once created: the iteration sets
    /// (two ping-pong directions, then in Mixed the residual's).
    iterate_sets: [Vec<vk::DescriptorSet>; 2],
    /// Mixed: phi += delta.
    apply_set: vk::DescriptorSet,
    init_set: vk::DescriptorSet,
    /// Coarse levels: the phi of the previous solve, saved by the warm start before this level
    /// iterates again (the finer level's correction reads new - saved).
    saved: Option<Image>,
    /// `shepard/warm_correct*.comp` of this level.
    warm_set: vk::DescriptorSet,
    reduce_set: vk::DescriptorSet,
    /// Heterogeneous: the weight derivation's set (`edit/derive_weights.comp`).
    pub(crate) derive_set: Option<vk::DescriptorSet>,
    /// The rest pose's texels (host copy): restores `Deformation::Identity` exactly and seeds
    /// textures allocated on a later edit.
    pub(crate) rest: LevelTexels,
    /// Deformation data, created on the first deformation (`edit.rs`).
    pub(crate) deform: Option<edit::LevelDeform>,
}

impl GpuLevel {
    /// The image holding this level's phi after whole blocks (in `Mixed` phi, else the latest
    /// state: [`PingPong::latest`]).
    pub(crate) fn result(&self) -> &Image {
        // Fp32/Fp16 blocks end where they start (an even number of sweeps).
        self.phi.as_ref().unwrap_or(&self.state[PingPong::FIRST])
    }
    fn push(&self) -> LevelPush {
        LevelPush {
            size: [self.packing.width as i32, self.packing.height as i32],
            width: self.packing.width,
            surface_rows: self.packing.surface_rows,
            kappa: [0.0; 4],
            mu_gain: [0.0; 4],
        }
    }
    /// The images bound to `graph_weights.glsl`'s `weight_r`, `weight_g`, `weight_b` in a
    /// material variant: `poison` (homogeneous), the fv fractions, kappa and mu (derived), or the
    /// stored per-channel weights.
    pub(crate) fn weight_images<'a>(
        &'a self,
        poison: &'a Image,
        homogeneous: bool,
        derived: bool,
    ) -> Result<[&'a Image; 3], Error> {
        match (&self.weights, homogeneous, &self.frac, &self.material) {
            (_, true, _, _) => Ok([poison; 3]),
            // graph_weights.glsl's DERIVED bindings: fractions, kappa, mu.
            (_, false, Some(frac), Some([kappa, mu])) if derived => Ok([frac, kappa, mu]),
            (Some(w), false, _, _) if !derived => Ok([&w[0], &w[1], &w[2]]),
            _ => Err(bad_param(
                "material",
                "heterogeneous variant without per-channel weights".into(),
            )),
        }
    }
    pub(crate) fn extent(&self) -> [u32; 3] {
        [self.packing.width, self.packing.height, 1]
    }
}

/// The pipelines that read weights, specialized for one material kind (`HOMOGENEOUS`).
pub(crate) struct Variant {
    iterate: ComputePipeline<LevelPush>,
    /// Mixed only: the residual (iteration 1 of a block).
    residual: Option<ComputePipeline<LevelPush>>,
}

pub(crate) struct Pipelines {
    /// Index 0 heterogeneous, 1 homogeneous; created when a material of that kind is first used.
    variants: [Option<Variant>; 2],
    /// Mixed only: apply (phi += delta).
    apply: Option<ComputePipeline<LevelPush>>,
    /// Heterogeneous weight derivation (`edit/derive_weights.comp`), created on first use.
    pub(crate) derive: Option<ComputePipeline<edit::DerivePush>>,
    /// Deformation passes, created on the first deformation.
    pub(crate) edit: Option<edit::DeformPipelines>,
    init: ComputePipeline<ShepardPush>,
    warm: ComputePipeline<WarmPush>,
    reduce: ComputePipeline<ReducePush>,
    j_plus: ComputePipeline<JPlusPush>,
    vertex: ComputePipeline<VertexPush>,
    /// The display vertices' exitance from the interior solution (`vertex_interior*.comp`).
    interior: ComputePipeline<InteriorPush>,
}

/// The GPU solve of one QuadGraph with one material (see the module doc).
pub struct GpuDiffusion {
    params: GpuSolveParams,
    pub(crate) pipelines: Pipelines,
    pub(crate) levels: Vec<GpuLevel>,
    /// Per level [`LevelControl`]; indirect arguments, host-readable after the frame.
    control: Buffer,
    /// Surface nodes clamped at J+ = 0 per channel (finest level).
    clamp_counts: Buffer,
    j_plus: Image,
    j_plus_set: vk::DescriptorSet,
    vertex_links: Buffer,
    vertex_weights: Buffer,
    vertex_j_plus: Buffer,
    vertex_count: u32,
    vertex_set: vk::DescriptorSet,
    /// The interior reconstruction's per-vertex samples (`SurfaceSamples` as linear texel
    /// indices of the finest level); `None`: the vertices use the Shepard pass.
    interior: Option<InteriorSamples>,
    /// The display mesh, whose exitance [`Self::record_exitance`] writes in place, and the set
    /// binding its vertex buffer ([`Self::bind_mesh`]).
    mesh: Option<(Arc<GpuMesh>, vk::DescriptorSet)>,
    /// The parity rule of the iterations.
    ping_pong: PingPong,
    /// Blocks recorded per level.
    blocks: Vec<u32>,
    stats: RecordStats,
    /// phi holds a previous solve's result at the current exposure (for warm starts).
    solved: bool,
    /// Per level, the solve (a count of [`Self::record`] calls) whose iterations its phi holds;
    /// `None`: no solution at the current exposure. A warm correction of level h needs levels h
    /// and h - 1 to hold solutions of the same solve (their difference is the coarse change).
    level_solve: Vec<Option<u64>>,
    records: u64,
    q_scale: f32,
    pub(crate) f_dr: f64,
    pub(crate) a: f64,
    /// The boundary model of [`GpuSolveParams::exit`] at the current material's eta.
    pub(crate) boundary: super::transport::Boundary,
    /// Push-constant material of the homogeneous weight path: kappa rgb and 2A; mu rgb and q_gain.
    pub(crate) kappa: [f32; 4],
    pub(crate) mu_gain: [f32; 4],
    /// Which variant the iterations use.
    pub(crate) homogeneous: bool,
    /// A 1x1 RGBA32F of NaN bound to the per-channel weight slots of the homogeneous variant:
    /// the specialized shader never reads it, and a read would turn phi into NaN.
    poison: Image,
    /// Edits waiting to be recorded in front of the next solve (`edit.rs`).
    pub(crate) edits: edit::EditState,
    /// The multigrid schedule's hierarchy on the GPU ([`GpuSolveParams::multigrid`]), rebuilt
    /// by every material change.
    pub(crate) multigrid: Option<multigrid::GpuMultigrid>,
}

pub(crate) fn bad_param(name: &'static str, problem: String) -> Error {
    Error::Solver(SolverError::BadParameter { name, problem })
}

pub(crate) fn image(
    ctx: &Context,
    name: &'static str,
    p: &Packing,
    format: vk::Format,
) -> Result<Image, Error> {
    Ok(Image::new(
        ctx,
        &ImageDesc {
            name,
            width: p.width,
            height: p.height,
            format,
            usage: STORAGE_IMAGE,
        },
    )?)
}

/// Uploads every `(image, bytes)` in one submission and leaves the images in GENERAL.
pub(crate) fn upload_images(
    ctx: &Context,
    name: &str,
    items: &[(&Image, Vec<u8>)],
) -> Result<(), Error> {
    let staging: Vec<Buffer> = items
        .iter()
        .map(|(_, bytes)| {
            Buffer::with_data(
                ctx,
                "diffusion upload",
                vk::BufferUsageFlags::TRANSFER_SRC,
                bytes,
            )
        })
        .collect::<Result<_, _>>()?;
    ctx.execute(name, |cb| {
        // SAFETY: `cb` is recording; images and staging buffers outlive the waited submission.
        unsafe {
            let to_dst: Vec<_> = items
                .iter()
                .map(|(img, _)| barrier::image_barrier(img, Access::Undefined, Access::TransferDst))
                .collect();
            // why: the copies overwrite whole images; earlier contents are discarded (layout).
            barrier::record(ctx, cb, &[], &to_dst);
            for ((img, _), buf) in items.iter().zip(&staging) {
                img.record_upload_from(ctx, cb, buf);
            }
            let to_general: Vec<_> = items
                .iter()
                .map(|(img, _)| {
                    barrier::image_barrier(img, Access::TransferDst, Access::ComputeReadWrite)
                })
                .collect();
            // why: the solve reads (RAW) and may write these in GENERAL.
            barrier::record(ctx, cb, &[], &to_general);
        }
        Ok(())
    })?;
    Ok(())
}

pub(crate) fn bytes_of<T: bytemuck::Pod>(v: &[T]) -> Vec<u8> {
    bytemuck::cast_slice(v).to_vec()
}

/// The surface rows of a level (what `surface_position` and `surface_normal` cover).
pub(crate) fn surface_packing(p: &Packing) -> Packing {
    Packing {
        width: p.width,
        height: p.surface_rows.max(1),
        ..Packing::default()
    }
}

/// A raw synchronization2 memory barrier (for the indirect-argument and host hazards that
/// [`Access`] has no state for).
pub(crate) fn raw_barrier(
    src_stage: vk::PipelineStageFlags2,
    src_access: vk::AccessFlags2,
    dst_stage: vk::PipelineStageFlags2,
    dst_access: vk::AccessFlags2,
) -> vk::MemoryBarrier2<'static> {
    vk::MemoryBarrier2::default()
        .src_stage_mask(src_stage)
        .src_access_mask(src_access)
        .dst_stage_mask(dst_stage)
        .dst_access_mask(dst_access)
}

impl GpuDiffusion {
    /// Assembles every level's operator (f64), builds and uploads the textures, creates the
    /// pipelines. Fails with a typed error on bad parameters, graphs or materials.
    pub fn new(
        ctx: &Context,
        graph: &QuadGraph,
        material: &MaterialField,
        params: &GpuSolveParams,
    ) -> Result<Self, Error> {
        if graph.levels.is_empty() {
            return Err(SolverError::EmptyGraph.into());
        }
        if params.block < 2 || params.block % 2 != 0 || params.block > 1024 {
            return Err(bad_param(
                "block",
                format!("{} must be even, in 2..=1024", params.block),
            ));
        }
        if !(params.tolerance.is_finite() && params.tolerance >= 0.0) {
            return Err(bad_param(
                "tolerance",
                format!("{} must be finite and >= 0", params.tolerance),
            ));
        }
        if params.iterations.is_empty() || params.iterations.iter().any(|&n| n > 1_000_000) {
            return Err(bad_param(
                "iterations",
                format!("{:?}: one to many caps, each <= 1e6", params.iterations),
            ));
        }
        let eta = material.eta();
        crate::material::check_eta(eta).map_err(SolverError::from)?;
        if params.collimated && params.exit != super::transport::ExitQuery::Moments {
            return Err(SolverError::BadParameter {
                name: "collimated",
                problem: "the collimated source (DESIGN 2.7) is read by the moments exit query (2.6): set exit to Moments".into(),
            }
            .into());
        }
        let homogeneous = match material {
            MaterialField::Homogeneous(m) => {
                let c = m.coefficients();
                Some(HomogeneousMaterial {
                    // D of the material's kind (classical or Grosjean).
                    kappa: m.kappa(),
                    mu: c.mu(),
                })
            }
            _ => None,
        };
        let pipelines = Self::pipelines(ctx, params.precision, graph.levels.len() as u32)?;
        let mut levels: Vec<GpuLevel> = Vec::with_capacity(graph.levels.len());
        let (mut f_dr, mut a) = (0.0, 0.0);
        for (h, level) in graph.levels.iter().enumerate() {
            // The f64 operator validates geometry and material (typed errors naming the node).
            let op = LevelOperator::build_with(level, material, params.scheme, params.exit)
                .map_err(|e| e.at_level(h))?;
            (f_dr, a) = (op.f_dr, op.a);
            drop(op);
            let coarse = levels.last().map(|l| &l.packing);
            if h > 0 && level.from_coarser.is_none() {
                return Err(SolverError::MissingLinks { level: h }.into());
            }
            let mut texels =
                LevelTexels::build(level, params.scheme, coarse).map_err(|e| e.at_level(h))?;
            // The surface normal's w: the node's mean curvature, and its anisotropy (the
            // gather's upstream beam).
            let curvature = crate::quadgraph::surface_samples::surface_node_curvatures(
                level,
                &graph.surface,
                &graph.samples,
            );
            let inner = level.inner_count();
            for (s, k) in curvature.iter().enumerate() {
                let t = texels.packing.linear_index((inner + s) as u32) as usize;
                texels.surface_normal[t][3] = half::f16::from_f64(k.mean);
                let a = k.anisotropy;
                texels.surface_anisotropy[t] = [a.x, a.y, a.z, 0.0].map(half::f16::from_f64);
            }
            let finest = h + 1 == graph.levels.len();
            let gpu = Self::upload_level(
                ctx,
                &pipelines,
                params.precision,
                texels,
                levels.last(),
                finest,
                params.multigrid.as_ref().map(|m| m.finest_operator),
            )?;
            levels.push(gpu);
        }
        let poison = Image::new(
            ctx,
            &ImageDesc {
                name: "diffusion poison",
                width: 1,
                height: 1,
                format: vk::Format::R32G32B32A32_SFLOAT,
                usage: STORAGE_IMAGE,
            },
        )?;
        upload_images(
            ctx,
            "diffusion poison upload",
            &[(&poison, bytes_of(&[f32::NAN; 4]))],
        )?;
        let finest = levels.last().ok_or(SolverError::EmptyGraph)?;
        // Surface rows only: J+ is a surface node's (the pass runs over those rows).
        let j_plus = image(
            ctx,
            "diffusion j+",
            &surface_packing(&finest.packing),
            vk::Format::R32G32B32A32_SFLOAT,
        )?;
        let control = Buffer::new(
            ctx,
            &BufferDesc {
                name: "diffusion control",
                size: (levels.len() * std::mem::size_of::<LevelControl>()) as u64,
                usage: vk::BufferUsageFlags::STORAGE_BUFFER
                    | vk::BufferUsageFlags::INDIRECT_BUFFER
                    | vk::BufferUsageFlags::TRANSFER_DST
                    // TRANSFER_SRC: GpuFrame copies it per frame in flight (host frame reports).
                    | vk::BufferUsageFlags::TRANSFER_SRC,
                memory: MemoryUse::Readback,
            },
        )?;
        let clamp_counts = Buffer::new(
            ctx,
            &BufferDesc {
                name: "diffusion clamp counts",
                size: 16,
                usage: vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
                memory: MemoryUse::Readback,
            },
        )?;
        // Shading weights -> linear texel indices of the finest level.
        let shading = &graph.shading;
        let inner = finest.inner_count;
        let mut links = Vec::with_capacity(shading.links.len().max(1));
        let mut weights = Vec::with_capacity(shading.links.len().max(1));
        for (v, (l, w)) in shading.links.iter().zip(&shading.weights).enumerate() {
            let mut lt = [0u32; 4];
            let mut wt = [0f32; 4];
            for k in 0..4 {
                if l[k] == NO_NODE {
                    continue;
                }
                let node = inner + l[k] as usize;
                if node >= finest.node_count || !w[k].is_finite() {
                    return Err(SolverError::BadGraph {
                        level: levels.len() - 1,
                        problem: format!("vertex {v} links to surface node {} (invalid)", l[k]),
                    }
                    .into());
                }
                lt[k] = finest.packing.linear_index(node as u32);
                wt[k] = w[k] as f32;
            }
            links.push(lt);
            weights.push(wt);
        }
        let vertex_count = links.len() as u32;
        if links.is_empty() {
            links.push([0; 4]);
            weights.push([0.0; 4]);
        }
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let vertex_links = Buffer::with_data(ctx, "diffusion vertex links", storage, &links)?;
        let vertex_weights = Buffer::with_data(ctx, "diffusion vertex weights", storage, &weights)?;
        let mut vertex_j_plus = Buffer::new(
            ctx,
            &BufferDesc {
                name: "diffusion vertex j+",
                size: (links.len() * 16) as u64,
                usage: storage | vk::BufferUsageFlags::VERTEX_BUFFER,
                memory: MemoryUse::Readback,
            },
        )?;
        // Zeros: the interior surface writes no diffused share (the 4th float per vertex, the
        // per-node exit lobe's stream), which then reads as own light.
        vertex_j_plus.write_bytes(0, &vec![0u8; links.len() * 16])?;
        let finest = levels.last().ok_or(SolverError::EmptyGraph)?;
        let j_plus_set = pipelines.j_plus.allocate_set(
            ctx,
            &[
                DescriptorWrite::storage_image("phi", finest.result()),
                DescriptorWrite::storage_image("q", &finest.q),
                DescriptorWrite::storage_image("connectivity", &finest.connectivity),
                DescriptorWrite::storage_image("j_plus", &j_plus),
                DescriptorWrite::storage_image("particular", &finest.particular),
                DescriptorWrite::StorageBuffer {
                    name: "counts",
                    buffer: &clamp_counts,
                },
            ],
        )?;
        let vertex_set = pipelines.vertex.allocate_set(
            ctx,
            &[
                DescriptorWrite::storage_image("j_plus", &j_plus),
                DescriptorWrite::StorageBuffer {
                    name: "vertex_links",
                    buffer: &vertex_links,
                },
                DescriptorWrite::StorageBuffer {
                    name: "vertex_weights",
                    buffer: &vertex_weights,
                },
                DescriptorWrite::StorageBuffer {
                    name: "vertex_j_plus",
                    buffer: &vertex_j_plus,
                },
            ],
        )?;
        let interior = match params.surface {
            SurfaceReconstruction::Shepard => None,
            SurfaceReconstruction::DepthSample => return Err(bad_param(
                "surface",
                "the depth-sampled surface (ray-cast sources per vertex) is CPU only: use Interior"
                    .into(),
            )),
            SurfaceReconstruction::Interior => {
                Self::interior_samples(ctx, graph, &levels[levels.len() - 1])?
            }
        };
        let mut reduce_sets = Vec::with_capacity(levels.len());
        for l in &levels {
            let (latest, previous) = PingPong::new(params.precision).latest();
            let (latest, previous) = (&l.state[latest], &l.state[previous]);
            reduce_sets.push(pipelines.reduce.allocate_set(
                ctx,
                &[
                    DescriptorWrite::storage_image("latest", latest),
                    DescriptorWrite::storage_image("previous", previous),
                    DescriptorWrite::storage_image("phi", l.result()),
                    DescriptorWrite::storage_image("connectivity", &l.connectivity),
                    DescriptorWrite::StorageBuffer {
                        name: "control",
                        buffer: &control,
                    },
                ],
            )?);
        }
        for (l, set) in levels.iter_mut().zip(reduce_sets) {
            l.reduce_set = set;
        }
        // j+ image to GENERAL once.
        ctx.execute("diffusion j+ layout", |cb| {
            // SAFETY: `cb` is recording; the image outlives the waited submission.
            unsafe {
                // why: first use of the J+ image; it is written in GENERAL by every frame.
                barrier::image(
                    ctx,
                    cb,
                    &j_plus,
                    Access::Undefined,
                    Access::ComputeReadWrite,
                );
            }
            Ok(())
        })?;
        let blocks = (0..levels.len())
            .map(|h| {
                let cap = params
                    .iterations
                    .get(h)
                    .or(params.iterations.last())
                    .copied()
                    .unwrap_or(0);
                cap.div_ceil(params.block)
            })
            .collect();
        let mut out = Self {
            params: params.clone(),
            pipelines,
            levels,
            control,
            clamp_counts,
            j_plus,
            j_plus_set,
            vertex_links,
            vertex_weights,
            vertex_j_plus,
            vertex_count,
            vertex_set,
            interior,
            mesh: None,
            ping_pong: PingPong::new(params.precision),
            blocks,
            stats: RecordStats::default(),
            solved: false,
            level_solve: vec![None; graph.levels.len()],
            records: 0,
            q_scale: 1.0,
            f_dr,
            a,
            boundary: super::transport::Boundary::new(eta, params.exit),
            kappa: [0.0; 4],
            mu_gain: [0.0; 4],
            homogeneous: homogeneous.is_some(),
            poison,
            edits: edit::EditState::default(),
            multigrid: None,
        };
        // The material goes in exactly as a later edit does (heterogeneous weights derived on the
        // GPU by the first record), so a fresh solve and an edited one are the same computation.
        out.set_material(ctx, graph, material)?;
        Ok(out)
    }

    /// The boundary model (A, flux gain, exit query) the solve and its J+ pass use.
    pub fn boundary(&self) -> super::transport::Boundary {
        self.boundary
    }

    /// Push constants of the homogeneous path (kappa, 2A, mu, q_gain), zero kappa otherwise.
    pub(crate) fn set_constants(
        &mut self,
        homogeneous: Option<HomogeneousMaterial>,
        a: f64,
        q_gain: f64,
    ) {
        let (k, m) = homogeneous.map_or(([0.0; 3], [0.0; 3]), |h| (h.kappa, h.mu));
        self.kappa = [k[0] as f32, k[1] as f32, k[2] as f32, (2.0 * a) as f32];
        self.mu_gain = [m[0] as f32, m[1] as f32, m[2] as f32, q_gain as f32];
    }

    /// Creates the pipelines of one material variant (specialization constant `HOMOGENEOUS`) and
    /// their descriptor sets on every level, once. The heterogeneous variant needs every level's
    /// per-channel weights to exist.
    pub(crate) fn ensure_variant(&mut self, ctx: &Context, homogeneous: bool) -> Result<(), Error> {
        let v = usize::from(homogeneous);
        if self.pipelines.variants[v].is_none() {
            self.pipelines.variants[v] = Some(Self::variant(
                ctx,
                self.params.precision,
                homogeneous,
                self.derives_weights(),
                self.params.scheme == Scheme::Paper,
                self.levels.len() as u32,
            )?);
        }
        let Some(variant) = &self.pipelines.variants[v] else {
            return Ok(());
        };
        for l in &mut self.levels {
            if !l.iterate_sets[v].is_empty() {
                continue;
            }
            let derived = self.params.heterogeneous_weights == HeterogeneousWeights::Derived;
            let weights = l.weight_images(&self.poison, homogeneous, derived)?;
            let weight_writes = [
                DescriptorWrite::storage_image("weight_geo", &l.geo),
                DescriptorWrite::storage_image("weight_r", weights[0]),
                DescriptorWrite::storage_image("weight_g", weights[1]),
                DescriptorWrite::storage_image("weight_b", weights[2]),
            ];
            let mut sets = Vec::new();
            for (src, dst) in PingPong::SETS.map(|(s, d)| (&l.state[s], &l.state[d])) {
                let mut w = vec![
                    DescriptorWrite::storage_image("src", src),
                    DescriptorWrite::storage_image("dst", dst),
                    DescriptorWrite::storage_image("connectivity", &l.connectivity),
                ];
                w.extend(weight_writes);
                match &l.residual {
                    Some(r) => w.push(DescriptorWrite::storage_image("residual", r)),
                    None => w.push(DescriptorWrite::storage_image("q", &l.q)),
                }
                sets.push(variant.iterate.allocate_set(ctx, &w)?);
            }
            if let (Some(phi), Some(residual), Some(rp)) = (&l.phi, &l.residual, &variant.residual)
            {
                let mut w = vec![
                    DescriptorWrite::storage_image("phi", phi),
                    DescriptorWrite::storage_image("residual", residual),
                    DescriptorWrite::storage_image("delta", &l.state[PingPong::FIRST]),
                    DescriptorWrite::storage_image("q", &l.q),
                    DescriptorWrite::storage_image("connectivity", &l.connectivity),
                ];
                w.extend(weight_writes);
                sets.push(rp.allocate_set(ctx, &w)?);
            }
            l.iterate_sets[v] = sets;
        }
        Ok(())
    }

    /// Whether the heterogeneous sweeps derive their weights ([`HeterogeneousWeights::Derived`]).
    pub(crate) fn derives_weights(&self) -> bool {
        self.params.heterogeneous_weights == HeterogeneousWeights::Derived
    }

    /// The per-level control records ([`LevelControl`]; indirect arguments of the iterations).
    pub fn control_buffer(&self) -> &Buffer {
        &self.control
    }

    /// The parameters the solve was built with.
    pub fn params(&self) -> &GpuSolveParams {
        &self.params
    }

    /// The display mesh [`Self::bind_mesh`] bound, if any.
    pub fn bound_mesh(&self) -> Option<&Arc<GpuMesh>> {
        self.mesh.as_ref().map(|(m, _)| m)
    }

    /// Whether phi holds a solution at the current exposure (a warm start can use it).
    pub fn has_solution(&self) -> bool {
        self.solved
    }

    /// The material variant the iteration shaders run: `homogeneous` reads kappa and mu from
    /// push constants (no per-node material reads), `heterogeneous` reads weights per node.
    pub fn material_variant(&self) -> &'static str {
        if self.homogeneous {
            "homogeneous"
        } else {
            "heterogeneous"
        }
    }

    pub fn level_count(&self) -> usize {
        self.levels.len()
    }

    /// Nodes per level.
    pub fn node_count(&self, level: usize) -> usize {
        self.levels.get(level).map_or(0, |l| l.node_count)
    }

    pub fn surface_position(&self, level: usize) -> Option<&Image> {
        self.levels.get(level).map(|l| &l.surface_position)
    }
    pub fn surface_normal(&self, level: usize) -> Option<&Image> {
        self.levels.get(level).map(|l| &l.surface_normal)
    }

    /// A level's curvature anisotropy per surface node (the gather's upstream beam).
    pub fn surface_anisotropy(&self, level: usize) -> Option<&Image> {
        self.levels.get(level).map(|l| &l.surface_anisotropy)
    }
    /// Rows of `level`'s textures holding surface nodes (what the gather covers).
    pub fn surface_rows(&self, level: usize) -> Option<u32> {
        self.levels.get(level).map(|l| l.packing.surface_rows)
    }
    pub fn q_image(&self, level: usize) -> Option<&Image> {
        self.levels.get(level).map(|l| &l.q)
    }
    /// A level's image of the collimated source's exit-query part (surface rows, rgba16f, times
    /// the exposure), written by the gather when [`GpuSolveParams::collimated`] is on.
    pub fn particular_image(&self, level: usize) -> Option<&Image> {
        self.levels.get(level).map(|l| &l.particular)
    }
    /// A heterogeneous level's per-node kappa and mu images (RGBA32F; `None` for a homogeneous
    /// material, which never created them).
    pub fn material_images(&self, level: usize) -> Option<(&Image, &Image)> {
        self.levels
            .get(level)
            .and_then(|l| l.material.as_ref())
            .map(|[kappa, mu]| (kappa, mu))
    }
    /// The exposure every q (and therefore phi) is stored with.
    pub fn q_scale(&self) -> f32 {
        self.q_scale
    }
    /// Sets the exposure; q already uploaded or gathered must be written again.
    pub fn set_q_scale(&mut self, scale: f32) {
        if scale.is_finite() && scale > 0.0 && scale != self.q_scale {
            self.q_scale = scale;
            // phi is stored times the exposure: last solve's phi is no longer a start.
            self.solved = false;
            self.level_solve.fill(None);
        }
    }
    /// A power-of-two exposure mapping the largest q to about 1024: phi (about 7 q at most) then
    /// stays below 8192, far from fp16's 65504, and q keeps ~10 bits down to 1e-4 of its maximum.
    pub fn exposure_for<'a>(q: impl IntoIterator<Item = &'a [f32; 3]>) -> f32 {
        let max = q
            .into_iter()
            .flatten()
            .filter(|v| v.is_finite())
            .fold(0.0f32, |m, &v| m.max(v.abs()));
        if max > 0.0 {
            (1024.0 / max)
                .log2()
                .floor()
                .exp2()
                .clamp(f32::MIN_POSITIVE, 1e30)
        } else {
            1.0
        }
    }
    /// The per display-vertex J+ buffer (one vec4 per vertex, rgb = clamped J+), written by the
    /// last pass of [`Self::record`] (compute write; a draw reading it as vertex input needs a
    /// compute write -> vertex attribute read barrier).
    pub fn vertex_j_plus_buffer(&self) -> &Buffer {
        &self.vertex_j_plus
    }

    /// Headless: uploads q (by surface index) of `level`, times [`Self::q_scale`], into its q
    /// image. Fails on a wrong length, a negative or non-finite value, or fp16 overflow.
    pub fn upload_q(&mut self, ctx: &Context, level: usize, q: &[[f32; 3]]) -> Result<(), Error> {
        let l = self.levels.get(level).ok_or_else(|| {
            bad_param(
                "level",
                format!("{level} (only {} levels)", self.levels.len()),
            )
        })?;
        let surface = l.node_count - l.inner_count;
        if q.len() != surface {
            return Err(bad_param(
                "q",
                format!(
                    "{} values for {surface} surface nodes of level {level}",
                    q.len()
                ),
            ));
        }
        // phi reaches ~7.2 q (4/(1 - F_dr) at eta = 1.3); keep it inside fp16's range.
        let limit = 65504.0 / 8.0;
        let mut texels = vec![[f16::ZERO; 4]; l.packing.width as usize * l.packing.height as usize];
        for (s, v) in q.iter().enumerate() {
            for &c in v {
                if !(c.is_finite() && c >= 0.0) {
                    return Err(bad_param(
                        "q",
                        format!("surface node {s}: {c} (must be finite, >= 0)"),
                    ));
                }
                if c * self.q_scale > limit {
                    return Err(bad_param(
                        "q",
                        format!(
                            "surface node {s}: {c} times the exposure {} overflows fp16 phi; lower it (GpuDiffusion::exposure_for)",
                            self.q_scale
                        ),
                    ));
                }
            }
            let t = l.packing.linear_index((l.inner_count + s) as u32) as usize;
            texels[t] = [
                f16::from_f32(v[0] * self.q_scale),
                f16::from_f32(v[1] * self.q_scale),
                f16::from_f32(v[2] * self.q_scale),
                f16::ZERO,
            ];
        }
        let staging = Buffer::with_data(
            ctx,
            "diffusion q upload",
            vk::BufferUsageFlags::TRANSFER_SRC,
            &texels,
        )?;
        let img = &l.q;
        ctx.execute("diffusion q upload", |cb| {
            // SAFETY: `cb` is recording; image and staging outlive the waited submission.
            unsafe {
                // why: earlier solves read q (WAR); the copy needs TRANSFER_DST layout.
                barrier::image(ctx, cb, img, Access::ComputeReadWrite, Access::TransferDst);
                img.record_upload_from(ctx, cb, &staging);
                // why: the solve reads the new q (RAW) in GENERAL.
                barrier::image(ctx, cb, img, Access::TransferDst, Access::ComputeReadWrite);
            }
            Ok(())
        })?;
        Ok(())
    }

    /// What the last [`Self::plan`]ned solve records.
    pub fn record_stats(&self) -> RecordStats {
        self.stats
    }

    /// Makes [`Self::record_exitance`] also write the per-vertex J+ into `mesh`'s vertex buffer
    /// (its exitance field, in place): the shading pass then draws the GPU solution with no CPU
    /// round trip. `mesh` must be the graph's display surface; the solve keeps it alive.
    pub fn bind_mesh(&mut self, ctx: &Context, mesh: Arc<GpuMesh>) -> Result<(), Error> {
        if mesh.vertex_count() != self.vertex_count as usize {
            return Err(bad_param(
                "mesh",
                format!(
                    "{} vertices, but the shading weights cover {}",
                    mesh.vertex_count(),
                    self.vertex_count
                ),
            ));
        }
        let set = self.pipelines.vertex.allocate_set(
            ctx,
            &[
                DescriptorWrite::storage_image("j_plus", &self.j_plus),
                DescriptorWrite::StorageBuffer {
                    name: "vertex_links",
                    buffer: &self.vertex_links,
                },
                DescriptorWrite::StorageBuffer {
                    name: "vertex_weights",
                    buffer: &self.vertex_weights,
                },
                DescriptorWrite::StorageBuffer {
                    name: "vertex_j_plus",
                    buffer: mesh.vertex_buffer(),
                },
            ],
        )?;
        self.mesh = Some((mesh, set));
        if let Some(interior) = &mut self.interior {
            // A new mesh: its sets are allocated afresh (the pool has room for a few bindings).
            interior.sets[2] = None;
            interior.sets[3] = None;
        }
        self.ensure_interior_sets(ctx)
    }
}
