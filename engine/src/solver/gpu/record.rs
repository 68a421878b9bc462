//! The solve as two passes of the frame graph (`crate::frame`):
//! - [`PASS_SOLVE`]: per level, coarsest first, the Shepard initialisation (cold) or the warm
//!   correction, then blocks of Jacobi iterations each followed by the convergence reduction,
//!   which writes the indirect arguments of the following blocks (zero groups once converged);
//! - [`PASS_EXITANCE`]: J+ at the finest level's surface nodes (clamped at 0, counted) and per
//!   display vertex through the shading weights, into the bound display mesh.
//!
//! [`GpuDiffusion::plan`] decides a solve and does its bookkeeping (`&mut self`); the record
//! functions only record (`&self`), so a frame graph can hold them in its passes. Each pass
//! declares what it uses ([`GpuDiffusion::solve_uses`], [`GpuDiffusion::exitance_uses`]); the
//! graph places the barriers between passes. Inside a pass: exactly one global memory barrier
//! (compute write -> compute read|write) before every dispatch of the loop (in `Mixed` a block of
//! k iterations has k + 1 dispatches: residual, k - 1 sweeps, apply); around each convergence
//! reduction one barrier before it and one after it (compute write -> indirect read); one before
//! each init or warm correction. The counts are in [`GpuDiffusion::record_stats`];
//! synchronization validation checks they suffice.

use ash::vk;

use super::{
    raw_barrier, GpuDiffusion, InteriorPush, InteriorSamples, JPlusPush, LevelControl, LevelPush,
    Precision, RecordStats, ReducePush, ShepardPush, VertexPush, WarmPush, PASS_CONVERGENCE,
    PASS_INIT, PASS_JACOBI, PASS_J_PLUS, PASS_VERTEX_J_PLUS, PASS_WARM, WARM_CORRECT, WARM_SAVE,
};
use crate::mesh::Vertex;
use crate::vk::barrier::{self, Use};
use crate::vk::{Access, Buffer, Context, GpuProfiler};

/// The frame-graph pass of the iterations (init or warm correction, Jacobi, convergence).
pub const PASS_SOLVE: &str = "diffusion";
/// The frame-graph pass turning the finest level's phi into the display mesh's exitance.
pub const PASS_EXITANCE: &str = "exitance";

/// One solve as [`GpuDiffusion::plan`] decided it.
#[derive(Clone, Debug, PartialEq)]
pub struct SolvePlan {
    /// Starts from the last solution (every iterated level holds one at the current exposure).
    pub warm: bool,
    /// Blocks recorded per level, coarsest first (0: the level is not iterated).
    pub blocks: Vec<u32>,
    /// Per level, the warm start's [`WARM_CORRECT`] / [`WARM_SAVE`] flags.
    warm_flags: Vec<u32>,
    /// Multigrid schedule: also converged below this fraction of the start's residual (0, as
    /// [`GpuDiffusion::plan`] leaves it: the solve's tolerance alone). The cascade ignores it.
    pub start_tolerance: f32,
}

impl SolvePlan {
    /// Levels iterated.
    pub fn levels_iterated(&self) -> u32 {
        self.blocks.iter().filter(|&&b| b > 0).count() as u32
    }
    /// Warm start: levels whose start is corrected by the coarser level's change.
    pub fn corrected_levels(&self) -> u32 {
        self.warm_flags
            .iter()
            .filter(|&&f| f & WARM_CORRECT != 0)
            .count() as u32
    }
}

/// Opens (`Some`) or closes (`None`) a nested profiler scope.
///
/// # Safety
/// `cb` is recording.
pub(super) unsafe fn scope(
    profiler: &mut Option<&mut GpuProfiler>,
    ctx: &Context,
    cb: vk::CommandBuffer,
    name: Option<&'static str>,
) {
    // SAFETY: the caller's contract.
    unsafe {
        match name {
            Some(n) => {
                ctx.begin_label(cb, n);
                if let Some(p) = profiler.as_deref_mut() {
                    p.begin_scope(cb, n);
                }
            }
            None => {
                if let Some(p) = profiler.as_deref_mut() {
                    p.end_scope(cb);
                }
                ctx.end_label(cb);
            }
        }
    }
}

impl GpuDiffusion {
    /// Plans the next solve: warm when `warm` is asked and every level to iterate holds a
    /// solution at the current exposure (else cold); `finest_only` iterates the finest level
    /// alone (the small-graph skip). Updates the bookkeeping (which solution each level holds,
    /// [`Self::record_stats`]) as if the plan were recorded: record it with
    /// [`Self::record_solve`] in this frame.
    pub fn plan(&mut self, warm: bool, finest_only: bool) -> SolvePlan {
        let n = self.levels.len();
        let blocks: Vec<u32> = self
            .blocks
            .iter()
            .enumerate()
            .map(|(h, &b)| if finest_only && h + 1 < n { 0 } else { b })
            .collect();
        let iterate: Vec<bool> = blocks.iter().map(|&b| b > 0).collect();
        let prior = self.level_solve.clone();
        let warm = warm && self.solved && (0..n).all(|h| !iterate[h] || prior[h].is_some());
        // Per level, the warm start's flags: correct by the coarser level's change when both
        // hold solutions of the same solve and the coarser one iterates now; save this level's
        // phi when the finer level will correct from it.
        let same = |a: usize, b: usize| prior[a].is_some() && prior[a] == prior[b];
        let warm_flags: Vec<u32> = (0..n)
            .map(|h| {
                if !warm || !iterate[h] {
                    return 0;
                }
                let correct = h > 0 && iterate[h - 1] && same(h - 1, h);
                let save = h + 1 < n && iterate[h + 1] && same(h, h + 1);
                (u32::from(correct) * WARM_CORRECT) | (u32::from(save) * WARM_SAVE)
            })
            .collect();
        let k = self.params.block;
        let per_block = match self.params.precision {
            Precision::Mixed => k + 1,
            Precision::Fp32 | Precision::Fp16 => k,
        };
        let total_blocks: u32 = blocks.iter().sum();
        let plan = SolvePlan {
            warm,
            blocks,
            warm_flags,
            start_tolerance: 0.0,
        };
        self.stats = RecordStats {
            iteration_dispatches: total_blocks * per_block,
            iteration_barriers: total_blocks * per_block,
            blocks: total_blocks,
            iterations_recorded: total_blocks * k,
            warm,
            corrected_levels: plan.corrected_levels(),
        };
        self.solved = true;
        self.records += 1;
        for (solve, &iterated) in self.level_solve.iter_mut().zip(&iterate) {
            if iterated {
                *solve = Some(self.records);
            } else if !warm {
                // A cold start initialised this level without iterating it (one-level solve).
                *solve = None;
            }
        }
        plan
    }

    /// Bytes of a `copy_to` buffer that takes every record [`Self::record_solve`] copies: the
    /// levels' control records, then the multigrid's
    /// ([`super::multigrid::MultigridControl`]) when the schedule is multigrid.
    pub fn control_copy_size(&self) -> u64 {
        self.control.size
            + if self.multigrid.is_some() {
                MULTIGRID_CONTROL_BYTES
            } else {
                0
            }
    }

    /// What [`Self::record_solve`] uses: every level's state and graph textures, the control
    /// buffer (reset by a transfer, then indirect arguments and reduction records, then copied
    /// into `copy_to` for a read on the host after the frame).
    pub fn solve_uses<'a>(&'a self, copy_to: Option<&'a Buffer>) -> Vec<Use<'a>> {
        let mut uses = vec![Use::buffer_span(
            &self.control,
            Access::TransferDst,
            if copy_to.is_some() {
                Access::TransferSrc
            } else {
                Access::IndirectArgs
            },
        )];
        if let Some(copy) = copy_to {
            uses.push(Use::buffer_span(
                copy,
                Access::TransferDst,
                Access::HostRead,
            ));
        }
        for l in &self.levels {
            uses.push(Use::image(&l.q, Access::ComputeRead));
            for img in l
                .state
                .iter()
                .chain(&l.phi)
                .chain(&l.residual)
                .chain(&l.saved)
            {
                uses.push(Use::image(img, Access::ComputeReadWrite));
            }
            for img in [&l.connectivity, &l.geo]
                .into_iter()
                .chain(&l.frac)
                .chain(l.material.iter().flatten())
                .chain(l.weights.iter().flatten())
                .chain(&l.links)
            {
                uses.push(Use::image(img, Access::ComputeRead));
            }
        }
        uses.push(Use::image(&self.poison, Access::ComputeRead));
        if let Some(mg) = &self.multigrid {
            uses.extend(mg.uses());
        }
        uses
    }

    /// Records the iterations `plan` asked for (see the module doc), then copies the control
    /// records into `copy_to` (host-readable after the frame: the iterations each level ran).
    /// Blocks after convergence are recorded but dispatch zero groups.
    ///
    /// # Safety
    /// `cb` must be recording outside a rendering scope, inside a frame-graph pass declaring
    /// [`Self::solve_uses`] with the same `copy_to`; `self` and `copy_to` must outlive its
    /// execution; `plan` comes from [`Self::plan`] of this frame.
    pub unsafe fn record_solve(
        &self,
        ctx: &Context,
        cb: vk::CommandBuffer,
        plan: &SolvePlan,
        copy_to: Option<&Buffer>,
        mut profiler: Option<&mut GpuProfiler>,
    ) {
        use vk::AccessFlags2 as A;
        use vk::PipelineStageFlags2 as S;
        let raw = ctx.raw();
        let k = self.params.block;
        let initial: Vec<LevelControl> = self
            .levels
            .iter()
            .map(|l| LevelControl {
                groups: [l.packing.width.div_ceil(8), l.packing.height.div_ceil(8), 1],
                ..Default::default()
            })
            .collect();
        let v = usize::from(self.homogeneous);
        let Some(variant) = &self.pipelines.variants[v] else {
            // `set_material` creates the variant it selects; nothing to iterate with otherwise.
            return;
        };
        // SAFETY: the caller's contract; every set's resources live in `self`.
        unsafe {
            raw.cmd_update_buffer(cb, self.control.raw, 0, bytemuck::cast_slice(&initial));
            // why: the loop reads the reset control records as indirect arguments and in the
            // reductions (RAW).
            barrier::record(
                ctx,
                cb,
                &[barrier::memory_barrier(
                    Access::TransferDst,
                    Access::IndirectArgs,
                )],
                &[],
            );
            if let Some(mg) = &self.multigrid {
                // The multigrid schedule replaces the cascade's levels (`multigrid.rs`).
                mg.record(
                    ctx,
                    cb,
                    plan.warm,
                    self.params.tolerance,
                    plan.start_tolerance,
                    &mut profiler,
                );
            }
            for (h, level) in self
                .levels
                .iter()
                .enumerate()
                .filter(|_| self.multigrid.is_none())
            {
                let push = LevelPush {
                    kappa: self.kappa,
                    mu_gain: self.mu_gain,
                    ..level.push()
                };
                let sets = &level.iterate_sets[v];
                let offset = (h * std::mem::size_of::<LevelControl>()) as u64;
                // Shepard init and the warm correction both read the coarser level (none at 0).
                let coarse_width = h.checked_sub(1).map_or(1, |c| self.levels[c].packing.width);
                let iterate = plan.blocks[h] > 0;
                if !plan.warm {
                    scope(&mut profiler, ctx, cb, Some(PASS_INIT));
                    // why: init overwrites this level's phi, which earlier passes of this solve
                    // may not have read yet only at h = 0 (WAR), and reads the coarser level's
                    // last iteration (RAW).
                    barrier::memory(ctx, cb, Access::ComputeWrite, Access::ComputeReadWrite);
                    self.pipelines.init.dispatch(
                        ctx,
                        cb,
                        level.init_set,
                        &ShepardPush {
                            size: push.size,
                            coarse_width,
                            zero: u32::from(h == 0),
                        },
                        level.extent(),
                    );
                    scope(&mut profiler, ctx, cb, None);
                } else if iterate && plan.warm_flags[h] != 0 {
                    scope(&mut profiler, ctx, cb, Some(PASS_WARM));
                    // why: the correction reads the coarser level's last iteration (RAW) and its
                    // saved phi (RAW), and rewrites this level's phi and saved copy (WAR against
                    // the finer correction of the last solve).
                    barrier::memory(ctx, cb, Access::ComputeWrite, Access::ComputeReadWrite);
                    self.pipelines.warm.dispatch(
                        ctx,
                        cb,
                        level.warm_set,
                        &WarmPush {
                            size: push.size,
                            coarse_width,
                            flags: plan.warm_flags[h],
                        },
                        level.extent(),
                    );
                    scope(&mut profiler, ctx, cb, None);
                }
                for _ in 0..plan.blocks[h] {
                    scope(&mut profiler, ctx, cb, Some(PASS_JACOBI));
                    match (
                        self.params.precision,
                        &variant.residual,
                        &self.pipelines.apply,
                    ) {
                        (Precision::Mixed, Some(rp), Some(ap)) => {
                            // why: the residual reads phi written by init or the last apply (RAW)
                            // and overwrites delta the last reduction read (WAR).
                            barrier::memory(
                                ctx,
                                cb,
                                Access::ComputeWrite,
                                Access::ComputeReadWrite,
                            );
                            rp.dispatch_indirect(ctx, cb, sets[2], &push, &self.control, offset);
                            for j in 1..k {
                                // why: this sweep reads the previous iterate (RAW) and overwrites
                                // the one before (WAR).
                                barrier::memory(
                                    ctx,
                                    cb,
                                    Access::ComputeWrite,
                                    Access::ComputeReadWrite,
                                );
                                let set = sets[self.ping_pong.sweep_set(j - 1)];
                                variant.iterate.dispatch_indirect(
                                    ctx,
                                    cb,
                                    set,
                                    &push,
                                    &self.control,
                                    offset,
                                );
                            }
                            // why: phi += the last correction (RAW on delta).
                            barrier::memory(
                                ctx,
                                cb,
                                Access::ComputeWrite,
                                Access::ComputeReadWrite,
                            );
                            ap.dispatch_indirect(
                                ctx,
                                cb,
                                level.apply_set,
                                &push,
                                &self.control,
                                offset,
                            );
                        }
                        _ => {
                            for j in 0..k {
                                // why: this iteration reads the previous one's output (RAW) and
                                // overwrites what the one before read (WAR).
                                barrier::memory(
                                    ctx,
                                    cb,
                                    Access::ComputeWrite,
                                    Access::ComputeReadWrite,
                                );
                                let set = sets[self.ping_pong.sweep_set(j)];
                                variant.iterate.dispatch_indirect(
                                    ctx,
                                    cb,
                                    set,
                                    &push,
                                    &self.control,
                                    offset,
                                );
                            }
                        }
                    }
                    scope(&mut profiler, ctx, cb, None);
                    scope(&mut profiler, ctx, cb, Some(PASS_CONVERGENCE));
                    // why: the reduction reads the block's last two iterates (RAW).
                    barrier::memory(ctx, cb, Access::ComputeWrite, Access::ComputeReadWrite);
                    self.pipelines.reduce.dispatch(
                        ctx,
                        cb,
                        level.reduce_set,
                        &ReducePush {
                            size: push.size,
                            level: h as u32,
                            k,
                            tolerance: self.params.tolerance,
                        },
                        [1, 1, 1],
                    );
                    // why: the next block's indirect dispatches read the arguments the reduction
                    // wrote (RAW at DRAW_INDIRECT), and its next reduction updates them again.
                    barrier::record(
                        ctx,
                        cb,
                        &[raw_barrier(
                            S::COMPUTE_SHADER,
                            A::SHADER_STORAGE_WRITE,
                            S::DRAW_INDIRECT | S::COMPUTE_SHADER,
                            A::INDIRECT_COMMAND_READ
                                | A::SHADER_STORAGE_READ
                                | A::SHADER_STORAGE_WRITE,
                        )],
                        &[],
                    );
                    scope(&mut profiler, ctx, cb, None);
                }
            }
            if let Some(copy) = copy_to {
                // why: the copy reads the control records the reductions wrote (RAW).
                barrier::record(
                    ctx,
                    cb,
                    &[raw_barrier(
                        S::COMPUTE_SHADER,
                        A::SHADER_STORAGE_WRITE,
                        S::COPY,
                        A::TRANSFER_READ,
                    )],
                    &[],
                );
                raw.cmd_copy_buffer(
                    cb,
                    self.control.raw,
                    copy.raw,
                    &[vk::BufferCopy {
                        src_offset: 0,
                        dst_offset: 0,
                        size: self.control.size.min(copy.size),
                    }],
                );
                // The multigrid's record (cycles, residuals) after the levels' (see
                // `Self::control_copy_size`).
                if let Some(mg) = self
                    .multigrid
                    .as_ref()
                    .filter(|_| copy.size >= self.control_copy_size())
                {
                    raw.cmd_copy_buffer(
                        cb,
                        mg.control_buffer().raw,
                        copy.raw,
                        &[vk::BufferCopy {
                            src_offset: 0,
                            dst_offset: self.control.size,
                            size: MULTIGRID_CONTROL_BYTES,
                        }],
                    );
                    // why: the next solve resets the multigrid's control record, which the graph
                    // orders after this pass's compute use only: order it after this copy's read
                    // too (WAR).
                    barrier::record(
                        ctx,
                        cb,
                        &[raw_barrier(
                            S::COPY,
                            A::TRANSFER_READ,
                            S::ALL_COMMANDS,
                            A::empty(),
                        )],
                        &[],
                    );
                }
                // why: the host reads the copy after the frame's fence (host visibility).
                barrier::memory(ctx, cb, Access::TransferDst, Access::HostRead);
            }
        }
    }

    /// What [`Self::record_exitance`] uses: the finest level's phi, q and connectivity, the
    /// clamp counters (reset by a transfer), and the per-vertex J+ buffers: ours and the bound
    /// display mesh's ([`Self::bind_mesh`]).
    pub fn exitance_uses(&self) -> Vec<Use<'_>> {
        let finest = &self.levels[self.levels.len() - 1];
        let mut uses = vec![
            Use::image(finest.result(), Access::ComputeRead),
            Use::image(&finest.q, Access::ComputeRead),
            Use::image(&finest.connectivity, Access::ComputeRead),
            Use::image(&finest.particular, Access::ComputeRead),
            Use::image(&self.j_plus, Access::ComputeReadWrite),
            Use::buffer_span(
                &self.clamp_counts,
                Access::TransferDst,
                Access::ComputeReadWrite,
            ),
            Use::buffer(&self.vertex_j_plus, Access::ComputeWrite),
        ];
        if let Some((mesh, _)) = &self.mesh {
            uses.push(Use::buffer(mesh.vertex_buffer(), Access::ComputeWrite));
        }
        if let Some(interior) = &self.interior {
            uses.push(Use::buffer(&interior.nodes, Access::ComputeRead));
            uses.push(Use::buffer(&interior.weights, Access::ComputeRead));
            uses.push(Use::buffer(&interior.cells, Access::ComputeRead));
            uses.push(Use::buffer(&interior.lateral_nodes, Access::ComputeRead));
            uses.push(Use::buffer(&interior.lateral_weights, Access::ComputeRead));
            uses.push(Use::buffer(&interior.sample_phi, Access::ComputeReadWrite));
            uses.push(Use::image(
                &interior.vertex_gather.particular,
                Access::ComputeRead,
            ));
            if let (false, Some([kappa, mu])) = (self.homogeneous, &finest.material) {
                uses.push(Use::image(kappa, Access::ComputeRead));
                uses.push(Use::image(mu, Access::ComputeRead));
            }
        }
        uses
    }

    /// Records J+ at the finest level's surface nodes and per display vertex (see the module doc).
    ///
    /// # Safety
    /// `cb` must be recording outside a rendering scope, inside a frame-graph pass declaring
    /// [`Self::exitance_uses`], after a solve; `self` must outlive its execution.
    pub unsafe fn record_exitance(
        &self,
        ctx: &Context,
        cb: vk::CommandBuffer,
        profiler: Option<&mut GpuProfiler>,
    ) {
        // SAFETY: the caller's contract.
        unsafe { self.record_exitance_into(ctx, cb, profiler, true) }
    }

    /// As [`Self::record_exitance`], into the bound display mesh only: our per-vertex buffer
    /// (the exit lobe's share, [`Self::vertex_j_plus_buffer`]) keeps the last solve's values
    /// (`--bounce source`'s second solve: the shading draws what it added as the bounce's).
    ///
    /// # Safety
    /// As [`Self::record_exitance`].
    pub unsafe fn record_exitance_to_mesh(
        &self,
        ctx: &Context,
        cb: vk::CommandBuffer,
        profiler: Option<&mut GpuProfiler>,
    ) {
        // SAFETY: the caller's contract.
        unsafe { self.record_exitance_into(ctx, cb, profiler, false) }
    }

    unsafe fn record_exitance_into(
        &self,
        ctx: &Context,
        cb: vk::CommandBuffer,
        mut profiler: Option<&mut GpuProfiler>,
        ours: bool,
    ) {
        let finest = &self.levels[self.levels.len() - 1];
        // The exit query (DESIGN 2.6 or the flux-only one): X = f_phi phi - f_q q per node.
        let (phi_factor, q_factor) = self.boundary().flux_shading_factors();
        // SAFETY: the caller's contract; every set's resources live in `self`.
        unsafe {
            ctx.raw()
                .cmd_fill_buffer(cb, self.clamp_counts.raw, 0, 16, 0);
            // why: the J+ pass counts into the counters just reset (RAW after the transfer).
            barrier::memory(ctx, cb, Access::TransferDst, Access::ComputeReadWrite);
            scope(&mut profiler, ctx, cb, Some(PASS_J_PLUS));
            self.pipelines.j_plus.dispatch(
                ctx,
                cb,
                self.j_plus_set,
                &JPlusPush {
                    // The surface rows: the J+ image has no others.
                    size: [
                        finest.packing.width as i32,
                        finest.packing.surface_rows.max(1) as i32,
                    ],
                    surface_rows: finest.packing.surface_rows,
                    inv_q_scale: 1.0 / self.q_scale,
                    phi_factor: phi_factor as f32,
                    q_factor: q_factor as f32,
                    particular_factor: if self.params.collimated {
                        self.boundary().shading_input(1.0) as f32
                    } else {
                        0.0
                    },
                    flux_gain: self.boundary().flux_gain as f32,
                },
                [finest.packing.width, finest.packing.surface_rows.max(1), 1],
            );
            scope(&mut profiler, ctx, cb, None);
            scope(&mut profiler, ctx, cb, Some(PASS_VERTEX_J_PLUS));
            // why: the vertex pass reads the J+ image just written (RAW).
            barrier::memory(ctx, cb, Access::ComputeWrite, Access::ComputeReadWrite);
            match &self.interior {
                Some(interior) => self.dispatch_interior(ctx, cb, interior, ours),
                None => self.dispatch_shepard(ctx, cb, ours),
            }
            scope(&mut profiler, ctx, cb, None);
        }
    }

    /// The display vertices' exitance through the Shepard shading weights of the surface nodes'
    /// J+ (`vertex_j_plus.comp`): our buffer, and the bound mesh's.
    ///
    /// # Safety
    /// As [`Self::record_exitance`], after its J+ pass.
    unsafe fn dispatch_shepard(&self, ctx: &Context, cb: vk::CommandBuffer, ours: bool) {
        let finest = &self.levels[self.levels.len() - 1];
        // Our buffer also takes the diffused share (the per-node exit lobe's vertex stream).
        let mut targets = Vec::new();
        if ours {
            targets.push((self.vertex_set, 4u32, 0u32, 1u32));
        }
        if let Some((_, set)) = &self.mesh {
            let floats = |bytes: usize| (bytes / std::mem::size_of::<f32>()) as u32;
            targets.push((
                *set,
                floats(std::mem::size_of::<Vertex>()),
                floats(std::mem::offset_of!(Vertex, exitance)),
                0,
            ));
        }
        for (set, stride, offset, share) in targets {
            // SAFETY: the caller's contract; every set's resources live in `self`.
            unsafe {
                self.pipelines.vertex.dispatch(
                    ctx,
                    cb,
                    set,
                    &VertexPush {
                        count: self.vertex_count,
                        width: finest.packing.width,
                        stride,
                        offset,
                        share,
                    },
                    [self.vertex_count.max(1), 1, 1],
                );
            }
        }
    }

    /// The display vertices' exitance reconstructed from the interior solution
    /// (`vertex_interior*.comp`, [`GpuSolveParams::surface`]): our buffer, and the bound mesh's.
    ///
    /// # Safety
    /// As [`Self::record_exitance`].
    unsafe fn dispatch_interior(
        &self,
        ctx: &Context,
        cb: vk::CommandBuffer,
        interior: &InteriorSamples,
        ours: bool,
    ) {
        let finest = &self.levels[self.levels.len() - 1];
        let boundary = self.boundary();
        let (f_phi, f_d, f_q) = boundary.exitance_factors();
        let heterogeneous = !self.homogeneous;
        let push = |stride: u32, offset: u32, stage: f32| InteriorPush {
            count: self.vertex_count,
            width: finest.packing.width,
            stride,
            offset,
            kappa: [
                self.kappa[0],
                self.kappa[1],
                self.kappa[2],
                if heterogeneous { 1.0 } else { 0.0 },
            ],
            mu: [
                self.mu_gain[0],
                self.mu_gain[1],
                self.mu_gain[2],
                (2.0 * boundary.a) as f32,
            ],
            exit: [
                f_phi as f32,
                f_d as f32,
                f_q as f32,
                boundary.flux_gain as f32,
            ],
            scale: [
                1.0 / self.q_scale,
                boundary.shading_input(1.0) as f32,
                match (self.params.collimated, self.params.own_visibility) {
                    (false, _) => 0.0,
                    (true, false) => 1.0,
                    (true, true) => 2.0,
                },
                stage,
            ],
        };
        let h = usize::from(heterogeneous);
        // Stage 0: every vertex's sample phi, which the lateral stencils of stage 1 read.
        if let Some(set) = interior.sets[h] {
            // SAFETY: the caller's contract; the set's resources live in `self`.
            unsafe {
                self.pipelines.interior.dispatch(
                    ctx,
                    cb,
                    set,
                    &push(4, 0, 0.0),
                    [self.vertex_count.max(1), 1, 1],
                );
                // why: stage 1 reads the neighbours' samples stage 0 just wrote (RAW).
                barrier::memory(ctx, cb, Access::ComputeWrite, Access::ComputeReadWrite);
            }
        }
        let mut targets = Vec::new();
        if ours {
            targets.push((interior.sets[h], 4u32, 0u32));
        }
        if self.mesh.is_some() {
            let floats = |bytes: usize| (bytes / std::mem::size_of::<f32>()) as u32;
            targets.push((
                interior.sets[2 + h],
                floats(std::mem::size_of::<Vertex>()),
                floats(std::mem::offset_of!(Vertex, exitance)),
            ));
        }
        for (set, stride, offset) in targets {
            // A set not allocated cannot happen after `ensure_interior_sets` (material set,
            // mesh bound); skipping keeps the last values rather than binding nothing.
            let Some(set) = set else { continue };
            // SAFETY: the caller's contract; every set's resources live in `self`.
            unsafe {
                self.pipelines.interior.dispatch(
                    ctx,
                    cb,
                    set,
                    &push(stride, offset, 1.0),
                    [self.vertex_count.max(1), 1, 1],
                );
            }
        }
    }
}

/// Bytes of the multigrid's control record a frame's solve copies for the host.
const MULTIGRID_CONTROL_BYTES: u64 =
    std::mem::size_of::<super::multigrid::MultigridControl>() as u64;
