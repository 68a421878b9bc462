//! The on-disk cache of a face-cluster hierarchy, like the QuadGraph bake's
//! ([`crate::quadgraph::cache`], whose FNV-1a hash, atomic write and little-endian encoder it
//! reuses): a versioned file keyed by a hash of the mesh's content, checksummed, written atomically.
//!
//! Only the topology is stored (tree, rounds, cluster outlines, vertex-to-face table, and the
//! triangles to check against); the geometry is refitted from the mesh at load, which costs one
//! linear pass. Layout (little-endian): magic `TDIPOLE\0`, u32 format version, u32 zero, u64 key,
//! u64 payload length, the payload, u64 FNV-1a checksum of the payload.
//!
//! ```no_run
//! use translucent::mesh::shapes::Shape;
//! use translucent::solver::dipole::cache;
//! let mesh = Shape::Torus { major: 10.0, minor: 3.0 }.triangulate(32);
//! let (tree, _stats, outcome) = cache::build_cached("torus.dipole".as_ref(), &mesh)?;
//! println!("{outcome:?}: {} nodes", tree.nodes.len()); // Built, then Loaded on the next run
//! # Ok::<(), translucent::solver::dipole::DipoleError>(())
//! ```

use std::ops::Range;
use std::path::Path;

use super::hierarchy::{check_mesh, ClusterNode, FaceClusterHierarchy, HierarchyStats, NO_NODE};
use super::DipoleError;
use crate::mesh::TriMesh;
use crate::quadgraph::cache::{fnv1a64, write_atomically, Reader, Writer, FNV_OFFSET};
use crate::quadgraph::BakeError;

/// Bump whenever the layout or the meaning of a field changes (old files then read as stale), or
/// the clustering changes (old files would still load, but hold another hierarchy).
pub const FORMAT_VERSION: u32 = 1;
const MAGIC: &[u8; 8] = b"TDIPOLE\0";
const HEADER: usize = 8 + 4 + 4 + 8 + 8;

/// The cache key: the mesh's content (positions and triangles) and the format version. The
/// hierarchy has no parameters; a deformation at run time refits without the cache.
pub fn cache_key(mesh: &TriMesh) -> u64 {
    let mut w = Writer::default();
    w.u32(FORMAT_VERSION);
    w.dvec3s(&mesh.positions);
    w.u32s(&mesh.indices);
    fnv1a64(&w.0, FNV_OFFSET)
}

/// What [`build_cached`] did.
#[derive(Debug)]
pub enum CacheOutcome {
    /// The cache file matched and was loaded.
    Loaded,
    /// There was no cache file; the hierarchy was built and written.
    Built,
    /// The file could not be used (the error says why); a fresh build replaced it.
    Rebuilt(DipoleError),
}

/// Loads `path` if it holds the hierarchy of `mesh`; otherwise builds it and writes the file.
/// The stats of a loaded hierarchy have no build time.
pub fn build_cached(
    path: &Path,
    mesh: &TriMesh,
) -> Result<(FaceClusterHierarchy, HierarchyStats, CacheOutcome), DipoleError> {
    let key = cache_key(mesh);
    let outcome = if path.exists() {
        match load(path, mesh, key) {
            Ok(tree) => {
                let stats = HierarchyStats {
                    triangles: tree.leaf_count(),
                    nodes: tree.nodes.len(),
                    rounds: tree.rounds.len(),
                    component_rounds: 0,
                    depth: tree.depth(),
                    boundary_edges: tree.boundary_edges.len(),
                    seconds: 0.0,
                };
                return Ok((tree, stats, CacheOutcome::Loaded));
            }
            Err(e) => CacheOutcome::Rebuilt(e),
        }
    } else {
        CacheOutcome::Built
    };
    let (tree, stats) = FaceClusterHierarchy::build(mesh)?;
    save(&tree, path, key)?;
    Ok((tree, stats, outcome))
}

fn from_bake(e: BakeError) -> DipoleError {
    match e {
        BakeError::Io { path, source } => DipoleError::Io { path, source },
        other => DipoleError::Invalid(other.to_string()),
    }
}

/// Writes the hierarchy's topology to `path` under `key`, atomically.
pub fn save(tree: &FaceClusterHierarchy, path: &Path, key: u64) -> Result<(), DipoleError> {
    let mut w = Writer::default();
    w.u32s(&tree.indices);
    let nodes: Vec<[u32; 3]> = tree
        .nodes
        .iter()
        .map(|n| [n.children[0], n.children[1], n.parent])
        .collect();
    w.u32s(&nodes);
    let rounds: Vec<[u32; 2]> = tree.rounds.iter().map(|r| [r.start, r.end]).collect();
    w.u32s(&rounds);
    let singles = |v: &[u32]| v.iter().map(|&x| [x]).collect::<Vec<[u32; 1]>>();
    w.u32s(&singles(&tree.boundary_offsets));
    w.u32s(&tree.boundary_edges);
    w.u32s(&singles(&tree.vertex_face_offsets));
    w.u32s(&singles(&tree.vertex_faces));
    let payload = w.0;
    let mut bytes = Vec::with_capacity(HEADER + payload.len() + 8);
    bytes.extend_from_slice(MAGIC);
    bytes.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    bytes.extend_from_slice(&0u32.to_le_bytes());
    bytes.extend_from_slice(&key.to_le_bytes());
    bytes.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    bytes.extend_from_slice(&payload);
    bytes.extend_from_slice(&fnv1a64(&payload, FNV_OFFSET).to_le_bytes());
    write_atomically(path, &bytes).map_err(from_bake)
}

/// Reads a hierarchy written by [`save`] for `mesh` (a file made under another key is
/// [`DipoleError::CacheStale`]) and refits it to the mesh's positions.
pub fn load(
    path: &Path,
    mesh: &TriMesh,
    expect_key: u64,
) -> Result<FaceClusterHierarchy, DipoleError> {
    check_mesh(mesh)?;
    let bytes = std::fs::read(path).map_err(|source| DipoleError::Io {
        path: path.into(),
        source,
    })?;
    let p = || path.to_path_buf();
    let truncated = |expected: u64| DipoleError::CacheTruncated {
        path: p(),
        len: bytes.len() as u64,
        expected,
    };
    if bytes.len() < MAGIC.len() || &bytes[..MAGIC.len()] != MAGIC {
        return Err(if MAGIC.starts_with(&bytes) {
            truncated(HEADER as u64)
        } else {
            DipoleError::CacheMagic { path: p() }
        });
    }
    if bytes.len() < HEADER {
        return Err(truncated(HEADER as u64));
    }
    let u64_at = |o: usize| u64::from_le_bytes(std::array::from_fn(|i| bytes[o + i]));
    let version = u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]);
    if version != FORMAT_VERSION {
        return Err(DipoleError::CacheVersion {
            path: p(),
            found: version,
            expected: FORMAT_VERSION,
        });
    }
    let key = u64_at(16);
    let len = u64_at(24);
    let expected = (HEADER as u64).saturating_add(len).saturating_add(8);
    if bytes.len() as u64 != expected {
        return Err(truncated(expected));
    }
    let payload = &bytes[HEADER..HEADER + len as usize];
    if fnv1a64(payload, FNV_OFFSET) != u64_at(HEADER + len as usize) {
        return Err(DipoleError::CacheChecksum { path: p() });
    }
    if key != expect_key {
        return Err(DipoleError::CacheStale { path: p() });
    }
    let content = |reason: String| DipoleError::CacheContent { path: p(), reason };
    let mut tree = decode(payload).map_err(content)?;
    if tree.indices != mesh.indices {
        return Err(DipoleError::CacheStale { path: p() });
    }
    check(&tree, mesh.positions.len()).map_err(content)?;
    tree.refit(&mesh.positions)?;
    Ok(tree)
}

fn decode(payload: &[u8]) -> Result<FaceClusterHierarchy, String> {
    let mut r = Reader {
        bytes: payload,
        at: 0,
    };
    let indices: Vec<[u32; 3]> = r.u32s()?;
    let nodes = r
        .u32s::<3>()?
        .into_iter()
        .map(|[a, b, parent]| ClusterNode {
            children: [a, b],
            parent,
        })
        .collect();
    let rounds = r
        .u32s::<2>()?
        .into_iter()
        .map(|[a, b]| a..b)
        .collect::<Vec<Range<u32>>>();
    let singles = |v: Vec<[u32; 1]>| v.into_iter().map(|[x]| x).collect::<Vec<u32>>();
    let boundary_offsets = singles(r.u32s()?);
    let boundary_edges = r.u32s()?;
    let vertex_face_offsets = singles(r.u32s()?);
    let vertex_faces = singles(r.u32s()?);
    if r.at != r.bytes.len() {
        return Err(format!(
            "{} bytes left after the payload",
            r.bytes.len() - r.at
        ));
    }
    Ok(FaceClusterHierarchy {
        indices,
        positions: Vec::new(),
        nodes,
        rounds,
        boundary_offsets,
        boundary_edges,
        vertex_face_offsets,
        vertex_faces,
        geometry: Vec::new(),
    })
}

/// Cross-checks sizes and indices, so that a file which passes the checksum but came from a buggy
/// or foreign writer cannot make the refit or the links index out of bounds.
fn check(tree: &FaceClusterHierarchy, vertices: usize) -> Result<(), String> {
    let t = tree.indices.len();
    let n = tree.nodes.len();
    if n != 2 * t - 1 {
        return Err(format!(
            "{n} nodes for {t} triangles (a binary tree has {})",
            2 * t - 1
        ));
    }
    for (i, node) in tree.nodes.iter().enumerate() {
        let leaf = i < t;
        let children_ok = if leaf {
            node.children == [NO_NODE; 2]
        } else {
            node.children.iter().all(|&c| (c as usize) < i)
        };
        let parent_ok = if i == n - 1 {
            node.parent == NO_NODE
        } else {
            (node.parent as usize) > i && (node.parent as usize) < n
        };
        if !children_ok || !parent_ok {
            return Err(format!("node {i} has bad links {node:?}"));
        }
        if !leaf
            && node
                .children
                .iter()
                .any(|&c| tree.nodes[c as usize].parent != i as u32)
        {
            return Err(format!("node {i}'s children do not name it as parent"));
        }
    }
    let mut next = t as u32;
    for r in &tree.rounds {
        if r.start != next || r.end < r.start || r.end as usize > n {
            return Err(format!("round {r:?} is not the next range of nodes"));
        }
        next = r.end;
    }
    if next as usize != n {
        return Err("rounds do not cover the internal nodes".into());
    }
    let off = &tree.boundary_offsets;
    if off.len() != n - t + 1
        || off.first() != Some(&0)
        || off.windows(2).any(|w| w[0] > w[1])
        || off.last().map(|&x| x as usize) != Some(tree.boundary_edges.len())
    {
        return Err("boundary offsets are not a prefix sum".into());
    }
    if tree
        .boundary_edges
        .iter()
        .flatten()
        .any(|&v| v as usize >= vertices)
    {
        return Err("a boundary edge names a vertex out of range".into());
    }
    let vo = &tree.vertex_face_offsets;
    if vo.len() != vertices + 1
        || vo.first() != Some(&0)
        || vo.windows(2).any(|w| w[0] > w[1])
        || vo.last().map(|&x| x as usize) != Some(tree.vertex_faces.len())
        || tree.vertex_faces.iter().any(|&f| f as usize >= t)
    {
        return Err("vertex-to-face table is inconsistent".into());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::shapes::Shape;

    #[test]
    fn round_trip_and_every_kind_of_bad_file() {
        let dir =
            std::env::temp_dir().join(format!("translucent-dipole-cache-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("ball.dipole");
        let _ = std::fs::remove_file(&path);
        let mesh = Shape::Sphere { radius: 5.0 }.triangulate(10);
        let (built, _, outcome) = build_cached(&path, &mesh).unwrap();
        assert!(matches!(outcome, CacheOutcome::Built));
        let (loaded, _, outcome) = build_cached(&path, &mesh).unwrap();
        assert!(matches!(outcome, CacheOutcome::Loaded), "{outcome:?}");
        assert_eq!(built, loaded);

        let good = std::fs::read(&path).unwrap();
        let key = cache_key(&mesh);
        let attempt = |bytes: &[u8]| {
            std::fs::write(&path, bytes).unwrap();
            load(&path, &mesh, key)
        };
        let mut flipped = good.clone();
        flipped[HEADER + 5] ^= 1;
        assert!(matches!(
            attempt(&flipped),
            Err(DipoleError::CacheChecksum { .. })
        ));
        assert!(matches!(
            attempt(&good[..good.len() - 3]),
            Err(DipoleError::CacheTruncated { .. })
        ));
        assert!(matches!(
            attempt(&good[..4]),
            Err(DipoleError::CacheTruncated { .. })
        ));
        let mut version = good.clone();
        version[8] = 99;
        assert!(matches!(
            attempt(&version),
            Err(DipoleError::CacheVersion { .. })
        ));
        assert!(matches!(
            attempt(b"not a cache at all"),
            Err(DipoleError::CacheMagic { .. })
        ));
        // Another mesh (one vertex moved) reads the file as stale, and build_cached replaces it.
        std::fs::write(&path, &good).unwrap();
        let mut moved = mesh.clone();
        moved.positions[0].x += 1e-3;
        assert!(matches!(
            load(&path, &moved, cache_key(&moved)),
            Err(DipoleError::CacheStale { .. })
        ));
        let (_, _, outcome) = build_cached(&path, &moved).unwrap();
        assert!(matches!(
            outcome,
            CacheOutcome::Rebuilt(DipoleError::CacheStale { .. })
        ));
        // A checksummed payload with a node pointing outside the tree is refused by content.
        let mut tree = built.clone();
        tree.nodes[3].parent = 1;
        save(&tree, &path, key).unwrap();
        assert!(matches!(
            load(&path, &mesh, key),
            Err(DipoleError::CacheContent { .. })
        ));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
