//! Validation of input meshes (DESIGN section 3.1) and normalization (section 3.2).
//!
//! Rules, in the order they are checked:
//! - no faces or no vertices: [`MeshError::Empty`]; a face index out of range:
//!   [`MeshError::IndexOutOfRange`]; a non-finite coordinate: [`MeshError::NonFiniteVertex`].
//! - degenerate faces (a repeated vertex, or area below `degenerate_area` times the squared
//!   bounding-box diagonal) are dropped and counted: scans often carry a few zero-area slivers, and
//!   they bound nothing. If every face is degenerate: [`MeshError::AllDegenerate`].
//! - topology is that of the indices (as in the file: [`TriMesh::load_obj`] keeps one vertex per
//!   OBJ position; coincident but distinct vertices are not welded, which is how the teapot's
//!   patches are open). An edge shared by more than two faces:
//!   [`MeshError::NonManifoldEdge`]; an edge traversed the same way by both its faces:
//!   [`MeshError::InconsistentOrientation`]; both unless `force_non_manifold`.
//! - open sheets: boundary length / sqrt(surface area) above `max_boundary_ratio` (5; the Stanford
//!   bunny's holes give 1.42, the teapot 19.1): [`MeshError::OpenSurface`] unless `force_open`.
//!   Below it, holes are bridged by the generalized winding number.
//!
//! With a force flag the mesh is accepted and treated as a solid by the generalized winding number
//! (inside = |w| > 1/2); [`MeshReport::forced`] says so and [`MeshReport::summary`] spells it out.
//!
//! ```
//! use translucent::mesh::{shapes::Shape, ValidateOptions};
//!
//! let mut mesh = Shape::Sphere { radius: 1.0 }.triangulate(16);
//! let report = mesh.validate(&ValidateOptions::default()).unwrap();
//! assert_eq!((report.boundary_edges, report.components, report.inverted), (0, 1, false));
//! let (mesh, transform) = mesh.normalized(50.0).unwrap();
//! assert_eq!(transform.scale, 25.0);
//! let (lo, hi) = mesh.bounds();
//! assert!((hi - lo).max_element() - 50.0 < 1e-12);
//! ```

use std::fmt;

use glam::DVec3;

use super::{MeshError, TriMesh};

/// What [`TriMesh::validate`] accepts.
#[derive(Clone, Debug, PartialEq)]
pub struct ValidateOptions {
    /// Accept open surfaces (boundary ratio above `max_boundary_ratio`), treated as solids by the
    /// generalized winding number.
    pub force_open: bool,
    /// Accept non-manifold edges and inconsistently oriented faces, likewise.
    pub force_non_manifold: bool,
    /// Boundary length / sqrt(surface area) above which a surface is an open sheet.
    pub max_boundary_ratio: f64,
    /// Faces with area below this times the squared bounding-box diagonal are degenerate.
    pub degenerate_area: f64,
}

impl Default for ValidateOptions {
    fn default() -> Self {
        ValidateOptions {
            force_open: false,
            force_non_manifold: false,
            max_boundary_ratio: 5.0,
            degenerate_area: 1e-14,
        }
    }
}

impl ValidateOptions {
    /// Everything forced: any triangle soup is accepted as the solid its winding number describes.
    pub fn forced() -> Self {
        ValidateOptions {
            force_open: true,
            force_non_manifold: true,
            ..Default::default()
        }
    }
}

/// What [`TriMesh::validate`] found (counts after degenerate faces were dropped).
#[derive(Clone, Debug, PartialEq)]
pub struct MeshReport {
    /// Distinct vertex positions.
    pub vertices: usize,
    pub faces: usize,
    pub degenerate_faces_dropped: usize,
    /// Edges used by one face only.
    pub boundary_edges: usize,
    pub boundary_length: f64,
    pub surface_area: f64,
    /// `boundary_length / sqrt(surface_area)`: 0 for a closed surface.
    pub boundary_ratio: f64,
    /// Edges used by more than two faces.
    pub non_manifold_edges: usize,
    /// Edges whose two faces traverse them the same way.
    pub inconsistent_edges: usize,
    /// Connected parts (faces sharing a vertex position).
    pub components: usize,
    /// Enclosed volume by the divergence theorem, in the mesh's units cubed.
    pub signed_volume: f64,
    /// The faces wind inward (negative signed volume); queries flip normals to point outward.
    pub inverted: bool,
    /// Accepted only because of a force flag: treated as a solid by the winding number.
    pub forced: bool,
}

impl MeshReport {
    /// One paragraph for the command line: what the mesh is and what will be done with it.
    pub fn summary(&self) -> String {
        let mut s = format!(
            "{} faces, {} vertices, {} component{}",
            self.faces,
            self.vertices,
            self.components,
            if self.components == 1 { "" } else { "s" }
        );
        if self.boundary_edges == 0 {
            s += ", closed";
        } else {
            s += &format!(
                ", {} boundary edges (boundary length / sqrt(area) = {:.2})",
                self.boundary_edges, self.boundary_ratio
            );
        }
        if self.degenerate_faces_dropped > 0 {
            s += &format!(
                "; dropped {} degenerate faces",
                self.degenerate_faces_dropped
            );
        }
        if self.non_manifold_edges > 0 {
            s += &format!("; {} non-manifold edges", self.non_manifold_edges);
        }
        if self.inconsistent_edges > 0 {
            s += &format!(
                "; {} inconsistently oriented edges (faces are turned to agree with their \
                 neighbours when the solid is built)",
                self.inconsistent_edges
            );
        }
        if self.inverted {
            s += "; faces wind inward (inside-out): normals are flipped";
        }
        if self.forced {
            s += "; FORCED: not a closed solid, treated as one by the generalized winding number \
                  (inside where |w| > 1/2), results near the open parts are a guess";
        } else if self.boundary_edges > 0 {
            s += "; holes are bridged by the generalized winding number";
        }
        s
    }
}

impl fmt::Display for MeshReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.summary())
    }
}

/// The transform [`TriMesh::normalized`] applied: `p' = (p - centre) * scale`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Normalization {
    pub centre: DVec3,
    pub scale: f64,
}

impl Normalization {
    pub fn apply(&self, p: DVec3) -> DVec3 {
        (p - self.centre) * self.scale
    }

    /// Back to the input frame.
    pub fn invert(&self, p: DVec3) -> DVec3 {
        p / self.scale + self.centre
    }
}

impl TriMesh {
    /// Checks the mesh against the rules of the module doc and reports what it found; an accepted
    /// mesh loses its degenerate faces (counted in the report), a refused one is left unchanged.
    /// The first problem found is the error.
    pub fn validate(&mut self, options: &ValidateOptions) -> Result<MeshReport, MeshError> {
        self.check_structure()?;
        let (lo, hi) = self.bounds();
        let diagonal2 = (hi - lo).length_squared();
        let kept: Vec<[u32; 3]> = self
            .indices
            .iter()
            .filter(|t| {
                let [a, b, c] = t.map(|i| self.positions[i as usize]);
                t[0] != t[1]
                    && t[1] != t[2]
                    && t[2] != t[0]
                    && 0.5 * (b - a).cross(c - a).length() > options.degenerate_area * diagonal2
            })
            .copied()
            .collect();
        if kept.is_empty() {
            return Err(MeshError::AllDegenerate {
                faces: self.indices.len(),
            });
        }
        // The mesh changes only if it is accepted.
        let original = std::mem::replace(&mut self.indices, kept);
        let dropped = original.len() - self.indices.len();
        let result = self.analyse(options, dropped);
        if result.is_err() {
            self.indices = original;
        }
        result
    }

    /// Topology and the open-sheet rule on faces already free of degenerate ones.
    fn analyse(&self, options: &ValidateOptions, dropped: usize) -> Result<MeshReport, MeshError> {
        // Every face edge as (low, high, forward); sorted, uses of one edge are adjacent.
        let mut edges: Vec<(u32, u32, bool)> = Vec::with_capacity(3 * self.indices.len());
        for t in &self.indices {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                edges.push((a.min(b), a.max(b), a < b));
            }
        }
        edges.sort_unstable();
        let position_of = |v: u32| self.positions[v as usize];
        let (mut boundary_edges, mut boundary_length) = (0, 0.0);
        let (mut non_manifold, mut first_non_manifold) = (0, None);
        let (mut inconsistent, mut first_inconsistent) = (0, None);
        for run in edges.chunk_by(|x, y| (x.0, x.1) == (y.0, y.1)) {
            let (a, b, _) = run[0];
            match run.len() {
                1 => {
                    boundary_edges += 1;
                    boundary_length += (position_of(a) - position_of(b)).length();
                }
                2 => {
                    if run[0].2 == run[1].2 {
                        inconsistent += 1;
                        first_inconsistent.get_or_insert((a, b));
                    }
                }
                n => {
                    non_manifold += 1;
                    first_non_manifold.get_or_insert((a, b, n));
                }
            }
        }
        let surface_area = self.surface_area();
        let boundary_ratio = if surface_area > 0.0 {
            boundary_length / surface_area.sqrt()
        } else {
            0.0
        };
        let signed_volume = self.signed_volume();
        let mut report = MeshReport {
            vertices: self
                .indices
                .iter()
                .flatten()
                .collect::<std::collections::HashSet<_>>()
                .len(),
            faces: self.indices.len(),
            degenerate_faces_dropped: dropped,
            boundary_edges,
            boundary_length,
            surface_area,
            boundary_ratio,
            non_manifold_edges: non_manifold,
            inconsistent_edges: inconsistent,
            components: components(&self.indices, self.positions.len()),
            signed_volume,
            inverted: signed_volume < 0.0,
            forced: false,
        };

        if let Some((a, b, faces)) = first_non_manifold {
            if !options.force_non_manifold {
                let (pa, pb) = (position_of(a).to_array(), position_of(b).to_array());
                return Err(MeshError::NonManifoldEdge {
                    a,
                    b,
                    pa,
                    pb,
                    faces,
                });
            }
            report.forced = true;
        }
        if let Some((a, b)) = first_inconsistent {
            if !options.force_non_manifold {
                return Err(MeshError::InconsistentOrientation {
                    edges: inconsistent,
                    a,
                    b,
                });
            }
            report.forced = true;
        }
        if boundary_ratio > options.max_boundary_ratio {
            if !options.force_open {
                return Err(MeshError::OpenSurface {
                    boundary_edges,
                    ratio: boundary_ratio,
                    limit: options.max_boundary_ratio,
                });
            }
            report.forced = true;
        }
        Ok(report)
    }

    /// A copy centred and scaled as in DESIGN section 3.2: bounding-box centre at the origin,
    /// longest side `size_mm` millimetres (within [`super::SIZE_RANGE_MM`]); with the transform
    /// applied. Normals are unchanged (the scale is uniform).
    pub fn normalized(&self, size_mm: f64) -> Result<(TriMesh, Normalization), MeshError> {
        if !super::SIZE_RANGE_MM.contains(&size_mm) {
            return Err(MeshError::InvalidSize(size_mm));
        }
        self.check_structure()?;
        let (lo, hi) = self.bounds();
        let longest = (hi - lo).max_element();
        let transform = Normalization {
            centre: 0.5 * (lo + hi),
            scale: size_mm / longest,
        };
        if longest <= 0.0 || !transform.scale.is_finite() || !transform.centre.is_finite() {
            return Err(MeshError::ZeroExtent);
        }
        let mesh = TriMesh {
            positions: self.positions.iter().map(|&p| transform.apply(p)).collect(),
            normals: self.normals.clone(),
            indices: self.indices.clone(),
        };
        Ok((mesh, transform))
    }
}

/// Connected components of the faces (sharing a vertex), by union-find.
fn components(indices: &[[u32; 3]], vertices: usize) -> usize {
    let mut parent: Vec<u32> = (0..vertices as u32).collect();
    fn find(parent: &mut [u32], mut x: u32) -> u32 {
        while parent[x as usize] != x {
            parent[x as usize] = parent[parent[x as usize] as usize];
            x = parent[x as usize];
        }
        x
    }
    for t in indices {
        let r0 = find(&mut parent, t[0]);
        for &i in &t[1..] {
            let r = find(&mut parent, i);
            parent[r as usize] = r0;
        }
    }
    let mut roots = std::collections::HashSet::new();
    for t in indices {
        roots.insert(find(&mut parent, t[0]));
    }
    roots.len()
}
