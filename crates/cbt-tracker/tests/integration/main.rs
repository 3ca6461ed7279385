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
