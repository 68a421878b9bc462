//! The diffusion coefficient an object solves and shades with: per vertex, its surface mean, and
//! the material a method solves ([`super::ObjectParams::diffusion`]).

use glam::DVec3;

use crate::material::{DiffusionCoefficient, MaterialField};

/// D per channel (mm) at each of `positions` with the diffusion coefficient `diffusion`; 0
/// where a channel has no extinction or D is not finite.
pub(super) fn vertex_diffusion(
    field: &MaterialField,
    positions: &[DVec3],
    diffusion: DiffusionCoefficient,
) -> Vec<[f32; 3]> {
    positions
        .iter()
        .map(|&p| {
            let k = field.sample(p);
            std::array::from_fn(|c| {
                let d = diffusion.d(k.sigma_s[c], k.sigma_a[c]);
                if d.is_finite() && d >= 0.0 {
                    d as f32
                } else {
                    0.0
                }
            })
        })
        .collect()
}

/// The mean over `positions` of D per channel (mm) with the diffusion coefficient `diffusion`
/// (a homogeneous field: its own); finite, 0 where a channel has no extinction.
pub(super) fn surface_diffusion(
    field: &MaterialField,
    positions: &[DVec3],
    diffusion: DiffusionCoefficient,
) -> [f64; 3] {
    let d_at = |p: DVec3| {
        let k = field.sample(p);
        std::array::from_fn::<f64, 3, _>(|c| {
            let d = diffusion.d(k.sigma_s[c], k.sigma_a[c]);
            if d.is_finite() {
                d
            } else {
                0.0
            }
        })
    };
    if field.is_homogeneous() || positions.is_empty() {
        return d_at(DVec3::ZERO);
    }
    let mut sum = [0.0; 3];
    for &p in positions {
        let d = d_at(p);
        for c in 0..3 {
            sum[c] += d[c];
        }
    }
    sum.map(|s| s / positions.len() as f64)
}

/// The material a method solves: the QuadGraph method's with the object's diffusion
/// coefficient ([`ObjectParams::diffusion`]), the other methods' as given (they keep 1 / (3
/// sigma_t')).
pub(super) fn solved_field(
    field: &MaterialField,
    quadgraph: bool,
    diffusion: DiffusionCoefficient,
) -> std::borrow::Cow<'_, MaterialField> {
    if quadgraph && field.diffusion() != diffusion {
        std::borrow::Cow::Owned(field.clone().with_diffusion(diffusion))
    } else {
        std::borrow::Cow::Borrowed(field)
    }
}
