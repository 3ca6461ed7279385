//! How the crates' errors become Python exceptions: bad input is a `ValueError`, a file that
//! cannot be read or written an `OSError`; the message is the Rust error's.

use pyo3::PyErr;
use pyo3::exceptions::{PyOSError, PyValueError};

/// `ValueError` with `msg`.
pub fn value_error(msg: impl Into<String>) -> PyErr {
    PyValueError::new_err(msg.into())
}

/// An MSER error: `OSError` for files, `ValueError` otherwise.
pub fn from_mser(e: mser::MserError) -> PyErr {
    match e {
        mser::MserError::Io(_) | mser::MserError::Image(_) => PyOSError::new_err(e.to_string()),
        _ => PyValueError::new_err(e.to_string()),
    }
}

/// An LWPR error: `OSError` for files, `ValueError` otherwise (also for a corrupt model file).
pub fn from_lwpr(e: lwpr::LwprError) -> PyErr {
    match e {
        lwpr::LwprError::Io(_) => PyOSError::new_err(e.to_string()),
        _ => PyValueError::new_err(e.to_string()),
    }
}

/// An LWPR error reading the file `path`, as [`from_lwpr`] with the file named: the crate's
/// I/O errors name it already, its errors about the contents (a corrupt model) do not, and a
/// caller of several files would be left guessing which one. (A save uses [`from_lwpr`]: its
/// errors are the crate's I/O errors, or about the model, not a file.)
pub fn from_lwpr_file(path: &std::path::Path, e: lwpr::LwprError) -> PyErr {
    match e {
        lwpr::LwprError::Io(_) => PyOSError::new_err(e.to_string()),
        _ => PyValueError::new_err(format!("{}: {e}", path.display())),
    }
}

/// A Fourier-descriptor error (always bad input).
pub fn from_fd(e: fd_match::FdError) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// A tracking error: `OSError` for files, `ValueError` otherwise.
pub fn from_track(e: cbt_tracker::TrackError) -> PyErr {
    match e {
        cbt_tracker::TrackError::Io { .. } => PyOSError::new_err(e.to_string()),
        _ => PyValueError::new_err(e.to_string()),
    }
}

/// An error of the `visguide` pipeline: `OSError` for files (missing, unreadable or
/// undecodable images, like PIL's), `ValueError` otherwise.
pub fn from_visguide(e: visguide::VisguideError) -> PyErr {
    match e {
        visguide::VisguideError::Io { .. } | visguide::VisguideError::Image { .. } => {
            PyOSError::new_err(e.to_string())
        }
        _ => PyValueError::new_err(e.to_string()),
    }
}
