//! weft-cell: the offline half of weft. Homogenizes cell descriptions into blobs, and reads them.
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
    /// Homogenize cell descriptions (TOML) and write them into one blob, in order.
    Build {
        /// Cell descriptions; a cell's index in the blob is its position here.
        #[arg(required = true)]
        cells: Vec<PathBuf>,
        /// Output blob (LIB.weft).
        #[arg(short, long)]
        out: PathBuf,
        /// Divide each pixel into K×K squares of the same material.
        #[arg(long, default_value_t = 1)]
        refine: usize,
    },
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
        Command::Build { cells, out, refine } => build(&cells, &out, refine),
        Command::Inspect { blob, json } => inspect::run(&blob, json),
        Command::Preview { blob, out } => preview::run(&blob, &out).map(|()| {
            eprintln!("wrote {}", out.display());
        }),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("weft-cell: {message}");
            ExitCode::FAILURE
        }
    }
}

/// `build`: homogenize every cell, then write the blob (nothing is written on any error).
fn build(cells: &[PathBuf], out: &std::path::Path, refine: usize) -> Result<(), String> {
    use std::io::{IsTerminal, Write};
    if refine == 0 || refine > 64 {
        return Err(format!("--refine must be between 1 and 64, got {refine}"));
    }
    // Allowed, but usually a typo in the pattern: said before the (long) homogenization. A file
    // that does not load is reported by `build_blob` below, with the others' context.
    for path in cells {
        if let Ok(desc) = weft::cell::load(path) {
            for key in desc.unused_materials() {
                eprintln!(
                    "weft-cell: warning: {}: material {key:?} is not used by the pattern",
                    path.display()
                );
            }
        }
    }
    let started = std::time::Instant::now();
    // Progress only for a person watching: in a log or a pipeline it would be noise.
    let terminal = std::io::stderr().is_terminal();
    let mut last = usize::MAX;
    let mut report = |cell: usize, fraction: f64| {
        if !terminal {
            return;
        }
        // one line per cell, refreshed in place on a terminal
        let name = cells
            .get(cell)
            .map(|p| p.display().to_string())
            .unwrap_or_default();
        if cell != last && last != usize::MAX {
            eprintln!();
        }
        last = cell;
        eprint!("\rhomogenizing {name}: {:3.0}%", fraction * 100.0);
        let _ = std::io::stderr().flush();
    };
    let bytes = weft::homogenize::build_blob(cells, refine, &mut report).map_err(|e| {
        if terminal {
            eprintln!();
        }
        e.to_string()
    })?;
    if terminal {
        eprintln!();
    }
    std::fs::write(out, &bytes).map_err(|e| format!("{}: {e}", out.display()))?;
    eprintln!(
        "wrote {} ({} cells, {} bytes) in {:.0} ms",
        out.display(),
        cells.len(),
        bytes.len(),
        started.elapsed().as_secs_f64() * 1e3
    );
    Ok(())
}
