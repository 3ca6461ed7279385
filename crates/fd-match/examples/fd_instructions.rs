//! A fixed workload for instruction counting under callgrind, where CPU time is too noisy (a
//! shared, loaded machine): the FD Corr best-two search of `cargo xtask bench fd`'s synthetic
//! images (1,000 × 1,000 curves, canonical sampling) on one rayon thread, in a function of its
//! own. With a path to a JSON file `[[contours of image A], [contours of image B]]` (points as
//! `[x, y]`), those contours instead.
//!
//! ```text
//! cargo build --release -p fd-match --example fd_instructions
//! RAYON_NUM_THREADS=1 valgrind --tool=callgrind --toggle-collect='*instructions*measured*' \
//!     target/release/examples/fd_instructions [CONTOURS.json]
//! ```
//!
//! The `Collected` total is the instruction count of one search (descriptors already made).

use fd_match::{DescriptorConfig, Method, Sampling, SearchStats, best_two_with_stats};

#[path = "../benches/common/shapes.rs"]
mod shapes;

type Contours = Vec<Vec<(f64, f64)>>;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (ca, cb): (Contours, Contours) = match std::env::args().nth(1) {
        Some(path) => serde_json::from_str(&std::fs::read_to_string(path)?)?,
        None => shapes::bench_images(1000),
    };
    let cfg = DescriptorConfig::with_sampling(Sampling::Canonical);
    let a = fd_match::describe_all(cfg, &ca)?.set;
    let b = fd_match::describe_all(cfg, &cb)?.set;
    let st = measured(&a, &b)?;
    println!(
        "{} x {}: {} pairs, {} evaluated",
        a.len(),
        b.len(),
        st.pairs,
        st.evaluated
    );
    Ok(())
}

#[inline(never)]
fn measured(
    a: &fd_match::DescriptorSet,
    b: &fd_match::DescriptorSet,
) -> Result<SearchStats, fd_match::FdError> {
    Ok(best_two_with_stats(a, b, Method::FdCorr)?.1)
}
