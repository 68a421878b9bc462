//! The finest level's operator applied to a given vector, outside a solve: what tests compare
//! between [`FinestOperator::Csr`] and [`FinestOperator::Graph`] (and against the f64 `K`).

use super::*;

/// `f - K x` and `K x` of the finest level as the GPU forms them.
pub struct FinestProducts {
    /// From `residual.comp` (the V-cycle's residual pass).
    pub residual: Vec<[f32; 3]>,
    /// From `krylov.comp`'s apply mode (the CG's `K z`).
    pub product: Vec<[f32; 3]>,
}

impl GpuMultigrid {
    /// Writes `x` and `f` into the finest level's vectors, runs the residual pass and then the
    /// CG's `K z` pass, and reads both back. Overwrites the finest level's x, f and r (and the
    /// CG's partial sums): the next solve must start cold. The graph textures must hold the
    /// current material's weights (after one solve, for a heterogeneous material whose weights
    /// the GPU derives).
    pub fn apply_finest(
        &mut self,
        ctx: &Context,
        x: &[[f32; 3]],
        f: &[[f32; 3]],
    ) -> Result<FinestProducts, Error> {
        let top = self.top();
        let (offset, count) = (self.levels[top].offset, self.levels[top].count);
        if x.len() != count as usize || f.len() != count as usize {
            return Err(Error::Solver(SolverError::BadParameter {
                name: "apply_finest",
                problem: format!(
                    "{} and {} values for {count} finest nodes",
                    x.len(),
                    f.len()
                ),
            }));
        }
        let stride = self.params.vector_storage.floats();
        let at = |name: &str| BUFFER_NAMES.iter().position(|&n| n == name).unwrap_or(0);
        let lay = |v: &[[f32; 3]]| -> Vec<f32> {
            v.iter()
                .flat_map(|c| {
                    let mut out = [0.0f32; 4];
                    out[..3].copy_from_slice(c);
                    out.into_iter().take(stride)
                })
                .collect()
        };
        let start = offset as usize * stride * 4;
        self.buffers[at("x")].write_bytes(start, bytemuck::cast_slice(&lay(x)))?;
        self.buffers[at("f")].write_bytes(start, bytemuck::cast_slice(&lay(f)))?;
        let read_r = |mg: &Self| -> Result<Vec<[f32; 3]>, Error> {
            let bytes = mg.buffers[at("r")].read_bytes()?;
            let floats: &[f32] =
                bytemuck::cast_slice(&bytes[start..start + count as usize * stride * 4]);
            Ok(floats
                .chunks_exact(stride)
                .map(|c| [c[0], c[1], c[2]])
                .collect())
        };
        self.dispatch_finest(ctx, RESIDUAL, 0)?;
        let residual = read_r(self)?;
        self.dispatch_finest(ctx, KRYLOV, CG_APPLY)?;
        let product = read_r(self)?;
        Ok(FinestProducts { residual, product })
    }

    /// One direct dispatch of `kernel` over the finest level, waited for, its writes made
    /// visible to the host.
    fn dispatch_finest(&self, ctx: &Context, kernel: usize, mode: u32) -> Result<(), Error> {
        use vk::AccessFlags2 as A;
        use vk::PipelineStageFlags2 as S;
        let top = self.top();
        let rec_base = MultigridPush {
            width: self.width,
            sums: self.partials,
            surface_rows: self.surface_rows,
            kappa: self.kappa,
            mu_gain: self.mu_gain,
            ..Default::default()
        };
        ctx.execute("multigrid apply finest", |cb| {
            let mut no_profiler = None;
            let rec = Recorder {
                mg: self,
                ctx,
                cb,
                base: rec_base,
                profiler: std::cell::RefCell::new(&mut no_profiler),
            };
            // SAFETY: `cb` is recording outside a rendering scope; every resource of the sets
            // lives in `self` or the solve that owns it, and the submission is waited for.
            unsafe {
                rec.direct(kernel, top, mode, self.levels[top].count);
                // why: the host reads r after the wait (compute write -> host read).
                barrier::record(
                    ctx,
                    cb,
                    &[super::super::raw_barrier(
                        S::COMPUTE_SHADER,
                        A::SHADER_STORAGE_WRITE,
                        S::HOST,
                        A::HOST_READ,
                    )],
                    &[],
                );
            }
            Ok(())
        })?;
        Ok(())
    }
}

/// Largest magnitudes of one level's vectors at one stage of [`GpuMultigrid::probe_cold_start`].
#[derive(Clone, Debug, serde::Serialize)]
pub struct LevelMagnitudes {
    pub stage: String,
    pub level: usize,
    /// max |v| over the level's nodes and channels (non-finite values counted apart).
    pub x: f32,
    pub f: f32,
    pub r: f32,
    pub d: f32,
    /// Non-finite values of x, f, r, d.
    pub non_finite: [usize; 4],
    /// The node (level index) of the largest |d|, its diagonal (rgb, row scale) and whether it
    /// is paired with a partner (the 2x2 block).
    pub d_node: usize,
    pub d_node_diag: [f32; 4],
    pub d_node_paired: bool,
}

impl GpuMultigrid {
    /// Measurement only (`TRANSLUCENT_MULTIGRID_PROBE=1` in `translucent render`): replays the
    /// cold start's full multigrid pass stage by stage from the q image of the last solve and
    /// reads every level's vectors after each stage. Overwrites the solve's vectors: the next
    /// solve must start cold.
    pub fn probe_cold_start(&self, ctx: &Context) -> Result<Vec<LevelMagnitudes>, Error> {
        let top = self.top();
        let mut control: MultigridControl = bytemuck::Zeroable::zeroed();
        for (l, level) in self.levels.iter().enumerate() {
            control.args[l] = [level.count.div_ceil(GROUP), 1, 1, 0];
        }
        let base = MultigridPush {
            width: self.width,
            tolerance: 0.0,
            max_log: 2,
            sums: self.partials,
            surface_rows: self.surface_rows,
            kappa: self.kappa,
            mu_gain: self.mu_gain,
            ..Default::default()
        };
        let mut rows = Vec::new();
        let run = |stage: &str,
                   rows: &mut Vec<LevelMagnitudes>,
                   body: &dyn Fn(&Recorder<'_, '_>)|
         -> Result<(), Error> {
            ctx.execute("multigrid probe", |cb| {
                let mut no_profiler = None;
                let rec = Recorder {
                    mg: self,
                    ctx,
                    cb,
                    base,
                    profiler: std::cell::RefCell::new(&mut no_profiler),
                };
                body(&rec);
                // SAFETY: `cb` is recording; the host reads after the wait.
                unsafe {
                    // why: the host reads the vectors (compute write -> host read).
                    barrier::memory(ctx, cb, Access::ComputeWrite, Access::HostRead);
                }
                Ok(())
            })?;
            rows.extend(self.magnitudes(stage)?);
            Ok(())
        };
        let n_top = self.levels[top].count;
        let control_buffer = &self.control;
        run("rhs, restrict", &mut rows, &|rec| {
            // SAFETY: as `record`: every set's resources live in `self`; the submission is
            // waited for.
            unsafe {
                ctx.raw().cmd_update_buffer(
                    rec.cb,
                    control_buffer.raw,
                    0,
                    bytemuck::bytes_of(&control),
                );
                // why: the kernels read the reset control record as indirect arguments and
                // update it (RAW after the transfer).
                barrier::record(
                    ctx,
                    rec.cb,
                    &[super::super::raw_barrier(
                        vk::PipelineStageFlags2::COPY,
                        vk::AccessFlags2::TRANSFER_WRITE,
                        vk::PipelineStageFlags2::DRAW_INDIRECT
                            | vk::PipelineStageFlags2::COMPUTE_SHADER,
                        vk::AccessFlags2::INDIRECT_COMMAND_READ
                            | vk::AccessFlags2::SHADER_STORAGE_READ
                            | vk::AccessFlags2::SHADER_STORAGE_WRITE,
                    )],
                    &[],
                );
                rec.direct(RHS, top, RHS_COLD, n_top);
                for l in (1..=top).rev() {
                    rec.indirect(RESTRICT, l - 1, 1, [0.0; 3], [0.0; 3]);
                }
            }
        })?;
        // The stages after the first: (name, what they record).
        type Stage<'s> = (String, Box<dyn Fn(&Recorder<'_, '_>) + 's>);
        let mut stages: Vec<Stage<'_>> = vec![(
            "coarse solve".into(),
            // SAFETY: as above.
            Box::new(|rec| unsafe { rec.coarse() }),
        )];
        for l in 1..=top {
            let (pre, post) = self.params.fmg_sweeps_at(l, top);
            stages.push((
                format!("L{l} prolong"),
                // SAFETY: as above.
                Box::new(move |rec| unsafe { rec.indirect(PROLONG, l, 1, [0.0; 3], [0.0; 3]) }),
            ));
            stages.push((
                format!("L{l} pre-smooth {pre}"),
                // SAFETY: as above.
                Box::new(move |rec| unsafe { rec.smooth(l, pre, Start::X) }),
            ));
            stages.push((
                format!("L{l} restrict"),
                // SAFETY: as above.
                Box::new(move |rec| unsafe {
                    rec.indirect(RESIDUAL, l, 0, [0.0; 3], [0.0; 3]);
                    rec.indirect(RESTRICT, l - 1, 0, [0.0; 3], [0.0; 3]);
                }),
            ));
            stages.push((
                format!("L{l} coarse correction"),
                // SAFETY: as above.
                Box::new(move |rec| unsafe { rec.v_cycle(l - 1, true) }),
            ));
            stages.push((
                format!("L{l} prolong correction"),
                // SAFETY: as above.
                Box::new(move |rec| unsafe { rec.indirect(PROLONG, l, 0, [0.0; 3], [0.0; 3]) }),
            ));
            stages.push((
                format!("L{l} post-smooth {post}"),
                // SAFETY: as above.
                Box::new(move |rec| unsafe { rec.smooth(l, post, Start::X) }),
            ));
        }
        for (name, body) in &stages {
            run(name, &mut rows, body.as_ref())?;
        }
        Ok(rows)
    }

    /// Per level the largest magnitudes of x, f, r and d (see [`LevelMagnitudes`]).
    fn magnitudes(&self, stage: &str) -> Result<Vec<LevelMagnitudes>, Error> {
        let at = |name: &str| BUFFER_NAMES.iter().position(|&n| n == name).unwrap_or(0);
        let stride = self.params.vector_storage.floats();
        let half = self.params.update_storage == UpdateStorage::F16;
        let floats = |name: &str| -> Result<Vec<f32>, Error> {
            Ok(bytemuck::pod_collect_to_vec(
                self.buffers[at(name)].read_bytes()?,
            ))
        };
        let (x, f, r) = (floats("x")?, floats("f")?, floats("r")?);
        let d_raw: Vec<u32> = bytemuck::pod_collect_to_vec(self.buffers[at("d")].read_bytes()?);
        let diag: Vec<[f32; 4]> =
            bytemuck::pod_collect_to_vec(self.buffers[at("diag")].read_bytes()?);
        let partner: Vec<u32> =
            bytemuck::pod_collect_to_vec(self.buffers[at("partner")].read_bytes()?);
        let d_at = |i: usize| -> [f32; 3] {
            if half {
                let lo = d_raw[2 * i];
                let hi = d_raw[2 * i + 1];
                [
                    half::f16::from_bits(lo as u16).to_f32(),
                    half::f16::from_bits((lo >> 16) as u16).to_f32(),
                    half::f16::from_bits(hi as u16).to_f32(),
                ]
            } else {
                std::array::from_fn(|c| f32::from_bits(d_raw[stride * i + c]))
            }
        };
        let mut out = Vec::new();
        for (l, level) in self.levels.iter().enumerate() {
            let nodes = level.offset as usize..(level.offset + level.count) as usize;
            let mut m = LevelMagnitudes {
                stage: stage.to_string(),
                level: l,
                x: 0.0,
                f: 0.0,
                r: 0.0,
                d: 0.0,
                non_finite: [0; 4],
                d_node: 0,
                d_node_diag: [0.0; 4],
                d_node_paired: false,
            };
            for i in nodes {
                for c in 0..3 {
                    let vals = [
                        x[stride * i + c],
                        f[stride * i + c],
                        r[stride * i + c],
                        d_at(i)[c],
                    ];
                    for (k, v) in vals.into_iter().enumerate() {
                        if !v.is_finite() {
                            m.non_finite[k] += 1;
                            continue;
                        }
                        let slot = match k {
                            0 => &mut m.x,
                            1 => &mut m.f,
                            2 => &mut m.r,
                            _ => &mut m.d,
                        };
                        if v.abs() > *slot {
                            *slot = v.abs();
                            if k == 3 {
                                m.d_node = i - level.offset as usize;
                                m.d_node_diag = diag[i];
                                m.d_node_paired = partner[i] != NO_NODE;
                            }
                        }
                    }
                }
            }
            out.push(m);
        }
        Ok(out)
    }
}
