//! Building the viewer's [`Setup`] from the command line: the bake, the material, the scene,
//! the script (everything that does not need a window).

use super::*;

pub(super) fn rgb(option: &str, text: &str) -> anyhow::Result<[f64; 3]> {
    let v: Vec<f64> = text
        .split(',')
        .map(|v| v.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("{option} {text:?}: expected R,G,B numbers"))?;
    v.try_into()
        .map_err(|_| anyhow::anyhow!("{option} {text:?}: expected 3 numbers"))
}

/// `path` with extension `ext` (the screenshot's PNG and EXR).
pub(super) fn with_extension(path: &Path, ext: &str) -> PathBuf {
    path.with_extension(ext)
}

/// The PNG and EXR paths of a screenshot named `path` (`.png` or `.exr`).
pub(super) fn screenshot_paths(path: &Path) -> anyhow::Result<(PathBuf, PathBuf)> {
    match path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .as_deref()
    {
        Some("png" | "exr") => Ok((with_extension(path, "png"), with_extension(path, "exr"))),
        _ => bail!("screenshot {}: must end in .png or .exr", path.display()),
    }
}

impl Setup {
    pub(super) fn new(args: &ViewArgs) -> anyhow::Result<Setup> {
        // Everything a user can get wrong is checked before the bake and the window.
        if args.frames == Some(0) {
            bail!("--frames 0: give at least one frame");
        }
        if let Some(s) = &args.screenshot {
            screenshot_paths(s).context("--screenshot")?;
        }
        if !(args.tolerance.is_finite() && args.tolerance >= 0.0) {
            bail!(
                "--tolerance {}: must be a finite non-negative number",
                args.tolerance
            );
        }
        if args.iterations == Some(0) {
            bail!("--iterations 0: give at least one iteration per level");
        }
        if args.iterations.is_some() && args.schedule.as_deref() == Some("multigrid") {
            bail!("--iterations sets the cascade's Jacobi iterations per level; --schedule multigrid stops at --tolerance");
        }
        if args.schedule.as_deref() == Some("multigrid") && args.precision == "fp16" {
            bail!("--schedule multigrid keeps phi in fp32: use --precision mixed or fp32 (or --schedule cascade)");
        }
        if let Some(dir) = &args.shader_dir {
            translucent::shader::runtime::ShaderTree::new(dir).context("--shader-dir")?;
        }
        if let Some(m) = METHODS.iter().find(|m| m.name == args.method && !m.built) {
            bail!("--method {}: not built yet (only quadgraph is)", m.name);
        }
        let script = match &args.script {
            Some(path) => Script::read(path)?,
            None => Script::default(),
        };
        if let (Some(n), Some(last)) = (args.frames, script.last_frame()) {
            if last >= n {
                bail!(
                    "--script has actions at frame {last}, but --frames {n} runs frames 0..={}",
                    n - 1
                );
            }
        }
        let frame = args.scene.frame_desc()?;
        let environment = match (&args.env_constant, &args.env) {
            (Some(text), _) => Environment::Constant(rgb("--env-constant", text)?),
            (None, Some(path)) => Environment::load_exr(path).context("--env")?,
            (None, None) => Environment::None,
        };
        let lights = args.scene.lights()?;
        Scene {
            lights,
            environment,
        }
        .validate()?;
        let field = args.material.field(args.object.size_mm, DEFAULT_MATERIAL)?;
        let object = args.object.load(Some(DEFAULT_SHAPE))?;
        // `auto`: the material's bound only (the viewer zooms, so no pixel footprint binds).
        let resolution = args.object.resolution(&object, &field, None);
        let params = args.object.bake_params_for(&resolution, &field);
        let start = Instant::now();
        let (mut graph, stats, outcome, file) =
            crate::cache::bake(&object, &params, args.cache_dir.as_deref())?;
        // The bounce (the library's default for the QuadGraph, as `render`'s): the links stored
        // with the bake, or built once and stored with it.
        let method: translucent::frame::MethodKind = args.method.parse().unwrap_or_default();
        if Settings::for_method(method, true).bounce != translucent::frame::BounceMode::Off {
            let key = translucent::quadgraph::cache::cache_key(&object.surface, &params);
            crate::cache::bounce_links(
                &mut graph,
                &translucent::frame::BounceParams::default(),
                Some((file.as_path(), key)),
            )?;
        }
        eprintln!(
            "{}",
            resolution.line(
                stats
                    .levels
                    .last()
                    .map_or(0, |l| l.surface_nodes + l.inner_nodes)
            )
        );
        eprintln!("{}", object.view_line());
        eprintln!(
            "{} {} in {:.1} s ({})",
            match outcome {
                translucent::quadgraph::cache::CacheOutcome::Loaded => "loaded",
                _ => "baked",
            },
            object.name,
            start.elapsed().as_secs_f64(),
            file.display()
        );
        Ok(Setup {
            args: args.clone(),
            name: object.name,
            graph: Arc::new(graph),
            field,
            environment,
            frame,
            script,
            resolution: resolution.cells,
            up: object.up.axis,
            front: object.front.side,
            dipole_hierarchy: std::sync::OnceLock::new(),
        })
    }

    /// The material `state` names (or the command line's).
    pub(super) fn field(&self, state: &ViewState) -> anyhow::Result<MaterialField> {
        match &state.material {
            None => Ok(self.field.clone()),
            Some(name) => MaterialArgs {
                material: Some(name.clone()),
                sigma_a: None,
                sigma_s: None,
                eta: self.args.material.eta,
                volume: None,
            }
            .field(self.args.object.size_mm, DEFAULT_MATERIAL),
        }
    }

    pub(super) fn frame_exposure(&self) -> f32 {
        self.args.scene.exposure
    }

    pub(super) fn scene(&self, state: &ViewState) -> Scene {
        Scene {
            lights: state.lights.clone(),
            environment: self.environment,
        }
    }

    /// What the object for `state` resolves to: the library's real-time defaults for its method
    /// and material ([`view_settings`]).
    pub(super) fn settings(&self, state: &ViewState) -> Settings {
        let homogeneous = self.field(state).map_or(true, |f| f.is_homogeneous());
        view_settings(
            &self.args,
            state.method_name().parse().unwrap_or_default(),
            homogeneous,
            state.precision,
            state.single_scattering,
        )
    }

    /// The object's parameters for `state`.
    pub(super) fn object_params(&self, state: &ViewState) -> ObjectParams {
        let settings = self.settings(state);
        ObjectParams {
            color_format: COLOR_FORMAT,
            depth_format: DEPTH_FORMAT,
            specular: self.frame.specular,
            roughness: self.frame.roughness,
            radiance: self.frame.radiance,
            exit_lobe: self.frame.exit_lobe,
            skip: state.skip,
            // render's default (QuadGraph; the viewer has no option for it).
            tangential_flux: translucent::defaults::TANGENTIAL_FLUX
                && state.method_name() == "quadgraph",
            ..settings.object_params()
        }
    }

    /// Builds the object for `state` (a new method, precision or skip setting).
    pub(super) fn object(
        &self,
        ctx: &Context,
        state: &ViewState,
    ) -> anyhow::Result<TranslucentObject> {
        match state.method_name() {
            "voxel" => Ok(TranslucentObject::with_method(
                ctx,
                MethodDesc::Voxel {
                    mesh: self.graph.surface.clone(),
                    params: crate::render::voxel::voxel_params(None, None, None)?,
                },
                &self.field(state)?,
                &self.scene(state),
                &self.object_params(state),
            )?),
            "dipole" => {
                let hierarchy = match self.dipole_hierarchy.get() {
                    Some(h) => h.clone(),
                    None => {
                        let (tree, _) = translucent::solver::dipole::FaceClusterHierarchy::build(
                            &self.graph.surface,
                        )?;
                        self.dipole_hierarchy.get_or_init(|| Arc::new(tree)).clone()
                    }
                };
                Ok(TranslucentObject::with_method(
                    ctx,
                    MethodDesc::Dipole {
                        mesh: self.graph.surface.clone(),
                        hierarchy,
                        params: translucent::frame::DipoleParams {
                            heterogeneous:
                                translucent::solver::dipole::HeterogeneousPolicy::TextureOnly,
                            ..Default::default()
                        },
                    },
                    &self.field(state)?,
                    &self.scene(state),
                    &self.object_params(state),
                )?)
            }
            "quadgraph" => Ok(TranslucentObject::new(
                ctx,
                self.graph.clone(),
                &self.field(state)?,
                &self.scene(state),
                &self.object_params(state),
            )?),
            other => bail!("method {other} is not built"),
        }
    }

    /// The `translucent render` options that draw what `state` shows at `extent`.
    pub(super) fn render_args(&self, state: &ViewState, extent: [u32; 2]) -> Vec<String> {
        let a = &self.args;
        let mut out: Vec<String> = Vec::new();
        // `--option=value`: values such as a camera at x < 0 start with '-'.
        let mut push = |k: &str, v: String| out.push(format!("{k}={v}"));
        match (&a.object.mesh, &a.object.shape) {
            (Some(m), _) => push("--mesh", m.display().to_string()),
            (None, s) => push("--shape", s.clone().unwrap_or(DEFAULT_SHAPE.into())),
        }
        if a.object.mesh.is_some() {
            push("--up", self.up.to_string());
        }
        push("--size-mm", a.object.size_mm.to_string());
        push("-K", a.object.k.to_string());
        push("--levels", a.object.levels.to_string());
        push("--resolution", self.resolution.to_string());
        if state.method_name() != "quadgraph" {
            push("--method", state.method_name().to_string());
        }
        match &state.material {
            Some(name) => push("--material", name.clone()),
            None => {
                if let Some(v) = &a.material.volume {
                    push("--volume", v.display().to_string());
                }
                if let (Some(sa), Some(ss)) = (&a.material.sigma_a, &a.material.sigma_s) {
                    push("--sigma-a", sa.clone());
                    push("--sigma-s", ss.clone());
                }
                if let Some(m) = &a.material.material {
                    push("--material", m.clone());
                }
            }
        }
        if let Some(eta) = a.material.eta {
            push("--eta", eta.to_string());
        }
        for light in &state.lights {
            push("--light", light_arg(light));
        }
        if let Some(e) = &a.env_constant {
            push("--env-constant", e.clone());
        }
        if let Some(e) = &a.env {
            push("--env", e.display().to_string());
        }
        push("--camera", camera_arg(&state.camera));
        push("--width", extent[0].to_string());
        push("--height", extent[1].to_string());
        // The viewer draws one sample per pixel.
        push("--supersample", "1".into());
        push("--radiance", a.scene.radiance.clone());
        push("--exposure", a.scene.exposure.to_string());
        push("--scheme", a.scheme.clone());
        // The QuadGraph's solver options as the object resolved them (named, so the command
        // reproduces the frame whatever the defaults); render refuses them for the other methods.
        let settings = self.settings(state);
        if state.method_name() == "quadgraph" {
            push("--precision", precision_name(state.precision).into());
            push("--schedule", settings.schedule.name().into());
            if settings.schedule == Schedule::Cascade {
                push("--iterations", settings.cascade_iterations.to_string());
            }
            push("--tolerance", a.tolerance.to_string());
            push("--source", source_name(settings.source).into());
            push("--bounce", settings.bounce.name().into());
        }
        if a.scene.no_specular {
            out.push("--no-specular".into());
        }
        // render's default is `on`; the viewer's state decides.
        out.push(format!(
            "--single-scattering={}",
            if state.single_scattering { "on" } else { "off" }
        ));
        if !state.skip {
            out.push("--no-skip".into());
        }
        if state.method_name() == "dipole" && !self.field(state).is_ok_and(|f| f.is_homogeneous()) {
            out.push("--texture-only".into());
        }
        out
    }
}

/// The settings `translucent view` resolves for `method` on a homogeneous (`true`) or
/// heterogeneous material: the library's real-time defaults ([`Settings::for_method`], as
/// `render` starts from) changed by the options given and the viewer's switches. The viewer
/// differs from `render` only where its switches do (precision `p`, single scattering `s`) and
/// in drawing one sample per pixel (`render --supersample 1`).
pub(crate) fn view_settings(
    args: &ViewArgs,
    method: translucent::frame::MethodKind,
    homogeneous: bool,
    precision: Precision,
    single_scattering: bool,
) -> Settings {
    let mut settings = Settings::for_method(method, homogeneous);
    if method == translucent::frame::MethodKind::QuadGraph {
        settings = match args.source.as_deref() {
            Some("flux") => settings.with_source(Source::BoundaryFlux),
            Some("beam") => settings.with_source(Source::Collimated),
            Some("second") => settings.with_source(Source::SecondCollision),
            _ => settings,
        };
    }
    settings.scheme = if args.scheme == "paper" {
        Scheme::Paper
    } else {
        Scheme::Fv
    };
    settings.precision = precision;
    settings.tolerance = args.tolerance;
    if let Some(n) = args.iterations {
        settings.cascade_iterations = n;
        settings.schedule = Schedule::Cascade;
    }
    match args.schedule.as_deref() {
        Some("cascade") => settings.schedule = Schedule::Cascade,
        Some("multigrid") => settings.schedule = Schedule::Multigrid,
        _ => {}
    }
    settings.schedule = settings.schedule_allowed();
    if !single_scattering {
        settings.single_scattering = None;
    }
    settings
}

/// `render --source`'s name of a light source.
pub(crate) fn source_name(source: Source) -> &'static str {
    match source {
        Source::BoundaryFlux => "flux",
        Source::Collimated => "beam",
        Source::SecondCollision => "second",
    }
}

/// Whether the viewer starts with single scattering: the library's default (on) unless
/// `--single-scattering off`.
pub(crate) fn start_single_scattering(args: &ViewArgs) -> bool {
    match args.single_scattering.as_deref() {
        Some(v) => v == "on",
        None => Settings::default().single_scattering.is_some(),
    }
}
