//! Replays fuzz inputs through their hostile-input entry point on stable (issue 17): what a
//! cargo-fuzz artifact does, with a normal backtrace and no nightly.
//!
//! ```text
//! cargo run --release -p translucent-tools --example fuzz_replay -- cache fuzz/artifacts/cache/crash-*
//! ```
//!
//! Prints `refused: ...` or `accepted` per file; a panic is the crash the fuzzer found.
//! `make-env-seeds DIR` and `make-cache-seeds DIR` write those targets' seed inputs.

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let target = args
        .next()
        .ok_or_else(|| anyhow::anyhow!("usage: fuzz_replay TARGET FILE..."))?;
    if target == "make-env-seeds" {
        // The env target's seeds: small equirectangular maps in the encodings users send.
        let dir = std::path::PathBuf::from(args.next().unwrap_or_else(|| ".".into()));
        use exr::prelude::*;
        let sky = |x: usize, y: usize| (0.2 + x as f32 * 0.1, 0.5 + y as f32 * 0.2, 1.0f32);
        for (name, encoding) in [
            ("seed-8x4-uncompressed.exr", Encoding::UNCOMPRESSED),
            ("seed-8x4-zip.exr", Encoding::SMALL_LOSSLESS),
            ("seed-8x4-rle.exr", Encoding::FAST_LOSSLESS),
        ] {
            let image = Image::from_layer(Layer::new(
                (8, 4),
                LayerAttributes::named("sky"),
                encoding,
                SpecificChannels::rgb(|p: Vec2<usize>| sky(p.x(), p.y())),
            ));
            image.write().to_file(dir.join(name))?;
        }
        return Ok(());
    }
    if target == "make-cache-seeds" {
        // The cache target's seeds in the current format (see `hostile::cache_seeds`).
        let dir = std::path::PathBuf::from(args.next().unwrap_or_else(|| ".".into()));
        for (name, bytes) in
            translucent_tools::hostile::cache_seeds().map_err(|e| anyhow::anyhow!(e))?
        {
            std::fs::write(dir.join(name), bytes)?;
        }
        return Ok(());
    }
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
