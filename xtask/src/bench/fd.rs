//! `cargo xtask bench fd`: fd-match descriptor extraction and 1,000 × 1,000 all-pairs matching
//! with the ratio test, against the naive per-pair FFT method in the same run.
//!
//! Data: 1,000 random closed curves (Fourier series with random elongation and harmonics,
//! 200 vertices) for image A; image B holds similarity-transformed, start-shifted, jittered
//! copies of 700 of them and 300 unrelated curves, shuffled. Seeded, so every run measures the
//! same work.
//!
//! Peers: "naive" correlates every pair with a freshly allocated zero-padded buffer, a planned
//! inverse FFT of the same size (planner cache lookup, scratch allocated by `process`) and a
//! parabolic peak fit, without the magnitude bound — the straightforward implementation of
//! eq. 9–12. "brute force" is our own kernel without pruning ([`fd_match::best_two_brute_force`]).
//! All methods run on all cores (rayon).

use std::f64::consts::PI;

use fd_match::{
    BestTwo, Complex64, DescriptorConfig, DescriptorSet, Extractor, Method, Sampling,
    best_two_brute_force, best_two_with_stats, describe_all, fd_frequency, mutual_matches,
};
use rand::{RngExt, SeedableRng, rngs::StdRng, seq::SliceRandom};
use rayon::prelude::*;
use rustfft::FftPlanner;

use super::BenchArgs;
use crate::Result;
use crate::report::{BenchRow, time_median};

// The criterion bench's random shapes (one definition for both measurements).
#[path = "../../../crates/fd-match/benches/common/shapes.rs"]
mod shapes;

use shapes::{Contour, shape};

const N: usize = 1000;

fn data() -> (Vec<Contour>, Vec<Contour>) {
    let mut rng = StdRng::seed_from_u64(20091201);
    let a: Vec<Contour> = (0..N).map(|_| shape(&mut rng)).collect();
    let mut b: Vec<Contour> = Vec::with_capacity(N);
    for c in a.iter().take(700) {
        let (phi, s) = (rng.random_range(-PI..PI), rng.random_range(0.5..2.0));
        let (tx, ty) = (rng.random_range(0.0..800.0), rng.random_range(0.0..600.0));
        let shift = rng.random_range(0..c.len());
        let mut t: Contour = (0..c.len())
            .map(|i| {
                let (x, y) = c[(i + shift) % c.len()];
                let (sx, sy) = (
                    s * (x * phi.cos() - y * phi.sin()),
                    s * (x * phi.sin() + y * phi.cos()),
                );
                (
                    sx + tx + rng.random_range(-0.3..0.3),
                    sy + ty + rng.random_range(-0.3..0.3),
                )
            })
            .collect();
        t.dedup();
        b.push(t);
    }
    for _ in 0..300 {
        b.push(shape(&mut rng));
    }
    b.shuffle(&mut rng);
    (a, b)
}

/// CPU seconds used by this process so far (user + system, from `/proc/self/stat`; Linux only,
/// `None` elsewhere). Lets the report give a rate per CPU-second, which other processes sharing
/// the cores disturb much less than wall time.
fn cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the command name (which is in parentheses and may contain spaces).
    let rest = &stat[stat.rfind(')')? + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks: f64 = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0) // USER_HZ is 100 on Linux
}

/// The naive method: per pair, allocate, inverse FFT, argmax, parabolic fit.
fn naive_best_two(q: &DescriptorSet, t: &DescriptorSet) -> Vec<BestTwo> {
    let k = q.config().max_frequency();
    let m = 2 * (2 * k + 1).next_power_of_two(); // the grid of `fd_match::Correlator::new`
    (0..q.len())
        .into_par_iter()
        .map_init(FftPlanner::<f64>::new, |planner, i| {
            let mut errs: Vec<(f64, usize)> = Vec::with_capacity(t.len());
            for j in 0..t.len() {
                let (a, b) = (q.fd(i), t.fd(j));
                let mut buf = vec![Complex64::new(0.0, 0.0); m];
                for (ii, (x, y)) in a.iter().zip(b).enumerate() {
                    let n = fd_frequency(ii, k);
                    buf[n.rem_euclid(m as isize) as usize] = x.conj() * y;
                }
                planner.plan_fft_inverse(m).process(&mut buf);
                let (jm, vm) =
                    buf.iter()
                        .map(|z| z.norm())
                        .enumerate()
                        .fold(
                            (0, -1.0),
                            |acc, (jj, v)| if v > acc.1 { (jj, v) } else { acc },
                        );
                let (l, r) = (buf[(jm + m - 1) % m].norm(), buf[(jm + 1) % m].norm());
                let den = l - 2.0 * vm + r;
                let d = if den < 0.0 { 0.5 * (l - r) / den } else { 0.0 };
                let peak = vm - 0.25 * (l - r) * d;
                errs.push((2.0 - 2.0 * peak, j));
            }
            errs.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
            let c = |e: &(f64, usize)| fd_match::Candidate {
                index: e.1,
                error: e.0,
                alignment: None,
            };
            BestTwo {
                best: errs.first().map(c),
                second: errs.get(1).map(c),
            }
        })
        .collect()
}

/// Runs the bench.
pub fn run(_args: &BenchArgs) -> Result<Vec<BenchRow>> {
    let (ca, cb) = data();
    let mut rows = Vec::new();

    // Extraction: our reusable extractor (one thread) against planning and allocating per contour.
    for sampling in [Sampling::AffineArcLength, Sampling::Canonical] {
        let cfg = DescriptorConfig::with_sampling(sampling);
        let mut ex = Extractor::new(cfg)?;
        let mut set = DescriptorSet::new(cfg)?;
        let ours = time_median(1, 5, || {
            set = DescriptorSet::new(cfg).expect("valid");
            for (i, c) in ca.iter().enumerate() {
                ex.describe_into(c, &mut set, i).expect("valid contour");
            }
        });
        let naive = time_median(1, 3, || {
            for c in &ca {
                let mut e = Extractor::new(cfg).expect("valid");
                std::hint::black_box(e.describe(c).expect("valid contour"));
            }
        });
        rows.push(BenchRow::lower_is_better(
            format!("extract 1 contour ({}), 1 thread", sampling.name()),
            ours / N as f64 * 1e6,
            naive / N as f64 * 1e6,
            "us",
        ));
    }

    let cfg = DescriptorConfig::with_sampling(Sampling::Canonical);
    let a = describe_all(cfg, &ca)?.set;
    let b = describe_all(cfg, &cb)?.set;
    if a.len() != N || b.len() != N {
        return Err("bench contours were rejected".into());
    }
    let pairs = (N * N) as f64;

    let mut stats = None;
    let c0 = cpu_seconds();
    let ours = time_median(1, 5, || {
        stats = Some(best_two_with_stats(&a, &b, Method::FdCorr).expect("compatible"));
    });
    let c1 = cpu_seconds();
    let (fast, st) = stats.expect("ran");
    let mut naive_res = Vec::new();
    let naive = time_median(0, 3, || naive_res = naive_best_two(&a, &b));
    let c2 = cpu_seconds();
    if let (Some(c0), Some(c1), Some(c2)) = (c0, c1, c2) {
        rows.push(BenchRow::higher_is_better(
            "FD Corr best-two 1000x1000 per CPU-second vs naive",
            6.0 * pairs / (c1 - c0) / 1e6,
            3.0 * pairs / (c2 - c1) / 1e6,
            "Mpairs/cpu-s",
        ));
    }
    let mut brute_res = Vec::new();
    let brute = time_median(0, 3, || {
        brute_res = best_two_brute_force(&a, &b, Method::FdCorr).expect("compatible")
    });
    if brute_res != fast {
        return Err("pruned search differs from brute force".into());
    }
    let agree = fast
        .iter()
        .zip(&naive_res)
        .filter(|(x, y)| x.best.map(|c| c.index) == y.best.map(|c| c.index))
        .count();
    println!(
        "FD Corr 1000x1000: {} of {} pairs evaluated ({:.2} %); best index agrees with naive for {agree}/{N} queries",
        st.evaluated,
        st.pairs,
        100.0 * st.evaluated as f64 / st.pairs as f64
    );
    rows.push(BenchRow::higher_is_better(
        "FD Corr best-two 1000x1000 vs naive per-pair FFT",
        pairs / ours / 1e6,
        pairs / naive / 1e6,
        "Mpairs/s",
    ));
    rows.push(BenchRow::higher_is_better(
        "FD Corr best-two 1000x1000 vs own brute force",
        pairs / ours / 1e6,
        pairs / brute / 1e6,
        "Mpairs/s",
    ));

    // Full symmetric matching with the ratio test (both directions + mutual check).
    let mut accepted = 0;
    let sym = time_median(1, 3, || {
        let ab = best_two_with_stats(&a, &b, Method::FdCorr)
            .expect("compatible")
            .0;
        let ba = best_two_with_stats(&b, &a, Method::FdCorr)
            .expect("compatible")
            .0;
        accepted = mutual_matches(&ab, &ba)
            .iter()
            .filter(|m| m.accepted(fd_match::DEFAULT_RATIO_THRESHOLD))
            .count();
    });
    let naive_sym = time_median(0, 1, || {
        let ab = naive_best_two(&a, &b);
        let ba = naive_best_two(&b, &a);
        std::hint::black_box(mutual_matches(&ab, &ba));
    });
    println!("symmetric matching: {accepted} matches accepted at T_r = 0.5 (700 true pairs)");
    rows.push(BenchRow::lower_is_better(
        "symmetric FD Corr matching + ratio test, 1000x1000",
        sym * 1e3,
        naive_sym * 1e3,
        "ms",
    ));
    for method in [Method::AbsFdSsd, Method::Afd1Ssd] {
        let t = time_median(1, 3, || {
            std::hint::black_box(best_two_with_stats(&a, &b, method).expect("compatible"));
        });
        rows.push(BenchRow::higher_is_better(
            format!("{} best-two 1000x1000 vs naive FD Corr", method.name()),
            pairs / t / 1e6,
            pairs / naive / 1e6,
            "Mpairs/s",
        ));
    }
    Ok(rows)
}
