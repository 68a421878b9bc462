//! What `render` runs when an option is not given: the light source, the schedule, single
//! scattering, and `--method auto`'s pick. The values are the library's real-time defaults
//! ([`translucent::defaults::Settings`], shared with `view`, `bench` and
//! `ObjectParams::default`); this file says how render's options change them.

use anyhow::{bail, Context as _};
use translucent::defaults::{Schedule, Settings};
use translucent::frame::{choose_method, MethodChoice, MethodKind, SceneTraits};

use super::{RenderArgs, DEFAULT_MATERIAL};

/// `render`'s light source on the GPU when none is named, for homogeneous materials (the
/// library's: [`translucent::defaults::HOMOGENEOUS_SOURCE`]).
pub const DEFAULT_SOURCE: translucent::solver::transport::Source =
    translucent::defaults::HOMOGENEOUS_SOURCE;

/// `render`'s `--continuation` when not named: whether a beam source's light continues through
/// walls to the faces turned away from the light (benches/RESULTS.md, "Thin walls: the beam
/// through the wall").
pub const DEFAULT_CONTINUATION: bool = false;

/// `render`'s `--upstream-beam` when not named (a beam source): the library's
/// [`translucent::defaults::UPSTREAM_BEAM`].
pub const DEFAULT_UPSTREAM_BEAM: bool = translucent::defaults::UPSTREAM_BEAM;

/// `render`'s `--own-visibility` when not named (a beam source): the library's
/// [`translucent::defaults::OWN_VISIBILITY`].
pub const DEFAULT_OWN_VISIBILITY: bool = translucent::defaults::OWN_VISIBILITY;

/// `render`'s upstream beam when `--upstream-beam` is not named: curved (the library's
/// [`translucent::defaults::CURVED_PARTICULAR`]) or wave 8's area factor (`on`).
pub const DEFAULT_CURVED_PARTICULAR: bool = translucent::defaults::CURVED_PARTICULAR;

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

/// The schedule a render uses: `--schedule` when given; else the library's default
/// ([`Settings::schedule`], multigrid: DESIGN 5.1, measured faster than the cascade:
/// benches/RESULTS.md, "GPU multigrid with CG, and the default schedule") on the GPU solver
/// unless an option only the cascade has asks for it (`--precision fp16`, whose phi the cycles
/// cannot keep; `--iterations`, the cascade's cap per level; `--scheme paper`, whose operator is
/// not symmetric, which the CG around the V-cycle assumes: [`Settings::schedule_allowed`]);
/// cascade + exact PCG on the CPU solver (the f64 reference).
pub fn schedule_of(args: &RenderArgs) -> &'static str {
    match args.schedule.as_deref() {
        Some("multigrid") => "multigrid",
        Some(_) => "cascade",
        None if args.solver != "gpu" || args.iterations.is_some() => "cascade",
        None => {
            let fp16 = args.precision.as_deref() == Some("fp16");
            let paper = args.scheme == "paper";
            let settings = Settings {
                precision: if fp16 {
                    translucent::solver::gpu::Precision::Fp16
                } else {
                    Settings::default().precision
                },
                scheme: if paper {
                    translucent::solver::Scheme::Paper
                } else {
                    translucent::solver::Scheme::Fv
                },
                ..Settings::default()
            };
            settings.schedule_allowed().name()
        }
    }
}

impl RenderArgs {
    /// A beam source asked for by name (`--source beam|second`, `--beam-source`).
    pub fn explicit_beam(&self) -> bool {
        self.beam_source || matches!(self.source.as_deref(), Some("beam" | "second"))
    }

    /// `--continuation` resolved: the given one, else [`DEFAULT_CONTINUATION`].
    pub fn continuation(&self) -> bool {
        self.continuation
            .as_deref()
            .map_or(DEFAULT_CONTINUATION, |v| v == "on")
    }

    /// `--upstream-beam` resolved: the given one, else [`DEFAULT_UPSTREAM_BEAM`] (with a beam
    /// source only).
    pub fn upstream_beam(&self) -> bool {
        self.upstream_beam
            .as_deref()
            .map_or(DEFAULT_UPSTREAM_BEAM, |v| v != "off")
            && self.light_source() != translucent::solver::transport::Source::BoundaryFlux
    }

    /// `--own-visibility` resolved: the given one, else [`DEFAULT_OWN_VISIBILITY`] (with a beam
    /// source only).
    pub fn own_visibility(&self) -> bool {
        self.own_visibility
            .as_deref()
            .map_or(DEFAULT_OWN_VISIBILITY, |v| v == "on")
            && self.light_source() != translucent::solver::transport::Source::BoundaryFlux
    }

    /// `--upstream-beam curved`: the upstream beam with the curved particular solution; when not
    /// named, [`DEFAULT_CURVED_PARTICULAR`] (`on` names the area factor).
    pub fn curved_particular(&self) -> bool {
        self.upstream_beam()
            && self
                .upstream_beam
                .as_deref()
                .map_or(DEFAULT_CURVED_PARTICULAR, |v| v == "curved")
    }

    /// `--source` resolved: the given one; else [`DEFAULT_SOURCE`] for the QuadGraph method on
    /// the GPU unless `--exit-query flux` asks for the boundary-flux model (the default before
    /// wave 5); the f64 reference (`--solver cpu`) keeps the boundary flux unless named.
    /// Heterogeneous materials take the same source as homogeneous ones since wave 9
    /// ([`translucent::defaults::HETEROGENEOUS_SOURCE`]).
    pub fn light_source(&self) -> translucent::solver::transport::Source {
        use translucent::solver::transport::Source;
        match self.source.as_deref() {
            Some("beam") => Source::Collimated,
            Some("second") => Source::SecondCollision,
            Some(_) => Source::BoundaryFlux,
            None if self.beam_source => Source::Collimated,
            None if self.solver != "gpu" || self.exit_query.as_deref() == Some("flux") => {
                Source::BoundaryFlux
            }
            None => {
                Settings::for_method(self.method_kind(), !self.material.is_heterogeneous()).source
            }
        }
    }

    /// `--diffusion-coefficient` resolved: the given one; else the library's for the method
    /// ([`Settings::for_method`]: Grosjean's for the QuadGraph, classical for the others).
    pub fn diffusion(&self) -> anyhow::Result<translucent::material::DiffusionCoefficient> {
        match self.diffusion_coefficient.as_deref() {
            Some(name) => Ok(name.parse()?),
            None => Ok(Settings::for_method(self.method_kind(), true).diffusion),
        }
    }

    /// `--method` as the library's kind (`auto` is resolved before any frame; it reads as the
    /// QuadGraph here).
    pub fn method_kind(&self) -> MethodKind {
        self.method.parse().unwrap_or_default()
    }

    /// Everything the GPU frame's solve and single scattering resolve to: the library's
    /// real-time defaults ([`Settings::for_method`]) changed by the options given.
    pub fn settings(&self) -> anyhow::Result<Settings> {
        let mut settings =
            Settings::for_method(self.method_kind(), !self.material.is_heterogeneous())
                .with_source(self.light_source());
        if settings.source == translucent::solver::transport::Source::BoundaryFlux {
            if let Some(query) = &self.exit_query {
                settings.exit = query.parse()?;
            }
        }
        settings.schedule = if schedule_of(self) == "multigrid" {
            Schedule::Multigrid
        } else {
            Schedule::Cascade
        };
        settings.scheme = if self.scheme == "paper" {
            translucent::solver::Scheme::Paper
        } else {
            translucent::solver::Scheme::Fv
        };
        if let Some(p) = &self.precision {
            settings.precision = p.parse()?;
        }
        settings.tolerance = self.tolerance;
        if let Some(n) = self.iterations {
            settings.cascade_iterations = u32::try_from(n).context("--iterations: too large")?;
        }
        // `auto` needs the lattice spacing: `surface_for` resolves it after the bake.
        if self.surface != "auto" {
            settings.surface = self.surface.parse()?;
        }
        settings.heterogeneous_weights = self.heterogeneous_weights.parse()?;
        settings.single_scattering = self.scatter_params()?;
        settings.bounce = self.bounce_mode()?;
        settings.diffusion = self.diffusion()?;
        settings.upstream_beam = self.upstream_beam();
        settings.curved_particular = self.curved_particular();
        Ok(settings)
    }

    /// `--surface` resolved for `field` on the display `surface` with a finest lattice of
    /// `spacing_mm`: the one named, or with `auto` (the default) the library's rule
    /// [`translucent::defaults::surface_for`].
    pub fn surface_for(
        &self,
        field: &translucent::material::MaterialField,
        surface: &translucent::mesh::TriMesh,
        spacing_mm: f64,
    ) -> anyhow::Result<translucent::solver::transport::SurfaceReconstruction> {
        if self.surface == "auto" {
            Ok(translucent::defaults::surface_for(
                field, surface, spacing_mm,
            ))
        } else {
            Ok(self.surface.parse()?)
        }
    }

    /// `--bounce` resolved: the given mode; else the library's for the method
    /// ([`Settings::for_method`]: local for the QuadGraph), off with `--solver cpu`.
    pub fn bounce_mode(&self) -> anyhow::Result<translucent::frame::BounceMode> {
        match self.bounce.as_deref() {
            Some(mode) => Ok(mode.parse()?),
            None if self.solver != "gpu" => Ok(translucent::frame::BounceMode::Off),
            None => Ok(Settings::for_method(self.method_kind(), true).bounce),
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
        // Default `on` (the library's): the march with the front-lit skip rule.
        let mode = self.single_scattering.as_deref().unwrap_or("on");
        Ok((mode != "off").then(|| {
            translucent::defaults::scatter_for(
                self.light_source(),
                self.scatter_samples,
                mode == "on",
            )
        }))
    }
}
