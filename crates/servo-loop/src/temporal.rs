//! Temporal consistency of percepts: a percept that disagrees with the last accepted one and
//! the move commanded in between is refused (issue #19; docs/methods.md § Servoing).
//!
//! A second camera cannot see a tip found at the wrong place *along* its epipolar line, but
//! the arm's own move can. With `(x₀, y₀)` the last accepted percept and its command and `y`
//! the command just executed, the learned inverse model `f̂` says how far the percept should
//! have moved: `f̂(x) − f̂(x₀) ≈ J (x − x₀)` (to first order the learned inverse image
//! Jacobian `J`; the difference of `f̂` itself keeps the check exact for larger moves). The
//! **residual**
//!
//! ```text
//! r = ‖(y − y₀) − (f̂(x) − f̂(x₀))‖      (command units, e.g. µs)
//! ```
//!
//! is the model's error difference `e(x₀) − e(x)` (`e = y − f̂(x)`, smooth in the pose, so small
//! for a short move) plus `J δ` for a percept off by `δ`. The threshold is learned from the
//! training moves' own residuals: for every pair of training samples whose commands lie at most
//! [`TemporalConfig::max_move`] apart, `r_ij = ‖e_i − e_j‖`; the pairs are binned by their
//! command distance `d` and the line `a + b·d` is fitted (least squares, `a, b ≥ 0`) through
//! each bin's [`TemporalConfig::quantile`]; a percept is refused when `r > κ (a + b·d)`
//! (`κ` = [`TemporalConfig::factor`]). Moves longer than `max_move` are not judged (the model's
//! error is no longer nearly the same at both ends), nor are percepts outside the model.
//!
//! [`TemporalPlant`] puts the check behind the [`Plant`] seam: the loops see a refused percept
//! as [`ServoError::PerceptInconsistent`] and never move on it.

use serde::{Deserialize, Serialize};

use crate::error::{Result, ServoError, check_finite, check_len};
use crate::inverse::InverseModel;
use crate::plant::{Observation, Plant, check_command};
use crate::stats::quantile_linear;

/// Settings of [`TemporalCheck::learn`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TemporalConfig {
    /// Longest move judged: command distance (Euclidean over the controlled set-points)
    /// between the last accepted percept's command and the new one. Also the range of the
    /// training pairs the threshold is learned from.
    pub max_move: f64,
    /// Quantile of the training pairs' residuals per distance bin (in `(0, 1)`).
    pub quantile: f64,
    /// Factor `κ > 0` on the fitted quantile line.
    pub factor: f64,
    /// Distance bins over `(0, max_move]` (at least 2, at most [`TemporalConfig::MAX_BINS`]).
    pub bins: usize,
}

impl Default for TemporalConfig {
    /// Moves up to 60 command units (µs for hobby servos) judged, the median per distance bin,
    /// factor 4: fixed before any run of `cargo xtask eval servo`, not chosen. On its
    /// development seeds (1001–1005, three arms) these settings stop 3–6 of 150 runs per arm and
    /// leave the p90 of the servo percepts about where it is without the check; factor 2.5
    /// stops 13–16 runs and lowers it on two arms, factor 8 never fires (docs/methods.md
    /// § Servoing).
    fn default() -> Self {
        TemporalConfig {
            max_move: 60.0,
            quantile: 0.5,
            factor: 4.0,
            bins: 4,
        }
    }
}

impl TemporalConfig {
    /// Most distance bins accepted (2¹⁶): learning allocates every bin before it sees a
    /// sample, and a bin counts only with [`TemporalCheck::MIN_PAIRS_PER_BIN`] pairs, so more
    /// bins would need more than 650,000 training pairs within `max_move` to fill. (`usize::MAX`
    /// bins used to be a capacity-overflow panic, a few billion an allocation failure.)
    pub const MAX_BINS: usize = 1 << 16;

    /// Checks every field's range.
    pub fn validate(&self) -> Result<()> {
        if !(self.max_move.is_finite() && self.max_move > 0.0) {
            return Err(ServoError::invalid(
                "max_move",
                "must be finite and positive",
            ));
        }
        if !(self.quantile > 0.0 && self.quantile < 1.0) {
            return Err(ServoError::invalid("quantile", "must lie in (0, 1)"));
        }
        if !(self.factor.is_finite() && self.factor > 0.0) {
            return Err(ServoError::invalid("factor", "must be finite and positive"));
        }
        if self.bins < 2 {
            return Err(ServoError::invalid("bins", "at least 2 distance bins"));
        }
        if self.bins > Self::MAX_BINS {
            return Err(ServoError::invalid(
                "bins",
                "at most TemporalConfig::MAX_BINS = 2^16 distance bins",
            ));
        }
        Ok(())
    }
}

/// The learned temporal check (module doc): refuse when `r > κ (a + b·d)` for a move of
/// command distance `d ≤ max_move`.
///
/// Deserialising applies [`TemporalConfig::validate`] and checks the fitted line as
/// [`TemporalCheck::learn`] leaves it (offset and slope finite and `≥ 0`): a file that fails
/// is an error, never a check that refuses or passes every percept.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "TemporalCheckFile")]
pub struct TemporalCheck {
    config: TemporalConfig,
    /// Fitted quantile line: offset `a` and slope `b`.
    offset: f64,
    slope: f64,
    /// Training pairs the line was fitted to.
    pairs: usize,
}

/// The serialised form of a [`TemporalCheck`], checked on deserialisation.
#[derive(Deserialize)]
struct TemporalCheckFile {
    config: TemporalConfig,
    offset: f64,
    slope: f64,
    pairs: usize,
}

impl TryFrom<TemporalCheckFile> for TemporalCheck {
    type Error = ServoError;

    fn try_from(f: TemporalCheckFile) -> Result<Self> {
        f.config.validate()?;
        TemporalCheck::check_line(f.offset, f.slope)?;
        Ok(TemporalCheck {
            config: f.config,
            offset: f.offset,
            slope: f.slope,
            pairs: f.pairs,
        })
    }
}

/// What the check says about one percept.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Verdict {
    /// Consistent: residual and threshold.
    Consistent {
        /// The residual `r`.
        residual: f64,
        /// The threshold at this move's distance.
        threshold: f64,
    },
    /// Inconsistent: residual and threshold (`residual > threshold`).
    Inconsistent {
        /// The residual `r`.
        residual: f64,
        /// The threshold at this move's distance.
        threshold: f64,
    },
    /// Not judged: the move is longer than `max_move`, or a percept lies outside the model
    /// (for the [`crate::MotionCheck`]: too few remembered percepts near the command).
    NotJudged,
}

impl Verdict {
    /// Inconsistent when `residual > threshold`, else consistent.
    pub fn of(residual: f64, threshold: f64) -> Verdict {
        if residual > threshold {
            Verdict::Inconsistent {
                residual,
                threshold,
            }
        } else {
            Verdict::Consistent {
                residual,
                threshold,
            }
        }
    }
}

/// Euclidean distance of two equally long vectors.
pub(crate) fn distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(p, q)| (p - q) * (p - q))
        .sum::<f64>()
        .sqrt()
}

impl TemporalCheck {
    /// Least training pairs per distance bin for the bin to count.
    pub const MIN_PAIRS_PER_BIN: usize = 10;

    /// Learns the threshold from training samples `(percept, command)` and the model trained
    /// on them (module doc). Samples outside the model are skipped. Errors: an invalid config,
    /// samples of the wrong dimension or not finite, fewer than two distance bins with
    /// [`Self::MIN_PAIRS_PER_BIN`] pairs ([`ServoError::NotEnoughData`]).
    pub fn learn(
        model: &InverseModel,
        samples: &[(Vec<f64>, Vec<f64>)],
        config: &TemporalConfig,
    ) -> Result<TemporalCheck> {
        config.validate()?;
        let mut kept: Vec<(&[f64], Vec<f64>)> = Vec::with_capacity(samples.len());
        for (x, y) in samples {
            check_len("sample command", y, model.command_dim())?;
            check_finite("sample command", y)?;
            match model.predict(x) {
                Ok(fx) => kept.push((y, y.iter().zip(&fx).map(|(a, b)| a - b).collect())),
                Err(ServoError::OutsideModel) => {}
                Err(e) => return Err(e),
            }
        }
        let width = config.max_move / config.bins as f64;
        let mut binned: Vec<Vec<f64>> = vec![Vec::new(); config.bins];
        for (i, (yi, ei)) in kept.iter().enumerate() {
            for (yj, ej) in &kept[i + 1..] {
                let d = distance(yi, yj);
                if d > config.max_move {
                    continue;
                }
                let bin = ((d / width) as usize).min(config.bins - 1);
                binned[bin].push(distance(ei, ej));
            }
        }
        let pairs = binned.iter().map(Vec::len).sum();
        let points: Vec<(f64, f64)> = binned
            .iter()
            .enumerate()
            .filter(|(_, r)| r.len() >= Self::MIN_PAIRS_PER_BIN)
            .map(|(k, r)| {
                (
                    (k as f64 + 0.5) * width,
                    quantile_linear(r, config.quantile),
                )
            })
            .collect();
        if points.len() < 2 {
            return Err(ServoError::NotEnoughData(format!(
                "the temporal check needs training pairs within {} in at least two distance bins",
                config.max_move
            )));
        }
        // Least-squares line through the bins' quantiles, offset and slope kept ≥ 0.
        let n = points.len() as f64;
        let (md, mq) = (
            points.iter().map(|p| p.0).sum::<f64>() / n,
            points.iter().map(|p| p.1).sum::<f64>() / n,
        );
        let sdd: f64 = points.iter().map(|p| (p.0 - md).powi(2)).sum();
        let sdq: f64 = points.iter().map(|p| (p.0 - md) * (p.1 - mq)).sum();
        let mut slope = (sdq / sdd).max(0.0);
        let mut offset = mq - slope * md;
        if offset < 0.0 {
            // Through the origin instead.
            offset = 0.0;
            let s2: f64 = points.iter().map(|p| p.0 * p.0).sum();
            slope = points.iter().map(|p| p.0 * p.1).sum::<f64>() / s2;
        }
        Ok(TemporalCheck {
            config: *config,
            offset,
            slope,
            pairs,
        })
    }

    /// Checks a quantile line as [`TemporalCheck::learn`] fits it: offset `a` and slope `b`
    /// finite and `≥ 0` (a negative threshold would refuse every percept, an infinite one
    /// none). [`ServoError::InvalidParameter`] otherwise.
    fn check_line(offset: f64, slope: f64) -> Result<()> {
        for (name, v) in [("offset", offset), ("slope", slope)] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(ServoError::invalid(
                    name,
                    &format!("the threshold line must be finite and ≥ 0, got {v}"),
                ));
            }
        }
        Ok(())
    }

    /// The settings.
    pub fn config(&self) -> &TemporalConfig {
        &self.config
    }

    /// The fitted quantile line `(a, b)`.
    pub fn line(&self) -> (f64, f64) {
        (self.offset, self.slope)
    }

    /// Training pairs within `max_move` the line was fitted to.
    pub fn pairs(&self) -> usize {
        self.pairs
    }

    /// The threshold `κ (a + b·d)` for a move of command distance `d`.
    pub fn threshold(&self, d: f64) -> f64 {
        self.config.factor * (self.offset + self.slope * d)
    }

    /// Judges percept `x` after command `y`, given the last accepted percept `last_x` and its
    /// command `last_y` (module doc). Errors: dimensions or non-finite values.
    pub fn judge(
        &self,
        model: &InverseModel,
        (last_x, last_y): (&[f64], &[f64]),
        (x, y): (&[f64], &[f64]),
    ) -> Result<Verdict> {
        check_len("command", y, model.command_dim())?;
        check_len("command", last_y, model.command_dim())?;
        check_finite("command", y)?;
        check_finite("command", last_y)?;
        let d = distance(y, last_y);
        if d > self.config.max_move {
            return Ok(Verdict::NotJudged);
        }
        let (f0, f1) = match (model.predict(last_x), model.predict(x)) {
            (Ok(a), Ok(b)) => (a, b),
            (Err(ServoError::OutsideModel), _) | (_, Err(ServoError::OutsideModel)) => {
                return Ok(Verdict::NotJudged);
            }
            (Err(e), _) | (_, Err(e)) => return Err(e),
        };
        let residual = y
            .iter()
            .zip(last_y)
            .zip(f1.iter().zip(&f0))
            .map(|((a, b), (c, e))| ((a - b) - (c - e)).powi(2))
            .sum::<f64>()
            .sqrt();
        Ok(Verdict::of(residual, self.threshold(d)))
    }
}

/// A plant whose percepts pass the [`TemporalCheck`] (module doc): an inconsistent percept is
/// refused with [`ServoError::PerceptInconsistent`] (counted), and the last accepted percept
/// stays the reference. Without a check it passes every percept through.
pub struct TemporalPlant<P: Plant> {
    plant: P,
    check: Option<(InverseModel, TemporalCheck)>,
    pending: Option<Vec<f64>>,
    last: Option<(Vec<f64>, Vec<f64>)>,
    judged: usize,
    refused: usize,
}

impl<P: Plant> TemporalPlant<P> {
    /// `plant` checked with `check` and the model it was learned with. Errors: a model whose
    /// dimensions differ from the plant's.
    pub fn new(plant: P, model: InverseModel, check: TemporalCheck) -> Result<Self> {
        if model.percept_dim() != plant.percept_dim() || model.command_dim() != plant.command_dim()
        {
            return Err(ServoError::DimensionMismatch {
                what: "temporal check model (percept × command)",
                // Saturating: a plant's own dimensions may be absurd (this overflowed).
                expected: plant.percept_dim().saturating_mul(plant.command_dim()),
                got: model.percept_dim().saturating_mul(model.command_dim()),
            });
        }
        Ok(TemporalPlant {
            check: Some((model, check)),
            ..Self::unchecked(plant)
        })
    }

    /// `plant` without a check (every percept passes; for comparisons).
    pub fn unchecked(plant: P) -> Self {
        TemporalPlant {
            plant,
            check: None,
            pending: None,
            last: None,
            judged: 0,
            refused: 0,
        }
    }

    /// The wrapped plant.
    pub fn plant(&self) -> &P {
        &self.plant
    }

    /// The wrapped plant, mutably.
    pub fn plant_mut(&mut self) -> &mut P {
        &mut self.plant
    }

    /// Gives the wrapped plant back.
    pub fn into_inner(self) -> P {
        self.plant
    }

    /// Percepts judged (a move within `max_move`, both percepts inside the model).
    pub fn judged(&self) -> usize {
        self.judged
    }

    /// Percepts refused as inconsistent.
    pub fn refused(&self) -> usize {
        self.refused
    }
}

impl<P: Plant> Plant for TemporalPlant<P> {
    fn percept_dim(&self) -> usize {
        self.plant.percept_dim()
    }

    fn command_dim(&self) -> usize {
        self.plant.command_dim()
    }

    fn command_range(&self, j: usize) -> [f64; 2] {
        self.plant.command_range(j)
    }

    /// Checks `y` ([`check_command`]) and executes it on the wrapped plant. A refused `y`
    /// reaches no plant and changes no state; on an error of the wrapped plant (a move may have
    /// been made) the pending command is forgotten, so the next percept is not judged.
    fn act(&mut self, y: &[f64]) -> Result<()> {
        check_command(&*self, y)?;
        self.pending = None;
        self.plant.act(y)?;
        self.pending = Some(y.to_vec());
        Ok(())
    }

    fn observe(&mut self) -> Result<Observation> {
        let obs = self.plant.observe()?;
        let Some(y) = self.pending.clone() else {
            // No command known for this percept: it cannot be judged nor become the reference.
            return Ok(obs);
        };
        if let (Some((model, check)), Some((lx, ly))) = (&self.check, &self.last) {
            match check.judge(model, (lx, ly), (&obs.x, &y))? {
                Verdict::Inconsistent {
                    residual,
                    threshold,
                } => {
                    self.judged += 1;
                    self.refused += 1;
                    return Err(ServoError::PerceptInconsistent {
                        residual,
                        threshold,
                    });
                }
                Verdict::Consistent { .. } => self.judged += 1,
                Verdict::NotJudged => {}
            }
        }
        self.last = Some((obs.x.clone(), y));
        Ok(obs)
    }

    fn percept_bounds(&self) -> Option<Vec<[f64; 2]>> {
        self.plant.percept_bounds()
    }
}
