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
use translucent::frame::MethodChoice;
use translucent::headless::{ExitanceMesh, FrameDesc, HeadlessHost, HeadlessRenderer};
use translucent::scene::Camera;
use translucent::scene::Environment;
use translucent::scene::Light;
use translucent::solver::gpu::GpuSolveParams;
use translucent::solver::multigrid::MultigridParams;
use translucent::solver::{self, CpuSolveParams, Schedule, Scheme};
use translucent::vk::{Context, ContextDesc, FrameTimings};
use translucent::{ObjectParams, TranslucentObject};

use crate::material_args::MaterialArgs;
use crate::object_args::ObjectArgs;
use crate::scene_args::SceneArgs;

mod checks;
mod defaults;
pub mod dipole;
mod graph_file;
mod output;
pub mod voxel;

pub use defaults::{choice_json, resolve_auto, schedule_of, DEFAULT_SOURCE};
pub use graph_file::{load_graph_file, GraphFileError};
use output::{gpu_bytes_json, gpu_multigrid_json, profile_in_order};
pub(crate) use output::{supersample_factor, write_output, write_trace};

#[derive(clap::Args, Debug, Clone)]
pub struct RenderArgs {
    #[command(flatten)]
    pub object: ObjectArgs,
    #[command(flatten)]
    pub material: MaterialArgs,
    #[command(flatten)]
    pub scene: SceneArgs,
    /// The method: quadgraph (diffusion on the QuadGraph, Wang et al. 2010), voxel (shortest
    /// optical paths on a voxel grid built every frame, Ozawa et al.; no bake) or dipole
    /// (hierarchical boundary elements with the dipole BSSRDF, Mertens et al. 2003; homogeneous
    /// materials), or auto (picked from the scene by `frame::choose_method`'s documented rule;
    /// the choice and its reason are printed, and in --json as `method_choice`).
    #[arg(long, default_value = "quadgraph", value_parser = ["quadgraph", "voxel", "dipole", "auto"])]
    pub method: String,
    /// `--method auto`'s choice, once made (not an option).
    #[arg(skip)]
    pub method_choice: Option<MethodChoice>,
    /// Voxel method: voxels along the object's longest side (4..=256), or auto (from the
    /// material's mean free path).
    #[arg(long, value_name = "N|auto")]
    pub voxels: Option<String>,
    /// Voxel method: diffusion (default: sigma_tr along the path, the diffusion falloff at the
    /// exit) or paper (sigma_t' along the path, exp(-n) at the exit, as published).
    #[arg(long, value_name = "MODEL", value_parser = ["paper", "diffusion"])]
    pub voxel_model: Option<String>,
    /// Voxel method: soft minimum over paths (log-sum-exp temperature per unit of the cheapest
    /// edge, 0..=0.3; 0: the hard minimum of the paper).
    #[arg(long, value_name = "BETA")]
    pub voxel_soft: Option<f32>,
    /// --method dipole with a heterogeneous material (--volume, procedural presets): transport
    /// through the field's mean and modulate the exitance by the field like a texture (the
    /// paper's "texture only"); without it such a material is refused.
    #[arg(long)]
    pub texture_only: bool,
    /// --method dipole: the refinement oracle's tolerance (the largest error of one link's push
    /// and of one point sample, relative to the total diffuse reflectance): smaller is more
    /// links, more accurate and slower (benches/RESULTS.md, "Dipole method in the frame").
    #[arg(long, value_name = "F")]
    pub link_tolerance: Option<f64>,
    /// gpu (default): the GPU frame (shadow maps, irradiance gather and Jacobi on the GPU,
    /// convergence decided on the GPU). cpu: the f64 reference solver.
    #[arg(long, default_value = "gpu", value_parser = ["cpu", "gpu"])]
    pub solver: String,
    /// Discretization: fv (finite volumes, default) or paper (Eqs. 5/6, for comparison).
    #[arg(long, default_value = "fv", value_parser = ["fv", "paper"])]
    pub scheme: String,
    /// Jacobi iterations per level. Without it the CPU solver runs multi-level Jacobi to
    /// --tolerance and then solves the finest level exactly; with it, exactly this schedule.
    /// For the GPU solver it is the cap per level (default 2000), stopped early at --tolerance.
    #[arg(long)]
    pub iterations: Option<usize>,
    /// Stop a level's iterations once the estimated relative error is below this.
    #[arg(long, default_value_t = translucent::defaults::TOLERANCE)]
    pub tolerance: f64,
    /// How the levels are used (DESIGN 5.1): multigrid (full multigrid + CG-accelerated
    /// V-cycles to the relative residual --tolerance, on either solver; warm frames start from
    /// the last solution) or cascade (the paper's: Jacobi per level, coarsest first; then, for
    /// the CPU solver, PCG on the finest level unless --iterations). Default: multigrid on the
    /// GPU solver, except with the cascade's own options (--precision fp16, --iterations,
    /// --scheme paper);
    /// cascade (+ the exact PCG) on the CPU solver, the f64 reference.
    #[arg(long, value_parser = ["cascade", "multigrid"])]
    pub schedule: Option<String>,
    /// The multigrid cycle's smoother and schedule, `key=value,..` over the defaults (keys: nu
    /// PRE/POST Chebyshev degree on the finest level, cnu on the middle levels, cheb LOWER
    /// fraction of lambda_max, jacobi OMEGA, ctol coarsest tolerance, fmg V-cycles per level of
    /// the cold start, krylov 0|1). For measurements: the defaults are the measured best.
    #[arg(long, value_name = "KEY=VALUE,..")]
    pub multigrid_cycle: Option<String>,
    /// GPU state precision (mixed, fp16, fp32); applies to the GPU solver only.
    #[arg(long, value_parser = ["mixed", "fp16", "fp32"])]
    pub precision: Option<String>,
    /// Constant environment radiance R,G,B.
    #[arg(long, value_name = "R,G,B", conflicts_with = "env")]
    pub env_constant: Option<String>,
    /// Environment radiance from an equirectangular EXR (Mitsuba's envmap convention, +Y up),
    /// projected onto order-2 spherical harmonics.
    #[arg(long, value_name = "FILE.exr")]
    pub env: Option<PathBuf>,
    /// Where the lights' transmitted light enters the diffusion (GPU and CPU, the same
    /// formulas; `solver::transport::Source`): `flux`, DESIGN section 2's boundary flux (with the
    /// `flux` exit query unless `--exit-query moments`); `beam`, the collimated source of DESIGN
    /// 2.7 (per lit surface node the analytic particular solution in the Robin row, read by the
    /// moments exit query, implied; single scattering added as the difference to the flat closed
    /// form); `second`, the same with the second-collision density (DESIGN 2.8's second option:
    /// the beam times the share of once-scattered light that collides again) and single
    /// scattering added whole, never skipped as front-lit. Heterogeneous materials take each
    /// surface node's own coefficients. Default: `second` on the GPU (benches/RESULTS.md, "Model
    /// terms on the GPU (wave 5)"); `flux` with `--exit-query flux`, `--solver cpu` or another
    /// `--method`.
    #[arg(long, value_name = "flux|beam|second", value_parser = ["flux", "beam", "second"], conflicts_with = "beam_source")]
    pub source: Option<String>,
    /// `--source beam` (kept for scripts).
    #[arg(long)]
    pub beam_source: bool,
    /// With a beam source on the GPU: a light a surface node's shadow lookup sees partly occluded
    /// (a shadow edge or the terminator) enters as the boundary flux (DESIGN 2.7's fallback).
    #[arg(long)]
    pub shadow_edge_flux: bool,
    /// With a beam source (GPU and CPU solvers, the same rule; DESIGN 2.7's thin walls): `on`, a
    /// surface node facing away from a light gets the particular solution of the beam that
    /// entered on the light's side of the wall, attenuated along the refracted path (exact for a
    /// slab at any thickness; the GPU finds the entry in the light's shadow map and takes the
    /// wall's faces parallel); `off`, only lit nodes carry a beam. Default: see
    /// `defaults::DEFAULT_CONTINUATION`.
    #[arg(long, value_name = "on|off", value_parser = ["on", "off"])]
    pub continuation: Option<String>,
    /// With a beam source (GPU and CPU solvers, the same formula and baked curvature): `on`,
    /// each surface node's beam is taken from upstream on the curved surface
    /// (`transport::upstream_beam`: lights the crescent past the terminator of a back-lit
    /// object); `off`, the planar beam. `--upstream-beam` alone is `on`. Default: see
    /// `defaults::DEFAULT_UPSTREAM_BEAM`.
    #[arg(long, value_name = "on|off", value_parser = ["on", "off"], num_args = 0..=1, default_missing_value = "on")]
    pub upstream_beam: Option<String>,
    /// How exitance is read at the surface (GPU and CPU solvers, same formulas): `moments`, the
    /// Fresnel-moment boundary and exit query of DESIGN 2.6 (phi and its inward derivative from
    /// the node's Robin row), or `flux` (the default), DESIGN section 2's boundary-flux query (J+).
    /// `--beam-source` implies `moments`.
    #[arg(long, value_name = "flux|moments", value_parser = ["flux", "moments"])]
    pub exit_query: Option<String>,
    /// How the display vertices get their exitance (GPU and CPU solvers, same formulas):
    /// `interior` (phi at a point a fixed depth inside, interpolated from the tetrahedra around
    /// it, extended to the surface by the local 1D profile with the surface's mean curvature;
    /// DESIGN 2.6, issue 12 item 4: no lattice rings or blotches, the sphere's closed-form albedo
    /// within 0.4%), `shepard` (each surface node's J+ through the shading weights; closer to the
    /// path-traced back-lit references for long diffusion lengths) or `auto` (the default:
    /// interior where a channel's s = sqrt(sigma_a / D) times the lattice spacing exceeds 0.5,
    /// as skin1 and ketchup at the auto resolution, Shepard otherwise; benches/RESULTS.md
    /// "Surface auto and the curved profile").
    #[arg(long, value_name = "auto|interior|shepard", default_value = "auto", value_parser = ["auto", "interior", "shepard"])]
    pub surface: String,
    /// The diffusion coefficient D of the QuadGraph method (GPU and CPU solvers, the solve, the
    /// sources and the exit query alike; `material::DiffusionCoefficient`): `grosjean` (the
    /// default with `--method quadgraph`), (2 sigma_a + sigma_s') / (3 sigma_t'^2), or
    /// `classical`, 1 / (3 sigma_t') (the voxel and dipole methods' only one). They differ only
    /// at low albedo: against the path-traced references Grosjean's is level or better on every
    /// scene with the default surface (split `.vol` sphere 19.5% -> 16.7%; benches/RESULTS.md,
    /// "Diffusion coefficient at low albedo"). `--json` `diffusion_coefficient` says which ran.
    #[arg(long, value_name = "classical|grosjean", value_parser = ["classical", "grosjean"])]
    pub diffusion_coefficient: Option<String>,
    /// Heterogeneous materials on the GPU cascade: `derived` (the default) computes the Jacobi
    /// weights in every sweep from the per-node kappa and mu by the harmonic face mean (48 bytes
    /// per node less, 8 texel reads per node and sweep); `stored` keeps three RGBA32F weight
    /// textures derived once per edit (3 reads). benches/RESULTS.md, "Bytes per node (wave 5)".
    #[arg(long, value_name = "derived|stored", default_value = "derived", value_parser = ["derived", "stored"])]
    pub heterogeneous_weights: String,
    /// The multigrid schedule's coarse-level operators (DESIGN 5.1): `galerkin` (the default,
    /// `P^T K P`: ~130-480 entries per coarse row) or `rediscretized` (each coarse graph's own fv
    /// operator, 4-7 entries per row). benches/RESULTS.md, "Coarse operator and its storage".
    #[arg(long, value_name = "galerkin|rediscretized", value_parser = ["galerkin", "rediscretized"])]
    pub coarse_operator: Option<String>,
    /// How the GPU multigrid stores the coarse levels' off-diagonal entries: `f16` (the default:
    /// relative to each row's diagonal, the rounding lumped onto the f32 diagonal) or `f32`; the
    /// finest level stays f32.
    #[arg(long, value_name = "f32|f16", value_parser = ["f32", "f16"])]
    pub coarse_storage: Option<String>,
    /// How the GPU multigrid stores the prolongation's links (its transpose, the restriction,
    /// reads the same links): `f32` (the default: node and f32 weight) or `packed` (one u32 per
    /// link, `node << 8 | code`, weight `(code - 85) / 85`, the hierarchy built with the same
    /// quantized weights: 37 bytes per node less, a CG iteration more on the default scene).
    /// benches/RESULTS.md, "Multigrid storage (wave 7)".
    #[arg(long, value_name = "f32|packed", value_parser = ["f32", "packed"])]
    pub link_storage: Option<String>,
    /// How the GPU multigrid stores its per-node RGB vectors (x, f, r, d, the CG's): `rgb` (the
    /// default: 12 bytes, no padding lane) or `rgba` (16 bytes, the fourth float unused).
    /// benches/RESULTS.md, "Multigrid storage (wave 7)".
    #[arg(long, value_name = "rgb|rgba", value_parser = ["rgb", "rgba"])]
    pub vector_storage: Option<String>,
    /// The GPU multigrid's finest operator: `graph` (default: matrix-free from the cascade's graph
    /// textures) or `csr` (its own rows). RESULTS "Matrix-free finest level (wave 8)".
    #[arg(long, value_name = "csr|graph", value_parser = ["csr", "graph"])]
    pub finest_operator: Option<String>,
    /// The GPU multigrid's smoother update d and CG's last z: `f16` (default, 8 bytes) or `f32`.
    #[arg(long, value_name = "f32|f16", value_parser = ["f32", "f16"])]
    pub update_storage: Option<String>,
    /// Drop the Galerkin coarse levels' weak entries (|k_ij| < THETA sqrt(k_ii k_jj)), lumped so
    /// every row sums as before (`MultigridParams::sparsify`, `--multigrid-cycle drop=`); 0 drops none.
    #[arg(long, value_name = "THETA")]
    pub coarse_drop: Option<f64>,
    /// Single scattering of DESIGN 2.8 as the shared frame-graph pass `single_scattering` (GPU,
    /// every method): per display vertex the refracted view ray is marched at exponentially
    /// stratified depths up to the far face (a back-face depth pre-pass from the eye), lit through
    /// unbiased depth views of the shadow maps' projections, added to the method's exitance as
    /// the difference to the flat-surface closed form. `on` (the default): marched unless every
    /// light is in front of the object as the eye sees it (the error budget's rule, skipped with
    /// the reason "front-lit"); `always`: marched on every view; `off`: the pass is not recorded
    /// (benches/RESULTS.md, "Single scattering: far-face stop"). Not applied with `--solver cpu`.
    #[arg(long, value_name = "on|off|always", value_parser = ["on", "off", "always"])]
    pub single_scattering: Option<String>,
    /// One bounce of exitance between display vertices (issue 12 item 5): light leaving the
    /// surface enters it again elsewhere (concave parts; eta = 1 outside). `local`: at bake time
    /// cosine-weighted rays per display vertex find the surface it sees (sparse form factors);
    /// per solve the pass `bounce` gathers E_b = sum F M and adds R_d E_b where it enters (no
    /// second solve). `local` is the default with `--method quadgraph` on the GPU (the links are
    /// stored with the bake: the next render of the mesh casts no ray; a convex mesh gets none
    /// without casting rays); `off`: no links, no pass, and the default of the other methods
    /// and of `--solver cpu` (benches/RESULTS.md, "One bounce between surface points").
    #[arg(long, value_name = "off|local", value_parser = ["off", "local"])]
    pub bounce: Option<String>,
    /// Bounces per solve of `--bounce local` (1..=16): 1 is light that left the surface once and
    /// entered it again; each more lets it leave and enter again (a concave corner's
    /// interreflection: the back-lit plate's foot, benches/RESULTS.md "Thin walls: the plate's
    /// foot and interreflection"). Two dispatches over the display vertices each.
    #[arg(long, value_name = "N", default_value_t = translucent::defaults::BOUNCES)]
    pub bounces: u32,
    /// Rays per display vertex of `--bounce local`'s links (1..=4096).
    #[arg(long, value_name = "N", default_value_t = translucent::frame::BounceParams::default().rays)]
    pub bounce_rays: u32,
    /// Depths per view ray of `--single-scattering on` (4..=16).
    #[arg(long, value_name = "N", default_value_t = translucent::defaults::SCATTER_SAMPLES)]
    pub scatter_samples: u32,
    /// Output image: `.png` (exposure, tone map, sRGB) or `.exr` (linear radiance).
    #[arg(long)]
    pub out: PathBuf,
    /// Render this many frames of the same scene, as a host would; the last one is written.
    #[arg(long, default_value_t = 1)]
    pub frames: u32,
    /// GPU solver: rotate every light about +Y by this many degrees per frame (the environment
    /// stays), so later frames warm-start a new solve.
    #[arg(long, value_name = "DEG")]
    pub orbit_light: Option<f64>,
    /// GPU solver: rotate the camera about +Y through its target by this many degrees per frame
    /// (a camera-only change: shading only).
    #[arg(long, value_name = "DEG")]
    pub orbit_camera: Option<f64>,
    /// GPU solver: turn every skip off (each frame a full cold solve), for comparisons.
    #[arg(long)]
    pub no_skip: bool,
    /// Write the image even when no pixel of the object is lit (otherwise that is an error:
    /// usually a light or the camera inside the object, or a light pointing away).
    #[arg(long)]
    pub allow_black: bool,
    /// PNG only: a studio backdrop (a grey gradient, lighter towards the floor) behind the
    /// object instead of black; composited by the object's coverage after the render, so the
    /// object's pixels are unchanged. EXR stays linear radiance on black (DESIGN 8).
    #[arg(long)]
    pub backdrop: bool,
    /// Anti-aliasing: render N x N samples per output pixel and average them (linear radiance,
    /// before the tone map); 1 turns it off. Default 2: smooth silhouettes for 4x the shading
    /// and read-back (not the solve; benches/RESULTS.md, "Anti-aliasing").
    #[arg(long, value_name = "N", default_value_t = translucent::defaults::SUPERSAMPLE,
          value_parser = clap::value_parser!(u32).range(1..=4))]
    pub supersample: u32,
    /// Print the per-pass GPU milliseconds of the last frame.
    #[arg(long)]
    pub profile: bool,
    /// Print one JSON object: device, levels, frames (passes, iterations), residual, energy.
    #[arg(long)]
    pub json: bool,
    /// Write the GPU timestamp scopes of all frames as a Chrome trace (chrome://tracing, Perfetto).
    #[arg(long)]
    pub trace: Option<PathBuf>,
    /// Where baked QuadGraphs are cached (default: $TRANSLUCENT_CACHE_DIR, else
    /// $XDG_CACHE_HOME/translucent, else ~/.cache/translucent).
    #[arg(long, value_name = "DIR")]
    pub cache_dir: Option<PathBuf>,
    /// Render with this QuadGraph, written by `translucent bake --out FILE.qgraph`, instead of
    /// baking or using the cache. It must be a bake of the surface the object options describe
    /// (the --mesh or --shape, --size-mm and --up given to `bake`); the bake's own options
    /// (--resolution, --levels, -K, --relax) are the file's and may not be given.
    #[arg(
        long,
        value_name = "FILE.qgraph",
        conflicts_with_all = ["resolution", "levels", "k", "relax", "cache_dir"]
    )]
    pub graph: Option<PathBuf>,
}

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
            let params = args.object.bake_params(&resolution);
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
    let surface = args.surface_for(&field, resolution.spacing_mm)?;
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
    let bounce_links = if on_gpu && settings.bounce == translucent::frame::BounceMode::Local {
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
            skip: !args.no_skip,
            single_scattering: settings.single_scattering,
            bounce: settings.bounce,
            ..ObjectParams::default()
        };
        let mut translucent =
            TranslucentObject::new(&ctx, graph.clone(), &field, &solver_scene, &object_params)?;
        translucent.set_bounces(args.bounces)?;
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
                "mode": "local",
                "bounces": args.bounces,
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
            let mg_report = match (multigrid, solve) {
                (true, Some(_)) => translucent
                    .quadgraph()
                    .context("the QuadGraph method reports the solve")?
                    .solve()
                    .multigrid_report(&ctx)?,
                _ => None,
            };
            let converged = match &mg_report {
                Some(m) => Some(m.converged),
                None => solve.map(|s| s.converged()),
            };
            // The cascade's fp16 phi stops when its update rounds to zero: stalled, not converged.
            let stalled = match &mg_report {
                Some(_) => None,
                None => solve.map(|s| s.stalled()),
            };
            if let (Some(m), false) = (&mg_report, args.json) {
                if !m.converged {
                    eprintln!(
                        "warning: frame {i}: the multigrid cycles stopped at relative residual {:.1e} ({:?})",
                        m.residual, m.state
                    );
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
