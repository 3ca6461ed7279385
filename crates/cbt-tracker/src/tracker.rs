//! The interface shared by every tracker of the crate, and their common output.

use serde::{Deserialize, Serialize};

use crate::{Detection, Point, TrackError};

/// One hypothesis of an estimate: a position and its certainty.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Hypothesis {
    /// Position (value space).
    pub position: Point,
    /// Certainty: for CBT the posterior mass of the decoding window (eq. 2.5 on the
    /// posterior), in `[0, 1]`.
    pub certainty: f64,
}

/// A tracker's state estimate after a step.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Estimate {
    /// The estimated position (CBT: the best decoded mode; Kalman: the filtered mean;
    /// particle filter: the weighted particle mean).
    pub position: Point,
    /// Certainty of the estimate when the tracker has one (CBT), else `None`.
    pub certainty: Option<f64>,
    /// Runner-up hypotheses (CBT only; empty for the others). The dense layouts rank the
    /// best mode and its runner-ups by decreasing certainty; the stationary layout ranks
    /// them by the height of their highest cell (module `stationary::window`, step 4), so
    /// there a runner-up may have a larger certainty than the best mode.
    pub runner_ups: Vec<Hypothesis>,
}

impl Estimate {
    /// A bare position estimate.
    pub fn at(position: Point) -> Self {
        Estimate {
            position,
            certainty: None,
            runner_ups: Vec::new(),
        }
    }
}

/// A frame-by-frame tracker: the interface the evaluation treats every method through.
///
/// A step whose input is bad (non-finite, off-grid) returns an error and leaves the tracker
/// exactly as it was before the call.
pub trait Tracker {
    /// A short label, e.g. `CBT 2nd order` or `PF 1000`.
    fn name(&self) -> String;
    /// Restarts the track at a known position (zero velocity).
    fn reset(&mut self, start: Point) -> Result<(), TrackError>;
    /// One time step: prediction, then the update with this frame's detections (possibly
    /// none); returns the new estimate.
    fn step(&mut self, detections: &[Detection]) -> Result<Estimate, TrackError>;
    /// The current estimate.
    fn estimate(&self) -> Estimate;
}

/// One step of `tracker` on the detections that lie on its grid: a detection it refuses as
/// off its grid ([`TrackError::OutsideGrid`]) is left out and the step taken again on the rest
/// (a refused step leaves the tracker unchanged, so this is the step on the detections it can
/// use). Returns the estimate and how many detections were left out, so that the caller can
/// say so. A frame whose detections all lie off the grid is a step without detections; every
/// other error is returned as it is.
pub fn step_on_grid(
    tracker: &mut dyn Tracker,
    detections: &[Detection],
) -> Result<(Estimate, usize), TrackError> {
    let mut kept: Option<Vec<Detection>> = None;
    loop {
        let now = kept.as_deref().unwrap_or(detections);
        match tracker.step(now) {
            Ok(e) => return Ok((e, detections.len() - now.len())),
            Err(e) => {
                let &TrackError::OutsideGrid {
                    x, y, lo_y, hi_y, ..
                } = &e
                else {
                    return Err(e);
                };
                // In 1-D the error reports y = 0 and a second axis [0, 0] (a real axis has
                // hi > lo), whatever the detection's unused y: match on x alone there.
                let one_d = lo_y == 0.0 && hi_y == 0.0 && y == 0.0;
                let rest: Vec<Detection> = now
                    .iter()
                    .filter(|d| !(d.pos[0] == x && (one_d || d.pos[1] == y)))
                    .copied()
                    .collect();
                // Not one of the detections (e.g. the tracker's own state): the error stands.
                if rest.len() == now.len() {
                    return Err(e);
                }
                kept = Some(rest);
            }
        }
    }
}
