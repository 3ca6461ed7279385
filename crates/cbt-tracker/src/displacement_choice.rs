//! How the stationary system model counts its second-order displacements, chosen from the
//! training data itself by held-out tracking ([`Displacements::Selected`]).
//!
//! [`Displacements::Interpolated`] counts every step in the velocity columns around its
//! previous displacement and so averages each column over the velocities near it: where the
//! training velocities thin out, each column's mean is pulled toward the slower bulk, a damping
//! the targets may not have. [`Displacements::Aligned`] counts each step at its column's own
//! velocity and has no such pull, and its columns are sharper (the acceleration's spread only).
//! Which suits a training set is not a property of the motion alone: on the densest synthetic
//! clutter the damped columns track better (docs/methods.md § Tracking, *Each velocity column
//! learned at its own velocity*; likely because the damping holds back a velocity that a
//! clutter detection has taken, a reading not traced). The held-out likelihood of the true
//! tracks cannot see that (module [`crate::smoothing`]: it prefers the sharpest model), so the
//! choice scores what a user scores, the tracking error:
//!
//! 1. **Split.** The training runs are dealt into `K = min(4, n)` folds, run `i` to fold
//!    `i mod K` (deterministic, no random draw).
//! 2. **Fit.** For each fold and each candidate, a model is learned on the other folds' runs
//!    ([`CbtModel::learn`] with that counting; a fold whose other runs are too short to learn
//!    from is left out for both candidates).
//! 3. **Score.** The filter ([`CbtTracker`]) tracks every held-out run whose frames hold one
//!    state each (at least three frames), started at its first state and stepped through its
//!    detections (a detection set off the grid counts as an empty frame, as in the study);
//!    a run's score is its RMSE against the states.
//! 4. **Pick.** The candidate with the lower mean score over all scored runs. A tie, or no
//!    run to score, keeps [`Displacements::Interpolated`], the stationary default.
//!
//! Cost: `2K` extra learnings, and a tracking pass of each candidate over the training runs.
//! Measured results: the crate docs, *Which settings*.

use serde::{Deserialize, Serialize};

use crate::config::{CbtConfig, Displacements};
use crate::{CbtModel, CbtTracker, Point, Space, TrackError, Tracker, TrainingFrame, metrics};

/// Folds of the held-out tracking.
const FOLDS: usize = 4;

/// The candidates, in the order ties are broken (the first wins).
const CANDIDATES: [Displacements; 2] = [Displacements::Interpolated, Displacements::Aligned];

/// The outcome of [`select`]: the counting picked and the held-out score of each candidate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DisplacementChoice {
    /// The counting the model is learned with.
    pub pick: Displacements,
    /// Per candidate ([`Displacements::Interpolated`], [`Displacements::Aligned`]), the mean
    /// RMSE of the held-out runs (value units); `None` when no run could be scored.
    pub scores: [(Displacements, Option<f64>); 2],
    /// The held-out runs scored (the same for both candidates).
    pub runs: usize,
}

/// A run the held-out tracking can score: one state in every frame, at least three frames.
fn scorable(run: &[TrainingFrame]) -> bool {
    run.len() >= 3 && run.iter().all(|f| f.states.len() == 1)
}

/// The RMSE of the filter of `model` on `run` (a [`scorable`] one), started at its first
/// state.
fn track_rmse(model: &CbtModel, run: &[TrainingFrame]) -> Result<f64, TrackError> {
    let mut t = CbtTracker::new(model.clone());
    t.reset(run[0].states[0])?;
    let mut estimates = vec![run[0].states[0]];
    for f in &run[1..] {
        let (e, _) = crate::tracker::step_on_grid(&mut t, &f.detections)?;
        estimates.push(e.position);
    }
    let truths: Vec<Option<Point>> = run.iter().map(|f| Some(f.states[0])).collect();
    Ok(metrics::score(&estimates, &truths, 2, f64::INFINITY)?.rmse)
}

/// Chooses the counting of `config` (whose `displacements` is ignored) for `sequences` by
/// held-out tracking (module docs).
pub fn select(
    space: &Space,
    config: &CbtConfig,
    sequences: &[Vec<TrainingFrame>],
) -> Result<DisplacementChoice, TrackError> {
    let k = FOLDS.min(sequences.len());
    let mut sums = [0.0; 2];
    let mut runs = 0;
    for fold in 0..k {
        let held: Vec<&Vec<TrainingFrame>> = sequences
            .iter()
            .enumerate()
            .filter(|(i, s)| i % k == fold && scorable(s))
            .map(|(_, s)| s)
            .collect();
        if held.is_empty() {
            continue;
        }
        let rest: Vec<Vec<TrainingFrame>> = sequences
            .iter()
            .enumerate()
            .filter(|(i, _)| i % k != fold)
            .map(|(_, s)| s.clone())
            .collect();
        let mut models = Vec::with_capacity(CANDIDATES.len());
        for d in CANDIDATES {
            let cfg = CbtConfig {
                displacements: d,
                ..*config
            };
            match CbtModel::learn(space.clone(), cfg, &rest) {
                Ok(m) => models.push(m),
                // Too little left to learn from: the fold is left out for both.
                Err(TrackError::EmptyTraining { .. }) => break,
                Err(e) => return Err(e),
            }
        }
        if models.len() < CANDIDATES.len() {
            continue;
        }
        for run in held {
            for (sum, m) in sums.iter_mut().zip(&models) {
                *sum += track_rmse(m, run)?;
            }
            runs += 1;
        }
    }
    let scores = [0, 1].map(|c| (CANDIDATES[c], (runs > 0).then(|| sums[c] / runs as f64)));
    // Strictly lower wins; a tie (or nothing scored) keeps the first candidate.
    let pick = if runs > 0 && sums[1] < sums[0] {
        CANDIDATES[1]
    } else {
        CANDIDATES[0]
    };
    Ok(DisplacementChoice { pick, scores, runs })
}
