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
