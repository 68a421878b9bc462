//! The material the march samples (DESIGN 2.8, "heterogeneous: tau through the material
//! field"): one set of coefficients, or a grid of the field over the display mesh's box.

use glam::DVec3;

use crate::material::MaterialField;

/// Nodes per axis of the material grid the march samples for a heterogeneous field (DESIGN 2.8,
/// "heterogeneous: tau through the material field"): the field sampled at the nodes of the
/// display mesh's bounding box, trilinear in between (1.2 MB). 33 nodes put a node every 0.6 mm
/// on the 20 mm split sphere, finer than the diffusion's finest spacing at the default
/// resolution (32 cells: ~0.8 mm), so the march sees the field the solve sees.
pub const MEDIUM_NODES: u32 = 33;

/// The `Medium` storage buffer's header of `march.comp`, followed by two vec4 per grid node
/// (sigma_s' rgb, then sigma_a rgb), x fastest.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct MediumHeader {
    /// x: nodes per axis; y: 1 = heterogeneous (sample the grid), 0 = the push constants'.
    pub nodes: [u32; 4],
    /// xyz: the grid's first node (object frame, mm).
    pub origin: [f32; 4],
    /// xyz: node spacing (mm).
    pub spacing: [f32; 4],
}

/// The march's material: a header and, for a heterogeneous field, [`MEDIUM_NODES`]^3 nodes.
pub(super) fn medium_data(field: &MaterialField, positions: &[DVec3]) -> Vec<[f32; 4]> {
    if matches!(field, MaterialField::Homogeneous(_)) || positions.is_empty() {
        let homogeneous = MediumHeader {
            nodes: [1, 0, 0, 0],
            origin: [0.0; 4],
            spacing: [1.0, 1.0, 1.0, 0.0],
        };
        return bytemuck::cast_slice(&[homogeneous]).to_vec();
    }
    let (lo, hi) = positions
        .iter()
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(*p), hi.max(*p))
        });
    let n = MEDIUM_NODES as usize;
    let spacing = ((hi - lo) / (n - 1) as f64).max(DVec3::splat(1e-9));
    let header = MediumHeader {
        nodes: [MEDIUM_NODES, 1, 0, 0],
        origin: lo.as_vec3().extend(0.0).to_array(),
        spacing: spacing.as_vec3().extend(0.0).to_array(),
    };
    let mut data: Vec<[f32; 4]> = bytemuck::cast_slice(&[header]).to_vec();
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let p = lo + spacing * DVec3::new(i as f64, j as f64, k as f64);
                let c = field.sample(p);
                let f = |v: [f64; 3]| [v[0] as f32, v[1] as f32, v[2] as f32, 0.0];
                data.push(f(c.sigma_s));
                data.push(f(c.sigma_a));
            }
        }
    }
    data
}
