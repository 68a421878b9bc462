//! What `render` runs when an option is not given: the light source, the schedule, single
//! scattering, and `--method auto`'s pick (one place for render's defaults).

use anyhow::bail;
use translucent::frame::{choose_method, MethodChoice, SceneTraits};

use super::{RenderArgs, DEFAULT_MATERIAL};

/// `render`'s light source on the GPU when none is named (benches/RESULTS.md, "Model terms on the
/// GPU (wave 5)": against the path-traced references the second-collision source is better than
/// the boundary flux on six scenes of seven and level on the seventh, and where it loses to the
/// first-collision beam it does so within that scene's noise).
pub const DEFAULT_SOURCE: translucent::solver::transport::Source =
    translucent::solver::transport::Source::SecondCollision;

/// `render`'s diffusion coefficient with `--method quadgraph` when none is named
/// (benches/RESULTS.md, "Diffusion coefficient at low albedo": against the path-traced
/// references Grosjean's D is level or better on every scene with the Shepard surface; it
/// differs from 1 / (3 sigma_t') only at low albedo). The library's default stays classical.
pub const DEFAULT_DIFFUSION_COEFFICIENT: translucent::material::DiffusionCoefficient =
    translucent::material::DiffusionCoefficient::Grosjean;

/// `--method auto`: the arguments with the method [`choose_method`] picks for this material and
/// scene (a rigid object: `render` neither deforms nor re-meshes).
pub fn resolve_auto(args: &RenderArgs) -> anyhow::Result<RenderArgs> {
    if args.solver != "gpu" {
        bail!("--method auto picks a GPU method: --solver cpu is the QuadGraph's f64 reference (use --method quadgraph)");
    }
    let field = args.material.field(args.object.size_mm, DEFAULT_MATERIAL)?;
    let traits = SceneTraits {
        heterogeneous: !field.is_homogeneous(),
        environment: args.env_constant.is_some() || args.env.is_some(),
        ..SceneTraits::default()
    };
    let choice = choose_method(&traits);
    if !args.json {
        eprintln!("--method auto: {} ({})", choice.kind.name(), choice.reason);
    }
    Ok(RenderArgs {
        method: choice.kind.name().to_string(),
        method_choice: Some(choice),
        ..args.clone()
    })
}

/// `method_choice` of the render JSON: what `--method auto` picked and why (from the last
/// frame's `FrameReport`), or null for a method given by name.
pub fn choice_json(choice: Option<MethodChoice>) -> serde_json::Value {
    match choice {
        Some(c) => serde_json::json!({ "method": c.kind.name(), "reason": c.reason }),
        None => serde_json::Value::Null,
    }
}

/// The schedule a render uses: `--schedule` when given; else multigrid on the GPU solver (DESIGN
/// 5.1: the default, measured faster than the cascade: benches/RESULTS.md, "GPU multigrid with
/// CG, and the default schedule") unless an option only the cascade has asks for it (`--precision fp16`, whose phi
/// the cycles cannot keep; `--iterations`, the cascade's cap per level; `--scheme paper`, whose
/// operator is not symmetric, which the CG around the V-cycle assumes); cascade + exact PCG on
/// the CPU solver (the f64 reference).
pub fn schedule_of(args: &RenderArgs) -> &'static str {
    match args.schedule.as_deref() {
        Some("multigrid") => "multigrid",
        Some(_) => "cascade",
        None if args.solver != "gpu"
            || args.precision.as_deref() == Some("fp16")
            || args.iterations.is_some()
            || args.scheme == "paper" =>
        {
            "cascade"
        }
        None => "multigrid",
    }
}

impl RenderArgs {
    /// A beam source asked for by name (`--source beam|second`, `--beam-source`).
    pub fn explicit_beam(&self) -> bool {
        self.beam_source || matches!(self.source.as_deref(), Some("beam" | "second"))
    }

    /// `--source` resolved: the given one; else [`DEFAULT_SOURCE`] for the QuadGraph method on
    /// the GPU unless `--exit-query flux` asks for the boundary-flux model (the default before
    /// wave 5); the f64 reference (`--solver cpu`) keeps the boundary flux unless named, and so
    /// do heterogeneous materials: near the particular solution's resonance the beam's share is
    /// sensitive to the coefficients (the agate's blue differs by 22% between its `.vol` grid
    /// and the procedural field it samples, against 0.8% with the flux: benches/RESULTS.md,
    /// "Model terms on the GPU (wave 5)"), so a heterogeneous beam is opt-in until that is fixed.
    pub fn light_source(&self) -> translucent::solver::transport::Source {
        use translucent::solver::transport::Source;
        match self.source.as_deref() {
            Some("beam") => Source::Collimated,
            Some("second") => Source::SecondCollision,
            Some(_) => Source::BoundaryFlux,
            None if self.beam_source => Source::Collimated,
            None if self.method != "quadgraph"
                || self.solver != "gpu"
                || self.material.is_heterogeneous()
                || self.exit_query.as_deref() == Some("flux") =>
            {
                Source::BoundaryFlux
            }
            None => DEFAULT_SOURCE,
        }
    }

    /// `--single-scattering` and `--scatter-samples` as the object's parameters (`None`: off).
    pub fn scatter_params(&self) -> anyhow::Result<Option<translucent::frame::ScatterParams>> {
        let range = translucent::frame::single_scattering::SAMPLE_RANGE;
        if !range.contains(&self.scatter_samples) {
            bail!(
                "--scatter-samples {}: must be in {}..={}",
                self.scatter_samples,
                range.start(),
                range.end()
            );
        }
        // Default `on`: the march with the front-lit skip rule.
        let mode = self.single_scattering.as_deref().unwrap_or("on");
        Ok(
            (mode != "off").then_some(translucent::frame::ScatterParams {
                samples: self.scatter_samples,
                skip_front_lit: mode == "on",
                // The second-collision source leaves the once-scattered light to the march.
                mode: if self.light_source()
                    == translucent::solver::transport::Source::SecondCollision
                {
                    translucent::frame::ScatterMode::Full
                } else {
                    translucent::frame::ScatterMode::Difference
                },
                // The gather's environment is a boundary flux: its once-scattered light is in
                // the diffusion already (ScatterParams::environment).
                environment: false,
            }),
        )
    }
}
