//! What the viewer shows, as plain data: camera, lights, material, method, precision and the
//! switches; [`ViewState::apply`] turns an [`Action`] into a change of it and says what the GPU
//! side must do ([`Effect`]). No Vulkan here, so all of it is unit tested.

use glam::{DQuat, DVec3};
use translucent::scene::{Camera, Light};
use translucent::solver::gpu::Precision;

use super::controls::Action;
use crate::material_args::PROCEDURAL;

/// A method of DESIGN section 6 and whether this build has it. The viewer's method key walks
/// this list; a method that is not built is named in the overlay and not switched to. When
/// voxel and dipole land, set `built` and build them in `super::ObjectSetup::object`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MethodEntry {
    pub name: &'static str,
    pub built: bool,
}

pub const METHODS: [MethodEntry; 3] = [
    MethodEntry {
        name: "quadgraph",
        built: true,
    },
    MethodEntry {
        name: "voxel",
        built: true,
    },
    MethodEntry {
        name: "dipole",
        built: true,
    },
];

/// Every material the viewer can switch to: the measured presets, then the procedural patterns.
pub fn materials() -> Vec<&'static str> {
    translucent::material::presets::PRESETS
        .iter()
        .map(|p| p.name)
        .chain(PROCEDURAL)
        .collect()
}

/// The camera may not come closer to the object's centre than this many radii (inside it the
/// image is black) nor go further than [`MAX_DISTANCE_RADII`].
pub const MIN_DISTANCE_RADII: f64 = 1.05;
pub const MAX_DISTANCE_RADII: f64 = 1000.0;
/// The orbit stops this far from the poles (the view's up vector is +Y).
pub const MAX_ELEVATION_DEG: f64 = 89.0;

/// What an applied action requires of the GPU side.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Effect {
    pub camera: bool,
    pub lights: bool,
    pub material: bool,
    /// A new object (precision, skipping, method: [`translucent::ObjectParams`] fields).
    pub rebuild: bool,
    pub resize: Option<(u32, u32)>,
    pub screenshot: Option<Option<std::path::PathBuf>>,
    pub reload_shaders: bool,
    pub quit: bool,
}

/// The scene and switches the viewer shows.
#[derive(Clone, Debug, PartialEq)]
pub struct ViewState {
    pub camera: Camera,
    /// Where [`Action::ResetCamera`] goes back to.
    pub home: Camera,
    /// The object's bounding sphere (centre, radius), mm.
    pub bounds: (DVec3, f64),
    pub lights: Vec<Light>,
    /// The material's name: a preset or pattern, or `None` while the command line's own
    /// coefficients (`--sigma-a/--sigma-s`, `--volume`) are shown.
    pub material: Option<String>,
    /// Index into [`METHODS`].
    pub method: usize,
    pub precision: Precision,
    /// Single scattering (DESIGN section 2.8): `ObjectParams::single_scattering`.
    pub single_scattering: bool,
    /// `ObjectParams::skip`.
    pub skip: bool,
    pub overlay: bool,
    pub help: bool,
    /// The last thing the viewer wants the user to know (shown in the overlay).
    pub note: Option<String>,
}

impl ViewState {
    /// A state looking through `camera` at an object bounded by `bounds`.
    pub fn new(camera: Camera, bounds: (DVec3, f64), lights: Vec<Light>) -> ViewState {
        ViewState {
            camera,
            home: camera,
            bounds,
            lights,
            material: None,
            method: 0,
            precision: Precision::Mixed,
            single_scattering: false,
            skip: true,
            overlay: true,
            help: false,
            note: None,
        }
    }

    /// Applies `action`. Actions that cannot be done (a method not built, an unknown material)
    /// change nothing and leave a note.
    pub fn apply(&mut self, action: &Action) -> Effect {
        let mut effect = Effect::default();
        match action {
            Action::Orbit { yaw_deg, pitch_deg } => {
                self.camera = orbit(self.camera, *yaw_deg, *pitch_deg);
                effect.camera = true;
            }
            Action::Zoom(factor) => {
                self.camera = zoom(self.camera, *factor, self.bounds.1);
                effect.camera = true;
            }
            Action::Camera(c) => {
                self.camera = *c;
                effect.camera = true;
            }
            Action::ResetCamera => {
                self.camera = self.home;
                effect.camera = true;
            }
            Action::Light { yaw_deg, pitch_deg } => {
                if let Some(key) = self.lights.first_mut() {
                    *key = turn_light(key, *yaw_deg, *pitch_deg);
                    effect.lights = true;
                } else {
                    self.note = Some("no light to turn (environment only)".into());
                }
            }
            Action::Material(name) => {
                let all = materials();
                match all.iter().find(|m| m.eq_ignore_ascii_case(name)) {
                    Some(m) => {
                        self.material = Some((*m).to_string());
                        effect.material = true;
                    }
                    None => {
                        self.note = Some(format!(
                            "material {name:?}: unknown (known: {})",
                            all.join(", ")
                        ))
                    }
                }
            }
            Action::CycleMaterial(step) => {
                let all = materials();
                let current = self
                    .material
                    .as_deref()
                    .and_then(|m| all.iter().position(|n| *n == m));
                let n = all.len() as i64;
                let next = match current {
                    Some(i) => (i as i64 + i64::from(*step)).rem_euclid(n),
                    None => 0,
                };
                self.material = Some(all[next as usize].to_string());
                effect.material = true;
            }
            Action::Method(name) => match METHODS.iter().position(|m| m.name == name) {
                Some(i) => effect.rebuild = self.switch_method(i),
                None => {
                    let names: Vec<_> = METHODS.iter().map(|m| m.name).collect();
                    self.note = Some(format!(
                        "method {name:?}: unknown (known: {})",
                        names.join(", ")
                    ));
                }
            },
            Action::CycleMethod => {
                // The next method that is built; with only one built, say which are missing.
                let next = (1..=METHODS.len())
                    .map(|k| (self.method + k) % METHODS.len())
                    .find(|&i| METHODS[i].built)
                    .unwrap_or(self.method);
                if next == self.method {
                    let missing: Vec<_> = METHODS
                        .iter()
                        .filter(|m| !m.built)
                        .map(|m| m.name)
                        .collect();
                    self.note = Some(format!(
                        "only {} is built ({}: not yet)",
                        METHODS[self.method].name,
                        missing.join(", ")
                    ));
                } else {
                    effect.rebuild = self.switch_method(next);
                }
            }
            Action::Precision(p) => {
                effect.rebuild = self.precision != *p;
                self.precision = *p;
            }
            Action::CyclePrecision => {
                self.precision = match self.precision {
                    Precision::Mixed => Precision::Fp32,
                    Precision::Fp32 => Precision::Fp16,
                    Precision::Fp16 => Precision::Mixed,
                };
                effect.rebuild = true;
            }
            Action::SingleScattering(on) => {
                let wanted = on.unwrap_or(!self.single_scattering);
                // A new object: `ObjectParams::single_scattering` is fixed at creation.
                effect.rebuild = wanted != self.single_scattering;
                self.single_scattering = wanted;
            }
            Action::Skip(on) => {
                let skip = on.unwrap_or(!self.skip);
                effect.rebuild = skip != self.skip;
                self.skip = skip;
            }
            Action::Overlay(on) => self.overlay = on.unwrap_or(!self.overlay),
            Action::Help(on) => {
                self.help = on.unwrap_or(!self.help);
                if self.help {
                    self.overlay = true;
                }
            }
            Action::Resize { width, height } => effect.resize = Some((*width, *height)),
            Action::Screenshot(path) => effect.screenshot = Some(path.clone()),
            Action::ReloadShaders => effect.reload_shaders = true,
            Action::Quit => effect.quit = true,
        }
        effect
    }

    fn switch_method(&mut self, index: usize) -> bool {
        if !METHODS[index].built {
            self.note = Some(format!("method {}: not built yet", METHODS[index].name));
            return false;
        }
        let changed = index != self.method;
        self.method = index;
        changed
    }

    pub fn method_name(&self) -> &'static str {
        METHODS[self.method].name
    }
}

/// `camera` turned about its target: `yaw_deg` about +Y, then `pitch_deg` up, the elevation
/// kept within [`MAX_ELEVATION_DEG`] of the horizon.
pub fn orbit(camera: Camera, yaw_deg: f64, pitch_deg: f64) -> Camera {
    let offset = camera.eye - camera.target;
    let distance = offset.length();
    let elevation = (offset.y / distance).clamp(-1.0, 1.0).asin().to_degrees();
    let new_elevation = (elevation + pitch_deg).clamp(-MAX_ELEVATION_DEG, MAX_ELEVATION_DEG);
    let mut horizontal = DVec3::new(offset.x, 0.0, offset.z);
    if horizontal.length() < 1e-12 * distance {
        horizontal = DVec3::Z; // looking straight down or up: any azimuth will do
    }
    let azimuth = DQuat::from_rotation_y(yaw_deg.to_radians()) * horizontal.normalize();
    let e = new_elevation.to_radians();
    Camera {
        eye: camera.target + (azimuth * e.cos() + DVec3::Y * e.sin()) * distance,
        ..camera
    }
}

/// `camera` moved along its view line to `factor` times its distance, kept between
/// [`MIN_DISTANCE_RADII`] and [`MAX_DISTANCE_RADII`] object radii.
pub fn zoom(camera: Camera, factor: f64, radius: f64) -> Camera {
    let offset = camera.eye - camera.target;
    let distance = (offset.length() * factor).clamp(
        MIN_DISTANCE_RADII * radius,
        MAX_DISTANCE_RADII * radius.max(1e-9),
    );
    Camera {
        eye: camera.target + offset.normalize() * distance,
        ..camera
    }
}

/// `light` turned about the object's origin: `yaw_deg` about +Y, then `pitch_deg` about the
/// horizontal axis across its direction (or position, for point and spot lights).
pub fn turn_light(light: &Light, yaw_deg: f64, pitch_deg: f64) -> Light {
    let yawed = light.rotated(DQuat::from_rotation_y(yaw_deg.to_radians()));
    let along = match yawed {
        Light::Directional { direction, .. } => direction,
        Light::Point { position, .. } | Light::Spot { position, .. } => position,
    };
    let axis = DVec3::Y.cross(along);
    let axis = if axis.length() < 1e-9 * along.length().max(1e-300) {
        DVec3::X
    } else {
        axis.normalize()
    };
    yawed.rotated(DQuat::from_axis_angle(axis, pitch_deg.to_radians()))
}

/// `v` as `X,Y,Z` with the shortest decimal that reads back exactly.
fn xyz(v: DVec3) -> String {
    format!("{},{},{}", v.x, v.y, v.z)
}

fn rgb(c: [f64; 3]) -> String {
    format!("{},{},{}", c[0], c[1], c[2])
}

/// `light` in the `--light` syntax (DESIGN section 8), exactly.
pub fn light_arg(light: &Light) -> String {
    match *light {
        Light::Directional {
            direction,
            irradiance,
        } => format!("dir:{}:{}", xyz(direction), rgb(irradiance)),
        Light::Point {
            position,
            intensity,
        } => format!("point:{}:{}", xyz(position), rgb(intensity)),
        Light::Spot {
            position,
            direction,
            intensity,
            inner_deg,
            outer_deg,
        } => format!(
            "spot:{}:{}:{}:{inner_deg},{outer_deg}",
            xyz(position),
            xyz(direction),
            rgb(intensity)
        ),
    }
}

/// `camera` in the `--camera` syntax, exactly.
pub fn camera_arg(camera: &Camera) -> String {
    format!(
        "{}:{}:{}",
        xyz(camera.eye),
        xyz(camera.target),
        camera.fovy_deg
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene_args::{parse_camera, parse_light};

    fn state() -> ViewState {
        let camera = Camera {
            eye: DVec3::new(0.0, 0.0, 100.0),
            target: DVec3::ZERO,
            fovy_deg: 30.0,
        };
        ViewState::new(
            camera,
            (DVec3::ZERO, 25.0),
            vec![
                parse_light("dir:0,-1,1:5,5,5").expect("light"),
                parse_light("point:0,50,0:9,9,9").expect("light"),
            ],
        )
    }

    #[test]
    fn orbit_keeps_distance_and_target_and_stops_short_of_the_poles() {
        let s = state();
        let c = orbit(s.camera, 90.0, 0.0);
        assert!(
            (c.eye - DVec3::new(100.0, 0.0, 0.0)).length() < 1e-9,
            "{c:?}"
        );
        let up = orbit(s.camera, 0.0, 200.0);
        let elevation = (up.eye.y / up.eye.length()).asin().to_degrees();
        assert!((elevation - MAX_ELEVATION_DEG).abs() < 1e-9);
        assert!((up.eye.length() - 100.0).abs() < 1e-9);
        // From the clamped pole the orbit still moves (no NaN from a zero horizontal part).
        let on = orbit(up, 45.0, -10.0);
        assert!(on.eye.is_finite() && on.validate().is_ok());
    }

    #[test]
    fn zoom_is_bounded_by_the_object_radius() {
        let s = state();
        assert!((zoom(s.camera, 0.5, 25.0).eye.z - 50.0).abs() < 1e-9);
        let near = zoom(s.camera, 1e-6, 25.0);
        assert!((near.eye.length() - MIN_DISTANCE_RADII * 25.0).abs() < 1e-9);
        let far = zoom(s.camera, 1e9, 25.0);
        assert!((far.eye.length() - MAX_DISTANCE_RADII * 25.0).abs() < 1e-6);
    }

    #[test]
    fn turning_the_key_light_leaves_the_others_and_keeps_its_colour() {
        let mut s = state();
        let fill = s.lights[1];
        let e = s.apply(&Action::Light {
            yaw_deg: 90.0,
            pitch_deg: 0.0,
        });
        assert!(e.lights && !e.camera);
        let Light::Directional {
            direction,
            irradiance,
        } = s.lights[0]
        else {
            panic!("still directional")
        };
        assert!(
            (direction - DVec3::new(1.0, -1.0, 0.0)).length() < 1e-9,
            "{direction}"
        );
        assert_eq!(irradiance, [5.0; 3]);
        assert_eq!(s.lights[1], fill);
        // Pitch about the horizontal axis keeps the length.
        let up = turn_light(&s.lights[0], 0.0, 45.0);
        let Light::Directional { direction: d, .. } = up else {
            panic!()
        };
        assert!((d.length() - 2f64.sqrt()).abs() < 1e-9);
        assert!(d.y.abs() < 1e-9 || (d.y + 2f64.sqrt()).abs() < 1e-9, "{d}");
    }

    #[test]
    fn switches_say_what_the_gpu_side_must_redo() {
        let mut s = state();
        assert!(s.apply(&Action::CyclePrecision).rebuild);
        assert_eq!(s.precision, Precision::Fp32);
        assert!(!s.apply(&Action::Precision(Precision::Fp32)).rebuild);
        assert!(s.apply(&Action::Skip(None)).rebuild);
        assert!(!s.skip);
        assert!(!s.apply(&Action::Skip(Some(false))).rebuild);
        assert!(s.apply(&Action::SingleScattering(None)).rebuild);
        assert!(s.single_scattering);
        assert!(!s.apply(&Action::SingleScattering(Some(true))).rebuild);
        assert!(s.apply(&Action::Material("Marble".into())).material);
        assert_eq!(s.material.as_deref(), Some("marble"));
        assert!(!s.apply(&Action::Material("jade".into())).material);
        assert!(s.note.as_deref().is_some_and(|n| n.contains("jade")));
        s.apply(&Action::CycleMaterial(-1));
        assert_eq!(s.material.as_deref(), Some("ketchup"));
        // The method key walks quadgraph -> voxel -> dipole -> quadgraph, each a new object.
        for name in ["voxel", "dipole", "quadgraph"] {
            assert!(s.apply(&Action::CycleMethod).rebuild);
            assert_eq!(s.method_name(), name);
        }
        assert!(s.apply(&Action::Method("dipole".into())).rebuild);
        assert!(
            !s.apply(&Action::Method("dipole".into())).rebuild,
            "already"
        );
        assert!(!s.apply(&Action::Method("photon".into())).rebuild);
        assert!(s.note.as_deref().is_some_and(|n| n.contains("photon")));
        assert!(s.apply(&Action::Quit).quit);
        s.apply(&Action::Orbit {
            yaw_deg: 10.0,
            pitch_deg: 5.0,
        });
        assert!(s.apply(&Action::ResetCamera).camera);
        assert_eq!(s.camera, s.home);
    }

    #[test]
    fn lights_and_cameras_print_in_the_syntax_the_command_line_reads_back() {
        let s = state();
        let turned = turn_light(&s.lights[0], 33.3, -12.1);
        for light in [turned, s.lights[1]] {
            assert_eq!(parse_light(&light_arg(&light)).expect("parses"), light);
        }
        let spot = parse_light("spot:0,0,-50:0,0,1:2000,1800,1500:15,25").expect("spot");
        assert_eq!(parse_light(&light_arg(&spot)).expect("parses"), spot);
        let camera = orbit(s.camera, 17.0, 23.0);
        assert_eq!(parse_camera(&camera_arg(&camera)).expect("parses"), camera);
    }
}
