//! The typed errors of the Paper A evaluation.

use std::path::PathBuf;

use thiserror::Error;

/// Everything that can go wrong while reading a sequence or evaluating it.
#[derive(Debug, Error)]
pub enum PaperAError {
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
    /// From the pipeline (`visguide`): an unreadable image, a malformed homography, a
    /// degenerate region.
    #[error(transparent)]
    Visguide(#[from] visguide::VisguideError),
}
