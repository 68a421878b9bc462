//! The crate of `examples/wgpu_host.rs` (run it with `cargo run --release --example wgpu_host`
//! from the repository root): a headless wgpu program that embeds a translucent object through
//! `translucent::interop::wgpu`, its test (`tests/wgpu_host.rs`) and the interop overhead bench
//! (`examples/wgpu_overhead.rs`). The library itself is empty.
