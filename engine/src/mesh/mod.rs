//! Triangle meshes: OBJ loading (tobj), procedural shapes, validation, inside/outside, ray queries.

pub mod shapes;

use glam::DVec3;

/// An indexed triangle mesh in f64 (converted to f32 at upload). Counter-clockwise faces seen from
/// outside; `normals` are per-vertex unit normals (same length as `positions`).
#[derive(Clone, Debug, Default)]
pub struct TriMesh {
    pub positions: Vec<DVec3>,
    pub normals: Vec<DVec3>,
    pub indices: Vec<[u32; 3]>,
}

/// Bad mesh input. Each variant names the problem (and the file, where there is one).
#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    #[error("mesh: {0}")]
    Invalid(String),
}

impl TriMesh {
    /// Axis-aligned bounds (min, max). `(0, 0)` for an empty mesh.
    pub fn bounds(&self) -> (DVec3, DVec3) {
        let mut it = self.positions.iter();
        let Some(&first) = it.next() else {
            return (DVec3::ZERO, DVec3::ZERO);
        };
        it.fold((first, first), |(lo, hi), &p| (lo.min(p), hi.max(p)))
    }

    /// Recomputes area-weighted per-vertex normals from the faces.
    pub fn compute_normals(&mut self) {
        let mut normals = vec![DVec3::ZERO; self.positions.len()];
        for tri in &self.indices {
            let [a, b, c] = tri.map(|i| self.positions[i as usize]);
            let n = (b - a).cross(c - a);
            for &i in tri {
                normals[i as usize] += n;
            }
        }
        self.normals = normals.into_iter().map(|n| n.normalize_or_zero()).collect();
    }
}

/// A closed solid the bake and the solvers can query: inside/outside, ray hits and bounds.
/// Implemented exactly by [`shapes::Shape`] and, for triangle meshes, with the generalized winding
/// number over a bounding volume hierarchy (robust to holes and inside-out winding).
pub trait Solid: Sync {
    /// Whether `p` lies inside the solid.
    fn contains(&self, p: DVec3) -> bool;
    /// The first crossing of the boundary along `origin + t * dir` (`dir` unit length) with
    /// `0 < t <= t_max`: the distance `t` and the boundary's outward unit normal there.
    fn ray_hit(&self, origin: DVec3, dir: DVec3, t_max: f64) -> Option<(f64, DVec3)>;
    /// Axis-aligned bounds (min, max) in mm.
    fn bounds(&self) -> (DVec3, DVec3);
}
