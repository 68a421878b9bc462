//! The deformations and their pure-CPU geometry (mapping points and normals, validation, deformed
//! levels for the CPU reference); nothing here touches the GPU.

use glam::{DMat3, DVec3, Mat4};

use crate::quadgraph::graph::GraphLevel;
use crate::solver::gpu::SolverError;
use crate::{Error, QuadGraph};

/// A deformation of the object, in its normalized frame (mm). Applied to the rest pose the bake
/// produced (not accumulated): `deform(Identity)` restores the baked shape.
#[derive(Clone, Debug, PartialEq)]
pub enum Deformation {
    /// The baked shape.
    Identity,
    /// An affine map of every position (normals by its inverse transpose). Must be invertible
    /// and orientation-preserving.
    Affine(Mat4),
    /// A twist about the +Y axis through the origin: `radians_per_mm * y` radians at height y.
    Twist { radians_per_mm: f32 },
    /// New positions of every level's tetrahedron vertices (outer index: level, coarsest first).
    TetPositions(Vec<Vec<[f32; 3]>>),
}

fn invalid(problem: String) -> Error {
    Error::Solver(SolverError::BadParameter {
        name: "deformation",
        problem,
    })
}

impl Deformation {
    /// The analytic map of a point (f64, the same formulas as `edit/map_vertices.comp`); `None`
    /// for `TetPositions`.
    pub fn map_point(&self, p: DVec3) -> Option<DVec3> {
        match self {
            Deformation::Identity => Some(p),
            Deformation::Affine(m) => Some(m.as_dmat4().transform_point3(p)),
            Deformation::Twist { radians_per_mm } => {
                let a = f64::from(*radians_per_mm) * p.y;
                let (s, c) = a.sin_cos();
                Some(DVec3::new(c * p.x + s * p.z, p.y, -s * p.x + c * p.z))
            }
            Deformation::TetPositions(_) => None,
        }
    }

    /// Checks the deformation against `graph` (module doc, "Degenerate input").
    pub fn validate(&self, graph: &QuadGraph) -> Result<(), Error> {
        match self {
            Deformation::Identity => Ok(()),
            Deformation::Affine(m) => {
                if !m.is_finite() {
                    return Err(invalid(format!("affine map {m} is not finite")));
                }
                let rows = m.row(3);
                if rows != glam::Vec4::W {
                    return Err(invalid(format!(
                        "affine map has a projective last row {rows} (expected 0, 0, 0, 1)"
                    )));
                }
                let m3 = glam::DMat3::from_mat4(m.as_dmat4());
                let det = m3.determinant();
                let norm = (m3.x_axis.length_squared()
                    + m3.y_axis.length_squared()
                    + m3.z_axis.length_squared())
                .sqrt()
                    / 3f64.sqrt();
                if det.is_nan() || det <= 1e-6 * norm.powi(3) {
                    return Err(invalid(format!(
                        "affine map with determinant {det:e} flattens or mirrors the object (must be > 1e-6 |M|^3)"
                    )));
                }
                Ok(())
            }
            Deformation::Twist { radians_per_mm } => {
                if radians_per_mm.is_finite() {
                    Ok(())
                } else {
                    Err(invalid(format!(
                        "twist rate {radians_per_mm} is not finite"
                    )))
                }
            }
            Deformation::TetPositions(levels) => {
                if levels.len() != graph.levels.len() {
                    return Err(invalid(format!(
                        "{} levels of positions for {} graph levels",
                        levels.len(),
                        graph.levels.len()
                    )));
                }
                for (h, (p, level)) in levels.iter().zip(&graph.levels).enumerate() {
                    if p.len() != level.tets.vertices.len() {
                        return Err(invalid(format!(
                            "level {h}: {} positions for {} tetrahedron vertices",
                            p.len(),
                            level.tets.vertices.len()
                        )));
                    }
                    if let Some(v) = p.iter().position(|v| !v.iter().all(|x| x.is_finite())) {
                        return Err(invalid(format!("level {h}: vertex {v} is not finite")));
                    }
                    let d = |i: u32| DVec3::from(p[i as usize].map(f64::from));
                    for (t, tet) in level.tets.tets.iter().enumerate() {
                        let [a, b, c, e] = tet.map(d);
                        let volume = (b - a).dot((c - a).cross(e - a)) / 6.0;
                        if volume.is_nan() || volume <= 0.0 {
                            return Err(invalid(format!(
                                "level {h}: tetrahedron {t} gets volume {volume:e} (flattened or inverted)"
                            )));
                        }
                    }
                }
                Ok(())
            }
        }
    }

    /// The deformed tetrahedron vertices of level `h` (f64), as the GPU computes them.
    pub fn level_vertices(&self, h: usize, level: &GraphLevel) -> Vec<DVec3> {
        match self {
            Deformation::TetPositions(p) => p
                .get(h)
                .map(|v| v.iter().map(|x| DVec3::from(x.map(f64::from))).collect())
                .unwrap_or_else(|| level.tets.vertices.clone()),
            _ => level
                .tets
                .vertices
                .iter()
                .map(|&v| self.map_point(v).unwrap_or(v))
                .collect(),
        }
    }

    /// The CPU reference of what the GPU does to level `h` (f64): tetrahedron vertices mapped,
    /// every node at its barycentric coordinates in its rest tetrahedron, surface normals by
    /// F^-T of that tetrahedron. Build a `LevelOperator` on it to check the GPU's weights.
    pub fn deformed_level(&self, h: usize, level: &GraphLevel) -> GraphLevel {
        let vertices = self.level_vertices(h, level);
        let mut out = level.clone();
        let inner = level.inner_count();
        for node in 0..level.node_count() {
            let t = if node < inner {
                node
            } else {
                level.surface_faces[node - inner].0 as usize
            };
            let tet = level.tets.tets[t];
            let rest = tet.map(|v| level.tets.vertices[v as usize]);
            let def = tet.map(|v| vertices[v as usize]);
            let b = barycentric(rest, level.positions[node]);
            out.positions[node] = def[0] * b[0] + def[1] * b[1] + def[2] * b[2] + def[3] * b[3];
            if node >= inner {
                let s = node - inner;
                out.surface_normals[s] = transform_normal(rest, def, level.surface_normals[s]);
            }
        }
        out.tets.vertices = vertices;
        out
    }
}

/// Barycentric coordinates of `x` in the tetrahedron `v` (outside it: some negative; exact for
/// affine maps either way).
pub fn barycentric(v: [DVec3; 4], x: DVec3) -> [f64; 4] {
    let d = DMat3::from_cols(v[1] - v[0], v[2] - v[0], v[3] - v[0]);
    let l = d.inverse() * (x - v[0]);
    [1.0 - l.x - l.y - l.z, l.x, l.y, l.z]
}

/// n' ~ F^-T n for the deformation gradient F = D' D^-1 of a tetrahedron (normalized; the rest
/// normal where the deformed tetrahedron is flat).
pub fn transform_normal(rest: [DVec3; 4], def: [DVec3; 4], n: DVec3) -> DVec3 {
    let d = DMat3::from_cols(rest[1] - rest[0], rest[2] - rest[0], rest[3] - rest[0]);
    let e = DMat3::from_cols(def[1] - def[0], def[2] - def[0], def[3] - def[0]);
    let m = e.inverse().transpose() * (d.transpose() * n);
    let m = m.normalize_or_zero();
    if m == DVec3::ZERO || !m.is_finite() {
        n
    } else {
        m
    }
}
