//! `translucent render`'s command line: every option of [`RenderArgs`], with its meaning.

use std::path::PathBuf;

use translucent::frame::MethodChoice;

use crate::material_args::MaterialArgs;
use crate::object_args::ObjectArgs;
use crate::scene_args::SceneArgs;

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
    /// object) with wave 8's area factor and a planar particular solution; `off`, the planar
    /// beam; `curved`, the upstream beam with its particular solution below the curved surface
    /// (`transport::Transport::curved_particular`: the volume's narrowing and the lateral terms
    /// in K, in full on umbilic nodes, faded to `on` where the principal curvatures differ).
    /// `--upstream-beam` alone is `on`. Default: `curved` (see `defaults::DEFAULT_UPSTREAM_BEAM`,
    /// `defaults::DEFAULT_CURVED_PARTICULAR`).
    #[arg(long, value_name = "on|off|curved", value_parser = ["on", "off", "curved"], num_args = 0..=1, default_missing_value = "on")]
    pub upstream_beam: Option<String>,
    /// With a beam source and the interior surface (GPU and CPU solvers, the same formula):
    /// `on`, each display vertex's collimated exit part follows the vertex's own light
    /// visibility (the gather's shadow lookup at the vertex; the CPU's ray), so a cast shadow's
    /// edge is as sharp as the display mesh; `off`, the source nodes' visibility (blurred over
    /// about a lattice spacing). One light and no environment only (otherwise off).
    /// `--own-visibility` alone is `on`. Default: see `defaults::DEFAULT_OWN_VISIBILITY`.
    #[arg(long, value_name = "on|off", value_parser = ["on", "off"], num_args = 0..=1, default_missing_value = "on")]
    pub own_visibility: Option<String>,
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
    /// Draw the diffusion's tangential flux toward the view (`ObjectParams::tangential_flux`): in
    /// P1 the radiance inside is (phi + 3 J . w) / (4 pi); the exit lobes draw the normal flux,
    /// this adds the part along the surface, -3 D grad_t phi . w_t / (4 pi) (from the screen
    /// gradient of the exitance per display vertex, `frame::TangentialPass`, D per vertex): a
    /// terminator seen from its lit side is darker, from its dark side brighter. GPU solver only
    /// (`--solver cpu` draws without it). Default: on
    /// (`translucent::defaults::TANGENTIAL_FLUX`; benches/RESULTS.md, "A
    /// smooth tangential flux (wave 9)"). `--tangential-flux` alone is `on`.
    #[arg(long, value_name = "on|off", value_parser = ["on", "off"], num_args = 0..=1, default_missing_value = "on")]
    pub tangential_flux: Option<String>,
    /// One bounce of exitance between display vertices (issue 12 item 5): light leaving the
    /// surface enters it again elsewhere (concave parts; eta = 1 outside). `local`: at bake time
    /// cosine-weighted rays per display vertex find the surface it sees (sparse form factors);
    /// per solve the pass `bounce` gathers E_b = sum F M and adds R_d E_b where it enters (no
    /// second solve). `local` is the default with `--method quadgraph` on the GPU (the links are
    /// stored with the bake: the next render of the mesh casts no ray; a convex mesh gets none
    /// without casting rays); `off`: no links, no pass, and the default of the other methods
    /// and of `--solver cpu` (benches/RESULTS.md, "One bounce between surface points");
    /// `source`: the bounces as `local`, then the last gathered E_b enters the surface nodes' q
    /// (T_d E_b, as diffuse light) and a second, warm-started solve carries it inside; its
    /// exitance replaces the local re-emission (benches/RESULTS.md, "Bounced light as a source
    /// of the solve").
    #[arg(long, value_name = "off|local|source", value_parser = ["off", "local", "source"])]
    pub bounce: Option<String>,
    /// Bounces per solve of `--bounce local` (1..=16): 1 is light that left the surface once and
    /// entered it again; each more lets it leave and enter again (a concave corner's
    /// interreflection: the back-lit plate's foot, benches/RESULTS.md "Thin walls: the plate's
    /// foot and interreflection"). Two dispatches over the display vertices each.
    #[arg(long, value_name = "N", default_value_t = translucent::defaults::BOUNCES)]
    pub bounces: u32,
    /// `--bounce source`'s second solve stops below this fraction of its start residual (the
    /// bounce's share of q; it starts from the first solve's solution) or at the solve's own
    /// tolerance; 0: the solve's tolerance alone (the full second solve). In [0, 1)
    /// (benches/RESULTS.md, "A cheaper bounce source").
    #[arg(long, value_name = "REL", default_value_t = translucent::defaults::BOUNCE_TOLERANCE)]
    pub bounce_tolerance: f32,
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
