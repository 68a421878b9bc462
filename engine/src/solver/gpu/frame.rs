//! [`GpuFrame`]: the whole QuadGraph frame of DESIGN section 5 on the GPU, for hosts and the CLI:
//! shadow maps of the shadow-casting lights and the irradiance gather (part B's
//! `render::shadow_maps` / `render::irradiance`) writing q into the solve's per-level q images,
//! then the [`GpuDiffusion`] solve, in one command buffer. [`GpuFrame::record_parts`] records only
//! the parts a frame needs (the skips of DESIGN section 5, decided by `crate::TranslucentObject`)
//! and keeps per-frame copies of the solve's iteration counters for hosts with frames in flight
//! ([`GpuFrame::completed_solves`]).
//!
//! ```no_run
//! # use translucent::solver::gpu::{GpuFrame, GpuSolveParams};
//! # use translucent::render::HeadlessRenderer;
//! # use translucent::mesh::GpuMesh;
//! # fn f(ctx: &translucent::vk::Context, graph: &translucent::QuadGraph,
//! #      field: &translucent::material::MaterialField, scene: &translucent::scene::Scene,
//! #      renderer: &mut HeadlessRenderer) -> Result<(), translucent::Error> {
//! let mut frame = GpuFrame::new(ctx, graph, field, scene, &GpuSolveParams::default())?;
//! frame.solve.bind_mesh(ctx, renderer.mesh())?; // J+ lands in the displayed mesh's vertices
//! // The shadow caster: the displayed surface (its exitance is not read by the depth pass).
//! let caster = GpuMesh::new(ctx, &graph.surface, &vec![[0.0; 3]; graph.surface.positions.len()])?;
//! let mut failed = None;
//! let captured = renderer.render_frame_after(ctx, |cb, profiler| {
//!     // SAFETY: `cb` is recording; `frame` and `caster` outlive the waited frame.
//!     failed = unsafe { frame.record(ctx, cb, &caster, Some(profiler)) }.err();
//! })?;
//! if let Some(e) = failed { return Err(e); }
//! let report = frame.report(ctx, graph, field, scene, None, &GpuSolveParams::default())?;
//! # Ok(()) }
//! ```

use ash::vk;

use super::{GpuDiffusion, GpuSolveParams, LevelControl};
use crate::material::MaterialField;
use crate::mesh::GpuMesh;
use crate::render::{
    q_scale_for, GatherLevel, GatherScene, IrradiancePass, ShadowMaps, ShadowMapsDesc,
    MAX_SHADOW_VIEWS,
};
use crate::scene::Scene;
use crate::solver::cpu::Energy;
use crate::solver::operator::LevelOperator;
use crate::vk::{barrier, Access, Buffer, BufferDesc, Context, GpuProfiler, MemoryUse};
use crate::{Error, QuadGraph};

/// Shadow maps + irradiance gather + GPU solve of one object.
pub struct GpuFrame {
    pub solve: GpuDiffusion,
    shadows: ShadowMaps,
    gather: IrradiancePass,
    levels: Vec<GatherLevel>,
    uniforms: GatherScene,
    q_scale: f32,
    eta: f32,
    /// Bounding sphere of the finest level's nodes (centre, radius in mm): the shadow views' fit.
    bounds: (glam::DVec3, f64),
    /// Per-frame copies of the solve's control records (one slot per frame in flight, plus one):
    /// the iterations a host frame ran are read once the host reports it complete.
    control_copies: Vec<ControlCopy>,
    /// The scene of the last `set_lights` (a deformation refits its shadow views).
    scene: Scene,
}

/// One slot of [`GpuFrame`]'s control copies: the frame that wrote it, if not read yet.
struct ControlCopy {
    buffer: Buffer,
    frame: Option<u64>,
}

/// Which parts of a frame [`GpuFrame::record_parts`] records (DESIGN section 5 skips).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameParts {
    /// Render the shadow maps (ignored, with nothing recorded, when no light casts shadows).
    pub shadows: bool,
    /// Gather q at the surface nodes of every level.
    pub gather: bool,
    /// Solve, and how.
    pub solve: Option<SolvePlan>,
}

impl FrameParts {
    /// Everything, cold: what [`GpuFrame::record`] records.
    pub const ALL: FrameParts = FrameParts {
        shadows: true,
        gather: true,
        solve: Some(SolvePlan {
            warm: false,
            finest_only: false,
        }),
    };
}

/// How one frame's solve runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SolvePlan {
    /// Start from the last solution (light, material or shape changed a little): every level
    /// iterates from its own last phi, each finer one first corrected by the coarser level's
    /// change (see [`GpuSolveParams::warm_start`]). Ignored, cold instead, when a level to
    /// iterate has no last solution at the current exposure.
    pub warm: bool,
    /// Iterate only the finest level: the small-graph skip (cold, the finest level starts from
    /// zero; warm, from its own last phi with no coarse correction). Measured against the
    /// corrected multi-level warm start in benches/RESULTS.md, "Host frames".
    pub finest_only: bool,
}

/// What [`GpuFrame::record_parts`] actually recorded.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RecordedParts {
    pub shadows: bool,
    pub gather: bool,
    pub solve: bool,
    /// The solve started from the last solution.
    pub warm: bool,
    /// Levels iterated (1 when only the finest).
    pub levels_iterated: u32,
    /// Warm start: levels whose start was corrected by the coarser level's change.
    pub corrected_levels: u32,
}

/// The control records of a solve that completed (see [`GpuFrame::completed_solves`]).
#[derive(Clone, Debug, PartialEq)]
pub struct CompletedSolve {
    /// The host frame that ran it.
    pub frame: u64,
    /// Per level, coarsest first.
    pub levels: Vec<LevelControl>,
}

impl CompletedSolve {
    /// Iterations run per level.
    pub fn iterations(&self) -> Vec<u32> {
        self.levels.iter().map(|l| l.iterations).collect()
    }
    /// Whether every level that iterated stopped at the tolerance before its cap.
    pub fn converged(&self) -> bool {
        self.levels
            .iter()
            .all(|l| l.iterations == 0 || l.stopped_early != 0)
    }
}

/// What [`GpuFrame::report`] computes on the CPU from the GPU's finest-level phi.
#[derive(Clone, Debug)]
pub struct GpuFrameReport {
    /// Relative residual per channel, ||S (b - A phi)|| / ||S b|| (b from the f64 reference q).
    pub residual: [f64; 3],
    pub energy: Energy,
    /// Surface nodes clamped at J+ = 0 per channel (the GPU counter).
    pub clamped: [u32; 3],
    /// Iterations run per level (the GPU counter).
    pub iterations: Vec<u32>,
}

impl GpuFrame {
    /// Builds the solve (textures of every level), the shadow maps for `scene`'s lights and the
    /// gather bound to the solve's q images. The exposure is `render::q_scale_for` of the finest
    /// level (the largest unshadowed q maps to 2048).
    pub fn new(
        ctx: &Context,
        graph: &QuadGraph,
        field: &MaterialField,
        scene: &Scene,
        params: &GpuSolveParams,
    ) -> Result<Self, Error> {
        let mut solve = GpuDiffusion::new(ctx, graph, field, params)?;
        let eta = field.eta();
        let q_scale = q_scale_for(scene, graph.finest(), eta);
        solve.set_q_scale(q_scale);
        let mut shadows = ShadowMaps::new(
            ctx,
            &ShadowMapsDesc {
                max_views: MAX_SHADOW_VIEWS as u32,
                ..ShadowMapsDesc::default()
            },
        )?;
        let bounds = graph.finest().bounding_sphere();
        shadows.set_lights(&scene.lights, bounds, true)?;
        let gather = IrradiancePass::new(ctx, graph.levels.len() as u32)?;
        let mut levels = Vec::with_capacity(graph.levels.len());
        for h in 0..graph.levels.len() {
            let missing = || Error::Solver(super::SolverError::EmptyGraph);
            levels.push(gather.bind_level(
                ctx,
                &shadows,
                solve.surface_position(h).ok_or_else(missing)?,
                solve.surface_normal(h).ok_or_else(missing)?,
                solve.q_image(h).ok_or_else(missing)?,
                solve.surface_rows(h).ok_or_else(missing)?,
            )?);
        }
        let uniforms = GatherScene::new(scene, &shadows)?;
        let control_bytes = solve.control.size;
        let control_copies = (0..=ctx.frames_in_flight())
            .map(|_| {
                Ok(ControlCopy {
                    buffer: Buffer::new(
                        ctx,
                        &BufferDesc {
                            name: "diffusion control copy",
                            size: control_bytes,
                            usage: vk::BufferUsageFlags::TRANSFER_DST,
                            memory: MemoryUse::Readback,
                        },
                    )?,
                    frame: None,
                })
            })
            .collect::<Result<Vec<_>, Error>>()?;
        Ok(Self {
            solve,
            shadows,
            gather,
            levels,
            uniforms,
            q_scale,
            eta: eta as f32,
            bounds,
            control_copies,
            scene: scene.clone(),
        })
    }

    /// New lights and environment for the next [`GpuFrame::record`]: refits the shadow views and
    /// rewrites the gather's scene. The exposure stays unless the new scene's brightest q leaves
    /// the fp16-safe band around it (a factor of 4 either way), so a light moving a little keeps
    /// the last solution usable as a warm start. A bad scene is a typed error and leaves the
    /// previous one in place.
    pub fn set_lights(&mut self, graph: &QuadGraph, scene: &Scene) -> Result<(), Error> {
        let previous = (
            self.shadows.views().to_vec(),
            self.shadows.light_views().to_vec(),
        );
        self.shadows.set_lights(&scene.lights, self.bounds, true)?;
        let uniforms = match GatherScene::new(scene, &self.shadows) {
            Ok(u) => u,
            Err(e) => {
                self.shadows.restore(previous);
                return Err(e.into());
            }
        };
        self.uniforms = uniforms;
        self.scene = scene.clone();
        let wanted = q_scale_for(scene, graph.finest(), f64::from(self.eta));
        let ratio = wanted / self.q_scale;
        if !(0.25..=4.0).contains(&ratio) {
            self.q_scale = wanted;
            self.solve.set_q_scale(wanted);
        }
        Ok(())
    }

    /// The exposure q and phi are stored at (see [`GpuDiffusion::q_scale`]).
    pub fn q_scale(&self) -> f32 {
        self.q_scale
    }

    /// Whether the current lights cast any shadow (otherwise the frame records no shadow pass).
    pub fn casts_shadows(&self) -> bool {
        self.shadows.any_shadows()
    }

    /// The shadow atlas (the shading pass reads it for the specular term's shadow).
    pub fn shadows(&self) -> &ShadowMaps {
        &self.shadows
    }

    /// Whether the solve holds a solution at the current exposure (a warm start can use it).
    pub fn has_solution(&self) -> bool {
        self.solve.solved
    }

    /// Nodes of the finest level (the small-graph skip's measure).
    pub fn finest_nodes(&self) -> usize {
        self.solve.levels.last().map_or(0, |l| l.node_count)
    }

    /// The material variant the solve's iteration shaders run: `homogeneous` reads kappa and mu
    /// from push constants (no per-node material reads), `heterogeneous` reads weights per node.
    pub fn material_variant(&self) -> &'static str {
        if self.solve.homogeneous {
            "homogeneous"
        } else {
            "heterogeneous"
        }
    }

    /// Records shadow maps (cast by `caster`, the displayed mesh), the gather of every level and
    /// a solve of every level: cold, or warm when [`GpuSolveParams::warm_start`] is set (and a
    /// last solution exists).
    ///
    /// # Safety
    /// `cb` must be recording outside a rendering scope; `self` and `caster` must outlive its
    /// execution.
    pub unsafe fn record(
        &mut self,
        ctx: &Context,
        cb: vk::CommandBuffer,
        caster: &GpuMesh,
        profiler: Option<&mut GpuProfiler>,
    ) -> Result<(), Error> {
        let (frame, _) = ctx.frames();
        let parts = FrameParts {
            solve: Some(SolvePlan {
                warm: self.solve.params.warm_start,
                finest_only: false,
            }),
            ..FrameParts::ALL
        };
        // SAFETY: the caller's contract.
        unsafe { self.record_parts(ctx, cb, caster, &parts, frame, profiler) }?;
        Ok(())
    }

    /// Records the parts of the frame `parts` asks for. The shadow atlas and q images keep
    /// their contents from the last frame that wrote them, so a skipped part leaves what the
    /// following parts read valid as long as its inputs did not change. A recorded solve also
    /// copies its control records for [`GpuFrame::completed_solves`] (keyed by `frame`).
    ///
    /// # Safety
    /// As [`GpuFrame::record`].
    pub unsafe fn record_parts(
        &mut self,
        ctx: &Context,
        cb: vk::CommandBuffer,
        caster: &GpuMesh,
        parts: &FrameParts,
        frame: u64,
        mut profiler: Option<&mut GpuProfiler>,
    ) -> Result<RecordedParts, Error> {
        let mut done = RecordedParts::default();
        // SAFETY: the caller's contract.
        unsafe {
            // Staged material and deformation edits first: the shadow pass draws the deformed
            // caster, the gather reads the deformed surface nodes.
            self.solve.record_edits(ctx, cb, profiler.as_deref_mut());
            // The first frame always runs it: it also moves the atlas into the layout the
            // descriptors name (with no shadow-casting light that is all it records).
            if parts.shadows || self.shadows.atlas_state == Access::Undefined {
                done.shadows = self.shadows.any_shadows();
                self.shadows
                    .record(ctx, cb, caster, profiler.as_deref_mut());
            }
            if parts.gather {
                done.gather = true;
                self.gather.record_scene(ctx, cb, &self.uniforms);
                for (h, level) in self.levels.iter().enumerate() {
                    let Some(q) = self.solve.q_image(h) else {
                        continue;
                    };
                    // q stays in GENERAL between frames; the solve's first barrier orders its reads.
                    self.gather.record(
                        ctx,
                        cb,
                        level,
                        &self.shadows,
                        q,
                        Access::ComputeReadWrite,
                        self.q_scale,
                        self.eta,
                        profiler.as_deref_mut(),
                    )?;
                }
            }
            if let Some(plan) = parts.solve {
                let levels = self.solve.levels.len();
                let caps = self.solve.blocks.clone();
                if plan.finest_only {
                    for b in &mut self.solve.blocks[..levels - 1] {
                        *b = 0;
                    }
                }
                let previous_warm = self.solve.params.warm_start;
                self.solve.params.warm_start = plan.warm;
                self.solve.record(ctx, cb, profiler);
                let warm = self.solve.stats.warm;
                self.solve.params.warm_start = previous_warm;
                self.solve.blocks = caps;
                done.solve = true;
                done.warm = warm;
                done.levels_iterated = if plan.finest_only { 1 } else { levels as u32 };
                done.corrected_levels = self.solve.stats.corrected_levels;
                self.record_control_copy(ctx, cb, frame);
            }
        }
        Ok(done)
    }

    /// Copies the control records into the slot of `frame` for a later host read.
    ///
    /// # Safety
    /// As [`GpuFrame::record`], after the solve.
    unsafe fn record_control_copy(&mut self, ctx: &Context, cb: vk::CommandBuffer, frame: u64) {
        use vk::AccessFlags2 as A;
        use vk::PipelineStageFlags2 as S;
        let slots = self.control_copies.len() as u64;
        let slot = &mut self.control_copies[(frame % slots) as usize];
        slot.frame = Some(frame);
        let size = self.solve.control.size;
        let to_copy = vk::MemoryBarrier2::default()
            .src_stage_mask(S::COMPUTE_SHADER)
            .src_access_mask(A::SHADER_STORAGE_WRITE)
            .dst_stage_mask(S::COPY)
            .dst_access_mask(A::TRANSFER_READ);
        let to_host = barrier::memory_barrier(Access::TransferDst, Access::HostRead);
        // SAFETY: the caller's contract; both buffers hold `size` bytes.
        unsafe {
            // why: the copy reads the control records the reductions wrote (RAW).
            barrier::record(ctx, cb, &[to_copy], &[]);
            ctx.raw().cmd_copy_buffer(
                cb,
                self.solve.control.raw,
                slot.buffer.raw,
                &[vk::BufferCopy {
                    src_offset: 0,
                    dst_offset: 0,
                    size,
                }],
            );
            // why: the host reads the copy after the frame's fence (host visibility), and the
            // next frame's control reset must not overwrite the source before the copy (WAR).
            barrier::record(
                ctx,
                cb,
                &[
                    to_host,
                    vk::MemoryBarrier2::default()
                        .src_stage_mask(S::COPY)
                        .dst_stage_mask(S::COPY | S::CLEAR),
                ],
                &[],
            );
        }
    }

    /// The control records of every recorded solve whose frame is `<= completed` and was not
    /// returned before, oldest first. Reads host memory only: no wait, no submission.
    pub fn completed_solves(&mut self, completed: u64) -> Result<Vec<CompletedSolve>, Error> {
        let mut out = Vec::new();
        for slot in &mut self.control_copies {
            let Some(frame) = slot.frame.filter(|&f| f <= completed) else {
                continue;
            };
            slot.frame = None;
            let bytes = slot.buffer.read_bytes()?;
            out.push(CompletedSolve {
                frame,
                levels: bytes
                    .chunks_exact(std::mem::size_of::<LevelControl>())
                    .map(bytemuck::pod_read_unaligned)
                    .collect(),
            });
        }
        out.sort_by_key(|s| s.frame);
        Ok(out)
    }

    /// Headless, after the frame completed: residual and energy of the finest level from the GPU's
    /// phi, computed in f64 with the reference's q (`Scene::surface_irradiance` with `occluder`),
    /// which the gathered q approximates (fp16, shadow maps instead of rays).
    pub fn report(
        &self,
        ctx: &Context,
        graph: &QuadGraph,
        field: &MaterialField,
        scene: &Scene,
        occluder: Option<&dyn crate::mesh::Solid>,
        params: &GpuSolveParams,
    ) -> Result<GpuFrameReport, Error> {
        let level = graph.finest();
        let op = LevelOperator::build(level, field, params.scheme)?;
        let q = scene.surface_irradiance(level, field.eta(), occluder);
        let b = op.rhs(&q);
        let phi: Vec<[f64; 3]> = self
            .solve
            .read_phi(ctx, graph.levels.len() - 1)?
            .iter()
            .map(|p| p.map(f64::from))
            .collect();
        let residual = op.residual(&phi, &b);
        let inner = level.inner_count();
        let mut energy = Energy::default();
        for s in 0..level.surface_count() {
            for c in 0..3 {
                let j = (1.0 + 1.0 / op.a) * phi[inner + s][c] / 4.0 - q[s][c] / (1.0 + op.f_dr);
                energy.transmitted_input[c] += q[s][c] * op.areas[s];
                energy.exitance[c] += (1.0 - op.f_dr) * j * op.areas[s];
            }
        }
        for ((mu, p), v) in op.mu.iter().zip(&phi[..inner]).zip(&op.volumes) {
            for c in 0..3 {
                energy.absorbed[c] += mu[c] * p[c] * v;
            }
        }
        Ok(GpuFrameReport {
            residual,
            energy,
            clamped: self.solve.clamped(ctx)?,
            iterations: self.solve.iterations_run(ctx)?,
        })
    }
}

/// Hooks of the live edits (`edit.rs`, branch gpuedit).
impl GpuFrame {
    /// The gather's eta after a material edit.
    pub(super) fn set_eta(&mut self, eta: f64) {
        self.eta = eta as f32;
    }

    /// The bounding sphere (centre, radius in mm) the shadow views are fitted to.
    pub fn shadow_bounds(&self) -> (glam::DVec3, f64) {
        self.bounds
    }

    /// Refits the shadow views to a deformed object's bounding sphere.
    pub(super) fn refit_bounds(&mut self, bounds: (glam::DVec3, f64)) -> Result<(), Error> {
        self.shadows.set_lights(&self.scene.lights, bounds, true)?;
        self.uniforms = GatherScene::new(&self.scene, &self.shadows)?;
        self.bounds = bounds;
        Ok(())
    }
}
