//! `translucent`: the command line (DESIGN section 8); the commands live in the library
//! (`lib.rs`), which the fuzz targets share.

use clap::Parser as _;
use translucent_tools::{error_report, run, Cli};

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    match run(&cli) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", error_report(&e));
            std::process::ExitCode::FAILURE
        }
    }
}
