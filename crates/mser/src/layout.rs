//! The padded pixel layout of the flood: row length, and padded index → row and column by the
//! high half of one multiplication (64 × 64 bits for every layout, [`RowDiv`]; 32 × 32 bits
//! where that is exact, [`RowDiv32`], which the moment summation vectorises).
//!
//! The flood works on a copy of the image with a frame: image pixel `(x, y)` has the padded index
//! `(y + 1) · stride + x`, and every row ends in at least one padding column, so the left
//! neighbour of `x = 0` is the previous row's padding and the four neighbour steps `±1`,
//! `±stride` of any image pixel stay inside `(height + 2) · stride` cells.
//!
//! The row length is an *odd* multiple of 16 pixels. A power of two would make the rows of one
//! column share a few cache sets (rows 2 KiB apart fill the same set of an 8-way cache every
//! 4 KiB), and the flood, which often walks along columns, then evicts its own neighbours; with an
//! odd multiple consecutive rows spread over all sets. (Measured on graf img1: the flood of one
//! polarity 5–8 % faster than with the power-of-two stride 1024.)

/// Padded row length for an image `width` pixels wide: the smallest odd multiple of 16 that
/// leaves at least one padding column.
pub fn padded_stride(width: usize) -> usize {
    ((width + 1).div_ceil(16) * 16) | 16
}

/// Row and column of padded indices below 2^28 (the size limit checked by
/// [`GrayView::new`](crate::GrayView::new)), for one row length.
///
/// `row(i) = ⌊i · m / 2^64⌋` (the high half of one 64 × 64-bit product) with `m = ⌈2^64 / s⌉`
/// equals `⌊i / s⌋`: the product overestimates `i / s` by `ε = i (m − 2^64/s) / 2^64 < i / 2^64
/// < 2^-36 < 1 / s`, and the fractional part of `i / s` is at most `1 − 1/s`, so the floor is
/// unchanged. `m ≤ 2^63` fits in 64 bits for `s ≥ 2`. (The former `⌊i · m' / 2^k⌋` with `k`
/// depending on `s` cost a shift by a register per pixel in the moment summation of module
/// `stats`, whose loop then reloaded shift and multiplier from the stack; this form: callgrind,
/// one detection of both polarities, boat img1 −0.7 %, leuven img6 −0.2 % instructions.)
#[derive(Debug, Clone, Copy, Default)]
pub struct RowDiv {
    stride: u32,
    mul: u64,
}

impl RowDiv {
    /// The divider for row length `stride` (`2 ≤ stride ≤ 2^28`).
    pub fn new(stride: u32) -> Self {
        debug_assert!((2..=1 << 28).contains(&stride));
        RowDiv {
            stride,
            mul: u64::MAX / stride as u64 + 1,
        }
    }

    /// Padded row of padded index `i`: `⌊i / stride⌋` (image row + 1).
    #[inline]
    pub fn row(&self, i: u32) -> u32 {
        ((i as u128 * self.mul as u128) >> 64) as u32
    }

    /// Column and padded row `(x, y + 1)` of padded index `i`.
    #[inline]
    pub fn col_row(&self, i: u32) -> (u32, u32) {
        let y = self.row(i);
        (i - y * self.stride, y)
    }
}

/// Row and column of padded indices by the high half of a 32 × 32-bit product, for layouts small
/// enough that it is exact (see [`RowDiv::narrow`]): `row(i) = ⌊i · m / 2^32⌋` with
/// `m = ⌈2^32 / s⌉`.
///
/// Exactness: `m · s = 2^32 + r` with `0 ≤ r < s`, so `i · m / 2^32 = i / s + i · r / (s · 2^32)`;
/// the fractional part of `i / s` is at most `1 − 1/s`, so the floor is `⌊i / s⌋` whenever
/// `i · r < 2^32`, which [`RowDiv::narrow`] checks for the largest index. The product needs no
/// 128-bit multiplication (whose fixed registers cost the moment summation of module `stats`
/// three register copies and three reloads per pixel).
#[derive(Debug, Clone, Copy)]
pub struct RowDiv32 {
    stride: u32,
    mul: u32,
}

impl RowDiv {
    /// The 32-bit divider for the same row length, if it is exact for every index up to `last`.
    pub fn narrow(&self, last: u32) -> Option<RowDiv32> {
        let s = self.stride as u64;
        let mul = (1u64 << 32).div_ceil(s);
        let r = mul * s - (1 << 32);
        (mul <= u32::MAX as u64 && (last as u64) * r < 1 << 32).then_some(RowDiv32 {
            stride: self.stride,
            mul: mul as u32,
        })
    }
}

/// Column and padded row of a padded index: [`RowDiv`] for every layout, [`RowDiv32`] for those
/// small enough.
pub trait ColRow: Copy {
    /// Column and padded row `(x, y + 1)` of padded index `i`.
    fn col_row(self, i: u32) -> (u32, u32);
}

impl ColRow for RowDiv {
    #[inline]
    fn col_row(self, i: u32) -> (u32, u32) {
        RowDiv::col_row(&self, i)
    }
}

impl ColRow for RowDiv32 {
    #[inline]
    fn col_row(self, i: u32) -> (u32, u32) {
        let y = ((i as u64 * self.mul as u64) >> 32) as u32;
        (i - y * self.stride, y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strides_are_odd_multiples_of_16_with_a_padding_column() {
        for w in 1..5000 {
            let s = padded_stride(w);
            assert!(
                s > w && s.is_multiple_of(16) && !(s / 16).is_multiple_of(2),
                "width {w}: stride {s}"
            );
            assert!(s <= w + 32);
        }
    }

    #[test]
    fn row_division_is_exact() {
        // Every index of small layouts, and the extremes and a spread of indices below 2^28 for
        // every power of two and its neighbours as row length.
        for s in 2..600u32 {
            let d = RowDiv::new(s);
            for i in 0..s * 40 {
                assert_eq!(d.col_row(i), (i % s, i / s), "stride {s}, index {i}");
            }
        }
        let mut strides: Vec<u32> = (4..=28)
            .flat_map(|b| [(1 << b) - 1, 1 << b, (1 << b) + 1])
            .collect();
        strides.extend([816, 1040, 3 * 5 * 7 * 16, (1 << 28) - 16]);
        for s in strides.into_iter().filter(|&s| s <= 1 << 28) {
            let d = RowDiv::new(s);
            let rows = ((1u32 << 28) - 1) / s;
            for r in (0..=rows)
                .step_by((rows as usize / 500).max(1))
                .chain([rows])
            {
                let at = r * s;
                for j in [
                    at.saturating_sub(1),
                    at,
                    at + (s - 1).min((1 << 28) - 1 - at),
                ] {
                    assert_eq!(d.row(j), j / s, "stride {s}, index {j}");
                }
            }
            let top = (1 << 28) - 1;
            assert_eq!(d.row(top), top / s, "stride {s}, index {top}");
        }
    }

    #[test]
    fn narrow_division_is_exact_where_offered() {
        // Every index of small layouts; for every stride the largest index it is offered for
        // (found by halving) and the indices around multiples of the stride below it.
        for s in 2..600u32 {
            let d = RowDiv::new(s).narrow(s * 40).expect("small layout");
            for i in 0..s * 40 {
                assert_eq!(
                    ColRow::col_row(d, i),
                    (i % s, i / s),
                    "stride {s}, index {i}"
                );
            }
        }
        let strides = (4..=28).flat_map(|b| [(1u32 << b) - 1, 1 << b, (1 << b) + 1]);
        let more = [816, 880, 912, 1040, 3 * 5 * 7 * 16, (1 << 28) - 16];
        for s in strides.chain(more).filter(|&s| s <= 1 << 28) {
            let wide = RowDiv::new(s);
            // The largest `last` with `narrow(last)` offered.
            let (mut lo, mut hi) = (0u32, u32::MAX);
            if wide.narrow(0).is_none() {
                continue;
            }
            while lo < hi {
                let mid = lo + (hi - lo).div_ceil(2);
                if wide.narrow(mid).is_some() {
                    lo = mid;
                } else {
                    hi = mid - 1;
                }
            }
            let d = wide.narrow(lo).unwrap();
            let rows = lo / s;
            for r in (0..=rows)
                .step_by((rows as usize / 2000).max(1))
                .chain([rows])
            {
                let at = r.saturating_mul(s);
                for j in [at.saturating_sub(1), at, at.saturating_add(s - 1)] {
                    if j <= lo {
                        assert_eq!(
                            ColRow::col_row(d, j),
                            (j % s, j / s),
                            "stride {s}, index {j}"
                        );
                    }
                }
            }
            assert_eq!(
                ColRow::col_row(d, lo),
                (lo % s, lo / s),
                "stride {s}, index {lo}"
            );
        }
        // The Oxford images' layouts (up to 850 × 680 pixels) get it.
        assert!(RowDiv::new(880).narrow(880 * 682).is_some());
    }
}
