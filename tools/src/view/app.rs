//! The winit application: input becomes actions, actions change the state, each redraw applies
//! the state to the object and draws a frame; [`run`] is the command's entry point.

use super::*;

/// A scripted run that draws no frame for this long (a window that never gets an area) fails
/// instead of hanging CI.
const STALL_LIMIT: Duration = Duration::from_secs(120);

/// The winit application: input becomes actions, actions change the state, each redraw applies
/// the state to the object and draws a frame.
struct App {
    setup: Setup,
    state: ViewState,
    viewer: Option<Viewer>,
    mouse: Mouse,
    /// Input since the last drawn frame.
    input: Vec<Action>,
    /// Frames drawn so far (the script's frame index of the next one).
    index: u64,
    /// The frame whose script actions were applied (a frame that could not be drawn is tried
    /// again without applying them twice).
    applied: Option<u64>,
    /// Action texts and a screenshot asked for but not yet drawn.
    carried: (Vec<String>, Option<PathBuf>),
    screenshots: u32,
    validation: bool,
    last_progress: Instant,
    /// When the event loop last began an iteration, and the longest gap between two
    /// iterations after the first frame (the window handles no event meanwhile): ms, and the
    /// frame index drawn next when it ended.
    last_iteration: Option<Instant>,
    longest_stall: (f64, u64),
    #[cfg(feature = "hot-reload")]
    shaders: reload::ShaderWatch,
    result: anyhow::Result<()>,
}

impl App {
    fn fail(&mut self, event_loop: &ActiveEventLoop, e: anyhow::Error) {
        if self.result.is_ok() {
            self.result = Err(e);
        }
        event_loop.exit();
    }

    /// Applies this frame's script actions and the input, then draws.
    fn frame(&mut self, event_loop: &ActiveEventLoop) -> anyhow::Result<()> {
        let Some(viewer) = self.viewer.as_mut() else {
            return Ok(());
        };
        let mut actions = Vec::new();
        if self.applied != Some(self.index) {
            actions.extend(self.setup.script.actions_at(self.index).iter().cloned());
            self.applied = Some(self.index);
        }
        actions.append(&mut self.input);
        let mut rebuild = false;
        let mut material = false;
        let mut lights = false;
        let mut reload = false;
        let mut quit = false;
        for action in &actions {
            let effect = self.state.apply(action);
            rebuild |= effect.rebuild;
            material |= effect.material;
            lights |= effect.lights;
            reload |= effect.reload_shaders;
            quit |= effect.quit;
            if let Some((width, height)) = effect.resize {
                let size = winit::dpi::PhysicalSize::new(width, height);
                if viewer.window.request_inner_size(size).is_some() {
                    viewer.stale = true;
                }
            }
            if let Some(path) = effect.screenshot {
                self.screenshots += 1;
                self.carried.1 = Some(path.unwrap_or_else(|| {
                    PathBuf::from(format!("translucent-view-{:04}.png", self.screenshots))
                }));
            }
            self.carried.0.push(format!("{action:?}"));
        }
        if rebuild {
            // A new object (precision, skipping, method): the old one is released once the
            // frames that used it completed.
            viewer.object = self.setup.object(&viewer.ctx, &self.state)?;
        } else {
            if material {
                let field = self.setup.field(&self.state)?;
                viewer.object.set_material(&viewer.ctx, &field)?;
            }
            if lights {
                viewer.object.set_lights(&self.setup.scene(&self.state))?;
            }
        }
        viewer.object.set_camera(Some(self.state.camera))?;
        if reload {
            self.reload_shaders();
        }
        #[cfg(feature = "hot-reload")]
        if self.shaders.changed() {
            self.reload_shaders();
        }
        let Some(viewer) = self.viewer.as_mut() else {
            return Ok(());
        };
        let last = self.setup.args.frames.is_some_and(|n| self.index + 1 >= n);
        if last && self.carried.1.is_none() {
            self.carried.1 = self.setup.args.screenshot.clone();
        }
        let drawn = viewer.draw(
            &self.setup,
            &self.state,
            self.index,
            self.carried.0.clone(),
            self.carried.1.as_deref(),
        )?;
        if drawn.is_some() {
            self.carried = (Vec::new(), None);
            self.index += 1;
            self.last_progress = Instant::now();
            if last {
                quit = true;
            }
        }
        if quit {
            self.finish()?;
            event_loop.exit();
        }
        Ok(())
    }

    /// Recompiles the viewer's shaders and rebuilds its pipeline (feature `hot-reload`).
    fn reload_shaders(&mut self) {
        #[cfg(feature = "hot-reload")]
        {
            let Some(viewer) = self.viewer.as_mut() else {
                return;
            };
            let result = self.shaders.compile().and_then(|(v, f)| {
                viewer.idle()?;
                viewer.present.reload(&v, &f)
            });
            self.state.note = Some(match result {
                Ok(()) => "shaders reloaded".into(),
                Err(e) => format!("shader reload failed (old shaders kept): {e:#}"),
            });
        }
        #[cfg(not(feature = "hot-reload"))]
        {
            self.state.note =
                Some("built without the hot-reload feature: shaders are embedded".into());
        }
    }

    /// Waits for the last frames, writes the report.
    fn finish(&mut self) -> anyhow::Result<()> {
        let Some(viewer) = self.viewer.as_mut() else {
            return Ok(());
        };
        viewer.idle()?;
        let (stall_ms, stall_frame) = self.longest_stall;
        eprintln!(
            "event loop: longest stall {stall_ms:.0} ms (before frame {stall_frame}); {} iteration(s) went back to the events while the GPU was busy",
            viewer.busy_polls
        );
        viewer.log.event_loop = Some(serde_json::json!({
            "longest_stall_ms": stall_ms,
            "longest_stall_before_frame": stall_frame,
            "busy_polls": viewer.busy_polls,
        }));
        if let Some(path) = &self.setup.args.report {
            let extent = viewer
                .swapchain
                .as_ref()
                .map_or([0, 0], |s| [s.extent.width, s.extent.height]);
            let state = &self.state;
            let final_scene = serde_json::json!({
                "render_args": self.setup.render_args(state, extent),
                "camera": camera_arg(&state.camera),
                "lights": state.lights.iter().map(light_arg).collect::<Vec<_>>(),
                "material": state.material,
                "method": state.method_name(),
                "precision": precision_name(state.precision),
                "skip": state.skip,
                "single_scattering": state.single_scattering,
                "extent": extent,
            });
            viewer.log.write(
                path,
                &viewer.host.device_name,
                final_scene,
                host::validation_messages(),
            )?;
        }
        Ok(())
    }
}

impl ApplicationHandler for App {
    fn new_events(&mut self, _: &ActiveEventLoop, _: winit::event::StartCause) {
        let now = Instant::now();
        // From the first drawn frame on (window and object creation come before it).
        if let (Some(last), true) = (self.last_iteration, self.index > 0) {
            let gap = (now - last).as_secs_f64() * 1e3;
            if gap > self.longest_stall.0 {
                self.longest_stall = (gap, self.index);
            }
        }
        self.last_iteration = Some(now);
    }

    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.viewer.is_some() {
            return;
        }
        let size = winit::dpi::PhysicalSize::new(self.setup.frame.width, self.setup.frame.height);
        let attributes = Window::default_attributes()
            .with_title(format!("translucent view: {}", self.setup.name))
            .with_inner_size(size);
        let made = event_loop
            .create_window(attributes)
            .context("creating the window")
            .and_then(|w| {
                Viewer::new(
                    &self.setup,
                    &self.state,
                    Arc::new(w),
                    self.validation,
                    self.setup.args.frames.is_some(),
                )
            });
        match made {
            Ok(v) => {
                self.last_progress = Instant::now();
                self.viewer = Some(v);
            }
            Err(e) => self.fail(event_loop, e),
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        match event {
            WindowEvent::CloseRequested => {
                if let Err(e) = self.finish() {
                    self.fail(event_loop, e);
                }
                event_loop.exit();
            }
            WindowEvent::Resized(_) => {
                if let Some(v) = self.viewer.as_mut() {
                    v.stale = true;
                }
            }
            WindowEvent::KeyboardInput { event, .. }
                if event.state == ElementState::Pressed && !event.repeat =>
            {
                if let Some(action) =
                    key_name(&event.logical_key).and_then(|k| controls::key_action(&k))
                {
                    self.input.push(action);
                }
            }
            WindowEvent::MouseInput { state, button, .. } => {
                let down = state == ElementState::Pressed;
                match button {
                    MouseButton::Left => self.mouse.left = down,
                    MouseButton::Right => self.mouse.right = down,
                    _ => {}
                }
            }
            WindowEvent::CursorMoved { position, .. } => {
                if let Some(a) = self.mouse.moved(position.x, position.y) {
                    self.input.push(a);
                }
            }
            WindowEvent::CursorLeft { .. } => self.mouse.last = None,
            WindowEvent::MouseWheel { delta, .. } => {
                let lines = match delta {
                    MouseScrollDelta::LineDelta(_, y) => f64::from(y),
                    MouseScrollDelta::PixelDelta(p) => p.y * controls::LINES_PER_PIXEL,
                };
                if let Some(a) = controls::wheel_action(lines) {
                    self.input.push(a);
                }
            }
            WindowEvent::RedrawRequested => {
                if let Err(e) = self.frame(event_loop) {
                    self.fail(event_loop, e);
                }
            }
            _ => {}
        }
    }

    fn about_to_wait(&mut self, event_loop: &ActiveEventLoop) {
        if let Some(v) = &self.viewer {
            v.window.request_redraw();
        }
        if self.setup.args.frames.is_some() && self.last_progress.elapsed() > STALL_LIMIT {
            self.fail(
                event_loop,
                anyhow::anyhow!(
                    "no frame drawn for {} s (frame {}): the window has no area?",
                    STALL_LIMIT.as_secs(),
                    self.index
                ),
            );
        }
    }
}

/// `translucent view`.
pub fn run(args: &ViewArgs) -> anyhow::Result<()> {
    let setup = Setup::new(args)?;
    let aspect = f64::from(setup.frame.width) / f64::from(setup.frame.height.max(1));
    let bounds = setup.graph.finest().bounding_sphere();
    let camera = setup
        .frame
        .camera
        .unwrap_or_else(|| crate::scene_args::default_camera(bounds.0, bounds.1, aspect));
    // Without --light: the default lights placed relative to the starting camera. They stay in
    // the world while the camera orbits (see the module page: an orbit only re-shades), and the
    // right mouse button turns the key light from there.
    let mut state = ViewState::new(camera, bounds, args.scene.lights_for(&camera)?);
    state.material = match (&args.material.volume, &args.material.sigma_a) {
        (None, None) => Some(
            args.material
                .material
                .clone()
                .unwrap_or_else(|| DEFAULT_MATERIAL.into()),
        ),
        _ => None,
    };
    state.precision = args.precision.parse()?;
    state.skip = !args.no_skip;
    state.method = METHODS
        .iter()
        .position(|m| m.name == args.method)
        .unwrap_or(0);
    let event_loop = EventLoop::new().context(
        "opening the window system (no display? set DISPLAY or WAYLAND_DISPLAY; headless: run under Xvfb)",
    )?;
    event_loop.set_control_flow(ControlFlow::Poll);
    let mut app = App {
        #[cfg(feature = "hot-reload")]
        shaders: reload::ShaderWatch::new(),
        setup,
        state,
        viewer: None,
        mouse: Mouse::default(),
        input: Vec::new(),
        index: 0,
        applied: None,
        carried: (Vec::new(), None),
        screenshots: 0,
        validation: std::env::var("TRANSLUCENT_VALIDATION").is_ok_and(|v| v == "1"),
        last_progress: Instant::now(),
        last_iteration: None,
        longest_stall: (0.0, 0),
        result: Ok(()),
    };
    event_loop
        .run_app(&mut app)
        .context("running the window's event loop")?;
    // The device, surface and instance go now: validation also checks their destruction.
    drop(app.viewer.take());
    app.result?;
    let messages = host::validation_messages();
    if messages > 0 {
        bail!("{messages} validation message(s) (printed above)");
    }
    if let Some(n) = args.frames {
        if app.index < n {
            bail!("the window closed after {} of {n} frames", app.index);
        }
    }
    Ok(())
}
