//! What the user can ask the viewer to do ([`Action`]) and which key asks for it. Mouse drags,
//! the wheel, keys and script lines all become actions, so a script replays exactly what the
//! keyboard and mouse do.
//!
//! ```text
//! left drag: orbit    wheel: zoom    right drag: key light direction
//! ```

use std::path::PathBuf;

use translucent::scene::Camera;
use translucent::solver::gpu::Precision;

/// Degrees of orbit per pixel of mouse drag.
pub const DEGREES_PER_PIXEL: f64 = 0.3;
/// Distance factor per wheel line (a wheel step up moves closer).
pub const ZOOM_PER_LINE: f64 = 0.9;
/// Wheel lines per pixel of a touchpad's pixel delta.
pub const LINES_PER_PIXEL: f64 = 1.0 / 40.0;

/// One request to the viewer.
#[derive(Clone, Debug, PartialEq)]
pub enum Action {
    /// Turn the camera about its target: `yaw_deg` about +Y, `pitch_deg` up (left drag).
    Orbit {
        yaw_deg: f64,
        pitch_deg: f64,
    },
    /// Multiply the camera's distance to its target (wheel).
    Zoom(f64),
    /// Put the camera exactly here.
    Camera(Camera),
    /// Back to the starting camera.
    ResetCamera,
    /// Turn the key light (the first light) about the object: `yaw_deg` about +Y, `pitch_deg`
    /// about the horizontal axis across its direction (right drag).
    Light {
        yaw_deg: f64,
        pitch_deg: f64,
    },
    /// A material by name (a measured preset or a procedural pattern).
    Material(String),
    /// The next (+1) or previous (-1) material of [`crate::view::state::MATERIALS`].
    CycleMaterial(i32),
    /// A method by name (see [`crate::view::state::METHODS`]).
    Method(String),
    /// The next method of the list.
    CycleMethod,
    Precision(Precision),
    /// mixed -> fp32 -> fp16 -> mixed.
    CyclePrecision,
    /// Single scattering on (`Some(true)`), off, or toggled (`None`).
    SingleScattering(Option<bool>),
    /// The object's skips on, off or toggled (`ObjectParams::skip`).
    Skip(Option<bool>),
    /// The text overlay on, off or toggled.
    Overlay(Option<bool>),
    /// The key list in the overlay on, off or toggled.
    Help(Option<bool>),
    /// Ask the window for this inner size in pixels.
    Resize {
        width: u32,
        height: u32,
    },
    /// Write the current frame: PNG and EXR next to each other (`None`: a numbered name).
    Screenshot(Option<PathBuf>),
    /// Compile the shaders that changed in the shader directory and use them (hot reload).
    ReloadShaders,
    Quit,
}

/// Keys and what they do, for the overlay's help and the README. A key is its character
/// (lower case; upper case means with Shift) or a named key in lower case (`escape`, `f12`, ...).
pub const BINDINGS: &[(&str, &str)] = &[
    ("left drag", "orbit the camera"),
    ("wheel", "zoom"),
    ("right drag", "turn the key light"),
    ("1..5", "material: skimmilk marble skin1 wholemilk ketchup"),
    (
        "6..9, 0",
        "material: apple potato veined-marble agate split",
    ),
    ("m / M", "next / previous material"),
    ("k", "next method (quadgraph; voxel, dipole when built)"),
    ("p", "precision: mixed -> fp32 -> fp16"),
    ("s", "single scattering on/off"),
    ("x", "skipping on/off"),
    ("r", "reset the camera"),
    ("c or f12", "screenshot (PNG + EXR)"),
    ("h", "this help"),
    ("o", "overlay on/off"),
    ("f5", "reload changed shaders (--shader-dir)"),
    ("escape or q", "quit"),
];

/// The materials keys `1`..`9`, `0` select, in that order.
pub const NUMBER_KEY_MATERIALS: [&str; 10] = [
    "skimmilk",
    "marble",
    "skin1",
    "wholemilk",
    "ketchup",
    "apple",
    "potato",
    "veined-marble",
    "agate",
    "split",
];

/// The action of key `key` (see [`BINDINGS`] for the names), if it has one.
pub fn key_action(key: &str) -> Option<Action> {
    if let Some(digit) = key.chars().next().and_then(|c| c.to_digit(10)) {
        if key.len() == 1 {
            // 1..9 then 0: the keyboard's order.
            let index = (digit as usize + 9) % 10;
            return Some(Action::Material(NUMBER_KEY_MATERIALS[index].into()));
        }
    }
    Some(match key {
        "m" => Action::CycleMaterial(1),
        "M" => Action::CycleMaterial(-1),
        "k" | "K" => Action::CycleMethod,
        "p" | "P" => Action::CyclePrecision,
        "s" | "S" => Action::SingleScattering(None),
        "x" | "X" => Action::Skip(None),
        "r" | "R" => Action::ResetCamera,
        "c" | "C" | "f12" => Action::Screenshot(None),
        "h" | "H" => Action::Help(None),
        "o" | "O" => Action::Overlay(None),
        "f5" => Action::ReloadShaders,
        "escape" | "q" | "Q" => Action::Quit,
        _ => return None,
    })
}

/// Mouse state: which button drags and where the cursor was.
#[derive(Clone, Copy, Debug, Default)]
pub struct Mouse {
    pub left: bool,
    pub right: bool,
    pub last: Option<(f64, f64)>,
}

impl Mouse {
    /// The action of moving the cursor to `(x, y)` (pixels), given the buttons held.
    pub fn moved(&mut self, x: f64, y: f64) -> Option<Action> {
        let last = self.last.replace((x, y));
        let (dx, dy) = match last {
            Some((lx, ly)) => (x - lx, y - ly),
            None => return None,
        };
        if dx == 0.0 && dy == 0.0 {
            return None;
        }
        // Dragging right turns the scene right: the camera goes left (negative yaw); dragging
        // down looks from higher up.
        let (yaw_deg, pitch_deg) = (-dx * DEGREES_PER_PIXEL, dy * DEGREES_PER_PIXEL);
        if self.left {
            Some(Action::Orbit { yaw_deg, pitch_deg })
        } else if self.right {
            Some(Action::Light {
                yaw_deg: -yaw_deg,
                pitch_deg,
            })
        } else {
            None
        }
    }
}

/// The zoom of `lines` wheel lines (positive: away from the user, closer to the object).
pub fn wheel_action(lines: f64) -> Option<Action> {
    (lines != 0.0 && lines.is_finite()).then(|| Action::Zoom(ZOOM_PER_LINE.powf(lines)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn number_keys_follow_the_keyboard_and_every_binding_named_in_the_help_exists() {
        assert_eq!(key_action("1"), Some(Action::Material("skimmilk".into())));
        assert_eq!(key_action("0"), Some(Action::Material("split".into())));
        assert_eq!(key_action("M"), Some(Action::CycleMaterial(-1)));
        assert_eq!(key_action("escape"), Some(Action::Quit));
        assert_eq!(key_action("f12"), Some(Action::Screenshot(None)));
        assert_eq!(key_action("z"), None);
        assert_eq!(key_action("12"), None);
        for key in ["m", "k", "p", "s", "x", "r", "c", "h", "o", "f5", "q"] {
            assert!(key_action(key).is_some(), "{key}");
            assert!(
                BINDINGS
                    .iter()
                    .any(|(k, _)| k.split([' ', '/']).any(|w| w == key)),
                "{key} is bound but not in the help"
            );
        }
    }

    #[test]
    fn drags_orbit_or_turn_the_light_and_the_wheel_zooms() {
        let mut mouse = Mouse::default();
        assert_eq!(
            mouse.moved(10.0, 10.0),
            None,
            "the first position only anchors"
        );
        mouse.left = true;
        let Some(Action::Orbit { yaw_deg, pitch_deg }) = mouse.moved(20.0, 10.0) else {
            panic!("left drag orbits");
        };
        assert_eq!((yaw_deg, pitch_deg), (-10.0 * DEGREES_PER_PIXEL, 0.0));
        mouse.left = false;
        mouse.right = true;
        assert!(matches!(
            mouse.moved(20.0, 30.0),
            Some(Action::Light { .. })
        ));
        mouse.right = false;
        assert_eq!(mouse.moved(25.0, 30.0), None, "no button: no action");
        let Some(Action::Zoom(f)) = wheel_action(2.0) else {
            panic!("the wheel zooms")
        };
        assert!((f - ZOOM_PER_LINE * ZOOM_PER_LINE).abs() < 1e-12);
        assert_eq!(wheel_action(0.0), None);
    }
}
