//! The f64 reference's surface reconstructions at the display vertices (issue 12 item 4): the
//! exit query on the local 1D profile through each vertex's interior sample, and the shading
//! weights' interpolation of per-node sources they start from.

use super::*;
use crate::scene::Environment;
use crate::solver::sources::{arrival, Arrival};

/// Per display vertex, the exit query on the local 1D profile through the vertex's interior sample
/// (issue 12 item 4): the vertex's own sources (lights ray-cast from the vertex, the environment;
/// the bounce's interpolated from the surface nodes), phi_h at the sample point, the remainder
/// extended to the surface by [`profile_from_sample`], the particular solutions added back.
/// Returns the exitance M per vertex (unclamped).
pub fn reconstruct_vertices(
    graph: &QuadGraph,
    model: &SourceModel,
    phi_h: &[[f64; 3]],
    bounce: Option<&[LocalSource]>,
) -> Vec<[f64; 3]> {
    let surface = &graph.surface;
    let samples = &graph.samples;
    let level = graph.finest();
    let boundary = model.boundary;
    let sampled: Vec<[f64; 3]> = (0..surface.positions.len())
        .into_par_iter()
        .map(|v| samples.interpolate(v, phi_h))
        .collect();
    (0..surface.positions.len())
        .into_par_iter()
        .map(|v| {
            let x = surface.positions[v];
            let n = surface
                .normals
                .get(v)
                .copied()
                .unwrap_or(DVec3::Y)
                .normalize_or(DVec3::Y);
            // The local coefficients: those of the tetrahedron holding the sample point.
            let cell = samples.cell[v] as usize;
            let here = model
                .material
                .sample(level.positions[cell.min(level.inner_count() - 1)]);
            let kind = model.material.diffusion();
            let optics: [Optics; 3] = std::array::from_fn(|c| Optics::channel_with(&here, c, kind));
            let h: [f64; 3] = std::array::from_fn(|c| boundary.h(optics[c]));
            let mut src = model.at_node(
                x,
                n,
                &here,
                h,
                samples
                    .curvature
                    .get(v)
                    .map(|&k| crate::solver::transport::SurfaceCurvature::umbilic(k)),
            );
            if let Some(extra) = bounce {
                let mut e = extra[v];
                e.rhs = std::array::from_fn(|c| {
                    boundary.flux_gain * e.q_flux[c] - (e.phi_p[c] - h[c] * e.dphi_p[c])
                });
                src.add(&e);
            }
            let p = sampled[v];
            let laplacian = samples.lateral_laplacian(v, &sampled);
            let curvature = samples.curvature.get(v).copied().unwrap_or(0.0);
            let spread = samples.spread.get(v).copied().unwrap_or_default();
            std::array::from_fn(|c| {
                let o = optics[c];
                let depth = samples.depth[v];
                let (s, rhs) = (o.s(), src.rhs[c]);
                let lambda = lateral_lambda(laplacian[c], p[c], s, depth, rhs);
                let p =
                    sample_on_lateral_profile(s, lambda, h[c], depth, p[c], rhs, curvature, spread);
                let (phi0, dphi0) =
                    lateral_profile_from_sample(s, lambda, h[c], depth, p, rhs, curvature);
                boundary.exitance(
                    o.d(),
                    phi0 + src.phi_p[c],
                    dphi0 + src.dphi_p[c],
                    src.q_flux[c],
                )
            })
        })
        .collect()
}

/// Per display vertex, the exitance M reconstructed from the interior solution (issue 12 item 4,
/// [`SurfaceReconstruction::Interior`]), the f64 twin of the GPU's `diffusion/vertex_interior`:
/// phi at the vertex's sample point (`QuadGraph::samples`, a fixed depth inside along the
/// normal), the sources q and the collimated exit part P averaged with the vertex's source
/// weights (`SurfaceSamples::source_average`), the local
/// 1D profile through the sample ([`profile_from_sample`], h = 2 A D and s of the tetrahedron
/// holding the sample) for phi(0) and dphi/dz_in(0), then the exit query plus P. Unclamped.
/// With `own` ([`Transport::own_visibility`]) the lit beam's q and P follow the vertex's own
/// light visibility ([`own_visibility_sources`]) instead of the nodes'.
pub fn interior_vertices(
    graph: &QuadGraph,
    boundary: &Boundary,
    material: &MaterialField,
    sources: &[LocalSource],
    phi_h: &[[f64; 3]],
    own: Option<&OwnVisibility>,
) -> Result<Vec<[f64; 3]>, SolverError> {
    let level = graph.finest();
    let inner = level.inner_count();
    // The diffuse-flux equivalent of each node's Robin right-hand side (what the GPU keeps in q)
    // and the particular solution's part of the exit query (the GPU's `particular`).
    let q: Vec<[f64; 3]> = sources
        .iter()
        .map(|s| s.rhs.map(|r| r / boundary.flux_gain))
        .collect();
    let part: Vec<[f64; 3]> = (0..sources.len())
        .map(|s| {
            let d = material.kappa_at(level.positions[level.surface_faces[s].0 as usize]);
            std::array::from_fn(|c| {
                boundary.exitance(d[c], sources[s].phi_p[c], sources[s].dphi_p[c], 0.0)
            })
        })
        .collect();
    let samples = &graph.samples;
    let vertices = graph.surface.positions.len();
    if samples.depth.len() != vertices || samples.sources.len() != vertices {
        return Err(SolverError::BadParameter {
            name: "surface",
            problem: format!(
                "the interior reconstruction needs the bake's surface samples ({} for {vertices} vertices: bake again)",
                samples.depth.len()
            ),
        });
    }
    let sampled: Vec<[f64; 3]> = (0..vertices)
        .into_par_iter()
        .map(|v| samples.interpolate(v, phi_h))
        .collect();
    Ok((0..vertices)
        .into_par_iter()
        .map(|v| {
            let cell = (samples.cell[v] as usize).min(inner.saturating_sub(1));
            let here = material.sample(level.positions[cell]);
            let kappa = here.kappa_with(material.diffusion());
            let p = sampled[v];
            let laplacian = samples.lateral_laplacian(v, &sampled);
            let (q_v, part_v) = match own {
                Some(own) => own_visibility_sources(
                    samples.sources[v]
                        .iter()
                        .zip(&samples.source_weights[v])
                        .filter(|(&s, _)| s != NO_NODE)
                        .map(|(&s, &w)| {
                            let s = s as usize;
                            (w, q[s], part[s], own.nodes[s])
                        }),
                    own.vertices[v],
                ),
                None => (
                    samples.source_average(v, &q),
                    samples.source_average(v, &part),
                ),
            };
            let curvature = samples.curvature.get(v).copied().unwrap_or(0.0);
            let spread = samples.spread.get(v).copied().unwrap_or_default();
            std::array::from_fn(|c| {
                let (d, h) = (kappa[c], 2.0 * boundary.a * kappa[c]);
                let s = (here.mu()[c] / d).sqrt();
                let qv = q_v[c];
                let (depth, rhs) = (samples.depth[v], boundary.flux_gain * qv);
                // The lateral term: the samples' along-surface Laplacian over the sample.
                let lambda = lateral_lambda(laplacian[c], p[c], s, depth, rhs);
                let p =
                    sample_on_lateral_profile(s, lambda, h, depth, p[c], rhs, curvature, spread);
                let (phi0, dphi0) =
                    lateral_profile_from_sample(s, lambda, h, depth, p, rhs, curvature);
                boundary.exitance(d, phi0, dphi0, qv) + part_v[c]
            })
        })
        .collect())
}

/// Per display vertex, the Shepard interpolation (shading weights) of per-node sources; the
/// right-hand sides are left for the caller to recompute with the vertex's own h.
pub(super) fn shade_sources(
    graph: &QuadGraph,
    per_node: &[LocalSource],
) -> Result<Vec<LocalSource>, SolverError> {
    let fields: [fn(&LocalSource) -> [f64; 3]; 5] = [
        |s| s.phi_p,
        |s| s.dphi_p,
        |s| s.q_flux,
        |s| s.transmitted,
        |s| s.absorbed,
    ];
    let shaded: Vec<Vec<[f32; 3]>> = fields
        .iter()
        .map(|f| shade_vertices(graph, &per_node.iter().map(f).collect::<Vec<_>>()))
        .collect::<Result<_, _>>()?;
    let d = |v: [f32; 3]| v.map(f64::from);
    Ok((0..graph.surface.positions.len())
        .map(|v| LocalSource {
            rhs: [0.0; 3],
            phi_p: d(shaded[0][v]),
            dphi_p: d(shaded[1][v]),
            q_flux: d(shaded[2][v]),
            transmitted: d(shaded[3][v]),
            absorbed: d(shaded[4][v]),
        })
        .collect())
}

/// The light visibility of the shading points ([`Transport::own_visibility`]): per surface node
/// its visibility where its sources are the lit beam's (so proportional to it), -1 where they
/// are not (facing away, a beam through the body); per display vertex the same at the vertex
/// (its own normal, a ray from it).
pub struct OwnVisibility {
    pub nodes: Vec<f64>,
    pub vertices: Vec<f64>,
}

impl OwnVisibility {
    /// `None` unless the scene has exactly one light and no environment (whose sources do not
    /// follow the light's visibility); `offset` lifts ray origins.
    pub fn new(
        graph: &QuadGraph,
        scene: &Scene,
        occluder: Option<&dyn Solid>,
        continuation: bool,
        offset: f64,
    ) -> Option<Self> {
        let ([light], Environment::None) = (scene.lights.as_slice(), &scene.environment) else {
            return None;
        };
        let visibility = |x: DVec3, n: DVec3| -> f64 {
            let (e, l, _) = light.arriving(x);
            if n.dot(l) <= 0.0 || e.iter().all(|&v| v == 0.0) {
                return -1.0;
            }
            match arrival(light, x, n, occluder, offset, continuation) {
                Arrival::Lit { .. } => 1.0,
                Arrival::Behind { .. } => -1.0,
                Arrival::Dark => 0.0,
            }
        };
        let level = graph.finest();
        let inner = level.inner_count();
        let nodes = (0..level.surface_count())
            .into_par_iter()
            .map(|s| visibility(level.positions[inner + s], level.surface_normals[s]))
            .collect();
        let surface = &graph.surface;
        let vertices = (0..surface.positions.len())
            .into_par_iter()
            .map(|v| {
                let n = surface.normals.get(v).copied().unwrap_or(DVec3::Y);
                visibility(surface.positions[v], n.normalize_or(DVec3::Y))
            })
            .collect();
        Some(Self { nodes, vertices })
    }
}

/// A vertex's sources q and collimated part P at its own light visibility `own` (the GPU's
/// `vertex_interior.glsl`, the same formula), from its source nodes' `(weight, q, P,
/// visibility)`: those whose visibility is -1 add w q and w P as before; the others' (the lit
/// beam's, proportional to their visibility) are taken per unit weighted visibility times the
/// vertex's where that is below their weighted visibility (a cast shadow's dark side: a lit
/// vertex keeps the nodes' average, whose lateral loss toward the shadow the 1D profile lacks;
/// taking it whole there made the front-lit bunny's lit edge 1.124x too bright). Unchanged where
/// the vertex's own is -1 or none of those nodes is lit.
pub fn own_visibility_sources(
    nodes: impl Iterator<Item = (f64, [f64; 3], [f64; 3], f64)>,
    own: f64,
) -> ([f64; 3], [f64; 3]) {
    let (mut q, mut part, mut q_beam, mut part_beam) = ([0.0; 3], [0.0; 3], [0.0; 3], [0.0; 3]);
    let (mut w_beam, mut w_vis) = (0.0, 0.0);
    for (w, qk, pk, vis) in nodes {
        for c in 0..3 {
            q[c] += w * qk[c];
            part[c] += w * pk[c];
            if vis >= 0.0 {
                q_beam[c] += w * qk[c];
                part_beam[c] += w * pk[c];
            }
        }
        if vis >= 0.0 {
            w_beam += w;
            w_vis += w * vis;
        }
    }
    if !(own >= 0.0 && w_vis > OWN_VISIBILITY_LIT * w_beam) {
        return (q, part);
    }
    let f = (own * w_beam / w_vis).min(1.0) - 1.0;
    (
        std::array::from_fn(|c| q[c] + f * q_beam[c]),
        std::array::from_fn(|c| part[c] + f * part_beam[c]),
    )
}

/// The beam nodes' weighted visibility (a share of their weight) at or below which
/// [`own_visibility_sources`] leaves a vertex's sources as they are (none of them lit: their
/// sources per unit visibility are unknown); `vertex_interior.glsl`'s `OWN_VISIBILITY_LIT`.
pub const OWN_VISIBILITY_LIT: f64 = 1e-3;
