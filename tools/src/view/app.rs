//! The winit application and the render thread; [`run`] is the command's entry point.
//!
//! Two threads: the window's event loop (this module's [`App`], the main thread) turns input
//! into actions and sends them to the render thread ([`Renderer`]), which owns the Vulkan host,
//! the object and the swapchain, applies the actions to the state and draws frames. lavapipe
//! runs a submission inside `vkQueueSubmit`, and a cold solve is one submission of seconds: on
//! the render thread it holds up frames, not the window (which keeps taking input, moving and
//! closing; the last image stays on screen and the title says the GPU is busy). The event loop
//! wakes every `HEARTBEAT` and measures the longest gap between two wakes (printed at exit,
//! `event_loop` in `--report`).

use super::*;

/// A scripted run that draws no frame for this long (a window that never gets an area) fails
/// instead of hanging CI.
const STALL_LIMIT: Duration = Duration::from_secs(120);
/// The event loop wakes at least this often (an idle wake costs microseconds); the longest gap
/// between two wakes is the longest time the window could not have handled an event.
const HEARTBEAT: Duration = Duration::from_millis(10);

/// What the window's thread sends the render thread.
enum Input {
    Action(Action),
    /// The window's size changed: rebuild the swapchain before the next frame.
    Resized,
    /// The window is closing: finish (the report) and stop.
    Close,
}

/// What the render thread starts from (sent to it: the Vulkan objects are made there).
struct Start {
    setup: Setup,
    state: ViewState,
    stall: Arc<std::sync::Mutex<(f64, u64)>>,
    drawn: Arc<std::sync::atomic::AtomicU64>,
}

impl Start {
    fn renderer(self) -> Renderer {
        Renderer {
            shaders: reload::ShaderWatch::new(self.setup.args.shader_dir.clone()),
            setup: self.setup,
            state: self.state,
            viewer: None,
            input: Vec::new(),
            index: 0,
            applied: None,
            carried: (Vec::new(), None),
            screenshots: 0,
            validation: std::env::var("TRANSLUCENT_VALIDATION").is_ok_and(|v| v == "1"),
            last_progress: Instant::now(),
            stall: self.stall,
            drawn: self.drawn,
        }
    }
}

/// The render thread's side: the state, the Vulkan host and object, the script.
struct Renderer {
    setup: Setup,
    state: ViewState,
    viewer: Option<Viewer>,
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
    /// The event loop's longest iteration (ms) and the frame drawn next when it happened,
    /// measured on the window's thread.
    stall: Arc<std::sync::Mutex<(f64, u64)>>,
    /// Frames drawn, for the window's thread.
    drawn: Arc<std::sync::atomic::AtomicU64>,
    /// Hot reload: the shader directory and what was compiled from it.
    shaders: reload::ShaderWatch,
}

impl Renderer {
    /// Creates the Vulkan host for `window`, then draws frames until the script's last one,
    /// a quit action or [`Input::Close`]; the viewer is dropped here, on the thread that made it.
    fn run(
        mut self,
        window: Arc<Window>,
        inputs: std::sync::mpsc::Receiver<Input>,
    ) -> anyhow::Result<u64> {
        let result = self.draw_frames(window, &inputs);
        // The device, surface and instance go now: validation also checks their destruction.
        drop(self.viewer.take());
        result.map(|()| self.index)
    }

    fn draw_frames(
        &mut self,
        window: Arc<Window>,
        inputs: &std::sync::mpsc::Receiver<Input>,
    ) -> anyhow::Result<()> {
        self.viewer = Some(Viewer::new(
            &self.setup,
            &self.state,
            window,
            self.validation,
            self.setup.args.frames.is_some(),
        )?);
        self.last_progress = Instant::now();
        loop {
            for input in inputs.try_iter() {
                match input {
                    Input::Action(a) => self.input.push(a),
                    Input::Resized => {
                        if let Some(v) = self.viewer.as_mut() {
                            v.stale = true;
                        }
                    }
                    Input::Close => return self.finish(),
                }
            }
            let before = self.index;
            if self.frame()? {
                return Ok(());
            }
            if self.index == before {
                // Nothing drawn (minimized, or the GPU still busy): do not spin a core.
                std::thread::sleep(GPU_POLL);
            }
            if self.setup.args.frames.is_some() && self.last_progress.elapsed() > STALL_LIMIT {
                bail!(
                    "no frame drawn for {} s (frame {}): the window has no area?",
                    STALL_LIMIT.as_secs(),
                    self.index
                );
            }
        }
    }

    /// Applies this frame's script actions and the input, then draws. `true`: the session
    /// ended (the script's last frame or a quit action; the report is written).
    fn frame(&mut self) -> anyhow::Result<bool> {
        let Some(viewer) = self.viewer.as_mut() else {
            return Ok(false);
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
        // A file saved in the shader directory reloads as F5 does.
        let saved = self.shaders.changed();
        if reload || saved {
            self.reload_shaders(if reload { "key" } else { "file" });
        }
        let Some(viewer) = self.viewer.as_mut() else {
            return Ok(false);
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
            self.drawn
                .store(self.index, std::sync::atomic::Ordering::Relaxed);
            self.last_progress = Instant::now();
            if last {
                quit = true;
            }
        }
        if quit {
            self.finish()?;
        }
        Ok(quit)
    }

    /// Hot reload (`trigger`: "key" for F5 or the script, "file" for a saved file): compiles
    /// the shaders of the shader directory that differ from the built-in ones and rebuilds what
    /// uses a changed one. A failure keeps the old pipelines; the overlay (the state's note),
    /// stderr and the report's `shader_reloads` say what happened.
    fn reload_shaders(&mut self, trigger: &str) {
        let Some(viewer) = self.viewer.as_mut() else {
            return;
        };
        let began = Instant::now();
        let compiled = self.shaders.compile();
        let compile_ms = began.elapsed().as_secs_f64() * 1e3;
        let failed = |e: String| format!("shader reload failed (old shaders kept): {e}");
        let (ok, note, changed, glslc_runs) = match compiled {
            Err(e) => (false, failed(e.to_string()), Vec::new(), 0),
            Ok(c) if c.changed.is_empty() => (
                true,
                format!(
                    "shader reload: no shader in {} changed",
                    self.shaders.root().display()
                ),
                Vec::new(),
                c.compiled,
            ),
            Ok(c) => {
                let installed = viewer.install_shaders(
                    &self.setup,
                    &self.state,
                    c.overrides.clone(),
                    &c.changed,
                );
                match installed {
                    Ok(()) => {
                        self.shaders.installed(&c);
                        let note = format!("shaders reloaded: {}", c.changed.join(", "));
                        (true, note, c.changed, c.compiled)
                    }
                    Err(e) => (false, failed(format!("{e:#}")), c.changed, c.compiled),
                }
            }
        };
        let reload_ms = began.elapsed().as_secs_f64() * 1e3;
        eprintln!(
            "{note} (frame {}, compile {compile_ms:.0} ms, total {reload_ms:.0} ms)",
            self.index
        );
        viewer.log.shader_reloads.push(serde_json::json!({
            "frame": self.index,
            "trigger": trigger,
            "ok": ok,
            "changed": changed,
            "compiled": glslc_runs,
            "compile_ms": compile_ms,
            "reload_ms": reload_ms,
            "message": note,
        }));
        self.state.note = Some(note);
    }

    /// Waits for the last frames, writes the report.
    fn finish(&mut self) -> anyhow::Result<()> {
        let Some(viewer) = self.viewer.as_mut() else {
            return Ok(());
        };
        viewer.idle()?;
        let (stall_ms, stall_frame) = *self
            .stall
            .lock()
            .map_err(|_| anyhow::anyhow!("the window's thread panicked"))?;
        eprintln!(
            "event loop: longest stall {stall_ms:.1} ms between two event-loop wakes, after frame {stall_frame} (heartbeat {} ms); the render thread found the GPU busy {} time(s)",
            HEARTBEAT.as_millis(),
            viewer.busy_polls
        );
        viewer.log.event_loop = Some(serde_json::json!({
            "longest_stall_ms": stall_ms,
            "longest_stall_after_frames": stall_frame,
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

impl Viewer {
    /// Installs `overrides` in the context and rebuilds what uses a `changed` shader: the
    /// present pass (`viewer/`) and/or the object (its pipelines; the solution is solved
    /// again). On any error the old shaders and pipelines stay.
    fn install_shaders(
        &mut self,
        setup: &Setup,
        state: &ViewState,
        overrides: std::collections::HashMap<String, Vec<u32>>,
        changed: &[String],
    ) -> anyhow::Result<()> {
        self.idle()?;
        let previous = self.ctx.set_shader_overrides(overrides);
        let rebuilt = self.rebuild_with_shaders(setup, state, changed);
        if rebuilt.is_err() {
            self.ctx.set_shader_overrides(previous);
        }
        rebuilt
    }

    fn rebuild_with_shaders(
        &mut self,
        setup: &Setup,
        state: &ViewState,
        changed: &[String],
    ) -> anyhow::Result<()> {
        let object = if changed.iter().any(|n| !n.starts_with("viewer/")) {
            let mut object = setup.object(&self.ctx, state)?;
            object.set_camera(Some(state.camera))?;
            Some(object)
        } else {
            None
        };
        if changed.iter().any(|n| n.starts_with("viewer/")) {
            self.present.reload(&self.ctx)?;
        }
        if let Some(object) = object {
            self.object = object;
        }
        Ok(())
    }
}

/// The window's side: input to actions for the render thread, and the render thread's end.
struct App {
    title: String,
    size: winit::dpi::PhysicalSize<u32>,
    /// The render thread before the window exists (started in `resumed`).
    renderer: Option<(Start, std::sync::mpsc::Receiver<Input>)>,
    thread: Option<std::thread::JoinHandle<anyhow::Result<u64>>>,
    /// Kept so that the window outlives the render thread's use of it.
    window: Option<Arc<Window>>,
    inputs: std::sync::mpsc::Sender<Input>,
    proxy: winit::event_loop::EventLoopProxy<Finished>,
    mouse: Mouse,
    /// When the last event-loop iteration began; the longest gap between two (shared with the
    /// renderer's report) and the frames drawn (to say when it happened).
    iteration_began: Option<Instant>,
    stall: Arc<std::sync::Mutex<(f64, u64)>>,
    drawn: Arc<std::sync::atomic::AtomicU64>,
    result: anyhow::Result<()>,
}

/// The render thread ended (sent to wake the event loop).
#[derive(Debug)]
struct Finished;

/// Sends [`Finished`] when dropped: the event loop ends even if the render thread panics.
struct SayFinished(winit::event_loop::EventLoopProxy<Finished>);

impl Drop for SayFinished {
    fn drop(&mut self) {
        let _ = self.0.send_event(Finished);
    }
}

impl App {
    fn send(&mut self, input: Input) {
        // A render thread that ended already has said why (through its result).
        let _ = self.inputs.send(input);
    }
}

impl ApplicationHandler<Finished> for App {
    fn new_events(&mut self, _: &ActiveEventLoop, _: winit::event::StartCause) {
        // The gap since the last iteration began: with the heartbeat below, longer than
        // HEARTBEAT only when an iteration (or the system) held the loop up. From the first
        // drawn frame on (window creation comes before it).
        let now = Instant::now();
        let drawn = self.drawn.load(std::sync::atomic::Ordering::Relaxed);
        if let (Some(last), true) = (self.iteration_began, drawn > 0) {
            let ms = (now - last).as_secs_f64() * 1e3;
            if let Ok(mut stall) = self.stall.lock() {
                if ms > stall.0 {
                    *stall = (ms, drawn);
                }
            }
        }
        self.iteration_began = Some(now);
    }

    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        let Some((start, inputs)) = self.renderer.take() else {
            return;
        };
        let attributes = Window::default_attributes()
            .with_title(self.title.clone())
            .with_inner_size(self.size);
        let window = match event_loop.create_window(attributes) {
            Ok(w) => Arc::new(w),
            Err(e) => {
                self.result = Err(anyhow::Error::new(e).context("creating the window"));
                event_loop.exit();
                return;
            }
        };
        self.window = Some(window.clone());
        let finished = SayFinished(self.proxy.clone());
        let spawned = std::thread::Builder::new()
            .name("translucent view render".into())
            .spawn(move || {
                let _finished = finished;
                start.renderer().run(window, inputs)
            });
        match spawned {
            Ok(handle) => self.thread = Some(handle),
            Err(e) => {
                self.result = Err(anyhow::Error::new(e).context("starting the render thread"));
                event_loop.exit();
            }
        }
    }

    fn user_event(&mut self, event_loop: &ActiveEventLoop, _: Finished) {
        event_loop.exit();
    }

    fn window_event(&mut self, _: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        match event {
            // The render thread finishes (waits for the GPU, writes the report) and says so.
            WindowEvent::CloseRequested => self.send(Input::Close),
            WindowEvent::Resized(_) => self.send(Input::Resized),
            WindowEvent::KeyboardInput { event, .. }
                if event.state == ElementState::Pressed && !event.repeat =>
            {
                if let Some(action) =
                    key_name(&event.logical_key).and_then(|k| controls::key_action(&k))
                {
                    self.send(Input::Action(action));
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
                    self.send(Input::Action(a));
                }
            }
            WindowEvent::CursorLeft { .. } => self.mouse.last = None,
            WindowEvent::MouseWheel { delta, .. } => {
                let lines = match delta {
                    MouseScrollDelta::LineDelta(_, y) => f64::from(y),
                    MouseScrollDelta::PixelDelta(p) => p.y * controls::LINES_PER_PIXEL,
                };
                if let Some(a) = controls::wheel_action(lines) {
                    self.send(Input::Action(a));
                }
            }
            _ => {}
        }
    }

    fn about_to_wait(&mut self, event_loop: &ActiveEventLoop) {
        // Wake at least every HEARTBEAT even without input, so that the gaps measured in
        // `new_events` show whether the loop could have handled an event.
        event_loop.set_control_flow(ControlFlow::WaitUntil(Instant::now() + HEARTBEAT));
    }
}

/// `translucent view`.
pub fn run(args: &ViewArgs) -> anyhow::Result<()> {
    let setup = Setup::new(args)?;
    let aspect = f64::from(setup.frame.width) / f64::from(setup.frame.height.max(1));
    let bounds = setup.graph.finest().bounding_sphere();
    let camera = setup.frame.camera.unwrap_or_else(|| {
        crate::scene_args::default_camera(bounds.0, bounds.1, aspect, setup.front)
    });
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
    state.single_scattering = start_single_scattering(args);
    state.skip = !args.no_skip;
    state.method = METHODS
        .iter()
        .position(|m| m.name == args.method)
        .unwrap_or(0);
    let event_loop = EventLoop::<Finished>::with_user_event()
        .build()
        .context(
            "opening the window system (no display? set DISPLAY or WAYLAND_DISPLAY; headless: run under Xvfb)",
        )?;
    // The render thread draws; the event loop sleeps until an event or the heartbeat.
    event_loop.set_control_flow(ControlFlow::WaitUntil(Instant::now() + HEARTBEAT));
    let (sender, receiver) = std::sync::mpsc::channel();
    let stall = Arc::new(std::sync::Mutex::new((0.0, 0)));
    let drawn = Arc::new(std::sync::atomic::AtomicU64::new(0));
    let mut app = App {
        title: format!("translucent view: {}", setup.name),
        size: winit::dpi::PhysicalSize::new(setup.frame.width, setup.frame.height),
        renderer: None,
        thread: None,
        window: None,
        inputs: sender,
        proxy: event_loop.create_proxy(),
        mouse: Mouse::default(),
        iteration_began: None,
        stall: stall.clone(),
        drawn: drawn.clone(),
        result: Ok(()),
    };
    app.renderer = Some((
        Start {
            setup,
            state,
            stall,
            drawn,
        },
        receiver,
    ));
    event_loop
        .run_app(&mut app)
        .context("running the window's event loop")?;
    app.result?;
    let frames = match app.thread.take() {
        Some(handle) => handle
            .join()
            .map_err(|_| anyhow::anyhow!("the render thread panicked"))??,
        None => 0,
    };
    drop(app.window.take());
    let messages = host::validation_messages();
    if messages > 0 {
        bail!("{messages} validation message(s) (printed above)");
    }
    if let Some(n) = args.frames {
        if frames < n {
            bail!("the window closed after {frames} of {n} frames");
        }
    }
    Ok(())
}
