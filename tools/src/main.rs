//! `translucent`: the command line (DESIGN section 8). Each subcommand is a thin layer over the
//! library, in its own module; shared scene options live in `scene_args`.

use clap::{Parser, Subcommand};

mod bake;
mod bench;
mod info;
mod material_args;
mod object_args;
mod render;
mod render_dipole;
mod scene_args;

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
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let result = match &cli.command {
        Command::Info(args) => info::run(args),
        Command::Render(args) => render::run(args),
        Command::Bake(args) => bake::run(args),
        Command::Bench(args) => bench::run(args),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
