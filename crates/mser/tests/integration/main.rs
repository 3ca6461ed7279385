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

/// The property tests' configuration: `cases` cases drawn from a fixed seed, so every run
/// tests the same inputs and a failure reproduces.
fn seeded(cases: u32) -> proptest::test_runner::Config {
    proptest::test_runner::Config {
        cases,
        rng_seed: proptest::test_runner::RngSeed::Fixed(2009),
        ..Default::default()
    }
}
