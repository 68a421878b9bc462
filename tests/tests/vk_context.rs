//! Context creation: the device, features and validation; typed errors; a host's objects are
//! never destroyed by us.

use ash::vk;
use translucent::vk::{Buffer, BufferDesc, Context, ContextDesc, MemoryUse, VkError};
use translucent_tests::GpuTest;

#[test]
fn headless_context_reports_the_device_features_and_validation() {
    let gpu = GpuTest::new();
    let info = gpu.ctx.info();
    let wanted = std::env::var("TRANSLUCENT_DEVICE").unwrap_or_else(|_| "llvmpipe".into());
    assert!(
        info.device_name
            .to_lowercase()
            .contains(&wanted.to_lowercase()),
        "{info:?}"
    );
    assert!(info.validation);
    assert_eq!(
        info.features,
        [
            "Vulkan 1.3",
            "synchronization2",
            "dynamicRendering",
            "maintenance4"
        ]
    );
    assert!(
        info.api_version.starts_with("1.3") || info.api_version.starts_with("1.4"),
        "{info:?}"
    );
    gpu.finish();
}

#[test]
fn an_unknown_device_name_is_a_typed_error_naming_what_to_install() {
    let desc = ContextDesc {
        validation: false,
        device_name: Some("no such gpu 9000".into()),
        ..ContextDesc::default()
    };
    match Context::headless(&desc) {
        Err(e @ VkError::NoDevice { .. }) => {
            let text = e.to_string();
            assert!(
                text.contains("no such gpu 9000") && text.contains("mesa-vulkan-drivers"),
                "{text}"
            );
        }
        Err(e) => panic!("wrong error: {e}"),
        Ok(_) => panic!("found a device named 'no such gpu 9000'"),
    }
}

#[test]
fn submit_is_refused_on_a_host_context_and_host_objects_survive_it() {
    // SAFETY: loading the system loader.
    let entry = unsafe { ash::Entry::load() }.expect("Vulkan loader");
    let app = vk::ApplicationInfo::default().api_version(vk::API_VERSION_1_3);
    // SAFETY: plain instance creation, destroyed below.
    let instance = unsafe {
        entry.create_instance(
            &vk::InstanceCreateInfo::default().application_info(&app),
            None,
        )
    }
    .expect("instance");
    // SAFETY: live instance.
    let physical = unsafe { instance.enumerate_physical_devices() }
        .expect("devices")
        .into_iter()
        .find(|&p| {
            // SAFETY: enumerated from `instance`.
            let props = unsafe { instance.get_physical_device_properties(p) };
            props
                .device_name_as_c_str()
                .is_ok_and(|n| n.to_string_lossy().contains("llvmpipe"))
        })
        .expect("llvmpipe; install mesa-vulkan-drivers");
    let priorities = [1.0];
    let queues = [vk::DeviceQueueCreateInfo::default()
        .queue_family_index(0)
        .queue_priorities(&priorities)];
    let mut f13 = vk::PhysicalDeviceVulkan13Features::default()
        .synchronization2(true)
        .dynamic_rendering(true)
        .maintenance4(true);
    let info = vk::DeviceCreateInfo::default()
        .queue_create_infos(&queues)
        .push_next(&mut f13);
    // SAFETY: llvmpipe's family 0 does graphics and compute.
    let device = unsafe { instance.create_device(physical, &info, None) }.expect("device");

    // SAFETY: the handles are valid and outlive the context (dropped below, before destruction).
    let ctx = unsafe {
        Context::from_host(
            entry.clone(),
            instance.clone(),
            physical,
            device.clone(),
            0,
            0,
            3,
        )
    }
    .expect("host context");
    assert_eq!(ctx.frames_in_flight(), 3);
    assert!(matches!(
        ctx.execute("x", |_| Ok(())),
        Err(VkError::HostOwnsQueue { .. })
    ));
    ctx.begin_frame(1);
    let buffer = Buffer::new(
        &ctx,
        &BufferDesc {
            name: "host",
            size: 256,
            usage: vk::BufferUsageFlags::TRANSFER_DST,
            memory: MemoryUse::Upload,
        },
    )
    .expect("buffer");
    drop(buffer);
    assert_eq!(ctx.pending_releases(), 1);
    ctx.frame_completed(1);
    assert_eq!(ctx.live_allocations(), 0);
    drop(ctx);

    // The host's device is still alive and usable after our context is gone.
    // SAFETY: `device` is live (we never destroyed it); created and destroyed here.
    unsafe {
        let b = device
            .create_buffer(
                &vk::BufferCreateInfo::default()
                    .size(16)
                    .usage(vk::BufferUsageFlags::TRANSFER_DST),
                None,
            )
            .expect("host device still works");
        device.destroy_buffer(b, None);
        device.destroy_device(None);
        instance.destroy_instance(None);
    }
}
