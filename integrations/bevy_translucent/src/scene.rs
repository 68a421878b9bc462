//! Bevy's lights and cameras as our scene (`translucent::scene`), in the object's frame and in mm.
//!
//! Units: Bevy lengths times [`Units::mm_per_unit`]; a directional light's `illuminance` (lux), a
//! point or spot light's luminous intensity (`intensity` lumens / 4 pi, as Bevy's own shading reads
//! them) and the ambient light's `brightness` times their linear colour times
//! [`Units::light_scale`] give our irradiance, intensity and constant radiance. Only translation
//! moves the object: its rotation and scale are not applied (a QuadGraph is baked at one size,
//! in its own frame).

use std::f64::consts::PI;

use bevy::color::{Color, LinearRgba};
use bevy::math::{Mat4, Vec3};
use bevy::transform::components::GlobalTransform;
use glam::DVec3;
use translucent::scene::{Camera, Light};

/// How Bevy's quantities become ours (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Units {
    /// Millimetres per Bevy length unit.
    pub mm_per_unit: f64,
    /// Our irradiance per lux, intensity per candela, radiance per ambient brightness unit.
    pub light_scale: f64,
}

impl Default for Units {
    fn default() -> Self {
        Units {
            mm_per_unit: 1.0,
            light_scale: 1.0,
        }
    }
}

/// Why a Bevy camera or light cannot feed our scene.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SceneError {
    #[error("an orthographic camera: translucent draws through a pinhole (perspective) camera")]
    Orthographic,
    #[error("a {what} at a non-finite place or direction")]
    NotFinite { what: &'static str },
}

fn colour(c: Color, scale: f64) -> [f64; 3] {
    let LinearRgba {
        red, green, blue, ..
    } = c.to_linear();
    [red, green, blue].map(|v| f64::from(v) * scale)
}

fn dvec(v: Vec3) -> DVec3 {
    v.as_dvec3()
}

/// A light in the world, in mm (not yet in an object's frame): [`WorldLight::in_object`].
#[derive(Clone, Debug, PartialEq)]
pub struct WorldLight(pub Light);

impl WorldLight {
    /// `DirectionalLight { color, illuminance }`: travelling along the transform's forward (-Z).
    pub fn directional(
        color: Color,
        illuminance: f32,
        at: &GlobalTransform,
        units: &Units,
    ) -> Result<WorldLight, SceneError> {
        let direction = dvec(*at.forward());
        finite("directional light", direction)?;
        Ok(WorldLight(Light::Directional {
            direction,
            irradiance: colour(color, f64::from(illuminance) * units.light_scale),
        }))
    }

    /// `PointLight { color, intensity }` (lumens) at the transform's translation.
    pub fn point(
        color: Color,
        lumens: f32,
        at: &GlobalTransform,
        units: &Units,
    ) -> Result<WorldLight, SceneError> {
        let position = dvec(at.translation()) * units.mm_per_unit;
        finite("point light", position)?;
        Ok(WorldLight(Light::Point {
            position,
            intensity: colour(color, candela(lumens) * units.light_scale),
        }))
    }

    /// `SpotLight { color, intensity, inner_angle, outer_angle }` (lumens, half-angles in radians)
    /// at the transform's translation, pointing along its forward (-Z).
    pub fn spot(
        color: Color,
        lumens: f32,
        inner_angle: f32,
        outer_angle: f32,
        at: &GlobalTransform,
        units: &Units,
    ) -> Result<WorldLight, SceneError> {
        let position = dvec(at.translation()) * units.mm_per_unit;
        let direction = dvec(*at.forward());
        finite("spot light", position)?;
        finite("spot light", direction)?;
        Ok(WorldLight(Light::Spot {
            position,
            direction,
            intensity: colour(color, candela(lumens) * units.light_scale),
            inner_deg: f64::from(inner_angle).to_degrees(),
            outer_deg: f64::from(outer_angle).to_degrees(),
        }))
    }

    /// The light in the frame of an object whose origin is at `origin_mm` (world mm).
    pub fn in_object(&self, origin_mm: DVec3) -> Light {
        match self.0 {
            Light::Point {
                position,
                intensity,
            } => Light::Point {
                position: position - origin_mm,
                intensity,
            },
            Light::Spot {
                position,
                direction,
                intensity,
                inner_deg,
                outer_deg,
            } => Light::Spot {
                position: position - origin_mm,
                direction,
                intensity,
                inner_deg,
                outer_deg,
            },
            directional => directional,
        }
    }
}

/// Bevy's point and spot lights spread their lumens over the whole sphere (4 pi sr).
fn candela(lumens: f32) -> f64 {
    f64::from(lumens) / (4.0 * PI)
}

/// The ambient light (`GlobalAmbientLight { color, brightness }`) as our constant radiance.
pub fn ambient(color: Color, brightness: f32, units: &Units) -> [f64; 3] {
    colour(color, f64::from(brightness) * units.light_scale)
}

fn finite(what: &'static str, v: DVec3) -> Result<(), SceneError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(SceneError::NotFinite { what })
    }
}

/// A Bevy view (`ExtractedView`'s `world_from_view` and perspective `clip_from_view`) as our
/// camera in the frame of an object at `origin_mm`. Our camera keeps +Y up (no roll); its target
/// is one object-radius ahead of the eye (only its direction matters).
pub fn camera(
    world_from_view: &GlobalTransform,
    clip_from_view: &Mat4,
    origin_mm: DVec3,
    units: &Units,
) -> Result<Camera, SceneError> {
    // Bevy's perspective (infinite reverse z): w = -z_view, so w_axis.w = 0; orthographic: 1.
    if clip_from_view.w_axis.w != 0.0 {
        return Err(SceneError::Orthographic);
    }
    // Its y_axis.y is f = 1 / tan(fovy / 2).
    let fovy = 2.0 * (1.0 / f64::from(clip_from_view.y_axis.y)).atan();
    let eye = dvec(world_from_view.translation()) * units.mm_per_unit - origin_mm;
    let forward = dvec(*world_from_view.forward());
    finite("camera", eye)?;
    finite("camera", forward)?;
    Ok(Camera {
        eye,
        target: eye + forward,
        fovy_deg: fovy.to_degrees(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy::camera::{CameraProjection, PerspectiveProjection};
    use bevy::transform::components::Transform;

    #[test]
    fn a_bevy_perspective_camera_becomes_ours_with_its_field_of_view_and_look_direction() {
        let projection = PerspectiveProjection {
            fov: 30f32.to_radians(),
            aspect_ratio: 4.0 / 3.0,
            ..Default::default()
        };
        let at = GlobalTransform::from(
            Transform::from_xyz(0.0, 20.0, 60.0).looking_at(Vec3::ZERO, Vec3::Y),
        );
        let units = Units {
            mm_per_unit: 2.0,
            light_scale: 1.0,
        };
        let c = camera(
            &at,
            &projection.get_clip_from_view(),
            DVec3::new(0.0, 10.0, 0.0),
            &units,
        )
        .unwrap();
        assert!((c.fovy_deg - 30.0).abs() < 1e-4, "{}", c.fovy_deg);
        assert!(
            c.eye.distance(DVec3::new(0.0, 30.0, 120.0)) < 1e-4,
            "{:?}",
            c.eye
        );
        // The object is at (0, 10, 0) mm, the camera looks at the world origin: (0, -10, 0) here.
        let looking = (c.target - c.eye).normalize();
        let expected = (DVec3::new(0.0, -20.0, -60.0)).normalize();
        assert!(looking.distance(expected) < 1e-5, "{looking:?}");
    }

    #[test]
    fn an_orthographic_camera_is_refused() {
        let ortho = Mat4::orthographic_rh(-1.0, 1.0, -1.0, 1.0, 0.1, 10.0);
        assert_eq!(
            camera(
                &GlobalTransform::IDENTITY,
                &ortho,
                DVec3::ZERO,
                &Units::default()
            ),
            Err(SceneError::Orthographic)
        );
    }

    #[test]
    fn lights_convert_their_photometric_units_and_move_into_the_object_frame() {
        let units = Units {
            mm_per_unit: 10.0,
            light_scale: 0.5,
        };
        let down = GlobalTransform::from(
            Transform::from_xyz(1.0, 2.0, 3.0).looking_to(Vec3::NEG_Y, Vec3::Z),
        );
        let WorldLight(Light::Directional {
            direction,
            irradiance,
        }) = WorldLight::directional(Color::WHITE, 8.0, &down, &units).unwrap()
        else {
            panic!("directional")
        };
        assert!(direction.distance(DVec3::NEG_Y) < 1e-6);
        assert_eq!(irradiance, [4.0; 3]);
        let point = WorldLight::point(Color::WHITE, 4.0 * PI as f32, &down, &units).unwrap();
        let Light::Point {
            position,
            intensity,
        } = point.in_object(DVec3::new(10.0, 0.0, 0.0))
        else {
            panic!("point")
        };
        assert!(position.distance(DVec3::new(0.0, 20.0, 30.0)) < 1e-4);
        assert!((intensity[0] - 0.5).abs() < 1e-6, "{intensity:?}");
        let spot = WorldLight::spot(Color::WHITE, 1.0, 0.1, 0.5, &down, &units).unwrap();
        let Light::Spot {
            inner_deg,
            outer_deg,
            direction,
            ..
        } = spot.0
        else {
            panic!("spot")
        };
        assert!((inner_deg - 0.1f64.to_degrees()).abs() < 1e-4);
        assert!((outer_deg - 0.5f64.to_degrees()).abs() < 1e-4);
        assert!(direction.distance(DVec3::NEG_Y) < 1e-6);
    }
}
