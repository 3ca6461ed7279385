//! Exact passes over a row-major grid whose non-zero cells all lie in a few blocks (a wide
//! posterior assembled from parts far apart: most of its rectangle is exact zeros).
//!
//! Each function gives the bits of its dense counterpart in `simd`/`window` while visiting
//! only the blocks: a sum keeps every cell in the accumulator lane the dense pass gives it
//! (its index modulo eight, in whole aligned chunks) and skips only chunks that hold no block
//! cell, whose additions of `+0` leave the non-negative sums unchanged; a maximum, an extent
//! or a scaling has no order to keep, and zeros never pass an extent's test.

use super::simd::with_avx;

/// A block of cells: rows `r0..r1`, columns `c0..c1`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct Block {
    pub r0: usize,
    pub r1: usize,
    pub c0: usize,
    pub c1: usize,
}

impl Block {
    /// The part of the block inside rows `a0..a1` and columns `b0..b1`, relative to
    /// `(a0, b0)` (`None` when empty).
    pub fn clip(&self, a0: usize, a1: usize, b0: usize, b1: usize) -> Option<Block> {
        let (r0, r1) = (self.r0.max(a0), self.r1.min(a1));
        let (c0, c1) = (self.c0.max(b0), self.c1.min(b1));
        (r0 < r1 && c0 < c1).then(|| Block {
            r0: r0 - a0,
            r1: r1 - a0,
            c0: c0 - b0,
            c1: c1 - b0,
        })
    }
}

/// The columns of row `i` inside some block, as sorted, disjoint `[c0, c1)` segments.
fn segments(blocks: &[Block], i: usize, out: &mut Vec<(usize, usize)>) {
    out.clear();
    out.extend(
        blocks
            .iter()
            .filter(|b| b.r0 <= i && i < b.r1 && b.c0 < b.c1)
            .map(|b| (b.c0, b.c1)),
    );
    out.sort_unstable();
    let mut k = 0;
    for n in 0..out.len() {
        if k > 0 && out[n].0 <= out[k - 1].1 {
            out[k - 1].1 = out[k - 1].1.max(out[n].1);
        } else {
            out[k] = out[n];
            k += 1;
        }
    }
    out.truncate(k);
}

/// Adds the aligned chunks of eight of `v` lane by lane.
#[inline(always)]
fn add_chunks(acc: &mut [f64; 8], v: &[f64]) {
    for c in v.chunks_exact(8) {
        for (a, &x) in acc.iter_mut().zip(c) {
            *a += x;
        }
    }
}

#[inline(always)]
fn combine(acc: &[f64; 8], rest: f64) -> f64 {
    ((acc[0] + acc[4]) + (acc[1] + acc[5])) + ((acc[2] + acc[6]) + (acc[3] + acc[7])) + rest
}

/// Accumulates the cells `g0..g1` of `v` (`main` = the end of its whole chunks): chunks from
/// `next` on into `acc`, the cells beyond `main` one by one into `rest`.
#[inline(always)]
fn add_range(
    v: &[f64],
    (g0, g1): (usize, usize),
    main: usize,
    next: &mut usize,
    acc: &mut [f64; 8],
    rest: &mut f64,
) {
    let m1 = g1.min(main);
    if g0 < m1 {
        let (q0, q1) = ((g0 / 8).max(*next), m1.div_ceil(8));
        if q0 < q1 {
            add_chunks(acc, &v[q0 * 8..q1 * 8]);
            *next = q1;
        }
    }
    for &x in &v[g0.max(main).min(g1)..g1] {
        *rest += x;
    }
}

/// [`super::simd::lane_sum`] of the `h × w` grid `v`, zero outside `blocks`.
pub(crate) fn lane_sum(v: &[f64], w: usize, h: usize, blocks: &[Block]) -> f64 {
    let main = w * h / 8 * 8;
    let (mut acc, mut rest, mut next) = ([0.0f64; 8], 0.0, 0);
    let mut segs = Vec::new();
    with_avx(|| {
        for i in 0..h {
            segments(blocks, i, &mut segs);
            for &(c0, c1) in &segs {
                let g = (i * w + c0, i * w + c1);
                add_range(v, g, main, &mut next, &mut acc, &mut rest);
            }
        }
    });
    combine(&acc, rest)
}

/// [`super::simd::lane_max`] of the grid `v` (rows of `w` cells), zero outside `blocks`.
pub(crate) fn lane_max(v: &[f64], w: usize, blocks: &[Block]) -> f64 {
    let mut m = 0.0f64;
    for b in blocks {
        for i in b.r0..b.r1 {
            m = v[i * w + b.c0..i * w + b.c1]
                .iter()
                .fold(m, |a, &x| a.max(x));
        }
    }
    m
}

/// [`super::simd::row_extents`] of the `h × w` grid `v`, zero outside `blocks` (zeros never
/// pass the test).
pub(crate) fn row_extents(
    v: &[f64],
    w: usize,
    h: usize,
    blocks: &[Block],
    cut: f64,
    mut f: impl FnMut(usize, usize, usize),
) {
    let mut segs = Vec::new();
    for i in 0..h {
        segments(blocks, i, &mut segs);
        let row = &v[i * w..(i + 1) * w];
        let first = segs
            .iter()
            .find_map(|&(c0, c1)| super::simd::extent(&row[c0..c1], cut).map(|(a, _)| c0 + a));
        if let Some(a) = first {
            let last = segs
                .iter()
                .rev()
                .find_map(|&(c0, c1)| super::simd::extent(&row[c0..c1], cut).map(|(_, b)| c0 + b))
                .unwrap_or(a);
            f(i, a, last);
        }
    }
}

/// Multiplies the grid by `s` and writes its row sums (each [`super::simd::lane_sum`]'s
/// eight lanes within the row) into `mx` and its column totals (rows added in order) into
/// `my` (both zeroed here): the values of scaling every cell and then
/// `window::marginals_into`, for a grid zero outside `blocks`.
pub(crate) fn normalise_marginals(
    v: &mut [f64],
    w: usize,
    h: usize,
    blocks: &[Block],
    s: f64,
    mx: &mut Vec<f64>,
    my: &mut Vec<f64>,
) {
    mx.clear();
    mx.resize(h, 0.0);
    my.clear();
    my.resize(w, 0.0);
    let main = w / 8 * 8;
    let mut segs = Vec::new();
    with_avx(|| {
        for i in 0..h {
            segments(blocks, i, &mut segs);
            let row = &mut v[i * w..(i + 1) * w];
            for &(c0, c1) in &segs {
                for (x, t) in row[c0..c1].iter_mut().zip(&mut my[c0..c1]) {
                    *x *= s;
                    *t += *x;
                }
            }
            let (mut acc, mut rest, mut next) = ([0.0f64; 8], 0.0, 0);
            for &g in &segs {
                add_range(row, g, main, &mut next, &mut acc, &mut rest);
            }
            mx[i] = combine(&acc, rest);
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stationary::simd;

    /// A grid with values inside overlapping and separate blocks only.
    fn grid(w: usize, h: usize, blocks: &[Block]) -> Vec<f64> {
        let mut v = vec![0.0; w * h];
        for b in blocks {
            for i in b.r0..b.r1 {
                for j in b.c0..b.c1 {
                    v[i * w + j] = ((i * 31 + j * 17) % 13) as f64 * 0.07 + 1e-3;
                }
            }
        }
        v
    }

    fn blocks() -> Vec<Vec<Block>> {
        let b = |r0, r1, c0, c1| Block { r0, r1, c0, c1 };
        vec![
            vec![b(0, 3, 0, 5)],
            vec![b(2, 9, 3, 14), b(5, 12, 10, 21), b(15, 19, 30, 37)],
            vec![b(18, 20, 35, 37), b(0, 1, 0, 1)],
            vec![b(4, 6, 8, 9), b(4, 6, 16, 17), b(11, 20, 0, 37)],
        ]
    }

    #[test]
    fn block_passes_match_the_dense_ones_bit_for_bit() {
        for (w, h) in [(37usize, 20usize), (40, 20), (5, 3)] {
            for bl in blocks() {
                let bl: Vec<Block> = bl.iter().filter_map(|b| b.clip(0, h, 0, w)).collect();
                let v = grid(w, h, &bl);
                assert_eq!(
                    lane_sum(&v, w, h, &bl).to_bits(),
                    simd::lane_sum(&v).to_bits()
                );
                assert_eq!(lane_max(&v, w, &bl).to_bits(), simd::lane_max(&v).to_bits());
                for cut in [0.0, 0.5] {
                    let (mut a, mut b) = (Vec::new(), Vec::new());
                    row_extents(&v, w, h, &bl, cut, |i, f, l| a.push((i, f, l)));
                    simd::row_extents(&v, w, cut, |i, f, l| b.push((i, f, l)));
                    assert_eq!(a, b);
                }
                if simd::lane_sum(&v) == 0.0 {
                    continue; // no mass to normalise (never a posterior)
                }
                let s = 1.0 / simd::lane_sum(&v);
                let (mut got, mut mx, mut my) = (v.clone(), Vec::new(), Vec::new());
                normalise_marginals(&mut got, w, h, &bl, s, &mut mx, &mut my);
                let want: Vec<f64> = v.iter().map(|x| x * s).collect();
                assert_eq!(got, want);
                let rows: Vec<f64> = want.chunks_exact(w).map(simd::lane_sum).collect();
                let mut cols = vec![0.0; w];
                simd::column_totals(&mut cols, &want, w, h);
                assert_eq!(
                    mx.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
                    rows.iter().map(|x| x.to_bits()).collect::<Vec<_>>()
                );
                assert_eq!(my, cols);
            }
        }
    }
}
