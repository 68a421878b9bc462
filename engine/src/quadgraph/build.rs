//! The bake pipeline: per level tetrahedralize, split (paper Fig. 4), build the graph and place the
//! surface nodes on the input surface; then Shepard links between levels, shading weights and
//! texture packing. See [`QuadGraph::bake`].

use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;

use super::graph::{split_multi_boundary, GraphLevel, QuadGraph, NO_NODE};
use super::{packing, shepard, surface_samples, BakeError};
use crate::limits::{Limit, Limits};
use crate::mesh::{Solid, TriMesh};
use crate::tet::stuffing::{angle_range, StuffParams};
use crate::tet::{try_tetrahedralize, TetParams};

/// Bake parameters. They are part of the cache key.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BakeParams {
    /// Lattice cells across the longest side of the solid at the finest level (coarser levels halve
    /// it each). The default gives about 10^5 nodes on the finest level for compact shapes.
    pub resolution: u32,
    /// Grading `K` (paper section 4.1): 0 keeps the interior lattice uniform, larger values let
    /// interior tetrahedra grow faster away from the surface, up to 1, where cells double in size
    /// at every step (the octree's 2:1 balance); values above 1 give the same lattice as 1.
    pub k: f64,
    /// Number of levels `L` (coarsest first in [`QuadGraph::levels`]).
    pub levels: u32,
    /// Relax inner node positions (for the `paper` scheme only; `fv` uses centroids).
    pub relax: bool,
    /// Texture block size `r` (paper section 5.1).
    pub block: u32,
    pub stuffing: StuffParams,
    /// The interior surface samples' depth in finest lattice spacings
    /// ([`surface_samples::DEPTH_SPACINGS`] by default; `translucent::defaults::sample_depth_for`
    /// picks it for a material: shallower where the lattice does not show in the sample).
    pub sample_depth: f64,
    /// Resource limits (surface size, lattice nodes, surface samples), checked before the memory
    /// they bound is allocated; [`Limits::from_env`] by default. Not part of the cache key.
    pub limits: Limits,
}

impl Default for BakeParams {
    fn default() -> Self {
        Self {
            resolution: 48,
            k: 1.0,
            levels: 3,
            relax: false,
            block: 32,
            stuffing: StuffParams::default(),
            sample_depth: surface_samples::DEPTH_SPACINGS,
            limits: Limits::from_env(),
        }
    }
}

/// The coarsest level's lattice cells across the longest side above which
/// [`BakeParams::levels_for`] adds a level: the coarsest level's solve (one workgroup's
/// Chebyshev polynomial, `multigrid/coarse.comp`) grows with its nodes and its condition
/// (benches/RESULTS.md "Large lattices: the fp16 update and the coarsest level").
pub const COARSEST_CELLS: u32 = 8;

impl BakeParams {
    /// The levels for a finest lattice of `resolution` cells (`--levels auto`): the default 3,
    /// plus one per halving the coarsest level needs to come to [`COARSEST_CELLS`] cells or fewer,
    /// never a coarsest level under the bake's 4 cells, at most 8.
    ///
    /// ```
    /// use translucent::quadgraph::BakeParams;
    /// assert_eq!(BakeParams::levels_for(24), 3); // the reference scenes' lattices: as before
    /// assert_eq!(BakeParams::levels_for(35), 3);
    /// assert_eq!(BakeParams::levels_for(48), 4);
    /// assert_eq!(BakeParams::levels_for(96), 5);
    /// assert_eq!(BakeParams::levels_for(8), 2); // a coarsest level of 4 cells at least
    /// ```
    pub fn levels_for(resolution: u32) -> u32 {
        let mut levels = Self::default().levels;
        while levels < 8 && resolution >> (levels - 1) > COARSEST_CELLS {
            levels += 1;
        }
        while levels > 1 && resolution >> (levels - 1) < 4 {
            levels -= 1;
        }
        levels
    }
}

/// Reported to the progress callback when a stage starts.
#[derive(Clone, Copy, Debug)]
pub struct BakeProgress {
    /// `"tetrahedralize"`, `"graph"`, `"links"`, `"shading"` or `"packing"`.
    pub stage: &'static str,
    /// The level the stage works on (0: coarsest), and the number of levels.
    pub level: usize,
    pub levels: usize,
}

/// Per-level figures of a bake.
#[derive(Clone, Debug, Default, Serialize)]
pub struct LevelStats {
    pub spacing_mm: f64,
    pub surface_nodes: usize,
    pub inner_nodes: usize,
    pub tetrahedra_split: usize,
    /// Surface nodes whose ray met the input surface...
    pub surface_nodes_on_surface: usize,
    /// ...or met it too far behind the face and were clamped halfway to their inner node (see
    /// `place_surface_node`); the rest sit at their face centroid.
    pub surface_nodes_clamped: usize,
    /// Dihedral angles after the split of paper Fig. 4 (which makes thinner tetrahedra)...
    pub min_dihedral_deg: f64,
    pub max_dihedral_deg: f64,
    /// ...and of the stuffing alone, before it (not known for a cached graph).
    pub stuffing_dihedral_deg: (f64, f64),
    /// Cut lattice tetrahedra that were not finest BCC ones (the angle bound does not cover them).
    pub coarse_cut_tets: usize,
    pub texture_width: u32,
    pub texture_height: u32,
    pub surface_rows: u32,
    /// GPU texture bytes of this level (see [`texel_bytes`]).
    pub bytes: u64,
    /// Share of neighbour references within one texel block: our packing, and a random one.
    pub locality: f64,
    pub random_locality: f64,
}

/// Figures of a whole bake.
#[derive(Clone, Debug, Default, Serialize)]
pub struct BakeStats {
    pub levels: Vec<LevelStats>,
    pub total_bytes: u64,
    /// Texture bytes per node over all levels (the paper: about 90).
    pub bytes_per_node: f64,
    pub min_dihedral_deg: f64,
    pub max_dihedral_deg: f64,
    /// Wall-clock seconds per stage, in order.
    pub timings_s: Vec<(String, f64)>,
}

/// GPU bytes per texel of a level, following DESIGN section 4: phi ping and pong (2x RGBA16F) and
/// the mixed-precision phi (RGBA32F), q (RGBA16F), material (2x RGBA16F), connectivity
/// (2x RGBA32UI), fv weights (RGBA32F), positions (RGBA16F, as in the paper), and on every level
/// but the coarsest the level links (2x RGBA32UI + 2x RGBA16F).
pub fn texel_bytes(has_links: bool) -> u64 {
    let phi = 2 * 8 + 16;
    let q = 8;
    let material = 2 * 8;
    let connectivity = 2 * 16;
    let weights = 16;
    let positions = 8;
    let links = if has_links { 2 * 16 + 2 * 8 } else { 0 };
    phi + q + material + connectivity + weights + positions + links
}

impl BakeParams {
    fn validate(&self) -> Result<(), BakeError> {
        let bad = |name, value: String, reason| {
            Err(BakeError::Parameter {
                name,
                value,
                reason,
            })
        };
        if !(1..=8).contains(&self.levels) {
            return bad("levels", self.levels.to_string(), "must be 1 to 8");
        }
        // The lattice keeps a distance grid of about 7 bytes per fine cell: 512 cells across is
        // about 1 GB for a cube-shaped object.
        if !(4..=512).contains(&self.resolution) {
            return bad(
                "resolution",
                self.resolution.to_string(),
                "must be 4 to 512 cells",
            );
        }
        if self.resolution >> (self.levels - 1) < 4 {
            return bad(
                "resolution",
                self.resolution.to_string(),
                "the coarsest level would have fewer than 4 cells",
            );
        }
        if !surface_samples::DEPTH_RANGE.contains(&self.sample_depth) {
            return bad(
                "sample depth",
                self.sample_depth.to_string(),
                "must be 0.5 to 4 finest spacings",
            );
        }
        if !self.k.is_finite() || self.k < 0.0 || self.k > 100.0 {
            return bad("K", self.k.to_string(), "must be a number from 0 to 100");
        }
        if !(1..=256).contains(&self.block) {
            return bad("block", self.block.to_string(), "must be 1 to 256");
        }
        let s = &self.stuffing;
        if !(s.alpha_long > 0.0 && s.alpha_long < 0.5 && s.alpha_short > 0.0 && s.alpha_short < 0.5)
        {
            return bad(
                "alpha",
                format!("{}, {}", s.alpha_long, s.alpha_short),
                "must lie in (0, 0.5)",
            );
        }
        Ok(())
    }
}

impl QuadGraph {
    /// Bakes the QuadGraph of a closed triangle mesh (already validated and normalized, see
    /// [`crate::mesh`]): the mesh is both the solid (generalized winding number) and the display
    /// surface. [`QuadGraph::bake`] takes any [`Solid`] and reports progress.
    pub fn bake_mesh(mesh: &TriMesh, params: &BakeParams) -> crate::Result<(QuadGraph, BakeStats)> {
        let mut surface = mesh.clone();
        if surface.normals.len() != surface.positions.len() {
            surface.compute_normals();
        }
        let solid = crate::mesh::MeshSolid::new(surface.clone())?;
        Ok(Self::bake(&surface, &solid, params, &mut |_| {})?)
    }

    /// Bakes the QuadGraph of `solid`, whose boundary `surface` triangulates (in mm, normalized as
    /// DESIGN section 3 step 2; `surface` is also what is displayed). `progress` is called as each
    /// stage starts.
    pub fn bake(
        surface: &TriMesh,
        solid: &dyn Solid,
        params: &BakeParams,
        progress: &mut dyn FnMut(BakeProgress),
    ) -> Result<(QuadGraph, BakeStats), BakeError> {
        params.validate()?;
        let (lo, hi) = solid.bounds();
        let longest = (hi - lo).max_element();
        if !(lo.is_finite() && hi.is_finite() && longest > 0.0) {
            return Err(BakeError::Invalid(format!(
                "the solid's bounds {lo} .. {hi} are empty or not finite"
            )));
        }
        // Beyond this range the lattice's volumes and distances leave f64/f32 (a 1e300 mm solid
        // exhausted memory instead of failing).
        if !crate::mesh::SIZE_RANGE_MM.contains(&longest) {
            return Err(BakeError::Invalid(format!(
                "the solid's longest side is {longest} mm; sizes from {} to {} mm are supported",
                crate::mesh::SIZE_RANGE_MM.start(),
                crate::mesh::SIZE_RANGE_MM.end()
            )));
        }
        if surface.indices.is_empty() {
            return Err(BakeError::Invalid(
                "the surface mesh has no triangles".into(),
            ));
        }
        let limits = &params.limits;
        for (limit, count) in [
            (Limit::Vertices, surface.positions.len()),
            (Limit::Triangles, surface.indices.len()),
        ] {
            limits
                .check(limit, count as u64)
                .map_err(|e| BakeError::Invalid(format!("the surface mesh: {e}")))?;
        }
        let nlevels = params.levels as usize;
        let mut timings: Vec<(String, f64)> = Vec::new();
        let mut levels = Vec::with_capacity(nlevels);
        let mut stats = Vec::with_capacity(nlevels);
        for l in 0..nlevels {
            let spacing = longest / (params.resolution >> (nlevels - 1 - l)) as f64;
            progress(BakeProgress {
                stage: "tetrahedralize",
                level: l,
                levels: nlevels,
            });
            let start = Instant::now();
            let tet_params = TetParams {
                spacing,
                grading: params.k,
                stuffing: params.stuffing,
            };
            let (mesh, stuffed) =
                try_tetrahedralize(solid, surface, &tet_params, limits).map_err(|source| {
                    BakeError::Limit {
                        level: l,
                        spacing_mm: spacing,
                        source,
                    }
                })?;
            let (mesh, split) = split_multi_boundary(mesh);
            if mesh.tets.is_empty() {
                return Err(BakeError::Empty {
                    level: l,
                    spacing_mm: spacing,
                });
            }
            timings.push((
                format!("tetrahedralize[{l}]"),
                start.elapsed().as_secs_f64(),
            ));
            progress(BakeProgress {
                stage: "graph",
                level: l,
                levels: nlevels,
            });
            let start = Instant::now();
            let reach = 2.0 * spacing;
            let counts = [
                AtomicUsize::new(0),
                AtomicUsize::new(0),
                AtomicUsize::new(0),
            ];
            let mut level = GraphLevel::from_tets_par(mesh, spacing, |c, n, depth| {
                let (p, normal, placement) = place_surface_node(solid, c, n, reach, depth);
                counts[placement as usize].fetch_add(1, Ordering::Relaxed);
                (p, normal)
            });
            let [on_surface, clamped, _] = counts.map(AtomicUsize::into_inner);
            if params.relax {
                relax_inner_nodes(&mut level, 8);
            }
            timings.push((format!("graph[{l}]"), start.elapsed().as_secs_f64()));
            let (min_dihedral_deg, max_dihedral_deg) = angle_range(&level.tets, |_| true);
            stats.push(LevelStats {
                spacing_mm: spacing,
                surface_nodes: level.surface_count(),
                inner_nodes: level.inner_count(),
                tetrahedra_split: split,
                stuffing_dihedral_deg: (stuffed.min_dihedral_deg, stuffed.max_dihedral_deg),
                coarse_cut_tets: stuffed.coarse_cut_tets,
                surface_nodes_on_surface: on_surface,
                surface_nodes_clamped: clamped,
                min_dihedral_deg,
                max_dihedral_deg,
                ..Default::default()
            });
            levels.push(level);
        }
        let start = Instant::now();
        for l in 1..nlevels {
            progress(BakeProgress {
                stage: "links",
                level: l,
                levels: nlevels,
            });
            let links = shepard::level_links(&levels[l], &levels[l - 1]);
            levels[l].from_coarser = Some(links);
        }
        timings.push(("links".into(), start.elapsed().as_secs_f64()));
        progress(BakeProgress {
            stage: "shading",
            level: nlevels - 1,
            levels: nlevels,
        });
        let start = Instant::now();
        let finest = levels
            .last()
            .ok_or_else(|| BakeError::Invalid("no levels".into()))?;
        // The display mesh: the input surface with its vertices split at sharp edges, so each
        // face of a 90-degree edge has its own normal, shading weights, sample and bounce links.
        let surface = &display_surface(surface);
        let shading = shepard::shading_weights(surface, finest, solid);
        timings.push(("shading".into(), start.elapsed().as_secs_f64()));
        let start = Instant::now();
        let samples = surface_samples::surface_samples(surface, finest, solid, params.sample_depth);
        timings.push(("samples".into(), start.elapsed().as_secs_f64()));
        let start = Instant::now();
        for (l, level) in levels.iter_mut().enumerate() {
            progress(BakeProgress {
                stage: "packing",
                level: l,
                levels: nlevels,
            });
            level.packing = packing::pack(level, params.block, false);
        }
        timings.push(("packing".into(), start.elapsed().as_secs_f64()));
        let graph = QuadGraph {
            levels,
            surface: surface.clone(),
            shading,
            samples,
            bounce: None,
        };
        let mut summary = graph.stats();
        for (s, from_stats) in summary.levels.iter_mut().zip(stats) {
            s.tetrahedra_split = from_stats.tetrahedra_split;
            s.surface_nodes_on_surface = from_stats.surface_nodes_on_surface;
            s.surface_nodes_clamped = from_stats.surface_nodes_clamped;
            s.stuffing_dihedral_deg = from_stats.stuffing_dihedral_deg;
            s.coarse_cut_tets = from_stats.coarse_cut_tets;
        }
        summary.timings_s = timings;
        Ok((graph, summary))
    }

    /// Figures computable from the graph alone (a cached graph has no timings or split counts).
    pub fn stats(&self) -> BakeStats {
        let levels: Vec<LevelStats> = self
            .levels
            .iter()
            .map(|level| {
                let p = &level.packing;
                let bytes =
                    p.width as u64 * p.height as u64 * texel_bytes(level.from_coarser.is_some());
                let (lo, hi) = angle_range(&level.tets, |_| true);
                let random = packing::pack(level, p.block.max(1), true);
                LevelStats {
                    spacing_mm: level.spacing,
                    surface_nodes: level.surface_count(),
                    inner_nodes: level.inner_count(),
                    min_dihedral_deg: lo,
                    max_dihedral_deg: hi,
                    texture_width: p.width,
                    texture_height: p.height,
                    surface_rows: p.surface_rows,
                    bytes,
                    locality: packing::locality(level, p),
                    random_locality: packing::locality(level, &random),
                    ..Default::default()
                }
            })
            .collect();
        let total_bytes = levels.iter().map(|l| l.bytes).sum();
        let nodes: usize = levels.iter().map(|l| l.surface_nodes + l.inner_nodes).sum();
        BakeStats {
            min_dihedral_deg: levels
                .iter()
                .map(|l| l.min_dihedral_deg)
                .fold(180.0, f64::min),
            max_dihedral_deg: levels
                .iter()
                .map(|l| l.max_dihedral_deg)
                .fold(0.0, f64::max),
            bytes_per_node: total_bytes as f64 / nodes.max(1) as f64,
            total_bytes,
            levels,
            timings_s: Vec::new(),
        }
    }
}

/// The display mesh a bake of `surface` keeps in [`QuadGraph::surface`]: `surface` with its
/// vertices split at sharp edges ([`TriMesh::split_sharp_edges`] at
/// [`crate::mesh::SHARP_EDGE_COS`]); `surface` itself when it has none.
pub fn display_surface(surface: &TriMesh) -> TriMesh {
    surface.split_sharp_edges(crate::mesh::SHARP_EDGE_COS).0
}

/// Where a surface node ended up (counted in [`LevelStats`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Placement {
    Surface = 0,
    Clamped = 1,
    Centroid = 2,
}

/// Where the ray from a boundary face's centroid along its outward normal, or against it (the face
/// may lie just outside the true surface), first meets the surface within `reach`; the face centroid
/// and normal when neither does (as at the holes of a scanned mesh). From a centroid inside the solid
/// the first crossing is the surface nearby; from one outside, a hit whose surface normal faces away
/// from the face is another sheet of a thin part, and is skipped.
///
/// A backward hit is clamped to halfway to the inner node (`depth` behind the face): further back,
/// the surface node would sit next to or behind its inner node and the boundary distance `d_sk`
/// along the face normal (DESIGN section 2) would be tiny or negative. Measured without the clamp,
/// default settings: 45 of 18328 surface nodes on spot, 118 of 21648 on the bunny had `d_sk <= 0`.
fn place_surface_node(
    solid: &dyn Solid,
    centroid: DVec3,
    normal: DVec3,
    reach: f64,
    depth: f64,
) -> (DVec3, DVec3, Placement) {
    let mut best: Option<(f64, DVec3, DVec3, Placement)> = None;
    let inside = solid.contains(centroid);
    let limit = (0.5 * depth).max(0.0);
    // Rays start a hair behind the centroid: a face whose vertices are all cut points on one flat
    // triangle of the input lies in the surface, and a ray from exactly there skips that surface
    // as its own origin (about 6% of spot's faces).
    let back = 1e-5 * reach;
    for dir in [normal, -normal] {
        if let Some((t, n)) = solid.ray_hit(centroid - dir * back, dir, reach + back) {
            let t = t - back;
            let usable = t.is_finite() && n.is_finite() && (inside || n.dot(normal) > 0.0);
            if usable && best.is_none_or(|(bt, ..)| t.abs() < bt) {
                // Backward hits beyond the limit are clamped to it, keeping the surface's normal.
                let (t_placed, placement) = if dir == normal || t <= limit {
                    (t, Placement::Surface)
                } else {
                    (limit, Placement::Clamped)
                };
                best = Some((t.abs(), centroid + dir * t_placed, n.normalize(), placement));
            }
        }
    }
    best.map_or((centroid, normal, Placement::Centroid), |(_, p, n, k)| {
        (p, n, k)
    })
}

/// Moves each inner node toward the mean of its neighbours (a discrete stand-in for the paper's
/// reaction-diffusion relaxation), never leaving its own tetrahedron: a step that would put the node
/// closer than 10% (in barycentric terms) to a face is shortened. For the `paper` scheme only, which
/// uses node-to-node distances: a relaxed node may pass its surface node's plane distance, so the
/// `fv` scheme's `d_sk > 0` holds for centroids only.
pub fn relax_inner_nodes(level: &mut GraphLevel, iterations: usize) {
    let ni = level.inner_count();
    for _ in 0..iterations {
        let next: Vec<DVec3> = (0..ni)
            .into_par_iter()
            .map(|i| {
                let nb = level.neighbors[i];
                let valid: Vec<DVec3> = nb
                    .iter()
                    .filter(|&&j| j != NO_NODE)
                    .map(|&j| level.positions[j as usize])
                    .collect();
                let current = level.positions[i];
                if valid.is_empty() {
                    return current;
                }
                let target = valid.iter().sum::<DVec3>() / valid.len() as f64;
                let [a, b, c, d] = level.tets.tets[i].map(|v| level.tets.vertices[v as usize]);
                let mut step = 0.5;
                for _ in 0..6 {
                    let p = current + (target - current) * step;
                    if barycentric_min(a, b, c, d, p) >= 0.1 {
                        return p;
                    }
                    step *= 0.5;
                }
                current
            })
            .collect();
        level.positions[..ni].copy_from_slice(&next);
    }
}

fn barycentric_min(a: DVec3, b: DVec3, c: DVec3, d: DVec3, p: DVec3) -> f64 {
    let vol = |a: DVec3, b: DVec3, c: DVec3, d: DVec3| (b - a).dot((c - a).cross(d - a));
    let total = vol(a, b, c, d);
    if total.abs() < f64::MIN_POSITIVE {
        return 0.0;
    }
    [
        vol(p, b, c, d),
        vol(a, p, c, d),
        vol(a, b, p, d),
        vol(a, b, c, p),
    ]
    .iter()
    .map(|v| v / total)
    .fold(1.0, f64::min)
}
