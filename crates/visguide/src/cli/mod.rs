//! Argument parsing, the shared options and error reporting of the `visguide` binary.

mod common;
mod eval;
mod lwpr_cmd;
mod match_cmd;
mod regions;
mod track;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// The most worker threads `--threads` may ask for: a pool of, say, 100,000 threads is only
/// ever a typo, and starting it exhausts the system's threads or memory before any work.
const MAX_THREADS: usize = 1024;

/// Result of a subcommand: any error, printed as one line.
pub type CliResult<T = ()> = Result<T, Box<dyn std::error::Error + Send + Sync>>;

const ABOUT: &str = "The methods of Larsson's thesis (Linköping 2009) on your own files: MSER \
regions, Fourier-descriptor matching with a homography, channel-based tracking, LWPR regression.";

const LONG_ABOUT: &str =
    "The methods of F. Larsson, \"Methods for Visually Guided Robotic Systems: \
Matching, Tracking and Servoing\" (Linköping 2009) on your own images, tracks and tables.

Every output file is written atomically: a run that fails leaves no partial file behind, and an \
output that names an input (or a directory) is refused before any work. Errors are one line on \
stderr naming the file (and line) and what was expected (`<stdout>` when standard output was \
closed early, as by `| head`); the exit code is 0 on success, 1 when the work failed (bad \
input, unreadable file) and 2 for a usage error.";

const EXAMPLES: &str = "Examples:
  visguide regions --preset opencv --format json --out regions/ photos/
  visguide match img1.png img2.png --homography H1to2p --picture pair.png --out matches.json
  visguide track --train tracks/train/ tracks/test/seq01.csv --out seq01-track.csv
  visguide lwpr fit arm.csv --inputs 2 --model arm.lwpr.json
  visguide eval /data/oxford-affine/leuven";

#[derive(Parser)]
#[command(name = "visguide", version, about = ABOUT, long_about = LONG_ABOUT, after_help = EXAMPLES)]
struct Cli {
    /// No progress bars and no summaries on stderr (errors are still printed).
    #[arg(long, short, global = true)]
    quiet: bool,
    /// Worker threads for the parallel parts, 1 to 1024 (default: every core). Results never
    /// depend on it.
    #[arg(long, global = true, value_name = "N")]
    threads: Option<usize>,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    Regions(regions::RegionsArgs),
    Match(match_cmd::MatchArgs),
    Track(track::TrackArgs),
    Lwpr(lwpr_cmd::LwprArgs),
    Eval(eval::EvalArgs),
}

/// Runs the command line.
pub fn main() -> ExitCode {
    let cli = Cli::parse();
    let ui = common::Ui { quiet: cli.quiet };
    if let Some(n) = cli.threads {
        if n == 0 {
            common::say_on_stderr("visguide: error: --threads must be at least 1");
            return ExitCode::from(2);
        }
        if n > MAX_THREADS {
            common::say_on_stderr(&format!(
                "visguide: error: --threads {n} is more than the limit of {MAX_THREADS}"
            ));
            return ExitCode::from(2);
        }
        if let Err(e) = rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
        {
            common::say_on_stderr(&format!("visguide: error: cannot start {n} threads: {e}"));
            return ExitCode::FAILURE;
        }
    }
    let result = match &cli.command {
        Command::Regions(a) => regions::run(a, ui),
        Command::Match(a) => match_cmd::run(a, ui),
        Command::Track(a) => track::run(a, ui),
        Command::Lwpr(a) => lwpr_cmd::run(a, ui),
        Command::Eval(a) => eval::run(a, ui),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            let msg = e.to_string().replace('\n', " ");
            common::say_on_stderr(&format!("visguide: error: {msg}"));
            ExitCode::FAILURE
        }
    }
}
