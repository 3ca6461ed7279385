//! `visguide track`: channel-based tracking (Paper B) learned from the user's sequences (CSV or
//! MOTChallenge ground truth).

use std::io::Write;
use std::path::{Path, PathBuf};

use cbt_tracker::{
    Calibration, CbtConfig, CbtModel, CbtTracker, KalmanParams, KalmanTracker, ParticleFilter,
    PfModel, Point, Scales, Sequence, Space, Tracker, axis, csv, mot, sim, step_on_grid,
};
use clap::{Args, Subcommand, ValueEnum};
use visguide::models::{CBT_FORMAT, MODEL_VERSION, TrackModelFile};
use visguide::output::atomic::write_atomic;

use super::CliResult;
use super::common::{Ui, check_outputs, files_in};

/// Track one object through a sequence of frame-wise detections with Channel Based Tracking.
///
/// With `--format csv` (the default) sequences are CSV files `frame,kind,x,y` with rows
/// `FRAME,truth,X,Y` (at most one per frame) and `FRAME,det,X,Y` (any number per frame, clutter
/// included). With `--format mot` they are MOTChallenge ground-truth files (`gt.txt`: rows
/// `frame,id,left,top,width,height[,flag,…]`, no header; rows flagged 0 are left out): every id
/// is one target whose truth is its box centre. CBT learns its motion and observation models
/// from training sequences with truth (no associations needed). A sequence without a single
/// detection (ground truth only, as MOTChallenge `gt.txt` files are) gets detections simulated
/// at `--sim-level` with `--sim-seed`, in the model's extent. Each target's track starts at its
/// first frame's truth (or its first detection) and is written as CSV
/// `frame,tracker,x,y,certainty` (frame numbers as in the file); with `--format mot` every id of
/// the file is tracked and a first column `target` (`<file stem>-id<ID>`) names it. One step:
/// `track --train DIR SEQ`; two steps: `track learn` writes a model file, `track run` uses it.
#[derive(Args, Debug)]
#[command(
    args_conflicts_with_subcommands = true,
    after_help = "Examples:
  visguide track --train train/ test/seq01.csv --out seq01-track.csv --baselines
  visguide track learn --train train/ --model cars.cbt.json
  visguide track run cars.cbt.json test/seq01.csv --out seq01-track.csv
  visguide track --format mot --train mot/train/ mot/test/gt.txt --out tracks.csv"
)]
pub struct TrackArgs {
    #[command(subcommand)]
    pub command: Option<TrackCommand>,
    /// Folder of training sequences (`*.csv` with truth; `*.txt` with `--format mot`).
    #[arg(long, value_name = "DIR")]
    pub train: Option<PathBuf>,
    /// The sequence to track.
    #[arg(value_name = "SEQUENCE")]
    pub sequence: Option<PathBuf>,
    #[command(flatten)]
    pub input: InputOptions,
    #[command(flatten)]
    pub run: RunOptions,
}

/// File format of the sequences.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum SeqFormat {
    /// `frame,kind,x,y` CSV files (`*.csv`).
    Csv,
    /// MOTChallenge ground truth (`*.txt`), one target per id, the box centre as truth.
    Mot,
}

/// How sequences are read, and the detections simulated on those without any.
#[derive(Args, Debug, Clone)]
pub struct InputOptions {
    /// Format of the training files and of the sequence.
    #[arg(long, value_enum, default_value = "csv")]
    pub format: SeqFormat,
    /// Detector simulated on sequences without detections: level 0 (no clutter, P_D 1, σ 1 px)
    /// to 4 (10 clutter detections a frame, P_D 0.6, σ 8 px), the levels of Paper B's study.
    #[arg(long, default_value_t = 1, value_name = "0-4",
          value_parser = clap::value_parser!(u8).range(0..=4))]
    pub sim_level: u8,
    /// Seed of the simulated detections: a training sequence named N draws from (seed, h(N)),
    /// a tracked target from (seed + 1, h(N)), h the 64-bit FNV-1a hash of the name (a file's
    /// stem, `<stem>-id<ID>` for MOTChallenge), so a target's detections depend neither on the
    /// other targets nor on the file format it came in.
    #[arg(long, default_value_t = 0, value_name = "SEED")]
    pub sim_seed: u64,
}

/// The two steps.
#[derive(Subcommand, Debug)]
pub enum TrackCommand {
    /// Learn CBT (and the baselines' calibration) from training sequences; write a model file.
    Learn {
        /// Folder of training sequences (`*.csv` with truth; `*.txt` with `--format mot`).
        #[arg(long, value_name = "DIR")]
        train: PathBuf,
        /// Where the model goes.
        #[arg(long, default_value = "model.cbt.json", value_name = "FILE")]
        model: PathBuf,
        #[command(flatten)]
        input: InputOptions,
    },
    /// Track a sequence with a model file written by `track learn`.
    Run {
        /// The model file.
        model: PathBuf,
        /// The sequence to track.
        sequence: PathBuf,
        #[command(flatten)]
        input: InputOptions,
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
        Some(TrackCommand::Learn {
            train,
            model,
            input,
        }) => {
            check_outputs(&[model], &inputs_of(train, &[]), false)?;
            let (m, simulated) = learn(train, input)?;
            m.save(model)?;
            input.say_simulated(simulated, "training sequences", ui);
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
            input,
            run,
        }) => {
            check_outputs(run.out.as_slice(), &[model, sequence], false)?;
            let m = TrackModelFile::load(model)?;
            let targets = input.read_file(sequence)?;
            track(&m, sequence, targets, input, run, ui)
        }
        None => {
            let (Some(train), Some(seq)) = (&a.train, &a.sequence) else {
                return Err("track needs --train DIR and SEQUENCE (or the subcommands learn / run; see visguide track --help)".into());
            };
            check_outputs(a.run.out.as_slice(), &inputs_of(train, &[seq]), false)?;
            // The sequence is read first: a bad file fails before any learning.
            let targets = a.input.read_file(seq)?;
            let (m, simulated) = learn(train, &a.input)?;
            track(&m, seq, targets, &a.input, &a.run, ui)?;
            a.input.say_simulated(simulated, "training sequences", ui);
            Ok(())
        }
    }
}

/// The files a run reads: those in the training folder, and `files`.
fn inputs_of(train: &Path, files: &[&Path]) -> Vec<PathBuf> {
    let mut all = files_in(train);
    all.extend(files.iter().map(|p| p.to_path_buf()));
    all
}

impl InputOptions {
    /// The file extension of a training folder's sequences.
    fn extension(&self) -> &'static str {
        match self.format {
            SeqFormat::Csv => "csv",
            SeqFormat::Mot => "txt",
        }
    }

    /// Every sequence of a training folder, in file-name order (and id order within a file).
    fn read_dir(&self, dir: &Path) -> CliResult<Vec<Sequence>> {
        if !dir.is_dir() {
            return Err(format!(
                "{}: expected a directory of training sequences (*.{})",
                dir.display(),
                self.extension()
            )
            .into());
        }
        let train = match self.format {
            SeqFormat::Csv => csv::read_dir(dir)?,
            SeqFormat::Mot => mot::read_dir(dir)?,
        };
        if train.is_empty() {
            return Err(format!(
                "{}: no .{} sequences in it",
                dir.display(),
                self.extension()
            )
            .into());
        }
        Ok(train)
    }

    /// The targets of one sequence file: a CSV file is one target (no label); a MOTChallenge
    /// file one per id, labelled with its sequence name.
    fn read_file(&self, path: &Path) -> CliResult<Targets> {
        if path.is_dir() {
            return Err(format!(
                "{}: is a directory, expected a sequence file (*.{})",
                path.display(),
                self.extension()
            )
            .into());
        }
        Ok(match self.format {
            SeqFormat::Csv => vec![(None, csv::read(path)?)],
            SeqFormat::Mot => mot::read(path)?
                .into_iter()
                .map(|s| (Some(s.name.clone()), s))
                .collect(),
        })
    }

    /// Simulates detections, in `area`, on every sequence that has none; a sequence named `N`
    /// draws from `(seed, fnv1a(N))`. Returns how many were simulated.
    fn simulate(&self, seqs: &mut [Sequence], area: [f64; 4], seed: u64) -> CliResult<usize> {
        let level = sim::Level::preset(self.sim_level as usize);
        let mut n = 0;
        for s in seqs.iter_mut() {
            if s.frames.iter().all(|f| f.detections.is_empty()) {
                *s = sim::observe(s, &level, area, seed, fnv1a(s.name.as_bytes()))?;
                n += 1;
            }
        }
        Ok(n)
    }

    fn say_simulated(&self, n: usize, what: &str, ui: Ui) {
        if n > 0 {
            ui.say(format!(
                "{n} {what} without detections: detections simulated at level L{} (seed {})",
                self.sim_level, self.sim_seed
            ));
        }
    }
}

/// 64-bit FNV-1a: the simulation stream of a sequence from its name.
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x0100_0000_01b3)
    })
}

/// Learns the model file's contents from a training folder (the image layout of
/// `cargo xtask eval tracking`: stationary models on a grid as fine as the detection noise).
/// Also returns how many training sequences got simulated detections.
fn learn(dir: &Path, input: &InputOptions) -> CliResult<(TrackModelFile, usize)> {
    let mut train = input.read_dir(dir)?;
    let Some((lo, hi)) = Sequence::bounds(&train) else {
        return Err(format!("{}: the sequences hold no positions", dir.display()).into());
    };
    // A margin of a tenth of the extent so a test track may leave the training area a little.
    let margin = [(hi[0] - lo[0]) * 0.1 + 1.0, (hi[1] - lo[1]) * 0.1 + 1.0];
    let extent = [
        lo[0] - margin[0],
        hi[0] + margin[0],
        lo[1] - margin[1],
        hi[1] + margin[1],
    ];
    let simulated = input.simulate(&mut train, extent, input.sim_seed)?;
    let size = (extent[1] - extent[0]).min(extent[3] - extent[2]);
    let spacing = Scales::estimate(&train, size)?.fine_spacing(size)?;
    let kernel = cbt_tracker::DEFAULT_KERNEL;
    let (bx, by) = (
        axis(extent[0], extent[1], spacing, kernel)?,
        axis(extent[2], extent[3], spacing, kernel)?,
    );
    let space = Space::new(vec![bx.clone(), by.clone()], vec![bx, by])?;
    // The setting chosen for real motion (see `CbtConfig::stationary`).
    let cfg = CbtConfig::stationary();
    let cbt = CbtModel::learn_sequences(space, cfg, &train)?;
    let calibration = Calibration::estimate(&train, size / 10.0)?;
    let file = TrackModelFile {
        format: CBT_FORMAT.into(),
        version: MODEL_VERSION,
        extent,
        sequences: train.len(),
        cbt,
        calibration,
    };
    Ok((file, simulated))
}

/// One estimate per frame: the position and the certainty (CBT only).
type Estimates = Vec<(Point, Option<f64>)>;

/// The estimates of one tracker on one sequence, and how many detections lay outside the
/// model's grid (left out of their frames; the frames' other detections are used).
fn run_one(t: &mut dyn Tracker, s: &Sequence, start: Point) -> CliResult<(Estimates, usize)> {
    t.reset(start)?;
    let mut out = vec![(start, None)];
    let mut left_out = 0;
    // `s` has a first frame: `track` found its start there before any tracker runs.
    for f in &s.frames[1..] {
        let (e, n) = step_on_grid(t, &f.detections)?;
        left_out += n;
        out.push((e.position, e.certainty));
    }
    Ok((out, left_out))
}

/// The labelled targets of one sequence file.
type Targets = Vec<(Option<String>, Sequence)>;

fn track(
    m: &TrackModelFile,
    seq: &Path,
    targets: Targets,
    input: &InputOptions,
    o: &RunOptions,
    ui: Ui,
) -> CliResult {
    let (labels, mut seqs): (Vec<Option<String>>, Vec<Sequence>) = targets.into_iter().unzip();
    if seqs.is_empty() {
        return Err(format!("{}: no target to track", seq.display()).into());
    }
    let simulated = input.simulate(&mut seqs, m.extent, input.sim_seed.wrapping_add(1))?;
    let mut starts = Vec::with_capacity(seqs.len());
    for (s, label) in seqs.iter().zip(&labels) {
        let Some(first) = s.frames.first() else {
            return Err(format!("{}: the sequence has no frames", seq.display()).into());
        };
        let start = first
            .truth
            .or_else(|| first.detections.first().map(|d| d.pos))
            .ok_or_else(|| {
                format!(
                    "{}: {}frame {} has neither truth nor a detection to start from",
                    seq.display(),
                    label.as_ref().map_or(String::new(), |l| format!("{l}: ")),
                    s.first_frame
                )
            })?;
        starts.push(start);
    }
    let make = || -> CliResult<Vec<Box<dyn Tracker>>> {
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
        Ok(trackers)
    };
    let per_target = if o.baselines { 3 } else { 1 };
    let bar = ui.bar((per_target * seqs.len()) as u64, "tracking");
    // (target, tracker name, estimates, detections left out)
    let mut runs = Vec::new();
    for (k, s) in seqs.iter().enumerate() {
        // Fresh trackers per target (the particle filter's draws restart from its seed).
        for mut t in make()? {
            let (est, left_out) = run_one(t.as_mut(), s, starts[k]).map_err(|e| {
                let label = labels[k]
                    .as_ref()
                    .map_or(String::new(), |l| format!(" {l}:"));
                format!("{}:{label} {}: {e}", seq.display(), t.name())
            })?;
            runs.push((k, t.name(), est, left_out));
            bar.inc(1);
        }
    }
    bar.finish_and_clear();
    let labelled = labels.iter().any(Option::is_some);
    let fill = |w: &mut dyn Write| -> visguide::Result<()> {
        let io = |e| visguide::VisguideError::Io {
            path: o.out.clone().unwrap_or_else(|| "<stdout>".into()),
            source: e,
        };
        let prefix = if labelled { "target," } else { "" };
        writeln!(w, "{prefix}frame,tracker,x,y,certainty").map_err(io)?;
        for (k, name, est, _) in &runs {
            let label = labels[*k]
                .as_ref()
                .map_or(String::new(), |l| format!("{l},"));
            let first = seqs[*k].first_frame;
            for (i, (p, c)) in est.iter().enumerate() {
                let c = c.map_or(String::new(), |c| c.to_string());
                // At most the sequence's last frame number: the readers (`csv`, `mot`) and
                // `sim::observe` keep `first_frame + frames.len() − 1` within `u64`.
                let frame = first + i as u64;
                writeln!(w, "{label}{frame},{name},{},{},{c}", p[0], p[1]).map_err(io)?;
            }
        }
        Ok(())
    };
    match &o.out {
        Some(p) => write_atomic(p, fill)?,
        None => fill(&mut std::io::stdout().lock())?,
    }
    // Notes only after success: a failed run prints one line, its error.
    input.say_simulated(simulated, "tracked sequences", ui);
    // Mean error against the truth, where the sequence has it.
    for (k, name, est, left_out) in &runs {
        let label = labels[*k]
            .as_ref()
            .map_or(String::new(), |l| format!("{l} "));
        if *left_out > 0 {
            let [x0, x1, y0, y1] = m.extent;
            ui.say(format!(
                "{label}{name}: {left_out} detections outside the model's extent \
                 [{x0:.1}, {x1:.1}] × [{y0:.1}, {y1:.1}] were left out of their frames"
            ));
        }
        let errs: Vec<f64> = seqs[*k]
            .frames
            .iter()
            .zip(est)
            .filter_map(|(f, (p, _))| f.truth.map(|t| (t[0] - p[0]).hypot(t[1] - p[1])))
            .collect();
        if !errs.is_empty() {
            ui.say(format!(
                "{label}{name}: {} frames, mean error to the truth {:.2}",
                est.len(),
                errs.iter().sum::<f64>() / errs.len() as f64
            ));
        }
    }
    Ok(())
}
