//! [`DipoleMethod`]: the dipole method of DESIGN section 6 (Mertens et al. 2003, render mode of
//! section 5.5) behind the method seam. The face-cluster hierarchy and its links are built on the
//! CPU (rayon) when the object is created (the hierarchy once per topology, cached on disk by the
//! caller through [`crate::solver::dipole::cache`]; the links again after a material change); per
//! frame, after the shared shadow maps:
//! - [`PASS_IRRADIANCE`]: the shared irradiance gather ([`IrradiancePass`], the same shader as
//!   the QuadGraph's `gather_q`: lights with shadow-map visibility, environment) at every
//!   triangle's centroid with its face normal: the transmitted irradiance E T_i of the paper's
//!   Eq. 5 at the leaves (section 5.3);
//! - [`PASS_LINKS`]: the leaves' irradiance unscaled into the hierarchy's leaf buffer, then
//!   [`DipoleGatherPass`]: pull up the hierarchy, gather along the links (Eq. 6 with the form
//!   factors of Eq. 7 computed when linking), push to the triangles, average to the vertices and
//!   write J+ = M / (1 - F_dr) into the display mesh's exitance field, which the shared shading
//!   turns into radiance (DESIGN section 2: integrated over the hemisphere it gives back M).
//!
//! Deformation ([`Method::deform`], an analytic map of the rest pose): the hierarchy is refitted
//! ([`FaceClusterHierarchy::refit`], same topology) and relinked from scratch on the CPU (rayon;
//! measured cheaper than draining [`crate::solver::dipole::IncrementalLinks`] for a whole-object
//! deformation, benches/RESULTS.md "Dipole modes"), the pull and vertex weights and the links are
//! rewritten, and the next frame's [`PASS_DEFORM`] copies the moved display vertices and the
//! triangles' new centroids and normals into the display mesh and the leaf images before the
//! gather. The links and weights live in host-visible buffers the frames read: a deformation
//! while frames are in flight waits for them first.
//!
//! Incremental mode (paper section 5.5) runs in the frame: `Relink::Incremental` drains
//! [`crate::solver::dipole::IncrementalLinks`] a bounded number of form factors per frame after a
//! deformation or a material change. On-the-fly mode (no links stored) runs on the CPU only:
//! [`crate::solver::dipole::links::on_the_fly`], measured by `benches/src/bin/dipole.rs modes`.
//!
//! ```no_run
//! use std::sync::Arc;
//! use translucent::frame::dipole::DipoleParams;
//! use translucent::object::{MethodDesc, ObjectParams, TranslucentObject};
//! use translucent::solver::dipole::FaceClusterHierarchy;
//! # fn f(ctx: &translucent::vk::Context, mesh: translucent::mesh::TriMesh,
//! #      field: &translucent::material::MaterialField, scene: &translucent::scene::Scene)
//! #      -> Result<(), translucent::Error> {
//! let (tree, _) = FaceClusterHierarchy::build(&mesh).map_err(translucent::solver::SolverError::from)?;
//! let method = MethodDesc::Dipole { mesh, hierarchy: Arc::new(tree), params: DipoleParams::default() };
//! let object = TranslucentObject::with_method(ctx, method, field, scene, &ObjectParams::default())?;
//! # Ok(()) }
//! ```

use std::sync::Arc;

use ash::vk;
use glam::DVec3;

use super::graph::FrameGraph;
use super::method::{Method, MethodFrame};
use super::plan::MethodWork;
use super::report::CompletedSolve;
use crate::material::MaterialField;
use crate::mesh::{GpuMesh, TriMesh, Vertex};
use crate::render::{GatherLevel, GatherScene, IrradiancePass, ShadowMaps, SurfaceImages};
use crate::scene::Scene;
use crate::shader::{ComputePipeline, ComputePipelineDesc, DescriptorWrite};
use crate::solver::dipole::{
    irradiance::leaf_irradiance, BoundaryModel, DipoleGatherPass, DipoleMaterial,
    FaceClusterHierarchy, HeterogeneousPolicy, IncrementalLinks, LinkParams, LinkSet, LinkStats,
    StepReport,
};
use crate::solver::gpu::Deformation;
use crate::solver::SolverError;
use crate::vk::barrier::Use;
use crate::vk::{barrier, Access, Buffer, Context, Image, VkError};
use crate::Error;

/// The irradiance gather at the triangles' centroids.
pub const PASS_IRRADIANCE: &str = "dipole_irradiance";
/// Leaf irradiance, pull, link gather, push and the display mesh's J+.
pub const PASS_LINKS: &str = "dipole_links";
/// After a deformation: the moved display vertices and leaf centroids and normals copied in.
pub const PASS_DEFORM: &str = "dipole_deform";

/// Texels per row of the leaf images (the gather's workgroups are 8 x 8).
const LEAF_IMAGE_WIDTH: u32 = 256;
/// The brightest unshadowed leaf irradiance is stored at this value in fp16 (as the QuadGraph's
/// `q_scale_for`): far below fp16's 65504, far above its subnormals.
const Q_TARGET: f64 = 2048.0;

/// How a [`DipoleMethod`] is built.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DipoleParams {
    /// The dipole's boundary condition (DESIGN 2.6 moments by default, or Jensen's F_dr-based A).
    pub model: BoundaryModel,
    /// The refinement oracle and form-factor settings.
    pub links: LinkParams,
    /// A heterogeneous material: refused (typed error naming the other methods) or texture only.
    pub heterogeneous: HeterogeneousPolicy,
    /// How the links follow a deformation.
    pub relink: Relink,
}

/// How the links follow a deformation (paper section 5.5).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Relink {
    /// Relink from scratch on the CPU (rayon) in [`Method::deform`]: the next frame gathers with
    /// links made for the new shape.
    #[default]
    Full,
    /// The paper's incremental mode: [`Method::deform`] only refits the hierarchy and marks the
    /// links touching moved triangles stale; each frame then promotes, demotes or re-evaluates
    /// stale links ([`crate::solver::dipole::IncrementalLinks::step`]) for about
    /// `form_factors_per_frame` form factors and gathers with the links as they stand (some old
    /// form factors until the queue drained). The link buffer is reserved at twice the links at
    /// the deformation; a set outgrowing it waits on the GPU for the next deformation.
    Incremental { form_factors_per_frame: u64 },
}

impl Default for DipoleParams {
    fn default() -> Self {
        DipoleParams {
            model: BoundaryModel::Moments,
            links: LinkParams::default(),
            heterogeneous: HeterogeneousPolicy::Refuse,
            relink: Relink::Full,
        }
    }
}

/// Push constants of `dipole/leaf_irradiance.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct LeafPush {
    pub leaf_count: u32,
    pub width: u32,
    pub inv_q_scale: f32,
    pub pad: u32,
}

/// The texels of the leaf images (texel `(i % width, i / width)` is triangle `i`): position (a = 1
/// on a triangle with area) and normal; `(width, rows)`.
#[allow(clippy::type_complexity)]
fn leaf_texels(tree: &FaceClusterHierarchy) -> ((u32, u32), Vec<[f32; 4]>, Vec<[half::f16; 4]>) {
    let t = tree.leaf_count();
    let width = LEAF_IMAGE_WIDTH;
    let rows = (t as u32).div_ceil(width).max(1);
    let texels = (width * rows) as usize;
    let mut positions = vec![[0.0f32; 4]; texels];
    let mut normals = vec![[half::f16::ZERO; 4]; texels];
    for (i, g) in tree.geometry[..t].iter().enumerate() {
        if !(g.area > 0.0 && g.area.is_finite()) {
            continue; // degenerate: no irradiance (as the CPU's leaf_irradiance)
        }
        let (p, n) = (g.centroid, g.normal);
        positions[i] = [p.x as f32, p.y as f32, p.z as f32, 1.0];
        normals[i] = [
            half::f16::from_f64(n.x),
            half::f16::from_f64(n.y),
            half::f16::from_f64(n.z),
            half::f16::ZERO,
        ];
    }
    ((width, rows), positions, normals)
}

/// The gather's images over the triangles ([`leaf_texels`]), `q` undefined.
fn upload_leaf_images(ctx: &Context, tree: &FaceClusterHierarchy) -> Result<SurfaceImages, Error> {
    let (size, positions, normals) = leaf_texels(tree);
    Ok(SurfaceImages::from_texels(
        ctx,
        [
            "dipole leaf position",
            "dipole leaf normal",
            "dipole leaf q",
        ],
        size,
        &positions,
        &normals,
    )?)
}

/// A deformed shape's GPU data, staged for [`PASS_DEFORM`]'s copies.
struct StagedShape {
    vertices: Buffer,
    leaf_positions: Buffer,
    leaf_normals: Buffer,
}

impl StagedShape {
    /// The display vertices of `moved` and the leaf texels of `tree` (refitted to it).
    fn new(
        ctx: &Context,
        moved: &TriMesh,
        tree: &FaceClusterHierarchy,
    ) -> Result<StagedShape, Error> {
        let vertices: Vec<Vertex> = moved
            .positions
            .iter()
            .zip(&moved.normals)
            .map(|(p, n)| Vertex {
                position: p.as_vec3().to_array(),
                normal: n.as_vec3().to_array(),
                exitance: [0.0; 3],
            })
            .collect();
        let (_, positions, normals) = leaf_texels(tree);
        let normal_bits: Vec<u16> = normals.iter().flatten().map(|h| h.to_bits()).collect();
        let staging = |name, data: &[u8]| {
            Buffer::with_data(ctx, name, vk::BufferUsageFlags::TRANSFER_SRC, data)
        };
        Ok(StagedShape {
            vertices: staging("dipole deformed vertices", bytemuck::cast_slice(&vertices))?,
            leaf_positions: staging(
                "dipole deformed leaf positions",
                bytemuck::cast_slice(&positions),
            )?,
            leaf_normals: staging(
                "dipole deformed leaf normals",
                bytemuck::cast_slice(&normal_bits),
            )?,
        })
    }
}

/// A relink waiting until no frame in flight reads the links it replaces.
struct PendingMaterial {
    links: LinkSet,
    material: DipoleMaterial,
}

/// The dipole method (see the module doc).
pub struct DipoleMethod {
    tree: Arc<FaceClusterHierarchy>,
    /// The display mesh on the CPU (the texture-only factors are sampled at its vertices).
    surface: TriMesh,
    /// The display mesh whose exitance field the links pass writes.
    mesh: Arc<GpuMesh>,
    params: DipoleParams,
    material: DipoleMaterial,
    links: LinkSet,
    link_stats: LinkStats,
    gather: DipoleGatherPass,
    irradiance: IrradiancePass,
    images: SurfaceImages,
    level: GatherLevel,
    leaves: ComputePipeline<LeafPush>,
    leaves_set: vk::DescriptorSet,
    uniforms: GatherScene,
    q_scale: f32,
    pending: Option<PendingMaterial>,
    /// The scene (the leaf irradiance's exposure is refitted after a deformation).
    scene: Scene,
    /// A deformation's copies, waiting for the next frame; `copy_now` while that frame records.
    staged: Option<StagedShape>,
    copy_now: bool,
    /// The frame that recorded the copies of `staged` (dropped once it completed).
    staged_frame: Option<u64>,
    /// [`Relink::Incremental`]: the links kept per receiver with their queue of stale links.
    incremental: Option<IncrementalLinks>,
    /// What the last incremental step did (None before the first).
    last_step: Option<StepReport>,
    /// The last frame that recorded the passes, and the last one the host reported complete.
    last_recorded: Option<u64>,
    completed: u64,
    solved: bool,
    update: bool,
}

fn dipole_error(e: crate::solver::dipole::DipoleError) -> Error {
    Error::Solver(SolverError::Dipole(e))
}

/// The exposure of the leaf q image: the brightest unshadowed leaf at [`Q_TARGET`].
fn q_scale(tree: &FaceClusterHierarchy, scene: &Scene, eta: f64) -> Result<f32, Error> {
    let max = leaf_irradiance(tree, scene, eta, None)
        .map_err(dipole_error)?
        .iter()
        .flatten()
        .fold(0.0f64, |m, &v| m.max(v));
    if !(max > 0.0 && max.is_finite()) {
        return Ok(1.0);
    }
    Ok((Q_TARGET / max).clamp(f64::from(f32::MIN_POSITIVE), f64::from(f32::MAX)) as f32)
}

impl DipoleMethod {
    /// Links `tree` (the hierarchy of `surface`, the display mesh uploaded as `mesh`) for `field`,
    /// builds the GPU gather writing into `mesh`'s exitance and the irradiance gather bound to
    /// the shared `shadows`.
    // why: the method's inputs are distinct (hierarchy, its mesh on CPU and GPU, material, scene,
    // settings, shared shadows), as QuadGraphMethod::new's.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        ctx: &Context,
        tree: Arc<FaceClusterHierarchy>,
        surface: TriMesh,
        field: &MaterialField,
        scene: &Scene,
        params: &DipoleParams,
        shadows: &ShadowMaps,
        mesh: Arc<GpuMesh>,
    ) -> Result<DipoleMethod, Error> {
        params.links.validate().map_err(dipole_error)?;
        if tree.leaf_count() != surface.indices.len()
            || mesh.vertex_count() != surface.positions.len()
        {
            return Err(VkError::invalid(
                "dipole hierarchy",
                format!(
                    "{} leaves for {} triangles, {} GPU vertices for {} mesh vertices: the hierarchy \
                     and the display mesh must come from the same mesh",
                    tree.leaf_count(),
                    surface.indices.len(),
                    mesh.vertex_count(),
                    surface.positions.len()
                ),
            )
            .into());
        }
        let material =
            DipoleMaterial::from_field(field, &surface, params.model, params.heterogeneous)
                .map_err(dipole_error)?;
        let (links, link_stats) = LinkSet::build(&tree, &material.profile, &params.links);
        let mut gather = DipoleGatherPass::new(ctx, &tree, &links, material.modulation.as_deref())
            .map_err(dipole_error)?;
        let floats = (std::mem::size_of::<Vertex>() / 4) as u32;
        let offset = (std::mem::offset_of!(Vertex, exitance) / 4) as u32;
        gather
            .bind_mesh_output(
                ctx,
                mesh.vertex_buffer(),
                floats,
                offset,
                (1.0 / (1.0 - material.base.f_dr())) as f32,
            )
            .map_err(dipole_error)?;
        let images = upload_leaf_images(ctx, &tree)?;
        let irradiance = IrradiancePass::new(ctx, 1)?;
        let level = irradiance.bind_level(
            ctx,
            shadows,
            &images.position,
            &images.normal,
            &images.q,
            images.surface_rows,
        )?;
        let leaves = ComputePipeline::new(
            ctx,
            &ComputePipelineDesc {
                name: "dipole leaf irradiance",
                shader: "dipole/leaf_irradiance.comp",
                bindings: &["q", "leaf_irradiance"],
                max_sets: 1,
            },
        )?;
        let leaves_set = leaves.allocate_set(
            ctx,
            &[
                DescriptorWrite::storage_image("q", &images.q),
                DescriptorWrite::StorageBuffer {
                    name: "leaf_irradiance",
                    buffer: gather.leaf_irradiance(),
                },
            ],
        )?;
        let uniforms = GatherScene::new(scene, shadows)?;
        let q_scale = q_scale(&tree, scene, field.eta())?;
        let incremental = match params.relink {
            Relink::Full => None,
            Relink::Incremental { .. } => Some(IncrementalLinks::from_set(
                &links,
                &material.profile,
                &params.links,
                link_stats,
            )),
        };
        Ok(DipoleMethod {
            tree,
            surface,
            mesh,
            params: *params,
            material,
            links,
            link_stats,
            gather,
            irradiance,
            images,
            level,
            leaves,
            leaves_set,
            uniforms,
            q_scale,
            pending: None,
            scene: scene.clone(),
            staged: None,
            copy_now: false,
            staged_frame: None,
            incremental,
            last_step: None,
            last_recorded: None,
            completed: 0,
            solved: false,
            update: false,
        })
    }

    /// The face-cluster hierarchy.
    pub fn hierarchy(&self) -> &FaceClusterHierarchy {
        &self.tree
    }

    /// The links in use and the statistics of the linking that made them.
    pub fn links(&self) -> (&LinkSet, &LinkStats) {
        (&self.links, &self.link_stats)
    }

    /// The material the light is transported through (and the texture factors, if any).
    pub fn material(&self) -> &DipoleMaterial {
        &self.material
    }

    /// [`Relink::Incremental`]: what the last frame's step did and the stale links left.
    pub fn incremental_step(&self) -> Option<(StepReport, usize)> {
        let pending = self.incremental.as_ref()?.pending();
        Some((self.last_step.unwrap_or_default(), pending))
    }

    /// The exposure the leaf irradiance is stored at in fp16.
    pub fn q_scale(&self) -> f32 {
        self.q_scale
    }

    /// Makes `p` (its links already written) the material in use.
    fn apply(&mut self, p: PendingMaterial) -> Result<(), Error> {
        self.gather
            .set_modulation(p.material.modulation.as_deref())
            .map_err(dipole_error)?;
        self.gather
            .set_output_scale((1.0 / (1.0 - p.material.base.f_dr())) as f32);
        if self.incremental.is_some() {
            self.incremental = Some(IncrementalLinks::from_set(
                &p.links,
                &p.material.profile,
                &self.params.links,
                LinkStats::default(),
            ));
        }
        self.links = p.links;
        self.material = p.material;
        // The exitance must be gathered again with the new links.
        self.solved = false;
        Ok(())
    }

    /// Waits until no submitted frame reads the host-visible link and weight buffers.
    fn wait_for_frames(&mut self, ctx: &Context) -> Result<(), Error> {
        if !self.idle() {
            // SAFETY: the device is valid; waiting has no other effect.
            unsafe { ctx.raw().device_wait_idle() }.map_err(VkError::call("vkDeviceWaitIdle"))?;
            self.completed = self.last_recorded.unwrap_or(self.completed);
        }
        Ok(())
    }

    /// [`Relink::Incremental`]'s deformation: `tree` (refitted by `refit` to `moved`) replaces
    /// the hierarchy, the links touching moved triangles are queued; the frames relink.
    fn deform_incremental(
        &mut self,
        ctx: &Context,
        tree: FaceClusterHierarchy,
        refit: &crate::solver::dipole::RefitReport,
        moved: &TriMesh,
    ) -> Result<(DVec3, f64), Error> {
        let staged = StagedShape::new(ctx, moved, &tree)?;
        let q_scale = q_scale(&tree, &self.scene, self.material.base.eta)?;
        self.wait_for_frames(ctx)?;
        if self.gather.link_capacity() < self.links.len() * 3 / 2 {
            self.gather
                .set_links_reserving(ctx, &self.links, 2 * self.links.len())
                .map_err(dipole_error)?;
        }
        self.gather.refit(&tree).map_err(dipole_error)?;
        if let Some(links) = &mut self.incremental {
            links.geometry_changed(refit);
        }
        self.tree = Arc::new(tree);
        self.q_scale = q_scale;
        self.staged = Some(staged);
        self.staged_frame = None;
        self.solved = false;
        Ok(crate::mesh::bounding_sphere(&moved.positions))
    }

    /// [`Relink::Incremental`]: one bounded step of relinking, its links written when they fit.
    fn step_links(&mut self) -> Result<(), Error> {
        let Relink::Incremental {
            form_factors_per_frame,
        } = self.params.relink
        else {
            return Ok(());
        };
        let Some(links) = self.incremental.as_mut().filter(|l| l.pending() > 0) else {
            return Ok(());
        };
        let report = links.step(&self.tree, form_factors_per_frame);
        let set = links.link_set();
        self.last_step = Some(report);
        if set.len() <= self.gather.link_capacity() {
            self.gather.write_links(&set).map_err(dipole_error)?;
            self.links = set;
        }
        Ok(())
    }

    /// Whether the links of `pending` may replace the ones in use: no frame in flight reads them.
    fn idle(&self) -> bool {
        self.last_recorded.is_none_or(|f| f <= self.completed)
    }
}

impl Method for DipoleMethod {
    fn name(&self) -> &'static str {
        "dipole"
    }

    fn set_lights(&mut self, scene: &Scene, shadows: &ShadowMaps) -> Result<(), Error> {
        let uniforms = GatherScene::new(scene, shadows)?;
        self.q_scale = q_scale(&self.tree, scene, self.material.base.eta)?;
        self.uniforms = uniforms;
        self.scene = scene.clone();
        Ok(())
    }

    /// Relinks on the CPU for the new material (or texture factors). With no frame in flight
    /// the new links are written at once; otherwise they replace the old ones once the frames
    /// reading them completed (until then the method reports no solution, so each frame
    /// updates) when they fit the link buffer; a larger set waits for the frames in flight and
    /// replaces the buffer. In [`Relink::Incremental`] mode every link is marked stale instead and
    /// the frames re-evaluate them.
    fn set_material(&mut self, ctx: &Context, field: &MaterialField) -> Result<(), Error> {
        let material = DipoleMaterial::from_field(
            field,
            &self.surface,
            self.params.model,
            self.params.heterogeneous,
        )
        .map_err(dipole_error)?;
        if self.incremental.is_some() && self.pending.is_none() {
            // Incremental mode: every link is stale; the frames re-evaluate, promote and demote.
            self.wait_for_frames(ctx)?;
            if self.gather.link_capacity() < self.links.len() * 3 / 2 {
                self.gather
                    .set_links_reserving(ctx, &self.links, 2 * self.links.len())
                    .map_err(dipole_error)?;
            }
            self.gather
                .set_modulation(material.modulation.as_deref())
                .map_err(dipole_error)?;
            self.gather
                .set_output_scale((1.0 / (1.0 - material.base.f_dr())) as f32);
            if let Some(links) = &mut self.incremental {
                links.material_changed(material.profile);
            }
            self.material = material;
            self.solved = false;
            return Ok(());
        }
        let (links, stats) = LinkSet::build(&self.tree, &material.profile, &self.params.links);
        links.check(self.tree.nodes.len()).map_err(dipole_error)?;
        if self.idle() {
            self.gather.set_links(ctx, &links).map_err(dipole_error)?;
            self.apply(PendingMaterial { links, material })?;
        } else if links.len() <= self.gather.link_capacity() {
            self.pending = Some(PendingMaterial { links, material });
        } else {
            // A larger buffer: the frames in flight read the one it replaces.
            self.wait_for_frames(ctx)?;
            self.pending = None;
            self.gather.set_links(ctx, &links).map_err(dipole_error)?;
            self.apply(PendingMaterial { links, material })?;
        }
        self.link_stats = stats;
        Ok(())
    }

    /// Refits the hierarchy to `deformation` of the rest pose and relinks it (module doc). A
    /// typed error (tetrahedron positions, a non-finite vertex, too many links) changes nothing.
    fn deform(&mut self, ctx: &Context, deformation: &Deformation) -> Result<(DVec3, f64), Error> {
        if matches!(deformation, Deformation::TetPositions(_)) {
            return Err(VkError::invalid(
                "dipole deformation",
                "tetrahedron positions belong to a QuadGraph; the dipole method takes an analytic \
                 map of its surface (affine, twist)",
            )
            .into());
        }
        let mut moved = self.surface.clone();
        for p in &mut moved.positions {
            *p = deformation.map_point(*p).unwrap_or(*p);
        }
        moved.compute_normals();
        if let Some(v) = moved
            .positions
            .iter()
            .chain(&moved.normals)
            .position(|p| !p.as_vec3().is_finite())
        {
            return Err(VkError::invalid(
                "dipole deformation",
                format!(
                    "deformed vertex {} is not finite in f32",
                    v % moved.positions.len()
                ),
            )
            .into());
        }
        let mut tree = (*self.tree).clone();
        let refit = tree.refit(&moved.positions).map_err(dipole_error)?;
        if self.incremental.is_some() && self.pending.is_none() {
            return self.deform_incremental(ctx, tree, &refit, &moved);
        }
        // A material staged behind frames in flight: relink for it (its links are for the old
        // shape).
        let material = match &self.pending {
            Some(p) => p.material.clone(),
            None => self.material.clone(),
        };
        let (links, stats) = LinkSet::build(&tree, &material.profile, &self.params.links);
        links.check(tree.nodes.len()).map_err(dipole_error)?;
        let staged = StagedShape::new(ctx, &moved, &tree)?;
        let q_scale = q_scale(&tree, &self.scene, material.base.eta)?;
        self.wait_for_frames(ctx)?;
        // Fails (TooManyLinks) before writing anything.
        self.gather.set_links(ctx, &links).map_err(dipole_error)?;
        self.gather.refit(&tree).map_err(dipole_error)?;
        if let Some(p) = self.pending.take() {
            self.gather
                .set_modulation(p.material.modulation.as_deref())
                .map_err(dipole_error)?;
            self.gather
                .set_output_scale((1.0 / (1.0 - p.material.base.f_dr())) as f32);
            self.material = p.material;
        }
        if self.incremental.is_some() {
            self.incremental = Some(IncrementalLinks::from_set(
                &links,
                &self.material.profile,
                &self.params.links,
                stats,
            ));
        }
        self.tree = Arc::new(tree);
        self.links = links;
        self.link_stats = stats;
        self.q_scale = q_scale;
        self.staged = Some(staged);
        self.staged_frame = None;
        self.solved = false;
        Ok(crate::mesh::bounding_sphere(&moved.positions))
    }

    fn has_solution(&self) -> bool {
        self.solved
            && self.pending.is_none()
            && self.incremental.as_ref().is_none_or(|l| l.pending() == 0)
    }

    fn material_variant(&self) -> &'static str {
        if self.material.modulation.is_some() {
            "texture only"
        } else {
            "homogeneous"
        }
    }

    fn prepare(&mut self, work: MethodWork, frame: u64) -> Result<MethodFrame, Error> {
        if self.idle() {
            if let Some(p) = self.pending.take() {
                self.gather.write_links(&p.links).map_err(dipole_error)?;
                self.apply(p)?;
            }
        }
        if self.idle() {
            self.step_links()?;
        }
        let mut out = MethodFrame::default();
        self.copy_now = self.staged.is_some() && self.staged_frame.is_none();
        if self.copy_now {
            self.staged_frame = Some(frame);
        }
        self.update = match work {
            MethodWork::Skip(why)
                if self.solved && self.incremental.as_ref().is_none_or(|l| l.pending() == 0) =>
            {
                for pass in [PASS_IRRADIANCE, PASS_LINKS] {
                    out.skipped.push((pass, why));
                }
                false
            }
            _ => true,
        };
        if self.update {
            self.last_recorded = Some(frame);
            self.solved = true;
            out.levels_iterated = 1;
        }
        Ok(out)
    }

    fn add_edit_passes<'g>(&'g self, graph: &mut FrameGraph<'g>) {
        let Some(staged) = self.staged.as_ref().filter(|_| self.copy_now) else {
            return;
        };
        let target = self.mesh.vertex_buffer();
        graph
            .pass(PASS_DEFORM)
            .uses([
                Use::buffer(&staged.vertices, Access::TransferSrc),
                Use::buffer(&staged.leaf_positions, Access::TransferSrc),
                Use::buffer(&staged.leaf_normals, Access::TransferSrc),
                Use::buffer(target, Access::TransferDst),
                Use::image(&self.images.position, Access::TransferDst),
                Use::image(&self.images.normal, Access::TransferDst),
            ])
            .record(move |p| {
                // SAFETY: inside the graph's pass declaring the copies' buffers and images (the
                // graph puts the images in TRANSFER_DST); everything lives in `self` until the
                // frame completed.
                unsafe {
                    p.ctx.raw().cmd_copy_buffer(
                        p.cb,
                        staged.vertices.raw,
                        target.raw,
                        &[vk::BufferCopy::default().size(staged.vertices.size.min(target.size))],
                    );
                    self.images
                        .position
                        .record_upload_from(p.ctx, p.cb, &staged.leaf_positions);
                    self.images
                        .normal
                        .record_upload_from(p.ctx, p.cb, &staged.leaf_normals);
                }
                Ok(())
            });
    }

    fn add_passes<'g>(
        &'g self,
        graph: &mut FrameGraph<'g>,
        shadows: &'g ShadowMaps,
    ) -> Result<(), Error> {
        if !self.update {
            return Ok(());
        }
        graph
            .pass(PASS_IRRADIANCE)
            .uses(IrradiancePass::uses(
                shadows,
                &self.images.position,
                &self.images.normal,
                &self.images.q,
            ))
            .record(move |p| {
                // SAFETY: inside the graph's pass declaring the gather's uses; everything lives
                // in `self` and `shadows`, which outlive the frame.
                unsafe {
                    self.irradiance.record_scene(p.ctx, p.cb, &self.uniforms);
                    self.irradiance.record(
                        p.ctx,
                        p.cb,
                        &self.level,
                        self.q_scale,
                        self.material.base.eta as f32,
                    )?;
                }
                Ok(())
            });
        graph
            .pass(PASS_LINKS)
            .uses([
                Use::image(&self.images.q, Access::ComputeRead),
                Use::buffer(self.gather.leaf_irradiance(), Access::ComputeReadWrite),
                Use::buffer(self.mesh.vertex_buffer(), Access::ComputeWrite),
            ])
            .record(move |p| {
                let push = LeafPush {
                    leaf_count: self.gather.leaf_count(),
                    width: LEAF_IMAGE_WIDTH,
                    inv_q_scale: 1.0 / self.q_scale,
                    pad: 0,
                };
                // SAFETY: inside the graph's pass declaring the q image, the leaf buffer and the
                // display mesh; everything lives in `self`, which outlives the frame.
                unsafe {
                    // why: the previous frame's gather read the leaf buffer this dispatch
                    // rewrites (WAR across frames; the graph orders only this frame's passes).
                    barrier::memory(p.ctx, p.cb, Access::ComputeRead, Access::ComputeWrite);
                    self.leaves.dispatch(
                        p.ctx,
                        p.cb,
                        self.leaves_set,
                        &push,
                        [push.leaf_count, 1, 1],
                    );
                    // why: the pull and the gather read the leaf irradiance just written (RAW).
                    barrier::memory(p.ctx, p.cb, Access::ComputeWrite, Access::ComputeRead);
                    self.gather.record_dispatches(p.ctx, p.cb);
                }
                Ok(())
            });
        Ok(())
    }

    fn completed(&mut self, completed_frame: u64) -> Result<Vec<CompletedSolve>, Error> {
        self.completed = self.completed.max(completed_frame);
        if self.staged_frame.is_some_and(|f| f <= self.completed) {
            self.staged = None;
            self.staged_frame = None;
        }
        Ok(Vec::new())
    }

    fn gpu_bytes(&self) -> u64 {
        let image = |i: &Image, texel: u64| u64::from(i.width) * u64::from(i.height) * texel;
        self.gather.bytes()
            + image(&self.images.position, 16)
            + image(&self.images.normal, 8)
            + image(&self.images.q, 8)
    }

    fn as_any(&self) -> &dyn std::any::Any {
        self
    }

    fn as_any_mut(&mut self) -> &mut dyn std::any::Any {
        self
    }
}
