//! `quadcover`: with no subcommand, the editor; with one, the headless pipeline.

use std::process::ExitCode;

use clap::Parser;
use quadcover::cli::{Cli, run};

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Some(command) => {
            restore_default_sigpipe();
            run(command)
        }
        None => match quadcover::app::run_editor(cli.mesh) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("error: could not start the editor: {e}");
                ExitCode::FAILURE
            }
        },
    }
}

/// Rust ignores SIGPIPE, so printing to a closed pipe (`quadcover info m.obj | head`) would
/// panic in `println!`. Subcommands write to standard output like any Unix tool and end
/// quietly when the reader goes away; the editor keeps Rust's default.
fn restore_default_sigpipe() {
    #[cfg(unix)]
    // SAFETY: called before any other thread exists; SIG_DFL is a valid action for SIGPIPE.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}
