//! A host render graph embedding a translucent object (DESIGN section 7), headless:
//!
//! ```text
//! cargo run --release --example host_graph [OUT.png]          # default target/host_graph.png
//! TRANSLUCENT_VALIDATION=1 cargo run --release --example host_graph   # exits 1 on any message
//! ```
//!
//! The host creates its OWN instance and device with ash (validation and synchronization
//! validation on request), wraps them with `Context::from_host`, and runs a render graph of its
//! own with two frames in flight, each frame in one command buffer it begins, submits and fences
//! itself:
//! 1. background pass (dynamic rendering): a sky-coloured clear, a floor band and a pillar that is
//!    nearer than the object (cleared into the depth buffer, so the object is hidden behind it);
//! 2. our object's `record`: it loads the colour, depth-tests against the host's depth and hands
//!    the colour back in GENERAL for compute (the states are the host's choice);
//! 3. post pass (compute): exposure, tone map and sRGB into an 8-bit image, copied to a buffer.
//!
//! The light moves every frame (`set_lights`: a warm-started solve); the last frame is written
//! as PNG. The library never submits, waits, begins or ends these command buffers and never
//! destroys the host's objects; setup uploads run on the queue the host lends for setup.

use std::ffi::c_void;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::Arc;

use ash::vk;
use glam::DVec3;
use translucent::material::{Material, MaterialField};
use translucent::mesh::shapes::Shape;
use translucent::object::{RecordCtx, TargetImage, Targets};
use translucent::quadgraph::BakeParams;
use translucent::scene::{Environment, Light, Scene};
use translucent::vk::ImageState;
use translucent::vk::{Access, Context};
use translucent::{ObjectParams, QuadGraph, TranslucentObject};

const WIDTH: u32 = 160;
const HEIGHT: u32 = 120;
const FRAMES: u64 = 6;
const IN_FLIGHT: usize = 2;
const HDR_FORMAT: vk::Format = vk::Format::R16G16B16A16_SFLOAT;
const DEPTH_FORMAT: vk::Format = vk::Format::D32_SFLOAT;
const LDR_FORMAT: vk::Format = vk::Format::R8G8B8A8_UNORM;
/// Background colours (linear) of the host's own pass.
const SKY: [f32; 4] = [0.05, 0.08, 0.15, 1.0];
const FLOOR: [f32; 4] = [0.12, 0.10, 0.08, 1.0];
const PILLAR: [f32; 4] = [0.02, 0.02, 0.02, 1.0];

type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

/// Validation messages seen by the host's messenger.
static MESSAGES: AtomicU32 = AtomicU32::new(0);

unsafe extern "system" fn on_message(
    _severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _kind: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    _user: *mut c_void,
) -> vk::Bool32 {
    MESSAGES.fetch_add(1, Ordering::SeqCst);
    // SAFETY: the layer passes a valid callback data struct whose message is NUL-terminated.
    let text = unsafe { data.as_ref().and_then(|d| d.message_as_c_str()) };
    eprintln!(
        "validation: {}",
        text.map_or("?".into(), |t| t.to_string_lossy())
    );
    vk::FALSE
}

/// What one run produced.
#[derive(Debug)]
pub struct Outcome {
    pub messages: u32,
    /// Pixels of the last frame that differ from every background colour.
    pub object_pixels: usize,
    /// Iterations of each frame's solve (per level), by frame.
    pub iterations: Vec<(u64, Vec<u32>)>,
}

/// A host image with its memory and view.
struct HostImage {
    image: vk::Image,
    memory: vk::DeviceMemory,
    view: vk::ImageView,
}

fn memory_type(
    props: &vk::PhysicalDeviceMemoryProperties,
    bits: u32,
    flags: vk::MemoryPropertyFlags,
) -> Result<u32> {
    (0..props.memory_type_count)
        .find(|&i| {
            bits & (1 << i) != 0
                && props.memory_types[i as usize]
                    .property_flags
                    .contains(flags)
        })
        .ok_or_else(|| "no suitable memory type".into())
}

/// # Safety
/// `device` is live; the image is destroyed by the caller.
unsafe fn host_image(
    device: &ash::Device,
    props: &vk::PhysicalDeviceMemoryProperties,
    format: vk::Format,
    usage: vk::ImageUsageFlags,
    aspect: vk::ImageAspectFlags,
) -> Result<HostImage> {
    let info = vk::ImageCreateInfo::default()
        .image_type(vk::ImageType::TYPE_2D)
        .format(format)
        .extent(vk::Extent3D {
            width: WIDTH,
            height: HEIGHT,
            depth: 1,
        })
        .mip_levels(1)
        .array_layers(1)
        .samples(vk::SampleCountFlags::TYPE_1)
        .tiling(vk::ImageTiling::OPTIMAL)
        .usage(usage);
    // SAFETY: the caller's contract; each created object is returned to the caller.
    unsafe {
        let image = device.create_image(&info, None)?;
        let req = device.get_image_memory_requirements(image);
        let memory = device.allocate_memory(
            &vk::MemoryAllocateInfo::default()
                .allocation_size(req.size)
                .memory_type_index(memory_type(
                    props,
                    req.memory_type_bits,
                    vk::MemoryPropertyFlags::DEVICE_LOCAL,
                )?),
            None,
        )?;
        device.bind_image_memory(image, memory, 0)?;
        let view = device.create_image_view(
            &vk::ImageViewCreateInfo::default()
                .image(image)
                .view_type(vk::ImageViewType::TYPE_2D)
                .format(format)
                .subresource_range(range(aspect)),
            None,
        )?;
        Ok(HostImage {
            image,
            memory,
            view,
        })
    }
}

fn range(aspect: vk::ImageAspectFlags) -> vk::ImageSubresourceRange {
    vk::ImageSubresourceRange {
        aspect_mask: aspect,
        base_mip_level: 0,
        level_count: 1,
        base_array_layer: 0,
        layer_count: 1,
    }
}

#[allow(clippy::too_many_arguments)]
fn image_barrier(
    image: vk::Image,
    aspect: vk::ImageAspectFlags,
    src: (vk::PipelineStageFlags2, vk::AccessFlags2),
    dst: (vk::PipelineStageFlags2, vk::AccessFlags2),
    old: vk::ImageLayout,
    new: vk::ImageLayout,
) -> vk::ImageMemoryBarrier2<'static> {
    vk::ImageMemoryBarrier2::default()
        .src_stage_mask(src.0)
        .src_access_mask(src.1)
        .dst_stage_mask(dst.0)
        .dst_access_mask(dst.1)
        .old_layout(old)
        .new_layout(new)
        .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .image(image)
        .subresource_range(range(aspect))
}

/// The light of frame `i`: a directional light circling the object, 12 degrees a frame.
fn scene_at(i: u64) -> Scene {
    let a = (12.0 * i as f64).to_radians();
    Scene {
        lights: vec![Light::Directional {
            direction: DVec3::new(a.sin(), -0.8, -a.cos()).normalize(),
            irradiance: [3.0; 3],
        }],
        environment: Environment::Constant([0.02, 0.02, 0.03]),
    }
}

/// Runs the host: `FRAMES` frames, the last written to `out` as PNG.
pub fn run(out: &Path, validation: bool) -> Result<Outcome> {
    MESSAGES.store(0, Ordering::SeqCst);
    // SAFETY: loading the system's Vulkan loader.
    let entry = unsafe { ash::Entry::load()? };
    let app = vk::ApplicationInfo::default().api_version(vk::API_VERSION_1_3);
    // debug_utils: the library labels its passes (required of a host context).
    let mut extensions = vec![ash::ext::debug_utils::NAME.as_ptr()];
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
    // SAFETY: every pointer in `info` refers to locals alive across the call.
    let instance = unsafe { entry.create_instance(&info, None)? };
    let utils = ash::ext::debug_utils::Instance::new(&entry, &instance);
    let messenger = if validation {
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
        // SAFETY: live instance; destroyed below.
        Some(unsafe { utils.create_debug_utils_messenger(&info, None)? })
    } else {
        None
    };

    // The device: TRANSLUCENT_DEVICE picks by name, else the first with a graphics+compute queue.
    let wanted = std::env::var("TRANSLUCENT_DEVICE")
        .unwrap_or_default()
        .to_lowercase();
    // SAFETY: live instance.
    let physicals = unsafe { instance.enumerate_physical_devices()? };
    let (physical, family) = physicals
        .iter()
        .find_map(|&p| {
            // SAFETY: `p` was enumerated from `instance`.
            let props = unsafe { instance.get_physical_device_properties(p) };
            let name = props
                .device_name_as_c_str()
                .map(|n| n.to_string_lossy().to_lowercase())
                .unwrap_or_default();
            if props.api_version < vk::API_VERSION_1_3 || !name.contains(&wanted) {
                return None;
            }
            // SAFETY: as above.
            let families = unsafe { instance.get_physical_device_queue_family_properties(p) };
            let needed = vk::QueueFlags::GRAPHICS | vk::QueueFlags::COMPUTE;
            families
                .iter()
                .position(|f| f.queue_flags.contains(needed))
                .map(|f| (p, f as u32))
        })
        .ok_or("no Vulkan 1.3 device with a graphics+compute queue")?;
    let priorities = [1.0];
    let queues = [vk::DeviceQueueCreateInfo::default()
        .queue_family_index(family)
        .queue_priorities(&priorities)];
    let mut f13 = vk::PhysicalDeviceVulkan13Features::default()
        .synchronization2(true)
        .dynamic_rendering(true)
        .maintenance4(true);
    let info = vk::DeviceCreateInfo::default()
        .queue_create_infos(&queues)
        .push_next(&mut f13);
    // SAFETY: `physical` belongs to `instance`; the library checks the features in from_host.
    let device = unsafe { instance.create_device(physical, &info, None)? };
    // SAFETY: created just above with this family.
    let queue = unsafe { device.get_device_queue(family, 0) };
    // SAFETY: live instance.
    let memory = unsafe { instance.get_physical_device_memory_properties(physical) };

    // SAFETY: the handles are valid and outlive the context (dropped before they are destroyed).
    let mut ctx = unsafe {
        Context::from_host(
            entry.clone(),
            instance.clone(),
            physical,
            device.clone(),
            family,
            0,
            IN_FLIGHT as u32,
        )?
    };
    // SAFETY: this host is single-threaded: nothing else uses the queue during setup calls.
    unsafe { ctx.lend_queue_for_setup()? };

    let torus = Shape::Torus {
        major: 10.0,
        minor: 4.5,
    };
    let bake = BakeParams {
        resolution: 20,
        levels: 2,
        ..Default::default()
    };
    let graph = Arc::new(QuadGraph::bake(&torus.triangulate(64), &torus, &bake, &mut |_| {})?.0);
    let field = MaterialField::Homogeneous(Material::preset("marble")?);
    let cascade = translucent::defaults::Settings {
        schedule: translucent::defaults::Schedule::Cascade,
        ..translucent::defaults::Settings::realtime(true)
    };
    let mut object = TranslucentObject::new(
        &ctx,
        graph,
        &field,
        &scene_at(0),
        &ObjectParams {
            color_format: HDR_FORMAT,
            depth_format: DEPTH_FORMAT,
            // The paper's cascade, not the library's multigrid default: this example shows the
            // per-level warm start (every level resumes from its last solution), which the frame
            // reports per level (`CompletedSolve::iterations`; a multigrid solve reports 0 there).
            ..cascade.object_params()
        },
    )?;

    // SAFETY: every object below is created from `device` and destroyed at the end of `run`.
    let outcome = unsafe {
        let hdr = host_image(
            &device,
            &memory,
            HDR_FORMAT,
            vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::STORAGE,
            vk::ImageAspectFlags::COLOR,
        )?;
        let depth = host_image(
            &device,
            &memory,
            DEPTH_FORMAT,
            vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT,
            vk::ImageAspectFlags::DEPTH,
        )?;
        let ldr = host_image(
            &device,
            &memory,
            LDR_FORMAT,
            vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_SRC,
            vk::ImageAspectFlags::COLOR,
        )?;
        let bytes = u64::from(WIDTH * HEIGHT * 4);
        let readback = device.create_buffer(
            &vk::BufferCreateInfo::default()
                .size(bytes)
                .usage(vk::BufferUsageFlags::TRANSFER_DST),
            None,
        )?;
        let req = device.get_buffer_memory_requirements(readback);
        let readback_memory = device.allocate_memory(
            &vk::MemoryAllocateInfo::default()
                .allocation_size(req.size)
                .memory_type_index(memory_type(
                    &memory,
                    req.memory_type_bits,
                    vk::MemoryPropertyFlags::HOST_VISIBLE | vk::MemoryPropertyFlags::HOST_COHERENT,
                )?),
            None,
        )?;
        device.bind_buffer_memory(readback, readback_memory, 0)?;

        // The post pass: one compute pipeline, one descriptor set (never rewritten).
        let bindings = [0, 1].map(|b| {
            vk::DescriptorSetLayoutBinding::default()
                .binding(b)
                .descriptor_type(vk::DescriptorType::STORAGE_IMAGE)
                .descriptor_count(1)
                .stage_flags(vk::ShaderStageFlags::COMPUTE)
        });
        let set_layout = device.create_descriptor_set_layout(
            &vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings),
            None,
        )?;
        let push_range = [vk::PushConstantRange::default()
            .stage_flags(vk::ShaderStageFlags::COMPUTE)
            .size(16)];
        let set_layouts = [set_layout];
        let layout = device.create_pipeline_layout(
            &vk::PipelineLayoutCreateInfo::default()
                .set_layouts(&set_layouts)
                .push_constant_ranges(&push_range),
            None,
        )?;
        let spirv = translucent::shader::embedded("host_example/tone_map.comp")?;
        let module = device.create_shader_module(
            &vk::ShaderModuleCreateInfo::default().code(&spirv.words),
            None,
        )?;
        let stage = vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::COMPUTE)
            .module(module)
            .name(c"main");
        let pipeline = device
            .create_compute_pipelines(
                vk::PipelineCache::null(),
                &[vk::ComputePipelineCreateInfo::default()
                    .stage(stage)
                    .layout(layout)],
                None,
            )
            .map_err(|(_, e)| e)?[0];
        let pool_sizes = [vk::DescriptorPoolSize {
            ty: vk::DescriptorType::STORAGE_IMAGE,
            descriptor_count: 2,
        }];
        let descriptor_pool = device.create_descriptor_pool(
            &vk::DescriptorPoolCreateInfo::default()
                .max_sets(1)
                .pool_sizes(&pool_sizes),
            None,
        )?;
        let set = device.allocate_descriptor_sets(
            &vk::DescriptorSetAllocateInfo::default()
                .descriptor_pool(descriptor_pool)
                .set_layouts(&set_layouts),
        )?[0];
        let hdr_info = [vk::DescriptorImageInfo::default()
            .image_view(hdr.view)
            .image_layout(vk::ImageLayout::GENERAL)];
        let ldr_info = [vk::DescriptorImageInfo::default()
            .image_view(ldr.view)
            .image_layout(vk::ImageLayout::GENERAL)];
        device.update_descriptor_sets(
            &[
                vk::WriteDescriptorSet::default()
                    .dst_set(set)
                    .dst_binding(0)
                    .descriptor_type(vk::DescriptorType::STORAGE_IMAGE)
                    .image_info(&hdr_info),
                vk::WriteDescriptorSet::default()
                    .dst_set(set)
                    .dst_binding(1)
                    .descriptor_type(vk::DescriptorType::STORAGE_IMAGE)
                    .image_info(&ldr_info),
            ],
            &[],
        );

        // Frames in flight: a command buffer and a fence each.
        let command_pool = device.create_command_pool(
            &vk::CommandPoolCreateInfo::default()
                .queue_family_index(family)
                .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER),
            None,
        )?;
        let cbs = device.allocate_command_buffers(
            &vk::CommandBufferAllocateInfo::default()
                .command_pool(command_pool)
                .command_buffer_count(IN_FLIGHT as u32),
        )?;
        let mut fences = Vec::new();
        for _ in 0..IN_FLIGHT {
            fences.push(device.create_fence(
                &vk::FenceCreateInfo::default().flags(vk::FenceCreateFlags::SIGNALED),
                None,
            )?);
        }

        use vk::AccessFlags2 as A;
        use vk::PipelineStageFlags2 as S;
        let color_aspect = vk::ImageAspectFlags::COLOR;
        let depth_aspect = vk::ImageAspectFlags::DEPTH;
        let mut completed = 0u64;
        let mut iterations = Vec::new();
        let mut failure = None;
        for frame in 1..=FRAMES {
            let slot = (frame as usize - 1) % IN_FLIGHT;
            device.wait_for_fences(&[fences[slot]], true, u64::MAX)?;
            // The fence of frame - IN_FLIGHT signalled: that frame (and every earlier) is done.
            completed = completed.max(frame.saturating_sub(IN_FLIGHT as u64));
            device.reset_fences(&[fences[slot]])?;
            let cb = cbs[slot];
            device.reset_command_buffer(cb, vk::CommandBufferResetFlags::empty())?;
            device.begin_command_buffer(
                cb,
                &vk::CommandBufferBeginInfo::default()
                    .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
            )?;

            // 1. Background.
            let to_attachments = [
                // why: the last frame's post pass read the HDR image (WAR); cleared, so its
                // contents may go.
                image_barrier(
                    hdr.image,
                    color_aspect,
                    (S::COMPUTE_SHADER, A::NONE),
                    (
                        S::COLOR_ATTACHMENT_OUTPUT,
                        A::COLOR_ATTACHMENT_WRITE | A::COLOR_ATTACHMENT_READ,
                    ),
                    vk::ImageLayout::UNDEFINED,
                    vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
                ),
                // why: the last frame's depth tests (WAW); cleared.
                image_barrier(
                    depth.image,
                    depth_aspect,
                    (
                        S::EARLY_FRAGMENT_TESTS | S::LATE_FRAGMENT_TESTS,
                        A::DEPTH_STENCIL_ATTACHMENT_WRITE,
                    ),
                    (
                        S::EARLY_FRAGMENT_TESTS | S::LATE_FRAGMENT_TESTS,
                        A::DEPTH_STENCIL_ATTACHMENT_READ | A::DEPTH_STENCIL_ATTACHMENT_WRITE,
                    ),
                    vk::ImageLayout::UNDEFINED,
                    vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL,
                ),
            ];
            device.cmd_pipeline_barrier2(
                cb,
                &vk::DependencyInfo::default().image_memory_barriers(&to_attachments),
            );
            let color_attachment = [vk::RenderingAttachmentInfo::default()
                .image_view(hdr.view)
                .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
                .load_op(vk::AttachmentLoadOp::CLEAR)
                .store_op(vk::AttachmentStoreOp::STORE)
                .clear_value(vk::ClearValue {
                    color: vk::ClearColorValue { float32: SKY },
                })];
            let depth_attachment = vk::RenderingAttachmentInfo::default()
                .image_view(depth.view)
                .image_layout(vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL)
                .load_op(vk::AttachmentLoadOp::CLEAR)
                .store_op(vk::AttachmentStoreOp::STORE)
                .clear_value(vk::ClearValue {
                    depth_stencil: vk::ClearDepthStencilValue {
                        depth: 1.0,
                        stencil: 0,
                    },
                });
            let full = vk::Rect2D {
                offset: vk::Offset2D::default(),
                extent: vk::Extent2D {
                    width: WIDTH,
                    height: HEIGHT,
                },
            };
            device.cmd_begin_rendering(
                cb,
                &vk::RenderingInfo::default()
                    .render_area(full)
                    .layer_count(1)
                    .color_attachments(&color_attachment)
                    .depth_attachment(&depth_attachment),
            );
            let rect = |x: u32, y: u32, w: u32, h: u32| vk::ClearRect {
                rect: vk::Rect2D {
                    offset: vk::Offset2D {
                        x: x as i32,
                        y: y as i32,
                    },
                    extent: vk::Extent2D {
                        width: w,
                        height: h,
                    },
                },
                base_array_layer: 0,
                layer_count: 1,
            };
            device.cmd_clear_attachments(
                cb,
                &[vk::ClearAttachment {
                    aspect_mask: color_aspect,
                    color_attachment: 0,
                    clear_value: vk::ClearValue {
                        color: vk::ClearColorValue { float32: FLOOR },
                    },
                }],
                &[rect(0, HEIGHT * 3 / 4, WIDTH, HEIGHT / 4)],
            );
            // A pillar in front of the object: colour and the nearest depth.
            let pillar = [rect(WIDTH / 4, 0, WIDTH / 12, HEIGHT)];
            device.cmd_clear_attachments(
                cb,
                &[
                    vk::ClearAttachment {
                        aspect_mask: color_aspect,
                        color_attachment: 0,
                        clear_value: vk::ClearValue {
                            color: vk::ClearColorValue { float32: PILLAR },
                        },
                    },
                    vk::ClearAttachment {
                        aspect_mask: depth_aspect,
                        color_attachment: 0,
                        clear_value: vk::ClearValue {
                            depth_stencil: vk::ClearDepthStencilValue {
                                depth: 0.0,
                                stencil: 0,
                            },
                        },
                    },
                ],
                &pillar,
            );
            device.cmd_end_rendering(cb);

            // 2. The translucent object, between the host's passes.
            if frame > 1 {
                object.set_lights(&scene_at(frame - 1))?;
            }
            let general_for_compute = ImageState {
                stage: S::COMPUTE_SHADER,
                access: A::SHADER_STORAGE_READ,
                layout: vk::ImageLayout::GENERAL,
            };
            let targets = Targets {
                color: TargetImage {
                    image: hdr.image,
                    view: hdr.view,
                    format: HDR_FORMAT,
                    extent: full.extent,
                    before: Access::ColorAttachmentWrite.into(),
                    after: general_for_compute,
                },
                depth: Some(TargetImage {
                    image: depth.image,
                    view: depth.view,
                    format: DEPTH_FORMAT,
                    extent: full.extent,
                    before: Access::DepthAttachmentWrite.into(),
                    after: Access::DepthAttachmentWrite.into(),
                }),
                host_barriers: false,
            };
            let report = object.record(
                &mut RecordCtx {
                    ctx: &ctx,
                    cb,
                    frame,
                    completed_frame: completed,
                    profiler: None,
                },
                &targets,
            );
            match report {
                Ok(r) => iterations.extend(r.completed.iter().map(|s| (s.frame, s.iterations()))),
                Err(e) => {
                    // The command buffer is ended and submitted empty-handed: never left recording.
                    failure = Some(e);
                }
            }

            // 3. Post: tone map into the 8-bit image and copy it out.
            let ldr_to_general = [
                // why: the last frame's copy read the LDR image (WAR); fully overwritten.
                image_barrier(
                    ldr.image,
                    color_aspect,
                    (S::COPY, A::NONE),
                    (S::COMPUTE_SHADER, A::SHADER_STORAGE_WRITE),
                    vk::ImageLayout::UNDEFINED,
                    vk::ImageLayout::GENERAL,
                ),
            ];
            device.cmd_pipeline_barrier2(
                cb,
                &vk::DependencyInfo::default().image_memory_barriers(&ldr_to_general),
            );
            device.cmd_bind_pipeline(cb, vk::PipelineBindPoint::COMPUTE, pipeline);
            device.cmd_bind_descriptor_sets(
                cb,
                vk::PipelineBindPoint::COMPUTE,
                layout,
                0,
                &[set],
                &[],
            );
            let mut push = [0u8; 16];
            push[0..4].copy_from_slice(&(WIDTH as i32).to_le_bytes());
            push[4..8].copy_from_slice(&(HEIGHT as i32).to_le_bytes());
            push[8..12].copy_from_slice(&1.5f32.to_le_bytes());
            device.cmd_push_constants(cb, layout, vk::ShaderStageFlags::COMPUTE, 0, &push[..12]);
            device.cmd_dispatch(cb, WIDTH.div_ceil(8), HEIGHT.div_ceil(8), 1);
            let ldr_to_copy = [
                // why: the copy reads the tone-mapped texels (RAW), in TRANSFER_SRC layout.
                image_barrier(
                    ldr.image,
                    color_aspect,
                    (S::COMPUTE_SHADER, A::SHADER_STORAGE_WRITE),
                    (S::COPY, A::TRANSFER_READ),
                    vk::ImageLayout::GENERAL,
                    vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                ),
            ];
            // why: the last frame's host read of the buffer happened after its fence; the
            // copy below only needs the image barrier, plus this for the buffer (WAW order).
            let buffer_waw = [vk::MemoryBarrier2::default()
                .src_stage_mask(S::COPY)
                .src_access_mask(A::TRANSFER_WRITE)
                .dst_stage_mask(S::COPY)
                .dst_access_mask(A::TRANSFER_WRITE)];
            device.cmd_pipeline_barrier2(
                cb,
                &vk::DependencyInfo::default()
                    .memory_barriers(&buffer_waw)
                    .image_memory_barriers(&ldr_to_copy),
            );
            device.cmd_copy_image_to_buffer(
                cb,
                ldr.image,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                readback,
                &[vk::BufferImageCopy::default()
                    .image_subresource(
                        vk::ImageSubresourceLayers::default()
                            .aspect_mask(color_aspect)
                            .layer_count(1),
                    )
                    .image_extent(vk::Extent3D {
                        width: WIDTH,
                        height: HEIGHT,
                        depth: 1,
                    })],
            );
            // why: the CPU reads the buffer after the fence (host visibility of the copy).
            let to_host = [vk::MemoryBarrier2::default()
                .src_stage_mask(S::COPY)
                .src_access_mask(A::TRANSFER_WRITE)
                .dst_stage_mask(S::HOST)
                .dst_access_mask(A::HOST_READ)];
            device.cmd_pipeline_barrier2(
                cb,
                &vk::DependencyInfo::default().memory_barriers(&to_host),
            );
            device.end_command_buffer(cb)?;
            let cb_info = [vk::CommandBufferSubmitInfo::default().command_buffer(cb)];
            device.queue_submit2(
                queue,
                &[vk::SubmitInfo2::default().command_buffer_infos(&cb_info)],
                fences[slot],
            )?;
            if failure.is_some() {
                break;
            }
        }
        device.wait_for_fences(&fences, true, u64::MAX)?;
        completed = FRAMES;
        ctx.frame_completed(completed);
        iterations.extend(
            object
                .completed_solves(completed)?
                .iter()
                .map(|s| (s.frame, s.iterations())),
        );

        // The last frame, as the host's post pass wrote it.
        let mapped = device.map_memory(readback_memory, 0, bytes, vk::MemoryMapFlags::empty())?;
        let rgba = std::slice::from_raw_parts(mapped as *const u8, bytes as usize).to_vec();
        device.unmap_memory(readback_memory);
        let encode = |c: [f32; 4]| -> [u8; 3] {
            std::array::from_fn(|i| {
                let v = c[i] * 1.5;
                let t = v / (1.0 + v);
                let s = if t <= 0.003_130_8 {
                    12.92 * t
                } else {
                    1.055 * t.powf(1.0 / 2.4) - 0.055
                };
                (s * 255.0).round() as u8
            })
        };
        let background = [SKY, FLOOR, PILLAR].map(encode);
        let object_pixels = rgba
            .chunks_exact(4)
            .filter(|p| {
                background
                    .iter()
                    .all(|b| (0..3).any(|i| p[i].abs_diff(b[i]) > 2))
            })
            .count();

        for f in fences {
            device.destroy_fence(f, None);
        }
        device.destroy_command_pool(command_pool, None);
        device.destroy_descriptor_pool(descriptor_pool, None);
        device.destroy_pipeline(pipeline, None);
        device.destroy_shader_module(module, None);
        device.destroy_pipeline_layout(layout, None);
        device.destroy_descriptor_set_layout(set_layout, None);
        device.destroy_buffer(readback, None);
        device.free_memory(readback_memory, None);
        for img in [hdr, depth, ldr] {
            device.destroy_image_view(img.view, None);
            device.destroy_image(img.image, None);
            device.free_memory(img.memory, None);
        }
        if let Some(e) = failure {
            return Err(e.into());
        }
        let png = image::RgbaImage::from_raw(WIDTH, HEIGHT, rgba).ok_or("readback size")?;
        translucent::vk::capture::write_atomically(out, |tmp| {
            png.save_with_format(tmp, image::ImageFormat::Png)
                .map_err(|e| e.to_string())
        })?;
        Outcome {
            messages: 0,
            object_pixels,
            iterations,
        }
    };

    // Ours first (they may release into the host's device), then the host's own objects.
    drop(object);
    drop(ctx);
    // SAFETY: every child object was destroyed above; the GPU is idle (all fences waited).
    unsafe {
        device.destroy_device(None);
        if let Some(m) = messenger {
            utils.destroy_debug_utils_messenger(m, None);
        }
        instance.destroy_instance(None);
    }
    Ok(Outcome {
        messages: MESSAGES.load(Ordering::SeqCst),
        ..outcome
    })
}

#[allow(dead_code, reason = "a test includes this file for `run` only")]
fn main() {
    let out = std::env::args_os().nth(1).map_or_else(
        || PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../target/host_graph.png"),
        PathBuf::from,
    );
    let validation = std::env::var("TRANSLUCENT_VALIDATION").is_ok_and(|v| v == "1");
    match run(&out, validation) {
        Ok(o) if o.messages == 0 => {
            println!(
                "wrote {} ({} object pixels); iterations per solve: {:?}",
                out.display(),
                o.object_pixels,
                o.iterations
            );
        }
        Ok(o) => {
            eprintln!("{} validation message(s)", o.messages);
            std::process::exit(1);
        }
        Err(e) => {
            eprintln!("host_graph: {e}");
            std::process::exit(2);
        }
    }
}
