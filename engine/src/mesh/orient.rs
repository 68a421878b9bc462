//! Face orientation: which way each face of a mesh faces out of its solid.
//!
//! The generalized winding number needs neighbouring faces wound the same way (a sphere with every
//! other face flipped has `w = 0` inside). [`make_coherent`] turns faces to agree with their
//! neighbours across manifold edges, by a breadth-first walk over each connected part (what
//! "re-orient coherently" tools do); a consistently wound mesh, any mesh [`TriMesh::validate`]
//! accepts without force, is left as it is. [`outward_flips`] then decides, per part, whether its
//! normals point out of the solid: its largest face's normal must lead from larger `|w|` (inside)
//! to smaller (outside). For a closed mesh this is the sign of its volume; it also handles parts
//! wound inside-out, shells whose inner wall faces the cavity, and open parts.

use std::collections::VecDeque;

use glam::DVec3;
use rayon::prelude::*;

use super::bvh::Bvh;
use super::TriMesh;

/// A connected part (faces joined by manifold edges): its faces and its largest face.
pub(crate) struct Part {
    faces: Vec<u32>,
    largest: u32,
}

/// Turns faces wound against their neighbours (swapping two corners) and returns the connected
/// parts and the number of faces turned. Indices must be in range.
pub(crate) fn make_coherent(mesh: &mut TriMesh) -> (Vec<Part>, usize) {
    let faces = mesh.indices.len();
    // Each edge use as (low, high, face, forward); sorted, the uses of one edge are adjacent.
    let mut uses: Vec<(u32, u32, u32, bool)> = Vec::with_capacity(3 * faces);
    for (f, t) in mesh.indices.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            uses.push((a.min(b), a.max(b), f as u32, a < b));
        }
    }
    uses.par_sort_unstable();
    // Neighbours across manifold edges, and whether the two traverse the edge the same way (then
    // one of them winds against the other).
    // A face has three edges, so at most three manifold neighbours: fixed slots, no allocation.
    const NONE: (u32, bool) = (u32::MAX, false);
    let mut neighbours = vec![[NONE; 3]; faces];
    let mut link = |f: u32, g: u32, against: bool| {
        if let Some(slot) = neighbours[f as usize].iter_mut().find(|s| s.0 == u32::MAX) {
            *slot = (g, against);
        }
    };
    for run in uses.chunk_by(|x, y| (x.0, x.1) == (y.0, y.1)) {
        if let [(_, _, f, fwd_f), (_, _, g, fwd_g)] = run {
            link(*f, *g, fwd_f == fwd_g);
            link(*g, *f, fwd_f == fwd_g);
        }
    }
    let area = |f: u32| {
        let [a, b, c] = mesh.indices[f as usize].map(|i| mesh.positions[i as usize]);
        0.5 * (b - a).cross(c - a).length()
    };
    let mut turn = vec![false; faces];
    let mut seen = vec![false; faces];
    let mut parts = Vec::new();
    let mut queue = VecDeque::new();
    for seed in 0..faces as u32 {
        if seen[seed as usize] {
            continue;
        }
        seen[seed as usize] = true;
        queue.push_back(seed);
        let mut part = Part {
            faces: Vec::new(),
            largest: seed,
        };
        while let Some(f) = queue.pop_front() {
            part.faces.push(f);
            if area(f) > area(part.largest) {
                part.largest = f;
            }
            for &(g, against) in &neighbours[f as usize] {
                if g != u32::MAX && !seen[g as usize] {
                    seen[g as usize] = true;
                    turn[g as usize] = turn[f as usize] ^ against;
                    queue.push_back(g);
                }
            }
        }
        parts.push(part);
    }
    let mut turned = 0;
    for (t, turn) in mesh.indices.iter_mut().zip(turn) {
        if turn {
            t.swap(1, 2);
            turned += 1;
        }
    }
    (parts, turned)
}

/// Per mesh face of a coherent mesh: whether its geometric normal `(b - a) x (c - a)` must be
/// flipped to point out of the solid that `bvh` (built over the same faces) describes.
pub(crate) fn outward_flips(mesh: &TriMesh, bvh: &Bvh, parts: &[Part]) -> Vec<bool> {
    let (lo, hi) = mesh.bounds();
    let floor = 1e-9 * (hi - lo).length();
    let inward: Vec<bool> = parts
        .par_iter()
        .map(|part| {
            let [a, b, c] = mesh.indices[part.largest as usize].map(|i| mesh.positions[i as usize]);
            let n = (b - a).cross(c - a);
            if n == DVec3::ZERO {
                return false; // a part of zero-area faces bounds nothing and is never hit
            }
            let centre = (a + b + c) / 3.0;
            // Close enough that no other surface lies between the two samples.
            let step = (1e-3 * n.length().sqrt()).max(floor);
            let n = n.normalize();
            let ahead = bvh.winding_number(centre + n * step).abs();
            let behind = bvh.winding_number(centre - n * step).abs();
            ahead > behind
        })
        .collect();
    let mut flips = vec![false; mesh.indices.len()];
    for (part, inward) in parts.iter().zip(inward) {
        for &f in &part.faces {
            flips[f as usize] = inward;
        }
    }
    flips
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::shapes::Shape;

    #[test]
    fn consistent_meshes_are_kept_and_checkered_ones_made_coherent() {
        for shape in [
            Shape::Sphere { radius: 3.0 },
            Shape::Torus {
                major: 3.0,
                minor: 1.0,
            },
            Shape::Box {
                half_extents: DVec3::new(3.0, 1.0, 2.0),
            },
            Shape::Capsule {
                half_length: 2.0,
                radius: 1.0,
            },
        ] {
            let mut mesh = shape.triangulate(12);
            let before = mesh.indices.clone();
            let (parts, turned) = make_coherent(&mut mesh);
            assert_eq!((turned, parts.len()), (0, 1), "{shape:?}");
            assert_eq!(mesh.indices, before);

            // Every other face flipped: exactly those are turned back (the seed, face 0, is kept).
            let mut checkered = shape.triangulate(12);
            for t in checkered.indices.iter_mut().skip(1).step_by(2) {
                t.swap(1, 2);
            }
            let (_, turned) = make_coherent(&mut checkered);
            assert_eq!(turned, before.len() / 2, "{shape:?}");
            let volume = |m: &TriMesh| m.signed_volume();
            assert!((volume(&checkered) - volume(&mesh)).abs() < 1e-9 * volume(&mesh));
        }
    }
}
