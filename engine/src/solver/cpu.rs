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

use rayon::prelude::*;

use super::krylov::{self, KrylovReport};
use super::multigrid::{Hierarchy, MultigridParams, MultigridReport, Start};
use super::operator::{check_level, LevelOperator, Scheme};
use super::SolverError;
use crate::material::{fresnel, MaterialField};
use crate::mesh::Solid;
use crate::quadgraph::graph::{GraphLevel, QuadGraph, ShepardLinks, NO_NODE};
use crate::scene::{RadianceMode, Scene};

/// Outgoing radiance at a surface point with outgoing current `j_plus`, viewed at `cos_o` to the
/// normal (outside). Negative J+ gives zero radiance.
pub fn radiance(j_plus: [f64; 3], eta: f64, cos_o: f64, mode: RadianceMode) -> [f64; 3] {
    let ft = fresnel::transmittance(eta, cos_o);
    let k = match mode {
        RadianceMode::Physical => ft / (std::f64::consts::PI * eta * eta),
        RadianceMode::Paper => ft / std::f64::consts::PI,
    };
    j_plus.map(|j| k * j.max(0.0))
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
    /// Opt-in experiment (issue 6): deposit the lights' transmitted light as a volume source along
    /// the unscattered beam instead of as the boundary flux q (see [`beam_source`]). The
    /// environment stays a boundary flux. Needs the `occluder` (entry points are ray-cast).
    pub beam_source: bool,
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
            beam_source: false,
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
    /// Transmitted irradiance q per surface node.
    pub q: Vec<[f64; 3]>,
    /// J+ per surface node as the model gives it (may be negative for strong absorbers).
    pub j_plus: Vec<[f64; 3]>,
    /// J+ clamped at zero: what is displayed.
    pub j_plus_clamped: Vec<[f64; 3]>,
    /// Clamped J+ interpolated to `QuadGraph::surface`'s vertices with the shading weights.
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

/// Solves the diffusion problem on `graph` lit by `scene` (shadows cast by `occluder` when given).
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
    let eta = material.eta();
    crate::material::check_eta(eta)?;
    let finest = graph.levels.len() - 1;
    let (op, q, b, beam_power, phi, reports, exact, multigrid) = match &params.schedule {
        Schedule::Cascade => {
            let (phi, reports, (op, q, b, beam_power)) =
                cascade(graph, material, scene, occluder, params)?;
            let mut phi = phi;
            let exact = params.exact.then(|| {
                krylov::solve(
                    &op,
                    &b,
                    &mut phi,
                    params.exact_tolerance,
                    params.exact_max_iterations,
                )
            });
            (op, q, b, beam_power, phi, reports, exact, None)
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
            let hierarchy = Hierarchy::build(graph, material, params.scheme, &mg)?;
            let (q, b, beam_power) = level_source(
                &graph.levels[finest],
                &hierarchy.finest,
                material,
                scene,
                occluder,
                params.beam_source,
            )?;
            let start = match &params.initial {
                Some(previous) if previous.len() == graph.levels[finest].node_count() => {
                    Start::Warm(previous)
                }
                Some(previous) => {
                    return Err(SolverError::BadParameter {
                        name: "initial",
                        problem: format!(
                            "{} values for the finest level's {} nodes",
                            previous.len(),
                            graph.levels[finest].node_count()
                        ),
                    })
                }
                None => Start::Cold,
            };
            let f = hierarchy.scale(&b);
            let (phi, report) = hierarchy.solve(&f, start, &mg, &mut |_, _| {});
            if report.residual.is_nan() || report.residual >= super::multigrid::DIVERGED {
                return Err(SolverError::Diverged {
                    residual: report.residual,
                    cycles: report.cycles.len(),
                    hint: "use the Galerkin coarse operator on strong material contrasts",
                });
            }
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
            let Hierarchy { finest: op, .. } = hierarchy;
            (op, q, b, beam_power, phi, reports, None, Some(report))
        }
    };
    if phi.iter().flatten().any(|v| !v.is_finite()) {
        return Err(SolverError::NonFinite {
            what: "phi (the solve diverged: the paper scheme is not guaranteed to converge under Jacobi)".into(),
        });
    }
    let residual = op.residual(&phi, &b);
    if residual.iter().any(|r| !r.is_finite()) {
        return Err(SolverError::NonFinite {
            what: "the residual (irradiance beyond the range of f64 sums of squares?)".into(),
        });
    }

    let level = &graph.levels[finest];
    let inner = level.inner_count();
    let j_plus: Vec<[f64; 3]> = (0..level.surface_count())
        .map(|s| {
            std::array::from_fn(|c| {
                (1.0 + 1.0 / op.a) * phi[inner + s][c] / 4.0 - q[s][c] / (1.0 + op.f_dr)
            })
        })
        .collect();
    let mut clamped = [0usize; 3];
    let j_plus_clamped: Vec<[f64; 3]> = j_plus
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
    // The beam source's scattered power enters through the volume (zero without it).
    let mut energy = Energy {
        transmitted_input: beam_power,
        ..Energy::default()
    };
    for s in 0..level.surface_count() {
        for c in 0..3 {
            energy.transmitted_input[c] += q[s][c] * op.areas[s];
            energy.exitance[c] += (1.0 - op.f_dr) * j_plus[s][c] * op.areas[s];
        }
    }
    for ((mu, phi_i), v) in op.mu.iter().zip(&phi[..inner]).zip(&op.volumes) {
        for c in 0..3 {
            energy.absorbed[c] += mu[c] * phi_i[c] * v;
        }
    }
    let vertex_j_plus = shade_vertices(graph, &j_plus_clamped)?;
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
        q,
        j_plus,
        j_plus_clamped,
        vertex_j_plus,
        clamped,
        levels: reports,
        exact,
        residual,
        energy,
        operator: op,
        multigrid,
    })
}

/// Irradiance q per surface node, the right-hand side b and the beam source's power.
type Source = (Vec<[f64; 3]>, Vec<[f64; 3]>, [f64; 3]);
/// The finest level's system, irradiance and source, as [`solve`] assembles it.
type Assembled = (LevelOperator, Vec<[f64; 3]>, Vec<[f64; 3]>, [f64; 3]);
/// The cascade's finest phi, its per-level reports and the finest level's system.
type Cascaded = (Vec<[f64; 3]>, Vec<LevelReport>, Assembled);

/// The paper's cascade (section 4.3): Jacobi per level, coarsest first, each finer level started
/// from the Shepard resampling of the coarser one. Returns the finest phi, the per-level reports
/// and the finest level's system.
fn cascade(
    graph: &QuadGraph,
    material: &MaterialField,
    scene: &Scene,
    occluder: Option<&dyn Solid>,
    params: &CpuSolveParams,
) -> Result<Cascaded, SolverError> {
    let finest = graph.levels.len() - 1;
    let mut reports = Vec::with_capacity(graph.levels.len());
    let mut phi: Vec<[f64; 3]> = Vec::new();
    let mut last = None;
    for (h, level) in graph.levels.iter().enumerate() {
        check_level(level).map_err(|e| e.at_level(h))?;
        let op = LevelOperator::build(level, material, params.scheme).map_err(|e| e.at_level(h))?;
        let (q, b, beam_power) =
            level_source(level, &op, material, scene, occluder, params.beam_source)?;
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
            last = Some((op, q, b, beam_power));
        }
    }
    let last = last.ok_or(SolverError::EmptyGraph)?;
    Ok((phi, reports, last))
}

/// Irradiance q at the surface nodes of `level`, the right-hand side b and the power the beam
/// source deposits (zero without it).
fn level_source(
    level: &GraphLevel,
    op: &LevelOperator,
    material: &MaterialField,
    scene: &Scene,
    occluder: Option<&dyn Solid>,
    with_beam: bool,
) -> Result<Source, SolverError> {
    let eta = material.eta();
    if !with_beam {
        let q = scene.surface_irradiance(level, eta, occluder);
        let b = op.rhs(&q);
        return Ok((q, b, [0.0; 3]));
    }
    let occluder = occluder.ok_or_else(|| SolverError::BadParameter {
        name: "beam_source",
        problem: "needs the solid (occluder) to find where each beam enters".into(),
    })?;
    let environment = Scene {
        lights: Vec::new(),
        environment: scene.environment,
    };
    let q = environment.surface_irradiance(level, eta, Some(occluder));
    let mut b = op.rhs(&q);
    let source = beam_source(level, material, &scene.lights, op, occluder, eta);
    let mut power = [0.0; 3];
    for ((bi, si), v) in b.iter_mut().zip(&source).zip(&op.volumes) {
        *bi = *si;
        for c in 0..3 {
            power[c] += si[c] * v;
        }
    }
    Ok((q, b, power))
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

/// The opt-in beam source (issue 6, [`CpuSolveParams::beam_source`]): per inner node, the power
/// per unit volume that the lights' unscattered beams scatter there, sigma_s'(x) E F_t exp(-tau),
/// tau the optical depth from where the beam enters (the first boundary crossing towards the
/// light; nothing if the light is occluded beyond it). The diffusion approximation's classic
/// extended source: the boundary flux q puts all transmitted light on the surface as if it were
/// already diffuse, while a collimated beam scatters first at about one transport mean free path
/// below it. The beam is not refracted (exact for eta = 1, where the path-traced references
/// with delta lights are). Per channel the deposit is scaled so that the extinguished power,
/// sum sigma_t' E F_t exp(-tau) V_i, equals the power the boundary flux would bring in, sum q A,
/// which removes the cell-centred quadrature error of the exponential (the object is assumed
/// optically thick along every beam).
pub fn beam_source(
    level: &GraphLevel,
    material: &MaterialField,
    lights: &[crate::scene::Light],
    op: &LevelOperator,
    occluder: &dyn Solid,
    eta: f64,
) -> Vec<[f64; 3]> {
    let inner = level.inner_count();
    let offset = 1e-4 * level.spacing.max(1e-6);
    let mut total = vec![[0.0; 3]; inner];
    for light in lights {
        let single = Scene {
            lights: vec![*light],
            environment: crate::scene::Environment::None,
        };
        let q = single.surface_irradiance(level, eta, Some(occluder));
        // (extinction density, scattering density) per node.
        let deposit: Vec<([f64; 3], [f64; 3])> = (0..inner)
            .into_par_iter()
            .map(|i| {
                let x = level.positions[i];
                let (e, l, dist) = light.arriving(x);
                let Some((t, normal)) = occluder.ray_hit(x, l, dist) else {
                    return ([0.0; 3], [0.0; 3]);
                };
                let entry = x + l * (t + offset);
                if occluder.occluded(entry, l, dist - t - offset) {
                    return ([0.0; 3], [0.0; 3]);
                }
                let f_t = fresnel::transmittance(eta, normal.dot(l));
                // Optical depth by the midpoint rule (exact for homogeneous materials).
                let steps = ((t / (0.5 * level.spacing.max(1e-6))).ceil() as usize).clamp(1, 16);
                let mut tau = [0.0; 3];
                for k in 0..steps {
                    let c = material.sample(x + l * (t * (k as f64 + 0.5) / steps as f64));
                    for (ch, tau) in tau.iter_mut().enumerate() {
                        *tau += (c.sigma_s[ch] + c.sigma_a[ch]) * t / steps as f64;
                    }
                }
                let here = material.sample(x);
                let beam: [f64; 3] = std::array::from_fn(|c| e[c] * f_t * (-tau[c]).exp());
                (
                    std::array::from_fn(|c| (here.sigma_s[c] + here.sigma_a[c]) * beam[c]),
                    std::array::from_fn(|c| here.sigma_s[c] * beam[c]),
                )
            })
            .collect();
        for c in 0..3 {
            let incoming: f64 = q.iter().zip(&op.areas).map(|(q, a)| q[c] * a).sum();
            let extinguished: f64 = deposit
                .iter()
                .zip(&op.volumes)
                .map(|(d, v)| d.0[c] * v)
                .sum();
            let scale = if extinguished > 0.0 {
                incoming / extinguished
            } else {
                0.0
            };
            for (t, d) in total.iter_mut().zip(&deposit) {
                t[c] += scale * d.1[c];
            }
        }
    }
    total
}
