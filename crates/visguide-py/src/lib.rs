//! Python bindings of the visguide crates, built by maturin into the `visguide` wheel
//! (`pyproject.toml` beside this crate; the Python package lives in `python/visguide`).
//!
//! This crate is the extension module `visguide._visguide`; the Python modules
//! `visguide.mser`, `visguide.lwpr`, `visguide.fd` and `visguide.tracking` re-export its
//! functions and classes with docstrings and type stubs. It adds no algorithm of its own: every
//! number comes from the `mser`, `lwpr`, `fd-match` and `cbt-tracker` crates, whose docs hold
//! the math (thesis Papers A–C), and from the `visguide` crate's image-pair pipeline
//! (`visguide.fd.match_images`: regions → descriptors → matches → homography). What lives
//! here is the conversion between NumPy arrays and the crates' types, and of their errors into
//! Python exceptions (`ValueError` for bad input, `OSError` for files, `TypeError` from
//! argument conversion for wrong dtypes or ranks).
//! LWPR models also read and write the reference library's XML model files (the `lwpr` crate's
//! `xml` module) with its Python module's names, `write_XML` and `LWPR(filename)` / `read_XML`.
//!
//! Arrays: a 2-D `uint8` image whose rows are contiguous is read in place (any row stride);
//! other layouts are copied once. Long computations (`mser.detect`, `LWPR.update_batch`,
//! `LWPR.predict_batch`) release the GIL.
//!
//! What a call adds to the Rust call: argument conversion, one `Region` object per region, one
//! copy of a batch. `python/benchmarks/overhead.py` times the same calls from Python and from
//! Rust (`examples/overhead.rs`, a separate process) and finds no measurable overhead
//! (`docs/performance.md`, *visguide-py*); that the Python side took less CPU than the Rust
//! process is unexplained.
//!
//! The library target has no Rust unit tests: the bindings are tested by pytest (`python/tests`,
//! run by `.ci/run`) against reference values that `tests/reference.rs` computes with the crates
//! directly (`tests/reference.json`). The Rust side links libpython only for the extension
//! module's own symbols, so `cargo test` needs nothing from Python at run time.

use pyo3::prelude::*;

mod cbt_config;
mod errors;
mod fd_py;
mod image;
mod lwpr_py;
mod mser_py;
mod pair_py;
mod tracking_py;

/// The compiled part of the `visguide` package (use `visguide.mser`, `visguide.lwpr`, ...).
#[pymodule]
fn _visguide(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(mser_py::detect, m)?)?;
    m.add_function(wrap_pyfunction!(mser_py::preset_dict, m)?)?;
    m.add_class::<mser_py::PyRegion>()?;
    m.add_class::<lwpr_py::PyLwpr>()?;
    m.add_function(wrap_pyfunction!(fd_py::describe, m)?)?;
    m.add_function(wrap_pyfunction!(fd_py::match_sets, m)?)?;
    m.add_class::<fd_py::PyDescriptors>()?;
    m.add_function(wrap_pyfunction!(pair_py::match_images, m)?)?;
    m.add_class::<tracking_py::PyCbt>()?;
    m.add_class::<tracking_py::PyKalman>()?;
    m.add_class::<tracking_py::PyParticleFilter>()?;
    Ok(())
}
