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
        assert_eq!(
            translucent_tools::error_report(&e),
            "--mesh a.obj: mesh: no triangles"
        );
        let plain = anyhow::anyhow!("disk full").context("--out x.png");
        assert_eq!(
            translucent_tools::error_report(&plain),
            "--out x.png: disk full"
        );
    }
}
