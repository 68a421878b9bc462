//! Replays fuzz inputs through their hostile-input entry point on stable (issue 17): what a
//! cargo-fuzz artifact does, with a normal backtrace and no nightly.
//!
//! ```text
//! cargo run --release -p translucent-tools --example fuzz_replay -- cache fuzz/artifacts/cache/crash-*
//! ```
//!
//! Prints `refused: ...` or `accepted` per file; a panic is the crash the fuzzer found.

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let target = args
        .next()
        .ok_or_else(|| anyhow::anyhow!("usage: fuzz_replay TARGET FILE..."))?;
    anyhow::ensure!(
        translucent_tools::hostile::TARGETS.contains(&target.as_str()),
        "no target {target:?}; known: {:?}",
        translucent_tools::hostile::TARGETS
    );
    for file in args {
        let data = std::fs::read(&file).map_err(|e| anyhow::anyhow!("{file}: {e}"))?;
        match translucent_tools::hostile::run(&target, &data) {
            Ok(()) => println!("{file}: accepted"),
            Err(message) => println!("{file}: refused: {message}"),
        }
    }
    Ok(())
}
