//! The camera (DESIGN section 8 conventions: millimetres, +Y up, right-handed, the camera looks
//! from eye to target with vertical field of view FOVY, pixel (0,0) top-left).
//!
//! ```
//! use translucent::scene::Camera;
//! let camera = Camera { eye: glam::DVec3::new(0.0, 20.0, 60.0), target: glam::DVec3::ZERO, fovy_deg: 30.0 };
//! camera.validate()?;
//! let view_proj = camera.view_proj(1.0, glam::DVec3::ZERO, 10.0); // f32 matrix for the shaders
//! # let _ = view_proj;
//! # Ok::<(), translucent::scene::SceneError>(())
//! ```

use glam::{DVec3, Mat4};

use super::SceneError;

/// A pinhole camera: `eye` looks at `target`, vertical field of view `fovy_deg`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub eye: DVec3,
    pub target: DVec3,
    pub fovy_deg: f64,
}

/// The largest camera coordinate [`Camera::validate`] accepts (mm).
pub const MAX_CAMERA_MM: f64 = 1e10;

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

    pub fn validate(&self) -> Result<(), SceneError> {
        let bad = |problem: &str| {
            Err(SceneError::Invalid {
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
        if (self.eye - self.target).length() < 1e-9 {
            return bad("eye and target coincide");
        }
        if !(self.fovy_deg > 0.0 && self.fovy_deg < 180.0) {
            return bad("field of view must be in (0, 180) degrees");
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::shapes::Shape;

    #[test]
    fn bad_cameras_are_typed_errors() {
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
        let mesh = Shape::Torus {
            major: 17.5,
            minor: 7.5,
        }
        .triangulate(48);
        let (c, r) = crate::mesh::bounding_sphere(&mesh.positions);
        for aspect in [0.5, 1.0, 2.0] {
            let cam = Camera::framing(c, r, aspect);
            let vp = cam.view_proj(aspect, c, r);
            for p in &mesh.positions {
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
