//! Procedural shapes, defined exactly by a signed distance (negative inside), with a triangulation
//! for display. They make every command usable with no input files, and they are the exact oracles
//! the mesh queries are tested against.
//!
//! ```
//! use glam::DVec3;
//! use translucent::mesh::{shapes::Shape, Solid};
//!
//! let slab = Shape::Box { half_extents: DVec3::new(50.0, 5.0, 50.0) };
//! assert!(slab.contains(DVec3::new(40.0, 4.0, -40.0)));
//! let (t, n) = slab.ray_hit(DVec3::new(0.0, 20.0, 0.0), -DVec3::Y, 100.0).unwrap();
//! assert_eq!((t, n), (15.0, DVec3::Y));
//! let display = slab.triangulate(32); // closed, outward, a grid on every face
//! assert!(!display.indices.is_empty());
//! ```

use std::collections::HashMap;
use std::f64::consts::{PI, TAU};

use glam::{DVec2, DVec3};

use super::{MeshError, Solid, TriMesh};

/// A procedural solid centred at the origin (millimetres).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shape {
    Sphere {
        radius: f64,
    },
    /// Ring in the XZ plane: `major` radius of the ring, `minor` radius of the tube.
    Torus {
        major: f64,
        minor: f64,
    },
    /// Axis-aligned box from `-half_extents` to `half_extents` (a wide thin box is the slab of the
    /// analytic transmittance tests).
    Box {
        half_extents: DVec3,
    },
    /// The points within `radius` of the segment from `-half_length` to `half_length` on the Y axis.
    Capsule {
        half_length: f64,
        radius: f64,
    },
}

impl Shape {
    /// Checks the parameters: finite, sizes > 0 (a capsule's `half_length` may be 0, a sphere),
    /// a torus's tube thinner than its ring (else it overlaps itself).
    pub fn validate(&self) -> Result<(), MeshError> {
        let problem = match *self {
            Shape::Sphere { radius } if !(radius.is_finite() && radius > 0.0) => {
                "radius must be finite and > 0"
            }
            Shape::Torus { major, minor }
                if !(minor.is_finite() && minor > 0.0 && major.is_finite()) =>
            {
                "radii must be finite and > 0"
            }
            Shape::Torus { major, minor } if minor >= major => {
                "the tube radius must be less than the ring radius"
            }
            Shape::Box { half_extents }
                if !(half_extents.is_finite() && half_extents.min_element() > 0.0) =>
            {
                "half extents must be finite and > 0"
            }
            Shape::Capsule {
                half_length,
                radius,
            } if !(half_length.is_finite()
                && half_length >= 0.0
                && radius.is_finite()
                && radius > 0.0) =>
            {
                "radius must be finite and > 0, half length finite and >= 0"
            }
            _ => return Ok(()),
        };
        Err(MeshError::InvalidShape {
            shape: *self,
            problem,
        })
    }

    /// Signed distance in mm, negative inside.
    pub fn signed_distance(&self, p: DVec3) -> f64 {
        match *self {
            Shape::Sphere { radius } => p.length() - radius,
            Shape::Torus { major, minor } => {
                let q = glam::DVec2::new(glam::DVec2::new(p.x, p.z).length() - major, p.y);
                q.length() - minor
            }
            Shape::Box { half_extents } => {
                let q = p.abs() - half_extents;
                q.max(DVec3::ZERO).length() + q.max_element().min(0.0)
            }
            Shape::Capsule {
                half_length,
                radius,
            } => (p - DVec3::Y * p.y.clamp(-half_length, half_length)).length() - radius,
        }
    }

    /// The outward unit normal of the boundary point nearest to `p` (the normalized gradient of the
    /// signed distance; on a box edge, the face whose plane is nearest).
    pub fn normal_at(&self, p: DVec3) -> DVec3 {
        let n = match *self {
            Shape::Sphere { .. } => p,
            Shape::Torus { major, .. } => {
                let ring = DVec2::new(p.x, p.z).length();
                if ring > 0.0 {
                    let s = 1.0 - major / ring;
                    DVec3::new(p.x * s, p.y, p.z * s)
                } else {
                    // On the axis every direction towards the ring is equally near.
                    DVec3::X
                }
            }
            Shape::Box { half_extents } => {
                let q = p.abs() - half_extents;
                let axis = if q.x >= q.y && q.x >= q.z {
                    0
                } else if q.y >= q.z {
                    1
                } else {
                    2
                };
                let mut n = DVec3::ZERO;
                n[axis] = if p[axis] < 0.0 { -1.0 } else { 1.0 };
                n
            }
            Shape::Capsule { half_length, .. } => {
                p - DVec3::Y * p.y.clamp(-half_length, half_length)
            }
        };
        // The centre of a sphere or the axis of a capsule has no nearest boundary point.
        let n = n.normalize_or_zero();
        if n == DVec3::ZERO {
            DVec3::Y
        } else {
            n
        }
    }

    /// Half the diagonal of the bounding box: the length scale for tolerances.
    fn scale(&self) -> f64 {
        let (lo, hi) = Solid::bounds(self);
        0.5 * (hi - lo).length()
    }

    /// Hits closer than this to the ray origin are the surface the ray starts on (a shadow ray from
    /// a surface point) and are skipped.
    fn self_hit_epsilon(&self) -> f64 {
        1e-9 * self.scale()
    }

    /// A closed, outward triangulation with unit vertex normals: `segments` (at least 4) steps
    /// around a sphere's or torus's ring and a capsule's cap (about `2 * segments^2` triangles), or
    /// cells along a box's longest side, with about square cells on every face. Normals come from
    /// the exact shape, except on box edges and corners, where they average the adjacent faces.
    pub fn triangulate(&self, segments: u32) -> TriMesh {
        let segments = segments.max(4);
        match *self {
            Shape::Sphere { radius } => {
                let (rings, sectors) = (segments, 2 * segments);
                let mut mesh = TriMesh::default();
                // Poles are single vertices so the mesh is closed and manifold.
                mesh.positions.push(DVec3::Y * radius);
                for r in 1..rings {
                    let theta = PI * r as f64 / rings as f64;
                    for s in 0..sectors {
                        let phi = TAU * s as f64 / sectors as f64;
                        let d = DVec3::new(
                            theta.sin() * phi.cos(),
                            theta.cos(),
                            -theta.sin() * phi.sin(),
                        );
                        mesh.positions.push(d * radius);
                    }
                }
                mesh.positions.push(-DVec3::Y * radius);
                let ring = |r: u32, s: u32| 1 + (r - 1) * sectors + s % sectors;
                let south = mesh.positions.len() as u32 - 1;
                for s in 0..sectors {
                    mesh.indices.push([0, ring(1, s), ring(1, s + 1)]);
                    mesh.indices
                        .push([south, ring(rings - 1, s + 1), ring(rings - 1, s)]);
                }
                for r in 1..rings - 1 {
                    for s in 0..sectors {
                        let (a, b, c, d) = (
                            ring(r, s),
                            ring(r, s + 1),
                            ring(r + 1, s),
                            ring(r + 1, s + 1),
                        );
                        mesh.indices.push([a, c, d]);
                        mesh.indices.push([a, d, b]);
                    }
                }
                mesh.normals = mesh.positions.iter().map(|p| p.normalize()).collect();
                mesh
            }
            Shape::Torus { major, minor } => {
                let (around, tube) = (2 * segments, segments);
                let mut mesh = TriMesh::default();
                for i in 0..around {
                    let u = TAU * i as f64 / around as f64;
                    let centre = DVec3::new(u.cos(), 0.0, -u.sin()) * major;
                    for j in 0..tube {
                        let v = TAU * j as f64 / tube as f64;
                        let n = DVec3::new(v.cos() * u.cos(), v.sin(), -v.cos() * u.sin());
                        mesh.positions.push(centre + n * minor);
                        mesh.normals.push(n);
                    }
                }
                let id = |i: u32, j: u32| (i % around) * tube + j % tube;
                for i in 0..around {
                    for j in 0..tube {
                        let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i, j + 1), id(i + 1, j + 1));
                        mesh.indices.push([a, b, d]);
                        mesh.indices.push([a, d, c]);
                    }
                }
                mesh
            }
            Shape::Box { half_extents } => box_mesh(half_extents, segments),
            Shape::Capsule {
                half_length,
                radius,
            } => capsule_mesh(half_length, radius, segments),
        }
    }
}

/// A box with a grid on every face: `segments` cells along the longest side, square-ish cells
/// elsewhere, so interpolated shading stays smooth on wide faces. Vertices are shared between faces
/// (welded by lattice index), so the mesh is closed and manifold.
fn box_mesh(half_extents: DVec3, segments: u32) -> TriMesh {
    let cell = 2.0 * half_extents.max_element() / segments as f64;
    let cells = (2.0 * half_extents / cell).ceil().max(DVec3::ONE);
    let n = [cells.x as u32, cells.y as u32, cells.z as u32];
    // Exact ends so that welded vertices sit exactly on the box.
    let coord = |axis: usize, i: u32| match i {
        0 => -half_extents[axis],
        i if i == n[axis] => half_extents[axis],
        i => half_extents[axis] * (2.0 * i as f64 / n[axis] as f64 - 1.0),
    };
    let mut mesh = TriMesh::default();
    let mut ids: HashMap<[u32; 3], u32> = HashMap::new();
    let mut vertex = |mesh: &mut TriMesh, key: [u32; 3]| {
        *ids.entry(key).or_insert_with(|| {
            mesh.positions.push(DVec3::new(
                coord(0, key[0]),
                coord(1, key[1]),
                coord(2, key[2]),
            ));
            mesh.positions.len() as u32 - 1
        })
    };
    for axis in 0..3 {
        // (u, v, axis) is a cyclic permutation of (x, y, z), so u x v = +axis.
        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
        for side in [0, n[axis]] {
            for i in 0..n[u] {
                for j in 0..n[v] {
                    let mut quad = [[0u32; 3]; 4];
                    for (corner, (di, dj)) in quad.iter_mut().zip([(0, 0), (1, 0), (1, 1), (0, 1)])
                    {
                        corner[axis] = side;
                        corner[u] = i + di;
                        corner[v] = j + dj;
                    }
                    let [a, b, c, d] = quad.map(|k| vertex(&mut mesh, k));
                    if side == 0 {
                        mesh.indices.push([a, c, b]);
                        mesh.indices.push([a, d, c]);
                    } else {
                        mesh.indices.push([a, b, c]);
                        mesh.indices.push([a, c, d]);
                    }
                }
            }
        }
    }
    mesh.compute_normals();
    mesh
}

/// A capsule revolved from its profile: the upper half sphere lifted by `half_length`, a cylinder
/// with about square cells, and the lower half sphere; poles are single vertices (closed, manifold).
fn capsule_mesh(half_length: f64, radius: f64, segments: u32) -> TriMesh {
    let (half_rings, sectors) = (segments.div_ceil(2), 2 * segments);
    let arc_step = PI * radius / (2 * half_rings) as f64;
    let bands = ((2.0 * half_length / arc_step).round() as u32).max(1);
    // Profile rings from the top down (ring radius, height, unit normal), poles excluded.
    let mut rings: Vec<(f64, f64, DVec2)> = Vec::new();
    for r in 1..=half_rings {
        let theta = PI * r as f64 / (2 * half_rings) as f64;
        rings.push((
            radius * theta.sin(),
            half_length + radius * theta.cos(),
            DVec2::new(theta.sin(), theta.cos()),
        ));
    }
    for b in 1..bands {
        let y = half_length * (1.0 - 2.0 * b as f64 / bands as f64);
        rings.push((radius, y, DVec2::X));
    }
    for r in (0..half_rings).rev() {
        let theta = PI * r as f64 / (2 * half_rings) as f64;
        rings.push((
            radius * theta.sin(),
            -half_length - radius * theta.cos(),
            DVec2::new(theta.sin(), -theta.cos()),
        ));
    }
    let mut mesh = TriMesh::default();
    mesh.positions.push(DVec3::Y * (half_length + radius));
    mesh.normals.push(DVec3::Y);
    for &(rho, y, n) in &rings {
        for s in 0..sectors {
            let phi = TAU * s as f64 / sectors as f64;
            let (c, d) = (phi.cos(), -phi.sin());
            mesh.positions.push(DVec3::new(rho * c, y, rho * d));
            mesh.normals.push(DVec3::new(n.x * c, n.y, n.x * d));
        }
    }
    mesh.positions.push(-DVec3::Y * (half_length + radius));
    mesh.normals.push(-DVec3::Y);
    let count = rings.len() as u32;
    let ring = |r: u32, s: u32| 1 + r * sectors + s % sectors;
    let south = mesh.positions.len() as u32 - 1;
    for s in 0..sectors {
        mesh.indices.push([0, ring(0, s), ring(0, s + 1)]);
        mesh.indices
            .push([south, ring(count - 1, s + 1), ring(count - 1, s)]);
    }
    for r in 0..count - 1 {
        for s in 0..sectors {
            let (a, b, c, d) = (
                ring(r, s),
                ring(r, s + 1),
                ring(r + 1, s),
                ring(r + 1, s + 1),
            );
            mesh.indices.push([a, c, d]);
            mesh.indices.push([a, d, b]);
        }
    }
    mesh
}

/// The first crossing of an exact signed distance field along a ray, by sphere tracing: a step of
/// |distance| can never jump over the surface, so the crossing is bracketed by the first sign change
/// and then bisected. A floor on the step keeps grazing rays moving; it can only miss a crossing that
/// enters and leaves within one floor step (a tangent ray).
fn sphere_trace(
    sdf: impl Fn(DVec3) -> f64,
    origin: DVec3,
    dir: DVec3,
    t_min: f64,
    t_max: f64,
    scale: f64,
) -> Option<f64> {
    const MAX_STEPS: usize = 1 << 20;
    let floor = 1e-7 * scale;
    let mut t = t_min;
    let mut d = sdf(origin + dir * t);
    let inside = d < 0.0;
    for _ in 0..MAX_STEPS {
        if t >= t_max {
            return None;
        }
        let t_next = (t + d.abs().max(floor)).min(t_max);
        let d_next = sdf(origin + dir * t_next);
        if (d_next < 0.0) != inside {
            let (mut lo, mut hi) = (t, t_next);
            while hi - lo > 1e-13 * scale.max(hi) {
                let mid = 0.5 * (lo + hi);
                if (sdf(origin + dir * mid) < 0.0) == inside {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            return Some(hi);
        }
        t = t_next;
        d = d_next;
    }
    None
}

impl Solid for Shape {
    fn contains(&self, p: DVec3) -> bool {
        self.signed_distance(p) < 0.0
    }

    fn ray_hit(&self, origin: DVec3, dir: DVec3, t_max: f64) -> Option<(f64, DVec3)> {
        let eps = self.self_hit_epsilon();
        let t = match *self {
            Shape::Sphere { radius } => {
                // |o + t d|^2 = r^2 with |d| = 1: t^2 + 2 b t + c = 0. The far root is computed from
                // the product of the roots, which avoids cancellation.
                let b = origin.dot(dir);
                let c = origin.length_squared() - radius * radius;
                let disc = b * b - c;
                if disc < 0.0 {
                    return None;
                }
                let q = -b - b.signum() * disc.sqrt();
                let (t0, t1) = if q == 0.0 {
                    (0.0, 0.0)
                } else {
                    (q.min(c / q), q.max(c / q))
                };
                [t0, t1].into_iter().find(|&t| t > eps)?
            }
            Shape::Box { half_extents } => {
                let (mut near, mut far) = (f64::NEG_INFINITY, f64::INFINITY);
                for axis in 0..3 {
                    if dir[axis] == 0.0 {
                        if origin[axis].abs() > half_extents[axis] {
                            return None;
                        }
                        continue;
                    }
                    let a = (-half_extents[axis] - origin[axis]) / dir[axis];
                    let b = (half_extents[axis] - origin[axis]) / dir[axis];
                    near = near.max(a.min(b));
                    far = far.min(a.max(b));
                }
                if near > far {
                    return None;
                }
                [near, far].into_iter().find(|&t| t > eps)?
            }
            Shape::Torus { .. } | Shape::Capsule { .. } => {
                // Only the part of the ray inside the bounding sphere can cross.
                let r = self.scale();
                let b = origin.dot(dir);
                let disc = b * b - (origin.length_squared() - r * r);
                if disc < 0.0 {
                    return None;
                }
                let t_enter = (-b - disc.sqrt()).max(eps);
                let t_leave = (-b + disc.sqrt()).min(t_max);
                if t_enter >= t_leave {
                    return None;
                }
                sphere_trace(
                    |p| self.signed_distance(p),
                    origin,
                    dir,
                    t_enter,
                    t_leave,
                    r,
                )?
            }
        };
        (t <= t_max).then(|| (t, self.normal_at(origin + dir * t)))
    }

    fn bounds(&self) -> (DVec3, DVec3) {
        let hi = match *self {
            Shape::Sphere { radius } => DVec3::splat(radius),
            Shape::Torus { major, minor } => DVec3::new(major + minor, minor, major + minor),
            Shape::Box { half_extents } => half_extents,
            Shape::Capsule {
                half_length,
                radius,
            } => DVec3::new(radius, half_length + radius, radius),
        };
        (-hi, hi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sum of signed tetrahedron volumes from the origin: positive iff faces wind outward.
    fn signed_volume(m: &TriMesh) -> f64 {
        m.indices
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| m.positions[i as usize]);
                a.dot(b.cross(c)) / 6.0
            })
            .sum()
    }

    /// Closed and consistently oriented: every directed edge occurs once, and so does its reverse.
    fn assert_closed_oriented(shape: &Shape, m: &TriMesh) {
        let mut directed = std::collections::HashSet::new();
        for t in &m.indices {
            for k in 0..3 {
                assert!(
                    directed.insert((t[k], t[(k + 1) % 3])),
                    "{shape:?}: edge used twice in one direction"
                );
            }
        }
        for &(a, b) in &directed {
            assert!(
                directed.contains(&(b, a)),
                "{shape:?}: boundary edge {a}-{b}"
            );
        }
        assert_eq!(m.normals.len(), m.positions.len());
        for n in &m.normals {
            assert!((n.length() - 1.0).abs() < 1e-12, "{shape:?}: normal {n}");
        }
    }

    /// Small deterministic generator (splitmix64) so failures reproduce.
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> f64 {
            self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            (z ^ (z >> 31)) as f64 / u64::MAX as f64
        }
        fn in_cube(&mut self, half: f64) -> DVec3 {
            DVec3::new(self.next(), self.next(), self.next()) * (2.0 * half) - DVec3::splat(half)
        }
        fn direction(&mut self) -> DVec3 {
            loop {
                let d = self.in_cube(1.0);
                if d.length() > 0.1 && d.length() < 1.0 {
                    return d.normalize();
                }
            }
        }
    }

    fn all_shapes() -> [Shape; 4] {
        [
            Shape::Sphere { radius: 10.0 },
            Shape::Torus {
                major: 10.0,
                minor: 4.0,
            },
            Shape::Box {
                half_extents: DVec3::new(50.0, 5.0, 30.0),
            },
            Shape::Capsule {
                half_length: 8.0,
                radius: 5.0,
            },
        ]
    }

    #[test]
    fn triangulations_are_closed_outward_and_converge_to_the_exact_volume() {
        for shape in all_shapes() {
            let exact = match shape {
                Shape::Sphere { radius } => 4.0 / 3.0 * PI * radius.powi(3),
                Shape::Torus { major, minor } => 2.0 * PI * PI * major * minor * minor,
                Shape::Box { half_extents } => {
                    8.0 * half_extents.x * half_extents.y * half_extents.z
                }
                Shape::Capsule {
                    half_length,
                    radius,
                } => PI * radius * radius * (2.0 * half_length + 4.0 / 3.0 * radius),
            };
            let coarse_mesh = shape.triangulate(16);
            assert_closed_oriented(&shape, &coarse_mesh);
            let coarse = (signed_volume(&coarse_mesh) - exact).abs();
            let fine = signed_volume(&shape.triangulate(64));
            assert!(fine > 0.0, "{shape:?} winds inward");
            assert!(
                (fine - exact).abs() < 0.01 * exact,
                "{shape:?}: {fine} vs {exact}"
            );
            if matches!(shape, Shape::Box { .. }) {
                assert!(
                    (fine - exact).abs() < 1e-9 * exact,
                    "a box triangulation is exact"
                );
            } else {
                assert!(
                    (fine - exact).abs() < coarse / 4.0,
                    "{shape:?} does not converge"
                );
            }
            for p in &coarse_mesh.positions {
                assert!(
                    shape.signed_distance(*p).abs() < 1e-9,
                    "{shape:?}: vertex off the surface"
                );
            }
        }
    }

    #[test]
    fn box_faces_carry_a_grid_of_about_square_cells() {
        let shape = Shape::Box {
            half_extents: DVec3::new(50.0, 5.0, 50.0),
        };
        let mesh = shape.triangulate(20);
        // 20 x 20 cells on the two big faces, 20 x 2 on the four thin ones, 2 triangles per cell.
        assert_eq!(mesh.indices.len(), 2 * (2 * 400 + 4 * 40));
        let longest = mesh
            .indices
            .iter()
            .flat_map(|t| (0..3).map(move |k| (t[k], t[(k + 1) % 3])))
            .map(|(a, b)| (mesh.positions[a as usize] - mesh.positions[b as usize]).length())
            .fold(0.0, f64::max);
        assert!(
            longest <= 5.0 * 2f64.sqrt() + 1e-12,
            "cell diagonal {longest}"
        );
    }

    #[test]
    fn bad_parameters_are_refused() {
        for shape in all_shapes() {
            shape.validate().unwrap();
        }
        Shape::Capsule {
            half_length: 0.0,
            radius: 1.0,
        }
        .validate()
        .unwrap();
        for bad in [
            Shape::Sphere { radius: 0.0 },
            Shape::Sphere { radius: f64::NAN },
            Shape::Torus {
                major: 4.0,
                minor: 4.0,
            },
            Shape::Torus {
                major: f64::INFINITY,
                minor: 1.0,
            },
            Shape::Box {
                half_extents: DVec3::new(1.0, -1.0, 1.0),
            },
            Shape::Box {
                half_extents: DVec3::new(1.0, 1.0, f64::NAN),
            },
            Shape::Capsule {
                half_length: -1.0,
                radius: 1.0,
            },
            Shape::Capsule {
                half_length: 1.0,
                radius: 0.0,
            },
        ] {
            let err = bad.validate().unwrap_err();
            // Compared through Debug: NaN parameters are not equal to themselves.
            assert!(
                matches!(err, MeshError::InvalidShape { shape, .. } if format!("{shape:?}") == format!("{bad:?}")),
                "{bad:?}"
            );
            assert!(err.to_string().contains("invalid shape"));
        }
    }

    /// Tiny and huge objects: every query stays finite and consistent.
    #[test]
    fn extreme_scales_stay_finite() {
        let mut rng = Rng(17);
        for scale in [1e-6, 1e6] {
            for shape in all_shapes() {
                let shape = match shape {
                    Shape::Sphere { radius } => Shape::Sphere {
                        radius: radius * scale,
                    },
                    Shape::Torus { major, minor } => Shape::Torus {
                        major: major * scale,
                        minor: minor * scale,
                    },
                    Shape::Box { half_extents } => Shape::Box {
                        half_extents: half_extents * scale,
                    },
                    Shape::Capsule {
                        half_length,
                        radius,
                    } => Shape::Capsule {
                        half_length: half_length * scale,
                        radius: radius * scale,
                    },
                };
                for _ in 0..200 {
                    let origin = rng.in_cube(40.0 * scale);
                    let dir = rng.direction();
                    if let Some((t, n)) = shape.ray_hit(origin, dir, 100.0 * scale) {
                        assert!(t.is_finite() && n.is_finite() && (n.length() - 1.0).abs() < 1e-12);
                        assert!(
                            shape.signed_distance(origin + dir * t).abs() < 1e-8 * scale,
                            "{shape:?}"
                        );
                    }
                }
            }
        }
    }

    /// Shadow rays start on the surface: leaving it, they must not hit the point they start from;
    /// entering, the first crossing is the far side.
    #[test]
    fn rays_from_the_surface_skip_their_own_point() {
        for shape in all_shapes() {
            let scale = shape.scale();
            for p in shape.triangulate(12).positions.iter().step_by(3) {
                let n = shape.normal_at(*p);
                if let Some((t, _)) = shape.ray_hit(*p, n, 10.0 * scale) {
                    // Only a torus can be met again going outward: across its hole.
                    assert!(
                        matches!(shape, Shape::Torus { .. }) && t > 1.0,
                        "{shape:?} at {p}: {t}"
                    );
                }
                let (t, _) = shape
                    .ray_hit(*p, -n, 10.0 * scale)
                    .expect("an inward ray leaves the solid");
                assert!(t > 1e-3 * scale, "{shape:?} at {p}: {t}");
            }
        }
    }

    #[test]
    fn box_signed_distance_is_exact() {
        let shape = Shape::Box {
            half_extents: DVec3::new(3.0, 2.0, 1.0),
        };
        assert_eq!(shape.signed_distance(DVec3::ZERO), -1.0);
        assert_eq!(shape.signed_distance(DVec3::new(5.0, 0.0, 0.0)), 2.0);
        assert_eq!(shape.signed_distance(DVec3::new(6.0, 6.0, 0.0)), 5.0);
        assert_eq!(shape.signed_distance(DVec3::new(2.5, 0.0, 0.0)), -0.5);
        assert_eq!(shape.normal_at(DVec3::new(0.0, 0.0, -0.9)), -DVec3::Z);
    }

    #[test]
    fn sphere_and_box_rays_match_closed_forms() {
        let sphere = Shape::Sphere { radius: 10.0 };
        assert_eq!(
            sphere.ray_hit(DVec3::new(0.0, 0.0, -30.0), DVec3::Z, 100.0),
            Some((20.0, -DVec3::Z))
        );
        // From the inside the first crossing is the far side.
        assert_eq!(
            sphere.ray_hit(DVec3::ZERO, DVec3::X, 100.0),
            Some((10.0, DVec3::X))
        );
        // A shadow ray leaving the surface does not hit the surface it starts on.
        assert_eq!(
            sphere.ray_hit(DVec3::new(10.0, 0.0, 0.0), DVec3::X, 100.0),
            None
        );
        assert_eq!(
            sphere.ray_hit(DVec3::new(0.0, 0.0, -30.0), DVec3::Z, 19.0),
            None
        );
        assert_eq!(
            sphere.ray_hit(DVec3::new(0.0, 10.5, -30.0), DVec3::Z, 100.0),
            None
        );
        // Off-axis: distance 6 from the centre line, so the chord half-length is 8.
        let (t, n) = sphere
            .ray_hit(DVec3::new(6.0, 0.0, -30.0), DVec3::Z, 100.0)
            .unwrap();
        assert!((t - 22.0).abs() < 1e-12 && (n - DVec3::new(0.6, 0.0, -0.8)).length() < 1e-12);

        let slab = Shape::Box {
            half_extents: DVec3::new(50.0, 5.0, 50.0),
        };
        assert_eq!(
            slab.ray_hit(DVec3::new(10.0, 20.0, 0.0), -DVec3::Y, 100.0),
            Some((15.0, DVec3::Y))
        );
        assert_eq!(
            slab.ray_hit(DVec3::new(10.0, 0.0, 0.0), -DVec3::Y, 100.0),
            Some((5.0, -DVec3::Y))
        );
        assert_eq!(
            slab.ray_hit(DVec3::new(60.0, 20.0, 0.0), -DVec3::Y, 100.0),
            None
        );
        // Parallel to a face, outside its slab.
        assert_eq!(
            slab.ray_hit(DVec3::new(-80.0, 6.0, 0.0), DVec3::X, 1000.0),
            None
        );
        let d = DVec3::new(1.0, -1.0, 0.0).normalize();
        let (t, n) = slab.ray_hit(DVec3::new(0.0, 10.0, 0.0), d, 100.0).unwrap();
        assert!((t - 5.0 * 2f64.sqrt()).abs() < 1e-12 && n == DVec3::Y);
    }

    #[test]
    fn torus_and_capsule_rays_match_closed_forms() {
        let torus = Shape::Torus {
            major: 10.0,
            minor: 4.0,
        };
        let (t, n) = torus
            .ray_hit(DVec3::new(-30.0, 0.0, 0.0), DVec3::X, 100.0)
            .unwrap();
        assert!(
            (t - 16.0).abs() < 1e-10 && (n + DVec3::X).length() < 1e-9,
            "{t} {n}"
        );
        // Starting in the hole, the first crossing is the inner equator.
        let (t, n) = torus.ray_hit(DVec3::ZERO, DVec3::Z, 100.0).unwrap();
        assert!(
            (t - 6.0).abs() < 1e-10 && (n + DVec3::Z).length() < 1e-9,
            "{t} {n}"
        );
        // Straight down through the hole misses.
        assert_eq!(
            torus.ray_hit(DVec3::new(0.0, 30.0, 0.0), -DVec3::Y, 100.0),
            None
        );
        // Down through the tube's centre line: enters at y = 4.
        let (t, n) = torus
            .ray_hit(DVec3::new(0.0, 30.0, 10.0), -DVec3::Y, 100.0)
            .unwrap();
        assert!(
            (t - 26.0).abs() < 1e-10 && (n - DVec3::Y).length() < 1e-9,
            "{t} {n}"
        );

        let capsule = Shape::Capsule {
            half_length: 8.0,
            radius: 5.0,
        };
        let (t, n) = capsule
            .ray_hit(DVec3::new(0.0, 40.0, 0.0), -DVec3::Y, 100.0)
            .unwrap();
        assert!(
            (t - 27.0).abs() < 1e-10 && (n - DVec3::Y).length() < 1e-9,
            "{t} {n}"
        );
        let (t, n) = capsule
            .ray_hit(DVec3::new(3.0, 0.0, -20.0), DVec3::Z, 100.0)
            .unwrap();
        assert!(
            (t - 16.0).abs() < 1e-10 && (n - DVec3::new(0.6, 0.0, -0.8)).length() < 1e-9,
            "{t} {n}"
        );
    }

    /// Random rays against every shape: a reported hit lies on the surface with the gradient as
    /// normal, and no crossing is skipped before it (checked at dense samples along the ray).
    #[test]
    fn random_rays_find_the_first_crossing() {
        let mut rng = Rng(7);
        for shape in all_shapes() {
            let scale = shape.scale();
            for _ in 0..2000 {
                let origin = rng.in_cube(1.5 * scale);
                let dir = rng.direction();
                let t_max = 4.0 * scale * rng.next();
                let hit = shape.ray_hit(origin, dir, t_max);
                let end = match hit {
                    Some((t, n)) => {
                        let p = origin + dir * t;
                        assert!(t > 0.0 && t <= t_max);
                        assert!(
                            shape.signed_distance(p).abs() < 1e-9 * scale,
                            "{shape:?}: hit off surface"
                        );
                        assert!((n - shape.normal_at(p)).length() < 1e-12 && n.is_finite());
                        t
                    }
                    None => t_max,
                };
                let start = shape.contains(origin + dir * (1e-6 * scale));
                for k in 1..200 {
                    let p = origin + dir * (end * k as f64 / 200.0);
                    if shape.signed_distance(p).abs() > 1e-6 * scale {
                        assert_eq!(
                            shape.contains(p),
                            start,
                            "{shape:?}: crossing skipped before t = {end}"
                        );
                    }
                }
            }
        }
    }
}
