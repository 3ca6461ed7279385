//! `visguide`'s integration tests: one module per concern, all in one test binary, so
//! the crate and its dependencies are linked once rather than once per file. One module:
//! `cargo test -p visguide --test integration MODULE::`.

mod cli;
mod common;
mod geometry_oracles;
mod pipeline_learn_checks;
mod pipeline_on_arm_sim;
mod scoring_oracles;
mod servo_on_arm_sim;
mod vote_oracle;
