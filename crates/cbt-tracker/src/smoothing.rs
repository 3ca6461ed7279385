//! Data-driven smoothing of the learned system densities: the smoothing is chosen from the
//! training data itself, by held-out likelihood ([`Smoothing::HeldOut`]).
//!
//! The stationary layout's system model (module `stationary`) is a Dirichlet-smoothed
//! estimate per velocity column,
//!
//! ```text
//! T[δ | v] = (C_2[δ, v] + α·F_v[δ]) / (Σ_δ C_2[δ, v] + α),   F_v = N(δ; v, σ²)  (constant velocity)
//! S[δ]     = (C_1[δ] + α·F_0[δ]) / (Σ_δ C_1[δ] + α)
//! ```
//!
//! with two smoothing constants: the prior's pseudo-mass `α`
//! ([`CbtConfig::prior_weight`]) and its width `σ` in channels
//! ([`CbtConfig::fallback_sigma`]). Where a column has few counts the estimate is the prior:
//! too narrow a `σ` (or too small an `α` for spiky counts) is a narrow wrong density, and a
//! track held by it is lost on the first unexpected step. Which `(α, σ)` suits a training set
//! depends on how much of it there is and on how the targets move, so it is measured:
//!
//! 1. **Split.** The training sequences are dealt into `K = min(5, n)` folds, sequence `i`
//!    to fold `i mod K` (deterministic, no random draw).
//! 2. **Fit.** For each fold, the soft counts `C_1`, `C_2` of the other folds' sequences
//!    (exactly as [`CbtModel::learn`](crate::CbtModel::learn) counts them).
//! 3. **Score.** For each candidate `(α, σ)` of the [`SmoothingGrid`], the fold's model is
//!    normalised with it and the held-out fold's tracks are scored by their log-likelihood
//!    under the chain the filter runs: `log S(δ_1) + Σ_{k ≥ 2} log T(δ_k | v_k)` per axis,
//!    with `δ_k = u_k − u_{k−1}`, `v_k = u_{k−1} − u_{k−2}` the displacements of the state's
//!    channel coordinates `u`. The densities are read at the continuous displacement by
//!    linear interpolation between channels (it integrates to the column's sum less half its
//!    two end values, which the priors leave near zero); a displacement beyond the model's radius gets the density `1e-9` (the same for
//!    every candidate). Only runs of frames with exactly one state are scored (a frame with
//!    several states has no single displacement); runs break at frames without states.
//! 4. **Pick.** The candidate with the largest held-out log-likelihood summed over the folds.
//!    Ties go to the broader candidate (larger `σ`, then larger `α`): when the data cannot
//!    tell, the model degrades toward the broad prior, not toward a narrow one.
//!
//! **Measured** (pedestrian study, validation scenes only; synthetic RC-car sets; figures in
//! [`CbtConfig::stationary`]'s docs): the held-out true tracks of both are smoother than a
//! filter that knows its target's velocity only from detections can exploit, so the pick is
//! the sharpest prior of the grid (`α = 300`, `σ = 0.5`). That helps on the walkers (the hard
//! level's lost frames 25.6 % → 17.6 %) and loses synthetic tracks in dense clutter, so it is
//! not the default. Conditioning the score on the velocity measured on the detections
//! (`v̂ = ẑ_{k−1} − ẑ_{k−2}`, the nearest detection to the truth) picks broad priors
//! (`σ` 2–6 channels) instead, and was worse on the synthetic sets too (L3/L4 7.27/14.19
//! against 6.84/13.65) and on the walkers at the medium level (5.99 against 5.53); it was
//! not kept.
//!
//! The observation model has no such constant to choose: its kernel is the measured
//! displacement distribution of detections around states, truncated at three of its
//! measured standard deviations, and its clutter density is measured on a ring of
//! displacements against their exposure (module `stationary`).

use serde::{Deserialize, Serialize};

use crate::config::{CbtConfig, Layout};
use crate::encode::encode_states;
use crate::history::History;
use crate::stationary::{StatSystem, check_space, motion_radius};
use crate::{Space, TrackError, TrainingFrame};

/// How the smoothing constants `α` ([`CbtConfig::prior_weight`]) and `σ`
/// ([`CbtConfig::fallback_sigma`]) of the learned system model are set.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Smoothing {
    /// As configured (the behaviour of files written before this option existed).
    #[default]
    Fixed,
    /// Chosen from the training data by held-out likelihood over [`SmoothingGrid::default`]
    /// when the model is learned ([`select`]; module docs); the learned model's configuration
    /// holds the chosen values. Stationary layout only.
    HeldOut,
}

impl Smoothing {
    /// Whether this is [`Smoothing::Fixed`] (the default, not written to saved files).
    pub fn is_fixed(&self) -> bool {
        *self == Smoothing::Fixed
    }
}

/// Candidate smoothing constants.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SmoothingGrid {
    /// Candidate pseudo-masses `α` of the prior column (soft counts).
    pub prior_weights: Vec<f64>,
    /// Candidate widths `σ` of the prior column (channels).
    pub fallback_sigmas: Vec<f64>,
}

impl Default for SmoothingGrid {
    /// `α ∈ {1, 3, 10, 30, 100, 300}`, `σ ∈ {0.5, 1, 1.5, 2, 3, 4, 6}` channels: from a
    /// prior one training sample outweighs to one that holds against a hundred, and from a
    /// prior about as sharp as the channels to one wider than any walker's change of pace on
    /// the pedestrian study's finest grid.
    fn default() -> Self {
        SmoothingGrid {
            prior_weights: vec![1.0, 3.0, 10.0, 30.0, 100.0, 300.0],
            fallback_sigmas: vec![0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 6.0],
        }
    }
}

/// One candidate's held-out score.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CandidateScore {
    /// `α`.
    pub prior_weight: f64,
    /// `σ` (channels).
    pub fallback_sigma: f64,
    /// Held-out log-likelihood summed over the folds (nats).
    pub log_likelihood: f64,
}

/// The outcome of [`select`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Selection {
    /// The chosen `α`.
    pub prior_weight: f64,
    /// The chosen `σ` (channels).
    pub fallback_sigma: f64,
    /// Number of folds `K`.
    pub folds: usize,
    /// Held-out displacements scored (per axis, summed over the folds).
    pub held_out: usize,
    /// Every candidate's score, in the grid's order (`σ` outer, `α` inner).
    pub scores: Vec<CandidateScore>,
}

/// The checks every held-out selection starts with (this one and
/// [`crate::observation_smoothing::select_observation`]): `config` valid and of the stationary
/// layout (else [`TrackError::Selection`] with `not_stationary`), `space` one it can use.
pub(crate) fn check_selection_setup(
    space: &Space,
    config: &CbtConfig,
    not_stationary: &'static str,
) -> Result<(), TrackError> {
    config.validate()?;
    if config.layout != Layout::Stationary {
        return Err(TrackError::Selection {
            reason: not_stationary,
        });
    }
    check_space(space)
}

/// Density given to a held-out displacement outside the model's radius.
const OUTSIDE: f64 = 1e-9;

/// Largest number of folds.
const MAX_FOLDS: usize = 5;

/// Chooses `(α, σ)` for the stationary system model of `config` on `space` from the training
/// `sequences` by held-out likelihood (module docs). `config`'s own `α` and `σ` are not used;
/// its [`system_fallback`](CbtConfig::system_fallback) is.
///
/// Errors: a configuration that is invalid or not [`Layout::Stationary`], a space the layout
/// cannot use, an empty or non-finite candidate list, fewer than two sequences with states
/// ([`TrackError::Selection`]: nothing to hold out), no held-out displacement to score, and
/// every error of learning (a state off the grid, …).
pub fn select(
    space: &Space,
    config: &CbtConfig,
    sequences: &[Vec<TrainingFrame>],
    grid: &SmoothingGrid,
) -> Result<Selection, TrackError> {
    check_selection_setup(
        space,
        config,
        "held-out smoothing is implemented for the stationary layout only",
    )?;
    if grid.prior_weights.is_empty() || grid.fallback_sigmas.is_empty() {
        return Err(TrackError::Selection {
            reason: "no candidate smoothing",
        });
    }
    for &a in &grid.prior_weights {
        crate::error::positive("prior_weight", a)?;
    }
    for &s in &grid.fallback_sigmas {
        crate::error::positive("fallback_sigma", s)?;
    }
    let used: Vec<&Vec<TrainingFrame>> = sequences
        .iter()
        .filter(|s| s.iter().any(|f| !f.states.is_empty()))
        .collect();
    if used.len() < 2 {
        return Err(TrackError::Selection {
            reason: "fewer than two training sequences with states: nothing to hold out",
        });
    }
    let k = used.len().min(MAX_FOLDS);
    // One radius for every fold and candidate: wide enough for the broadest prior.
    let widest = grid.fallback_sigmas.iter().copied().fold(0.0, f64::max);
    let r = motion_radius(
        space,
        sequences,
        &CbtConfig {
            fallback_sigma: widest,
            ..*config
        },
    );
    // Held-out displacements (channel units) of every sequence, per axis.
    let tracks: Vec<Chains> = used
        .iter()
        .map(|s| chains(space, s))
        .collect::<Result<_, _>>()?;
    let mut candidates = Vec::new();
    for &s in &grid.fallback_sigmas {
        for &a in &grid.prior_weights {
            candidates.push(CandidateScore {
                prior_weight: a,
                fallback_sigma: s,
                log_likelihood: 0.0,
            });
        }
    }
    let mut held_out = 0;
    for fold in 0..k {
        let mut sys = [StatSystem::new(r, config), StatSystem::new(r, config)];
        for (i, seq) in used.iter().enumerate() {
            if i % k != fold {
                count(space, config, seq, &mut sys)?;
            }
        }
        let test: Vec<&Chains> = (0..used.len())
            .filter(|i| i % k == fold)
            .map(|i| &tracks[i])
            .collect();
        held_out += test.iter().map(|c| c.len()).sum::<usize>();
        for c in &mut candidates {
            let cfg = CbtConfig {
                prior_weight: c.prior_weight,
                fallback_sigma: c.fallback_sigma,
                ..*config
            };
            sys.iter_mut().for_each(|s| s.normalise(&cfg));
            c.log_likelihood += test.iter().map(|t| t.log_likelihood(&sys)).sum::<f64>();
        }
    }
    if held_out == 0 {
        return Err(TrackError::Selection {
            reason: "no held-out displacement to score (no two consecutive frames with one \
                     state each)",
        });
    }
    // Broadest first, so that ties (strictly greater needed to replace) keep the broad one.
    let mut order: Vec<usize> = (0..candidates.len()).collect();
    order.sort_by(|&i, &j| {
        let (a, b) = (&candidates[i], &candidates[j]);
        b.fallback_sigma
            .total_cmp(&a.fallback_sigma)
            .then(b.prior_weight.total_cmp(&a.prior_weight))
    });
    let mut best = order[0];
    for &i in &order[1..] {
        if candidates[i].log_likelihood > candidates[best].log_likelihood {
            best = i;
        }
    }
    Ok(Selection {
        prior_weight: candidates[best].prior_weight,
        fallback_sigma: candidates[best].fallback_sigma,
        folds: k,
        held_out,
        scores: candidates,
    })
}

/// Adds one sequence's soft counts to the per-axis system models, chaining frames as
/// [`CbtModel::learn`](crate::CbtModel::learn) does.
fn count(
    space: &Space,
    cfg: &CbtConfig,
    seq: &[TrainingFrame],
    sys: &mut [StatSystem; 2],
) -> Result<(), TrackError> {
    let mut h = History::default();
    for f in seq {
        let x = encode_states(space, &f.states, 1.0, false)?;
        let (prev, prev2) = h.take();
        if let (false, Some(p1)) = (x.is_empty(), prev.as_ref()) {
            for (d, s) in sys.iter_mut().enumerate() {
                s.add_frames(cfg, d, &x, p1, prev2.as_ref());
            }
        }
        h.push(&f.states, x, prev);
    }
    Ok(())
}

/// A sequence's scored displacements per axis: `(v, δ)` with `v = None` for the first step
/// of a run (scored by `S`).
struct Chains {
    steps: Vec<(Option<[f64; 2]>, [f64; 2])>,
}

impl Chains {
    fn len(&self) -> usize {
        self.steps.len()
    }

    fn log_likelihood(&self, sys: &[StatSystem; 2]) -> f64 {
        let mut ll = 0.0;
        for (v, delta) in &self.steps {
            for (d, s) in sys.iter().enumerate() {
                let p = match v {
                    None => interpolate(s.first(), s.radius(), delta[d]),
                    Some(v) => second(s, v[d], delta[d]),
                };
                ll += p.max(OUTSIDE).ln();
            }
        }
        ll
    }
}

/// Runs of frames with exactly one state, as channel coordinates, and their displacements.
fn chains(space: &Space, seq: &[TrainingFrame]) -> Result<Chains, TrackError> {
    let mut steps = Vec::new();
    let (mut prev, mut prev2): (Option<[f64; 2]>, Option<[f64; 2]>) = (None, None);
    for f in seq {
        let u = match f.states.as_slice() {
            [p] => Some(space.state_index(p)?),
            _ => None,
        };
        if let (Some(u), Some(p)) = (u, prev) {
            let delta = [u[0] - p[0], u[1] - p[1]];
            let v = prev2.map(|q| [p[0] - q[0], p[1] - q[1]]);
            steps.push((v, delta));
        }
        prev2 = if u.is_some() { prev } else { None };
        prev = u;
    }
    Ok(Chains { steps })
}

/// The density of a distribution over the integer displacements `−r..=r` (index `δ + r`) at
/// the continuous displacement `x`, linear between channels (0 outside).
fn interpolate(col: &[f64], r: usize, x: f64) -> f64 {
    let t = x + r as f64;
    if !(t >= 0.0 && t <= (col.len() - 1) as f64) {
        return 0.0;
    }
    let i = (t.floor() as usize).min(col.len() - 1);
    let f = t - i as f64;
    let next = col.get(i + 1).copied().unwrap_or(0.0);
    (1.0 - f) * col[i] + f * next
}

/// `T(δ | v)` at continuous `v` and `δ`: the columns of the two velocity channels around `v`,
/// mixed linearly (0 outside the radius).
fn second(s: &StatSystem, v: f64, delta: f64) -> f64 {
    let r = s.radius();
    let w = 2 * r + 1;
    let t = v + r as f64;
    if !(t >= 0.0 && t <= (w - 1) as f64) {
        return 0.0;
    }
    let i = (t.floor() as usize).min(w - 1);
    let f = t - i as f64;
    let col = |j: usize| interpolate(&s.second()[j * w..(j + 1) * w], r, delta);
    let lo = col(i);
    if f > 0.0 && i + 1 < w {
        (1.0 - f) * lo + f * col(i + 1)
    } else {
        lo
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolation_integrates_to_the_columns_sum() {
        let col = [0.1, 0.2, 0.4, 0.2, 0.1];
        let n = 40_000;
        let (lo, hi) = (-3.0, 3.0);
        let h = (hi - lo) / n as f64;
        let integral: f64 = (0..n)
            .map(|i| interpolate(&col, 2, lo + (i as f64 + 0.5) * h) * h)
            .sum();
        // The piecewise-linear density over [−2, 2] integrates to Σ − (ends)/2.
        assert!((integral - (1.0 - 0.5 * (0.1 + 0.1))).abs() < 1e-4);
        assert_eq!(interpolate(&col, 2, 0.0), 0.4);
        assert!((interpolate(&col, 2, 0.5) - 0.3).abs() < 1e-12);
        assert_eq!(interpolate(&col, 2, 2.5), 0.0);
        assert_eq!(interpolate(&col, 2, f64::NAN), 0.0);
    }
}
