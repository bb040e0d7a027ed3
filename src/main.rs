//! `quadcover`: with no subcommand, the editor; with one, the headless pipeline.

use std::process::ExitCode;

use clap::Parser;
use quadcover::cli::{Cli, run};

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Some(command) => run(command),
        None => match quadcover::app::run_editor(cli.mesh) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("error: could not start the editor: {e}");
                ExitCode::FAILURE
            }
        },
    }
}
