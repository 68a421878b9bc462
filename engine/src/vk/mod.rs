//! A thin owning layer over ash. Knows nothing about translucency.
//!
//! The model:
//! - [`Context`] is either owned ([`Context::headless`]: instance, device, one queue, validation) or
//!   borrowed from a host ([`Context::from_host`]: the host keeps its entry, instance and device; we
//!   never destroy them, never submit and never wait on its queue).
//! - Frames: the host (or the headless submitter) says which frame it records with
//!   [`Context::begin_frame`] and which frame the GPU has finished with [`Context::frame_completed`].
//!   A [`Buffer`] or [`Image`] dropped while frame `n` is being recorded is destroyed once frame `n` is
//!   reported complete, never earlier.
//! - Memory comes from gpu-allocator; the `Allocator` is dropped before the device.
//! - Barriers go through synchronization2 with the named states of [`barrier::Access`].
//! - [`GpuProfiler`] writes named, nestable timestamp scopes and reads them without stalling.
//! - [`capture`] reads a color target back and writes PNG or EXR atomically.
//!
//! ```no_run
//! use translucent::vk::{Buffer, BufferDesc, Context, ContextDesc, MemoryUse};
//! # fn main() -> Result<(), translucent::vk::VkError> {
//! let ctx = Context::headless(&ContextDesc { validation: true, ..ContextDesc::default() })?;
//! let buffer = Buffer::new(
//!     &ctx,
//!     &BufferDesc {
//!         name: "example",
//!         size: 1024,
//!         usage: ash::vk::BufferUsageFlags::TRANSFER_DST,
//!         memory: MemoryUse::Readback,
//!     },
//! )?;
//! ctx.execute("fill", |cb| {
//!     // SAFETY: `cb` is recording and `buffer` lives until the submission completes.
//!     unsafe { ctx.raw().cmd_fill_buffer(cb, buffer.raw, 0, 1024, 7) };
//!     Ok(())
//! })?;
//! assert_eq!(buffer.read_bytes()?[0], 7);
//! drop(buffer); // destroyed at once: no frame is in flight
//! assert!(ctx.take_validation_messages().is_empty());
//! # Ok(()) }
//! ```

pub mod barrier;
pub mod capture;
pub(crate) mod context;
pub(crate) mod device;
mod memory;
mod profiler;
pub(crate) mod validation;

pub use barrier::{Access, ImageState, Tracked};
pub use capture::{ImageReadback, LinearImage};
#[cfg(feature = "wgpu")]
pub(crate) use context::HostOptions;
pub use context::{
    Context, ContextDesc, DeviceInfo, HostVulkan, Severity, Submission, ValidationLog,
    ValidationMessage,
};
pub use memory::{
    Buffer, BufferDesc, BufferView, Image, ImageDesc, MemoryUse, Sampler, VolumeDesc,
};
pub use profiler::{FrameTimings, GpuProfiler, ScopeTiming};

/// The Vulkan version and features every context requires.
pub const REQUIRED_FEATURES: [&str; 3] = ["synchronization2", "dynamicRendering", "maintenance4"];

/// What to install when no Vulkan device is found (Debian package names).
pub const INSTALL_HINT: &str =
    "install a Vulkan driver; for the CPU driver lavapipe and the validation layer: \
     `apt-get install mesa-vulkan-drivers vulkan-validationlayers`";

/// A failing Vulkan call, an unsuitable device or a failed read-back/write.
#[derive(Debug, thiserror::Error)]
pub enum VkError {
    #[error("{call} failed: {result}")]
    Call {
        call: &'static str,
        result: ash::vk::Result,
    },
    #[error("cannot load the Vulkan loader (libvulkan.so.1): {0}; {INSTALL_HINT}")]
    Loader(String),
    /// The loader found no driver (vkCreateInstance: VK_ERROR_INCOMPATIBLE_DRIVER).
    #[error("the Vulkan loader found no driver (vkCreateInstance: {result}); {INSTALL_HINT}")]
    NoDriver { result: ash::vk::Result },
    #[error("no Vulkan device{}; available: [{}]; {INSTALL_HINT}",
        .wanted.as_ref().map(|w| format!(" whose name contains {w:?} (TRANSLUCENT_DEVICE)")).unwrap_or_default(),
        .available.join(", "))]
    NoDevice {
        wanted: Option<String>,
        available: Vec<String>,
    },
    #[error("device {device:?} does not support Vulkan 1.3 (it reports {version})")]
    ApiVersion { device: String, version: String },
    #[error("device {device:?} lacks the required Vulkan 1.3 feature `{feature}`")]
    MissingFeature {
        device: String,
        feature: &'static str,
    },
    #[error("device {device:?} has no queue family with graphics and compute")]
    NoQueue { device: String },
    #[error(
        "validation was requested but the layer VK_LAYER_KHRONOS_validation is missing; \
             install `vulkan-validationlayers`"
    )]
    NoValidationLayer,
    #[error("allocating memory for {name:?}: {message}")]
    Allocation { name: String, message: String },
    #[error("{operation} needs a context that owns its queue (Context::headless); a host context never submits")]
    HostOwnsQueue { operation: &'static str },
    #[error("{what}: {problem}")]
    InvalidArgument { what: String, problem: String },
    #[error("writing {path}: {message}")]
    Write {
        path: std::path::PathBuf,
        message: String,
    },
}

impl VkError {
    /// vkCreateInstance's failure: no driver (with the install hint) or the call's result.
    pub fn create_instance(result: ash::vk::Result) -> VkError {
        match result {
            ash::vk::Result::ERROR_INCOMPATIBLE_DRIVER => VkError::NoDriver { result },
            result => VkError::Call {
                call: "vkCreateInstance",
                result,
            },
        }
    }

    /// Wraps a failed call's result; use as `.map_err(VkError::call("vkCreateImage"))`.
    pub fn call(call: &'static str) -> impl Fn(ash::vk::Result) -> VkError {
        move |result| VkError::Call { call, result }
    }

    pub(crate) fn invalid(what: impl Into<String>, problem: impl Into<String>) -> VkError {
        VkError::InvalidArgument {
            what: what.into(),
            problem: problem.into(),
        }
    }
}
