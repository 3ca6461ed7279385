//! The crate's error type.

use thiserror::Error;

/// Everything that can go wrong in this crate. Every fallible call leaves the model exactly as
/// it was before the call.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum LwprError {
    /// A parameter given to the builder is out of its valid range.
    #[error("invalid parameter `{name}`: {reason}")]
    InvalidParameter {
        /// The parameter's name (the reference library's name).
        name: &'static str,
        /// Why it was rejected.
        reason: String,
    },
    /// An input or output vector has the wrong length.
    #[error("dimension mismatch for {what}: expected {expected}, got {got}")]
    DimensionMismatch {
        /// Which argument (`x`, `y`, ...).
        what: &'static str,
        /// The model's dimension.
        expected: usize,
        /// The length that was passed.
        got: usize,
    },
    /// An input or output value is NaN or infinite.
    #[error("non-finite value in {what} at index {index}")]
    NonFinite {
        /// Which argument (`x`, `y`, `cutoff`).
        what: &'static str,
        /// Index of the first offending element.
        index: usize,
    },
    /// A finite input or output so large that the model's arithmetic (squares and products
    /// of differences in its statistics and metric gradient) could overflow.
    #[error("{what}[{index}] = {value:e} exceeds the documented bound of {bound:e}")]
    TooLarge {
        /// Which argument (`x`, `y`, `x / norm_in`, `y / norm_out`).
        what: &'static str,
        /// Index of the first offending element.
        index: usize,
        /// Its value.
        value: f64,
        /// The bound ([`crate::MAX_ABS_VALUE`]).
        bound: f64,
    },
    /// A model larger than the documented limits ([`crate::MAX_INPUTS`], [`crate::MAX_OUTPUTS`]).
    #[error("{what} = {got} exceeds the limit of {max}")]
    TooBig {
        /// `n_in` or `n_out`.
        what: &'static str,
        /// The size asked for.
        got: usize,
        /// The limit.
        max: usize,
    },
    /// [`Lwpr::predict_with_confidence`](crate::Lwpr::predict_with_confidence) at an input
    /// where an active, trustworthy receptive field has no PLS direction with enough data for
    /// the bound: its only direction (always so with one input) has a discounted data count of
    /// `2·n_in` or less, as after fast forgetting (a small `final_lambda`), so there is no
    /// cross-validation error to scale the bound by (the reference library reads before its
    /// array there). [`Lwpr::predict`](crate::Lwpr::predict) and
    /// [`Lwpr::predict_with_jacobian`](crate::Lwpr::predict_with_jacobian) do not need it.
    #[error(
        "no confidence bound: receptive field {field} of output {output} is trustworthy but \
         its only PLS direction has too little data"
    )]
    NoConfidence {
        /// The output dimension.
        output: usize,
        /// Index of the receptive field among that output's fields.
        field: usize,
    },
    /// A saved model could not be read (corrupt, truncated, wrong version or inconsistent).
    #[error("cannot load model: {0}")]
    Format(String),
    /// An I/O error while reading or writing a model file.
    #[error("i/o error: {0}")]
    Io(String),
}

impl From<std::io::Error> for LwprError {
    fn from(e: std::io::Error) -> Self {
        LwprError::Io(e.to_string())
    }
}

/// Shorthand for results of this crate.
pub type Result<T> = std::result::Result<T, LwprError>;
