//! OBJ input through tobj: every object and group merged into one triangulated [`TriMesh`] with one
//! vertex per OBJ position; errors name the file and, where the problem is a line, the line.
//!
//! ```no_run
//! let mesh = translucent::mesh::TriMesh::load_obj("spot.obj")?;
//! println!("{} triangles", mesh.indices.len());
//! # Ok::<(), translucent::mesh::MeshError>(())
//! ```

use std::collections::HashMap;
use std::path::Path;

use glam::DVec3;

use super::{MeshError, TriMesh};

impl TriMesh {
    /// Loads an OBJ file. Polygons are fanned into triangles. One vertex per OBJ position (`v`):
    /// the file's connectivity is kept, so validation sees the topology the file has, and vertices
    /// of different objects or groups at identical positions are merged (a closed surface split into
    /// groups stays closed). Normals: the file's normals averaged per position where every corner
    /// has one (hard edges become smooth), otherwise computed from the faces. Texture coordinates
    /// and material libraries are not read.
    ///
    /// Errors: the file cannot be read ([`MeshError::Io`]) or parsed ([`MeshError::Obj`]), a face
    /// index is out of range or a coordinate is not finite (with the line), or there are no
    /// triangles; all but the first two are wrapped in [`MeshError::InFile`].
    pub fn load_obj(path: impl AsRef<Path>) -> Result<TriMesh, MeshError> {
        let path = path.as_ref();
        let bytes = std::fs::read(path).map_err(|source| MeshError::Io {
            path: path.into(),
            source,
        })?;
        // tobj reports bad indices and non-finite numbers without a location: find them first.
        prescan(&bytes).map_err(|e| e.in_file(path))?;
        let options = tobj::LoadOptions {
            triangulate: true,
            single_index: false,
            ignore_points: true,
            ignore_lines: true,
        };
        let (models, _materials) = tobj::load_obj_buf(&mut bytes.as_slice(), &options, |_| {
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

/// Checks `v` lines for finite coordinates and `f` lines for vertex indices in range (1-based,
/// negative = relative to the vertices so far), naming the line.
fn prescan(bytes: &[u8]) -> Result<(), MeshError> {
    let text = String::from_utf8_lossy(bytes);
    let total = text
        .lines()
        .filter(|l| l.split_whitespace().next() == Some("v"))
        .count();
    let (mut vertices, mut faces) = (0usize, 0usize);
    for (number, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                let words: Vec<&str> = words.take(3).collect();
                if let Some(bad) = words.iter().find(|w| w.parse::<f64>().is_err()) {
                    return Err(MeshError::Syntax {
                        line: number + 1,
                        problem: format!("vertex {}: {bad:?} is not a number", vertices + 1),
                    });
                }
                if words.len() < 3 {
                    return Err(MeshError::Syntax {
                        line: number + 1,
                        problem: format!(
                            "vertex {} has {} coordinate(s), expected x y z (a truncated file?)",
                            vertices + 1,
                            words.len()
                        ),
                    });
                }
                let coords: Vec<f64> = words.iter().filter_map(|w| w.parse().ok()).collect();
                // tobj stores f32: a finite f64 beyond its range would load as infinity.
                if coords.iter().any(|&c| !(c as f32).is_finite()) {
                    let mut position = [f64::NAN; 3];
                    position[..coords.len()].copy_from_slice(&coords);
                    return Err(MeshError::NonFiniteVertex {
                        vertex: vertices + 1,
                        position,
                        line: Some(number + 1),
                    });
                }
                vertices += 1;
            }
            Some("f") => {
                faces += 1;
                let words: Vec<&str> = words.collect();
                if words.len() < 3 {
                    return Err(MeshError::Syntax {
                        line: number + 1,
                        problem: format!(
                            "face {faces} has {} vertex reference(s), expected at least 3 (a truncated file?)",
                            words.len()
                        ),
                    });
                }
                for word in words {
                    let Some(Ok(index)) = word.split('/').next().map(str::parse::<i64>) else {
                        return Err(MeshError::Syntax {
                            line: number + 1,
                            problem: format!("face {faces}: {word:?} is not a vertex index"),
                        });
                    };
                    let resolved = if index < 0 {
                        vertices as i64 + index + 1
                    } else {
                        index
                    };
                    // A face may use vertices defined after it: check against the file's total.
                    if resolved < 1 || resolved > total as i64 {
                        let line = Some(number + 1);
                        return Err(MeshError::IndexOutOfRange {
                            face: faces,
                            index,
                            vertices: total,
                            line,
                        });
                    }
                }
            }
            _ => {}
        }
    }
    Ok(())
}
