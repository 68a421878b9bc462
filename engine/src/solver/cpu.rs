//! The f64 CPU reference solve of a baked QuadGraph: the project's ground truth for the GPU frame.
//!
//! Per level, coarsest first (paper section 4.3, Fig. 9): assemble the system, gather q at the
//! surface nodes, initialise phi (zero or a guess on the coarsest level; Shepard resampling from the
//! coarser level, paper Eq. 10, above it), iterate Jacobi. With `exact`, the finest level is then
//! solved to a relative residual of 1e-10 (PCG for `fv`, BiCGSTAB for `paper`).
//! Then J+ = (1 + 1/A) phi / 4 - q / (1 + F_dr) at the surface nodes, clamped at zero for display
//! (strong absorbers such as ketchup's green and blue give J+ < 0 in this model; the count is reported),
//! interpolated to the display mesh's vertices, and the energy balance.
//!
//! ```
//! use glam::DVec3;
//! use translucent::material::{Material, MaterialField};
//! use translucent::solver::{self, CpuSolveParams};
//! use translucent::scene::{Environment, Scene};
//! use translucent::{tet::TetMesh, GraphLevel, QuadGraph};
//! let level = GraphLevel::from_tets(TetMesh::bcc_box(DVec3::splat(-5.0), DVec3::splat(5.0), [5, 5, 5]), 2.0, |c, n| (c, n));
//! let graph = QuadGraph { levels: vec![level], ..Default::default() };
//! let field = MaterialField::Homogeneous(Material::preset("marble")?);
//! let scene = Scene { lights: vec!["dir:0,-1,0:1,1,1".parse()?], environment: Environment::Constant([0.2; 3]) };
//! let sol = solver::solve(&graph, &field, &scene, None, &CpuSolveParams::default())?;
//! assert!(sol.residual.iter().all(|&r| r < 1e-9));
//! let e = sol.energy;
//! for c in 0..3 { // the fv scheme conserves energy exactly
//!     assert!((e.transmitted_input[c] - e.exitance[c] - e.absorbed[c]).abs() < 1e-6 * e.transmitted_input[c]);
//! }
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod surface;
use surface::shade_sources;
pub use surface::{
    interior_vertices, own_visibility_sources, reconstruct_vertices, OwnVisibility,
    OWN_VISIBILITY_LIT,
};

use rayon::prelude::*;

use glam::DVec3;

use super::krylov::{self, KrylovReport};
use super::multigrid::{Hierarchy, MultigridParams, MultigridReport, Start};
use super::operator::{check_level, LevelOperator, Scheme};
use super::sources::{LocalSource, SourceModel};
use super::transport::{
    lateral_lambda, lateral_profile_from_sample, sample_on_lateral_profile, Boundary, Optics,
    Source, SurfaceReconstruction, Transport,
};
use super::SolverError;
use crate::material::{fresnel, MaterialField};
use crate::mesh::Solid;
use crate::quadgraph::graph::{GraphLevel, QuadGraph, ShepardLinks, NO_NODE};
use crate::scene::{ExitLobe, RadianceMode, Scene};

/// Outgoing radiance at a surface point with outgoing current `j_plus`, viewed at `cos_o` to the
/// normal (outside). Negative J+ gives zero radiance.
pub fn radiance(j_plus: [f64; 3], eta: f64, cos_o: f64, mode: RadianceMode) -> [f64; 3] {
    radiance_with_lobe(j_plus, eta, cos_o, mode, ExitLobe::Lambert)
}

/// [`radiance`] with the exit lobe `lobe` (`shade_mesh.frag`'s formula in f64).
pub fn radiance_with_lobe(
    j_plus: [f64; 3],
    eta: f64,
    cos_o: f64,
    mode: RadianceMode,
    lobe: ExitLobe,
) -> [f64; 3] {
    radiance_with_lobe_at(j_plus, eta, cos_o, mode, lobe, 1.0)
}

/// [`radiance_with_lobe`] at a vertex of diffused share `share` (the per-node lobe,
/// [`ExitLobe::Node`]; the other lobes ignore it).
pub fn radiance_with_lobe_at(
    j_plus: [f64; 3],
    eta: f64,
    cos_o: f64,
    mode: RadianceMode,
    lobe: ExitLobe,
    share: f64,
) -> [f64; 3] {
    let ft = fresnel::transmittance(eta, cos_o) * lobe.factor_at(eta, cos_o, share);
    let k = match mode {
        RadianceMode::Physical => ft / (std::f64::consts::PI * eta * eta),
        RadianceMode::Paper => ft / std::f64::consts::PI,
    };
    j_plus.map(|j| k * j.max(0.0))
}

/// [`radiance_with_lobe_at`] with the own light's shape ([`ExitLobe::Chandra`]): `own` what
/// lights the point ([`crate::scene::own_lobe::OwnLight::at`]), `omega` the albedo per channel
/// ([`crate::scene::own_lobe::surface_albedo`]); the other lobes ignore both.
#[allow(
    clippy::too_many_arguments,
    reason = "the shading's inputs, one per formula term"
)]
pub fn radiance_lit(
    j_plus: [f64; 3],
    eta: f64,
    cos_o: f64,
    mode: RadianceMode,
    lobe: ExitLobe,
    share: f64,
    own: &crate::scene::own_lobe::OwnLight,
    omega: [f64; 3],
) -> [f64; 3] {
    let ft = fresnel::transmittance(eta, cos_o);
    let k = match mode {
        RadianceMode::Physical => ft / (std::f64::consts::PI * eta * eta),
        RadianceMode::Paper => ft / std::f64::consts::PI,
    };
    let g = lobe.factor_lit(eta, cos_o, share, own, omega);
    std::array::from_fn(|c| k * g[c] * j_plus[c].max(0.0))
}

/// Parameters of [`solve`].
#[derive(Clone, Debug)]
pub struct CpuSolveParams {
    pub scheme: Scheme,
    /// Jacobi iterations per level, coarsest first; the last entry repeats for further levels.
    pub iterations: Vec<usize>,
    /// Jacobi stops on a level once its estimated relative error, (max|dphi| / max|phi|) / (1 - rho)
    /// with rho the measured contraction per iteration (DESIGN section 5), is below this.
    pub tolerance: f64,
    /// Solve the finest level exactly (to `exact_tolerance`) after the Jacobi levels.
    pub exact: bool,
    /// Relative residual that defines "converged" for the exact solve.
    pub exact_tolerance: f64,
    pub exact_max_iterations: usize,
    /// Initial phi on the coarsest level (node order of that level); zero when `None`. With
    /// [`Schedule::Multigrid`]: the finest level's previous solution (a warm start).
    pub initial: Option<Vec<[f64; 3]>>,
    /// The transport terms (issue 12): exit query, source, continuation through thin walls, the
    /// surface reconstruction, one bounce. The default is the model of DESIGN section 2 (what
    /// the GPU frame computes). Single scattering is view-dependent: [`super::single_scattering`].
    pub transport: Transport,
    /// How the levels are used: the paper's one-way cascade (default here) or multigrid cycles.
    pub schedule: Schedule,
}

/// How a solve uses the levels (DESIGN section 5.1).
#[derive(Clone, Debug, Default, PartialEq)]
pub enum Schedule {
    /// The paper's cascade: Jacobi per level, coarsest first, each level started from the coarser
    /// one's Shepard resampling; then, with [`CpuSolveParams::exact`], PCG on the finest level.
    #[default]
    Cascade,
    /// Multigrid cycles ([`super::multigrid`]): full multigrid from nothing, or V-cycles from
    /// [`CpuSolveParams::initial`] when it holds a finest-level solution (a warm start). They stop
    /// at the multigrid tolerance, or at [`CpuSolveParams::exact_tolerance`] with `exact`.
    /// `iterations` and `tolerance` (the cascade's) are not used.
    Multigrid(MultigridParams),
}

impl Default for CpuSolveParams {
    fn default() -> Self {
        Self {
            scheme: Scheme::Fv,
            iterations: vec![200],
            tolerance: 1e-4,
            exact: true,
            exact_tolerance: 1e-10,
            exact_max_iterations: 100_000,
            initial: None,
            transport: Transport::default(),
            schedule: Schedule::Cascade,
        }
    }
}

/// Energy per channel (DESIGN section 8's `energy`): sum q dA, sum (1 - F_dr) J+ dA over the
/// surface nodes (dA = face area) and sum mu phi dV over the inner nodes (dV = tetrahedron volume).
/// Exitance uses the unclamped J+, so transmitted_input = exitance + absorbed holds (exactly for `fv`).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct Energy {
    pub transmitted_input: [f64; 3],
    pub exitance: [f64; 3],
    pub absorbed: [f64; 3],
}

/// What one level's Jacobi run did.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct LevelReport {
    pub surface_nodes: usize,
    pub inner_nodes: usize,
    pub jacobi_iterations: usize,
    /// Estimated relative error when Jacobi stopped; `None` when it cannot be told (fewer than 16
    /// iterations, or no contraction measured).
    pub jacobi_error_estimate: Option<f64>,
}

/// The result on the finest level.
#[derive(Clone, Debug)]
pub struct CpuSolution {
    /// phi at every node of the finest level (inner, then surface).
    pub phi: Vec<[f64; 3]>,
    /// The diffuse boundary flux q per surface node (all of the transmitted light with the
    /// boundary-flux source; the environment's only, or nothing, with beams).
    pub q: Vec<[f64; 3]>,
    /// Per surface node the value the mesh pass shades, F_t X / (pi eta^2): J+ for the classic
    /// exit query, M eta^2 / (1 - 2 C1(1/eta)) for the moments query (may be negative for strong
    /// absorbers).
    pub j_plus: Vec<[f64; 3]>,
    /// The same clamped at zero: what is displayed.
    pub j_plus_clamped: Vec<[f64; 3]>,
    /// The displayed value per vertex of `QuadGraph::surface`: the clamped node values through the
    /// shading weights, or the depth-sampled exit query (`Transport::surface`), clamped at zero.
    pub vertex_j_plus: Vec<[f32; 3]>,
    /// Surface nodes clamped per channel.
    pub clamped: [usize; 3],
    /// Per level, coarsest first.
    pub levels: Vec<LevelReport>,
    /// The exact solve of the finest level, when requested.
    pub exact: Option<KrylovReport>,
    /// Final relative residual per channel on the finest level, ||S (b - A phi)|| / ||S b||.
    pub residual: [f64; 3],
    pub energy: Energy,
    /// The finest level's assembled system (for inspection and comparisons).
    pub operator: LevelOperator,
    /// What the multigrid cycles did ([`Schedule::Multigrid`] only).
    pub multigrid: Option<MultigridReport>,
    /// Exitance leaving the object per finest surface node (DESIGN 2.6's M, or (1 - F_dr) J+).
    pub exitance: Vec<[f64; 3]>,
    /// Exitance per display vertex (unclamped).
    pub vertex_exitance: Vec<[f64; 3]>,
    /// Display vertices whose shading value was clamped at zero, per channel.
    pub vertex_clamped: [usize; 3],
    /// Per finest surface node the per-node exit lobe's diffused share
    /// ([`crate::scene::diffused_share`]; the GPU's J+ alpha).
    pub diffused_share: Vec<f64>,
    /// The same per display vertex through the shading weights (the Shepard surface; zeros for
    /// the interior and depth-sampled surfaces, which carry none: own light).
    pub vertex_diffused_share: Vec<f32>,
    /// The finest level's sources per surface node (bounce included).
    pub sources: Vec<LocalSource>,
    pub boundary: Boundary,
}

/// Jacobi on one level from `x`; returns the iterations run and the error estimate (see
/// [`LevelReport::jacobi_error_estimate`]).
pub fn jacobi(
    op: &LevelOperator,
    b: &[[f64; 3]],
    x: &mut Vec<[f64; 3]>,
    max_iterations: usize,
    tolerance: f64,
) -> (usize, Option<f64>) {
    const BLOCK: usize = 8;
    let mut next = vec![[0.0; 3]; x.len()];
    let mut history: Vec<f64> = Vec::with_capacity(max_iterations.min(1 << 16));
    let mut estimate = None;
    for it in 1..=max_iterations {
        let (delta, max) = op.jacobi_sweep(b, x, &mut next);
        std::mem::swap(x, &mut next);
        let rel = (0..3)
            .map(|c| if max[c] > 0.0 { delta[c] / max[c] } else { 0.0 })
            .fold(0.0, f64::max);
        if rel == 0.0 {
            return (it, Some(0.0));
        }
        history.push(rel);
        if it >= 2 * BLOCK && it % BLOCK == 0 {
            let rho = (rel / history[it - 1 - BLOCK]).powf(1.0 / BLOCK as f64);
            // An update of 1e-4 at rho = 0.999 still means ~10% error (DESIGN section 5).
            estimate = (rho < 1.0).then(|| rel / (1.0 - rho));
            if estimate.is_some_and(|e| e < tolerance) {
                return (it, estimate);
            }
        }
    }
    (max_iterations, estimate)
}

/// Shepard resampling from the coarser level (paper Eq. 10).
pub fn prolong(links: &ShepardLinks, coarse: &[[f64; 3]]) -> Vec<[f64; 3]> {
    links
        .links
        .par_iter()
        .zip(&links.weights)
        .map(|(l, w)| {
            let mut v = [0.0; 3];
            for (&c, &wc) in l.iter().zip(w) {
                if c != NO_NODE {
                    for ch in 0..3 {
                        v[ch] += wc * coarse[c as usize][ch];
                    }
                }
            }
            v
        })
        .collect()
}

fn check_links(
    links: &ShepardLinks,
    fine: &GraphLevel,
    coarse_nodes: usize,
    level: usize,
) -> Result<(), SolverError> {
    let bad = |problem: String| SolverError::BadGraph { level, problem };
    if links.links.len() != fine.node_count() || links.weights.len() != fine.node_count() {
        return Err(bad(format!(
            "{} Shepard links for {} nodes",
            links.links.len(),
            fine.node_count()
        )));
    }
    for (x, (l, w)) in links.links.iter().zip(&links.weights).enumerate() {
        if l.iter()
            .any(|&c| c != NO_NODE && c as usize >= coarse_nodes)
            || w.iter().any(|v| !v.is_finite())
        {
            return Err(bad(format!(
                "Shepard link of node {x} is out of range or not finite"
            )));
        }
    }
    Ok(())
}

/// One level's surface sources and the extrapolation length h = 2 A kappa of each surface row.
fn level_sources(
    graph: &QuadGraph,
    level: &GraphLevel,
    material: &MaterialField,
    model: &SourceModel,
    op: &LevelOperator,
) -> (Vec<LocalSource>, Vec<[f64; 3]>) {
    let inner = level.inner_count();
    // The upstream beam's curvature per surface node: the GPU gather's (baked, not probed).
    let curvature = if model.transport.upstream_beam {
        crate::quadgraph::surface_samples::surface_node_curvatures(
            level,
            &graph.surface,
            &graph.samples,
        )
    } else {
        Vec::new()
    };
    (0..level.surface_count())
        .into_par_iter()
        .map(|s| {
            let x = level.positions[inner + s];
            let here = material.sample(x);
            // The row's kappa: the cell's for fv, the surface node's own for the paper scheme.
            let row = match op.scheme {
                Scheme::Fv => material.sample(level.positions[level.surface_faces[s].0 as usize]),
                Scheme::Paper => here,
            };
            let d = row.kappa_with(material.diffusion());
            let h: [f64; 3] = std::array::from_fn(|c| 2.0 * op.a * d[c]);
            let k = curvature.get(s).copied();
            (model.at_node(x, level.surface_normals[s], &here, h, k), h)
        })
        .unzip()
}

/// Solves the diffusion problem on `graph` lit by `scene` (shadows cast by `occluder` when given).
// why: the energy sums index several [f64; 3] arrays per channel at once.
#[allow(clippy::needless_range_loop)]
pub fn solve(
    graph: &QuadGraph,
    material: &MaterialField,
    scene: &Scene,
    occluder: Option<&dyn Solid>,
    params: &CpuSolveParams,
) -> Result<CpuSolution, SolverError> {
    if graph.levels.is_empty() {
        return Err(SolverError::EmptyGraph);
    }
    scene.validate()?;
    if !(params.tolerance.is_finite() && params.tolerance >= 0.0) {
        return Err(SolverError::BadParameter {
            name: "tolerance",
            problem: format!("{} must be finite and >= 0", params.tolerance),
        });
    }
    if !(params.exact_tolerance.is_finite() && params.exact_tolerance > 0.0) {
        return Err(SolverError::BadParameter {
            name: "exact_tolerance",
            problem: format!("{} must be finite and > 0", params.exact_tolerance),
        });
    }
    let transport = params.transport;
    if transport.bounce_rays > 0 && occluder.is_none() {
        return Err(SolverError::BadParameter {
            name: "bounce_rays",
            problem: "one bounce between surface points needs the solid (occluder) to cast rays"
                .into(),
        });
    }
    if !(transport.thin_wall_mfp.is_finite() && transport.thin_wall_mfp >= 0.0) {
        return Err(SolverError::BadParameter {
            name: "thin_wall_mfp",
            problem: format!("{} must be finite and >= 0", transport.thin_wall_mfp),
        });
    }
    let vertices = graph.surface.positions.len();
    if matches!(
        transport.surface,
        SurfaceReconstruction::DepthSample | SurfaceReconstruction::Interior
    ) && vertices > 0
        && graph.samples.depth.len() != vertices
    {
        return Err(SolverError::BadParameter {
            name: "surface",
            problem: format!(
                "the depth-sampled exit query needs the bake's surface samples ({} for {vertices} vertices: bake again)",
                graph.samples.depth.len()
            ),
        });
    }
    let eta = material.eta();
    crate::material::check_eta(eta)?;
    let finest = graph.levels.len() - 1;
    let level = &graph.levels[finest];
    let inner = level.inner_count();
    // The finest level's system, sources and phi, by the schedule. Both use the transport's source
    // model and its boundary constants (exit query) on every level.
    let mut hierarchy_mg: Option<(Hierarchy, MultigridParams)> = None;
    let (op, mut sources, row_h, mut b, boundary, cap, mut phi, reports, mut exact, mut multigrid) =
        match &params.schedule {
            Schedule::Cascade => {
                let (phi, reports, (op, sources, row_h, b, boundary, cap)) =
                    cascade(graph, material, scene, occluder, params)?;
                (
                    op, sources, row_h, b, boundary, cap, phi, reports, None, None,
                )
            }
            Schedule::Multigrid(mg) => {
                let mg = MultigridParams {
                    tolerance: if params.exact {
                        params.exact_tolerance
                    } else {
                        mg.tolerance
                    },
                    ..mg.clone()
                };
                for (h, level) in graph.levels.iter().enumerate() {
                    check_level(level).map_err(|e| e.at_level(h))?;
                }
                let hierarchy =
                    Hierarchy::build_with(graph, material, params.scheme, transport.exit, &mg)?;
                let model =
                    SourceModel::new(scene, material, occluder, transport, ray_offset(level));
                let (sources, row_h) =
                    level_sources(graph, level, material, &model, &hierarchy.finest);
                let mut b = vec![[0.0; 3]; level.node_count()];
                for (s, src) in sources.iter().enumerate() {
                    b[inner + s] = src.rhs;
                }
                let start = match &params.initial {
                    Some(previous) if previous.len() == level.node_count() => Start::Warm(previous),
                    Some(previous) => {
                        return Err(SolverError::BadParameter {
                            name: "initial",
                            problem: format!(
                                "{} values for the finest level's {} nodes",
                                previous.len(),
                                level.node_count()
                            ),
                        })
                    }
                    None => Start::Cold,
                };
                let (phi, report) = multigrid_solve(&hierarchy, &b, start, &mg)?;
                let reports = graph
                    .levels
                    .iter()
                    .zip(&report.sweeps)
                    .map(|(level, &sweeps)| LevelReport {
                        surface_nodes: level.surface_count(),
                        inner_nodes: level.inner_count(),
                        jacobi_iterations: sweeps as usize,
                        jacobi_error_estimate: None,
                    })
                    .collect();
                let op = hierarchy.finest.clone();
                hierarchy_mg = Some((hierarchy, mg));
                let boundary = model.boundary;
                (
                    op,
                    sources,
                    row_h,
                    b,
                    boundary,
                    0,
                    phi,
                    reports,
                    None,
                    Some(report),
                )
            }
        };
    // The exact solve (cascade) or the multigrid cycles again (warm) after the bounce.
    let exact_solve = |phi: &mut Vec<[f64; 3]>, b: &[[f64; 3]]| {
        if params.exact {
            Some(krylov::solve(
                &op,
                b,
                phi,
                params.exact_tolerance,
                params.exact_max_iterations,
            ))
        } else {
            None
        }
    };
    if hierarchy_mg.is_none() {
        exact = exact_solve(&mut phi, &b);
    }
    check_finite(&phi)?;

    // One bounce: the exitance of the first solve lights the surface points it can see.
    let mut bounce_sources = Vec::new();
    if let (Some(solid), true) = (occluder, transport.bounce_rays > 0) {
        let model = SourceModel::new(scene, material, occluder, transport, ray_offset(level));
        let exitance = node_exitance(&op, &boundary, &sources, &row_h, &phi, material, level);
        bounce_sources = super::bounce::bounce_sources(
            level,
            &exitance,
            &model,
            solid,
            &row_h,
            transport.bounce_rays,
        );
        for (s, extra) in bounce_sources.iter().enumerate() {
            sources[s].add(extra);
            b[inner + s] = sources[s].rhs;
        }
        match &hierarchy_mg {
            Some((hierarchy, mg)) => {
                let (again, report) = multigrid_solve(hierarchy, &b, Start::Warm(&phi), mg)?;
                phi = again;
                multigrid = Some(report);
            }
            None => {
                exact = exact_solve(&mut phi, &b);
                if !params.exact {
                    jacobi(&op, &b, &mut phi, cap, params.tolerance);
                }
            }
        }
        check_finite(&phi)?;
    }
    let residual = op.residual(&phi, &b);
    if residual.iter().any(|r| !r.is_finite()) {
        return Err(SolverError::NonFinite {
            what: "the residual (irradiance beyond the range of f64 sums of squares?)".into(),
        });
    }

    let exitance = node_exitance(&op, &boundary, &sources, &row_h, &phi, material, level);
    let diffused_share = node_diffused_share(
        &op, &boundary, &sources, &row_h, &phi, material, level, &exitance,
    );
    let j_plus: Vec<[f64; 3]> = exitance
        .iter()
        .map(|m| m.map(|v| boundary.shading_input(v)))
        .collect();
    let (j_plus_clamped, clamped) = clamp_negative(&j_plus);
    let mut energy = Energy::default();
    for (s, src) in sources.iter().enumerate() {
        for c in 0..3 {
            energy.transmitted_input[c] += src.transmitted[c] * op.areas[s];
            energy.exitance[c] += exitance[s][c] * op.areas[s];
            energy.absorbed[c] += src.absorbed[c] * op.areas[s];
        }
    }
    for ((mu, phi_i), v) in op.mu.iter().zip(&phi[..inner]).zip(&op.volumes) {
        for c in 0..3 {
            energy.absorbed[c] += mu[c] * phi_i[c] * v;
        }
    }
    let vertex_diffused_share: Vec<f32> = match transport.surface {
        SurfaceReconstruction::Shepard => {
            let per_node: Vec<[f64; 3]> = diffused_share.iter().map(|&s| [s; 3]).collect();
            shade_vertices(graph, &per_node)?
                .iter()
                .map(|v| v[0].clamp(0.0, 1.0))
                .collect()
        }
        _ => vec![0.0; graph.surface.positions.len()],
    };
    let (vertex_j_plus, vertex_exitance, vertex_clamped) = match transport.surface {
        SurfaceReconstruction::Shepard => {
            let v = shade_vertices(graph, &j_plus_clamped)?;
            let m = shade_vertices(graph, &exitance)?;
            (v, m.iter().map(|m| m.map(f64::from)).collect(), clamped)
        }
        SurfaceReconstruction::Interior => {
            let own = if transport.own_visibility && transport.source != Source::BoundaryFlux {
                OwnVisibility::new(
                    graph,
                    scene,
                    occluder,
                    transport.continuation,
                    ray_offset(level),
                )
            } else {
                None
            };
            let m = interior_vertices(graph, &boundary, material, &sources, &phi, own.as_ref())?;
            let x: Vec<[f64; 3]> = m
                .iter()
                .map(|m| m.map(|v| boundary.shading_input(v)))
                .collect();
            let (x, vertex_clamped) = clamp_negative(&x);
            (
                x.iter().map(|x| x.map(|v| v as f32)).collect(),
                m,
                vertex_clamped,
            )
        }
        SurfaceReconstruction::DepthSample => {
            let model = SourceModel::new(scene, material, occluder, transport, ray_offset(level));
            let bounce_at_vertices = if bounce_sources.is_empty() {
                None
            } else {
                Some(shade_sources(graph, &bounce_sources)?)
            };
            let m = reconstruct_vertices(graph, &model, &phi, bounce_at_vertices.as_deref());
            let x: Vec<[f64; 3]> = m
                .iter()
                .map(|m| m.map(|v| boundary.shading_input(v)))
                .collect();
            let (x, vertex_clamped) = clamp_negative(&x);
            (
                x.iter().map(|x| x.map(|v| v as f32)).collect(),
                m,
                vertex_clamped,
            )
        }
    };
    // Finite phi can still give a non-finite exitance (huge finite shading weights, or an f32
    // overflow at the vertices): found by the cache fuzz target on a crafted cache (issue 17).
    if j_plus.iter().flatten().any(|v| !v.is_finite())
        || vertex_j_plus.iter().flatten().any(|v| !v.is_finite())
    {
        return Err(SolverError::NonFinite {
            what: "the exitance J+ (at the surface nodes or the shaded vertices)".into(),
        });
    }
    Ok(CpuSolution {
        phi,
        q: sources.iter().map(|s| s.q_flux).collect(),
        j_plus,
        j_plus_clamped,
        vertex_j_plus,
        clamped,
        levels: reports,
        exact,
        residual,
        energy,
        operator: op,
        exitance,
        vertex_exitance,
        vertex_clamped,
        diffused_share,
        vertex_diffused_share,
        sources,
        boundary,
        multigrid,
    })
}

/// The finest level's relative residual and energy balance for a given phi (the GPU's, read
/// back) with the sources and the exit query `transport` makes: what [`solve`] reports for its
/// own phi, so a GPU frame and the f64 reference report alike for the same light source (the
/// beam sources' particular solutions included, which the boundary flux alone leaves out).
// why: the energy sums index several [f64; 3] arrays per channel at once.
#[allow(clippy::needless_range_loop)]
pub fn balance(
    graph: &QuadGraph,
    material: &MaterialField,
    scene: &Scene,
    occluder: Option<&dyn Solid>,
    scheme: Scheme,
    transport: Transport,
    phi: &[[f64; 3]],
) -> Result<([f64; 3], Energy), SolverError> {
    let level = graph.levels.last().ok_or(SolverError::EmptyGraph)?;
    if phi.len() != level.node_count() {
        return Err(SolverError::BadParameter {
            name: "phi",
            problem: format!(
                "{} values for the finest level's {} nodes",
                phi.len(),
                level.node_count()
            ),
        });
    }
    let op = LevelOperator::build_with(level, material, scheme, transport.exit)?;
    let model = SourceModel::new(scene, material, occluder, transport, ray_offset(level));
    let (sources, row_h) = level_sources(graph, level, material, &model, &op);
    let inner = level.inner_count();
    let mut b = vec![[0.0; 3]; level.node_count()];
    for (s, src) in sources.iter().enumerate() {
        b[inner + s] = src.rhs;
    }
    let residual = op.residual(phi, &b);
    let exitance = node_exitance(&op, &model.boundary, &sources, &row_h, phi, material, level);
    let mut energy = Energy::default();
    for (s, src) in sources.iter().enumerate() {
        for c in 0..3 {
            energy.transmitted_input[c] += src.transmitted[c] * op.areas[s];
            energy.exitance[c] += exitance[s][c] * op.areas[s];
            energy.absorbed[c] += src.absorbed[c] * op.areas[s];
        }
    }
    for ((mu, phi_i), v) in op.mu.iter().zip(&phi[..inner]).zip(&op.volumes) {
        for c in 0..3 {
            energy.absorbed[c] += mu[c] * phi_i[c] * v;
        }
    }
    Ok((residual, energy))
}

/// Ray origins are lifted this far off a level's surface: enough to miss it under f64 round-off,
/// far below the lattice scale.
fn ray_offset(level: &GraphLevel) -> f64 {
    1e-4 * level.spacing.max(1e-6)
}

fn check_finite(phi: &[[f64; 3]]) -> Result<(), SolverError> {
    if phi.iter().flatten().any(|v| !v.is_finite()) {
        return Err(SolverError::NonFinite {
            what: "phi (the solve diverged: the paper scheme is not guaranteed to converge under Jacobi)".into(),
        });
    }
    Ok(())
}

/// Values clamped at zero, and how many were clamped per channel.
fn clamp_negative(values: &[[f64; 3]]) -> (Vec<[f64; 3]>, [usize; 3]) {
    let mut clamped = [0usize; 3];
    let out = values
        .iter()
        .map(|j| {
            std::array::from_fn(|c| {
                if j[c] < 0.0 {
                    clamped[c] += 1;
                    0.0
                } else {
                    j[c]
                }
            })
        })
        .collect();
    (out, clamped)
}

/// Exitance per surface node of the finest level from the solved remainder phi_h: the total
/// phi = phi_h + phi_p and its inward derivative (phi_h - rhs) / h + dphi_p, read by the exit
/// query (the Robin row says (phi_k - phi_s) / d_sk = (phi_s - rhs) / h).
fn node_exitance(
    op: &LevelOperator,
    boundary: &Boundary,
    sources: &[LocalSource],
    row_h: &[[f64; 3]],
    phi: &[[f64; 3]],
    material: &MaterialField,
    level: &GraphLevel,
) -> Vec<[f64; 3]> {
    let inner = op.inner_count;
    (0..sources.len())
        .into_par_iter()
        .map(|s| {
            let src = &sources[s];
            let d = material.kappa_at(level.positions[level.surface_faces[s].0 as usize]);
            std::array::from_fn(|c| {
                let phi_h = phi[inner + s][c];
                let dphi_h = (phi_h - src.rhs[c]) / row_h[s][c];
                boundary.exitance(
                    d[c],
                    phi_h + src.phi_p[c],
                    dphi_h + src.dphi_p[c],
                    src.q_flux[c],
                )
            })
        })
        .collect()
}

/// The per-node exit lobe's diffused share of every finest surface node
/// ([`crate::scene::diffused_share`]): the remainder phi_h against its Robin row's right side, the
/// remainder's exitance (particular parts left out) against the node's `exitance`.
#[allow(
    clippy::too_many_arguments,
    reason = "the same inputs as node_exitance, plus its result"
)]
fn node_diffused_share(
    op: &LevelOperator,
    boundary: &Boundary,
    sources: &[LocalSource],
    row_h: &[[f64; 3]],
    phi: &[[f64; 3]],
    material: &MaterialField,
    level: &GraphLevel,
    exitance: &[[f64; 3]],
) -> Vec<f64> {
    let inner = op.inner_count;
    (0..sources.len())
        .into_par_iter()
        .map(|s| {
            let src = &sources[s];
            let d = material.kappa_at(level.positions[level.surface_faces[s].0 as usize]);
            let phi_h: [f64; 3] = phi[inner + s];
            let homogeneous = std::array::from_fn(|c| {
                let dphi_h = (phi_h[c] - src.rhs[c]) / row_h[s][c];
                boundary.exitance(d[c], phi_h[c], dphi_h, src.q_flux[c])
            });
            crate::scene::diffused_share(phi_h, src.rhs, exitance[s], homogeneous)
        })
        .collect()
}

/// The finest level of the cascade: its system, sources, extrapolation lengths h, right-hand side,
/// boundary and the Jacobi cap.
type Assembled = (
    LevelOperator,
    Vec<LocalSource>,
    Vec<[f64; 3]>,
    Vec<[f64; 3]>,
    Boundary,
    usize,
);
/// The cascade's finest phi, its per-level reports and the finest level's system.
type Cascaded = (Vec<[f64; 3]>, Vec<LevelReport>, Assembled);

/// The paper's cascade (section 4.3): Jacobi per level, coarsest first, each finer level started
/// from the Shepard resampling of the coarser one; each level's operator has the transport's
/// boundary constants and its sources come from the transport's [`SourceModel`].
fn cascade(
    graph: &QuadGraph,
    material: &MaterialField,
    scene: &Scene,
    occluder: Option<&dyn Solid>,
    params: &CpuSolveParams,
) -> Result<Cascaded, SolverError> {
    let transport = params.transport;
    let finest = graph.levels.len() - 1;
    let mut reports = Vec::with_capacity(graph.levels.len());
    let mut phi: Vec<[f64; 3]> = Vec::new();
    let mut last = None;
    for (h, level) in graph.levels.iter().enumerate() {
        check_level(level).map_err(|e| e.at_level(h))?;
        let op = LevelOperator::build_with(level, material, params.scheme, transport.exit)
            .map_err(|e| e.at_level(h))?;
        // Far enough off the surface to miss it under f64 round-off, far below the lattice scale.
        let model = SourceModel::new(scene, material, occluder, transport, ray_offset(level));
        let (sources, row_h) = level_sources(graph, level, material, &model, &op);
        let mut b = vec![[0.0; 3]; level.node_count()];
        for (s, src) in sources.iter().enumerate() {
            b[level.inner_count() + s] = src.rhs;
        }
        phi = if h == 0 {
            match &params.initial {
                Some(guess) if guess.len() == level.node_count() => guess.clone(),
                Some(guess) => {
                    return Err(SolverError::BadParameter {
                        name: "initial",
                        problem: format!("{} values for {} nodes", guess.len(), level.node_count()),
                    })
                }
                None => vec![[0.0; 3]; level.node_count()],
            }
        } else {
            let links = level
                .from_coarser
                .as_ref()
                .ok_or(SolverError::MissingLinks { level: h })?;
            check_links(links, level, graph.levels[h - 1].node_count(), h)?;
            prolong(links, &phi)
        };
        let cap = params
            .iterations
            .get(h)
            .or(params.iterations.last())
            .copied()
            .unwrap_or(0);
        let (iterations, estimate) = jacobi(&op, &b, &mut phi, cap, params.tolerance);
        reports.push(LevelReport {
            surface_nodes: level.surface_count(),
            inner_nodes: level.inner_count(),
            jacobi_iterations: iterations,
            jacobi_error_estimate: estimate,
        });
        if h == finest {
            last = Some((op, sources, row_h, b, model.boundary, cap));
        }
    }
    let last = last.ok_or(SolverError::EmptyGraph)?;
    Ok((phi, reports, last))
}

/// Multigrid cycles on the finest level's right-hand side `b` (unscaled); a diverged run is an error.
fn multigrid_solve(
    hierarchy: &Hierarchy,
    b: &[[f64; 3]],
    start: Start<'_>,
    mg: &MultigridParams,
) -> Result<(Vec<[f64; 3]>, MultigridReport), SolverError> {
    let f = hierarchy.scale(b);
    let (phi, report) = hierarchy.solve(&f, start, mg, &mut |_, _| {});
    if report.residual.is_nan() || report.residual >= super::multigrid::DIVERGED {
        return Err(SolverError::Diverged {
            residual: report.residual,
            cycles: report.cycles.len(),
            hint: "use the Galerkin coarse operator on strong material contrasts",
        });
    }
    Ok((phi, report))
}

/// Interpolates per-surface-node values to the display mesh's vertices with `graph.shading`.
pub fn shade_vertices(
    graph: &QuadGraph,
    per_node: &[[f64; 3]],
) -> Result<Vec<[f32; 3]>, SolverError> {
    let w = &graph.shading;
    if w.links.len() != w.weights.len() {
        return Err(SolverError::BadGraph {
            level: graph.levels.len().saturating_sub(1),
            problem: format!(
                "{} shading links but {} weight rows",
                w.links.len(),
                w.weights.len()
            ),
        });
    }
    w.links
        .iter()
        .zip(&w.weights)
        .enumerate()
        .map(|(v, (l, wt))| {
            let mut acc = [0.0f64; 3];
            for (&s, &ws) in l.iter().zip(wt) {
                if s == NO_NODE {
                    continue;
                }
                let node = per_node
                    .get(s as usize)
                    .ok_or_else(|| SolverError::BadGraph {
                        level: graph.levels.len().saturating_sub(1),
                        problem: format!(
                            "vertex {v} links to surface node {s} (only {})",
                            per_node.len()
                        ),
                    })?;
                for c in 0..3 {
                    acc[c] += ws * node[c];
                }
            }
            Ok(acc.map(|x| x as f32))
        })
        .collect()
}
