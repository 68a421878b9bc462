//! A material edit: the new field's texels staged for the next frame's `edits` pass (and the
//! heterogeneous textures created on the first heterogeneous material).

use ash::vk;

use crate::material::{fresnel, MaterialField};
use crate::shader::{ComputePipeline, ComputePipelineDesc, DescriptorWrite};
use crate::solver::gpu::textures::{HomogeneousMaterial, MaterialTexels};
use crate::solver::gpu::{bytes_of, image, GpuDiffusion, SolverError};
use crate::solver::transport::Boundary;
use crate::vk::Context;
use crate::{Error, QuadGraph};

use super::*;

impl GpuDiffusion {
    /// Allocates the fv fraction texture of every level (seeded with the rest pose).
    pub(super) fn ensure_frac(&mut self, ctx: &Context) -> Result<(), Error> {
        for h in 0..self.levels.len() {
            if self.levels[h].frac.is_some() {
                continue;
            }
            let cascade = self.graph_packing(h);
            let l = &mut self.levels[h];
            l.frac = Some(image(
                ctx,
                "diffusion weight frac",
                &cascade,
                vk::Format::R32G32B32A32_SFLOAT,
            )?);
            let mut bytes = bytes_of(&l.rest.frac);
            bytes.truncate((cascade.width * cascade.height) as usize * 16);
            self.stage(ctx, h, Target::Frac, &bytes, true)?;
        }
        Ok(())
    }

    /// Allocates what a heterogeneous material needs on every level (fractions, kappa, mu, the
    /// three weight textures, the derivation's set) and its pipeline variant.
    pub(crate) fn ensure_heterogeneous(&mut self, ctx: &Context) -> Result<(), Error> {
        self.ensure_frac(ctx)?;
        // Derived in the sweep (`HeterogeneousWeights::Derived`): no weight textures, no pass.
        let stored = !self.derives_weights();
        if stored && self.pipelines.derive.is_none() {
            self.pipelines.derive = Some(ComputePipeline::new(
                ctx,
                &ComputePipelineDesc {
                    name: PASS_DERIVE_WEIGHTS,
                    shader: "edit/derive_weights.comp",
                    bindings: &[
                        "connectivity",
                        "geo",
                        "frac",
                        "kappa",
                        "mu",
                        "weight_r",
                        "weight_g",
                        "weight_b",
                    ],
                    max_sets: self.levels.len() as u32,
                },
            )?);
        }
        for h in 0..self.levels.len() {
            if self.levels[h].material.is_some() {
                continue;
            }
            let f32x4 = vk::Format::R32G32B32A32_SFLOAT;
            // Under the multigrid schedule the weights are placeholders (`upload.rs`): its
            // hierarchy is built on the CPU, and nothing derives or reads them.
            let cascade = self.cascade_packing(h);
            let l = &mut self.levels[h];
            let p = &l.packing;
            l.material = Some([
                image(ctx, "diffusion kappa", p, f32x4)?,
                image(ctx, "diffusion mu", p, f32x4)?,
            ]);
            if stored {
                l.weights = Some([
                    image(ctx, "diffusion weight r", &cascade, f32x4)?,
                    image(ctx, "diffusion weight g", &cascade, f32x4)?,
                    image(ctx, "diffusion weight b", &cascade, f32x4)?,
                ]);
            }
            // Every new texture gets a first (fresh) upload, which also moves it out of
            // UNDEFINED; set_material's kappa and mu replace these zeros before any record.
            let zeros = vec![0u8; l.rest.texel_count() * 16];
            let weight_zeros = vec![0u8; (cascade.width * cascade.height) as usize * 16];
            let weights = [Target::Weight(0), Target::Weight(1), Target::Weight(2)];
            for (target, bytes) in [(Target::Kappa, &zeros), (Target::Mu, &zeros)]
                .into_iter()
                .chain(
                    weights
                        .into_iter()
                        .map(|t| (t, &weight_zeros))
                        .filter(|_| stored),
                )
            {
                self.stage(ctx, h, target, bytes, true)?;
            }
            if self.params.multigrid.is_some() {
                continue; // no derivation set: nothing to derive into
            }
            let l = &mut self.levels[h];
            let (Some(derive), Some(frac), Some([kappa, mu]), Some([r, g, b])) =
                (&self.pipelines.derive, &l.frac, &l.material, &l.weights)
            else {
                continue;
            };
            l.derive_set = Some(derive.allocate_set(
                ctx,
                &[
                    DescriptorWrite::storage_image("connectivity", &l.connectivity),
                    DescriptorWrite::storage_image("geo", &l.geo),
                    DescriptorWrite::storage_image("frac", frac),
                    DescriptorWrite::storage_image("kappa", kappa),
                    DescriptorWrite::storage_image("mu", mu),
                    DescriptorWrite::storage_image("weight_r", r),
                    DescriptorWrite::storage_image("weight_g", g),
                    DescriptorWrite::storage_image("weight_b", b),
                ],
            )?);
        }
        self.ensure_variant(ctx, false)
    }

    /// The packing of level `h`'s graph factors (geometry, fv fractions): the cascade's, and
    /// full size on the finest level for the multigrid's matrix-free finest operator
    /// (`FinestOperator::Graph`, which reads them).
    pub(crate) fn graph_packing(&self, h: usize) -> crate::quadgraph::graph::Packing {
        let graph =
            self.params.multigrid.as_ref().is_some_and(|m| {
                m.finest_operator == crate::solver::multigrid::FinestOperator::Graph
            });
        if graph && h + 1 == self.levels.len() {
            self.levels[h].packing.clone()
        } else {
            self.cascade_packing(h)
        }
    }

    /// The packing of level `h`'s cascade-only textures: a 1x1 placeholder under the multigrid
    /// schedule (`upload.rs`).
    pub(crate) fn cascade_packing(&self, h: usize) -> crate::quadgraph::graph::Packing {
        if self.params.multigrid.is_some() {
            crate::solver::gpu::upload::placeholder()
        } else {
            self.levels[h].packing.clone()
        }
    }

    /// Stages a new material for every level (see the module doc). The graph must be the one the
    /// solve was built from. A bad material is a typed error naming the node; nothing changes then.
    pub fn set_material(
        &mut self,
        ctx: &Context,
        graph: &QuadGraph,
        field: &MaterialField,
    ) -> Result<(), Error> {
        self.check_graph(graph)?;
        let eta = field.eta();
        crate::material::check_eta(eta).map_err(SolverError::from)?;
        // The boundary model of the exit query (DESIGN 2.6 for moments): A and the flux gain.
        let boundary = Boundary::new(eta, self.params.exit);
        let (f_dr, a) = (fresnel::diffuse_reflectance(eta), boundary.a);
        let q_gain = boundary.flux_gain;
        let homogeneous = match field {
            MaterialField::Homogeneous(m) => {
                let c = m.coefficients();
                crate::material::check_pair(c.sigma_s, c.sigma_a).map_err(SolverError::from)?;
                Some(HomogeneousMaterial {
                    // D of the material's kind (classical or Grosjean).
                    kappa: m.kappa(),
                    mu: c.mu(),
                })
            }
            _ => None,
        };
        let materials = match homogeneous {
            Some(_) => Vec::new(),
            None => graph
                .levels
                .iter()
                .zip(&self.levels)
                .enumerate()
                .map(|(h, (level, l))| {
                    MaterialTexels::build(level, &l.packing, field).map_err(|e| e.at_level(h))
                })
                .collect::<Result<Vec<_>, _>>()?,
        };
        match homogeneous {
            Some(_) => self.ensure_variant(ctx, true)?,
            None => {
                self.ensure_heterogeneous(ctx)?;
                for (h, m) in materials.iter().enumerate() {
                    self.stage(ctx, h, Target::Kappa, &bytes_of(&m.kappa), false)?;
                    self.stage(ctx, h, Target::Mu, &bytes_of(&m.mu), false)?;
                }
                self.edits.derive = true;
            }
        }
        self.homogeneous = homogeneous.is_some();
        self.f_dr = f_dr;
        self.a = a;
        self.boundary = boundary;
        self.set_constants(homogeneous, a, q_gain);
        self.ensure_interior_sets(ctx)?;
        self.build_multigrid(ctx, graph, field)?;
        Ok(())
    }

    /// The multigrid schedule's hierarchy for `field` (Galerkin levels on the CPU, uploaded),
    /// when the parameters ask for it; the next solve starts cold.
    fn build_multigrid(
        &mut self,
        ctx: &Context,
        graph: &QuadGraph,
        field: &MaterialField,
    ) -> Result<(), Error> {
        let Some(mg) = self.params.multigrid.clone() else {
            return Ok(());
        };
        self.multigrid = None;
        let hierarchy = crate::solver::multigrid::Hierarchy::build_with(
            graph,
            field,
            self.params.scheme,
            self.params.exit,
            &mg,
        )?;
        let finest = self.levels.last().ok_or(SolverError::EmptyGraph)?;
        // The cascade's graph of the finest level (the matrix-free finest operator,
        // `FinestOperator::Graph`): a heterogeneous material's weights derived in the kernel
        // from the fv fractions, kappa and mu (the multigrid derives no weight textures).
        let derived = !self.homogeneous;
        let [r, g, b] = finest.weight_images(&self.poison, self.homogeneous, derived)?;
        let graph = crate::solver::gpu::multigrid::FinestGraph {
            connectivity: &finest.connectivity,
            weights: [&finest.geo, r, g, b],
            homogeneous: self.homogeneous,
            derived,
            paper: self.params.scheme == crate::solver::operator::Scheme::Paper,
            kappa: self.kappa,
            mu_gain: self.mu_gain,
        };
        self.multigrid = Some(crate::solver::gpu::multigrid::GpuMultigrid::new(
            ctx,
            &hierarchy,
            &mg,
            &finest.packing,
            &finest.q,
            finest.result(),
            &graph,
        )?);
        self.solved = false;
        Ok(())
    }
}
