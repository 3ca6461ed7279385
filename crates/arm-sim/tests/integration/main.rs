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
