//! `cargo xtask bench NAME`: one module per measured crate; each returns rows of
//! [`BenchRow`] measured against its peer in the same run.
//!
//! Adding a bench: a module here with `run(&BenchArgs) -> Result<Vec<BenchRow>>` and one entry
//! in [`BENCHES`].

mod chan_repr;
mod cli;
mod cpu;
pub use cpu::thread_seconds;
mod fd;
#[cfg(feature = "opencv")]
mod fd_opencv;
mod lwpr;
mod mser;
mod tracking;

use clap::Args;

use crate::report::{self, BenchRow};
use crate::{Result, workspace_root};

/// Arguments of `cargo xtask bench`.
#[derive(Args)]
pub struct BenchArgs {
    /// Which bench to run; omit to list them.
    pub name: Option<String>,
    /// Folder holding benchmark data (e.g. `oxford-affine/`); default: `$VISGUIDE_DATA`.
    #[arg(long, env = "VISGUIDE_DATA")]
    pub data: Option<std::path::PathBuf>,
    /// `bench tracking` only: CBT's system model counts its displacements this way
    /// (`cbt_tracker::Displacements`) instead of `CbtConfig::stationary`'s, to time a candidate
    /// setting that `eval tracking --displacements` scores on development data; the bench then
    /// reports its time rows only (its accuracy rows are on the test sets).
    #[arg(long, value_enum)]
    pub displacements: Option<crate::eval::tracking::DisplacementsArg>,
}

impl BenchArgs {
    /// The Oxford affine benchmark folder (`DATA/oxford-affine`), or an error saying how to set
    /// it.
    pub fn oxford_root(&self) -> Result<std::path::PathBuf> {
        Ok(self
            .data
            .as_ref()
            .ok_or("set VISGUIDE_DATA (or --data) to the folder holding oxford-affine/")?
            .join("oxford-affine"))
    }
}

/// A bench: its name, the peer it is measured against, and the function that measures.
pub struct Bench {
    /// Name on the command line and of `target/bench/NAME.json`.
    pub name: &'static str,
    /// The peer measured in the same run.
    pub peer: &'static str,
    /// Runs the measurement.
    pub run: fn(&BenchArgs) -> Result<Vec<BenchRow>>,
}

/// Every bench.
pub const BENCHES: &[Bench] = &[
    Bench {
        name: "chan-repr",
        peer: "the plain per-channel loop over each value's support (eq. 2.1 on the active channels)",
        run: chan_repr::run,
    },
    Bench {
        name: "lwpr",
        peer: "reference LWPR C library 1.2.6 (built from ../shared/peers/lwpr in the same run)",
        run: lwpr::run,
    },
    Bench {
        name: "fd",
        peer: "every pair with the same exact correlation kernel (same FFT length, plans and buffers reused), no bound; results asserted identical",
        run: fd::run,
    },
    Bench {
        name: "mser",
        peer: "OpenCV MSER::detectRegions (xtask feature `opencv`), one thread, same parameters (min_diversity 0), region sets asserted equal",
        run: mser::run,
    },
    Bench {
        name: "cli",
        peer: "the library doing the same job (read, decode, detect, write each region file) on the same 100 images with the same parameters, region files asserted byte-identical; the bare mser::detect for information; --threads 1 vs every thread; OpenCV detectRegions with the xtask feature `opencv`",
        run: cli::run,
    },
    Bench {
        name: "tracking",
        peer: "SIR particle filter (100/1,000/10,000 particles), Kalman + NN",
        run: tracking::run,
    },
];

/// Runs `cargo xtask bench`.
pub fn run(args: &BenchArgs) -> Result<()> {
    let Some(name) = &args.name else {
        for b in BENCHES {
            println!("{:<12} against {}", b.name, b.peer);
        }
        return Ok(());
    };
    let bench = BENCHES
        .iter()
        .find(|b| b.name == name)
        .ok_or_else(|| format!("unknown bench `{name}`; run `cargo xtask bench` for the list"))?;
    if args.displacements.is_some() && bench.name != "tracking" {
        return Err(format!("--displacements is for `bench tracking`, not `bench {name}`").into());
    }
    let rows = (bench.run)(args)?;
    report::publish(
        &workspace_root().join("target/bench"),
        bench.name,
        bench.peer,
        &rows,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::tracking::DisplacementsArg;

    #[test]
    fn displacements_are_refused_by_every_bench_but_tracking() {
        for b in BENCHES.iter().filter(|b| b.name != "tracking") {
            let args = BenchArgs {
                name: Some(b.name.into()),
                data: None,
                displacements: Some(DisplacementsArg::Fitted),
            };
            let err = run(&args).expect_err(b.name).to_string();
            assert!(err.contains("--displacements"), "{}: {err}", b.name);
        }
    }
}
