//! `chan-repr`'s integration tests: one module per concern, all in one test binary, so
//! the crate and its dependencies are linked once rather than once per file. One module:
//! `cargo test -p chan-repr --test integration MODULE::`.

mod histograms;
mod hostile;
mod oracles;
mod ordering;
mod properties;
mod serialization;
mod worked_example;
