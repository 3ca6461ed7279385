//! The crate's error type.

use thiserror::Error;

/// Everything that can go wrong when detecting regions, extracting their pixels or contours, or
/// reading and writing region files.
#[derive(Debug, Error)]
pub enum MserError {
    /// An image with zero width or zero height.
    #[error("empty image: {width}x{height}")]
    EmptyImage {
        /// Width given.
        width: usize,
        /// Height given.
        height: usize,
    },
    /// A row stride smaller than the width.
    #[error("row stride {stride} is smaller than the width {width}")]
    StrideTooSmall {
        /// Stride given.
        stride: usize,
        /// Width given.
        width: usize,
    },
    /// A pixel buffer shorter than `stride * (height - 1) + width`.
    #[error("pixel buffer holds {got} bytes, the image needs {needed}")]
    BufferTooSmall {
        /// Bytes given.
        got: usize,
        /// Bytes needed.
        needed: usize,
    },
    /// An image too large for the detector's 32-bit pixel indices.
    #[error("image {width}x{height} is too large (at most 2^28 padded pixels)")]
    ImageTooLarge {
        /// Width given.
        width: usize,
        /// Height given.
        height: usize,
    },
    /// Detector parameters that contradict each other or are out of range.
    #[error("invalid parameter `{name}`: {reason}")]
    InvalidParameter {
        /// Parameter name.
        name: &'static str,
        /// Why it is invalid.
        reason: String,
    },
    /// A region asked for its pixels or contour on an image it was not detected in.
    #[error("region does not belong to this image: {reason}")]
    RegionImageMismatch {
        /// What did not match.
        reason: &'static str,
    },
    /// A region file that could not be read or written.
    #[error("region file I/O: {0}")]
    Io(#[from] std::io::Error),
    /// A region file whose content is malformed.
    #[error("region file, line {line}: {reason}")]
    Parse {
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        reason: String,
    },
    /// An image file that could not be decoded.
    #[error("image: {0}")]
    Image(#[from] image::ImageError),
    /// An error reported by OpenCV (feature `opencv`).
    #[cfg(feature = "opencv")]
    #[error("opencv: {0}")]
    OpenCv(#[from] opencv::Error),
}

/// The crate's result type.
pub type Result<T> = std::result::Result<T, MserError>;
