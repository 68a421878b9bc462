//! The command recording of one GPU multigrid solve (FMG start, CG-accelerated V-cycles, output).

use super::*;

/// Fine profiler scopes ([`GpuMultigrid::fine_scopes`]): per level (finest 2 and above read as
/// 2), the coarsest solve, and per CG iteration.
const SCOPE_SMOOTH: [&str; 3] = ["mg smooth L0", "mg smooth L1", "mg smooth L2+"];
const SCOPE_RESTRICT: [&str; 3] = ["mg restrict L0", "mg restrict L1", "mg restrict L2+"];
const SCOPE_PROLONG: [&str; 3] = ["mg prolong L0", "mg prolong L1", "mg prolong L2+"];
const SCOPE_COARSE: &str = "mg coarse solve";
const SCOPE_CG_ITERATION: &str = "mg cg iteration";
const SCOPE_CG_PASSES: &str = "mg cg passes";

/// Where a smoothing run starts ([`Recorder::smooth`]).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(super) enum Start {
    /// x = 0 (its first step reads f as the residual).
    Zero,
    /// The level's x.
    X,
    /// The level's r holds the iterate (the prolongation's [`PROLONG_INTO_R`]).
    R,
}

/// Records the kernels of one solve.
pub(super) struct Recorder<'a, 'b> {
    pub(super) mg: &'a GpuMultigrid,
    pub(super) ctx: &'a Context,
    pub(super) cb: vk::CommandBuffer,
    pub(super) base: MultigridPush,
    /// The solve's profiler (its fine scopes: [`GpuMultigrid::fine_scopes`]).
    pub(super) profiler: std::cell::RefCell<&'a mut Option<&'b mut GpuProfiler>>,
}

impl Recorder<'_, '_> {
    pub(super) fn push(
        &self,
        level: usize,
        mode: u32,
        alpha: [f64; 3],
        beta: [f64; 3],
    ) -> MultigridPush {
        let l = &self.mg.levels[level];
        let f = |v: [f64; 3]| [v[0] as f32, v[1] as f32, v[2] as f32, 0.0];
        MultigridPush {
            count: l.count,
            offset: l.offset,
            mode,
            alpha: f(alpha),
            beta: f(beta),
            ..self.base
        }
    }

    /// # Safety
    /// As [`GpuMultigrid::record`].
    pub(super) unsafe fn direct(&self, kernel: usize, level: usize, mode: u32, invocations: u32) {
        // SAFETY: the caller's contract.
        unsafe { self.direct_with(kernel, level, mode, [0.0; 3], invocations) }
    }

    /// [`Self::direct`] with the push constants' `alpha` (the warm start's coefficients).
    ///
    /// # Safety
    /// As [`GpuMultigrid::record`].
    pub(super) unsafe fn direct_with(
        &self,
        kernel: usize,
        level: usize,
        mode: u32,
        alpha: [f64; 3],
        invocations: u32,
    ) {
        let (pipeline, set) = &self.mg.pipelines[kernel];
        let push = self.push(level, mode, alpha, [0.0; 3]);
        // SAFETY: the caller's contract.
        unsafe {
            // why: every kernel reads what the one before wrote (RAW) and overwrites what
            // earlier ones read (WAR).
            barrier::memory(
                self.ctx,
                self.cb,
                Access::ComputeWrite,
                Access::ComputeReadWriteTexels,
            );
            pipeline.dispatch(self.ctx, self.cb, *set, &push, [invocations, 1, 1]);
        }
    }

    /// One dispatch over the nodes of `level`, its group count read from the control record
    /// (zero once the cycles stopped).
    ///
    /// # Safety
    /// As [`GpuMultigrid::record`].
    pub(super) unsafe fn indirect(
        &self,
        kernel: usize,
        level: usize,
        mode: u32,
        alpha: [f64; 3],
        beta: [f64; 3],
    ) {
        let set = self.mg.pipelines[kernel].1;
        // SAFETY: the caller's contract.
        unsafe { self.indirect_in(kernel, set, level, mode, alpha, beta) }
    }

    /// [`Self::indirect`] with the descriptor set `set` of the kernel's pipeline.
    ///
    /// # Safety
    /// As [`GpuMultigrid::record`].
    pub(super) unsafe fn indirect_in(
        &self,
        kernel: usize,
        set: vk::DescriptorSet,
        level: usize,
        mode: u32,
        alpha: [f64; 3],
        beta: [f64; 3],
    ) {
        let pipeline = &self.mg.pipelines[kernel].0;
        let push = self.push(level, mode, alpha, beta);
        let offset = (level * std::mem::size_of::<[u32; 4]>()) as u64;
        // SAFETY: the caller's contract.
        unsafe {
            // why: every kernel reads what the one before wrote (RAW) and overwrites what
            // earlier ones read (WAR).
            barrier::memory(
                self.ctx,
                self.cb,
                Access::ComputeWrite,
                Access::ComputeReadWriteTexels,
            );
            pipeline.dispatch_indirect(self.ctx, self.cb, set, &push, &self.mg.control, offset);
        }
    }

    /// `steps` steps of the level's Chebyshev polynomial (damped Jacobi: alpha = 0) from `start`:
    /// x = 0 (the first step's residual is f and its residual pass is skipped), the level's x, or
    /// (only with [`Self::fused`] and an odd count) the level's r (the prolongation wrote x + P e
    /// there). The steps end in x.
    ///
    /// # Safety
    /// As [`GpuMultigrid::record`].
    pub(super) unsafe fn smooth(&self, level: usize, steps: u32, start: Start) {
        let bounds = self.mg.levels[level].bounds;
        let coefficients = |step: u32| {
            let (alpha, beta): ([f64; 3], [f64; 3]) = match self.mg.params.smoother {
                Smoother::Jacobi { omega } if level > 0 => ([0.0; 3], [omega; 3]),
                _ => {
                    let c = chebyshev_coefficients(bounds, step);
                    (c.map(|(a, _)| a), c.map(|(_, b)| b))
                }
            };
            (if step == 0 { [0.0; 3] } else { alpha }, beta)
        };
        // Fused: each step a `relax.comp` pass (a residual and a step in one), from x into r or
        // from r into x; the run must end in x, so an odd count of them from x starts with one
        // step of two passes (a residual, then `smooth.comp`).
        let fused = self.fused(level);
        let mut in_r = start == Start::R;
        let relaxed = match start {
            Start::Zero => steps.saturating_sub(1),
            Start::X | Start::R => steps,
        };
        // (From r the count is odd: the caller's rule.)
        let mut split = match (fused, start) {
            (false, _) => relaxed,
            (true, Start::R) => 0,
            (true, _) => relaxed % 2,
        };
        let (relax_there, relax_back) = (self.mg.pipelines[RELAX].1, self.mg.relax_back);
        for step in 0..steps {
            let (alpha, beta) = coefficients(step);
            // SAFETY: the caller's contract.
            unsafe {
                if start == Start::Zero && step == 0 {
                    self.indirect(SMOOTH, level, 1, alpha, beta);
                } else if split > 0 && !in_r {
                    self.indirect(RESIDUAL, level, 0, [0.0; 3], [0.0; 3]);
                    self.indirect(SMOOTH, level, 0, alpha, beta);
                    split -= 1;
                } else {
                    let set = if in_r { relax_back } else { relax_there };
                    self.indirect_in(RELAX, set, level, 0, alpha, beta);
                    in_r = !in_r;
                }
            }
        }
        debug_assert!(!in_r, "a smoothing run ends in x");
    }

    /// Whether level `level`'s smoothing steps run as fused `relax.comp` passes
    /// ([`RelaxLevels`]).
    pub(super) fn fused(&self, level: usize) -> bool {
        match self.mg.relax {
            RelaxLevels::None => false,
            RelaxLevels::Finest => level == self.mg.top() && level > 0,
            RelaxLevels::AboveCoarsest => level > 0,
        }
    }

    /// The coarsest level's solve: the Chebyshev polynomial on its whole interval, from x = 0.
    ///
    /// # Safety
    /// As [`GpuMultigrid::record`].
    pub(super) unsafe fn coarse(&self) {
        // The restriction zeroed the coarsest x (full multigrid's and every V-cycle's).
        let bounds = self.mg.levels[0].bounds;
        let lo = bounds.map(|(lo, _)| lo);
        let hi = bounds.map(|(_, hi)| hi);
        // SAFETY: the caller's contract.
        unsafe {
            self.open(SCOPE_COARSE);
            if self.mg.coarse_in_one_dispatch {
                // One workgroup runs every step (`coarse.comp`); it reads the control state
                // instead of the indirect arguments.
                let (pipeline, set) = &self.mg.pipelines[COARSE];
                let push = self.push(0, self.mg.coarse_steps, lo, hi);
                // why: the solve reads the right-hand side the restriction just wrote (RAW)
                // and overwrites x, d and r earlier kernels read (WAR).
                barrier::memory(
                    self.ctx,
                    self.cb,
                    Access::ComputeWrite,
                    Access::ComputeReadWriteTexels,
                );
                pipeline.dispatch(self.ctx, self.cb, *set, &push, [GROUP, 1, 1]);
            } else {
                self.smooth(0, self.mg.coarse_steps, Start::Zero);
            }
            self.close();
        }
    }

    /// Opens a fine profiler scope (only with [`GpuMultigrid::fine_scopes`]).
    ///
    /// # Safety
    /// As [`GpuMultigrid::record`].
    pub(super) unsafe fn open(&self, name: &'static str) {
        if self.mg.fine_scopes {
            // SAFETY: the caller's contract.
            unsafe {
                scope(
                    &mut self.profiler.borrow_mut(),
                    self.ctx,
                    self.cb,
                    Some(name),
                )
            };
        }
    }

    /// Closes the fine scope opened last.
    ///
    /// # Safety
    /// As [`GpuMultigrid::record`].
    pub(super) unsafe fn close(&self) {
        if self.mg.fine_scopes {
            // SAFETY: the caller's contract.
            unsafe { scope(&mut self.profiler.borrow_mut(), self.ctx, self.cb, None) };
        }
    }

    /// One V-cycle from level `l`; `from_zero`: x = 0 on entry (a coarse correction, or the CG's
    /// preconditioner applied to the CG residual).
    ///
    /// # Safety
    /// As [`GpuMultigrid::record`].
    pub(super) unsafe fn v_cycle(&self, l: usize, from_zero: bool) {
        // SAFETY: the caller's contract.
        unsafe { self.v_cycle_with(l, from_zero, self.mg.sweeps(l)) }
    }

    /// [`Self::v_cycle`] with `(pre, post)` smoothing steps on level `l` (the levels below it
    /// keep the cycle's): the full multigrid pass's finest V-cycle (`MultigridParams::fmg_sweeps`).
    ///
    /// # Safety
    /// As [`GpuMultigrid::record`].
    pub(super) unsafe fn v_cycle_with(&self, l: usize, from_zero: bool, (pre, post): (u32, u32)) {
        // SAFETY: the caller's contract.
        unsafe {
            if l == 0 {
                self.coarse();
                return;
            }
            self.open(SCOPE_SMOOTH[l.min(2)]);
            self.smooth(l, pre, if from_zero { Start::Zero } else { Start::X });
            self.close();
            self.open(SCOPE_RESTRICT[l.min(2)]);
            self.indirect(RESIDUAL, l, 0, [0.0; 3], [0.0; 3]);
            self.indirect(RESTRICT, l - 1, 0, [0.0; 3], [0.0; 3]);
            self.close();
            // The restriction zeroed the coarser level's x.
            self.v_cycle(l - 1, true);
            // An odd count of fused post-smoothing steps starts from r: the prolongation writes
            // x + P e there, and the steps alternate r -> x -> r -> x.
            let into_r = self.fused(l) && post % 2 == 1;
            self.open(SCOPE_PROLONG[l.min(2)]);
            let mode = if into_r { PROLONG_INTO_R } else { 0 };
            self.indirect(PROLONG, l, mode, [0.0; 3], [0.0; 3]);
            self.close();
            self.open(SCOPE_SMOOTH[l.min(2)]);
            self.smooth(l, post, if into_r { Start::R } else { Start::X });
            self.close();
        }
    }

    /// The finest level's residual, its norm and the convergence check.
    ///
    /// # Safety
    /// As [`GpuMultigrid::record`].
    pub(super) unsafe fn residual_check(&self) {
        let top = self.mg.top();
        // SAFETY: the caller's contract.
        unsafe {
            self.indirect(RESIDUAL, top, 0, [0.0; 3], [0.0; 3]);
            self.indirect(NORM, top, 0, [0.0; 3], [0.0; 3]);
            self.check(CHECK_RESIDUAL);
        }
    }

    /// One flexible CG iteration preconditioned by one V-cycle (`krylov.comp`: two finest-level
    /// passes, K z with the dot products, then the step), ending in the convergence check of the
    /// CG residual.
    ///
    /// # Safety
    /// As [`GpuMultigrid::record`].
    pub(super) unsafe fn krylov_iteration(&self) {
        let top = self.mg.top();
        let none = [0.0; 3];
        // SAFETY: the caller's contract.
        unsafe {
            // The step zeroed x: the V-cycle preconditions the CG residual from zero.
            self.open(SCOPE_CG_ITERATION);
            self.v_cycle(top, true);
            self.open(SCOPE_CG_PASSES);
            self.indirect(KRYLOV, top, CG_APPLY, none, none);
            self.check(CHECK_CG);
            self.indirect(KRYLOV, top, CG_STEP, none, none);
            self.check(CHECK_RESIDUAL);
            self.close();
            self.close();
        }
    }

    /// # Safety
    /// As [`GpuMultigrid::record`].
    pub(super) unsafe fn check(&self, mode: u32) {
        use vk::AccessFlags2 as A;
        use vk::PipelineStageFlags2 as S;
        let (pipeline, set) = &self.mg.pipelines[CHECK];
        let push = MultigridPush {
            mode,
            width: self.mg.partials,
            ..self.base
        };
        // SAFETY: the caller's contract.
        unsafe {
            // why: the check sums the partials the norm or krylov kernel just wrote (RAW).
            barrier::memory(
                self.ctx,
                self.cb,
                Access::ComputeWrite,
                Access::ComputeReadWriteTexels,
            );
            pipeline.dispatch(self.ctx, self.cb, *set, &push, [GROUP, 1, 1]);
            // why: the next cycle's indirect dispatches read the arguments the check may have
            // zeroed (RAW at DRAW_INDIRECT).
            barrier::record(
                self.ctx,
                self.cb,
                &[super::super::raw_barrier(
                    S::COMPUTE_SHADER,
                    A::SHADER_STORAGE_WRITE,
                    S::DRAW_INDIRECT | S::COMPUTE_SHADER,
                    A::INDIRECT_COMMAND_READ | A::SHADER_STORAGE_READ | A::SHADER_STORAGE_WRITE,
                )],
                &[],
            );
        }
    }
}
