//! `quadcover`: with no subcommand, the editor; with one, the headless pipeline.

use std::process::ExitCode;

use clap::Parser;
use quadcover::cli::{Cli, run};

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Some(command) => run(command),
        // The editor is wired in once src/app lands.
        None => {
            eprintln!("the editor is not built yet; try `quadcover info MESH`");
            ExitCode::FAILURE
        }
    }
}
