//! The motion check of percepts: a percept must agree with what the learner has seen near the
//! commanded pose, moved by the commanded difference (issue #19; docs/methods.md § Servoing,
//! *Motion check*).
//!
//! A tip found at the wrong place *along* the epipolar line passes every cross-camera check;
//! the commanded move does not explain it. The check remembers accepted percepts with their
//! commands `(x_i, y_i)`: the training moves' percepts, then every percept the servo accepted
//! (so during servoing the previous accepted percept is the nearest reference). For a new
//! percept `x` after command `y` it takes the [`MotionConfig::neighbours`] remembered percepts
//! whose commands are nearest `y` (within [`MotionConfig::reach`]) and predicts
//! `x̂ = x_i + Ĵ (y − y_i)` by a local linear fit (least squares of `x` on `[1, y − y_i]`, refitted
//! once without neighbours more than 3 times the median fit residual away, so a wrong
//! remembered percept does not carry the prediction); `Ĵ` is the image Jacobian the learner's
//! own moves show there. The **residual** is the largest pixel distance over the cameras,
//! `r = max_c ‖x_c − x̂_c‖`.
//!
//! The threshold is learned from the training moves themselves: every training percept is
//! predicted from the others (leave one out) and the threshold is
//! `κ · q` with `q` the residuals' [`MotionConfig::quantile`] and `κ` =
//! [`MotionConfig::factor`]. A percept with `r > κ q` is inconsistent; a [`VisualPlant`]
//! re-captures it and then refuses it with [`ServoError::PerceptInconsistent`] (the loop never
//! moves on it). A command with too few remembered percepts within reach is not judged.
//!
//! [`VisualPlant`]: crate::VisualPlant

use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use crate::error::{Result, ServoError, check_finite};
use crate::stats::quantile_linear;
use crate::temporal::{Verdict, distance};

/// Settings of [`MotionCheck::learn`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MotionConfig {
    /// Remembered percepts the prediction is fitted to (at least command dimension + 2).
    pub neighbours: usize,
    /// Largest command distance (Euclidean over the controlled set-points) of a neighbour.
    pub reach: f64,
    /// Quantile of the training moves' leave-one-out residuals (in `(0, 1)`).
    pub quantile: f64,
    /// Factor `κ > 0` on that quantile.
    pub factor: f64,
}

impl Default for MotionConfig {
    /// 16 neighbours within 150 command units (µs for hobby servos; the training moves of
    /// `eval servo` lie about 50 µs apart), the median residual, factor 4: fixed before any
    /// run (the median and factor 4 as for the [`crate::TemporalCheck`]), not tuned.
    fn default() -> Self {
        MotionConfig {
            neighbours: 16,
            reach: 150.0,
            quantile: 0.5,
            factor: 4.0,
        }
    }
}

impl MotionConfig {
    /// Checks every field's range (`neighbours ≥ 3`; the fit needs command dimension + 2,
    /// checked by [`MotionCheck::learn`]).
    pub fn validate(&self) -> Result<()> {
        if self.neighbours < 3 {
            return Err(ServoError::invalid("neighbours", "at least 3"));
        }
        if !(self.reach.is_finite() && self.reach > 0.0) {
            return Err(ServoError::invalid("reach", "must be finite and positive"));
        }
        if !(self.quantile > 0.0 && self.quantile < 1.0) {
            return Err(ServoError::invalid("quantile", "must lie in (0, 1)"));
        }
        if !(self.factor.is_finite() && self.factor > 0.0) {
            return Err(ServoError::invalid("factor", "must be finite and positive"));
        }
        Ok(())
    }
}

/// The learned motion check (module doc): remembered percepts and the threshold. A saved
/// check is checked as it is read (settings, dimensions, every remembered pair, the scale).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "MotionCheckFile")]
pub struct MotionCheck {
    config: MotionConfig,
    percept_dim: usize,
    command_dim: usize,
    /// Remembered `(percept, command)` pairs: training moves first, then accepted percepts.
    memory: Vec<(Vec<f64>, Vec<f64>)>,
    /// Training moves among `memory` (the first ones).
    trained: usize,
    /// The learned quantile `q` of the leave-one-out residuals.
    scale: f64,
}

/// A [`MotionCheck`] as read, before its checks.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MotionCheckFile {
    config: MotionConfig,
    percept_dim: usize,
    command_dim: usize,
    memory: Vec<(Vec<f64>, Vec<f64>)>,
    trained: usize,
    scale: f64,
}

impl TryFrom<MotionCheckFile> for MotionCheck {
    type Error = ServoError;

    fn try_from(f: MotionCheckFile) -> Result<Self> {
        f.config.validate()?;
        check_dims(&f.config, f.percept_dim, f.command_dim)?;
        check_samples(&f.memory, f.percept_dim, f.command_dim)?;
        if f.trained == 0 || f.trained > f.memory.len() {
            return Err(ServoError::invalid(
                "trained",
                "must count at least one and at most the remembered percepts",
            ));
        }
        if !(f.scale.is_finite() && f.scale >= 0.0) {
            return Err(ServoError::invalid("scale", "must be finite and ≥ 0"));
        }
        Ok(MotionCheck {
            config: f.config,
            percept_dim: f.percept_dim,
            command_dim: f.command_dim,
            memory: f.memory,
            trained: f.trained,
            scale: f.scale,
        })
    }
}

/// Checks the dimensions against each other and the settings: 2 coordinates per camera, a
/// non-empty command, enough neighbours for a local linear fit.
fn check_dims(config: &MotionConfig, percept_dim: usize, command_dim: usize) -> Result<()> {
    if percept_dim == 0 || !percept_dim.is_multiple_of(2) || command_dim == 0 {
        return Err(ServoError::invalid(
            "samples",
            "percepts of 2 coordinates per camera and a non-empty command",
        ));
    }
    // Saturating: a saved check's `command_dim` may be anything (`usize::MAX` overflowed).
    if config.neighbours < command_dim.saturating_add(2) {
        return Err(ServoError::invalid(
            "neighbours",
            "at least the command dimension + 2 (a local linear fit)",
        ));
    }
    Ok(())
}

/// Checks every `(percept, command)` pair's dimensions and values.
fn check_samples(
    samples: &[(Vec<f64>, Vec<f64>)],
    percept_dim: usize,
    command_dim: usize,
) -> Result<()> {
    for (x, y) in samples {
        if x.len() != percept_dim || y.len() != command_dim {
            return Err(ServoError::DimensionMismatch {
                what: "motion check sample (percept + command)",
                // Saturating: a saved check's dimensions may be anything (they overflowed).
                expected: percept_dim.saturating_add(command_dim),
                got: x.len() + y.len(),
            });
        }
        check_finite("sample percept", x)?;
        check_finite("sample command", y)?;
    }
    Ok(())
}

/// Largest 2-D distance over the cameras (pairs of coordinates).
fn camera_residual(x: &[f64], p: &[f64]) -> f64 {
    x.chunks(2)
        .zip(p.chunks(2))
        .map(|(a, b)| distance(a, b))
        .fold(0.0, f64::max)
}

impl MotionCheck {
    /// Learns the check from training samples `(percept, command)` (module doc). Errors: an
    /// invalid config, fewer neighbours than command dimension + 2, samples of mixed or odd
    /// percept dimension or not finite, fewer than `neighbours + 1` samples or no training
    /// sample with enough neighbours within reach ([`ServoError::NotEnoughData`]).
    pub fn learn(samples: &[(Vec<f64>, Vec<f64>)], config: &MotionConfig) -> Result<MotionCheck> {
        config.validate()?;
        let Some((x0, y0)) = samples.first() else {
            return Err(ServoError::NotEnoughData(
                "the motion check needs training samples".into(),
            ));
        };
        let (percept_dim, command_dim) = (x0.len(), y0.len());
        check_dims(config, percept_dim, command_dim)?;
        check_samples(samples, percept_dim, command_dim)?;
        if samples.len() <= config.neighbours {
            return Err(ServoError::NotEnoughData(format!(
                "the motion check needs more than {} training samples",
                config.neighbours
            )));
        }
        let mut check = MotionCheck {
            config: *config,
            percept_dim,
            command_dim,
            memory: samples.to_vec(),
            trained: samples.len(),
            scale: 0.0,
        };
        let residuals: Vec<f64> = (0..samples.len())
            .filter_map(|i| {
                let (x, y) = &samples[i];
                check
                    .predict_excluding(y, Some(i))
                    .map(|p| camera_residual(x, &p))
            })
            .collect();
        if residuals.is_empty() {
            return Err(ServoError::NotEnoughData(format!(
                "no training sample has {} others within {}",
                config.neighbours, config.reach
            )));
        }
        check.scale = quantile_linear(&residuals, config.quantile);
        Ok(check)
    }

    /// The settings.
    pub fn config(&self) -> &MotionConfig {
        &self.config
    }

    /// Percept dimension (2 per camera).
    pub fn percept_dim(&self) -> usize {
        self.percept_dim
    }

    /// Command dimension.
    pub fn command_dim(&self) -> usize {
        self.command_dim
    }

    /// The threshold `κ q` in pixels.
    pub fn threshold(&self) -> f64 {
        self.config.factor * self.scale
    }

    /// Remembered percepts (training moves and accepted percepts).
    pub fn remembered(&self) -> usize {
        self.memory.len()
    }

    /// Training moves the threshold was learned from.
    pub fn trained(&self) -> usize {
        self.trained
    }

    /// The percept predicted at command `y` from the remembered percepts near it; `None` when
    /// fewer than `neighbours` lie within reach. Errors: dimension, non-finite values.
    pub fn predict(&self, y: &[f64]) -> Result<Option<Vec<f64>>> {
        self.check_command(y)?;
        Ok(self.predict_excluding(y, None))
    }

    fn check_command(&self, y: &[f64]) -> Result<()> {
        if y.len() != self.command_dim {
            return Err(ServoError::DimensionMismatch {
                what: "command",
                expected: self.command_dim,
                got: y.len(),
            });
        }
        check_finite("command", y)
    }

    /// The local linear prediction (module doc), leaving out memory entry `skip`.
    fn predict_excluding(&self, y: &[f64], skip: Option<usize>) -> Option<Vec<f64>> {
        let k = self.config.neighbours;
        let mut near: Vec<(f64, usize)> = self
            .memory
            .iter()
            .enumerate()
            .filter(|&(i, _)| Some(i) != skip)
            .map(|(i, (_, yi))| (distance(yi, y), i))
            .filter(|&(d, _)| d <= self.config.reach)
            .collect();
        if near.len() < k {
            return None;
        }
        // The k nearest (ties by memory order: deterministic).
        let cmp = |a: &(f64, usize), b: &(f64, usize)| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1));
        near.select_nth_unstable_by(k - 1, cmp);
        near.truncate(k);
        near.sort_by(cmp);
        let idx: Vec<usize> = near.iter().map(|&(_, i)| i).collect();
        let first = self.fit(y, &idx)?;
        // Refit without neighbours far off the first fit (a wrong remembered percept).
        let mut res: Vec<f64> = idx
            .iter()
            .map(|&i| camera_residual(&self.memory[i].0, &self.fitted(&first, y, i)))
            .collect();
        let cut = 3.0 * quantile_linear(&res, 0.5);
        let kept: Vec<usize> = idx
            .iter()
            .zip(res.drain(..))
            .filter(|&(_, r)| r <= cut)
            .map(|(&i, _)| i)
            .collect();
        if kept.len() == idx.len() || kept.len() < self.command_dim + 2 {
            return Some(first.column(0).iter().copied().collect());
        }
        let second = self.fit(y, &kept)?;
        Some(second.column(0).iter().copied().collect())
    }

    /// Least squares of the neighbours' percepts on `[1, y_i − y]`: a
    /// `percept_dim × (1 + command_dim)` matrix, column 0 the prediction at `y`.
    fn fit(&self, y: &[f64], idx: &[usize]) -> Option<DMatrix<f64>> {
        let m = self.command_dim;
        let a = DMatrix::from_fn(idx.len(), m + 1, |r, c| {
            if c == 0 {
                1.0
            } else {
                self.memory[idx[r]].1[c - 1] - y[c - 1]
            }
        });
        let b = DMatrix::from_fn(idx.len(), self.percept_dim, |r, c| self.memory[idx[r]].0[c]);
        let svd = a.svd(true, true);
        let sol = svd.solve(&b, 1e-9).ok()?;
        if sol.iter().all(|v| v.is_finite()) {
            Some(sol.transpose())
        } else {
            None
        }
    }

    /// The fit's percept at memory entry `i`'s command.
    fn fitted(&self, fit: &DMatrix<f64>, y: &[f64], i: usize) -> Vec<f64> {
        let dy = DVector::from_iterator(
            self.command_dim + 1,
            std::iter::once(1.0).chain(self.memory[i].1.iter().zip(y).map(|(a, b)| a - b)),
        );
        (fit * dy).iter().copied().collect()
    }

    /// Judges percept `x` after command `y` (module doc). Errors: dimensions, non-finite
    /// values.
    pub fn judge(&self, x: &[f64], y: &[f64]) -> Result<Verdict> {
        self.check_pair(x, y)?;
        Ok(match self.predict_excluding(y, None) {
            Some(p) => Verdict::of(camera_residual(x, &p), self.threshold()),
            None => Verdict::NotJudged,
        })
    }

    /// Checks a percept and command's dimensions and values.
    fn check_pair(&self, x: &[f64], y: &[f64]) -> Result<()> {
        self.check_command(y)?;
        if x.len() != self.percept_dim {
            return Err(ServoError::DimensionMismatch {
                what: "percept",
                expected: self.percept_dim,
                got: x.len(),
            });
        }
        check_finite("percept", x)
    }

    /// Remembers an accepted percept `x` at command `y` (the next percepts near `y` are
    /// predicted from it too). Errors: dimensions, non-finite values.
    pub fn remember(&mut self, x: &[f64], y: &[f64]) -> Result<()> {
        self.check_pair(x, y)?;
        self.memory.push((x.to_vec(), y.to_vec()));
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A smooth non-linear map from 2 commands to 2 cameras' points, sampled on a grid.
    fn g(y: &[f64]) -> Vec<f64> {
        let (a, b) = (y[0] / 300.0, y[1] / 300.0);
        vec![
            300.0 + 80.0 * a.cos() + 40.0 * (a + b).cos(),
            200.0 + 80.0 * a.sin() + 40.0 * (a + b).sin(),
            310.0 + 75.0 * a.cos() + 42.0 * (a + b).cos(),
            190.0 + 70.0 * a.sin() + 45.0 * (a + b).sin(),
        ]
    }

    fn grid() -> Vec<(Vec<f64>, Vec<f64>)> {
        let mut s = Vec::new();
        for i in 0..20 {
            for j in 0..20 {
                let y = vec![20.0 + 10.0 * i as f64, 40.0 + 10.0 * j as f64];
                // A small deterministic "recognition noise".
                let mut x = g(&y);
                x[0] += 0.3 * ((i * 7 + j * 3) % 5) as f64 - 0.6;
                s.push((x, y));
            }
        }
        s
    }

    fn config() -> MotionConfig {
        MotionConfig {
            reach: 40.0,
            ..MotionConfig::default()
        }
    }

    #[test]
    fn predicts_a_smooth_map_and_refuses_a_gross_offset() {
        let check = MotionCheck::learn(&grid(), &config()).unwrap();
        assert!(check.threshold() > 0.0 && check.threshold() < 3.0);
        let y = [105.0, 133.0];
        let p = check.predict(&y).unwrap().unwrap();
        assert!(camera_residual(&p, &g(&y)) < 0.5, "{p:?}");
        assert!(matches!(
            check.judge(&g(&y), &y).unwrap(),
            Verdict::Consistent { .. }
        ));
        // 8 px off in camera 1 only (the threshold is about 4 × the noise's median).
        let mut x = g(&y);
        x[3] += 8.0;
        assert!(matches!(
            check.judge(&x, &y).unwrap(),
            Verdict::Inconsistent { residual, .. } if residual > 7.0
        ));
        // Far outside what was seen: not judged.
        assert_eq!(
            check.judge(&x, &[900.0, 900.0]).unwrap(),
            Verdict::NotJudged
        );
    }

    #[test]
    fn a_wrong_remembered_percept_does_not_carry_the_prediction() {
        let mut check = MotionCheck::learn(&grid(), &config()).unwrap();
        let y = [105.0, 133.0];
        let mut wrong = g(&[106.0, 133.0]);
        wrong[0] += 40.0;
        check.remember(&wrong, &[106.0, 133.0]).unwrap();
        assert_eq!(check.remembered(), 401);
        assert_eq!(check.trained(), 400);
        let p = check.predict(&y).unwrap().unwrap();
        assert!(camera_residual(&p, &g(&y)) < 0.5, "{p:?}");
    }

    #[test]
    fn bad_input_is_a_typed_error() {
        let s = grid();
        for bad in [
            MotionConfig {
                neighbours: 2,
                ..config()
            },
            MotionConfig {
                reach: f64::NAN,
                ..config()
            },
            MotionConfig {
                quantile: 1.0,
                ..config()
            },
            MotionConfig {
                factor: 0.0,
                ..config()
            },
            // Too few for a local linear fit in 2 commands.
            MotionConfig {
                neighbours: 3,
                ..config()
            },
        ] {
            assert!(matches!(
                MotionCheck::learn(&s, &bad),
                Err(ServoError::InvalidParameter { .. })
            ));
        }
        assert!(matches!(
            MotionCheck::learn(&s[..10], &config()),
            Err(ServoError::NotEnoughData(_))
        ));
        assert!(matches!(
            MotionCheck::learn(&[], &config()),
            Err(ServoError::NotEnoughData(_))
        ));
        let mut odd = s.clone();
        odd[3].0.pop();
        assert!(MotionCheck::learn(&odd, &config()).is_err());
        let mut nan = s.clone();
        nan[3].1[0] = f64::NAN;
        assert!(matches!(
            MotionCheck::learn(&nan, &config()),
            Err(ServoError::NonFinite { .. })
        ));
        let check = MotionCheck::learn(&s, &config()).unwrap();
        assert!(check.judge(&[1.0; 3], &[100.0, 100.0]).is_err());
        assert!(check.judge(&[1.0; 4], &[100.0]).is_err());
        assert!(check.judge(&[f64::NAN; 4], &[100.0, 100.0]).is_err());
        // A refused percept or command is not remembered, whichever check refuses it.
        let mut c = check.clone();
        for (x, y) in [
            (vec![1.0; 4], vec![f64::INFINITY, 0.0]),
            (vec![1.0; 4], vec![100.0]),
            (vec![1.0; 4], vec![100.0, 100.0, 100.0]),
            (vec![1.0; 3], vec![100.0, 100.0]),
            (vec![1.0; 5], vec![100.0, 100.0]),
            (vec![1.0, f64::NAN, 1.0, 1.0], vec![100.0, 100.0]),
        ] {
            assert!(c.remember(&x, &y).is_err(), "{x:?} {y:?}: accepted");
            assert_eq!(c, check, "{x:?} {y:?}: remembered");
        }
    }

    #[test]
    fn a_saved_check_is_checked_as_it_is_read() {
        let check = MotionCheck::learn(&grid(), &config()).unwrap();
        let json = serde_json::to_value(&check).unwrap();
        let back: MotionCheck = serde_json::from_value(json.clone()).unwrap();
        assert_eq!(back, check);
        // Each edit would make `judge` index out of bounds or compare against nonsense.
        let edits: [(&str, serde_json::Value); 5] = [
            ("/memory/7/0", serde_json::json!([1.0, 2.0, 3.0])),
            ("/memory/7/1/0", serde_json::Value::Null),
            ("/trained", serde_json::json!(100_000)),
            ("/scale", serde_json::json!(-1.0)),
            ("/command_dim", serde_json::json!(3)),
        ];
        for (path, value) in edits {
            let mut bad = json.clone();
            *bad.pointer_mut(path).unwrap() = value;
            assert!(
                serde_json::from_value::<MotionCheck>(bad).is_err(),
                "{path} accepted"
            );
        }
    }
}
