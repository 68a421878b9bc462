//! `translucent render`: bakes (or loads from the cache) the QuadGraph of a mesh or shape, solves the
//! diffusion problem for the lights and the material, shades the display mesh with the result
//! headless and writes PNG or EXR (DESIGN section 8).
//!
//! ```text
//! translucent render --out marble.png --profile
//! translucent render --shape torus --material skimmilk --light dir:0,-1,0:4,4,4 --out t.exr --json
//! translucent render --shape torus --frames 8 --orbit-light 5 --json --out t.png
//! ```
//!
//! The GPU path renders through [`TranslucentObject`] exactly as a host would (one command buffer
//! per frame from a minimal headless host): `--frames N` shows the skips of DESIGN section 5
//! (frames after the first run no shadow, gather or solve unless `--orbit-light` moves the lights),
//! and `--json` lists per frame the passes run, the iterations and the skipped passes with reasons.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{bail, Context as _};
use std::sync::Arc;
use translucent::quadgraph::cache::CacheOutcome;
use translucent::scene;

use glam::{DQuat, DVec3};
use translucent::headless::{ExitanceMesh, FrameDesc, HeadlessHost, HeadlessRenderer};
use translucent::scene::Camera;
use translucent::scene::Environment;
use translucent::scene::Light;
use translucent::solver::gpu::GpuSolveParams;
use translucent::solver::multigrid::MultigridParams;
use translucent::solver::{self, CpuSolveParams, Schedule, Scheme};
use translucent::vk::{Context, ContextDesc, FrameTimings};
use translucent::{ObjectParams, TranslucentObject};

mod args;
mod checks;
mod defaults;
pub mod dipole;
mod graph_file;
mod output;
pub mod voxel;

pub use args::RenderArgs;
pub use defaults::{choice_json, resolve_auto, schedule_of, DEFAULT_SOURCE};
pub use graph_file::{load_graph_file, GraphFileError};
use output::{gpu_bytes_json, gpu_multigrid_json, profile_in_order};
pub(crate) use output::{supersample_factor, write_output, write_trace};

/// The default scene: a torus of skim milk, back lit (see `scene_args::default_lights`), so the
/// light passing through its tube shows.
const DEFAULT_SHAPE: &str = "torus";
pub(crate) const DEFAULT_MATERIAL: &str = "skimmilk";

/// Where baked QuadGraphs are cached without `--cache-dir` (shared by `render` and `bench`).
pub(crate) fn default_cache_dir() -> PathBuf {
    let env = |k: &str| {
        std::env::var_os(k)
            .filter(|v| !v.is_empty())
            .map(PathBuf::from)
    };
    env("TRANSLUCENT_CACHE_DIR")
        .or_else(|| env("XDG_CACHE_HOME").map(|d| d.join("translucent")))
        .or_else(|| env("HOME").map(|d| d.join(".cache").join("translucent")))
        .unwrap_or_else(|| std::env::temp_dir().join("translucent-cache"))
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

pub fn run(args: &RenderArgs) -> anyhow::Result<()> {
    checks::output(args)?;
    let started = Instant::now();
    if args.frames == 0 {
        bail!("--frames 0: must render at least one frame");
    }
    if let Some(path) = &args.graph {
        let why = match args.method.as_str() {
            "voxel" => "builds its voxel grid every frame",
            "dipole" => "links the surface's triangles",
            "auto" => "may pick another method: name quadgraph",
            _ => "",
        };
        if !why.is_empty() {
            return Err(GraphFileError::Method {
                path: path.clone(),
                method: args.method.clone(),
                why,
            }
            .into());
        }
    }
    if args.method == "auto" {
        return run(&resolve_auto(args)?);
    }
    let diffusion = checks::method_options(args)?;
    match args.method.as_str() {
        "quadgraph" | "dipole" => {}
        "voxel" => return crate::render::voxel::run(args),
        other => bail!("--method {other}: unknown (quadgraph, voxel, dipole)"),
    }
    let on_gpu = args.solver == "gpu";
    checks::solver_options(args, on_gpu)?;
    let schedule = schedule_of(args);
    let multigrid = schedule == "multigrid";
    let coarse_gpu = checks::coarse_params(args, MultigridParams::gpu())?;
    let coarse_cpu = checks::coarse_params(args, MultigridParams::default())?;
    if !multigrid
        && (args.coarse_operator.is_some()
            || args.coarse_storage.is_some()
            || args.link_storage.is_some()
            || args.vector_storage.is_some()
            || args.finest_operator.is_some()
            || args.update_storage.is_some()
            || args.coarse_drop.is_some())
    {
        bail!("--coarse-operator, --coarse-storage, --link-storage, --vector-storage, --finest-operator, --update-storage and --coarse-drop shape the multigrid's storage: add --schedule multigrid");
    }
    if multigrid && on_gpu && args.precision.as_deref() == Some("fp16") {
        bail!("--schedule multigrid keeps phi in fp32: use --precision mixed or fp32 (or --schedule cascade)");
    }
    if multigrid && args.iterations.is_some() {
        bail!("--iterations sets the cascade's Jacobi iterations per level; --schedule multigrid stops at --tolerance");
    }
    if args.iterations == Some(0) {
        bail!("--iterations 0: give at least one iteration per level");
    }
    if args.solver != "gpu"
        && args
            .single_scattering
            .as_deref()
            .is_some_and(|v| v != "off")
    {
        // why: the CPU path shades the f64 solution through the fixed-exitance renderer, which
        // has no material for the march (the CPU reference's own is solver::single_scattering).
        eprintln!("note: --solver cpu renders without single scattering (GPU pass only)");
    }
    let mut frame_desc = args.scene.frame_desc()?;
    // The options are checked before the bake; the default lights follow the camera (below).
    args.scene.lights()?;
    let environment = match (&args.env_constant, &args.env) {
        (Some(text), _) => Environment::Constant(rgb("--env-constant", text)?),
        (None, Some(path)) => Environment::load_exr(path).context("--env")?,
        (None, None) => Environment::None,
    };
    let field = args
        .material
        .field(args.object.size_mm, DEFAULT_MATERIAL)?
        .with_diffusion(diffusion);

    // Bake, or load the cached bake of the same surface and parameters.
    let object = args.object.load(Some(DEFAULT_SHAPE))?;
    // Without --camera: the three-quarter view of the object's bounding sphere.
    if frame_desc.camera.is_none() {
        let aspect = f64::from(frame_desc.width) / f64::from(frame_desc.height.max(1));
        frame_desc.camera = Some(object.default_camera(aspect));
    }
    let object_view = object.view_json();
    if !args.json {
        eprintln!("{}", object.view_line());
    }
    // Without --light: the default lights placed relative to the camera (`--camera` or the
    // automatic framing), so a custom view is lit as the default one is.
    let lights = args
        .scene
        .lights_for(&frame_desc.camera.context("the camera is set above")?)?;
    // Anti-aliasing: the frames are rendered this many times larger per side.
    let supersample = supersample_factor(args, frame_desc.width, frame_desc.height);
    if args.method == "dipole" {
        let cache_dir = args.cache_dir.clone().unwrap_or_else(default_cache_dir);
        std::fs::create_dir_all(&cache_dir)
            .with_context(|| format!("creating the cache directory {}", cache_dir.display()))?;
        return crate::render::dipole::run(crate::render::dipole::DipoleRender {
            args,
            object,
            field,
            scene: scene::Scene {
                lights,
                environment,
            },
            frame_desc,
            cache_dir,
            started,
        });
    }
    // `--resolution auto`: from the material and the pixel footprint of the object for the
    // camera this render uses (the automatic framing when none is given).
    let footprint_camera = frame_desc.camera.context("the camera is set above")?;
    let start = Instant::now();
    let (mut graph, stats, outcome, cache_file, resolution, cache_key) = match &args.graph {
        // `--graph FILE`: the bake `translucent bake` wrote, with its own resolution.
        Some(path) => {
            let graph = load_graph_file(path, &object)?;
            let stats = graph.stats();
            let spacing_mm = stats.levels.last().map_or(0.0, |l| l.spacing_mm);
            let (lo, hi) = object.bounds();
            let resolution = crate::object_args::Resolution {
                cells: ((hi - lo).max_element() / spacing_mm.max(f64::MIN_POSITIVE)).round() as u32,
                spacing_mm,
                auto: None,
            };
            (
                graph,
                stats,
                CacheOutcome::Loaded,
                path.clone(),
                resolution,
                None,
            )
        }
        None => {
            let resolution = args.object.resolution(
                &object,
                &field,
                Some((&footprint_camera, frame_desc.height)),
            );
            let params = args.object.bake_params_for(&resolution, &field);
            // The bake cache with its size limit (least recently used bakes are evicted).
            let (graph, stats, outcome, cache_file) =
                crate::cache::bake(&object, &params, args.cache_dir.as_deref())?;
            let key = translucent::quadgraph::cache::cache_key(&object.surface, &params);
            (graph, stats, outcome, cache_file, resolution, Some(key))
        }
    };
    let bake_s = start.elapsed().as_secs_f64();
    let finest_nodes = stats
        .levels
        .last()
        .map_or(0, |l| l.surface_nodes + l.inner_nodes);
    if !args.json {
        eprintln!("{}", resolution.line(finest_nodes));
    }

    let scheme = if args.scheme == "paper" {
        Scheme::Paper
    } else {
        Scheme::Fv
    };
    // Solve on the CPU (f64 reference), or below on the GPU.
    let exit_query: solver::transport::ExitQuery =
        args.exit_query.as_deref().unwrap_or("flux").parse()?;
    let surface = args.surface_for(&field, &object.surface, resolution.spacing_mm)?;
    let source = args.light_source();
    let beams = source != solver::transport::Source::BoundaryFlux;
    let solve_params = CpuSolveParams {
        scheme,
        iterations: vec![args
            .iterations
            .unwrap_or(CpuSolveParams::default().iterations[0])],
        tolerance: args.tolerance,
        exact: args.iterations.is_none() && !multigrid,
        transport: solver::transport::Transport {
            surface,
            ..if beams {
                solver::transport::Transport {
                    source,
                    continuation: args.continuation(),
                    upstream_beam: args.upstream_beam(),
                    curved_particular: args.curved_particular(),
                    own_visibility: args.own_visibility(),
                    ..solver::transport::Transport::gpu_collimated()
                }
            } else {
                solver::transport::Transport {
                    exit: exit_query,
                    ..solver::transport::Transport::default()
                }
            }
        },
        schedule: if multigrid {
            Schedule::Multigrid(
                MultigridParams {
                    tolerance: args.tolerance,
                    ..coarse_cpu
                }
                .with_cycle_spec(args.multigrid_cycle.as_deref().unwrap_or(""))?,
            )
        } else {
            Schedule::Cascade
        },
        ..CpuSolveParams::default()
    };
    let solver_scene = scene::Scene {
        lights: lights.clone(),
        environment,
    };
    let start = Instant::now();
    let solution = if on_gpu {
        None
    } else {
        let bar = crate::progress::spinner();
        bar.set_message("solving on the CPU (the f64 reference)");
        let solved = solver::solve(
            &graph,
            &field,
            &solver_scene,
            Some(object.solid.as_ref()),
            &solve_params,
        );
        bar.finish_and_clear();
        Some(solved?)
    };
    let solve_s = start.elapsed().as_secs_f64();

    let ctx = Context::headless(&ContextDesc {
        echo_validation: true,
        ..ContextDesc::default()
    })?;
    // The library's real-time defaults, changed by the options given (`defaults.rs`).
    let mut settings = args.settings()?;
    settings.surface = surface;
    let base = settings.solve_params();
    let gpu_params = GpuSolveParams {
        shadow_edge_flux: args.shadow_edge_flux,
        continuation: args.continuation(),
        upstream_beam: args.upstream_beam(),
        curved_particular: args.curved_particular(),
        own_visibility: args.own_visibility(),
        // The multigrid's coarse operator and cycle as named (`--coarse-*`, `--multigrid-cycle`).
        multigrid: match base.multigrid.as_ref() {
            Some(m) => Some(
                MultigridParams {
                    tolerance: m.tolerance,
                    warm_start: m.warm_start,
                    ..coarse_gpu.clone()
                }
                .with_cycle_spec(args.multigrid_cycle.as_deref().unwrap_or(""))?,
            ),
            None => None,
        },
        ..base
    };
    // `--bounce local`: the links stored with the bake, or built now and stored with it (in the
    // bake cache; a `--graph FILE` is not rewritten), so the next render of this mesh casts no ray.
    let bounce_links = if on_gpu && settings.bounce != translucent::frame::BounceMode::Off {
        let params = translucent::frame::BounceParams {
            rays: args.bounce_rays,
            ..Default::default()
        };
        let store = cache_key.map(|key| (cache_file.as_path(), key));
        let (seconds, stored) = crate::cache::bounce_links(&mut graph, &params, store)?;
        Some((params, seconds, stored))
    } else {
        None
    };
    let graph = Arc::new(graph);
    let level_count = graph.levels.len();
    let mut frames = Vec::new();
    let mut timings = Vec::new();
    let mut last = None;
    let mut gpu_report = None;
    let mut gpu_bytes = None;
    let mut gpu_bytes_split = None;
    let mut last_gpu_multigrid = None;
    let mut report_scene = solver_scene.clone();
    let mut method_choice = None;
    let mut bounce_json = None;
    if on_gpu {
        let object_params = ObjectParams {
            solve: gpu_params.clone(),
            specular: frame_desc.specular,
            roughness: frame_desc.roughness,
            radiance: frame_desc.radiance,
            exit_lobe: frame_desc.exit_lobe,
            tangential_flux: match args.tangential_flux.as_deref() {
                Some(on) => on == "on",
                None => translucent::defaults::TANGENTIAL_FLUX,
            },
            skip: !args.no_skip,
            single_scattering: settings.single_scattering,
            bounce: settings.bounce,
            ..ObjectParams::default()
        };
        let mut translucent =
            TranslucentObject::new(&ctx, graph.clone(), &field, &solver_scene, &object_params)?;
        translucent.set_bounces(args.bounces)?;
        translucent.set_bounce_tolerance(args.bounce_tolerance)?;
        if let (Some((params, build_s, stored)), Some(links)) =
            (bounce_links, graph.bounce.as_ref())
        {
            // The object took the links from the graph (`ObjectParams::bounce`); a convex
            // object has none and records no pass.
            anyhow::ensure!(
                translucent.bounce().is_some() == (links.link_count() > 0),
                "the bounce pass was not set up"
            );
            let vertices = links.vertex_count().max(1);
            let how = if stored {
                "loaded with the bake"
            } else {
                "built"
            };
            if !args.json {
                eprintln!(
                    "bounce: {} links over {} display vertices ({:.1} bytes each), {how} in {build_s:.2} s",
                    links.link_count(),
                    links.vertex_count(),
                    links.bytes() as f64 / vertices as f64
                );
            }
            bounce_json = Some(serde_json::json!({
                "mode": settings.bounce.name(),
                "source_nodes": translucent
                    .method()
                    .as_any()
                    .downcast_ref::<translucent::frame::QuadGraphMethod>()
                    .and_then(|q| q.bounce_source())
                    .map(|s| s.covered()),
                "bounces": args.bounces,
                "tolerance": args.bounce_tolerance,
                "rays": params.rays,
                "max_links": params.max_links,
                "links": links.link_count(),
                "linked_vertices": (0..links.vertex_count()).filter(|&v| links.offsets[v + 1] > links.offsets[v]).count(),
                "display_vertices": links.vertex_count(),
                "bytes": links.bytes(),
                "bytes_per_vertex": links.bytes() as f64 / vertices as f64,
                "build_seconds": build_s,
                "stored": stored,
            }));
        }
        let aspect = f64::from(frame_desc.width) / f64::from(frame_desc.height.max(1));
        let (centre, radius) = graph.finest().bounding_sphere();
        let base_camera = frame_desc
            .camera
            .unwrap_or_else(|| Camera::framing(centre, radius, aspect));
        translucent.set_camera(frame_desc.camera)?;
        if let Some(choice) = args.method_choice {
            translucent.set_method_choice(choice)?;
        }
        let mut host = HeadlessHost::new(
            &ctx,
            frame_desc.width * supersample,
            frame_desc.height * supersample,
        )?;
        let bar = crate::progress::spinner();
        for i in 0..args.frames {
            bar.set_message(format!(
                "frame {i} of {}: {}",
                args.frames,
                if i == 0 {
                    "solving on the GPU and shading"
                } else {
                    "shading (solving only what changed)"
                }
            ));
            if i > 0 {
                if let Some(deg) = args.orbit_light {
                    report_scene = scene::Scene {
                        lights: orbit_lights(&solver_scene.lights, deg * f64::from(i)),
                        environment: solver_scene.environment,
                    };
                    translucent.set_lights(&report_scene)?;
                }
                if let Some(deg) = args.orbit_camera {
                    translucent.set_camera(Some(orbit_camera(base_camera, deg * f64::from(i))))?;
                }
            }
            let (captured, report) = host.render(&ctx, &mut translucent)?;
            method_choice = report.method_choice;
            // The host waited: this frame's own solve (if any) has completed.
            let solves = translucent.completed_solves(ctx.frames().1)?;
            let solve = solves.iter().find(|s| s.frame == captured.frame);
            let iterations = solve.map_or_else(|| vec![0; level_count], |s| s.iterations());
            // A level that ran to its cap did not reach --tolerance (optically thin objects need
            // many more Jacobi iterations than the default cap): say so rather than stay silent.
            let mut mg_report = match (multigrid, solve) {
                (true, Some(_)) => translucent
                    .quadgraph()
                    .context("the QuadGraph method reports the solve")?
                    .solve()
                    .multigrid_report(&ctx)?,
                _ => None,
            };
            // `--bounce source`: the solver's record is the second solve's; the frame's copies
            // hold both.
            let bounce_report = solve.and_then(|s| s.bounce.clone());
            if bounce_report.is_some() {
                mg_report = solve.and_then(|s| s.multigrid.clone());
            }
            // Measurement only: the cold start replayed stage by stage, every level's largest
            // magnitudes after each (benches/RESULTS.md "Large lattices: the fp16 update").
            if mg_report.is_some()
                && std::env::var("TRANSLUCENT_MULTIGRID_PROBE").as_deref() == Ok("1")
            {
                let solve = translucent
                    .quadgraph()
                    .context("the QuadGraph method reports the solve")?
                    .solve();
                for m in solve.multigrid_probe(&ctx)?.unwrap_or_default() {
                    eprintln!(
                        "probe {:<24} L{} x {:>10.3e} f {:>10.3e} r {:>10.3e} d {:>10.3e} non-finite {:?} d at {} diag {:?} paired {}",
                        m.stage, m.level, m.x, m.f, m.r, m.d, m.non_finite, m.d_node, m.d_node_diag, m.d_node_paired
                    );
                }
            }
            // A diverged (or non-finite) solve must not reach an image: fail before any output.
            for m in mg_report.iter().chain(&bounce_report) {
                let solve = translucent
                    .quadgraph()
                    .context("the QuadGraph method reports the solve")?
                    .solve();
                m.check(solve.level_count(), solve.node_count(0))
                    .with_context(|| format!("frame {i}"))?;
            }
            let converged = match &mg_report {
                Some(m) => Some(m.converged && bounce_report.as_ref().is_none_or(|b| b.converged)),
                None => solve.map(|s| s.converged()),
            };
            // The cascade's fp16 phi stops when its update rounds to zero: stalled, not converged.
            let stalled = match &mg_report {
                Some(_) => None,
                None => solve.map(|s| s.stalled()),
            };
            if let (Some(m), false) = (&mg_report, args.json) {
                for (what, m) in [
                    ("", Some(m)),
                    (" of the bounce solve", bounce_report.as_ref()),
                ] {
                    match m {
                        Some(m) if !m.converged => eprintln!(
                            "warning: frame {i}: the multigrid cycles{what} stopped at relative residual {:.1e} ({:?})",
                            m.residual, m.state
                        ),
                        _ => {}
                    }
                }
            } else if stalled == Some(true) && !args.json {
                eprintln!(
                    "warning: frame {i}: a level stalled (its fp16 update rounded to zero before --tolerance); use --precision mixed"
                );
            } else if converged == Some(false) && !args.json {
                eprintln!(
                    "warning: frame {i}: a level reached the iteration cap before --tolerance (iterations per level {iterations:?}); raise --iterations"
                );
            }
            let skipped: serde_json::Map<String, serde_json::Value> = report
                .skipped
                .iter()
                .map(|(pass, why)| (pass.to_string(), why.to_string().into()))
                .collect();
            frames.push(serde_json::json!({
                "frame": i,
                "passes": captured.passes,
                "iterations": iterations,
                "converged": converged,
                "skipped": skipped,
                "warm_start": report.warm_start,
                "material_variant": report.material_variant,
            }));
            // Only multigrid frames carry the key (a `null` in frames reads as NaN to the checks).
            if let (Some(m), Some(frame)) = (&mg_report, frames.last_mut()) {
                frame["multigrid"] = gpu_multigrid_json(m);
                if let Some(b) = &bounce_report {
                    // `--bounce source`'s second solve, and the frame's solve work in all.
                    frame["bounce_multigrid"] = gpu_multigrid_json(b);
                    frame["solve_work_units"] = (m.work_units + b.work_units).into();
                }
            }
            // Only cascade frames that solved carry `stalled` (likewise no `null`).
            if let (Some(stalled), Some(frame)) = (stalled, frames.last_mut()) {
                frame["stalled"] = stalled.into();
            }
            if mg_report.is_some() {
                last_gpu_multigrid = mg_report;
            }
            timings.extend(captured.timings.clone());
            last = Some(captured);
        }
        bar.finish_and_clear();
        let quadgraph = translucent
            .quadgraph()
            .context("the QuadGraph method reports the solve")?;
        gpu_report =
            Some(quadgraph.report(&ctx, &field, &report_scene, Some(object.solid.as_ref()))?);
        gpu_bytes = Some(translucent.gpu_bytes());
        let solve = quadgraph.solve();
        let finest_nodes = solve.node_count(solve.level_count() - 1);
        gpu_bytes_split = Some(gpu_bytes_json(
            &solve.bytes_breakdown(),
            &solve.multigrid_bytes_by_buffer(),
            finest_nodes,
        ));
        drop(host);
        drop(translucent);
    } else {
        let vertices = graph.surface.positions.len();
        let mesh = ExitanceMesh {
            mesh: graph.surface.clone(),
            exitance: solution
                .as_ref()
                .map_or_else(|| vec![[0.0; 3]; vertices], |s| s.vertex_j_plus.clone()),
            eta: field.eta(),
        };
        // The same frame as the GPU path's (shadow maps, shading with the environment's mirror
        // reflection), with the f64 solution as the given exitance.
        let supersampled = FrameDesc {
            width: frame_desc.width * supersample,
            height: frame_desc.height * supersample,
            ..frame_desc.clone()
        };
        let mut renderer = HeadlessRenderer::new(&ctx, &mesh, &solver_scene, &supersampled)?;
        if let Some(s) = &solution {
            renderer.set_diffused_share(&ctx, &s.vertex_diffused_share)?;
        }
        for i in 0..args.frames {
            let captured = renderer.render_frame(&ctx)?;
            let iterations: Vec<usize> = match (&solution, i) {
                (Some(s), 0) => s.levels.iter().map(|l| l.jacobi_iterations).collect(),
                _ => vec![0; level_count],
            };
            frames.push(serde_json::json!({
                "frame": i,
                "passes": captured.passes,
                "iterations": iterations,
            }));
            timings.extend(captured.timings.clone());
            last = Some(captured);
        }
    }
    if let Some(path) = &args.trace {
        write_trace(path, &FrameTimings::chrome_trace(&timings).to_string())?;
    }
    let last = last.context("no frame rendered")?;
    write_output(args, &last.image, supersample, started)?;

    // The last frame's GPU scopes in execution order (nested ones indented) and its total.
    let profile = last.timings.as_ref().map(profile_in_order);
    if args.profile && !args.json {
        println!(
            "bake {bake_s:9.3} s ({}), {}",
            match outcome {
                CacheOutcome::Loaded => "cache",
                _ => "baked",
            },
            match &gpu_report {
                Some(r) => match &last_gpu_multigrid {
                    Some(m) => format!(
                        "GPU multigrid solve ({}): {} cycles, {:.1} work units, residual {:.1e}",
                        if m.warm { "warm" } else { "cold" },
                        m.cycles.len(),
                        m.work_units,
                        m.residual
                    ),
                    None => format!("GPU solve, iterations per level {:?}", r.iterations),
                },
                None => match solution.as_ref().and_then(|s| s.multigrid.as_ref()) {
                    Some(m) => format!(
                        "CPU multigrid solve {solve_s:.3} s: {} cycles, {:.1} work units, residual {:.1e}",
                        m.cycles.len(),
                        m.work_units,
                        m.residual
                    ),
                    None => format!("CPU solve {solve_s:.3} s"),
                },
            }
        );
        match &profile {
            None => println!("no GPU timestamps on this device"),
            Some((scopes, total)) => {
                println!("GPU ms of the last frame (frame {}):", args.frames - 1);
                for (name, depth, ms) in scopes {
                    let indent = 2 + 2 * *depth as usize;
                    println!("{:indent$}{name:<w$} {ms:9.3}", "", w = 30 - indent);
                }
                println!("  {:<28} {total:9.3}", "total");
            }
        }
    }
    let (residual, energy, clamped) = match (&solution, &gpu_report) {
        (Some(s), _) => (s.residual, s.energy, s.clamped.map(|c| c as u64)),
        (None, Some(r)) => (r.residual, r.energy, r.clamped.map(u64::from)),
        (None, None) => bail!("no solve ran"),
    };
    if clamped.iter().any(|&c| c > 0) && !args.json {
        eprintln!(
            "note: J+ < 0 (the diffusion model's limit for strong absorbers) clamped to 0 at {clamped:?} surface nodes (R, G, B)"
        );
    }
    if args.json {
        let levels: Vec<_> = stats
            .levels
            .iter()
            .map(|l| {
                serde_json::json!({
                    "surface_nodes": l.surface_nodes,
                    "inner_nodes": l.inner_nodes,
                    "bytes": l.bytes,
                })
            })
            .collect();
        let out = serde_json::json!({
            "device": ctx.info().device_name,
            "output": args.out.display().to_string(),
            "width": frame_desc.width,
            "height": frame_desc.height,
            "method": args.method,
            "method_choice": choice_json(method_choice),
            "solver": args.solver,
            "scheme": args.scheme,
            "levels": levels,
            "resolution": resolution.json(Some(finest_nodes)),
            "view": object_view,
            "frames": frames,
            "exact_iterations": solution.as_ref().and_then(|s| s.exact.as_ref()).map(|e| e.iterations),
            "schedule": schedule,
            // The multigrid's coarse operator and the GPU's storage of its coarse entries.
            "coarse_operator": multigrid.then(|| format!("{:?}", coarse_gpu.coarse).to_lowercase()),
            "coarse_storage": multigrid.then(|| format!("{:?}", coarse_gpu.coarse_storage).to_lowercase()),
            "link_storage": multigrid.then(|| format!("{:?}", coarse_gpu.link_storage).to_lowercase()),
            "vector_storage": multigrid.then(|| format!("{:?}", coarse_gpu.vector_storage).to_lowercase()),
            // The finest level's operator (`--finest-operator`) and the fp16 vectors
            // (`--update-storage`), one object (the macro's recursion limit).
            "finest_storage": multigrid.then(|| serde_json::json!({
                "operator": format!("{:?}", coarse_gpu.finest_operator).to_lowercase(),
                "updates": format!("{:?}", coarse_gpu.update_storage).to_lowercase(),
            })),
            "coarse_drop": if multigrid { coarse_gpu.with_cycle_spec(args.multigrid_cycle.as_deref().unwrap_or(""))?.sparsify } else { None },
            // Where the lights' transmitted light enters (`--source`, resolved).
            // `--diffusion-coefficient`: which D the solve used.
            "diffusion_coefficient": field.diffusion().name(),
            "source": match source {
                solver::transport::Source::BoundaryFlux => "flux",
                solver::transport::Source::Collimated => "beam",
                solver::transport::Source::SecondCollision => "second",
            },
            "exit_lobe": frame_desc.exit_lobe.name(),
            // `--surface`, resolved (`auto` picks per material and spacing).
            "surface": match surface {
                solver::transport::SurfaceReconstruction::Interior => "interior",
                solver::transport::SurfaceReconstruction::Shepard => "shepard",
                solver::transport::SurfaceReconstruction::DepthSample => "depth-sample",
            },
            "multigrid": match &last_gpu_multigrid {
                Some(m) => Some(gpu_multigrid_json(m)),
                None => solution.as_ref().and_then(|s| s.multigrid.as_ref()).map(|m| serde_json::json!({
                "cycles": m.cycles.len(),
                "work_units": m.work_units,
                "matvec_units": m.matvec_units,
                "converged": m.converged,
                "residual": m.residual,
                "mean_factor": m.mean_factor,
                "factor_per_cycle": m.cycles.iter().map(|c| c.factor).collect::<Vec<_>>(),
                "residual_per_cycle": m.cycles.iter().map(|c| c.residual).collect::<Vec<_>>(),
                "coarse_iterations": m.coarse_iterations,
                "sweeps_per_level": m.sweeps,
            })),
            },
            "precision": on_gpu.then(|| format!("{:?}", gpu_params.precision).to_lowercase()),
            "gpu_bytes": gpu_bytes,
            "gpu_bytes_split": gpu_bytes_split,
            // `--bounce`: the links' size and bake time (its GPU ms are the pass `bounce`).
            "bounce": bounce_json,
            "residual": residual,
            "energy": {
                "transmitted_input": energy.transmitted_input,
                "exitance": energy.exitance,
                "absorbed": energy.absorbed,
            },
            "clamped_nodes": clamped,
            // A GPU solve has no CPU solve time (its GPU ms are in `frames` and `profile`).
            "cpu_seconds": { "bake": bake_s, "solve": (!on_gpu).then_some(solve_s) },
            "profile": args.profile.then(|| profile.as_ref().map(|(scopes, total)| serde_json::json!({
                "frame": args.frames - 1,
                "scopes": scopes.iter().map(|(n, d, ms)| serde_json::json!({"name": n, "depth": d, "ms": ms})).collect::<Vec<_>>(),
                "total_ms": total,
            }))),
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

/// `lights` rotated about +Y by `degrees` (directions and positions).
pub(crate) fn orbit_lights(lights: &[Light], degrees: f64) -> Vec<Light> {
    let q = DQuat::from_rotation_y(degrees.to_radians());
    lights.iter().map(|l| l.rotated(q)).collect()
}

/// `camera` with its eye rotated about the vertical line through its target.
pub(crate) fn orbit_camera(camera: Camera, degrees: f64) -> Camera {
    let q = DQuat::from_rotation_y(degrees.to_radians());
    let offset: DVec3 = camera.eye - camera.target;
    Camera {
        eye: camera.target + q * offset,
        ..camera
    }
}
