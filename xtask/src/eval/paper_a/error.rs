//! The typed errors of the Paper A evaluation.

use std::path::PathBuf;

use thiserror::Error;

/// Everything that can go wrong while reading a sequence or evaluating it.
#[derive(Debug, Error)]
pub enum PaperAError {
    /// A homography file that is not nine finite numbers forming a non-singular matrix.
    #[error("malformed homography: {reason}")]
    Homography {
        /// What is wrong.
        reason: String,
    },
    /// A file that could not be read.
    #[error("cannot read {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// An image that could not be decoded.
    #[error("cannot decode image {path}: {reason}")]
    Image {
        /// The file.
        path: PathBuf,
        /// The decoder's message.
        reason: String,
    },
    /// A sequence folder without the expected files.
    #[error("sequence {name} in {dir}: {reason}")]
    Sequence {
        /// The sequence name.
        name: String,
        /// Its folder.
        dir: PathBuf,
        /// What is missing.
        reason: String,
    },
    /// An ellipse that is not a proper ellipse (non-finite or not positive definite).
    #[error("degenerate ellipse ({u}, {v}, {a}, {b}, {c})")]
    Ellipse {
        /// Centre x.
        u: f64,
        /// Centre y.
        v: f64,
        /// Coefficient a.
        a: f64,
        /// Coefficient b.
        b: f64,
        /// Coefficient c.
        c: f64,
    },
}
