//! `translucent render --method voxel`: the voxel method (Ozawa et al., `frame::VoxelMethod`)
//! through the same object, headless host, shading and capture as the QuadGraph; no bake.
//!
//! ```text
//! translucent render --method voxel --shape sphere --material marble --out v.png --profile
//! translucent render --method voxel --voxels 64 --voxel-model paper --out v.exr --json
//! ```

use anyhow::{bail, Context as _};
use glam::DQuat;
use std::time::Instant;
use translucent::frame::VoxelMethod;
use translucent::headless::HeadlessHost;
use translucent::scene::{self, Camera, Environment};
use translucent::solver::voxel::{VoxelModel, VoxelParams, VoxelResolution};
use translucent::vk::{Context, ContextDesc};
use translucent::{MethodDesc, ObjectParams, TranslucentObject};

use crate::render::RenderArgs;

/// The default scene of `render` (same as the QuadGraph's).
const DEFAULT_SHAPE: &str = "torus";
const DEFAULT_MATERIAL: &str = "skimmilk";

/// The model without `--voxel-model` (benches/RESULTS.md, "Voxel method": closer to path tracing
/// on the references).
pub const DEFAULT_MODEL: VoxelModel = VoxelModel::Diffusion;

/// `--voxels`, `--voxel-model`, `--voxel-soft` as [`VoxelParams`].
pub fn voxel_params(
    voxels: Option<&str>,
    model: Option<&str>,
    soft: Option<f32>,
) -> anyhow::Result<VoxelParams> {
    let params = VoxelParams {
        resolution: match voxels {
            Some(v) => v
                .parse::<VoxelResolution>()
                .with_context(|| format!("--voxels {v}"))?,
            None => VoxelResolution::Auto,
        },
        model: match model {
            Some(m) => m
                .parse::<VoxelModel>()
                .with_context(|| format!("--voxel-model {m}"))?,
            None => DEFAULT_MODEL,
        },
        soft_beta: soft.unwrap_or(0.0),
        ..VoxelParams::default()
    };
    params.validate().context("--voxel-soft")?;
    Ok(params)
}

pub fn run(args: &RenderArgs) -> anyhow::Result<()> {
    let started = Instant::now();
    if args.solver != "gpu" {
        bail!("--method voxel runs on the GPU: --solver cpu is the QuadGraph's f64 reference");
    }
    for (given, name) in [
        (args.scheme != "fv", "--scheme"),
        (args.precision.is_some(), "--precision"),
        (args.iterations.is_some(), "--iterations"),
        (args.explicit_beam(), "--source beam|second (--beam-source)"),
        (args.shadow_edge_flux, "--shadow-edge-flux"),
        (args.continuation.is_some(), "--continuation"),
        (args.upstream_beam.is_some(), "--upstream-beam"),
    ] {
        if given {
            bail!("{name} applies to the QuadGraph method, not --method voxel");
        }
    }
    if let Some(deg) = args
        .orbit_light
        .into_iter()
        .chain(args.orbit_camera)
        .find(|d| !d.is_finite())
    {
        bail!("--orbit-light/--orbit-camera {deg}: must be a finite number of degrees");
    }
    let params = voxel_params(
        args.voxels.as_deref(),
        args.voxel_model.as_deref(),
        args.voxel_soft,
    )?;
    let frame_desc = args.scene.frame_desc()?;
    let environment = match (&args.env_constant, &args.env) {
        (Some(text), _) => {
            let v: Vec<f64> = text
                .split(',')
                .map(|c| c.trim().parse::<f64>())
                .collect::<Result<_, _>>()
                .with_context(|| format!("--env-constant {text}: expected R,G,B"))?;
            let [r, g, b] = v[..] else {
                bail!("--env-constant {text}: expected R,G,B");
            };
            Environment::Constant([r, g, b])
        }
        (None, Some(path)) => Environment::load_exr(path).context("--env")?,
        (None, None) => Environment::None,
    };
    let field = args.material.field(args.object.size_mm, DEFAULT_MATERIAL)?;
    let object = args.object.load(Some(DEFAULT_SHAPE))?;
    let aspect = f64::from(frame_desc.width) / f64::from(frame_desc.height.max(1));
    let base_camera = frame_desc
        .camera
        .unwrap_or_else(|| object.default_camera(aspect));
    if !args.json {
        eprintln!("{}", object.view_line());
    }
    // Without --light: the default lights placed relative to this camera.
    let lights = args.scene.lights_for(&base_camera)?;
    let base_scene = scene::Scene {
        lights: lights.clone(),
        environment,
    };

    let ctx = Context::headless(&ContextDesc {
        echo_validation: true,
        ..ContextDesc::default()
    })?;
    let mut translucent = TranslucentObject::with_method(
        &ctx,
        MethodDesc::Voxel {
            mesh: object.surface.clone(),
            params: params.clone(),
        },
        &field,
        &base_scene,
        &ObjectParams {
            specular: frame_desc.specular,
            roughness: frame_desc.roughness,
            radiance: frame_desc.radiance,
            exit_lobe: frame_desc.exit_lobe,
            skip: !args.no_skip,
            single_scattering: args.scatter_params()?,
            ..ObjectParams::default()
        },
    )?;
    translucent.set_camera(Some(base_camera))?;
    if let Some(choice) = args.method_choice {
        translucent.set_method_choice(choice)?;
    }
    let mut method_choice = None;
    let supersample = crate::render::supersample_factor(args, frame_desc.width, frame_desc.height);
    let mut host = HeadlessHost::new(
        &ctx,
        frame_desc.width * supersample,
        frame_desc.height * supersample,
    )?;
    let mut frames = Vec::new();
    let mut timings = Vec::new();
    let mut last = None;
    for i in 0..args.frames {
        if i > 0 {
            if let Some(deg) = args.orbit_light {
                let q = DQuat::from_rotation_y((deg * f64::from(i)).to_radians());
                translucent.set_lights(&scene::Scene {
                    lights: base_scene.lights.iter().map(|l| l.rotated(q)).collect(),
                    environment: base_scene.environment,
                })?;
            }
            if let Some(deg) = args.orbit_camera {
                let q = DQuat::from_rotation_y((deg * f64::from(i)).to_radians());
                translucent.set_camera(Some(Camera {
                    eye: base_camera.target + q * (base_camera.eye - base_camera.target),
                    ..base_camera
                }))?;
            }
        }
        let (captured, report) = host.render(&ctx, &mut translucent)?;
        method_choice = report.method_choice;
        let solves = translucent.completed_solves(ctx.frames().1)?;
        let solve = solves.iter().find(|s| s.frame == captured.frame);
        let iterations = solve.map_or(0, |s| s.iterations()[0]);
        let converged = solve.map(|s| s.converged());
        if converged == Some(false) && !args.json {
            eprintln!(
                "warning: frame {}: the relaxation reached its cap ({iterations} iterations) before its fixed point",
                captured.frame
            );
        }
        let skipped: serde_json::Map<String, serde_json::Value> = report
            .skipped
            .iter()
            .map(|(pass, why)| (pass.to_string(), why.to_string().into()))
            .collect();
        frames.push(serde_json::json!({
            "frame": captured.frame,
            "passes": captured.passes,
            "iterations": [iterations],
            "converged": converged,
            "skipped": skipped,
            "material_variant": report.material_variant,
        }));
        timings.extend(captured.timings.clone());
        last = Some(captured);
    }
    let voxel = translucent
        .method()
        .as_any()
        .downcast_ref::<VoxelMethod>()
        .context("the voxel method")?;
    let grid = voxel.passes().report(&ctx)?;
    let gpu_bytes = translucent.gpu_bytes();
    drop(host);
    drop(translucent);
    if let Some(path) = &args.trace {
        let trace = translucent::vk::FrameTimings::chrome_trace(&timings).to_string();
        translucent::vk::capture::write_atomically(path, |tmp| {
            std::fs::write(tmp, trace.as_bytes()).map_err(|e| e.to_string())
        })
        .with_context(|| format!("--trace {}", path.display()))?;
    }
    let last = last.context("no frame rendered")?;
    crate::render::write_output(args, &last.image, supersample, started)?;
    if args.profile && !args.json {
        println!(
            "voxel grid {}x{}x{} ({} along the longest side), {:?} model, relaxation {} iterations{}",
            grid.dims[0],
            grid.dims[1],
            grid.dims[2],
            grid.voxels,
            params.model,
            grid.iterations,
            if grid.converged { "" } else { " (cap)" }
        );
        if last.passes.is_empty() {
            println!("no GPU timestamps on this device");
        }
        for (pass, ms) in &last.passes {
            println!("{pass:<22} {ms:9.3} ms");
        }
    }
    if args.json {
        let out = serde_json::json!({
            "device": ctx.info().device_name,
            "output": args.out.display().to_string(),
            "width": frame_desc.width,
            "exit_lobe": frame_desc.exit_lobe.name(),
            "height": frame_desc.height,
            "method": "voxel",
            "method_choice": crate::render::choice_json(method_choice),
            "view": object.view_json(),
            "voxel_model": format!("{:?}", params.model).to_lowercase(),
            "voxels": grid.voxels,
            "dims": grid.dims,
            "frames": frames,
            "gpu_bytes": gpu_bytes,
        });
        println!("{out}");
    }
    let messages = ctx.take_validation_messages();
    drop(ctx);
    if !messages.is_empty() {
        bail!("{} validation message(s) (printed above)", messages.len());
    }
    Ok(())
}
