//! Scores of a tracker on a sequence: RMSE of the position estimate and the track-loss share.

use serde::{Deserialize, Serialize};

use crate::data::check_point;
use crate::{Point, TrackError};

/// Accuracy of one tracker on one sequence.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Score {
    /// Root mean square of the Euclidean position error over the scored frames.
    pub rmse: f64,
    /// Share of scored frames whose error exceeds the track-loss radius.
    pub loss_share: f64,
    /// Number of scored frames: the frames `k ≥ 1` that have a truth (frame 0, the start, is
    /// not scored).
    pub frames: usize,
}

/// Scores `estimates[k]` against `truths[k]` over the frames `k ≥ 1` that have a truth
/// (frame 0 is the trackers' given start), using the first `dims` coordinates.
///
/// A typed error for slices of different lengths, `dims` outside `1..=2`, a `radius` that is
/// NaN or negative, or a coordinate that is not finite.
///
/// ```
/// use cbt_tracker::metrics::score;
/// let truth = [Some([0.0, 0.0]), Some([1.0, 0.0]), Some([2.0, 0.0])];
/// let est = [[0.0, 0.0], [1.0, 3.0], [2.0, 4.0]];
/// let s = score(&est, &truth, 2, 3.5).unwrap();
/// assert_eq!(s.frames, 2);
/// assert!((s.rmse - 12.5f64.sqrt()).abs() < 1e-12);
/// assert_eq!(s.loss_share, 0.5);
/// ```
pub fn score(
    estimates: &[Point],
    truths: &[Option<Point>],
    dims: usize,
    radius: f64,
) -> Result<Score, TrackError> {
    if estimates.len() != truths.len() {
        return Err(TrackError::Mismatch(format!(
            "{} estimates for {} frames of truth",
            estimates.len(),
            truths.len()
        )));
    }
    if !(1..=2).contains(&dims) {
        return Err(TrackError::InvalidParameter {
            name: "dims",
            value: dims as f64,
            reason: "must be 1 or 2",
        });
    }
    if radius.is_nan() || radius < 0.0 {
        return Err(TrackError::InvalidParameter {
            name: "radius",
            value: radius,
            reason: "must be a non-negative number",
        });
    }
    for (e, t) in estimates.iter().zip(truths).skip(1) {
        if let Some(t) = t {
            check_point("estimate", e, dims)?;
            check_point("truth", t, dims)?;
        }
    }
    let (mut se, mut lost, mut n) = (0.0, 0usize, 0usize);
    for (e, t) in estimates.iter().zip(truths).skip(1) {
        let Some(t) = t else { continue };
        let d2: f64 = (0..dims).map(|d| (e[d] - t[d]).powi(2)).sum();
        se += d2;
        if d2.sqrt() > radius {
            lost += 1;
        }
        n += 1;
    }
    if n == 0 {
        return Ok(Score {
            rmse: 0.0,
            loss_share: 0.0,
            frames: 0,
        });
    }
    Ok(Score {
        rmse: (se / n as f64).sqrt(),
        loss_share: lost as f64 / n as f64,
        frames: n,
    })
}
