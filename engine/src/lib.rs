//! # Translucent
//!
//! Real-time rendering of heterogeneous translucent objects (marble, jade, wax, milk, skin) on Vulkan.
//! Every frame solves the light diffusion equation inside the object on a volumetric graph (the
//! QuadGraph of Wang et al. 2010), so lights, materials and shape can change at run time.
//!
//! ## The model on one page
//!
//! **Who submits, who waits.** The host owns the device, the queue, the command buffers and the
//! frame loop. A [`TranslucentObject`] records into the host's command buffer
//! ([`TranslucentObject::record`]) and never begins, ends or submits one, never waits on a fence
//! and never destroys a host object. Headless programs (tests, `translucent render`, the bench)
//! use [`headless::HeadlessHost`], a minimal host that submits one frame and waits for it.
//!
//! **Frames and release.** Each record names the frame being recorded (monotonic) and the last
//! frame the GPU finished ([`RecordCtx`]). What an object drops while a frame may still read it
//! (an old material texture, a replaced mesh) is queued on the [`vk::Context`] and destroyed
//! when a later record reports that frame complete; the iterations a solve ran come back the same
//! way, in a later frame's [`FrameReport::completed`].
//!
//! **Changes and the plan.** Setters ([`TranslucentObject::set_lights`], `set_material`,
//! `deform`, `set_camera`) validate at once (a typed error changes nothing) and mark what
//! changed. At record time [`frame::FramePlan`] turns the changes into what runs and, for each
//! pass that does not, why ([`SkipReason`]).
//!
//! **The frame graph.** A frame is one [`frame::FrameGraph`]: passes in order, each declaring
//! the resources it touches and how ([`vk::barrier::Use`]: first and last access). The graph
//! places every barrier between passes from those declarations (with a generated "why"), opens
//! one debug label and one GPU timestamp scope per pass under the pass's name, and returns what
//! ran and what was skipped. Barriers inside a pass (between Jacobi sweeps) stay the pass's.
//! Host targets enter as imported resources with the state they come in and must leave in.
//!
//! **The method seam.** What turns gathered light into surface exitance is a [`frame::Method`]
//! (the QuadGraph solve; a fixed exitance for references); shadow maps, gathering, shading and
//! capture are shared by every method. [`MethodDesc`] selects one.
//!
//! The modules, lowest first (imports run one way: `vk` <- `shader` <- {`render`, `solver`} <-
//! `frame` <- `object`):
//! - [`vk`]: a thin owning layer over ash that knows nothing about translucency; [`shader`]:
//!   embedded SPIR-V and its reflection.
//! - [`mesh`], [`tet`], [`quadgraph`], [`material`], [`scene`]: data (meshes, tetrahedra, the
//!   baked graph, optical coefficients, lights and cameras).
//! - [`render`]: passes (shadow maps, irradiance gather, shading, capture); [`solver`]: the
//!   diffusion solvers (f64 CPU reference, GPU). Neither imports the other.
//! - [`frame`]: the graph, the plan, the methods and the report; [`object`]: the composition;
//!   [`headless`]: a host for programs without a window.
//!
//! ## Adding a pass
//!
//! A pass is a name, its declarations and a closure that records it. It records no barrier for
//! what it declared; the graph puts them before it:
//!
//! ```no_run
//! use translucent::frame::FrameGraph;
//! use translucent::vk::{barrier::Use, Access, Context, Image};
//!
//! /// Our new pass's name: the debug label, the profiler scope and the report's entry.
//! const PASS_BLUR: &str = "blur_q";
//!
//! # fn f(ctx: &Context, cb: ash::vk::CommandBuffer, q: &Image, blurred: &Image)
//! #      -> Result<(), translucent::Error> {
//! let mut graph = FrameGraph::new(ctx);
//! // ... earlier passes wrote `q` ...
//! graph
//!     .pass(PASS_BLUR)
//!     .uses([Use::image(q, Access::ComputeRead), Use::image(blurred, Access::ComputeWrite)])
//!     .record(|p| {
//!         // bind the pipeline, push constants, dispatch: p.ctx.raw().cmd_dispatch(p.cb, ..)
//!         let _ = (p.ctx, p.cb);
//!         Ok(())
//!     });
//! // SAFETY: `cb` is recording outside a rendering scope; `q` and `blurred` outlive it.
//! let run = unsafe { graph.execute(cb, None, false)? };
//! for note in &run.barriers {
//!     println!("before {}: {}", note.before, note.why);
//! }
//! # Ok(()) }
//! ```
//!
//! Inside [`TranslucentObject`] a method adds its passes in [`frame::Method::add_passes`]; a pass
//! every method shares goes into [`object`]'s composition next to the shadow and shading passes.

pub mod defaults;
pub mod frame;
pub mod headless;
#[cfg(feature = "wgpu")]
pub mod interop;
pub mod limits;
pub mod material;
pub mod mesh;
pub mod object;
pub mod quadgraph;
pub mod render;
pub mod scene;
pub mod shader;
pub mod solver;
pub mod tet;
pub mod vk;

pub use frame::{FrameReport, SkipReason};
pub use object::{MethodDesc, ObjectParams, RecordCtx, TargetImage, Targets, TranslucentObject};
pub use quadgraph::graph::{GraphLevel, NodeKind, QuadGraph};

/// Every error the library returns. Each module has its own typed error; this wraps them.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error(transparent)]
    Vk(#[from] vk::VkError),
    #[error(transparent)]
    Mesh(#[from] mesh::MeshError),
    #[error(transparent)]
    Bake(#[from] quadgraph::BakeError),
    #[error(transparent)]
    Material(#[from] material::MaterialError),
    #[error(transparent)]
    Solver(#[from] solver::SolverError),
    #[error(transparent)]
    Shader(#[from] shader::ShaderError),
    #[error(transparent)]
    Render(#[from] render::RenderError),
    #[error(transparent)]
    Scene(#[from] scene::SceneError),
    #[error(transparent)]
    Frame(#[from] frame::FrameError),
}

/// Result with the crate's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;
