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
