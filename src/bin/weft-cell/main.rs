//! weft-cell: the offline half of weft. Reads (and, with `build`, will write) cell blobs.
//!
//! Every subcommand returns `Result<(), String>`; the message goes to stderr and the exit status
//! is non-zero, so the tool composes in asset pipelines.

mod inspect;
mod preview;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "weft-cell",
    version,
    about = "Build and examine weft cell blobs"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Print the cells of a blob: homogenized stiffness, bounds, mesh sizes.
    Inspect {
        /// The cell blob (LIB.weft).
        blob: PathBuf,
        /// Print one JSON object instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// Render each cell's pattern and its deformation under the three unit strains to a PNG.
    Preview {
        /// The cell blob (LIB.weft).
        blob: PathBuf,
        /// Output PNG.
        #[arg(short, long)]
        out: PathBuf,
    },
}

fn main() -> ExitCode {
    let result = match Cli::parse().command {
        Command::Inspect { blob, json } => inspect::run(&blob, json),
        Command::Preview { blob, out } => preview::run(&blob, &out),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("weft-cell: {message}");
            ExitCode::FAILURE
        }
    }
}
