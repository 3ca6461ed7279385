//! The magnitude lower bound of the FD Corr error, evaluated in single precision.
//!
//! For unit-norm FDs, `e = 2 − 2 max_l |r₁₂(l)| ≥ 2 − 2 Σ_n |C₁(n)||C₂(n)|` (see
//! [`crate::search`]). The all-pairs search needs this bound for every pair, which makes the dot
//! product of magnitudes its most frequent operation. [`BoundTable`] stores every descriptor's
//! magnitudes as `f32`, zero-padded to a multiple of [`LANES`] so the product runs in eight
//! independent accumulators that the compiler keeps in SIMD registers, with half the memory
//! traffic of `f64`.
//!
//! **Rounding.** Converting the two factors, multiplying and summing at most `N − 1` non-negative
//! terms in `f32` (unit roundoff `u = 2⁻²⁴`) gives a relative error of at most `(N + 2)·u` on a
//! sum that is at most 1 (Cauchy–Schwarz on unit-norm vectors): `3.2e-6` for `N = 51`, so the
//! bound `2 − 2·dot` is off by at most `2(N + 2)·u = 6.4e-6`. [`bound_slack`] (the larger of
//! `1e-5` and twice that worst case, plus the correlator's `f64` rounding margin) is subtracted
//! before any comparison, so the `f32` bound never prunes a pair the exact bound would keep; it
//! only costs pairs whose bound lies within `1e-5` of the threshold a harmless evaluation.
//!
//! **Builds.** On x86-64 CPUs with AVX the loop runs in a copy compiled for AVX, chosen at run
//! time: one 8-lane register holds one [`LANES`] block, and the operations per lane and their
//! order are the baseline build's (no fused multiply-add), so the bounds are bit-identical to
//! it (tested) with half the instructions.

use crate::descriptor::DescriptorSet;

/// Width of the accumulator block and of the row padding.
pub(crate) const LANES: usize = 8;

/// Amount subtracted from an `f32` bound before comparing it with an exact error (see the
/// module doc: at least `2·(N + 2)·2⁻²⁴` for every supported `N`, plus the `f64` rounding
/// margin of the correlator).
pub(crate) fn bound_slack(coefficients: usize) -> f64 {
    let u = f32::EPSILON as f64 / 2.0;
    (1e-5f64).max(4.0 * (coefficients as f64 + 2.0) * u) + crate::correlation::ROUNDING_MARGIN
}

/// The magnitudes of a descriptor set as zero-padded `f32` rows.
pub(crate) struct BoundTable {
    stride: usize,
    rows: Vec<f32>,
}

impl BoundTable {
    /// The table of `set` (cost: one pass over its magnitudes).
    pub(crate) fn new(set: &DescriptorSet) -> Self {
        let d = set.fd_len();
        let stride = d.div_ceil(LANES) * LANES;
        let mut rows = vec![0.0f32; stride * set.len()];
        for (i, row) in rows.chunks_exact_mut(stride).enumerate() {
            for (r, &m) in row.iter_mut().zip(set.magnitudes(i)) {
                *r = m as f32;
            }
        }
        BoundTable { stride, rows }
    }

    /// Padded magnitude row `i`.
    #[inline]
    pub(crate) fn row(&self, i: usize) -> &[f32] {
        &self.rows[i * self.stride..(i + 1) * self.stride]
    }

    /// `2 − 2 Σ |C_q(n)||C_j(n)|` for every row `j` of this table against the padded `query`
    /// row, appended to `out` as `(bound, j)`; row `skip` (if any) is left out.
    pub(crate) fn bounds_into(
        &self,
        query: &[f32],
        skip: Option<usize>,
        out: &mut Vec<(f64, usize)>,
    ) {
        if self.stride == 0 {
            return;
        }
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx") {
            // SAFETY: the CPU supports AVX (checked just above).
            unsafe { self.bounds_into_avx(query, skip, out) };
            return;
        }
        self.bounds_into_plain(query, skip, out);
    }

    /// [`bounds_into`](Self::bounds_into) compiled for the baseline target.
    fn bounds_into_plain(&self, query: &[f32], skip: Option<usize>, out: &mut Vec<(f64, usize)>) {
        bounds_of_rows(&self.rows, self.stride, query, skip, out);
    }

    /// [`bounds_into`](Self::bounds_into) compiled with AVX, whose 8-lane registers hold one
    /// [`LANES`] block: the same operations on the same lanes in the same order, so the bounds
    /// are bit-identical to the baseline build's, at half the instructions.
    ///
    /// # Safety
    /// The CPU must support AVX.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    unsafe fn bounds_into_avx(
        &self,
        query: &[f32],
        skip: Option<usize>,
        out: &mut Vec<(f64, usize)>,
    ) {
        bounds_of_rows(&self.rows, self.stride, query, skip, out);
    }
}

/// The loop of [`BoundTable::bounds_into`], inlined into each of its target-feature builds.
#[inline(always)]
fn bounds_of_rows(
    rows: &[f32],
    stride: usize,
    query: &[f32],
    skip: Option<usize>,
    out: &mut Vec<(f64, usize)>,
) {
    out.reserve(rows.len() / stride);
    for (j, row) in rows.chunks_exact(stride).enumerate() {
        if Some(j) != skip {
            out.push((2.0 - 2.0 * f64::from(dot_padded(query, row)), j));
        }
    }
}

/// Dot product of two rows of equal length, a multiple of [`LANES`].
#[inline(always)]
fn dot_padded(a: &[f32], b: &[f32]) -> f32 {
    let mut acc = [0.0f32; LANES];
    for (x, y) in a.chunks_exact(LANES).zip(b.chunks_exact(LANES)) {
        for l in 0..LANES {
            acc[l] += x[l] * y[l];
        }
    }
    let s = [
        acc[0] + acc[4],
        acc[1] + acc[5],
        acc[2] + acc[6],
        acc[3] + acc[7],
    ];
    (s[0] + s[2]) + (s[1] + s[3])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{DescriptorConfig, Sampling, describe_all};

    fn set() -> DescriptorSet {
        let shapes: Vec<Vec<(f64, f64)>> = (0..12)
            .map(|s| {
                (0..40)
                    .map(|t| {
                        let a = t as f64 * std::f64::consts::TAU / 40.0;
                        let r = 10.0 + (s as f64 * 0.7 + 1.0) * (3.0 * a + s as f64).cos();
                        (r * a.cos() * (1.0 + 0.1 * s as f64), r * a.sin())
                    })
                    .collect()
            })
            .collect();
        let cfg = DescriptorConfig::with_sampling(Sampling::ArcLength);
        describe_all(cfg, &shapes).unwrap().set
    }

    #[test]
    fn every_build_gives_the_same_bounds() {
        let set = set();
        let table = BoundTable::new(&set);
        for i in 0..set.len() {
            let (mut a, mut b) = (Vec::new(), Vec::new());
            table.bounds_into(table.row(i), Some(i), &mut a);
            table.bounds_into_plain(table.row(i), Some(i), &mut b);
            assert_eq!(a, b);
        }
    }

    #[test]
    fn f32_bound_is_within_its_slack_of_the_exact_bound() {
        let set = set();
        let table = BoundTable::new(&set);
        let slack = bound_slack(set.config().coefficients) - crate::correlation::ROUNDING_MARGIN;
        let mut out = Vec::new();
        for i in 0..set.len() {
            out.clear();
            table.bounds_into(table.row(i), Some(i), &mut out);
            assert_eq!(out.len(), set.len() - 1);
            for &(b, j) in &out {
                assert_ne!(j, i);
                let exact: f64 = set
                    .magnitudes(i)
                    .iter()
                    .zip(set.magnitudes(j))
                    .map(|(x, y)| x * y)
                    .sum();
                let exact = 2.0 - 2.0 * exact;
                assert!((b - exact).abs() < slack / 4.0, "{b} vs {exact}");
            }
        }
    }
}
