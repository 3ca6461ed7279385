//! `fd-match`'s integration tests: one module per concern, all in one test binary, so
//! the crate and its dependencies are linked once rather than once per file. One module:
//! `cargo test -p fd-match --test integration MODULE::`.

mod common;
mod errors;
mod methods;
mod oracles;
mod properties;
mod search;
mod serialization;

/// The property tests' configuration: `cases` cases drawn from a fixed seed, so every run
/// tests the same inputs and a failure reproduces.
fn seeded(cases: u32) -> proptest::test_runner::Config {
    proptest::test_runner::Config {
        cases,
        rng_seed: proptest::test_runner::RngSeed::Fixed(2009),
        ..Default::default()
    }
}
