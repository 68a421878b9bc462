//! CPU references of the voxel method: Dijkstra's algorithm on the same grid, in the same f32
//! arithmetic as the GPU relaxation, so the two agree bit for bit (`tests/tests/voxel_relax.rs`).
//!
//! ```
//! use translucent::solver::voxel::cpu::{dijkstra, VoxelGraph, N_UNLIT};
//! // A 3 x 1 x 1 row of solid voxels lit at the left end.
//! let graph = VoxelGraph {
//!     dims: [3, 1, 1],
//!     h: 0.5,
//!     solid: vec![true; 3],
//!     sigma: vec![[2.0, 1.0, 0.0]; 3],
//!     seed: vec![[0.0; 3], [N_UNLIT; 3], [N_UNLIT; 3]],
//! };
//! let n = dijkstra(&graph);
//! assert_eq!(n[2], [2.0, 1.0, 0.0]); // two edges of 0.5 mm at sigma 2, 1, 0
//! ```

use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// The optical depth of an unreached or unlit voxel (`N_UNLIT` in `include/voxel_grid.glsl`).
pub const N_UNLIT: f32 = 1e30;

/// Edge length factors of the 26-neighbourhood in f32 (1, sqrt 2, sqrt 3), as the shaders'
/// `edge_factor` returns them.
pub const EDGE_FACTORS: [f32; 3] = [1.0, std::f32::consts::SQRT_2, 1.732_050_8];

/// A voxel graph as the GPU relaxation sees it (read back from the GPU's volumes, so both start
/// from the same bits).
#[derive(Clone, Debug, PartialEq)]
pub struct VoxelGraph {
    pub dims: [u32; 3],
    /// Voxel size, mm (f32, as the GPU fitted it).
    pub h: f32,
    /// Per voxel, x fastest.
    pub solid: Vec<bool>,
    /// The per-mm cost coefficient per channel.
    pub sigma: Vec<[f32; 3]>,
    /// n0 per channel (N_UNLIT where no light enters).
    pub seed: Vec<[f32; 3]>,
}

/// The edge cost of `voxel/relax_common.glsl`'s `edge_cost`: (a + b) * 0.5 * len, in f32.
pub fn edge_cost(a: f32, b: f32, len: f32) -> f32 {
    let mean = (a + b) * 0.5;
    mean * len
}

#[derive(PartialEq)]
struct Entry {
    n: f32,
    voxel: usize,
}

impl Eq for Entry {}

impl Ord for Entry {
    // A min-heap on n; on equal n the lower voxel index first. The values do not depend on the
    // order of ties: an equal cost is the same number whichever path gives it.
    fn cmp(&self, other: &Self) -> Ordering {
        other
            .n
            .total_cmp(&self.n)
            .then_with(|| other.voxel.cmp(&self.voxel))
    }
}

impl PartialOrd for Entry {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

/// The shortest optical path to every solid voxel, per channel: Dijkstra from every seeded voxel
/// at once (the paper's "weighted goal nodes": each starts at its own n0), over the
/// 26-neighbourhood of solid voxels, with [`edge_cost`]. Unreached voxels keep N_UNLIT; empty
/// voxels keep their seed.
///
/// f32 addition is monotone (a <= b implies a + c <= b + c after rounding) and costs are >= 0, so
/// Dijkstra's greedy order is valid for the rounded sums, and the result is the minimum over all
/// paths of the path's cost summed in path order: the Bellman-Ford fixed point the GPU reaches.
pub fn dijkstra(graph: &VoxelGraph) -> Vec<[f32; 3]> {
    let [nx, ny, nz] = graph.dims.map(|d| d as i64);
    let count = (nx * ny * nz) as usize;
    assert!(
        graph.solid.len() == count && graph.sigma.len() == count && graph.seed.len() == count,
        "graph arrays must have one entry per voxel"
    );
    let mut result = graph.seed.clone();
    let index = |x: i64, y: i64, z: i64| (x + nx * (y + ny * z)) as usize;
    let mut offsets = Vec::new();
    for z in -1i64..=1 {
        for y in -1i64..=1 {
            for x in -1i64..=1 {
                let k = (x.abs() + y.abs() + z.abs()) as usize;
                if k > 0 {
                    offsets.push(([x, y, z], graph.h * EDGE_FACTORS[k - 1]));
                }
            }
        }
    }
    for c in 0..3 {
        let mut n: Vec<f32> = graph.seed.iter().map(|s| s[c]).collect();
        let mut done = vec![false; count];
        let mut heap: BinaryHeap<Entry> = (0..count)
            .filter(|&i| graph.solid[i] && n[i] < N_UNLIT)
            .map(|i| Entry { n: n[i], voxel: i })
            .collect();
        while let Some(Entry { n: d, voxel }) = heap.pop() {
            if done[voxel] || d > n[voxel] {
                continue;
            }
            done[voxel] = true;
            let (x, y, z) = (
                voxel as i64 % nx,
                (voxel as i64 / nx) % ny,
                voxel as i64 / (nx * ny),
            );
            for &([ox, oy, oz], len) in &offsets {
                let (ux, uy, uz) = (x + ox, y + oy, z + oz);
                if ux < 0 || uy < 0 || uz < 0 || ux >= nx || uy >= ny || uz >= nz {
                    continue;
                }
                let u = index(ux, uy, uz);
                if !graph.solid[u] || done[u] {
                    continue;
                }
                let candidate = d + edge_cost(graph.sigma[u][c], graph.sigma[voxel][c], len);
                if candidate < n[u] {
                    n[u] = candidate;
                    heap.push(Entry {
                        n: candidate,
                        voxel: u,
                    });
                }
            }
        }
        for (r, v) in result.iter_mut().zip(&n) {
            r[c] = *v;
        }
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Bellman-Ford to its fixed point, the GPU's Jacobi on the CPU.
    fn bellman_ford(graph: &VoxelGraph) -> Vec<[f32; 3]> {
        let [nx, ny, nz] = graph.dims.map(|d| d as i64);
        let mut n = graph.seed.clone();
        loop {
            let mut next = n.clone();
            for z in 0..nz {
                for y in 0..ny {
                    for x in 0..nx {
                        let v = (x + nx * (y + ny * z)) as usize;
                        if !graph.solid[v] {
                            continue;
                        }
                        for oz in -1i64..=1 {
                            for oy in -1i64..=1 {
                                for ox in -1i64..=1 {
                                    let k = (ox.abs() + oy.abs() + oz.abs()) as usize;
                                    let (ux, uy, uz) = (x + ox, y + oy, z + oz);
                                    if k == 0
                                        || ux < 0
                                        || uy < 0
                                        || uz < 0
                                        || ux >= nx
                                        || uy >= ny
                                        || uz >= nz
                                    {
                                        continue;
                                    }
                                    let u = (ux + nx * (uy + ny * uz)) as usize;
                                    if !graph.solid[u] {
                                        continue;
                                    }
                                    let len = graph.h * EDGE_FACTORS[k - 1];
                                    for c in 0..3 {
                                        let cand = n[u][c]
                                            + edge_cost(graph.sigma[u][c], graph.sigma[v][c], len);
                                        next[v][c] = next[v][c].min(cand);
                                    }
                                }
                            }
                        }
                    }
                }
            }
            if next == n {
                return n;
            }
            n = next;
        }
    }

    #[test]
    fn dijkstra_equals_the_bellman_ford_fixed_point_bit_for_bit() {
        // A 9^3 block with a hole, irregular coefficients and seeds of different strength.
        let dims = [9u32, 7, 8];
        let count = (dims[0] * dims[1] * dims[2]) as usize;
        let mut state = 12345u32;
        let mut random = || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            state as f32 / u32::MAX as f32
        };
        let solid: Vec<bool> = (0..count).map(|_| random() > 0.15).collect();
        let sigma: Vec<[f32; 3]> = (0..count)
            .map(|_| [random() * 3.0, random() * 0.1, 1e4 * random()])
            .collect();
        let seed: Vec<[f32; 3]> = (0..count)
            .map(|_| {
                if random() > 0.9 {
                    [-random().ln(), 2.0 * random(), 0.0]
                } else {
                    [N_UNLIT; 3]
                }
            })
            .collect();
        let graph = VoxelGraph {
            dims,
            h: 0.37,
            solid,
            sigma,
            seed,
        };
        let d = dijkstra(&graph);
        let b = bellman_ford(&graph);
        assert_eq!(d, b);
        assert!(d.iter().flatten().all(|v| v.is_finite()));
        // Something was relaxed (the test can fail).
        assert!(d.iter().zip(&graph.seed).any(|(a, s)| a[0] < s[0]));
    }
}
