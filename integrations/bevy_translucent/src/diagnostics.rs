//! Our FrameReport in the main world: [`TranslucentFrames`] (every object frame and error) and
//! Bevy diagnostics, one measurement per object frame:
//!
//! | path | value |
//! |---|---|
//! | `translucent/gpu_ms` | GPU ms of our passes in the object's last completed frame |
//! | `translucent/passes` | passes recorded |
//! | `translucent/skipped` | passes (or parts) skipped |
//! | `translucent/solve` | 1 when the frame solved the diffusion, else 0 |
//! | `translucent/warm_start` | 1 when that solve started from the last solution |
//! | `translucent/shading_only` | 1 when the frame recorded only the shading pass |
//!
//! Reports reach the main world one update after the frame that recorded them.

use bevy::diagnostic::{DiagnosticPath, Diagnostics};
use bevy::prelude::*;
use translucent::solver::gpu::PASS_SOLVE;
use translucent::vk::FrameTimings;

use crate::render::{Channel, ObjectFrame};

pub const GPU_MS: DiagnosticPath = DiagnosticPath::const_new("translucent/gpu_ms");
pub const PASSES: DiagnosticPath = DiagnosticPath::const_new("translucent/passes");
pub const SKIPPED: DiagnosticPath = DiagnosticPath::const_new("translucent/skipped");
pub const SOLVE: DiagnosticPath = DiagnosticPath::const_new("translucent/solve");
pub const WARM_START: DiagnosticPath = DiagnosticPath::const_new("translucent/warm_start");
pub const SHADING_ONLY: DiagnosticPath = DiagnosticPath::const_new("translucent/shading_only");
/// Every path above (registered by the plugin).
pub const PATHS: [DiagnosticPath; 6] = [GPU_MS, PASSES, SKIPPED, SOLVE, WARM_START, SHADING_ONLY];

/// The name of our shading pass (the last pass of every frame).
const PASS_SHADING: &str = "shading";

/// Every object frame received so far (oldest first) and every error of the plugin.
#[derive(Resource, Default, Debug)]
pub struct TranslucentFrames {
    pub frames: Vec<ObjectFrame>,
    pub errors: Vec<String>,
}

fn flag(b: bool) -> f64 {
    if b {
        1.0
    } else {
        0.0
    }
}

/// The GPU ms of a frame's top-level scopes (our passes; nested scopes are inside them).
pub fn gpu_ms(t: &FrameTimings) -> f64 {
    t.scopes
        .iter()
        .filter(|s| s.depth == 0)
        .map(|s| s.duration_ms)
        .sum()
}

/// Moves what the render world sent into [`TranslucentFrames`] and the diagnostics.
pub fn publish(
    channel: Res<Channel>,
    mut frames: ResMut<TranslucentFrames>,
    mut diagnostics: Diagnostics,
) {
    let (new, errors) = {
        let mut outbox = channel.lock();
        (
            std::mem::take(&mut outbox.frames),
            std::mem::take(&mut outbox.errors),
        )
    };
    for f in &new {
        let r = &f.report;
        let solved = r.passes.contains(&PASS_SOLVE);
        diagnostics.add_measurement(&PASSES, || r.passes.len() as f64);
        diagnostics.add_measurement(&SKIPPED, || r.skipped.len() as f64);
        diagnostics.add_measurement(&SOLVE, || flag(solved));
        diagnostics.add_measurement(&WARM_START, || flag(solved && r.warm_start));
        diagnostics.add_measurement(&SHADING_ONLY, || flag(r.passes == [PASS_SHADING]));
        if let Some(t) = &f.gpu {
            diagnostics.add_measurement(&GPU_MS, || gpu_ms(t));
        }
    }
    frames.frames.extend(new);
    frames.errors.extend(errors);
}
