//! `translucent volume`: writes a procedural heterogeneous material as a `.vol` grid (DESIGN
//! section 2: sigma_s' RGB then sigma_a RGB per voxel, 1/mm, Mitsuba 3's layout), sampled from
//! the same fields `--material agate|veined-marble|split` uses, over the box an object of
//! `--size-mm` fills after normalization. `render --volume FILE.vol` then draws that material.
//!
//! ```text
//! translucent volume --pattern agate --out agate.vol
//! translucent render --volume agate.vol --eta 1.5 --out agate.png
//! ```

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{bail, Context as _};
use glam::DVec3;
use translucent::material::VolGrid;

use crate::material_args::{MaterialArgs, PROCEDURAL};

#[derive(clap::Args, Debug)]
pub struct VolumeArgs {
    /// The procedural pattern: agate, veined-marble or split (as `--material`).
    #[arg(long, value_parser = PROCEDURAL)]
    pub pattern: String,
    /// The `.vol` file to write.
    #[arg(long, value_name = "FILE.vol")]
    pub out: PathBuf,
    /// The object size the pattern is scaled to (its bands and veins follow `--size-mm` as in
    /// `render`); the grid spans +-size/2 mm on every axis.
    #[arg(long, default_value_t = 50.0, allow_negative_numbers = true)]
    pub size_mm: f64,
    /// Voxels along each axis.
    #[arg(long, default_value_t = 64)]
    pub resolution: u32,
}

/// Voxels along an axis beyond this would make a file of gigabytes (512^3 x 24 bytes = 3 GiB).
const MAX_RESOLUTION: u32 = 512;

pub fn run(args: &VolumeArgs) -> anyhow::Result<()> {
    // Every bad option is refused before any work (and nothing is written).
    if args.out.extension().and_then(|e| e.to_str()) != Some("vol") {
        bail!("--out {}: must end in .vol", args.out.display());
    }
    if !(1..=MAX_RESOLUTION).contains(&args.resolution) {
        bail!(
            "--resolution {}: must be in 1..={MAX_RESOLUTION}",
            args.resolution
        );
    }
    let range = translucent::mesh::SIZE_RANGE_MM;
    if !range.contains(&args.size_mm) {
        bail!(
            "--size-mm {}: must be a number of millimetres from {} to {}",
            args.size_mm,
            range.start(),
            range.end()
        );
    }
    let field = MaterialArgs {
        material: Some(args.pattern.clone()),
        sigma_a: None,
        sigma_s: None,
        eta: None,
        volume: None,
    }
    .field(args.size_mm, &args.pattern)?;
    let start = Instant::now();
    let half = DVec3::splat(0.5 * args.size_mm);
    let r = args.resolution as usize;
    let grid = VolGrid::from_fn([r; 3], -half, half, |p| {
        let c = field.sample(p);
        (c.sigma_s, c.sigma_a)
    })
    .with_context(|| format!("--pattern {}", args.pattern))?;
    grid.write(&args.out)
        .with_context(|| format!("--out {}", args.out.display()))?;
    let bytes = std::fs::metadata(&args.out).map_or(0, |m| m.len());
    println!(
        "wrote {} ({r}x{r}x{r} voxels, {}, {:.0} ms): render it with --volume {}",
        args.out.display(),
        crate::cache::human(bytes),
        start.elapsed().as_secs_f64() * 1e3,
        args.out.display()
    );
    Ok(())
}
