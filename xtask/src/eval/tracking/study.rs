//! The tracking study: learn on training sequences, run every tracker on every test sequence
//! from the first frame's truth, score RMSE and track loss.

use std::time::Instant;

use cbt_tracker::metrics::{Score, score};
use cbt_tracker::{
    Calibration, CbtConfig, CbtModel, CbtTracker, KalmanParams, KalmanTracker,
    LearnedParticleFilter, ObservationFallback, Order, ParticleFilter, PeriodicInput, PfModel,
    Point, Scales, Sequence, Space, Tracker, axis,
};
use indicatif::ProgressBar;
use serde::Serialize;

use crate::Result;

/// Particle counts of the particle-filter baselines.
pub const PARTICLES: [usize; 3] = [100, 1000, 10_000];

/// Seeds of every random tracker (particle filters): seed `s` of test sequence `i` is
/// `set seed + i + s·SEED_STRIDE`.
pub const SEEDS: u64 = 5;
/// Distance between the seeds of one sequence.
pub const SEED_STRIDE: u64 = 100_000;

/// UNGM's known input: the drive `8·cos(1.2k)` has the phase `1.2k mod 2π`.
pub const UNGM_OMEGA: f64 = 1.2;
/// Phase channels of the UNGM input (chosen on development runs, seed 3002, not the test
/// runs: docs/methods.md § Tracking).
pub const UNGM_PHASE_CHANNELS: usize = 12;

/// What kind of data a set holds.
#[derive(Debug, Clone, Copy, Serialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum SetKind {
    /// Image coordinates on `[x_lo, x_hi] × [y_lo, y_hi]`.
    Image {
        /// Lower end of x.
        x_lo: f64,
        /// Upper end of x.
        x_hi: f64,
        /// Lower end of y.
        y_lo: f64,
        /// Upper end of y.
        y_hi: f64,
    },
    /// The 1-D UNGM benchmark (state x, measurement z = x²/20 + n).
    Ungm,
}

/// A set of training and test sequences to study.
pub struct SetSpec {
    /// Name (file name of its JSON).
    pub name: String,
    /// One-line description.
    pub description: String,
    /// Clutter rate of the set (for the RMSE-vs-clutter plot), if known.
    pub clutter_rate: Option<f64>,
    /// Data kind.
    pub kind: SetKind,
    /// Training sequences (truth + detections).
    pub train: Vec<Sequence>,
    /// Test sequences.
    pub test: Vec<Sequence>,
    /// Track-loss radius.
    pub radius: f64,
    /// Seed of the particle filters (sequence `i` uses `seed + i`).
    pub seed: u64,
}

/// One tracker on one sequence.
#[derive(Debug, Clone, Serialize)]
pub struct Run {
    /// Tracker label.
    pub tracker: String,
    /// RMSE, track-loss share (random trackers: means over the [`SEEDS`] seeds), scored frames.
    #[serde(flatten)]
    pub score: Score,
    /// Random trackers: the RMSE of each seed (empty for deterministic trackers).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub seed_rmse: Vec<f64>,
    /// Frames with detections the tracker refused as off its grid (those were left out, the
    /// frame's others used).
    pub rejected_frames: usize,
    /// The estimates (frame 0 = the given start; random trackers: the first seed's); not
    /// serialised.
    #[serde(skip)]
    pub estimates: Vec<Point>,
    /// Wall time of the steps in seconds (random trackers: mean over seeds); not serialised
    /// (fixtures hold no timings).
    #[serde(skip)]
    pub seconds: f64,
    /// Thread CPU time of the steps in seconds (`clock_gettime`'s thread clock; as `seconds`;
    /// 0 where the OS does not say).
    #[serde(skip)]
    pub cpu_seconds: f64,
}

impl Run {
    /// The runs of seeds `0, 1, …` as one entry: means over seeds, the first seed's
    /// estimates.
    pub fn over_seeds(mut first: Run, rest: Vec<Run>) -> Run {
        let n = (1 + rest.len()) as f64;
        if rest.is_empty() {
            return first;
        }
        first.seed_rmse = std::iter::once(first.score.rmse)
            .chain(rest.iter().map(|r| r.score.rmse))
            .collect();
        first.score.rmse = first.seed_rmse.iter().sum::<f64>() / n;
        first.score.loss_share =
            (first.score.loss_share + rest.iter().map(|r| r.score.loss_share).sum::<f64>()) / n;
        first.seconds = (first.seconds + rest.iter().map(|r| r.seconds).sum::<f64>()) / n;
        first.cpu_seconds =
            (first.cpu_seconds + rest.iter().map(|r| r.cpu_seconds).sum::<f64>()) / n;
        first.rejected_frames += rest.iter().map(|r| r.rejected_frames).sum::<usize>();
        first
    }
}

/// All trackers on one sequence.
#[derive(Debug, Clone, Serialize)]
pub struct SeqResult {
    /// Sequence name.
    pub sequence: String,
    /// Number of frames.
    pub frames: usize,
    /// Detections per frame on average.
    pub mean_detections: f64,
    /// One entry per tracker.
    pub runs: Vec<Run>,
}

/// The result of one set.
#[derive(Debug, Clone, Serialize)]
pub struct SetResult {
    /// Set name.
    pub set: String,
    /// Description.
    pub description: String,
    /// Clutter rate (synthetic sets).
    pub clutter_rate: Option<f64>,
    /// Data kind and extent.
    pub kind: SetKind,
    /// Channel spacing of CBT's grid (state axes; UNGM: state, measurement).
    pub spacing: Vec<f64>,
    /// Channels per state axis.
    pub channels: Vec<usize>,
    /// Calibrated baseline parameters (image sets).
    pub calibration: Option<Calibration>,
    /// Track-loss radius.
    pub loss_radius: f64,
    /// Tracker labels in run order.
    pub trackers: Vec<String>,
    /// Per sequence.
    pub sequences: Vec<SeqResult>,
}

/// Makes a fresh tracker from a seed.
pub type Maker = Box<dyn Fn(u64) -> Result<Box<dyn Tracker>>>;

/// A set's trackers with its CBT grid (spacing, channels) and the baselines' calibration.
pub type SetTrackers = (Trackers, Vec<f64>, Vec<usize>, Option<Calibration>);

/// A factory of fresh trackers for one set.
pub struct Trackers {
    /// One maker per tracker, in run order.
    pub makers: Vec<Maker>,
    /// Whether each tracker draws random numbers (its result depends on the seed).
    pub seeded: Vec<bool>,
}

/// The smoothing of CBT's models on the image sets (`--held-out-smoothing`, development runs
/// only; unset: [`CbtConfig::stationary`]'s).
static SMOOTHING: std::sync::OnceLock<cbt_tracker::Smoothing> = std::sync::OnceLock::new();

/// Sets the smoothing of CBT's models on the image sets for this process (first call wins).
pub fn set_smoothing(s: cbt_tracker::Smoothing) {
    let _ = SMOOTHING.set(s);
}

static START: std::sync::OnceLock<cbt_tracker::StartMotion> = std::sync::OnceLock::new();

/// Sets the start motion of CBT's models on the image sets for this process (first call
/// wins; development runs).
pub fn set_start(s: cbt_tracker::StartMotion) {
    let _ = START.set(s);
}

static DISPLACEMENTS: std::sync::OnceLock<cbt_tracker::Displacements> = std::sync::OnceLock::new();

/// Sets how CBT's models on the image sets count displacements for this process (first call
/// wins; development runs).
pub fn set_displacements(d: cbt_tracker::Displacements) {
    let _ = DISPLACEMENTS.set(d);
}

static OBSERVATION: std::sync::OnceLock<cbt_tracker::ObservationSmoothing> =
    std::sync::OnceLock::new();

/// Sets how CBT's observation models on the image sets are smoothed for this process (first
/// call wins; development runs).
pub fn set_observation(o: cbt_tracker::ObservationSmoothing) {
    let _ = OBSERVATION.set(o);
}

static VELOCITY: std::sync::OnceLock<cbt_tracker::Velocity> = std::sync::OnceLock::new();

/// Sets how CBT's second order on the image sets carries the velocity for this process
/// (first call wins; development runs).
pub fn set_velocity(v: cbt_tracker::Velocity) {
    let _ = VELOCITY.set(v);
}

fn cbt_models(space: &Space, base: CbtConfig, train: &[Sequence]) -> Result<(CbtModel, CbtModel)> {
    let second = CbtModel::learn_sequences(space.clone(), base, train)?;
    let first = CbtModel::learn_sequences(
        space.clone(),
        CbtConfig {
            order: Order::First,
            ..base
        },
        train,
    )?;
    Ok((second, first))
}

fn cbt_makers(second: CbtModel, first: CbtModel) -> Vec<Maker> {
    let (s2, s1, s3) = (second.clone(), first, second);
    vec![
        Box::new(move |_| Ok(Box::new(CbtTracker::new(s2.clone())) as Box<dyn Tracker>)),
        Box::new(move |_| Ok(Box::new(CbtTracker::new(s1.clone())) as Box<dyn Tracker>)),
        Box::new(move |_| {
            Ok(Box::new(CbtTracker::new(s3.clone()).with_self_learning()) as Box<dyn Tracker>)
        }),
    ]
}

impl Trackers {
    /// The trackers of a set: CBT (three variants), Kalman (image sets) and the particle
    /// filters, with the CBT grid and the baselines' calibration.
    pub fn for_set(spec: &SetSpec) -> Result<SetTrackers> {
        match spec.kind {
            SetKind::Image {
                x_lo,
                x_hi,
                y_lo,
                y_hi,
            } => {
                let extent = (x_hi - x_lo).min(y_hi - y_lo);
                // The stationary layout: shift-invariant models and the posterior on its
                // support, on a grid as fine as the detection noise asks for.
                let spacing = Scales::estimate(&spec.train, extent)?.fine_spacing(extent)?;
                let kernel = cbt_tracker::DEFAULT_KERNEL;
                let (bx, by) = (
                    axis(x_lo, x_hi, spacing, kernel)?,
                    axis(y_lo, y_hi, spacing, kernel)?,
                );
                let space = Space::new(vec![bx.clone(), by.clone()], vec![bx, by])?;
                // The image-tracking configuration (its docs: why, measured on the
                // pedestrian study's validation scenes).
                let cfg = CbtConfig {
                    smoothing: SMOOTHING.get().copied().unwrap_or_default(),
                    start: START
                        .get()
                        .copied()
                        .unwrap_or(CbtConfig::stationary().start),
                    displacements: DISPLACEMENTS
                        .get()
                        .copied()
                        .unwrap_or(CbtConfig::stationary().displacements),
                    observation_smoothing: OBSERVATION
                        .get()
                        .copied()
                        .unwrap_or(CbtConfig::stationary().observation_smoothing),
                    velocity: VELOCITY
                        .get()
                        .copied()
                        .unwrap_or(CbtConfig::stationary().velocity),
                    ..CbtConfig::stationary()
                };
                let (second, first) = cbt_models(&space, cfg, &spec.train)?;
                let cal = Calibration::estimate(&spec.train, extent / 10.0)?;
                let area = (x_hi - x_lo) * (y_hi - y_lo);
                let mut makers = cbt_makers(second, first);
                let mut seeded = vec![false; makers.len() + 1];
                makers.push(Box::new(move |_| {
                    Ok(
                        Box::new(KalmanTracker::new(KalmanParams::from_calibration(&cal))?)
                            as Box<dyn Tracker>,
                    )
                }));
                for n in PARTICLES {
                    let model = PfModel::from_calibration(&cal, area);
                    makers.push(Box::new(move |seed| {
                        Ok(Box::new(ParticleFilter::new(model, n, seed)?) as Box<dyn Tracker>)
                    }));
                    seeded.push(true);
                }
                Ok((
                    Trackers { makers, seeded },
                    vec![
                        space.state_basis(0).spacing(),
                        space.state_basis(1).spacing(),
                    ],
                    vec![space.axis_len(0), space.axis_len(1)],
                    Some(cal),
                ))
            }
            SetKind::Ungm => {
                // Grid over the training data's extent (+5 state, +3 measurement units);
                // spacing 1 on both: a third of the process noise σ_v = √10 and the
                // measurement noise σ_n = 1.
                let (mut xl, mut xh, mut zl, mut zh) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
                for s in &spec.train {
                    for f in &s.frames {
                        if let Some(t) = f.truth {
                            xl = xl.min(t[0]);
                            xh = xh.max(t[0]);
                        }
                        for d in &f.detections {
                            zl = zl.min(d.pos[0]);
                            zh = zh.max(d.pos[0]);
                        }
                    }
                }
                let kernel = cbt_tracker::DEFAULT_KERNEL;
                let state = axis(xl - 5.0, xh + 5.0, 1.0, kernel)?;
                let meas = axis(zl - 3.0, zh + 3.0, 1.0, kernel)?;
                let space = Space::new(vec![state.clone()], vec![meas.clone()])?;
                let cfg = CbtConfig {
                    observation_fallback: ObservationFallback::Uniform,
                    ..CbtConfig::default()
                };
                let (second, first) = cbt_models(&space, cfg, &spec.train)?;
                // The like-for-like pair: CBT given UNGM's known input (the phase of 1.2k),
                // and particle filters that know only CBT's learned first-order models.
                let phased = CbtModel::learn_sequences(
                    space.clone(),
                    CbtConfig {
                        order: Order::First,
                        input: Some(PeriodicInput {
                            omega: UNGM_OMEGA,
                            channels: UNGM_PHASE_CHANNELS,
                        }),
                        ..cfg
                    },
                    &spec.train,
                )?;
                let learned = first.clone();
                let mut makers = cbt_makers(second, first);
                let p = phased.clone();
                makers.push(Box::new(move |_| {
                    Ok(Box::new(CbtTracker::new(p.clone())) as Box<dyn Tracker>)
                }));
                let mut seeded = vec![false; makers.len()];
                for n in PARTICLES {
                    let model = PfModel::Ungm {
                        process_var: 10.0,
                        meas_var: 1.0,
                        init_sigma: 1.0,
                    };
                    makers.push(Box::new(move |seed| {
                        Ok(Box::new(ParticleFilter::new(model, n, seed)?) as Box<dyn Tracker>)
                    }));
                    seeded.push(true);
                }
                for m in [learned, phased] {
                    makers.push(Box::new(move |seed| {
                        Ok(Box::new(LearnedParticleFilter::new(m.clone(), 1000, seed)?)
                            as Box<dyn Tracker>)
                    }));
                    seeded.push(true);
                }
                Ok((
                    Trackers { makers, seeded },
                    vec![state.spacing(), meas.spacing()],
                    vec![state.len()],
                    None,
                ))
            }
        }
    }
}

/// Runs one tracker over a sequence; frames with detections the tracker rejects count as
/// empty frames.
pub fn run_one(t: &mut dyn Tracker, s: &Sequence, dims: usize, radius: f64) -> Result<Run> {
    // A track starts at its first frame with a truth; earlier frames are not scored.
    let k0 = s
        .start()
        .ok_or_else(|| format!("sequence {}: no frame has a truth to start from", s.name))?;
    let frames = &s.frames[k0..];
    let start = frames[0].truth.unwrap_or_default();
    t.reset(start)?;
    let mut est = vec![start];
    let mut rejected = 0;
    let t0 = Instant::now();
    let c0 = crate::bench::thread_seconds().unwrap_or(0.0);
    for f in &frames[1..] {
        let (e, left_out) = cbt_tracker::step_on_grid(t, &f.detections)
            .map_err(|e| format!("sequence {}: {e}", s.name))?;
        rejected += usize::from(left_out > 0);
        est.push(e.position);
    }
    let seconds = t0.elapsed().as_secs_f64();
    let cpu_seconds = crate::bench::thread_seconds().map_or(0.0, |c| c - c0);
    let truths: Vec<Option<Point>> = frames.iter().map(|f| f.truth).collect();
    Ok(Run {
        tracker: t.name(),
        score: score(&est, &truths, dims, radius)?,
        seed_rmse: Vec::new(),
        rejected_frames: rejected,
        estimates: est,
        seconds,
        cpu_seconds,
    })
}

/// Runs every tracker on every test sequence of a set.
pub fn run_set(spec: &SetSpec, pb: &ProgressBar) -> Result<SetResult> {
    let (trackers, spacing, channels, calibration) = Trackers::for_set(spec)?;
    let dims = match spec.kind {
        SetKind::Image { .. } => 2,
        SetKind::Ungm => 1,
    };
    let mut sequences = Vec::new();
    let mut names = Vec::new();
    for (i, s) in spec.test.iter().enumerate() {
        if s.frames.is_empty() {
            return Err(format!("test sequence {} has no frames", s.name).into());
        }
        let mut runs = Vec::new();
        for (ti, make) in trackers.makers.iter().enumerate() {
            let seeds = if trackers.seeded[ti] { SEEDS } else { 1 };
            let mut per_seed = Vec::new();
            for k in 0..seeds {
                let seed = spec
                    .seed
                    .wrapping_add(i as u64)
                    .wrapping_add(k * SEED_STRIDE);
                let mut t = make(seed)?;
                per_seed.push(run_one(t.as_mut(), s, dims, spec.radius)?);
            }
            let first = per_seed.remove(0);
            runs.push(Run::over_seeds(first, per_seed));
        }
        if names.is_empty() {
            names = runs.iter().map(|r| r.tracker.clone()).collect();
        }
        let dets: usize = s.frames.iter().map(|f| f.detections.len()).sum();
        sequences.push(SeqResult {
            sequence: s.name.clone(),
            frames: s.frames.len(),
            mean_detections: dets as f64 / s.frames.len() as f64,
            runs,
        });
        pb.inc(1);
    }
    Ok(SetResult {
        set: spec.name.clone(),
        description: spec.description.clone(),
        clutter_rate: spec.clutter_rate,
        kind: spec.kind,
        spacing,
        channels,
        calibration,
        loss_radius: spec.radius,
        trackers: names,
        sequences,
    })
}

/// Per-tracker aggregate of a set (or of several).
#[derive(Debug, Clone, Serialize)]
pub struct Aggregate {
    /// Tracker label.
    pub tracker: String,
    /// Mean over sequences of the per-sequence RMSE (random trackers: its mean over seeds).
    pub mean_rmse: f64,
    /// Random trackers: the standard deviation over seeds of the mean over sequences
    /// (0 for deterministic trackers).
    pub spread: f64,
    /// Median over sequences of the per-sequence RMSE.
    pub median_rmse: f64,
    /// Mean track-loss share.
    pub mean_loss_share: f64,
    /// Sequences where this tracker has the lowest RMSE (ties count for each).
    pub best_in: usize,
    /// Sequences scored.
    pub sequences: usize,
}

/// Aggregates over all sequences of the given sets, per tracker (trackers in the order of
/// the first set).
pub fn aggregate(sets: &[&SetResult]) -> Vec<Aggregate> {
    let Some(first) = sets.first() else {
        return Vec::new();
    };
    first
        .trackers
        .iter()
        .enumerate()
        .map(|(ti, name)| {
            let mut rmse = Vec::new();
            let mut per_seed: Vec<f64> = Vec::new();
            let (mut loss, mut best) = (0.0, 0);
            for set in sets {
                for s in &set.sequences {
                    let Some(r) = s.runs.iter().find(|r| &r.tracker == name) else {
                        continue;
                    };
                    rmse.push(r.score.rmse);
                    per_seed.resize(per_seed.len().max(r.seed_rmse.len()), 0.0);
                    for (a, v) in per_seed.iter_mut().zip(&r.seed_rmse) {
                        *a += v;
                    }
                    loss += r.score.loss_share;
                    let min = s
                        .runs
                        .iter()
                        .map(|r| r.score.rmse)
                        .fold(f64::INFINITY, f64::min);
                    if r.score.rmse <= min {
                        best += 1;
                    }
                }
            }
            let n = rmse.len();
            let mean = rmse.iter().sum::<f64>() / n.max(1) as f64;
            let median = if n == 0 {
                0.0
            } else {
                crate::stats::median(&mut rmse)
            };
            let _ = ti;
            let seeds = per_seed.len();
            let spread = if seeds > 1 {
                let m: Vec<f64> = per_seed.iter().map(|v| v / n.max(1) as f64).collect();
                let mu = m.iter().sum::<f64>() / seeds as f64;
                (m.iter().map(|v| (v - mu).powi(2)).sum::<f64>() / (seeds - 1) as f64).sqrt()
            } else {
                0.0
            };
            Aggregate {
                tracker: name.clone(),
                mean_rmse: mean,
                spread,
                median_rmse: median,
                mean_loss_share: loss / n.max(1) as f64,
                best_in: best,
                sequences: n,
            }
        })
        .collect()
}

/// Sequences where tracker `a` has an RMSE no larger than tracker `b`'s.
pub fn head_to_head(sets: &[&SetResult], a: &str, b: &str) -> (usize, usize) {
    let (mut wins, mut total) = (0, 0);
    for set in sets {
        for s in &set.sequences {
            let ra = s.runs.iter().find(|r| r.tracker == a);
            let rb = s.runs.iter().find(|r| r.tracker == b);
            if let (Some(ra), Some(rb)) = (ra, rb) {
                total += 1;
                if ra.score.rmse <= rb.score.rmse {
                    wins += 1;
                }
            }
        }
    }
    (wins, total)
}
