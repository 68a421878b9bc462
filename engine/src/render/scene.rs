//! What to render: a mesh with per-vertex exitance J+, lights, a camera (DESIGN section 8
//! conventions: millimetres, +Y up, right-handed, the camera looks from eye to target).

use glam::{DVec3, Mat4};

use super::RenderError;
use crate::material::fresnel;
use crate::mesh::shapes::Shape;
use crate::mesh::TriMesh;

pub use crate::solver::{Light, RadianceMode};

impl Light {
    /// The built-in scene's light: directional, from the upper left front, white irradiance 3.
    pub fn default_light() -> Light {
        Light::Directional {
            direction: DVec3::new(1.0, -1.0, -1.0).normalize(),
            irradiance: [3.0; 3],
        }
    }
}

/// A pinhole camera: `eye` looks at `target`, vertical field of view `fovy_deg`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub eye: DVec3,
    pub target: DVec3,
    pub fovy_deg: f64,
}

/// The largest camera coordinate [`Camera::validate`] accepts (mm).
pub const MAX_CAMERA_MM: f64 = 1e10;

/// The vertical fields of view [`Camera::validate`] accepts (degrees).
pub const FOVY_RANGE_DEG: std::ops::RangeInclusive<f64> = 1e-3..=179.0;

impl Camera {
    /// Frames the sphere (`centre`, `radius`) from the front, slightly above.
    pub fn framing(centre: DVec3, radius: f64, aspect: f64) -> Camera {
        let radius = radius.max(1e-3);
        let fovy_deg: f64 = 30.0;
        let half_v = (fovy_deg.to_radians() * 0.5).tan().atan();
        let half_h = ((fovy_deg.to_radians() * 0.5).tan() * aspect).atan();
        // 1.3: a margin around the silhouette.
        let distance = radius / half_v.min(half_h).sin() * 1.3;
        Camera {
            eye: centre + DVec3::new(0.0, 0.35, 1.0).normalize() * distance,
            target: centre,
            fovy_deg,
        }
    }

    pub fn validate(&self) -> Result<(), RenderError> {
        let bad = |problem: &str| {
            Err(RenderError::Invalid {
                what: "camera".into(),
                problem: problem.into(),
            })
        };
        if !self.eye.is_finite() || !self.target.is_finite() || !self.fovy_deg.is_finite() {
            return bad("values must be finite");
        }
        // The view matrix is f32: an eye at 1e300 mm is finite but renders nothing. 1e10 mm is a
        // hundred times the largest object (`mesh::SIZE_RANGE_MM`).
        if self.eye.abs().max(self.target.abs()).max_element() > MAX_CAMERA_MM {
            return bad(&format!(
                "coordinates must be within +-{MAX_CAMERA_MM:e} mm"
            ));
        }
        // The view matrix is f32: eye and target that coincide in f32 give a NaN view (found by the
        // scene_strings fuzz target, issue 17), hence a separation relative to their magnitude.
        let scale = self.eye.abs().max(self.target.abs()).max_element();
        if (self.eye - self.target).length() < 1e-9_f64.max(1e-6 * scale) {
            return bad("eye and target coincide (closer than 1e-6 of their coordinates)");
        }
        // In f32 radians a field of view near 0 or 180 degrees has a zero or negative tangent.
        if !(FOVY_RANGE_DEG.contains(&self.fovy_deg)) {
            return bad(&format!(
                "field of view must be within {} to {} degrees",
                FOVY_RANGE_DEG.start(),
                FOVY_RANGE_DEG.end()
            ));
        }
        Ok(())
    }

    /// Projection * view for Vulkan (depth 0..1, pixel (0,0) top-left) over a scene of radius
    /// `scene_radius` around `centre`.
    pub fn view_proj(&self, aspect: f64, centre: DVec3, scene_radius: f64) -> Mat4 {
        let forward = (self.target - self.eye).normalize();
        let up = if forward.cross(DVec3::Y).length() < 1e-6 {
            DVec3::Z
        } else {
            DVec3::Y
        };
        let view = Mat4::look_at_rh(self.eye.as_vec3(), self.target.as_vec3(), up.as_vec3());
        let distance = (centre - self.eye).dot(forward);
        let far = (distance + 2.0 * scene_radius).max(1e-3);
        let near = (distance - 2.0 * scene_radius).max(far * 1e-4);
        let mut proj = Mat4::perspective_rh(
            self.fovy_deg.to_radians() as f32,
            aspect as f32,
            near as f32,
            far as f32,
        );
        // Vulkan's clip space has y down; flipping here keeps +Y up on screen.
        proj.y_axis.y = -proj.y_axis.y;
        proj * view
    }
}

/// The object to render: a mesh in mm with one exitance J+ (linear RGB) per vertex.
#[derive(Clone, Debug)]
pub struct Scene {
    pub mesh: TriMesh,
    pub exitance: Vec<[f32; 3]>,
    pub lights: Vec<Light>,
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

impl Scene {
    /// A procedural shape of overall size `size_mm` (sphere: diameter; torus: outer diameter)
    /// with J+ from [`lambert_exitance`] (a light marble-like albedo).
    pub fn procedural(
        shape: &str,
        size_mm: f64,
        lights: Vec<Light>,
        eta: f64,
    ) -> Result<Scene, RenderError> {
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
        for l in &lights {
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
        let exitance = lambert_exitance(&mesh, &lights, eta, [0.85, 0.80, 0.72], 0.05);
        Ok(Scene {
            mesh,
            exitance,
            lights,
            eta,
        })
    }

    /// (centre, radius) of a sphere around the mesh: the bounding box centre and the farthest
    /// vertex from it.
    pub fn bounding_sphere(&self) -> (DVec3, f64) {
        let (lo, hi) = self.mesh.bounds();
        let centre = (lo + hi) * 0.5;
        let radius = self
            .mesh
            .positions
            .iter()
            .map(|p| p.distance(centre))
            .fold(0.0, f64::max);
        (centre, radius.max(1e-3))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
        assert!(Scene::procedural("cube", 50.0, vec![], 1.3).is_err());
        assert!(Scene::procedural("sphere", -1.0, vec![], 1.3).is_err());
        assert!(Scene::procedural("sphere", 50.0, vec![], f64::NAN).is_err());
        let zero = Light::Directional {
            direction: DVec3::ZERO,
            irradiance: [1.0; 3],
        };
        assert!(Scene::procedural("sphere", 50.0, vec![zero], 1.3).is_err());
        let cam = Camera {
            eye: DVec3::ONE,
            target: DVec3::ONE,
            fovy_deg: 40.0,
        };
        assert!(cam.validate().is_err());
        let far = Camera {
            eye: DVec3::new(0.0, 0.0, 1e300),
            target: DVec3::ZERO,
            fovy_deg: 30.0,
        };
        assert!(far.validate().is_err(), "an eye at 1e300 mm is refused");
    }

    #[test]
    fn framing_puts_the_whole_object_inside_the_view() {
        let scene =
            Scene::procedural("torus", 50.0, vec![Light::default_light()], 1.3).expect("scene");
        for aspect in [0.5, 1.0, 2.0] {
            let (c, r) = scene.bounding_sphere();
            let cam = Camera::framing(c, r, aspect);
            let vp = cam.view_proj(aspect, c, r);
            for p in &scene.mesh.positions {
                let clip = vp * p.as_vec3().extend(1.0);
                let ndc = clip.truncate() / clip.w;
                assert!(
                    ndc.x.abs() <= 1.0 && ndc.y.abs() <= 1.0 && (0.0..=1.0).contains(&ndc.z),
                    "{ndc:?}"
                );
            }
        }
    }
}
