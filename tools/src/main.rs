//! `translucent`: the command line (DESIGN section 8). Each subcommand is a thin layer over the
//! library, in its own module.

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(name = "translucent", version, about = "Real-time heterogeneous translucency on Vulkan")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// The Vulkan device, driver and the features used.
    Info(info::InfoArgs),
    /// Bake (or load from the cache) the QuadGraph of a mesh or shape.
    Bake(bake::BakeArgs),
}

mod bake;

mod info {
    #[derive(clap::Args)]
    pub struct InfoArgs {
        /// Print one JSON object.
        #[arg(long)]
        pub json: bool,
    }
    pub fn run(_args: &InfoArgs) -> anyhow::Result<()> {
        anyhow::bail!("not built yet")
    }
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let result = match &cli.command {
        Command::Info(args) => info::run(args),
        Command::Bake(args) => bake::run(args),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
