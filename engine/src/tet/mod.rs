//! Tetrahedral meshing by isosurface stuffing (Labelle and Shewchuk 2007, "Isosurface Stuffing: Fast
//! Tetrahedral Meshes with Good Dihedral Angles") on a body-centred cubic lattice, graded by an
//! octree (DESIGN section 3, step 3).
//!
//! [`lattice`] builds the background lattice, [`stuffing`] cuts and warps it to the solid;
//! [`tetrahedralize`] runs both.
//!
//! ```
//! use glam::DVec3;
//! use translucent::mesh::Solid;
//! use translucent::tet::{tetrahedralize, TetParams};
//! struct Ball;
//! impl Solid for Ball {
//!     fn contains(&self, p: DVec3) -> bool { p.length() < 10.0 }
//!     fn ray_hit(&self, _: DVec3, _: DVec3, _: f64) -> Option<(f64, DVec3)> { None }
//!     fn bounds(&self) -> (DVec3, DVec3) { (DVec3::splat(-10.0), DVec3::splat(10.0)) }
//! }
//! let surface = translucent::mesh::shapes::Shape::Sphere { radius: 10.0 }.triangulate(32);
//! let (mesh, stats) = tetrahedralize(&Ball, &surface, &TetParams { spacing: 2.0, grading: 0.5, ..Default::default() });
//! assert!(mesh.tets.len() > 100 && stats.min_dihedral_deg > 8.0);
//! ```

pub mod lattice;
pub mod structured;
pub mod stuffing;

use glam::DVec3;

use crate::limits::{Limit, LimitExceeded, Limits};
use crate::mesh::{Solid, TriMesh};

/// A tetrahedral mesh. Every tetrahedron is positively oriented:
/// `(v1 - v0) . ((v2 - v0) x (v3 - v0)) > 0`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TetMesh {
    /// Vertex positions in millimetres (normalized object frame).
    pub vertices: Vec<glam::DVec3>,
    /// Four vertex indices per tetrahedron.
    pub tets: Vec<[u32; 4]>,
}

/// Parameters of [`tetrahedralize`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TetParams {
    /// Finest lattice spacing in mm (BCC long-edge length near the surface).
    pub spacing: f64,
    /// Grading `K`: 0 keeps the interior uniform; larger values let interior tetrahedra grow faster
    /// with the distance to the surface (see [`lattice::LatticeParams::grading`]).
    pub grading: f64,
    pub stuffing: stuffing::StuffParams,
}

impl Default for TetParams {
    fn default() -> Self {
        Self {
            spacing: 1.0,
            grading: 1.0,
            stuffing: stuffing::StuffParams::default(),
        }
    }
}

/// Tetrahedralizes `solid`; `surface` is a triangulation of its boundary, used only to find where the
/// lattice must be finest (points on it are taken no farther apart than half the spacing).
pub fn tetrahedralize(
    solid: &dyn Solid,
    surface: &TriMesh,
    params: &TetParams,
) -> (TetMesh, stuffing::StuffStats) {
    let samples =
        lattice::sample_surface(&surface.positions, &surface.indices, params.spacing / 2.0);
    let lattice = lattice::BccLattice::build(
        &lattice::LatticeParams {
            spacing: params.spacing,
            grading: params.grading,
        },
        solid.bounds(),
        &samples,
    );
    stuffing::stuff(&lattice, solid, &params.stuffing)
}

/// [`tetrahedralize`] within `limits`: the surface samples ([`Limit::SurfaceSamples`]) are
/// counted before they are made, and the lattice's nodes ([`Limit::LatticeNodes`]) estimated
/// before it is built (see [`lattice::BccLattice::build_limited`]).
pub fn try_tetrahedralize(
    solid: &dyn Solid,
    surface: &TriMesh,
    params: &TetParams,
    limits: &Limits,
) -> Result<(TetMesh, stuffing::StuffStats), LimitExceeded> {
    let max_gap = params.spacing / 2.0;
    let samples = lattice::surface_sample_count(&surface.positions, &surface.indices, max_gap);
    limits.check(Limit::SurfaceSamples, samples)?;
    let samples = lattice::sample_surface(&surface.positions, &surface.indices, max_gap);
    let lattice = lattice::BccLattice::build_limited(
        &lattice::LatticeParams {
            spacing: params.spacing,
            grading: params.grading,
        },
        solid.bounds(),
        &samples,
        limits.max_lattice_nodes,
    )?;
    Ok(stuffing::stuff(&lattice, solid, &params.stuffing))
}

/// Signed volume of a tetrahedron (positive for the orientation of [`TetMesh`]).
pub fn signed_volume(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> f64 {
    (b - a).dot((c - a).cross(d - a)) / 6.0
}

/// The six interior dihedral angles of a tetrahedron, in degrees.
pub fn dihedral_angles(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> [f64; 6] {
    let p = [a, b, c, d];
    // Dihedral angle at edge (i, j) between the faces (i, j, k) and (i, j, l).
    let pairs = [
        (0, 1, 2, 3),
        (0, 2, 1, 3),
        (0, 3, 1, 2),
        (1, 2, 0, 3),
        (1, 3, 0, 2),
        (2, 3, 0, 1),
    ];
    pairs.map(|(i, j, k, l)| {
        let e = (p[j] - p[i]).normalize_or_zero();
        let u = p[k] - p[i];
        let v = p[l] - p[i];
        let u = (u - e * u.dot(e)).normalize_or_zero();
        let v = (v - e * v.dot(e)).normalize_or_zero();
        u.dot(v).clamp(-1.0, 1.0).acos().to_degrees()
    })
}

#[cfg(test)]
pub(crate) mod tests;
