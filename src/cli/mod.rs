//! The headless command line: `quadcover info`, `quadcover solve`, `quadcover bench`.
//! Without a subcommand the binary opens the editor (see `main.rs`).

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

pub mod bench;
pub mod extract;
mod info;
pub mod prepare;
pub mod solve;

/// Field-guided global parameterization and tiling of triangle meshes (QuadCover).
#[derive(Debug, Parser)]
#[command(name = "quadcover", version, about)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Option<Command>,
    /// Mesh to open in the editor (OBJ, PLY, OFF or STL); the embedded default mesh otherwise.
    pub mesh: Option<PathBuf>,
}

#[derive(Debug, Subcommand)]
#[allow(clippy::large_enum_variant)] // parsed once per run
pub enum Command {
    /// Print a mesh's statistics (V, E, F, components, genus, boundary loops) and repairs.
    Info(info::InfoArgs),
    /// Time each pipeline stage (and peak memory) on meshes of about 10k, 100k and 1M triangles.
    Bench(bench::BenchArgs),
    /// Seamless QuadCover parameterization (N = 2, 4, 6): per-corner UVs to OBJ, JSON report.
    Solve(solve::SolveArgs),
    /// Remesh a seamless parameterization (OBJ with per-corner UVs): quads, triangles, stripes.
    Extract(extract::ExtractArgs),
    /// Remesh the input isotropically, keeping sharp features and the boundary (for raw CAD
    /// tessellations; `solve` does it by itself where the input needs it).
    Prepare(prepare::PrepareArgs),
}

/// Exit code for bad input (invalid mesh, unreadable file, bad arguments).
pub const EXIT_BAD_INPUT: u8 = 2;

/// Runs a headless subcommand; errors are printed to stderr and turned into an exit code.
pub fn run(command: Command) -> ExitCode {
    let result = match command {
        Command::Info(args) => info::run(&args),
        Command::Bench(args) => bench::run(&args),
        Command::Solve(args) => solve::run(&args),
        Command::Extract(args) => extract::run(&args),
        Command::Prepare(args) => prepare::run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(EXIT_BAD_INPUT)
        }
    }
}

/// Errors of the command line, each printed as one clear message.
pub type CliError = Box<dyn std::error::Error + Send + Sync>;
