//! `cargo xtask eval`: every evaluation target writes its fixtures into its own folder below the
//! output root (`fixtures/<target>/`). With `--check`, the targets write into a temporary folder
//! that is then compared with the committed `fixtures/` (tolerances: [`crate::fixture_check`]).
//!
//! `cargo xtask eval` runs every target with its default options; `cargo xtask eval TARGET
//! [OPTIONS]` runs one, where `--out DIR` names that target's own output folder. A target that
//! needs benchmark data (`paper-a`) is skipped with a note by a plain run without the data,
//! leaving its committed fixtures untouched and unchecked; named alone, it is an error.
//!
//! Adding a target: a module here with `run(&EvalContext, &Args)`, a variant of [`EvalTarget`],
//! and one line in each of [`EvalTarget::all`], [`EvalTarget::name`] and [`EvalTarget::run`].

mod arm_sim;
mod chan_repr;
mod lwpr;
pub(crate) mod paper_a;
mod servo;
pub(crate) mod tracking;

use std::path::{Path, PathBuf};

use clap::{Args, Subcommand};

use crate::{Result, fixture_check, workspace_root};

/// Arguments of `cargo xtask eval`.
#[derive(Args)]
pub struct EvalArgs {
    /// Regenerate into a temporary folder and fail if the result differs from `fixtures/`.
    #[arg(long, global = true)]
    pub check: bool,
    /// Folder holding benchmark data (e.g. `oxford-affine/`); default: `$VISGUIDE_DATA`.
    #[arg(long, env = "VISGUIDE_DATA", global = true)]
    pub data: Option<PathBuf>,
    /// Output folder: the root for all targets, or the folder of the one target named.
    #[arg(long, global = true)]
    pub out: Option<PathBuf>,
    /// One target to run (default: all of them, with default options).
    #[command(subcommand)]
    pub target: Option<EvalTarget>,
}

/// The evaluation targets.
#[derive(Subcommand, Clone)]
pub enum EvalTarget {
    /// The thesis's channel-coding worked example (eq. 2.3-2.9) and Figure 2.1.
    ChanRepr,
    /// LWPR learning curves on the cross function (nMSE and receptive fields against samples).
    Lwpr,
    /// Paper A's precision-recall study on the Oxford data (Leuven, Boat, Graf by default).
    PaperA(paper_a::PaperAArgs),
    /// Paper A's pipeline on generated scenes with known homographies (needs no data).
    PaperASynthetic,
    /// Paper B: Channel Based Tracking against Kalman and particle filters (synthetic
    /// RC-car sequences, UNGM, or the user's CSV sequences); fixtures in `fixtures/paper-b/`.
    Tracking(tracking::TrackingArgs),
    /// The simulated arm: a rendered frame per camera with the true tip, the workspace in the image.
    ArmSim,
    /// Paper C: learned visual servoing of the simulated arm (LWPR, Broyden, true Jacobian).
    Servo(servo::ServoArgs),
}

impl EvalTarget {
    /// Every target with default options, in the order a plain `cargo xtask eval` runs them.
    pub fn all() -> Vec<EvalTarget> {
        vec![
            EvalTarget::ChanRepr,
            EvalTarget::Lwpr,
            EvalTarget::PaperA(Default::default()),
            EvalTarget::PaperASynthetic,
            EvalTarget::Tracking(Default::default()),
            EvalTarget::ArmSim,
            EvalTarget::Servo(Default::default()),
        ]
    }

    /// The target's name, also its fixture sub-folder.
    pub fn name(&self) -> &'static str {
        match self {
            EvalTarget::ChanRepr => "chan-repr",
            EvalTarget::Lwpr => "lwpr",
            EvalTarget::Tracking(_) => "paper-b",
            EvalTarget::PaperA(_) => "paper-a",
            EvalTarget::PaperASynthetic => "paper-a-synthetic",
            EvalTarget::ArmSim => "arm-sim",
            EvalTarget::Servo(_) => "paper-c",
        }
    }

    /// Why the target cannot run without (complete) benchmark data, if it needs data.
    fn missing_data(&self, data: Option<&Path>) -> Option<String> {
        match self {
            EvalTarget::PaperA(args) => paper_a::missing_data(data, args),
            _ => None,
        }
    }

    fn run(&self, ctx: &EvalContext) -> Result<()> {
        match self {
            EvalTarget::ChanRepr => chan_repr::run(ctx),
            EvalTarget::Lwpr => lwpr::run(ctx),
            EvalTarget::Tracking(args) => tracking::run(ctx, args),
            EvalTarget::PaperA(args) => paper_a::run(ctx, args),
            EvalTarget::PaperASynthetic => paper_a::run_synthetic(ctx),
            EvalTarget::ArmSim => arm_sim::run(ctx),
            EvalTarget::Servo(args) => servo::run(ctx, args),
        }
    }
}

/// What an evaluation target is given.
pub struct EvalContext {
    /// The folder this target writes into, already created and empty.
    pub out_dir: PathBuf,
    /// The benchmark data folder, if the user has one (`--data` or `$VISGUIDE_DATA`).
    pub data_dir: Option<PathBuf>,
}

/// Runs `cargo xtask eval`.
pub fn run(args: &EvalArgs) -> Result<()> {
    let fixtures = workspace_root().join("fixtures");
    let targets = match &args.target {
        Some(t) => vec![t.clone()],
        None => EvalTarget::all(),
    };
    let single = args.target.is_some();
    let check_root = std::env::temp_dir().join(format!("visguide-eval-{}", std::process::id()));
    let out_dir_of = |t: &EvalTarget| -> PathBuf {
        if args.check {
            check_root.join(t.name())
        } else {
            match (&args.out, single) {
                (Some(dir), true) => dir.clone(),
                (Some(root), false) => root.join(t.name()),
                (None, _) => fixtures.join(t.name()),
            }
        }
    };
    let data_dir = args.data.clone().filter(|d| {
        let ok = d.is_dir();
        if !ok {
            eprintln!(
                "note: data folder {} not found; synthetic data only",
                d.display()
            );
        }
        ok
    });
    let mut ran = Vec::new();
    for t in &targets {
        if let Some(why) = t.missing_data(data_dir.as_deref()) {
            if single {
                return Err(format!("{}: {why}", t.name()).into());
            }
            // Leave the committed fixtures of a data-bound target alone; --check skips it.
            eprintln!("skip {}: {why}", t.name());
            continue;
        }
        ran.push(t.name());
        let out_dir = out_dir_of(t);
        if out_dir.exists() {
            std::fs::remove_dir_all(&out_dir)?;
        }
        std::fs::create_dir_all(&out_dir)?;
        let ctx = EvalContext {
            out_dir,
            data_dir: data_dir.clone(),
        };
        let data = ctx
            .data_dir
            .as_ref()
            .map_or("none (synthetic data only)".into(), |d| {
                d.display().to_string()
            });
        eprintln!(
            "eval {} -> {} (data: {data})",
            t.name(),
            ctx.out_dir.display()
        );
        t.run(&ctx)?;
        // The tracking target also writes its pedestrian study beside its folder (when the
        // data is there): check that folder too.
        if matches!(t, EvalTarget::Tracking(_))
            && tracking::sibling(&ctx.out_dir).is_dir()
            && args.check
        {
            ran.push(tracking::PEDESTRIANS_DIR);
        }
    }
    if args.check {
        let names = ran;
        let result = fixture_check::compare_trees(&fixtures, &check_root, &names);
        std::fs::remove_dir_all(&check_root).ok();
        let diffs = result?;
        if !diffs.is_empty() {
            for d in &diffs {
                eprintln!("fixture mismatch: {d}");
            }
            return Err(format!(
                "{} fixture file(s) differ; rerun `cargo xtask eval` and commit",
                diffs.len()
            )
            .into());
        }
        eprintln!("fixtures reproduce ({} target(s))", names.len());
    }
    Ok(())
}

/// Writes `value` as pretty JSON (with a trailing newline) to `dir/name`.
pub fn write_json<T: serde::Serialize>(dir: &Path, name: &str, value: &T) -> Result<()> {
    let mut text = serde_json::to_string_pretty(value)?;
    text.push('\n');
    std::fs::write(dir.join(name), text)?;
    Ok(())
}
