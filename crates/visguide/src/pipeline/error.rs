//! The pipeline's typed errors.

use thiserror::Error;

/// Why learning or running the Fourier-descriptor + CBT pipeline failed.
#[derive(Debug, Error)]
pub enum PipelineError {
    /// A parameter out of range (nothing was changed).
    #[error("invalid parameter `{name}`: {reason}")]
    InvalidParameter {
        /// The parameter.
        name: &'static str,
        /// What is wrong with it.
        reason: String,
    },
    /// The training captures held too little to learn from.
    #[error("not enough training data: {0}")]
    NotEnoughData(String),
    /// The robot refused a command or a capture.
    #[error("robot failed during {during}: {message}")]
    Robot {
        /// `command` or `capture`.
        during: &'static str,
        /// The robot's own message.
        message: String,
    },
    /// Regions, contours or descriptors could not be computed.
    #[error(transparent)]
    Features(#[from] crate::VisguideError),
    /// The descriptor library refused its input.
    #[error(transparent)]
    Descriptors(#[from] fd_match::FdError),
    /// The tracker refused its input or model.
    #[error(transparent)]
    Track(#[from] cbt_tracker::TrackError),
    /// The forward model's regression (LWPR) refused its input.
    #[error("lwpr: {0}")]
    Lwpr(#[from] lwpr::LwprError),
    /// The servo library (the heuristic percept, the control space) failed.
    #[error(transparent)]
    Servo(#[from] servo_loop::ServoError),
}

/// The pipeline's result type.
pub type Result<T> = std::result::Result<T, PipelineError>;

/// `Ok` when `value` lies in `[0, 1]` (a certainty or a share), else
/// [`PipelineError::InvalidParameter`] naming the setting `name`.
pub(crate) fn check_unit_interval(name: &'static str, value: f64) -> Result<()> {
    if (0.0..=1.0).contains(&value) {
        Ok(())
    } else {
        Err(PipelineError::InvalidParameter {
            name,
            reason: format!("{value} must lie in [0, 1]"),
        })
    }
}
