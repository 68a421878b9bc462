//! Live edits of a [`GpuFrame`] / [`GpuDiffusion`] without a re-bake (paper section 6.4; DESIGN
//! sections 4 and 5): a new material (homogeneous or heterogeneous) and a deformation of the
//! object. Both only stage data on the CPU side; the GPU work is recorded in front of the next
//! solve ([`GpuDiffusion::record_edits`], called by [`GpuFrame::record`] before the shadow and
//! gather passes and by [`GpuDiffusion::record`]), so a host that records into its own command
//! buffers never sees a submission of ours.
//!
//! Material ([`GpuDiffusion::set_material`]):
//! - homogeneous: push constants only (kappa, mu, 2A, q_gain) and the `HOMOGENEOUS = true`
//!   pipelines; nothing is uploaded, no per-node material exists on the GPU.
//! - heterogeneous: kappa and mu sampled at the rest-pose node positions (CPU, validated, a typed
//!   error naming the node), uploaded per level (2 x RGBA32F), then `edit/derive_weights.comp`
//!   rebuilds the per-channel Jacobi weights from the geometric factors (harmonic face kappa for
//!   fv). Switching kinds back and forth just picks the other pipeline variant; the heterogeneous
//!   textures, once created, stay (memory is flat across switches).
//!
//! Deformation ([`GpuDiffusion::deform`], [`GpuFrame::deform`]), per level, on the GPU:
//! 1. tetrahedron vertices: `edit/map_vertices.comp` evaluates `Affine` / `Twist` on the rest
//!    pose; `TetPositions` are uploaded;
//! 2. `edit/deform_nodes.comp`: every node at its barycentric coordinates in its rest tetrahedron
//!    (exact for affine maps), surface normals through that tetrahedron's F^-T, written to the
//!    gather's `surface_position` / `surface_normal`;
//! 3. `edit/deform_geometry.comp`: A_f, V_i, d_ij, delta and d_sk in fp32 -> the geometric
//!    factors;
//! 4. heterogeneous: the weights again (the material path's derivation).
//!
//! The display and shadow-caster meshes (`meshes`) follow through `edit/deform_mesh.comp`: each
//! vertex at barycentric coordinates in the finest-level tetrahedron under its first shading link,
//! normal by F^-T, copied into the mesh's vertex buffer (position and normal only; the exitance
//! stays the solve's). `Identity` restores the baked geometry bit for bit (uploads of the rest
//! texels, not a recomputation). What stays at rest: the Shepard links between levels and the
//! shading weights (their topology and weights are those of the rest pose; for moderate
//! deformations they remain a partition of unity over the same neighbours).
//!
//! Degenerate input: an affine map with det <= 1e-6 |M|^3 (flattening or mirroring), a non-finite
//! value, or `TetPositions` giving any tetrahedron a volume <= 0 is a typed error, and nothing
//! changes. Past those checks the GPU clamps volumes and distances (1e-9 h^3, 1e-6 h for lattice
//! spacing h) so fp32 rounding of a nearly flat tetrahedron cannot produce Inf or NaN.
//!
//! ```no_run
//! # use translucent::solver::gpu::{Deformation, GpuFrame};
//! # fn f(ctx: &translucent::vk::Context, graph: &translucent::QuadGraph, frame: &mut GpuFrame,
//! #      mesh: &translucent::mesh::GpuMesh, jade: &translucent::material::MaterialField) -> Result<(), translucent::Error> {
//! frame.set_material(ctx, graph, jade)?; // staged; recorded by the next frame.record(..)
//! frame.deform(ctx, graph, &Deformation::Twist { radians_per_mm: 0.02 }, &[mesh])?;
//! // ... record the frame; later:
//! frame.deform(ctx, graph, &Deformation::Identity, &[mesh])?; // back to the baked shape
//! # Ok(()) }
//! ```

use std::sync::Arc;

use ash::vk;
use glam::{DMat3, DVec3, Mat4};

use super::textures::{HomogeneousMaterial, MaterialTexels};
use super::{
    bad_param, bytes_of, image, raw_barrier, surface_packing, GpuDiffusion, GpuLevel, SolverError,
};
use crate::material::{fresnel, MaterialField};
use crate::mesh::{GpuMesh, Vertex};
use crate::quadgraph::graph::{GraphLevel, NO_NODE};
use crate::shader::{ComputePipeline, ComputePipelineDesc, DescriptorWrite};
use crate::solver::operator::Scheme;
use crate::vk::barrier::Use;
use crate::vk::{barrier, Access, Buffer, BufferDesc, Context, GpuProfiler, Image, MemoryUse};
use crate::{Error, QuadGraph};

/// Pass names (profiler scopes, debug labels).
pub const PASS_EDIT_UPLOAD: &str = "edit upload";
pub const PASS_DEFORM: &str = "edit deform";
pub const PASS_DEFORM_MESH: &str = "edit deform mesh";
pub const PASS_DERIVE_WEIGHTS: &str = "edit derive weights";

/// A deformation of the object, in its normalized frame (mm). Applied to the rest pose the bake
/// produced (not accumulated): `deform(Identity)` restores the baked shape.
#[derive(Clone, Debug, PartialEq)]
pub enum Deformation {
    /// The baked shape.
    Identity,
    /// An affine map of every position (normals by its inverse transpose). Must be invertible
    /// and orientation-preserving.
    Affine(Mat4),
    /// A twist about the +Y axis through the origin: `radians_per_mm * y` radians at height y.
    Twist { radians_per_mm: f32 },
    /// New positions of every level's tetrahedron vertices (outer index: level, coarsest first).
    TetPositions(Vec<Vec<[f32; 3]>>),
}

fn invalid(problem: String) -> Error {
    Error::Solver(SolverError::BadParameter {
        name: "deformation",
        problem,
    })
}

impl Deformation {
    /// The analytic map of a point (f64, the same formulas as `edit/map_vertices.comp`); `None`
    /// for `TetPositions`.
    pub fn map_point(&self, p: DVec3) -> Option<DVec3> {
        match self {
            Deformation::Identity => Some(p),
            Deformation::Affine(m) => Some(m.as_dmat4().transform_point3(p)),
            Deformation::Twist { radians_per_mm } => {
                let a = f64::from(*radians_per_mm) * p.y;
                let (s, c) = a.sin_cos();
                Some(DVec3::new(c * p.x + s * p.z, p.y, -s * p.x + c * p.z))
            }
            Deformation::TetPositions(_) => None,
        }
    }

    /// Checks the deformation against `graph` (module doc, "Degenerate input").
    pub fn validate(&self, graph: &QuadGraph) -> Result<(), Error> {
        match self {
            Deformation::Identity => Ok(()),
            Deformation::Affine(m) => {
                if !m.is_finite() {
                    return Err(invalid(format!("affine map {m} is not finite")));
                }
                let rows = m.row(3);
                if rows != glam::Vec4::W {
                    return Err(invalid(format!(
                        "affine map has a projective last row {rows} (expected 0, 0, 0, 1)"
                    )));
                }
                let m3 = glam::DMat3::from_mat4(m.as_dmat4());
                let det = m3.determinant();
                let norm = (m3.x_axis.length_squared()
                    + m3.y_axis.length_squared()
                    + m3.z_axis.length_squared())
                .sqrt()
                    / 3f64.sqrt();
                if det.is_nan() || det <= 1e-6 * norm.powi(3) {
                    return Err(invalid(format!(
                        "affine map with determinant {det:e} flattens or mirrors the object (must be > 1e-6 |M|^3)"
                    )));
                }
                Ok(())
            }
            Deformation::Twist { radians_per_mm } => {
                if radians_per_mm.is_finite() {
                    Ok(())
                } else {
                    Err(invalid(format!(
                        "twist rate {radians_per_mm} is not finite"
                    )))
                }
            }
            Deformation::TetPositions(levels) => {
                if levels.len() != graph.levels.len() {
                    return Err(invalid(format!(
                        "{} levels of positions for {} graph levels",
                        levels.len(),
                        graph.levels.len()
                    )));
                }
                for (h, (p, level)) in levels.iter().zip(&graph.levels).enumerate() {
                    if p.len() != level.tets.vertices.len() {
                        return Err(invalid(format!(
                            "level {h}: {} positions for {} tetrahedron vertices",
                            p.len(),
                            level.tets.vertices.len()
                        )));
                    }
                    if let Some(v) = p.iter().position(|v| !v.iter().all(|x| x.is_finite())) {
                        return Err(invalid(format!("level {h}: vertex {v} is not finite")));
                    }
                    let d = |i: u32| DVec3::from(p[i as usize].map(f64::from));
                    for (t, tet) in level.tets.tets.iter().enumerate() {
                        let [a, b, c, e] = tet.map(d);
                        let volume = (b - a).dot((c - a).cross(e - a)) / 6.0;
                        if volume.is_nan() || volume <= 0.0 {
                            return Err(invalid(format!(
                                "level {h}: tetrahedron {t} gets volume {volume:e} (flattened or inverted)"
                            )));
                        }
                    }
                }
                Ok(())
            }
        }
    }

    /// The deformed tetrahedron vertices of level `h` (f64), as the GPU computes them.
    pub fn level_vertices(&self, h: usize, level: &GraphLevel) -> Vec<DVec3> {
        match self {
            Deformation::TetPositions(p) => p
                .get(h)
                .map(|v| v.iter().map(|x| DVec3::from(x.map(f64::from))).collect())
                .unwrap_or_else(|| level.tets.vertices.clone()),
            _ => level
                .tets
                .vertices
                .iter()
                .map(|&v| self.map_point(v).unwrap_or(v))
                .collect(),
        }
    }

    /// The CPU reference of what the GPU does to level `h` (f64): tetrahedron vertices mapped,
    /// every node at its barycentric coordinates in its rest tetrahedron, surface normals by
    /// F^-T of that tetrahedron. Build a `LevelOperator` on it to check the GPU's weights.
    pub fn deformed_level(&self, h: usize, level: &GraphLevel) -> GraphLevel {
        let vertices = self.level_vertices(h, level);
        let mut out = level.clone();
        let inner = level.inner_count();
        for node in 0..level.node_count() {
            let t = if node < inner {
                node
            } else {
                level.surface_faces[node - inner].0 as usize
            };
            let tet = level.tets.tets[t];
            let rest = tet.map(|v| level.tets.vertices[v as usize]);
            let def = tet.map(|v| vertices[v as usize]);
            let b = barycentric(rest, level.positions[node]);
            out.positions[node] = def[0] * b[0] + def[1] * b[1] + def[2] * b[2] + def[3] * b[3];
            if node >= inner {
                let s = node - inner;
                out.surface_normals[s] = transform_normal(rest, def, level.surface_normals[s]);
            }
        }
        out.tets.vertices = vertices;
        out
    }
}

/// Barycentric coordinates of `x` in the tetrahedron `v` (outside it: some negative; exact for
/// affine maps either way).
pub fn barycentric(v: [DVec3; 4], x: DVec3) -> [f64; 4] {
    let d = DMat3::from_cols(v[1] - v[0], v[2] - v[0], v[3] - v[0]);
    let l = d.inverse() * (x - v[0]);
    [1.0 - l.x - l.y - l.z, l.x, l.y, l.z]
}

/// n' ~ F^-T n for the deformation gradient F = D' D^-1 of a tetrahedron (normalized; the rest
/// normal where the deformed tetrahedron is flat).
pub fn transform_normal(rest: [DVec3; 4], def: [DVec3; 4], n: DVec3) -> DVec3 {
    let d = DMat3::from_cols(rest[1] - rest[0], rest[2] - rest[0], rest[3] - rest[0]);
    let e = DMat3::from_cols(def[1] - def[0], def[2] - def[0], def[3] - def[0]);
    let m = e.inverse().transpose() * (d.transpose() * n);
    let m = m.normalize_or_zero();
    if m == DVec3::ZERO || !m.is_finite() {
        n
    } else {
        m
    }
}

/// Push constants of `edit/derive_weights.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct DerivePush {
    pub size: [i32; 2],
    pub width: u32,
    pub surface_rows: u32,
    pub paper: u32,
    pub two_a: f32,
    pub q_gain: f32,
    pub pad: u32,
}

/// Push constants of `edit/map_vertices.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct MapPush {
    pub affine: [f32; 16],
    pub count: u32,
    /// 0 affine, 1 twist.
    pub mode: u32,
    pub rate: f32,
    pub pad: u32,
}

/// Push constants of `edit/deform_nodes.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct NodesPush {
    pub size: [i32; 2],
    pub width: u32,
    pub surface_rows: u32,
}

/// Push constants of `edit/deform_geometry.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GeometryPush {
    pub size: [i32; 2],
    pub width: u32,
    pub surface_rows: u32,
    pub paper: u32,
    pub min_volume: f32,
    pub min_distance: f32,
    pub pad: u32,
}

/// Push constants of `edit/deform_mesh.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct MeshPush {
    pub count: u32,
}

/// One display-mesh vertex's anchor (`MeshVertex` in `edit/deform_mesh.comp`).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct MeshAnchor {
    bary: [f32; 4],
    normal: [f32; 4],
    tet: [u32; 4],
}

pub(crate) struct DeformPipelines {
    map: ComputePipeline<MapPush>,
    nodes: ComputePipeline<NodesPush>,
    geometry: ComputePipeline<GeometryPush>,
    mesh: ComputePipeline<MeshPush>,
}

impl DeformPipelines {
    fn new(ctx: &Context, levels: u32) -> Result<Self, Error> {
        let sets = levels.max(1);
        Ok(Self {
            map: ComputePipeline::new(
                ctx,
                &ComputePipelineDesc {
                    name: "edit map vertices",
                    shader: "edit/map_vertices.comp",
                    bindings: &["rest", "vertices"],
                    max_sets: sets,
                },
            )?,
            nodes: ComputePipeline::new(
                ctx,
                &ComputePipelineDesc {
                    name: "edit deform nodes",
                    shader: "edit/deform_nodes.comp",
                    bindings: &[
                        "cells",
                        "bary",
                        "rest_normals",
                        "tets",
                        "rest",
                        "vertices",
                        "node_pos",
                        "surface_position",
                        "surface_normal",
                    ],
                    max_sets: sets,
                },
            )?,
            geometry: ComputePipeline::new(
                ctx,
                &ComputePipelineDesc {
                    name: "edit deform geometry",
                    shader: "edit/deform_geometry.comp",
                    bindings: &[
                        "cells",
                        "tets",
                        "vertices",
                        "node_pos",
                        "connectivity",
                        "geo",
                        "frac",
                    ],
                    max_sets: sets,
                },
            )?,
            mesh: ComputePipeline::new(
                ctx,
                &ComputePipelineDesc {
                    name: PASS_DEFORM_MESH,
                    shader: "edit/deform_mesh.comp",
                    bindings: &["map", "tets", "rest", "vertices", "values"],
                    max_sets: 1,
                },
            )?,
        })
    }
}

/// One level's deformation data on the GPU (created on the first deformation).
pub(crate) struct LevelDeform {
    buffers: Vec<Buffer>,
    vertex_count: u32,
    map_set: vk::DescriptorSet,
    nodes_set: vk::DescriptorSet,
    geometry_set: vk::DescriptorSet,
    min_volume: f32,
    min_distance: f32,
    /// Index into `buffers` of the deformed vertices.
    vertices: usize,
    /// Whether the level is not at rest.
    deformed: bool,
}

impl LevelDeform {
    pub(crate) fn bytes(&self) -> u64 {
        self.buffers.iter().map(|b| b.size).sum()
    }
    fn vertices(&self) -> &Buffer {
        &self.buffers[self.vertices]
    }
}

/// The display meshes' deformation data (finest level).
pub(crate) struct MeshDeform {
    #[allow(dead_code)] // owned here: the descriptor set refers to it
    anchors: Buffer,
    /// Rest vertices in the `Vertex` layout (restores `Identity` exactly).
    rest: Buffer,
    /// Deformed vertices in the `Vertex` layout.
    out: Buffer,
    count: u32,
    set: vk::DescriptorSet,
}

/// Which texture an upload writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Target {
    Geo,
    Frac,
    Kappa,
    Mu,
    Weight(usize),
    SurfacePosition,
    SurfaceNormal,
}

struct Upload {
    level: usize,
    target: Target,
    staging: Buffer,
    /// First write of a new texture (its layout is still UNDEFINED).
    fresh: bool,
}

/// How the pending deformation moves the tetrahedron vertices.
#[derive(Clone, Copy, Debug)]
enum VertexSource {
    Map(MapPush),
    Uploaded,
}

/// Edits taken for one frame ([`GpuDiffusion::take_edits`]), recorded by
/// [`GpuDiffusion::record_edits`]; dropping it releases the staging buffers after that frame.
pub struct StagedEdits {
    derive: bool,
    uploads: Vec<Upload>,
    vertex_uploads: Vec<(usize, Buffer)>,
    deform: Option<VertexSource>,
    meshes: Vec<Arc<GpuMesh>>,
    mesh_from_rest: bool,
}

impl StagedEdits {
    /// Whether the edits move the display mesh (the shadow caster: the shadow maps must follow).
    pub fn moves_mesh(&self) -> bool {
        !self.meshes.is_empty()
    }
}

/// Edits staged by `set_material` / `deform`, taken by [`GpuDiffusion::take_edits`].
#[derive(Default)]
pub(crate) struct EditState {
    /// Re-derive the heterogeneous weights.
    pub(crate) derive: bool,
    uploads: Vec<Upload>,
    vertex_uploads: Vec<(usize, Buffer)>,
    deform: Option<VertexSource>,
    /// Mesh vertex buffers to rewrite (kept alive here until recorded) and whether from the rest
    /// pose.
    meshes: Vec<Arc<GpuMesh>>,
    mesh_from_rest: bool,
    mesh: Option<MeshDeform>,
    /// The deformation last staged (for reports and tests).
    pub(crate) current: Option<Deformation>,
}

impl EditState {
    fn is_empty(&self) -> bool {
        !self.derive
            && self.uploads.is_empty()
            && self.vertex_uploads.is_empty()
            && self.deform.is_none()
            && self.meshes.is_empty()
    }
}

fn staging<T: bytemuck::Pod>(ctx: &Context, data: &[T]) -> Result<Buffer, Error> {
    Ok(Buffer::with_data(
        ctx,
        "edit staging",
        vk::BufferUsageFlags::TRANSFER_SRC,
        data,
    )?)
}

fn storage<T: bytemuck::Pod>(
    ctx: &Context,
    name: &'static str,
    data: &[T],
) -> Result<Buffer, Error> {
    Ok(Buffer::with_data(
        ctx,
        name,
        vk::BufferUsageFlags::STORAGE_BUFFER,
        data,
    )?)
}

fn gpu_buffer(ctx: &Context, name: &'static str, size: u64) -> Result<Buffer, Error> {
    Ok(Buffer::new(
        ctx,
        &BufferDesc {
            name,
            size: size.max(16),
            usage: vk::BufferUsageFlags::STORAGE_BUFFER
                | vk::BufferUsageFlags::TRANSFER_DST
                | vk::BufferUsageFlags::TRANSFER_SRC,
            memory: MemoryUse::GpuOnly,
        },
    )?)
}

fn to_f32x4(v: DVec3, w: f32) -> [f32; 4] {
    [v.x as f32, v.y as f32, v.z as f32, w]
}

impl GpuLevel {
    fn target(&self, target: Target) -> Option<&Image> {
        match target {
            Target::Geo => Some(&self.geo),
            Target::Frac => self.frac.as_ref(),
            Target::Kappa => self.material.as_ref().map(|m| &m[0]),
            Target::Mu => self.material.as_ref().map(|m| &m[1]),
            Target::Weight(c) => self.weights.as_ref().map(|w| &w[c]),
            Target::SurfacePosition => Some(&self.surface_position),
            Target::SurfaceNormal => Some(&self.surface_normal),
        }
    }
    fn deformed(&self) -> bool {
        self.deform.as_ref().is_some_and(|d| d.deformed)
    }
}

impl GpuDiffusion {
    fn stage(
        &mut self,
        ctx: &Context,
        level: usize,
        target: Target,
        bytes: &[u8],
        fresh: bool,
    ) -> Result<(), Error> {
        let staging = staging(ctx, bytes)?;
        // A newer upload of the same texture replaces an unrecorded older one.
        let fresh = fresh
            || self
                .edits
                .uploads
                .iter()
                .any(|u| u.level == level && u.target == target && u.fresh);
        self.edits
            .uploads
            .retain(|u| !(u.level == level && u.target == target));
        self.edits.uploads.push(Upload {
            level,
            target,
            staging,
            fresh,
        });
        Ok(())
    }

    /// Allocates the fv fraction texture of every level (seeded with the rest pose).
    fn ensure_frac(&mut self, ctx: &Context) -> Result<(), Error> {
        for h in 0..self.levels.len() {
            if self.levels[h].frac.is_some() {
                continue;
            }
            let l = &mut self.levels[h];
            l.frac = Some(image(
                ctx,
                "diffusion weight frac",
                &l.packing,
                vk::Format::R32G32B32A32_SFLOAT,
            )?);
            let bytes = bytes_of(&l.rest.frac);
            self.stage(ctx, h, Target::Frac, &bytes, true)?;
        }
        Ok(())
    }

    /// Allocates what a heterogeneous material needs on every level (fractions, kappa, mu, the
    /// three weight textures, the derivation's set) and its pipeline variant.
    pub(crate) fn ensure_heterogeneous(&mut self, ctx: &Context) -> Result<(), Error> {
        self.ensure_frac(ctx)?;
        if self.pipelines.derive.is_none() {
            self.pipelines.derive = Some(ComputePipeline::new(
                ctx,
                &ComputePipelineDesc {
                    name: PASS_DERIVE_WEIGHTS,
                    shader: "edit/derive_weights.comp",
                    bindings: &[
                        "connectivity",
                        "geo",
                        "frac",
                        "kappa",
                        "mu",
                        "weight_r",
                        "weight_g",
                        "weight_b",
                    ],
                    max_sets: self.levels.len() as u32,
                },
            )?);
        }
        for h in 0..self.levels.len() {
            if self.levels[h].weights.is_some() {
                continue;
            }
            let f32x4 = vk::Format::R32G32B32A32_SFLOAT;
            let l = &mut self.levels[h];
            let p = &l.packing;
            l.material = Some([
                image(ctx, "diffusion kappa", p, f32x4)?,
                image(ctx, "diffusion mu", p, f32x4)?,
            ]);
            l.weights = Some([
                image(ctx, "diffusion weight r", p, f32x4)?,
                image(ctx, "diffusion weight g", p, f32x4)?,
                image(ctx, "diffusion weight b", p, f32x4)?,
            ]);
            // Every new texture gets a first (fresh) upload, which also moves it out of
            // UNDEFINED; set_material's kappa and mu replace these zeros before any record.
            let zeros = vec![0u8; l.rest.texel_count() * 16];
            for target in [
                Target::Kappa,
                Target::Mu,
                Target::Weight(0),
                Target::Weight(1),
                Target::Weight(2),
            ] {
                self.stage(ctx, h, target, &zeros, true)?;
            }
            let l = &mut self.levels[h];
            let (Some(derive), Some(frac), Some([kappa, mu]), Some([r, g, b])) =
                (&self.pipelines.derive, &l.frac, &l.material, &l.weights)
            else {
                continue;
            };
            l.derive_set = Some(derive.allocate_set(
                ctx,
                &[
                    DescriptorWrite::storage_image("connectivity", &l.connectivity),
                    DescriptorWrite::storage_image("geo", &l.geo),
                    DescriptorWrite::storage_image("frac", frac),
                    DescriptorWrite::storage_image("kappa", kappa),
                    DescriptorWrite::storage_image("mu", mu),
                    DescriptorWrite::storage_image("weight_r", r),
                    DescriptorWrite::storage_image("weight_g", g),
                    DescriptorWrite::storage_image("weight_b", b),
                ],
            )?);
        }
        self.ensure_variant(ctx, false)
    }

    /// Stages a new material for every level (see the module doc). The graph must be the one the
    /// solve was built from. A bad material is a typed error naming the node; nothing changes then.
    pub fn set_material(
        &mut self,
        ctx: &Context,
        graph: &QuadGraph,
        field: &MaterialField,
    ) -> Result<(), Error> {
        self.check_graph(graph)?;
        let eta = field.eta();
        crate::material::check_eta(eta).map_err(SolverError::from)?;
        let (f_dr, a) = (fresnel::diffuse_reflectance(eta), fresnel::boundary_a(eta));
        let q_gain = 4.0 / (1.0 - f_dr);
        let homogeneous = match field {
            MaterialField::Homogeneous(m) => {
                let c = m.coefficients();
                crate::material::check_pair(c.sigma_s, c.sigma_a).map_err(SolverError::from)?;
                Some(HomogeneousMaterial {
                    kappa: c.kappa(),
                    mu: c.mu(),
                })
            }
            _ => None,
        };
        let materials = match homogeneous {
            Some(_) => Vec::new(),
            None => graph
                .levels
                .iter()
                .zip(&self.levels)
                .enumerate()
                .map(|(h, (level, l))| {
                    MaterialTexels::build(level, &l.packing, field).map_err(|e| e.at_level(h))
                })
                .collect::<Result<Vec<_>, _>>()?,
        };
        match homogeneous {
            Some(_) => self.ensure_variant(ctx, true)?,
            None => {
                self.ensure_heterogeneous(ctx)?;
                for (h, m) in materials.iter().enumerate() {
                    self.stage(ctx, h, Target::Kappa, &bytes_of(&m.kappa), false)?;
                    self.stage(ctx, h, Target::Mu, &bytes_of(&m.mu), false)?;
                }
                self.edits.derive = true;
            }
        }
        self.homogeneous = homogeneous.is_some();
        self.f_dr = f_dr;
        self.a = a;
        self.set_constants(homogeneous, a, q_gain);
        Ok(())
    }

    fn check_graph(&self, graph: &QuadGraph) -> Result<(), Error> {
        let same = graph.levels.len() == self.levels.len()
            && graph
                .levels
                .iter()
                .zip(&self.levels)
                .all(|(g, l)| g.node_count() == l.node_count);
        if same {
            Ok(())
        } else {
            Err(bad_param(
                "graph",
                "not the graph this solve was built from (level or node counts differ)".into(),
            ))
        }
    }

    fn ensure_deform(&mut self, ctx: &Context, graph: &QuadGraph) -> Result<(), Error> {
        if self.pipelines.edit.is_none() {
            self.pipelines.edit = Some(DeformPipelines::new(ctx, self.levels.len() as u32)?);
        }
        self.ensure_frac(ctx)?;
        let Some(pipes) = &self.pipelines.edit else {
            return Ok(());
        };
        for (level, l) in graph.levels.iter().zip(&mut self.levels) {
            if l.deform.is_some() {
                continue;
            }
            let texels = l.rest.texel_count();
            let inner = level.inner_count();
            let mut cells = vec![u32::MAX; texels];
            let mut bary = vec![[0f32; 4]; texels];
            let mut normals = vec![[0f32; 4]; texels];
            for node in 0..level.node_count() {
                let t = l.packing.linear_index(node as u32) as usize;
                let (tet, cell) = if node < inner {
                    (node, node as u32)
                } else {
                    let (k, f) = level.surface_faces[node - inner];
                    normals[t] = to_f32x4(level.surface_normals[node - inner], 0.0);
                    (k as usize, k * 4 + u32::from(f))
                };
                cells[t] = cell;
                let rest = level.tets.tets[tet].map(|v| level.tets.vertices[v as usize]);
                bary[t] = barycentric(rest, level.positions[node]).map(|b| b as f32);
            }
            let rest: Vec<[f32; 4]> = level
                .tets
                .vertices
                .iter()
                .map(|&v| to_f32x4(v, 1.0))
                .collect();
            let tets: Vec<[u32; 4]> = level.tets.tets.clone();
            let buffers = vec![
                storage(ctx, "deform cells", &cells)?,
                storage(ctx, "deform bary", &bary)?,
                storage(ctx, "deform rest normals", &normals)?,
                storage(ctx, "deform tets", &tets)?,
                storage(ctx, "deform rest vertices", &rest)?,
                gpu_buffer(ctx, "deform vertices", rest.len() as u64 * 16)?,
                gpu_buffer(ctx, "deform node positions", texels as u64 * 16)?,
            ];
            let sb = |name, i: usize| DescriptorWrite::StorageBuffer {
                name,
                buffer: &buffers[i],
            };
            let map_set = pipes
                .map
                .allocate_set(ctx, &[sb("rest", 4), sb("vertices", 5)])?;
            let nodes_set = pipes.nodes.allocate_set(
                ctx,
                &[
                    sb("cells", 0),
                    sb("bary", 1),
                    sb("rest_normals", 2),
                    sb("tets", 3),
                    sb("rest", 4),
                    sb("vertices", 5),
                    sb("node_pos", 6),
                    DescriptorWrite::storage_image("surface_position", &l.surface_position),
                    DescriptorWrite::storage_image("surface_normal", &l.surface_normal),
                ],
            )?;
            let Some(frac) = &l.frac else {
                return Err(bad_param("deformation", "no fraction texture".into()));
            };
            let geometry_set = pipes.geometry.allocate_set(
                ctx,
                &[
                    sb("cells", 0),
                    sb("tets", 3),
                    sb("vertices", 5),
                    sb("node_pos", 6),
                    DescriptorWrite::storage_image("connectivity", &l.connectivity),
                    DescriptorWrite::storage_image("geo", &l.geo),
                    DescriptorWrite::storage_image("frac", frac),
                ],
            )?;
            let h = level.spacing.max(1e-6);
            l.deform = Some(LevelDeform {
                vertex_count: rest.len() as u32,
                buffers,
                map_set,
                nodes_set,
                geometry_set,
                min_volume: (1e-9 * h * h * h).max(f64::from(f32::MIN_POSITIVE)) as f32,
                min_distance: (1e-6 * h) as f32,
                vertices: 5,
                deformed: false,
            });
        }
        Ok(())
    }

    /// The display meshes' anchors (finest level), built on first use.
    fn ensure_mesh(&mut self, ctx: &Context, graph: &QuadGraph) -> Result<(), Error> {
        if self.edits.mesh.is_some() {
            return Ok(());
        }
        let (Some(pipes), Some(finest)) = (&self.pipelines.edit, self.levels.last()) else {
            return Ok(());
        };
        let Some(deform) = &finest.deform else {
            return Ok(());
        };
        let level = graph.finest();
        let surface = &graph.surface;
        let inner = level.inner_count();
        let mut anchors = Vec::with_capacity(surface.positions.len());
        let mut rest = Vec::with_capacity(surface.positions.len());
        for (v, (&p, &n)) in surface.positions.iter().zip(&surface.normals).enumerate() {
            // The tetrahedron under the vertex's first shading link, else the nearest surface
            // node's (rare: vertices with no link).
            let s = graph
                .shading
                .links
                .get(v)
                .and_then(|l| l.iter().copied().find(|&s| s != NO_NODE))
                .map(|s| s as usize)
                .filter(|&s| s < level.surface_count())
                .or_else(|| {
                    (0..level.surface_count()).min_by(|&a, &b| {
                        let da = level.positions[inner + a].distance_squared(p);
                        let db = level.positions[inner + b].distance_squared(p);
                        da.total_cmp(&db)
                    })
                })
                .ok_or_else(|| bad_param("mesh", "the finest level has no surface node".into()))?;
            let t = level.surface_faces[s].0 as usize;
            let tet = level.tets.tets[t].map(|i| level.tets.vertices[i as usize]);
            anchors.push(MeshAnchor {
                bary: barycentric(tet, p).map(|b| b as f32),
                normal: to_f32x4(n, 0.0),
                tet: [t as u32, 0, 0, 0],
            });
            rest.push(Vertex {
                position: p.as_vec3().to_array(),
                normal: n.as_vec3().to_array(),
                exitance: [0.0; 3],
            });
        }
        if anchors.is_empty() {
            return Err(bad_param(
                "mesh",
                "the display surface has no vertices".into(),
            ));
        }
        let anchors_buf = storage(ctx, "deform mesh anchors", &anchors)?;
        let rest_buf = Buffer::with_data(
            ctx,
            "deform mesh rest",
            vk::BufferUsageFlags::TRANSFER_SRC,
            &rest,
        )?;
        let out = gpu_buffer(
            ctx,
            "deform mesh vertices",
            (rest.len() * std::mem::size_of::<Vertex>()) as u64,
        )?;
        let set = pipes.mesh.allocate_set(
            ctx,
            &[
                DescriptorWrite::StorageBuffer {
                    name: "map",
                    buffer: &anchors_buf,
                },
                DescriptorWrite::StorageBuffer {
                    name: "tets",
                    buffer: &deform.buffers[3],
                },
                DescriptorWrite::StorageBuffer {
                    name: "rest",
                    buffer: &deform.buffers[4],
                },
                DescriptorWrite::StorageBuffer {
                    name: "vertices",
                    buffer: deform.vertices(),
                },
                DescriptorWrite::StorageBuffer {
                    name: "values",
                    buffer: &out,
                },
            ],
        )?;
        self.edits.mesh = Some(MeshDeform {
            anchors: anchors_buf,
            rest: rest_buf,
            out,
            count: rest.len() as u32,
            set,
        });
        Ok(())
    }

    /// Stages a deformation of every level (see the module doc) and of `meshes` (each must have
    /// the display surface's vertex count), recorded by the next [`Self::record_edits`], which
    /// rewrites their positions and normals.
    pub fn deform(
        &mut self,
        ctx: &Context,
        graph: &QuadGraph,
        deformation: &Deformation,
        meshes: &[Arc<GpuMesh>],
    ) -> Result<(), Error> {
        self.check_graph(graph)?;
        deformation.validate(graph)?;
        for m in meshes {
            if m.vertex_count() != graph.surface.positions.len() {
                return Err(bad_param(
                    "meshes",
                    format!(
                        "a mesh has {} vertices, the display surface {}",
                        m.vertex_count(),
                        graph.surface.positions.len()
                    ),
                ));
            }
        }
        let was_deformed = self.levels.iter().any(GpuLevel::deformed);
        if *deformation == Deformation::Identity {
            if was_deformed {
                for h in 0..self.levels.len() {
                    let l = &self.levels[h];
                    let surface = surface_packing(&l.packing);
                    let n = (surface.width * surface.height) as usize;
                    let uploads = [
                        (Target::Geo, bytes_of(&l.rest.geo)),
                        (Target::Frac, bytes_of(&l.rest.frac)),
                        (
                            Target::SurfacePosition,
                            bytes_of(&l.rest.surface_position[..n.min(l.rest.texel_count())]),
                        ),
                        (
                            Target::SurfaceNormal,
                            bytes_of(&l.rest.surface_normal[..n.min(l.rest.texel_count())]),
                        ),
                    ];
                    for (target, bytes) in uploads {
                        self.stage(ctx, h, target, &bytes, false)?;
                    }
                    if let Some(d) = &mut self.levels[h].deform {
                        d.deformed = false;
                    }
                }
                self.edits.derive |= !self.homogeneous;
                self.edits.deform = None;
                self.edits.vertex_uploads.clear();
            }
            self.edits.mesh_from_rest = true;
        } else {
            self.ensure_deform(ctx, graph)?;
            self.ensure_mesh(ctx, graph)?;
            self.edits.vertex_uploads.clear();
            let source = match deformation {
                Deformation::Affine(m) => VertexSource::Map(MapPush {
                    affine: m.to_cols_array(),
                    count: 0,
                    mode: 0,
                    rate: 0.0,
                    pad: 0,
                }),
                Deformation::Twist { radians_per_mm } => VertexSource::Map(MapPush {
                    affine: Mat4::IDENTITY.to_cols_array(),
                    count: 0,
                    mode: 1,
                    rate: *radians_per_mm,
                    pad: 0,
                }),
                Deformation::TetPositions(levels) => {
                    for (h, p) in levels.iter().enumerate() {
                        let v: Vec<[f32; 4]> = p.iter().map(|x| [x[0], x[1], x[2], 1.0]).collect();
                        let buf = staging(ctx, &v)?;
                        self.edits.vertex_uploads.push((h, buf));
                    }
                    VertexSource::Uploaded
                }
                Deformation::Identity => return Ok(()),
            };
            // Rest uploads staged earlier would land before (and be overwritten by) the passes;
            // a fresh texture's first upload stays (it also leaves UNDEFINED).
            self.edits.uploads.retain(|u| match u.target {
                Target::Geo | Target::SurfacePosition | Target::SurfaceNormal => false,
                Target::Frac => u.fresh,
                _ => true,
            });
            self.edits.deform = Some(source);
            self.edits.derive |= !self.homogeneous;
            self.edits.mesh_from_rest = false;
            for l in &mut self.levels {
                if let Some(d) = &mut l.deform {
                    d.deformed = true;
                }
            }
        }
        if deformation != &Deformation::Identity || was_deformed {
            self.edits.meshes = meshes.to_vec();
        }
        self.edits.current = Some(deformation.clone());
        Ok(())
    }

    /// Takes the staged edits for recording in this frame (`None` when nothing is staged); the
    /// staging buffers they hold are released once the frame completed.
    pub fn take_edits(&mut self) -> Option<StagedEdits> {
        if self.edits.is_empty() {
            return None;
        }
        let edits = std::mem::take(&mut self.edits);
        let EditState {
            derive,
            uploads,
            vertex_uploads,
            deform,
            meshes,
            mesh_from_rest,
            mesh,
            current,
        } = edits;
        self.edits.mesh = mesh;
        self.edits.current = current;
        Some(StagedEdits {
            derive: derive && !self.homogeneous,
            uploads,
            vertex_uploads,
            deform,
            meshes,
            mesh_from_rest,
        })
    }

    /// What [`Self::record_edits`] of `staged` uses: the textures it uploads (from a transfer
    /// into GENERAL), every texture and buffer the deformation and weight passes read and write,
    /// and the display meshes whose positions and normals it copies in.
    pub fn edit_uses<'a>(&'a self, staged: &'a StagedEdits) -> Vec<Use<'a>> {
        let mut uses: Vec<Use<'a>> = Vec::new();
        let mut seen = std::collections::HashSet::new();
        let mut add = |u: Use<'a>, uses: &mut Vec<Use<'a>>| {
            if seen.insert(u.resource.handle()) {
                uses.push(u);
            }
        };
        for u in &staged.uploads {
            if let Some(img) = self.levels.get(u.level).and_then(|l| l.target(u.target)) {
                add(
                    Use::image_span(img, Access::TransferDst, Access::ComputeReadWrite),
                    &mut uses,
                );
            }
        }
        for (h, _) in &staged.vertex_uploads {
            if let Some(d) = self.levels.get(*h).and_then(|l| l.deform.as_ref()) {
                add(
                    Use::buffer_span(d.vertices(), Access::TransferDst, Access::ComputeReadWrite),
                    &mut uses,
                );
            }
        }
        if staged.deform.is_some() || staged.derive {
            for l in &self.levels {
                let images = [&l.geo, &l.surface_position, &l.surface_normal]
                    .into_iter()
                    .chain(&l.frac)
                    .chain(l.material.iter().flatten())
                    .chain(l.weights.iter().flatten());
                for img in images {
                    add(Use::image(img, Access::ComputeReadWrite), &mut uses);
                }
                for b in l.deform.iter().flat_map(|d| &d.buffers) {
                    add(Use::buffer(b, Access::ComputeReadWrite), &mut uses);
                }
            }
        }
        if let Some(m) = &self.edits.mesh {
            for b in [&m.rest, &m.out] {
                add(Use::buffer(b, Access::ComputeReadWrite), &mut uses);
            }
            for mesh in &staged.meshes {
                add(
                    Use::buffer(mesh.vertex_buffer(), Access::TransferDst),
                    &mut uses,
                );
            }
        }
        uses
    }

    /// Records `staged` (uploads, deformation passes, mesh rewrite, weight derivation), with the
    /// barriers between its own steps; the frame graph orders it against everything else from
    /// [`Self::edit_uses`].
    ///
    /// # Safety
    /// `cb` must be recording outside a rendering scope, inside a frame-graph pass declaring
    /// [`Self::edit_uses`] of `staged`; `self` and `staged` must outlive its execution.
    pub unsafe fn record_edits(
        &self,
        ctx: &Context,
        cb: vk::CommandBuffer,
        staged: &StagedEdits,
        mut profiler: Option<&mut GpuProfiler>,
    ) {
        use vk::AccessFlags2 as A;
        use vk::PipelineStageFlags2 as S;
        let raw = ctx.raw();
        let mut scope = |cb, name: Option<&'static str>| {
            // SAFETY: forwarded contract of `record_edits`.
            unsafe {
                match name {
                    Some(n) => {
                        ctx.begin_label(cb, n);
                        if let Some(p) = profiler.as_deref_mut() {
                            p.begin_scope(cb, n);
                        }
                    }
                    None => {
                        if let Some(p) = profiler.as_deref_mut() {
                            p.end_scope(cb);
                        }
                        ctx.end_label(cb);
                    }
                }
            }
        };
        // SAFETY: the caller's contract; every resource used lives in `self` or `staged`.
        unsafe {
            if !staged.uploads.is_empty() || !staged.vertex_uploads.is_empty() {
                scope(cb, Some(PASS_EDIT_UPLOAD));
                let images: Vec<(&Image, &Upload)> = staged
                    .uploads
                    .iter()
                    .filter_map(|u| {
                        self.levels
                            .get(u.level)
                            .and_then(|l| l.target(u.target))
                            .map(|i| (i, u))
                    })
                    .collect();
                for (img, u) in &images {
                    img.record_upload_from(ctx, cb, &u.staging);
                }
                for (h, buf) in &staged.vertex_uploads {
                    if let Some(d) = self.levels.get(*h).and_then(|l| l.deform.as_ref()) {
                        let size = buf.size.min(d.vertices().size);
                        let region = vk::BufferCopy::default().size(size);
                        raw.cmd_copy_buffer(cb, buf.raw, d.vertices().raw, &[region]);
                    }
                }
                let to_general: Vec<_> = images
                    .iter()
                    .map(|(img, _)| {
                        barrier::image_barrier(img, Access::TransferDst, Access::ComputeReadWrite)
                    })
                    .collect();
                // why: the passes below read the uploaded texels and vertices (RAW), in GENERAL.
                barrier::record(
                    ctx,
                    cb,
                    &[raw_barrier(
                        S::COPY,
                        A::TRANSFER_WRITE,
                        S::COMPUTE_SHADER,
                        A::SHADER_STORAGE_READ | A::SHADER_STORAGE_WRITE,
                    )],
                    &to_general,
                );
                scope(cb, None);
            }
            if let (Some(source), Some(pipes)) = (staged.deform, &self.pipelines.edit) {
                scope(cb, Some(PASS_DEFORM));
                if let VertexSource::Map(push) = source {
                    for l in &self.levels {
                        if let Some(d) = &l.deform {
                            pipes.map.dispatch(
                                ctx,
                                cb,
                                d.map_set,
                                &MapPush {
                                    count: d.vertex_count,
                                    ..push
                                },
                                [d.vertex_count, 1, 1],
                            );
                        }
                    }
                    // why: the node pass reads the mapped vertices (RAW).
                    barrier::memory(ctx, cb, Access::ComputeWrite, Access::ComputeRead);
                }
                for l in &self.levels {
                    if let Some(d) = &l.deform {
                        pipes.nodes.dispatch(
                            ctx,
                            cb,
                            d.nodes_set,
                            &NodesPush {
                                size: [l.packing.width as i32, l.packing.height as i32],
                                width: l.packing.width,
                                surface_rows: l.packing.surface_rows,
                            },
                            l.extent(),
                        );
                    }
                }
                if let Some(m) = &self.edits.mesh {
                    pipes.mesh.dispatch(
                        ctx,
                        cb,
                        m.set,
                        &MeshPush { count: m.count },
                        [m.count, 1, 1],
                    );
                }
                // why: the geometry pass reads the neighbours' new positions (RAW), the mesh copy
                // the deformed mesh vertices (RAW at transfer).
                barrier::record(
                    ctx,
                    cb,
                    &[raw_barrier(
                        S::COMPUTE_SHADER,
                        A::SHADER_STORAGE_WRITE,
                        S::COMPUTE_SHADER | S::COPY,
                        A::SHADER_STORAGE_READ | A::TRANSFER_READ,
                    )],
                    &[],
                );
                let paper = u32::from(self.params.scheme == Scheme::Paper);
                for l in &self.levels {
                    if let Some(d) = &l.deform {
                        pipes.geometry.dispatch(
                            ctx,
                            cb,
                            d.geometry_set,
                            &GeometryPush {
                                size: [l.packing.width as i32, l.packing.height as i32],
                                width: l.packing.width,
                                surface_rows: l.packing.surface_rows,
                                paper,
                                min_volume: d.min_volume,
                                min_distance: d.min_distance,
                                pad: 0,
                            },
                            l.extent(),
                        );
                    }
                }
                scope(cb, None);
            }
            if let (false, Some(m)) = (staged.meshes.is_empty(), &self.edits.mesh) {
                scope(cb, Some(PASS_DEFORM_MESH));
                let src = if staged.mesh_from_rest { &m.rest } else { &m.out };
                let stride = std::mem::size_of::<Vertex>() as u64;
                // Positions and normals only: the exitance (last 12 bytes) is the solve's.
                let span = std::mem::offset_of!(Vertex, exitance) as u64;
                let regions: Vec<vk::BufferCopy> = (0..u64::from(m.count))
                    .map(|v| {
                        vk::BufferCopy::default()
                            .src_offset(v * stride)
                            .dst_offset(v * stride)
                            .size(span)
                    })
                    .collect();
                for mesh in &staged.meshes {
                    let dst = mesh.vertex_buffer();
                    if dst.size >= u64::from(m.count) * stride {
                        raw.cmd_copy_buffer(cb, src.raw, dst.raw, &regions);
                    }
                }
                scope(cb, None);
            }
            if staged.derive {
                if let Some(dp) = &self.pipelines.derive {
                    scope(cb, Some(PASS_DERIVE_WEIGHTS));
                    // why: the derivation reads the geometry and material just written (RAW).
                    barrier::memory(ctx, cb, Access::ComputeWrite, Access::ComputeReadWrite);
                    let push = DerivePush {
                        size: [0, 0],
                        width: 0,
                        surface_rows: 0,
                        paper: u32::from(self.params.scheme == Scheme::Paper),
                        two_a: self.kappa[3],
                        q_gain: self.mu_gain[3],
                        pad: 0,
                    };
                    for l in &self.levels {
                        if let Some(set) = l.derive_set {
                            dp.dispatch(
                                ctx,
                                cb,
                                set,
                                &DerivePush {
                                    size: [l.packing.width as i32, l.packing.height as i32],
                                    width: l.packing.width,
                                    surface_rows: l.packing.surface_rows,
                                    ..push
                                },
                                l.extent(),
                            );
                        }
                    }
                    scope(cb, None);
                }
            }
        }
    }

    /// The deformation staged last (`None`: never deformed).
    pub fn deformation(&self) -> Option<&Deformation> {
        self.edits.current.as_ref()
    }

    /// Whether edits are staged and not recorded yet.
    pub fn edits_pending(&self) -> bool {
        !self.edits.is_empty()
    }
}
