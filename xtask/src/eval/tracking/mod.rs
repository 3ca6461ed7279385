//! `cargo xtask eval tracking`: Paper B's study. Channel Based Tracking (second order, first
//! order, online) against a constant-velocity Kalman filter with nearest-neighbour gating and
//! SIR particle filters with 100, 1,000 and 10,000 particles, on
//!
//! - synthetic RC-car-following sequences at five difficulty levels (docs/methods.md § Tracking; 4
//!   training sequences of 300 frames and 5 test sequences of 150 frames per level),
//! - the UNGM benchmark of Arulampalam et al. (docs/methods.md § Tracking; CBT learns its models
//!   from 20 simulated training runs),
//! - or the user's own CSV sequences (`--train DIR --test DIR`).
//!
//! Writes into `fixtures/paper-b/` (or `--out`): one JSON per set, `summary.md`, and SVG
//! plots (trajectories of two sequences, RMSE against clutter rate). No timings: those are
//! `cargo xtask bench tracking`'s.

pub mod pedestrians;
mod plots;
mod rc_dev;
pub mod study;
mod summary;

use std::path::{Path, PathBuf};

use cbt_tracker::sim::{Level, Scenario, Ungm, generate, observe};
use cbt_tracker::{Sequence, csv, mot};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;

use super::{EvalContext, write_json};
use crate::Result;
use study::{SetKind, SetResult, SetSpec, aggregate, run_set};

/// Options of `cargo xtask eval tracking`.
#[derive(Args, Clone, Debug, Default)]
pub struct TrackingArgs {
    /// Folder of training sequences (`*.csv`, header `frame,kind,x,y`); needs `--test`.
    #[arg(long, requires = "test", value_name = "DIR")]
    pub train: Option<PathBuf>,
    /// Folder of test sequences; needs `--train`.
    #[arg(long, requires = "train", value_name = "DIR")]
    pub test: Option<PathBuf>,
    /// Image width for CSV data (default: the data's extent).
    #[arg(long)]
    pub width: Option<f64>,
    /// Image height for CSV data (default: the data's extent).
    #[arg(long)]
    pub height: Option<f64>,
    /// Also write the synthetic sequences as CSV below DIR (`<set>/train`, `<set>/test`).
    #[arg(long, value_name = "DIR")]
    pub write_csv: Option<PathBuf>,
    /// Format of the `--train` / `--test` files: `csv` (`*.csv`, `frame,kind,x,y`) or `mot`
    /// (MOTChallenge ground truth `*.txt`, one single-target sequence per id, box centre as
    /// truth).
    #[arg(long, value_enum, default_value_t = Format::Csv)]
    pub format: Format,
    /// Detections simulated on sequences that hold none (MOT ground truth): `easy` (P_D 1,
    /// σ 2 px, no clutter), `medium` (0.9, 4 px, 2 a frame) or `hard` (0.7, 6 px, 6 a frame).
    #[arg(long, value_enum, default_value_t = Difficulty::Medium)]
    pub level: Difficulty,
    /// Development runs: only the pedestrian study, only the folds of its validation scenes
    /// (both trainings, every level; the synthetic sets are skipped). Its summary and folds
    /// go into the target's pedestrian folder (use `--out DIR`: `DIR-pedestrians`).
    #[arg(long, conflicts_with = "train")]
    pub validation_only: bool,
    /// With `--validation-only`: run only the trackers whose label starts with PREFIX (e.g.
    /// `CBT`; ending in `$`: the label exactly, e.g. `CBT 2nd order$`), the rows of the others
    /// are left out.
    #[arg(long, value_name = "PREFIX", requires = "validation_only")]
    pub trackers: Option<String>,
    /// With `--validation-only`: CBT's system-model smoothing chosen by held-out likelihood
    /// (`cbt_tracker::Smoothing::HeldOut`) instead of the fixed constants of
    /// `CbtConfig::stationary`.
    #[arg(long, requires = "validation_only")]
    pub held_out_smoothing: bool,
    /// Development runs: CBT (second order) on the synthetic RC-car levels with test
    /// sequences of development seeds (not the study's), mean RMSE per level printed, nothing
    /// written. Combines with the CBT options below.
    #[arg(long, conflicts_with_all = ["train", "validation_only"])]
    pub rc_car_development: bool,
    /// With `--validation-only` or `--rc-car-development`: CBT's first step after a start
    /// predicts with this start motion (`cbt_tracker::StartMotion`) instead of
    /// `CbtConfig::stationary`'s.
    #[arg(long, value_enum)]
    pub start_motion: Option<StartArg>,
    /// With `--validation-only` or `--rc-car-development`: CBT's system model counts its
    /// displacements this way (`cbt_tracker::Displacements`) instead of
    /// `CbtConfig::stationary`'s.
    #[arg(long, value_enum)]
    pub displacements: Option<DisplacementsArg>,
    /// With `--validation-only` or `--rc-car-development`: CBT's observation model smoothed
    /// this way (`cbt_tracker::ObservationSmoothing`) instead of `CbtConfig::stationary`'s.
    #[arg(long, value_enum)]
    pub observation_smoothing: Option<ObservationArg>,
    /// With `--validation-only` or `--rc-car-development`: how CBT's second order carries
    /// the velocity (`cbt_tracker::Velocity`) instead of `CbtConfig::stationary`'s.
    #[arg(long, value_enum)]
    pub velocity: Option<VelocityArg>,
}

/// `--velocity`.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum VelocityArg {
    /// `Velocity::Factored`.
    Factored,
    /// `Velocity::PerPosition`.
    PerPosition,
}

/// `--observation-smoothing`.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum ObservationArg {
    /// `ObservationSmoothing::Counted`.
    Counted,
    /// `ObservationSmoothing::HeldOut`.
    HeldOut,
}

/// `--displacements`.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum DisplacementsArg {
    /// `Displacements::Channels`.
    Channels,
    /// `Displacements::Interpolated`.
    Interpolated,
    /// `Displacements::Aligned`.
    Aligned,
    /// `Displacements::Selected`.
    Selected,
    /// `Displacements::Fitted`.
    Fitted,
}

impl DisplacementsArg {
    /// The library's value.
    pub fn displacements(self) -> cbt_tracker::Displacements {
        match self {
            DisplacementsArg::Channels => cbt_tracker::Displacements::Channels,
            DisplacementsArg::Interpolated => cbt_tracker::Displacements::Interpolated,
            DisplacementsArg::Aligned => cbt_tracker::Displacements::Aligned,
            DisplacementsArg::Selected => cbt_tracker::Displacements::Selected,
            DisplacementsArg::Fitted => cbt_tracker::Displacements::Fitted,
        }
    }
}

/// `--start-motion`.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum StartArg {
    /// `StartMotion::Marginal`.
    Marginal,
    /// `StartMotion::Learned`.
    Learned,
    /// `StartMotion::Pooled`.
    Pooled,
}

/// File format of the user's sequences.
#[derive(clap::ValueEnum, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Format {
    /// `frame,kind,x,y` CSV files.
    #[default]
    Csv,
    /// MOTChallenge ground truth.
    Mot,
}

/// Simulated detector difficulty (the levels of the pedestrian study).
#[derive(clap::ValueEnum, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Difficulty {
    /// P_D 1, σ 2 px, no clutter.
    Easy,
    /// P_D 0.9, σ 4 px, 2 clutter detections a frame.
    #[default]
    Medium,
    /// P_D 0.7, σ 6 px, 6 clutter detections a frame.
    Hard,
}

impl Difficulty {
    /// All three, easy first.
    pub const ALL: [Difficulty; 3] = [Difficulty::Easy, Difficulty::Medium, Difficulty::Hard];

    /// The detector level.
    pub fn level(self) -> Level {
        let (name, clutter_rate, p_detect, noise_sigma) = match self {
            Difficulty::Easy => ("easy", 0.0, 1.0, 2.0),
            Difficulty::Medium => ("medium", 2.0, 0.9, 4.0),
            Difficulty::Hard => ("hard", 6.0, 0.7, 6.0),
        };
        Level {
            name: name.into(),
            clutter_rate,
            p_detect,
            noise_sigma,
        }
    }
}

/// Track-loss radius on the image sets: 2.5 × the largest detection noise σ (8 px).
pub const IMAGE_LOSS_RADIUS: f64 = 20.0;
/// Track-loss radius on UNGM: about 1.6 process-noise σ (√10).
pub const UNGM_LOSS_RADIUS: f64 = 5.0;

/// Test sequences per synthetic level.
pub const TEST_PER_LEVEL: usize = 5;

/// The synthetic sets: levels L0–L4 (with `test_per_level` test sequences of `frames`
/// frames each) and UNGM.
pub fn synthetic_sets(
    test_per_level: usize,
    frames: usize,
    levels: &[usize],
) -> Result<Vec<SetSpec>> {
    let sc = Scenario::default();
    let mut sets: Vec<SetSpec> = levels
        .iter()
        .map(|&i| {
            let lv = Level::preset(i);
            Ok(SetSpec {
                name: format!("rc-car-{}", lv.name),
                description: format!(
                    "Synthetic RC-car following, {}×{} px, level {}: clutter {} per frame \
                     (Poisson, uniform), P_D = {}, detection noise σ = {} px; 4 training \
                     sequences × 300 frames (seed {}), {} test sequences × {} frames (seed {}).",
                    sc.width,
                    sc.height,
                    lv.name,
                    lv.clutter_rate,
                    lv.p_detect,
                    lv.noise_sigma,
                    1000 + i,
                    test_per_level,
                    frames,
                    2000 + i
                ),
                clutter_rate: Some(lv.clutter_rate),
                kind: SetKind::Image {
                    x_lo: 0.0,
                    x_hi: sc.width,
                    y_lo: 0.0,
                    y_hi: sc.height,
                },
                train: generate(&sc, &lv, 4, 300, 1000 + i as u64)?,
                test: generate(&sc, &lv, test_per_level, frames, 2000 + i as u64)?,
                radius: IMAGE_LOSS_RADIUS,
                seed: 5000 + 100 * i as u64,
            })
        })
        .collect::<Result<_>>()?;
    let u = Ungm::default();
    sets.push(SetSpec {
        name: "ungm".into(),
        description: format!(
            "UNGM (Arulampalam et al. 2002): x_k = x/2 + 25x/(1+x²) + 8cos(1.2k) + v, \
             z = x²/20 + n, v ~ N(0, 10), n ~ N(0, 1), x_0 = 0.1; 20 training runs × 100 \
             steps (seed 3000), {} test runs × 100 steps (seed 3001). The Kalman filter does \
             not apply (non-linear, sign-ambiguous measurement). PF 100/1000/10000 use the \
             true model, time step k included; CBT learns a time-independent model and cannot \
             know the 8cos(1.2k) drive. The like-for-like rows: *CBT 1st order + phase* is \
             given k as a known input (its first-order model conditioned on the phase \
             1.2k mod 2π in {} periodic channels, learned from the same training runs); \
             *PF 1000 learned* knows only CBT's learned first-order models (transition and \
             likelihood, no k), *PF 1000 learned + phase* the phase-conditioned ones.",
            2 * test_per_level,
            study::UNGM_PHASE_CHANNELS
        ),
        clutter_rate: None,
        kind: SetKind::Ungm,
        train: u.generate(20, 100, 3000)?,
        test: u.generate(2 * test_per_level, 100, 3001)?,
        radius: UNGM_LOSS_RADIUS,
        seed: 9000,
    });
    Ok(sets)
}

/// The protocol paragraph of the synthetic study.
fn protocol(sets: &[SetSpec]) -> String {
    let n: usize = sets.iter().map(|s| s.test.len()).sum();
    format!(
        "{n} test sequences in {} sets. CBT learns both models from the training sequences' \
         unordered sets of truths and detections (no associations). Image sets: the stationary \
         layout (shift-invariant models pooled over the grid by displacement: per-axis \
         first- and second-order motion, a joint 2-D observation kernel with the learned \
         detection probability and clutter density; the posterior held jointly on the window \
         of its support, the velocity carried in the state; `CbtConfig::stationary`: \
         constant-velocity fallback for thinly trained velocities, prior weight 10, motion \
         counted at the states' interpolated coordinates, the first step after a start \
         predicted with a start density learned from the training runs' first steps), \
         channel spacing 0.75 × the training data's \
         detection noise. UNGM: the dense separable layout (measurement ≠ state), spacing 1. \
         The baselines' parameters (σ_a, σ_z, P_D, clutter rate) are calibrated on the same \
         training data. Track-loss radius: {} px on the image sets, {} on UNGM.",
        sets.len(),
        IMAGE_LOSS_RADIUS,
        UNGM_LOSS_RADIUS
    )
}

#[derive(Serialize)]
struct SetFile<'a> {
    #[serde(flatten)]
    result: &'a SetResult,
    aggregate: Vec<study::Aggregate>,
}

/// Why the study must be written to a folder the user names, if it must: the user's own
/// sequences (`--train`/`--test`) or the validation scenes alone make a study other than
/// `fixtures/paper-b`'s or `fixtures/paper-b-pedestrians`'s, which it would replace (and
/// `--check` fail). `--rc-car-development` prints and writes nothing.
pub fn needs_own_out(args: &TrackingArgs) -> Option<&'static str> {
    (args.train.is_some() || args.validation_only).then_some(
        "eval tracking --train/--test or --validation-only writes a study of its own: name a \
         folder with --out (fixtures/paper-b holds the shipped study), and no --check",
    )
}

/// Runs the target.
pub fn run(ctx: &EvalContext, args: &TrackingArgs) -> Result<()> {
    if let Some(m) = args.start_motion {
        if !(args.validation_only || args.rc_car_development) {
            return Err("--start-motion needs --validation-only or --rc-car-development".into());
        }
        study::set_start(match m {
            StartArg::Marginal => cbt_tracker::StartMotion::Marginal,
            StartArg::Learned => cbt_tracker::StartMotion::Learned,
            StartArg::Pooled => cbt_tracker::StartMotion::Pooled,
        });
    }
    if let Some(m) = args.displacements {
        if !(args.validation_only || args.rc_car_development) {
            return Err("--displacements needs --validation-only or --rc-car-development".into());
        }
        study::set_displacements(m.displacements());
    }
    if let Some(m) = args.observation_smoothing {
        if !(args.validation_only || args.rc_car_development) {
            return Err(
                "--observation-smoothing needs --validation-only or --rc-car-development".into(),
            );
        }
        study::set_observation(match m {
            ObservationArg::Counted => cbt_tracker::ObservationSmoothing::Counted,
            ObservationArg::HeldOut => cbt_tracker::ObservationSmoothing::HeldOut,
        });
    }
    if let Some(v) = args.velocity {
        if !(args.validation_only || args.rc_car_development) {
            return Err("--velocity needs --validation-only or --rc-car-development".into());
        }
        study::set_velocity(match v {
            VelocityArg::Factored => cbt_tracker::Velocity::Factored,
            VelocityArg::PerPosition => cbt_tracker::Velocity::PerPosition,
        });
    }
    if args.rc_car_development {
        return rc_dev::run();
    }
    if args.validation_only {
        if args.held_out_smoothing {
            study::set_smoothing(cbt_tracker::Smoothing::HeldOut);
        }
        return run_pedestrians(ctx, args);
    }
    let specs = match (&args.train, &args.test) {
        (Some(train), Some(test)) => vec![user_set(train, test, args)?],
        _ => synthetic_sets(TEST_PER_LEVEL, 150, &[0, 1, 2, 3, 4])?,
    };
    if let Some(dir) = &args.write_csv {
        for s in &specs {
            for (part, seqs) in [("train", &s.train), ("test", &s.test)] {
                for q in seqs {
                    csv::write(&dir.join(&s.name).join(part), q)?;
                }
            }
        }
        eprintln!("wrote the sequences as CSV below {}", dir.display());
    }
    let total: usize = specs.iter().map(|s| s.test.len()).sum();
    let pb = ProgressBar::new(total as u64);
    pb.set_style(
        ProgressStyle::with_template("{prefix:>12} [{bar:30}] {pos}/{len} sequences {elapsed}")
            .map_err(|e| e.to_string())?
            .progress_chars("=> "),
    );
    let mut results = Vec::new();
    for s in &specs {
        pb.set_prefix(s.name.clone());
        results.push(run_set(s, &pb)?);
    }
    pb.finish_and_clear();
    for r in &results {
        write_json(
            &ctx.out_dir,
            &format!("{}.json", r.set),
            &SetFile {
                result: r,
                aggregate: aggregate(&[r]),
            },
        )?;
    }
    let text = if args.train.is_some() {
        summary::render(
            &results,
            &format!(
                "User sequences: training from {}, test from {}.",
                args.train
                    .as_ref()
                    .map_or(String::new(), |p| p.display().to_string()),
                args.test
                    .as_ref()
                    .map_or(String::new(), |p| p.display().to_string())
            ),
        )
    } else {
        summary::render(&results, &protocol(&specs))
    };
    std::fs::write(ctx.out_dir.join("summary.md"), text)?;
    // Trajectories of two sequences: the first test sequences of the middle and a hard level
    // (or the user's first two).
    let picks: Vec<(usize, usize)> = if args.train.is_some() {
        (0..specs[0].test.len().min(2)).map(|i| (0, i)).collect()
    } else {
        vec![(2, 0), (3, 0)]
    };
    for (set, seq) in picks {
        let name = format!("trajectories-{}-{}.svg", results[set].set, seq);
        plots::trajectories(
            &results[set],
            &specs[set].test[seq],
            seq,
            &ctx.out_dir.join(name),
        )?;
    }
    let image: Vec<&SetResult> = results
        .iter()
        .filter(|r| r.clutter_rate.is_some())
        .collect();
    if image.len() > 1 {
        plots::rmse_vs_clutter(&image, &ctx.out_dir.join("rmse-vs-clutter.svg"))?;
    }
    if args.train.is_none() {
        run_pedestrians(ctx, args)?;
    }
    Ok(())
}

/// Name of the pedestrian study's fixture folder, beside the target's own.
pub const PEDESTRIANS_DIR: &str = "paper-b-pedestrians";

/// The real-motion study, when `pedestrians/` is in the data folder: written into
/// [`PEDESTRIANS_DIR`] beside the target's folder. Without the data it is skipped with a note
/// (its committed fixtures untouched); under `CI=true` a missing data folder is an error.
fn run_pedestrians(ctx: &EvalContext, args: &TrackingArgs) -> Result<()> {
    let Some(dir) = pedestrians::folder(ctx.data_dir.as_deref()) else {
        let why = "the pedestrian study needs `pedestrians/eth-ucy/` in the data folder \
                   (--data or VISGUIDE_DATA)";
        if std::env::var("CI").is_ok_and(|v| v == "true") {
            return Err(format!("{why}; under CI=true it must run").into());
        }
        eprintln!("note: skip {PEDESTRIANS_DIR}: {why}");
        return Ok(());
    };
    // Staged beside the target's own folder (`fixtures/paper-b-pedestrians`, `DIR-pedestrians`).
    let out = ctx.sibling("-pedestrians");
    let scenes = pedestrians::load(&dir)?;
    let only = pedestrians::Only {
        validation: args.validation_only,
        trackers: args.trackers.clone(),
    };
    let folds = pedestrians::run(&scenes, &only)?;
    let text = pedestrians::summary(&scenes, &folds);
    std::fs::create_dir_all(&out)?;
    write_json(&out, "folds.json", &folds)?;
    std::fs::write(out.join("summary.md"), text)?;
    Ok(())
}

/// The user's CSV sequences as one image set.
fn user_set(train: &Path, test: &Path, args: &TrackingArgs) -> Result<SetSpec> {
    let read = |dir: &Path| -> Result<Vec<Sequence>> {
        Ok(match args.format {
            Format::Csv => csv::read_dir(dir)?,
            Format::Mot => mot::read_dir(dir)?,
        })
    };
    let (mut train, mut test) = (read(train)?, read(test)?);
    for s in &test {
        let scored = s.start().map_or(0, |k| {
            s.frames[k + 1..]
                .iter()
                .filter(|f| f.truth.is_some())
                .count()
        });
        if scored == 0 {
            return Err(format!(
                "test sequence {}: no frame with a truth after its first one (nothing to score)",
                s.name
            )
            .into());
        }
    }
    let Some((lo, hi)) = Sequence::bounds(train.iter().chain(&test)) else {
        return Err("the CSV sequences hold no positions".into());
    };
    let (x_lo, x_hi) = match args.width {
        Some(w) => (0.0, w),
        None => (lo[0].min(0.0), hi[0] + 1.0),
    };
    let (y_lo, y_hi) = match args.height {
        Some(h) => (0.0, h),
        None => (lo[1].min(0.0), hi[1] + 1.0),
    };
    // Sequences without a single detection (ground truth only) get simulated ones.
    let level = args.level.level();
    let mut simulated = 0;
    for (part, seqs) in [(0u64, &mut train), (1, &mut test)] {
        for (i, s) in seqs.iter_mut().enumerate() {
            if s.frames.iter().all(|f| f.detections.is_empty()) {
                let seed = 7000 + part;
                *s = observe(s, &level, [x_lo, x_hi, y_lo, y_hi], seed, i as u64)?;
                simulated += 1;
            }
        }
    }
    let frames: usize = test.iter().map(|s: &Sequence| s.frames.len()).sum();
    Ok(SetSpec {
        name: "user".into(),
        description: format!(
            "{} training and {} test sequences ({} test frames) on [{x_lo}, {x_hi}] × \
             [{y_lo}, {y_hi}]{}.",
            train.len(),
            test.len(),
            frames,
            if simulated > 0 {
                format!(
                    "; detections simulated at level {} on {simulated} sequences without \
                     any (seeds 7000 training, 7001 test)",
                    level.name
                )
            } else {
                String::new()
            }
        ),
        clutter_rate: None,
        kind: SetKind::Image {
            x_lo,
            x_hi,
            y_lo,
            y_hi,
        },
        train,
        test,
        radius: IMAGE_LOSS_RADIUS,
        seed: 5000,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The summary of a small synthetic study (levels L1 and L3, two 40-frame test
    /// sequences each, plus UNGM), as a snapshot.
    #[test]
    fn summary_snapshot() {
        let specs = synthetic_sets(2, 40, &[1, 3]).unwrap();
        let pb = ProgressBar::hidden();
        let results: Vec<SetResult> = specs.iter().map(|s| run_set(s, &pb).unwrap()).collect();
        insta::assert_snapshot!(summary::render(&results, &protocol(&specs)));
    }

    /// MOTChallenge ground truth (frames from 1, ids starting late) and a CSV file that starts
    /// at frame 5 with detections before its first truth: read, detections simulated where
    /// there are none, every tracker run from each sequence's first truth.
    #[test]
    fn users_files_as_they_come() {
        let dir = std::env::temp_dir().join(format!("visguide-mot-{}", std::process::id()));
        std::fs::remove_dir_all(&dir).ok();
        for part in ["train", "test"] {
            std::fs::create_dir_all(dir.join(part)).unwrap();
        }
        let walk = |id: usize, from: usize, n: usize, x0: f64| -> String {
            (0..n)
                .map(|k| format!("{},{id},{},60,10,20,1,1,1\n", from + k, x0 + 2.0 * k as f64))
                .collect()
        };
        std::fs::write(
            dir.join("train/gt.txt"),
            format!("\u{feff}{}{}", walk(1, 1, 60, 20.0), walk(2, 10, 50, 40.0)),
        )
        .unwrap();
        std::fs::write(dir.join("test/gt.txt"), walk(7, 30, 25, 30.0)).unwrap();
        let args = TrackingArgs {
            train: Some(dir.join("train")),
            test: Some(dir.join("test")),
            width: Some(200.0),
            height: Some(150.0),
            format: Format::Mot,
            level: Difficulty::Easy,
            ..Default::default()
        };
        let set = user_set(&dir.join("train"), &dir.join("test"), &args).unwrap();
        assert_eq!((set.train.len(), set.test.len()), (2, 1));
        assert_eq!(set.test[0].first_frame, 30);
        assert!(
            set.description
                .contains("simulated at level easy on 3 sequences")
        );
        // Easy level: one detection per frame, near the box centre.
        for f in &set.test[0].frames {
            let t = f.truth.unwrap();
            assert_eq!(f.detections.len(), 1);
            assert!((f.detections[0].pos[0] - t[0]).abs() < 10.0);
        }
        let r = run_set(&set, &ProgressBar::hidden()).unwrap();
        for run in &r.sequences[0].runs {
            assert_eq!(run.score.frames, 24, "{}", run.tracker);
            if run.tracker.starts_with("CBT") {
                assert!(run.score.rmse < 5.0, "{} {}", run.tracker, run.score.rmse);
            }
        }
        // A one-frame id is refused with its file and line.
        std::fs::write(dir.join("test/gt.txt"), "3,9,1,1,2,2\n").unwrap();
        let e = user_set(&dir.join("train"), &dir.join("test"), &args)
            .err()
            .expect("a one-frame id is an error");
        assert!(e.to_string().contains("gt.txt:1:"), "{e}");
        // CSV: a file starting at frame 5 with a detection before its first truth.
        let csv_args = TrackingArgs {
            format: Format::Csv,
            ..args
        };
        let test = dir.join("csvtest");
        std::fs::create_dir_all(&test).unwrap();
        let train = dir.join("csvtrain");
        for q in &set.train {
            csv::write(&train, q).unwrap();
        }
        let mut text = String::from("frame,kind,x,y\n5,det,50,60\n");
        for k in 6..30 {
            let x = 30.0 + 2.0 * (k - 6) as f64;
            text.push_str(&format!("{k},truth,{x},60\n{k},det,{x},60\n"));
        }
        std::fs::write(test.join("late.csv"), &text).unwrap();
        let mut set = user_set(&train, &test, &csv_args).unwrap();
        assert_eq!((set.test[0].first_frame, set.test[0].start()), (5, Some(1)));
        set.test.truncate(1);
        let r = run_set(&set, &ProgressBar::hidden()).unwrap();
        assert_eq!(r.sequences[0].runs[0].score.frames, 23);
        // A test file whose only truth is its last frame has nothing to score.
        std::fs::write(
            test.join("late.csv"),
            "frame,kind,x,y\n5,det,1,1\n6,truth,1,1\n",
        )
        .unwrap();
        let e = user_set(&train, &test, &csv_args)
            .err()
            .expect("nothing to score is an error");
        assert!(e.to_string().contains("late"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn csv_study_runs_on_written_sequences() {
        let dir = std::env::temp_dir().join(format!("visguide-tracking-{}", std::process::id()));
        std::fs::remove_dir_all(&dir).ok();
        let specs = synthetic_sets(1, 30, &[2]).unwrap();
        for (part, seqs) in [("train", &specs[0].train), ("test", &specs[0].test)] {
            for q in seqs {
                csv::write(&dir.join(part), q).unwrap();
            }
        }
        let args = TrackingArgs {
            train: Some(dir.join("train")),
            test: Some(dir.join("test")),
            width: Some(320.0),
            height: Some(240.0),
            ..Default::default()
        };
        let user = user_set(&dir.join("train"), &dir.join("test"), &args).unwrap();
        let pb = ProgressBar::hidden();
        let a = run_set(&user, &pb).unwrap();
        let b = run_set(&specs[0], &pb).unwrap();
        // Same data, same seeds of the trackers' randomness except the set seed: CBT and
        // Kalman (deterministic) give identical scores.
        for (x, y) in a.sequences[0].runs.iter().zip(&b.sequences[0].runs).take(4) {
            assert_eq!(x.tracker, y.tracker);
            assert_eq!(x.score, y.score);
        }
        std::fs::remove_dir_all(&dir).ok();
    }
}
