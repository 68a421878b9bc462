//! Lights, in the command-line syntax of DESIGN section 8.
//!
//! ```
//! use translucent::scene::{Environment, Light, Scene};
//! let key: Light = "dir:0,-1,0:3,3,3".parse()?;          // irradiance 3 arriving straight down
//! let fill: Light = "point:0,40,40:5000,5000,5000".parse()?; // intensity (W/sr-like units)
//! let rim: Light = "spot:0,0,-50:0,0,1:2000,1800,1500:15,25".parse()?;
//! let scene = Scene { lights: vec![key, fill, rim], environment: Environment::Constant([0.1; 3]) };
//! scene.validate()?;
//! assert!("dir:0,0,0:1,1,1".parse::<Light>().is_err()); // no direction
//! # Ok::<(), translucent::scene::SceneError>(())
//! ```

use std::str::FromStr;

use glam::DVec3;

use super::SceneError;

/// A light. Colours are linear RGB; positions and directions in mm in the object frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Light {
    /// Parallel light: `irradiance` arriving on a surface facing it, travelling along `direction`.
    Directional {
        direction: DVec3,
        irradiance: [f64; 3],
    },
    /// Isotropic point light: irradiance `intensity / r^2` on a surface facing it.
    Point {
        position: DVec3,
        intensity: [f64; 3],
    },
    /// Point light restricted to a cone around `direction` (where it points); full intensity inside
    /// `inner_deg` of the axis, smooth (smoothstep in cos) falloff to zero at `outer_deg`.
    Spot {
        position: DVec3,
        direction: DVec3,
        intensity: [f64; 3],
        inner_deg: f64,
        outer_deg: f64,
    },
}

pub(super) fn bad(what: &str, problem: impl Into<String>) -> SceneError {
    SceneError::Invalid {
        what: what.to_string(),
        problem: problem.into(),
    }
}

/// The largest light or environment colour component accepted. The GPU takes colours as f32 and
/// phi reaches ~7 q, so q must stay far below f32::MAX (3.4e38); the CPU's f64 residual sums
/// overflowed from 1e150. Before this bound a `dir:0,-1,0:1e300,..` light reached the GPU as an
/// f32 infinity and the command line wrote an image and a JSON report with NaN (`null`) in it.
pub const MAX_LIGHT_COLOUR: f64 = 1e30;

pub(super) fn check_colour(what: &str, c: [f64; 3]) -> Result<(), SceneError> {
    if c.iter().all(|v| v.is_finite() && *v >= 0.0) {
        if c.iter().any(|&v| v > MAX_LIGHT_COLOUR) {
            return Err(bad(
                what,
                format!("colour {c:?} is above the supported {MAX_LIGHT_COLOUR:e}"),
            ));
        }
        Ok(())
    } else {
        Err(bad(what, format!("colour {c:?} must be finite and >= 0")))
    }
}

fn check_direction(what: &str, d: DVec3) -> Result<(), SceneError> {
    if d.is_finite() && d.length() > 0.0 {
        Ok(())
    } else {
        Err(bad(
            what,
            format!("direction {d} must be finite and non-zero"),
        ))
    }
}

impl Light {
    /// The built-in scene's light: directional, from the upper left front, white irradiance 3.
    pub fn default_light() -> Light {
        Light::Directional {
            direction: DVec3::new(1.0, -1.0, -1.0).normalize(),
            irradiance: [3.0; 3],
        }
    }

    /// The light turned by `rotation` about the origin of the object frame (directions and
    /// positions; colours and cone angles unchanged): an orbiting light, frame after frame.
    pub fn rotated(&self, rotation: glam::DQuat) -> Light {
        match *self {
            Light::Directional {
                direction,
                irradiance,
            } => Light::Directional {
                direction: rotation * direction,
                irradiance,
            },
            Light::Point {
                position,
                intensity,
            } => Light::Point {
                position: rotation * position,
                intensity,
            },
            Light::Spot {
                position,
                direction,
                intensity,
                inner_deg,
                outer_deg,
            } => Light::Spot {
                position: rotation * position,
                direction: rotation * direction,
                intensity,
                inner_deg,
                outer_deg,
            },
        }
    }

    /// Checks finiteness, non-negative colours, non-zero directions and cone angles.
    pub fn validate(&self) -> Result<(), SceneError> {
        match *self {
            Light::Directional {
                direction,
                irradiance,
            } => {
                check_direction("directional light", direction)?;
                check_colour("directional light", irradiance)
            }
            Light::Point {
                position,
                intensity,
            } => {
                if !position.is_finite() {
                    return Err(bad(
                        "point light",
                        format!("position {position} is not finite"),
                    ));
                }
                check_colour("point light", intensity)
            }
            Light::Spot {
                position,
                direction,
                intensity,
                inner_deg,
                outer_deg,
            } => {
                if !position.is_finite() {
                    return Err(bad(
                        "spot light",
                        format!("position {position} is not finite"),
                    ));
                }
                check_direction("spot light", direction)?;
                check_colour("spot light", intensity)?;
                if !(inner_deg.is_finite()
                    && outer_deg.is_finite()
                    && 0.0 <= inner_deg
                    && inner_deg <= outer_deg
                    && outer_deg <= 180.0)
                {
                    return Err(bad(
                        "spot light",
                        format!("cone angles {inner_deg}, {outer_deg}: need 0 <= inner <= outer <= 180 degrees"),
                    ));
                }
                Ok(())
            }
        }
    }

    /// Irradiance arriving at `p` (before the cosine and Fresnel factors), the unit direction
    /// towards the light and the distance to it (infinite for a directional light).
    pub fn arriving(&self, p: DVec3) -> ([f64; 3], DVec3, f64) {
        match *self {
            Light::Directional {
                direction,
                irradiance,
            } => (irradiance, -direction.normalize(), f64::INFINITY),
            Light::Point {
                position,
                intensity,
            } => {
                let (l, r) = towards(position, p);
                (intensity.map(|i| i / (r * r)), l, r)
            }
            Light::Spot {
                position,
                direction,
                intensity,
                inner_deg,
                outer_deg,
            } => {
                let (l, r) = towards(position, p);
                let cos_axis = (-l).dot(direction.normalize());
                let (ci, co) = (inner_deg.to_radians().cos(), outer_deg.to_radians().cos());
                let falloff = if ci - co > 1e-12 {
                    let t = ((cos_axis - co) / (ci - co)).clamp(0.0, 1.0);
                    t * t * (3.0 - 2.0 * t)
                } else if cos_axis >= co {
                    1.0
                } else {
                    0.0
                };
                (intensity.map(|i| i * falloff / (r * r)), l, r)
            }
        }
    }
}

fn towards(light: DVec3, p: DVec3) -> (DVec3, f64) {
    let v = light - p;
    // A light sitting exactly on a node would divide by zero; keep r away from 0.
    let r = v.length().max(1e-9);
    (v / r, r)
}

fn parse_vec(s: &str, what: &str) -> Result<DVec3, SceneError> {
    let v = parse_floats::<3>(s, what)?;
    Ok(DVec3::from_array(v))
}

fn parse_floats<const N: usize>(s: &str, what: &str) -> Result<[f64; N], SceneError> {
    let parts: Vec<&str> = s.split(',').collect();
    if parts.len() != N {
        return Err(bad(
            what,
            format!("'{s}' should be {N} comma-separated numbers"),
        ));
    }
    let mut out = [0.0; N];
    for (o, p) in out.iter_mut().zip(parts) {
        *o = p
            .trim()
            .parse::<f64>()
            .map_err(|e| bad(what, format!("'{p}': {e}")))?;
        if !o.is_finite() {
            return Err(bad(what, format!("'{p}' is not finite")));
        }
    }
    Ok(out)
}

impl FromStr for Light {
    type Err = SceneError;

    /// `dir:X,Y,Z:R,G,B`, `point:X,Y,Z:R,G,B` or `spot:X,Y,Z:DX,DY,DZ:R,G,B:INNER_DEG,OUTER_DEG`.
    fn from_str(s: &str) -> Result<Self, SceneError> {
        let parts: Vec<&str> = s.split(':').collect();
        let light = match parts.as_slice() {
            ["dir", d, c] => Light::Directional {
                direction: parse_vec(d, "directional light")?,
                irradiance: parse_floats(c, "directional light")?,
            },
            ["point", p, c] => Light::Point {
                position: parse_vec(p, "point light")?,
                intensity: parse_floats(c, "point light")?,
            },
            ["spot", p, d, c, a] => {
                let [inner_deg, outer_deg] = parse_floats(a, "spot light")?;
                Light::Spot {
                    position: parse_vec(p, "spot light")?,
                    direction: parse_vec(d, "spot light")?,
                    intensity: parse_floats(c, "spot light")?,
                    inner_deg,
                    outer_deg,
                }
            }
            _ => {
                return Err(bad(
                    "light",
                    format!(
                        "'{s}': expected dir:X,Y,Z:R,G,B, point:X,Y,Z:R,G,B or \
                         spot:X,Y,Z:DX,DY,DZ:R,G,B:INNER_DEG,OUTER_DEG"
                    ),
                ))
            }
        };
        light.validate()?;
        Ok(light)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn rotated_turns_directions_and_positions_and_keeps_the_rest() {
        let q = glam::DQuat::from_rotation_y(PI / 2.0); // +X -> -Z
        let spot = Light::Spot {
            position: DVec3::new(2.0, 1.0, 0.0),
            direction: DVec3::X,
            intensity: [1.0, 2.0, 3.0],
            inner_deg: 10.0,
            outer_deg: 20.0,
        };
        let Light::Spot {
            position,
            direction,
            intensity,
            inner_deg,
            outer_deg,
        } = spot.rotated(q)
        else {
            panic!("a spot stays a spot");
        };
        assert!(
            (position - DVec3::new(0.0, 1.0, -2.0)).length() < 1e-12,
            "{position}"
        );
        assert!((direction - DVec3::NEG_Z).length() < 1e-12, "{direction}");
        assert_eq!(
            (intensity, inner_deg, outer_deg),
            ([1.0, 2.0, 3.0], 10.0, 20.0)
        );
        let sun = Light::Directional {
            direction: DVec3::X,
            irradiance: [4.0; 3],
        };
        assert_eq!(sun.rotated(glam::DQuat::IDENTITY), sun);
    }

    #[test]
    fn lights_parse_and_fall_off() {
        let l: Light = "point:0,10,0:100,100,100".parse().unwrap();
        let (e, dir, r) = l.arriving(DVec3::ZERO);
        assert!(
            (e[0] - 1.0).abs() < 1e-12
                && (dir - DVec3::Y).length() < 1e-12
                && (r - 10.0).abs() < 1e-12
        );
        let spot: Light = "spot:0,10,0:0,-1,0:100,100,100:10,20".parse().unwrap();
        let at = |deg: f64| {
            spot.arriving(DVec3::new(10.0 * deg.to_radians().tan(), 0.0, 0.0))
                .0[0]
        };
        assert!(
            at(5.0) > 0.0
                && (at(5.0) * (10.0 / 5f64.to_radians().cos()).powi(2) - 100.0).abs() < 1e-9
        );
        assert!(at(15.0) > 0.0 && at(15.0) < at(5.0));
        assert_eq!(at(25.0), 0.0);
        for s in [
            "dir:0,0,0:1,1,1",
            "dir:0,-1,0:1,1",
            "point:0,0,0:-1,0,0",
            "spot:0,0,0:0,1,0:1,1,1:30,20",
            "sun:0,1,0:1,1,1",
            "dir:0,nan,0:1,1,1",
        ] {
            assert!(s.parse::<Light>().is_err(), "{s} parsed");
        }
    }
}
