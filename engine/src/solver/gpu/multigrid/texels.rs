//! Uniform texel views of the multigrid's read-only inputs (the `*_t` bindings of
//! `multigrid/residual.comp` and `multigrid/smooth.comp`, `TEXEL_READS`): the same buffers, read
//! with `texelFetch` instead of a storage-buffer load. Same values, same arithmetic; on lavapipe
//! (llvmpipe) a storage-buffer read at a per-invocation address is a loop over the SIMD lanes
//! with a bounds branch per lane and component, a texel fetch one branchless gather
//! (benches/RESULTS.md "Fewer bytes per finest pass (wave 11)").

use ash::vk;

use super::kernels::BUFFER_NAMES;
use crate::vk::{Buffer, BufferView, Context, VkError};

/// Where the residual and smoothing kernels read their read-only inputs from. The environment
/// variable `TRANSLUCENT_MULTIGRID_READS`, read when the solver is created, picks it: `texel`
/// ([`Self::Texel`]), `buffer` ([`Self::Buffer`]); unset: [`Self::DEFAULT`].
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(crate) enum Reads {
    /// Storage buffers (`buf.v[i]`).
    Buffer,
    /// Uniform texel buffers over the same storage (`texelFetch(buf_t, i)`).
    Texel,
}

impl Reads {
    pub(crate) const DEFAULT: Reads = Reads::Buffer;

    pub(crate) fn from_env() -> Self {
        match std::env::var("TRANSLUCENT_MULTIGRID_READS").as_deref() {
            Ok("texel") => Self::Texel,
            Ok("buffer") => Self::Buffer,
            _ => Self::DEFAULT,
        }
    }
}

/// The buffer a `*_t` binding views (`"x_t"` -> `"x"`), or `None` for any other binding.
pub(super) fn viewed(binding: &str) -> Option<&str> {
    binding
        .strip_suffix("_t")
        .filter(|name| BUFFER_NAMES.contains(name))
}

/// A view's texel format and bytes per texel, by the buffer it views (its element type in the
/// shaders: `diag` vec4, `values16` uvec2, the index buffers uint, every other one float).
fn format_of(name: &str) -> (vk::Format, u64) {
    match name {
        "diag" => (vk::Format::R32G32B32A32_SFLOAT, 16),
        "values16" => (vk::Format::R32G32_UINT, 8),
        "row_start" | "cols" | "partner" | "node_texel" | "texel_node" => (vk::Format::R32_UINT, 4),
        _ => (vk::Format::R32_SFLOAT, 4),
    }
}

/// One view per buffer some kernel reads through a `*_t` binding, in [`BUFFER_NAMES`] order.
pub(super) struct TexelViews {
    views: Vec<(&'static str, BufferView)>,
}

impl TexelViews {
    /// Views of the `buffers` (in [`BUFFER_NAMES`] order) that any of `bindings` names.
    pub(super) fn new<'b>(
        ctx: &Context,
        buffers: &[Buffer],
        bindings: impl Iterator<Item = &'b str>,
    ) -> Result<Self, VkError> {
        let wanted: Vec<&str> = bindings.filter_map(viewed).collect();
        let mut views = Vec::new();
        for (name, buffer) in BUFFER_NAMES.iter().zip(buffers) {
            if wanted.contains(name) {
                let (format, bytes) = format_of(name);
                views.push((*name, BufferView::new(ctx, buffer, format, bytes)?));
            }
        }
        Ok(Self { views })
    }

    /// The view of the buffer the `*_t` binding `binding` names.
    pub(super) fn get(&self, binding: &str) -> Option<vk::BufferView> {
        let name = viewed(binding)?;
        self.views
            .iter()
            .find(|(n, _)| *n == name)
            .map(|(_, v)| v.raw)
    }
}
