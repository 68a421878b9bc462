//! Fuzz target `render_argv`: arbitrary bytes into `translucent_tools::hostile::run("render_argv", ..)` (see that
//! module for what it drives and which invariants it checks). Refusals are fine; a panic is a crash.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let _ = translucent_tools::hostile::run("render_argv", data);
});
