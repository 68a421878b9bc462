//! `translucent view`: an interactive window on one object (cargo feature `window`, on by
//! default). Orbit with the left mouse button, zoom with the wheel, turn the key light with the
//! right button; keys switch material, method, precision, single scattering and skipping
//! ([`controls::BINDINGS`]); an overlay shows per-pass GPU ms, iterations per level and every
//! skipped pass with its reason.
//!
//! ```text
//! translucent view                                   # the default scene: a back-lit milk torus
//! translucent view --mesh ../shared/meshes/spot.obj --material skin1
//! translucent view --frames 60 --script demo.script --screenshot shot.png --report frames.json
//! ```
//!
//! The viewer is the project's second host example (after `engine/examples/host_graph.rs`): it
//! creates its own instance, device and swapchain ([`host`]), lends them to the library with
//! `Context::from_host`, and per frame records into its own command buffer: a clear of its HDR
//! target (`translucent::render::COLOR_FORMAT`), the object's `record` (exactly as a host does:
//! the object adds its passes and barriers, and hands the target back for sampling), then its
//! own present pass ([`present`]: tone map and overlay into the swapchain image); it submits,
//! presents and fences two frames in flight itself. A frame with nothing changed records only
//! the object's shading pass (the report says why each other pass was skipped).
//!
//! The clear and the present pass are host passes around `record`, not frame-graph passes: they
//! touch only the viewer's own images (the HDR target and the swapchain image), whose states the
//! viewer tracks itself and hands to the object as the target's `before`/`after`; the graph's
//! barriers cover everything the object owns. The present pass has its own profiler scope
//! (`present`), a screenshot's copy `capture`.

mod controls;
mod host;
mod overlay;
mod present;
#[cfg(feature = "hot-reload")]
mod reload;
mod report;
mod script;
mod state;

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{bail, Context as _};
use ash::vk;
use translucent::headless::FrameDesc;
use translucent::material::MaterialField;
use translucent::object::{MethodDesc, RecordCtx, TargetImage, Targets};
use translucent::render::{COLOR_FORMAT, DEPTH_FORMAT};
use translucent::scene::{Environment, Scene};
use translucent::solver::gpu::{GpuSolveParams, Precision};
use translucent::solver::Scheme;
use translucent::vk::{barrier, Access, Context, GpuProfiler, Image, ImageDesc, ImageReadback};
use translucent::{ObjectParams, QuadGraph, TranslucentObject};
use winit::application::ApplicationHandler;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::Key;
use winit::raw_window_handle::{HasDisplayHandle, HasWindowHandle};
use winit::window::{Window, WindowId};

use crate::material_args::MaterialArgs;
use crate::object_args::ObjectArgs;
use crate::scene_args::SceneArgs;
use controls::{Action, Mouse};
use host::{Host, Swapchain};
use overlay::Colour;
use present::{PresentPass, PresentPush};
use report::{FrameEntry, FrameLog};
use script::Script;
use state::{camera_arg, light_arg, ViewState, METHODS};

/// Frames the viewer keeps in flight (command buffers, fences, profiler slots).
const IN_FLIGHT: usize = 2;
/// Timestamp scopes per frame: a whole cold solve has two per Jacobi block and level.
const PROFILER_SCOPES: u32 = 4096;
/// The material when no material option is given (as `render`).
const DEFAULT_MATERIAL: &str = "skimmilk";
const DEFAULT_SHAPE: &str = "torus";

#[derive(clap::Args, Debug, Clone)]
pub struct ViewArgs {
    #[command(flatten)]
    pub object: ObjectArgs,
    #[command(flatten)]
    pub material: MaterialArgs,
    /// `--width/--height` are the window's starting size.
    #[command(flatten)]
    pub scene: SceneArgs,
    /// The method to start with (the `k` key walks quadgraph, voxel, dipole). voxel: `--voxels
    /// auto` and render's default model; dipole: a heterogeneous material as a texture
    /// (`render --texture-only`).
    #[arg(long, default_value = "quadgraph", value_parser = ["quadgraph", "voxel", "dipole"])]
    pub method: String,
    /// Discretization: fv (finite volumes, default) or paper (Eqs. 5/6).
    #[arg(long, default_value = "fv", value_parser = ["fv", "paper"])]
    pub scheme: String,
    /// Jacobi iteration cap per level.
    #[arg(long, default_value_t = 2000)]
    pub iterations: u32,
    /// Stop a level's iterations once the estimated relative error is below this.
    #[arg(long, default_value_t = 1e-4)]
    pub tolerance: f64,
    /// GPU state precision to start with (the `p` key cycles).
    #[arg(long, default_value = "mixed", value_parser = ["mixed", "fp16", "fp32"])]
    pub precision: String,
    /// Constant environment radiance R,G,B.
    #[arg(long, value_name = "R,G,B", conflicts_with = "env")]
    pub env_constant: Option<String>,
    /// Environment radiance from an equirectangular EXR (order-2 spherical harmonics).
    #[arg(long, value_name = "FILE.exr")]
    pub env: Option<PathBuf>,
    /// Start with the skips off (the `x` key toggles).
    #[arg(long)]
    pub no_skip: bool,
    /// Render this many frames and exit (with --script and --screenshot: a scripted session).
    #[arg(long)]
    pub frames: Option<u64>,
    /// Scripted input: camera, light, material and switch changes at given frames (format in
    /// the README's "Viewer" section).
    #[arg(long, value_name = "FILE")]
    pub script: Option<PathBuf>,
    /// After the last frame, write it as FILE.png and FILE.exr (either extension names both).
    #[arg(long, value_name = "FILE.png")]
    pub screenshot: Option<PathBuf>,
    /// Write per frame what the overlay shows (passes, skipped passes and why, GPU ms,
    /// iterations) and the final scene as `render` options, as JSON, when the viewer exits.
    #[arg(long, value_name = "FILE.json")]
    pub report: Option<PathBuf>,
    /// Where baked QuadGraphs are cached (as `render`).
    #[arg(long, value_name = "DIR")]
    pub cache_dir: Option<PathBuf>,
}

/// Everything that does not need a window: the baked graph, the material and the scene.
struct Setup {
    args: ViewArgs,
    name: String,
    graph: Arc<QuadGraph>,
    /// The command line's material (used while the state names no other).
    field: MaterialField,
    environment: Environment,
    frame: FrameDesc,
    script: Script,
    /// The finest lattice's cells across (`--resolution`, or what `auto` chose).
    resolution: u32,
    /// The dipole method's face-cluster hierarchy of the display mesh, built on first use.
    dipole_hierarchy: std::sync::OnceLock<Arc<translucent::solver::dipole::FaceClusterHierarchy>>,
}

fn rgb(option: &str, text: &str) -> anyhow::Result<[f64; 3]> {
    let v: Vec<f64> = text
        .split(',')
        .map(|v| v.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("{option} {text:?}: expected R,G,B numbers"))?;
    v.try_into()
        .map_err(|_| anyhow::anyhow!("{option} {text:?}: expected 3 numbers"))
}

/// `path` with extension `ext` (the screenshot's PNG and EXR).
fn with_extension(path: &Path, ext: &str) -> PathBuf {
    path.with_extension(ext)
}

/// The PNG and EXR paths of a screenshot named `path` (`.png` or `.exr`).
fn screenshot_paths(path: &Path) -> anyhow::Result<(PathBuf, PathBuf)> {
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
    fn new(args: &ViewArgs) -> anyhow::Result<Setup> {
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
        if args.iterations == 0 {
            bail!("--iterations 0: give at least one iteration per level");
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
        let params = args.object.bake_params(&resolution);
        let start = Instant::now();
        let (graph, stats, outcome, file) =
            crate::cache::bake(&object, &params, args.cache_dir.as_deref())?;
        eprintln!(
            "{}",
            resolution.line(
                stats
                    .levels
                    .last()
                    .map_or(0, |l| l.surface_nodes + l.inner_nodes)
            )
        );
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
            dipole_hierarchy: std::sync::OnceLock::new(),
        })
    }

    /// The material `state` names (or the command line's).
    fn field(&self, state: &ViewState) -> anyhow::Result<MaterialField> {
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

    fn frame_exposure(&self) -> f32 {
        self.args.scene.exposure
    }

    fn scene(&self, state: &ViewState) -> Scene {
        Scene {
            lights: state.lights.clone(),
            environment: self.environment,
        }
    }

    /// The object's parameters for `state`.
    fn object_params(&self, state: &ViewState) -> ObjectParams {
        ObjectParams {
            solve: GpuSolveParams {
                scheme: if self.args.scheme == "paper" {
                    Scheme::Paper
                } else {
                    Scheme::Fv
                },
                precision: state.precision,
                iterations: vec![self.args.iterations],
                tolerance: self.args.tolerance as f32,
                ..GpuSolveParams::default()
            },
            color_format: COLOR_FORMAT,
            depth_format: DEPTH_FORMAT,
            specular: self.frame.specular,
            roughness: self.frame.roughness,
            radiance: self.frame.radiance,
            skip: state.skip,
            single_scattering: state
                .single_scattering
                .then(translucent::frame::ScatterParams::default),
            ..ObjectParams::default()
        }
    }

    /// Builds the object for `state` (a new method, precision or skip setting).
    fn object(&self, ctx: &Context, state: &ViewState) -> anyhow::Result<TranslucentObject> {
        match state.method_name() {
            "voxel" => Ok(TranslucentObject::with_method(
                ctx,
                MethodDesc::Voxel {
                    mesh: self.graph.surface.clone(),
                    params: crate::render_voxel::voxel_params(None, None, None)?,
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
    fn render_args(&self, state: &ViewState, extent: [u32; 2]) -> Vec<String> {
        let a = &self.args;
        let mut out: Vec<String> = Vec::new();
        // `--option=value`: values such as a camera at x < 0 start with '-'.
        let mut push = |k: &str, v: String| out.push(format!("{k}={v}"));
        match (&a.object.mesh, &a.object.shape) {
            (Some(m), _) => push("--mesh", m.display().to_string()),
            (None, s) => push("--shape", s.clone().unwrap_or(DEFAULT_SHAPE.into())),
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
        push("--radiance", a.scene.radiance.clone());
        push("--exposure", a.scene.exposure.to_string());
        push("--scheme", a.scheme.clone());
        // The QuadGraph's solver options; render refuses them for the other methods.
        if state.method_name() == "quadgraph" {
            push("--precision", precision_name(state.precision).into());
            push("--iterations", a.iterations.to_string());
            push("--tolerance", a.tolerance.to_string());
        }
        if a.scene.no_specular {
            out.push("--no-specular".into());
        }
        if !state.skip {
            out.push("--no-skip".into());
        }
        if state.method_name() == "dipole" && !self.field(state).is_ok_and(|f| f.is_homogeneous()) {
            out.push("--texture-only".into());
        }
        out
    }
}

fn precision_name(p: Precision) -> &'static str {
    match p {
        Precision::Mixed => "mixed",
        Precision::Fp16 => "fp16",
        Precision::Fp32 => "fp32",
    }
}

/// The text of a winit key, as [`controls::key_action`] names keys.
fn key_name(key: &Key) -> Option<String> {
    match key {
        Key::Character(s) => Some(s.to_string()),
        Key::Named(n) => Some(format!("{n:?}").to_lowercase()),
        _ => None,
    }
}

/// Per frame slot: a command buffer, its fence and the acquire semaphore.
struct FrameSlots {
    pool: vk::CommandPool,
    cbs: Vec<vk::CommandBuffer>,
    fences: Vec<vk::Fence>,
    acquired: Vec<vk::Semaphore>,
}

impl FrameSlots {
    fn new(host: &Host) -> anyhow::Result<FrameSlots> {
        let d = &host.device;
        let mut slots = FrameSlots {
            pool: vk::CommandPool::null(),
            cbs: Vec::new(),
            fences: Vec::new(),
            acquired: Vec::new(),
        };
        // SAFETY: valid create infos on a live device; `destroy` frees what was made.
        let made = unsafe {
            (|| -> Result<(), vk::Result> {
                slots.pool = d.create_command_pool(
                    &vk::CommandPoolCreateInfo::default()
                        .queue_family_index(host.family)
                        .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER),
                    None,
                )?;
                slots.cbs = d.allocate_command_buffers(
                    &vk::CommandBufferAllocateInfo::default()
                        .command_pool(slots.pool)
                        .command_buffer_count(IN_FLIGHT as u32),
                )?;
                for _ in 0..IN_FLIGHT {
                    slots.fences.push(d.create_fence(
                        &vk::FenceCreateInfo::default().flags(vk::FenceCreateFlags::SIGNALED),
                        None,
                    )?);
                    slots
                        .acquired
                        .push(d.create_semaphore(&vk::SemaphoreCreateInfo::default(), None)?);
                }
                Ok(())
            })()
        };
        if let Err(e) = made {
            slots.destroy(host);
            return Err(e).context("creating the frame slots");
        }
        Ok(slots)
    }

    /// The GPU must be idle.
    fn destroy(&self, host: &Host) {
        // SAFETY: the caller's contract; null handles are allowed.
        unsafe {
            for &f in &self.fences {
                host.device.destroy_fence(f, None);
            }
            for &s in &self.acquired {
                host.device.destroy_semaphore(s, None);
            }
            host.device.destroy_command_pool(self.pool, None);
        }
    }
}

/// One completed frame's GPU times: host frame, (scope, ms, depth) in execution order, total ms.
type FrameTimes = (u64, Vec<(String, f64, u32)>, f64);

/// What the overlay shows of the frames that completed.
#[derive(Default)]
struct Completed {
    /// GPU ms per scope of the last frame whose timings came back, and its total.
    timings: Option<FrameTimes>,
    /// The same of the last frame that solved (so the solve's passes stay in view).
    solve_timings: Option<FrameTimes>,
    /// The last completed solve: host frame, iterations per level, converged.
    solve: Option<(u64, Vec<u32>, bool)>,
}

/// The window, its Vulkan host, the library's context and the object. `Drop` waits for the GPU
/// and destroys the swapchain and frame slots; then the fields drop in declaration order: the
/// object and our passes, the context, the host, the window last.
struct Viewer {
    object: TranslucentObject,
    present: PresentPass,
    hdr: Image,
    hdr_state: Access,
    profiler: GpuProfiler,
    ctx: Context,
    slots: FrameSlots,
    swapchain: Option<Swapchain>,
    /// The swapchain must be rebuilt before the next frame (resize, out of date, suboptimal).
    stale: bool,
    present_mode: vk::PresentModeKHR,
    /// Host frames recorded so far (the next is `frame + 1`).
    frame: u64,
    completed: Completed,
    last_report: Option<translucent::FrameReport>,
    log: FrameLog,
    /// When the last frame began recording (for the report's `interval_ms`).
    last_draw: Option<Instant>,
    host: Host,
    window: Arc<Window>,
}

impl Viewer {
    fn new(
        setup: &Setup,
        state: &ViewState,
        window: Arc<Window>,
        validation: bool,
        scripted: bool,
    ) -> anyhow::Result<Viewer> {
        let host = Host::new(
            window.display_handle()?.as_raw(),
            window.window_handle()?.as_raw(),
            validation,
        )?;
        // SAFETY: the handles are valid and outlive the context: the viewer drops the context
        // (and everything made from it) before the host.
        let mut ctx = unsafe {
            Context::from_host(
                host.parts.entry.clone(),
                host.instance().clone(),
                host.physical,
                host.device.clone(),
                host.family,
                0,
                IN_FLIGHT as u32,
            )?
        };
        // SAFETY: single-threaded: nothing else uses the queue while the library submits setup
        // work (object creation, rebuilds).
        unsafe { ctx.lend_queue_for_setup()? };
        let size = window.inner_size();
        // A scripted run should not wait for vertical blanks.
        let present_mode = if scripted {
            vk::PresentModeKHR::IMMEDIATE
        } else {
            vk::PresentModeKHR::FIFO
        };
        let slots = FrameSlots::new(&host)?;
        let swapchain = Swapchain::new(
            &host,
            vk::Extent2D {
                width: size.width,
                height: size.height,
            },
            present_mode,
            None,
        )?;
        let format = swapchain
            .as_ref()
            .map_or(vk::Format::B8G8R8A8_UNORM, |s| s.format);
        let extent = swapchain.as_ref().map_or(
            vk::Extent2D {
                width: size.width.max(1),
                height: size.height.max(1),
            },
            |s| s.extent,
        );
        let mut present = PresentPass::new(&ctx, &host.device, format, IN_FLIGHT)?;
        let hdr = hdr_image(&ctx, extent)?;
        present.set_source(&hdr);
        let (cols, rows) = text_grid(extent);
        present.reserve_text(&ctx, cols * rows)?;
        let object = setup.object(&ctx, state)?;
        let profiler = GpuProfiler::new(&ctx, "viewer frame", PROFILER_SCOPES)?;
        Ok(Viewer {
            object,
            present,
            hdr,
            hdr_state: Access::Undefined,
            profiler,
            ctx,
            slots,
            stale: swapchain.is_none(),
            swapchain,
            present_mode,
            frame: 0,
            completed: Completed::default(),
            last_report: None,
            log: FrameLog::default(),
            last_draw: None,
            host,
            window,
        })
    }

    /// Waits for the GPU and tells the library every frame recorded so far is complete.
    fn idle(&mut self) -> anyhow::Result<()> {
        // SAFETY: live device.
        unsafe { self.host.device.device_wait_idle() }.context("vkDeviceWaitIdle")?;
        self.ctx.frame_completed(self.frame);
        self.collect(self.frame)?;
        Ok(())
    }

    /// Reads what completed up to host frame `completed`: timings and solves.
    fn collect(&mut self, completed: u64) -> anyhow::Result<()> {
        self.profiler.frame_completed(completed);
        for t in self.profiler.take_results() {
            let (passes, total) = overlay::passes_in_order(&t);
            let flat = passes.iter().map(|(n, ms, _)| (n.clone(), *ms)).collect();
            self.log.timings(t.frame, flat);
            if passes
                .iter()
                .any(|(name, _, _)| name.starts_with("diffusion"))
            {
                self.completed.solve_timings = Some((t.frame, passes.clone(), total));
            }
            self.completed.timings = Some((t.frame, passes, total));
        }
        for s in self.object.completed_solves(completed)? {
            self.log.solve(s.frame, s.iterations(), s.converged());
            self.completed.solve = Some((s.frame, s.iterations(), s.converged()));
        }
        Ok(())
    }

    /// Rebuilds the swapchain (and the HDR target, the overlay grid) for the window's size.
    fn rebuild_swapchain(&mut self) -> anyhow::Result<()> {
        self.idle()?;
        let size = self.window.inner_size();
        let extent = vk::Extent2D {
            width: size.width,
            height: size.height,
        };
        let new = Swapchain::new(
            &self.host,
            extent,
            self.present_mode,
            self.swapchain.as_ref(),
        )?;
        if let Some(old) = self.swapchain.take() {
            old.destroy(&self.host);
        }
        self.swapchain = new;
        let Some(sc) = &self.swapchain else {
            return Ok(()); // minimized: nothing to render into until the window has an area
        };
        if sc.extent != self.hdr.extent() {
            self.hdr = hdr_image(&self.ctx, sc.extent)?;
            self.hdr_state = Access::Undefined;
            self.present.set_source(&self.hdr);
            let (cols, rows) = text_grid(sc.extent);
            self.present.reserve_text(&self.ctx, cols * rows)?;
        }
        self.stale = false;
        Ok(())
    }

    /// Records, submits and presents one frame. `None`: no frame was drawn (minimized, or the
    /// swapchain went out of date: it is rebuilt and the next call draws).
    fn draw(
        &mut self,
        setup: &Setup,
        state: &ViewState,
        index: u64,
        actions: Vec<String>,
        screenshot: Option<&Path>,
    ) -> anyhow::Result<Option<u64>> {
        if self.stale {
            self.rebuild_swapchain()?;
        }
        let Some(sc) = &self.swapchain else {
            return Ok(None);
        };
        let (sc_raw, extent, encode_srgb) = (sc.raw, sc.extent, sc.encode_srgb);
        let began = Instant::now();
        let interval_ms = self
            .last_draw
            .replace(began)
            .map(|t| (began - t).as_secs_f64() * 1e3);
        let host_frame = self.frame + 1;
        let slot = (host_frame % IN_FLIGHT as u64) as usize;
        let d = self.host.device.clone();
        let (cb, fence, acquired) = (
            self.slots.cbs[slot],
            self.slots.fences[slot],
            self.slots.acquired[slot],
        );
        // SAFETY: the fence belongs to this device.
        unsafe { d.wait_for_fences(&[fence], true, u64::MAX) }.context("vkWaitForFences")?;
        // The slot's last frame (host_frame - IN_FLIGHT) and every earlier one are done.
        let completed = host_frame.saturating_sub(IN_FLIGHT as u64);
        self.collect(completed)?;
        // SAFETY: live swapchain; the semaphore is unsignalled (its last acquire was waited on
        // by that frame's submission, whose fence we just waited for).
        let acquire = unsafe {
            self.host.swapchain_loader.acquire_next_image(
                sc_raw,
                u64::MAX,
                acquired,
                vk::Fence::null(),
            )
        };
        let image_index = match acquire {
            Ok((i, suboptimal)) => {
                self.stale |= suboptimal;
                i as usize
            }
            Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => {
                self.stale = true;
                return Ok(None);
            }
            Err(e) => return Err(e).context("vkAcquireNextImageKHR"),
        };
        let (cols, rows) = text_grid(extent);
        let lines = self.overlay_lines(setup, state, index, extent);
        self.present
            .write_text(slot, &overlay::layout(&lines, cols, rows))?;
        let readback = screenshot
            .map(|_| ImageReadback::new(&self.ctx, &self.hdr))
            .transpose()?;
        let sc = self.swapchain.as_ref().context("swapchain")?;
        let (target_image, target_view, rendered) = (
            sc.images[image_index],
            sc.views[image_index],
            sc.rendered[image_index],
        );

        // SAFETY: the slot's previous submission completed (fence), so its command buffer can
        // be reset; everything recorded below lives until this frame's fence signals.
        let report = unsafe {
            d.reset_fences(&[fence]).context("vkResetFences")?;
            d.reset_command_buffer(cb, vk::CommandBufferResetFlags::empty())
                .context("vkResetCommandBuffer")?;
            d.begin_command_buffer(
                cb,
                &vk::CommandBufferBeginInfo::default()
                    .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
            )
            .context("vkBeginCommandBuffer")?;
            self.profiler.begin_frame(cb, host_frame);
            // why: the last frame's present pass sampled the HDR image (WAR); the clear
            // overwrites it in TRANSFER_DST layout.
            barrier::image(
                &self.ctx,
                cb,
                &self.hdr,
                self.hdr_state,
                Access::TransferDst,
            );
            d.cmd_clear_color_image(
                cb,
                self.hdr.raw,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &vk::ClearColorValue { float32: [0.0; 4] },
                &[vk::ImageSubresourceRange::default()
                    .aspect_mask(vk::ImageAspectFlags::COLOR)
                    .level_count(1)
                    .layer_count(1)],
            );
            let targets = Targets {
                color: TargetImage {
                    image: self.hdr.raw,
                    view: self.hdr.view,
                    format: COLOR_FORMAT,
                    extent,
                    before: Access::TransferDst.into(),
                    after: Access::FragmentSampled.into(),
                },
                depth: None,
                host_barriers: false,
            };
            let report = self.object.record(
                &mut RecordCtx {
                    ctx: &self.ctx,
                    cb,
                    frame: host_frame,
                    completed_frame: completed,
                    profiler: Some(&mut self.profiler),
                },
                &targets,
            );
            self.hdr_state = Access::FragmentSampled;
            if let Some(r) = &readback {
                self.profiler.begin_scope(cb, "capture");
                r.record(&self.ctx, cb, &self.hdr, Access::FragmentSampled);
                self.profiler.end_scope(cb);
            }
            self.profiler.begin_scope(cb, "present");
            // why: the swapchain image comes from the presentation engine (the acquire
            // semaphore is waited at colour output); its old contents are not needed.
            let to_attachment = [raw_barrier(
                target_image,
                (
                    vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT,
                    vk::AccessFlags2::NONE,
                ),
                (
                    vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT,
                    vk::AccessFlags2::COLOR_ATTACHMENT_WRITE,
                ),
                vk::ImageLayout::UNDEFINED,
                vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
            )];
            d.cmd_pipeline_barrier2(
                cb,
                &vk::DependencyInfo::default().image_memory_barriers(&to_attachment),
            );
            self.present.record(
                cb,
                slot,
                target_view,
                extent,
                &PresentPush {
                    size: [extent.width as i32, extent.height as i32],
                    grid: [cols as i32, rows as i32],
                    exposure: setup.frame_exposure(),
                    encode_srgb: u32::from(encode_srgb),
                    text_scale: text_scale(extent),
                    overlay: u32::from(state.overlay),
                },
            );
            // why: presentation reads the image after our colour writes (the semaphore
            // signalled at submit end orders it; the layout must be PRESENT_SRC).
            let to_present = [raw_barrier(
                target_image,
                (
                    vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT,
                    vk::AccessFlags2::COLOR_ATTACHMENT_WRITE,
                ),
                (vk::PipelineStageFlags2::NONE, vk::AccessFlags2::NONE),
                vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
                vk::ImageLayout::PRESENT_SRC_KHR,
            )];
            d.cmd_pipeline_barrier2(
                cb,
                &vk::DependencyInfo::default().image_memory_barriers(&to_present),
            );
            self.profiler.end_scope(cb);
            d.end_command_buffer(cb).context("vkEndCommandBuffer")?;
            let cbs = [vk::CommandBufferSubmitInfo::default().command_buffer(cb)];
            let waits = [vk::SemaphoreSubmitInfo::default()
                .semaphore(acquired)
                .stage_mask(vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT)];
            let signals = [vk::SemaphoreSubmitInfo::default()
                .semaphore(rendered)
                .stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)];
            d.queue_submit2(
                self.host.queue,
                &[vk::SubmitInfo2::default()
                    .command_buffer_infos(&cbs)
                    .wait_semaphore_infos(&waits)
                    .signal_semaphore_infos(&signals)],
                fence,
            )
            .context("vkQueueSubmit2")?;
            report
        };
        self.frame = host_frame;
        let report = report?;
        let swapchains = [sc_raw];
        let indices = [image_index as u32];
        let wait = [rendered];
        // SAFETY: the image was acquired and its frame submitted with `rendered` to signal.
        let presented = unsafe {
            self.host.swapchain_loader.queue_present(
                self.host.queue,
                &vk::PresentInfoKHR::default()
                    .wait_semaphores(&wait)
                    .swapchains(&swapchains)
                    .image_indices(&indices),
            )
        };
        match presented {
            Ok(suboptimal) => self.stale |= suboptimal,
            Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => self.stale = true,
            Err(e) => return Err(e).context("vkQueuePresentKHR"),
        }
        self.log.push(FrameEntry {
            interval_ms,
            ..FrameEntry::from_report(index, [extent.width, extent.height], actions, &report)
        });
        self.last_report = Some(report);
        if let (Some(r), Some(path)) = (readback, screenshot) {
            // A screenshot waits for its own frame (once, on a key press or at the end).
            // SAFETY: the fence was submitted with this frame.
            unsafe { d.wait_for_fences(&[fence], true, u64::MAX) }.context("vkWaitForFences")?;
            let image = r.read()?;
            let (png, exr) = screenshot_paths(path)?;
            image.write_png(&png, setup.frame_exposure())?;
            image.write_exr(&exr)?;
            eprintln!(
                "wrote {} and {} ({}x{})",
                png.display(),
                exr.display(),
                image.width,
                image.height
            );
        }
        Ok(Some(host_frame))
    }

    /// The overlay's lines for this frame.
    fn overlay_lines(
        &self,
        setup: &Setup,
        state: &ViewState,
        index: u64,
        extent: vk::Extent2D,
    ) -> Vec<(String, Colour)> {
        let on = |b: bool| if b { "on" } else { "off" };
        let mut lines = vec![
            (
                format!(
                    "translucent view  {}  {}x{}  frame {index}",
                    self.host.device_name, extent.width, extent.height
                ),
                Colour::Heading,
            ),
            (
                format!(
                    "{}: {} levels, {} finest nodes   material {}",
                    setup.name,
                    setup.graph.levels.len(),
                    setup.graph.finest().node_count(),
                    state.material.as_deref().unwrap_or("(command line)")
                ),
                Colour::Text,
            ),
            (
                format!(
                    "method {}  precision {}  skipping {}  single scattering {} (hook)",
                    state.method_name(),
                    precision_name(state.precision),
                    on(state.skip),
                    on(state.single_scattering)
                ),
                Colour::Text,
            ),
        ];
        if let Some(r) = &self.last_report {
            lines.push((
                format!("last frame ran: {}", r.passes.join(", ")),
                Colour::Good,
            ));
            if !r.skipped.is_empty() {
                lines.push(("skipped:".into(), Colour::Text));
                for l in overlay::skipped_lines(&r.skipped) {
                    lines.push((l, Colour::Dim));
                }
            }
        }
        match &self.completed.solve {
            Some((frame, iterations, converged)) => lines.push((
                format!(
                    "solve of frame {}: iterations per level {iterations:?}{}",
                    frame - 1,
                    if *converged { "" } else { " (cap reached)" }
                ),
                if *converged {
                    Colour::Text
                } else {
                    Colour::Warning
                },
            )),
            None => lines.push(("no solve completed yet".into(), Colour::Dim)),
        }
        let solve = self
            .completed
            .solve_timings
            .as_ref()
            .filter(|s| self.completed.timings.as_ref().is_some_and(|t| t.0 != s.0));
        for (what, timings) in [
            ("frame", &self.completed.timings),
            ("last solve, frame", &solve.cloned()),
        ] {
            if let Some((frame, passes, total)) = timings {
                lines.push((
                    format!("GPU ms, {what} {}: total {total:.2}", frame - 1),
                    Colour::Heading,
                ));
                for (name, ms, depth) in passes {
                    // Scopes inside a pass are indented under it (not added to the total).
                    let indent = 2 + 2 * *depth as usize;
                    let colour = if *depth == 0 {
                        Colour::Text
                    } else {
                        Colour::Dim
                    };
                    lines.push((
                        format!("{:indent$}{name:<w$}{ms:9.3}", "", w = 30 - indent),
                        colour,
                    ));
                }
            }
        }
        if !self.profiler.enabled() {
            lines.push(("no GPU timestamps on this device".into(), Colour::Dim));
        }
        if let Some(note) = &state.note {
            lines.push((note.clone(), Colour::Warning));
        }
        if state.help {
            lines.push(("keys:".into(), Colour::Heading));
            for (key, what) in controls::BINDINGS {
                lines.push((format!("  {key:<14}{what}"), Colour::Text));
            }
        } else {
            lines.push(("h: keys".into(), Colour::Dim));
        }
        lines
    }
}

impl Drop for Viewer {
    fn drop(&mut self) {
        // SAFETY: waiting for idle makes every object the GPU used free to destroy.
        let _ = unsafe { self.host.device.device_wait_idle() };
        self.ctx.frame_completed(self.frame);
        if let Some(sc) = self.swapchain.take() {
            sc.destroy(&self.host);
        }
        self.slots.destroy(&self.host);
        // Then the fields drop in declaration order: the object, our passes, images, profiler
        // and the context (each destroys at once: every frame is complete), the host's device,
        // surface and instance, and the window last.
    }
}

/// Text pixels per font pixel: 2 on large windows.
fn text_scale(extent: vk::Extent2D) -> u32 {
    if extent.width >= 1600 {
        2
    } else {
        1
    }
}

/// Font pixels of a text cell (the 8x8 glyph and two rows of line spacing) and the margin in
/// screen pixels per text scale: `viewer/present.frag`'s `CELL` and `TEXT_MARGIN`.
const TEXT_CELL: [u32; 2] = [8, 10];
const TEXT_MARGIN: u32 = 4;

/// Columns and rows of text cells that fit `extent`.
fn text_grid(extent: vk::Extent2D) -> (usize, usize) {
    let s = text_scale(extent);
    let fit = |pixels: u32, cell: u32| (pixels.saturating_sub(TEXT_MARGIN * s) / (cell * s)).max(1);
    (
        fit(extent.width, TEXT_CELL[0]) as usize,
        fit(extent.height, TEXT_CELL[1]) as usize,
    )
}

fn hdr_image(ctx: &Context, extent: vk::Extent2D) -> anyhow::Result<Image> {
    Ok(Image::new(
        ctx,
        &ImageDesc {
            name: "viewer hdr",
            width: extent.width,
            height: extent.height,
            format: COLOR_FORMAT,
            // Cleared each frame, drawn by the object, sampled by the present pass, copied out
            // for screenshots.
            usage: vk::ImageUsageFlags::COLOR_ATTACHMENT
                | vk::ImageUsageFlags::SAMPLED
                | vk::ImageUsageFlags::TRANSFER_DST
                | vk::ImageUsageFlags::TRANSFER_SRC,
        },
    )?)
}

fn raw_barrier(
    image: vk::Image,
    src: (vk::PipelineStageFlags2, vk::AccessFlags2),
    dst: (vk::PipelineStageFlags2, vk::AccessFlags2),
    old: vk::ImageLayout,
    new: vk::ImageLayout,
) -> vk::ImageMemoryBarrier2<'static> {
    vk::ImageMemoryBarrier2::default()
        .src_stage_mask(src.0)
        .src_access_mask(src.1)
        .dst_stage_mask(dst.0)
        .dst_access_mask(dst.1)
        .old_layout(old)
        .new_layout(new)
        .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .image(image)
        .subresource_range(
            vk::ImageSubresourceRange::default()
                .aspect_mask(vk::ImageAspectFlags::COLOR)
                .level_count(1)
                .layer_count(1),
        )
}

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
    let mut state = ViewState::new(camera, bounds, args.scene.lights()?);
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
