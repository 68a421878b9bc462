//! `translucent`: the command line (DESIGN section 8). Each subcommand is a thin layer over the
//! library, in its own module; shared scene options live in `scene_args`.

use clap::{Parser, Subcommand};

mod bake;
mod bench;
mod cache;
mod info;
mod material_args;
mod object_args;
mod progress;
mod render;
mod render_dipole;
mod render_voxel;
mod scene_args;
#[cfg(feature = "window")]
mod view;
mod volume;

#[derive(Parser)]
#[command(
    name = "translucent",
    version,
    about = "Real-time heterogeneous translucency on Vulkan"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
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

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let result = match &cli.command {
        Command::Info(args) => info::run(args),
        Command::Render(args) => render::run(args),
        Command::Bake(args) => bake::run(args),
        Command::Bench(args) => bench::run(args),
        #[cfg(feature = "window")]
        Command::View(args) => view::run(args),
        Command::Volume(args) => volume::run(args),
        Command::Cache(args) => cache::run(args),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", error_line(&e));
            std::process::ExitCode::FAILURE
        }
    }
}

/// The error and its causes on one line, each cause once: a library error that already names its
/// source (`thiserror`'s `{source}` in the message) would otherwise be printed twice
/// ("no triangles: no triangles").
fn error_line(e: &anyhow::Error) -> String {
    let mut line = String::new();
    for cause in e.chain() {
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

#[cfg(test)]
mod tests {
    #[test]
    fn an_error_line_names_each_cause_once() {
        #[derive(Debug, thiserror::Error)]
        #[error("no triangles")]
        struct Empty;
        #[derive(Debug, thiserror::Error)]
        #[error("mesh: {0}")]
        struct Mesh(#[source] Empty);
        let e = anyhow::Error::new(Mesh(Empty)).context("--mesh a.obj");
        assert_eq!(super::error_line(&e), "--mesh a.obj: mesh: no triangles");
        let plain = anyhow::anyhow!("disk full").context("--out x.png");
        assert_eq!(super::error_line(&plain), "--out x.png: disk full");
    }
}
