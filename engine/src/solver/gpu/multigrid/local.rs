//! The warm start's local relaxation ([`MultigridParams::local_relaxation`],
//! `multigrid/local.comp`): mark the finest nodes whose start residual alone exceeds the
//! tolerance, add `rings` of neighbours, then `sweeps` damped block-Jacobi sweeps on those nodes
//! only, every pass after the marking dispatched indirectly over the list's length.

use super::*;
use crate::solver::multigrid::LocalRelaxation;

/// Words of the `local` buffer's header (`HEADER` in `local.comp`): count, range begin and end,
/// a pad, then the range's `VkDispatchIndirectCommand` at word [`LOCAL_ARGS`] and a pad.
const LOCAL_HEADER: u64 = 8;
/// Word of the header's indirect arguments (`ARGS` in `local.comp`).
const LOCAL_ARGS: u64 = 4;
/// Damping of the local Jacobi sweeps (benches/RESULTS.md "Local relaxation of the warm start
/// (wave 8)": 0.8 left a smaller residual than 1.0 and 0.6 in the f64 probe).
const LOCAL_OMEGA: f64 = 0.8;
/// The list holds at most this fraction of the finest nodes (the default scene lists ~7%); the
/// nodes past it are flagged but not relaxed.
const LOCAL_CAPACITY_FRACTION: usize = 4;

/// Modes of `multigrid/local.comp`.
const LOCAL_MARK: u32 = 0;
const LOCAL_RING: u32 = 1;
const LOCAL_GROW: u32 = 2;
const LOCAL_ALL: u32 = 3;
const LOCAL_RESIDUAL: u32 = 4;
const LOCAL_STEP: u32 = 5;

/// Where the `local` buffer keeps its flags and list.
#[derive(Clone, Copy, Debug)]
pub(super) struct LocalLayout {
    /// Flag words (one bit per finest node); 0 without local relaxation.
    words: u32,
    /// List entries.
    capacity: u32,
}

impl LocalLayout {
    pub(super) fn new(params: &MultigridParams, n_top: usize) -> Self {
        if params.local_relaxation.is_none() {
            return Self {
                words: 0,
                capacity: 0,
            };
        }
        Self {
            words: n_top.div_ceil(32) as u32,
            capacity: n_top.div_ceil(LOCAL_CAPACITY_FRACTION) as u32,
        }
    }

    /// `local.comp`'s specialization: its flag words (`LOCAL_WORDS`) and list capacity
    /// (`LOCAL_CAPACITY`).
    pub(super) fn spec_constants(&self) -> [SpecConstant; 2] {
        [
            SpecConstant {
                id: 9,
                value: self.words,
            },
            SpecConstant {
                id: 10,
                value: self.capacity,
            },
        ]
    }

    /// The buffer (storage, indirect arguments, cleared by a transfer each frame).
    pub(super) fn buffer(&self, ctx: &Context) -> Result<Buffer, Error> {
        let words = LOCAL_HEADER + u64::from(self.words) + u64::from(self.capacity);
        Ok(Buffer::new(
            ctx,
            &BufferDesc {
                name: "multigrid local",
                size: 4 * words,
                usage: vk::BufferUsageFlags::STORAGE_BUFFER
                    | vk::BufferUsageFlags::INDIRECT_BUFFER
                    | vk::BufferUsageFlags::TRANSFER_DST,
                // why GpuOnly would do: nothing on the host reads it; Upload keeps every multigrid
                // buffer in the one heap lavapipe has.
                memory: MemoryUse::Upload,
            },
        )?)
    }

    /// Records the clear of the header and the flags (the list is read only below its count).
    ///
    /// # Safety
    /// `cb` must be recording outside a rendering scope; the caller records the barrier to the
    /// kernels that read the buffer.
    pub(super) unsafe fn clear(&self, ctx: &Context, cb: vk::CommandBuffer, local: &Buffer) {
        let size = 4 * (LOCAL_HEADER + u64::from(self.words));
        // SAFETY: the caller's contract; the range lies inside the buffer (`Self::buffer`).
        unsafe { ctx.raw().cmd_fill_buffer(cb, local.raw, 0, size, 0) };
    }
}

impl Recorder<'_, '_> {
    fn local_push(&self, mode: u32, omega: f64) -> MultigridPush {
        let top = self.mg.top();
        let level = &self.mg.levels[top];
        MultigridPush {
            count: level.count,
            offset: level.offset,
            mode,
            beta: [omega as f32; 4],
            ..self.base
        }
    }

    /// One `local.comp` dispatch: `groups` direct, or `None` over the list's current range.
    ///
    /// # Safety
    /// As [`GpuMultigrid::record`].
    unsafe fn local_dispatch(&self, mode: u32, groups: Option<u32>) {
        use vk::AccessFlags2 as A;
        use vk::PipelineStageFlags2 as S;
        let (pipeline, set) = &self.mg.pipelines[LOCAL];
        let push = self.local_push(mode, LOCAL_OMEGA);
        // SAFETY: the caller's contract; `local` has INDIRECT_BUFFER usage and holds the
        // arguments at LOCAL_ARGS.
        unsafe {
            // why: each local pass reads what the one before wrote (x, r, the list: RAW), its
            // indirect arguments included (the range the last ring or all pass set: RAW at
            // DRAW_INDIRECT), and overwrites what it read (WAR).
            barrier::record(
                self.ctx,
                self.cb,
                &[super::super::raw_barrier(
                    S::COMPUTE_SHADER,
                    A::SHADER_STORAGE_WRITE | A::SHADER_STORAGE_READ,
                    S::DRAW_INDIRECT | S::COMPUTE_SHADER,
                    A::INDIRECT_COMMAND_READ | A::SHADER_STORAGE_READ | A::SHADER_STORAGE_WRITE,
                )],
                &[],
            );
            match groups {
                Some(g) => pipeline.dispatch(self.ctx, self.cb, *set, &push, [g * GROUP, 1, 1]),
                None => pipeline.dispatch_indirect(
                    self.ctx,
                    self.cb,
                    *set,
                    &push,
                    &self.mg.local,
                    4 * LOCAL_ARGS,
                ),
            }
        }
    }

    /// The local relaxation of the finest level's x against its f (after the reference ||f||
    /// was stored; before the start's residual).
    ///
    /// # Safety
    /// As [`GpuMultigrid::record`]; the `local` buffer was cleared this frame.
    pub(super) unsafe fn local_relaxation(&self, relaxation: LocalRelaxation) {
        let n_top = self.mg.levels[self.mg.top()].count;
        // SAFETY: the caller's contract.
        unsafe {
            self.local_dispatch(LOCAL_MARK, Some(n_top.div_ceil(GROUP)));
            for _ in 0..relaxation.rings {
                self.local_dispatch(LOCAL_RING, Some(1));
                self.local_dispatch(LOCAL_GROW, None);
            }
            self.local_dispatch(LOCAL_ALL, Some(1));
            for _ in 0..relaxation.sweeps {
                self.local_dispatch(LOCAL_RESIDUAL, None);
                self.local_dispatch(LOCAL_STEP, None);
            }
        }
    }
}

impl Recorder<'_, '_> {
    /// [`Self::local_relaxation`] once more in the same solve: the list's header and flags
    /// cleared first (the listed count adds up in the control record).
    ///
    /// # Safety
    /// As [`GpuMultigrid::record`].
    pub(super) unsafe fn local_relaxation_again(&self, relaxation: LocalRelaxation) {
        use vk::AccessFlags2 as A;
        use vk::PipelineStageFlags2 as S;
        // SAFETY: the caller's contract.
        unsafe {
            // why: the last relaxation's passes read and wrote the list and read it as indirect
            // arguments; the clear overwrites them (WAR, WAW).
            barrier::record(
                self.ctx,
                self.cb,
                &[super::super::raw_barrier(
                    S::COMPUTE_SHADER | S::DRAW_INDIRECT,
                    A::SHADER_STORAGE_WRITE,
                    S::COPY,
                    A::TRANSFER_WRITE,
                )],
                &[],
            );
            self.mg
                .local_layout
                .clear(self.ctx, self.cb, &self.mg.local);
            // why: the marking reads and updates the cleared flags and header (RAW, WAW after
            // the transfer), the later passes read the header as indirect arguments.
            barrier::record(
                self.ctx,
                self.cb,
                &[super::super::raw_barrier(
                    S::COPY,
                    A::TRANSFER_WRITE,
                    S::DRAW_INDIRECT | S::COMPUTE_SHADER,
                    A::INDIRECT_COMMAND_READ | A::SHADER_STORAGE_READ | A::SHADER_STORAGE_WRITE,
                )],
                &[],
            );
            self.local_relaxation(relaxation);
        }
    }
}

impl GpuMultigrid {
    /// Local relaxations of one warm start: one, and one more between two coarse corrections
    /// ([`MultigridParams::warm_corrections`]).
    fn local_passes(&self) -> u64 {
        u64::from(self.params.warm_corrections.max(1))
    }

    /// Node updates of a warm start's local relaxations that listed `listed` nodes together:
    /// per relaxation the marking pass over the finest level, one visit per listed node in the
    /// ring passes (each visits the nodes the one before listed) and one per sweep; and the
    /// coarse corrections after them (a V(0,0) cycle each).
    pub(super) fn local_updates(&self, listed: u64) -> u64 {
        match self.params.local_relaxation {
            Some(r) => {
                let top = self.top();
                let n_top = u64::from(self.levels[top].count);
                self.local_passes() * n_top
                    + listed * u64::from(r.sweeps + u32::from(r.rings > 0))
                    + u64::from(self.params.warm_corrections)
                        * self.v_cycle_updates_with(top, (0, 0))
            }
            None => 0,
        }
    }

    /// Matrix entries the same passes read: the markings' residuals, one per sweep on the
    /// listed nodes (their rows: the finest level's mean) and the coarse corrections'.
    pub(super) fn local_entries(&self, listed: u64) -> u64 {
        match self.params.local_relaxation {
            Some(r) => {
                let top = self.top();
                let level = &self.levels[top];
                let per_row = level.entries as f64 / f64::from(level.count.max(1));
                self.local_passes() * level.entries
                    + (listed as f64 * f64::from(r.sweeps) * per_row).round() as u64
                    + u64::from(self.params.warm_corrections)
                        * self.v_cycle_entries_with(top, false, (0, 0))
            }
            None => 0,
        }
    }
}
