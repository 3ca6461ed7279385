//! Plain data: points, detections, training frames and sequences.

use serde::{Deserialize, Serialize};

use crate::TrackError;

/// A position. Two-dimensional problems (image coordinates) use both entries; one-dimensional
/// problems (e.g. the UNGM benchmark) use `[x, 0.0]`.
pub type Point = [f64; 2];

/// One detection of a frame: its position and a non-negative confidence weight (1 for a
/// plain detection). Clutter is not marked: the trackers cannot tell it from the target.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Detection {
    /// Detected position (measurement space).
    pub pos: Point,
    /// Detector confidence; the channel encoding of the detection is scaled by it.
    pub weight: f64,
}

impl Detection {
    /// A detection with weight 1.
    pub fn new(x: f64, y: f64) -> Self {
        Detection {
            pos: [x, y],
            weight: 1.0,
        }
    }

    /// Checks the coordinates (the first `dims`) and the weight are finite, weight ≥ 0.
    pub(crate) fn validate(&self, dims: usize) -> Result<(), TrackError> {
        check_point("detection coordinate", &self.pos, dims)?;
        if !self.weight.is_finite() {
            return Err(TrackError::NonFinite {
                what: "detection weight",
                value: self.weight,
            });
        }
        if self.weight < 0.0 {
            return Err(TrackError::NegativeWeight(self.weight));
        }
        Ok(())
    }
}

/// Checks the first `dims` coordinates of a point are finite.
pub(crate) fn check_point(what: &'static str, p: &Point, dims: usize) -> Result<(), TrackError> {
    check_finite(what, &p[..dims])
}

/// Checks that every truth and detection coordinate (both axes) of `train` is finite: the
/// training statistics ([`crate::Calibration::estimate`], [`crate::Scales::estimate`]) would
/// otherwise turn a NaN into a silently wrong scale.
pub(crate) fn check_sequences(train: &[Sequence]) -> Result<(), TrackError> {
    for f in train.iter().flat_map(|s| &s.frames) {
        if let Some(t) = &f.truth {
            check_point("truth coordinate", t, 2)?;
        }
        for d in &f.detections {
            check_point("detection coordinate", &d.pos, 2)?;
        }
    }
    Ok(())
}

/// Checks every value is finite: [`TrackError::NonFinite`] with the first that is not.
pub(crate) fn check_finite(what: &'static str, v: &[f64]) -> Result<(), TrackError> {
    match v.iter().find(|v| !v.is_finite()) {
        Some(&value) => Err(TrackError::NonFinite { what, value }),
        None => Ok(()),
    }
}

/// One training frame: the (unordered) set of true states and the (unordered) set of
/// detections, clutter included. No association between the two is given or needed.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TrainingFrame {
    /// The states present in the frame (usually the one annotated target position; may be
    /// empty when the frame is unannotated).
    pub states: Vec<Point>,
    /// The frame's detections.
    pub detections: Vec<Detection>,
}

/// A sequence of frames with ground truth and detections, as used for training and scoring.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Sequence {
    /// A name (file stem, generator label).
    pub name: String,
    /// The frame number of `frames[0]` in the source (a file's smallest frame number;
    /// MOTChallenge files start at 1). Generated sequences start at 0.
    #[serde(default)]
    pub first_frame: u64,
    /// The frames, in time order (`frames[k]` is frame number `first_frame + k`).
    pub frames: Vec<Frame>,
}

/// One frame of a [`Sequence`]: at most one true position and any number of detections.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Frame {
    /// The true target position, when known.
    pub truth: Option<Point>,
    /// Detections, clutter included.
    pub detections: Vec<Detection>,
}

impl Sequence {
    /// Index of the first frame with a truth: where a tracker starts (earlier frames are
    /// not scored); `None` when no frame has one.
    pub fn start(&self) -> Option<usize> {
        self.frames.iter().position(|f| f.truth.is_some())
    }

    /// The smallest box `(lo, hi)` holding every truth and detection position of `sequences`
    /// (what a tracker's state space must cover); `None` when they hold no position.
    ///
    /// ```
    /// use cbt_tracker::{Detection, Frame, Sequence};
    /// let s = Sequence {
    ///     frames: vec![Frame { truth: Some([1.0, 5.0]), detections: vec![Detection::new(3.0, -2.0)] }],
    ///     ..Default::default()
    /// };
    /// assert_eq!(Sequence::bounds([&s]), Some(([1.0, -2.0], [3.0, 5.0])));
    /// assert_eq!(Sequence::bounds([&Sequence::default()]), None);
    /// ```
    pub fn bounds<'a>(sequences: impl IntoIterator<Item = &'a Sequence>) -> Option<(Point, Point)> {
        let mut lo = [f64::INFINITY; 2];
        let mut hi = [f64::NEG_INFINITY; 2];
        for s in sequences {
            for f in &s.frames {
                for p in f.truth.iter().chain(f.detections.iter().map(|d| &d.pos)) {
                    for d in 0..2 {
                        lo[d] = lo[d].min(p[d]);
                        hi[d] = hi[d].max(p[d]);
                    }
                }
            }
        }
        lo[0].is_finite().then_some((lo, hi))
    }

    /// The sequence as training frames (the truth, when present, is the frame's one state).
    pub fn training_frames(&self) -> Vec<TrainingFrame> {
        self.frames
            .iter()
            .map(|f| TrainingFrame {
                states: f.truth.into_iter().collect(),
                detections: f.detections.clone(),
            })
            .collect()
    }
}
