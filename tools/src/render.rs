//! `translucent render`: renders the built-in default scene (a procedural shape, a default light,
//! an auto-framed camera) headless and writes PNG or EXR. J+ comes from the Lambert-like CPU
//! stand-in until the diffusion solvers are plugged in.

use std::path::PathBuf;

use anyhow::{bail, Context as _};
use translucent::render::{HeadlessRenderer, Scene};
use translucent::vk::capture::write_atomically;
use translucent::vk::{Context, ContextDesc, FrameTimings};

use crate::scene_args::SceneArgs;

#[derive(clap::Args, Debug)]
pub struct RenderArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
    /// Output image: `.png` (exposure, tone map, sRGB) or `.exr` (linear radiance).
    #[arg(long)]
    pub out: PathBuf,
    /// Render this many frames of the same scene, as a host would; the last one is written.
    #[arg(long, default_value_t = 1)]
    pub frames: u32,
    /// Print the per-pass GPU milliseconds of the last frame.
    #[arg(long)]
    pub profile: bool,
    /// Print one JSON object: device, per-frame pass timings.
    #[arg(long)]
    pub json: bool,
    /// Write the GPU timestamp scopes of all frames as a Chrome trace (chrome://tracing, Perfetto).
    #[arg(long)]
    pub trace: Option<PathBuf>,
}

pub fn run(args: &RenderArgs) -> anyhow::Result<()> {
    match args
        .out
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .as_deref()
    {
        Some("png" | "exr") => {}
        _ => bail!("--out {}: must end in .png or .exr", args.out.display()),
    }
    if args.frames == 0 {
        bail!("--frames 0: must render at least one frame");
    }
    let frame_desc = args.scene.frame_desc()?;
    let lights = args.scene.lights()?;
    let scene = Scene::procedural(
        &args.scene.shape,
        args.scene.size_mm,
        lights,
        args.scene.eta,
    )
    .context("building the scene")?;

    let ctx = Context::headless(&ContextDesc {
        echo_validation: true,
        ..ContextDesc::default()
    })?;
    let mut renderer = HeadlessRenderer::new(&ctx, &scene, &frame_desc)?;
    let mut frames = Vec::new();
    let mut timings = Vec::new();
    let mut last = None;
    for _ in 0..args.frames {
        let captured = renderer.render_frame(&ctx)?;
        frames.push(serde_json::json!({ "frame": captured.frame, "passes": captured.passes }));
        timings.extend(captured.timings.clone());
        last = Some(captured);
    }
    if let Some(path) = &args.trace {
        let trace = FrameTimings::chrome_trace(&timings).to_string();
        write_atomically(path, |tmp| {
            std::fs::write(tmp, trace.as_bytes()).map_err(|e| e.to_string())
        })
        .with_context(|| format!("--trace {}", path.display()))?;
    }
    let last = last.context("no frame rendered")?;
    last.image
        .write(&args.out, args.scene.exposure)
        .with_context(|| format!("--out {}", args.out.display()))?;

    if args.profile && !args.json {
        if last.passes.is_empty() {
            println!("no GPU timestamps on this device");
        }
        for (pass, ms) in &last.passes {
            println!("{pass:<12} {ms:9.3} ms");
        }
    }
    if args.json {
        let out = serde_json::json!({
            "device": ctx.info().device_name,
            "output": args.out.display().to_string(),
            "width": frame_desc.width,
            "height": frame_desc.height,
            "frames": frames,
        });
        println!("{out}");
    }
    let messages = ctx.take_validation_messages();
    drop(renderer);
    drop(ctx);
    if !messages.is_empty() {
        bail!("{} validation message(s) (printed above)", messages.len());
    }
    Ok(())
}
