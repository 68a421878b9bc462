//! Single scattering (DESIGN 2.8) in f64, per display vertex, for one eye: the refracted view ray
//! is marched at exponentially stratified depths up to the object's far face; at each depth the
//! light arrives through the object from where its beam entered (exact visibility by ray casting,
//! the refracted light path by Jensen's correction s mu_i / mu_t, heterogeneous optical depths
//! through the material field), is scattered with the isotropic phase function p = 1 / (4 pi)
//! (reduced coefficients, as the references) and leaves through the boundary with T_o / eta^2.
//!
//! The result is what the mesh pass shades (F_t X / (pi eta^2) is the radiance): X = pi S with
//! L_ss = (T_o / eta^2) S. [`SingleScattering::Difference`] subtracts the flat-surface closed
//! form of each light that lights the vertex directly (what [`super::transport::Source::Collimated`]
//! already carries); [`SingleScattering::Full`] adds everything, the environment's single
//! scattering by the flat closed form (it is unshadowed, as its diffusion part).
//!
//! ```no_run
//! # use translucent::solver::{self, single_scattering::vertex_single_scattering, transport::Transport};
//! # fn demo(graph: &translucent::QuadGraph, field: &translucent::material::MaterialField,
//! #         scene: &translucent::scene::Scene, solid: &dyn translucent::mesh::Solid) {
//! let eye = glam::DVec3::new(0.0, 20.0, 60.0);
//! let ss = vertex_single_scattering(&graph.surface, field, scene, solid, &Transport::second_collision(), eye, 16);
//! assert_eq!(ss.len(), graph.surface.positions.len());
//! # }
//! ```

use std::f64::consts::PI;

use glam::DVec3;
use rayon::prelude::*;

use super::sources::{arrival, environment_beams, Arrival};
use super::transport::{
    flat_single_scattering, refract_inward, Refraction, SingleScattering, Transport,
};
use crate::material::{Coefficients, MaterialField};
use crate::mesh::{Solid, TriMesh};
use crate::scene::Scene;

/// Material samples per segment for heterogeneous optical depths (midpoint rule).
const DEPTH_SAMPLES: usize = 8;
/// Beyond this optical depth a path contributes nothing worth a ray (exp(-30)).
const MAX_OPTICAL_DEPTH: f64 = 30.0;

fn sigma_t(c: &Coefficients) -> [f64; 3] {
    std::array::from_fn(|ch| c.sigma_s[ch] + c.sigma_a[ch])
}

/// Optical depth per channel along the straight segment from `a` to `b`.
fn optical_depth(material: &MaterialField, a: DVec3, b: DVec3) -> [f64; 3] {
    let length = a.distance(b);
    if let MaterialField::Homogeneous(m) = material {
        return std::array::from_fn(|ch| (m.sigma_s[ch] + m.sigma_a[ch]) * length);
    }
    let mut tau = [0.0; 3];
    for k in 0..DEPTH_SAMPLES {
        let st = sigma_t(&material.sample(a.lerp(b, (k as f64 + 0.5) / DEPTH_SAMPLES as f64)));
        for ch in 0..3 {
            tau[ch] += st[ch] * length / DEPTH_SAMPLES as f64;
        }
    }
    tau
}

/// Per vertex of `mesh` (outward normals), the single-scattering shading value X (see the module
/// doc) seen from `eye`, with `samples` depths along each view ray. Zero where the vertex faces
/// away from the eye or `transport.single_scattering` is off.
pub fn vertex_single_scattering(
    mesh: &TriMesh,
    material: &MaterialField,
    scene: &Scene,
    solid: &dyn Solid,
    transport: &Transport,
    eye: DVec3,
    samples: usize,
) -> Vec<[f64; 3]> {
    let mode = transport.single_scattering;
    if mode == SingleScattering::Off || samples == 0 {
        return vec![[0.0; 3]; mesh.positions.len()];
    }
    let eta = material.eta();
    let (lo, hi) = solid.bounds();
    let span = (hi - lo).length().max(1e-9);
    let offset = 1e-6 * span;
    (0..mesh.positions.len())
        .into_par_iter()
        .map(|v| {
            let x = mesh.positions[v];
            let n = mesh
                .normals
                .get(v)
                .copied()
                .unwrap_or(DVec3::ZERO)
                .normalize_or_zero();
            let to_eye = (eye - x).normalize_or_zero();
            let mu_o = n.dot(to_eye);
            if mu_o <= 0.0 || n == DVec3::ZERO {
                return [0.0; 3];
            }
            let w = refract_inward(-to_eye, n, eta);
            let mu_o_inside = -w.dot(n);
            let start = x - n * offset;
            let t_max = solid
                .ray_hit(start, w, 2.0 * span)
                .map_or(2.0 * span, |(t, _)| t);
            let here = material.sample(start);
            let st_here = sigma_t(&here);
            let sigma_ref = (st_here[0] + st_here[1] + st_here[2]) / 3.0;
            let mass = 1.0 - (-sigma_ref * t_max).exp();
            let mut sum = [0.0; 3];
            for k in 0..samples {
                // Stratified in the exponential's cumulative distribution on [0, t_max].
                let u = (k as f64 + 0.5) / samples as f64;
                let t = -(1.0 - u * mass).ln() / sigma_ref;
                let pdf = sigma_ref * (-sigma_ref * t).exp() / mass;
                let xk = start + w * t;
                let tau_v = optical_depth(material, start, xk);
                if tau_v.iter().all(|&t| t > MAX_OPTICAL_DEPTH) {
                    continue;
                }
                let at = material.sample(xk);
                for light in &scene.lights {
                    let (e, l, dist) = light.arriving(xk);
                    if e.iter().all(|&c| c == 0.0) {
                        continue;
                    }
                    // The beam enters where the ray from x_k towards the light leaves the object.
                    let Some((te, ne)) = solid.ray_hit(xk, l, dist) else {
                        continue;
                    };
                    let mu_i = ne.dot(l);
                    let entry = xk + l * te;
                    if mu_i <= 0.0 || solid.occluded(entry + ne * offset, l, dist - te) {
                        continue;
                    }
                    let r = Refraction::new(eta, mu_i);
                    let jensen = mu_i / r.mu_t.max(1e-6);
                    let tau_l = optical_depth(material, xk, entry);
                    let (e_entry, _, _) = light.arriving(entry);
                    for ch in 0..3 {
                        let tau = tau_l[ch] * jensen + tau_v[ch];
                        if tau > MAX_OPTICAL_DEPTH {
                            continue;
                        }
                        // Fluence of the refracted beam: E mu_i T_i / mu_t.
                        let fluence = e_entry[ch] * mu_i * r.t_i / r.mu_t.max(1e-6);
                        sum[ch] += at.sigma_s[ch] / (4.0 * PI) * fluence * (-tau).exp()
                            / (samples as f64 * pdf);
                    }
                }
            }
            let albedo: [f64; 3] = std::array::from_fn(|ch| here.sigma_s[ch] / st_here[ch]);
            match mode {
                SingleScattering::Difference => {
                    for light in &scene.lights {
                        if let Arrival::Lit { irradiance, mu_i } =
                            arrival(light, x, n, Some(solid), offset, false)
                        {
                            let r = Refraction::new(eta, mu_i);
                            for ch in 0..3 {
                                sum[ch] -= flat_single_scattering(
                                    albedo[ch],
                                    r,
                                    mu_o_inside,
                                    irradiance[ch] * mu_i,
                                );
                            }
                        }
                    }
                }
                SingleScattering::Full => {
                    for (mu, irr) in environment_beams(&scene.environment, n) {
                        let r = Refraction::new(eta, mu);
                        for ch in 0..3 {
                            sum[ch] += flat_single_scattering(albedo[ch], r, mu_o_inside, irr[ch]);
                        }
                    }
                }
                SingleScattering::Off => {}
            }
            // X = pi S: the mesh pass multiplies by F_t / (pi eta^2), T_o / eta^2 of L_ss.
            sum.map(|s| PI * s)
        })
        .collect()
}
