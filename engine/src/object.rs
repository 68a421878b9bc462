//! [`TranslucentObject`]: one translucent object as a host render graph embeds it (DESIGN sections
//! 5 and 7). It owns the method ([`crate::frame::Method`]: the QuadGraph solve, or a fixed
//! exitance), the shadow atlas, the display mesh (which also casts the shadows) and the shading
//! pipeline, and records all of it, as one [`crate::frame::FrameGraph`], into
//! the HOST's command buffer: it never begins, ends or submits a command buffer, never waits and
//! never destroys a host object.
//!
//! Changes are validated and applied by the setters ([`TranslucentObject::set_lights`],
//! `set_material`, `deform`, `set_camera`: a typed error changes nothing) and mark what is dirty;
//! [`TranslucentObject::record`] then records only the work they require (DESIGN section 5,
//! decided in one place, [`crate::frame::FramePlan`]) and says in its [`FrameReport`] what ran
//! and, per skipped pass, why:
//! - nothing changed: no shadow map, gather or solve, only the shading;
//! - camera only: the same (the view-dependent Fresnel term is in the shading);
//! - lights, material or shape changed: a warm-started solve: every level from its own last
//!   solution, each finer level first corrected by the coarser level's change (the smooth part
//!   of the change, which the finest level's Jacobi damps slowest; one level on a small graph);
//! - no shadow-casting light: no shadow pass;
//! - converged: no more iterations (decided on the GPU; [`CompletedSolve::converged`]);
//! - a small graph: a cold solve iterates one level;
//! - homogeneous material: the solve's homogeneous variant ([`FrameReport::material_variant`]).
//!
//! [`ObjectParams::skip`] `= false` turns every skip off (every frame a cold full solve).
//!
//! Frames: `RecordCtx::frame` is the host's frame number (monotonic), `completed_frame` the last
//! one the GPU finished; objects we drop are released once their frame completed, and the
//! iterations a solve ran come back in the report of a later frame ([`FrameReport::completed`]).
//!
//! Boundary: our pass LOADs the host's colour (its background stays) and depth-tests against the
//! host's depth if given. By default we record the barriers from each target's `before` state and
//! to its `after` state; a host graph that places them itself reads [`TranslucentObject::declare`]
//! and sets [`Targets::host_barriers`].
//!
//! ```no_run
//! use std::sync::Arc;
//! use translucent::object::{ObjectParams, RecordCtx, TargetImage, Targets, TranslucentObject};
//! use translucent::vk::Access;
//! # fn f(ctx: &translucent::vk::Context, graph: Arc<translucent::QuadGraph>,
//! #      field: &translucent::material::MaterialField, scene: &translucent::scene::Scene,
//! #      cb: ash::vk::CommandBuffer, color: ash::vk::Image, view: ash::vk::ImageView)
//! #      -> Result<(), translucent::Error> {
//! let mut object = TranslucentObject::new(ctx, graph, field, scene, &ObjectParams::default())?;
//! let targets = Targets {
//!     color: TargetImage {
//!         image: color,
//!         view,
//!         format: translucent::render::COLOR_FORMAT,
//!         extent: ash::vk::Extent2D { width: 640, height: 480 },
//!         before: Access::ColorAttachmentWrite.into(),
//!         after: Access::FragmentSampled.into(),
//!     },
//!     depth: None,
//!     host_barriers: false,
//! };
//! object.set_lights(scene)?; // e.g. a light moved: the next frame warm-starts
//! // SAFETY: `cb` is recording outside a rendering scope; the object and the images outlive it.
//! let report = unsafe {
//!     object.record(&mut RecordCtx { ctx, cb, frame: 7, completed_frame: 5, profiler: None }, &targets)?
//! };
//! println!("{:?} skipped {:?}", report.passes, report.skipped);
//! # Ok(()) }
//! ```

use std::sync::Arc;

use ash::vk;
use glam::DVec3;

use crate::frame::graph::FrameGraph;
use crate::frame::plan::{Changes, Conditions, FramePlan, PASS_SHADING, PASS_SHADOW};
use crate::frame::quadgraph::QuadGraphParams;
use crate::frame::{
    BounceLinks, BouncePass, FixedExitance, FrameReport, Method, QuadGraphMethod, ScatterParams,
    SingleScatteringPass, TangentialPass, VoxelMethod, PASS_BOUNCE, PASS_SCATTER_DEPTHS,
    PASS_SINGLE_SCATTERING, SINGLE_LEVEL_NODES,
};
use crate::material::MaterialField;
use crate::mesh::{GpuMesh, TriMesh};
use crate::render::{
    environment_sh, MeshPass, RenderError, ShadeAttachments, ShadePush, ShadeUniforms, ShadowMaps,
    ShadowMapsDesc, COLOR_FORMAT, DEPTH_FORMAT, MAX_SHADOW_VIEWS,
};
use crate::scene::{Camera, ExitLobe, Light, RadianceMode, Scene};
use crate::solver::gpu::{Deformation, GpuSolveParams};
use crate::vk::{Access, Context, Image, ImageDesc, ImageState};
use crate::{Error, QuadGraph};

mod diffusion;
mod host;
mod record;

use diffusion::{solved_field, surface_diffusion, vertex_diffusion};

pub use host::{HostResource, RecordCtx, ResourceUse, TargetImage, Targets};

pub use crate::frame::{CompletedSolve, SkipReason};

/// How to build a [`TranslucentObject`].
#[derive(Clone, Debug)]
pub struct ObjectParams {
    /// The QuadGraph method's solve.
    pub solve: GpuSolveParams,
    /// The host colour target's format (the shading pipeline is built for it).
    pub color_format: vk::Format,
    /// The depth format: the host's depth target's, or of our own depth buffer when the host
    /// gives none.
    pub depth_format: vk::Format,
    /// Cook-Torrance specular of the first directional light, shadowed by its atlas tile.
    pub specular: bool,
    /// GGX roughness (alpha = roughness^2), in (0, 1].
    pub roughness: f32,
    pub radiance: RadianceMode,
    /// The angular shape of the diffusion's exit radiance (`--exit-lobe`).
    pub exit_lobe: ExitLobe,
    /// `false`: every frame records everything with a cold solve (for comparisons).
    pub skip: bool,
    /// Finest-level node count below which a cold solve iterates one level.
    pub single_level_nodes: usize,
    /// Single scattering (DESIGN 2.8) as the shared pass `single_scattering` between the method
    /// and the shading; `None`: off (the pass is not recorded).
    pub single_scattering: Option<ScatterParams>,
    /// One bounce between display vertices ([`crate::frame::bounce`]): with
    /// [`BounceMode::Local`] a QuadGraph object takes the links its graph carries
    /// ([`crate::QuadGraph::bounce`], stored with the bake; a graph without links gets no bounce: build
    /// them with [`BounceLinks::build`] and store them there, or call [`Self::set_bounce`]);
    /// links without a single link (a convex object) record no pass.
    pub bounce: crate::frame::BounceMode,
    /// The diffusion coefficient D of the QuadGraph method (solve, sources, exit query, bounce):
    /// it replaces the material's own ([`MaterialField::with_diffusion`], what the f64 CPU
    /// solver reads) at creation and in [`TranslucentObject::set_material`]. The other methods
    /// keep 1 / (3 sigma_t'). Default [`crate::defaults::DIFFUSION`] (Grosjean's), as
    /// `translucent render` runs.
    pub diffusion: crate::material::DiffusionCoefficient,
    /// Draw the diffusion's tangential flux toward the view (`render --tangential-flux`;
    /// [`crate::solver::transport::Boundary::tangential_flux_factor`]): the exit lobes draw the
    /// normal flux only. Off by default (benches/RESULTS.md, "The front-lit spheres, term by
    /// term (wave 9)").
    pub tangential_flux: bool,
}

impl Default for ObjectParams {
    /// The real-time defaults ([`crate::defaults::Settings::realtime`] for a homogeneous
    /// material: multigrid, the second-collision source, single scattering on), as `translucent
    /// render` runs them. For a heterogeneous material use [`ObjectParams::for_material`].
    fn default() -> Self {
        crate::defaults::Settings::default().object_params()
    }
}

impl ObjectParams {
    /// The real-time defaults resolved for `field` ([`crate::defaults::Settings::for_material`]:
    /// the boundary-flux source for a heterogeneous material).
    pub fn for_material(field: &crate::material::MaterialField) -> Self {
        crate::defaults::Settings::for_material(field).object_params()
    }

    /// Everything but the solve and single scattering at its default; the solve is the
    /// solver's own default (cascade, boundary flux) capped at the default iterations.
    pub(crate) fn base() -> Self {
        ObjectParams {
            solve: GpuSolveParams {
                iterations: vec![crate::defaults::CASCADE_ITERATIONS],
                ..GpuSolveParams::default()
            },
            color_format: COLOR_FORMAT,
            depth_format: DEPTH_FORMAT,
            specular: true,
            roughness: 0.35,
            radiance: RadianceMode::Physical,
            exit_lobe: ExitLobe::default(),
            skip: true,
            single_level_nodes: SINGLE_LEVEL_NODES,
            single_scattering: None,
            bounce: crate::frame::BounceMode::Off,
            diffusion: crate::material::DiffusionCoefficient::Classical,
            tangential_flux: false,
        }
    }
}

/// What computes the surface exitance of a [`TranslucentObject`] (the method seam,
/// [`crate::frame::Method`]); the display mesh comes with it.
#[derive(Clone, Debug)]
pub enum MethodDesc {
    /// Diffusion on a baked QuadGraph; the display mesh is `graph.surface`.
    QuadGraph(Arc<QuadGraph>),
    /// Exitance J+ given per vertex of `mesh` (the CPU reference's output, fixtures).
    Exitance {
        mesh: TriMesh,
        exitance: Vec<[f32; 3]>,
    },
    /// Shortest optical paths on a voxel grid built every frame from `mesh` (Ozawa et al.;
    /// [`crate::frame::VoxelMethod`]): no bake, so the mesh may deform or change topology
    /// ([`TranslucentObject::set_mesh`]).
    Voxel {
        mesh: TriMesh,
        params: crate::solver::voxel::VoxelParams,
    },
    /// Hierarchical boundary elements with the dipole ([`crate::frame::DipoleMethod`]) on the
    /// display mesh `mesh`, whose face-cluster hierarchy is `hierarchy`.
    Dipole {
        mesh: TriMesh,
        hierarchy: Arc<crate::solver::dipole::FaceClusterHierarchy>,
        params: crate::frame::DipoleParams,
    },
}

/// The shading pass's use of the host's colour target (its declaration and [`TranslucentObject::declare`]).
const COLOR_USE: Access = Access::ColorAttachmentWrite;
/// The shading pass's use of a depth target.
const DEPTH_USE: Access = Access::DepthAttachmentWrite;

/// A translucent object recorded into a host's frames (see the module doc).
pub struct TranslucentObject {
    method: Box<dyn Method>,
    /// The display mesh: the method writes its exitance; it also casts the shadows.
    mesh: Arc<GpuMesh>,
    shadows: ShadowMaps,
    shading: MeshPass,
    /// Single scattering per display vertex (its output is zero while off).
    scatter: SingleScatteringPass,
    /// The rest pose's display vertices (a heterogeneous field's mean coefficients for `scatter`).
    rest_positions: Vec<DVec3>,
    params: ObjectParams,
    lights: Vec<Light>,
    /// The last scene (`scatter` re-reads it when the shadow views are refitted).
    scene: Scene,
    /// The rest pose's bounding sphere: what the automatic camera frames.
    framing: (DVec3, f64),
    /// The bounding sphere the shadow views are fitted to (follows deformations).
    shadow_bounds: (DVec3, f64),
    /// The environment's mirror reflection in the shading's basis (zero without specular).
    env_sh: [[f32; 4]; 9],
    eta: f32,
    /// The reduced albedo per channel the own-light lobe reads ([`ExitLobe::Chandra`],
    /// [`crate::scene::own_lobe::surface_albedo`]).
    own_albedo: [f64; 3],
    /// The surface's mean diffusion coefficient D per channel (mm; the object's
    /// [`ObjectParams::diffusion`]), for the tangential flux ([`ObjectParams::tangential_flux`])
    /// where no [`TangentialPass`] gives it per vertex.
    surface_d: [f64; 3],
    /// The tangential flux's smooth gradient per vertex, when [`ObjectParams::tangential_flux`]
    /// is on and the display mesh is the surface given (every method but a voxel mesh of its
    /// own); `None`: the shading's screen derivatives stand in.
    tangential: Option<TangentialPass>,
    /// Whether a frame recorded the [`TangentialPass`] since it was built (later frames record
    /// it only with a new exitance).
    tangential_written: std::cell::Cell<bool>,
    camera: Option<Camera>,
    changes: Changes,
    own_depth: Option<Image>,
    last_frame: Option<u64>,
    /// `--method auto`'s choice, repeated in every [`FrameReport`].
    method_choice: Option<crate::frame::MethodChoice>,
    /// One bounce of exitance between display vertices ([`Self::set_bounce`]); `None`: off.
    bounce: Option<BouncePass>,
    /// Bounces per new exitance of that pass ([`Self::set_bounces`]).
    bounces: u32,
}

fn invalid(what: &str, problem: String) -> Error {
    Error::Render(RenderError::Invalid {
        what: what.into(),
        problem,
    })
}

impl TranslucentObject {
    /// The QuadGraph method on `graph` with `field` lit by `scene`: builds the solve, the display
    /// mesh, the shadow maps and the shading pipeline for `params`' formats. Uploads run at
    /// creation (see [`Context::from_host`] for hosts).
    pub fn new(
        ctx: &Context,
        graph: Arc<QuadGraph>,
        field: &MaterialField,
        scene: &Scene,
        params: &ObjectParams,
    ) -> Result<TranslucentObject, Error> {
        Self::with_method(ctx, MethodDesc::QuadGraph(graph), field, scene, params)
    }

    /// An object whose exitance comes from `method` (see [`MethodDesc`]).
    pub fn with_method(
        ctx: &Context,
        method: MethodDesc,
        field: &MaterialField,
        scene: &Scene,
        params: &ObjectParams,
    ) -> Result<TranslucentObject, Error> {
        if !(params.roughness.is_finite() && params.roughness > 0.0 && params.roughness <= 1.0) {
            return Err(invalid(
                "roughness",
                format!("{} is not in (0, 1]", params.roughness),
            ));
        }
        check_light_count(scene)?;
        scene.validate()?;
        let field = &*solved_field(
            field,
            matches!(method, MethodDesc::QuadGraph(_)),
            params.diffusion,
        );
        let surface = match &method {
            MethodDesc::QuadGraph(graph) => &graph.surface,
            MethodDesc::Exitance { mesh, .. }
            | MethodDesc::Voxel { mesh, .. }
            | MethodDesc::Dipole { mesh, .. } => mesh,
        };
        let framing = crate::mesh::bounding_sphere(&surface.positions);
        let rest_positions = surface.positions.clone();
        let rest_indices = match params.tangential_flux {
            true => surface.indices.clone(),
            false => Vec::new(),
        };
        // The bounce links stored with the bake, when the parameters ask for the bounce.
        let bounce_links = match &method {
            MethodDesc::QuadGraph(graph) if params.bounce != crate::frame::BounceMode::Off => {
                graph.bounce.clone()
            }
            _ => None,
        };
        let mut shadows = ShadowMaps::new(
            ctx,
            &ShadowMapsDesc {
                max_views: MAX_SHADOW_VIEWS as u32,
                ..ShadowMapsDesc::default()
            },
        )?;
        let shadow_bounds = match &method {
            MethodDesc::QuadGraph(graph) => graph.finest().bounding_sphere(),
            MethodDesc::Exitance { .. } | MethodDesc::Voxel { .. } | MethodDesc::Dipole { .. } => {
                framing
            }
        };
        shadows.set_lights(&scene.lights, shadow_bounds, true)?;
        let (mesh, method): (Arc<GpuMesh>, Box<dyn Method>) = match method {
            MethodDesc::QuadGraph(graph) => {
                let vertices = graph.surface.positions.len();
                let mesh = Arc::new(GpuMesh::new(
                    ctx,
                    &graph.surface,
                    &vec![[0.0; 3]; vertices],
                )?);
                let method = QuadGraphMethod::new(
                    ctx,
                    graph,
                    field,
                    scene,
                    &QuadGraphParams {
                        solve: params.solve.clone(),
                        single_level_nodes: params.single_level_nodes,
                    },
                    &shadows,
                    mesh.clone(),
                )?;
                (mesh, Box::new(method))
            }
            MethodDesc::Exitance { mesh, exitance } => {
                let mesh = Arc::new(GpuMesh::new(ctx, &mesh, &exitance)?);
                (mesh.clone(), Box::new(FixedExitance::new(mesh)))
            }
            MethodDesc::Voxel { mesh, params } => {
                let (method, mesh) = VoxelMethod::new(ctx, &mesh, field, scene, &params)?;
                (mesh, Box::new(method))
            }
            MethodDesc::Dipole {
                mesh: surface,
                hierarchy,
                params,
            } => {
                let vertices = surface.positions.len();
                let mesh = Arc::new(GpuMesh::new(ctx, &surface, &vec![[0.0; 3]; vertices])?);
                let method = crate::frame::DipoleMethod::new(
                    ctx,
                    hierarchy,
                    surface,
                    field,
                    scene,
                    &params,
                    &shadows,
                    mesh.clone(),
                )?;
                (mesh, Box::new(method))
            }
        };
        let shading = MeshPass::new(
            ctx,
            &shadows.atlas,
            params.color_format,
            params.depth_format,
        )?;
        let mut scatter = SingleScatteringPass::new(
            ctx,
            mesh.vertex_count(),
            &params.single_scattering.unwrap_or_default(),
            &shadows,
        )?;
        scatter.set_lights(scene, &shadows, shadow_bounds)?;
        scatter.set_material(field, &rest_positions);
        let own_albedo = crate::scene::own_lobe::surface_albedo(field, &rest_positions);
        let surface_d = surface_diffusion(field, &rest_positions, params.diffusion);
        let tangential =
            tangential_pass(ctx, params, &mesh, &rest_positions, &rest_indices, field)?;
        let mut object = TranslucentObject {
            method,
            mesh,
            shadows,
            shading,
            scatter,
            rest_positions,
            params: params.clone(),
            lights: scene.lights.clone(),
            scene: scene.clone(),
            framing,
            shadow_bounds,
            env_sh: environment_sh(&scene.environment),
            eta: field.eta() as f32,
            own_albedo,
            surface_d,
            tangential,
            tangential_written: std::cell::Cell::new(false),
            camera: None,
            // The first frame draws everything: nothing of it exists yet (a fixed exitance has its
            // solution, but no shadow map).
            changes: Changes {
                lights: true,
                material: true,
                shape: true,
                camera: true,
            },
            own_depth: None,
            last_frame: None,
            method_choice: None,
            bounce: None,
            bounces: crate::defaults::BOUNCES,
        };
        // No link (a convex object): no pass to record.
        if let Some(links) = bounce_links.as_ref().filter(|l| l.link_count() > 0) {
            object.set_bounce(ctx, Some(links), field)?;
        }
        Ok(object)
    }

    /// New lights and environment: the shadow views are refitted and the method updated now; the
    /// next frame renders them. A bad light or environment, or more than
    /// [`crate::render::MAX_LIGHTS`], is a typed error and changes nothing.
    pub fn set_lights(&mut self, scene: &Scene) -> Result<(), Error> {
        check_light_count(scene)?;
        scene.validate()?;
        let previous = (
            self.shadows.views().to_vec(),
            self.shadows.light_views().to_vec(),
        );
        self.shadows
            .set_lights(&scene.lights, self.shadow_bounds, true)?;
        if let Err(e) = self.method.set_lights(scene, &self.shadows) {
            self.shadows.restore(previous);
            return Err(e);
        }
        self.scatter
            .set_lights(scene, &self.shadows, self.shadow_bounds)?;
        self.scene = scene.clone();
        self.env_sh = environment_sh(&scene.environment);
        self.lights = scene.lights.clone();
        self.changes.lights = true;
        Ok(())
    }

    /// A new material (homogeneous or heterogeneous): validated and staged now (a typed error
    /// changes nothing), uploaded by the next frame, which warm-starts the solve.
    pub fn set_material(&mut self, ctx: &Context, field: &MaterialField) -> Result<(), Error> {
        let field = &*self.solved_field(field);
        if let Some(bounce) = &mut self.bounce {
            let optics = crate::frame::bounce::vertex_wall_optics(
                field,
                self.params.solve.exit,
                &self.rest_positions,
                bounce.crossings(),
            );
            bounce.set_reflectance(&optics)?;
        }
        self.method.set_material(ctx, field)?;
        self.scatter.set_material(field, &self.rest_positions);
        self.eta = field.eta() as f32;
        self.own_albedo = crate::scene::own_lobe::surface_albedo(field, &self.rest_positions);
        self.surface_d = surface_diffusion(field, &self.rest_positions, self.params.diffusion);
        if let Some(tangential) = &mut self.tangential {
            let d = vertex_diffusion(field, &self.rest_positions, self.params.diffusion);
            tangential.set_diffusion(&d, tangential_factor(field.eta(), &self.params))?;
        }
        self.changes.material = true;
        Ok(())
    }

    /// A new shape (relative to the baked rest pose): validated and staged now (a typed error
    /// changes nothing); the next frame deforms the object on the GPU and warm-starts the solve.
    pub fn deform(&mut self, ctx: &Context, deformation: &Deformation) -> Result<(), Error> {
        let bounds = self.method.deform(ctx, deformation)?;
        self.shadows.set_lights(&self.lights, bounds, true)?;
        self.scatter
            .set_lights(&self.scene, &self.shadows, bounds)?;
        self.shadow_bounds = bounds;
        self.changes.shape = true;
        Ok(())
    }

    /// A topology change (a fracture, a re-mesh): `mesh` is drawn from the next frame. Only a
    /// method with no bake takes one ([`MethodDesc::Voxel`]); others, and a bad mesh, are a
    /// typed error that changes nothing.
    pub fn set_mesh(&mut self, ctx: &Context, mesh: &TriMesh) -> Result<(), Error> {
        let name = self.method.name();
        let Some(voxel) = self.method_mut::<VoxelMethod>() else {
            return Err(invalid(
                "mesh",
                format!("the {name} method bakes its mesh: a new topology needs the voxel method"),
            ));
        };
        let (display, bounds) = voxel.set_mesh(ctx, mesh)?;
        self.shadows.set_lights(&self.lights, bounds, true)?;
        self.scatter.resize(ctx, display.vertex_count())?;
        self.scatter
            .set_lights(&self.scene, &self.shadows, bounds)?;
        if self.params.tangential_flux && mesh.positions.len() == display.vertex_count() {
            // The new topology's own gradient operator; the object keeps no field: the
            // surface's mean D at every vertex.
            let d = vec![self.surface_d.map(|d| d as f32); mesh.positions.len()];
            let factor = tangential_factor(f64::from(self.eta), &self.params);
            self.tangential = Some(TangentialPass::new(
                ctx,
                &display,
                &mesh.positions,
                &mesh.indices,
                &d,
                factor,
            )?);
            self.tangential_written.set(false);
        } else {
            self.tangential = None;
        }
        self.mesh = display;
        self.shadow_bounds = bounds;
        self.changes.shape = true;
        Ok(())
    }

    /// Records that the method was picked by [`crate::frame::choose_method`] (`--method auto`):
    /// every later [`FrameReport::method_choice`] carries it. A choice naming another method
    /// than the object's is a typed error.
    pub fn set_method_choice(&mut self, choice: crate::frame::MethodChoice) -> Result<(), Error> {
        if choice.kind.name() != self.method.name() {
            return Err(invalid(
                "method choice",
                format!(
                    "{} was chosen but the object runs the {} method",
                    choice.kind.name(),
                    self.method.name()
                ),
            ));
        }
        self.method_choice = Some(choice);
        Ok(())
    }

    /// A new camera; `None` frames the object automatically. Checked here.
    pub fn set_camera(&mut self, camera: Option<Camera>) -> Result<(), Error> {
        if let Some(c) = &camera {
            c.validate()?;
        }
        if self.camera != camera {
            self.camera = camera;
            self.changes.camera = true;
        }
        Ok(())
    }

    /// The camera set last (`None`: framed automatically).
    pub fn camera(&self) -> Option<Camera> {
        self.camera
    }

    /// The method computing the exitance (`as_any().downcast_ref::<QuadGraphMethod>()` for the
    /// QuadGraph's report and read-backs).
    pub fn method(&self) -> &dyn Method {
        &*self.method
    }

    /// The QuadGraph method, if that is the object's method.
    pub fn quadgraph(&self) -> Option<&QuadGraphMethod> {
        self.method.as_any().downcast_ref::<QuadGraphMethod>()
    }

    /// The single-scattering pass (its per-vertex output is zero while
    /// [`ObjectParams::single_scattering`] is off).
    pub fn single_scattering(&self) -> &SingleScatteringPass {
        &self.scatter
    }

    /// The sphere the shadow views are fitted to (the deformed shape's, after `deform`).
    pub fn shadow_bounds(&self) -> (DVec3, f64) {
        self.shadow_bounds
    }

    /// The display mesh (its exitance field holds the method's last output).
    pub fn mesh(&self) -> &Arc<GpuMesh> {
        &self.mesh
    }

    /// Replaces the exitance of a [`MethodDesc::Exitance`] object (drawn from the next frame).
    pub fn set_exitance(&mut self, ctx: &Context, exitance: &[[f32; 3]]) -> Result<(), Error> {
        let Some(fixed) = self.method_mut::<FixedExitance>() else {
            return Err(invalid(
                "exitance",
                format!("the {} method computes its own", self.method.name()),
            ));
        };
        fixed.set_exitance(ctx, exitance)?;
        self.changes.material = true;
        Ok(())
    }

    /// The per-node exit lobe's diffused share per display vertex for a given exitance
    /// ([`FixedExitance::set_diffused_share`]); an error for methods that compute their own.
    pub fn set_diffused_share(&mut self, ctx: &Context, share: &[f32]) -> Result<(), Error> {
        let Some(fixed) = self.method_mut::<FixedExitance>() else {
            return Err(invalid(
                "diffused share",
                format!("the {} method computes its own", self.method.name()),
            ));
        };
        fixed.set_diffused_share(ctx, share)
    }

    /// One bounce of exitance between display vertices ([`crate::frame::bounce`]): `links` built
    /// on this object's display mesh ([`BounceLinks::build`] of the method's surface), R and T
    /// ([`crate::frame::bounce::vertex_wall_optics`] at the links' wall crossings) from `field`
    /// (the material it renders, as given to [`Self::set_material`]) and the solve's exit query. Added in place to the exitance the method writes from the next solve on (a
    /// [`MethodDesc::Exitance`] object: from its next [`Self::set_exitance`]); `None` turns it
    /// off (from the next solve). The voxel method re-meshes: a typed error there, as are links
    /// for another vertex count.
    pub fn set_bounce(
        &mut self,
        ctx: &Context,
        links: Option<&BounceLinks>,
        field: &MaterialField,
    ) -> Result<(), Error> {
        // The source's pass holds the bounce pass's irradiance buffer: dropped first.
        if let Some(q) = self.method.as_any_mut().downcast_mut::<QuadGraphMethod>() {
            q.set_bounce_source(ctx, None)?;
        }
        let Some(links) = links else {
            self.bounce = None;
            self.changes.material = true;
            return Ok(());
        };
        if self.method.as_any().is::<VoxelMethod>() {
            return Err(invalid(
                "bounce",
                "the voxel method re-meshes: the bounce needs a baked display mesh".into(),
            ));
        }
        let optics = crate::frame::bounce::vertex_wall_optics(
            &self.solved_field(field),
            self.params.solve.exit,
            &self.rest_positions,
            &links.across,
        );
        let mut pass = BouncePass::new(ctx, &self.mesh, links, &optics)?;
        pass.set_bounces(self.bounces)?;
        let pass = self.bounce.insert(pass);
        if self.params.bounce == crate::frame::BounceMode::Source {
            if let Some(q) = self.method.as_any_mut().downcast_mut::<QuadGraphMethod>() {
                q.set_bounce_source(ctx, Some(pass.irradiance()))?;
            }
        }
        self.changes.material = true;
        Ok(())
    }

    /// Bounces per new exitance of the bounce pass ([`crate::frame::bounce::BouncePass::set_bounces`],
    /// default [`crate::defaults::BOUNCES`]), kept for a pass [`Self::set_bounce`] makes later;
    /// a count outside [`crate::frame::bounce::BOUNCE_RANGE`] is a typed error. From the next
    /// solve on.
    pub fn set_bounces(&mut self, bounces: u32) -> Result<(), Error> {
        if let Some(pass) = &mut self.bounce {
            pass.set_bounces(bounces)?;
            self.changes.material = true;
        } else if !crate::frame::bounce::BOUNCE_RANGE.contains(&bounces) {
            return Err(invalid(
                "bounces",
                format!(
                    "{bounces} bounces, outside {:?}",
                    crate::frame::bounce::BOUNCE_RANGE
                ),
            ));
        }
        self.bounces = bounces;
        Ok(())
    }

    /// `field` as this object's method solves it ([`ObjectParams::diffusion`]).
    fn solved_field<'a>(&self, field: &'a MaterialField) -> std::borrow::Cow<'a, MaterialField> {
        solved_field(
            field,
            self.method.as_any().is::<QuadGraphMethod>(),
            self.params.diffusion,
        )
    }

    /// `--bounce source`'s second solve: its tolerance relative to its start
    /// ([`QuadGraphMethod::set_bounce_tolerance`]; in [0, 1), else a typed error; other methods
    /// have no second solve). From the next frame.
    pub fn set_bounce_tolerance(&mut self, relative: f32) -> Result<(), Error> {
        match self.method_mut::<QuadGraphMethod>() {
            Some(q) => q.set_bounce_tolerance(relative),
            None if relative.is_finite() && (0.0..1.0).contains(&relative) => Ok(()),
            None => Err(invalid(
                "bounce tolerance",
                format!("{relative}: must be in [0, 1)"),
            )),
        }
    }

    /// The bounce pass, when on.
    pub fn bounce(&self) -> Option<&BouncePass> {
        self.bounce.as_ref()
    }

    fn method_mut<T: 'static>(&mut self) -> Option<&mut T> {
        let any: &mut dyn std::any::Any = self.method.as_any_mut();
        any.downcast_mut::<T>()
    }

    /// Solves whose frame is `<= completed_frame` not reported yet (a frame's [`FrameReport`]
    /// carries those of earlier frames; this reads the last one's once it completed).
    pub fn completed_solves(&mut self, completed_frame: u64) -> Result<Vec<CompletedSolve>, Error> {
        self.method.completed(completed_frame)
    }

    /// GPU bytes of the method's resources.
    pub fn gpu_bytes(&self) -> u64 {
        self.method.gpu_bytes()
    }

    /// How [`TranslucentObject::record`] uses the host's targets, for a host graph that places
    /// the boundary barriers itself ([`Targets::host_barriers`]): before the record, the colour
    /// must be in `COLOR_ATTACHMENT_OPTIMAL` with earlier writes available to colour-attachment
    /// reads and writes, the depth likewise in `DEPTH_ATTACHMENT_OPTIMAL`; after it, our writes
    /// are at these stages. Everything else we record touches only our own resources.
    pub fn declare(&self) -> Vec<ResourceUse> {
        let color: ImageState = COLOR_USE.into();
        let depth: ImageState = DEPTH_USE.into();
        vec![
            ResourceUse {
                resource: HostResource::Color,
                stage: color.stage,
                access: color.access,
                layout: color.layout,
                read: true,
                write: true,
            },
            ResourceUse {
                resource: HostResource::Depth,
                stage: depth.stage,
                access: depth.access,
                layout: depth.layout,
                read: true,
                write: true,
            },
        ]
    }

    fn check_targets(&self, targets: &Targets) -> Result<(), Error> {
        let (color_format, depth_format) = self.shading.formats();
        let c = &targets.color;
        if c.extent.width == 0 || c.extent.height == 0 {
            return Err(invalid(
                "colour target",
                format!("{}x{} has no pixels", c.extent.width, c.extent.height),
            ));
        }
        if c.format != color_format {
            return Err(invalid(
                "colour target",
                format!(
                    "format {:?}, but the object was built for {color_format:?} (ObjectParams::color_format)",
                    c.format
                ),
            ));
        }
        if c.image == vk::Image::null() || c.view == vk::ImageView::null() {
            return Err(invalid("colour target", "null image or view".into()));
        }
        if let Some(d) = &targets.depth {
            if d.format != depth_format {
                return Err(invalid(
                    "depth target",
                    format!(
                        "format {:?}, but the object was built for {depth_format:?} (ObjectParams::depth_format)",
                        d.format
                    ),
                ));
            }
            if d.extent != c.extent {
                return Err(invalid(
                    "depth target",
                    format!(
                        "{}x{}, the colour target is {}x{}",
                        d.extent.width, d.extent.height, c.extent.width, c.extent.height
                    ),
                ));
            }
            if d.image == vk::Image::null() || d.view == vk::ImageView::null() {
                return Err(invalid("depth target", "null image or view".into()));
            }
        }
        if !targets.host_barriers {
            for (name, state) in [("colour target", &c.after)]
                .into_iter()
                .chain(targets.depth.as_ref().map(|d| ("depth target", &d.after)))
            {
                if state.layout == vk::ImageLayout::UNDEFINED
                    || state.layout == vk::ImageLayout::PREINITIALIZED
                {
                    return Err(invalid(
                        name,
                        format!("cannot leave it in {:?}", state.layout),
                    ));
                }
            }
        }
        Ok(())
    }

    /// The shading uniforms for an `extent` target: camera, and the first directional light's
    /// atlas tile for the specular shadow.
    fn uniforms(&self, extent: vk::Extent2D) -> (ShadeUniforms, bool) {
        let aspect = f64::from(extent.width) / f64::from(extent.height.max(1));
        let (centre, radius) = self.framing;
        let camera = self
            .camera
            .unwrap_or_else(|| Camera::framing(centre, radius, aspect));
        let shadows = &self.shadows;
        let specular = self
            .params
            .specular
            .then(|| {
                self.lights.iter().enumerate().find_map(|(i, l)| match *l {
                    Light::Directional {
                        direction,
                        irradiance,
                    } => Some((i, direction, irradiance)),
                    _ => None,
                })
            })
            .flatten()
            .and_then(|(i, direction, irradiance)| {
                let &(first, count) = shadows.light_views().get(i)?;
                let m = (count > 0)
                    .then(|| shadows.atlas_view_proj(first as usize))
                    .flatten()?;
                Some((m, direction, irradiance))
            });
        let (light_view_proj, light_dir, irradiance) = match specular {
            Some((m, d, e)) => (m, d.normalize().as_vec3().extend(1.0), e.map(|v| v as f32)),
            None => (glam::Mat4::IDENTITY, glam::Vec4::ZERO, [0.0; 3]),
        };
        (
            ShadeUniforms {
                view_proj: camera.view_proj(aspect, centre, radius).to_cols_array(),
                light_view_proj: light_view_proj.to_cols_array(),
                camera_pos: camera.eye.as_vec3().extend(1.0).to_array(),
                light_dir: light_dir.to_array(),
                light_irradiance: [irradiance[0], irradiance[1], irradiance[2], 0.0],
                env_sh: match self.params.specular {
                    true => self.env_sh,
                    false => [[0.0; 4]; 9],
                },
                own_albedo: {
                    let a = self.own_albedo.map(|v| v as f32);
                    let applies = self.params.exit_lobe.own_light_applies(f64::from(self.eta));
                    [a[0], a[1], a[2], if applies { 1.0 } else { 0.0 }]
                },
                own_lights: crate::render::own_light_uniforms(&self.lights),
                own_env_sh: self.env_sh,
                tangential: match self.params.tangential_flux {
                    // f D grad X comes per vertex from the pass.
                    true if self.tangential.is_some() => [1.0, 1.0, 1.0, 2.0],
                    true => {
                        let f = crate::solver::transport::Boundary::new(
                            f64::from(self.eta),
                            self.params.solve.exit,
                        )
                        .tangential_flux_factor();
                        let d = self.surface_d.map(|d| (f * d) as f32);
                        [d[0], d[1], d[2], 1.0]
                    }
                    false => [0.0; 4],
                },
            },
            specular.is_some(),
        )
    }
}

/// [`crate::solver::transport::Boundary::tangential_flux_factor`] of the object's boundary.
fn tangential_factor(eta: f64, params: &ObjectParams) -> f32 {
    crate::solver::transport::Boundary::new(eta, params.solve.exit).tangential_flux_factor() as f32
}

/// The tangential flux's pass for `mesh` when [`ObjectParams::tangential_flux`] is on and the
/// mesh's vertices are `positions` (triangles `indices`); `None` otherwise.
fn tangential_pass(
    ctx: &Context,
    params: &ObjectParams,
    mesh: &GpuMesh,
    positions: &[DVec3],
    indices: &[[u32; 3]],
    field: &MaterialField,
) -> Result<Option<TangentialPass>, Error> {
    if !params.tangential_flux || positions.len() != mesh.vertex_count() {
        return Ok(None);
    }
    let d = vertex_diffusion(field, positions, params.diffusion);
    let pass = TangentialPass::new(
        ctx,
        mesh,
        positions,
        indices,
        &d,
        tangential_factor(field.eta(), params),
    )?;
    Ok(Some(pass))
}

fn check_light_count(scene: &Scene) -> Result<(), Error> {
    if scene.lights.len() > crate::render::MAX_LIGHTS {
        return Err(invalid(
            "lights",
            format!(
                "{} lights; at most {} are supported",
                scene.lights.len(),
                crate::render::MAX_LIGHTS
            ),
        ));
    }
    Ok(())
}
