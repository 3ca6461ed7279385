//! `cargo xtask eval`: every evaluation target writes its fixtures into its own folder below the
//! output root (`fixtures/<target>/`). With `--check`, the targets write into a temporary folder
//! that is then compared with the committed `fixtures/` (tolerances: [`crate::fixture_check`]).
//!
//! Outputs are atomic ([`crate::output`]): the data and every destination are checked before
//! anything is written, each target writes into a temporary folder beside its destination, and
//! the folders are moved into place only when every target succeeded. A failed or interrupted
//! run leaves every destination as it was. `--out DIR` replaces DIR only if it is empty or an
//! earlier output of ours (it holds [`crate::output::MARKER`]), never the current folder, the
//! repository or a folder above them. With `CI=true`, a target skipped for missing data is an
//! error ([`crate::strict_ci`]).
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
mod pipeline;
mod servo;
pub(crate) mod tracking;

use std::path::{Path, PathBuf};

use clap::{Args, Subcommand};

use crate::output::{self, Destination, Staged};
use crate::{Result, fixture_check, strict_ci, workspace_root};

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
#[derive(Subcommand, Clone, Debug)]
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
    /// The thesis's future work: FD recognition + CBT tracking as the servo percept, on the
    /// default and hard scenes (developed on) and the other shipped arms (held out).
    Pipeline(pipeline::PipelineArgs),
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
            EvalTarget::Pipeline(Default::default()),
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
            EvalTarget::Pipeline(_) => "pipeline",
        }
    }

    /// Folders the target may write beside its own, named by a suffix to its destination's
    /// name (`-x`: `fixtures/NAME-x/`, or `DIR-x` for `--out DIR`), through
    /// [`EvalContext::sibling`]; each replaces its destination only if the target wrote into
    /// it, else the destination keeps its contents.
    pub fn siblings(&self) -> &'static [&'static str] {
        match self {
            // The pedestrian study (`fixtures/paper-b-pedestrians/`), when its data is there.
            EvalTarget::Tracking(_) => &["-pedestrians"],
            _ => &[],
        }
    }

    /// Why the target, as asked, must write to a folder the user names (`--out`, no
    /// `--check`) instead of its fixtures, if it must.
    fn needs_own_out(&self) -> Option<&'static str> {
        match self {
            EvalTarget::Pipeline(args) => pipeline::needs_own_out(args),
            EvalTarget::Servo(args) => servo::needs_own_out(args),
            EvalTarget::Tracking(args) => tracking::needs_own_out(args),
            EvalTarget::PaperA(args) => paper_a::needs_own_out(args),
            _ => None,
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
            EvalTarget::Pipeline(args) => pipeline::run(ctx, args),
        }
    }
}

/// What an evaluation target is given.
pub struct EvalContext {
    /// The folder this target writes into: a temporary folder beside the destination, holding
    /// only [`crate::output::MARKER`]; moved into place after every target succeeded.
    pub out_dir: PathBuf,
    /// The benchmark data folder, if the user has one (`--data` or `$VISGUIDE_DATA`).
    pub data_dir: Option<PathBuf>,
}

impl EvalContext {
    /// The staged folder of the sibling output with this suffix (one of
    /// [`EvalTarget::siblings`]), beside [`EvalContext::out_dir`].
    pub fn sibling(&self, suffix: &str) -> PathBuf {
        crate::output::staged_sibling(&self.out_dir, suffix)
    }
}

/// Whether a staged folder replaces (or, with `--check`, is compared with) its destination.
/// A sibling the target did not write keeps its old contents. So does the target's own folder
/// when it wrote nothing (a development run that only prints, e.g. `eval servo --development`,
/// used to empty `fixtures/paper-c`); `--check` still compares it, so a target that stops
/// writing fails the check.
fn replaces_destination(own_folder: bool, check: bool, unused: bool) -> bool {
    !unused || (own_folder && check)
}

/// Runs `cargo xtask eval`: checks every destination and the data first, stages each target's
/// output in a temporary folder beside its destination ([`crate::output`]), and moves all of
/// them into place only after every target succeeded. With `--check`, the staged folders are
/// compared with `fixtures/` and removed; nothing outside the temporary folder is written.
pub fn run(args: &EvalArgs) -> Result<()> {
    let fixtures = workspace_root().join("fixtures");
    let targets = match &args.target {
        Some(t) => vec![t.clone()],
        None => EvalTarget::all(),
    };
    let single = args.target.is_some();
    if let Some(why) = args.target.as_ref().and_then(EvalTarget::needs_own_out)
        && (args.check || args.out.is_none())
    {
        return Err(why.into());
    }
    let data_dir = match &args.data {
        Some(d) if !d.is_dir() => {
            let why = format!("data folder {} not found", d.display());
            strict_ci::skip_or_fail(&format!("{why}; synthetic data only"))?;
            None
        }
        d => d.clone(),
    };
    // Every check before anything is written: data, then destinations.
    let mut plan = Vec::new();
    for t in &targets {
        if let Some(why) = t.missing_data(data_dir.as_deref()) {
            if single {
                return Err(format!("{}: {why}", t.name()).into());
            }
            // Leave the committed fixtures of a data-bound target alone; --check skips it.
            strict_ci::skip_or_fail(&format!("skip {}: {why}", t.name()))?;
            continue;
        }
        plan.push(t);
    }
    let check_root = if args.check {
        let root = std::env::temp_dir().join(format!("visguide-eval-check-{}", std::process::id()));
        Some(Staged::new(&Destination::check(&root, false)?)?)
    } else {
        None
    };
    // Per target, its own destination first, then its siblings'.
    let mut destinations: Vec<Vec<(String, Destination)>> = Vec::new();
    for t in &plan {
        let dest = match (&check_root, &args.out, single) {
            (Some(root), _, _) => Destination::check(&root.path().join(t.name()), true)?,
            (None, Some(dir), true) => Destination::check(dir, false)?,
            (None, Some(root), false) => Destination::check(&root.join(t.name()), false)?,
            (None, None, _) => Destination::check(&fixtures.join(t.name()), true)?,
        };
        let trusted = check_root.is_some() || args.out.is_none();
        let mut own = vec![(t.name().to_string(), dest)];
        for suffix in t.siblings() {
            let main = own[0].1.path();
            let name = main.file_name().unwrap_or_default().to_string_lossy();
            let beside = main.with_file_name(format!("{name}{suffix}"));
            own.push((
                format!("{}{suffix}", t.name()),
                Destination::check(&beside, trusted)?,
            ));
        }
        for (_, d) in &own {
            if destinations
                .iter()
                .flatten()
                .any(|(_, e)| e.path() == d.path())
            {
                return Err(format!("two targets write {}", d.path().display()).into());
            }
        }
        destinations.push(own);
    }
    let data = data_dir
        .as_ref()
        .map_or("none (synthetic data only)".into(), |d| {
            d.display().to_string()
        });
    // (name, staged folder) of every output to move into place or compare.
    let mut staged: Vec<(String, Staged)> = Vec::new();
    for (t, own) in plan.iter().zip(&destinations) {
        let dest = own[0].1.path();
        let mut stages = Vec::new();
        for (name, d) in own {
            stages.push((name.clone(), Staged::new(d)?));
        }
        let ctx = EvalContext {
            out_dir: stages[0].1.path().to_path_buf(),
            data_dir: data_dir.clone(),
        };
        eprintln!("eval {} -> {} (data: {data})", t.name(), dest.display());
        let started = std::time::Instant::now();
        t.run(&ctx)
            .map_err(|e| format!("{}: {e} ({} left unchanged)", t.name(), dest.display()))?;
        // A log's note of where the time goes (stderr, never a fixture).
        eprintln!(
            "eval {}: done in {:.0} s",
            t.name(),
            started.elapsed().as_secs_f64()
        );
        for (i, (name, stage)) in stages.into_iter().enumerate() {
            if replaces_destination(i == 0, check_root.is_some(), stage.is_unused()) {
                staged.push((name, stage));
            } else if i == 0 {
                eprintln!(
                    "eval {}: wrote nothing; {} left unchanged",
                    t.name(),
                    dest.display()
                );
            }
        }
    }
    let Some(check_root) = check_root else {
        return output::commit_all(staged.into_iter().map(|(_, s)| s).collect());
    };
    // The staged folders are named `.NAME.partial-PID` below the check root: compare those.
    let names: Vec<String> = staged.iter().map(|(n, _)| n.clone()).collect();
    let actual: Vec<(String, PathBuf)> = staged
        .iter()
        .map(|(n, s)| (n.clone(), s.path().to_path_buf()))
        .collect();
    let diffs = fixture_check::compare_folders(&fixtures, &actual)?;
    drop(staged);
    drop(check_root);
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
    eprintln!(
        "fixtures reproduce ({} folder(s): {})",
        names.len(),
        names.join(", ")
    );
    Ok(())
}

/// Writes `value` as pretty JSON (with a trailing newline) to `dir/name`.
pub fn write_json<T: serde::Serialize>(dir: &Path, name: &str, value: &T) -> Result<()> {
    let mut text = serde_json::to_string_pretty(value)?;
    text.push('\n');
    let path = dir.join(name);
    std::fs::write(&path, text).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::{EvalArgs, EvalTarget, pipeline::PipelineArgs, replaces_destination, run};

    /// Every target run on something other than its fixtures' study (the user's arm file,
    /// sequences, seed or setting; `eval pipeline --arm` first) needs a folder of its own:
    /// refused before anything runs without `--out` or with `--check` (it would replace or
    /// fail the fixtures); the fixtures' own runs and the modes that only print are not
    /// refused.
    #[test]
    fn own_studies_need_an_output_folder_of_their_own() {
        use super::{paper_a::PaperAArgs, servo::ServoArgs, tracking::TrackingArgs};
        let servo = |f: fn(&mut ServoArgs)| {
            let mut a = ServoArgs::default();
            f(&mut a);
            EvalTarget::Servo(a)
        };
        let tracking = |f: fn(&mut TrackingArgs)| {
            let mut a = TrackingArgs::default();
            f(&mut a);
            EvalTarget::Tracking(a)
        };
        let paper_a = |f: fn(&mut PaperAArgs)| {
            let mut a = PaperAArgs::default();
            f(&mut a);
            EvalTarget::PaperA(a)
        };
        let own = [
            servo(|a| a.arm = Some("my-arm.json".into())),
            servo(|a| a.seed = 7),
            servo(|a| a.percept = super::servo::PerceptMode::Simulated),
            servo(|a| a.face_gate = Some(2.0)),
            servo(|a| a.no_seeds = true),
            tracking(|a| {
                a.train = Some("train".into());
                a.test = Some("test".into());
            }),
            tracking(|a| a.validation_only = true),
            paper_a(|a| a.sequences = vec!["bikes".into()]),
            paper_a(|a| a.mser.delta = Some(5)),
            paper_a(|a| a.no_sensitivity = true),
            EvalTarget::Pipeline(PipelineArgs {
                arms: vec!["no-such-arm.json".into()],
                ..PipelineArgs::default()
            }),
        ];
        for t in &own {
            assert!(t.needs_own_out().is_some(), "{t:?}");
            for (check, out) in [(false, None), (true, None), (true, Some("somewhere"))] {
                let args = EvalArgs {
                    check,
                    data: None,
                    out: out.map(Into::into),
                    target: Some(t.clone()),
                };
                let e = run(&args).unwrap_err().to_string();
                assert!(e.contains("name a folder with --out"), "{t:?}: {e}");
            }
        }
        let fixtures = [
            servo(|_| {}),
            servo(|a| a.development = true),
            servo(|a| a.diagnose_recognition = true),
            tracking(|_| {}),
            tracking(|a| a.rc_car_development = true),
            paper_a(|_| {}),
            paper_a(|a| {
                a.sequences = ["leuven", "boat", "graf"].map(String::from).to_vec();
                a.matches_dir = Some("pictures".into());
            }),
            EvalTarget::Pipeline(PipelineArgs::default()),
            EvalTarget::Pipeline(PipelineArgs {
                arms: vec!["mine.json".into()],
                development: true,
                ..PipelineArgs::default()
            }),
        ];
        for t in &fixtures {
            assert!(t.needs_own_out().is_none(), "{t:?}");
        }
    }

    /// The same rule on command lines as clap parses them: the fixtures' own command lines
    /// (clap's defaults, which the `Default`s above must equal) are not refused.
    #[test]
    fn own_studies_on_the_command_line() {
        #[derive(clap::Parser)]
        struct Line {
            #[command(flatten)]
            eval: EvalArgs,
        }
        let needs = |line: &str| {
            let parsed = <Line as clap::Parser>::try_parse_from(
                std::iter::once("eval").chain(line.split_whitespace()),
            )
            .unwrap_or_else(|e| panic!("{line}: {e}"));
            parsed
                .eval
                .target
                .and_then(|t| t.needs_own_out().map(str::to_owned))
        };
        for line in [
            "servo",
            "servo --seed 2009",
            "servo --development",
            "tracking",
            "tracking --rc-car-development",
            "paper-a",
            "paper-a --preset larsson2009 --sequences leuven,boat,graf",
            "pipeline",
            "pipeline --development",
        ] {
            assert_eq!(needs(line), None, "{line}");
        }
        for line in [
            "servo --arm mine.json",
            "servo --seed 7",
            "servo --percept simulated",
            "tracking --train a --test b",
            "tracking --validation-only",
            "paper-a --delta 5",
            "paper-a --preset opencv",
            "paper-a --sequences bikes",
            "pipeline --arm mine.json",
        ] {
            assert!(needs(line).is_some(), "{line}");
        }
    }

    #[test]
    fn a_target_that_wrote_nothing_leaves_its_folder_unless_checked() {
        // The target's own folder: replaced when written, kept when empty, compared by --check.
        assert!(replaces_destination(true, false, false));
        assert!(!replaces_destination(true, false, true));
        assert!(replaces_destination(true, true, true));
        // A sibling: only when written, with or without --check.
        assert!(replaces_destination(false, false, false));
        assert!(!replaces_destination(false, false, true));
        assert!(!replaces_destination(false, true, true));
    }
}
