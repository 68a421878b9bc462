//! `translucent view`: an interactive window on one object (cargo feature `window`, on by
//! default). Orbit with the left mouse button, zoom with the wheel, turn the key light with the
//! right button; keys switch material, method, precision, single scattering and skipping
//! ([`controls::BINDINGS`]); an overlay shows per-pass GPU ms, the solve's iterations per level
//! (cascade) or cycles and work units (multigrid) and every
//! skipped pass with its reason.
//!
//! Lights: without `--light` the default lights are placed relative to the starting camera
//! (`--camera` or the automatic framing; `scene_args::default_lights_for`), as `translucent
//! render` places them. While the camera orbits they stay fixed in the world: orbiting then
//! shows the object's lit and back-lit sides and re-runs only the shading pass (lights that
//! followed the camera would re-solve the diffusion at every mouse move). The right mouse button
//! turns the key light from there; `r` (reset camera) does not move the lights.
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
//! presents and fences two frames in flight itself, on a render thread (`app`: the window's
//! event loop stays responsive while a long solve runs inside `vkQueueSubmit`). A frame with nothing changed records only
//! the object's shading pass (the report says why each other pass was skipped).
//!
//! The clear and the present pass are host passes around `record`, not frame-graph passes: they
//! touch only the viewer's own images (the HDR target and the swapchain image), whose states the
//! viewer tracks itself and hands to the object as the target's `before`/`after`; the graph's
//! barriers cover everything the object owns. The present pass has its own profiler scope
//! (`present`), a screenshot's copy `capture`.

mod app;
mod controls;
mod host;
mod overlay;
mod present;
mod reload;
mod report;
mod script;
mod setup;
mod state;
mod targets;

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{bail, Context as _};
use ash::vk;
use translucent::defaults::{Schedule, Settings};
use translucent::headless::FrameDesc;
use translucent::material::MaterialField;
use translucent::object::{MethodDesc, RecordCtx, TargetImage, Targets};
use translucent::render::{COLOR_FORMAT, DEPTH_FORMAT};
use translucent::scene::{Environment, Scene};
use translucent::solver::gpu::Precision;
use translucent::solver::transport::Source;
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
use setup::*;
use state::{camera_arg, light_arg, ViewState, METHODS};
use targets::*;

pub use app::run;
#[cfg(test)]
pub(crate) use setup::{start_single_scattering, view_settings};

/// Frames the viewer keeps in flight (command buffers, fences, profiler slots).
const IN_FLIGHT: usize = 2;
/// How long one event-loop iteration waits for the GPU before it goes back to the window's
/// events (the frame is tried again on the next iteration): short enough that input and
/// window events keep flowing during a long solve, long enough not to spin a core.
const GPU_POLL: Duration = Duration::from_millis(4);
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
    /// The cascade's Jacobi iteration cap per level (default 2000); as with `render`, giving it
    /// runs the cascade.
    #[arg(long)]
    pub iterations: Option<u32>,
    /// The solve's stopping point: the multigrid's relative residual, or the cascade's estimated
    /// relative error per level.
    #[arg(long, default_value_t = translucent::defaults::TOLERANCE)]
    pub tolerance: f64,
    /// How the levels are used (DESIGN 5.1), as `render --schedule`: multigrid (the default, the
    /// library's) or cascade; fp16 precision (the `p` key) and `--scheme paper` run the cascade.
    #[arg(long, value_parser = ["cascade", "multigrid"])]
    pub schedule: Option<String>,
    /// Where the lights' light enters the diffusion, as `render --source`: flux, beam or second
    /// (default: the library's, second for homogeneous materials and flux for heterogeneous ones).
    #[arg(long, value_name = "flux|beam|second", value_parser = ["flux", "beam", "second"])]
    pub source: Option<String>,
    /// Single scattering to start with (the `s` key toggles): on (the default, as `render`'s)
    /// or off.
    #[arg(long, value_name = "on|off", value_parser = ["on", "off"])]
    pub single_scattering: Option<String>,
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
    /// Shader hot reload: GLSL sources with the layout of `shaders-glsl/` (default: env
    /// TRANSLUCENT_SHADER_DIR, else the source tree this binary was built from). On F5, the
    /// script's `reload-shaders`, or a file saved there, every shader that differs from the
    /// built-in one is compiled with glslc and used; a broken one keeps the old pipelines.
    #[arg(long, value_name = "DIR")]
    pub shader_dir: Option<PathBuf>,
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
    /// The mesh's up axis (`--up`, or what `auto` chose): passed on to the equivalent render.
    up: &'static str,
    /// The side the starting camera looks from without `--camera` (`framing::choose_front`).
    front: crate::framing::Side,
    /// The dipole method's face-cluster hierarchy of the display mesh, built on first use.
    dipole_hierarchy: std::sync::OnceLock<Arc<translucent::solver::dipole::FaceClusterHierarchy>>,
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
    /// The last completed solve (its counters: per level, or the multigrid's cycles).
    solve: Option<translucent::frame::CompletedSolve>,
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
    /// Since when the GPU has been busy with an earlier frame while a new one waits (`None`:
    /// not waiting); the window's title says so.
    busy_since: Option<Instant>,
    /// The title says the GPU is busy.
    busy_titled: bool,
    /// The object's name (the window's title).
    name: String,
    /// Event-loop iterations that found the GPU busy and went back to the events.
    pub(super) busy_polls: u64,
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
            busy_since: None,
            busy_titled: false,
            name: setup.name.clone(),
            busy_polls: 0,
            host,
            window,
        })
    }

    /// Notes whether the next frame waits for the GPU: after BUSY_TITLE_AFTER of waiting the
    /// window's title says the GPU is working (the last image stays on screen).
    fn set_busy(&mut self, busy: bool) {
        const BUSY_TITLE_AFTER: Duration = Duration::from_millis(250);
        let title = |extra: &str| format!("translucent view: {}{extra}", self.name);
        match (busy, self.busy_since) {
            (true, None) => self.busy_since = Some(Instant::now()),
            (true, Some(t)) if t.elapsed() >= BUSY_TITLE_AFTER && !self.busy_titled => {
                self.window.set_title(&title(" (GPU busy: solving...)"));
                self.busy_titled = true;
            }
            (false, Some(_)) => {
                self.busy_since = None;
                if self.busy_titled {
                    self.window.set_title(&title(""));
                    self.busy_titled = false;
                }
            }
            _ => {}
        }
        self.busy_polls += u64::from(busy);
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
            self.log.solve(&s);
            self.completed.solve = Some(s);
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
        // The slot's last frame must complete before its command buffer is reused, but the
        // event loop does not wait for it beyond GPU_POLL: while the GPU is busy (a cold solve
        // is one long submission) the window keeps taking input, shows the last image, says so
        // in its title, and the next loop iteration tries again.
        // SAFETY: the fence belongs to this device.
        match unsafe { d.wait_for_fences(&[fence], true, GPU_POLL.as_nanos() as u64) } {
            Ok(()) => self.set_busy(false),
            Err(vk::Result::TIMEOUT) => {
                self.set_busy(true);
                return Ok(None);
            }
            Err(e) => return Err(e).context("vkWaitForFences"),
        }
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
            Some(solve) => lines.push(overlay::solve_line(solve)),
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
            // A compile error is glslc's message, several lines.
            for line in note.lines() {
                lines.push((line.to_string(), Colour::Warning));
            }
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
