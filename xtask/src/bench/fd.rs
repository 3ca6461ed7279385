//! `cargo xtask bench fd`: fd-match's pruned all-pairs best-two search (FD Corr, eq. 9–12 with
//! the magnitude bound) against the best plain implementation of the same computation: every
//! pair correlated with the same exact kernel (zero-padded inverse FFT of the same length
//! `M = 128` for K = 25, plan and buffers made once per thread and reused, the same Newton peak
//! refinement), no bound ([`fd_match::best_two_brute_force`]). Both sides return the same
//! best/second-best targets, errors and alignments; the bench asserts that they are identical
//! in every run and fails otherwise.
//!
//! Data, because the pruning rate depends on how spread the spectra are:
//! - synthetic: 1,000 random closed curves (Fourier series with random elongation and
//!   harmonics, 200 vertices) for image A; image B holds similarity-transformed, start-shifted,
//!   jittered copies of 700 of them and 300 unrelated curves, shuffled (seeded);
//! - real: the outer contours of every MSER region (the thesis setting `larsson2009`, both
//!   polarities, `min_diversity = 0`, so nested near-duplicates and all) of img1 against img2
//!   of graf, boat and leuven (`$VISGUIDE_DATA/oxford-affine`; skipped with a note when absent).
//!
//! Times are the CPU time of all the process's threads (scheduler run time, ns resolution),
//! median of interleaved rounds, so the rates are pairs per CPU-second, i.e. per core; both
//! sides run on rayon's pool. With the xtask feature `opencv`, OpenCV's contrib
//! `ximgproc::ContourFitting` (a different estimator, so no equality and no ratio) is timed per
//! pair on a sample and printed for information.

use fd_match::{
    BestTwo, DescriptorConfig, DescriptorSet, Method, Sampling, best_two_brute_force,
    best_two_with_stats, describe_all,
};

use super::BenchArgs;
use super::cpu::{Clock, interleaved, load_average};
use crate::Result;
use crate::report::BenchRow;

// The criterion bench's random shapes (one definition for both measurements).
#[path = "../../../crates/fd-match/benches/common/shapes.rs"]
mod shapes;

pub use shapes::Contour;

const N: usize = 1000;

fn data() -> (Vec<Contour>, Vec<Contour>) {
    shapes::bench_images(N)
}

/// The outer contours of every MSER region of an Oxford image (module docs).
fn mser_contours(path: &std::path::Path) -> Result<Vec<Vec<(u32, u32)>>> {
    let gray = mser::load_gray(path)?;
    let img = mser::GrayView::from_image(&gray)?;
    let params = mser::MserParams {
        min_diversity: 0.0,
        ..mser::MserParams::larsson2009()
    };
    let regions = mser::detect(&img, &params)?;
    Ok(regions
        .iter()
        .map(|r| r.contour(&img))
        .collect::<std::result::Result<_, _>>()?)
}

/// One measured row: the pruned search against brute force on `a × b`, asserting identical
/// results; `rounds` interleaved rounds of process CPU time.
fn measure(case: &str, a: &DescriptorSet, b: &DescriptorSet, rounds: usize) -> Result<BenchRow> {
    let pairs = (a.len() * b.len()) as f64;
    let mut fast: Option<(Vec<BestTwo>, fd_match::SearchStats)> = None;
    let mut brute: Vec<BestTwo> = Vec::new();
    let wall = std::time::Instant::now();
    let (ours, peer) = interleaved(
        Clock::Process,
        0,
        rounds,
        || fast = Some(best_two_with_stats(a, b, Method::FdCorr).expect("compatible")),
        || brute = best_two_brute_force(a, b, Method::FdCorr).expect("compatible"),
    )?;
    let wall = wall.elapsed().as_secs_f64();
    let (fast, st) = fast.expect("ran");
    if fast != brute {
        let differ = fast.iter().zip(&brute).filter(|(x, y)| x != y).count();
        return Err(
            format!("{case}: pruned search differs from brute force for {differ} queries").into(),
        );
    }
    let t0 = std::time::Instant::now();
    std::hint::black_box(best_two_with_stats(a, b, Method::FdCorr).expect("compatible"));
    let ours_wall = t0.elapsed().as_secs_f64();
    println!(
        "{case}: {}x{} = {} pairs, {} evaluated ({:.2} %), results identical to brute force; {rounds} rounds took {wall:.1} s wall; one more run of ours: {:.1} Mpairs/s wall on {} threads",
        a.len(),
        b.len(),
        st.pairs,
        st.evaluated,
        100.0 * st.evaluated as f64 / st.pairs as f64,
        pairs / ours_wall / 1e6,
        rayon::current_num_threads()
    );
    Ok(BenchRow::higher_is_better(
        format!(
            "{case}: FD Corr best-two vs brute force ({}x{})",
            a.len(),
            b.len()
        ),
        pairs / ours / 1e6,
        pairs / peer / 1e6,
        "Mpairs/CPU-s",
    ))
}

/// Runs the bench.
pub fn run(args: &BenchArgs) -> Result<Vec<BenchRow>> {
    println!(
        "times: {}, interleaved rounds; load average at the start: {}",
        Clock::Process.name(),
        load_average()
    );
    let cfg = DescriptorConfig::with_sampling(Sampling::Canonical);
    let (ca, cb) = data();
    let a = describe_all(cfg, &ca)?.set;
    let b = describe_all(cfg, &cb)?.set;
    if a.len() != N || b.len() != N {
        return Err("bench contours were rejected".into());
    }
    let mut rows = vec![measure("synthetic curves", &a, &b, 5)?];

    let root = args.data.as_ref().map(|d| d.join("oxford-affine"));
    match root.filter(|r| r.join("graf/img1.png").exists()) {
        None => println!("skipped the MSER contours: VISGUIDE_DATA/oxford-affine not found"),
        Some(root) => {
            for seq in ["graf", "boat", "leuven"] {
                let sets = ["img1.png", "img2.png"].map(|f| -> Result<DescriptorSet> {
                    let contours = mser_contours(&root.join(seq).join(f))?;
                    let d = describe_all(cfg, &contours)?;
                    println!(
                        "{seq} {f}: {} MSER contours, {} described, {} rejected (degenerate)",
                        contours.len(),
                        d.set.len(),
                        d.rejected.len()
                    );
                    Ok(d.set)
                });
                let [qa, qb] = sets;
                rows.push(measure(
                    &format!("{seq} MSER contours img1 vs img2"),
                    &qa?,
                    &qb?,
                    3,
                )?);
            }
        }
    }
    contour_fitting(&a, &ca, &cb)?;
    println!("load average at the end: {}", load_average());
    Ok(rows)
}

/// Without the feature there is no OpenCV peer.
#[cfg(not(feature = "opencv"))]
fn contour_fitting(_a: &DescriptorSet, _ca: &[Contour], _cb: &[Contour]) -> Result<()> {
    println!(
        "OpenCV ContourFitting not measured: needs the xtask feature `opencv` (libopencv-contrib-dev)"
    );
    Ok(())
}

#[cfg(feature = "opencv")]
fn contour_fitting(_a: &DescriptorSet, ca: &[Contour], cb: &[Contour]) -> Result<()> {
    super::fd_opencv::contour_fitting(ca, cb)
}
