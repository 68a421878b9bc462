//! The device every resource holds an `Arc` of: raw handles, the allocator, the deferred release
//! queue and the frame counters.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};

use ash::vk;
use gpu_allocator::vulkan::{Allocation, Allocator};

use super::context::{HostVulkan, ValidationMessage};
use super::VkError;

/// Instance and device we created: destroyed when the last resource is gone.
pub(crate) struct OwnedVulkan {
    #[allow(
        dead_code,
        reason = "keeps the Vulkan loader library loaded until the instance is destroyed"
    )]
    pub entry: ash::Entry,
    pub instance: ash::Instance,
    pub device: ash::Device,
    pub messenger: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
}

/// Who owns the raw instance and device. The host's are a separate type with no destroy path.
pub(crate) enum Handles {
    Owned(OwnedVulkan),
    Host(HostVulkan),
}

impl Handles {
    pub fn device(&self) -> &ash::Device {
        match self {
            Handles::Owned(o) => &o.device,
            Handles::Host(h) => h.device(),
        }
    }
    pub fn instance(&self) -> &ash::Instance {
        match self {
            Handles::Owned(o) => &o.instance,
            Handles::Host(h) => h.instance(),
        }
    }
}

/// Something the GPU may still use, destroyed once its frame completed.
pub(crate) enum Retired {
    Buffer(vk::Buffer, Allocation),
    Image(vk::Image, vk::ImageView, Allocation),
    Pipeline(vk::Pipeline),
    PipelineLayout(vk::PipelineLayout),
    DescriptorSetLayout(vk::DescriptorSetLayout),
    DescriptorPool(vk::DescriptorPool),
    QueryPool(vk::QueryPool),
    Sampler(vk::Sampler),
    BufferView(vk::BufferView),
}

#[derive(Default)]
pub(crate) struct Frames {
    /// The frame being recorded (or the last one submitted).
    pub current: u64,
    /// The last frame the GPU has finished.
    pub completed: u64,
    /// (frame that last could use it, object), in retirement order.
    pub pending: Vec<(u64, Retired)>,
}

pub(crate) struct Device {
    pub handles: Handles,
    pub physical: vk::PhysicalDevice,
    pub queue_family: u32,
    pub queue: vk::Queue,
    pub properties: vk::PhysicalDeviceProperties,
    pub debug_utils: Option<ash::ext::debug_utils::Device>,
    /// `None` only during drop: the allocator goes before the device.
    pub allocator: Mutex<Option<Allocator>>,
    /// Bytes the live allocations asked for (their memory requirements' sizes), without the
    /// alignment padding the allocator adds in front of each one: that padding depends on where
    /// the allocation lands in a block, and gpu-allocator's free list is a `HashSet` (random
    /// iteration order per process), so its report's byte total varies between equal states.
    pub requested_bytes: AtomicU64,
    pub frames: Mutex<Frames>,
    pub messages: Arc<Mutex<Vec<ValidationMessage>>>,
    /// Data that must outlive the instance (the validation callback's user data).
    pub keep: Mutex<Option<Box<dyn std::any::Any + Send + Sync>>>,
}

impl Device {
    pub fn raw(&self) -> &ash::Device {
        self.handles.device()
    }

    pub fn keep_alive(&self, data: Box<dyn std::any::Any + Send + Sync>) {
        *self.keep.lock().unwrap_or_else(|e| e.into_inner()) = Some(data);
    }

    pub fn lock_frames(&self) -> MutexGuard<'_, Frames> {
        // A panic while holding the lock leaves the counters consistent; keep going.
        self.frames.lock().unwrap_or_else(|e| e.into_inner())
    }

    pub fn lock_allocator(&self) -> MutexGuard<'_, Option<Allocator>> {
        self.allocator.lock().unwrap_or_else(|e| e.into_inner())
    }

    pub fn allocate(
        &self,
        name: &str,
        requirements: vk::MemoryRequirements,
        location: gpu_allocator::MemoryLocation,
        linear: bool,
    ) -> Result<Allocation, VkError> {
        let mut guard = self.lock_allocator();
        let allocator = guard.as_mut().ok_or_else(|| VkError::Allocation {
            name: name.into(),
            message: "device is shutting down".into(),
        })?;
        let allocation = allocator
            .allocate(&gpu_allocator::vulkan::AllocationCreateDesc {
                name,
                requirements,
                location,
                linear,
                allocation_scheme: gpu_allocator::vulkan::AllocationScheme::GpuAllocatorManaged,
            })
            .map_err(|e| VkError::Allocation {
                name: name.into(),
                message: e.to_string(),
            })?;
        self.requested_bytes
            .fetch_add(allocation.size(), Ordering::Relaxed);
        Ok(allocation)
    }

    /// Queues `object` for destruction after the frame being recorded completes (at once when no
    /// frame is in flight).
    pub fn retire(&self, object: Retired) {
        let mut frames = self.lock_frames();
        if frames.completed >= frames.current {
            drop(frames);
            self.destroy(object);
        } else {
            let frame = frames.current;
            frames.pending.push((frame, object));
        }
    }

    /// Marks `completed` done and destroys what waited for it.
    pub fn frame_completed(&self, completed: u64) -> usize {
        let due: Vec<Retired> = {
            let mut frames = self.lock_frames();
            frames.completed = frames.completed.max(completed);
            let done = frames.completed;
            let (due, keep): (Vec<_>, Vec<_>) =
                frames.pending.drain(..).partition(|(f, _)| *f <= done);
            frames.pending = keep;
            due.into_iter().map(|(_, o)| o).collect()
        };
        let n = due.len();
        for object in due {
            self.destroy(object);
        }
        n
    }

    fn destroy(&self, object: Retired) {
        let device = self.raw();
        let free = |allocation: Allocation| {
            self.requested_bytes
                .fetch_sub(allocation.size(), Ordering::Relaxed);
            if let Some(allocator) = self.lock_allocator().as_mut() {
                // A failing free only means the allocation was already gone: nothing to leak.
                let _ = allocator.free(allocation);
            }
        };
        // SAFETY: every retired object was created from this device, and its last use (a frame
        // that has completed, or none) is over, so destroying it cannot race the GPU.
        unsafe {
            match object {
                Retired::Buffer(b, a) => {
                    device.destroy_buffer(b, None);
                    free(a);
                }
                Retired::Image(i, v, a) => {
                    device.destroy_image_view(v, None);
                    device.destroy_image(i, None);
                    free(a);
                }
                Retired::Pipeline(p) => device.destroy_pipeline(p, None),
                Retired::PipelineLayout(l) => device.destroy_pipeline_layout(l, None),
                Retired::DescriptorSetLayout(l) => device.destroy_descriptor_set_layout(l, None),
                Retired::DescriptorPool(p) => device.destroy_descriptor_pool(p, None),
                Retired::QueryPool(q) => device.destroy_query_pool(q, None),
                Retired::Sampler(s) => device.destroy_sampler(s, None),
                Retired::BufferView(v) => device.destroy_buffer_view(v, None),
            }
        }
    }

    /// Gives `handle` a debug-utils name (shown by validation messages and capture tools).
    pub fn set_name<H: vk::Handle>(&self, handle: H, name: &str) {
        let Some(utils) = &self.debug_utils else {
            return;
        };
        let Ok(cname) = std::ffi::CString::new(name) else {
            return;
        };
        let info = vk::DebugUtilsObjectNameInfoEXT::default()
            .object_handle(handle)
            .object_name(&cname);
        // SAFETY: `handle` is a live object of this device; naming is purely informational.
        let _ = unsafe { utils.set_debug_utils_object_name(&info) };
    }
}

impl Drop for Device {
    fn drop(&mut self) {
        if let Handles::Owned(o) = &self.handles {
            // SAFETY: we own the device; waiting makes every retired object safe to destroy.
            let _ = unsafe { o.device.device_wait_idle() };
        }
        // Host contexts: the host guarantees our frames are done before dropping the context.
        let pending: Vec<Retired> = self
            .lock_frames()
            .pending
            .drain(..)
            .map(|(_, o)| o)
            .collect();
        for object in pending {
            self.destroy(object);
        }
        // The allocator frees its memory blocks through the device: it must go first.
        drop(self.lock_allocator().take());
        if let Handles::Owned(o) = &self.handles {
            // SAFETY: all child objects were destroyed above, in child-before-parent order.
            unsafe {
                o.device.destroy_device(None);
                if let Some((utils, messenger)) = &o.messenger {
                    utils.destroy_debug_utils_messenger(*messenger, None);
                }
                o.instance.destroy_instance(None);
            }
        }
    }
}
