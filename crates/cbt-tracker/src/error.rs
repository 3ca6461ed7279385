//! The crate's error type.

use std::path::PathBuf;

use chan_repr::ChanError;
use thiserror::Error;

/// Everything that can go wrong when learning models, filtering or reading sequences.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum TrackError {
    /// An error of the channel representation (bad basis, value out of range, …).
    #[error("channel representation: {0}")]
    Chan(#[from] ChanError),
    /// Training data without a single usable frame (no frame with a state, or no transition
    /// for a system model of the requested order).
    #[error("empty training set: {reason}")]
    EmptyTraining {
        /// What was missing.
        reason: &'static str,
    },
    /// Held-out smoothing selection ([`crate::smoothing::select`]) impossible on these data
    /// or this configuration (one training sequence, nothing to hold out, …).
    #[error("smoothing selection: {reason}")]
    Selection {
        /// Why.
        reason: &'static str,
    },
    /// A parameter outside its valid range (zero channels, negative noise, …).
    #[error("invalid parameter `{name}` = {value}: {reason}")]
    InvalidParameter {
        /// Parameter name.
        name: &'static str,
        /// Value given.
        value: f64,
        /// Why it is invalid.
        reason: &'static str,
    },
    /// A grid on which the layout's dense tables would not fit in memory
    /// ([`crate::MAX_MODEL_VALUES`]; module `footprint`).
    #[error(
        "the {layout:?} layout would hold about {values:.2e} numbers on this grid (at most \
         2^28, 2 GiB): choose a coarser spacing, a smaller extent or the stationary layout"
    )]
    ModelTooLarge {
        /// The layout asked for.
        layout: crate::Layout,
        /// Its estimated number of `f64`-sized values.
        values: f64,
    },
    /// A NaN or infinite coordinate or weight.
    #[error("non-finite {what}: {value}")]
    NonFinite {
        /// What was non-finite.
        what: &'static str,
        /// The offending number.
        value: f64,
    },
    /// A detection or state outside the grid the models were learned on.
    #[error("{what} ({x}, {y}) is outside the tracking grid [{lo_x}, {hi_x}] × [{lo_y}, {hi_y}]")]
    OutsideGrid {
        /// What was outside (detection, state).
        what: &'static str,
        /// x coordinate.
        x: f64,
        /// y coordinate (0 for one-dimensional problems).
        y: f64,
        /// Lower end of the first axis.
        lo_x: f64,
        /// Upper end of the first axis.
        hi_x: f64,
        /// Lower end of the second axis (0 in 1-D).
        lo_y: f64,
        /// Upper end of the second axis (0 in 1-D).
        hi_y: f64,
    },
    /// A negative detection weight.
    #[error("negative detection weight {0}")]
    NegativeWeight(f64),
    /// Two models or a model and a tracker that do not belong together.
    #[error("mismatch: {0}")]
    Mismatch(String),
    /// A deserialised model or tracker whose parts do not fit together (layouts, sizes against
    /// its space, non-finite or negative values): a corrupted or hand-edited file.
    #[error("corrupt model or tracker: {0}")]
    Corrupt(String),
    /// A malformed sequence file, with the line (1-based) where it went wrong.
    #[error("{}:{line}: {reason}", path.display())]
    Csv {
        /// The file.
        path: PathBuf,
        /// 1-based line number (0: the file as a whole).
        line: usize,
        /// What is wrong.
        reason: String,
    },
    /// An I/O error (unreadable file or folder).
    #[error("{}: {reason}", path.display())]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// The operating system's message, or why the path was refused.
        reason: String,
    },
}

/// Checks that a parameter is finite and positive.
pub(crate) fn positive(name: &'static str, value: f64) -> Result<(), TrackError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(TrackError::InvalidParameter {
            name,
            value,
            reason: "must be finite and positive",
        })
    }
}

/// Checks that a parameter is finite and non-negative.
pub(crate) fn non_negative(name: &'static str, value: f64) -> Result<(), TrackError> {
    if value.is_finite() && value >= 0.0 {
        Ok(())
    } else {
        Err(TrackError::InvalidParameter {
            name,
            value,
            reason: "must be finite and non-negative",
        })
    }
}

/// Checks that a parameter is finite and in `[0, 1]` (or `[0, 1)` when `open` is set).
pub(crate) fn unit(name: &'static str, value: f64, open: bool) -> Result<(), TrackError> {
    if value.is_finite() && value >= 0.0 && (value < 1.0 || (!open && value == 1.0)) {
        Ok(())
    } else {
        Err(TrackError::InvalidParameter {
            name,
            value,
            reason: if open {
                "must lie in [0, 1)"
            } else {
                "must lie in [0, 1]"
            },
        })
    }
}
