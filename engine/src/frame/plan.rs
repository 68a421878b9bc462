//! [`FramePlan`]: what a frame runs, decided from what changed since the last one (DESIGN
//! section 5, "Skip what the scene does not need"). Pure logic: no GPU, tested on its own.
//!
//! ```
//! use translucent::frame::plan::{Changes, Conditions, FramePlan, MethodWork, Update};
//! use translucent::frame::SkipReason;
//! let plan = FramePlan::decide(
//!     Changes { camera: true, ..Changes::default() },
//!     &Conditions { skip: true, has_solution: true, casts_shadows: true, shadows_read: true },
//! );
//! assert_eq!(plan.method, MethodWork::Skip(SkipReason::CameraOnly)); // re-shade only
//! assert!(!plan.shadows);
//! let plan = FramePlan::decide(
//!     Changes { lights: true, ..Changes::default() },
//!     &Conditions { skip: true, has_solution: true, casts_shadows: true, shadows_read: true },
//! );
//! assert_eq!(plan.method, MethodWork::Update(Update::Warm));
//! ```

use super::report::SkipReason;

/// The shared shadow pass's name (graph pass, debug label, profiler scope).
pub const PASS_SHADOW: &str = "shadow_map";
/// The shared shading pass's name.
pub const PASS_SHADING: &str = "shading";

/// What changed since the last recorded frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Changes {
    pub lights: bool,
    pub material: bool,
    pub shape: bool,
    pub camera: bool,
}

impl Changes {
    /// Whether the surface exitance must be computed again.
    pub fn exitance(&self) -> bool {
        self.lights || self.material || self.shape
    }
}

/// What the plan needs to know about the object.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Conditions {
    /// Skipping is on ([`crate::object::ObjectParams::skip`]); off, every frame is a cold solve.
    pub skip: bool,
    /// The method holds a solution it can start from.
    pub has_solution: bool,
    /// Some light casts a shadow.
    pub casts_shadows: bool,
    /// Some pass reads the shadow maps (the method's gather, or the specular).
    pub shadows_read: bool,
}

/// How the method updates the surface exitance this frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Update {
    /// From scratch.
    Cold,
    /// From the last solution (lights, material or shape changed).
    Warm,
}

/// What the method does this frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MethodWork {
    /// Update the exitance.
    Update(Update),
    /// The last exitance stands, for this reason (the method lists its passes as skipped).
    Skip(SkipReason),
}

impl MethodWork {
    /// The update, if any.
    pub fn update(self) -> Option<Update> {
        match self {
            MethodWork::Update(u) => Some(u),
            MethodWork::Skip(_) => None,
        }
    }
}

/// What one frame runs; the shading always runs.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FramePlan {
    /// Render the shadow maps.
    pub shadows: bool,
    /// What the method does.
    pub method: MethodWork,
    /// Shared passes left out, with why.
    pub skipped: Vec<(&'static str, SkipReason)>,
}

impl FramePlan {
    /// The plan for a frame with `changes` under `c` (see the module doc).
    pub fn decide(changes: Changes, c: &Conditions) -> FramePlan {
        let (shadows_wanted, method, quiet) = if !c.skip || !c.has_solution {
            (true, Some(Update::Cold), None)
        } else if changes.exitance() {
            (
                changes.lights || changes.shape,
                Some(Update::Warm),
                Some(SkipReason::ShadowsUnchanged),
            )
        } else {
            let why = if changes.camera {
                SkipReason::CameraOnly
            } else {
                SkipReason::Unchanged
            };
            (false, None, Some(why))
        };
        let mut skipped = Vec::new();
        let shadows = shadows_wanted && c.casts_shadows && c.shadows_read;
        if !shadows {
            let why = if shadows_wanted && !c.casts_shadows {
                SkipReason::NoShadowCaster
            } else if shadows_wanted {
                SkipReason::NotRead
            } else {
                quiet.unwrap_or(SkipReason::Unchanged)
            };
            skipped.push((PASS_SHADOW, why));
        }
        FramePlan {
            shadows,
            method: match method {
                Some(u) => MethodWork::Update(u),
                None => MethodWork::Skip(quiet.unwrap_or(SkipReason::Unchanged)),
            },
            skipped,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SOLVED: Conditions = Conditions {
        skip: true,
        has_solution: true,
        casts_shadows: true,
        shadows_read: true,
    };

    #[test]
    fn the_first_frame_and_skipping_off_solve_cold_with_shadows() {
        for c in [
            Conditions {
                has_solution: false,
                ..SOLVED
            },
            Conditions {
                skip: false,
                ..SOLVED
            },
        ] {
            let p = FramePlan::decide(Changes::default(), &c);
            assert_eq!(
                (p.shadows, p.method),
                (true, MethodWork::Update(Update::Cold)),
                "{c:?}"
            );
            assert!(p.skipped.is_empty());
        }
    }

    #[test]
    fn a_material_change_warm_starts_without_shadows() {
        let p = FramePlan::decide(
            Changes {
                material: true,
                ..Changes::default()
            },
            &SOLVED,
        );
        assert_eq!(p.method, MethodWork::Update(Update::Warm));
        assert_eq!(p.skipped, [(PASS_SHADOW, SkipReason::ShadowsUnchanged)]);
    }

    #[test]
    fn lights_or_shape_warm_start_with_shadows_unless_none_cast() {
        for changes in [
            Changes {
                lights: true,
                ..Changes::default()
            },
            Changes {
                shape: true,
                ..Changes::default()
            },
        ] {
            let p = FramePlan::decide(changes, &SOLVED);
            assert_eq!(
                (p.shadows, p.method),
                (true, MethodWork::Update(Update::Warm))
            );
            let dark = FramePlan::decide(
                changes,
                &Conditions {
                    casts_shadows: false,
                    shadows_read: true,
                    ..SOLVED
                },
            );
            assert_eq!(dark.skipped, [(PASS_SHADOW, SkipReason::NoShadowCaster)]);
            // A precomputed exitance without specular: nothing would read the shadow maps.
            let unread = FramePlan::decide(
                changes,
                &Conditions {
                    shadows_read: false,
                    ..SOLVED
                },
            );
            assert!(!unread.shadows);
            assert_eq!(unread.skipped, [(PASS_SHADOW, SkipReason::NotRead)]);
        }
    }

    #[test]
    fn nothing_or_the_camera_only_reshades() {
        for (changes, why) in [
            (Changes::default(), SkipReason::Unchanged),
            (
                Changes {
                    camera: true,
                    ..Changes::default()
                },
                SkipReason::CameraOnly,
            ),
        ] {
            let p = FramePlan::decide(changes, &SOLVED);
            assert_eq!((p.shadows, p.method), (false, MethodWork::Skip(why)));
            assert_eq!(p.skipped, [(PASS_SHADOW, why)]);
        }
    }
}
