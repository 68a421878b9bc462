//! The f64 reference's surface reconstructions at the display vertices (issue 12 item 4): the
//! exit query on the local 1D profile through each vertex's interior sample, and the shading
//! weights' interpolation of per-node sources they start from.

use super::*;

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
pub fn interior_vertices(
    graph: &QuadGraph,
    boundary: &Boundary,
    material: &MaterialField,
    sources: &[LocalSource],
    phi_h: &[[f64; 3]],
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
            let (q_v, part_v) = (
                samples.source_average(v, &q),
                samples.source_average(v, &part),
            );
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
