//! `cargo xtask`: the project's automation.
//!
//! - `cargo xtask eval [TARGET…] [--check] [--data DIR] [--out DIR]` regenerates the committed
//!   fixtures under `fixtures/` (or checks that a fresh run reproduces them).
//! - `cargo xtask bench NAME` measures one of our crates against its peer, prints a table and
//!   writes `target/bench/NAME.json`.
//! - `cargo xtask data fetch [--dir DIR]` downloads, unpacks and checks the Oxford affine benchmark.

mod bench;
mod data_fetch;
#[cfg(test)]
mod doc_links;
mod eval;
mod fixture_check;
mod goal;
mod markdown;
mod output;
mod palette;
mod report;
mod stats;
mod strict_ci;

use std::path::PathBuf;

use clap::{Parser, Subcommand};

/// Error type of the xtask: any error, with its message shown to the user.
pub type Error = Box<dyn std::error::Error + Send + Sync>;
/// Result type of the xtask.
pub type Result<T> = std::result::Result<T, Error>;

#[derive(Parser)]
#[command(name = "xtask", about = "visguide project automation")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Regenerate the evaluation fixtures under `fixtures/`.
    Eval(eval::EvalArgs),
    /// Measure a crate against its peer: prints a table, writes `target/bench/NAME.json`.
    Bench(bench::BenchArgs),
    /// Benchmark data: `cargo xtask data fetch [--dir DIR]` downloads the Oxford affine set.
    Data(data_fetch::DataArgs),
}

fn main() {
    let cli = Cli::parse();
    if matches!(cli.command, Command::Eval(_)) {
        // Before any thread starts: an interrupt then removes the unfinished output.
        output::interrupt::install();
    }
    let result = match cli.command {
        Command::Eval(args) => eval::run(&args),
        Command::Bench(args) => bench::run(&args),
        Command::Data(args) => data_fetch::run(&args),
    };
    if let Err(e) = result {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}

/// The workspace root (the parent of the xtask crate's manifest directory).
pub fn workspace_root() -> PathBuf {
    let manifest = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    manifest.parent().map(PathBuf::from).unwrap_or(manifest)
}
