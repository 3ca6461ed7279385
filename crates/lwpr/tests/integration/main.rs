//! `lwpr`'s integration tests: one module per concern, all in one test binary, so
//! the crate and its dependencies are linked once rather than once per file. One module:
//! `cargo test -p lwpr --test integration MODULE::`.

// `common/five_d.rs` is also compiled into `src/io.rs`'s unit tests, so it names the model types
// as `crate::Lwpr` and `crate::LwprBuilder`: here they are imported at the root.
use lwpr::{Lwpr, LwprBuilder};

mod accuracy;
mod arithmetic;
mod common;
mod confidence;
#[path = "../../peer/harness.rs"]
mod harness;
mod hostile;
mod io;
mod jacobian;
mod prediction;
mod reference;
mod robustness;
mod xml;

/// The property tests' configuration: `cases` cases drawn from a fixed seed, so every run
/// tests the same inputs and a failure reproduces.
fn seeded(cases: u32) -> proptest::test_runner::Config {
    proptest::test_runner::Config {
        cases,
        rng_seed: proptest::test_runner::RngSeed::Fixed(2009),
        ..Default::default()
    }
}
