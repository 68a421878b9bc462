//! One bounce of exitance between surface points (DESIGN 2.5's fourth cause, issue 12 item 5): at
//! eta = 1 nothing reflects light that leaves a concave object back, so it crosses the air and
//! enters the object again elsewhere (the inside of a torus, the bunny's folds). Per surface node,
//! cosine-weighted rays over its outer hemisphere find the object's surface; the radiance leaving
//! it there towards the node (the exit query's lobe of the nearest surface node's exitance)
//! arrives as a beam, which the source model turns into a particular solution or a boundary flux.
//! The CPU reference's form; a GPU version would take visibility from the shadow/depth machinery.
//!
//! ```no_run
//! # use translucent::solver::{self, CpuSolveParams, transport::Transport};
//! # fn demo(graph: &translucent::QuadGraph, field: &translucent::material::MaterialField,
//! #         scene: &translucent::scene::Scene, solid: &dyn translucent::mesh::Solid) -> Result<(), solver::SolverError> {
//! let transport = Transport { bounce_rays: 64, ..Transport::collimated() };
//! let params = CpuSolveParams { transport, ..Default::default() };
//! let with_bounce = solver::solve(graph, field, scene, Some(solid), &params)?;
//! # Ok(()) }
//! ```

use std::f64::consts::PI;

use kiddo::immutable::float::kdtree::ImmutableKdTree;
use kiddo::SquaredEuclidean;
use rayon::prelude::*;

use super::sources::{LocalSource, SourceModel};
use super::transport::tangent_frame;
use crate::mesh::Solid;
use crate::quadgraph::graph::GraphLevel;

/// Nearest surface nodes examined for one whose normal agrees with the surface hit.
const CANDIDATES: usize = 8;

/// A hash of two integers to [0, 1) (deterministic jitter for stratified rays).
fn hash01(a: u64, b: u64) -> f64 {
    let mut z = a
        .wrapping_mul(0x9e37_79b9_7f4a_7c15)
        .wrapping_add(b.wrapping_mul(0xbf58_476d_1ce4_e5b9));
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
}

/// The light arriving at every surface node of `level` from the rest of the object's surface,
/// whose exitance per surface node is `exitance`, as sources for the node's Robin row (`row_h`
/// its extrapolation lengths). `rays` per node (rounded to a square of strata).
pub fn bounce_sources(
    level: &GraphLevel,
    exitance: &[[f64; 3]],
    model: &SourceModel,
    solid: &dyn Solid,
    row_h: &[[f64; 3]],
    rays: u32,
) -> Vec<LocalSource> {
    let inner = level.inner_count();
    let surface = &level.positions[inner..];
    let coords: Vec<[f64; 3]> = surface.iter().map(|p| p.to_array()).collect();
    let tree: ImmutableKdTree<f64, u32, 3, 32> = ImmutableKdTree::new_from_slice(&coords);
    let strata = (f64::from(rays).sqrt().ceil() as u32).max(1);
    let total = f64::from(strata * strata);
    let offset = 1e-4 * level.spacing.max(1e-6);
    (0..surface.len())
        .into_par_iter()
        .map(|s| {
            let (x, n) = (surface[s], level.surface_normals[s]);
            let (t, b) = tangent_frame(n);
            let mut beams = Vec::new();
            for i in 0..strata {
                for j in 0..strata {
                    let key = (s as u64) << 20 | u64::from(i * strata + j);
                    let u1 = (f64::from(i) + hash01(key, 1)) / f64::from(strata);
                    let u2 = (f64::from(j) + hash01(key, 2)) / f64::from(strata);
                    // Cosine-weighted: each ray stands for pi / total of the irradiance.
                    let (r, phi) = (u1.sqrt(), 2.0 * PI * u2);
                    let dir = n * (1.0 - u1).max(0.0).sqrt() + (t * phi.cos() + b * phi.sin()) * r;
                    let Some((hit_t, hit_n)) = solid.ray_hit(x + n * offset, dir, f64::INFINITY)
                    else {
                        continue;
                    };
                    let cos_out = -hit_n.dot(dir);
                    if cos_out <= 0.0 {
                        continue;
                    }
                    let y = x + n * offset + dir * hit_t;
                    let near = tree.nearest_n::<SquaredEuclidean>(
                        &y.to_array(),
                        std::num::NonZero::new(CANDIDATES)
                            .unwrap_or(std::num::NonZero::<usize>::MIN),
                    );
                    let Some(source) = near
                        .iter()
                        .find(|c| level.surface_normals[c.item as usize].dot(hit_n) > 0.0)
                    else {
                        continue;
                    };
                    let m = exitance[source.item as usize];
                    let irr: [f64; 3] = std::array::from_fn(|c| {
                        PI / total * model.boundary.radiance(m[c].max(0.0), cos_out)
                    });
                    beams.push((n.dot(dir), irr));
                }
            }
            let here = model.material.sample(x);
            model.diffuse_beams(&here, row_h[s], &beams, true)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hash_is_uniform_enough() {
        let mean: f64 = (0..10_000).map(|i| hash01(i, 7)).sum::<f64>() / 10_000.0;
        assert!((mean - 0.5).abs() < 0.01, "{mean}");
        assert!((0..1000).all(|i| (0.0..1.0).contains(&hash01(i, 3))));
    }
}
