//! `cargo xtask bench chan-repr`: soft-histogram encoding (`SoftHistogram::extend_1d`) against
//! the best plain implementation of the same sum: for every value, the channels inside the
//! kernel's support (and only those), each evaluated by the kernel's closed form (eq. 2.1 per
//! active channel). Ours differs only in how it evaluates cos² along the support (one rotated
//! phasor instead of a cosine per channel); for the B-spline both sides do the same work.
//!
//! Every channel of both histograms is asserted equal (to 1e-9 of the largest channel: the two
//! evaluate cos² by different roundings) in the run that times them; the bench fails otherwise.

use chan_repr::{ChannelBasis, Kernel, SoftHistogram};

use super::BenchArgs;
use super::cpu::{Clock, interleaved, load_average};
use crate::Result;
use crate::report::BenchRow;

const SAMPLES: usize = 1_000_000;

/// The plain implementation: the support `⌈t − r⌉..=⌊t + r⌋` of every value, clipped to the
/// channels, each channel's kernel value computed on its own.
fn plain_histogram(basis: &ChannelBasis, xs: &[f64]) -> Vec<f64> {
    let kernel = basis.kernel();
    let r = kernel.support_radius();
    let n = basis.len() as i64;
    let mut counts = vec![0.0; basis.len()];
    for &x in xs {
        let t = basis.to_index(x);
        let lo = (t - r).ceil().max(0.0) as i64;
        let hi = ((t + r).floor() as i64).min(n - 1);
        for k in lo..=hi {
            counts[k as usize] += kernel.value(t - k as f64);
        }
    }
    counts
}

/// Fails unless the two histograms agree channel by channel.
fn check_equal(case: &str, ours: &[f64], plain: &[f64]) -> Result<()> {
    let scale = plain.iter().fold(0.0f64, |m, &c| m.max(c.abs()));
    let worst = ours
        .iter()
        .zip(plain)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f64, f64::max);
    if ours.len() != plain.len() || worst > 1e-9 * scale {
        return Err(format!(
            "{case}: histograms differ (largest channel difference {worst:e}, largest channel {scale})"
        )
        .into());
    }
    Ok(())
}

/// Runs the bench.
pub fn run(_args: &BenchArgs) -> Result<Vec<BenchRow>> {
    // A deterministic, well-spread sequence in [0, 1) (golden-ratio steps); no RNG needed.
    let xs: Vec<f64> = (0..SAMPLES)
        .map(|i| (i as f64 * 0.618_033_988_749_894_9).fract())
        .collect();
    println!(
        "ours vs the plain per-channel loop over each value's support, thread CPU time, median of 7 interleaved rounds; load average {}",
        load_average()
    );
    let mut rows = Vec::new();
    for (name, kernel) in [
        ("cos2 m=3", Kernel::Cos2 { m: 3 }),
        ("cos2 m=5", Kernel::Cos2 { m: 5 }),
        ("B-spline", Kernel::BSpline2),
    ] {
        for n in [64usize, 1024] {
            let basis = ChannelBasis::covering(0.0, 1.0, n, kernel)?;
            let case = format!("encode 1e6 into {n} channels, {name}");
            let mut ours = Vec::new();
            let mut plain = Vec::new();
            let mut failed = None;
            let (t_ours, t_plain) = interleaved(
                Clock::Thread,
                1,
                7,
                || {
                    let mut h = SoftHistogram::one_d(basis.clone());
                    if let Err(e) = h.extend_1d(&xs) {
                        failed = Some(e);
                    }
                    ours = h.counts().to_vec();
                },
                || plain = plain_histogram(&basis, &xs),
            )?;
            if let Some(e) = failed {
                return Err(e.into());
            }
            check_equal(&case, &ours, &plain)?;
            rows.push(BenchRow::lower_is_better(
                case,
                t_ours / SAMPLES as f64 * 1e9,
                t_plain / SAMPLES as f64 * 1e9,
                "ns/value",
            ));
        }
    }
    println!("every channel asserted equal to the plain loop's (1e-9 of the largest channel)");
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_plain_loop_is_eq_2_1_and_the_check_catches_a_difference() {
        let basis = ChannelBasis::covering(0.0, 1.0, 16, Kernel::Cos2 { m: 3 }).unwrap();
        let xs = [0.1, 0.37, 0.5, 0.93];
        let plain = plain_histogram(&basis, &xs);
        let mut dense = vec![0.0; 16];
        for &x in &xs {
            for (k, d) in dense.iter_mut().zip(basis.encode(x).unwrap()) {
                *k += d;
            }
        }
        check_equal("eq. 2.1", &plain, &dense).unwrap();
        let mut h = SoftHistogram::one_d(basis.clone());
        h.extend_1d(&xs).unwrap();
        check_equal("ours", h.counts(), &plain).unwrap();
        let mut off = plain.clone();
        off[7] += 1e-6;
        assert!(check_equal("off", &off, &plain).is_err());
    }
}
