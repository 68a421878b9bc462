//! Headless rendering through the one frame composition ([`crate::TranslucentObject`]):
//! [`HeadlessHost`] is a minimal host (its own colour target, one command buffer per frame,
//! submit, wait, read back), [`HeadlessRenderer`] renders a mesh with given per-vertex exitance
//! (the CPU reference's output, test fixtures) through the same object, with the
//! [`crate::frame::FixedExitance`] method.
//!
//! ```no_run
//! use translucent::headless::{ExitanceMesh, FrameDesc, HeadlessRenderer};
//! use translucent::scene::{Environment, Light, Scene};
//! use translucent::vk::{Context, ContextDesc};
//! # fn main() -> Result<(), translucent::Error> {
//! let ctx = Context::headless(&ContextDesc::default())?;
//! let scene = Scene { lights: vec![Light::default_light()], environment: Environment::None };
//! let mesh = ExitanceMesh::procedural("sphere", 50.0, &scene.lights, 1.3)?;
//! // mesh.exitance = solver_output; // one [r, g, b] J+ per vertex of mesh.mesh
//! let mut renderer = HeadlessRenderer::new(&ctx, &mesh, &scene, &FrameDesc::default())?;
//! let frame = renderer.render_frame(&ctx)?;
//! println!("{:?}", frame.passes); // {"capture": .., "shading": .., "shadow_map": ..}
//! frame.image.write_exr(std::path::Path::new("sphere.exr"))?;
//! # Ok(()) }
//! ```

use glam::DVec3;
use std::collections::BTreeMap;

use crate::material::{fresnel, Material, MaterialField};
use crate::mesh::shapes::Shape;
use crate::mesh::TriMesh;
use crate::object::{MethodDesc, ObjectParams, RecordCtx, TargetImage, Targets};
use crate::render::{OffscreenTarget, RenderError};
use crate::scene::{Camera, ExitLobe, Light, RadianceMode, Scene};
use crate::vk::{Access, Context, FrameTimings, GpuProfiler, ImageReadback, LinearImage};
use crate::{Error, FrameReport, TranslucentObject};

/// One rendered frame.
#[derive(Clone, Debug)]
pub struct Captured {
    /// Linear radiance, row 0 at the top; background 0.
    pub image: LinearImage,
    /// GPU milliseconds per pass of this frame (absent: skipped, or no timestamps on the device).
    pub passes: BTreeMap<String, f64>,
    /// The frame's timestamp scopes (for [`crate::vk::FrameTimings::chrome_trace`]).
    pub timings: Option<FrameTimings>,
    pub frame: u64,
}

/// A mesh in mm with one exitance J+ (linear RGB) per vertex, seen through an interface of index
/// ratio `eta`: what [`HeadlessRenderer`] draws.
#[derive(Clone, Debug)]
pub struct ExitanceMesh {
    pub mesh: TriMesh,
    pub exitance: Vec<[f32; 3]>,
    /// Relative index of refraction n_inside / n_outside.
    pub eta: f64,
}

/// Per-frame settings.
#[derive(Clone, Debug)]
pub struct FrameDesc {
    pub width: u32,
    pub height: u32,
    /// `None`: framed automatically.
    pub camera: Option<Camera>,
    pub radiance: RadianceMode,
    /// The angular shape of the exit radiance (`--exit-lobe`).
    pub exit_lobe: ExitLobe,
    /// Cook-Torrance specular of the first directional light (shadowed by its depth map).
    pub specular: bool,
    /// GGX roughness (alpha = roughness^2).
    pub roughness: f32,
}

impl Default for FrameDesc {
    fn default() -> Self {
        FrameDesc {
            width: 512,
            height: 512,
            camera: None,
            radiance: RadianceMode::Physical,
            exit_lobe: ExitLobe::default(),
            specular: true,
            roughness: 0.35,
        }
    }
}

/// A stand-in for the diffusion solver: J+ per vertex from the lights, as if every point were a
/// Lambertian reflector of `albedo` inside a medium of index `eta` (exitance `(1 - F_dr) J+ =
/// albedo q`), plus a constant environment of radiance `ambient`. Shadows are ignored.
/// q = sum over lights of E max(0, n.l) F_t(eta, theta_l), plus pi L (1 - F_dr,ext) for the
/// environment (DESIGN section 2).
pub fn lambert_exitance(
    mesh: &TriMesh,
    lights: &[Light],
    eta: f64,
    albedo: [f64; 3],
    ambient: f64,
) -> Vec<[f32; 3]> {
    let f_dr = fresnel::diffuse_reflectance(eta);
    let q_env = std::f64::consts::PI * ambient * (1.0 - fresnel::external_diffuse_reflectance(eta));
    mesh.positions
        .iter()
        .zip(&mesh.normals)
        .map(|(&p, &n)| {
            let mut q = [q_env; 3];
            for light in lights {
                let (e, l, _) = light.arriving(p);
                let cos = n.dot(l);
                if cos > 0.0 {
                    let t = fresnel::transmittance(eta, cos);
                    for c in 0..3 {
                        q[c] += e[c] * cos * t;
                    }
                }
            }
            std::array::from_fn(|c| {
                let j = albedo[c] * q[c] / (1.0 - f_dr);
                if j.is_finite() {
                    j.max(0.0) as f32
                } else {
                    0.0
                }
            })
        })
        .collect()
}

impl ExitanceMesh {
    /// A procedural shape of overall size `size_mm` (sphere: diameter; torus: outer diameter)
    /// with J+ from [`lambert_exitance`] (a light marble-like albedo) under `lights`.
    pub fn procedural(
        shape: &str,
        size_mm: f64,
        lights: &[Light],
        eta: f64,
    ) -> Result<ExitanceMesh, RenderError> {
        if !(size_mm.is_finite() && size_mm > 0.0) {
            return Err(RenderError::Invalid {
                what: "size".into(),
                problem: format!("{size_mm} mm is not a positive size"),
            });
        }
        if !(eta.is_finite() && eta > 0.0) {
            return Err(RenderError::Invalid {
                what: "eta".into(),
                problem: format!("{eta} is not a positive index ratio"),
            });
        }
        for l in lights {
            l.validate()?;
        }
        let mesh = match shape {
            "sphere" => Shape::Sphere {
                radius: 0.5 * size_mm,
            }
            .triangulate(64),
            "torus" => Shape::Torus {
                major: 0.35 * size_mm,
                minor: 0.15 * size_mm,
            }
            .triangulate(48),
            other => {
                return Err(RenderError::Invalid {
                    what: "shape".into(),
                    problem: format!("unknown shape {other:?} (sphere, torus)"),
                })
            }
        };
        let exitance = lambert_exitance(&mesh, lights, eta, [0.85, 0.80, 0.72], 0.05);
        Ok(ExitanceMesh {
            mesh,
            exitance,
            eta,
        })
    }

    /// (centre, radius) of a sphere around the mesh: the bounding box centre and the farthest
    /// vertex from it.
    pub fn bounding_sphere(&self) -> (DVec3, f64) {
        crate::mesh::bounding_sphere(&self.mesh.positions)
    }
}

/// Renders a mesh with given exitance through a [`TranslucentObject`] and a [`HeadlessHost`],
/// as a host would (shadow maps for the specular term, shading, capture).
pub struct HeadlessRenderer {
    object: TranslucentObject,
    host: HeadlessHost,
}

impl HeadlessRenderer {
    /// The object for `mesh` lit by `scene` (its lights for the specular term and its shadow,
    /// its environment for the mirror reflection) framed by `frame`.
    pub fn new(
        ctx: &Context,
        mesh: &ExitanceMesh,
        scene: &Scene,
        frame: &FrameDesc,
    ) -> Result<HeadlessRenderer, Error> {
        let params = ObjectParams {
            specular: frame.specular,
            roughness: frame.roughness,
            radiance: frame.radiance,
            exit_lobe: frame.exit_lobe,
            // why: the exitance is given: no solve, and no single scattering (its material
            // here is a stand-in).
            ..ObjectParams::base()
        };
        // Only `eta` reaches the shading from the material here: the exitance is given.
        let field = MaterialField::Homogeneous(Material::new([1.0; 3], [0.0; 3], mesh.eta)?);
        let mut object = TranslucentObject::with_method(
            ctx,
            MethodDesc::Exitance {
                mesh: mesh.mesh.clone(),
                exitance: mesh.exitance.clone(),
            },
            &field,
            scene,
            &params,
        )?;
        object.set_camera(frame.camera)?;
        let host = HeadlessHost::new(ctx, frame.width, frame.height)?;
        Ok(HeadlessRenderer { object, host })
    }

    /// Replaces the per-vertex exitance J+ (one per vertex of the mesh), drawn from the next frame.
    pub fn set_exitance(&mut self, ctx: &Context, exitance: &[[f32; 3]]) -> Result<(), Error> {
        self.object.set_exitance(ctx, exitance)
    }

    /// The per-node exit lobe's diffused share per vertex (one per vertex of the mesh, in
    /// [0, 1]), read from the next frame on by [`ExitLobe::Node`].
    pub fn set_diffused_share(&mut self, ctx: &Context, share: &[f32]) -> Result<(), Error> {
        self.object.set_diffused_share(ctx, share)
    }

    /// Renders one frame, waits for it and reads it back.
    pub fn render_frame(&mut self, ctx: &Context) -> Result<Captured, Error> {
        Ok(self.host.render(ctx, &mut self.object)?.0)
    }

    /// The object (display mesh, camera).
    pub fn object(&mut self) -> &mut TranslucentObject {
        &mut self.object
    }
}

/// Renders `mesh` under `scene` once, headless.
///
/// ```no_run
/// use translucent::headless::{render_headless, ExitanceMesh, FrameDesc};
/// use translucent::scene::{Environment, Light, Scene};
/// # fn f(ctx: &translucent::vk::Context) -> Result<(), translucent::Error> {
/// let scene = Scene { lights: vec![Light::default_light()], environment: Environment::None };
/// let mesh = ExitanceMesh::procedural("sphere", 50.0, &scene.lights, 1.3)?;
/// let captured = render_headless(ctx, &mesh, &scene, &FrameDesc::default())?;
/// captured.image.write_png(std::path::Path::new("sphere.png"), 1.0)?;
/// # Ok(()) }
/// ```
pub fn render_headless(
    ctx: &Context,
    mesh: &ExitanceMesh,
    scene: &Scene,
    frame: &FrameDesc,
) -> Result<Captured, Error> {
    HeadlessRenderer::new(ctx, mesh, scene, frame)?.render_frame(ctx)
}

/// A minimal host for a [`crate::TranslucentObject`]: owns a colour target, and per frame clears
/// it to black, lets the object record into the same command buffer exactly as into a host's
/// (colour handed over from a transfer clear, our own depth), submits, waits and reads back.
///
/// ```no_run
/// # fn f(ctx: &translucent::vk::Context, object: &mut translucent::TranslucentObject)
/// #      -> Result<(), translucent::Error> {
/// let mut host = translucent::headless::HeadlessHost::new(ctx, 64, 64)?;
/// let (captured, report) = host.render(ctx, object)?; // first frame: solves
/// let (_, report) = host.render(ctx, object)?; // nothing changed: shading only
/// assert!(report.skipped.contains_key("diffusion"));
/// # Ok(()) }
/// ```
pub struct HeadlessHost {
    target: OffscreenTarget,
    readback: ImageReadback,
    profiler: GpuProfiler,
}

impl HeadlessHost {
    pub fn new(ctx: &Context, width: u32, height: u32) -> Result<HeadlessHost, RenderError> {
        if width == 0 || height == 0 {
            return Err(RenderError::Invalid {
                what: "target".into(),
                problem: format!("{width}x{height} has no pixels"),
            });
        }
        let target = OffscreenTarget::new(ctx, width, height)?;
        let readback = ImageReadback::new(ctx, &target.color)?;
        // Room for a whole solve (scopes per Jacobi block) per frame.
        let profiler = GpuProfiler::new(ctx, "headless host frame", 4096)?;
        Ok(HeadlessHost {
            target,
            readback,
            profiler,
        })
    }

    /// Renders one frame of `object`, waits, reads back.
    pub fn render(
        &mut self,
        ctx: &Context,
        object: &mut TranslucentObject,
    ) -> Result<(Captured, FrameReport), Error> {
        use ash::vk;
        let mut result = None;
        let submission = ctx.submit("headless host frame", |cb| {
            let (frame, completed) = ctx.frames();
            let p = &mut self.profiler;
            let color = &self.target.color;
            // SAFETY: `cb` is recording; the target, read-back and `object` outlive the waited
            // submission.
            unsafe {
                p.begin_frame(cb, frame);
                // why: the clear overwrites what the last frame's capture read (WAR), in
                // TRANSFER_DST layout.
                crate::vk::barrier::image(
                    ctx,
                    cb,
                    color,
                    self.target.color_state,
                    Access::TransferDst,
                );
                ctx.raw().cmd_clear_color_image(
                    cb,
                    color.raw,
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                    &vk::ClearColorValue { float32: [0.0; 4] },
                    &[vk::ImageSubresourceRange {
                        aspect_mask: vk::ImageAspectFlags::COLOR,
                        base_mip_level: 0,
                        level_count: 1,
                        base_array_layer: 0,
                        layer_count: 1,
                    }],
                );
                let targets = Targets {
                    color: TargetImage {
                        image: color.raw,
                        view: color.view,
                        format: color.format,
                        extent: color.extent(),
                        before: Access::TransferDst.into(),
                        after: Access::TransferSrc.into(),
                    },
                    depth: None,
                    host_barriers: false,
                };
                let report = object.record(
                    &mut RecordCtx {
                        ctx,
                        cb,
                        frame,
                        completed_frame: completed,
                        profiler: Some(p),
                    },
                    &targets,
                );
                let ok = report.is_ok();
                result = Some(report);
                if ok {
                    p.begin_scope(cb, "capture");
                    self.readback.record(ctx, cb, color, Access::TransferSrc);
                    p.end_scope(cb);
                }
            }
            Ok(())
        })?;
        let frame = submission.frame();
        submission.wait()?;
        self.target.color_state = Access::TransferSrc;
        self.profiler.frame_completed(frame);
        let report = result.ok_or_else(|| RenderError::Invalid {
            what: "frame".into(),
            problem: "not recorded".into(),
        })??;
        let timings = self.profiler.latest().filter(|t| t.frame == frame).cloned();
        let passes = timings.as_ref().map(|t| t.passes()).unwrap_or_default();
        let image = self.readback.read()?;
        Ok((
            Captured {
                image,
                passes,
                timings,
                frame,
            },
            report,
        ))
    }

    /// Solves that completed by the last waited frame (their iterations), for the last frame's
    /// report: a frame's own solve is only known once it completed.
    pub fn completed_solves(
        &self,
        ctx: &Context,
        object: &mut TranslucentObject,
    ) -> Result<Vec<crate::frame::CompletedSolve>, Error> {
        object.completed_solves(ctx.frames().1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::fresnel;

    #[test]
    fn lambert_exitance_integrates_to_albedo_times_transmitted_irradiance() {
        let mesh = Shape::Sphere { radius: 10.0 }.triangulate(16);
        let light = Light::Directional {
            direction: -DVec3::Y,
            irradiance: [2.0, 1.0, 0.0],
        };
        let eta = 1.3;
        let j = lambert_exitance(&mesh, &[light], eta, [0.5; 3], 0.0);
        let top = mesh
            .positions
            .iter()
            .position(|p| p.y > 9.99)
            .expect("pole");
        let f_dr = fresnel::diffuse_reflectance(eta);
        let expected = 0.5 * 2.0 * fresnel::transmittance(eta, 1.0) / (1.0 - f_dr);
        assert!((f64::from(j[top][0]) - expected).abs() < 1e-5);
        assert_eq!(j[top][2], 0.0);
        let bottom = mesh
            .positions
            .iter()
            .position(|p| p.y < -9.99)
            .expect("pole");
        assert_eq!(j[bottom], [0.0; 3]);
        assert!(j.iter().flatten().all(|v| v.is_finite() && *v >= 0.0));
    }

    #[test]
    fn bad_scene_input_is_a_typed_error() {
        assert!(ExitanceMesh::procedural("cube", 50.0, &[], 1.3).is_err());
        assert!(ExitanceMesh::procedural("sphere", -1.0, &[], 1.3).is_err());
        assert!(ExitanceMesh::procedural("sphere", 50.0, &[], f64::NAN).is_err());
        let zero = Light::Directional {
            direction: DVec3::ZERO,
            irradiance: [1.0; 3],
        };
        assert!(ExitanceMesh::procedural("sphere", 50.0, &[zero], 1.3).is_err());
    }
}
