//! The typed errors of the library. Every message names the file (and line, for tables) and
//! what was expected, so the command line can print it as one line.

use std::path::PathBuf;

use thiserror::Error;

/// Everything that can go wrong in the pipeline.
#[derive(Debug, Error)]
pub enum VisguideError {
    /// A file that could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// An image that could not be decoded, or has no pixels.
    #[error("{path}: not a readable image ({reason})")]
    Image {
        /// The file.
        path: PathBuf,
        /// The decoder's message.
        reason: String,
    },
    /// A homography that is not nine finite numbers forming a non-singular matrix.
    #[error("malformed homography: {reason}")]
    Homography {
        /// What is wrong.
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
    /// A table (CSV) with a row that is not what was expected.
    #[error("{path}:{line}: {reason}")]
    Table {
        /// The file.
        path: PathBuf,
        /// 1-based line number (0: the file as a whole).
        line: usize,
        /// What was expected.
        reason: String,
    },
    /// A saved model that cannot be used (wrong kind, other version, corrupt).
    #[error("{path}: not a usable model file ({reason})")]
    Model {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// An argument outside its valid range.
    #[error("invalid {name}: {reason}")]
    Invalid {
        /// The argument.
        name: &'static str,
        /// Why.
        reason: String,
    },
    /// Too few correspondences for a homography.
    #[error("a homography needs at least 4 matches with distinct positions; got {0}")]
    TooFewMatches(usize),
    /// From the MSER detector.
    #[error(transparent)]
    Mser(#[from] mser::MserError),
    /// From the Fourier descriptors.
    #[error(transparent)]
    Fd(#[from] fd_match::FdError),
}

/// Result with [`VisguideError`].
pub type Result<T, E = VisguideError> = std::result::Result<T, E>;

/// Wraps an I/O error with its file.
pub(crate) fn io(path: impl Into<PathBuf>) -> impl FnOnce(std::io::Error) -> VisguideError {
    let path = path.into();
    move |source| VisguideError::Io { path, source }
}
