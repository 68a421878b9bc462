//! `translucent render --method dipole`: the face-cluster hierarchy of the display mesh (built on
//! the CPU with rayon, or loaded from the cache: rebuilt only when the mesh's topology or
//! positions change), linked for the material, rendered through [`TranslucentObject`] exactly as
//! the QuadGraph path (shared shadow maps, irradiance gather, shading, capture).
//!
//! ```text
//! translucent render --method dipole --shape sphere --material marble --out d.png --json
//! ```

use std::sync::Arc;
use std::time::Instant;

use anyhow::{bail, Context as _};
use translucent::frame::DipoleParams;
use translucent::headless::HeadlessHost;
use translucent::material::MaterialField;
use translucent::mesh::MeshSolid;
use translucent::object::MethodDesc;
use translucent::scene::{Camera, Scene};
use translucent::solver::dipole::{self, cache, HeterogeneousPolicy, ReceiverCriterion};
use translucent::vk::{Context, ContextDesc, FrameTimings};
use translucent::{ObjectParams, TranslucentObject};

use crate::object_args::Object;
use crate::render::RenderArgs;

/// What `render` hands over after parsing the shared options.
pub struct DipoleRender<'a> {
    pub args: &'a RenderArgs,
    pub object: Object,
    pub field: MaterialField,
    pub scene: Scene,
    pub frame_desc: translucent::headless::FrameDesc,
    pub cache_dir: std::path::PathBuf,
    /// When the command started (for the `wrote` line).
    pub started: Instant,
}

pub fn run(r: DipoleRender<'_>) -> anyhow::Result<()> {
    let args = r.args;
    if args.solver != "gpu" {
        bail!("--method dipole runs on the GPU (its CPU evaluation is in the dipole bench)");
    }
    for (name, set) in [
        ("--iterations", args.iterations.is_some()),
        ("--precision", args.precision.is_some()),
        ("--source beam|second (--beam-source)", args.explicit_beam()),
        ("--shadow-edge-flux", args.shadow_edge_flux),
        ("--continuation", args.continuation.is_some()),
        ("--upstream-beam", args.upstream_beam.is_some()),
        ("--scheme paper", args.scheme != "fv"),
    ] {
        if set {
            bail!("{name} is an option of the QuadGraph method, not of --method dipole");
        }
    }
    let key = cache::cache_key(&r.object.surface);
    let cache_file = r
        .cache_dir
        .join(format!("{}-{key:016x}.dipole", r.object.name));
    let start = Instant::now();
    let (tree, hierarchy_stats, outcome) = cache::build_cached(&cache_file, &r.object.surface)?;
    let hierarchy_s = start.elapsed().as_secs_f64();
    if let cache::CacheOutcome::Rebuilt(reason) = &outcome {
        eprintln!("warning: {reason}; built again");
    }
    let tree = Arc::new(tree);
    let mut params = DipoleParams {
        heterogeneous: if args.texture_only {
            HeterogeneousPolicy::TextureOnly
        } else {
            HeterogeneousPolicy::Refuse
        },
        ..DipoleParams::default()
    };
    if let Some(t) = args.link_tolerance {
        params.links.receiver = ReceiverCriterion::Transport { tolerance: t };
        params.links.sample_tolerance = t;
        params.links.validate().context("--link-tolerance")?;
    }
    let ctx = Context::headless(&ContextDesc {
        echo_validation: true,
        ..ContextDesc::default()
    })?;
    let object_params = ObjectParams {
        specular: r.frame_desc.specular,
        roughness: r.frame_desc.roughness,
        radiance: r.frame_desc.radiance,
        exit_lobe: r.frame_desc.exit_lobe,
        skip: !args.no_skip,
        single_scattering: args.scatter_params()?,
        ..ObjectParams::default()
    };
    let start = Instant::now();
    let mut object = TranslucentObject::with_method(
        &ctx,
        MethodDesc::Dipole {
            mesh: r.object.surface.clone(),
            hierarchy: tree.clone(),
            params,
        },
        &r.field,
        &r.scene,
        &object_params,
    )?;
    let create_s = start.elapsed().as_secs_f64();
    let method = object
        .method()
        .as_any()
        .downcast_ref::<translucent::frame::DipoleMethod>()
        .context("the object runs the dipole method")?;
    let (links, link_stats) = method.links();
    let (link_count, link_s) = (links.len(), link_stats.seconds);
    let links = links.clone();
    let material = method.material().clone();
    let aspect = f64::from(r.frame_desc.width) / f64::from(r.frame_desc.height.max(1));
    let (centre, radius) = translucent::mesh::bounding_sphere(&r.object.surface.positions);
    let base_camera = r
        .frame_desc
        .camera
        .unwrap_or_else(|| Camera::framing(centre, radius, aspect));
    object.set_camera(r.frame_desc.camera)?;
    if let Some(choice) = args.method_choice {
        object.set_method_choice(choice)?;
    }
    let mut method_choice = None;
    let supersample =
        crate::render::supersample_factor(args, r.frame_desc.width, r.frame_desc.height);
    let mut host = HeadlessHost::new(
        &ctx,
        r.frame_desc.width * supersample,
        r.frame_desc.height * supersample,
    )?;
    let mut frames = Vec::new();
    let mut timings = Vec::new();
    let mut last = None;
    let mut report_scene = r.scene.clone();
    for i in 0..args.frames {
        if i > 0 {
            if let Some(deg) = args.orbit_light {
                report_scene = Scene {
                    lights: crate::render::orbit_lights(&r.scene.lights, deg * f64::from(i)),
                    environment: r.scene.environment,
                };
                object.set_lights(&report_scene)?;
            }
            if let Some(deg) = args.orbit_camera {
                object.set_camera(Some(crate::render::orbit_camera(
                    base_camera,
                    deg * f64::from(i),
                )))?;
            }
        }
        let (captured, report) = host.render(&ctx, &mut object)?;
        method_choice = report.method_choice;
        let skipped: serde_json::Map<String, serde_json::Value> = report
            .skipped
            .iter()
            .map(|(pass, why)| (pass.to_string(), why.to_string().into()))
            .collect();
        frames.push(serde_json::json!({
            "frame": captured.frame,
            "passes": captured.passes,
            "skipped": skipped,
            "material_variant": report.material_variant,
        }));
        timings.extend(captured.timings.clone());
        last = Some(captured);
    }
    let gpu_bytes = object.gpu_bytes();
    drop(host);
    drop(object);
    if let Some(path) = &args.trace {
        crate::render::write_trace(path, &FrameTimings::chrome_trace(&timings).to_string())?;
    }
    let last = last.context("no frame rendered")?;
    crate::render::write_output(args, &last.image, supersample, r.started)?;

    // Energy on the CPU, in f64 (render mode with shadow rays against the display mesh, whose
    // triangle centroids lie inside a procedural shape's own solid): sum E A and sum M A over the
    // triangles, the dipole's counterpart of the QuadGraph's balance.
    let start = Instant::now();
    let occluder = MeshSolid::new(r.object.surface.clone())?;
    let irradiance = dipole::irradiance::leaf_irradiance(
        &tree,
        &report_scene,
        material.base.eta,
        Some(&occluder),
    )?;
    let exitance = dipole::links::render(&tree, &material.profile, &links, &irradiance, None);
    let energy_s = start.elapsed().as_secs_f64();
    let (mut input, mut output) = ([0.0f64; 3], [0.0f64; 3]);
    for (f, g) in tree.geometry[..tree.leaf_count()].iter().enumerate() {
        for c in 0..3 {
            input[c] += irradiance[f][c] * g.area;
            output[c] += exitance.leaf[f][c] * g.area;
        }
    }

    if args.profile && !args.json {
        println!(
            "hierarchy {hierarchy_s:9.3} s ({}), {} links ({:.1} per triangle) in {link_s:.3} s",
            match outcome {
                cache::CacheOutcome::Loaded => "cache",
                _ => "built",
            },
            link_count,
            link_count as f64 / tree.leaf_count() as f64
        );
        if last.passes.is_empty() {
            println!("no GPU timestamps on this device");
        }
        for (pass, ms) in &last.passes {
            println!("{pass:<18} {ms:9.3} ms");
        }
    }
    if args.json {
        let out = serde_json::json!({
            "device": ctx.info().device_name,
            "output": args.out.display().to_string(),
            "width": r.frame_desc.width,
            "exit_lobe": r.frame_desc.exit_lobe.name(),
            "height": r.frame_desc.height,
            "method": "dipole",
            "method_choice": crate::render::choice_json(method_choice),
            "view": r.object.view_json(),
            "solver": "gpu",
            "hierarchy": {
                "triangles": hierarchy_stats.triangles,
                "nodes": hierarchy_stats.nodes,
                "depth": tree.depth(),
                "cache": match outcome {
                    cache::CacheOutcome::Loaded => "loaded",
                    cache::CacheOutcome::Built => "built",
                    cache::CacheOutcome::Rebuilt(_) => "rebuilt",
                },
            },
            "links": {
                "count": link_count,
                "per_triangle": link_count as f64 / tree.leaf_count() as f64,
            },
            "material_variant": if material.modulation.is_some() { "texture only" } else { "homogeneous" },
            "frames": frames,
            "gpu_bytes": gpu_bytes,
            "energy": {
                "transmitted_input": input,
                "exitance": output,
                "absorbed": serde_json::Value::Null,
            },
            "cpu_seconds": {
                "hierarchy": hierarchy_s,
                "links": link_s,
                "object": create_s,
                "energy": energy_s,
            },
            "cache": cache_file.display().to_string(),
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
