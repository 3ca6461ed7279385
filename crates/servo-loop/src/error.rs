//! The crate's error type.

use thiserror::Error;

/// Everything that can stop learning or servoing. Every error leaves the learned models
/// ([`crate::InverseModel`], [`crate::GripperModel`]) exactly as they were before the failing
/// step: a model is only updated with a move whose command was executed *and* whose percept was
/// recognised.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum ServoError {
    /// The robot reported an error (the message is the robot's own).
    #[error("robot error during {during}: {message}")]
    Robot {
        /// `"command"` or `"capture"`.
        during: &'static str,
        /// The robot's error message.
        message: String,
    },
    /// The gripper was not found in a camera image with enough certainty.
    #[error("gripper not recognised in camera {camera}: certainty {certainty:.3} below {min:.3}")]
    RecognitionFailed {
        /// Camera index.
        camera: usize,
        /// Certainty of the best match (0 when there was no candidate at all).
        certainty: f64,
        /// The required certainty.
        min: f64,
    },
    /// A percept was found but doubted: its certainty stayed below the plant's threshold on
    /// every capture (e.g. the cameras' points disagree with the learned epipolar geometry).
    /// Nothing was learned from it and no move was made on it.
    #[error(
        "percept refused: camera {camera}'s certainty {certainty:.3} below {min:.3} after {captures} capture(s)"
    )]
    PerceptRefused {
        /// The camera with the lowest certainty.
        camera: usize,
        /// Its certainty on the last capture.
        certainty: f64,
        /// The plant's threshold.
        min: f64,
        /// Captures tried.
        captures: usize,
    },
    /// A percept disagrees with the accepted ones and the move commanded since
    /// ([`crate::MotionCheck`], pixels; [`crate::TemporalCheck`], command units): refused, the
    /// loop does not move on it.
    #[error(
        "percept refused: motion residual {residual:.2} exceeds {threshold:.2} (the move commanded since the accepted percepts does not explain it)"
    )]
    PerceptInconsistent {
        /// The check's residual (the motion check's pixel distance to its prediction, or the
        /// temporal check's `‖Δy − (f̂(x) − f̂(x₀))‖`).
        residual: f64,
        /// The learned threshold at this move's distance.
        threshold: f64,
    },
    /// A percept was refused and every recovery move after it ([`crate::Recovery`]) was
    /// refused too: the run stops where the last move left it.
    #[error("percept refused and not recovered after {tries} recovery move(s); last: {last}")]
    RecoveryFailed {
        /// Recovery moves made.
        tries: usize,
        /// The last refusal ([`ServoError::PerceptRefused`] or
        /// [`ServoError::PerceptInconsistent`]).
        last: Box<ServoError>,
    },
    /// A command left the servo range; nothing was sent.
    #[error("command for joint {joint} is {value:.1}, outside the servo range [{min}, {max}]")]
    OutOfServoRange {
        /// Index of the controlled joint.
        joint: usize,
        /// The offending set-point.
        value: f64,
        /// Lower end of the range.
        min: f64,
        /// Upper end of the range.
        max: f64,
    },
    /// A target lies outside the image of a camera.
    #[error("target ({u:.1}, {v:.1}) lies outside camera {camera}'s {width}×{height} image")]
    TargetOutsideImage {
        /// Camera index.
        camera: usize,
        /// Column.
        u: f64,
        /// Row.
        v: f64,
        /// Image width.
        width: u32,
        /// Image height.
        height: u32,
    },
    /// An image target whose cameras' points are not views of one 3-D point (by the learned
    /// epipolar geometry).
    #[error(
        "target inconsistent between camera 0 and camera {camera}: {distance_px:.1} px from the epipolar geometry (consistency {consistency:.3} below {min:.3})"
    )]
    TargetInconsistent {
        /// The camera whose point disagrees with camera 0's.
        camera: usize,
        /// Sampson distance of the pair (pixels).
        distance_px: f64,
        /// Its consistency.
        consistency: f64,
        /// The required consistency.
        min: f64,
    },
    /// A number that must be finite is not.
    #[error("non-finite value in {what} at index {index}")]
    NonFinite {
        /// Which argument.
        what: &'static str,
        /// Index of the first offending element.
        index: usize,
    },
    /// A vector or image set has the wrong size.
    #[error("dimension mismatch for {what}: expected {expected}, got {got}")]
    DimensionMismatch {
        /// Which argument.
        what: &'static str,
        /// Expected size.
        expected: usize,
        /// Given size.
        got: usize,
    },
    /// A parameter is outside its valid range.
    #[error("invalid parameter `{name}`: {reason}")]
    InvalidParameter {
        /// The parameter's name.
        name: &'static str,
        /// Why it was rejected.
        reason: String,
    },
    /// Learning found too little usable data (e.g. no move changed the image).
    #[error("not enough training data: {0}")]
    NotEnoughData(String),
    /// The learned inverse model has no trustworthy receptive field at the query.
    #[error("the learned model does not cover the percept (no trustworthy receptive field)")]
    OutsideModel,
    /// An error of the LWPR model.
    #[error("lwpr: {0}")]
    Lwpr(#[from] lwpr::LwprError),
    /// An error of the channel coding.
    #[error("channel coding: {0}")]
    Channel(#[from] chan_repr::ChanError),
}

impl ServoError {
    /// Whether this error is a refused percept: doubted ([`ServoError::PerceptRefused`]),
    /// inconsistent with the commanded move ([`ServoError::PerceptInconsistent`]) or not
    /// recovered ([`ServoError::RecoveryFailed`]). The loop stopped instead of moving on it.
    pub fn is_refused_percept(&self) -> bool {
        matches!(
            self,
            ServoError::PerceptRefused { .. }
                | ServoError::PerceptInconsistent { .. }
                | ServoError::RecoveryFailed { .. }
        )
    }

    /// [`ServoError::InvalidParameter`] for `name`, rejected because of `reason`.
    pub(crate) fn invalid(name: &'static str, reason: &str) -> ServoError {
        ServoError::InvalidParameter {
            name,
            reason: reason.into(),
        }
    }
}

/// Shorthand for results of this crate.
pub type Result<T> = std::result::Result<T, ServoError>;

/// Checks that every value is finite.
pub(crate) fn check_finite(what: &'static str, v: &[f64]) -> Result<()> {
    match v.iter().position(|x| !x.is_finite()) {
        Some(index) => Err(ServoError::NonFinite { what, index }),
        None => Ok(()),
    }
}

/// Checks a length.
pub(crate) fn check_len(what: &'static str, v: &[f64], expected: usize) -> Result<()> {
    if v.len() == expected {
        Ok(())
    } else {
        Err(ServoError::DimensionMismatch {
            what,
            expected,
            got: v.len(),
        })
    }
}
