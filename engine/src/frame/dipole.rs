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
//! What it does not do yet: deformation ([`Method::deform`] is a typed error; the CPU side,
//! [`FaceClusterHierarchy::refit`] and [`crate::solver::dipole::IncrementalLinks`], exists) and
//! the on-the-fly and incremental modes inside a frame (they run on the CPU:
//! [`crate::solver::dipole::links::on_the_fly`], `benches/src/bin/dipole.rs`).
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
    FaceClusterHierarchy, HeterogeneousPolicy, LinkParams, LinkSet, LinkStats,
};
use crate::solver::gpu::Deformation;
use crate::solver::SolverError;
use crate::vk::barrier::Use;
use crate::vk::{barrier, Access, Context, Image, VkError};
use crate::Error;

/// The irradiance gather at the triangles' centroids.
pub const PASS_IRRADIANCE: &str = "dipole_irradiance";
/// Leaf irradiance, pull, link gather, push and the display mesh's J+.
pub const PASS_LINKS: &str = "dipole_links";

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
}

impl Default for DipoleParams {
    fn default() -> Self {
        DipoleParams {
            model: BoundaryModel::Moments,
            links: LinkParams::default(),
            heterogeneous: HeterogeneousPolicy::Refuse,
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

/// The gather's images over the triangles (texel `(i % width, i / width)` is triangle `i`):
/// position (a = 1 on a triangle with area) and normal filled, `q` undefined.
fn upload_leaf_images(ctx: &Context, tree: &FaceClusterHierarchy) -> Result<SurfaceImages, Error> {
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
    Ok(SurfaceImages::from_texels(
        ctx,
        [
            "dipole leaf position",
            "dipole leaf normal",
            "dipole leaf q",
        ],
        (width, rows),
        &positions,
        &normals,
    )?)
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
        self.links = p.links;
        self.material = p.material;
        // The exitance must be gathered again with the new links.
        self.solved = false;
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
        Ok(())
    }

    /// Relinks on the CPU for the new material (or texture factors). With no frame in flight
    /// the new links are written at once; otherwise they replace the old ones once the frames
    /// reading them completed (until then the method reports no solution, so each frame
    /// updates), which needs them to fit the link buffer: a larger set while frames are in
    /// flight is an error that changes nothing (retry after they completed).
    fn set_material(&mut self, ctx: &Context, field: &MaterialField) -> Result<(), Error> {
        let material = DipoleMaterial::from_field(
            field,
            &self.surface,
            self.params.model,
            self.params.heterogeneous,
        )
        .map_err(dipole_error)?;
        let (links, stats) = LinkSet::build(&self.tree, &material.profile, &self.params.links);
        links.check(self.tree.nodes.len()).map_err(dipole_error)?;
        if self.idle() {
            self.gather.set_links(ctx, &links).map_err(dipole_error)?;
            self.apply(PendingMaterial { links, material })?;
        } else if links.len() <= self.gather.link_capacity() {
            self.pending = Some(PendingMaterial { links, material });
        } else {
            return Err(VkError::invalid(
                "dipole material",
                format!(
                    "the new material needs {} links, more than the buffer in use by frames in                      flight holds ({}): set it again once they completed",
                    links.len(),
                    self.gather.link_capacity()
                ),
            )
            .into());
        }
        self.link_stats = stats;
        Ok(())
    }

    fn deform(&mut self, _: &Context, _: &Deformation) -> Result<(DVec3, f64), Error> {
        Err(VkError::invalid(
            "dipole method",
            "deformation inside a frame is not built yet (use --method quadgraph); the CPU \
             refit and incremental relinking exist in solver::dipole",
        )
        .into())
    }

    fn has_solution(&self) -> bool {
        self.solved && self.pending.is_none()
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
        let mut out = MethodFrame::default();
        self.update = match work {
            MethodWork::Skip(why) if self.solved => {
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

    fn add_edit_passes<'g>(&'g self, _: &mut FrameGraph<'g>) {}

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
