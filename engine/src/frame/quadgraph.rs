//! [`QuadGraphMethod`]: the QuadGraph frame of DESIGN section 5 behind the method seam. Per frame
//! (as [`super::FramePlan`] decides): the staged edits ([`PASS_EDITS`]), then after the shared
//! shadow maps the irradiance gather writing q at every level's surface nodes ([`PASS_GATHER`]),
//! the multi-level solve ([`PASS_SOLVE`]: Shepard initialisation or warm start, Jacobi blocks,
//! convergence on the GPU) and J+ into the display mesh ([`PASS_EXITANCE`]). The iterations a
//! solve ran come back once the host reports its frame complete
//! ([`QuadGraphMethod::completed`]).
//!
//! ```no_run
//! # use std::sync::Arc;
//! # use translucent::{TranslucentObject, ObjectParams, frame::QuadGraphMethod};
//! # fn f(object: &TranslucentObject, ctx: &translucent::vk::Context,
//! #      field: &translucent::material::MaterialField, scene: &translucent::scene::Scene)
//! #      -> Result<(), translucent::Error> {
//! // After a headless frame completed: residual and energy of the GPU solution, in f64.
//! if let Some(q) = object.method().as_any().downcast_ref::<QuadGraphMethod>() {
//!     let report = q.report(ctx, field, scene, None)?;
//!     println!("residual {:?}, iterations {:?}", report.residual, report.iterations);
//! }
//! # Ok(()) }
//! ```

use std::sync::Arc;

use ash::vk;
use glam::DVec3;

use super::bounce::{
    BounceSourcePass, NodeGather, PASS_BOUNCE_EXITANCE, PASS_BOUNCE_KEEP, PASS_BOUNCE_RESTORE,
    PASS_BOUNCE_SOLVE, PASS_BOUNCE_SOURCE,
};
use super::graph::FrameGraph;
use super::method::{Method, MethodFrame};
use super::plan::{MethodWork, Update};
use super::report::{CompletedSolve, SkipReason};
use crate::material::MaterialField;
use crate::mesh::GpuMesh;
use crate::render::{
    q_scale_for, BeamSource, GatherLevel, GatherScene, IrradiancePass, ShadowMaps,
};
use crate::scene::Scene;
use crate::solver::cpu::Energy;
use crate::solver::gpu::edit::StagedEdits;
use crate::solver::gpu::multigrid::MultigridControl;
use crate::solver::gpu::{
    Deformation, GpuDiffusion, GpuSolveParams, LevelControl, SolvePlan, PASS_EXITANCE, PASS_SOLVE,
};
use crate::solver::SolverError;
use crate::vk::barrier::Use;
use crate::vk::{Access, Buffer, BufferDesc, Context, MemoryUse};
use crate::{Error, QuadGraph};

/// The staged edits' pass (uploads, deformation, mesh rewrite, weight derivation).
pub const PASS_EDITS: &str = "edits";
/// The irradiance gather at every level's surface nodes.
pub const PASS_GATHER: &str = "gather_q";
/// The Shepard initialisation, left out by a warm start (a part of [`PASS_SOLVE`]).
pub const PART_INIT: &str = "diffusion init";
/// The coarse levels, left out on a small graph (a part of [`PASS_SOLVE`]).
pub const PART_COARSE: &str = "diffusion coarse levels";

/// Below this many finest-level nodes a cold solve iterates the finest level only. Chosen by
/// measurement (benches/RESULTS.md, "Host frames", part (c), lavapipe): a one-level cold solve of
/// a sphere was faster at 4248 finest nodes (307 vs 363 ms), even at 11952 and 2x-5x slower from
/// 26592 up, and it always runs more iterations (dispatches), which a GPU with per-dispatch cost
/// pays for: the threshold stays below the smallest graph where it was measured to win.
pub const SINGLE_LEVEL_NODES: usize = 4096;

/// What [`QuadGraphMethod::report`] computes on the CPU from the GPU's finest-level phi.
#[derive(Clone, Debug)]
pub struct QuadGraphReport {
    /// Relative residual per channel, ||S (b - A phi)|| / ||S b|| (b from the f64 reference q).
    pub residual: [f64; 3],
    pub energy: Energy,
    /// Surface nodes clamped at J+ = 0 per channel (the GPU counter).
    pub clamped: [u32; 3],
    /// Iterations run per level (the GPU counter).
    pub iterations: Vec<u32>,
}

/// One slot of the per-frame copies of the solve's control records.
struct ControlCopy {
    buffer: Buffer,
    frame: Option<u64>,
    /// Whether that frame's solve started warm (the multigrid's report counts its start).
    warm: bool,
    /// `--bounce source`'s second solve of the same frame writes here (its record would
    /// otherwise replace the first's).
    bounce: Buffer,
    /// Whether that frame ran the second solve, and whether it started warm.
    bounce_warm: Option<bool>,
}

/// This frame's work, decided by [`Method::prepare`].
#[derive(Default)]
struct Prepared {
    edits: Option<StagedEdits>,
    solve: Option<SolvePlan>,
    /// The control-copy slot this frame's solve writes.
    slot: usize,
    /// The second, warm-started solve with the bounced light as a source (`--bounce source`).
    bounce_solve: Option<SolvePlan>,
    /// The first solve starts warm from the last frame's first solution ([`KeptX`]).
    restore_x: bool,
}

/// `--bounce source` under the multigrid: the first solve's finest x, copied before the second
/// solve and back before the next frame's first. Without it the next first solve would start
/// from the second's solution, a whole bounce away from its own problem (the default scene's
/// warm frames: 51.3 work units against 29.7 without the bounce; benches/RESULTS.md "Lead notes
/// after the wave-13 merge").
struct KeptX {
    buffer: Buffer,
    /// Whether `buffer` holds the last solving frame's first solution.
    valid: bool,
}

/// The QuadGraph method (see the module doc).
pub struct QuadGraphMethod {
    graph: Arc<QuadGraph>,
    solve: GpuDiffusion,
    gather: IrradiancePass,
    levels: Vec<GatherLevel>,
    /// The gather at the display vertices (`solver::gpu::interior::VertexGather`), after the
    /// levels: the interior pass's own visibility.
    vertex_level: Option<GatherLevel>,
    uniforms: GatherScene,
    q_scale: f32,
    eta: f32,
    /// Per-frame copies of the solve's control records (one slot per frame in flight, plus one):
    /// the iterations a host frame ran are read once the host reports it complete.
    control_copies: Vec<ControlCopy>,
    single_level_nodes: usize,
    prepared: Prepared,
    /// [`crate::frame::BounceMode::Source`]'s pass (q += q_scale T_d E_b), when on.
    bounce_source: Option<BounceSourcePass>,
    /// The second solve's tolerance relative to its start ([`Self::set_bounce_tolerance`]).
    bounce_tolerance: f32,
    /// The first solve's x across the second (with the bounce source and the multigrid).
    kept_x: Option<KeptX>,
}

/// The gather's collimated source (DESIGN 2.7) for the solve's boundary model: on when the solve
/// asks for it; a homogeneous material passes its coefficients, a heterogeneous one has the
/// gather read each node's own (`local`, from the level's kappa and mu images).
fn beam_source(solve: &GpuDiffusion, field: &MaterialField) -> Option<BeamSource> {
    let params = solve.params();
    if !params.collimated {
        return None;
    }
    let (sigma_s, sigma_a, kappa, local) = match field {
        MaterialField::Homogeneous(m) => {
            let c = m.coefficients();
            (
                c.sigma_s.map(|v| v as f32),
                c.sigma_a.map(|v| v as f32),
                m.kappa().map(|v| v as f32),
                false,
            )
        }
        _ => ([0.0; 3], [0.0; 3], [0.0; 3], true),
    };
    let b = solve.boundary();
    Some(BeamSource {
        sigma_s,
        sigma_a,
        kappa,
        diffusion: field.diffusion(),
        a: b.a as f32,
        exit_phi: (0.25 * (1.0 - 2.0 * b.c1)) as f32,
        exit_flux: (0.5 * (1.0 - 3.0 * b.c2)) as f32,
        flux_gain: b.flux_gain as f32,
        local,
        second_collision: params.second_collision,
        shadow_edge_flux: params.shadow_edge_flux,
        continuation: params.continuation,
        upstream: params.upstream_beam,
        curved: params.curved_particular,
    })
}

/// How a [`QuadGraphMethod`] solves.
#[derive(Clone, Debug)]
pub struct QuadGraphParams {
    pub solve: GpuSolveParams,
    /// Finest-level node count below which a cold solve iterates one level.
    pub single_level_nodes: usize,
}

impl QuadGraphMethod {
    /// Builds the solve (textures of every level) and the gather bound to the solve's q images
    /// and the shared `shadows`; J+ will be written into `mesh` (the graph's display surface).
    /// The exposure is `render::q_scale_for` of the finest level. A cold solve iterates only the
    /// finest level below `single_level_nodes` finest nodes.
    pub fn new(
        ctx: &Context,
        graph: Arc<QuadGraph>,
        field: &MaterialField,
        scene: &Scene,
        params: &QuadGraphParams,
        shadows: &ShadowMaps,
        mesh: Arc<GpuMesh>,
    ) -> Result<Self, Error> {
        let single_level_nodes = params.single_level_nodes;
        let mut solve = GpuDiffusion::new(ctx, &graph, field, &params.solve)?;
        solve.bind_mesh(ctx, mesh)?;
        let eta = field.eta();
        let q_scale = q_scale_for(scene, graph.finest(), eta);
        solve.set_q_scale(q_scale);
        let mut gather = IrradiancePass::new(ctx, graph.levels.len() as u32 + 1)?;
        // The environment's transmitted fraction of the solve's boundary model (DESIGN 2.6).
        gather.env_transmittance = Some(solve.boundary().diffuse_transmittance() as f32);
        gather.beam = beam_source(&solve, field);
        let mut levels = Vec::with_capacity(graph.levels.len());
        for h in 0..graph.levels.len() {
            let missing = || Error::Solver(SolverError::EmptyGraph);
            levels.push(gather.bind_level_with(
                ctx,
                shadows,
                solve.surface_position(h).ok_or_else(missing)?,
                solve.surface_normal(h).ok_or_else(missing)?,
                solve.surface_anisotropy(h).ok_or_else(missing)?,
                solve.q_image(h).ok_or_else(missing)?,
                solve.particular_image(h).ok_or_else(missing)?,
                solve.material_images(h),
                solve.surface_rows(h).ok_or_else(missing)?,
            )?);
        }
        let vertex_level = match solve.vertex_gather() {
            Some(v) => Some(gather.bind_level_with(
                ctx,
                shadows,
                &v.position,
                &v.normal,
                &v.anisotropy,
                &v.q,
                &v.particular,
                None,
                v.rows,
            )?),
            None => None,
        };
        let uniforms = GatherScene::new(scene, shadows)?;
        let copy = |name| {
            Buffer::new(
                ctx,
                &BufferDesc {
                    name,
                    size: solve.control_copy_size(),
                    usage: vk::BufferUsageFlags::TRANSFER_DST,
                    memory: MemoryUse::Readback,
                },
            )
        };
        let control_copies = (0..=ctx.frames_in_flight())
            .map(|_| {
                Ok(ControlCopy {
                    buffer: copy("diffusion control copy")?,
                    frame: None,
                    warm: false,
                    bounce: copy("bounce solve control copy")?,
                    bounce_warm: None,
                })
            })
            .collect::<Result<Vec<_>, Error>>()?;
        Ok(QuadGraphMethod {
            graph,
            solve,
            gather,
            levels,
            vertex_level,
            uniforms,
            q_scale,
            eta: eta as f32,
            control_copies,
            single_level_nodes,
            prepared: Prepared::default(),
            bounce_source: None,
            bounce_tolerance: crate::defaults::BOUNCE_TOLERANCE,
            kept_x: None,
        })
    }

    /// [`crate::frame::BounceMode::Source`]: the bounce pass's `irradiance` (E_b per display
    /// vertex) becomes a source of a second solve every frame that solves ([`NodeGather`] of the
    /// graph's finest surface nodes); `None`: off. The buffer must outlive this method or the
    /// next call.
    pub fn set_bounce_source(
        &mut self,
        ctx: &Context,
        irradiance: Option<&Buffer>,
    ) -> Result<(), Error> {
        self.bounce_source = None;
        self.kept_x = None;
        let Some(irradiance) = irradiance else {
            return Ok(());
        };
        if let Some(mg) = &self.solve.multigrid {
            self.kept_x = Some(KeptX {
                buffer: Buffer::new(
                    ctx,
                    &BufferDesc {
                        name: "bounce kept x",
                        size: mg.finest_x().2,
                        usage: vk::BufferUsageFlags::TRANSFER_SRC
                            | vk::BufferUsageFlags::TRANSFER_DST,
                        memory: MemoryUse::GpuOnly,
                    },
                )?,
                valid: false,
            });
        }
        let finest = self.graph.finest();
        let texels: Vec<u32> = (finest.inner_count()..finest.positions.len())
            .map(|node| finest.packing.linear_index(node as u32))
            .collect();
        let gather = NodeGather::build(&self.graph);
        let q = self
            .solve
            .q_image(self.graph.levels.len() - 1)
            .ok_or(Error::Solver(SolverError::EmptyGraph))?;
        self.bounce_source = Some(BounceSourcePass::new(
            ctx,
            &gather,
            &texels,
            finest.packing.width,
            irradiance,
            q,
            self.graph.surface.positions.len(),
        )?);
        Ok(())
    }

    /// [`crate::frame::BounceMode::Source`]'s second solve stops below `relative` times its
    /// start residual (the bounce's share of q: it starts from the first solve's solution) or at
    /// the solve's tolerance, whichever comes first; 0: the solve's tolerance alone. In [0, 1)
    /// (else a typed error); default [`crate::defaults::BOUNCE_TOLERANCE`]. From the next frame.
    pub fn set_bounce_tolerance(&mut self, relative: f32) -> Result<(), Error> {
        if !(relative.is_finite() && (0.0..1.0).contains(&relative)) {
            return Err(Error::Solver(SolverError::Invalid(format!(
                "bounce tolerance {relative}: must be in [0, 1)"
            ))));
        }
        self.bounce_tolerance = relative;
        Ok(())
    }

    /// The bounce source's pass, when on.
    pub fn bounce_source(&self) -> Option<&BounceSourcePass> {
        self.bounce_source.as_ref()
    }

    /// The GPU solve (textures, read-backs, record statistics).
    pub fn solve(&self) -> &GpuDiffusion {
        &self.solve
    }

    /// The baked graph.
    pub fn graph(&self) -> &QuadGraph {
        &self.graph
    }

    /// The exposure q and phi are stored at (see [`GpuDiffusion::q_scale`]).
    pub fn q_scale(&self) -> f32 {
        self.q_scale
    }

    /// Nodes of the finest level (the small-graph skip's measure).
    pub fn finest_nodes(&self) -> usize {
        self.solve.node_count(self.graph.levels.len() - 1)
    }

    /// Headless, after the frame completed: residual and energy of the finest level from the
    /// GPU's phi, computed in f64 with the reference's sources for the solve's light source
    /// ([`crate::solver::cpu::balance`], lights ray-cast against `occluder`), which the gathered
    /// q approximates (fp16, shadow maps instead of rays).
    pub fn report(
        &self,
        ctx: &Context,
        field: &MaterialField,
        scene: &Scene,
        occluder: Option<&dyn crate::mesh::Solid>,
    ) -> Result<QuadGraphReport, Error> {
        let phi: Vec<[f64; 3]> = self
            .solve
            .read_phi(ctx, self.graph.levels.len() - 1)?
            .iter()
            .map(|p| p.map(f64::from))
            .collect();
        // The f64 reference's sources for the solve's light source (a beam source's particular
        // solution and exit query included): the boundary flux alone under-reports a beam
        // source's exitance (1196 -> 879 with `second`, benches/RESULTS.md "Loose ends").
        let params = self.solve.params();
        let (residual, energy) = crate::solver::cpu::balance(
            &self.graph,
            field,
            scene,
            occluder,
            params.scheme,
            params.transport(),
            &phi,
        )?;
        Ok(QuadGraphReport {
            residual,
            energy,
            clamped: self.solve.clamped(ctx)?,
            iterations: self.solve.iterations_run(ctx)?,
        })
    }

    /// The gather's uses of one frame: the shadow atlas, every level's surface geometry and q.
    fn gather_uses<'a>(&'a self, shadows: &'a ShadowMaps) -> Vec<Use<'a>> {
        let mut uses = vec![Use::image(&shadows.atlas, Access::DepthSampledShaders)];
        for h in 0..self.levels.len() {
            for img in [
                self.solve.surface_position(h),
                self.solve.surface_normal(h),
                self.solve.surface_anisotropy(h),
            ]
            .into_iter()
            .flatten()
            {
                uses.push(Use::image(img, Access::ComputeRead));
            }
            if let Some(q) = self.solve.q_image(h) {
                uses.push(Use::image(q, Access::ComputeWrite));
            }
            if let Some(p) = self.solve.particular_image(h) {
                uses.push(Use::image(p, Access::ComputeWrite));
            }
            // A heterogeneous material's beam reads each node's coefficients.
            if let Some((kappa, mu)) = self.solve.material_images(h) {
                uses.push(Use::image(kappa, Access::ComputeRead));
                uses.push(Use::image(mu, Access::ComputeRead));
            }
        }
        if let Some(v) = self.solve.vertex_gather() {
            for img in [&v.position, &v.normal, &v.anisotropy] {
                uses.push(Use::image(img, Access::ComputeRead));
            }
            for img in [&v.q, &v.particular] {
                uses.push(Use::image(img, Access::ComputeWrite));
            }
        }
        uses
    }
}

impl Method for QuadGraphMethod {
    fn name(&self) -> &'static str {
        "quadgraph"
    }

    /// Rewrites the gather's scene. The exposure stays unless the new scene's brightest q leaves
    /// the fp16-safe band around it (a factor of 4 either way), so a light moving a little keeps
    /// the last solution usable as a warm start.
    fn set_lights(&mut self, scene: &Scene, shadows: &ShadowMaps) -> Result<(), Error> {
        self.uniforms = GatherScene::new(scene, shadows)?;
        let wanted = q_scale_for(scene, self.graph.finest(), f64::from(self.eta));
        let ratio = wanted / self.q_scale;
        if !(0.25..=4.0).contains(&ratio) {
            self.q_scale = wanted;
            self.solve.set_q_scale(wanted);
        }
        Ok(())
    }

    fn set_material(&mut self, ctx: &Context, field: &MaterialField) -> Result<(), Error> {
        self.solve.set_material(ctx, &self.graph, field)?;
        self.eta = field.eta() as f32;
        self.gather.env_transmittance = Some(self.solve.boundary().diffuse_transmittance() as f32);
        self.gather.beam = beam_source(&self.solve, field);
        Ok(())
    }

    fn deform(&mut self, ctx: &Context, deformation: &Deformation) -> Result<(DVec3, f64), Error> {
        let mesh = self.solve.bound_mesh().cloned();
        self.solve
            .deform(ctx, &self.graph, deformation, mesh.as_slice())?;
        let level = self.graph.finest();
        let points: Vec<DVec3> = match deformation {
            Deformation::TetPositions(_) => {
                deformation.level_vertices(self.graph.levels.len() - 1, level)
            }
            _ => level
                .positions
                .iter()
                .map(|&p| deformation.map_point(p).unwrap_or(p))
                .collect(),
        };
        Ok(crate::mesh::bounding_sphere(&points))
    }

    fn has_solution(&self) -> bool {
        self.solve.has_solution()
    }

    fn material_variant(&self) -> &'static str {
        self.solve.material_variant()
    }

    fn prepare(&mut self, work: MethodWork, frame: u64) -> Result<MethodFrame, Error> {
        let edits = self.solve.take_edits();
        let mut out = MethodFrame {
            moves_mesh: edits.as_ref().is_some_and(StagedEdits::moves_mesh),
            ..MethodFrame::default()
        };
        if edits.is_none() {
            out.skipped.push((PASS_EDITS, SkipReason::NoEdits));
        }
        if let MethodWork::Skip(why) = work {
            for pass in [PASS_GATHER, PASS_SOLVE, PASS_EXITANCE] {
                out.skipped.push((pass, why));
            }
        }
        let levels = self.graph.levels.len();
        let solve = work.update().map(|u| {
            let small = self.finest_nodes() < self.single_level_nodes;
            let plan = self.solve.plan(u == Update::Warm, small);
            if plan.warm {
                out.skipped.push((PART_INIT, SkipReason::WarmStart));
            }
            if (plan.levels_iterated() as usize) < levels {
                out.skipped.push((PART_COARSE, SkipReason::SmallGraph));
            }
            out.warm_start = plan.warm;
            out.levels_iterated = plan.levels_iterated();
            plan
        });
        let slots = self.control_copies.len() as u64;
        let slot = (frame % slots) as usize;
        if let Some(plan) = &solve {
            self.control_copies[slot].frame = Some(frame);
            self.control_copies[slot].warm = plan.warm;
        }
        self.control_copies[slot].bounce_warm = None;
        // The bounce's second solve starts from the first (warm, same exposure).
        let bounce_solve = match (&solve, &self.bounce_source) {
            (Some(_), Some(_)) => {
                let small = self.finest_nodes() < self.single_level_nodes;
                // It solves for the bounce's share: converged relative to that share.
                let mut plan = self.solve.plan(true, small);
                plan.start_tolerance = self.bounce_tolerance;
                Some(plan)
            }
            _ => None,
        };
        if let Some(plan) = &bounce_solve {
            // Its control record goes to the slot's second copy.
            self.control_copies[slot].bounce_warm = Some(plan.warm);
        }
        // A warm first solve continues the last first solution (kept before that frame's second
        // solve); a frame that solves keeps its own when it runs the second solve.
        let mut restore_x = false;
        if let (Some(plan), Some(kept)) = (&solve, &mut self.kept_x) {
            restore_x = plan.warm && kept.valid && bounce_solve.is_some();
            kept.valid = bounce_solve.is_some();
        }
        self.prepared = Prepared {
            edits,
            solve,
            slot,
            bounce_solve,
            restore_x,
        };
        Ok(out)
    }

    fn add_edit_passes<'g>(&'g self, graph: &mut FrameGraph<'g>) {
        // The staged edits are held until the next `prepare`, released after the frame
        // completes.
        if let Some(edits) = &self.prepared.edits {
            add_edits_pass(graph, &self.solve, edits);
        }
    }

    fn add_passes<'g>(
        &'g self,
        graph: &mut FrameGraph<'g>,
        shadows: &'g ShadowMaps,
    ) -> Result<(), Error> {
        let Some(plan) = &self.prepared.solve else {
            return Ok(());
        };
        graph
            .pass(PASS_GATHER)
            .uses(self.gather_uses(shadows))
            .record(move |p| {
                // SAFETY: inside the graph's pass declaring the gather's uses; everything lives
                // in `self` and `shadows`, which outlive the frame.
                unsafe {
                    self.gather.record_scene(p.ctx, p.cb, &self.uniforms);
                    for (h, level) in self.levels.iter().enumerate() {
                        self.gather
                            .record(p.ctx, p.cb, level, self.q_scale, self.eta)
                            .map_err(|e| {
                                Error::Solver(SolverError::Invalid(format!("level {h}: {e}")))
                            })?;
                    }
                    if let Some(level) = &self.vertex_level {
                        self.gather
                            .record(p.ctx, p.cb, level, self.q_scale, self.eta)
                            .map_err(|e| {
                                Error::Solver(SolverError::Invalid(format!("vertices: {e}")))
                            })?;
                    }
                }
                Ok(())
            });
        if let (true, Some(kept), Some(mg)) =
            (self.prepared.restore_x, &self.kept_x, &self.solve.multigrid)
        {
            add_copy_pass(graph, PASS_BOUNCE_RESTORE, kept, mg.finest_x(), false);
        }
        let slot = &self.control_copies[self.prepared.slot].buffer;
        add_solve_passes(graph, &self.solve, plan, Some(slot), false);
        Ok(())
    }

    fn add_bounce_passes<'g>(&'g self, graph: &mut FrameGraph<'g>, irradiance: &'g Buffer) {
        let (Some(source), Some(plan)) = (&self.bounce_source, &self.prepared.bounce_solve) else {
            return;
        };
        let Some(q) = self.solve.q_image(self.graph.levels.len() - 1) else {
            return;
        };
        let gain = self.q_scale * self.solve.boundary().diffuse_transmittance() as f32;
        graph
            .pass(PASS_BOUNCE_SOURCE)
            .uses(source.uses(irradiance, q))
            .record(move |p| {
                // SAFETY: inside the graph's pass declaring the source's uses; `self` and the
                // bounce pass's buffer outlive the frame.
                unsafe { source.record(p.ctx, p.cb, gain) };
                Ok(())
            });
        if let (Some(kept), Some(mg)) = (&self.kept_x, &self.solve.multigrid) {
            add_copy_pass(graph, PASS_BOUNCE_KEEP, kept, mg.finest_x(), true);
        }
        // The second solve's record goes to the slot's own copy: the frame reports both.
        let slot = &self.control_copies[self.prepared.slot].bounce;
        add_solve_passes(graph, &self.solve, plan, Some(slot), true);
    }

    /// The control records of every recorded solve whose frame is `<= completed` and was not
    /// returned before, oldest first. Reads host memory only: no wait, no submission.
    fn completed(&mut self, completed: u64) -> Result<Vec<CompletedSolve>, Error> {
        let mut out = Vec::new();
        for slot in &mut self.control_copies {
            let Some(frame) = slot.frame.filter(|&f| f <= completed) else {
                continue;
            };
            slot.frame = None;
            let bytes = slot.buffer.read_bytes()?;
            let levels_size = self.solve.control_buffer().size as usize;
            let (levels, rest) = bytes.split_at(levels_size.min(bytes.len()));
            let report = |rest: &[u8], warm: bool| match &self.solve.multigrid {
                Some(mg) if rest.len() >= std::mem::size_of::<MultigridControl>() => mg
                    .report_of(
                        &bytemuck::pod_read_unaligned(
                            &rest[..std::mem::size_of::<MultigridControl>()],
                        ),
                        warm,
                    )
                    .map(Some),
                _ => Ok(None),
            };
            let multigrid = report(rest, slot.warm)?;
            let bounce = match slot.bounce_warm.take() {
                Some(warm) => {
                    let bytes = slot.bounce.read_bytes()?;
                    report(&bytes[levels_size.min(bytes.len())..], warm)?
                }
                None => None,
            };
            out.push(CompletedSolve {
                frame,
                levels: levels
                    .chunks_exact(std::mem::size_of::<LevelControl>())
                    .map(bytemuck::pod_read_unaligned)
                    .collect(),
                multigrid,
                bounce,
            });
        }
        out.sort_by_key(|s| s.frame);
        Ok(out)
    }

    fn gpu_bytes(&self) -> u64 {
        self.solve.bytes().0
            + self
                .bounce_source
                .as_ref()
                .map_or(0, BounceSourcePass::bytes)
            + self.kept_x.as_ref().map_or(0, |k| k.buffer.size)
    }

    fn exit_share(&self) -> Option<&Buffer> {
        Some(self.solve.vertex_j_plus_buffer())
    }

    /// The solver's own vertex J+ (`GpuDiffusion::vertex_j_plus_buffer`): the same
    /// values the mesh's exitance takes, before the bounce.
    fn exit_share_carries_exitance(&self) -> bool {
        true
    }

    fn as_any(&self) -> &dyn std::any::Any {
        self
    }

    fn as_any_mut(&mut self) -> &mut dyn std::any::Any {
        self
    }
}

/// The staged edits' pass (a heterogeneous material's weights, a material change, a
/// deformation).
fn add_edits_pass<'g>(graph: &mut FrameGraph<'g>, solve: &'g GpuDiffusion, edits: &'g StagedEdits) {
    graph
        .pass(PASS_EDITS)
        .uses(solve.edit_uses(edits))
        .record(move |p| {
            // SAFETY: inside the graph's pass declaring the edits' uses; `solve` and `edits`
            // outlive the frame.
            unsafe { solve.record_edits(p.ctx, p.cb, edits, p.profiler()) };
            Ok(())
        });
}

/// A solve's pass (its control record copied to `slot` for the host when given) and its
/// exitance's: [`PASS_SOLVE`], [`PASS_EXITANCE`] (the vertex J+ the frame's bounce and shading
/// read), or with `bounce` the second solve of `--bounce source`, [`PASS_BOUNCE_SOLVE`] and
/// [`PASS_BOUNCE_EXITANCE`] (its exitance straight into the display mesh).
fn add_solve_passes<'g>(
    graph: &mut FrameGraph<'g>,
    solve: &'g GpuDiffusion,
    plan: &'g SolvePlan,
    slot: Option<&'g Buffer>,
    bounce: bool,
) {
    let (solve_pass, exitance_pass) = if bounce {
        (PASS_BOUNCE_SOLVE, PASS_BOUNCE_EXITANCE)
    } else {
        (PASS_SOLVE, PASS_EXITANCE)
    };
    graph
        .pass(solve_pass)
        .uses(solve.solve_uses(slot))
        .record(move |p| {
            // SAFETY: inside the graph's pass declaring the solve's uses; `solve`, `plan` and
            // `slot` outlive the frame.
            unsafe { solve.record_solve(p.ctx, p.cb, plan, slot, p.profiler()) };
            Ok(())
        });
    graph
        .pass(exitance_pass)
        .uses(solve.exitance_uses())
        .record(move |p| {
            // SAFETY: inside the graph's pass declaring the exitance's uses.
            unsafe {
                if bounce {
                    solve.record_exitance_to_mesh(p.ctx, p.cb, p.profiler());
                } else {
                    solve.record_exitance(p.ctx, p.cb, p.profiler());
                }
            }
            Ok(())
        });
}

/// The pass copying the finest x into `kept` (`keep`) or back.
fn add_copy_pass<'g>(
    graph: &mut FrameGraph<'g>,
    name: &'static str,
    kept: &'g KeptX,
    (x, offset, size): (&'g Buffer, u64, u64),
    keep: bool,
) {
    let (src, dst) = if keep {
        (x, &kept.buffer)
    } else {
        (&kept.buffer, x)
    };
    let (src_offset, dst_offset) = if keep { (offset, 0) } else { (0, offset) };
    graph
        .pass(name)
        .uses([
            Use::buffer(src, Access::TransferSrc),
            Use::buffer(dst, Access::TransferDst),
        ])
        .record(move |p| {
            let region = vk::BufferCopy::default()
                .src_offset(src_offset)
                .dst_offset(dst_offset)
                .size(size);
            // SAFETY: inside the pass declaring both buffers; they live in the method, which
            // outlives the frame.
            unsafe {
                p.ctx
                    .raw()
                    .cmd_copy_buffer(p.cb, src.raw, dst.raw, &[region])
            };
            Ok(())
        });
}

/// Headless: one solve of `solve` (its q uploaded or gathered before) in its own submission,
/// through a frame graph with the staged edits' pass (a heterogeneous material's weights, a
/// material change: [`GpuDiffusion::take_edits`], as a frame of an object runs them), the
/// solve's and the exitance's passes: for tests and benchmarks of the solver alone (a frame of
/// an object records them through [`QuadGraphMethod`]). `warm` asks for a warm start
/// ([`GpuDiffusion::plan`] falls back to cold without a solution).
pub fn solve_headless(
    ctx: &Context,
    solve: &mut GpuDiffusion,
    warm: bool,
) -> Result<SolvePlan, Error> {
    let edits = solve.take_edits();
    let plan = solve.plan(warm, false);
    let solve = &*solve;
    let edits = edits.as_ref();
    let mut result = Ok(());
    ctx.execute("diffusion solve", |cb| {
        let mut graph = FrameGraph::new(ctx);
        if let Some(edits) = edits {
            add_edits_pass(&mut graph, solve, edits);
        }
        add_solve_passes(&mut graph, solve, &plan, None, false);
        // SAFETY: `cb` is recording outside a rendering scope; everything outlives the wait.
        result = unsafe { graph.execute(cb, None, false) }.map(|_| ());
        Ok(())
    })?;
    result?;
    Ok(plan)
}
