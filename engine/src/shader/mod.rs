//! Embedded SPIR-V (compiled by `build.rs` with glslc) and its reflection (spirq).
