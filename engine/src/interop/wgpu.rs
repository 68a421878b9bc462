//! wgpu 27 interop (feature `wgpu`): a [`TranslucentObject`] drawn inside a wgpu frame, on wgpu's
//! Vulkan backend (wgpu-hal 27 is built on ash 0.38, our version, so its raw handles are ours).
//!
//! The model:
//! - **Device.** wgpu never enables the Vulkan 1.3 features we record with (synchronization2,
//!   dynamicRendering, maintenance4), so the device is opened through [`open_device`] (or
//!   [`create_device`], which also creates the instance and picks the adapter): it asks wgpu-hal for
//!   them at `vkCreateDevice`. [`WgpuContext::new`] refuses a device opened otherwise
//!   ([`WgpuError::FeaturesNotEnabled`]) unless the host enabled them itself
//!   ([`WgpuContext::new_unchecked`]).
//! - **Context.** [`WgpuContext`] borrows wgpu's instance, physical device, device and queue family
//!   (`as_hal`) into a [`Context`] (it derefs to one). Nothing of wgpu's is ever destroyed by us; the
//!   context keeps a clone of the `wgpu::Device`, so the raw device outlives every object of ours.
//! - **Recording.** wgpu 27 encodes a command encoder's passes and copies when it is *finished*,
//!   while `as_hal_mut` records at once: work recorded through `as_hal_mut` into an encoder that also
//!   holds wgpu commands runs before all of them. So [`WgpuContext::record_object`] records into a
//!   command buffer of its own, which the host submits between its own:
//!   `queue.submit([before, ours, after])`.
//! - **Targets and states.** wgpu tracks each texture's state and transitions it with barriers of
//!   its own. The command buffer we return first declares the colour target as
//!   `TextureUses::COLOR_TARGET` and the depth target as `TextureUses::DEPTH_STENCIL_WRITE`
//!   (`CommandEncoder::transition_resources`): at submission wgpu transitions them into those states
//!   in a command buffer it inserts before ours, and afterwards believes them still there. Our
//!   barriers come in from, and hand back in, exactly those states ([`WGPU_COLOR_TARGET`],
//!   [`WGPU_DEPTH_TARGET`]; see their docs for wgpu-hal's mapping). The transition also keeps the
//!   textures alive until the submission completes, as wgpu's own passes would.
//! - **Frames.** Each recorded command buffer is frame `n` of the context; wgpu reports its
//!   submission done (`CommandEncoder::on_submitted_work_done`, run by wgpu's `queue.submit` or
//!   `device.poll`), which completes frame `n` for deferred releases and the profiler. Command
//!   buffers must be submitted in the order they were recorded (or dropped).
//! - **Setup.** Creating an object uploads its textures: the context lends itself wgpu's queue for
//!   those submissions ([`Context::lend_queue_for_setup`]), hence `unsafe` constructors.
//!
//! ```no_run
//! use std::sync::Arc;
//! use translucent::interop::wgpu::{create_device, vk_format, WgpuContext, WgpuDesc, WgpuTargets};
//! use translucent::{ObjectParams, TranslucentObject};
//! # fn f(graph: Arc<translucent::QuadGraph>, field: &translucent::material::MaterialField,
//! #      scene: &translucent::scene::Scene, hdr: &wgpu::TextureView,
//! #      background: wgpu::CommandBuffer, overlay: wgpu::CommandBuffer)
//! #      -> Result<(), translucent::interop::wgpu::WgpuError> {
//! let host = create_device(&WgpuDesc::default())?; // instance, adapter, device, queue
//! // SAFETY: nothing else uses the queue while objects are created.
//! let ctx = unsafe { WgpuContext::new(&host.device, &host.queue, 2)? };
//! let params = ObjectParams {
//!     color_format: vk_format(wgpu::TextureFormat::Rgba16Float)?,
//!     ..ObjectParams::default()
//! };
//! let mut object = TranslucentObject::new(&ctx, graph, field, scene, &params)?;
//! let targets = WgpuTargets { color: hdr, depth: None };
//! let (ours, report) = ctx.record_object(&mut object, &targets, None)?;
//! host.queue.submit([background, ours, overlay]); // the host's passes around ours
//! println!("{:?}", report.passes);
//! # Ok(()) }
//! ```

use std::ffi::{c_void, CStr};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

use ::wgpu as wg;
use ash::vk;
use wg::hal::api::Vulkan;

use crate::frame::FrameReport;
use crate::object::{RecordCtx, TargetImage, Targets, TranslucentObject};
use crate::vk::context::check_device;
use crate::vk::validation::{on_validation_message, MessageSink};
use crate::vk::{
    Context, GpuProfiler, HostOptions, ImageState, ValidationMessage, VkError, REQUIRED_FEATURES,
};

/// The state wgpu-hal 27 keeps a colour texture in while wgpu-core tracks it as
/// `TextureUses::COLOR_TARGET` (after a render pass that drew into it, or our transition): layout
/// `COLOR_ATTACHMENT_OPTIMAL` (`conv::derive_image_layout`), stage `COLOR_ATTACHMENT_OUTPUT` with
/// colour-attachment reads and writes (`conv::map_texture_usage_to_barrier`). Between two uses in
/// this state wgpu records no barrier (`COLOR_TARGET` is an "ordered" use), so our hand-back barrier
/// must make our writes visible to colour-attachment reads and writes, which this state does.
pub const WGPU_COLOR_TARGET: ImageState = ImageState {
    stage: vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT,
    access: vk::AccessFlags2::from_raw(
        vk::AccessFlags2::COLOR_ATTACHMENT_READ.as_raw()
            | vk::AccessFlags2::COLOR_ATTACHMENT_WRITE.as_raw(),
    ),
    layout: vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
};

/// The state wgpu-hal 27 keeps a depth texture in while wgpu-core tracks it as
/// `TextureUses::DEPTH_STENCIL_WRITE`: layout `DEPTH_STENCIL_ATTACHMENT_OPTIMAL` (not our
/// `DEPTH_ATTACHMENT_OPTIMAL`: the object's barriers convert), early and late fragment tests with
/// depth reads and writes.
pub const WGPU_DEPTH_TARGET: ImageState = ImageState {
    stage: vk::PipelineStageFlags2::from_raw(
        vk::PipelineStageFlags2::EARLY_FRAGMENT_TESTS.as_raw()
            | vk::PipelineStageFlags2::LATE_FRAGMENT_TESTS.as_raw(),
    ),
    access: vk::AccessFlags2::from_raw(
        vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_READ.as_raw()
            | vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_WRITE.as_raw(),
    ),
    layout: vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL,
};

/// Everything this module can fail with.
#[derive(Debug, thiserror::Error)]
pub enum WgpuError {
    #[error("{what} is not on wgpu's Vulkan backend: translucent records Vulkan commands only")]
    NotVulkan { what: &'static str },
    #[error(
        "the wgpu device was not opened by translucent::interop::wgpu::open_device or \
         create_device: wgpu does not enable the Vulkan 1.3 features {REQUIRED_FEATURES:?} \
         translucent records with (open the device through them, or enable the features \
         yourself and use WgpuContext::new_unchecked)"
    )]
    FeaturesNotEnabled,
    #[error("no usable wgpu Vulkan adapter{}; found: [{}]",
        .wanted.as_ref().map(|w| format!(" whose name contains {w:?} (TRANSLUCENT_DEVICE)")).unwrap_or_default(),
        .found.join("; "))]
    NoAdapter {
        wanted: Option<String>,
        /// Each adapter seen, with why it was not used.
        found: Vec<String>,
    },
    #[error("{what}: the wgpu format {format:?} is not one translucent can render to (colour: Rgba16Float, Rgba32Float, Rgba8Unorm[Srgb], Bgra8Unorm[Srgb], Rgb10a2Unorm, Rg11b10Ufloat; depth: Depth32Float, Depth16Unorm)")]
    UnsupportedFormat {
        what: &'static str,
        format: wg::TextureFormat,
    },
    #[error("{what}: {problem}")]
    Target { what: &'static str, problem: String },
    #[error("creating the Vulkan instance for wgpu: {0}")]
    Instance(String),
    #[error("opening the wgpu device: {0}")]
    OpenDevice(String),
    #[error(transparent)]
    Vk(#[from] VkError),
    #[error(transparent)]
    Translucent(#[from] crate::Error),
}

/// Validation messages collected by the messenger [`create_instance`] installs (warnings and
/// errors of the Khronos layer, with synchronization validation, and of the loader).
#[derive(Clone)]
pub struct ValidationMessages(Arc<MessageSink>);

impl ValidationMessages {
    /// Takes the messages collected so far (shared with [`Context::take_validation_messages`] of
    /// contexts on this instance).
    pub fn take(&self) -> Vec<ValidationMessage> {
        std::mem::take(&mut *self.0.lock())
    }
}

/// Instances made by [`create_instance`] (their messages) and devices opened by [`open_device`]
/// (they have our features), by raw handle. A device handle stays listed after the device is
/// destroyed; a later device given the same handle value would pass the check.
#[derive(Default)]
struct Registry {
    instances: Vec<(u64, Arc<MessageSink>)>,
    devices: Vec<u64>,
}

static REGISTRY: Mutex<Registry> = Mutex::new(Registry {
    instances: Vec::new(),
    devices: Vec::new(),
});

fn registry() -> std::sync::MutexGuard<'static, Registry> {
    REGISTRY.lock().unwrap_or_else(|e| e.into_inner())
}

/// How [`create_device`] makes the wgpu instance and device.
#[derive(Clone, Debug)]
pub struct WgpuDesc {
    /// Khronos validation with synchronization validation (messages in
    /// [`WgpuDevice::validation`]). Default: env `TRANSLUCENT_VALIDATION=1`.
    pub validation: bool,
    /// Also print each validation message to stderr.
    pub echo_validation: bool,
    /// The first adapter whose name contains this (case-insensitive). Default: env
    /// `TRANSLUCENT_DEVICE`; otherwise discrete, integrated, virtual, then CPU.
    pub device_name: Option<String>,
    /// wgpu features the host needs besides ours.
    pub features: wg::Features,
    /// wgpu limits the host needs (`None`: the adapter's own).
    pub limits: Option<wg::Limits>,
}

impl Default for WgpuDesc {
    fn default() -> Self {
        WgpuDesc {
            validation: std::env::var("TRANSLUCENT_VALIDATION").is_ok_and(|v| v == "1"),
            echo_validation: false,
            device_name: std::env::var("TRANSLUCENT_DEVICE")
                .ok()
                .filter(|s| !s.is_empty()),
            features: wg::Features::empty(),
            limits: None,
        }
    }
}

/// What [`create_device`] made.
pub struct WgpuDevice {
    pub instance: wg::Instance,
    pub adapter: wg::Adapter,
    pub device: wg::Device,
    pub queue: wg::Queue,
    /// The validation messages (`None` without validation).
    pub validation: Option<ValidationMessages>,
}

/// Creates a wgpu instance on Vulkan 1.3 (with `VK_EXT_debug_utils` where present, so our passes
/// are labelled; with `validation`, the Khronos layer and synchronization validation, messages
/// collected by a messenger of ours instead of wgpu's `log` output).
pub fn create_instance(
    validation: bool,
    echo: bool,
) -> Result<(wg::Instance, Option<ValidationMessages>), WgpuError> {
    let instance_error = |e: &dyn std::fmt::Display| WgpuError::Instance(e.to_string());
    // SAFETY: loading the system Vulkan loader runs its initialisation code only.
    let entry = unsafe { ash::Entry::load() }.map_err(|e| VkError::Loader(e.to_string()))?;
    // SAFETY: plain queries on a loaded entry.
    let version = unsafe { entry.try_enumerate_instance_version() }
        .map_err(VkError::call("vkEnumerateInstanceVersion"))?
        .unwrap_or(vk::API_VERSION_1_0);
    if version < vk::API_VERSION_1_3 {
        return Err(WgpuError::Instance(format!(
            "the Vulkan loader offers version {}.{}, 1.3 is needed",
            vk::api_version_major(version),
            vk::api_version_minor(version)
        )));
    }
    // SAFETY: as above.
    let available = unsafe { entry.enumerate_instance_extension_properties(None) }
        .map_err(VkError::call("vkEnumerateInstanceExtensionProperties"))?;
    let has = |name: &CStr| {
        available
            .iter()
            .any(|e| e.extension_name_as_c_str() == Ok(name))
    };
    let mut flags = wg::InstanceFlags::empty();
    if has(ash::ext::debug_utils::NAME) {
        flags |= wg::InstanceFlags::DEBUG;
    }
    if validation {
        // SAFETY: as above.
        let layers = unsafe { entry.enumerate_instance_layer_properties() }
            .map_err(VkError::call("vkEnumerateInstanceLayerProperties"))?;
        if !layers
            .iter()
            .any(|l| l.layer_name_as_c_str() == Ok(c"VK_LAYER_KHRONOS_validation"))
        {
            return Err(VkError::NoValidationLayer.into());
        }
        if !flags.contains(wg::InstanceFlags::DEBUG) {
            return Err(WgpuError::Instance(
                "validation needs VK_EXT_debug_utils, which the loader does not offer".into(),
            ));
        }
        flags |= wg::InstanceFlags::VALIDATION;
    }
    let mut extensions =
        wg::hal::vulkan::Instance::desired_extensions(&entry, vk::API_VERSION_1_3, flags)
            .map_err(|e| instance_error(&e))?;
    let mut layers: Vec<&'static CStr> = Vec::new();
    if validation {
        layers.push(c"VK_LAYER_KHRONOS_validation");
        extensions.push(ash::ext::validation_features::NAME);
    }
    let names: Vec<*const std::ffi::c_char> = layers
        .iter()
        .chain(extensions.iter())
        .map(|s| s.as_ptr())
        .collect();
    let app = vk::ApplicationInfo::default()
        .application_name(c"translucent wgpu host")
        .engine_name(c"wgpu-hal")
        .api_version(vk::API_VERSION_1_3);
    let sync = [vk::ValidationFeatureEnableEXT::SYNCHRONIZATION_VALIDATION];
    let mut features = vk::ValidationFeaturesEXT::default().enabled_validation_features(&sync);
    let mut info = vk::InstanceCreateInfo::default()
        .application_info(&app)
        .enabled_layer_names(&names[..layers.len()])
        .enabled_extension_names(&names[layers.len()..]);
    if validation {
        info = info.push_next(&mut features);
    }
    // SAFETY: every pointer in `info` refers to locals alive across the call.
    let raw =
        unsafe { entry.create_instance(&info, None) }.map_err(VkError::call("vkCreateInstance"))?;

    let sink = Arc::new(MessageSink {
        messages: Arc::new(Mutex::new(Vec::new())),
        echo,
    });
    let messenger = if validation {
        let utils = ash::ext::debug_utils::Instance::new(&entry, &raw);
        let info = vk::DebugUtilsMessengerCreateInfoEXT::default()
            .message_severity(
                vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
                    | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
            )
            .message_type(
                vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                    | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                    | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
            )
            .pfn_user_callback(Some(on_validation_message))
            .user_data(Arc::as_ptr(&sink) as *mut c_void);
        // SAFETY: live instance; the sink outlives the messenger (the drop callback owns both).
        match unsafe { utils.create_debug_utils_messenger(&info, None) } {
            Ok(m) => Some((utils, m)),
            Err(result) => {
                // SAFETY: nothing was created from the instance.
                unsafe { raw.destroy_instance(None) };
                return Err(VkError::Call {
                    call: "vkCreateDebugUtilsMessengerEXT",
                    result,
                }
                .into());
            }
        }
    } else {
        None
    };
    let handle = vk::Handle::as_raw(raw.handle());
    registry().instances.push((handle, sink.clone()));
    let destroy = {
        let raw = raw.clone();
        let sink = sink.clone();
        Box::new(move || {
            registry().instances.retain(|(h, _)| *h != handle);
            // SAFETY: wgpu-hal calls this once, after every adapter and device of the instance
            // is gone; the messenger is a child of the instance and goes first.
            unsafe {
                if let Some((utils, messenger)) = &messenger {
                    utils.destroy_debug_utils_messenger(*messenger, None);
                }
                raw.destroy_instance(None);
            }
            drop(sink);
        })
    };
    // SAFETY: `raw` was created from `entry` with `extensions` (a superset of
    // `desired_extensions` for `flags`) at API 1.3; wgpu-hal does not destroy it: `destroy` does.
    let hal = unsafe {
        wg::hal::vulkan::Instance::from_raw(
            entry,
            raw,
            version,
            0,
            None,
            extensions,
            flags,
            wg::MemoryBudgetThresholds::default(),
            false,
            Some(destroy),
        )
    }
    .map_err(|e| instance_error(&e))?;
    // SAFETY: a freshly made Vulkan hal instance.
    let instance = unsafe { wg::Instance::from_hal::<Vulkan>(hal) };
    Ok((instance, validation.then_some(ValidationMessages(sink))))
}

/// Whether `adapter` can run translucent: Vulkan 1.3 with synchronization2, dynamicRendering and
/// maintenance4 supported, and a queue family 0 with graphics and compute (the one wgpu opens).
pub fn check_adapter(adapter: &wg::Adapter) -> Result<(), WgpuError> {
    // SAFETY: read-only queries through the adapter's raw handles.
    let hal =
        unsafe { adapter.as_hal::<Vulkan>() }.ok_or(WgpuError::NotVulkan { what: "adapter" })?;
    let instance = hal.shared_instance().raw_instance();
    let physical = hal.raw_physical_device();
    // wgpu opens queue family 0: the first family with graphics and compute must be that one.
    if check_device(instance, physical)? != 0 {
        return Err(VkError::NoQueue {
            device: adapter.get_info().name,
        }
        .into());
    }
    Ok(())
}

/// The Vulkan 1.3 feature structs we chain into wgpu-hal's `vkCreateDevice` (one struct each: the
/// `VkPhysicalDeviceVulkan13Features` aggregate may not sit beside the per-feature 1.3 structs
/// wgpu-hal chains itself, such as image robustness).
pub struct RequiredVulkanFeatures {
    synchronization2: vk::PhysicalDeviceSynchronization2Features<'static>,
    dynamic_rendering: vk::PhysicalDeviceDynamicRenderingFeatures<'static>,
    maintenance4: vk::PhysicalDeviceMaintenance4Features<'static>,
}

impl Default for RequiredVulkanFeatures {
    fn default() -> Self {
        RequiredVulkanFeatures {
            synchronization2: vk::PhysicalDeviceSynchronization2Features::default()
                .synchronization2(true),
            dynamic_rendering: vk::PhysicalDeviceDynamicRenderingFeatures::default()
                .dynamic_rendering(true),
            maintenance4: vk::PhysicalDeviceMaintenance4Features::default().maintenance4(true),
        }
    }
}

impl RequiredVulkanFeatures {
    /// Adds our features to a wgpu-hal device creation (`Adapter::open_with_callback`'s callback;
    /// Bevy's `RawVulkanInitSettings::add_create_device_callback`).
    ///
    /// # Safety
    /// The adapter must support the features ([`check_adapter`]); `extensions` are the ones
    /// wgpu-hal enables (on a Vulkan 1.3 device wgpu-hal only chains its own maintenance4 struct
    /// when it enabled `VK_KHR_maintenance4`: then ours is left out, as two would be invalid).
    pub unsafe fn chain<'p>(
        &'p mut self,
        extensions: &[&'static CStr],
        info: &mut vk::DeviceCreateInfo<'p>,
    ) {
        let mut chained = std::mem::take(info)
            .push_next(&mut self.synchronization2)
            .push_next(&mut self.dynamic_rendering);
        if !extensions.contains(&ash::khr::maintenance4::NAME) {
            chained = chained.push_next(&mut self.maintenance4);
        }
        *info = chained;
    }
}

/// Opens a wgpu device on `adapter` with the Vulkan 1.3 features translucent needs besides
/// `desc`'s (checked first: a typed error names a missing one).
pub fn open_device(
    adapter: &wg::Adapter,
    desc: &wg::DeviceDescriptor<'_>,
) -> Result<(wg::Device, wg::Queue), WgpuError> {
    check_adapter(adapter)?;
    let mut required = RequiredVulkanFeatures::default();
    let open = {
        // SAFETY: the guard is only used to open a device, which wgpu then owns.
        let hal = unsafe { adapter.as_hal::<Vulkan>() }
            .ok_or(WgpuError::NotVulkan { what: "adapter" })?;
        let required = &mut required;
        // SAFETY: the callback only adds features the adapter supports (checked above).
        unsafe {
            hal.open_with_callback(
                desc.required_features,
                &desc.memory_hints,
                Some(Box::new(move |args| {
                    required.chain(args.extensions, args.create_info);
                })),
            )
        }
        .map_err(|e| WgpuError::OpenDevice(e.to_string()))?
    };
    // SAFETY: `open` was made from this adapter's hal adapter with `desc.required_features`.
    let (device, queue) = unsafe { adapter.create_device_from_hal::<Vulkan>(open, desc) }
        .map_err(|e| WgpuError::OpenDevice(e.to_string()))?;
    // SAFETY: reading the raw handle only.
    let handle = unsafe { device.as_hal::<Vulkan>() }
        .map(|d| vk::Handle::as_raw(d.raw_device().handle()))
        .ok_or(WgpuError::NotVulkan { what: "device" })?;
    registry().devices.push(handle);
    Ok((device, queue))
}

fn adapter_rank(t: wg::DeviceType) -> u32 {
    match t {
        wg::DeviceType::DiscreteGpu => 0,
        wg::DeviceType::IntegratedGpu => 1,
        wg::DeviceType::VirtualGpu => 2,
        wg::DeviceType::Cpu => 3,
        wg::DeviceType::Other => 4,
    }
}

/// Creates the instance ([`create_instance`]), picks a Vulkan adapter that can run translucent
/// (`desc.device_name`, else discrete, integrated, virtual, CPU) and opens its device
/// ([`open_device`]) with `desc`'s features and limits (the adapter's limits by default).
pub fn create_device(desc: &WgpuDesc) -> Result<WgpuDevice, WgpuError> {
    let (instance, validation) = create_instance(desc.validation, desc.echo_validation)?;
    let mut adapters = instance.enumerate_adapters(wg::Backends::VULKAN);
    adapters.sort_by_key(|a| adapter_rank(a.get_info().device_type));
    let wanted = desc.device_name.as_ref().map(|w| w.to_lowercase());
    let mut found = Vec::new();
    let mut chosen = None;
    for adapter in adapters {
        let name = adapter.get_info().name;
        if wanted
            .as_ref()
            .is_some_and(|w| !name.to_lowercase().contains(w))
        {
            found.push(format!("{name} (name does not match)"));
            continue;
        }
        if !adapter.features().contains(desc.features) {
            found.push(format!(
                "{name} (lacks wgpu features {:?})",
                desc.features - adapter.features()
            ));
            continue;
        }
        match check_adapter(&adapter) {
            Ok(()) => {
                chosen = Some(adapter);
                break;
            }
            Err(e) => found.push(format!("{name} ({e})")),
        }
    }
    let adapter = chosen.ok_or(WgpuError::NoAdapter {
        wanted: desc.device_name.clone(),
        found,
    })?;
    let (device, queue) = open_device(
        &adapter,
        &wg::DeviceDescriptor {
            label: Some("translucent wgpu device"),
            required_features: desc.features,
            required_limits: desc.limits.clone().unwrap_or_else(|| adapter.limits()),
            ..Default::default()
        },
    )?;
    Ok(WgpuDevice {
        instance,
        adapter,
        device,
        queue,
        validation,
    })
}

/// The Vulkan format of a wgpu texture format we can render to (as wgpu-hal 27 maps it).
pub fn vk_format(format: wg::TextureFormat) -> Result<vk::Format, WgpuError> {
    use wg::TextureFormat as T;
    Ok(match format {
        T::Rgba16Float => vk::Format::R16G16B16A16_SFLOAT,
        T::Rgba32Float => vk::Format::R32G32B32A32_SFLOAT,
        T::Rgba8Unorm => vk::Format::R8G8B8A8_UNORM,
        T::Rgba8UnormSrgb => vk::Format::R8G8B8A8_SRGB,
        T::Bgra8Unorm => vk::Format::B8G8R8A8_UNORM,
        T::Bgra8UnormSrgb => vk::Format::B8G8R8A8_SRGB,
        T::Rgb10a2Unorm => vk::Format::A2B10G10R10_UNORM_PACK32,
        T::Rg11b10Ufloat => vk::Format::B10G11R11_UFLOAT_PACK32,
        T::Depth32Float => vk::Format::D32_SFLOAT,
        T::Depth16Unorm => vk::Format::D16_UNORM,
        _ => {
            return Err(WgpuError::UnsupportedFormat {
                what: "texture",
                format,
            })
        }
    })
}

/// The wgpu texture views [`WgpuContext::record_object`] draws into (their textures: 2D, one mip
/// level, one layer, one sample, `RENDER_ATTACHMENT` usage, already written by wgpu once, since
/// wgpu would clear a texture it believes uninitialized at its next use).
#[derive(Clone, Copy)]
pub struct WgpuTargets<'a> {
    /// Loaded and drawn over (the host's background stays).
    pub color: &'a wg::TextureView,
    /// The host's depth, tested against and written; `None`: the object's own depth buffer.
    pub depth: Option<&'a wg::TextureView>,
}

/// Frame counters fed by wgpu's submission callbacks.
#[derive(Default)]
struct FrameClock {
    /// The last frame number handed out.
    recorded: AtomicU64,
    /// The last frame whose command buffer wgpu reported done.
    completed: AtomicU64,
}

/// A [`Context`] borrowed from a wgpu device (see the module doc); derefs to the context.
pub struct WgpuContext {
    ctx: Context,
    device: wg::Device,
    clock: Arc<FrameClock>,
}

impl std::ops::Deref for WgpuContext {
    type Target = Context;
    fn deref(&self) -> &Context {
        &self.ctx
    }
}

impl WgpuContext {
    /// Borrows `device` (opened by [`open_device`] or [`create_device`], otherwise
    /// [`WgpuError::FeaturesNotEnabled`]) and its `queue`. `frames_in_flight`: how many recorded
    /// frames the host may have unfinished (sizes per-frame resources such as profiler slots).
    /// Validation messages of an instance made by [`create_instance`] are also readable through
    /// [`Context::take_validation_messages`].
    ///
    /// # Safety
    /// While our calls that submit setup work run (object creation, `set_material`, `deform`,
    /// read-backs), no other thread may submit to wgpu's queue (`vkQueueSubmit` needs external
    /// synchronization; wgpu's own lock does not cover our submissions).
    pub unsafe fn new(
        device: &wg::Device,
        queue: &wg::Queue,
        frames_in_flight: u32,
    ) -> Result<WgpuContext, WgpuError> {
        // SAFETY: forwarded contract.
        unsafe { Self::wrap(device, queue, frames_in_flight, true) }
    }

    /// [`WgpuContext::new`] for a device the host opened itself.
    ///
    /// # Safety
    /// As [`WgpuContext::new`], and the device was created with Vulkan 1.3's synchronization2,
    /// dynamicRendering and maintenance4 enabled (e.g. through [`RequiredVulkanFeatures::chain`]).
    pub unsafe fn new_unchecked(
        device: &wg::Device,
        queue: &wg::Queue,
        frames_in_flight: u32,
    ) -> Result<WgpuContext, WgpuError> {
        // SAFETY: forwarded contract.
        unsafe { Self::wrap(device, queue, frames_in_flight, false) }
    }

    unsafe fn wrap(
        device: &wg::Device,
        queue: &wg::Queue,
        frames_in_flight: u32,
        checked: bool,
    ) -> Result<WgpuContext, WgpuError> {
        let (entry, instance, physical, raw_device, family, index, labels) = {
            // SAFETY: we clone the handles and function tables; wgpu keeps owning the objects,
            // and the clone of `device` kept below keeps them alive for as long as we use them.
            let hal = unsafe { device.as_hal::<Vulkan>() }
                .ok_or(WgpuError::NotVulkan { what: "device" })?;
            let shared = hal.shared_instance();
            (
                shared.entry().clone(),
                shared.raw_instance().clone(),
                hal.raw_physical_device(),
                hal.raw_device().clone(),
                hal.queue_family_index(),
                hal.queue_index(),
                shared.extensions().contains(&ash::ext::debug_utils::NAME),
            )
        };
        let (opened, sink) = {
            let registry = registry();
            let handle = vk::Handle::as_raw(raw_device.handle());
            let instance_handle = vk::Handle::as_raw(instance.handle());
            (
                registry.devices.contains(&handle),
                registry
                    .instances
                    .iter()
                    .find(|(h, _)| *h == instance_handle)
                    .map(|(_, s)| s.messages.clone()),
            )
        };
        if checked && !opened {
            return Err(WgpuError::FeaturesNotEnabled);
        }
        // SAFETY: the handles are wgpu's live objects, created from each other; the caller
        // guarantees the features; `labels` says whether debug_utils is enabled.
        let mut ctx = unsafe {
            Context::from_host_with(
                entry,
                instance,
                physical,
                raw_device,
                family,
                index,
                frames_in_flight,
                HostOptions {
                    labels,
                    messages: sink,
                },
            )?
        };
        // SAFETY: the caller's contract (no concurrent submissions during our setup calls).
        unsafe { ctx.lend_queue_for_setup()? };
        // The raw device must outlive every object of ours (they hold the context's device).
        ctx.device
            .keep_alive(Box::new((device.clone(), queue.clone())));
        Ok(WgpuContext {
            ctx,
            device: device.clone(),
            clock: Arc::new(FrameClock::default()),
        })
    }

    /// The borrowed context.
    pub fn context(&self) -> &Context {
        &self.ctx
    }

    /// (last frame recorded, last frame wgpu reported done).
    pub fn frames(&self) -> (u64, u64) {
        (
            self.clock.recorded.load(Ordering::SeqCst),
            self.clock.completed.load(Ordering::SeqCst),
        )
    }

    /// Releases what waited for frames wgpu has reported done (also done at every
    /// [`WgpuContext::record_object`]); returns how many objects were destroyed.
    pub fn release_completed(&self) -> usize {
        self.ctx.frame_completed(self.frames().1)
    }

    /// Records this frame of `object` into a command buffer of its own, for the host to submit
    /// between its own (`queue.submit([before, ours, after])`, in recording order). The targets
    /// come in and leave in wgpu's `COLOR_TARGET` / `DEPTH_STENCIL_WRITE` states (module doc).
    /// With a `profiler`, its frame is begun in our command buffer and completed frames are read:
    /// `profiler.latest()` has the GPU ms per pass of the last completed frame.
    pub fn record_object(
        &self,
        object: &mut TranslucentObject,
        targets: &WgpuTargets<'_>,
        profiler: Option<&mut GpuProfiler>,
    ) -> Result<(wg::CommandBuffer, FrameReport), WgpuError> {
        let color = target(targets.color, Attachment::Color)?;
        let depth = targets
            .depth
            .map(|d| target(d, Attachment::Depth))
            .transpose()?;
        if let Some(d) = &depth {
            if d.image.extent != color.image.extent {
                return Err(WgpuError::Target {
                    what: "depth target",
                    problem: format!(
                        "{}x{}, the colour target is {}x{}",
                        d.image.extent.width,
                        d.image.extent.height,
                        color.image.extent.width,
                        color.image.extent.height
                    ),
                });
            }
        }
        let mut encoder = self
            .device
            .create_command_encoder(&wg::CommandEncoderDescriptor {
                label: Some("translucent object"),
            });
        // why: wgpu only knows the targets' states through its tracker; declaring them here
        // makes it transition them into COLOR_TARGET / DEPTH_STENCIL_WRITE in a command buffer
        // it inserts before ours at submission (layout change, and the host's earlier writes
        // available), and track them in those states after ours, which is where we leave them.
        encoder.transition_resources(
            std::iter::empty(),
            std::iter::once(wg::TextureTransition {
                texture: targets.color.texture(),
                selector: None,
                state: wg::TextureUses::COLOR_TARGET,
            })
            .chain(targets.depth.map(|d| wg::TextureTransition {
                texture: d.texture(),
                selector: None,
                state: wg::TextureUses::DEPTH_STENCIL_WRITE,
            })),
        );
        let frame = self.clock.recorded.fetch_add(1, Ordering::SeqCst) + 1;
        let completed = self.clock.completed.load(Ordering::SeqCst);
        let host_targets = Targets {
            color: color.image,
            depth: depth.map(|d| d.image),
            host_barriers: false,
        };
        let ctx = &self.ctx;
        // SAFETY: the raw command buffer is the encoder's, recording and outside any render
        // pass (the encoder holds no wgpu commands); we neither end nor destroy it. The targets'
        // images and views are kept alive until the submission completes (wgpu tracks the
        // textures through the transition; the callback below holds the views). `object`'s
        // resources are released only after `frame` completes (deferred release).
        let report = unsafe {
            encoder.as_hal_mut::<Vulkan, _, _>(|hal| {
                let cb = hal
                    .ok_or(WgpuError::NotVulkan {
                        what: "command encoder",
                    })?
                    .raw_handle();
                let mut profiler = profiler;
                if let Some(p) = profiler.as_deref_mut() {
                    p.frame_completed(completed);
                    p.begin_frame(cb, frame);
                }
                object
                    .record(
                        &mut RecordCtx {
                            ctx,
                            cb,
                            frame,
                            completed_frame: completed,
                            profiler,
                        },
                        &host_targets,
                    )
                    .map_err(WgpuError::from)
            })
        }?;
        let keep = (targets.color.clone(), targets.depth.cloned());
        let clock = self.clock.clone();
        encoder.on_submitted_work_done(move || {
            drop(keep);
            clock.completed.fetch_max(frame, Ordering::SeqCst);
        });
        Ok((encoder.finish(), report))
    }
}

impl Drop for WgpuContext {
    fn drop(&mut self) {
        // Everything we recorded must finish before what waits for it is destroyed.
        let _ = self.device.poll(wg::PollType::wait_indefinitely());
        self.ctx.frame_completed(self.frames().0);
    }
}

#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Attachment {
    Color,
    Depth,
}

struct WgpuTarget {
    image: TargetImage,
}

/// Checks a target view's texture and reads its raw handles.
fn target(view: &wg::TextureView, kind: Attachment) -> Result<WgpuTarget, WgpuError> {
    let what = match kind {
        Attachment::Color => "colour target",
        Attachment::Depth => "depth target",
    };
    let texture = view.texture();
    let bad = |problem: String| Err(WgpuError::Target { what, problem });
    if texture.dimension() != wg::TextureDimension::D2 {
        return bad(format!("a {:?} texture; 2D is needed", texture.dimension()));
    }
    if texture.mip_level_count() != 1 || texture.depth_or_array_layers() != 1 {
        return bad(format!(
            "{} mip levels and {} layers; one of each is supported",
            texture.mip_level_count(),
            texture.depth_or_array_layers()
        ));
    }
    if texture.sample_count() != 1 {
        return bad(format!(
            "{} samples per pixel; single-sampled targets only (e.g. Bevy's Msaa::Off)",
            texture.sample_count()
        ));
    }
    if !texture
        .usage()
        .contains(wg::TextureUsages::RENDER_ATTACHMENT)
    {
        return bad("its usage lacks RENDER_ATTACHMENT".into());
    }
    let format = texture.format();
    let is_depth = format.is_depth_stencil_format();
    if is_depth != (kind == Attachment::Depth) {
        return bad(format!("format {format:?} is not a {what} format"));
    }
    let vk_format = vk_format(format).map_err(|_| WgpuError::UnsupportedFormat { what, format })?;
    // SAFETY: reading raw handles; the view (and so the texture) is kept alive by the caller
    // for the recording and by the submission callback until the GPU is done.
    let (image, image_view) = unsafe {
        (
            texture.as_hal::<Vulkan>().map(|t| t.raw_handle()),
            view.as_hal::<Vulkan>().map(|v| v.raw_handle()),
        )
    };
    let (Some(image), Some(image_view)) = (image, image_view) else {
        return Err(WgpuError::NotVulkan { what });
    };
    let state = match kind {
        Attachment::Color => WGPU_COLOR_TARGET,
        Attachment::Depth => WGPU_DEPTH_TARGET,
    };
    Ok(WgpuTarget {
        image: TargetImage {
            image,
            view: image_view,
            format: vk_format,
            extent: vk::Extent2D {
                width: texture.width(),
                height: texture.height(),
            },
            before: state,
            after: state,
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formats_map_as_wgpu_hal_maps_them_and_others_are_refused() {
        assert_eq!(
            vk_format(wg::TextureFormat::Rgba16Float).unwrap(),
            vk::Format::R16G16B16A16_SFLOAT
        );
        assert_eq!(
            vk_format(wg::TextureFormat::Depth32Float).unwrap(),
            vk::Format::D32_SFLOAT
        );
        let e = vk_format(wg::TextureFormat::Depth24PlusStencil8).unwrap_err();
        assert!(e.to_string().contains("Depth24PlusStencil8"), "{e}");
    }
}
