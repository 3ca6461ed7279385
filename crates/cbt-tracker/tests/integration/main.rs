//! `cbt-tracker`'s integration tests: one module per concern, all in one test binary, so
//! the crate and its dependencies are linked once rather than once per file. One module:
//! `cargo test -p cbt-tracker --test integration MODULE::`.

mod baselines;
mod common;
mod corrupt;
mod dense_step;
mod displacement_choice;
mod displacements;
mod errors;
mod filtering;
mod input;
mod io;
mod learning;
mod observation_smoothing;
mod opencv;
mod oracles;
mod per_position;
mod properties;
mod rejected_input;
mod restore;
mod saved_form;
mod smoothing;
mod start;
mod stationary;

/// The property tests' configuration: `cases` cases drawn from a fixed seed, so every run
/// tests the same inputs and a failure reproduces.
fn seeded(cases: u32) -> proptest::test_runner::Config {
    proptest::test_runner::Config {
        cases,
        rng_seed: proptest::test_runner::RngSeed::Fixed(2009),
        ..Default::default()
    }
}
