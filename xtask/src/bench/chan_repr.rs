//! `cargo xtask bench chan-repr`: sparse soft-histogram encoding (O(active channels) per value)
//! against the dense evaluation of eq. 2.1 (every channel for every value).

use chan_repr::{ChannelBasis, Kernel, SoftHistogram};

use super::BenchArgs;
use crate::Result;
use crate::report::{BenchRow, time_median};

const SAMPLES: usize = 1_000_000;

/// Runs the bench.
pub fn run(_args: &BenchArgs) -> Result<Vec<BenchRow>> {
    // A deterministic, well-spread sequence in [0, 1) (golden-ratio steps); no RNG needed.
    let xs: Vec<f64> = (0..SAMPLES)
        .map(|i| (i as f64 * 0.618_033_988_749_894_9).fract())
        .collect();
    let mut rows = Vec::new();
    for (name, kernel) in [
        ("cos2 m=3", Kernel::Cos2 { m: 3 }),
        ("B-spline", Kernel::BSpline2),
    ] {
        for n in [64usize, 1024] {
            let basis = ChannelBasis::covering(0.0, 1.0, n, kernel)?;
            let mut sparse_sum = 0.0;
            let ours = time_median(1, 5, || {
                let mut h = SoftHistogram::one_d(basis.clone());
                h.extend_1d(&xs).expect("samples are in range");
                sparse_sum = h.counts().iter().sum();
            });
            let mut dense_sum = 0.0;
            let peer = time_median(1, if n > 100 { 1 } else { 5 }, || {
                let mut counts = vec![0.0; n];
                for &x in &xs {
                    let t = basis.to_index(x);
                    for (k, c) in counts.iter_mut().enumerate() {
                        *c += kernel.value(t - k as f64);
                    }
                }
                dense_sum = counts.iter().sum();
            });
            if (sparse_sum - dense_sum).abs() > 1e-6 * dense_sum {
                return Err(format!(
                    "sparse and dense histograms differ: {sparse_sum} vs {dense_sum}"
                )
                .into());
            }
            rows.push(BenchRow::lower_is_better(
                format!("encode 1e6 into {n} channels, {name}"),
                ours / SAMPLES as f64 * 1e9,
                peer / SAMPLES as f64 * 1e9,
                "ns/value",
            ));
        }
    }
    Ok(rows)
}
