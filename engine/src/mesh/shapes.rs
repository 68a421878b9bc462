//! Procedural shapes, defined exactly by a signed distance (negative inside), with a triangulation
//! for display. They make every command usable with no input files.

use std::f64::consts::{PI, TAU};

use glam::DVec3;

use super::TriMesh;

/// A procedural solid centred at the origin (millimetres).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shape {
    Sphere { radius: f64 },
    /// Ring in the XZ plane: `major` radius of the ring, `minor` radius of the tube.
    Torus { major: f64, minor: f64 },
}

impl Shape {
    /// Signed distance in mm, negative inside.
    pub fn signed_distance(&self, p: DVec3) -> f64 {
        match *self {
            Shape::Sphere { radius } => p.length() - radius,
            Shape::Torus { major, minor } => {
                let q = glam::DVec2::new(glam::DVec2::new(p.x, p.z).length() - major, p.y);
                q.length() - minor
            }
        }
    }

    /// A triangulation with about `2 * segments^2` triangles (unit normals from the exact shape).
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
                        let d = DVec3::new(theta.sin() * phi.cos(), theta.cos(), -theta.sin() * phi.sin());
                        mesh.positions.push(d * radius);
                    }
                }
                mesh.positions.push(-DVec3::Y * radius);
                let ring = |r: u32, s: u32| 1 + (r - 1) * sectors + s % sectors;
                let south = mesh.positions.len() as u32 - 1;
                for s in 0..sectors {
                    mesh.indices.push([0, ring(1, s), ring(1, s + 1)]);
                    mesh.indices.push([south, ring(rings - 1, s + 1), ring(rings - 1, s)]);
                }
                for r in 1..rings - 1 {
                    for s in 0..sectors {
                        let (a, b, c, d) = (ring(r, s), ring(r, s + 1), ring(r + 1, s), ring(r + 1, s + 1));
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
        }
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

    #[test]
    fn triangulations_are_closed_outward_and_converge_to_the_exact_volume() {
        let sphere = Shape::Sphere { radius: 10.0 };
        let torus = Shape::Torus { major: 10.0, minor: 4.0 };
        for (shape, exact) in [
            (sphere, 4.0 / 3.0 * PI * 1000.0),
            (torus, 2.0 * PI * PI * 10.0 * 16.0),
        ] {
            let coarse = (signed_volume(&shape.triangulate(16)) - exact).abs();
            let fine = signed_volume(&shape.triangulate(64));
            assert!(fine > 0.0, "{shape:?} winds inward");
            assert!((fine - exact).abs() < 0.01 * exact, "{shape:?}: {fine} vs {exact}");
            assert!((fine - exact).abs() < coarse / 4.0, "{shape:?} does not converge");
            for p in &shape.triangulate(16).positions {
                assert!(shape.signed_distance(*p).abs() < 1e-9);
            }
        }
    }
}
