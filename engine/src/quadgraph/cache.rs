//! The on-disk cache of a bake (DESIGN section 3 step 11): a versioned binary file keyed by a hash
//! of the surface mesh and the bake parameters, checksummed, written atomically (temporary file,
//! fsync, rename) so that a crash never leaves a partial file under the real name.
//!
//! Layout (little-endian): magic `TQGRAPH\0`, u32 format version, u32 zero, u64 key, u64 payload
//! length, the payload, u64 checksum of the payload. Hash and checksum are FNV-1a 64 over the
//! input taken as little-endian 64-bit words (zero-padded at the end): stable across Rust releases,
//! unlike `std`'s `DefaultHasher`, and eight times faster than byte-wise FNV.
//!
//! ```no_run
//! use translucent::mesh::shapes::Shape;
//! use translucent::quadgraph::{cache, BakeParams};
//! let ball = Shape::Sphere { radius: 10.0 };
//! let surface = ball.triangulate(32);
//! let params = BakeParams::default();
//! let (graph, _stats, outcome) =
//!     cache::bake_cached("ball.qgraph".as_ref(), &surface, &ball, &params, &mut |_| {}).unwrap();
//! println!("{outcome:?}: {} levels", graph.levels.len());
//! ```

use std::fs::File;
use std::io::{Read as _, Write};
use std::path::{Path, PathBuf};

use glam::DVec3;

use super::graph::{
    BounceLinks, GraphLevel, Packing, QuadGraph, ShadingWeights, ShepardLinks, WallCrossing,
};
use super::surface_samples::SurfaceSamples;
use super::{BakeError, BakeParams, BakeProgress, BakeStats};
use crate::limits::{Limit, Limits};
use crate::mesh::{Solid, TriMesh};
use crate::tet::TetMesh;

/// Bump whenever the layout or the meaning of a field changes: old files then read as stale.
pub const FORMAT_VERSION: u32 = 14;
const MAGIC: &[u8; 8] = b"TQGRAPH\0";
const HEADER: usize = 8 + 4 + 4 + 8 + 8;

/// FNV-1a 64 over `bytes` as little-endian 64-bit words, the last one zero-padded.
pub fn fnv1a64(bytes: &[u8], mut hash: u64) -> u64 {
    const PRIME: u64 = 0x0000_0100_0000_01b3;
    let mut words = bytes.chunks_exact(8);
    for w in &mut words {
        hash ^= u64::from_le_bytes([w[0], w[1], w[2], w[3], w[4], w[5], w[6], w[7]]);
        hash = hash.wrapping_mul(PRIME);
    }
    let rest = words.remainder();
    if !rest.is_empty() {
        let mut last = [0u8; 8];
        last[..rest.len()].copy_from_slice(rest);
        hash ^= u64::from_le_bytes(last);
        hash = hash.wrapping_mul(PRIME);
    }
    hash
}

/// FNV-1a 64 offset basis.
pub const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;

/// The cache key: the surface mesh's content (positions, normals, triangles), the bake parameters
/// and the format version.
pub fn cache_key(surface: &TriMesh, params: &BakeParams) -> u64 {
    let mut w = Writer::default();
    w.u32(FORMAT_VERSION);
    w.dvec3s(&surface.positions);
    w.dvec3s(&surface.normals);
    w.u32(surface.indices.len() as u32);
    for t in &surface.indices {
        t.iter().for_each(|&i| w.u32(i));
    }
    w.u32(params.resolution);
    w.f64(params.k);
    w.u32(params.levels);
    w.u32(params.relax as u32);
    w.u32(params.block);
    w.f64(params.stuffing.alpha_long);
    w.f64(params.stuffing.alpha_short);
    w.u32(params.stuffing.bisection_steps);
    w.f64(params.sample_depth);
    fnv1a64(&w.0, FNV_OFFSET)
}

/// What [`bake_cached`] did.
#[derive(Debug)]
pub enum CacheOutcome {
    /// The cache file matched and was loaded.
    Loaded,
    /// There was no cache file; the bake was written to it.
    Baked,
    /// The cache file could not be used (the error says why); a fresh bake replaced it.
    Rebuilt(BakeError),
}

/// Loads `path` if it holds a bake of this surface with these parameters; otherwise bakes and
/// writes it. A corrupt, truncated, stale or wrong-version file is reported in
/// [`CacheOutcome::Rebuilt`] and replaced. The stats of a loaded graph have no timings.
pub fn bake_cached(
    path: &Path,
    surface: &TriMesh,
    solid: &dyn Solid,
    params: &BakeParams,
    progress: &mut dyn FnMut(BakeProgress),
) -> Result<(QuadGraph, BakeStats, CacheOutcome), BakeError> {
    let key = cache_key(surface, params);
    let outcome = if path.exists() {
        match QuadGraph::load(path, Some(key)) {
            Ok(graph) => {
                let stats = graph.stats();
                return Ok((graph, stats, CacheOutcome::Loaded));
            }
            Err(e) => CacheOutcome::Rebuilt(e),
        }
    } else {
        CacheOutcome::Baked
    };
    let (graph, stats) = QuadGraph::bake(surface, solid, params, progress)?;
    graph.save(path, key)?;
    Ok((graph, stats, outcome))
}

impl QuadGraph {
    /// Writes the graph to `path` under `key`, atomically: a temporary file in the same directory
    /// is written, synced and renamed over `path`.
    pub fn save(&self, path: &Path, key: u64) -> Result<(), BakeError> {
        write_atomically(path, &self.to_cache_bytes(key))
    }

    /// Reads a graph written by [`QuadGraph::save`]. With `expect_key`, a file made for another key
    /// is [`BakeError::CacheStale`]. The file size is bounded by [`Limits::from_env`]'s
    /// [`Limit::FileBytes`], checked while reading.
    pub fn load(path: &Path, expect_key: Option<u64>) -> Result<QuadGraph, BakeError> {
        Self::load_with_limits(path, expect_key, &Limits::from_env())
    }

    /// [`QuadGraph::load`] with explicit limits.
    pub fn load_with_limits(
        path: &Path,
        expect_key: Option<u64>,
        limits: &Limits,
    ) -> Result<QuadGraph, BakeError> {
        let io = |source| BakeError::Io {
            path: path.into(),
            source,
        };
        let file = File::open(path).map_err(io)?;
        let mut bytes = Vec::new();
        // One byte past the limit tells "at the limit" from "above it" without reading the rest.
        file.take(limits.max_file_bytes.saturating_add(1))
            .read_to_end(&mut bytes)
            .map_err(io)?;
        limits
            .check(Limit::FileBytes, bytes.len() as u64)
            .map_err(|source| BakeError::CacheLimit {
                path: path.into(),
                source,
            })?;
        Self::from_cache_bytes(&bytes, path, expect_key)
    }

    /// Decodes the contents of a cache file held in memory (what [`QuadGraph::load`] does after
    /// reading it); `path` only names it in errors. Every header field, length, index and size is
    /// checked, so that no content, even one with a valid checksum, makes a consumer index out of
    /// bounds or allocate beyond what the bytes hold.
    pub fn from_cache_bytes(
        bytes: &[u8],
        path: &Path,
        expect_key: Option<u64>,
    ) -> Result<QuadGraph, BakeError> {
        let p = || path.to_path_buf();
        if bytes.len() < 8 || &bytes[..8] != MAGIC {
            if bytes.len() < 8 && MAGIC.starts_with(bytes) {
                return Err(BakeError::CacheTruncated {
                    path: p(),
                    len: bytes.len() as u64,
                    expected: HEADER as u64,
                });
            }
            return Err(BakeError::CacheMagic { path: p() });
        }
        if bytes.len() < HEADER {
            return Err(BakeError::CacheTruncated {
                path: p(),
                len: bytes.len() as u64,
                expected: HEADER as u64,
            });
        }
        let u32_at =
            |o: usize| u32::from_le_bytes([bytes[o], bytes[o + 1], bytes[o + 2], bytes[o + 3]]);
        let u64_at = |o: usize| u64::from_le_bytes(std::array::from_fn(|i| bytes[o + i]));
        let version = u32_at(8);
        if version != FORMAT_VERSION {
            return Err(BakeError::CacheVersion {
                path: p(),
                found: version,
                expected: FORMAT_VERSION,
            });
        }
        let key = u64_at(16);
        let len = u64_at(24);
        let expected = (HEADER as u64).saturating_add(len).saturating_add(8);
        if bytes.len() as u64 != expected {
            return Err(BakeError::CacheTruncated {
                path: p(),
                len: bytes.len() as u64,
                expected,
            });
        }
        let payload = &bytes[HEADER..HEADER + len as usize];
        if fnv1a64(payload, FNV_OFFSET) != u64_at(HEADER + len as usize) {
            return Err(BakeError::CacheChecksum { path: p() });
        }
        if expect_key.is_some_and(|k| k != key) {
            return Err(BakeError::CacheStale { path: p() });
        }
        let mut r = Reader {
            bytes: payload,
            at: 0,
        };
        let graph =
            decode(&mut r).map_err(|reason| BakeError::CacheContent { path: p(), reason })?;
        check(&graph).map_err(|reason| BakeError::CacheContent { path: p(), reason })?;
        Ok(graph)
    }

    /// The bytes [`QuadGraph::save`] writes for `key` (header, payload, checksum).
    pub fn to_cache_bytes(&self, key: u64) -> Vec<u8> {
        let mut w = Writer::default();
        encode(self, &mut w);
        let payload = w.0;
        let mut bytes = Vec::with_capacity(HEADER + payload.len() + 8);
        bytes.extend_from_slice(MAGIC);
        bytes.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
        bytes.extend_from_slice(&0u32.to_le_bytes());
        bytes.extend_from_slice(&key.to_le_bytes());
        bytes.extend_from_slice(&(payload.len() as u64).to_le_bytes());
        bytes.extend_from_slice(&payload);
        bytes.extend_from_slice(&fnv1a64(&payload, FNV_OFFSET).to_le_bytes());
        bytes
    }
}

/// Writes `bytes` to a temporary sibling of `path`, syncs it, and renames it over `path`.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), BakeError> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "cache".into());
    // Process id and a counter: two writers (processes or threads) never share a temporary file.
    static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let n = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let tmp: PathBuf = path.with_file_name(format!(".{name}.tmp-{}-{n}", std::process::id()));
    let result = (|| {
        // Errors name the file the caller asked for; the temporary name means nothing to them.
        let mut f = File::create(&tmp).map_err(|e| io_error(path, e))?;
        f.write_all(bytes).map_err(|e| io_error(path, e))?;
        f.sync_all().map_err(|e| io_error(path, e))?;
        drop(f);
        std::fs::rename(&tmp, path).map_err(|e| io_error(path, e))
    })();
    if result.is_err() {
        // The temporary file is ours and incomplete; nothing else may see it.
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

fn io_error(path: &Path, source: std::io::Error) -> BakeError {
    BakeError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Little-endian encoder of the cache payloads (also the dipole hierarchy's cache).
#[derive(Default)]
pub(crate) struct Writer(pub(crate) Vec<u8>);

impl Writer {
    pub(crate) fn u32(&mut self, v: u32) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    pub(crate) fn f64(&mut self, v: f64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    pub(crate) fn len(&mut self, n: usize) {
        self.0.extend_from_slice(&(n as u64).to_le_bytes());
    }
    pub(crate) fn dvec3s(&mut self, v: &[DVec3]) {
        self.len(v.len());
        self.0.reserve(v.len() * 24);
        for p in v {
            p.to_array().iter().for_each(|&x| self.f64(x));
        }
    }
    pub(crate) fn u32s<const N: usize>(&mut self, v: &[[u32; N]]) {
        self.len(v.len());
        self.0.reserve(v.len() * 4 * N);
        for a in v {
            a.iter().for_each(|&x| self.u32(x));
        }
    }
    pub(crate) fn f64s<const N: usize>(&mut self, v: &[[f64; N]]) {
        self.len(v.len());
        self.0.reserve(v.len() * 8 * N);
        for a in v {
            a.iter().for_each(|&x| self.f64(x));
        }
    }
}

/// Decoder matching [`Writer`]; every length is checked against the bytes left.
pub(crate) struct Reader<'a> {
    pub(crate) bytes: &'a [u8],
    pub(crate) at: usize,
}

impl Reader<'_> {
    pub(crate) fn take(&mut self, n: usize) -> Result<&[u8], String> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.bytes.len());
        let end = end.ok_or_else(|| format!("payload ends early at byte {}", self.at))?;
        let s = &self.bytes[self.at..end];
        self.at = end;
        Ok(s)
    }
    pub(crate) fn u32(&mut self) -> Result<u32, String> {
        let b = self.take(4)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }
    pub(crate) fn u64(&mut self) -> Result<u64, String> {
        let b = self.take(8)?;
        Ok(u64::from_le_bytes(std::array::from_fn(|i| b[i])))
    }
    pub(crate) fn f64(&mut self) -> Result<f64, String> {
        Ok(f64::from_bits(self.u64()?))
    }
    /// A length, checked against the bytes left so a corrupt length cannot allocate wildly.
    pub(crate) fn len(&mut self, item_bytes: usize) -> Result<usize, String> {
        let n = self.u64()?;
        let left = (self.bytes.len() - self.at) as u64;
        if n.saturating_mul(item_bytes as u64) > left {
            return Err(format!(
                "array of {n} items does not fit in the {left} bytes left"
            ));
        }
        Ok(n as usize)
    }
    pub(crate) fn dvec3s(&mut self) -> Result<Vec<DVec3>, String> {
        let n = self.len(24)?;
        let b = self.take(n * 24)?;
        Ok(b.chunks_exact(24)
            .map(|c| {
                let f = |i: usize| f64::from_le_bytes(std::array::from_fn(|k| c[8 * i + k]));
                DVec3::new(f(0), f(1), f(2))
            })
            .collect())
    }
    pub(crate) fn u32s<const N: usize>(&mut self) -> Result<Vec<[u32; N]>, String> {
        let n = self.len(4 * N)?;
        let b = self.take(n * 4 * N)?;
        Ok(b.chunks_exact(4 * N)
            .map(|c| {
                std::array::from_fn(|i| {
                    u32::from_le_bytes([c[4 * i], c[4 * i + 1], c[4 * i + 2], c[4 * i + 3]])
                })
            })
            .collect())
    }
    pub(crate) fn f64s<const N: usize>(&mut self) -> Result<Vec<[f64; N]>, String> {
        let n = self.len(8 * N)?;
        let b = self.take(n * 8 * N)?;
        Ok(b.chunks_exact(8 * N)
            .map(|c| {
                std::array::from_fn(|i| f64::from_le_bytes(std::array::from_fn(|k| c[8 * i + k])))
            })
            .collect())
    }
}

fn encode(g: &QuadGraph, w: &mut Writer) {
    w.dvec3s(&g.surface.positions);
    w.dvec3s(&g.surface.normals);
    w.u32s(&g.surface.indices);
    w.u32s(&g.shading.links);
    w.f64s(&g.shading.weights);
    w.f64s(&g.samples.depth.iter().map(|&d| [d]).collect::<Vec<_>>());
    w.u32s(&g.samples.nodes);
    w.f64s(&g.samples.weights);
    w.u32s(&g.samples.cell.iter().map(|&c| [c]).collect::<Vec<_>>());
    w.u32s(&g.samples.sources);
    w.f64s(&g.samples.source_weights);
    // Format 6: the vertices' mean curvature (the interior profile's curvature term).
    w.f64s(&g.samples.curvature.iter().map(|&k| [k]).collect::<Vec<_>>());
    // Format 7: the sample nodes' second moments (the interior sample's profile correction).
    w.f64s(&g.samples.spread);
    // Format 14: the lateral stencils (the interior profile's lateral term).
    w.u32s(&g.samples.lateral);
    w.f64s(&g.samples.lateral_weights);
    w.len(g.levels.len());
    for l in &g.levels {
        w.f64(l.spacing);
        w.dvec3s(&l.tets.vertices);
        w.u32s(&l.tets.tets);
        w.dvec3s(&l.positions);
        w.u32s(&l.neighbors);
        let faces: Vec<[u32; 2]> = l
            .surface_faces
            .iter()
            .map(|&(t, f)| [t, f as u32])
            .collect();
        w.u32s(&faces);
        w.dvec3s(&l.surface_normals);
        match &l.from_coarser {
            None => w.u32(0),
            Some(links) => {
                w.u32(1);
                w.u32s(&links.links);
                w.f64s(&links.weights);
            }
        }
        let p = &l.packing;
        [p.width, p.height, p.surface_rows, p.block]
            .iter()
            .for_each(|&x| w.u32(x));
        w.u32s(&p.texels);
    }
    // Format 5: one bounce's links, when a render stored them (flag 0: none).
    match &g.bounce {
        None => w.u32(0),
        Some(b) => {
            w.u32(1);
            w.u32(b.rays);
            w.u32(b.max_links);
            w.u32s(&b.offsets.iter().map(|&o| [o]).collect::<Vec<_>>());
            w.u32s(
                &b.links
                    .iter()
                    .map(|&(y, f)| [y, f.to_bits()])
                    .collect::<Vec<_>>(),
            );
            // Format 8: where each vertex's inward normal leaves again (a thin wall's far face).
            w.u32s(
                &b.across
                    .iter()
                    .map(|c| {
                        [
                            c.vertices[0],
                            c.vertices[1],
                            c.vertices[2],
                            c.weights[0].to_bits(),
                            c.weights[1].to_bits(),
                            c.weights[2].to_bits(),
                            c.thickness.to_bits(),
                        ]
                    })
                    .collect::<Vec<_>>(),
            );
        }
    }
}

fn decode(r: &mut Reader) -> Result<QuadGraph, String> {
    let surface = TriMesh {
        positions: r.dvec3s()?,
        normals: r.dvec3s()?,
        indices: r.u32s()?,
    };
    let shading = ShadingWeights {
        links: r.u32s()?,
        weights: r.f64s()?,
    };
    let depth: Vec<[f64; 1]> = r.f64s()?;
    let nodes = r.u32s()?;
    let weights = r.f64s()?;
    let cell: Vec<[u32; 1]> = r.u32s()?;
    let sources = r.u32s()?;
    let source_weights = r.f64s()?;
    let curvature: Vec<[f64; 1]> = r.f64s()?;
    let spread: Vec<[f64; 2]> = r.f64s()?;
    let lateral = r.u32s()?;
    let lateral_weights = r.f64s()?;
    let samples = SurfaceSamples {
        lateral,
        lateral_weights,
        curvature: curvature.into_iter().map(|[k]| k).collect(),
        spread,
        depth: depth.into_iter().map(|[d]| d).collect(),
        nodes,
        weights,
        cell: cell.into_iter().map(|[c]| c).collect(),
        sources,
        source_weights,
    };
    let n = r.len(1)?;
    let mut levels = Vec::with_capacity(n);
    for _ in 0..n {
        let spacing = r.f64()?;
        let tets = TetMesh {
            vertices: r.dvec3s()?,
            tets: r.u32s()?,
        };
        let positions = r.dvec3s()?;
        let neighbors = r.u32s()?;
        let faces: Vec<[u32; 2]> = r.u32s()?;
        let surface_faces = faces.iter().map(|&[t, f]| (t, f as u8)).collect();
        let surface_normals = r.dvec3s()?;
        let from_coarser = match r.u32()? {
            0 => None,
            1 => Some(ShepardLinks {
                links: r.u32s()?,
                weights: r.f64s()?,
            }),
            x => return Err(format!("bad link flag {x}")),
        };
        let (width, height, surface_rows, block) = (r.u32()?, r.u32()?, r.u32()?, r.u32()?);
        let packing = Packing {
            width,
            height,
            surface_rows,
            block,
            texels: r.u32s()?,
        };
        levels.push(GraphLevel {
            tets,
            positions,
            neighbors,
            surface_faces,
            surface_normals,
            spacing,
            from_coarser,
            packing,
        });
    }
    let bounce = match r.u32()? {
        0 => None,
        1 => {
            let (rays, max_links) = (r.u32()?, r.u32()?);
            let offsets: Vec<[u32; 1]> = r.u32s()?;
            let links: Vec<[u32; 2]> = r.u32s()?;
            let across: Vec<[u32; 7]> = r.u32s()?;
            Some(BounceLinks {
                offsets: offsets.into_iter().map(|[o]| o).collect(),
                links: links
                    .into_iter()
                    .map(|[y, f]| (y, f32::from_bits(f)))
                    .collect(),
                rays,
                max_links,
                across: across
                    .into_iter()
                    .map(|c| WallCrossing {
                        vertices: [c[0], c[1], c[2]],
                        weights: [c[3], c[4], c[5]].map(f32::from_bits),
                        thickness: f32::from_bits(c[6]),
                    })
                    .collect(),
            })
        }
        x => return Err(format!("bad bounce flag {x}")),
    };
    if r.at != r.bytes.len() {
        return Err(format!(
            "{} bytes left after the bounce links",
            r.bytes.len() - r.at
        ));
    }
    Ok(QuadGraph {
        levels,
        surface,
        shading,
        samples,
        bounce,
    })
}

/// The largest coordinate a cache may hold (mm): a hundred times the largest object
/// (`mesh::SIZE_RANGE_MM`).
const MAX_COORDINATE_MM: f64 = 1e10;

/// Cross-checks sizes and indices, so that a file which passes the checksum but was written by a
/// buggy or foreign writer still cannot make a consumer index out of bounds.
fn check(g: &QuadGraph) -> Result<(), String> {
    let in_range = |what: &str, i: u32, n: usize| {
        if i == super::graph::NO_NODE || (i as usize) < n {
            Ok(())
        } else {
            Err(format!("{what} index {i} out of range (< {n})"))
        }
    };
    // Triangle and tetrahedron corners have no "none": NO_NODE there is out of range (a tetrahedron
    // corner u32::MAX indexed past the vertices in `stats`: found by the cache fuzz target).
    let corner = |what: &str, i: u32, n: usize| {
        if (i as usize) < n {
            Ok(())
        } else {
            Err(format!("{what} index {i} out of range (< {n})"))
        }
    };
    if g.levels.is_empty() {
        return Err("no levels".into());
    }
    // Coordinates within a bound far above any object (`mesh::SIZE_RANGE_MM`), so that bounds,
    // distances and the f32 upload stay finite (found by the cache fuzz target: nodes at +-1e308
    // gave an infinite bounding sphere), and finite weights, normals and spacings.
    let coordinates = |what: &str, points: &[DVec3]| match points
        .iter()
        .find(|p| !(p.is_finite() && p.abs().max_element() <= MAX_COORDINATE_MM))
    {
        Some(p) => Err(format!(
            "{what} at ({:e}, {:e}, {:e}): coordinates must be finite and within \
             +-{MAX_COORDINATE_MM:e} mm",
            p.x, p.y, p.z
        )),
        None => Ok(()),
    };
    let finite = |what: &str, values: &mut dyn Iterator<Item = f64>| {
        for v in values {
            if !v.is_finite() {
                return Err(format!("{what}: {v} is not finite"));
            }
        }
        Ok(())
    };
    coordinates("surface vertex", &g.surface.positions)?;
    finite(
        "surface normals",
        &mut g.surface.normals.iter().flat_map(|n| n.to_array()),
    )?;
    finite(
        "shading weights",
        &mut g.shading.weights.iter().flatten().copied(),
    )?;
    for (h, l) in g.levels.iter().enumerate() {
        if !(l.spacing.is_finite() && l.spacing > 0.0 && l.spacing <= MAX_COORDINATE_MM) {
            return Err(format!("level {h}: spacing {} mm", l.spacing));
        }
        coordinates("tetrahedron vertex", &l.tets.vertices)?;
        coordinates("node", &l.positions)?;
        finite(
            "surface node normals",
            &mut l.surface_normals.iter().flat_map(|n| n.to_array()),
        )?;
        if let Some(links) = &l.from_coarser {
            finite(
                "level link weights",
                &mut links.weights.iter().flatten().copied(),
            )?;
        }
    }
    let nv = g.surface.positions.len();
    for t in &g.surface.indices {
        t.iter()
            .try_for_each(|&i| corner("surface triangle", i, nv))?;
    }
    if g.shading.links.len() != nv || g.shading.weights.len() != nv {
        return Err("shading weights do not match the surface's vertices".into());
    }
    let samples = &g.samples;
    let sampled = samples.depth.len();
    if sampled != 0
        && (sampled != nv
            || samples.nodes.len() != nv
            || samples.weights.len() != nv
            || samples.cell.len() != nv
            || samples.sources.len() != nv
            || samples.source_weights.len() != nv
            || samples.curvature.len() != nv
            || samples.spread.len() != nv
            || samples.lateral.len() != nv
            || samples.lateral_weights.len() != nv)
    {
        return Err("surface samples do not match the surface's vertices".into());
    }
    let finest_inner = g.finest().inner_count();
    for (nodes, &cell) in samples.nodes.iter().zip(&samples.cell) {
        nodes
            .iter()
            .chain(std::iter::once(&cell))
            .try_for_each(|&i| in_range("surface sample node", i, finest_inner))?;
    }
    if samples.depth.iter().any(|d| !(d.is_finite() && *d >= 0.0))
        || samples.curvature.iter().any(|k| !k.is_finite())
        || samples.spread.iter().flatten().any(|m| !m.is_finite())
        || samples.weights.iter().flatten().any(|w| !w.is_finite())
        || samples
            .lateral_weights
            .iter()
            .flatten()
            .any(|w| !w.is_finite())
        || samples
            .source_weights
            .iter()
            .flatten()
            .any(|w| !w.is_finite())
    {
        return Err("surface sample depths or weights are not finite".into());
    }
    for ids in &samples.lateral {
        ids.iter()
            .try_for_each(|&i| in_range("lateral stencil vertex", i, nv))?;
    }
    let finest_surface = g.finest().surface_count();
    for sources in &samples.sources {
        sources
            .iter()
            .try_for_each(|&i| in_range("surface sample source", i, finest_surface))?;
    }
    for l in &g.shading.links {
        l.iter()
            .try_for_each(|&i| in_range("shading link", i, finest_surface))?;
    }
    if let Some(b) = &g.bounce {
        if b.offsets.len() != nv + 1
            || b.offsets.first() != Some(&0)
            || b.offsets.windows(2).any(|w| w[0] > w[1])
            || b.offsets.last().map(|&o| o as usize) != Some(b.links.len())
        {
            return Err("bounce link offsets do not match the surface's vertices".into());
        }
        for &(y, f) in &b.links {
            corner("bounce link", y, nv)?;
            if !(f.is_finite() && f >= 0.0) {
                return Err("a bounce form factor is negative or not finite".into());
            }
        }
        if !(b.across.is_empty() || b.across.len() == nv) {
            return Err("bounce wall crossings do not match the surface's vertices".into());
        }
        for c in &b.across {
            c.vertices
                .iter()
                .try_for_each(|&y| corner("wall crossing", y, nv))?;
            if c.weights.iter().any(|w| !(w.is_finite() && *w >= 0.0))
                || c.thickness.is_nan()
                || c.thickness < 0.0
            {
                return Err("a wall crossing's weight or thickness is negative or NaN".into());
            }
        }
    }
    for (h, l) in g.levels.iter().enumerate() {
        let (ni, ns) = (l.tets.tets.len(), l.surface_faces.len());
        if l.neighbors.len() != ni || l.positions.len() != ni + ns || l.surface_normals.len() != ns
        {
            return Err(format!("level {h}: array sizes disagree"));
        }
        for t in &l.tets.tets {
            t.iter()
                .try_for_each(|&v| corner("tetrahedron vertex", v, l.tets.vertices.len()))?;
        }
        for nb in &l.neighbors {
            nb.iter()
                .try_for_each(|&j| in_range("neighbour", j, ni + ns))?;
        }
        for &(t, f) in &l.surface_faces {
            if t as usize >= ni || f > 3 {
                return Err(format!("level {h}: bad surface face ({t}, {f})"));
            }
        }
        if let Some(links) = &l.from_coarser {
            let coarse = g
                .levels
                .get(h.wrapping_sub(1))
                .map_or(0, |c| c.node_count());
            if links.links.len() != ni + ns || links.weights.len() != ni + ns {
                return Err(format!("level {h}: link arrays do not match the nodes"));
            }
            for ls in &links.links {
                ls.iter()
                    .try_for_each(|&j| in_range("level link", j, coarse))?;
            }
        }
        let p = &l.packing;
        if !p.texels.is_empty() {
            if p.texels.len() != ni + ns {
                return Err(format!("level {h}: packing does not match the nodes"));
            }
            if p.texels.iter().any(|&[u, v]| u >= p.width || v >= p.height) {
                return Err(format!(
                    "level {h}: texel outside the {}x{} texture",
                    p.width, p.height
                ));
            }
        }
    }
    Ok(())
}

// ---- The cache directory: size limit with least-recently-used eviction ---------------------
// (`translucent cache info|clean`; kept apart from the file format above.)

/// The default size limit of a cache directory (a 48-resolution bake of a 50 mm object is
/// 30-70 MB, so this keeps a few dozen).
pub const DEFAULT_LIMIT_BYTES: u64 = 2 << 30;

/// The extension of cache files; only such files are ever evicted or cleaned.
pub const EXTENSION: &str = "qgraph";

/// One cached bake in a cache directory.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CacheEntry {
    pub path: PathBuf,
    pub bytes: u64,
    /// When it was last written or loaded through [`bake_cached_lru`] (its modification time).
    pub last_used: std::time::SystemTime,
}

/// The `.qgraph` files of `dir`, least recently used first (a missing directory is empty).
pub fn entries(dir: &Path) -> Result<Vec<CacheEntry>, BakeError> {
    let read = match std::fs::read_dir(dir) {
        Ok(r) => r,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(io_error(dir, e)),
    };
    let mut out = Vec::new();
    for item in read {
        let item = item.map_err(|e| io_error(dir, e))?;
        let path = item.path();
        if path.extension().and_then(|e| e.to_str()) != Some(EXTENSION) {
            continue;
        }
        let meta = match item.metadata() {
            Ok(m) if m.is_file() => m,
            Ok(_) => continue,
            // Removed by another process since the listing: not an entry any more.
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => continue,
            Err(e) => return Err(io_error(&path, e)),
        };
        out.push(CacheEntry {
            path,
            bytes: meta.len(),
            last_used: meta.modified().map_err(|e| io_error(dir, e))?,
        });
    }
    out.sort_by(|a, b| a.last_used.cmp(&b.last_used).then(a.path.cmp(&b.path)));
    Ok(out)
}

/// Marks `path` as used now (its modification time), so eviction keeps it longest.
pub fn mark_used(path: &Path) -> Result<(), BakeError> {
    let file = File::options()
        .write(true)
        .open(path)
        .map_err(|e| io_error(path, e))?;
    file.set_modified(std::time::SystemTime::now())
        .map_err(|e| io_error(path, e))
}

/// Removes the least recently used `.qgraph` files of `dir` until the rest fit in
/// `limit_bytes`; `keep` (the bake just used) is never removed. Returns what was removed.
pub fn evict(
    dir: &Path,
    limit_bytes: u64,
    keep: Option<&Path>,
) -> Result<Vec<CacheEntry>, BakeError> {
    let all = entries(dir)?;
    let mut total: u64 = all.iter().map(|e| e.bytes).sum();
    let mut removed = Vec::new();
    for entry in all {
        if total <= limit_bytes {
            break;
        }
        if keep.is_some_and(|k| k == entry.path) {
            continue;
        }
        match std::fs::remove_file(&entry.path) {
            Ok(()) => {}
            // Another process evicted it first: the space is free either way.
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => return Err(io_error(&entry.path, e)),
        }
        total -= entry.bytes;
        removed.push(entry);
    }
    Ok(removed)
}

/// [`bake_cached`], then marks the file used and evicts the directory's least recently used
/// bakes beyond `limit_bytes` (never this one). Returns what was evicted too.
pub fn bake_cached_lru(
    path: &Path,
    surface: &TriMesh,
    solid: &dyn Solid,
    params: &BakeParams,
    limit_bytes: u64,
    progress: &mut dyn FnMut(BakeProgress),
) -> Result<(QuadGraph, BakeStats, CacheOutcome, Vec<CacheEntry>), BakeError> {
    let (graph, stats, outcome) = bake_cached(path, surface, solid, params, progress)?;
    mark_used(path)?;
    let dir = path.parent().unwrap_or(Path::new("."));
    let evicted = evict(dir, limit_bytes, Some(path))?;
    Ok((graph, stats, outcome, evicted))
}

#[cfg(test)]
mod lru_tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("translucent-lru-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("scratch");
        dir
    }

    fn file(dir: &Path, name: &str, bytes: usize, age_s: u64) -> PathBuf {
        let path = dir.join(name);
        std::fs::write(&path, vec![0u8; bytes]).expect("write");
        let when = std::time::SystemTime::now() - std::time::Duration::from_secs(age_s);
        File::options()
            .write(true)
            .open(&path)
            .and_then(|f| f.set_modified(when))
            .expect("mtime");
        path
    }

    #[test]
    fn eviction_removes_the_least_recently_used_bakes_and_nothing_else() {
        let dir = scratch("evict");
        let old = file(&dir, "old.qgraph", 100, 300);
        let mid = file(&dir, "mid.qgraph", 100, 200);
        let new = file(&dir, "new.qgraph", 100, 100);
        let other = file(&dir, "notes.txt", 1000, 400);
        let listed: Vec<_> = entries(&dir)
            .expect("list")
            .into_iter()
            .map(|e| e.path)
            .collect();
        assert_eq!(
            listed,
            [old.clone(), mid.clone(), new.clone()],
            "oldest first, only .qgraph"
        );
        // Using the oldest makes it the newest.
        mark_used(&old).expect("mark");
        let removed = evict(&dir, 200, None).expect("evict");
        assert_eq!(removed.iter().map(|e| &e.path).collect::<Vec<_>>(), [&mid]);
        assert!(old.exists() && new.exists() && other.exists());
        // `keep` survives even when it alone is over the limit.
        let removed = evict(&dir, 0, Some(&old)).expect("evict");
        assert_eq!(removed.len(), 1);
        assert!(old.exists() && !new.exists() && other.exists());
        assert!(entries(&dir.join("missing")).expect("empty").is_empty());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
