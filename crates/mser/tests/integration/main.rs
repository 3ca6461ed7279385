//! `mser`'s integration tests: one module per concern, all in one test binary, so
//! the crate and its dependencies are linked once rather than once per file. One module:
//! `cargo test -p mser --test integration MODULE::`.

mod bad_input;
mod common;
mod geometry;
mod image_conversion;
mod invariance;
mod opencv_crosscheck;
mod oxford_io;
mod parallel;
mod pixels;
mod reference;
mod snapshot;
mod variation_ties;
