//! Interop with the graphics stacks Rust hosts render through (feature `wgpu`).
//!
//! - [`wgpu`]: a [`crate::vk::Context`] borrowed from a wgpu 27 device on its Vulkan backend; a
//!   [`crate::TranslucentObject`] recorded into a wgpu command buffer of its own, between the host's
//!   wgpu passes, with wgpu textures as colour and depth targets; frame completion from wgpu's
//!   submission tracking. A Bevy plugin would build on it (not written yet).

pub mod wgpu;
