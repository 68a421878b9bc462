//! Triangle meshes: OBJ loading (tobj), procedural shapes, validation, inside/outside, ray queries.
//!
//! The path of an input mesh into the bake:
//!
//! ```no_run
//! use translucent::mesh::{MeshSolid, Solid, TriMesh, ValidateOptions};
//!
//! # fn main() -> Result<(), translucent::mesh::MeshError> {
//! let mut mesh = TriMesh::load_obj("bunny.obj")?; // every group merged, triangulated
//! let report = mesh.validate(&ValidateOptions::default())?; // refuses sheets, non-manifold edges
//! println!("{}", report.summary());
//! let (mesh, _transform) = mesh.normalized(50.0)?; // bounding-box centre at 0, longest side 50 mm
//! let solid = MeshSolid::new(mesh)?; // BVH + fast generalized winding number
//! assert!(!solid.contains(glam::DVec3::splat(1e3)));
//! # Ok(())
//! # }
//! ```
//!
//! Inside/outside is the generalized winding number `|w| > 1/2` (Jacobson et al. 2013), so holes are
//! bridged and inside-out meshes are still solids; [`shapes::Shape`] is the exact counterpart.

mod bvh;
mod gpu;
mod obj;
mod orient;
pub mod shapes;
mod solid;
pub(crate) mod split;
mod validate;

pub use gpu::{GpuMesh, Vertex};
pub use solid::{ClosestPoint, MeshSolid, RayHit};
pub use split::{weld_by_position, SHARP_EDGE_COS};
pub use validate::{MeshReport, Normalization, ValidateOptions};

use std::path::PathBuf;

use glam::DVec3;

/// Object sizes (longest side, mm) accepted by [`TriMesh::normalized`], the bake and the CLI's
/// `--size-mm`: the range the numerical stress matrix measured (`benches/src/bin/stress.rs`;
/// README "Numerical stress"). Outside it the bake's lattice arithmetic leaves f64 and the GPU's
/// f32 (a 1e300 mm sphere was killed for memory in the bake; 1e-300 mm gave zero volumes), so it
/// is refused, not attempted. Inside it, objects below about one mean free path need many more
/// Jacobi iterations on the GPU than the default cap (see the README).
pub const SIZE_RANGE_MM: std::ops::RangeInclusive<f64> = 1e-4..=1e8;

/// The bounding sphere (centre of the bounding box, radius in mm, at least 1e-3) of `points`;
/// (origin, 1) when there is none or one is not finite. What the shadow views and the automatic
/// camera are fitted to.
pub fn bounding_sphere(points: &[DVec3]) -> (DVec3, f64) {
    let (lo, hi) = points.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    );
    if !(lo.is_finite() && hi.is_finite()) {
        return (DVec3::ZERO, 1.0);
    }
    let centre = (lo + hi) * 0.5;
    let radius = points
        .iter()
        .map(|p| p.distance(centre))
        .fold(0.0, f64::max);
    (centre, radius.max(1e-3))
}

/// An indexed triangle mesh in f64 (converted to f32 at upload). Counter-clockwise faces seen from
/// outside; `normals` are per-vertex unit normals (same length as `positions`).
#[derive(Clone, Debug, Default)]
pub struct TriMesh {
    pub positions: Vec<DVec3>,
    pub normals: Vec<DVec3>,
    pub indices: Vec<[u32; 3]>,
}

/// Bad mesh input. Each variant names the problem; errors from a file are wrapped in
/// [`MeshError::InFile`], which names the file ([`MeshError::root`] unwraps it).
#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    #[error("cannot read {}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// An OBJ parse error that the line checks of [`TriMesh::parse_obj`] did not catch first (they
    /// mirror tobj's rules, so this is not expected; it has no line number).
    #[error("{}: not a valid OBJ file: {source}", path.display())]
    Obj {
        path: PathBuf,
        #[source]
        source: tobj::LoadError,
    },
    /// Names the file, and the line where the inner error has one: `FILE:LINE: problem`.
    #[error("{}{}: {source}", path.display(), source.line().map(|l| format!(":{l}")).unwrap_or_default())]
    InFile {
        path: PathBuf,
        #[source]
        source: Box<MeshError>,
    },
    /// A malformed OBJ line (wrapped in [`MeshError::InFile`], which prints the file and line).
    #[error("{problem}")]
    Syntax { line: usize, problem: String },
    #[error(transparent)]
    Limit(#[from] crate::limits::LimitExceeded),
    #[error("the mesh has no triangles")]
    Empty,
    #[error("face {face} refers to vertex {index}, but the mesh has {vertices} vertices")]
    IndexOutOfRange {
        face: usize,
        index: i64,
        vertices: usize,
        /// Line in the OBJ file, where the mesh came from one.
        line: Option<usize>,
    },
    #[error(
        "vertex {vertex} has a non-finite coordinate {} (or one beyond the f32 range of OBJ \
         loading)",
        point(.position)
    )]
    NonFiniteVertex {
        vertex: usize,
        position: [f64; 3],
        line: Option<usize>,
    },
    #[error("all {faces} faces are degenerate (zero area or a repeated vertex)")]
    AllDegenerate { faces: usize },
    #[error(
        "non-manifold edge between vertices {a} {} and {b} {}: shared by {faces} faces, a solid's \
         edges are shared by exactly 2 (parts touching along an edge, or a fin)",
        point(.pa),
        point(.pb)
    )]
    /// `a` and `b` index the mesh's vertices (for a loaded OBJ: numbered by first use in the faces,
    /// not by `v` line); `pa` and `pb` are their positions.
    NonManifoldEdge {
        a: u32,
        b: u32,
        pa: [f64; 3],
        pb: [f64; 3],
        faces: usize,
    },
    #[error(
        "open surface, not a solid: {boundary_edges} boundary edges, boundary length / sqrt(surface area) \
         = {ratio:.2} > {limit} (small holes are bridged, an open sheet is not); force it to treat it as \
         a solid anyway (inside = |generalized winding number| > 1/2)"
    )]
    OpenSurface {
        boundary_edges: usize,
        ratio: f64,
        limit: f64,
    },
    #[error(
        "inconsistent orientation: {edges} edges (first between vertices {a} and {b}) are traversed in the \
         same direction by both of their faces, so neighbouring faces wind opposite ways and inside \
         cannot be told from outside"
    )]
    InconsistentOrientation { edges: usize, a: u32, b: u32 },
    #[error(
        "vertex {vertex} at {} is too far from the origin for the queries (|coordinate| > \
         1e100, products would overflow): normalize the mesh first",
        point(.position)
    )]
    CoordinateTooLarge { vertex: usize, position: [f64; 3] },
    #[error("invalid shape {shape:?}: {problem}")]
    InvalidShape {
        shape: shapes::Shape,
        problem: &'static str,
    },
    #[error(
        "object size (longest side) must be a finite number of millimetres within {min} to {max}, got {0:e}",
        min = SIZE_RANGE_MM.start(),
        max = SIZE_RANGE_MM.end()
    )]
    InvalidSize(f64),
    #[error("the mesh has zero extent (all its vertices coincide)")]
    ZeroExtent,
}

/// A position as it would be written in an OBJ file (loaded coordinates are f32 values).
fn point(p: &[f64; 3]) -> String {
    format!("({} {} {})", p[0] as f32, p[1] as f32, p[2] as f32)
}

impl MeshError {
    /// The problem itself, without the [`MeshError::InFile`] layers naming the file.
    pub fn root(&self) -> &MeshError {
        match self {
            MeshError::InFile { source, .. } => source.root(),
            other => other,
        }
    }

    /// The line of the input file the problem is on, where known.
    pub fn line(&self) -> Option<usize> {
        match self {
            MeshError::InFile { source, .. } => source.line(),
            MeshError::Syntax { line, .. } => Some(*line),
            MeshError::IndexOutOfRange { line, .. } | MeshError::NonFiniteVertex { line, .. } => {
                *line
            }
            _ => None,
        }
    }

    /// Wraps `self` so its message names `path` (I/O and OBJ errors name it already).
    pub fn in_file(self, path: impl Into<PathBuf>) -> MeshError {
        match self {
            e @ (MeshError::Io { .. } | MeshError::Obj { .. } | MeshError::InFile { .. }) => e,
            e => MeshError::InFile {
                path: path.into(),
                source: Box::new(e),
            },
        }
    }
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

    /// The structural checks every query needs: faces exist, indices are in range, coordinates
    /// are finite.
    pub fn check_structure(&self) -> Result<(), MeshError> {
        if self.indices.is_empty() || self.positions.is_empty() {
            return Err(MeshError::Empty);
        }
        let vertices = self.positions.len();
        for (face, tri) in self.indices.iter().enumerate() {
            if let Some(&index) = tri.iter().find(|&&i| i as usize >= vertices) {
                return Err(MeshError::IndexOutOfRange {
                    face,
                    index: index.into(),
                    vertices,
                    line: None,
                });
            }
        }
        if let Some(vertex) = self.positions.iter().position(|p| !p.is_finite()) {
            let position = self.positions[vertex].to_array();
            return Err(MeshError::NonFiniteVertex {
                vertex,
                position,
                line: None,
            });
        }
        Ok(())
    }

    /// Enclosed volume by the divergence theorem (tetrahedra from the bounding-box centre, which
    /// keeps the sum well conditioned far from the origin): negative iff the faces wind inward.
    /// Faces with an index out of range are skipped ([`TriMesh::check_structure`] reports them).
    pub fn signed_volume(&self) -> f64 {
        let (lo, hi) = self.bounds();
        let o = 0.5 * (lo + hi);
        self.corners()
            .map(|[a, b, c]| (a - o).dot((b - o).cross(c - o)) / 6.0)
            .sum()
    }

    /// Total surface area (faces with an index out of range skipped).
    pub fn surface_area(&self) -> f64 {
        self.corners()
            .map(|[a, b, c]| 0.5 * (b - a).cross(c - a).length())
            .sum()
    }

    /// A face's corners, `None` if an index is out of range.
    fn face_corners(&self, tri: &[u32; 3]) -> Option<[DVec3; 3]> {
        let [a, b, c] = tri.map(|i| self.positions.get(i as usize).copied());
        Some([a?, b?, c?])
    }

    /// The corners of every face whose indices are all in range.
    fn corners(&self) -> impl Iterator<Item = [DVec3; 3]> + '_ {
        self.indices.iter().filter_map(|t| self.face_corners(t))
    }

    /// Recomputes area-weighted per-vertex normals from the faces (faces with an index out of range
    /// are skipped).
    pub fn compute_normals(&mut self) {
        let mut normals = vec![DVec3::ZERO; self.positions.len()];
        for tri in &self.indices {
            let Some([a, b, c]) = self.face_corners(tri) else {
                continue;
            };
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
    /// Whether the boundary is crossed anywhere in `0 < t <= t_max` (shadow rays). Same answer as
    /// `ray_hit(..).is_some()`; implementations may stop at the first crossing found.
    fn occluded(&self, origin: DVec3, dir: DVec3, t_max: f64) -> bool {
        self.ray_hit(origin, dir, t_max).is_some()
    }
    /// A point where `contains` changes along the segment from `inside` (contained) to `outside`
    /// (not), to within `tolerance` mm: what isosurface stuffing needs on a cut lattice edge.
    ///
    /// The default casts one ray along the segment and keeps its first crossing if `contains`
    /// agrees on both sides of it (`tolerance / 2` away); otherwise (a crossing with no surface to
    /// hit, as across a bridged hole) it bisects `contains`. One ray and two `contains` instead of
    /// `log2(length / tolerance)` of them.
    fn boundary_crossing(&self, inside: DVec3, outside: DVec3, tolerance: f64) -> DVec3 {
        let (delta, tolerance) = (outside - inside, tolerance.max(0.0));
        let length = delta.length();
        if length.is_finite() && length > tolerance {
            let dir = delta / length;
            if let Some((t, _)) = self.ray_hit(inside, dir, length) {
                let half = 0.5 * tolerance;
                let (before, after) = ((t - half).max(0.0), (t + half).min(length));
                if self.contains(inside + dir * before) && !self.contains(inside + dir * after) {
                    return inside + dir * t;
                }
            }
        }
        let (mut a, mut b) = (inside, outside);
        // 64 halvings reach any tolerance representable relative to the segment.
        for _ in 0..64 {
            if (b - a).length() <= tolerance {
                break;
            }
            let mid = 0.5 * (a + b);
            if self.contains(mid) {
                a = mid;
            } else {
                b = mid;
            }
        }
        0.5 * (a + b)
    }
}
