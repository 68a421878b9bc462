//! The method seam (DESIGN section 6): the part of a frame that turns the light arriving at the
//! object into the display mesh's surface exitance is one [`Method`]. Everything around it is
//! shared by every method: the shadow maps (rendered before the method's passes, from the same
//! display mesh), the shading (F_t / exit lobe, specular, environment reflection, into the host's
//! target), capture, profiling and the [`super::FrameReport`].
//!
//! A method keeps its own GPU state and, per frame, [`Method::prepare`]s (bookkeeping, `&mut`),
//! then adds its passes to the frame graph (`&self`): edits that move the display mesh before
//! the shadow pass ([`Method::add_edit_passes`]), the rest after it ([`Method::add_passes`]),
//! ending with the exitance written into the display mesh's vertex buffer (`Vertex::exitance`,
//! the outgoing partial current J+ the shading turns into radiance).
//!
//! Methods: [`MethodKind::QuadGraph`] ([`super::QuadGraphMethod`], the diffusion on the
//! QuadGraph) and [`super::FixedExitance`] (exitance given per vertex: the f64 CPU reference's
//! output, test fixtures). The voxel and dipole methods plug in here.

use glam::DVec3;

use super::graph::FrameGraph;
use super::plan::MethodWork;
use super::report::{CompletedSolve, SkipReason};
use crate::material::MaterialField;
use crate::render::ShadowMaps;
use crate::scene::Scene;
use crate::solver::gpu::Deformation;
use crate::vk::{Buffer, Context};
use crate::Error;

/// The methods behind `--method` (DESIGN section 8).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum MethodKind {
    /// Diffusion on the QuadGraph (Wang et al. 2010).
    #[default]
    QuadGraph,
    /// Shortest optical paths on a voxel grid (Ozawa et al.).
    Voxel,
    /// Hierarchical boundary elements with the dipole (Mertens et al. 2003).
    Dipole,
}

impl MethodKind {
    /// Its `--method` name.
    pub fn name(self) -> &'static str {
        match self {
            MethodKind::QuadGraph => "quadgraph",
            MethodKind::Voxel => "voxel",
            MethodKind::Dipole => "dipole",
        }
    }
}

impl std::str::FromStr for MethodKind {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self, Error> {
        match s {
            "quadgraph" => Ok(MethodKind::QuadGraph),
            "voxel" => Ok(MethodKind::Voxel),
            "dipole" => Ok(MethodKind::Dipole),
            _ => Err(super::graph::FrameError::Invalid {
                pass: "method",
                problem: format!("unknown method {s:?} (quadgraph, voxel, dipole)"),
            }
            .into()),
        }
    }
}

/// What a method will record this frame ([`Method::prepare`]).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct MethodFrame {
    /// The update starts from the last solution.
    pub warm_start: bool,
    /// Levels (or grids) iterated; 0 without an update.
    pub levels_iterated: u32,
    /// The method's passes (or parts of them) left out, with why.
    pub skipped: Vec<(&'static str, SkipReason)>,
    /// Staged edits move the display mesh (the shadow maps must be rendered again).
    pub moves_mesh: bool,
}

/// One way of computing the surface exitance (see the module doc). `Send`, so that a host may keep
/// a [`crate::TranslucentObject`] in state another thread owns (Bevy's render world does).
pub trait Method: Send {
    /// The `--method` name, for reports.
    fn name(&self) -> &'static str;

    /// New lights and environment, already validated; `shadows` are refitted to them.
    fn set_lights(&mut self, scene: &Scene, shadows: &ShadowMaps) -> Result<(), Error>;

    /// A new material: validated and staged here (an error changes nothing), recorded by the
    /// next frame.
    fn set_material(&mut self, ctx: &Context, field: &MaterialField) -> Result<(), Error>;

    /// A new shape: validated and staged (an error changes nothing); returns the deformed
    /// object's bounding sphere (centre, radius in mm), which the shadow views refit to.
    fn deform(&mut self, ctx: &Context, deformation: &Deformation) -> Result<(DVec3, f64), Error>;

    /// Whether a solution exists that an update can start from.
    fn has_solution(&self) -> bool;

    /// Whether the method's passes read the shadow maps (a gather does; a precomputed exitance
    /// does not, and then only the specular needs them).
    fn reads_shadows(&self) -> bool {
        true
    }

    /// The material path in use (`homogeneous` or `heterogeneous`).
    fn material_variant(&self) -> &'static str;

    /// Decides this frame's work and does the bookkeeping; the passes added next record exactly
    /// this. A skipped method lists its passes in [`MethodFrame::skipped`] with the reason.
    fn prepare(&mut self, work: MethodWork, frame: u64) -> Result<MethodFrame, Error>;

    /// Passes that run before the shadow maps (staged edits that move the display mesh).
    fn add_edit_passes<'g>(&'g self, graph: &mut FrameGraph<'g>);

    /// The method's passes after the shadow maps, ending with the display mesh's exitance.
    fn add_passes<'g>(
        &'g self,
        graph: &mut FrameGraph<'g>,
        shadows: &'g ShadowMaps,
    ) -> Result<(), Error>;

    /// [`super::BounceMode::Source`]: after the bounce pass left E_b per display vertex in
    /// `irradiance`, the passes that add it to the solve's source, solve again and write the new
    /// exitance (nothing where the method takes no bounce source: the default).
    fn add_bounce_passes<'g>(&'g self, graph: &mut FrameGraph<'g>, irradiance: &'g Buffer) {
        let _ = (graph, irradiance);
    }

    /// Updates of frames `<= completed_frame` not reported yet (GPU counters read after the
    /// host's fence; no wait).
    fn completed(&mut self, completed_frame: u64) -> Result<Vec<CompletedSolve>, Error>;

    /// GPU bytes of the method's resources.
    fn gpu_bytes(&self) -> u64;

    /// The per-node exit lobe's vertex stream ([`crate::scene::ExitLobe::Node`]): 16 bytes per
    /// display vertex, the diffused share ([`crate::scene::diffused_share`]) in the 4th float,
    /// written by [`Self::add_passes`]. `None`: the method has no share (the shading reads 0, a
    /// node's own light).
    fn exit_share(&self) -> Option<&Buffer> {
        None
    }

    /// Whether [`Self::exit_share`]'s first three floats per vertex hold the exitance the method
    /// wrote (before [`super::bounce`] adds to it in place): the shading then draws the bounced
    /// part with the Lambertian lobe ([`crate::scene::ExitLobe::with_bounce`]).
    fn exit_share_carries_exitance(&self) -> bool {
        false
    }

    /// For method-specific reports (e.g. [`super::QuadGraphMethod::report`]).
    fn as_any(&self) -> &dyn std::any::Any;

    /// For method-specific settings (e.g. [`super::FixedExitance::set_exitance`]).
    fn as_any_mut(&mut self) -> &mut dyn std::any::Any;
}
