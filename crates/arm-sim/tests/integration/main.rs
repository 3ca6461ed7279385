//! `arm-sim`'s integration tests: one module per concern, all in one test binary, so
//! the crate and its dependencies are linked once rather than once per file. One module:
//! `cargo test -p arm-sim --test integration MODULE::`.

mod arm_files;
mod camera;
mod commands;
mod config;
mod inspection;
mod kinematics;
mod oracles;
mod render;
mod scene_features;
mod servo;

/// The property tests' configuration: `cases` cases drawn from a fixed seed, so every run
/// tests the same inputs and a failure reproduces.
fn seeded(cases: u32) -> proptest::test_runner::Config {
    proptest::test_runner::Config {
        cases,
        rng_seed: proptest::test_runner::RngSeed::Fixed(2009),
        ..Default::default()
    }
}
