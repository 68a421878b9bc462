//! [`GpuFrame`]: the whole QuadGraph frame of DESIGN section 5 on the GPU, for hosts and the CLI:
//! shadow maps of the shadow-casting lights and the irradiance gather (part B's
//! `render::shadow_maps` / `render::irradiance`) writing q into the solve's per-level q images,
//! then the [`GpuDiffusion`] solve, in one command buffer.
//!
//! ```no_run
//! # use translucent::solver::gpu::{GpuFrame, GpuSolveParams};
//! # use translucent::render::{GpuMesh, HeadlessRenderer};
//! # fn f(ctx: &translucent::vk::Context, graph: &translucent::QuadGraph,
//! #      field: &translucent::material::MaterialField, scene: &translucent::solver::Scene,
//! #      renderer: &mut HeadlessRenderer) -> Result<(), translucent::Error> {
//! let mut frame = GpuFrame::new(ctx, graph, field, scene, &GpuSolveParams::default())?;
//! frame.solve.bind_mesh(ctx, renderer.mesh())?; // J+ lands in the displayed mesh's vertices
//! // The shadow caster: the displayed surface (its exitance is not read by the depth pass).
//! let caster = GpuMesh::new(ctx, &graph.surface, &vec![[0.0; 3]; graph.surface.positions.len()])?;
//! let mut failed = None;
//! let captured = renderer.render_frame_after(ctx, |cb, profiler| {
//!     // SAFETY: `cb` is recording; `frame` and `caster` outlive the waited frame.
//!     failed = unsafe { frame.record(ctx, cb, &caster, Some(profiler)) }.err();
//! })?;
//! if let Some(e) = failed { return Err(e); }
//! let report = frame.report(ctx, graph, field, scene, None, &GpuSolveParams::default())?;
//! # Ok(()) }
//! ```

use ash::vk;

use super::{GpuDiffusion, GpuSolveParams};
use crate::material::MaterialField;
use crate::render::{
    level_bounds, q_scale_for, GatherLevel, GatherScene, GpuMesh, IrradiancePass, ShadowMaps,
    ShadowMapsDesc, MAX_SHADOW_VIEWS,
};
use crate::solver::cpu::Energy;
use crate::solver::operator::LevelOperator;
use crate::solver::Scene;
use crate::vk::{Access, Context, GpuProfiler};
use crate::{Error, QuadGraph};

/// Shadow maps + irradiance gather + GPU solve of one object.
pub struct GpuFrame {
    pub solve: GpuDiffusion,
    shadows: ShadowMaps,
    gather: IrradiancePass,
    levels: Vec<GatherLevel>,
    uniforms: GatherScene,
    q_scale: f32,
    eta: f32,
    /// Bounding sphere of the finest level's nodes (centre, radius in mm): the shadow views' fit.
    bounds: (glam::DVec3, f64),
    /// The scene of the last `set_lights` (a deformation refits its shadow views).
    scene: Scene,
}

/// What [`GpuFrame::report`] computes on the CPU from the GPU's finest-level phi.
#[derive(Clone, Debug)]
pub struct GpuFrameReport {
    /// Relative residual per channel, ||S (b - A phi)|| / ||S b|| (b from the f64 reference q).
    pub residual: [f64; 3],
    pub energy: Energy,
    /// Surface nodes clamped at J+ = 0 per channel (the GPU counter).
    pub clamped: [u32; 3],
    /// Iterations run per level (the GPU counter).
    pub iterations: Vec<u32>,
}

impl GpuFrame {
    /// Builds the solve (textures of every level), the shadow maps for `scene`'s lights and the
    /// gather bound to the solve's q images. The exposure is `render::q_scale_for` of the finest
    /// level (the largest unshadowed q maps to 2048).
    pub fn new(
        ctx: &Context,
        graph: &QuadGraph,
        field: &MaterialField,
        scene: &Scene,
        params: &GpuSolveParams,
    ) -> Result<Self, Error> {
        let mut solve = GpuDiffusion::new(ctx, graph, field, params)?;
        let eta = field.eta();
        let q_scale = q_scale_for(scene, graph.finest(), eta);
        solve.set_q_scale(q_scale);
        let mut shadows = ShadowMaps::new(
            ctx,
            &ShadowMapsDesc {
                max_views: MAX_SHADOW_VIEWS as u32,
                ..ShadowMapsDesc::default()
            },
        )?;
        let bounds = level_bounds(graph.finest());
        shadows.set_lights(&scene.lights, bounds, true)?;
        let gather = IrradiancePass::new(ctx, graph.levels.len() as u32)?;
        let mut levels = Vec::with_capacity(graph.levels.len());
        for h in 0..graph.levels.len() {
            let missing = || Error::Solver(super::SolverError::EmptyGraph);
            levels.push(gather.bind_level(
                ctx,
                &shadows,
                solve.surface_position(h).ok_or_else(missing)?,
                solve.surface_normal(h).ok_or_else(missing)?,
                solve.q_image(h).ok_or_else(missing)?,
                solve.surface_rows(h).ok_or_else(missing)?,
            )?);
        }
        let uniforms = GatherScene::new(scene, &shadows)?;
        Ok(Self {
            solve,
            shadows,
            gather,
            levels,
            uniforms,
            q_scale,
            eta: eta as f32,
            bounds,
            scene: scene.clone(),
        })
    }

    /// New lights and environment for the next [`GpuFrame::record`]: refits the shadow views and
    /// rewrites the gather's scene. The exposure stays unless the new scene's brightest q leaves
    /// the fp16-safe band around it (a factor of 4 either way), so a light moving a little keeps
    /// the last solution usable as a warm start. A bad scene is a typed error and leaves the
    /// previous one in place.
    pub fn set_lights(&mut self, graph: &QuadGraph, scene: &Scene) -> Result<(), Error> {
        let previous = (
            self.shadows.views().to_vec(),
            self.shadows.light_views().to_vec(),
        );
        self.shadows.set_lights(&scene.lights, self.bounds, true)?;
        let uniforms = match GatherScene::new(scene, &self.shadows) {
            Ok(u) => u,
            Err(e) => {
                self.shadows.restore(previous);
                return Err(e.into());
            }
        };
        self.uniforms = uniforms;
        self.scene = scene.clone();
        let wanted = q_scale_for(scene, graph.finest(), f64::from(self.eta));
        let ratio = wanted / self.q_scale;
        if !(0.25..=4.0).contains(&ratio) {
            self.q_scale = wanted;
            self.solve.set_q_scale(wanted);
        }
        Ok(())
    }

    /// The exposure q and phi are stored at (see [`GpuDiffusion::q_scale`]).
    pub fn q_scale(&self) -> f32 {
        self.q_scale
    }

    /// Whether the current lights cast any shadow (otherwise the frame records no shadow pass).
    pub fn casts_shadows(&self) -> bool {
        self.shadows.any_shadows()
    }

    /// Records shadow maps (cast by `caster`, the displayed mesh), the gather of every level and
    /// the solve.
    ///
    /// # Safety
    /// `cb` must be recording outside a rendering scope; `self` and `caster` must outlive its
    /// execution.
    pub unsafe fn record(
        &mut self,
        ctx: &Context,
        cb: vk::CommandBuffer,
        caster: &GpuMesh,
        mut profiler: Option<&mut GpuProfiler>,
    ) -> Result<(), Error> {
        // SAFETY: the caller's contract.
        unsafe {
            // Staged material and deformation edits first: the shadow pass draws the deformed
            // caster, the gather reads the deformed surface nodes.
            self.solve.record_edits(ctx, cb, profiler.as_deref_mut());
            self.shadows
                .record(ctx, cb, caster, profiler.as_deref_mut());
            self.gather.record_scene(ctx, cb, &self.uniforms);
            for (h, level) in self.levels.iter().enumerate() {
                let Some(q) = self.solve.q_image(h) else {
                    continue;
                };
                // q stays in GENERAL between frames; the solve's first barrier orders its reads.
                self.gather.record(
                    ctx,
                    cb,
                    level,
                    &self.shadows,
                    q,
                    Access::ComputeReadWrite,
                    self.q_scale,
                    self.eta,
                    profiler.as_deref_mut(),
                )?;
            }
            self.solve.record(ctx, cb, profiler);
        }
        Ok(())
    }

    /// Headless, after the frame completed: residual and energy of the finest level from the GPU's
    /// phi, computed in f64 with the reference's q (`Scene::surface_irradiance` with `occluder`),
    /// which the gathered q approximates (fp16, shadow maps instead of rays).
    pub fn report(
        &self,
        ctx: &Context,
        graph: &QuadGraph,
        field: &MaterialField,
        scene: &Scene,
        occluder: Option<&dyn crate::mesh::Solid>,
        params: &GpuSolveParams,
    ) -> Result<GpuFrameReport, Error> {
        let level = graph.finest();
        let op = LevelOperator::build(level, field, params.scheme)?;
        let q = scene.surface_irradiance(level, field.eta(), occluder);
        let b = op.rhs(&q);
        let phi: Vec<[f64; 3]> = self
            .solve
            .read_phi(ctx, graph.levels.len() - 1)?
            .iter()
            .map(|p| p.map(f64::from))
            .collect();
        let residual = op.residual(&phi, &b);
        let inner = level.inner_count();
        let mut energy = Energy::default();
        for s in 0..level.surface_count() {
            for c in 0..3 {
                let j = (1.0 + 1.0 / op.a) * phi[inner + s][c] / 4.0 - q[s][c] / (1.0 + op.f_dr);
                energy.transmitted_input[c] += q[s][c] * op.areas[s];
                energy.exitance[c] += (1.0 - op.f_dr) * j * op.areas[s];
            }
        }
        for ((mu, p), v) in op.mu.iter().zip(&phi[..inner]).zip(&op.volumes) {
            for c in 0..3 {
                energy.absorbed[c] += mu[c] * p[c] * v;
            }
        }
        Ok(GpuFrameReport {
            residual,
            energy,
            clamped: self.solve.clamped(ctx)?,
            iterations: self.solve.iterations_run(ctx)?,
        })
    }
}

/// Hooks of the live edits (`edit.rs`, branch gpuedit).
impl GpuFrame {
    /// The gather's eta after a material edit.
    pub(super) fn set_eta(&mut self, eta: f64) {
        self.eta = eta as f32;
    }

    /// The bounding sphere (centre, radius in mm) the shadow views are fitted to.
    pub fn shadow_bounds(&self) -> (glam::DVec3, f64) {
        self.bounds
    }

    /// Refits the shadow views to a deformed object's bounding sphere.
    pub(super) fn refit_bounds(&mut self, bounds: (glam::DVec3, f64)) -> Result<(), Error> {
        self.shadows.set_lights(&self.scene.lights, bounds, true)?;
        self.uniforms = GatherScene::new(&self.scene, &self.shadows)?;
        self.bounds = bounds;
        Ok(())
    }
}
