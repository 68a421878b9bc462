//! One frame of a translucent object, as a small render graph (kajiya / Granite style, ours).
//!
//! - [`graph`]: [`FrameGraph`]: passes declare the resources they use and how; the graph places
//!   every barrier between passes, one debug label and one timestamp scope per pass, and says
//!   what ran and what was skipped.
//! - [`plan`]: [`FramePlan`]: what a frame runs, decided from what changed since the last one.
//! - [`method`]: the [`Method`] seam: the passes that turn gathered light into surface
//!   exitance ([`QuadGraphMethod`], [`DipoleMethod`]; [`FixedExitance`] for given values), between the
//!   shared shadow maps and the shared shading.
//! - [`report`]: [`FrameReport`] and [`SkipReason`].
//! - [`choice`]: `--method auto`'s rule ([`choose_method`]).
//! - [`single_scattering`]: [`SingleScatteringPass`], DESIGN 2.8 as a shared pass after the
//!   method's (every method gets it; `ObjectParams::single_scattering`).
//! - [`bounce`]: [`BouncePass`], one bounce of exitance between display vertices (light leaving
//!   the surface and entering it again elsewhere), after the method's exitance
//!   ([`crate::TranslucentObject::set_bounce`]).
//!
//! [`crate::TranslucentObject::record`] is the one composition: changes -> [`FramePlan`] ->
//! the method's edit passes -> shadow maps -> the method's passes -> single scattering's depth
//! pre-pass and march (when on and not skipped as front-lit) -> shading, into the host's
//! targets, all through one [`FrameGraph`]. The headless renderer, `translucent render`,
//! `translucent bench`, the example host and the viewer all record frames through it.

pub mod bounce;
pub mod choice;
pub mod dipole;
pub mod exitance;
pub mod graph;
pub mod method;
pub mod plan;
pub mod quadgraph;
pub mod report;
pub mod single_scattering;
pub mod tangential;
pub mod voxel;

pub use bounce::{BounceLinks, BounceMode, BounceParams, BouncePass, PASS_BOUNCE};
pub use choice::{choose_method, MethodChoice, SceneTraits};
pub use dipole::{DipoleMethod, DipoleParams};
pub use exitance::FixedExitance;
pub use graph::{BarrierNote, FrameError, FrameGraph, GraphRun, PassCtx, ResourceId};
pub use method::{Method, MethodFrame, MethodKind};
pub use plan::{FramePlan, PASS_SHADING, PASS_SHADOW};
pub use quadgraph::{solve_headless, QuadGraphMethod, QuadGraphReport, SINGLE_LEVEL_NODES};
pub use report::{CompletedSolve, FrameReport, SkipReason};
pub use single_scattering::{
    ScatterMode, ScatterParams, SingleScatteringPass, PASS_SCATTER_DEPTHS, PASS_SINGLE_SCATTERING,
};
pub use tangential::{TangentialPass, PASS_TANGENTIAL};
pub use voxel::VoxelMethod;
