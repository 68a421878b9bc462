//! Read-backs for tests, reports and the CLI (each waits on its own submission).

use super::*;

impl GpuDiffusion {
    /// Headless: makes the last solve's buffer writes host-visible (own submission, waited).
    fn sync_host(&self, ctx: &Context) -> Result<(), Error> {
        ctx.execute("diffusion host sync", |cb| {
            // SAFETY: `cb` is recording.
            unsafe {
                // why: the CPU reads the control, count and vertex buffers the compute passes
                // wrote (RAW across the host boundary).
                barrier::memory(ctx, cb, Access::ComputeWrite, Access::HostRead);
            }
            Ok(())
        })?;
        Ok(())
    }

    /// Headless, after the solve's submission completed: the control record of every level.
    pub fn control(&self, ctx: &Context) -> Result<Vec<LevelControl>, Error> {
        self.sync_host(ctx)?;
        let bytes = self.control.read_bytes()?;
        Ok(bytes
            .chunks_exact(std::mem::size_of::<LevelControl>())
            .map(bytemuck::pod_read_unaligned)
            .collect())
    }

    /// Headless, after the solve's submission completed: what the multigrid schedule's last
    /// solve did (`None` with the cascade).
    pub fn multigrid_report(
        &self,
        ctx: &Context,
    ) -> Result<Option<multigrid::GpuMultigridReport>, Error> {
        let Some(mg) = &self.multigrid else {
            return Ok(None);
        };
        self.sync_host(ctx)?;
        Ok(Some(mg.report()?))
    }

    /// Headless, after a solve (measurement only): the cold start replayed stage by stage with
    /// every level's largest magnitudes after each ([`multigrid::GpuMultigrid::probe_cold_start`];
    /// `None` with the cascade). Overwrites the solve's vectors: for a last frame only.
    pub fn multigrid_probe(
        &self,
        ctx: &Context,
    ) -> Result<Option<Vec<multigrid::LevelMagnitudes>>, Error> {
        self.sync_host(ctx)?;
        match &self.multigrid {
            Some(mg) => Ok(Some(mg.probe_cold_start(ctx)?)),
            None => Ok(None),
        }
    }

    /// Headless, between solves: the finest level's `f - K x` and `K x` as the multigrid's
    /// kernels form them ([`multigrid::GpuMultigrid::apply_finest`]; `None` with the cascade).
    /// The next solve starts cold.
    pub fn multigrid_apply_finest(
        &mut self,
        ctx: &Context,
        x: &[[f32; 3]],
        f: &[[f32; 3]],
    ) -> Result<Option<multigrid::FinestProducts>, Error> {
        self.sync_host(ctx)?;
        self.solved = false;
        match &mut self.multigrid {
            Some(mg) => Ok(Some(mg.apply_finest(ctx, x, f)?)),
            None => Ok(None),
        }
    }

    /// Headless: Jacobi iterations run per level (the GPU's counter).
    pub fn iterations_run(&self, ctx: &Context) -> Result<Vec<u32>, Error> {
        Ok(self.control(ctx)?.iter().map(|c| c.iterations).collect())
    }

    /// Headless: surface nodes clamped at J+ = 0 per channel in the last solve.
    pub fn clamped(&self, ctx: &Context) -> Result<[u32; 3], Error> {
        self.sync_host(ctx)?;
        let b = self.clamp_counts.read_bytes()?;
        let c: [u32; 4] = bytemuck::pod_read_unaligned(&b[..16]);
        Ok([c[0], c[1], c[2]])
    }

    /// Headless: the per display-vertex J+ of the last solve.
    pub fn read_vertex_j_plus(&self, ctx: &Context) -> Result<Vec<[f32; 3]>, Error> {
        self.sync_host(ctx)?;
        let b = self.vertex_j_plus.read_bytes()?;
        Ok(b.chunks_exact(16)
            .take(self.vertex_count as usize)
            .map(|c| {
                let v: [f32; 4] = bytemuck::pod_read_unaligned(c);
                [v[0], v[1], v[2]]
            })
            .collect())
    }

    fn read_nodes(
        &self,
        ctx: &Context,
        img: &Image,
        level: &GpuLevel,
        scale: f32,
    ) -> Result<Vec<[f32; 3]>, Error> {
        if (img.width, img.height) != (level.packing.width, level.packing.height) {
            // A placeholder (`upload.rs`): the multigrid schedule keeps phi of the finest level only.
            return Err(bad_param(
                "level",
                format!("{} holds no per-node values under this schedule", img.name),
            ));
        }
        let linear = ImageReadback::capture(ctx, img, Access::ComputeReadWrite)?;
        Ok(level
            .packing
            .texels
            .iter()
            .map(|&[u, v]| {
                let p = linear.pixel(u, v);
                [p[0] * scale, p[1] * scale, p[2] * scale]
            })
            .collect())
    }

    /// Headless: phi of `level` in node order (inner, then surface), unscaled.
    pub fn read_phi(&self, ctx: &Context, level: usize) -> Result<Vec<[f32; 3]>, Error> {
        let l = self.levels.get(level).ok_or_else(|| {
            bad_param(
                "level",
                format!("{level} (only {} levels)", self.levels.len()),
            )
        })?;
        self.read_nodes(ctx, l.result(), l, 1.0 / self.q_scale)
    }

    /// Headless: q per surface node of the finest level (surface index order), unscaled: what
    /// the gather and, with `--bounce source`, the bounced light wrote (the q image holds the
    /// surface rows only).
    pub fn read_q(&self, ctx: &Context) -> Result<Vec<[f32; 3]>, Error> {
        let l = &self.levels[self.levels.len() - 1];
        let scale = 1.0 / self.q_scale;
        let linear = ImageReadback::capture(ctx, &l.q, Access::ComputeReadWrite)?;
        Ok(l.packing.texels[l.inner_count..]
            .iter()
            .map(|&[u, v]| {
                let p = linear.pixel(u, v);
                [p[0] * scale, p[1] * scale, p[2] * scale]
            })
            .collect())
    }

    /// Headless: clamped J+ per surface node of the finest level (surface index order).
    pub fn read_j_plus(&self, ctx: &Context) -> Result<Vec<[f32; 3]>, Error> {
        let l = &self.levels[self.levels.len() - 1];
        // The J+ image holds the surface rows only.
        let linear = ImageReadback::capture(ctx, &self.j_plus, Access::ComputeReadWrite)?;
        Ok(l.packing.texels[l.inner_count..]
            .iter()
            .map(|&[u, v]| {
                let p = linear.pixel(u, v);
                [p[0], p[1], p[2]]
            })
            .collect())
    }

    /// Per surface node of the finest level the diffused share of the per-node exit lobe
    /// ([`crate::scene::diffused_share`], the J+ image's alpha), in the order of
    /// [`Self::read_j_plus`].
    pub fn read_diffused_share(&self, ctx: &Context) -> Result<Vec<f32>, Error> {
        let l = &self.levels[self.levels.len() - 1];
        let linear = ImageReadback::capture(ctx, &self.j_plus, Access::ComputeReadWrite)?;
        Ok(l.packing.texels[l.inner_count..]
            .iter()
            .map(|&[u, v]| linear.pixel(u, v)[3])
            .collect())
    }

    /// Headless: the per display-vertex diffused share of the last solve (the vertex stream
    /// [`crate::frame::Method::exit_share`] hands the shading).
    pub fn read_vertex_diffused_share(&self, ctx: &Context) -> Result<Vec<f32>, Error> {
        self.sync_host(ctx)?;
        let b = self.vertex_j_plus.read_bytes()?;
        Ok(b.chunks_exact(16)
            .take(self.vertex_count as usize)
            .map(|c| {
                let v: [f32; 4] = bytemuck::pod_read_unaligned(c);
                v[3]
            })
            .collect())
    }
}
