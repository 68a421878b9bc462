//! The `translucent` command line (DESIGN section 8) as a library: the binary (`main.rs`) parses
//! [`Cli`] and calls [`run`]; the fuzz targets (`fuzz/`) and the hostile-input regression tests
//! reach the same parsers through [`hostile`]. Each subcommand is a thin layer over the engine, in
//! its own module; shared scene options live in `scene_args`.
//!
//! ```
//! use clap::Parser as _;
//! let cli = translucent_tools::Cli::try_parse_from(["translucent", "render", "--out", "t.png"])?;
//! assert!(matches!(cli.command, translucent_tools::Command::Render(_)));
//! let e = anyhow::anyhow!("no triangles").context("x.obj: no triangles");
//! assert_eq!(translucent_tools::error_report(&e), "x.obj: no triangles");
//! # Ok::<(), clap::Error>(())
//! ```

use clap::{Parser, Subcommand};

pub mod backdrop;
pub mod bake;
pub mod bench;
pub mod cache;
pub mod framing;
pub mod hostile;
pub mod info;
pub mod material_args;
pub mod object_args;
pub mod progress;
pub mod render;
pub mod scene_args;
#[cfg(feature = "window")]
pub mod view;
pub mod volume;

#[derive(Parser)]
#[command(
    name = "translucent",
    version,
    about = "Real-time heterogeneous translucency on Vulkan"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand)]
pub enum Command {
    /// The Vulkan device, driver and the features used.
    Info(info::InfoArgs),
    /// Render a scene headless to PNG or EXR.
    Render(Box<render::RenderArgs>),
    /// Bake (or load from the cache) the QuadGraph of a mesh or shape.
    Bake(bake::BakeArgs),
    /// Run time against error: sweep solver and bake settings, write CSV and a PNG plot.
    Bench(Box<bench::BenchArgs>),
    /// An interactive window: orbit, move the light, switch materials, watch the skips.
    #[cfg(feature = "window")]
    View(Box<view::ViewArgs>),
    /// Write a procedural heterogeneous material as a .vol grid (for --volume).
    Volume(volume::VolumeArgs),
    /// The bake cache: `info` lists it, `clean` empties or trims it.
    Cache(cache::CacheArgs),
}

/// Runs one parsed command.
pub fn run(cli: &Cli) -> anyhow::Result<()> {
    match &cli.command {
        Command::Info(args) => info::run(args),
        Command::Render(args) => render::run(args),
        Command::Bake(args) => bake::run(args),
        Command::Bench(args) => bench::run(args),
        #[cfg(feature = "window")]
        Command::View(args) => view::run(args),
        Command::Volume(args) => volume::run(args),
        Command::Cache(args) => cache::run(args),
    }
}

/// An error and its causes on one line, `outer: cause: root`, each cause printed once: a cause
/// whose text the line already holds is left out (library errors that name a file print their
/// cause inside their own message and also return it as `source()`, so anyhow's `{:#}` printed it
/// twice: "x.obj: the mesh has no triangles: the mesh has no triangles").
pub fn error_report(error: &anyhow::Error) -> String {
    let mut line = String::new();
    for cause in error.chain() {
        let text = cause.to_string();
        if line.contains(&text) {
            continue;
        }
        if !line.is_empty() {
            line.push_str(": ");
        }
        line.push_str(&text);
    }
    line
}
