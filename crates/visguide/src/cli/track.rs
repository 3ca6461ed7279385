//! `visguide track`: channel-based tracking (Paper B) learned from the user's CSV sequences.

use std::io::Write;
use std::path::{Path, PathBuf};

use cbt_tracker::{
    Calibration, CbtConfig, CbtModel, CbtTracker, KalmanParams, KalmanTracker, Layout,
    ParticleFilter, PfModel, Point, Scales, Sequence, Space, TrackError, Tracker, axis, csv,
};
use clap::{Args, Subcommand};
use visguide::models::{CBT_FORMAT, MODEL_VERSION, TrackModelFile};
use visguide::output::atomic::write_atomic;

use super::CliResult;
use super::common::Ui;

/// Track one object through a sequence of frame-wise detections with Channel Based Tracking.
///
/// Sequences are CSV files `frame,kind,x,y` with rows `FRAME,truth,X,Y` (at most one per
/// frame) and `FRAME,det,X,Y` (any number per frame, clutter included). CBT learns its
/// motion and observation models from training sequences with truth (no associations needed).
/// The track starts at the first frame's truth (or its first detection) and is written as CSV
/// `frame,tracker,x,y,certainty`. One step: `track --train DIR SEQ.csv`; two steps: `track
/// learn` writes a model file, `track run` uses it.
#[derive(Args, Debug)]
#[command(
    args_conflicts_with_subcommands = true,
    after_help = "Examples:
  visguide track --train train/ test/seq01.csv --out seq01-track.csv --baselines
  visguide track learn --train train/ --model cars.cbt.json
  visguide track run cars.cbt.json test/seq01.csv --out seq01-track.csv"
)]
pub struct TrackArgs {
    #[command(subcommand)]
    pub command: Option<TrackCommand>,
    /// Folder of training sequences (`*.csv` with truth).
    #[arg(long, value_name = "DIR")]
    pub train: Option<PathBuf>,
    /// The sequence to track.
    #[arg(value_name = "SEQUENCE.csv")]
    pub sequence: Option<PathBuf>,
    #[command(flatten)]
    pub run: RunOptions,
}

/// The two steps.
#[derive(Subcommand, Debug)]
pub enum TrackCommand {
    /// Learn CBT (and the baselines' calibration) from training sequences; write a model file.
    Learn {
        /// Folder of training sequences (`*.csv` with truth).
        #[arg(long, value_name = "DIR")]
        train: PathBuf,
        /// Where the model goes.
        #[arg(long, default_value = "model.cbt.json", value_name = "FILE")]
        model: PathBuf,
    },
    /// Track a sequence with a model file written by `track learn`.
    Run {
        /// The model file.
        model: PathBuf,
        /// The sequence to track.
        sequence: PathBuf,
        #[command(flatten)]
        run: RunOptions,
    },
}

/// Options of a tracking run.
#[derive(Args, Debug, Clone)]
pub struct RunOptions {
    /// Output CSV (default: standard output).
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Also run the baselines: a constant-velocity Kalman filter with nearest-neighbour
    /// association and a particle filter (1000 particles).
    #[arg(long)]
    pub baselines: bool,
    /// Seed of the particle filter.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
}

/// Runs the subcommand.
pub fn run(a: &TrackArgs, ui: Ui) -> CliResult {
    match &a.command {
        Some(TrackCommand::Learn { train, model }) => {
            let m = learn(train)?;
            m.save(model)?;
            ui.say(format!(
                "learned from {} sequences on [{}, {}] × [{}, {}] → {}",
                m.sequences,
                m.extent[0],
                m.extent[1],
                m.extent[2],
                m.extent[3],
                model.display()
            ));
            Ok(())
        }
        Some(TrackCommand::Run {
            model,
            sequence,
            run,
        }) => {
            let m = TrackModelFile::load(model)?;
            track(&m, sequence, run, ui)
        }
        None => {
            let (Some(train), Some(seq)) = (&a.train, &a.sequence) else {
                return Err("track needs --train DIR and SEQUENCE.csv (or the subcommands learn / run; see visguide track --help)".into());
            };
            let m = learn(train)?;
            track(&m, seq, &a.run, ui)
        }
    }
}

fn read_train(dir: &Path) -> CliResult<Vec<Sequence>> {
    if !dir.is_dir() {
        return Err(format!(
            "{}: expected a directory of training sequences (*.csv)",
            dir.display()
        )
        .into());
    }
    let train = csv::read_dir(dir)?;
    if train.is_empty() {
        return Err(format!("{}: no .csv sequences in it", dir.display()).into());
    }
    Ok(train)
}

/// Learns the model file's contents from a training folder (the image layout of
/// `cargo xtask eval tracking`: stationary models on a grid as fine as the detection noise).
fn learn(dir: &Path) -> CliResult<TrackModelFile> {
    let train = read_train(dir)?;
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    for s in &train {
        for f in &s.frames {
            for p in f.truth.iter().chain(f.detections.iter().map(|d| &d.pos)) {
                for d in 0..2 {
                    lo[d] = lo[d].min(p[d]);
                    hi[d] = hi[d].max(p[d]);
                }
            }
        }
    }
    if !lo[0].is_finite() {
        return Err(format!("{}: the sequences hold no positions", dir.display()).into());
    }
    // A margin of a tenth of the extent so a test track may leave the training area a little.
    let margin = [(hi[0] - lo[0]) * 0.1 + 1.0, (hi[1] - lo[1]) * 0.1 + 1.0];
    let extent = [
        lo[0] - margin[0],
        hi[0] + margin[0],
        lo[1] - margin[1],
        hi[1] + margin[1],
    ];
    let size = (extent[1] - extent[0]).min(extent[3] - extent[2]);
    let spacing = Scales::estimate(&train, size)?.fine_spacing(size);
    let kernel = cbt_tracker::DEFAULT_KERNEL;
    let (bx, by) = (
        axis(extent[0], extent[1], spacing, kernel)?,
        axis(extent[2], extent[3], spacing, kernel)?,
    );
    let space = Space::new(vec![bx.clone(), by.clone()], vec![bx, by])?;
    let cfg = CbtConfig {
        layout: Layout::Stationary,
        ..CbtConfig::default()
    };
    let cbt = CbtModel::learn_sequences(space, cfg, &train)?;
    let calibration = Calibration::estimate(&train, size / 10.0)?;
    Ok(TrackModelFile {
        format: CBT_FORMAT.into(),
        version: MODEL_VERSION,
        extent,
        sequences: train.len(),
        cbt,
        calibration,
    })
}

fn run_one(
    t: &mut dyn Tracker,
    s: &Sequence,
    start: Point,
) -> CliResult<Vec<(Point, Option<f64>)>> {
    t.reset(start)?;
    let mut out = vec![(start, None)];
    for f in &s.frames[1..] {
        let e = match t.step(&f.detections) {
            Ok(e) => e,
            // Detections off the grid count as an empty frame.
            Err(TrackError::OutsideGrid { .. }) => t.step(&[])?,
            Err(e) => return Err(e.into()),
        };
        out.push((e.position, e.certainty));
    }
    Ok(out)
}

fn track(m: &TrackModelFile, seq: &Path, o: &RunOptions, ui: Ui) -> CliResult {
    if seq.is_dir() {
        return Err(format!(
            "{}: is a directory, expected a sequence CSV file",
            seq.display()
        )
        .into());
    }
    let s = csv::read(seq)?;
    let Some(first) = s.frames.first() else {
        return Err(format!("{}: the sequence has no frames", seq.display()).into());
    };
    let start = first
        .truth
        .or_else(|| first.detections.first().map(|d| d.pos))
        .ok_or_else(|| {
            format!(
                "{}: frame 0 has neither truth nor a detection to start from",
                seq.display()
            )
        })?;
    let mut trackers: Vec<Box<dyn Tracker>> = vec![Box::new(CbtTracker::new(m.cbt.clone()))];
    if o.baselines {
        let area = (m.extent[1] - m.extent[0]) * (m.extent[3] - m.extent[2]);
        trackers.push(Box::new(KalmanTracker::new(
            KalmanParams::from_calibration(&m.calibration),
        )?));
        trackers.push(Box::new(ParticleFilter::new(
            PfModel::from_calibration(&m.calibration, area),
            1000,
            o.seed,
        )?));
    }
    let bar = ui.bar(trackers.len() as u64, "tracking");
    let mut runs = Vec::new();
    for t in &mut trackers {
        runs.push((t.name(), run_one(t.as_mut(), &s, start)?));
        bar.inc(1);
    }
    bar.finish_and_clear();
    let fill = |w: &mut dyn Write| -> visguide::Result<()> {
        let io = |e| visguide::VisguideError::Io {
            path: o.out.clone().unwrap_or_else(|| "<stdout>".into()),
            source: e,
        };
        writeln!(w, "frame,tracker,x,y,certainty").map_err(io)?;
        for (name, est) in &runs {
            for (k, (p, c)) in est.iter().enumerate() {
                let c = c.map_or(String::new(), |c| c.to_string());
                writeln!(w, "{k},{name},{},{},{c}", p[0], p[1]).map_err(io)?;
            }
        }
        Ok(())
    };
    match &o.out {
        Some(p) => write_atomic(p, fill)?,
        None => fill(&mut std::io::stdout().lock())?,
    }
    // Mean error against the truth, where the sequence has it.
    for (name, est) in &runs {
        let errs: Vec<f64> = s
            .frames
            .iter()
            .zip(est)
            .filter_map(|(f, (p, _))| f.truth.map(|t| (t[0] - p[0]).hypot(t[1] - p[1])))
            .collect();
        if !errs.is_empty() {
            ui.say(format!(
                "{name}: {} frames, mean error to the truth {:.2}",
                est.len(),
                errs.iter().sum::<f64>() / errs.len() as f64
            ));
        }
    }
    Ok(())
}
