//! [`BouncePass`]: one bounce of exitance between display vertices (issue 12 item 5, DESIGN 2.5's
//! fourth cause). Outside the object is air (eta = 1 there): light that leaves a concave surface
//! crosses the air and enters the object again elsewhere: a U-block's slot, a torus's hole, the
//! bunny's folds, the base under a back-lit plate. The diffusion model does not carry light
//! through the air, so without this pass those regions stay too dark.
//!
//! Bake ([`BounceLinks::build`], CPU): per display vertex x, `rays` cosine-weighted rays over its
//! outer hemisphere against the mesh's BVH ([`MeshSolid::closest_hit`]); a ray that hits the
//! surface at y (from outside) gives 1 / rays of x's view to y's triangle, split over its three
//! vertices by the hit's barycentrics. So the sum of x's link weights is the form factor from x to
//! the visible surface (F(x, y) = cos_x cos_y dA_y / (pi r^2) integrated; the cosine-weighted
//! sampling carries cos_x / pi, the hit's solid angle cos_y dA_y / r^2), with the visibility of a
//! ray cast. A vertex keeps its [`BounceParams::max_links`] heaviest links, rescaled to the same
//! sum. A convex object's rays all escape: [`is_convex`] finds it before any ray is cast (no
//! links, no cost beyond the dispatch).
//!
//! Frame ([`PASS_BOUNCE`], after the method's exitance, before the shading): `bounce/bounce.comp`
//! gathers E_b(x) = sum_y F(x, y) X(y) from the display vertices' exitance values X (the shading's
//! J+ scale: the factor between X and the exitance M cancels), then the local model adds
//! X(x) += R_d(x) E_b(x): the re-entering light leaves near where it entered, with R_d the
//! half-space's total diffuse reflectance for diffuse incidence ([`diffuse_reflectance`]: the
//! model's own boundary, exit query and Fresnel transmission in and out; heterogeneous: the
//! coefficients at the vertex). No second solve.
//!
//! Thin walls: the bake also casts each vertex's inward normal to where it leaves the object
//! ([`WallCrossing`]: a back-lit plate's other face). The re-entering light is then split as a
//! slab of that thickness splits diffuse light ([`slab_reflectance_transmittance`], the same
//! model on both faces): X(x) += R(x) E_b(x) + T(x) E_b(x'), x' where x's inward normal leaves,
//! so light that the lit base throws onto a plate's back face shows on its front face. Thick
//! parts have T -> 0 and R -> the half-space's R_d. The pass runs on the frames whose method wrote a
//! new exitance (the bounce is added in place), and is skipped otherwise.
//!
//! Links are for the rest pose: a deformed object keeps its rest form factors.
//!
//! ```no_run
//! # use translucent::frame::bounce::{BounceLinks, BounceParams};
//! # fn f(mesh: &translucent::mesh::TriMesh) -> Result<(), translucent::Error> {
//! let links = BounceLinks::build(mesh, &BounceParams::default())?;
//! println!("{} links, {} bytes", links.link_count(), links.bytes());
//! # Ok(()) }
//! ```

use std::f64::consts::PI;

use ash::vk;
use glam::DVec3;
use rayon::prelude::*;

use crate::mesh::{GpuMesh, MeshSolid, TriMesh, Vertex};
use crate::quadgraph::WallCrossing;
use crate::render::RenderError;
use crate::shader::{ComputePipeline, ComputePipelineDesc, DescriptorWrite};
use crate::solver::transport::tangent_frame;
use crate::vk::barrier::Use;
use crate::vk::{barrier, Access, Buffer, Context};
use crate::Error;

mod optics;
mod source;
pub use optics::{
    diffuse_reflectance, slab_reflectance_transmittance, vertex_reflectance, vertex_wall_optics,
    WallOptics,
};
pub use source::{
    BounceSourcePass, BounceSourcePush, NodeGather, PASS_BOUNCE_EXITANCE, PASS_BOUNCE_KEEP,
    PASS_BOUNCE_RESTORE, PASS_BOUNCE_SOLVE, PASS_BOUNCE_SOURCE,
};

/// The pass's name (graph pass, debug label, profiler scope).
pub const PASS_BOUNCE: &str = "bounce";

/// The ray's start above the vertex, relative to the mesh's bounding radius (clear of the
/// vertex's own faces in f64; the BVH also ignores crossings within 1e-9 of the origin).
const START_OFFSET: f64 = 1e-5;
/// How far (relative to the bounding radius) a neighbouring face's far corner may stand in front
/// of a face's plane and the edge still count as convex: coplanar facets (a box's sides) within
/// f64 rounding of their coordinates; far below the rays' start offset, so a dent this shallow
/// could not be seen by a ray anyway.
const CONVEX_TOL: f64 = 1e-9;
/// Rays per vertex accepted by [`BounceLinks::build`].
pub const RAY_RANGE: std::ops::RangeInclusive<u32> = 1..=4096;
/// Links per vertex accepted.
pub const LINK_RANGE: std::ops::RangeInclusive<u32> = 1..=256;
/// Bounces per new exitance accepted ([`BouncePass::set_bounces`]): each costs two dispatches
/// over the display vertices.
pub const BOUNCE_RANGE: std::ops::RangeInclusive<u32> = 1..=16;

/// `render --bounce`: whether and how light re-enters the object.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BounceMode {
    /// No bounce (the pass is not recorded).
    #[default]
    Off,
    /// One bounce, re-emitted where it enters (R_d E_b, no second solve).
    Local,
    /// The bounces as [`Self::Local`], then the last gathered irradiance as a source of a second,
    /// warm-started solve whose exitance replaces the local re-emission ([`NodeGather`]): light
    /// that re-enters travels inside (QuadGraph method).
    Source,
}

impl BounceMode {
    pub fn name(self) -> &'static str {
        match self {
            BounceMode::Off => "off",
            BounceMode::Local => "local",
            BounceMode::Source => "source",
        }
    }
}

impl std::str::FromStr for BounceMode {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self, Error> {
        match s {
            "off" => Ok(BounceMode::Off),
            "local" => Ok(BounceMode::Local),
            "source" => Ok(BounceMode::Source),
            _ => Err(invalid(
                "bounce",
                format!("unknown bounce {s:?} (off, local, source)"),
            )),
        }
    }
}

/// How [`BounceLinks::build`] samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BounceParams {
    /// Cosine-weighted rays per vertex (rounded up to a square of strata), in [`RAY_RANGE`].
    pub rays: u32,
    /// Links kept per vertex (the heaviest), in [`LINK_RANGE`].
    pub max_links: u32,
}

impl Default for BounceParams {
    fn default() -> Self {
        // Measured in benches/RESULTS.md ("One bounce between surface points"; "The front-lit
        // bunny (wave 11)"). 256 rays (16 x 16 strata): against 64, every concave reference is
        // better at the defaults (bunny front 8.10 -> 7.94%, side 10.72 -> 10.57, U-block front
        // 9.93 -> 9.62, plate 11.01 -> 10.87), the convex ones unchanged; the links cost 4x
        // the rays on a concave mesh's first render (bunny 4.4 -> 11.7 s) and 28% more bytes.
        BounceParams {
            rays: 256,
            max_links: 32,
        }
    }
}

/// The links live with the bake ([`crate::QuadGraph::bounce`], written to the bake cache).
pub use crate::quadgraph::BounceLinks;

fn invalid(what: &str, problem: String) -> Error {
    Error::Render(RenderError::Invalid {
        what: what.into(),
        problem,
    })
}

/// A hash of two integers to [0, 1) (deterministic jitter, the same per stratum at every vertex
/// so neighbouring vertices see correlated, not independent, sampling error: no speckle).
fn hash01(a: u64, b: u64) -> f64 {
    let mut z = a
        .wrapping_mul(0x9e37_79b9_7f4a_7c15)
        .wrapping_add(b.wrapping_mul(0xbf58_476d_1ce4_e5b9));
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
}

impl BounceLinks {
    /// The links of `mesh`'s vertices (see the module doc). A mesh that is not a closed solid,
    /// or parameters outside their ranges, are a typed error.
    pub fn build(mesh: &TriMesh, params: &BounceParams) -> Result<BounceLinks, Error> {
        if !RAY_RANGE.contains(&params.rays) || !LINK_RANGE.contains(&params.max_links) {
            return Err(invalid(
                "bounce",
                format!(
                    "{} rays and {} links per vertex; rays {}..={}, links {}..={}",
                    params.rays,
                    params.max_links,
                    RAY_RANGE.start(),
                    RAY_RANGE.end(),
                    LINK_RANGE.start(),
                    LINK_RANGE.end()
                ),
            ));
        }
        if is_convex(mesh) {
            // Every ray would escape: no links (measured: the sphere's 2.5 s of rays go).
            return Ok(BounceLinks {
                offsets: vec![0; mesh.positions.len() + 1],
                links: Vec::new(),
                rays: params.rays,
                max_links: params.max_links,
                across: Vec::new(),
            });
        }
        let solid = MeshSolid::new(mesh.clone())?;
        let mesh = solid.mesh();
        let (_, radius) = crate::mesh::bounding_sphere(&mesh.positions);
        let offset = START_OFFSET * radius;
        let strata = (f64::from(params.rays).sqrt().ceil() as u32).max(1);
        let total = f64::from(strata * strata);
        let jitter: Vec<(f64, f64)> = (0..strata * strata)
            .map(|k| (hash01(u64::from(k), 1), hash01(u64::from(k), 2)))
            .collect();
        // A vertex on a concave crease casts its rays and its wall crossing along the normal of
        // the face it shades from (the same group as its shading weights), not the averaged
        // normal between the faces. The crossing starts at the vertex: at a plate's foot it runs
        // along the junction and leaves through the thick part (R near the half-space's, T ~ 0);
        // started inside the plate's face it passed the lit back corner's light and overshot
        // (benches/RESULTS.md, "Thin walls: the plate's crease").
        let creases = crate::quadgraph::crease::crease_normals(mesh, &mesh.normals, &solid);
        // A vertex split at a sharp edge casts its rays along its own face group's normal; a
        // crease's copies start off the normal averaged over all the faces at their position.
        let averaged = crate::quadgraph::crease::Welded::new(mesh, &mesh.normals).averaged;
        let per_vertex: Vec<(Vec<(u32, f32)>, WallCrossing)> = (0..mesh.positions.len())
            .into_par_iter()
            .map(|v| {
                let x = mesh.positions[v];
                let n = creases[v].map_or(mesh.normals[v], |(face, _)| face);
                if !x.is_finite() || !n.is_finite() || n.length_squared() < 0.5 {
                    return (Vec::new(), WallCrossing::NONE);
                }
                // A crease vertex's rays start off the averaged normal (into the free wedge, clear
                // of both faces' planes), and what they hit next to it is its own exitance: the
                // corner lights itself (a self-link; Jacobi over the bounces as any other link).
                let (start, own) = match creases[v] {
                    Some(_) if averaged[v].length_squared() > 0.5 => {
                        (x + averaged[v].normalize() * offset, true)
                    }
                    _ => (x + n * offset, false),
                };
                let across = wall_crossing(&solid, x, n.normalize(), offset);
                let (t, b) = tangent_frame(n);
                let mut weights: Vec<(u32, f64)> = Vec::new();
                for i in 0..strata {
                    for j in 0..strata {
                        let (ju, jv) = jitter[(i * strata + j) as usize];
                        let u1 = (f64::from(i) + ju) / f64::from(strata);
                        let u2 = (f64::from(j) + jv) / f64::from(strata);
                        // Cosine-weighted: each ray carries 1 / total of the form factor.
                        let (r, phi) = (u1.sqrt(), 2.0 * PI * u2);
                        let dir: DVec3 =
                            n * (1.0 - u1).max(0.0).sqrt() + (t * phi.cos() + b * phi.sin()) * r;
                        let Some(hit) = solid.closest_hit(start, dir, f64::INFINITY) else {
                            continue;
                        };
                        // A hit from inside: the start was not outside (a sliver); no light.
                        if hit.normal.dot(dir) >= 0.0 {
                            continue;
                        }
                        let face = mesh.indices[hit.face as usize];
                        for (k, &y) in face.iter().enumerate() {
                            let w = hit.barycentric[k] / total;
                            if (y as usize == v && !own) || w <= 0.0 {
                                continue;
                            }
                            match weights.iter_mut().find(|(s, _)| *s == y) {
                                Some(e) => e.1 += w,
                                None => weights.push((y, w)),
                            }
                        }
                    }
                }
                let sum: f64 = weights.iter().map(|w| w.1).sum();
                weights.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
                weights.truncate(params.max_links as usize);
                let kept: f64 = weights.iter().map(|w| w.1).sum();
                let scale = if kept > 0.0 { sum / kept } else { 0.0 };
                weights.sort_by_key(|w| w.0);
                let links = weights
                    .into_iter()
                    .map(|(y, w)| (y, (w * scale) as f32))
                    .collect();
                (links, across)
            })
            .collect();
        let mut offsets = Vec::with_capacity(per_vertex.len() + 1);
        let mut links = Vec::new();
        let mut across = Vec::with_capacity(per_vertex.len());
        offsets.push(0u32);
        for (l, c) in per_vertex {
            links.extend(l);
            across.push(c);
            offsets.push(
                u32::try_from(links.len())
                    .map_err(|_| invalid("bounce", "more than 2^32 links".into()))?,
            );
        }
        Ok(BounceLinks {
            offsets,
            links,
            rays: params.rays,
            max_links: params.max_links,
            across,
        })
    }

    /// Whether these links were built with `params` (a stored copy can be used as it is).
    pub fn built_with(&self, params: &BounceParams) -> bool {
        self.rays == params.rays && self.max_links == params.max_links
    }

    pub fn vertex_count(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    pub fn link_count(&self) -> usize {
        self.links.len()
    }

    /// The form factor from vertex `v` to the visible surface (the sum of its links).
    pub fn form_factor(&self, v: usize) -> f64 {
        self.incoming(v).iter().map(|&(_, w)| f64::from(w)).sum()
    }

    /// Vertex `v`'s links.
    pub fn incoming(&self, v: usize) -> &[(u32, f32)] {
        let (a, b) = (self.offsets[v] as usize, self.offsets[v + 1] as usize);
        &self.links[a..b]
    }

    /// GPU bytes of the links (offsets + links + the pass's per-vertex irradiance, the
    /// exitance before the bounces, R and T: 16 bytes each, and the wall crossing: 32).
    pub fn bytes(&self) -> u64 {
        (self.offsets.len() * 4 + self.links.len() * 8 + self.vertex_count() * 96) as u64
    }

    /// Vertex `v`'s wall crossing ([`WallCrossing::NONE`] where none was built).
    pub fn crossing(&self, v: usize) -> WallCrossing {
        self.across.get(v).copied().unwrap_or(WallCrossing::NONE)
    }

    /// The f64 reference of one bounce: X(x) + R(x) E_b(x) + T(x) E_b(x'), never below zero
    /// (E_b(x) = sum_y F(x, y) X(y), x' where x's inward normal leaves the object).
    pub fn apply(&self, exitance: &[[f32; 3]], optics: &WallOptics) -> Vec<[f32; 3]> {
        self.apply_bounces(exitance, optics, 1)
    }

    /// The f64 reference of the pass with `bounces` bounces (the GPU's recurrence): X_0 the
    /// method's exitance, E_k(x) = sum_y F(x, y) max(X_{k-1}(y), 0),
    /// X_k(x) = max(X_0(x) + R(x) E_k(x) + T(x) sum_i w_i E_k(x'_i), 0) (x'_i the far triangle's
    /// corners). Light that re-entered at y leaves again and reaches x: Jacobi on
    /// X = X_0 + (R + T P) F X, which converges (F's rows sum to the visible form factor, at
    /// most 1, P averages, and R + T < 1).
    pub fn apply_bounces(
        &self,
        exitance: &[[f32; 3]],
        optics: &WallOptics,
        bounces: u32,
    ) -> Vec<[f32; 3]> {
        let first: Vec<[f64; 3]> = exitance.iter().map(|x| x.map(f64::from)).collect();
        let mut x = first.clone();
        for _ in 0..bounces {
            let gathered: Vec<[f64; 3]> = (0..self.vertex_count())
                .map(|v| {
                    let mut e = [0.0f64; 3];
                    for &(y, w) in self.incoming(v) {
                        for (c, ec) in e.iter_mut().enumerate() {
                            *ec += f64::from(w) * x[y as usize][c].max(0.0);
                        }
                    }
                    e
                })
                .collect();
            x = (0..self.vertex_count())
                .map(|v| {
                    let wall = self.crossing(v);
                    std::array::from_fn(|c| {
                        let far: f64 = (0..3)
                            .map(|k| {
                                f64::from(wall.weights[k]) * gathered[wall.vertices[k] as usize][c]
                            })
                            .sum();
                        (first[v][c]
                            + f64::from(optics.reflectance[v][c]) * gathered[v][c]
                            + f64::from(optics.transmittance[v][c]) * far)
                            .max(0.0)
                    })
                })
                .collect();
        }
        x.iter().map(|v| v.map(|c| c as f32)).collect()
    }
}

/// Whether the closed surface `mesh` bounds a convex solid, without casting a ray: one connected
/// part, every edge shared by exactly two faces that traverse it in opposite directions (a
/// coherently wound closed surface), and every edge locally convex: the far corner of each face
/// lies on or behind the other face's plane (within [`CONVEX_TOL`] of the bounding radius), on
/// the same side for every edge (outward or inside-out winding alike). A connected closed
/// embedded surface that is locally convex at every edge bounds a convex solid (Tietze's
/// theorem), so no point of it sees another. Vertices at one position count as one (a display
/// mesh split at sharp edges). O(faces); a mesh that fails any condition (open seams, several
/// parts, a torus's or a bunny's concave edges) gets the rays.
pub fn is_convex(mesh: &TriMesh) -> bool {
    use std::collections::HashMap;
    let n = mesh.positions.len();
    if mesh.indices.is_empty()
        || mesh.indices.iter().flatten().any(|&i| i as usize >= n)
        || !mesh.positions.iter().all(|p| p.is_finite())
    {
        return false;
    }
    // Vertices split at sharp edges (a box's display mesh) are one vertex here.
    let welded = crate::mesh::weld_by_position(&mesh.positions);
    let indices: Vec<[u32; 3]> = mesh
        .indices
        .iter()
        .map(|t| t.map(|i| welded[i as usize]))
        .collect();
    let (_, radius) = crate::mesh::bounding_sphere(&mesh.positions);
    let tol = CONVEX_TOL * radius;
    /// A face at an edge: (face, traversed from the lower index, the face's far corner).
    type EdgeFace = (usize, bool, u32);
    // Per undirected edge: its faces, at most two.
    let mut edges: HashMap<(u32, u32), Vec<EdgeFace>> =
        HashMap::with_capacity(indices.len() * 3 / 2);
    let mut parent: Vec<u32> = (0..n as u32).collect();
    fn root(parent: &mut [u32], mut i: u32) -> u32 {
        while parent[i as usize] != i {
            parent[i as usize] = parent[parent[i as usize] as usize];
            i = parent[i as usize];
        }
        i
    }
    for (f, t) in indices.iter().enumerate() {
        for k in 0..3 {
            let (a, b, c) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
            if a == b {
                return false;
            }
            let e = edges.entry((a.min(b), a.max(b))).or_default();
            if e.len() == 2 {
                return false;
            }
            e.push((f, a < b, c));
            let (ra, rb) = (root(&mut parent, a), root(&mut parent, b));
            parent[ra as usize] = rb;
        }
    }
    let first = root(&mut parent, indices[0][0]);
    if indices
        .iter()
        .flatten()
        .any(|&i| root(&mut parent, i) != first)
    {
        return false;
    }
    let normal = |f: usize| {
        let p = indices[f].map(|i| mesh.positions[i as usize]);
        (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero()
    };
    let (mut front, mut behind) = (false, false);
    for (&(a, _), faces) in &edges {
        let [(f1, fwd1, c1), (f2, fwd2, c2)] = faces[..] else {
            return false;
        };
        if fwd1 == fwd2 {
            return false;
        }
        let at = mesh.positions[a as usize];
        for (f, c) in [(f1, c2), (f2, c1)] {
            let d = normal(f).dot(mesh.positions[c as usize] - at);
            front |= d > tol;
            behind |= d < -tol;
            if front && behind {
                return false;
            }
        }
    }
    true
}

/// Where `x`'s inward normal (`n` the outward unit normal) leaves `solid` again: the first
/// crossing from inside along -n ([`WallCrossing::NONE`] if the ray never leaves, or if its first
/// crossing enters: the start was not inside, a sliver).
fn wall_crossing(solid: &MeshSolid, x: DVec3, n: DVec3, offset: f64) -> WallCrossing {
    let dir = -n;
    let Some(hit) = solid.closest_hit(x + dir * offset, dir, f64::INFINITY) else {
        return WallCrossing::NONE;
    };
    if hit.normal.dot(dir) <= 0.0 {
        return WallCrossing::NONE;
    }
    let face = solid.mesh().indices[hit.face as usize];
    WallCrossing {
        vertices: face,
        weights: hit.barycentric.to_array().map(|w| w.max(0.0) as f32),
        thickness: (hit.t + offset) as f32,
    }
}

/// Push constants of `bounce/bounce.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct BouncePush {
    pub count: u32,
    /// Floats per vertex of the exitance buffer, and the exitance's first float.
    pub stride: u32,
    pub offset: u32,
    /// 0: gather E_b; 2: gather E_b and save the exitance as X_0 (the first bounce);
    /// 1: X = X_0 + R E_b + T E_b(across).
    pub mode: u32,
}

/// The pass: its pipeline, the links, the wall crossings, R and T on the GPU, the gathered
/// irradiance.
pub struct BouncePass {
    pipeline: ComputePipeline<BouncePush>,
    offsets: Buffer,
    links: Buffer,
    across: Buffer,
    /// The wall crossings on the CPU (R and T depend on their thickness and the material).
    crossings: Vec<WallCrossing>,
    /// R per vertex, then T per vertex (rgb, w unused).
    reflectance: Buffer,
    irradiance: Buffer,
    set: vk::DescriptorSet,
    vertex_count: u32,
    link_count: usize,
    bytes: u64,
    bounces: u32,
}

impl BouncePass {
    /// The pass for `mesh` (its vertex buffer is read and written in place) with `links` built
    /// on its vertices and `optics` (R and T) per vertex; [`crate::defaults::BOUNCES`] bounces
    /// ([`Self::set_bounces`]).
    pub fn new(
        ctx: &Context,
        mesh: &GpuMesh,
        links: &BounceLinks,
        optics: &WallOptics,
    ) -> Result<BouncePass, Error> {
        let n = mesh.vertex_count();
        if links.vertex_count() != n
            || optics.reflectance.len() != n
            || optics.transmittance.len() != n
            || !(links.across.is_empty() || links.across.len() == n)
        {
            return Err(invalid(
                "bounce",
                format!(
                    "links for {} vertices, {} wall crossings, {} reflectances and {} \
                     transmittances; the mesh has {n} vertices",
                    links.vertex_count(),
                    links.across.len(),
                    optics.reflectance.len(),
                    optics.transmittance.len()
                ),
            ));
        }
        if links
            .links
            .iter()
            .any(|&(y, w)| y as usize >= n || !w.is_finite() || w < 0.0)
            || links.offsets.windows(2).any(|w| w[0] > w[1])
            || links
                .offsets
                .last()
                .is_some_and(|&l| l as usize != links.links.len())
            || links.across.iter().any(|c| {
                c.vertices.iter().any(|&y| y as usize >= n)
                    || c.weights.iter().any(|w| !w.is_finite() || *w < 0.0)
            })
        {
            return Err(invalid("bounce", "links out of range or not finite".into()));
        }
        let pipeline = ComputePipeline::new(
            ctx,
            &ComputePipelineDesc {
                name: "bounce",
                shader: "bounce/bounce.comp",
                bindings: &[
                    "vertices",
                    "offsets",
                    "links",
                    "reflectance",
                    "irradiance",
                    "across",
                ],
                max_sets: 1,
            },
        )?;
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let offsets = Buffer::with_data(ctx, "bounce offsets", storage, &links.offsets)?;
        let packed: Vec<[u32; 2]> = links.links.iter().map(|&(y, w)| [y, w.to_bits()]).collect();
        // A zero-length buffer is not allowed: one unused link.
        let packed = if packed.is_empty() {
            vec![[0, 0]]
        } else {
            packed
        };
        let links_buffer = Buffer::with_data(ctx, "bounce links", storage, &packed)?;
        // Per vertex: the far triangle's corners, then their weights' bits (zero: no crossing).
        let mut across: Vec<[u32; 4]> = (0..n)
            .map(|v| {
                let c = links.crossing(v);
                [c.vertices[0], c.vertices[1], c.vertices[2], 0]
            })
            .collect();
        across.extend((0..n).map(|v| {
            let w = links.crossing(v).weights;
            [w[0].to_bits(), w[1].to_bits(), w[2].to_bits(), 0]
        }));
        if across.is_empty() {
            across.push([0; 4]);
        }
        let across = Buffer::with_data(ctx, "bounce across", storage, &across)?;
        let reflectance =
            Buffer::with_data(ctx, "bounce reflectance", storage, &Self::padded(optics)?)?;
        let irradiance = Buffer::with_data(
            ctx,
            "bounce irradiance",
            storage | vk::BufferUsageFlags::TRANSFER_SRC,
            // E_b, then X_0 (the exitance before the bounces).
            &vec![[0.0f32; 4]; 2 * n.max(1)],
        )?;
        let set = pipeline.allocate_set(
            ctx,
            &[
                DescriptorWrite::StorageBuffer {
                    name: "vertices",
                    buffer: mesh.vertex_buffer(),
                },
                DescriptorWrite::StorageBuffer {
                    name: "offsets",
                    buffer: &offsets,
                },
                DescriptorWrite::StorageBuffer {
                    name: "links",
                    buffer: &links_buffer,
                },
                DescriptorWrite::StorageBuffer {
                    name: "reflectance",
                    buffer: &reflectance,
                },
                DescriptorWrite::StorageBuffer {
                    name: "irradiance",
                    buffer: &irradiance,
                },
                DescriptorWrite::StorageBuffer {
                    name: "across",
                    buffer: &across,
                },
            ],
        )?;
        Ok(BouncePass {
            pipeline,
            offsets,
            links: links_buffer,
            across,
            crossings: links.across.clone(),
            reflectance,
            irradiance,
            set,
            vertex_count: n as u32,
            link_count: links.link_count(),
            bytes: links.bytes(),
            bounces: crate::defaults::BOUNCES,
        })
    }

    /// Bounces per new exitance, in [`BOUNCE_RANGE`]: 1 is light that left the surface once
    /// and entered it again; each more lets that light leave and enter again (a concave
    /// corner's interreflection). Takes effect from the next frame that records the pass.
    pub fn set_bounces(&mut self, bounces: u32) -> Result<(), Error> {
        if !BOUNCE_RANGE.contains(&bounces) {
            return Err(invalid(
                "bounces",
                format!(
                    "{bounces} bounces, outside {}..={}",
                    BOUNCE_RANGE.start(),
                    BOUNCE_RANGE.end()
                ),
            ));
        }
        self.bounces = bounces;
        Ok(())
    }

    /// Bounces per new exitance.
    pub fn bounces(&self) -> u32 {
        self.bounces
    }

    /// R per vertex, then T per vertex, as the shader reads them.
    fn padded(optics: &WallOptics) -> Result<Vec<[f32; 4]>, Error> {
        if optics
            .reflectance
            .iter()
            .chain(&optics.transmittance)
            .flatten()
            .any(|r| !r.is_finite() || !(0.0..=1.0).contains(r))
        {
            return Err(invalid(
                "bounce",
                "a reflectance or transmittance outside [0, 1] or not finite".into(),
            ));
        }
        let mut out: Vec<[f32; 4]> = optics
            .reflectance
            .iter()
            .chain(&optics.transmittance)
            .map(|r| [r[0], r[1], r[2], 0.0])
            .collect();
        if out.is_empty() {
            out.push([0.0; 4]);
        }
        Ok(out)
    }

    /// New R and T per vertex (a material change). Host-visible: call between frames, after
    /// the last frame that read it completed.
    pub fn set_reflectance(&mut self, optics: &WallOptics) -> Result<(), Error> {
        let n = self.vertex_count as usize;
        if optics.reflectance.len() != n || optics.transmittance.len() != n {
            return Err(invalid(
                "bounce",
                format!(
                    "{} reflectances and {} transmittances for {n} vertices",
                    optics.reflectance.len(),
                    optics.transmittance.len()
                ),
            ));
        }
        let padded = Self::padded(optics)?;
        self.reflectance
            .write_bytes(0, bytemuck::cast_slice(&padded))?;
        Ok(())
    }

    pub fn link_count(&self) -> usize {
        self.link_count
    }

    /// The wall crossings the pass was made with ([`BounceLinks::across`]).
    pub fn crossings(&self) -> &[WallCrossing] {
        &self.crossings
    }

    /// GPU bytes of the pass's buffers.
    pub fn bytes(&self) -> u64 {
        self.bytes
    }

    /// The gathered E_b per vertex (rgb, w unused), for checks.
    pub fn irradiance(&self) -> &Buffer {
        &self.irradiance
    }

    /// What [`Self::record`] uses.
    pub fn uses<'a>(&'a self, mesh: &'a GpuMesh) -> Vec<Use<'a>> {
        vec![
            Use::buffer(mesh.vertex_buffer(), Access::ComputeReadWrite),
            Use::buffer(&self.offsets, Access::ComputeRead),
            Use::buffer(&self.links, Access::ComputeRead),
            Use::buffer(&self.across, Access::ComputeRead),
            Use::buffer(&self.reflectance, Access::ComputeRead),
            Use::buffer(&self.irradiance, Access::ComputeReadWrite),
        ]
    }

    /// Records the gather and the local re-emission, once per bounce.
    ///
    /// # Safety
    /// `cb` must be recording outside a rendering scope, inside a frame-graph pass declaring
    /// [`Self::uses`] of the mesh given to [`Self::new`]; `self` must outlive its execution.
    pub unsafe fn record(&self, ctx: &Context, cb: vk::CommandBuffer) {
        let floats = |bytes: usize| (bytes / std::mem::size_of::<f32>()) as u32;
        let push = |mode| BouncePush {
            count: self.vertex_count,
            stride: floats(std::mem::size_of::<Vertex>()),
            offset: floats(std::mem::offset_of!(Vertex, exitance)),
            mode,
        };
        let groups = [self.vertex_count.max(1), 1, 1];
        // SAFETY: the caller's contract; the set's buffers live in `self` and the mesh.
        unsafe {
            for bounce in 0..self.bounces {
                if bounce > 0 {
                    // why: this gather reads the exitance the last re-emission wrote and
                    // overwrites the irradiance it read (RAW on the vertices, WAR on E_b).
                    barrier::memory(ctx, cb, Access::ComputeReadWrite, Access::ComputeReadWrite);
                }
                let gather = if bounce == 0 { 2 } else { 0 };
                self.pipeline
                    .dispatch(ctx, cb, self.set, &push(gather), groups);
                // why: the re-emission writes the exitance the gather read, and reads the
                // gathered irradiance of its own and its wall's far vertices, and X_0 (WAR on
                // the vertices, RAW on the irradiance).
                barrier::memory(ctx, cb, Access::ComputeReadWrite, Access::ComputeReadWrite);
                self.pipeline.dispatch(ctx, cb, self.set, &push(1), groups);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn convex_solids_are_found_and_concave_ones_are_not() {
        use crate::mesh::shapes::Shape;
        let sphere = Shape::Sphere { radius: 10.0 }.triangulate(24);
        assert!(is_convex(&sphere));
        let mut inside_out = sphere.clone();
        inside_out.indices.iter_mut().for_each(|t| t.swap(1, 2));
        assert!(is_convex(&inside_out));
        let torus = Shape::Torus {
            major: 8.0,
            minor: 3.0,
        }
        .triangulate(24);
        assert!(!is_convex(&torus));
        // Two spheres side by side: each is convex, together they see each other.
        let mut two = sphere.clone();
        let base = two.positions.len() as u32;
        two.positions
            .extend(sphere.positions.iter().map(|p| *p + DVec3::X * 30.0));
        two.normals.extend(&sphere.normals);
        two.indices
            .extend(sphere.indices.iter().map(|t| t.map(|i| i + base)));
        assert!(!is_convex(&two));
        // A dent: one vertex pushed towards the centre.
        let mut dented = sphere.clone();
        let v = dented.positions.len() / 2;
        dented.positions[v] *= 0.8;
        assert!(!is_convex(&dented));
        // A box's display mesh, split at its edges: still one convex solid.
        let cube = Shape::Box {
            half_extents: DVec3::new(5.0, 3.0, 2.0),
        }
        .triangulate(2);
        let (display, _) = cube.split_sharp_edges(crate::mesh::SHARP_EDGE_COS);
        assert!(display.positions.len() > cube.positions.len());
        assert!(is_convex(&display));
    }
}
