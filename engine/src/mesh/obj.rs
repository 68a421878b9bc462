//! OBJ input through tobj: every object and group merged into one triangulated [`TriMesh`] with one
//! vertex per OBJ position; errors name the file and, where the problem is a line, the line
//! (`FILE:LINE: problem`). Hostile input is bounded by [`Limits`] before it is parsed.
//!
//! ```
//! use translucent::mesh::{MeshError, TriMesh};
//! use translucent::limits::Limits;
//! let text = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nv 1 2";
//! let err = TriMesh::parse_obj(text, "cut.obj".as_ref(), &Limits::default()).unwrap_err();
//! assert_eq!(err.to_string(), "cut.obj:5: vertex 4: coordinate z is missing");
//! assert!(matches!(err.root(), MeshError::Syntax { line: 5, .. }));
//! let mesh = TriMesh::parse_obj(&text[..text.len() - 6], "ok.obj".as_ref(), &Limits::default())?;
//! assert_eq!(mesh.indices.len(), 1);
//! # Ok::<(), MeshError>(())
//! ```

use std::collections::HashMap;
use std::io::Read as _;
use std::path::Path;

use glam::DVec3;

use super::{MeshError, TriMesh};
use crate::limits::{Limit, Limits};

impl TriMesh {
    /// Loads an OBJ file. Polygons are fanned into triangles. One vertex per OBJ position (`v`):
    /// the file's connectivity is kept, so validation sees the topology the file has, and vertices
    /// of different objects or groups at identical positions are merged (a closed surface split into
    /// groups stays closed). Normals: the file's normals averaged per position where every corner
    /// has one (hard edges become smooth), otherwise computed from the faces. Texture coordinates
    /// and material libraries are not read.
    ///
    /// The [`Limits`] are [`Limits::from_env`]'s (see [`TriMesh::load_obj_with_limits`]).
    ///
    /// Errors: the file cannot be read ([`MeshError::Io`]); a line is malformed
    /// ([`MeshError::Syntax`], `FILE:LINE: problem`), a face index is out of range or a coordinate
    /// is not finite (with the line), a limit is exceeded, or there are no triangles; all but the
    /// first two are wrapped in [`MeshError::InFile`], which names the file and the line.
    pub fn load_obj(path: impl AsRef<Path>) -> Result<TriMesh, MeshError> {
        Self::load_obj_with_limits(path, &Limits::from_env())
    }

    /// [`TriMesh::load_obj`] with explicit limits: the file size ([`Limit::FileBytes`], checked
    /// while reading, so a huge or endless file is not read whole), then the vertex and triangle
    /// counts ([`Limit::Vertices`], [`Limit::Triangles`], counted before anything is parsed into
    /// memory).
    pub fn load_obj_with_limits(
        path: impl AsRef<Path>,
        limits: &Limits,
    ) -> Result<TriMesh, MeshError> {
        let path = path.as_ref();
        let io = |source| MeshError::Io {
            path: path.into(),
            source,
        };
        let file = std::fs::File::open(path).map_err(io)?;
        let mut bytes = Vec::new();
        // One byte past the limit tells "at the limit" from "above it" without reading the rest.
        file.take(limits.max_file_bytes.saturating_add(1))
            .read_to_end(&mut bytes)
            .map_err(io)?;
        limits
            .check(Limit::FileBytes, bytes.len() as u64)
            .map_err(|e| MeshError::Limit(e).in_file(path))?;
        Self::parse_obj(&bytes, path, limits)
    }

    /// Parses OBJ text held in memory (what [`TriMesh::load_obj`] does after reading the file);
    /// `path` only names the input in error messages. Every line is checked first, with the rules
    /// tobj applies and the line number in the error; tobj then parses text known to be valid.
    pub fn parse_obj(bytes: &[u8], path: &Path, limits: &Limits) -> Result<TriMesh, MeshError> {
        let counts = prescan(bytes).map_err(|e| e.in_file(path))?;
        let limit = |e| MeshError::Limit(e).in_file(path);
        limits
            .check(Limit::Vertices, counts.vertices)
            .map_err(limit)?;
        limits
            .check(Limit::Triangles, counts.triangles)
            .map_err(limit)?;
        let options = tobj::LoadOptions {
            triangulate: true,
            single_index: false,
            ignore_points: true,
            ignore_lines: true,
        };
        let (models, _materials) = tobj::load_obj_buf(&mut &bytes[..], &options, |_| {
            Err(tobj::LoadError::GenericFailure)
        })
        .map_err(|source| MeshError::Obj {
            path: path.into(),
            source,
        })?;
        let mut mesh = TriMesh::default();
        let mut normal_sums: Vec<DVec3> = Vec::new();
        let mut file_normals = true;
        // Vertices of earlier models by position: a later model at the same position reuses them.
        let mut earlier: HashMap<[u64; 3], u32> = HashMap::new();
        for model in &models {
            let m = &model.mesh;
            let local: Vec<DVec3> = m
                .positions
                .chunks_exact(3)
                .map(|p| DVec3::new(p[0].into(), p[1].into(), p[2].into()))
                .collect();
            let ids: Vec<u32> = local
                .iter()
                .map(|&p| match earlier.get(&position_key(p)) {
                    Some(&id) => id,
                    None => {
                        mesh.positions.push(p);
                        normal_sums.push(DVec3::ZERO);
                        mesh.positions.len() as u32 - 1
                    }
                })
                .collect();
            let has_normals = m.normal_indices.len() == m.indices.len() && !m.normals.is_empty();
            file_normals &= has_normals;
            for (face, tri) in m.indices.chunks_exact(3).enumerate() {
                let tri = [tri[0], tri[1], tri[2]];
                // tobj checked the indices; a violation here is a tobj bug, still not a panic.
                if let Some(&index) = tri.iter().find(|&&i| i as usize >= local.len()) {
                    let vertices = local.len();
                    return Err(MeshError::IndexOutOfRange {
                        face,
                        index: index.into(),
                        vertices,
                        line: None,
                    }
                    .in_file(path));
                }
                let tri = tri.map(|i| ids[i as usize]);
                if has_normals {
                    for (k, &v) in tri.iter().enumerate() {
                        let n = 3 * m.normal_indices[3 * face + k] as usize;
                        if let Some(n) = m.normals.get(n..n + 3) {
                            // Files do not always store unit normals; each corner counts once.
                            normal_sums[v as usize] +=
                                DVec3::new(n[0].into(), n[1].into(), n[2].into())
                                    .normalize_or_zero();
                        }
                    }
                }
                mesh.indices.push(tri);
            }
            for (&p, &id) in local.iter().zip(&ids) {
                earlier.entry(position_key(p)).or_insert(id);
            }
        }
        mesh.check_structure().map_err(|e| e.in_file(path))?;
        let usable = |n: &DVec3| n.is_finite() && n.length_squared() > 0.0;
        if file_normals && normal_sums.iter().all(usable) {
            mesh.normals = normal_sums.iter().map(|n| n.normalize()).collect();
        } else {
            mesh.compute_normals();
        }
        Ok(mesh)
    }
}

/// Bitwise identity of a position (-0 and +0 are the same).
fn position_key(p: DVec3) -> [u64; 3] {
    (p + DVec3::ZERO).to_array().map(f64::to_bits)
}

/// What [`prescan`] counted: `v` lines and the triangles the faces fan into.
#[derive(Clone, Copy, Debug, Default)]
struct ObjCounts {
    vertices: u64,
    triangles: u64,
}

/// One face corner's index in one slot (position, texture coordinate or normal), where it was.
#[derive(Clone, Copy, Debug)]
struct IndexAt {
    /// 0-based, as tobj resolves it (negative: relative, before the first element).
    resolved: i64,
    /// As written in the file.
    written: i64,
    line: usize,
    face: usize,
}

/// The indices of one slot a tobj model refers to. tobj resolves positive indices when the model
/// closes (at an `o`/`g` line after faces, or at the end), against everything read by then.
#[derive(Clone, Copy, Debug, Default)]
struct PendingSlot {
    highest: Option<IndexAt>,
    below_zero: Option<IndexAt>,
}

impl PendingSlot {
    fn note(&mut self, at: IndexAt) {
        if at.resolved < 0 {
            self.below_zero.get_or_insert(at);
        } else if self.highest.is_none_or(|h| at.resolved > h.resolved) {
            self.highest = Some(at);
        }
    }

    /// The first index that does not resolve among `count` elements.
    fn out_of_range(&self, count: u64) -> Option<IndexAt> {
        self.below_zero
            .or(self.highest.filter(|h| h.resolved as u64 >= count))
    }
}

/// Checks every line with the rules tobj applies (so that its parse cannot fail without a line
/// number), the indices in range, the coordinates finite in f32 (tobj's precision), and counts
/// vertices and triangles for the limits. No allocation beyond a few words of state: this runs
/// before anything is parsed into memory.
fn prescan(bytes: &[u8]) -> Result<ObjCounts, MeshError> {
    let mut counts = ObjCounts::default();
    let (mut texcoords, mut normals, mut faces) = (0u64, 0u64, 0usize);
    let mut coloured: Option<bool> = None;
    // The model being read: whether it has faces (tobj closes only such a model), and its indices.
    let mut has_faces = false;
    let mut pending = [PendingSlot::default(); 3];
    let close = |pending: &mut [PendingSlot; 3],
                 counts: &ObjCounts,
                 texcoords: u64,
                 normals: u64|
     -> Result<(), MeshError> {
        if let Some(at) = pending[0].out_of_range(counts.vertices) {
            return Err(MeshError::IndexOutOfRange {
                face: at.face,
                index: at.written,
                vertices: counts.vertices as usize,
                line: Some(at.line),
            });
        }
        // tobj reads texture coordinates and normals only when the file has some.
        for (slot, count, what, keyword) in [
            (1, texcoords, "texture coordinate", "vt"),
            (2, normals, "normal", "vn"),
        ] {
            if count == 0 {
                continue;
            }
            if let Some(at) = pending[slot].out_of_range(count) {
                return Err(MeshError::Syntax {
                    line: at.line,
                    problem: format!(
                        "face {} refers to {what} {}, but there are {count} `{keyword}` lines",
                        at.face, at.written
                    ),
                });
            }
        }
        *pending = [PendingSlot::default(); 3];
        Ok(())
    };
    for (number, raw) in bytes.split(|&b| b == b'\n').enumerate() {
        let line = number + 1;
        let syntax = |problem: String| MeshError::Syntax { line, problem };
        let text = std::str::from_utf8(raw).map_err(|e| {
            syntax(format!(
                "not UTF-8 text (invalid byte at column {})",
                e.valid_up_to() + 1
            ))
        })?;
        let mut words = text.split_whitespace();
        let Some(keyword) = words.next() else {
            continue;
        };
        let float = |what: &str, word: Option<&str>| -> Result<f32, MeshError> {
            let word = word.ok_or_else(|| syntax(format!("{what} is missing")))?;
            word.parse::<f32>()
                .map_err(|_| syntax(format!("{what} {word:?} is not a number")))
        };
        match keyword {
            "v" => {
                counts.vertices += 1;
                let vertex = counts.vertices as usize;
                let mut position = [0f32; 3];
                for (c, axis) in position.iter_mut().zip(["x", "y", "z"]) {
                    *c = float(&format!("vertex {vertex}: coordinate {axis}"), words.next())?;
                }
                let rest: [Option<&str>; 4] = std::array::from_fn(|_| words.next());
                let colour = match rest {
                    [None, ..] => false,
                    [Some(w), None, ..] => {
                        let w = float(&format!("vertex {vertex}: weight w"), Some(w))?;
                        if w == 0.0 {
                            return Err(syntax(format!(
                                "vertex {vertex}: weight w = 0 (x, y and z are divided by it)"
                            )));
                        }
                        position = position.map(|c| c / w);
                        false
                    }
                    [Some(r), Some(g), Some(b), None] => {
                        for (word, channel) in [(r, "red"), (g, "green"), (b, "blue")] {
                            float(&format!("vertex {vertex}: colour {channel}"), Some(word))?;
                        }
                        true
                    }
                    _ => {
                        let found = 3 + rest.iter().flatten().count() + words.count();
                        return Err(syntax(format!(
                            "vertex {vertex}: {found} numbers; expected x y z, x y z w or x y z r g b"
                        )));
                    }
                };
                if *coloured.get_or_insert(colour) != colour {
                    return Err(syntax(format!(
                        "vertex {vertex}: vertex colours on some `v` lines but not on others"
                    )));
                }
                if !position.iter().all(|c| c.is_finite()) {
                    return Err(MeshError::NonFiniteVertex {
                        vertex,
                        position: position.map(f64::from),
                        line: Some(line),
                    });
                }
            }
            "vt" => {
                texcoords += 1;
                for what in ["u", "v"] {
                    float(
                        &format!("texture coordinate {texcoords}: {what}"),
                        words.next(),
                    )?;
                }
            }
            "vn" => {
                normals += 1;
                for what in ["x", "y", "z"] {
                    float(&format!("normal {normals}: {what}"), words.next())?;
                }
            }
            // tobj reads `l` lines as faces too (ignored below 3 corners, like points).
            "f" | "l" => {
                faces += 1;
                has_faces = true;
                let corners = words.clone().count();
                if corners == 0 {
                    return Err(syntax(format!("face {faces} has no vertices")));
                }
                for word in words {
                    let indices =
                        corner_indices(word).map_err(|p| syntax(format!("face {faces}: {p}")))?;
                    if corners < 3 {
                        continue; // a point or a line: parsed, never resolved
                    }
                    let sizes = [counts.vertices, texcoords, normals];
                    for (slot, index) in indices.iter().enumerate() {
                        let written = match *index {
                            Some(0) | None if slot == 0 => {
                                return Err(MeshError::IndexOutOfRange {
                                    face: faces,
                                    index: index.unwrap_or(0),
                                    vertices: counts.vertices as usize,
                                    line: Some(line),
                                });
                            }
                            // tobj reads a missing or 0 texture or normal index as none.
                            Some(0) | None => continue,
                            Some(i) => i,
                        };
                        let resolved = if written < 0 {
                            sizes[slot] as i64 + written
                        } else {
                            written - 1
                        };
                        let at = IndexAt {
                            resolved,
                            written,
                            line,
                            face: faces,
                        };
                        if slot == 0 && resolved < 0 {
                            return Err(MeshError::IndexOutOfRange {
                                face: faces,
                                index: written,
                                vertices: counts.vertices as usize,
                                line: Some(line),
                            });
                        }
                        pending[slot].note(at);
                    }
                }
                counts.triangles += (corners as u64).saturating_sub(2);
            }
            "o" | "g" if has_faces => {
                close(&mut pending, &counts, texcoords, normals)?;
                has_faces = false;
            }
            "usemtl" => {
                // tobj splits the name off at the first space (not any whitespace).
                let name = text.split_once(' ').map_or("", |(_, n)| n).trim();
                if name.is_empty() {
                    return Err(syntax("`usemtl` without a material name".into()));
                }
            }
            _ => {}
        }
    }
    close(&mut pending, &counts, texcoords, normals)?;
    Ok(counts)
}

/// A face corner `v`, `v/vt`, `v//vn` or `v/vt/vn` as tobj reads it: up to three `/`-separated
/// integers (1-based, negative = relative), each possibly empty.
fn corner_indices(word: &str) -> Result<[Option<i64>; 3], String> {
    let mut indices = [None; 3];
    for (slot, part) in word.split('/').enumerate() {
        if part.is_empty() {
            continue;
        }
        let Some(index) = indices.get_mut(slot) else {
            return Err(format!("{word:?} has more than 3 `/`-separated indices"));
        };
        let value = part
            .parse::<isize>()
            .map_err(|_| format!("{part:?} in {word:?} is not an index"))?;
        *index = Some(value as i64);
    }
    Ok(indices)
}
