//! The measured runs: bakes through the cache, and the GPU frame of a configuration timed through
//! the object and the headless host (the frame the object ships).

use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::Instant;

use anyhow::{bail, Context as _};
use indicatif::ProgressBar;
use translucent::defaults::{Schedule, Settings};
use translucent::headless::{ExitanceMesh, FrameDesc, HeadlessHost, HeadlessRenderer};
use translucent::material::MaterialField;
use translucent::scene::{self};
use translucent::solver::gpu::{GpuSolveParams, PASS_EXITANCE, PASS_SOLVE};
use translucent::solver::multigrid::MultigridParams;
use translucent::solver::transport::Source;
use translucent::solver::{self, CpuSolution, CpuSolveParams};
use translucent::vk::{Access, Context, ImageReadback, LinearImage};
use translucent::{ObjectParams, QuadGraph, TranslucentObject};

use super::*;

/// Scopes the headless frame's profiler holds (`HeadlessRenderer`: 4096 queries, 2 per scope).
pub(super) const FRAME_SCOPES: u64 = 2048;
/// Iterations per convergence block (`GpuSolveParams::default().block`): one profiler scope for
/// the block's sweeps and one for its reduction.
pub(super) const BLOCK: u32 = 8;

/// Per-node RGB values (q, J+).
type Rgb = [f64; 3];

/// Runs every configuration on one bake: the exact rows first, then the GPU frames.
#[allow(clippy::too_many_arguments)]
pub(super) fn bench_bake(
    ctx: &Context,
    baked: &Baked,
    field: &MaterialField,
    scene: &scene::Scene,
    previous: &[scene::Scene],
    solid: &dyn translucent::mesh::Solid,
    frame_desc: &FrameDesc,
    sweep: &Sweep,
    configs: &[Config],
    closed_form: Option<[f64; 3]>,
    reference: Option<&Reference>,
    repeats: u32,
    progress: &ProgressBar,
    emit: &mut dyn FnMut(Row),
) -> anyhow::Result<()> {
    let graph = Arc::new(baked.graph.clone());
    let finest = graph.finest();
    let bake_name = format!("K{} L{} r{}", baked.k, baked.levels, baked.resolution);
    let base_row = |family_name: String| Row {
        family_name,
        k: baked.k,
        levels: baked.levels,
        resolution: baked.resolution,
        finest_nodes: finest.node_count(),
        finest_surface_nodes: finest.surface_count(),
        ..Row::empty()
    };

    let mut exact: BTreeMap<&'static str, CpuSolution> = BTreeMap::new();
    for &scheme in &sweep.schemes {
        let name = scheme_name(scheme);
        progress.set_message(format!("{bake_name} {name}: exact solve (CPU)"));
        let start = Instant::now();
        let solution = solver::solve(
            &graph,
            field,
            scene,
            Some(solid),
            &CpuSolveParams {
                scheme,
                iterations: vec![0],
                exact: true,
                ..CpuSolveParams::default()
            },
        )
        .with_context(|| format!("{bake_name} {name}: the exact solve"))?;
        let cpu_s = start.elapsed().as_secs_f64();
        let exact_j = &solution.j_plus_clamped;
        let mut row = base_row(format!("{bake_name} {name} exact"));
        row.solver = "exact";
        row.scheme = name;
        row.cpu_s = Some(cpu_s);
        // No Jacobi: PCG (fv) or BiCGSTAB (paper) on the finest level; its iteration count is
        // not comparable, so the column stays empty.
        // Through the same metric as the GPU rows: 0 here, unless the metric is broken.
        row.discrete = rel_rms(exact_j.iter().copied().zip(exact_j.iter().copied()));
        row.solver_error = row.discrete;
        row.closed_form = closed_form.map(|cf| analytic_error(exact_j, &solution.q, &cf));
        if let Some(reference) = reference {
            let shown = ExitanceMesh {
                mesh: graph.surface.clone(),
                exitance: solution.vertex_j_plus.clone(),
                eta: field.eta(),
            };
            let captured =
                HeadlessRenderer::new(ctx, &shown, scene, frame_desc)?.render_frame(ctx)?;
            row.image = Some(reference.error(&captured.image));
        }
        emit(row);
        exact.insert(name, solution);
        progress.inc(1);
    }

    // Per scheme: the first gathered q and its exact J+.
    let mut same_q: BTreeMap<&'static str, (Vec<Rgb>, Vec<Rgb>)> = BTreeMap::new();
    for config in configs {
        let scheme = scheme_name(config.scheme);
        let family_name = format!(
            "{bake_name} {scheme} {} {}{}{}{}",
            precision_name(config.precision),
            if config.warm { "warm" } else { "cold" },
            if config.multigrid { " multigrid" } else { "" },
            if config.bounce == translucent::frame::BounceMode::Off {
                String::new()
            } else {
                format!(" bounce {}", config.bounce.name())
            },
            if config.exit_lobe == translucent::defaults::EXIT_LOBE {
                String::new()
            } else {
                format!(" lobe {}", config.exit_lobe.name())
            }
        );
        progress.set_message(format!(
            "{family_name} cap {} tol {}",
            config.cap, config.tolerance
        ));
        let solution = &exact[scheme];
        let run = run_gpu(
            ctx, &graph, field, scene, previous, frame_desc, config, repeats,
        )
        .with_context(|| format!("{family_name} cap {} tol {}", config.cap, config.tolerance))?;
        if sweep.warm_probe && config.warm && !run.previous_q.is_empty() {
            let mut qs = run.previous_q.clone();
            qs.push(run.q.clone());
            println!("{family_name} tol {}:", config.tolerance);
            super::warm_probe::probe(
                &graph,
                field,
                config.scheme,
                &config.cycle,
                f64::from(config.tolerance),
                &qs,
            )?;
        }
        let j_plus: Vec<[f64; 3]> = run.j_plus.iter().map(|j| j.map(f64::from)).collect();
        if j_plus.len() != solution.j_plus_clamped.len() {
            bail!(
                "{family_name}: the GPU returned {} surface nodes, the graph has {}",
                j_plus.len(),
                solution.j_plus_clamped.len()
            );
        }
        if let Some(n) = j_plus.iter().position(|j| j.iter().any(|v| !v.is_finite())) {
            bail!(
                "{family_name}: J+ at surface node {n} is not finite ({:?})",
                j_plus[n]
            );
        }
        // The exact solution for the q the GPU gathered: the same for the configurations of
        // this bake and scheme with the same lights, shadow maps and exposure; a warm object
        // keeps the exposure of the first frame of its light path, so its fp16 q rounds
        // differently (a 6e-5 difference on the default scene): solved again for its own q.
        let cached = same_q.get(scheme).is_some_and(|(q, _)| *q == run.q);
        let own;
        let exact_j = if cached {
            &same_q[scheme].1
        } else {
            let j = exact_for_q(&graph, field, config.scheme, &run.q, &solution.phi)
                .with_context(|| format!("{family_name}: the exact solve for the gathered q"))?;
            if same_q.contains_key(scheme) {
                own = j;
                &own
            } else {
                &same_q.entry(scheme).or_insert((run.q.clone(), j)).1
            }
        };
        let mut row = base_row(family_name);
        row.solver_error = rel_rms(j_plus.iter().copied().zip(exact_j.iter().copied()));
        row.scheme = scheme;
        row.precision = Some(precision_name(config.precision));
        row.start = Some(if config.warm { "warm" } else { "cold" });
        row.schedule = Some(if config.multigrid {
            "multigrid"
        } else {
            "cascade"
        });
        row.bounce = Some(config.bounce.name());
        row.exit_lobe = Some(config.exit_lobe.name());
        row.iterations_cap = Some(config.cap);
        row.tolerance = Some(config.tolerance);
        row.node_updates = Some(match &run.multigrid {
            // Work units are node updates / finest nodes.
            Some(m) => (m.work_units * graph.finest().node_count() as f64).round() as u64,
            None => run
                .iterations
                .iter()
                .zip(&graph.levels)
                .map(|(&i, l)| u64::from(i) * l.node_count() as u64)
                .sum(),
        });
        row.iterations = run.iterations;
        row.solve_gpu_ms = Some(run.solve_ms);
        row.frame_gpu_ms = Some(run.frame_ms);
        row.gpu_bytes = Some(run.bytes.0);
        row.bytes_per_node = Some(run.bytes.1);
        row.discrete = rel_rms(
            j_plus
                .iter()
                .copied()
                .zip(solution.j_plus_clamped.iter().copied()),
        );
        row.closed_form = closed_form.map(|cf| analytic_error(&j_plus, &solution.q, &cf));
        row.image = reference.map(|r| r.error(&run.image));
        emit(row);
        progress.inc(1);
    }
    Ok(())
}

pub(super) struct GpuRun {
    /// q per finest surface node as the frame gathered it (unscaled).
    pub(super) q: Vec<[f64; 3]>,
    /// Warm: the q of the untimed frames before the last timed one, oldest first.
    pub(super) previous_q: Vec<Vec<[f64; 3]>>,
    pub(super) iterations: Vec<u32>,
    /// The multigrid schedule's last solve.
    pub(super) multigrid: Option<translucent::solver::gpu::multigrid::GpuMultigridReport>,
    pub(super) solve_ms: f64,
    pub(super) frame_ms: f64,
    pub(super) bytes: (u64, f64),
    pub(super) j_plus: Vec<[f32; 3]>,
    pub(super) image: LinearImage,
}

/// One configuration through the frame the object ships ([`TranslucentObject`] recorded by a
/// headless host): a warm-up frame, then `repeats` timed frames of `scene`. Cold: skipping off,
/// so every frame solves from scratch. Warm: each timed frame follows untimed ones with the
/// `previous` lights (oldest first, a few degrees apart), so every timed solve starts from the
/// solutions of a light moving steadily towards `scene`'s, as in a host whose light moves (and
/// the warm start's extrapolation through the last solutions sees that motion).
#[allow(clippy::too_many_arguments)]
pub(super) fn run_gpu(
    ctx: &Context,
    graph: &Arc<QuadGraph>,
    field: &MaterialField,
    scene: &scene::Scene,
    previous: &[scene::Scene],
    frame_desc: &FrameDesc,
    config: &Config,
    repeats: u32,
) -> anyhow::Result<GpuRun> {
    let params = object_params(config, field, frame_desc);
    let first = match previous.first() {
        Some(oldest) if config.warm => oldest,
        _ => scene,
    };
    let mut object = TranslucentObject::new(ctx, graph.clone(), field, first, &params)?;
    object.set_camera(frame_desc.camera)?;
    let mut host = HeadlessHost::new(ctx, frame_desc.width, frame_desc.height)?;
    let (mut solve, mut whole) = (Vec::new(), Vec::new());
    let mut last = None;
    let mut previous_q = Vec::new();
    for i in 0..=repeats {
        if config.warm {
            previous_q.clear();
            for lights in previous {
                object.set_lights(lights)?;
                host.render(ctx, &mut object)?;
                previous_q.push(gathered_q(ctx, &object, graph)?);
            }
            object.set_lights(scene)?;
        }
        let (captured, report) = host.render(ctx, &mut object)?;
        if config.warm && i > 0 && !report.warm_start {
            bail!("a warm configuration's timed frame did not warm-start");
        }
        if i > 0 {
            let timings = captured
                .timings
                .as_ref()
                .context("no GPU timestamps on this device: bench measures GPU time")?;
            // The capture copy is recorded last: if it is missing, the profiler ran out of
            // queries and the solve's time would be short.
            if !captured.passes.contains_key("capture") {
                bail!("the frame profiler ran out of timestamp queries (lower --iterations)");
            }
            let top = timings.scopes.iter().filter(|s| s.depth == 0);
            solve.push(
                top.clone()
                    .filter(|s| s.name == PASS_SOLVE || s.name == PASS_EXITANCE)
                    .map(|s| s.duration_ms)
                    .sum(),
            );
            whole.push(
                top.filter(|s| s.name != "capture")
                    .map(|s| s.duration_ms)
                    .sum(),
            );
        }
        last = Some(captured);
    }
    let last = last.context("no frame rendered")?;
    let method = object
        .quadgraph()
        .context("the QuadGraph method reports the solve")?;
    let q = gathered_q(ctx, &object, graph)?;
    Ok(GpuRun {
        q,
        previous_q,
        iterations: method.solve().iterations_run(ctx)?,
        multigrid: method.solve().multigrid_report(ctx)?,
        solve_ms: median(solve),
        frame_ms: median(whole),
        bytes: method.solve().bytes(),
        j_plus: method.solve().read_j_plus(ctx)?,
        image: last.image,
    })
}

/// q per finest surface node as the object's last frame gathered it (unscaled).
fn gathered_q(
    ctx: &Context,
    object: &TranslucentObject,
    graph: &QuadGraph,
) -> anyhow::Result<Vec<[f64; 3]>> {
    let method = object
        .quadgraph()
        .context("the QuadGraph method reports the solve")?;
    let level = graph.finest();
    let finest = graph.levels.len() - 1;
    let gathered = ImageReadback::capture(
        ctx,
        method.solve().q_image(finest).context("no q image")?,
        Access::ComputeReadWrite,
    )?;
    let unscale = 1.0 / f64::from(method.q_scale());
    Ok(level.packing.texels[level.inner_count()..]
        .iter()
        .map(|&[u, v]| {
            let p = gathered.pixel(u, v);
            [p[0], p[1], p[2]].map(|x| f64::from(x) * unscale)
        })
        .collect())
}

/// The settings one configuration of the sweep runs: the library's real-time defaults for
/// `field` ([`Settings::for_material`], as `render` and `view` start from) with the swept
/// options, and deliberate pins for comparability: the boundary-flux source (errors (a) and
/// (b) compare J+ with the exact discrete solution and the closed form of the boundary-flux
/// system), no single scattering and no bounce (not part of the solve the bench measures), and
/// the material's own diffusion coefficient (classical: what the exact solution and the closed
/// form use; render's QuadGraph default is Grosjean's).
pub(crate) fn sweep_settings(config: &Config, field: &MaterialField) -> Settings {
    let mut settings = Settings::for_material(field).with_source(Source::BoundaryFlux);
    settings.schedule = if config.multigrid {
        Schedule::Multigrid
    } else {
        Schedule::Cascade
    };
    settings.scheme = config.scheme;
    settings.precision = config.precision;
    settings.cascade_iterations = config.cap;
    // The sweep keeps tolerances as f32 (the GPU's): read back as the decimal the user typed.
    settings.tolerance = translucent::defaults::f32_decimal(config.tolerance);
    settings.heterogeneous_weights = config.weights;
    settings.single_scattering = None;
    // `--bounce`, default off (pinned for comparability; after the solve, so the errors against
    // the exact solution read the same J+ either way).
    settings.bounce = config.bounce;
    // Pinned: the exact solution and the closed form are the material's own D (classical
    // unless the material says otherwise), not the QuadGraph's real-time default.
    settings.diffusion = field.diffusion();
    settings
}

/// The object's parameters for one configuration ([`sweep_settings`]; skipping only for warm
/// starts).
pub(crate) fn object_params(
    config: &Config,
    field: &MaterialField,
    frame_desc: &FrameDesc,
) -> ObjectParams {
    let settings = sweep_settings(config, field);
    let solve = settings.solve_params();
    ObjectParams {
        solve: GpuSolveParams {
            block: BLOCK,
            // The cycle of `--multigrid-cycle` over the library's, at the swept tolerance.
            multigrid: solve.multigrid.as_ref().map(|m| MultigridParams {
                tolerance: m.tolerance,
                ..config.cycle.clone()
            }),
            ..solve
        },
        specular: frame_desc.specular,
        roughness: frame_desc.roughness,
        radiance: frame_desc.radiance,
        exit_lobe: config.exit_lobe,
        skip: config.warm,
        ..settings.object_params()
    }
}
