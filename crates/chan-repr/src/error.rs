//! The crate's error type.

use thiserror::Error;

/// Everything that can go wrong when building a basis, encoding or decoding.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ChanError {
    /// A basis with no channels, or fewer than one decoding window needs.
    #[error("{got} channels are too few: the kernel's decoding window needs at least {needed}")]
    TooFewChannels {
        /// Channels asked for.
        got: usize,
        /// The decoding window's size.
        needed: usize,
    },
    /// A basis or grid larger than the documented limit (checked before any allocation).
    #[error("{got} channels exceed the limit of {max}")]
    TooManyChannels {
        /// Channels asked for.
        got: usize,
        /// The limit.
        max: usize,
    },
    /// A finite number so large that sums of it could overflow (weights, coefficients and
    /// histogram totals are limited to [`crate::MAX_MASS`]), or a Gaussian kernel so wide that
    /// its decoding is rounding noise (`sigma` is limited to [`crate::GAUSSIAN_MAX_SIGMA`]).
    #[error("{what} {value} exceeds the limit of {max}")]
    TooLarge {
        /// What was too large.
        what: &'static str,
        /// The offending number.
        value: f64,
        /// The limit.
        max: f64,
    },
    /// A channel index outside its dimension.
    #[error("channel index {index} of dimension {dim} is outside 0..{len}")]
    IndexOutOfBounds {
        /// The dimension.
        dim: usize,
        /// The index given.
        index: usize,
        /// The dimension's number of channels.
        len: usize,
    },
    /// A kernel width that leaves too few overlapping channels for local decoding.
    #[error("kernel too narrow: {reason}")]
    TooNarrow {
        /// Which limit was violated.
        reason: String,
    },
    /// A parameter (spacing, range, width), or a field of a deserialised decoding result, that
    /// is non-finite, zero or negative where it must not be (or a window estimate marked
    /// `valid` without an estimate: `name` is `valid`, `value` 1 for true).
    #[error("invalid parameter `{name}` = {value}: {reason}")]
    InvalidParameter {
        /// Parameter name.
        name: &'static str,
        /// Value given.
        value: f64,
        /// Why it is invalid.
        reason: &'static str,
    },
    /// A value or a channel coefficient that is NaN or infinite.
    #[error("non-finite {what}: {value}")]
    NonFinite {
        /// What was non-finite (value, weight, channel coefficient).
        what: &'static str,
        /// The offending number.
        value: f64,
    },
    /// A value outside the representable (decodable) range of the basis.
    #[error("value {value} is outside the representable range [{lo}, {hi}]")]
    OutOfRange {
        /// The value.
        value: f64,
        /// Lower end of the representable range.
        lo: f64,
        /// Upper end of the representable range.
        hi: f64,
    },
    /// A negative channel coefficient or weight (channel vectors are monopolar).
    #[error("negative {what}: {value} (channel vectors are non-negative)")]
    Negative {
        /// What was negative.
        what: &'static str,
        /// The offending number.
        value: f64,
    },
    /// An n-D grid (or a basis, a 1-D grid) whose decoding window, or the channels one
    /// encoded value touches, would be larger than the documented limit (the cost of one
    /// window or one added value grows as the product over dimensions, so very many dimensions
    /// would take practically forever).
    #[error("{what}: {got} channels exceed the limit of {max}")]
    GridTooLarge {
        /// Which product was too large.
        what: &'static str,
        /// The product (saturated at `usize::MAX`).
        got: usize,
        /// The limit.
        max: usize,
    },
    /// Histogram coefficients whose sum is not what `total_weight` of encoded values can give.
    #[error(
        "the channel coefficients sum to {counts_sum}, but a total weight of {total_weight} \
         encoded values gives between {lo} and {hi}"
    )]
    InconsistentTotal {
        /// The total weight given.
        total_weight: f64,
        /// The sum of the coefficients given.
        counts_sum: f64,
        /// The smallest sum that total weight can give.
        lo: f64,
        /// The largest sum that total weight can give.
        hi: f64,
    },
    /// A slice of the wrong length (channel vector or n-D value).
    #[error("expected {expected} {what}, got {got}")]
    LengthMismatch {
        /// What was counted.
        what: &'static str,
        /// Expected length.
        expected: usize,
        /// Actual length.
        got: usize,
    },
}
