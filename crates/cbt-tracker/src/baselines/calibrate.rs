//! Noise and clutter statistics of a training set with ground truth, used to set the
//! baselines' parameters (the baselines get what they need from the same training data CBT
//! learns from, never from the test data).

use serde::{Deserialize, Serialize};

use crate::error::{non_negative, positive, unit};
use crate::{Sequence, TrackError};

/// Statistics of a training set: process and detection noise, detection probability and
/// clutter rate.
///
/// Read back with serde it is validated as [`Calibration::validate`] checks
/// ([`TrackError::InvalidParameter`] otherwise), like every value [`Calibration::estimate`]
/// returns.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "CalibrationRaw")]
pub struct Calibration {
    /// Acceleration noise `σ_a` per axis of a discrete white-noise-acceleration model:
    /// `sqrt(2 · mean((x_{k+1} − 2x_k + x_{k−1})²))` of the truth (the second difference of
    /// that model has variance `σ_a²/2`).
    pub accel_sigma: f64,
    /// Detection noise `σ_z` per axis: 1.4826 · median |residual| of the detection nearest to
    /// the truth (residuals beyond `max_residual` ignored as clutter).
    pub meas_sigma: f64,
    /// Detection probability: share of truth frames with a detection within 3 `σ_z` (both
    /// axes).
    pub p_detect: f64,
    /// Mean number of the other detections per frame (clutter).
    pub clutter_rate: f64,
}

/// A [`Calibration`] as read, before its check.
#[derive(Deserialize)]
struct CalibrationRaw {
    accel_sigma: f64,
    meas_sigma: f64,
    p_detect: f64,
    clutter_rate: f64,
}

impl TryFrom<CalibrationRaw> for Calibration {
    type Error = TrackError;

    fn try_from(r: CalibrationRaw) -> Result<Self, TrackError> {
        let c = Calibration {
            accel_sigma: r.accel_sigma,
            meas_sigma: r.meas_sigma,
            p_detect: r.p_detect,
            clutter_rate: r.clutter_rate,
        };
        c.validate()?;
        Ok(c)
    }
}

impl Calibration {
    /// Checks what [`Calibration::estimate`] guarantees: both noise scales finite and
    /// positive, `p_detect` in `[0, 1]`, `clutter_rate` finite and non-negative.
    pub fn validate(&self) -> Result<(), TrackError> {
        positive("accel_sigma", self.accel_sigma)?;
        positive("meas_sigma", self.meas_sigma)?;
        unit("p_detect", self.p_detect, false)?;
        non_negative("clutter_rate", self.clutter_rate)
    }

    /// Estimates the statistics from sequences with truth; `max_residual` bounds the
    /// residuals taken as the target's (e.g. a tenth of the image size).
    /// `max_residual` must be finite and positive, and every truth and detection coordinate
    /// finite ([`TrackError::NonFinite`]); statistics that overflow are
    /// [`TrackError::InvalidParameter`] errors.
    pub fn estimate(train: &[Sequence], max_residual: f64) -> Result<Calibration, TrackError> {
        positive("max_residual", max_residual)?;
        crate::data::check_sequences(train)?;
        let mut acc2 = Vec::new();
        let mut res = Vec::new();
        for s in train {
            for w in s.frames.windows(3) {
                if let (Some(a), Some(b), Some(c)) = (w[0].truth, w[1].truth, w[2].truth) {
                    for d in 0..2 {
                        acc2.push((c[d] - 2.0 * b[d] + a[d]).powi(2));
                    }
                }
            }
        }
        if acc2.is_empty() {
            return Err(TrackError::EmptyTraining {
                reason: "no three consecutive frames with truth to calibrate the baselines",
            });
        }
        let accel_sigma = (2.0 * acc2.iter().sum::<f64>() / acc2.len() as f64)
            .sqrt()
            .max(1e-6);
        // The residual of the detection nearest to the truth per frame (with clutter, the
        // median of all residuals within the box would over-estimate σ_z).
        for s in train {
            for f in &s.frames {
                let Some(t) = f.truth else { continue };
                let best = f
                    .detections
                    .iter()
                    .map(|d| ((d.pos[0] - t[0]).abs(), (d.pos[1] - t[1]).abs()))
                    .filter(|r| r.0 < max_residual && r.1 < max_residual)
                    .min_by(|a, b| (a.0.hypot(a.1)).total_cmp(&b.0.hypot(b.1)));
                if let Some((rx, ry)) = best {
                    res.push(rx);
                    res.push(ry);
                }
            }
        }
        let meas_sigma = if res.is_empty() {
            max_residual / 3.0
        } else {
            res.sort_by(f64::total_cmp);
            (1.4826 * res[res.len() / 2]).max(1e-3)
        };
        let (mut frames, mut hits, mut others) = (0usize, 0usize, 0usize);
        for s in train {
            for f in &s.frames {
                let Some(t) = f.truth else { continue };
                frames += 1;
                let hit = f.detections.iter().any(|d| {
                    (d.pos[0] - t[0]).abs() <= 3.0 * meas_sigma
                        && (d.pos[1] - t[1]).abs() <= 3.0 * meas_sigma
                });
                if hit {
                    hits += 1;
                }
                others += f.detections.len() - usize::from(hit);
            }
        }
        let frames = frames.max(1) as f64;
        let c = Calibration {
            accel_sigma,
            meas_sigma,
            p_detect: (hits as f64 / frames).clamp(0.01, 0.999),
            clutter_rate: others as f64 / frames,
        };
        // Finite coordinates can still overflow (a jump of 1e300 squares to ∞).
        c.validate()?;
        Ok(c)
    }
}
