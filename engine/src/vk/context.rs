//! [`Context`]: owned (headless) or borrowed from a host; validation; frames; one-shot submission.

use std::ffi::{c_void, CStr, CString};
use std::sync::atomic::Ordering;
use std::sync::{Arc, Mutex};

use ash::vk;
use gpu_allocator::vulkan::{Allocator, AllocatorCreateDesc};

use super::device::{Device, Handles, OwnedVulkan};
use super::validation::{on_validation_message, MessageSink};
pub use super::validation::{Severity, ValidationLog, ValidationMessage};
use super::{VkError, REQUIRED_FEATURES};

const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

/// How to create a headless context.
#[derive(Clone, Debug)]
pub struct ContextDesc {
    /// Khronos validation with synchronization validation; messages are collected (see
    /// [`Context::take_validation_messages`]). Default: env `TRANSLUCENT_VALIDATION=1`.
    pub validation: bool,
    /// Also print each validation message to stderr as it arrives.
    pub echo_validation: bool,
    /// Pick the first device whose name contains this (case-insensitive). Default: env
    /// `TRANSLUCENT_DEVICE`; otherwise discrete GPU, then integrated, then CPU.
    pub device_name: Option<String>,
    /// Frames the host may have in flight (sizes per-frame resources such as profiler slots).
    pub frames_in_flight: u32,
}

impl Default for ContextDesc {
    fn default() -> Self {
        ContextDesc {
            validation: std::env::var("TRANSLUCENT_VALIDATION").is_ok_and(|v| v == "1"),
            echo_validation: false,
            device_name: std::env::var("TRANSLUCENT_DEVICE")
                .ok()
                .filter(|s| !s.is_empty()),
            frames_in_flight: 2,
        }
    }
}

/// Vulkan objects a host lends us. There is deliberately no way to destroy them through this type.
pub struct HostVulkan {
    #[allow(
        dead_code,
        reason = "keeps the Vulkan loader library loaded while we use its functions"
    )]
    entry: ash::Entry,
    instance: ash::Instance,
    device: ash::Device,
}

impl HostVulkan {
    pub(crate) fn device(&self) -> &ash::Device {
        &self.device
    }
    pub(crate) fn instance(&self) -> &ash::Instance {
        &self.instance
    }
}

/// How a host context borrowed by an interop module differs from [`Context::from_host`]'s.
pub(crate) struct HostOptions {
    /// The instance has `VK_EXT_debug_utils` enabled: passes are labelled and objects named.
    pub labels: bool,
    /// Messages collected by a messenger the interop module created on the host's instance
    /// (read through [`Context::take_validation_messages`]); `None`: the host collects its own.
    pub messages: Option<Arc<Mutex<Vec<ValidationMessage>>>>,
}

/// What `translucent info` prints.
#[derive(Clone, Debug, serde::Serialize)]
pub struct DeviceInfo {
    pub device_name: String,
    pub device_type: String,
    pub driver_name: String,
    pub driver_info: String,
    pub api_version: String,
    pub features: Vec<&'static str>,
    pub validation: bool,
    pub timestamps: bool,
    pub timestamp_period_ns: f32,
    pub subgroup_size: u32,
}

/// The Vulkan context: device, queue, allocator, frame counters and (headless) a submitter.
pub struct Context {
    pub(crate) device: Arc<Device>,
    submitter: Option<Mutex<vk::CommandPool>>,
    info: DeviceInfo,
    frames_in_flight: u32,
    /// A host context whose host lent its queue for setup work ([`Context::lend_queue_for_setup`]):
    /// those submissions leave the host's frame counters alone.
    lent_queue: bool,
    /// SPIR-V words by shader name that pipelines use instead of the embedded shaders (hot
    /// reload: `shader::load`).
    shader_overrides: std::collections::HashMap<String, Vec<u32>>,
}

fn version_string(v: u32) -> String {
    format!(
        "{}.{}.{}",
        vk::api_version_major(v),
        vk::api_version_minor(v),
        vk::api_version_patch(v)
    )
}

fn c_name(bytes: &[std::ffi::c_char]) -> String {
    // SAFETY: Vulkan fixed-size name arrays are NUL-terminated within their length.
    let bytes: &[u8] = unsafe { std::slice::from_raw_parts(bytes.as_ptr().cast(), bytes.len()) };
    CStr::from_bytes_until_nul(bytes)
        .map(|c| c.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// Checks API version and the 1.3 features; returns the graphics+compute queue family.
pub(crate) fn check_device(
    instance: &ash::Instance,
    physical: vk::PhysicalDevice,
) -> Result<u32, VkError> {
    // SAFETY: `physical` was enumerated from `instance`.
    let props = unsafe { instance.get_physical_device_properties(physical) };
    let name = c_name(&props.device_name);
    if props.api_version < vk::API_VERSION_1_3 {
        return Err(VkError::ApiVersion {
            device: name,
            version: version_string(props.api_version),
        });
    }
    let mut f13 = vk::PhysicalDeviceVulkan13Features::default();
    let mut f2 = vk::PhysicalDeviceFeatures2::default().push_next(&mut f13);
    // SAFETY: as above; the chain holds only core 1.3 structs.
    unsafe { instance.get_physical_device_features2(physical, &mut f2) };
    for (present, feature) in [
        f13.synchronization2,
        f13.dynamic_rendering,
        f13.maintenance4,
    ]
    .into_iter()
    .zip(REQUIRED_FEATURES)
    {
        if present == vk::FALSE {
            return Err(VkError::MissingFeature {
                device: name,
                feature,
            });
        }
    }
    // SAFETY: as above.
    let families = unsafe { instance.get_physical_device_queue_family_properties(physical) };
    families
        .iter()
        .position(|f| {
            f.queue_flags
                .contains(vk::QueueFlags::GRAPHICS | vk::QueueFlags::COMPUTE)
        })
        .map(|i| i as u32)
        .ok_or(VkError::NoQueue { device: name })
}

fn device_rank(t: vk::PhysicalDeviceType) -> u32 {
    match t {
        vk::PhysicalDeviceType::DISCRETE_GPU => 0,
        vk::PhysicalDeviceType::INTEGRATED_GPU => 1,
        vk::PhysicalDeviceType::VIRTUAL_GPU => 2,
        vk::PhysicalDeviceType::CPU => 3,
        _ => 4,
    }
}

impl Context {
    /// Creates an instance and a device of our own (Vulkan 1.3, synchronization2, dynamic
    /// rendering, maintenance4), with validation if `desc.validation`.
    pub fn headless(desc: &ContextDesc) -> Result<Context, VkError> {
        // SAFETY: loading the system Vulkan loader runs its initialisation code; nothing else
        // in this process depends on it being absent.
        let entry = unsafe { ash::Entry::load() }.map_err(|e| VkError::Loader(e.to_string()))?;
        let messages = Arc::new(Mutex::new(Vec::new()));
        // Boxed so the callback's pointer stays valid; leaked into the device below (freed there).
        let user = Box::new(MessageSink {
            messages: messages.clone(),
            echo: desc.echo_validation,
        });

        // SAFETY: plain queries on a loaded entry.
        let layers = unsafe { entry.enumerate_instance_layer_properties() }
            .map_err(VkError::call("vkEnumerateInstanceLayerProperties"))?;
        let has_layer = layers
            .iter()
            .any(|l| c_name(&l.layer_name).as_bytes() == VALIDATION_LAYER.to_bytes());
        if desc.validation && !has_layer {
            return Err(VkError::NoValidationLayer);
        }
        // SAFETY: as above.
        let extensions = unsafe { entry.enumerate_instance_extension_properties(None) }
            .map_err(VkError::call("vkEnumerateInstanceExtensionProperties"))?;
        let has_debug_utils = extensions.iter().any(|e| {
            c_name(&e.extension_name).as_bytes() == ash::ext::debug_utils::NAME.to_bytes()
        });
        let use_messenger = desc.validation && has_debug_utils;

        let app_name = c"translucent";
        let app = vk::ApplicationInfo::default()
            .application_name(app_name)
            .engine_name(app_name)
            .api_version(vk::API_VERSION_1_3);
        let mut ext_names = Vec::new();
        if has_debug_utils {
            ext_names.push(ash::ext::debug_utils::NAME.as_ptr());
        }
        let mut layer_names = Vec::new();
        let enabled_features = [vk::ValidationFeatureEnableEXT::SYNCHRONIZATION_VALIDATION];
        let mut validation_features =
            vk::ValidationFeaturesEXT::default().enabled_validation_features(&enabled_features);
        if desc.validation {
            layer_names.push(VALIDATION_LAYER.as_ptr());
            ext_names.push(ash::ext::validation_features::NAME.as_ptr());
        }
        let mut messenger_info = vk::DebugUtilsMessengerCreateInfoEXT::default()
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
            .user_data(&*user as *const MessageSink as *mut c_void);
        let mut instance_info = vk::InstanceCreateInfo::default()
            .application_info(&app)
            .enabled_layer_names(&layer_names)
            .enabled_extension_names(&ext_names);
        if desc.validation {
            // Chained so instance creation and destruction are validated too.
            instance_info = instance_info.push_next(&mut validation_features);
            if use_messenger {
                instance_info = instance_info.push_next(&mut messenger_info);
            }
        }
        // SAFETY: every pointer in `instance_info` refers to locals alive across the call.
        let instance = unsafe { entry.create_instance(&instance_info, None) }
            .map_err(VkError::create_instance)?;
        let messenger = if use_messenger {
            let utils = ash::ext::debug_utils::Instance::new(&entry, &instance);
            // A fresh struct: the one chained into the instance has its `p_next` rewritten.
            let mut info = messenger_info;
            info.p_next = std::ptr::null();
            // SAFETY: `instance` is live; the callback's user data outlives the messenger.
            match unsafe { utils.create_debug_utils_messenger(&info, None) } {
                Ok(m) => Some((utils, m)),
                Err(result) => {
                    // SAFETY: nothing was created from the instance yet.
                    unsafe { instance.destroy_instance(None) };
                    return Err(VkError::Call {
                        call: "vkCreateDebugUtilsMessengerEXT",
                        result,
                    });
                }
            }
        } else {
            None
        };
        let destroy_instance =
            |messenger: &Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>| {
                // SAFETY: no device was created; the messenger (if any) is a child of the instance.
                unsafe {
                    if let Some((u, m)) = messenger {
                        u.destroy_debug_utils_messenger(*m, None);
                    }
                    instance.destroy_instance(None);
                }
            };

        let chosen = Self::choose_device(&instance, desc.device_name.as_deref());
        let (physical, queue_family) = match chosen {
            Ok(c) => c,
            Err(e) => {
                destroy_instance(&messenger);
                return Err(e);
            }
        };
        let priorities = [1.0f32];
        let queue_info = [vk::DeviceQueueCreateInfo::default()
            .queue_family_index(queue_family)
            .queue_priorities(&priorities)];
        let mut f13 = vk::PhysicalDeviceVulkan13Features::default()
            .synchronization2(true)
            .dynamic_rendering(true)
            .maintenance4(true);
        let device_info = vk::DeviceCreateInfo::default()
            .queue_create_infos(&queue_info)
            .push_next(&mut f13);
        // SAFETY: `physical` belongs to `instance`; the features were checked in `check_device`.
        let device = match unsafe { instance.create_device(physical, &device_info, None) } {
            Ok(d) => d,
            Err(result) => {
                destroy_instance(&messenger);
                return Err(VkError::Call {
                    call: "vkCreateDevice",
                    result,
                });
            }
        };
        let debug_utils =
            has_debug_utils.then(|| ash::ext::debug_utils::Device::new(&instance, &device));
        let owned = OwnedVulkan {
            entry,
            instance,
            device,
            messenger,
        };
        let ctx = Self::build(
            Handles::Owned(owned),
            physical,
            queue_family,
            0,
            debug_utils,
            messages,
            desc.validation,
            desc.frames_in_flight,
            true,
        );
        // The callback's user data must live as long as the instance: the device owns it now.
        match ctx {
            Ok(ctx) => {
                ctx.device.keep_alive(user);
                Ok(ctx)
            }
            Err(e) => {
                // `build` dropped the device (and instance) on failure; the box can go now.
                drop(user);
                Err(e)
            }
        }
    }

    /// Wraps a host's Vulkan objects. We never destroy them, never submit to `queue_family`'s queue
    /// and never wait on it (unless the host lends it for setup work with
    /// [`Context::lend_queue_for_setup`]); the host drives frames with [`Context::begin_frame`] and
    /// [`Context::frame_completed`]. The instance must have `VK_EXT_debug_utils` enabled (passes
    /// are labelled). The host must have enabled Vulkan 1.3 with synchronization2,
    /// dynamicRendering and maintenance4 (checked here as device support).
    ///
    /// # Safety
    /// The handles must be valid, `device` created from `physical` of `instance` with the features
    /// above enabled, and they must outlive the returned context and every object created from it.
    pub unsafe fn from_host(
        entry: ash::Entry,
        instance: ash::Instance,
        physical: vk::PhysicalDevice,
        device: ash::Device,
        queue_family: u32,
        queue_index: u32,
        frames_in_flight: u32,
    ) -> Result<Context, VkError> {
        let options = HostOptions {
            labels: true,
            messages: None,
        };
        // SAFETY: the caller's contract.
        unsafe {
            Self::from_host_with(
                entry,
                instance,
                physical,
                device,
                queue_family,
                queue_index,
                frames_in_flight,
                options,
            )
        }
    }

    /// [`Context::from_host`] for interop modules (wgpu): the host's instance may lack
    /// `VK_EXT_debug_utils` (no labels or names then), and its validation messages may already be
    /// collected by a messenger the interop module created.
    ///
    /// # Safety
    /// As [`Context::from_host`]; with `options.labels` the instance has `VK_EXT_debug_utils`.
    #[allow(clippy::too_many_arguments)]
    pub(crate) unsafe fn from_host_with(
        entry: ash::Entry,
        instance: ash::Instance,
        physical: vk::PhysicalDevice,
        device: ash::Device,
        queue_family: u32,
        queue_index: u32,
        frames_in_flight: u32,
        options: HostOptions,
    ) -> Result<Context, VkError> {
        check_device(&instance, physical)?;
        let debug_utils = options
            .labels
            .then(|| ash::ext::debug_utils::Device::new(&instance, &device));
        let validation = options.messages.is_some();
        let messages = options
            .messages
            .unwrap_or_else(|| Arc::new(Mutex::new(Vec::new())));
        let host = HostVulkan {
            entry,
            instance,
            device,
        };
        Self::build(
            Handles::Host(host),
            physical,
            queue_family,
            queue_index,
            debug_utils,
            messages,
            validation,
            frames_in_flight,
            false,
        )
    }

    /// Host contexts: the host lends its queue for setup work outside its frames. Creating an
    /// object uploads its textures and headless reports read results back; with this, those calls
    /// submit their own command buffers to the queue and wait for them (the host's frames are
    /// still recorded only into the host's command buffers, never submitted by us). Such
    /// submissions do not advance or complete the host's frames: what they drop is released when
    /// the host completes its current frame.
    ///
    /// # Safety
    /// While any of our calls that may submit runs (constructors, `set_material`, `deform`,
    /// read-backs), the host must not access the queue from another thread (Vulkan's external
    /// synchronization of `vkQueueSubmit`).
    pub unsafe fn lend_queue_for_setup(&mut self) -> Result<(), VkError> {
        if self.submitter.is_some() {
            return Ok(());
        }
        let info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(self.device.queue_family)
            .flags(
                vk::CommandPoolCreateFlags::TRANSIENT
                    | vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER,
            );
        // SAFETY: live device; destroyed in `Drop for Context`.
        let pool = unsafe { self.raw().create_command_pool(&info, None) }
            .map_err(VkError::call("vkCreateCommandPool"))?;
        self.submitter = Some(Mutex::new(pool));
        self.lent_queue = true;
        Ok(())
    }

    /// Completes `frame` unless the submission ran on a lent host queue (the host owns frames).
    fn complete_submission(&self, frame: u64) {
        if !self.lent_queue {
            self.frame_completed(frame);
        }
    }

    fn choose_device(
        instance: &ash::Instance,
        wanted: Option<&str>,
    ) -> Result<(vk::PhysicalDevice, u32), VkError> {
        // SAFETY: plain query on a live instance.
        let physicals = unsafe { instance.enumerate_physical_devices() }
            .map_err(VkError::call("vkEnumeratePhysicalDevices"))?;
        let mut candidates: Vec<(u32, String, vk::PhysicalDevice)> = physicals
            .iter()
            .map(|&p| {
                // SAFETY: `p` was just enumerated from `instance`.
                let props = unsafe { instance.get_physical_device_properties(p) };
                (
                    device_rank(props.device_type),
                    c_name(&props.device_name),
                    p,
                )
            })
            .collect();
        let available: Vec<String> = candidates.iter().map(|c| c.1.clone()).collect();
        if let Some(w) = wanted {
            let w = w.to_lowercase();
            candidates.retain(|c| c.1.to_lowercase().contains(&w));
        }
        candidates.sort_by_key(|c| c.0);
        let mut first_error = None;
        for (_, _, p) in &candidates {
            match check_device(instance, *p) {
                Ok(family) => return Ok((*p, family)),
                Err(e) => {
                    first_error.get_or_insert(e);
                }
            }
        }
        Err(first_error.unwrap_or(VkError::NoDevice {
            wanted: wanted.map(str::to_owned),
            available,
        }))
    }

    #[allow(clippy::too_many_arguments)]
    fn build(
        handles: Handles,
        physical: vk::PhysicalDevice,
        queue_family: u32,
        queue_index: u32,
        debug_utils: Option<ash::ext::debug_utils::Device>,
        messages: Arc<Mutex<Vec<ValidationMessage>>>,
        validation: bool,
        frames_in_flight: u32,
        owns_queue: bool,
    ) -> Result<Context, VkError> {
        let instance = handles.instance().clone();
        let raw = handles.device().clone();
        // SAFETY: the family and index were used to create the device (ours or the host's).
        let queue = unsafe { raw.get_device_queue(queue_family, queue_index) };
        // SAFETY: plain queries.
        let properties = unsafe { instance.get_physical_device_properties(physical) };
        let mut driver = vk::PhysicalDeviceDriverProperties::default();
        let mut subgroup = vk::PhysicalDeviceSubgroupProperties::default();
        let mut props2 = vk::PhysicalDeviceProperties2::default()
            .push_next(&mut driver)
            .push_next(&mut subgroup);
        // SAFETY: core 1.2/1.1 property structs on a 1.3 device.
        unsafe { instance.get_physical_device_properties2(physical, &mut props2) };
        // SAFETY: plain query.
        let families = unsafe { instance.get_physical_device_queue_family_properties(physical) };
        let valid_bits = families
            .get(queue_family as usize)
            .map_or(0, |f| f.timestamp_valid_bits);
        let timestamps =
            valid_bits > 0 && properties.limits.timestamp_compute_and_graphics == vk::TRUE;
        let info = DeviceInfo {
            device_name: c_name(&properties.device_name),
            device_type: format!("{:?}", properties.device_type),
            driver_name: c_name(&driver.driver_name),
            driver_info: c_name(&driver.driver_info),
            api_version: version_string(properties.api_version),
            features: [&["Vulkan 1.3"][..], &REQUIRED_FEATURES[..]].concat(),
            validation,
            timestamps,
            timestamp_period_ns: properties.limits.timestamp_period,
            subgroup_size: subgroup.subgroup_size,
        };
        let allocator = Allocator::new(&AllocatorCreateDesc {
            instance,
            device: raw.clone(),
            physical_device: physical,
            debug_settings: Default::default(),
            buffer_device_address: false,
            allocation_sizes: Default::default(),
        });
        let device = Arc::new(Device {
            handles,
            physical,
            queue_family,
            queue,
            properties,
            debug_utils,
            allocator: Mutex::new(None),
            requested_bytes: Default::default(),
            frames: Mutex::new(Default::default()),
            messages,
            keep: Mutex::new(None),
        });
        let allocator = allocator.map_err(|e| VkError::Allocation {
            name: "allocator".into(),
            message: e.to_string(),
        })?;
        *device.lock_allocator() = Some(allocator);
        let submitter = if owns_queue {
            let info = vk::CommandPoolCreateInfo::default()
                .queue_family_index(queue_family)
                .flags(
                    vk::CommandPoolCreateFlags::TRANSIENT
                        | vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER,
                );
            // SAFETY: live device; destroyed in `Drop for Context`.
            let pool = unsafe { raw.create_command_pool(&info, None) }
                .map_err(VkError::call("vkCreateCommandPool"))?;
            Some(Mutex::new(pool))
        } else {
            None
        };
        Ok(Context {
            device,
            submitter,
            info,
            frames_in_flight: frames_in_flight.max(1),
            lent_queue: false,
            shader_overrides: std::collections::HashMap::new(),
        })
    }

    /// Replaces the SPIR-V (words by shader name, as `shader::embedded` names them) that
    /// pipelines created from now on use instead of the embedded shaders; returns the previous
    /// set. Pipelines that exist keep theirs: the host rebuilds what should change (hot reload,
    /// `shader::runtime`). An empty map goes back to the embedded shaders.
    pub fn set_shader_overrides(
        &mut self,
        overrides: std::collections::HashMap<String, Vec<u32>>,
    ) -> std::collections::HashMap<String, Vec<u32>> {
        std::mem::replace(&mut self.shader_overrides, overrides)
    }

    /// The SPIR-V installed for shader `name` with [`Context::set_shader_overrides`].
    pub fn shader_override(&self, name: &str) -> Option<&[u32]> {
        self.shader_overrides.get(name).map(Vec::as_slice)
    }

    /// The raw ash device, for recording commands.
    pub fn raw(&self) -> &ash::Device {
        self.device.raw()
    }

    /// The queue (ours, or the host's: then only for reference, we never submit to it).
    pub fn queue(&self) -> (u32, vk::Queue) {
        (self.device.queue_family, self.device.queue)
    }

    pub fn physical_device(&self) -> vk::PhysicalDevice {
        self.device.physical
    }

    pub fn limits(&self) -> &vk::PhysicalDeviceLimits {
        &self.device.properties.limits
    }

    pub fn info(&self) -> &DeviceInfo {
        &self.info
    }

    pub fn frames_in_flight(&self) -> u32 {
        self.frames_in_flight
    }

    /// Whether `format` supports `features` with optimal tiling.
    pub fn format_supports(&self, format: vk::Format, features: vk::FormatFeatureFlags) -> bool {
        // SAFETY: plain query.
        let props = unsafe {
            self.device
                .handles
                .instance()
                .get_physical_device_format_properties(self.device.physical, format)
        };
        props.optimal_tiling_features.contains(features)
    }

    /// A handle on the collected messages that outlives the context (so messages emitted while
    /// the device and instance are destroyed, such as leaked objects, can still be checked).
    pub fn validation_log(&self) -> ValidationLog {
        ValidationLog(self.device.messages.clone(), Arc::downgrade(&self.device))
    }

    /// Takes the validation messages collected so far (warnings and errors only).
    pub fn take_validation_messages(&self) -> Vec<ValidationMessage> {
        std::mem::take(
            &mut *self
                .device
                .messages
                .lock()
                .unwrap_or_else(|e| e.into_inner()),
        )
    }

    /// The host starts recording `frame` (monotonic). Objects dropped from now on wait for it.
    pub fn begin_frame(&self, frame: u64) {
        let mut frames = self.device.lock_frames();
        frames.current = frames.current.max(frame);
    }

    /// The GPU has finished every frame up to `completed`: destroys what waited for them and
    /// returns how many objects were destroyed.
    pub fn frame_completed(&self, completed: u64) -> usize {
        self.device.frame_completed(completed)
    }

    /// (frame being recorded, last completed frame).
    pub fn frames(&self) -> (u64, u64) {
        let f = self.device.lock_frames();
        (f.current, f.completed)
    }

    /// Objects waiting for their frame to complete.
    pub fn pending_releases(&self) -> usize {
        self.device.lock_frames().pending.len()
    }

    /// Live gpu-allocator allocations (0 once everything is released).
    pub fn live_allocations(&self) -> usize {
        self.device
            .lock_allocator()
            .as_ref()
            .map_or(0, |a| a.generate_report().allocations.len())
    }

    /// The allocator's totals: (live allocations, bytes they asked for, bytes of memory blocks
    /// held). For soak tests: all three stay flat when nothing leaks, and equal states give equal
    /// totals. The bytes are the allocations' requested sizes, not gpu-allocator's
    /// `total_allocated_bytes`, which adds each allocation's alignment padding: that depends on
    /// where it lands in a block, and the allocator picks among equal free chunks in the order of
    /// a `HashSet` (random per process), so the same allocations measured -56..+24 bytes apart
    /// (the voxel soak's first period, issue 14).
    pub fn allocator_usage(&self) -> (usize, u64, u64) {
        let requested = self.device.requested_bytes.load(Ordering::Relaxed);
        self.device
            .lock_allocator()
            .as_ref()
            .map_or((0, requested, 0), |a| {
                let r = a.generate_report();
                (r.allocations.len(), requested, r.total_capacity_bytes)
            })
    }

    /// gpu-allocator's own byte total: the requested bytes of [`Self::allocator_usage`] plus each
    /// allocation's alignment padding (placement-dependent: for diagnosis, not for flatness checks).
    pub fn allocator_padded_bytes(&self) -> u64 {
        self.device
            .lock_allocator()
            .as_ref()
            .map_or(0, |a| a.generate_report().total_allocated_bytes)
    }

    /// Gives `handle` a debug-utils name.
    pub fn set_name<H: vk::Handle>(&self, handle: H, name: &str) {
        self.device.set_name(handle, name);
    }

    /// Opens a command-buffer label (closed by [`Context::end_label`]).
    ///
    /// # Safety
    /// `cb` must be in the recording state.
    pub unsafe fn begin_label(&self, cb: vk::CommandBuffer, name: &str) {
        let Some(utils) = &self.device.debug_utils else {
            return;
        };
        let Ok(cname) = CString::new(name) else {
            return;
        };
        // SAFETY: caller guarantees `cb` is recording.
        unsafe {
            utils.cmd_begin_debug_utils_label(
                cb,
                &vk::DebugUtilsLabelEXT::default().label_name(&cname),
            )
        };
    }

    /// Inserts a one-off label (e.g. the frame graph's "why" of a barrier) where debug utils exist.
    ///
    /// # Safety
    /// `cb` must be in the recording state.
    pub unsafe fn insert_label(&self, cb: vk::CommandBuffer, text: &str) {
        let Some(utils) = &self.device.debug_utils else {
            return;
        };
        let Ok(cname) = CString::new(text) else {
            return;
        };
        // SAFETY: caller guarantees `cb` is recording.
        unsafe {
            utils.cmd_insert_debug_utils_label(
                cb,
                &vk::DebugUtilsLabelEXT::default().label_name(&cname),
            )
        };
    }

    /// Whether command-buffer labels are recorded (debug utils present).
    pub fn labels_enabled(&self) -> bool {
        self.device.debug_utils.is_some()
    }

    /// Closes the label opened last by [`Context::begin_label`].
    ///
    /// # Safety
    /// `cb` must be recording with an open label.
    pub unsafe fn end_label(&self, cb: vk::CommandBuffer) {
        let Some(utils) = &self.device.debug_utils else {
            return;
        };
        // SAFETY: caller guarantees an open label on a recording `cb`.
        unsafe { utils.cmd_end_debug_utils_label(cb) };
    }

    /// Headless only: starts the next frame, records `record` into a fresh command buffer and
    /// submits it. Wait with [`Submission::wait`] (which reports the frame complete). `record`
    /// must not submit itself (the command pool is locked while it runs).
    pub fn submit(
        &self,
        name: &str,
        record: impl FnOnce(vk::CommandBuffer) -> Result<(), VkError>,
    ) -> Result<Submission<'_>, VkError> {
        let pool = self.submitter.as_ref().ok_or(VkError::HostOwnsQueue {
            operation: "submit",
        })?;
        let pool = pool.lock().unwrap_or_else(|e| e.into_inner());
        let raw = self.raw();
        let alloc = vk::CommandBufferAllocateInfo::default()
            .command_pool(*pool)
            .command_buffer_count(1);
        // SAFETY: the pool is ours and externally synchronized by the mutex.
        let cb = unsafe { raw.allocate_command_buffers(&alloc) }
            .map_err(VkError::call("vkAllocateCommandBuffers"))?[0];
        let free = |fence: Option<vk::Fence>| {
            // SAFETY: `cb` is not pending (never submitted, or its fence was waited on).
            unsafe {
                raw.free_command_buffers(*pool, &[cb]);
                if let Some(f) = fence {
                    raw.destroy_fence(f, None);
                }
            }
        };
        self.set_name(cb, name);
        let frame = {
            let mut frames = self.device.lock_frames();
            if !self.lent_queue {
                frames.current += 1;
            }
            frames.current
        };
        let begin = vk::CommandBufferBeginInfo::default()
            .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
        // SAFETY: fresh command buffer.
        if let Err(result) = unsafe { raw.begin_command_buffer(cb, &begin) } {
            free(None);
            self.complete_submission(frame);
            return Err(VkError::Call {
                call: "vkBeginCommandBuffer",
                result,
            });
        }
        let recorded = record(cb).and_then(|()| {
            // SAFETY: `cb` is recording.
            unsafe { raw.end_command_buffer(cb) }.map_err(VkError::call("vkEndCommandBuffer"))
        });
        if let Err(e) = recorded {
            free(None);
            self.complete_submission(frame);
            return Err(e);
        }
        // SAFETY: plain object creation.
        let fence = unsafe { raw.create_fence(&vk::FenceCreateInfo::default(), None) }
            .map_err(VkError::call("vkCreateFence"))?;
        let cbs = [vk::CommandBufferSubmitInfo::default().command_buffer(cb)];
        let submit = vk::SubmitInfo2::default().command_buffer_infos(&cbs);
        // SAFETY: we own the queue (headless) and the pool lock serializes queue access too.
        if let Err(result) = unsafe { raw.queue_submit2(self.device.queue, &[submit], fence) } {
            free(Some(fence));
            self.complete_submission(frame);
            return Err(VkError::Call {
                call: "vkQueueSubmit2",
                result,
            });
        }
        Ok(Submission {
            ctx: self,
            cb,
            fence,
            frame,
            waited: false,
        })
    }

    /// Headless only: [`Context::submit`] and wait.
    pub fn execute(
        &self,
        name: &str,
        record: impl FnOnce(vk::CommandBuffer) -> Result<(), VkError>,
    ) -> Result<(), VkError> {
        self.submit(name, record)?.wait()
    }
}

/// A headless submission in flight (frame number `frame`). Dropping it waits.
pub struct Submission<'a> {
    ctx: &'a Context,
    cb: vk::CommandBuffer,
    fence: vk::Fence,
    frame: u64,
    waited: bool,
}

impl Submission<'_> {
    /// The frame number this submission runs as.
    pub fn frame(&self) -> u64 {
        self.frame
    }

    /// Waits for the GPU, reports the frame complete (releasing what waited for it).
    pub fn wait(mut self) -> Result<(), VkError> {
        self.wait_inner()
    }

    fn wait_inner(&mut self) -> Result<(), VkError> {
        if self.waited {
            return Ok(());
        }
        self.waited = true;
        let raw = self.ctx.raw();
        // SAFETY: the fence belongs to this device and was submitted with the command buffer.
        let result = unsafe { raw.wait_for_fences(&[self.fence], true, u64::MAX) }
            .map_err(VkError::call("vkWaitForFences"));
        if let Some(pool) = &self.ctx.submitter {
            let pool = pool.lock().unwrap_or_else(|e| e.into_inner());
            // SAFETY: the fence signalled (or the device is lost): the command buffer is not pending.
            unsafe {
                raw.free_command_buffers(*pool, &[self.cb]);
                raw.destroy_fence(self.fence, None);
            }
        }
        result?;
        self.ctx.complete_submission(self.frame);
        Ok(())
    }
}

impl Drop for Submission<'_> {
    fn drop(&mut self) {
        let _ = self.wait_inner();
    }
}

impl Drop for Context {
    fn drop(&mut self) {
        if let Some(pool) = &self.submitter {
            let pool = *pool.lock().unwrap_or_else(|e| e.into_inner());
            // SAFETY: every `Submission` borrows the context, so none is pending now.
            unsafe { self.raw().destroy_command_pool(pool, None) };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn device_order_is_discrete_integrated_virtual_cpu() {
        use vk::PhysicalDeviceType as T;
        let mut types = [
            T::CPU,
            T::OTHER,
            T::INTEGRATED_GPU,
            T::VIRTUAL_GPU,
            T::DISCRETE_GPU,
        ];
        types.sort_by_key(|t| device_rank(*t));
        assert_eq!(
            types,
            [
                T::DISCRETE_GPU,
                T::INTEGRATED_GPU,
                T::VIRTUAL_GPU,
                T::CPU,
                T::OTHER
            ]
        );
    }

    #[test]
    fn missing_features_and_versions_are_named_in_errors() {
        let e = VkError::MissingFeature {
            device: "gpu".into(),
            feature: "maintenance4",
        };
        assert!(e.to_string().contains("`maintenance4`"));
        assert_eq!(
            version_string(vk::make_api_version(0, 1, 2, 198)),
            "1.2.198"
        );
        let e = VkError::NoDevice {
            wanted: Some("nvidia".into()),
            available: vec!["llvmpipe".into()],
        };
        let text = e.to_string();
        assert!(
            text.contains("\"nvidia\"")
                && text.contains("llvmpipe")
                && text.contains("vulkan-validationlayers"),
            "{text}"
        );
    }
}
