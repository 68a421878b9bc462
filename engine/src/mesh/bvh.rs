//! Bounding volume hierarchy over the triangles of a mesh, shared by every query of
//! [`MeshSolid`](super::MeshSolid): ray casts, closest points and the fast generalized winding number.
//!
//! Built top-down by the binned surface-area heuristic (SAH: centroids binned along the longest
//! axis, costs from the triangles' bounds). Every node also stores the far-field moments of its
//! triangles (Barill et al. 2018, "Fast winding numbers for soups and clouds", section 3.2): the
//! area-weighted centre, the radius of a ball around it holding all the triangles, the dipole
//! `sum a_t n_t`, the second-order moment `sum a_t (c_t - centre) n_t^T` and the third-order one.
//! Far nodes are summed through these moments, near leaves exactly (Van Oosterom-Strackee solid
//! angles), which makes a query cost about logarithmic in the triangle count.
//! No crate we know of computes fast winding numbers for triangle soups with a quality we could rely
//! on, so this is written here and tested against the brute-force sum.

use glam::{DMat3, DVec3};
use rayon::prelude::*;

/// Triangles per leaf at most (unless they cannot be separated: identical centroids).
const LEAF_SIZE: usize = 4;
/// Bins of the SAH sweep.
const BINS: usize = 16;
/// A node is evaluated by its far-field expansion when the query is farther from its centre than
/// `beta * radius` (Barill et al. use 2). Measured worst errors away from the surface (bunny, 2000
/// points, 50 mm): third order, beta 2: 6e-3, beta 3: 9e-4, beta 4: 3e-4; second order, beta 2: 5e-2.
/// The accurate winding number uses third order at this beta:
pub(crate) const ACCURATE_BETA: f64 = 4.0;
/// The quick estimate that [`Bvh::inside`] tries first: second order at beta 2, 2x cheaper.
pub(crate) const QUICK_BETA: f64 = 2.0;
/// [`Bvh::inside`] trusts the quick estimate when `||w| - 1/2|` exceeds this: 4x its worst error
/// measured (5e-2; a point can only be misclassified where `|w|` is this close to 1/2).
pub(crate) const QUICK_MARGIN: f64 = 0.2;
/// From this depth on, splits are by median only, so no tree is deeper than `SAH_DEPTH + 32`.
const SAH_DEPTH: usize = 64;
/// Traversal stack: a depth-first walk holds at most one pending sibling per level.
const STACK: usize = 128;

#[derive(Clone, Copy, Debug)]
pub(crate) struct Node {
    pub lo: DVec3,
    pub hi: DVec3,
    /// Leaf: first triangle (in BVH order). Inner node: the right child; the left one is the next
    /// node (depth-first layout: a node, its left subtree, its right subtree).
    pub first: u32,
    /// Triangles of a leaf; 0 marks an inner node.
    pub count: u32,
}

/// Far-field moments of a node's triangles (see the module doc).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Moments {
    pub centre: DVec3,
    pub radius: f64,
    pub dipole: DVec3,
    pub quadrupole: DMat3,
}

/// Third-order moments of a node: `[i] = sum_t (a_t n_t)_i int_t (x - centre)(x - centre)^T dA / a_t`.
/// Kept apart from [`Moments`] so that the second-order pass does not drag them through the cache.
pub(crate) type Octupole = [DMat3; 3];

#[derive(Clone, Debug)]
pub(crate) struct Bvh {
    pub nodes: Vec<Node>,
    pub moments: Vec<Moments>,
    pub octupoles: Vec<Octupole>,
    /// What the quick pass reads, one cache line per node.
    quick: Vec<QuickNode>,
    /// Triangle corners in BVH order (copied for locality).
    pub tris: Vec<[DVec3; 3]>,
    /// The mesh face of each BVH triangle.
    pub faces: Vec<u32>,
}

/// Where a ray meets a triangle: distance, BVH triangle index, barycentrics of corners 1 and 2.
#[derive(Clone, Copy, Debug)]
pub(crate) struct TriHit {
    pub t: f64,
    pub tri: u32,
    pub u: f64,
    pub v: f64,
}

impl Bvh {
    /// Builds over `tris` (corners, mesh face index). `tris` must not be empty.
    pub fn build(tris: Vec<([DVec3; 3], u32)>) -> Bvh {
        let centroids: Vec<DVec3> = tris
            .par_iter()
            .map(|(t, _)| (t[0] + t[1] + t[2]) / 3.0)
            .collect();
        let boxes: Vec<(DVec3, DVec3)> = tris
            .par_iter()
            .map(|(t, _)| (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2])))
            .collect();
        let input = BuildInput {
            centroids: &centroids,
            boxes: &boxes,
        };
        let mut order: Vec<u32> = (0..tris.len() as u32).collect();
        let mut tree = Subtree::default();
        build_into(&input, &mut order, 0, 0, &mut tree);
        let sorted: Vec<[DVec3; 3]> = order.iter().map(|&i| tris[i as usize].0).collect();
        let faces = order.iter().map(|&i| tris[i as usize].1).collect();
        let (moments, octupoles) = moments_bottom_up(&tree, &sorted);
        let quick = tree
            .nodes
            .iter()
            .zip(&moments)
            .map(|(n, m)| QuickNode::new(n, m))
            .collect();
        Bvh {
            nodes: tree.nodes,
            moments,
            octupoles,
            quick,
            tris: sorted,
            faces,
        }
    }

    /// The generalized winding number at `q` (Jacobson et al. 2013: the triangles' solid angles
    /// summed, over 4 pi), with far nodes replaced by their third-order Taylor expansion (Barill et
    /// al. 2018, section 3.2) and near leaves summed exactly.
    pub fn winding_number(&self, q: DVec3) -> f64 {
        self.winding_number_with(q, ACCURATE_BETA)
    }

    /// `|w| > 1/2`: the quick estimate where it is clearly on one side, else the accurate one.
    pub fn inside(&self, q: DVec3) -> bool {
        let quick = self.quick_winding_number(q).abs();
        if (quick - 0.5).abs() > QUICK_MARGIN {
            return quick > 0.5;
        }
        self.winding_number(q).abs() > 0.5
    }

    /// The quick estimate: second order at [`QUICK_BETA`], from the compact f32 node copies.
    pub(crate) fn quick_winding_number(&self, q: DVec3) -> f64 {
        let mut stack = [0u32; STACK];
        let mut top = 1;
        let mut sum = 0.0;
        while top > 0 {
            top -= 1;
            let index = stack[top];
            let node = &self.quick[index as usize];
            let r = node.centre() - q;
            let d2 = r.length_squared();
            if d2 > f64::from(node.reach2) {
                sum += node.far_field(r, d2);
            } else if node.count > 0 {
                let tris = &self.tris[node.first as usize..(node.first + node.count) as usize];
                sum += tris.iter().map(|t| solid_angle(q, t)).sum::<f64>()
                    / (4.0 * std::f64::consts::PI);
            } else if top + 2 <= STACK {
                stack[top] = index + 1;
                stack[top + 1] = node.first;
                top += 2;
            } else {
                // Unreachable for trees this builder makes; exact fallback rather than a wrong sum.
                sum += self.exact_range(q, index);
            }
        }
        sum
    }

    /// The hierarchical sum: far nodes (beyond `beta` radii) by their third-order expansion, near
    /// leaves exactly.
    pub(crate) fn winding_number_with(&self, q: DVec3, beta: f64) -> f64 {
        let mut stack = [0u32; STACK];
        let mut top = 1;
        let mut sum = 0.0;
        while top > 0 {
            top -= 1;
            let index = stack[top] as usize;
            let node = self.nodes[index];
            let m = &self.moments[index];
            let r = m.centre - q;
            let d2 = r.length_squared();
            if d2 > (beta * m.radius).powi(2) {
                sum += far_field_third(m, &self.octupoles[index], r, d2);
            } else if node.count > 0 {
                let tris = &self.tris[node.first as usize..(node.first + node.count) as usize];
                sum += tris.iter().map(|t| solid_angle(q, t)).sum::<f64>()
                    / (4.0 * std::f64::consts::PI);
            } else if top + 2 <= STACK {
                stack[top] = index as u32 + 1;
                stack[top + 1] = node.first;
                top += 2;
            } else {
                // Unreachable for trees this builder makes; exact fallback rather than a wrong sum.
                sum += self.exact_range(q, index as u32);
            }
        }
        sum
    }

    /// Exact winding number of the subtree under `node`, recursively (fallback only).
    fn exact_range(&self, q: DVec3, node: u32) -> f64 {
        let n = self.nodes[node as usize];
        if n.count > 0 {
            let tris = &self.tris[n.first as usize..(n.first + n.count) as usize];
            tris.iter().map(|t| solid_angle(q, t)).sum::<f64>() / (4.0 * std::f64::consts::PI)
        } else {
            self.exact_range(q, node + 1) + self.exact_range(q, n.first)
        }
    }

    /// The brute-force winding number: every triangle's exact solid angle (Jacobson et al. 2013).
    pub fn winding_number_exact(&self, q: DVec3) -> f64 {
        self.tris.iter().map(|t| solid_angle(q, t)).sum::<f64>() / (4.0 * std::f64::consts::PI)
    }

    /// The nearest triangle crossing with `t_min < t <= t_max`. With `any`, the first one found.
    pub fn intersect(
        &self,
        origin: DVec3,
        dir: DVec3,
        t_min: f64,
        t_max: f64,
        any: bool,
    ) -> Option<TriHit> {
        // A huge finite inverse instead of infinity keeps 0 * inv = 0 for a ray lying in a box face
        // plane (with infinity that is NaN and the slab test would drop the box).
        let inv = dir.to_array().map(|c| {
            if c.abs() < 1e-300 {
                1e300f64.copysign(c)
            } else {
                1.0 / c
            }
        });
        let inv = DVec3::from_array(inv);
        let mut best: Option<TriHit> = None;
        let mut t_best = t_max;
        let mut stack = [0u32; STACK];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let index = stack[top];
            let node = self.nodes[index as usize];
            if node.count > 0 {
                for k in node.first..node.first + node.count {
                    if let Some((t, u, v)) = ray_triangle(origin, dir, &self.tris[k as usize]) {
                        if t > t_min && t <= t_best {
                            t_best = t;
                            best = Some(TriHit { t, tri: k, u, v });
                            if any {
                                return best;
                            }
                        }
                    }
                }
                continue;
            }
            let (l, r) = (index + 1, node.first);
            let tl = slab(&self.nodes[l as usize], origin, inv, t_min, t_best);
            let tr = slab(&self.nodes[r as usize], origin, inv, t_min, t_best);
            // Push the farther child first so the nearer one is searched first and shrinks t_best.
            let mut push = |n: u32| {
                if top < STACK {
                    stack[top] = n;
                    top += 1;
                }
            };
            match (tl, tr) {
                (Some(a), Some(b)) if a <= b => {
                    push(r);
                    push(l);
                }
                (Some(_), Some(_)) => {
                    push(l);
                    push(r);
                }
                (Some(_), None) => push(l),
                (None, Some(_)) => push(r),
                (None, None) => {}
            }
        }
        best
    }

    /// The point of the surface nearest to `p`: (BVH triangle, point, squared distance).
    pub fn closest_point(&self, p: DVec3) -> (u32, DVec3, f64) {
        let mut best = (
            0u32,
            self.tris[0][0],
            (self.tris[0][0] - p).length_squared(),
        );
        let mut stack = [0u32; STACK];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let index = stack[top];
            let node = self.nodes[index as usize];
            if box_distance2(&node, p) >= best.2 {
                continue;
            }
            if node.count > 0 {
                for k in node.first..node.first + node.count {
                    let c = closest_on_triangle(p, &self.tris[k as usize]);
                    let d2 = (c - p).length_squared();
                    if d2 < best.2 {
                        best = (k, c, d2);
                    }
                }
                continue;
            }
            let (l, r) = (index + 1, node.first);
            let dl = box_distance2(&self.nodes[l as usize], p);
            let dr = box_distance2(&self.nodes[r as usize], p);
            let (near, far) = if dl <= dr { (l, r) } else { (r, l) };
            if top + 2 <= STACK {
                stack[top] = far;
                stack[top + 1] = near;
                top += 2;
            }
        }
        best
    }
}

/// A node as the quick pass needs it, in f32 (its error, ~1e-7 relative, is far below the quick
/// pass's own): centre, `(QUICK_BETA radius)^2`, dipole, and of the quadrupole only what the second
/// order term reads: its trace and symmetric part. 64 bytes, one cache line: the quick pass is bound
/// by memory access, not arithmetic.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
struct QuickNode {
    centre: [f32; 3],
    reach2: f32,
    dipole: [f32; 3],
    trace: f32,
    /// xx, yy, zz, xy + yx, yz + zy, zx + xz.
    symmetric: [f32; 6],
    first: u32,
    count: u32,
}

impl QuickNode {
    fn new(n: &Node, m: &Moments) -> QuickNode {
        let c = &m.quadrupole;
        let f = |v: DVec3| v.as_vec3().to_array();
        QuickNode {
            centre: f(m.centre),
            reach2: ((QUICK_BETA * m.radius).powi(2)) as f32,
            dipole: f(m.dipole),
            trace: (c.x_axis.x + c.y_axis.y + c.z_axis.z) as f32,
            symmetric: [
                c.x_axis.x as f32,
                c.y_axis.y as f32,
                c.z_axis.z as f32,
                (c.y_axis.x + c.x_axis.y) as f32,
                (c.z_axis.y + c.y_axis.z) as f32,
                (c.x_axis.z + c.z_axis.x) as f32,
            ],
            first: n.first,
            count: n.count,
        }
    }

    fn centre(&self) -> DVec3 {
        DVec3::from(glam::Vec3::from_array(self.centre))
    }

    /// Second-order far-field winding number (Barill et al. 2018, section 3.2; [`far_field_third`]
    /// without its last term), with `r = centre - q`, `d2 = |r|^2`.
    fn far_field(&self, r: DVec3, d2: f64) -> f64 {
        let s = self.symmetric.map(f64::from);
        let rcr = r.x * r.x * s[0]
            + r.y * r.y * s[1]
            + r.z * r.z * s[2]
            + r.x * r.y * s[3]
            + r.y * r.z * s[4]
            + r.z * r.x * s[5];
        let dipole = DVec3::from(glam::Vec3::from_array(self.dipole));
        let inv3 = 1.0 / (d2 * d2.sqrt());
        (r.dot(dipole) * inv3 + f64::from(self.trace) * inv3 - 3.0 * rcr * inv3 / d2)
            / (4.0 * std::f64::consts::PI)
    }
}

/// Subtrees with more triangles than this are built in parallel.
const PARALLEL_BUILD: usize = 4096;

struct BuildInput<'a> {
    centroids: &'a [DVec3],
    boxes: &'a [(DVec3, DVec3)],
}

/// Nodes in depth-first layout with their triangle ranges (for the moments); child links are
/// relative to the start of `nodes`.
#[derive(Default)]
struct Subtree {
    nodes: Vec<Node>,
    ranges: Vec<(usize, usize)>,
}

impl Subtree {
    fn append(&mut self, other: Subtree) {
        let offset = self.nodes.len() as u32;
        self.nodes.extend(other.nodes.into_iter().map(|mut n| {
            if n.count == 0 {
                n.first += offset;
            }
            n
        }));
        self.ranges.extend(other.ranges);
    }
}

/// Appends the subtree over `order` (triangles `start..start + order.len()` of the final order) to
/// `out`, partitioning `order` in place. Large halves are built on separate threads and appended.
fn build_into(
    input: &BuildInput,
    order: &mut [u32],
    start: usize,
    depth: usize,
    out: &mut Subtree,
) {
    let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    let (mut clo, mut chi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    for &i in order.iter() {
        let (blo, bhi) = input.boxes[i as usize];
        lo = lo.min(blo);
        hi = hi.max(bhi);
        clo = clo.min(input.centroids[i as usize]);
        chi = chi.max(input.centroids[i as usize]);
    }
    let here = out.nodes.len();
    let count = order.len();
    out.nodes.push(Node {
        lo,
        hi,
        first: start as u32,
        count: count as u32,
    });
    out.ranges.push((start, start + count));
    if count <= LEAF_SIZE {
        return;
    }
    let mid = if depth >= SAH_DEPTH {
        median_split(order, input.centroids, clo, chi)
    } else {
        sah_split(order, input.centroids, input.boxes, clo, chi)
    };
    out.nodes[here].count = 0;
    let (left, right) = order.split_at_mut(mid);
    if count > PARALLEL_BUILD {
        let (l, r) = rayon::join(
            || {
                let mut tree = Subtree::default();
                build_into(input, left, start, depth + 1, &mut tree);
                tree
            },
            || {
                let mut tree = Subtree::default();
                build_into(input, right, start + mid, depth + 1, &mut tree);
                tree
            },
        );
        out.append(l);
        out.nodes[here].first = out.nodes.len() as u32;
        out.append(r);
    } else {
        build_into(input, left, start, depth + 1, out);
        out.nodes[here].first = out.nodes.len() as u32;
        build_into(input, right, start + mid, depth + 1, out);
    }
}

fn longest_axis(extent: DVec3) -> usize {
    if extent.x >= extent.y && extent.x >= extent.z {
        0
    } else if extent.y >= extent.z {
        1
    } else {
        2
    }
}

/// Partitions `order` at the median centroid along the longest axis; returns the left size.
fn median_split(order: &mut [u32], centroids: &[DVec3], clo: DVec3, chi: DVec3) -> usize {
    let axis = longest_axis(chi - clo);
    let mid = order.len() / 2;
    order.select_nth_unstable_by(mid, |&a, &b| {
        centroids[a as usize][axis].total_cmp(&centroids[b as usize][axis])
    });
    mid
}

/// Partitions `order` (a node's triangles) at the cheapest SAH plane along the longest centroid
/// axis and returns the size of the left part (both parts are non-empty).
fn sah_split(
    order: &mut [u32],
    centroids: &[DVec3],
    tri_boxes: &[(DVec3, DVec3)],
    clo: DVec3,
    chi: DVec3,
) -> usize {
    let extent = chi - clo;
    let axis = longest_axis(extent);
    if extent[axis] <= 0.0 {
        // All centroids coincide: no plane separates them; halve so leaves stay small.
        return order.len() / 2;
    }
    let bin_of = |i: u32| {
        (((centroids[i as usize][axis] - clo[axis]) / extent[axis] * BINS as f64) as usize)
            .min(BINS - 1)
    };
    let mut counts = [0usize; BINS];
    let mut boxes = [(DVec3::INFINITY, DVec3::NEG_INFINITY); BINS];
    for &i in order.iter() {
        let b = bin_of(i);
        counts[b] += 1;
        let (lo, hi) = tri_boxes[i as usize];
        boxes[b] = (boxes[b].0.min(lo), boxes[b].1.max(hi));
    }
    let area = |(lo, hi): (DVec3, DVec3)| {
        let e = (hi - lo).max(DVec3::ZERO);
        e.x * e.y + e.y * e.z + e.z * e.x
    };
    let merge = |a: (DVec3, DVec3), b: (DVec3, DVec3)| (a.0.min(b.0), a.1.max(b.1));
    let mut right_cost = [0.0; BINS];
    let (mut acc, mut n) = ((DVec3::INFINITY, DVec3::NEG_INFINITY), 0);
    for b in (1..BINS).rev() {
        acc = merge(acc, boxes[b]);
        n += counts[b];
        right_cost[b] = area(acc) * n as f64;
    }
    let (mut best, mut best_cost) = (0, f64::INFINITY);
    let (mut acc, mut n) = ((DVec3::INFINITY, DVec3::NEG_INFINITY), 0);
    for b in 1..BINS {
        acc = merge(acc, boxes[b - 1]);
        n += counts[b - 1];
        let cost = area(acc) * n as f64 + right_cost[b];
        if n > 0 && n < order.len() && cost < best_cost {
            best = b;
            best_cost = cost;
        }
    }
    if best == 0 {
        // Every centroid fell in one bin: split at the median instead.
        return median_split(order, centroids, clo, chi);
    }
    let mut left = 0;
    for k in 0..order.len() {
        if bin_of(order[k]) < best {
            order.swap(k, left);
            left += 1;
        }
    }
    left
}

/// Moments of every node: leaves from their triangles, inner nodes from their children by the
/// parallel-axis shifts (children follow their parent in the depth-first layout, so a reverse sweep
/// sees children first). Radii are exact: the farthest corner from each centre.
fn moments_bottom_up(tree: &Subtree, tris: &[[DVec3; 3]]) -> (Vec<Moments>, Vec<Octupole>) {
    let n = tree.nodes.len();
    let mut moments = vec![
        Moments {
            centre: DVec3::ZERO,
            radius: 0.0,
            dipole: DVec3::ZERO,
            quadrupole: DMat3::ZERO,
        };
        n
    ];
    let mut octupoles = vec![[DMat3::ZERO; 3]; n];
    let mut areas = vec![0.0; n];
    for index in (0..n).rev() {
        let node = tree.nodes[index];
        if node.count > 0 {
            let (s, e) = tree.ranges[index];
            (moments[index], octupoles[index]) = moments_of(&tris[s..e]);
            areas[index] = tris[s..e]
                .iter()
                .map(|[a, b, c]| 0.5 * (*b - *a).cross(*c - *a).length())
                .sum();
            continue;
        }
        let children = [index + 1, node.first as usize];
        let area = areas[children[0]] + areas[children[1]];
        let centre = if area > 0.0 {
            children
                .iter()
                .map(|&k| moments[k].centre * areas[k])
                .sum::<DVec3>()
                / area
        } else {
            0.5 * (node.lo + node.hi)
        };
        let mut m = Moments {
            centre,
            radius: 0.0,
            dipole: DVec3::ZERO,
            quadrupole: DMat3::ZERO,
        };
        let mut octupole = [DMat3::ZERO; 3];
        for k in children {
            let (c, t) = (&moments[k], &octupoles[k]);
            let delta = c.centre - centre;
            m.dipole += c.dipole;
            // Offsets from the new centre are the child's offsets plus delta.
            m.quadrupole += c.quadrupole + outer(delta, c.dipole);
            for (i, o) in octupole.iter_mut().enumerate() {
                let column = c.quadrupole.col(i);
                *o += t[i]
                    + outer(column, delta)
                    + outer(delta, column)
                    + outer(delta, delta) * c.dipole[i];
            }
        }
        (moments[index], octupoles[index], areas[index]) = (m, octupole, area);
    }
    let radii: Vec<f64> = tree
        .ranges
        .par_iter()
        .zip(moments.par_iter())
        .map(|(&(s, e), m)| {
            tris[s..e]
                .iter()
                .flatten()
                .map(|p| (*p - m.centre).length_squared())
                .fold(0.0, f64::max)
                .sqrt()
        })
        .collect();
    for (m, r) in moments.iter_mut().zip(radii) {
        m.radius = r;
    }
    (moments, octupoles)
}

/// `u v^T`.
fn outer(u: DVec3, v: DVec3) -> DMat3 {
    DMat3::from_cols(u * v.x, u * v.y, u * v.z)
}

fn moments_of(tris: &[[DVec3; 3]]) -> (Moments, Octupole) {
    let mut area = 0.0;
    let mut weighted = DVec3::ZERO;
    let mut dipole = DVec3::ZERO;
    for [a, b, c] in tris {
        let an = 0.5 * (*b - *a).cross(*c - *a);
        let w = an.length();
        area += w;
        weighted += w * (*a + *b + *c) / 3.0;
        dipole += an;
    }
    let centre = if area > 0.0 {
        weighted / area
    } else {
        tris.iter().flatten().sum::<DVec3>() / (3 * tris.len()) as f64
    };
    let mut radius: f64 = 0.0;
    let mut quadrupole = DMat3::ZERO;
    let mut octupole = [DMat3::ZERO; 3];
    for [a, b, c] in tris {
        let an = 0.5 * (*b - *a).cross(*c - *a);
        // The integral of (x - centre) over a flat triangle is its area times the centroid's offset.
        let offset = (*a + *b + *c) / 3.0 - centre;
        quadrupole += DMat3::from_cols(offset * an.x, offset * an.y, offset * an.z);
        // int_t x x^T dA = a_t / 12 (sum_k v_k v_k^T + s s^T) for corners v_k (relative), s = sum v_k.
        let v = [*a - centre, *b - centre, *c - centre];
        let s = v[0] + v[1] + v[2];
        let outer = |u: DVec3| DMat3::from_cols(u * u.x, u * u.y, u * u.z);
        let second = (outer(v[0]) + outer(v[1]) + outer(v[2]) + outer(s)) * (1.0 / 12.0);
        for (i, m) in octupole.iter_mut().enumerate() {
            *m += second * an[i];
        }
        for p in v {
            radius = radius.max(p.length());
        }
    }
    (
        Moments {
            centre,
            radius,
            dipole,
            quadrupole,
        },
        octupole,
    )
}

/// Third-order far-field winding number of a node seen from `q`, with `r = centre - q` and
/// `d2 = |r|^2`: the Taylor series of Barill et al. 2018 (section 3.2), written out here. With
/// `f(x) = (x - q) / (4 pi |x - q|^3)` the integrand, `f . n` expanded at the centre gives
/// `f . dipole + sum_ij df_i/dx_j quadrupole_ji + 1/2 sum_ijk d2f_i/dx_j dx_k octupole_i,jk`, where
/// `4 pi df_i/dx_j = (delta_ij - 3 r_i r_j / d2) / |r|^3` and
/// `4 pi d2f_i/dx_j dx_k = -3 (delta_ij r_k + delta_ik r_j + delta_jk r_i) / |r|^5
///                        + 15 r_i r_j r_k / |r|^7`.
fn far_field_third(m: &Moments, octupole: &Octupole, r: DVec3, d2: f64) -> f64 {
    let d = d2.sqrt();
    let inv3 = 1.0 / (d2 * d);
    let inv5 = inv3 / d2;
    let c = &m.quadrupole;
    let second = (c.x_axis.x + c.y_axis.y + c.z_axis.z) * inv3 - 3.0 * r.dot(*c * r) * inv5;
    let (mut a1, mut a3, mut b) = (0.0, 0.0, 0.0);
    for (i, t) in octupole.iter().enumerate() {
        let tr = *t * r;
        a1 += tr[i];
        a3 += r[i] * (t.x_axis.x + t.y_axis.y + t.z_axis.z);
        b += r[i] * r.dot(tr);
    }
    let third = 0.5 * (-3.0 * (2.0 * a1 + a3) * inv5 + 15.0 * b * inv5 / d2);
    (r.dot(m.dipole) * inv3 + second + third) / (4.0 * std::f64::consts::PI)
}

/// Signed solid angle of triangle `t` seen from `q` (Van Oosterom and Strackee 1983; Jacobson et al.
/// 2013): positive when `q` is behind a counter-clockwise triangle. Finite for every input:
/// a query on a vertex gives `atan2(0, 0) = 0`.
pub(crate) fn solid_angle(q: DVec3, t: &[DVec3; 3]) -> f64 {
    let (a, b, c) = (t[0] - q, t[1] - q, t[2] - q);
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let det = a.dot(b.cross(c));
    let den = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
    2.0 * det.atan2(den)
}

/// Möller-Trumbore, with edge tests widened by a relative 1e-12: rounding in the barycentrics could
/// otherwise let a ray through a shared edge or vertex slip between all the triangles there
/// (a hit found twice is harmless). Returns `(t, u, v)`, barycentrics of corners 1 and 2.
fn ray_triangle(o: DVec3, d: DVec3, t: &[DVec3; 3]) -> Option<(f64, f64, f64)> {
    let e1 = t[1] - t[0];
    let e2 = t[2] - t[0];
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv = 1.0 / det;
    let s = o - t[0];
    let u = s.dot(p) * inv;
    const SLACK: f64 = 1e-12;
    if !(-SLACK..=1.0 + SLACK).contains(&u) {
        return None;
    }
    let qv = s.cross(e1);
    let v = d.dot(qv) * inv;
    if v < -SLACK || u + v > 1.0 + SLACK {
        return None;
    }
    Some((e2.dot(qv) * inv, u, v))
}

/// Entry distance of the ray into the node's box within `[t_min, t_max]`, if it enters.
fn slab(n: &Node, o: DVec3, inv: DVec3, t_min: f64, t_max: f64) -> Option<f64> {
    let a = (n.lo - o) * inv;
    let b = (n.hi - o) * inv;
    let near = a.x.min(b.x).max(a.y.min(b.y)).max(a.z.min(b.z)).max(t_min);
    let far = a.x.max(b.x).min(a.y.max(b.y)).min(a.z.max(b.z)).min(t_max);
    (near <= far).then_some(near)
}

fn box_distance2(n: &Node, p: DVec3) -> f64 {
    let d = (n.lo - p).max(p - n.hi).max(DVec3::ZERO);
    d.length_squared()
}

/// Closest point of a triangle to `p` (Ericson, "Real-Time Collision Detection", 5.1.5).
pub(crate) fn closest_on_triangle(p: DVec3, t: &[DVec3; 3]) -> DVec3 {
    let [a, b, c] = *t;
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// A soup of `n` random triangles of size ~`size` in a 20 mm cube: overlapping, intersecting,
    /// unoriented. The hierarchy must answer exactly as a loop over all triangles does.
    fn soup(n: usize, size: f64, seed: u64) -> Bvh {
        let mut state = seed;
        let mut next = move || {
            state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            (z ^ (z >> 31)) as f64 / u64::MAX as f64 - 0.5
        };
        let tris = (0..n as u32)
            .map(|f| {
                let c = DVec3::new(next(), next(), next()) * 20.0;
                let t = [0, 1, 2].map(|_| c + DVec3::new(next(), next(), next()) * size);
                (t, f)
            })
            .collect();
        Bvh::build(tris)
    }

    fn brute_hit(bvh: &Bvh, o: DVec3, d: DVec3, t_min: f64, t_max: f64) -> Option<f64> {
        bvh.tris
            .iter()
            .filter_map(|t| ray_triangle(o, d, t).map(|h| h.0))
            .filter(|&t| t > t_min && t <= t_max)
            .min_by(f64::total_cmp)
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]
        #[test]
        fn rays_agree_with_a_loop_over_all_triangles(
            ox in -15.0..15.0f64, oy in -15.0..15.0f64, oz in -15.0..15.0f64,
            dx in -1.0..1.0f64, dy in -1.0..1.0f64, dz in -1.0..1.0f64, t_max in 0.0..40.0f64,
        ) {
            // More triangles than PARALLEL_BUILD, so the threaded build is covered too.
            thread_local!(static SOUP: Bvh = soup(3 * PARALLEL_BUILD, 2.0, 1));
            let d = DVec3::new(dx, dy, dz);
            prop_assume!(d.length() > 1e-3);
            let (o, d) = (DVec3::new(ox, oy, oz), d.normalize());
            SOUP.with(|bvh| {
                let brute = brute_hit(bvh, o, d, 1e-9, t_max);
                let fast = bvh.intersect(o, d, 1e-9, t_max, false).map(|h| h.t);
                prop_assert_eq!(fast, brute);
                prop_assert_eq!(bvh.intersect(o, d, 1e-9, t_max, true).is_some(), brute.is_some());
                Ok(())
            })?;
        }

        #[test]
        fn closest_points_and_winding_numbers_agree_with_loops(
            x in -15.0..15.0f64, y in -15.0..15.0f64, z in -15.0..15.0f64,
        ) {
            thread_local!(static SOUP: Bvh = soup(500, 2.0, 2));
            let q = DVec3::new(x, y, z);
            SOUP.with(|bvh| {
                let brute = bvh
                    .tris
                    .iter()
                    .map(|t| (closest_on_triangle(q, t) - q).length_squared())
                    .fold(f64::INFINITY, f64::min);
                prop_assert_eq!(bvh.closest_point(q).2, brute);
                // An open soup: w is far from integers, the expansion must still track it.
                if brute > 1.0 {
                    let (fast, exact) = (bvh.winding_number(q), bvh.winding_number_exact(q));
                    prop_assert!((fast - exact).abs() < 2e-3, "{} vs {}", fast, exact);
                }
                Ok(())
            })?;
        }
    }

    /// The parallel-axis shifts reproduce the moments summed directly over each node's triangles.
    #[test]
    fn shifted_moments_equal_direct_sums() {
        let bvh = soup(3000, 2.0, 3);
        let scale = |m: &DMat3| m.to_cols_array().iter().fold(0.0f64, |a, x| a.max(x.abs()));
        let mut ranges = Vec::new();
        // Each node's triangle range from the layout: leaves hold theirs, parents span children.
        fn span(bvh: &Bvh, index: usize, out: &mut Vec<(usize, usize, usize)>) -> (usize, usize) {
            let n = bvh.nodes[index];
            let range = if n.count > 0 {
                (n.first as usize, (n.first + n.count) as usize)
            } else {
                let (a, _) = span(bvh, index + 1, out);
                let (_, b) = span(bvh, n.first as usize, out);
                (a, b)
            };
            out.push((index, range.0, range.1));
            range
        }
        span(&bvh, 0, &mut ranges);
        assert_eq!(ranges.len(), bvh.nodes.len());
        for (index, s, e) in ranges {
            let (direct, octupole) = moments_of(&bvh.tris[s..e]);
            let got = &bvh.moments[index];
            assert!((got.centre - direct.centre).length() < 1e-9, "{index}");
            assert!((got.radius - direct.radius).abs() < 1e-9);
            assert!((got.dipole - direct.dipole).length() < 1e-9 * direct.dipole.length().max(1.0));
            let tol = 1e-9 * scale(&direct.quadrupole).max(1.0);
            assert!(
                scale(&(got.quadrupole - direct.quadrupole)) < tol,
                "{index}"
            );
            for (got, direct) in bvh.octupoles[index].iter().zip(&octupole) {
                let tol = 1e-9 * scale(direct).max(1.0);
                assert!(scale(&(*got - *direct)) < tol, "{index}");
            }
        }
    }

    #[test]
    fn degenerate_inputs_build_valid_trees() {
        // A fan around one axis: the centroids sit on two points only, and no plane separates those.
        let fan: Vec<([DVec3; 3], u32)> = (0..100)
            .map(|i| {
                let a = i as f64 * 0.0628;
                let u = DVec3::new(a.cos(), a.sin(), 0.0);
                ([u, -u, DVec3::Z * if i % 2 == 0 { 1.0 } else { -1.0 }], i)
            })
            .collect();
        let bvh = Bvh::build(fan);
        let leaves: Vec<&Node> = bvh.nodes.iter().filter(|n| n.count > 0).collect();
        assert_eq!(leaves.iter().map(|n| n.count).sum::<u32>(), 100);
        assert!(leaves.iter().all(|n| n.count as usize <= LEAF_SIZE));
        let mut faces = bvh.faces.clone();
        faces.sort_unstable();
        assert_eq!(faces, (0..100).collect::<Vec<_>>());
        // A single triangle.
        let one = Bvh::build(vec![([DVec3::ZERO, DVec3::X, DVec3::Y], 7)]);
        assert_eq!((one.nodes.len(), one.faces[0]), (1, 7));
        assert!(one
            .intersect(DVec3::new(0.2, 0.2, 1.0), -DVec3::Z, 0.0, 2.0, false)
            .is_some());
    }
}
