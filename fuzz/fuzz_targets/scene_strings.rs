//! Fuzz target `scene_strings`: arbitrary bytes into `translucent_tools::hostile::run("scene_strings", ..)` (see that
//! module for what it drives and which invariants it checks). Refusals are fine; a panic is a crash.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let _ = translucent_tools::hostile::run("scene_strings", data);
});
