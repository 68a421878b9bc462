//! `translucent bench`: run time against error (issue 6). Sweeps solver and bake settings on one
//! scene, runs each configuration as the real GPU frame (shadow maps, irradiance gather, multi-level
//! Jacobi with the GPU's convergence test, shading) and measures, per configuration:
//! - GPU milliseconds from timestamp scopes: the solve (the `diffusion *` passes) and the whole
//!   frame (every top-level pass but the headless `capture` copy), the median of `--repeats`
//!   frames after one warm-up frame (lavapipe JIT-compiles a pipeline at its first dispatch);
//! - the Jacobi iterations run per level (the GPU's counter) and the GPU bytes of the solve;
//! - errors, each a relative RMS sqrt(sum (ours - ref)^2 / sum ref^2) per channel and over all:
//!   (a) J+ over the finest surface nodes against the exact discrete solution of the same graph
//!   and scheme (f64, PCG / BiCGSTAB to 1e-10, with ray-cast shadows: the GPU's shadow maps and
//!   fp16 q are part of what is measured);
//!   (b) J+ against the closed form, where one exists (a sphere shape, homogeneous material, only
//!   a constant environment: `solver::analytic`, DESIGN section 2);
//!   (c) the rendered image against `--reference FILE.exr` over the object's pixels (reference
//!   alpha >= 0.999, or non-black where it has no alpha: `tools/compare_exr.py`'s metric), rendered
//!   at the reference's size with `--camera`.
//!
//! Each bake (K x levels x resolution, through the bake cache) and scheme also gets one `exact`
//! row: the exact discrete solution through the same metrics (its error (a) is 0 by construction,
//! its (b) is the discretization error and its (c) the model + discretization floor no iteration
//! count can beat). Sweeps are the cross product of the lists; a *family* is one setting of
//! everything but `--iterations` and `--tolerance`, drawn in one colour. The Pareto front (no
//! configuration both faster and more accurate) is marked in the CSV and the plot.
//!
//! A warm start (`--start warm`) turns the lights about +Y in steps of `--warm-degrees` towards
//! the scene's own: [`WARM_PATH`] untimed frames at -3, -2 and -1 steps, then the timed frame
//! with the scene's lights, each frame starting from the previous ones' solutions (a light
//! moving steadily a few degrees per frame, which the warm start's extrapolation assumes); only
//! the frames with the scene's own lights are timed and measured, so cold and warm rows solve
//! the same problem.
//!
//! Outputs `DIR/bench.csv` and `DIR/bench.png` (`translucent_benches::plot`: log-log, decade
//! labels, x = solve GPU ms, y = error (a); a second panel with error (c), else (b), when there is
//! one, the exact rows' values (the floors) as grey lines; each family in its colour, named by the
//! CSV's `colour` column; the front in black), both written only after every configuration ran.
//! A progress bar on stderr, one summary line per configuration on stdout (or one JSON object
//! with `--json`), then the real-time and quality picks: the configurations with the fewest node
//! updates whose solver error (a') is within 1% and 0.1%.
//!
//! `--method quadgraph,voxel,dipole` (any subset, or `auto`) compares the methods instead, on the
//! path-traced references ([`methods`]: `methods.csv`, `methods.png`).
//!
//! ```text
//! translucent bench --shape sphere --material marble --resolution 16,24 --levels 1,3 \
//!     --iterations 16,64,256 --tolerance 0 --start cold,warm --out bench-out
//! translucent bench --suite heterogeneous --out benches/results/bench-heterogeneous
//! translucent bench --method quadgraph,voxel,dipole --scenes marble-sphere-dir --out m
//! ```

use std::path::PathBuf;

use anyhow::{bail, Context as _};
use clap::Parser as _;
use indicatif::{ProgressBar, ProgressStyle};
use translucent::material::MaterialField;
use translucent::quadgraph::cache::{self, CacheOutcome};
use translucent::scene::{self, Environment};
use translucent::solver::analytic::Homogeneous;
use translucent::vk::capture::write_atomically;
use translucent::vk::{Context, ContextDesc};
use translucent::QuadGraph;

use crate::material_args::MaterialArgs;
use crate::object_args::ObjectArgs;
use crate::scene_args::SceneArgs;

mod csv;
mod gpu;
mod methods;
mod metrics;
mod plot;
#[cfg(test)]
mod same_defaults;
mod suites;
mod sweep;
mod warm_probe;

use csv::*;
use gpu::*;
use metrics::*;
use plot::*;
use suites::*;
use sweep::*;

/// `--schedule`'s default: the library's ([`translucent::defaults::Settings::schedule`]; a unit
/// test keeps them equal, as clap's default is text).
const DEFAULT_SCHEDULE: &str = "multigrid";
/// Untimed frames before each timed warm frame, the lights turning one `--warm-degrees` step
/// each: enough earlier solutions for the quadratic warm start (`warm=quadratic`: three).
pub const WARM_PATH: u32 = 3;

/// What the sweep runs where it deliberately differs from `render`'s defaults (said in `--help`
/// and the README): the boundary-flux source and no single scattering, because errors (a) and
/// (b) compare J+ with the exact discrete solution and the closed form of the boundary-flux
/// system ([`gpu::sweep_settings`]); a fixed `--resolution` list (48), not `auto`, so bakes are
/// swept; one sample per pixel.
#[derive(clap::Args, Debug, Clone)]
pub struct BenchArgs {
    /// A fixed, documented sweep (heterogeneous, thin, scan, scan-reference, sphere-env,
    /// multilevel, schedules): it sets the scene and the lists; options given beside it override the suite's.
    #[arg(long, value_name = "NAME")]
    pub suite: Option<String>,
    /// OBJ file (validated, then normalized to --size-mm).
    #[arg(long, value_name = "FILE.obj", conflicts_with = "shape")]
    pub mesh: Option<PathBuf>,
    /// Procedural shape instead of a mesh: sphere, torus, box, capsule (default: torus).
    #[arg(long, value_name = "NAME")]
    pub shape: Option<String>,
    /// Longest side of the object in millimetres.
    #[arg(long, default_value_t = 50.0, allow_negative_numbers = true)]
    pub size_mm: f64,
    /// Grading K values to sweep (each is a bake, through the cache).
    #[arg(
        short = 'K',
        value_name = "K,..",
        default_value = "1",
        allow_hyphen_values = true
    )]
    pub k: String,
    /// Level counts to sweep (each is a bake).
    #[arg(
        long,
        value_name = "N,..",
        default_value = "3",
        allow_hyphen_values = true
    )]
    pub levels: String,
    /// Finest-level lattice resolutions to sweep (each is a bake).
    #[arg(
        long,
        value_name = "N,..",
        default_value = "48",
        allow_hyphen_values = true
    )]
    pub resolution: String,
    /// Relax inner node positions (for the `paper` scheme only).
    #[arg(long)]
    pub relax: bool,
    /// Accept meshes that fail validation as the solid their winding number describes.
    #[arg(long)]
    pub force: bool,
    #[command(flatten)]
    pub material: MaterialArgs,
    #[command(flatten)]
    pub scene: SceneArgs,
    /// Constant environment radiance R,G,B (with no other light: the sphere's closed form).
    #[arg(long, value_name = "R,G,B", conflicts_with = "env")]
    pub env_constant: Option<String>,
    /// Environment radiance from an equirectangular EXR, projected onto order-2 SH.
    #[arg(long, value_name = "FILE.exr")]
    pub env: Option<PathBuf>,
    /// Discretizations to sweep: fv, paper.
    #[arg(long, value_name = "S,..", default_value = "fv")]
    pub scheme: String,
    /// GPU state precisions to sweep: mixed, fp32, fp16.
    #[arg(long, value_name = "P,..", default_value = "mixed")]
    pub precision: String,
    /// Starts to sweep: cold (Shepard initialization every frame), warm (the last frame's
    /// solution, with the lights turned by --warm-degrees about +Y since that frame).
    #[arg(long, value_name = "cold,warm", default_value = "cold")]
    pub start: String,
    /// Heterogeneous materials on the cascade: `derived` (the default, weights computed in every
    /// sweep from per-node kappa and mu) or `stored` (three weight textures), as `render`'s
    /// option of the same name; one value for the whole sweep.
    #[arg(long, value_name = "derived|stored", default_value = "derived", value_parser = ["derived", "stored"])]
    pub heterogeneous_weights: String,
    /// Schedules to sweep (DESIGN 5.1): cascade (the paper's Jacobi per level, --iterations
    /// caps it), multigrid (full multigrid / V-cycles to the relative residual --tolerance; the
    /// default, the library's and `render`'s). The named suites pin `cascade` (all but
    /// `schedules`) so their rows stay comparable with the tables in benches/RESULTS.md. As with
    /// `render`, an option only the cascade has (`--iterations`, fp16 in `--precision`, paper in
    /// `--scheme`) makes the cascade the default.
    #[arg(long, value_name = "S,..")]
    pub schedule: Option<String>,
    /// One bounce between display vertices to sweep (`off,local`; DESIGN's `render --bounce`):
    /// default `off`, pinned for comparability (render's QuadGraph default is `local`). The
    /// bounce changes the displayed exitance only, so errors (a) and (b) (the surface nodes'
    /// J+) are the same for both; frame time and error (c) against `--reference` differ. The
    /// links are built once per bake and stored with it. `--exit-lobe` is a sweep axis as well
    /// (`lambert,p1,fitted`).
    #[arg(long, value_name = "off,local", default_value = "off")]
    pub bounce: String,
    /// The multigrid cycle's smoother and schedule over the defaults, as `render`'s option of the
    /// same name (`nu=3/3,cheb=0.1,fmg=2,..`); one value for the whole sweep.
    #[arg(long, value_name = "KEY=VALUE,..")]
    pub multigrid_cycle: Option<String>,
    /// Jacobi iteration caps per level to sweep (the cascade's; default the library's
    /// `defaults::CASCADE_ITERATIONS`, 2000).
    #[arg(long, value_name = "N,..", allow_hyphen_values = true)]
    pub iterations: Option<String>,
    /// Convergence tolerances to sweep (0: always run the cap). The library's and `render`'s
    /// default is 1e-4 (`defaults::TOLERANCE`); the bench sweeps around it.
    #[arg(
        long,
        value_name = "F,..",
        default_value = "1e-2,1e-3,1e-4",
        allow_hyphen_values = true
    )]
    pub tolerance: String,
    /// Timed frames per configuration (the median is reported), after one warm-up frame.
    #[arg(long, default_value_t = 3)]
    pub repeats: u32,
    /// How far the lights turned since the previous frame for `--start warm`, in degrees.
    #[arg(long, default_value_t = 5.0, allow_negative_numbers = true)]
    pub warm_degrees: f64,
    /// For each warm configuration, print where its start residual sits (share of the top
    /// nodes, of the nodes where q jumps) and the f64 cycle's work from it (`bench::warm_probe`).
    #[arg(long)]
    pub warm_probe: bool,
    /// A path-traced reference image (linear EXR, e.g. `tests/reference/pt/*.exr`): the frame is
    /// rendered at its size with `--camera` (required), and error (c) is measured against it.
    #[arg(long, value_name = "FILE.exr", requires = "camera")]
    pub reference: Option<PathBuf>,
    /// Output directory for bench.csv and bench.png.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Print one JSON object (the rows, the front, the picks) instead of the summary lines.
    #[arg(long)]
    pub json: bool,
    /// Only redraw `--out DIR`/bench.png from the bench.csv already there (nothing runs).
    #[arg(long)]
    pub replot: bool,
    /// Methods to compare (quadgraph, voxel, dipole, auto; any subset): instead of the QuadGraph
    /// sweep, runs each method at its `render` defaults on the path-traced references
    /// (tests/reference/pt) and writes methods.csv and methods.png (time against image error).
    #[arg(long, value_name = "M,..")]
    pub method: Option<String>,
    /// With --method: the reference scenes to run (default: all eight): skimmilk-sphere-dir,
    /// marble-sphere-dir, marble-sphere-backlit, marble-torus-backlit, split-sphere-dir,
    /// marble-sphere-env, bunny-marble-dir, bunny-marble-side.
    #[arg(long, value_name = "NAME,..", requires = "method")]
    pub scenes: Option<String>,
    /// Where baked QuadGraphs are cached (as for `render`).
    #[arg(long, value_name = "DIR")]
    pub cache_dir: Option<PathBuf>,
}

/// Bad bench options, each naming the option and the item.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    #[error("{option} {list:?}: {item:?} {problem}")]
    BadList {
        option: &'static str,
        list: String,
        item: String,
        problem: String,
    },
    #[error("--suite {name:?}: unknown (known: {known})")]
    UnknownSuite { name: String, known: String },
    #[error("--reference {path}: {problem}")]
    BadReference { path: PathBuf, problem: String },
    #[error("{option}: {problem}")]
    BadOption {
        option: &'static str,
        problem: String,
    },
}

pub fn run(args: &BenchArgs) -> anyhow::Result<()> {
    if let Some(methods) = &args.method {
        return methods::run(args, methods);
    }
    let Some(name) = &args.suite else {
        return run_sweep(args);
    };
    let mut argv = vec!["translucent bench".to_string()];
    argv.extend(suite_args(name)?);
    // The user's options (after `bench`), minus `--suite NAME`, override the suite's.
    let mut user = std::env::args().skip(2);
    while let Some(a) = user.next() {
        if a == "--suite" {
            user.next();
        } else if !a.starts_with("--suite=") {
            argv.push(a);
        }
    }
    let cli = SuiteCli::try_parse_from(&argv)
        .with_context(|| format!("--suite {name}: {}", argv[1..].join(" ")))?;
    run_sweep(&cli.args)
}

/// One bake of the sweep: its parameters and graph.
struct Baked {
    k: f64,
    levels: u32,
    resolution: u32,
    graph: QuadGraph,
}

/// The camera and lights a bench renders with, as `translucent render` chooses them: the
/// `--camera`, or the automatic three-quarter view of `object` (set in `frame_desc`); the
/// `--light` values, or the default lights placed relative to that camera
/// (`scene_args::default_lights_for`). The path-traced reference scenes give both.
fn view(
    scene: &SceneArgs,
    object: &crate::object_args::Object,
    frame_desc: &mut translucent::headless::FrameDesc,
) -> anyhow::Result<Vec<scene::Light>> {
    let aspect = f64::from(frame_desc.width) / f64::from(frame_desc.height.max(1));
    let camera = *frame_desc
        .camera
        .get_or_insert_with(|| object.default_camera(aspect));
    scene.lights_for(&camera)
}

fn run_sweep(args: &BenchArgs) -> anyhow::Result<()> {
    if args.replot {
        return replot(&args.out);
    }
    // Everything a user can get wrong is checked before any work (and nothing is written then).
    let sweep = Sweep::parse(args)?;
    if args.out.exists() && !args.out.is_dir() {
        return Err(BenchError::BadOption {
            option: "--out",
            problem: format!("{} exists and is not a directory", args.out.display()),
        }
        .into());
    }
    let configs = sweep.configs();
    // Checked before any work; the lights used are placed by `view` below.
    args.scene.lights()?;
    // The exit lobe is a sweep axis (`Config::exit_lobe`): the frame's is set per configuration.
    let mut frame_desc = crate::scene_args::SceneArgs {
        exit_lobe: translucent::defaults::EXIT_LOBE.name().to_string(),
        ..args.scene.clone()
    }
    .frame_desc()?;
    let environment = match (&args.env_constant, &args.env) {
        (Some(text), _) => Environment::Constant(rgb("--env-constant", text)?),
        (None, Some(path)) => Environment::load_exr(path).context("--env")?,
        (None, None) => Environment::None,
    };
    let field = args.material.field(args.size_mm, "skimmilk")?;
    let reference = args.reference.as_deref().map(Reference::load).transpose()?;
    if let Some(r) = &reference {
        frame_desc.width = r.width;
        frame_desc.height = r.height;
    }
    let object_args = ObjectArgs {
        mesh: args.mesh.clone(),
        shape: args.shape.clone(),
        size_mm: args.size_mm,
        k: sweep.k[0],
        levels: crate::object_args::LevelsArg::Count(sweep.levels[0]),
        resolution: crate::object_args::ResolutionArg::Cells(sweep.resolution[0]),
        relax: args.relax,
        up: "auto".into(),
        force: args.force,
    };
    let object = object_args.load(Some("torus"))?;
    // The render's view: without --camera its automatic three-quarter view, without --light its
    // default lights placed relative to the camera (the given one or the automatic one).
    let lights = view(&args.scene, &object, &mut frame_desc)?;
    if !args.json {
        eprintln!("{}", object.view_line());
    }
    let scene = scene::Scene {
        lights: lights.clone(),
        environment,
    };
    scene.validate()?;
    // Oldest first: -WARM_PATH steps, ..., -1 step.
    let previous: Vec<scene::Scene> = (1..=WARM_PATH)
        .rev()
        .map(|k| scene::Scene {
            lights: turned(&lights, -f64::from(k) * args.warm_degrees),
            environment,
        })
        .collect();
    // (b): a sphere of radius size/2 of a homogeneous material lit only by a constant environment.
    let closed_form = match (&field, environment, args.mesh.is_none()) {
        (MaterialField::Homogeneous(m), Environment::Constant(_), true)
            if object.name == "shape-sphere" && lights.iter().all(dark) =>
        {
            let r = 0.5 * args.size_mm;
            Some(std::array::from_fn::<f64, 3, _>(|c| {
                let h = Homogeneous::channel(m, c);
                // J+ = albedo q / (1 - F_dr), uniform over the sphere.
                h.sphere_albedo(r) / (1.0 - h.f_dr)
            }))
        }
        _ => None,
    };

    let cache_dir = args
        .cache_dir
        .clone()
        .unwrap_or_else(crate::render::default_cache_dir);
    std::fs::create_dir_all(&cache_dir)
        .with_context(|| format!("creating the cache directory {}", cache_dir.display()))?;
    let ctx = Context::headless(&ContextDesc {
        echo_validation: true,
        ..ContextDesc::default()
    })?;

    let bakes = sweep.k.len() * sweep.levels.len() * sweep.resolution.len();
    let total = bakes * (sweep.schemes.len() + configs.len());
    let progress = ProgressBar::new(total as u64);
    progress.set_style(
        ProgressStyle::with_template("{elapsed:>5} [{bar:30}] {pos}/{len} {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    let say = |row: &Row| {
        if !args.json {
            progress.suspend(|| println!("{}", row.summary()));
        }
    };

    let mut rows: Vec<Row> = Vec::new();
    let mut families: Vec<String> = Vec::new();
    let mut family_of = |name: &str| -> usize {
        match families.iter().position(|f| f == name) {
            Some(i) => i,
            None => {
                families.push(name.to_string());
                families.len() - 1
            }
        }
    };
    for &k in &sweep.k {
        for &levels in &sweep.levels {
            for &resolution in &sweep.resolution {
                progress.set_message(format!(
                    "bake K {k} levels {levels} resolution {resolution}"
                ));
                let params = ObjectArgs {
                    k,
                    levels: crate::object_args::LevelsArg::Count(levels),
                    ..object_args.clone()
                }
                .bake_params(&crate::object_args::Resolution {
                    cells: resolution,
                    spacing_mm: 0.0,
                    auto: None,
                });
                let key = cache::cache_key(&object.surface, &params);
                let cache_file = cache_dir.join(format!("{}-{key:016x}.qgraph", object.name));
                let (mut graph, _, outcome) = cache::bake_cached(
                    &cache_file,
                    &object.surface,
                    object.solid.as_ref(),
                    &params,
                    &mut |_| {},
                )
                .with_context(|| format!("bake K {k} levels {levels} resolution {resolution}"))?;
                if let CacheOutcome::Rebuilt(reason) = &outcome {
                    progress.suspend(|| eprintln!("warning: {reason}; baked again"));
                }
                if configs
                    .iter()
                    .any(|c| c.bounce != translucent::frame::BounceMode::Off)
                {
                    progress.set_message(format!("bounce links, resolution {resolution}"));
                    crate::cache::bounce_links(
                        &mut graph,
                        &translucent::frame::BounceParams::default(),
                        Some((&cache_file, key)),
                    )?;
                }
                let baked = Baked {
                    k,
                    levels,
                    resolution,
                    graph,
                };
                bench_bake(
                    &ctx,
                    &baked,
                    &field,
                    &scene,
                    &previous,
                    object.solid.as_ref(),
                    &frame_desc,
                    &sweep,
                    &configs,
                    closed_form,
                    reference.as_ref(),
                    args.repeats,
                    &progress,
                    &mut |mut row: Row| {
                        let name = row.family_name.clone();
                        row.family = family_of(&name);
                        row.colour = colour_name(row.family);
                        say(&row);
                        rows.push(row);
                    },
                )?;
            }
        }
    }
    progress.finish_and_clear();
    let messages = ctx.take_validation_messages();
    drop(ctx);
    if !messages.is_empty() {
        bail!("{} validation message(s) (printed above)", messages.len());
    }

    mark_pareto(&mut rows);
    let picks = picks(&rows);
    std::fs::create_dir_all(&args.out).with_context(|| format!("--out {}", args.out.display()))?;
    let mut csv = String::from(CSV_HEADER);
    csv.push('\n');
    for row in &rows {
        csv.push_str(&row.csv());
        csv.push('\n');
    }
    let csv_path = args.out.join("bench.csv");
    write_atomically(&csv_path, |tmp| {
        std::fs::write(tmp, csv.as_bytes()).map_err(|e| e.to_string())
    })
    .with_context(|| format!("writing {}", csv_path.display()))?;
    let png_path = args.out.join("bench.png");
    write_atomically(&png_path, |tmp| plot(tmp, &rows).map_err(|e| e.to_string()))
        .with_context(|| format!("writing {}", png_path.display()))?;

    if args.json {
        let out = serde_json::json!({
            "suite": args.suite,
            "reference": reference.as_ref().map(|r| r.path.display().to_string()),
            "reference_mask": reference.as_ref().map(|r| r.mask_kind),
            "closed_form": closed_form.is_some(),
            "csv": csv_path.display().to_string(),
            "png": png_path.display().to_string(),
            "rows": rows,
            "realtime": picks.0,
            "quality": picks.1,
        });
        println!("{out}");
    } else {
        for (what, limit, pick) in [
            ("real-time", REALTIME, picks.0),
            ("quality", QUALITY, picks.1),
        ] {
            match pick {
                Some(i) => println!(
                    "{what}: the cheapest configuration (node updates) whose solver error is within {limit:.0e}: {}",
                    rows[i].summary()
                ),
                None => println!("{what}: no configuration's solver error came within {limit:.0e}"),
            }
        }
        println!("wrote {} and {}", csv_path.display(), png_path.display());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;
    use translucent::scene::Light;

    #[test]
    fn relative_rms_is_the_scale_error_and_none_for_a_black_channel() {
        let reference = [[1.0, 2.0, 0.0], [3.0, 1.0, 0.0]];
        let ours: Vec<[f64; 3]> = reference.iter().map(|r| [1.1 * r[0], r[1], 0.5]).collect();
        let e = rel_rms(ours.iter().copied().zip(reference.iter().copied()));
        assert!((e[0].expect("red") - 0.1).abs() < 1e-12);
        assert_eq!(e[1], Some(0.0));
        assert_eq!(e[2], None);
        let all = ((0.01 * 10.0 + 0.25 * 2.0) / 15.0f64).sqrt();
        assert!((e[3].expect("all") - all).abs() < 1e-12);
    }

    #[test]
    fn the_pareto_front_keeps_only_undominated_rows() {
        let row = |ms: f64, e: f64| Row {
            solve_gpu_ms: Some(ms),
            solver_error: [None, None, None, Some(e)],
            ..Row::empty()
        };
        let mut rows = vec![row(1.0, 0.1), row(2.0, 0.2), row(3.0, 0.01), row(3.0, 0.02)];
        mark_pareto(&mut rows);
        let front: Vec<bool> = rows.iter().map(|r| r.pareto_solver).collect();
        assert_eq!(front, [true, false, true, false]);
        assert_eq!(picks(&rows), (Some(2), None));
    }

    #[test]
    fn bad_lists_name_the_option_and_the_item() {
        let e = list("--levels", "1,,3", uint(1, 8)).expect_err("empty item");
        assert!(e.to_string().contains("--levels"), "{e}");
        let e = list("--iterations", "8,x", uint(1, 10)).expect_err("not a number");
        assert!(e.to_string().contains("\"x\""), "{e}");
        let e = list("-K", "-1", non_negative).expect_err("negative");
        assert!(e.to_string().contains(">= 0"), "{e}");
        assert_eq!(
            list("--levels", "1, 2,3", uint(1, 8)).expect("ok"),
            [1, 2, 3]
        );
    }

    /// Directions equal to rounding (rotations of normalised f64 vectors).
    const DIRECTION_TOL: f64 = 1e-9;
    /// The far camera's key light is turned by well over 30 degrees from the fixed one (a chord
    /// of 0.5 is 29 degrees).
    const TURNED_MIN: f64 = 0.5;

    fn sphere() -> crate::object_args::Object {
        ObjectArgs {
            mesh: None,
            shape: Some("sphere".into()),
            size_mm: 20.0,
            k: 1.0,
            levels: crate::object_args::LevelsArg::Count(1),
            resolution: crate::object_args::ResolutionArg::Cells(8),
            relax: false,
            up: "auto".into(),
            force: false,
        }
        .load(None)
        .expect("sphere")
    }

    fn bench_args(extra: &[&str]) -> BenchArgs {
        let mut argv = vec!["translucent bench", "--shape", "sphere", "--out", "x"];
        argv.extend(extra);
        SuiteCli::try_parse_from(&argv).expect("bench args").args
    }

    fn key_direction(lights: &[Light]) -> DVec3 {
        match lights[0] {
            Light::Directional { direction, .. } => direction,
            ref other => panic!("the default key light is directional, got {other:?}"),
        }
    }

    #[test]
    fn a_bench_camera_without_lights_gets_the_camera_relative_defaults() {
        let object = sphere();
        // From below, behind and to the left: the fixed defaults would light the far side.
        let args = bench_args(&["--camera=-36,-42,24:0,0,0:30"]);
        let mut frame_desc = args.scene.frame_desc().expect("frame");
        let camera = frame_desc.camera.expect("--camera given");
        let lights = view(&args.scene, &object, &mut frame_desc).expect("view");
        assert_eq!(frame_desc.camera, Some(camera), "the given camera is kept");
        let want = crate::scene_args::default_lights_for(&camera);
        assert_eq!(lights.len(), want.len());
        let to_eye = (camera.eye - camera.target).normalize();
        assert!(
            (key_direction(&lights) - key_direction(&want)).length() < DIRECTION_TOL,
            "{lights:?}"
        );
        // The key is a back light for this camera (travels towards its eye), turned far from
        // the fixed default key (what bench used before).
        assert!(key_direction(&lights).dot(to_eye) > 0.5);
        let fixed = key_direction(&crate::scene_args::default_lights());
        assert!(
            (key_direction(&lights) - fixed).length() > TURNED_MIN,
            "{lights:?}"
        );

        // Without --camera: the automatic view, lit by the defaults placed for it.
        let args = bench_args(&[]);
        let mut frame_desc = args.scene.frame_desc().expect("frame");
        let lights = view(&args.scene, &object, &mut frame_desc).expect("view");
        assert_eq!(frame_desc.camera, Some(object.default_camera(1.0)));
        let want = crate::scene_args::default_lights_for(&object.default_camera(1.0));
        assert!((key_direction(&lights) - key_direction(&want)).length() < DIRECTION_TOL);
    }

    #[test]
    fn the_reference_suites_keep_their_own_lights_and_camera() {
        for (name, _) in suites() {
            let mut argv = vec!["translucent bench".to_string()];
            argv.extend(suite_args(name).expect("suite"));
            argv.extend(["--out".into(), "x".into()]);
            let args = SuiteCli::try_parse_from(&argv).expect("suite").args;
            if args.reference.is_none() {
                continue;
            }
            // The camera and lights do not depend on the object when both are given.
            let object = sphere();
            let mut frame_desc = args.scene.frame_desc().expect("frame");
            let given = frame_desc.camera;
            let lights = view(&args.scene, &object, &mut frame_desc).expect("view");
            assert!(
                given.is_some(),
                "{name}: a reference scene gives its camera"
            );
            assert_eq!(frame_desc.camera, given, "{name}");
            assert_eq!(lights, args.scene.lights().expect("lights"), "{name}");
            assert!(!args.scene.lights.is_empty(), "{name}: gives its lights");
        }
    }

    #[test]
    fn every_suite_parses_and_turned_lights_keep_their_power() {
        for (name, _) in suites() {
            let mut argv = vec!["translucent bench".to_string()];
            argv.extend(suite_args(name).expect("suite"));
            argv.extend(["--out".into(), "x".into()]);
            let cli = SuiteCli::try_parse_from(&argv).unwrap_or_else(|e| panic!("{name}: {e}"));
            Sweep::parse(&cli.args).unwrap_or_else(|e| panic!("{name}: {e}"));
        }
        assert!(suite_args("nope").is_err());
        let l = turned(&["dir:0,-1,1:1,2,3".parse().expect("light")], 90.0);
        match l[0] {
            Light::Directional {
                direction,
                irradiance,
            } => {
                assert!(
                    (direction.normalize() - DVec3::new(1.0, -1.0, 0.0).normalize()).length()
                        < 1e-12
                );
                assert_eq!(irradiance, [1.0, 2.0, 3.0]);
            }
            _ => panic!("kind changed"),
        }
    }
}
