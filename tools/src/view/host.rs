//! The viewer as a host (DESIGN section 7): its OWN Vulkan instance (with the window system's
//! surface extensions and, on request, validation with synchronization validation), device
//! (with `VK_KHR_swapchain`) and swapchain. The library borrows the instance and device through
//! `Context::from_host`, exactly as in `engine/examples/host_graph.rs`.

use std::ffi::c_void;
use std::sync::Mutex;

use anyhow::{bail, Context as _};
use ash::vk;
use raw_window_handle::{RawDisplayHandle, RawWindowHandle};

/// Validation messages the host's messenger saw (warnings and errors).
static MESSAGES: Mutex<Vec<String>> = Mutex::new(Vec::new());

unsafe extern "system" fn on_message(
    _severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _kind: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    _user: *mut c_void,
) -> vk::Bool32 {
    // SAFETY: the layer passes a valid callback data struct whose strings are NUL-terminated
    // for the duration of the callback.
    let text = unsafe { data.as_ref().and_then(|d| d.message_as_c_str()) }
        .map_or_else(|| "?".into(), |t| t.to_string_lossy().into_owned());
    eprintln!("validation: {text}");
    MESSAGES
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .push(text);
    vk::FALSE
}

/// How many validation messages arrived so far.
pub fn validation_messages() -> usize {
    MESSAGES.lock().unwrap_or_else(|e| e.into_inner()).len()
}

/// Instance, messenger and surface: destroyed (in that order reversed) when dropped, also when
/// creating the device fails.
pub struct InstanceParts {
    pub entry: ash::Entry,
    pub instance: ash::Instance,
    messenger: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    pub surface_loader: ash::khr::surface::Instance,
    pub surface: vk::SurfaceKHR,
}

impl Drop for InstanceParts {
    fn drop(&mut self) {
        // SAFETY: the device (the only other child of the instance) is destroyed before (see
        // `Host`'s drop); children go before parents.
        unsafe {
            self.surface_loader.destroy_surface(self.surface, None);
            if let Some((utils, m)) = &self.messenger {
                utils.destroy_debug_utils_messenger(*m, None);
            }
            self.instance.destroy_instance(None);
        }
    }
}

/// Instance, surface, device and queue of the viewer. Dropped last (after the library's context
/// and everything created from it).
pub struct Host {
    pub device: ash::Device,
    pub physical: vk::PhysicalDevice,
    pub family: u32,
    pub queue: vk::Queue,
    pub swapchain_loader: ash::khr::swapchain::Device,
    pub device_name: String,
    /// Dropped after `Host::drop` destroyed the device.
    pub parts: InstanceParts,
}

impl Host {
    /// Creates instance, surface and device for the window behind `display` and `window`.
    /// `TRANSLUCENT_DEVICE` picks the device by name, as for the rest of the command line.
    pub fn new(
        display: RawDisplayHandle,
        window: RawWindowHandle,
        validation: bool,
    ) -> anyhow::Result<Host> {
        // SAFETY: loading the system's Vulkan loader.
        let entry = unsafe { ash::Entry::load() }
            .with_context(|| format!("no Vulkan loader; {}", translucent::vk::INSTALL_HINT))?;
        let app = vk::ApplicationInfo::default()
            .application_name(c"translucent view")
            .api_version(vk::API_VERSION_1_3);
        let mut extensions = ash_window::enumerate_required_extensions(display)
            .context("the window system's Vulkan surface extensions")?
            .to_vec();
        // debug_utils: the library labels its passes (required of a host context).
        extensions.push(ash::ext::debug_utils::NAME.as_ptr());
        let mut layers = Vec::new();
        if validation {
            layers.push(c"VK_LAYER_KHRONOS_validation".as_ptr());
            extensions.push(ash::ext::validation_features::NAME.as_ptr());
        }
        let sync = [vk::ValidationFeatureEnableEXT::SYNCHRONIZATION_VALIDATION];
        let mut features = vk::ValidationFeaturesEXT::default().enabled_validation_features(&sync);
        let mut info = vk::InstanceCreateInfo::default()
            .application_info(&app)
            .enabled_layer_names(&layers)
            .enabled_extension_names(&extensions);
        if validation {
            info = info.push_next(&mut features);
        }
        // SAFETY: every pointer in `info` refers to locals or statics alive across the call.
        let instance = unsafe { entry.create_instance(&info, None) }
            .map_err(translucent::vk::VkError::create_instance)
            .with_context(|| {
                if validation {
                    "vkCreateInstance (validation asked for: is vulkan-validationlayers installed?)"
                } else {
                    "vkCreateInstance"
                }
            })?;
        let surface_loader = ash::khr::surface::Instance::new(&entry, &instance);
        let mut parts = InstanceParts {
            entry,
            instance,
            messenger: None,
            surface_loader,
            surface: vk::SurfaceKHR::null(),
        };
        if validation {
            let utils = ash::ext::debug_utils::Instance::new(&parts.entry, &parts.instance);
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
                .pfn_user_callback(Some(on_message));
            // SAFETY: live instance; destroyed with `parts`.
            let m = unsafe { utils.create_debug_utils_messenger(&info, None) }
                .context("vkCreateDebugUtilsMessengerEXT")?;
            parts.messenger = Some((utils, m));
        }
        // SAFETY: the handles come from a live winit window that outlives the surface (the
        // viewer drops the host before the window). Destroying a null surface is allowed.
        parts.surface = unsafe {
            ash_window::create_surface(&parts.entry, &parts.instance, display, window, None)
        }
        .context("creating the window's Vulkan surface")?;
        let (physical, family, name) = pick_device(&parts)?;
        let priorities = [1.0];
        let queues = [vk::DeviceQueueCreateInfo::default()
            .queue_family_index(family)
            .queue_priorities(&priorities)];
        let mut f13 = vk::PhysicalDeviceVulkan13Features::default()
            .synchronization2(true)
            .dynamic_rendering(true)
            .maintenance4(true);
        let device_extensions = [ash::khr::swapchain::NAME.as_ptr()];
        let info = vk::DeviceCreateInfo::default()
            .queue_create_infos(&queues)
            .enabled_extension_names(&device_extensions)
            .push_next(&mut f13);
        // SAFETY: `physical` belongs to the instance; `Context::from_host` checks the features.
        let device = unsafe { parts.instance.create_device(physical, &info, None) }
            .context("vkCreateDevice (Vulkan 1.3 with synchronization2, dynamicRendering, maintenance4, VK_KHR_swapchain)")?;
        // SAFETY: created just above with this family.
        let queue = unsafe { device.get_device_queue(family, 0) };
        let swapchain_loader = ash::khr::swapchain::Device::new(&parts.instance, &device);
        Ok(Host {
            device,
            physical,
            family,
            queue,
            swapchain_loader,
            device_name: name,
            parts,
        })
    }

    pub fn instance(&self) -> &ash::Instance {
        &self.parts.instance
    }

    pub fn surface(&self) -> vk::SurfaceKHR {
        self.parts.surface
    }

    pub fn surface_loader(&self) -> &ash::khr::surface::Instance {
        &self.parts.surface_loader
    }
}

/// The first Vulkan 1.3 device (whose name contains `TRANSLUCENT_DEVICE`, if set) with a
/// graphics+compute queue family that can present to the surface.
fn pick_device(parts: &InstanceParts) -> anyhow::Result<(vk::PhysicalDevice, u32, String)> {
    let wanted = std::env::var("TRANSLUCENT_DEVICE")
        .unwrap_or_default()
        .to_lowercase();
    // SAFETY: live instance.
    let physicals = unsafe { parts.instance.enumerate_physical_devices() }
        .context("vkEnumeratePhysicalDevices")?;
    let mut seen = Vec::new();
    for &p in &physicals {
        // SAFETY: `p` was enumerated from the instance.
        let props = unsafe { parts.instance.get_physical_device_properties(p) };
        let name = props
            .device_name_as_c_str()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        seen.push(name.clone());
        if props.api_version < vk::API_VERSION_1_3 || !name.to_lowercase().contains(&wanted) {
            continue;
        }
        // SAFETY: as above.
        let families = unsafe {
            parts
                .instance
                .get_physical_device_queue_family_properties(p)
        };
        let needed = vk::QueueFlags::GRAPHICS | vk::QueueFlags::COMPUTE;
        let family = (0..families.len() as u32).find(|&f| {
            families[f as usize].queue_flags.contains(needed)
                // SAFETY: `f` is a family of `p`; the surface is live.
                && unsafe {
                    parts
                        .surface_loader
                        .get_physical_device_surface_support(p, f, parts.surface)
                }
                .unwrap_or(false)
        });
        if let Some(f) = family {
            return Ok((p, f, name));
        }
    }
    bail!(
        "no Vulkan 1.3 device{} with a graphics+compute queue that can present to the window (devices: {seen:?}); {}",
        if wanted.is_empty() {
            String::new()
        } else {
            format!(" named like {wanted:?} (TRANSLUCENT_DEVICE)")
        },
        translucent::vk::INSTALL_HINT
    )
}

impl Drop for Host {
    fn drop(&mut self) {
        // SAFETY: the viewer destroys every child of the device (swapchain, the library's
        // context and its objects, its own pipelines) before dropping the host; waiting for
        // idle first makes that true of the GPU too. `parts` goes after this.
        unsafe {
            let _ = self.device.device_wait_idle();
            self.device.destroy_device(None);
        }
    }
}

/// The window's swapchain and what belongs to each of its images.
pub struct Swapchain {
    pub raw: vk::SwapchainKHR,
    pub format: vk::Format,
    /// The format is `*_UNORM`: the present pass encodes sRGB itself.
    pub encode_srgb: bool,
    pub extent: vk::Extent2D,
    pub images: Vec<vk::Image>,
    pub views: Vec<vk::ImageView>,
    /// Signalled when an image's frame is rendered; presentation waits on it. One per image: a
    /// semaphore is only free again once its image is acquired again.
    pub rendered: Vec<vk::Semaphore>,
}

/// Formats the present pass can write, best first: UNORM (the shader encodes sRGB exactly as
/// the PNG writer), then the SRGB formats.
const SURFACE_FORMATS: [(vk::Format, bool); 4] = [
    (vk::Format::B8G8R8A8_UNORM, true),
    (vk::Format::R8G8B8A8_UNORM, true),
    (vk::Format::B8G8R8A8_SRGB, false),
    (vk::Format::R8G8B8A8_SRGB, false),
];

impl Swapchain {
    /// A swapchain of `extent` (clamped to what the surface allows), replacing `old`. `None`
    /// when the surface has no area (a minimized window): nothing to render into.
    pub fn new(
        host: &Host,
        extent: vk::Extent2D,
        present_mode: vk::PresentModeKHR,
        old: Option<&Swapchain>,
    ) -> anyhow::Result<Option<Swapchain>> {
        // SAFETY: live physical device and surface.
        let caps = unsafe {
            host.surface_loader()
                .get_physical_device_surface_capabilities(host.physical, host.surface())
        }
        .context("vkGetPhysicalDeviceSurfaceCapabilitiesKHR")?;
        let extent = if caps.current_extent.width != u32::MAX {
            caps.current_extent
        } else {
            vk::Extent2D {
                width: extent
                    .width
                    .clamp(caps.min_image_extent.width, caps.max_image_extent.width),
                height: extent
                    .height
                    .clamp(caps.min_image_extent.height, caps.max_image_extent.height),
            }
        };
        if extent.width == 0 || extent.height == 0 {
            return Ok(None);
        }
        // SAFETY: as above.
        let formats = unsafe {
            host.surface_loader()
                .get_physical_device_surface_formats(host.physical, host.surface())
        }
        .context("vkGetPhysicalDeviceSurfaceFormatsKHR")?;
        let (format, encode_srgb) = SURFACE_FORMATS
            .iter()
            .find(|(f, _)| {
                formats
                    .iter()
                    .any(|s| s.format == *f && s.color_space == vk::ColorSpaceKHR::SRGB_NONLINEAR)
            })
            .copied()
            .with_context(|| format!("no 8-bit RGBA/BGRA surface format among {formats:?}"))?;
        // SAFETY: as above.
        let modes = unsafe {
            host.surface_loader()
                .get_physical_device_surface_present_modes(host.physical, host.surface())
        }
        .context("vkGetPhysicalDeviceSurfacePresentModesKHR")?;
        let present_mode = if modes.contains(&present_mode) {
            present_mode
        } else {
            vk::PresentModeKHR::FIFO // always supported
        };
        let mut count = caps.min_image_count + 1;
        if caps.max_image_count > 0 {
            count = count.min(caps.max_image_count);
        }
        let info = vk::SwapchainCreateInfoKHR::default()
            .surface(host.surface())
            .min_image_count(count)
            .image_format(format)
            .image_color_space(vk::ColorSpaceKHR::SRGB_NONLINEAR)
            .image_extent(extent)
            .image_array_layers(1)
            .image_usage(vk::ImageUsageFlags::COLOR_ATTACHMENT)
            .image_sharing_mode(vk::SharingMode::EXCLUSIVE)
            .pre_transform(caps.current_transform)
            .composite_alpha(vk::CompositeAlphaFlagsKHR::OPAQUE)
            .present_mode(present_mode)
            .clipped(true)
            .old_swapchain(old.map_or(vk::SwapchainKHR::null(), |o| o.raw));
        // SAFETY: valid create info; `old` (if any) is not used after this (the caller destroys it).
        let raw = unsafe { host.swapchain_loader.create_swapchain(&info, None) }
            .context("vkCreateSwapchainKHR")?;
        let mut swapchain = Swapchain {
            raw,
            format,
            encode_srgb,
            extent,
            images: Vec::new(),
            views: Vec::new(),
            rendered: Vec::new(),
        };
        // SAFETY: `raw` was just created.
        swapchain.images = unsafe { host.swapchain_loader.get_swapchain_images(raw) }
            .context("vkGetSwapchainImagesKHR")?;
        for &image in &swapchain.images.clone() {
            let view_info = vk::ImageViewCreateInfo::default()
                .image(image)
                .view_type(vk::ImageViewType::TYPE_2D)
                .format(format)
                .subresource_range(
                    vk::ImageSubresourceRange::default()
                        .aspect_mask(vk::ImageAspectFlags::COLOR)
                        .level_count(1)
                        .layer_count(1),
                );
            // SAFETY: a swapchain image of this device.
            let view = unsafe { host.device.create_image_view(&view_info, None) };
            let view = match view {
                Ok(v) => v,
                Err(e) => {
                    swapchain.destroy(host);
                    return Err(e).context("vkCreateImageView (swapchain)");
                }
            };
            swapchain.views.push(view);
            // SAFETY: live device.
            let semaphore = unsafe {
                host.device
                    .create_semaphore(&vk::SemaphoreCreateInfo::default(), None)
            };
            match semaphore {
                Ok(s) => swapchain.rendered.push(s),
                Err(e) => {
                    swapchain.destroy(host);
                    return Err(e).context("vkCreateSemaphore");
                }
            }
        }
        Ok(Some(swapchain))
    }

    /// Destroys the views, semaphores and the swapchain.
    ///
    /// The GPU must be done with them (the viewer waits for the device to be idle first).
    pub fn destroy(&self, host: &Host) {
        // SAFETY: the caller's contract: no pending work uses these objects.
        unsafe {
            for &v in &self.views {
                host.device.destroy_image_view(v, None);
            }
            for &s in &self.rendered {
                host.device.destroy_semaphore(s, None);
            }
            host.swapchain_loader.destroy_swapchain(self.raw, None);
        }
    }
}
