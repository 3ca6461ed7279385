//! `servo-loop`'s integration tests: one module per concern, all in one test binary, so
//! the crate and its dependencies are linked once rather than once per file. One module:
//! `cargo test -p servo-loop --test integration MODULE::`.

mod analytic;
mod approach;
mod bad_input;
mod common;
mod image_target;
mod oracles;
mod percept_seam;
mod recognition_units;
mod recovery;
mod refusals;
mod serialization;
mod temporal;
