//! What a solve did: work and matrix-vector units per pass (as [`Hierarchy::solve`] counts them)
//! and the report read back from the control record; the accessors a report and a frame read
//! (bytes, the control record, the finest x).

use super::*;

/// How a GPU multigrid solve ended ([`MultigridControl::state`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum CycleState {
    Running,
    Converged,
    Diverged,
    CycleCap,
}

/// What the last GPU multigrid solve did, read after its frame.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct GpuMultigridReport {
    /// Started from the last solution (V-cycles only).
    pub warm: bool,
    /// Order of the warm start's extrapolation (0: the last solution; 1: linear through the last
    /// two; 2: quadratic through the last three); 0 when cold.
    pub warm_order: u32,
    /// Cold: the full multigrid pass first, then the V-cycles; warm: the V-cycles (factor against
    /// the starting residual).
    pub cycles: Vec<CycleReport>,
    /// Relative residual at the start (warm: after the local relaxation, if any) or after the
    /// full multigrid pass (cold).
    pub start_residual: f64,
    pub residual: f64,
    pub converged: bool,
    pub state: CycleState,
    /// Node updates / finest nodes (as the CPU [`Hierarchy::solve`] counts them; a CG iteration
    /// also counts its two passes over the finest level: K z with the dots, and the step).
    pub work_units: f64,
    /// Matrix entries read (operator rows with their diagonal, prolongation and restriction
    /// links) / the entries of one finest-level operator application: the work unit that
    /// weighs the coarse levels' wider rows (a Galerkin row holds ~10x a finest row's entries).
    pub matvec_units: f64,
    /// Geometric mean of the V-cycles' factors; `None` before two.
    pub mean_factor: Option<f64>,
    /// Chebyshev steps of every coarsest-level solve.
    pub coarse_steps: u32,
    /// Finest nodes the warm start's local relaxation relaxed (0: none, or a cold start).
    pub local_nodes: u32,
    /// Read-only inputs read through texel views (`TRANSLUCENT_MULTIGRID_READS`).
    pub texel_reads: bool,
    /// The fp16 rows' columns read from their entries (`TRANSLUCENT_MULTIGRID_COLUMNS`).
    pub packed_columns: bool,
}

impl GpuMultigridReport {
    /// `Err(SolverError::GpuDiverged)` when the solve ended Diverged or with a non-finite
    /// residual (its solution must not reach an image); `levels` and `coarsest_nodes` name the
    /// hierarchy in the message.
    ///
    /// ```
    /// # use translucent::solver::gpu::multigrid::GpuMultigridReport;
    /// # fn f(report: &GpuMultigridReport) -> Result<(), translucent::solver::SolverError> {
    /// report.check(3, 1_100)?;
    /// # Ok(()) }
    /// ```
    pub fn check(&self, levels: usize, coarsest_nodes: usize) -> Result<(), SolverError> {
        let finite = self.residual.is_finite() && self.start_residual.is_finite();
        if self.state != CycleState::Diverged && finite {
            return Ok(());
        }
        Err(SolverError::GpuDiverged {
            residual: self.residual,
            start_residual: self.start_residual,
            cycles: self.cycles.len(),
            levels,
            coarsest_nodes,
        })
    }
}

impl GpuMultigrid {
    /// Whether the CG starts with one pass forming the start's residual, its norm and the
    /// iterate (`krylov.comp` mode 3) instead of a residual, a norm and a copy: with CG and a
    /// finest-level pre-smoother (whose first step from zero does not read the x it leaves).
    pub(super) fn fused_start(&self) -> bool {
        self.params.krylov && self.sweeps(self.top()).0 > 0
    }

    /// Work units of one V-cycle from level `l` (as [`Hierarchy::solve`] counts them).
    pub(super) fn v_cycle_updates(&self, l: usize) -> u64 {
        self.v_cycle_updates_with(l, self.sweeps(l))
    }

    /// [`Self::v_cycle_updates`] with `(pre, post)` smoothing steps on level `l`.
    pub(super) fn v_cycle_updates_with(&self, l: usize, (pre, post): (u32, u32)) -> u64 {
        if l == 0 {
            return u64::from(self.coarse_steps + 1) * u64::from(self.levels[0].count);
        }
        let n = u64::from(self.levels[l].count);
        n * u64::from(pre + post + 3) + self.v_cycle_updates(l - 1)
    }

    /// Matrix entries one V-cycle from level `l` reads (see [`GpuMultigridReport::matvec_units`]).
    /// `from_zero`: the cycle starts from x = 0 (a coarse correction, or the CG's preconditioner),
    /// so its first smoothing step reads f and no residual.
    pub(super) fn v_cycle_entries(&self, l: usize, from_zero: bool) -> u64 {
        self.v_cycle_entries_with(l, from_zero, self.sweeps(l))
    }

    /// [`Self::v_cycle_entries`] with `(pre, post)` smoothing steps on level `l`.
    pub(super) fn v_cycle_entries_with(
        &self,
        l: usize,
        from_zero: bool,
        (pre, post): (u32, u32),
    ) -> u64 {
        let level = &self.levels[l];
        if l == 0 {
            // The coarsest level always starts from zero (the restriction zeroes it).
            return u64::from(self.coarse_steps.saturating_sub(1)) * level.entries;
        }
        // A residual per smoothing step (but a first one from zero) and one before the
        // restriction; restriction and prolongation read the links once each.
        let skipped = u32::from(from_zero && pre > 0);
        u64::from(pre + post + 1 - skipped) * level.entries
            + 2 * level.links
            + self.v_cycle_entries(l - 1, true)
    }

    /// GPU bytes of the buffers.
    pub fn bytes(&self) -> u64 {
        self.bytes
    }

    /// Bytes per buffer (the operators' `row_start`, `cols`, `values`, `values16`, `diag`, ...,
    /// the vectors, the control record): they sum to [`Self::bytes`].
    pub fn bytes_by_buffer(&self) -> &[(&'static str, u64)] {
        &self.buffer_bytes
    }

    /// Chebyshev steps of one coarsest-level solve.
    pub fn coarse_steps(&self) -> u32 {
        self.coarse_steps
    }

    /// The finest level's x (after a solve its solution, `scale` times phi): its buffer and
    /// byte range. `render --bounce source` keeps the first solve's across the second, whose
    /// sum would otherwise start the next frame's first solve a whole bounce away.
    pub fn finest_x(&self) -> (&Buffer, u64, u64) {
        let top = &self.levels[self.top()];
        let bytes = (self.params.vector_storage.floats() * std::mem::size_of::<f32>()) as u64;
        debug_assert_eq!(BUFFER_NAMES[0], "x");
        (
            &self.buffers[0],
            u64::from(top.offset) * bytes,
            u64::from(top.count) * bytes,
        )
    }

    /// The control record of the last solve (call after its submission completed and its writes
    /// were made host-visible).
    pub fn control(&self) -> Result<MultigridControl, Error> {
        let bytes = self.control.read_bytes()?;
        Ok(bytemuck::pod_read_unaligned(
            &bytes[..std::mem::size_of::<MultigridControl>()],
        ))
    }

    /// What the last solve did, from its control record.
    pub fn report(&self) -> Result<GpuMultigridReport, Error> {
        self.report_of(&self.control()?, self.warm.get())
    }

    /// The control buffer (a frame's solve copies it for the host: [`Self::report_of`]).
    pub(crate) fn control_buffer(&self) -> &Buffer {
        &self.control
    }

    /// What a solve did from its control record `c` (a copy taken after its frame) and whether
    /// it started warm.
    pub fn report_of(&self, c: &MultigridControl, warm: bool) -> Result<GpuMultigridReport, Error> {
        let top = self.top();
        let n_top = u64::from(self.levels[top].count).max(1);
        let logged = (c.logged as usize).min(MAX_LOG);
        let log: Vec<f64> = c.residual[..logged].iter().map(|&v| f64::from(v)).collect();
        let per = |u: u64| u as f64 / n_top as f64;
        // A CG iteration: the V-cycle, then the apply (K z and the dots) and step (direction,
        // K dir, iterate and residual) passes; without CG the V-cycle and the residual (its norm
        // in the same pass).
        let krylov = self.params.krylov;
        let v_updates = self.v_cycle_updates(top) + if krylov { 2 * n_top } else { n_top };
        // CG: the start and finish passes (x into the iterate and back); the fused start is
        // also the start's residual and norm (counted below).
        let krylov_ends = match (krylov, self.fused_start()) {
            (true, true) => n_top,
            (true, false) => 2 * n_top,
            (false, _) => 0,
        };
        let mut cycles = Vec::new();
        // The start: warm, the residual's norm; cold, the full multigrid pass (f restricted,
        // the coarsest solved, per level a prolongation and a V-cycle) and the residual's norm.
        // A warm start keeping earlier solutions also reads and shifts them (one pass).
        let extrapolation = if warm && self.params.warm_start.history() > 0 {
            n_top
        } else {
            0
        };
        // A warm start relaxed locally: the marking pass and the listed nodes' updates.
        let listed = if warm { u64::from(c.local_nodes) } else { 0 };
        let relaxed = warm && c.warm_order > 0;
        let local = if relaxed {
            self.local_updates(listed)
        } else {
            0
        };
        let start = krylov_ends
            + if warm {
                n_top + extrapolation + local
            } else {
                (1..=top)
                    .map(|l| {
                        2 * u64::from(self.levels[l].count)
                            + u64::from(self.params.fmg_cycles_at(l, top))
                                * self.v_cycle_updates_with(l, self.params.fmg_sweeps_at(l, top))
                    })
                    .sum::<u64>()
                    + self.v_cycle_updates(0)
                    + n_top
            };
        if !warm {
            if let Some(&r) = log.first() {
                cycles.push(CycleReport {
                    residual: r,
                    factor: r,
                    work_units: per(start),
                });
            }
        }
        for k in 1..log.len() {
            cycles.push(CycleReport {
                residual: log[k],
                factor: if log[k - 1] > 0.0 {
                    log[k] / log[k - 1]
                } else {
                    0.0
                },
                work_units: per(v_updates),
            });
        }
        let v_factors: Vec<f64> = cycles
            .iter()
            .skip(usize::from(!warm))
            .map(|c| c.factor)
            .collect();
        let mean_factor = (v_factors.len() >= 2).then(|| {
            let logs: f64 = v_factors.iter().map(|f| f.max(1e-300).ln()).sum();
            (logs / v_factors.len() as f64).exp()
        });
        let state = match c.state {
            0 => CycleState::Running,
            1 => CycleState::Converged,
            2 => CycleState::Diverged,
            _ => CycleState::CycleCap,
        };
        let residual = log.last().copied().unwrap_or(f64::NAN);
        let v_cycles = log.len().saturating_sub(1) as u64;
        let work_units = per(start + v_cycles * v_updates);
        // The same passes in matrix entries: the finest residual or K p once per cycle (plus
        // the start's), full multigrid's restrictions, coarsest solve, prolongations, V-cycles.
        let top_entries = self.levels[top].entries;
        let v_entries = self.v_cycle_entries(top, self.params.krylov) + top_entries;
        let start_entries = top_entries
            + if warm {
                if relaxed {
                    self.local_entries(listed)
                } else {
                    0
                }
            } else {
                (1..=top)
                    .map(|l| {
                        2 * self.levels[l].links
                            + u64::from(self.params.fmg_cycles_at(l, top))
                                * self.v_cycle_entries_with(
                                    l,
                                    false,
                                    self.params.fmg_sweeps_at(l, top),
                                )
                    })
                    .sum::<u64>()
                    + self.v_cycle_entries(0, true)
            };
        let matvec_units =
            (start_entries + v_cycles * v_entries) as f64 / top_entries.max(1) as f64;
        Ok(GpuMultigridReport {
            warm,
            warm_order: c.warm_order,
            start_residual: log.first().copied().unwrap_or(f64::NAN),
            residual,
            converged: state == CycleState::Converged,
            state,
            cycles,
            work_units,
            matvec_units,
            mean_factor,
            coarse_steps: self.coarse_steps,
            local_nodes: listed as u32,
            texel_reads: self.reads == texels::Reads::Texel,
            packed_columns: self.packed_columns,
        })
    }
}
