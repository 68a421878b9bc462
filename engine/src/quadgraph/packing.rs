//! Texture packing (paper section 5.1, DESIGN section 3 step 10): nodes go into `r x r` texel blocks
//! of a 2D texture, each block filled by a breadth-first traversal of connected nodes, so that a
//! node's neighbours are mostly in its own block (cache hits on the GPU). Inner nodes are connected
//! through shared faces; surface nodes through boundary faces sharing an edge (the paper's
//! "proximity on the surface").
//!
//! ```
//! # use translucent::quadgraph::packing::pack_order;
//! // A path graph 0-1-2-3 packs in one block, in order.
//! let adj = vec![vec![1], vec![0, 2], vec![1, 3], vec![2]];
//! let blocks = pack_order(&adj, 4);
//! assert_eq!(blocks, vec![vec![0, 1, 2, 3]]);
//! ```

use std::collections::{HashMap, VecDeque};

use super::graph::{GraphLevel, Packing, NO_NODE, TET_FACES};

/// Texture width in texels: the smallest multiple of `block` at least the square root of the node
/// count, so that the textures are about square.
fn texture_width(nodes: usize, block: u32) -> u32 {
    let side = (nodes as f64).sqrt().ceil() as u32;
    side.div_ceil(block).max(1) * block
}

/// Groups nodes (`0..adjacency.len()`) into blocks of `capacity` (the last may be short): each block
/// grows by a breadth-first traversal from a seed, which walks through already assigned nodes
/// without taking them; the next block's seed is the first unassigned node left in the previous
/// block's queue (paper section 5.1).
pub fn pack_order(adjacency: &[Vec<u32>], capacity: usize) -> Vec<Vec<u32>> {
    let n = adjacency.len();
    let mut assigned = vec![false; n];
    let mut seen_in = vec![u32::MAX; n];
    let mut blocks = Vec::new();
    let mut scan = 0usize;
    let mut next_seed: Option<u32> = None;
    let mut remaining = n;
    // Walking through assigned nodes is bounded so that a block surrounded by full ones does not
    // traverse the whole graph; a traversal that runs dry restarts at the first unassigned node,
    // so every block but the last is full.
    let walk_budget = 16 * capacity;
    while remaining > 0 {
        let id = blocks.len() as u32;
        let mut block = Vec::with_capacity(capacity);
        let mut queue: VecDeque<u32> = VecDeque::new();
        let mut budget = 0usize;
        let mut seed = next_seed.take().filter(|&s| !assigned[s as usize]);
        while block.len() < capacity && remaining > 0 {
            let v = match queue.pop_front() {
                Some(v) if budget > 0 => v,
                _ => {
                    let s = seed.take().unwrap_or_else(|| {
                        while assigned[scan] {
                            scan += 1;
                        }
                        scan as u32
                    });
                    queue.clear();
                    budget = walk_budget;
                    seen_in[s as usize] = id;
                    s
                }
            };
            budget -= 1;
            if !assigned[v as usize] {
                assigned[v as usize] = true;
                block.push(v);
                remaining -= 1;
            }
            for &w in &adjacency[v as usize] {
                if seen_in[w as usize] != id {
                    seen_in[w as usize] = id;
                    queue.push_back(w);
                }
            }
        }
        next_seed = queue.into_iter().find(|&v| !assigned[v as usize]);
        blocks.push(block);
    }
    blocks
}

/// Inner-node adjacency (shared faces) and surface-node adjacency (boundary faces sharing an edge),
/// each in its own local numbering.
fn adjacencies(level: &GraphLevel) -> (Vec<Vec<u32>>, Vec<Vec<u32>>) {
    let ni = level.inner_count();
    let inner: Vec<Vec<u32>> = level
        .neighbors
        .iter()
        .map(|nb| {
            nb.iter()
                .copied()
                .filter(|&j| j != NO_NODE && (j as usize) < ni)
                .collect()
        })
        .collect();
    let mut by_edge: HashMap<(u32, u32), Vec<u32>> = HashMap::new();
    for (s, &(t, f)) in level.surface_faces.iter().enumerate() {
        let tet = level.tets.tets[t as usize];
        let face = TET_FACES[f as usize].map(|l| tet[l]);
        for k in 0..3 {
            let (a, b) = (face[k], face[(k + 1) % 3]);
            by_edge
                .entry((a.min(b), a.max(b)))
                .or_default()
                .push(s as u32);
        }
    }
    let mut surface = vec![Vec::new(); level.surface_count()];
    for faces in by_edge.values() {
        for &a in faces {
            for &b in faces {
                if a != b {
                    surface[a as usize].push(b);
                }
            }
        }
    }
    for list in &mut surface {
        list.sort_unstable();
        list.dedup();
    }
    (inner, surface)
}

/// Lays blocks out row-major from texel row `row0`; returns the rows used (a multiple of `block`).
fn place_blocks(
    blocks: &[Vec<u32>],
    width: u32,
    block: u32,
    row0: u32,
    offset: u32,
    texels: &mut [[u32; 2]],
) -> u32 {
    let per_row = width / block;
    for (b, nodes) in blocks.iter().enumerate() {
        let (bx, by) = (b as u32 % per_row, b as u32 / per_row);
        for (k, &node) in nodes.iter().enumerate() {
            let (x, y) = (k as u32 % block, k as u32 / block);
            texels[(node + offset) as usize] = [bx * block + x, row0 + by * block + y];
        }
    }
    (blocks.len() as u32).div_ceil(per_row) * block
}

/// Packs `level` with breadth-first blocks (`random: false`) or in a shuffled order (`random: true`,
/// the baseline the locality figure is compared with).
pub fn pack(level: &GraphLevel, block: u32, random: bool) -> Packing {
    let (ni, ns) = (level.inner_count(), level.surface_count());
    let width = texture_width(level.node_count(), block);
    let capacity = (block * block) as usize;
    let (inner_blocks, surface_blocks) = if random {
        (
            chunks(shuffled(ni), capacity),
            chunks(shuffled(ns), capacity),
        )
    } else {
        let (inner_adj, surface_adj) = adjacencies(level);
        (
            pack_order(&inner_adj, capacity),
            pack_order(&surface_adj, capacity),
        )
    };
    let mut texels = vec![[0u32; 2]; ni + ns];
    let surface_rows = place_blocks(&surface_blocks, width, block, 0, ni as u32, &mut texels);
    let inner_rows = place_blocks(&inner_blocks, width, block, surface_rows, 0, &mut texels);
    Packing {
        width,
        height: surface_rows + inner_rows,
        surface_rows,
        block,
        texels,
    }
}

fn chunks(order: Vec<u32>, capacity: usize) -> Vec<Vec<u32>> {
    order.chunks(capacity).map(|c| c.to_vec()).collect()
}

/// A fixed pseudo-random permutation of `0..n` (xorshift, so the baseline is reproducible).
fn shuffled(n: usize) -> Vec<u32> {
    let mut v: Vec<u32> = (0..n as u32).collect();
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    for i in (1..n).rev() {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        v.swap(i, (state % (i as u64 + 1)) as usize);
    }
    v
}

/// Share of neighbour references (inner-inner and inner-surface, both directions) whose two nodes
/// sit in the same texel block.
pub fn locality(level: &GraphLevel, packing: &Packing) -> f64 {
    let b = packing.block.max(1);
    let block_of = |node: u32| {
        let [u, v] = packing.texels[node as usize];
        (u / b, v / b)
    };
    let (mut same, mut total) = (0u64, 0u64);
    for (i, nb) in level.neighbors.iter().enumerate() {
        for &j in nb {
            if j == NO_NODE {
                continue;
            }
            // Each reference is read by node i; surface -> inner references are counted too.
            let both = if (j as usize) < level.inner_count() {
                1
            } else {
                2
            };
            total += both;
            if block_of(i as u32) == block_of(j) {
                same += both;
            }
        }
    }
    if total == 0 {
        1.0
    } else {
        same as f64 / total as f64
    }
}
