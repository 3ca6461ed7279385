//! Order statistics: the one home of the medians and quantiles that servo-loop's learners use
//! (the temporal and motion checks' thresholds, the silhouette's noise, reach and contrast),
//! that the crates above it use (visguide's prior on the votes' position) and that the studies
//! report (xtask re-exports them). Each is named for what it computes, because results depend on
//! which definition is used.

/// Median: the middle value of an odd-sized sample, the mean of the two middle values of an
/// even-sized one; NaN for an empty sample. Sorts `xs` in place (NaNs sort last). The mean of
/// two finite values is finite: where their sum overflows, each is halved first.
pub fn median(xs: &mut [f64]) -> f64 {
    xs.sort_by(f64::total_cmp);
    let n = xs.len();
    match n {
        0 => f64::NAN,
        _ if n % 2 == 1 => xs[n / 2],
        _ => {
            let (a, b) = (xs[n / 2 - 1], xs[n / 2]);
            let sum = a + b;
            if sum.is_finite() {
                0.5 * sum
            } else {
                // Only an overflow (or an infinite or NaN value) gets here.
                0.5 * a + 0.5 * b
            }
        }
    }
}

/// Nearest-rank quantile from below: the value of rank `⌊q·n⌋` (0-based, at most `n − 1`) in
/// the order of [`f64::total_cmp`], so `q = 0.5` is the upper median of an even-sized sample;
/// NaN for an empty sample or a `q` outside `[0, 1]` (or NaN). Reorders `xs` (a selection,
/// linear time, not a sort).
pub fn quantile_rank(xs: &mut [f64], q: f64) -> f64 {
    if xs.is_empty() || !(0.0..=1.0).contains(&q) {
        return f64::NAN;
    }
    let k = ((xs.len() as f64 * q) as usize).min(xs.len() - 1);
    *xs.select_nth_unstable_by(k, f64::total_cmp).1
}

/// Linearly interpolated quantile (the `R-7` / NumPy default): position `q·(n − 1)` in the
/// sorted non-NaN values; NaN when there are none or when `q` lies outside `[0, 1]` (or is
/// NaN).
pub fn quantile_linear(xs: &[f64], q: f64) -> f64 {
    if !(0.0..=1.0).contains(&q) {
        // A `q` above 1 indexed past the end of the sample (a panic).
        return f64::NAN;
    }
    let mut s: Vec<f64> = xs.iter().copied().filter(|x| !x.is_nan()).collect();
    if s.is_empty() {
        return f64::NAN;
    }
    s.sort_by(f64::total_cmp);
    let pos = q * (s.len() - 1) as f64;
    let (lo, hi) = (pos.floor() as usize, pos.ceil() as usize);
    s[lo] + (pos - lo as f64) * (s[hi] - s[lo])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_of_odd_even_and_empty_samples() {
        assert_eq!(median(&mut [3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&mut [4.0, 1.0, 2.0, 3.0]), 2.5);
        assert!(median(&mut []).is_nan());
        // Sorted in place, NaNs last.
        let mut xs = [3.0, f64::NAN, -1.0, 2.0];
        assert_eq!(median(&mut xs), 2.5);
        assert_eq!(xs[..3], [-1.0, 2.0, 3.0]);
        assert!(xs[3].is_nan());
        // Two finite middle values whose sum overflows have a finite mean (it was ∞).
        assert_eq!(median(&mut [f64::MAX, f64::MAX]), f64::MAX);
        let m = median(&mut [1e308, 1.5e308, 0.0, f64::INFINITY]);
        assert!(m.is_finite() && m > 1e308 && m < 1.5e308, "{m:e}");
        assert_eq!(median(&mut [-f64::MAX, -f64::MAX]), -f64::MAX);
        // Infinite values stay infinite.
        assert_eq!(median(&mut [f64::INFINITY, f64::INFINITY]), f64::INFINITY);
    }

    #[test]
    fn rank_quantile_matches_counting_below() {
        // Brute force: the smallest value with more than ⌊q·n⌋ values at or below it.
        let xs = [5.0, -1.0, 3.5, 3.5, 9.0, 0.0, 2.0, 7.0, 4.0, 1.0, 8.0];
        for q in [0.0, 0.1, 0.25, 0.5, 0.9, 0.99, 1.0] {
            let k = ((xs.len() as f64 * q) as usize).min(xs.len() - 1);
            let want = xs
                .iter()
                .copied()
                .filter(|&v| xs.iter().filter(|&&w| w <= v).count() > k)
                .fold(f64::INFINITY, f64::min);
            assert_eq!(quantile_rank(&mut xs.clone(), q), want, "q = {q}");
            // The same value as indexing the sorted sample.
            let mut sorted = xs;
            sorted.sort_by(f64::total_cmp);
            assert_eq!(quantile_rank(&mut xs.clone(), q), sorted[k], "q = {q}");
        }
        assert_eq!(quantile_rank(&mut [1.0, 2.0, 3.0, 4.0], 0.5), 3.0); // upper median
        assert!(quantile_rank(&mut [], 0.5).is_nan());
        // Two quantiles of one buffer in a row (the first reorders it).
        let mut v = xs;
        assert_eq!(
            (quantile_rank(&mut v, 0.5), quantile_rank(&mut v, 0.9)),
            (3.5, 8.0)
        );
    }

    #[test]
    fn quantiles_outside_the_unit_interval_are_nan_not_a_panic() {
        let xs = [4.0, 1.0, 3.0, 2.0];
        for q in [1.5, 2.0, -0.5, f64::NAN, f64::INFINITY] {
            assert!(quantile_linear(&xs, q).is_nan(), "linear, q = {q}");
            assert!(quantile_rank(&mut xs.clone(), q).is_nan(), "rank, q = {q}");
        }
        // The ends of the interval are valid.
        assert_eq!(quantile_linear(&xs, 1.0), 4.0);
        assert_eq!(quantile_rank(&mut xs.clone(), 1.0), 4.0);
        assert_eq!(quantile_rank(&mut xs.clone(), 0.0), 1.0);
    }

    #[test]
    fn linear_quantile_interpolates_and_ignores_nan() {
        let xs = [4.0, f64::NAN, 1.0, 3.0, 2.0];
        assert_eq!(quantile_linear(&xs, 0.0), 1.0);
        assert_eq!(quantile_linear(&xs, 1.0), 4.0);
        assert_eq!(quantile_linear(&xs, 0.5), 2.5);
        assert!((quantile_linear(&xs, 0.9) - 3.7).abs() < 1e-12);
        assert!(quantile_linear(&[f64::NAN], 0.5).is_nan());
    }
}
