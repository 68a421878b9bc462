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
//! A warm start (`--start warm`) alternates the lights between `--warm-degrees` about +Y and
//! the scene's own every frame, each frame starting from the previous one's solution (a light
//! swinging a few degrees per frame); only the frames with the scene's own lights are timed and
//! measured, so cold and warm rows solve the same problem.
//!
//! Outputs `DIR/bench.csv` and `DIR/bench.png` (`translucent_benches::plot`: log-log, decade
//! labels, x = solve GPU ms, y = error (a); a second panel with error (c), else (b), when there is
//! one, the exact rows' values (the floors) as grey lines; each family in its colour, named by the
//! CSV's `colour` column; the front in black), both written only after every configuration ran.
//! A progress bar on stderr, one summary line per configuration on stdout (or one JSON object
//! with `--json`), then the real-time and quality picks: the configurations with the fewest node
//! updates whose solver error (a') is within 1% and 0.1%.
//!
//! ```text
//! translucent bench --shape sphere --material marble --resolution 16,24 --levels 1,3 \
//!     --iterations 16,64,256 --tolerance 0 --start cold,warm --out bench-out
//! translucent bench --suite heterogeneous --out benches/results/bench-heterogeneous
//! ```

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use anyhow::{bail, Context as _};
use clap::Parser as _;
use glam::DQuat;
use indicatif::{ProgressBar, ProgressStyle};
use translucent::material::MaterialField;
use translucent::quadgraph::cache::{self, CacheOutcome};
use translucent::headless::{ExitanceMesh, FrameDesc, HeadlessHost, HeadlessRenderer};
use translucent::scene::{self, Environment, Light};
use translucent::solver::analytic::Homogeneous;
use translucent::solver::gpu::{GpuSolveParams, Precision, PASS_EXITANCE, PASS_SOLVE};
use translucent::solver::krylov;
use translucent::solver::operator::LevelOperator;
use translucent::solver::{self, CpuSolution, CpuSolveParams, Scheme};
use translucent::vk::capture::write_atomically;
use translucent::vk::{Access, Context, ContextDesc, ImageReadback, LinearImage};
use translucent::{ObjectParams, QuadGraph, TranslucentObject};
use translucent_benches::plot::{error_vs_time, palette, palette_hex, Panel, Series};

use crate::material_args::MaterialArgs;
use crate::object_args::ObjectArgs;
use crate::scene_args::SceneArgs;

#[derive(clap::Args, Debug, Clone)]
pub struct BenchArgs {
    /// A fixed, documented sweep (heterogeneous, thin, scan, scan-reference, sphere-env,
    /// multilevel): it sets the scene and the lists; options given beside it override the suite's.
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
    /// Jacobi iteration caps per level to sweep.
    #[arg(
        long,
        value_name = "N,..",
        default_value = "2000",
        allow_hyphen_values = true
    )]
    pub iterations: String,
    /// Convergence tolerances to sweep (0: always run the cap).
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
    /// Where baked QuadGraphs are cached (as for `render`).
    #[arg(long, value_name = "DIR")]
    pub cache_dir: Option<PathBuf>,
}

/// Re-parses a suite's options followed by the user's (later ones win).
#[derive(clap::Parser, Debug)]
#[command(name = "translucent bench", args_override_self = true)]
struct SuiteCli {
    #[command(flatten)]
    args: BenchArgs,
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

/// The camera every path-traced reference in `tests/reference/pt` uses (its README).
const PT_CAMERA: &str = "0,20,60:0,0,0:30";

/// The suites: name, what it shows, its options. Paths are relative to the repository root;
/// meshes come from `$TRANSLUCENT_MESH_DIR` (default `../shared/meshes`).
#[rustfmt::skip]
const SUITES: [(&str, &str, &[&str]); 6] = [
    (
        "heterogeneous",
        "skim milk / skin1 split sphere (.vol), directional light, against its path-traced reference",
        &[
            "--shape", "sphere", "--size-mm", "20",
            "--volume", "tests/reference/pt/milk-skin-split.vol", "--eta", "1",
            "--light", "dir:0.5,-1,-0.5:4,4,4", "--camera", PT_CAMERA, "--width", "96",
            "--height", "96", "--no-specular",
            "--reference", "tests/reference/pt/split-sphere-dir-eta1.exr", "--resolution", "24,32",
            "--levels", "3", "-K", "1", "--iterations", "2000",
            "--tolerance", "1e-2,3e-3,1e-3,1e-4", "--precision", "mixed,fp32",
            "--start", "cold,warm", "--repeats", "2",
        ],
    ),
    (
        "thin",
        "cheburashka (thin ears), veined marble, back and fill light",
        &[
            "--mesh", "@MESHES/cheburashka.obj", "--size-mm", "50", "--material", "veined-marble",
            "--width", "128", "--height", "128", "--no-specular", "--resolution", "32",
            "--levels", "3", "-K", "0,1", "--iterations", "2000",
            "--tolerance", "1e-2,1e-3,1e-4", "--precision", "mixed,fp32,fp16",
            "--start", "cold", "--repeats", "2",
        ],
    ),
    (
        "scan",
        "Stanford bunny (a scan with holes), skim milk, back and fill light",
        &[
            "--mesh", "@MESHES/stanford-bunny.obj", "--size-mm", "50", "--material", "skimmilk",
            "--width", "128", "--height", "128", "--no-specular", "--resolution", "24",
            "--levels", "3", "-K", "1", "--iterations", "16,64,256,1024", "--tolerance", "0",
            "--scheme", "fv,paper", "--start", "cold,warm", "--repeats", "2",
        ],
    ),
    (
        "scan-reference",
        "Stanford bunny lit from the side through its thin ears, marble, against its path-traced reference",
        &[
            "--mesh", "@MESHES/stanford-bunny.obj", "--size-mm", "20", "--material", "marble",
            "--eta", "1", "--light", "dir:1,-0.2,0:5,5,5", "--camera", PT_CAMERA,
            "--width", "96", "--height", "96", "--no-specular",
            "--reference", "tests/reference/pt/bunny-marble-side-eta1.exr", "--resolution", "24,32",
            "--levels", "3", "-K", "1", "--iterations", "2000",
            "--tolerance", "1e-2,1e-3,1e-4", "--precision", "mixed", "--start", "cold,warm",
            "--repeats", "2",
        ],
    ),
    (
        "sphere-env",
        "marble sphere in a white environment (closed form), against its path-traced reference",
        &[
            "--shape", "sphere", "--size-mm", "20", "--material", "marble", "--eta", "1.3",
            "--env-constant", "1,1,1", "--light", "dir:0,-1,0:0,0,0", "--camera", PT_CAMERA,
            "--width", "96", "--height", "96",
            "--reference", "tests/reference/pt/marble-sphere-env-eta1.3.exr",
            "--resolution", "16,24,32", "--levels", "3", "-K", "1", "--iterations", "2000",
            "--tolerance", "1e-2,1e-3,1e-4", "--repeats", "2",
        ],
    ),
    (
        "multilevel",
        "paper Fig. 14: one level against three, skin1 sphere (gpu_solve's table)",
        &[
            "--shape", "sphere", "--size-mm", "20", "--material", "skin1",
            "--light", "dir:-0.3,-1,0.2:1,1,1", "--env-constant", "0.05,0.05,0.05", "--width", "96",
            "--height", "96", "--no-specular", "--resolution", "24", "--levels", "1,3", "-K", "1",
            "--iterations", "2000", "--tolerance", "3e-2,1e-2,3e-3,1e-3,3e-4,1e-4",
            "--repeats", "2",
        ],
    ),
];

/// Scopes the headless frame's profiler holds (`HeadlessRenderer`: 4096 queries, 2 per scope).
const FRAME_SCOPES: u64 = 2048;
/// Iterations per convergence block (`GpuSolveParams::default().block`): one profiler scope for
/// the block's sweeps and one for its reduction.
const BLOCK: u32 = 8;

/// One swept setting.
#[derive(Clone, Debug)]
struct Config {
    scheme: Scheme,
    precision: Precision,
    warm: bool,
    cap: u32,
    tolerance: f32,
}

/// The lists, parsed and checked before anything runs.
struct Sweep {
    k: Vec<f64>,
    levels: Vec<u32>,
    resolution: Vec<u32>,
    schemes: Vec<Scheme>,
    precisions: Vec<Precision>,
    starts: Vec<bool>,
    iterations: Vec<u32>,
    tolerances: Vec<f32>,
}

fn list<T>(
    option: &'static str,
    text: &str,
    parse: impl Fn(&str) -> Result<T, String>,
) -> Result<Vec<T>, BenchError> {
    let bad = |item: &str, problem: String| BenchError::BadList {
        option,
        list: text.to_string(),
        item: item.to_string(),
        problem,
    };
    let mut out = Vec::new();
    for item in text.split(',') {
        let item = item.trim();
        if item.is_empty() {
            return Err(bad(item, "is empty (a stray comma?)".into()));
        }
        out.push(parse(item).map_err(|p| bad(item, p))?);
    }
    Ok(out)
}

fn uint(min: u32, max: u32) -> impl Fn(&str) -> Result<u32, String> {
    move |s| {
        let v: u32 = s.parse().map_err(|_| "is not a whole number".to_string())?;
        if (min..=max).contains(&v) {
            Ok(v)
        } else {
            Err(format!("is outside {min}..={max}"))
        }
    }
}

fn non_negative(s: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|_| "is not a number".to_string())?;
    if v.is_finite() && v >= 0.0 {
        Ok(v)
    } else {
        Err("must be a finite number >= 0".into())
    }
}

impl Sweep {
    fn parse(args: &BenchArgs) -> Result<Sweep, BenchError> {
        let sweep = Sweep {
            k: list("-K", &args.k, non_negative)?,
            levels: list("--levels", &args.levels, uint(1, 8))?,
            resolution: list("--resolution", &args.resolution, uint(4, 512))?,
            schemes: list("--scheme", &args.scheme, |s| match s {
                "fv" => Ok(Scheme::Fv),
                "paper" => Ok(Scheme::Paper),
                _ => Err("is not a scheme (fv, paper)".into()),
            })?,
            precisions: list("--precision", &args.precision, |s| {
                s.parse::<Precision>()
                    .map_err(|_| "is not a precision (mixed, fp32, fp16)".to_string())
            })?,
            starts: list("--start", &args.start, |s| match s {
                "cold" => Ok(false),
                "warm" => Ok(true),
                _ => Err("is not a start (cold, warm)".into()),
            })?,
            iterations: list("--iterations", &args.iterations, uint(1, 1_000_000))?,
            tolerances: list("--tolerance", &args.tolerance, |s| {
                non_negative(s).map(|v| v as f32)
            })?,
        };
        // The headless frame's profiler must hold every scope of the largest frame, or the
        // timings would silently leave out the last blocks.
        let max_levels = u64::from(*sweep.levels.iter().max().unwrap_or(&1));
        for &cap in &sweep.iterations {
            let scopes = max_levels * (2 * u64::from(cap.div_ceil(BLOCK)) + 2) + 8;
            if scopes > FRAME_SCOPES {
                return Err(BenchError::BadList {
                    option: "--iterations",
                    list: args.iterations.clone(),
                    item: cap.to_string(),
                    problem: format!(
                        "needs {scopes} timestamp scopes per frame with {max_levels} levels; the \
                         headless frame profiler holds {FRAME_SCOPES} (cap at most {})",
                        (FRAME_SCOPES - 8) / max_levels / 2 * u64::from(BLOCK) - u64::from(BLOCK)
                    ),
                });
            }
        }
        if args.repeats == 0 {
            return Err(BenchError::BadOption {
                option: "--repeats",
                problem: "0: time at least one frame".into(),
            });
        }
        if !args.warm_degrees.is_finite() {
            return Err(BenchError::BadOption {
                option: "--warm-degrees",
                problem: format!("{} is not finite", args.warm_degrees),
            });
        }
        Ok(sweep)
    }

    fn configs(&self) -> Vec<Config> {
        let mut out = Vec::new();
        for &scheme in &self.schemes {
            for &precision in &self.precisions {
                for &warm in &self.starts {
                    for &tolerance in &self.tolerances {
                        for &cap in &self.iterations {
                            out.push(Config {
                                scheme,
                                precision,
                                warm,
                                cap,
                                tolerance,
                            });
                        }
                    }
                }
            }
        }
        out
    }
}

fn scheme_name(s: Scheme) -> &'static str {
    match s {
        Scheme::Fv => "fv",
        Scheme::Paper => "paper",
    }
}

fn precision_name(p: Precision) -> &'static str {
    match p {
        Precision::Mixed => "mixed",
        Precision::Fp32 => "fp32",
        Precision::Fp16 => "fp16",
    }
}

/// Relative RMS per channel and over all three; `None` where the reference is all zero.
type Errors = [Option<f64>; 4];

fn rel_rms(pairs: impl Iterator<Item = ([f64; 3], [f64; 3])>) -> Errors {
    let (mut d2, mut r2) = ([0.0f64; 3], [0.0f64; 3]);
    for (ours, reference) in pairs {
        for c in 0..3 {
            d2[c] += (ours[c] - reference[c]).powi(2);
            r2[c] += reference[c].powi(2);
        }
    }
    let ratio = |d: f64, r: f64| (r > 0.0).then(|| (d / r).sqrt());
    [
        ratio(d2[0], r2[0]),
        ratio(d2[1], r2[1]),
        ratio(d2[2], r2[2]),
        ratio(d2.iter().sum(), r2.iter().sum()),
    ]
}

/// A reference image and its object mask.
struct Reference {
    path: PathBuf,
    width: u32,
    height: u32,
    rgb: Vec<[f64; 3]>,
    mask: Vec<bool>,
    mask_kind: &'static str,
}

impl Reference {
    fn load(path: &Path) -> Result<Reference, BenchError> {
        let bad = |problem: String| BenchError::BadReference {
            path: path.to_path_buf(),
            problem,
        };
        let image = exr::prelude::read_first_rgba_layer_from_file(
            path,
            |res, channels: &exr::prelude::RgbaChannels| {
                (
                    res.width(),
                    channels.3.is_some(),
                    vec![[0.0f64; 4]; res.width() * res.height()],
                )
            },
            |(w, _, buf), pos, (r, g, b, a): (f32, f32, f32, f32)| {
                buf[pos.y() * *w + pos.x()] =
                    [f64::from(r), f64::from(g), f64::from(b), f64::from(a)]
            },
        )
        .map_err(|e| bad(e.to_string()))?;
        let size = image.layer_data.size;
        let (_, has_alpha, pixels) = &image.layer_data.channel_data.pixels;
        if let Some(i) = pixels.iter().position(|p| p.iter().any(|v| !v.is_finite())) {
            return Err(bad(format!(
                "pixel ({}, {}) is not finite",
                i % size.width(),
                i / size.width()
            )));
        }
        let (width, height) = (
            u32::try_from(size.width()).map_err(|_| bad("too wide".into()))?,
            u32::try_from(size.height()).map_err(|_| bad("too tall".into()))?,
        );
        if !(1..=4096).contains(&width) || !(1..=4096).contains(&height) {
            return Err(bad(format!(
                "{width}x{height}: expected 1..=4096 px a side"
            )));
        }
        // compare_exr.py's default mask: pixels the object covers fully (silhouette pixels,
        // where a rasterizer and a path tracer differ by construction, are left out).
        let mask: Vec<bool> = pixels
            .iter()
            .map(|p| match has_alpha {
                true => p[3] >= 0.999,
                false => p[..3].iter().any(|&v| v > 0.0),
            })
            .collect();
        if !mask.iter().any(|&m| m) {
            return Err(bad("no object pixels (alpha >= 0.999 or non-black)".into()));
        }
        Ok(Reference {
            path: path.to_path_buf(),
            width,
            height,
            rgb: pixels.iter().map(|p| [p[0], p[1], p[2]]).collect(),
            mask,
            mask_kind: if *has_alpha { "alpha" } else { "nonblack" },
        })
    }

    fn error(&self, image: &LinearImage) -> Errors {
        rel_rms(
            image
                .pixels
                .iter()
                .zip(&self.rgb)
                .zip(&self.mask)
                .filter(|(_, &m)| m)
                .map(|((o, r), _)| ([o[0], o[1], o[2]].map(f64::from), *r)),
        )
    }
}

/// One line of the CSV.
#[derive(Clone, Debug, serde::Serialize)]
struct Row {
    /// `gpu` (a GPU frame) or `exact` (the exact discrete solution, on the CPU).
    solver: &'static str,
    family: usize,
    family_name: String,
    colour: String,
    k: f64,
    levels: u32,
    resolution: u32,
    scheme: &'static str,
    precision: Option<&'static str>,
    start: Option<&'static str>,
    iterations_cap: Option<u32>,
    tolerance: Option<f32>,
    iterations: Vec<u32>,
    /// Sum over levels of iterations x nodes: a work measure that, unlike lavapipe's times on
    /// a loaded machine, does not move between runs.
    node_updates: Option<u64>,
    finest_nodes: usize,
    finest_surface_nodes: usize,
    solve_gpu_ms: Option<f64>,
    frame_gpu_ms: Option<f64>,
    cpu_s: Option<f64>,
    gpu_bytes: Option<u64>,
    bytes_per_node: Option<f64>,
    discrete: Errors,
    /// (a') against the exact solution of the same system for the q this frame gathered: the
    /// error the iterations leave, without the gather's (shadow maps, fp16 q).
    solver_error: Errors,
    closed_form: Option<Errors>,
    image: Option<Errors>,
    pareto_solver: bool,
    pareto_image: bool,
}

const CSV_HEADER: &str =
    "solver,family,family_name,colour,k,levels,resolution,scheme,precision,start,\
iterations_cap,tolerance,iterations_per_level,node_updates,finest_nodes,finest_surface_nodes,solve_gpu_ms,\
frame_gpu_ms,cpu_s,gpu_bytes,bytes_per_node,discrete_r,discrete_g,discrete_b,discrete_all,\
solver_r,solver_g,solver_b,solver_all,\
closed_form_r,closed_form_g,closed_form_b,closed_form_all,image_r,image_g,image_b,image_all,\
pareto_solver,pareto_image";

fn opt<T: std::fmt::Display>(v: Option<T>) -> String {
    v.map_or(String::new(), |v| v.to_string())
}

fn errs(e: Option<&Errors>) -> String {
    (0..4)
        .map(|c| {
            e.and_then(|e| e[c])
                .map_or(String::new(), |v| format!("{v:.6e}"))
        })
        .collect::<Vec<_>>()
        .join(",")
}

impl Row {
    fn empty() -> Row {
        Row {
            solver: "gpu",
            family: 0,
            family_name: String::new(),
            colour: String::new(),
            k: 0.0,
            levels: 0,
            resolution: 0,
            scheme: "fv",
            precision: None,
            start: None,
            iterations_cap: None,
            tolerance: None,
            iterations: Vec::new(),
            node_updates: None,
            finest_nodes: 0,
            finest_surface_nodes: 0,
            solve_gpu_ms: None,
            frame_gpu_ms: None,
            cpu_s: None,
            gpu_bytes: None,
            bytes_per_node: None,
            discrete: [None; 4],
            solver_error: [None; 4],
            closed_form: None,
            image: None,
            pareto_solver: false,
            pareto_image: false,
        }
    }

    fn csv(&self) -> String {
        let iterations: Vec<String> = self.iterations.iter().map(u32::to_string).collect();
        [
            self.solver.to_string(),
            self.family.to_string(),
            self.family_name.clone(),
            self.colour.clone(),
            self.k.to_string(),
            self.levels.to_string(),
            self.resolution.to_string(),
            self.scheme.to_string(),
            opt(self.precision),
            opt(self.start),
            opt(self.iterations_cap),
            opt(self.tolerance),
            iterations.join(";"),
            opt(self.node_updates),
            self.finest_nodes.to_string(),
            self.finest_surface_nodes.to_string(),
            opt(self.solve_gpu_ms.map(|v| format!("{v:.3}"))),
            opt(self.frame_gpu_ms.map(|v| format!("{v:.3}"))),
            opt(self.cpu_s.map(|v| format!("{v:.3}"))),
            opt(self.gpu_bytes),
            opt(self.bytes_per_node.map(|v| format!("{v:.1}"))),
            errs(Some(&self.discrete)),
            errs(Some(&self.solver_error)),
            errs(self.closed_form.as_ref()),
            errs(self.image.as_ref()),
            self.pareto_solver.to_string(),
            self.pareto_image.to_string(),
        ]
        .join(",")
    }

    /// The error drawn in the plot's second panel: the image's, else the closed form's.
    fn absolute(&self) -> Option<f64> {
        self.image.or(self.closed_form).and_then(|e| e[3])
    }

    fn summary(&self) -> String {
        let e = |v: Option<&Errors>| {
            v.and_then(|e| e[3])
                .map_or_else(|| "-".to_string(), |v| format!("{v:.2e}"))
        };
        let ms = |v: Option<f64>| v.map_or_else(|| "-".to_string(), |v| format!("{v:.1}"));
        format!(
            "{:<5} {:<40} cap {:>5} tol {:>7} | iterations {:?} | solve {} ms, frame {} ms | error: discrete {}, solver {}, closed form {}, image {}",
            self.solver,
            self.family_name,
            opt(self.iterations_cap),
            opt(self.tolerance),
            self.iterations,
            ms(self.solve_gpu_ms),
            ms(self.frame_gpu_ms),
            e(Some(&self.discrete)),
            e(Some(&self.solver_error)),
            e(self.closed_form.as_ref()),
            e(self.image.as_ref()),
        )
    }
}

fn rgb(option: &'static str, text: &str) -> Result<[f64; 3], BenchError> {
    let v = list(option, text, |s| {
        s.parse::<f64>()
            .ok()
            .filter(|v| v.is_finite() && *v >= 0.0)
            .ok_or_else(|| "is not a finite number >= 0".to_string())
    })?;
    v.try_into().map_err(|v: Vec<f64>| BenchError::BadOption {
        option,
        problem: format!("{text:?}: expected 3 numbers, got {}", v.len()),
    })
}

/// The lights turned by `degrees` about +Y through the origin (the previous frame of a warm start).
fn turned(lights: &[Light], degrees: f64) -> Vec<Light> {
    let q = DQuat::from_rotation_y(degrees.to_radians());
    lights.iter().map(|l| l.rotated(q)).collect()
}

fn dark(l: &Light) -> bool {
    match l {
        Light::Directional { irradiance: e, .. }
        | Light::Point { intensity: e, .. }
        | Light::Spot { intensity: e, .. } => e.iter().all(|&v| v == 0.0),
    }
}

/// Expands a suite into argv (the user's own options after it, so they win).
fn suite_args(name: &str) -> Result<Vec<String>, BenchError> {
    let Some((_, _, options)) = SUITES.iter().find(|(n, _, _)| *n == name) else {
        return Err(BenchError::UnknownSuite {
            name: name.to_string(),
            known: suites()
                .map(|(n, d)| format!("{n} ({d})"))
                .collect::<Vec<_>>()
                .join("; "),
        });
    };
    let meshes = std::env::var("TRANSLUCENT_MESH_DIR")
        .ok()
        .filter(|d| !d.is_empty())
        .unwrap_or_else(|| "../shared/meshes".into());
    Ok(options
        .iter()
        .map(|o| o.replace("@MESHES", &meshes))
        .collect())
}

/// The suites: name and what each shows.
fn suites() -> impl Iterator<Item = (&'static str, &'static str)> {
    SUITES.iter().map(|(n, d, _)| (*n, *d))
}

pub fn run(args: &BenchArgs) -> anyhow::Result<()> {
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
    let lights = args.scene.lights()?;
    let mut frame_desc = args.scene.frame_desc()?;
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
        levels: sweep.levels[0],
        resolution: sweep.resolution[0],
        relax: args.relax,
        force: args.force,
    };
    let object = object_args.load(Some("torus"))?;
    let scene = scene::Scene {
        lights: lights.clone(),
        environment,
    };
    scene.validate()?;
    let previous = scene::Scene {
        lights: turned(&lights, -args.warm_degrees),
        environment,
    };
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
                    levels,
                    resolution,
                    ..object_args.clone()
                }
                .bake_params();
                let key = cache::cache_key(&object.surface, &params);
                let cache_file = cache_dir.join(format!("{}-{key:016x}.qgraph", object.name));
                let (graph, _, outcome) = cache::bake_cached(
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

/// Redraws `dir/bench.png` from `dir/bench.csv` (the columns the plot reads).
fn replot(dir: &Path) -> anyhow::Result<()> {
    let csv_path = dir.join("bench.csv");
    let text = std::fs::read_to_string(&csv_path)
        .with_context(|| format!("--replot: reading {}", csv_path.display()))?;
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap_or_default().split(',').collect();
    let column = |name: &str| {
        header
            .iter()
            .position(|h| *h == name)
            .with_context(|| format!("{}: no column {name}", csv_path.display()))
    };
    let [solver, family, ms, discrete, closed, image, front_d, front_i] = [
        "solver",
        "family",
        "solve_gpu_ms",
        "solver_all",
        "closed_form_all",
        "image_all",
        "pareto_solver",
        "pareto_image",
    ]
    .map(column);
    let (solver, family, ms, discrete) = (solver?, family?, ms?, discrete?);
    let (closed, image, front_d, front_i) = (closed?, image?, front_d?, front_i?);
    let mut rows = Vec::new();
    for (n, line) in lines.enumerate() {
        let cells: Vec<&str> = line.split(',').collect();
        let bad = || anyhow::anyhow!("{} line {}: malformed", csv_path.display(), n + 2);
        if cells.len() != header.len() {
            return Err(bad());
        }
        let number = |i: usize| -> anyhow::Result<Option<f64>> {
            match cells[i] {
                "" => Ok(None),
                v => v.parse::<f64>().map(Some).map_err(|_| bad()),
            }
        };
        let all = |i: usize| -> anyhow::Result<Option<Errors>> {
            Ok(number(i)?.map(|v| [None, None, None, Some(v)]))
        };
        rows.push(Row {
            solver: if cells[solver] == "exact" {
                "exact"
            } else {
                "gpu"
            },
            family: cells[family].parse().map_err(|_| bad())?,
            solve_gpu_ms: number(ms)?,
            solver_error: all(discrete)?.unwrap_or([None; 4]),
            closed_form: all(closed)?,
            image: all(image)?,
            pareto_solver: cells[front_d] == "true",
            pareto_image: cells[front_i] == "true",
            ..Row::empty()
        });
    }
    let png_path = dir.join("bench.png");
    write_atomically(&png_path, |tmp| plot(tmp, &rows).map_err(|e| e.to_string()))
        .with_context(|| format!("writing {}", png_path.display()))?;
    println!("wrote {}", png_path.display());
    Ok(())
}

/// Discrete error (a) below which the iterations are done for real time: 1%, well under the
/// model's own error against path tracing (the RESULTS ptref section: 1.4-39%).
const REALTIME: f64 = 1e-2;
/// ... and for the quality setting: 0.1%.
const QUALITY: f64 = 1e-3;

/// (real-time, quality): the GPU rows whose solver error is within [`REALTIME`] and
/// [`QUALITY`] with the fewest node updates (a deterministic cost: on a loaded machine the
/// measured milliseconds of one configuration move by 2-4x), then the least solve time.
fn picks(rows: &[Row]) -> (Option<usize>, Option<usize>) {
    let fastest_within = |limit: f64| {
        rows.iter()
            .enumerate()
            .filter(|(_, r)| r.solver_error[3].is_some_and(|e| e <= limit))
            .filter_map(|(i, r)| Some((i, r.node_updates.unwrap_or(0), r.solve_gpu_ms?)))
            .min_by(|a, b| a.1.cmp(&b.1).then(a.2.total_cmp(&b.2)))
            .map(|(i, _, _)| i)
    };
    (fastest_within(REALTIME), fastest_within(QUALITY))
}

/// Marks the GPU rows no other GPU row beats in both solve time and error.
fn mark_pareto(rows: &mut [Row]) {
    let front = |rows: &[Row], error: &dyn Fn(&Row) -> Option<f64>| -> Vec<bool> {
        rows.iter()
            .map(|r| {
                let (Some(t), Some(e)) = (r.solve_gpu_ms, error(r)) else {
                    return false;
                };
                !rows.iter().any(|o| match (o.solve_gpu_ms, error(o)) {
                    (Some(to), Some(eo)) => to <= t && eo <= e && (to < t || eo < e),
                    _ => false,
                })
            })
            .collect()
    };
    let solver = front(rows, &|r| r.solver_error[3]);
    let image = front(rows, &|r| r.absolute());
    for (r, (d, i)) in rows.iter_mut().zip(solver.into_iter().zip(image)) {
        r.pareto_solver = d;
        r.pareto_image = i;
    }
}

fn colour_name(family: usize) -> String {
    palette_hex(family)
}

/// Runs every configuration on one bake: the exact rows first, then the GPU frames.
#[allow(clippy::too_many_arguments)]
fn bench_bake(
    ctx: &Context,
    baked: &Baked,
    field: &MaterialField,
    scene: &scene::Scene,
    previous: &scene::Scene,
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
            let captured = HeadlessRenderer::new(ctx, &shown, scene, frame_desc)?.render_frame(ctx)?;
            row.image = Some(reference.error(&captured.image));
        }
        emit(row);
        exact.insert(name, solution);
        progress.inc(1);
    }

    let mut same_q: BTreeMap<&'static str, Vec<[f64; 3]>> = BTreeMap::new();
    for config in configs {
        let scheme = scheme_name(config.scheme);
        let family_name = format!(
            "{bake_name} {scheme} {} {}",
            precision_name(config.precision),
            if config.warm { "warm" } else { "cold" }
        );
        progress.set_message(format!(
            "{family_name} cap {} tol {}",
            config.cap, config.tolerance
        ));
        let solution = &exact[scheme];
        let run = run_gpu(ctx, &graph, field, scene, previous, frame_desc, config, repeats)
        .with_context(|| format!("{family_name} cap {} tol {}", config.cap, config.tolerance))?;
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
        // The exact solution for the q the GPU gathered (the same for every configuration of
        // this bake and scheme: same lights, same shadow maps, same exposure).
        if !same_q.contains_key(scheme) {
            let j = exact_for_q(&graph, field, config.scheme, &run.q, &solution.phi)
                .with_context(|| format!("{family_name}: the exact solve for the gathered q"))?;
            same_q.insert(scheme, j);
        }
        let mut row = base_row(family_name);
        row.solver_error = rel_rms(j_plus.iter().copied().zip(same_q[scheme].iter().copied()));
        row.scheme = scheme;
        row.precision = Some(precision_name(config.precision));
        row.start = Some(if config.warm { "warm" } else { "cold" });
        row.iterations_cap = Some(config.cap);
        row.tolerance = Some(config.tolerance);
        row.node_updates = Some(
            run.iterations
                .iter()
                .zip(&graph.levels)
                .map(|(&i, l)| u64::from(i) * l.node_count() as u64)
                .sum(),
        );
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

/// Error (b): J+ against the sphere's uniform closed-form J+ = albedo q / (1 - F_dr) (`per_q` is
/// albedo / (1 - F_dr) per channel), with the reference's own q (uniform for a constant
/// environment).
fn analytic_error(j_plus: &[[f64; 3]], q: &[[f64; 3]], per_q: &[f64; 3]) -> Errors {
    rel_rms(
        j_plus
            .iter()
            .zip(q)
            .map(|(j, q)| (*j, std::array::from_fn(|c| per_q[c] * q[c]))),
    )
}

/// Clamped J+ per finest surface node of the exact solution (to 1e-10) of the finest level's
/// system for the surface irradiance `q` (per surface node), starting from `phi`.
fn exact_for_q(
    graph: &QuadGraph,
    field: &MaterialField,
    scheme: Scheme,
    q: &[[f64; 3]],
    phi: &[[f64; 3]],
) -> anyhow::Result<Vec<[f64; 3]>> {
    let level = graph.finest();
    let op = LevelOperator::build(level, field, scheme)?;
    let b = op.rhs(q);
    let mut phi = phi.to_vec();
    let report = krylov::solve(&op, &b, &mut phi, 1e-10, 100_000);
    if !report.converged {
        bail!("did not converge (relative residual {:?})", report.residual);
    }
    let inner = level.inner_count();
    Ok(q.iter()
        .enumerate()
        .map(|(s, q)| {
            std::array::from_fn(|c| {
                ((1.0 + 1.0 / op.a) * phi[inner + s][c] / 4.0 - q[c] / (1.0 + op.f_dr)).max(0.0)
            })
        })
        .collect())
}

struct GpuRun {
    /// q per finest surface node as the frame gathered it (unscaled).
    q: Vec<[f64; 3]>,
    iterations: Vec<u32>,
    solve_ms: f64,
    frame_ms: f64,
    bytes: (u64, f64),
    j_plus: Vec<[f32; 3]>,
    image: LinearImage,
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    match v.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => v[n / 2],
        n => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
}

/// One configuration through the frame the object ships ([`TranslucentObject`] recorded by a
/// headless host): a warm-up frame, then `repeats` timed frames of `scene`. Cold: skipping off,
/// so every frame solves from scratch. Warm: each timed frame follows an untimed one with the
/// `previous` lights, so every timed solve starts from the solution of the lights a few degrees
/// away, as in a host whose light moves.
#[allow(clippy::too_many_arguments)]
fn run_gpu(
    ctx: &Context,
    graph: &Arc<QuadGraph>,
    field: &MaterialField,
    scene: &scene::Scene,
    previous: &scene::Scene,
    frame_desc: &FrameDesc,
    config: &Config,
    repeats: u32,
) -> anyhow::Result<GpuRun> {
    let params = ObjectParams {
        solve: GpuSolveParams {
            scheme: config.scheme,
            precision: config.precision,
            iterations: vec![config.cap],
            block: BLOCK,
            tolerance: config.tolerance,
            ..GpuSolveParams::default()
        },
        specular: frame_desc.specular,
        roughness: frame_desc.roughness,
        radiance: frame_desc.radiance,
        skip: config.warm,
        ..ObjectParams::default()
    };
    let first = if config.warm { previous } else { scene };
    let mut object = TranslucentObject::new(ctx, graph.clone(), field, first, &params)?;
    object.set_camera(frame_desc.camera)?;
    let mut host = HeadlessHost::new(ctx, frame_desc.width, frame_desc.height)?;
    let (mut solve, mut whole) = (Vec::new(), Vec::new());
    let mut last = None;
    for i in 0..=repeats {
        if config.warm {
            object.set_lights(previous)?;
            host.render(ctx, &mut object)?;
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
    let level = graph.finest();
    let finest = graph.levels.len() - 1;
    let gathered = ImageReadback::capture(
        ctx,
        method.solve().q_image(finest).context("no q image")?,
        Access::ComputeReadWrite,
    )?;
    let unscale = 1.0 / f64::from(method.q_scale());
    let q = level.packing.texels[level.inner_count()..]
        .iter()
        .map(|&[u, v]| {
            let p = gathered.pixel(u, v);
            [p[0], p[1], p[2]].map(|x| f64::from(x) * unscale)
        })
        .collect();
    Ok(GpuRun {
        q,
        iterations: method.solve().iterations_run(ctx)?,
        solve_ms: median(solve),
        frame_ms: median(whole),
        bytes: method.solve().bytes(),
        j_plus: method.solve().read_j_plus(ctx)?,
        image: last.image,
    })
}

/// Log-log error against solve GPU ms (`translucent_benches::plot`): one colour per family, the
/// Pareto front in black. Left: error (a); right (when any row has one): error (c) or (b), with
/// each exact row's value (the floor) as a grey line.
fn plot(path: &Path, rows: &[Row]) -> Result<(), Box<dyn std::error::Error>> {
    type ErrorOf<'a> = &'a dyn Fn(&Row) -> Option<f64>;
    type OnFront<'a> = &'a dyn Fn(&Row) -> bool;
    let solver = |r: &Row| r.solver_error[3];
    let absolute = |r: &Row| r.absolute();
    let mut kinds: Vec<(ErrorOf, OnFront)> = vec![(&solver, &|r: &Row| r.pareto_solver)];
    if rows.iter().any(|r| r.absolute().is_some()) {
        kinds.push((&absolute, &|r: &Row| r.pareto_image));
    }
    let families = rows.iter().map(|r| r.family).max().map_or(0, |m| m + 1);
    let panels: Vec<Panel> = kinds
        .iter()
        .map(|(error, on_front)| {
            let timed = |r: &Row| Some((r.solve_gpu_ms?, error(r)?));
            Panel {
                series: (0..families)
                    .map(|f| Series {
                        colour: palette(f),
                        points: rows
                            .iter()
                            .filter(|r| r.family == f)
                            .filter_map(timed)
                            .collect(),
                    })
                    .collect(),
                front: rows
                    .iter()
                    .filter(|r| on_front(r))
                    .filter_map(timed)
                    .collect(),
                floors: rows
                    .iter()
                    .filter(|r| r.solver == "exact")
                    .filter_map(error)
                    .filter(|&e| e > 0.0)
                    .collect(),
            }
        })
        .collect();
    error_vs_time(path, &panels)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

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
