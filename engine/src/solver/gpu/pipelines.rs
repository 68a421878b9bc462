//! The solve's compute pipelines (precision and material variants) and their descriptor sets.

use super::*;

impl GpuDiffusion {
    pub(super) fn variant(
        ctx: &Context,
        precision: Precision,
        homogeneous: bool,
        derived: bool,
        paper: bool,
        levels: u32,
    ) -> Result<Variant, Error> {
        let sets = 2 * levels + 2;
        // graph_weights.glsl: HOMOGENEOUS, DERIVED, PAPER.
        let spec = [
            SpecConstant::bool(0, homogeneous),
            SpecConstant::bool(1, derived),
            SpecConstant::bool(2, paper),
        ];
        let iterate = match precision {
            Precision::Mixed => "diffusion/correction_sweep_mixed.comp",
            Precision::Fp32 => "diffusion/jacobi_fp32.comp",
            Precision::Fp16 => "diffusion/jacobi_fp16.comp",
        };
        let weights = ["weight_geo", "weight_r", "weight_g", "weight_b"];
        let with_weights = |names: &[&'static str]| -> Vec<&'static str> {
            names.iter().chain(&weights).copied().collect()
        };
        let graph_bindings = if precision == Precision::Mixed {
            with_weights(&["src", "dst", "residual", "connectivity"])
        } else {
            with_weights(&["src", "dst", "q", "connectivity"])
        };
        let iterate = ComputePipeline::new_specialized(
            ctx,
            &ComputePipelineDesc {
                name: PASS_JACOBI,
                shader: iterate,
                bindings: &graph_bindings,
                max_sets: sets,
            },
            &spec,
        )?;
        let residual = if precision == Precision::Mixed {
            Some(ComputePipeline::new_specialized(
                ctx,
                &ComputePipelineDesc {
                    name: "diffusion residual",
                    shader: "diffusion/residual_fp32.comp",
                    bindings: &with_weights(&["phi", "residual", "delta", "q", "connectivity"]),
                    max_sets: sets,
                },
                &spec,
            )?)
        } else {
            None
        };
        Ok(Variant { iterate, residual })
    }

    pub(super) fn pipelines(
        ctx: &Context,
        precision: Precision,
        levels: u32,
    ) -> Result<Pipelines, Error> {
        let sets = 2 * levels + 2;
        let interior = match precision {
            Precision::Mixed | Precision::Fp32 => "diffusion/vertex_interior_fp32.comp",
            Precision::Fp16 => "diffusion/vertex_interior_fp16.comp",
        };
        let (init, warm, reduce, j_plus) = match precision {
            Precision::Mixed | Precision::Fp32 => (
                "shepard/init_phi_fp32.comp",
                "shepard/warm_correct_fp32.comp",
                if precision == Precision::Mixed {
                    "reduce/convergence_mixed.comp"
                } else {
                    "reduce/convergence_fp32.comp"
                },
                "diffusion/j_plus_fp32.comp",
            ),
            Precision::Fp16 => (
                "shepard/init_phi_fp16.comp",
                "shepard/warm_correct_fp16.comp",
                "reduce/convergence_fp16.comp",
                "diffusion/j_plus_fp16.comp",
            ),
        };
        let apply = if precision == Precision::Mixed {
            Some(ComputePipeline::new(
                ctx,
                &ComputePipelineDesc {
                    name: "diffusion apply correction",
                    shader: "diffusion/apply_correction.comp",
                    bindings: &["delta", "phi"],
                    max_sets: sets,
                },
            )?)
        } else {
            None
        };
        Ok(Pipelines {
            variants: [None, None],
            apply,
            derive: None,
            edit: None,
            init: ComputePipeline::new(
                ctx,
                &ComputePipelineDesc {
                    name: PASS_INIT,
                    shader: init,
                    bindings: &["coarse", "dst", "links_lo", "links_hi"],
                    max_sets: sets,
                },
            )?,
            warm: ComputePipeline::new(
                ctx,
                &ComputePipelineDesc {
                    name: PASS_WARM,
                    shader: warm,
                    bindings: &[
                        "phi",
                        "saved",
                        "coarse_new",
                        "coarse_prev",
                        "links_lo",
                        "links_hi",
                    ],
                    max_sets: sets,
                },
            )?,
            reduce: ComputePipeline::new(
                ctx,
                &ComputePipelineDesc {
                    name: PASS_CONVERGENCE,
                    shader: reduce,
                    bindings: &["latest", "previous", "phi", "connectivity", "control"],
                    max_sets: sets,
                },
            )?,
            j_plus: ComputePipeline::new(
                ctx,
                &ComputePipelineDesc {
                    name: PASS_J_PLUS,
                    shader: j_plus,
                    bindings: &["phi", "q", "connectivity", "j_plus", "counts", "particular"],
                    max_sets: 2,
                },
            )?,
            vertex: ComputePipeline::new(
                ctx,
                &ComputePipelineDesc {
                    name: PASS_VERTEX_J_PLUS,
                    shader: "diffusion/vertex_j_plus.comp",
                    bindings: &["j_plus", "vertex_links", "vertex_weights", "vertex_j_plus"],
                    max_sets: 4,
                },
            )?,
            interior: ComputePipeline::new(
                ctx,
                &ComputePipelineDesc {
                    name: PASS_VERTEX_J_PLUS,
                    shader: interior,
                    bindings: &[
                        "phi",
                        "q",
                        "particular",
                        "kappa",
                        "mu",
                        "source_nodes",
                        "source_weights",
                        "sample_nodes",
                        "sample_weights",
                        "sample_cells",
                        "vertex_j_plus",
                        "sample_phi",
                        "lateral_nodes",
                        "lateral_weights",
                        "vertex_particular",
                    ],
                    max_sets: 16,
                },
            )?,
        })
    }
}
