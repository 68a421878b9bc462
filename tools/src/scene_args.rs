//! Scene and frame options shared by the subcommands that render (DESIGN section 8 syntax).
//! Other subcommands extend [`SceneArgs`] with `#[command(flatten)]`. Invalid values are errors
//! naming the option.

use anyhow::{bail, Context as _};
use glam::{DQuat, DVec3};
use translucent::headless::FrameDesc;
use translucent::scene::{Camera, ExitLobe, Light, RadianceMode};

use crate::framing::Side;

#[derive(clap::Args, Debug, Clone)]
pub struct SceneArgs {
    /// `dir:X,Y,Z:R,G,B` (direction the light travels, irradiance), `point:X,Y,Z:R,G,B`
    /// (intensity) or `spot:X,Y,Z:DX,DY,DZ:R,G,B:INNER_DEG,OUTER_DEG`; repeatable.
    /// Default: a back light and a dim front fill placed relative to the camera (for the default
    /// camera: dir:0.2,-0.35,1:5,5,5 and dir:-0.6,-0.7,-0.4:0.6,0.6,0.6; a `--camera` elsewhere
    /// turns both with it, so the object is lit the same way from any side).
    #[arg(long = "light")]
    pub lights: Vec<String>,
    /// `X,Y,Z:TX,TY,TZ:FOVY_DEG`: eye, target, vertical field of view. Default: auto-framed.
    #[arg(long)]
    pub camera: Option<String>,
    #[arg(long, default_value_t = 512)]
    pub width: u32,
    #[arg(long, default_value_t = 512)]
    pub height: u32,
    /// `physical`: F_t J+ / (pi eta^2); `paper`: F_t J+ / pi (paper Eq. 4).
    #[arg(long, default_value = "physical", value_parser = ["physical", "paper"])]
    pub radiance: String,
    /// Angular shape of the exit radiance: `lambert` (DESIGN 2.6), `p1` (1 + 3/(2A) mu_i), `fitted`
    /// (half the P1 slope, fitted on Monte Carlo), `node` (a slope per surface node: P1 for light
    /// diffused from elsewhere, Lambert for a node's own; translucent::scene::ExitLobe), `chandra`
    /// (`node` with the own light's shape from its incidence cosine, Chandrasekhar's half-space
    /// law, at eta 1; translucent::scene::own_lobe; the default, translucent::defaults::EXIT_LOBE).
    /// `bench` sweeps a comma-separated list (`lambert,p1,fitted,node,chandra`); a frame takes one.
    #[arg(long, default_value = "chandra", value_parser = exit_lobe_list)]
    pub exit_lobe: String,
    /// No Cook-Torrance specular (and no shadow map pass).
    #[arg(long)]
    pub no_specular: bool,
    /// Exposure multiplier applied before the tone map (PNG only; EXR stays linear).
    #[arg(long, default_value_t = 1.0)]
    pub exposure: f32,
}

/// `--exit-lobe`'s value: one of [`ExitLobe::NAMES`], or a comma-separated list of them.
fn exit_lobe_list(text: &str) -> Result<String, String> {
    for item in text.split(',') {
        if !ExitLobe::NAMES.contains(&item.trim()) {
            return Err(format!(
                "'{item}' is not an exit lobe ({})",
                ExitLobe::NAMES.join(", ")
            ));
        }
    }
    Ok(text.to_string())
}

impl SceneArgs {
    /// `--exit-lobe`'s lobes (a list for `bench`'s sweep).
    pub fn exit_lobes(&self) -> anyhow::Result<Vec<ExitLobe>> {
        self.exit_lobe
            .split(',')
            .map(|s| Ok(s.trim().parse()?))
            .collect()
    }
}

fn numbers<const N: usize>(option: &str, text: &str) -> anyhow::Result<[f64; N]> {
    let values: Vec<f64> = text
        .split(',')
        .map(|v| {
            v.trim()
                .parse::<f64>()
                .with_context(|| format!("{option}: {v:?} is not a number"))
        })
        .collect::<anyhow::Result<_>>()?;
    let values: [f64; N] = values.try_into().map_err(|v: Vec<f64>| {
        anyhow::anyhow!("{option}: expected {N} numbers, got {}", v.len())
    })?;
    if values.iter().any(|v| !v.is_finite()) {
        bail!("{option}: {text:?} has a non-finite value");
    }
    Ok(values)
}

fn vec3(option: &str, text: &str) -> anyhow::Result<DVec3> {
    Ok(DVec3::from_array(numbers::<3>(option, text)?))
}

/// The default scene's lights for the default camera ([`default_camera`]'s view direction): a
/// back light that shows the light passing through the object, and a dim fill from the front so
/// its shape reads. [`default_lights_for`] turns them to another camera.
pub fn default_lights() -> Vec<Light> {
    vec![
        Light::Directional {
            direction: DVec3::new(0.2, -0.35, 1.0).normalize(),
            irradiance: [5.0; 3],
        },
        Light::Directional {
            direction: DVec3::new(-0.6, -0.7, -0.4).normalize(),
            irradiance: [0.6; 3],
        },
    ]
}

/// The camera's frame as a rotation taking (right, up, back) = (+X, +Y, +Z) to the camera's
/// right, up and back (towards the eye) directions; the up hint is +Y as in
/// `Camera::view_proj` (+Z when looking along Y).
fn camera_frame(camera: &Camera) -> DQuat {
    let back = (camera.eye - camera.target).normalize();
    let hint = if back.cross(DVec3::Y).length() < 1e-6 {
        DVec3::Z
    } else {
        DVec3::Y
    };
    let right = hint.cross(back).normalize();
    let up = back.cross(right);
    DQuat::from_mat3(&glam::DMat3::from_cols(right, up, back))
}

/// The default lights placed relative to `camera`: [`default_lights`] turned by the rotation
/// that takes the default camera's view to this one, so the key light stays behind the object
/// (slightly above and to the right of the view direction) and the fill in front above-left,
/// whichever side the camera looks from. For the default camera they are [`default_lights`].
pub fn default_lights_for(camera: &Camera) -> Vec<Light> {
    let reference = default_camera(DVec3::ZERO, 1.0, 1.0, Side::Front);
    let turn = camera_frame(camera) * camera_frame(&reference).inverse();
    default_lights()
        .iter()
        .map(|light| light.rotated(turn))
        .collect()
}

/// The azimuth (from +Z towards +X) and elevation of the default camera: a three-quarter view
/// from the front right and above, so the object's depth reads (a view straight from the front
/// shows one side of it).
pub const DEFAULT_VIEW_AZIMUTH_DEG: f64 = 35.0;
pub const DEFAULT_VIEW_ELEVATION_DEG: f64 = 25.0;

/// The commands' camera without `--camera`: the library's framing distance and field of view
/// (`Camera::framing`: the bounding sphere inside the view with a margin), seen in three-quarter
/// view from the object's front `side` (`framing::choose_front`: from +Z's side, or its mirror
/// through the centre from -Z's side).
pub fn default_camera(centre: DVec3, radius: f64, aspect: f64, side: Side) -> Camera {
    let framed = Camera::framing(centre, radius, aspect);
    let distance = (framed.eye - framed.target).length();
    let [front, back] =
        crate::framing::view_directions(DEFAULT_VIEW_AZIMUTH_DEG, DEFAULT_VIEW_ELEVATION_DEG);
    let direction = match side {
        Side::Front => front,
        Side::Back => back,
    };
    Camera {
        eye: centre + direction * distance,
        ..framed
    }
}

/// Parses one `--light` value (the syntax is the library's `Light::from_str`).
pub fn parse_light(text: &str) -> anyhow::Result<Light> {
    text.parse::<Light>()
        .with_context(|| format!("--light {text:?}"))
}

/// Parses `--camera X,Y,Z:TX,TY,TZ:FOVY_DEG`.
pub fn parse_camera(text: &str) -> anyhow::Result<Camera> {
    let parts: Vec<&str> = text.split(':').collect();
    let [eye, target, fovy] = parts.as_slice() else {
        bail!("--camera {text:?}: expected X,Y,Z:TX,TY,TZ:FOVY_DEG");
    };
    let [fovy_deg] = numbers("--camera field of view", fovy)?;
    let camera = Camera {
        eye: vec3("--camera eye", eye)?,
        target: vec3("--camera target", target)?,
        fovy_deg,
    };
    // Camera::validate also bounds the coordinates (scene::MAX_CAMERA_MM): an eye at 1e300 mm
    // is finite but renders nothing through an f32 view matrix.
    camera
        .validate()
        .with_context(|| format!("--camera {text:?}"))?;
    Ok(camera)
}

impl SceneArgs {
    /// The `--light` values, or the default lights for the default camera (to check the
    /// options; a render uses [`SceneArgs::lights_for`]).
    pub fn lights(&self) -> anyhow::Result<Vec<Light>> {
        if self.lights.is_empty() {
            return Ok(default_lights());
        }
        self.lights.iter().map(|l| parse_light(l)).collect()
    }

    /// The `--light` values, or without any the default lights placed relative to `camera`
    /// (the `--camera` or the automatic framing): [`default_lights_for`].
    pub fn lights_for(&self, camera: &Camera) -> anyhow::Result<Vec<Light>> {
        if self.lights.is_empty() {
            return Ok(default_lights_for(camera));
        }
        self.lights()
    }

    pub fn frame_desc(&self) -> anyhow::Result<FrameDesc> {
        for (option, v) in [("--width", self.width), ("--height", self.height)] {
            if !(1..=16384).contains(&v) {
                bail!("{option} {v}: must be in 1..=16384");
            }
        }
        if !(self.exposure.is_finite() && self.exposure >= 0.0) {
            bail!(
                "--exposure {}: must be a finite non-negative number",
                self.exposure
            );
        }
        Ok(FrameDesc {
            width: self.width,
            height: self.height,
            camera: self.camera.as_deref().map(parse_camera).transpose()?,
            radiance: if self.radiance == "paper" {
                RadianceMode::Paper
            } else {
                RadianceMode::Physical
            },
            exit_lobe: match self.exit_lobes()?.as_slice() {
                [one] => *one,
                _ => anyhow::bail!(
                    "--exit-lobe {}: one lobe per frame (`translucent bench` sweeps a list)",
                    self.exit_lobe
                ),
            },
            specular: !self.no_specular,
            ..FrameDesc::default()
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_camera_is_a_three_quarter_view_at_the_framing_distance() {
        let centre = DVec3::new(1.0, 2.0, 3.0);
        let framed = Camera::framing(centre, 10.0, 1.0);
        let camera = default_camera(centre, 10.0, 1.0, Side::Front);
        camera.validate().expect("valid");
        let d = camera.eye - centre;
        // Same distance and field of view: the object fits as it does in Camera::framing.
        assert!((d.length() - (framed.eye - centre).length()).abs() < 1e-9);
        assert_eq!(camera.fovy_deg, framed.fovy_deg);
        // From the front right and above, neither axis-aligned nor from behind.
        assert!(d.x > 0.3 * d.length() && d.y > 0.3 * d.length() && d.z > 0.5 * d.length());
    }

    /// Directions equal to rounding (the rotation is built from normalised f64 vectors).
    const DIRECTION_TOL: f64 = 1e-9;

    fn directions(lights: &[Light]) -> Vec<DVec3> {
        lights
            .iter()
            .map(|l| match l {
                Light::Directional { direction, .. } => *direction,
                other => panic!("the defaults are directional, got {other:?}"),
            })
            .collect()
    }

    #[test]
    fn default_lights_follow_the_camera() {
        let centre = DVec3::new(5.0, -2.0, 1.0);
        // The default camera (any centre, radius, aspect) keeps the documented directions.
        let home = default_camera(centre, 30.0, 1.5, Side::Front);
        for (a, b) in directions(&default_lights_for(&home))
            .iter()
            .zip(directions(&default_lights()))
        {
            assert!((*a - b).length() < DIRECTION_TOL, "{a} vs {b}");
        }
        // Each light keeps its angle to the view direction for cameras all around the object,
        // looking along Y included.
        let view = |c: &Camera| (c.target - c.eye).normalize();
        let reference: Vec<f64> = directions(&default_lights())
            .iter()
            .map(|d| d.dot(view(&home)))
            .collect();
        for eye in [
            DVec3::new(0.0, 0.0, -100.0),
            DVec3::new(-60.0, -70.0, 40.0),
            DVec3::new(0.0, 100.0, 0.0),
            DVec3::new(0.0, -100.0, 0.0),
            DVec3::new(100.0, 0.0, 0.0),
        ] {
            let camera = Camera {
                eye: centre + eye,
                target: centre,
                fovy_deg: 30.0,
            };
            let lights = directions(&default_lights_for(&camera));
            for (d, r) in lights.iter().zip(&reference) {
                assert!((d.length() - 1.0).abs() < DIRECTION_TOL);
                assert!(
                    (d.dot(view(&camera)) - r).abs() < DIRECTION_TOL,
                    "{eye}: {d}"
                );
            }
            // The key is a back light: it travels towards the eye.
            assert!(
                lights[0].dot(view(&camera)) < -0.5,
                "{eye}: key {}",
                lights[0]
            );
        }
    }

    #[test]
    fn lights_and_cameras_parse_and_bad_values_name_the_option() {
        assert_eq!(
            parse_light("dir:0,-1,0:1,2,3").expect("dir"),
            Light::Directional {
                direction: DVec3::new(0.0, -1.0, 0.0),
                irradiance: [1.0, 2.0, 3.0]
            }
        );
        assert!(matches!(
            parse_light("spot:0,50,0:0,-1,0:100,100,100:10,20"),
            Ok(Light::Spot { .. })
        ));
        assert!(matches!(
            parse_light("point:0,50,0:9,9,9"),
            Ok(Light::Point { .. })
        ));
        for bad in [
            "dir:0,0,0:1,1,1",
            "dir:1,2:1,1,1",
            "sun:1,1,1:1,1,1",
            "point:0,1,0:1,nan,1",
            "spot:0,1,0:0,-1,0:1,1,1:30,10",
        ] {
            let e = parse_light(bad).expect_err(bad).to_string();
            assert!(e.contains("--light"), "{e}");
        }
        let cam = parse_camera("0,0,100:0,0,0:40").expect("camera");
        assert_eq!(cam.fovy_deg, 40.0);
        for bad in [
            "0,0,100:0,0,0",
            "0,0,0:0,0,0:40",
            "0,0,1:0,0,0:200",
            "0,0,1e300:0,0,0:40",
            "0,0,100:1e11,0,0:40",
        ] {
            assert!(parse_camera(bad)
                .expect_err(bad)
                .to_string()
                .contains("--camera"));
        }
    }
}
