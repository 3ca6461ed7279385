//! `xtask`'s integration tests: one module per concern, all in one test binary, so
//! the crate and its dependencies are linked once rather than once per file. One module:
//! `cargo test -p xtask --test integration MODULE::`.

mod eval_output;
mod layering;
mod metadata;
mod test_targets;
mod walk;
