//! A thin owning layer over ash. Knows nothing about translucency.

/// A failing Vulkan call or an unsuitable device.
#[derive(Debug, thiserror::Error)]
pub enum VkError {
    #[error("{call} failed: {result}")]
    Call { call: &'static str, result: ash::vk::Result },
}
