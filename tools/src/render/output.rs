//! What `render` writes besides the image: the lit-pixel check of a PNG or EXR, the `--out`
//! probe, `--trace`, and the `--profile` / `--json` views of a frame's GPU scopes and multigrid.

use std::path::Path;
use std::time::Instant;

use anyhow::{bail, Context as _};
use translucent::vk::capture::write_atomically;
use translucent::vk::FrameTimings;

use super::RenderArgs;

/// One step of an 8-bit PNG channel: a pixel whose tone-mapped sRGB value is below it shows as
/// black.
const PNG_STEP: f32 = 1.0 / 255.0;

/// Pixels of the object (coverage > 0) with radiance: for a PNG (`Some(exposure)`) those it shows
/// brighter than black (the PNG writer's tone map: Narkowicz's ACES fit, then the sRGB curve), for
/// an EXR (`None`) any above 0.
pub(super) fn lit_pixels(image: &translucent::vk::LinearImage, png_exposure: Option<f32>) -> usize {
    let lit = |v: f32| {
        let Some(exposure) = png_exposure else {
            return v > 0.0;
        };
        let x = (v * exposure).clamp(0.0, 1e6);
        let t = ((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)).clamp(0.0, 1.0);
        let shown = if t <= 0.003_130_8 {
            12.92 * t
        } else {
            1.055 * t.powf(1.0 / 2.4) - 0.055
        };
        shown >= PNG_STEP
    };
    image
        .pixels
        .iter()
        .filter(|p| p[3] > 0.0 && p[..3].iter().any(|&v| v.is_finite() && lit(v)))
        .count()
}

/// A frame's GPU scopes in execution order as (name, depth, ms), scopes of the same name and
/// depth summed at their first place, and the total of the top-level scopes.
pub(super) fn profile_in_order(t: &FrameTimings) -> (Vec<(String, u32, f64)>, f64) {
    let mut scopes: Vec<(String, u32, f64)> = Vec::new();
    let mut total = 0.0;
    for s in &t.scopes {
        if s.depth == 0 {
            total += s.duration_ms;
        }
        match scopes
            .iter_mut()
            .find(|(n, d, _)| *n == s.name && *d == s.depth)
        {
            Some((_, _, ms)) => *ms += s.duration_ms,
            None => scopes.push((s.name.clone(), s.depth, s.duration_ms)),
        }
    }
    (scopes, total)
}

/// Fails unless a file can be created next to `out` (its folder exists and is writable), so a
/// bad `--out` is reported before the bake and the solve. Leaves nothing behind.
pub(crate) fn check_writable(out: &Path) -> anyhow::Result<()> {
    let dir = match out.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        bail!(
            "--out {}: the folder {} does not exist",
            out.display(),
            dir.display()
        );
    }
    if out.is_dir() {
        bail!("--out {}: is a folder", out.display());
    }
    let probe = dir.join(format!(".translucent-write-probe-{}", std::process::id()));
    match std::fs::File::create(&probe) {
        Ok(_) => {
            let _ = std::fs::remove_file(&probe);
            Ok(())
        }
        Err(e) => bail!(
            "--out {}: cannot write in {}: {e}",
            out.display(),
            dir.display()
        ),
    }
}

pub(crate) fn write_trace(path: &Path, trace: &str) -> anyhow::Result<()> {
    write_atomically(path, |tmp| {
        std::fs::write(tmp, trace.as_bytes()).map_err(|e| e.to_string())
    })
    .with_context(|| format!("--trace {}", path.display()))
}

/// `--json`'s "multigrid" of a GPU multigrid solve (the CPU one's fields where they exist).
pub(super) fn gpu_multigrid_json(
    m: &translucent::solver::gpu::multigrid::GpuMultigridReport,
) -> serde_json::Value {
    let mut json = serde_json::json!({
        "solver": "gpu",
        "warm": m.warm,
        "warm_order": m.warm_order,
        "local_nodes": m.local_nodes,
        "cycles": m.cycles.len(),
        "work_units": m.work_units,
        "matvec_units": m.matvec_units,
        "converged": m.converged,
        "state": m.state,
        "start_residual": m.start_residual,
        "residual": m.residual,
        "factor_per_cycle": m.cycles.iter().map(|c| c.factor).collect::<Vec<_>>(),
        "residual_per_cycle": m.cycles.iter().map(|c| c.residual).collect::<Vec<_>>(),
        "coarse_steps": m.coarse_steps,
    });
    // Present from two cycles on: a `null` in frames reads as NaN to the checks.
    if let Some(mean) = m.mean_factor {
        json["mean_factor"] = mean.into();
    }
    json
}

/// `--json`'s `gpu_bytes_split`: where the solve's GPU memory goes (issue 13 item 4), each part
/// in bytes and per finest-level node, beside the paper's ~90 bytes per node.
pub(super) fn gpu_bytes_json(
    b: &translucent::solver::gpu::SolveBytes,
    multigrid_by_buffer: &[(&str, u64)],
    finest_nodes: usize,
) -> serde_json::Value {
    let per_node = |v: u64| v as f64 / finest_nodes.max(1) as f64;
    let by_buffer: serde_json::Map<String, serde_json::Value> = multigrid_by_buffer
        .iter()
        .map(|&(name, bytes)| (name.to_string(), per_node(bytes).into()))
        .collect();
    serde_json::json!({
        // The multigrid hierarchy's buffers, bytes per finest node (operators, links, vectors).
        "multigrid_per_node_by_buffer": by_buffer,
        "textures": b.textures(),
        "multigrid": b.multigrid,
        "surface_shading": b.surface_shading(),
        "other": b.other(),
        "finest_nodes": finest_nodes,
        "bytes_per_finest_node": {
            "total": per_node(b.total()),
            "textures": per_node(b.textures()),
            "multigrid": per_node(b.multigrid),
            "surface_shading": per_node(b.surface_shading()),
            "other": per_node(b.other()),
        },
        "textures_by_kind": {
            "state": b.state,
            "rhs": b.rhs,
            "graph": b.graph,
            "material": b.material,
            "links": b.links,
        },
        "surface": b.surface,
        "shading": b.shading,
        "deform": b.deform,
        "control": b.control,
    })
}

/// The samples per side `--supersample` renders with for a `width` x `height` image: at most
/// the option, and no more than keeps the rendered image within 16384 pixels a side.
pub(crate) fn supersample_factor(args: &RenderArgs, width: u32, height: u32) -> u32 {
    let largest = width.max(height).max(1);
    args.supersample.clamp(1, (16384 / largest).max(1))
}

/// The image rendered `factor` x `factor` times larger, averaged down to the output size (a box
/// filter over linear radiance and coverage, so edges blend before the tone map).
pub(crate) fn downsample(
    image: &translucent::vk::capture::LinearImage,
    factor: u32,
) -> translucent::vk::capture::LinearImage {
    if factor <= 1 {
        return image.clone();
    }
    let (width, height) = (image.width / factor, image.height / factor);
    let weight = 1.0 / (factor * factor) as f32;
    let mut pixels = Vec::with_capacity((width * height) as usize);
    for y in 0..height {
        for x in 0..width {
            let mut sum = [0.0f32; 4];
            for sy in 0..factor {
                let row = ((y * factor + sy) * image.width) as usize;
                for sx in 0..factor {
                    let p = image.pixels[row + (x * factor + sx) as usize];
                    for c in 0..4 {
                        sum[c] += p[c] * weight;
                    }
                }
            }
            pixels.push(sum);
        }
    }
    translucent::vk::capture::LinearImage {
        width,
        height,
        pixels,
    }
}

/// What every method's render does with its last frame: averages the supersamples, refuses an
/// image with no lit object pixel (unless `--allow-black`), adds the backdrop, writes `--out`
/// and says so. Returns the written image.
pub(crate) fn write_output(
    args: &RenderArgs,
    rendered: &translucent::vk::capture::LinearImage,
    factor: u32,
    started: Instant,
) -> anyhow::Result<translucent::vk::capture::LinearImage> {
    let mut image = downsample(rendered, factor);
    // An EXR keeps any radiance (a dim scene is data); a PNG must show something.
    let png = args
        .out
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("png"));
    let lit = lit_pixels(&image, png.then_some(args.scene.exposure));
    if lit == 0 && !args.allow_black {
        bail!(
            "the image has no lit object pixel (nothing written to {}): is a light or the camera inside the object, or a light pointing away from it{}? --allow-black writes it anyway",
            args.out.display(),
            if png { ", or is --exposure too low" } else { "" }
        );
    }
    if args.backdrop {
        crate::backdrop::composite(&mut image, args.scene.exposure);
    }
    image
        .write(&args.out, args.scene.exposure)
        .with_context(|| format!("--out {}", args.out.display()))?;
    eprintln!(
        "wrote {} ({} x {}, {} ms)",
        args.out.display(),
        image.width,
        image.height,
        started.elapsed().as_millis()
    );
    Ok(image)
}
