//! What a frame ran ([`FrameReport`]) and why a pass did not run ([`SkipReason`]).

use std::collections::BTreeMap;

use super::graph::BarrierNote;
use crate::solver::gpu::LevelControl;

/// Why a pass did not run this frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SkipReason {
    /// Nothing changed since the last solve.
    Unchanged,
    /// Only the camera changed: the view-dependent part is in the shading.
    CameraOnly,
    /// No light casts a shadow (environment only, or the lights are black).
    NoShadowCaster,
    /// The lights and the shape did not change (the last shadow maps still hold).
    ShadowsUnchanged,
    /// Started from the last solution (no Shepard initialisation).
    WarmStart,
    /// The finest level is small enough to iterate alone
    /// ([`crate::object::ObjectParams::single_level_nodes`]).
    SmallGraph,
    /// Nothing staged (no material or shape edit).
    NoEdits,
    /// The method's exitance is given (precomputed), not solved.
    Precomputed,
    NotRead,
    /// Single scattering: every light is in front of the object as the eye sees it, where the
    /// march minus the flat closed form is below the error budget
    /// ([`crate::frame::single_scattering::FRONT_LIT_COSINE`]).
    FrontLit,
    /// Single scattering: no light is above the error budget (all black, as `--env-constant`'s
    /// placeholder light, or below [`crate::frame::single_scattering::DARK_LIGHT_FRACTION`] of
    /// the brightest light or environment): the march would add nothing visible.
    DarkLights,
}

impl std::fmt::Display for SkipReason {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            SkipReason::Unchanged => "nothing changed",
            SkipReason::CameraOnly => "camera only",
            SkipReason::NoShadowCaster => "no shadow-casting light",
            SkipReason::ShadowsUnchanged => "lights and shape unchanged",
            SkipReason::WarmStart => "warm start",
            SkipReason::SmallGraph => "small graph: one level",
            SkipReason::NoEdits => "no edits",
            SkipReason::Precomputed => "exitance precomputed",
            SkipReason::NotRead => "no pass reads it",
            SkipReason::FrontLit => "front-lit: below the error budget",
            SkipReason::DarkLights => "no light above the error budget",
        })
    }
}

/// The GPU counters of a solve that completed (see [`crate::TranslucentObject::completed_solves`]).
#[derive(Clone, Debug, PartialEq)]
pub struct CompletedSolve {
    /// The host frame that ran it.
    pub frame: u64,
    /// Per level, coarsest first (the cascade's counters: a multigrid solve runs none of its
    /// Jacobi levels and reports 0 there).
    pub levels: Vec<LevelControl>,
    /// The multigrid schedule's cycles, work units and residual (`None` with the cascade and
    /// the methods without a solve).
    pub multigrid: Option<crate::solver::gpu::multigrid::GpuMultigridReport>,
    /// `--bounce source`'s second solve of the same frame (warm from the first, the bounced
    /// light added to q: [`crate::frame::BounceMode::Source`]); `None` without it.
    pub bounce: Option<crate::solver::gpu::multigrid::GpuMultigridReport>,
}

impl CompletedSolve {
    /// Iterations run per level.
    pub fn iterations(&self) -> Vec<u32> {
        self.levels.iter().map(|l| l.iterations).collect()
    }
    /// Whether every level that iterated stopped at the tolerance before its cap (a stalled
    /// level did not).
    pub fn converged(&self) -> bool {
        if let Some(mg) = &self.multigrid {
            return mg.converged && self.bounce.as_ref().is_none_or(|b| b.converged);
        }
        self.levels
            .iter()
            .all(|l| l.iterations == 0 || l.stopped_early == LevelControl::CONVERGED)
    }
    /// Whether a level stopped because its update rounded to zero before the tolerance
    /// ([`LevelControl::STALLED`]: fp16 phi).
    pub fn stalled(&self) -> bool {
        self.levels
            .iter()
            .any(|l| l.stopped_early == LevelControl::STALLED)
    }
}

/// What one [`crate::TranslucentObject::record`] recorded.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameReport {
    pub frame: u64,
    /// The method that produced the surface exitance (`quadgraph`, ...).
    pub method: &'static str,
    /// When the method was chosen by `--method auto` ([`super::choose_method`]): the choice and
    /// its reason ([`crate::TranslucentObject::set_method_choice`]).
    pub method_choice: Option<super::MethodChoice>,
    /// Passes recorded, in order: the frame graph's pass names, which are also the debug labels
    /// and the profiler's top-level scopes.
    pub passes: Vec<&'static str>,
    /// Per pass (or part of a pass) not recorded, why.
    pub skipped: BTreeMap<&'static str, SkipReason>,
    /// The solve started from the last solution.
    pub warm_start: bool,
    /// Levels the solve iterated (0 without a solve).
    pub levels_iterated: u32,
    /// `homogeneous` (kappa, mu from push constants) or `heterogeneous` (per-node weights).
    pub material_variant: &'static str,
    /// Solves of earlier frames that completed since the last report (iterations, convergence).
    pub completed: Vec<CompletedSolve>,
    /// The barriers the frame graph placed between passes, each with its generated "why".
    pub barriers: Vec<BarrierNote>,
}
