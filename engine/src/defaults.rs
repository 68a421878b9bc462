//! The real-time defaults: what the library ([`ObjectParams::default`],
//! [`ObjectParams::for_material`]), `translucent render`, `translucent view` and `translucent
//! bench` run when nothing is named, in one place. The CLI's options start from [`Settings`] and
//! change only what the user names; what a command deliberately pins otherwise (bench's sweeps,
//! the viewer's one sample per pixel) is said in its help.
//!
//! The multigrid solves the rest pose only: an object that will be deformed
//! ([`crate::TranslucentObject::deform`]) takes [`Schedule::Cascade`] (`deform` otherwise returns
//! a typed error saying so).
//!
//! ```no_run
//! use translucent::defaults::{Schedule, Settings};
//! use translucent::material::{Material, MaterialField};
//! use translucent::solver::transport::Source;
//! use translucent::ObjectParams;
//!
//! let milk = MaterialField::Homogeneous(Material::new([0.7, 1.2, 1.9], [0.0014, 0.0025, 0.0142], 1.3)?);
//! let settings = Settings::for_material(&milk);
//! assert_eq!(settings.schedule, Schedule::Multigrid);
//! assert_eq!(settings.source, Source::SecondCollision);
//! // What `TranslucentObject::new(ctx, graph, &milk, scene, &params)` is given by default.
//! let params: ObjectParams = settings.object_params();
//! assert_eq!(Settings::of(&params), settings);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use crate::frame::{BounceMode, ScatterMode, ScatterParams};
use crate::material::{DiffusionCoefficient, MaterialField};
use crate::mesh::TriMesh;
use crate::object::ObjectParams;
use crate::quadgraph::surface_samples::surface_relief_degrees;
use crate::scene::ExitLobe;
use crate::solver::gpu::{GpuSolveParams, HeterogeneousWeights, Precision};
use crate::solver::multigrid::{MultigridParams, WarmStart};
use crate::solver::transport::{ExitQuery, Source, SurfaceReconstruction};
use crate::solver::Scheme;

/// The relative error (cascade: estimated per level; multigrid: relative residual) a solve stops
/// at.
pub const TOLERANCE: f64 = 1e-4;
/// The cascade's cap on Jacobi iterations per level (it stops earlier at [`TOLERANCE`]).
pub const CASCADE_ITERATIONS: u32 = 2000;
/// Depths per view ray of the single-scattering march (DESIGN 2.8).
pub const SCATTER_SAMPLES: u32 = 8;
/// Samples per output pixel side of `translucent render`'s headless host (anti-aliasing:
/// benches/RESULTS.md, "Anti-aliasing"). A host (the viewer, Bevy, wgpu) draws its own pixels:
/// the library has no supersampling, so their equivalent render commands name `--supersample 1`.
pub const SUPERSAMPLE: u32 = 2;
/// `translucent render`'s tangential flux toward the view
/// ([`crate::object::ObjectParams::tangential_flux`], the smooth per-vertex gradient with D per
/// vertex): better or level within 0.1 point on every reference (benches/RESULTS.md, "A smooth
/// tangential flux (wave 9)" and "Lead notes after the wave-9 merge": the split volume 9.0 ->
/// 7.8 once heterogeneous materials took the second-collision source); off in
/// [`crate::object::ObjectParams`]'s own default (the library's image tests keep their bounds).
pub const TANGENTIAL_FLUX: bool = true;

/// The exit lobe of render, view, bench and the library's real-time defaults
/// ([`Settings::object_params`], [`ObjectParams::for_material`]; `--exit-lobe`;
/// [`ObjectParams::default`] keeps DESIGN 2.6's Lambert, as it keeps the tangential flux off, so
/// the library's image tests keep their bounds):
/// the node lobe (P1 for diffused light) with each node's own light drawn by Chandrasekhar's
/// half-space law at eta 1, the bounce's light Lambertian ([`ExitLobe::with_bounce`]). Against
/// the 13 path-traced references (benches/RESULTS.md, "The Chandrasekhar exit lobe as the
/// default"): marble front 4.8 -> 2.5, plate 19.7 -> 15.2, torus 9.0 -> 7.9, 10 of 13 better or
/// level; the U-block worse (front 9.1 -> 10.3, back 15.1 -> 17.8) where its display vertices are
/// shared across the 90-degree edges (with the faces' vertices split: back 12.9 Lambert, 12.7
/// chandra).
pub const EXIT_LOBE: ExitLobe = ExitLobe::Chandra;

/// The light source for homogeneous materials (benches/RESULTS.md, "Model terms on the GPU (wave
/// 5)": against the path-traced references the second-collision source is better than the
/// boundary flux on six scenes of seven and level on the seventh).
pub const HOMOGENEOUS_SOURCE: Source = Source::SecondCollision;
/// The light source for heterogeneous materials: the homogeneous one (benches/RESULTS.md, "The
/// split .vol sphere, decomposed (wave 9)": the boundary flux made the skim milk | skin1 sphere
/// 16.7% off its path-traced reference against 10.0% with the second-collision source, whose
/// regions then match the homogeneous skin1 sphere's ratios within 1-2%). The agate's blue that
/// differed between its 24^3 `.vol` grid and the procedural field (22% in wave 5, 7.4% now) is
/// the grid's blur of its 2 mm bands near albedo 2/3: 665.9, 647.7, 628.1 at 24^3, 48^3, 96^3
/// against 620.2 procedural, so it converges with the grid.
pub const HETEROGENEOUS_SOURCE: Source = Source::SecondCollision;
/// The upstream beam with a beam source (`transport::upstream_beam`, each surface node's beam
/// taken from upstream on the curved surface; benches/RESULTS.md, "The upstream beam on the
/// GPU": 11 of 13 references better, the back-lit marble sphere 18.4 -> 9.8 %, the back-lit
/// U-block 18.7 -> 21.7 and the front-lit bunny 11.9 -> 12.4 worse).
pub const UPSTREAM_BEAM: bool = true;
/// A display vertex's lit beam sources at its own light visibility where below its source
/// nodes' (render `--own-visibility`; `solver::transport::Transport::own_visibility`;
/// benches/RESULTS.md, "Shadow edges on the front-lit bunny (wave 13)": front-lit bunny 8.02 ->
/// 7.65%, side-lit 9.80 -> 9.88%, the other eleven references unchanged).
pub const OWN_VISIBILITY: bool = true;
/// The upstream beam's curved particular solution (`transport::Transport::curved_particular`:
/// irradiance factor mu_up, the volume's narrowing and the lateral terms in K, in full on an
/// umbilic node and faded to wave 8's area factor where the principal curvatures differ,
/// `transport::SurfaceCurvature::umbilic_share`; benches/RESULTS.md, "The curved particular
/// solution on non-spherical surfaces": the front-lit milk sphere 5.53 -> 3.35 %, marble 2.45 ->
/// 1.97, the bunny side 9.80 -> 9.98 and the back-lit marble sphere 6.74 -> 7.18 worse).
pub const CURVED_PARTICULAR: bool = true;
/// One bounce of exitance between display vertices for the QuadGraph method (benches/RESULTS.md,
/// "One bounce between surface points": 4-8 points off every concave scene against path tracing,
/// the convex sphere unchanged, < 1 ms a frame; its links are stored with the bake, a convex mesh
/// gets none without casting rays). An object takes the links its graph carries
/// ([`crate::QuadGraph::bounce`]); a graph without links renders without the bounce.
pub const BOUNCE: BounceMode = BounceMode::Local;
/// Bounces per new exitance of that pass (`render --bounces`; benches/RESULTS.md, "Thin walls:
/// the plate's foot and interreflection"): 1 is light that left the surface once and entered it
/// again. 4 against 1 on the 13 path-traced references: plate 29.3 -> 24.8, U-block back 18.7 ->
/// 12.9, front 11.4 -> 10.0, torus back 18.4 -> 17.9, bunny side 15.3 -> 15.0, none worse; 8
/// bounces change the plate by 0.1 (the series has converged), each costs two dispatches over
/// the display vertices.
pub const BOUNCES: u32 = 4;
/// `--bounce source`'s second solve (`render --bounce-tolerance`; benches/RESULTS.md, "A cheaper
/// bounce source"): it starts from the first solve's solution, so its start residual is the
/// bounce's share of q; it stops below this fraction of that residual (or at the solve's own
/// tolerance, whichever comes first). 0: the solve's tolerance alone (the full second solve).
pub const BOUNCE_TOLERANCE: f32 = 1e-2;
/// The QuadGraph method's diffusion coefficient (benches/RESULTS.md, "Diffusion coefficient at
/// low albedo": against the path-traced references Grosjean's D is level or better on every
/// scene with the Shepard surface; it differs from 1 / (3 sigma_t') only at low albedo). The
/// voxel and dipole methods keep 1 / (3 sigma_t').
pub const DIFFUSION: DiffusionCoefficient = DiffusionCoefficient::Grosjean;

/// Where the multigrid's warm start starts (benches/RESULTS.md, "Warm start from extrapolated
/// solutions (wave 7)"): the solution extrapolated through the last two frames' solutions
/// (a light moving steadily); the first warm frame after a cold one starts from the last.
pub const WARM_START: WarmStart = WarmStart::Linear;

/// [`surface_for`]: the interior reconstruction where a channel's diffusion length 1/s is
/// shorter than this many finest spacings' inverse, i.e. s * spacing above it (issue 12 item 4,
/// benches/RESULTS.md "Surface auto and the curved profile"): there the Shepard interpolation of
/// the surface nodes' J+ draws the lattice (skin1's per-pixel CV 5-26% in green and blue, ketchup's
/// blotches and clamped channels; s * spacing 0.85-1.2 at the auto resolution) while the interior
/// one is flat and within 0.4% of the sphere's closed form. Below it (marble, milk: 0.1-0.25)
/// both are flat to 0.6% and Shepard is closer to the path-traced back-lit references (2-4 points).
pub const INTERIOR_ABOVE_S_SPACING: f64 = 0.5;

/// [`surface_for`]: the interior reconstruction where the display surface's relief finer than
/// [`RELIEF_SPACINGS`] finest spacings ([`surface_relief_degrees`], an area-weighted median)
/// exceeds this many degrees (issue 12, benches/RESULTS.md "The bunny, region by region"). Each
/// surface node takes its source cosine with the scan's face normal at one point, so Shepard
/// draws a scan's bumps sampled once per node: on the front-lit bunny (relief 6.5 degrees)
/// 10.4 of its 12.3 points are detail finer than 4 pixels, correlated 0.60 with the path
/// tracer's (the interior reconstruction, which averages the sources over 1.5 spacings: 0.90),
/// and the interior one takes the bunny front 12.3 -> 8.4, side 13.9 -> 12.9. Below it stay the smooth analytic
/// shapes (< 0.2 degrees), the flat-faced U-block and plate (0), where Shepard is 1.1 and 3.7
/// points closer to the back-lit references, the fandisk (7.5% with Shepard against a
/// 1024-spp reference, 8.1% interior) and the cheburashka at its auto spacing (9.9% Shepard,
/// 8.1% interior: a case the rule misses).
pub const INTERIOR_ABOVE_RELIEF_DEGREES: f64 = 5.5;
/// The radius of [`surface_for`]'s relief in finest spacings: the interior samples' own normal
/// smoothing ([`crate::quadgraph::surface_samples::NORMAL_SPACINGS`]).
pub const RELIEF_SPACINGS: f64 = crate::quadgraph::surface_samples::NORMAL_SPACINGS;

/// The display surface's reconstruction for `field` on `surface` (the display mesh, mm) with a
/// finest lattice of `spacing_mm`: the interior one where the largest s = sqrt(sigma_a / D) of the
/// material's channels times the spacing exceeds [`INTERIOR_ABOVE_S_SPACING`] or the surface's
/// relief finer than the lattice exceeds [`INTERIOR_ABOVE_RELIEF_DEGREES`], Shepard otherwise. A
/// `.vol` grid takes its cells' largest s (the skim milk | skin1 split sphere: skin1's, as the
/// homogeneous skin1 sphere; with the second-collision source interior is 0.4 points closer to its
/// reference than Shepard and draws no lattice rings on the skin1 cap: benches/RESULTS.md, "The
/// split .vol sphere, decomposed (wave 9)"); a procedural field keeps Shepard (not measured).
///
/// ```
/// use translucent::defaults::surface_for;
/// use translucent::material::{Material, MaterialField};
/// use translucent::mesh::shapes::Shape;
/// use translucent::solver::transport::SurfaceReconstruction;
/// let marble = MaterialField::Homogeneous(Material::preset("marble").unwrap());
/// let sphere = Shape::Sphere { radius: 10.0 }.triangulate(64);
/// assert_eq!(surface_for(&marble, &sphere, 0.83), SurfaceReconstruction::Shepard);
/// ```
pub fn surface_for(
    field: &MaterialField,
    surface: &TriMesh,
    spacing_mm: f64,
) -> SurfaceReconstruction {
    let Some(largest_s) = largest_s(field) else {
        return SurfaceReconstruction::Shepard;
    };
    if largest_s * spacing_mm > INTERIOR_ABOVE_S_SPACING
        || surface_relief_degrees(surface, RELIEF_SPACINGS * spacing_mm)
            > INTERIOR_ABOVE_RELIEF_DEGREES
    {
        SurfaceReconstruction::Interior
    } else {
        SurfaceReconstruction::Shepard
    }
}

/// The interior surface samples' depth (finest spacings, `BakeParams::sample_depth`) for
/// `field` on a finest lattice of `spacing_mm`: [`SHALLOW_SAMPLE_DEPTH`] where the largest s of
/// the material's channels times the spacing is at most [`INTERIOR_ABOVE_S_SPACING`] (the
/// lattice does not show in a shallower sample: a diffusion length of two spacings or more),
/// [`crate::quadgraph::surface_samples::DEPTH_SPACINGS`] otherwise and for a procedural field.
///
/// ```
/// use translucent::defaults::{sample_depth_for, SHALLOW_SAMPLE_DEPTH};
/// use translucent::material::{Material, MaterialField};
/// use translucent::quadgraph::surface_samples::DEPTH_SPACINGS;
/// let marble = MaterialField::Homogeneous(Material::preset("marble").unwrap());
/// let skin1 = MaterialField::Homogeneous(Material::preset("skin1").unwrap());
/// assert_eq!(sample_depth_for(&marble, 0.83), SHALLOW_SAMPLE_DEPTH);
/// assert_eq!(sample_depth_for(&skin1, 0.83), DEPTH_SPACINGS);
/// ```
pub fn sample_depth_for(field: &MaterialField, spacing_mm: f64) -> f64 {
    match largest_s(field) {
        Some(s) if s * spacing_mm <= INTERIOR_ABOVE_S_SPACING => SHALLOW_SAMPLE_DEPTH,
        _ => crate::quadgraph::surface_samples::DEPTH_SPACINGS,
    }
}

/// [`sample_depth_for`]'s depth where the lattice does not show in the sample (wave 13, issue
/// 12; benches/RESULTS.md "A shallower interior sample with the lateral term"): the profile
/// carries the sample to the surface with a lateral term estimated over three spacings, whose
/// error grows with depth^2; at 1.0 spacings the front-lit / side-lit marble bunny measure
/// 8.02 -> 7.82 / 9.80 -> 8.97% against path tracing (0.875: 7.85 / 8.81, 1.25: 7.85 / 9.36).
/// Where s * spacing is near 1 (skin1's blue) the sample's 16 nodes draw the lattice when it
/// is shallower: its per-pixel CV under a constant environment is 1.67% at 1.0 spacings, 1.09%
/// at 1.25, 0.56% at 1.5 (the issue's bound: 1%), so those keep 1.5.
pub const SHALLOW_SAMPLE_DEPTH: f64 = 1.0;

/// The largest s = sqrt(sigma_a / D) of `field`'s channels (of its cells for a `.vol` grid);
/// `None` for a procedural field.
fn largest_s(field: &MaterialField) -> Option<f64> {
    let diffusion = field.diffusion();
    let channels_s = |sigma_s: [f64; 3], sigma_a: [f64; 3]| {
        (0..3)
            .map(|c| {
                crate::solver::transport::Optics {
                    sigma_s: sigma_s[c],
                    sigma_a: sigma_a[c],
                    diffusion,
                }
                .s()
            })
            .filter(|s| s.is_finite())
            .fold(0.0, f64::max)
    };
    let largest_s = match field {
        MaterialField::Homogeneous(m) => channels_s(m.sigma_s, m.sigma_a),
        MaterialField::Grid { grid, .. } => grid
            .data
            .chunks_exact(crate::material::vol::VOL_CHANNELS)
            .map(|cell| {
                let f = |i: usize| f64::from(cell[i]);
                channels_s([f(0), f(1), f(2)], [f(3), f(4), f(5)])
            })
            .fold(0.0, f64::max),
        MaterialField::Procedural { .. } => return None,
    };
    Some(largest_s)
}

/// How the levels are used (DESIGN 5.1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Schedule {
    /// The paper's: Jacobi per level, coarsest first, capped by
    /// [`Settings::cascade_iterations`].
    Cascade,
    /// Full multigrid + CG-accelerated V-cycles to the relative residual (the default: measured
    /// faster than the cascade, benches/RESULTS.md "GPU multigrid with CG, and the default
    /// schedule").
    Multigrid,
}

impl Schedule {
    pub fn name(self) -> &'static str {
        match self {
            Schedule::Cascade => "cascade",
            Schedule::Multigrid => "multigrid",
        }
    }
}

/// The settings a frame resolves to: the solve's and the single-scattering pass's, as plain data
/// that can be compared across the commands (`translucent render --json` reports the same).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    pub schedule: Schedule,
    pub source: Source,
    /// How exitance is read: the moments query with a beam source (DESIGN 2.6-2.7), the
    /// boundary-flux query with the boundary flux.
    pub exit: ExitQuery,
    pub scheme: Scheme,
    pub precision: Precision,
    pub tolerance: f64,
    /// The cascade's cap per level (unused by multigrid).
    pub cascade_iterations: u32,
    pub surface: SurfaceReconstruction,
    pub heterogeneous_weights: HeterogeneousWeights,
    /// `None`: the single-scattering pass is not recorded.
    pub single_scattering: Option<ScatterParams>,
    /// One bounce between display vertices ([`crate::frame::bounce`]): [`BOUNCE`] for the
    /// QuadGraph method, off for the others.
    pub bounce: BounceMode,
    /// The multigrid's warm start ([`WARM_START`]; unused by the cascade).
    pub warm_start: WarmStart,
    /// The diffusion coefficient D the solve, its sources, the exit query and the bounce use:
    /// [`DIFFUSION`] for the QuadGraph method, classical for the others (which read none).
    pub diffusion: DiffusionCoefficient,
    /// The upstream beam ([`UPSTREAM_BEAM`] with a beam source, off with the boundary flux).
    pub upstream_beam: bool,
    /// Its curved particular solution ([`CURVED_PARTICULAR`] with the upstream beam, else off).
    pub curved_particular: bool,
}

impl Settings {
    /// The real-time defaults for a homogeneous (`true`) or heterogeneous material.
    pub fn realtime(homogeneous: bool) -> Settings {
        let source = if homogeneous {
            HOMOGENEOUS_SOURCE
        } else {
            HETEROGENEOUS_SOURCE
        };
        Settings {
            schedule: Schedule::Multigrid,
            source,
            exit: exit_for(source),
            scheme: Scheme::Fv,
            precision: Precision::Mixed,
            tolerance: TOLERANCE,
            cascade_iterations: CASCADE_ITERATIONS,
            surface: SurfaceReconstruction::Shepard,
            heterogeneous_weights: HeterogeneousWeights::Derived,
            single_scattering: Some(scatter_for(source, SCATTER_SAMPLES, true)),
            bounce: BOUNCE,
            warm_start: WARM_START,
            diffusion: DIFFUSION,
            upstream_beam: UPSTREAM_BEAM && source != Source::BoundaryFlux,
            curved_particular: CURVED_PARTICULAR && UPSTREAM_BEAM && source != Source::BoundaryFlux,
        }
    }

    /// The real-time defaults for `field`.
    pub fn for_material(field: &MaterialField) -> Settings {
        Settings::realtime(field.is_homogeneous())
    }

    /// The real-time defaults for `method` on a homogeneous (`true`) or heterogeneous material:
    /// the QuadGraph's are
    /// [`Settings::for_material`]'s; the voxel and dipole methods read no light source from the
    /// solve (their exitance carries the once-scattered light as the boundary flux does), so
    /// single scattering is added to theirs as the difference to the flat closed form.
    pub fn for_method(method: crate::frame::MethodKind, homogeneous: bool) -> Settings {
        let settings = Settings::realtime(homogeneous);
        match method {
            crate::frame::MethodKind::QuadGraph => settings,
            _ => Settings {
                bounce: BounceMode::Off,
                diffusion: DiffusionCoefficient::Classical,
                ..settings.with_source(Source::BoundaryFlux)
            },
        }
    }

    /// These settings with the light source `source`, the exit query, the upstream beam and the
    /// single-scattering mode that go with it (the march whole with the second-collision source, else as the
    /// difference to the flat closed form).
    pub fn with_source(self, source: Source) -> Settings {
        Settings {
            source,
            exit: exit_for(source),
            single_scattering: self
                .single_scattering
                .map(|s| scatter_for(source, s.samples, s.skip_front_lit)),
            upstream_beam: UPSTREAM_BEAM && source != Source::BoundaryFlux,
            curved_particular: CURVED_PARTICULAR && UPSTREAM_BEAM && source != Source::BoundaryFlux,
            ..self
        }
    }

    /// The schedule these settings fall back to when `precision` is fp16 (phi in fp16 cannot
    /// keep the cycles' corrections) or the scheme is the paper's (not symmetric, which the CG
    /// around the V-cycle assumes): the cascade.
    pub fn schedule_allowed(&self) -> Schedule {
        if self.precision == Precision::Fp16 || self.scheme == Scheme::Paper {
            Schedule::Cascade
        } else {
            self.schedule
        }
    }

    /// The GPU solve's parameters.
    pub fn solve_params(&self) -> GpuSolveParams {
        let beam = self.source != Source::BoundaryFlux;
        GpuSolveParams {
            scheme: self.scheme,
            precision: self.precision,
            iterations: vec![self.cascade_iterations],
            tolerance: self.tolerance as f32,
            exit: self.exit,
            collimated: beam,
            second_collision: self.source == Source::SecondCollision,
            upstream_beam: beam && self.upstream_beam,
            curved_particular: beam && self.upstream_beam && self.curved_particular,
            surface: self.surface,
            heterogeneous_weights: self.heterogeneous_weights,
            multigrid: (self.schedule == Schedule::Multigrid).then(|| MultigridParams {
                tolerance: self.tolerance,
                warm_start: self.warm_start,
                ..MultigridParams::gpu()
            }),
            ..GpuSolveParams::default()
        }
    }

    /// The object's parameters (formats, specular and skipping at their defaults).
    pub fn object_params(&self) -> ObjectParams {
        ObjectParams {
            solve: self.solve_params(),
            single_scattering: self.single_scattering,
            bounce: self.bounce,
            diffusion: self.diffusion,
            exit_lobe: EXIT_LOBE,
            ..ObjectParams::base()
        }
    }

    /// What `params` resolve to (the inverse of [`Settings::object_params`] on these fields).
    pub fn of(params: &ObjectParams) -> Settings {
        let s = &params.solve;
        Settings {
            schedule: if s.multigrid.is_some() {
                Schedule::Multigrid
            } else {
                Schedule::Cascade
            },
            source: match (s.collimated, s.second_collision) {
                (false, _) => Source::BoundaryFlux,
                (true, false) => Source::Collimated,
                (true, true) => Source::SecondCollision,
            },
            exit: s.exit,
            scheme: s.scheme,
            precision: s.precision,
            tolerance: s
                .multigrid
                .as_ref()
                .map_or(f32_decimal(s.tolerance), |m| m.tolerance),
            cascade_iterations: s.iterations.first().copied().unwrap_or(0),
            surface: s.surface,
            heterogeneous_weights: s.heterogeneous_weights,
            single_scattering: params.single_scattering,
            bounce: params.bounce,
            warm_start: s.multigrid.as_ref().map_or(WARM_START, |m| m.warm_start),
            diffusion: params.diffusion,
            upstream_beam: s.upstream_beam,
            curved_particular: s.curved_particular,
        }
    }
}

impl Default for Settings {
    /// [`Settings::realtime`] for a homogeneous material.
    fn default() -> Self {
        Settings::realtime(true)
    }
}

/// An f32 setting (the GPU's tolerance) as the shortest decimal that reads back as it, in f64:
/// 1e-4 stays 1e-4 (not 9.99999975e-5), so settings typed as text compare equal whether a
/// command keeps them as f32 or f64.
pub fn f32_decimal(value: f32) -> f64 {
    value.to_string().parse().unwrap_or(f64::from(value))
}

/// The exit query a source is read with (a beam source implies the moments query, DESIGN 2.7).
pub fn exit_for(source: Source) -> ExitQuery {
    match source {
        Source::BoundaryFlux => ExitQuery::Classic,
        Source::Collimated | Source::SecondCollision => ExitQuery::Moments,
    }
}

/// The single-scattering pass's parameters for `source`: the march whole with the
/// second-collision source (the once-scattered light is the march's alone), else the
/// difference to the flat closed form.
pub fn scatter_for(source: Source, samples: u32, skip_front_lit: bool) -> ScatterParams {
    ScatterParams {
        samples,
        skip_front_lit,
        mode: if source == Source::SecondCollision {
            ScatterMode::Full
        } else {
            ScatterMode::Difference
        },
        // The gather's environment is a boundary flux: its once-scattered light is in the
        // diffusion already (ScatterParams::environment).
        environment: false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `.vol` grid takes the surface rule from its cells: the skim milk | skin1 split of the
    /// path-traced reference gets skin1's interior (s x spacing 0.88 in blue at render's auto
    /// spacing 0.69 mm, Grosjean's D), a uniform marble grid marble's Shepard (0.17).
    #[test]
    fn the_surface_rule_reads_a_volume_grids_cells() {
        use crate::material::{Material, VolGrid};
        use glam::DVec3;
        let (milk, skin1) = (
            Material::preset("skimmilk").unwrap(),
            Material::preset("skin1").unwrap(),
        );
        let (lo, hi) = (DVec3::splat(-10.0), DVec3::splat(10.0));
        let split = VolGrid::from_fn([1, 2, 1], lo, hi, |p| {
            let m = if p.y < 0.0 { &milk } else { &skin1 };
            (m.sigma_s, m.sigma_a)
        })
        .unwrap();
        let marble = Material::preset("marble").unwrap();
        let uniform =
            VolGrid::from_fn([1, 2, 1], lo, hi, |_| (marble.sigma_s, marble.sigma_a)).unwrap();
        let field = |grid| {
            MaterialField::grid(grid, 1.0)
                .unwrap()
                .with_diffusion(DIFFUSION)
        };
        let spacing_mm = 0.69;
        let sphere = crate::mesh::shapes::Shape::Sphere { radius: 10.0 }.triangulate(64);
        assert_eq!(
            surface_for(&field(split.clone()), &sphere, spacing_mm),
            SurfaceReconstruction::Interior
        );
        assert_eq!(
            surface_for(&field(uniform.clone()), &sphere, spacing_mm),
            SurfaceReconstruction::Shepard
        );
        assert_eq!(
            surface_for(
                &MaterialField::Homogeneous(skin1.with_diffusion(DIFFUSION)),
                &sphere,
                spacing_mm
            ),
            SurfaceReconstruction::Interior
        );
        // The sample depth follows the same s * spacing: the split sphere and skin1 keep the
        // deep sample (their lattice would show), the marble grid and marble take the shallow
        // one; a lattice coarse enough to put marble above the threshold takes the deep one.
        use crate::quadgraph::surface_samples::DEPTH_SPACINGS;
        let homogeneous = |m: &Material| MaterialField::Homogeneous(m.with_diffusion(DIFFUSION));
        assert_eq!(sample_depth_for(&field(split), spacing_mm), DEPTH_SPACINGS);
        assert_eq!(
            sample_depth_for(&homogeneous(&skin1), spacing_mm),
            DEPTH_SPACINGS
        );
        assert_eq!(
            sample_depth_for(&field(uniform), spacing_mm),
            SHALLOW_SAMPLE_DEPTH
        );
        assert_eq!(
            sample_depth_for(&homogeneous(&marble), spacing_mm),
            SHALLOW_SAMPLE_DEPTH
        );
        assert_eq!(
            sample_depth_for(&homogeneous(&marble), 10.0),
            DEPTH_SPACINGS
        );
    }

    #[test]
    fn object_params_read_back_as_the_settings() {
        for homogeneous in [true, false] {
            let s = Settings::realtime(homogeneous);
            assert_eq!(Settings::of(&s.object_params()), s);
            let cascade = Settings {
                schedule: Schedule::Cascade,
                ..s
            }
            .with_source(Source::Collimated);
            assert_eq!(Settings::of(&cascade.object_params()), cascade);
        }
    }

    #[test]
    fn the_library_default_is_the_homogeneous_realtime_default() {
        assert_eq!(
            Settings::of(&ObjectParams::default()),
            Settings::realtime(true)
        );
        assert_eq!(Settings::realtime(true).source, Source::SecondCollision);
        assert_eq!(Settings::realtime(false).source, Source::SecondCollision);
        assert_eq!(Settings::realtime(false).schedule, Schedule::Multigrid);
        // render's QuadGraph D is the library's (it was render's alone before).
        assert_eq!(ObjectParams::default().diffusion, DIFFUSION);
        assert_eq!(DIFFUSION, DiffusionCoefficient::Grosjean);
        assert_eq!(
            Settings::for_method(crate::frame::MethodKind::Voxel, true).diffusion,
            DiffusionCoefficient::Classical
        );
    }

    /// The bunny's finest spacing at render's auto resolution (mm).
    const BUNNY_SPACING_MM: f64 = 0.833;

    /// A 10 mm sphere with bumps finer than the lattice: radial displacements of
    /// `amplitude` mm varying every vertex or so (a scan's relief, as the bunny's).
    fn bumpy_sphere(amplitude: f64) -> TriMesh {
        let mut mesh = crate::mesh::shapes::Shape::Sphere { radius: 10.0 }.triangulate(160);
        for (i, p) in mesh.positions.iter_mut().enumerate() {
            // A hash of the vertex index: no structure at the lattice's scale.
            let h =
                ((i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 40) as f64 / (1u64 << 24) as f64;
            *p *= 1.0 + amplitude * (2.0 * h - 1.0) / 10.0;
        }
        mesh.compute_normals();
        mesh
    }

    #[test]
    fn a_surface_with_relief_finer_than_the_lattice_takes_the_interior_reconstruction() {
        let marble =
            MaterialField::Homogeneous(crate::material::Material::preset("marble").unwrap());
        let shapes = crate::mesh::shapes::Shape::Box {
            half_extents: glam::DVec3::new(10.0, 5.0, 3.0),
        };
        let radius = RELIEF_SPACINGS * BUNNY_SPACING_MM;
        let smooth = crate::mesh::shapes::Shape::Sphere { radius: 10.0 }.triangulate(160);
        // A finely tessellated sphere is resolved by the lattice; a box's sharp edges are a
        // small share of its area; a bumpy sphere is not resolved.
        assert!(surface_relief_degrees(&smooth, radius) < 0.5);
        assert!(
            surface_relief_degrees(&shapes.triangulate(32), radius) < INTERIOR_ABOVE_RELIEF_DEGREES
        );
        assert!(
            surface_relief_degrees(&bumpy_sphere(0.15), radius) > INTERIOR_ABOVE_RELIEF_DEGREES
        );
        // Marble's s * spacing alone keeps Shepard: the relief decides.
        assert_eq!(
            surface_for(&marble, &smooth, BUNNY_SPACING_MM),
            SurfaceReconstruction::Shepard
        );
        assert_eq!(
            surface_for(&marble, &bumpy_sphere(0.15), BUNNY_SPACING_MM),
            SurfaceReconstruction::Interior
        );
        assert_eq!(surface_relief_degrees(&TriMesh::default(), radius), 0.0);
    }
}
