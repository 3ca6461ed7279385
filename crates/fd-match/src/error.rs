//! The crate's error type.

use thiserror::Error;

/// Everything that can go wrong when describing contours or matching descriptor sets.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum FdError {
    /// Fewer than three distinct points: no closed curve with an interior.
    #[error("a contour needs at least 3 points, got {got}")]
    TooFewPoints {
        /// Points left after dropping an explicit closing point.
        got: usize,
    },
    /// A coordinate that is NaN or infinite.
    #[error("point {index} has a non-finite coordinate ({x}, {y})")]
    NonFinite {
        /// Index of the point in the input.
        index: usize,
        /// Its x coordinate.
        x: f64,
        /// Its y coordinate.
        y: f64,
    },
    /// Two consecutive points (cyclically) coincide: a zero-length edge has no direction.
    #[error("point {index} repeats its predecessor ({x}, {y})")]
    RepeatedPoint {
        /// Index of the second of the two equal points (0 means the last and the first coincide).
        index: usize,
        /// Its x coordinate.
        x: f64,
        /// Its y coordinate.
        y: f64,
    },
    /// The contour encloses no area (all points collinear, or a curve that retraces itself).
    #[error("the contour encloses zero area (|area| = {area:e}, perimeter = {perimeter})")]
    ZeroArea {
        /// Absolute signed area of the polygon.
        area: f64,
        /// Its perimeter.
        perimeter: f64,
    },
    /// The first harmonic of the contour is degenerate (a line), so the affine-invariant
    /// descriptors AFD0/AFD1, which are normalised by it, are undefined.
    #[error("first Fourier harmonic is degenerate: affine-invariant descriptors are undefined")]
    DegenerateFirstHarmonic,
    /// An invalid configuration value.
    #[error("invalid parameter `{name}` = {value}: {reason}")]
    InvalidParameter {
        /// Parameter name.
        name: &'static str,
        /// Value given (as f64).
        value: f64,
        /// Why it is invalid.
        reason: &'static str,
    },
    /// Two descriptor sets built with different configurations cannot be compared.
    #[error("descriptor sets are incompatible: {reason}")]
    IncompatibleSets {
        /// What differs.
        reason: &'static str,
    },
    /// An index outside a descriptor set.
    #[error("index {index} is outside a set of {len} descriptors")]
    IndexOutOfRange {
        /// Index asked for.
        index: usize,
        /// Size of the set.
        len: usize,
    },
    /// Two vectors that must have the same length (descriptors, descriptor rows) do not.
    #[error("length mismatch: {left} values against {right}, expected {expected}")]
    LengthMismatch {
        /// Length of the first vector.
        left: usize,
        /// Length of the second vector.
        right: usize,
        /// Length required (the configuration's, or `left` when any common length will do).
        expected: usize,
    },
    /// A descriptor value that is NaN or infinite.
    #[error("descriptor value {index} of `{part}` is not finite")]
    NonFiniteDescriptor {
        /// Which part of the descriptor (`fd`, `afd0`, `afd1`, or `a`/`b` of a pair).
        part: &'static str,
        /// Index of the value.
        index: usize,
    },
    /// A descriptor whose norm is not 1 (descriptors are normalised by their energy).
    #[error("descriptor `{part}` has norm {norm}, expected 1")]
    NotUnitNorm {
        /// Which part of the descriptor.
        part: &'static str,
        /// Its Euclidean norm.
        norm: f64,
    },
}
