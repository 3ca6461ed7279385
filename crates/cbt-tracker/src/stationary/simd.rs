//! The filter's inner loops (`y += k·x` over contiguous rows, sums, maxima) compiled twice: for the baseline
//! target and, chosen at run time, with AVX (four f64 lanes instead of SSE2's two). Both
//! perform the same multiplications and additions in the same order per element (no fused
//! multiply-add), so results are bit-identical whichever runs.
//!
//! Tried and dropped for the stationary layout's step (callgrind on the development sequences):
//! hand-blocked four-wide axpys; fusing the step's sum with its maximum, or the normalisation with
//! the marginals (the fused loops vectorise worse); the peak-scan extents and the register-held
//! `x` pass for every window (kept only for large windows and long kernels, where they pay);
//! skipping displacement columns whose band misses a group of outputs. Not tried: an `f32`
//! posterior, a bound to skip negligible bumps (approximations that would need a validation
//! check).

/// The run-time dispatch of every function below, written once: when the CPU has AVX,
/// evaluates `$call` (an `unsafe` call of the function's `#[target_feature(enable = "avx")]`
/// copy, with the SAFETY comment of that copy's other preconditions) and returns its value
/// from the enclosing function; otherwise does nothing, and the plain code after it runs.
/// Compiled on x86-64 only (elsewhere the plain code always runs); the standard library
/// caches the CPU check.
macro_rules! avx_first {
    ($call:expr) => {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx") {
            return $call;
        }
    };
}

/// `dst[i] += k · src[i]` over the common length.
#[inline]
pub(crate) fn axpy(dst: &mut [f64], src: &[f64], k: f64) {
    avx_first!(
        // SAFETY: the CPU supports AVX (the macro checked).
        unsafe { axpy_avx(dst, src, k) }
    );
    axpy_body(dst, src, k);
}

/// `dst[i] = k · src[i]` over the common length.
#[inline]
pub(crate) fn scale_into(dst: &mut [f64], src: &[f64], k: f64) {
    avx_first!(
        // SAFETY: the CPU supports AVX (the macro checked).
        unsafe { scale_avx(dst, src, k) }
    );
    scale_body(dst, src, k);
}

/// Runs `f` compiled with AVX when the CPU has it (for loops that call the `_inline`
/// bodies below many times: one check instead of one per call).
#[inline]
pub(crate) fn with_avx<R>(f: impl FnOnce() -> R) -> R {
    avx_first!(
        // SAFETY: the CPU supports AVX (the macro checked).
        unsafe { with_avx_enabled(f) }
    );
    f()
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
fn with_avx_enabled<R>(f: impl FnOnce() -> R) -> R {
    f()
}

/// [`axpy`] without its own dispatch (inlined into the caller's code).
#[inline(always)]
pub(crate) fn axpy_inline(dst: &mut [f64], src: &[f64], k: f64) {
    axpy_body(dst, src, k);
}

/// [`lane_sum`] without its own dispatch (inlined into the caller's code).
#[inline(always)]
pub(crate) fn lane_sum_inline(v: &[f64]) -> f64 {
    lane_sum_body(v)
}

#[inline(always)]
fn axpy_body(dst: &mut [f64], src: &[f64], k: f64) {
    for (x, &s) in dst.iter_mut().zip(src) {
        *x += k * s;
    }
}

#[inline(always)]
fn scale_body(dst: &mut [f64], src: &[f64], k: f64) {
    for (x, &s) in dst.iter_mut().zip(src) {
        *x = k * s;
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
fn axpy_avx(dst: &mut [f64], src: &[f64], k: f64) {
    axpy_body(dst, src, k);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
fn scale_avx(dst: &mut [f64], src: &[f64], k: f64) {
    scale_body(dst, src, k);
}

/// One tap of a row convolution: `(first source column, length, first destination column,
/// weight)`.
pub(crate) type Tap = (usize, usize, usize, f64);

/// For each of `n` rows: `dst_row[d0..d0 + len] += k · src_row[b0..b0 + len]` for every tap
/// `(b0, len, d0, k)` in order (rows at strides `ds` and `ss`). For short rows (a dozen
/// cells): the AVX copy steps four lanes at a time with intrinsics and finishes the 0–3
/// left-over cells one by one, where the compiler's loop, unrolled to sixteen cells, would do
/// such a row in its scalar epilogue. Same multiplication and addition per cell either way.
#[inline]
pub(crate) fn axpy_taps(
    dst: &mut [f64],
    ds: usize,
    src: &[f64],
    ss: usize,
    n: usize,
    taps: &[Tap],
) {
    for &(b0, len, d0, _) in taps {
        assert!(b0 + len <= ss && d0 + len <= ds, "tap beyond its row");
    }
    assert!(
        dst.len() >= n * ds && src.len() >= n * ss,
        "rows beyond the buffers"
    );
    avx_first!(
        // SAFETY: the CPU supports AVX (the macro checked); every tap stays within its row
        // and every row within its buffer (asserted above).
        unsafe { axpy_taps_avx(dst, ds, src, ss, n, taps) }
    );
    for r in 0..n {
        let (d, s) = (&mut dst[r * ds..(r + 1) * ds], &src[r * ss..(r + 1) * ss]);
        for &(b0, len, d0, k) in taps {
            axpy_body(&mut d[d0..d0 + len], &s[b0..b0 + len], k);
        }
    }
}

/// For each of `n` rows: `out_row[i] = a_row[i] · b_row[q0 + i]` over the `nc` cells of the
/// row, with `a` = `src` (rows at stride `ss`) or, when `src` is `None`, `out` itself (in
/// place); `out` and `b` rows at strides `nc` and `bs`. Returns the sum of the rows' product
/// sums (eight accumulators each, as [`lane_sum`]), added row by row. The AVX copy does the
/// products four lanes at a time (lane masks for the tail) and adds them in exactly the
/// order of the plain loop (two four-lane accumulators for its eight, the left-over cells
/// one by one), so the result is bit-identical.
#[allow(clippy::too_many_arguments)]
pub(crate) fn mul_sum_rows(
    out: &mut [f64],
    nc: usize,
    src: Option<(&[f64], usize)>,
    b: &[f64],
    bs: usize,
    q0: usize,
    n: usize,
) -> f64 {
    assert!(
        out.len() >= n * nc && q0 + nc <= bs && b.len() >= n * bs,
        "rows beyond the buffers"
    );
    if let Some((a, ss)) = src {
        assert!(
            n == 0 || (nc <= ss && a.len() >= (n - 1) * ss + nc),
            "rows beyond the source"
        );
    }
    avx_first!(
        // SAFETY: the CPU supports AVX (the macro checked); rows lie within the buffers
        // (asserted above).
        unsafe { mul_sum_rows_avx(out, nc, src, b, bs, q0, n) }
    );
    let mut mass = 0.0;
    for r in 0..n {
        let row = &mut out[r * nc..(r + 1) * nc];
        if let Some((a, ss)) = src {
            row.copy_from_slice(&a[r * ss..r * ss + nc]);
        }
        mass += mul_sum_body(row, &b[r * bs + q0..r * bs + q0 + nc]);
    }
    mass
}

/// [`mul_sum_rows`] with AVX intrinsics.
///
/// # Safety
/// The CPU must support AVX; the rows must lie within the buffers.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[allow(clippy::too_many_arguments)]
unsafe fn mul_sum_rows_avx(
    out: &mut [f64],
    nc: usize,
    src: Option<(&[f64], usize)>,
    b: &[f64],
    bs: usize,
    q0: usize,
    n: usize,
) -> f64 {
    use std::arch::x86_64::{
        _mm256_add_pd, _mm256_loadu_pd, _mm256_loadu_si256, _mm256_maskload_pd,
        _mm256_maskstore_pd, _mm256_mul_pd, _mm256_setzero_pd, _mm256_storeu_pd,
    };
    let mut mass = 0.0;
    for r in 0..n {
        // SAFETY: the rows lie within the buffers (the caller's contract); each cell of `a`
        // is read before the same cell of `o` is written (in place: the same cell).
        unsafe {
            let o = out.as_mut_ptr().add(r * nc);
            let a: *const f64 = match src {
                Some((a, ss)) => a.as_ptr().add(r * ss),
                None => o,
            };
            let q = b.as_ptr().add(r * bs + q0);
            let (mut lo, mut hi) = (_mm256_setzero_pd(), _mm256_setzero_pd());
            let mut i = 0;
            while i + 8 <= nc {
                let x = _mm256_mul_pd(_mm256_loadu_pd(a.add(i)), _mm256_loadu_pd(q.add(i)));
                let y = _mm256_mul_pd(_mm256_loadu_pd(a.add(i + 4)), _mm256_loadu_pd(q.add(i + 4)));
                _mm256_storeu_pd(o.add(i), x);
                _mm256_storeu_pd(o.add(i + 4), y);
                lo = _mm256_add_pd(lo, x);
                hi = _mm256_add_pd(hi, y);
                i += 8;
            }
            let tail = i;
            if i + 4 <= nc {
                let x = _mm256_mul_pd(_mm256_loadu_pd(a.add(i)), _mm256_loadu_pd(q.add(i)));
                _mm256_storeu_pd(o.add(i), x);
                i += 4;
            }
            if i < nc {
                let m = _mm256_loadu_si256(TAIL_MASKS[nc - i].as_ptr().cast());
                let x = _mm256_mul_pd(
                    _mm256_maskload_pd(a.add(i), m),
                    _mm256_maskload_pd(q.add(i), m),
                );
                _mm256_maskstore_pd(o.add(i), m, x);
            }
            let mut rest = 0.0;
            for k in tail..nc {
                rest += *o.add(k);
            }
            let mut acc = [0.0f64; 4];
            _mm256_storeu_pd(acc.as_mut_ptr(), _mm256_add_pd(lo, hi));
            mass += ((acc[0] + acc[1]) + (acc[2] + acc[3])) + rest;
        }
    }
    mass
}

/// Calls `f(j)`, by increasing `j`, for every cell of `cur` that passes the first tests of a
/// local maximum: `!(v <= 0)`, `!(v < cut)`, `!(above[j] >= v)`, `!(below[j] > v)` (the
/// absent rows' tests pass). Every other cell fails one of them; the AVX copy tests four cells
/// per comparison (the same predicates, NaN included) and calls `f` for the same cells.
#[inline]
pub(crate) fn peak_candidates(
    cur: &[f64],
    above: Option<&[f64]>,
    below: Option<&[f64]>,
    cut: f64,
    mut f: impl FnMut(usize),
) {
    let n = cur.len();
    assert!(above.is_none_or(|a| a.len() >= n) && below.is_none_or(|b| b.len() >= n));
    avx_first!(
        // SAFETY: the CPU supports AVX (the macro checked); the rows are as long as `cur`
        // (asserted above).
        unsafe { peak_candidates_avx(cur, above, below, cut, &mut f) }
    );
    for (j, &v) in cur.iter().enumerate() {
        if candidate(v, above.map(|a| a[j]), below.map(|b| b[j]), cut) {
            f(j);
        }
    }
}

/// The scalar form of [`peak_candidates`]'s test.
#[inline(always)]
fn candidate(v: f64, above: Option<f64>, below: Option<f64>, cut: f64) -> bool {
    !(v <= 0.0 || v < cut || above.is_some_and(|a| a >= v) || below.is_some_and(|b| b > v))
}

/// [`peak_candidates`] with AVX comparisons.
///
/// # Safety
/// The CPU must support AVX; `above` and `below` must be at least as long as `cur`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
unsafe fn peak_candidates_avx(
    cur: &[f64],
    above: Option<&[f64]>,
    below: Option<&[f64]>,
    cut: f64,
    f: &mut impl FnMut(usize),
) {
    use std::arch::x86_64::{
        _CMP_NGE_UQ, _CMP_NGT_UQ, _CMP_NLE_UQ, _CMP_NLT_UQ, _mm256_and_pd, _mm256_cmp_pd,
        _mm256_loadu_pd, _mm256_movemask_pd, _mm256_set1_pd, _mm256_setzero_pd,
    };
    let n = cur.len();
    let (zero, cutv) = (_mm256_setzero_pd(), _mm256_set1_pd(cut));
    let mut j = 0;
    while j + 4 <= n {
        // SAFETY: j + 4 ≤ n and the rows hold at least n cells.
        let bits = unsafe {
            let v = _mm256_loadu_pd(cur.as_ptr().add(j));
            let mut m = _mm256_and_pd(
                _mm256_cmp_pd::<_CMP_NLE_UQ>(v, zero),
                _mm256_cmp_pd::<_CMP_NLT_UQ>(v, cutv),
            );
            if let Some(a) = above {
                let a = _mm256_loadu_pd(a.as_ptr().add(j));
                m = _mm256_and_pd(m, _mm256_cmp_pd::<_CMP_NGE_UQ>(a, v));
            }
            if let Some(b) = below {
                let b = _mm256_loadu_pd(b.as_ptr().add(j));
                m = _mm256_and_pd(m, _mm256_cmp_pd::<_CMP_NGT_UQ>(b, v));
            }
            _mm256_movemask_pd(m)
        };
        let mut bits = bits as u32;
        while bits != 0 {
            f(j + bits.trailing_zeros() as usize);
            bits &= bits - 1;
        }
        j += 4;
    }
    for (k, &v) in cur.iter().enumerate().skip(j) {
        if candidate(v, above.map(|a| a[k]), below.map(|b| b[k]), cut) {
            f(k);
        }
    }
}

/// The first and last index of `row` whose value passes `v >= cut && v > 0` (NaN fails), or
/// `None` when no cell does. The AVX copy tests four cells per comparison from each end (the
/// same ordered predicates) and returns the same indices.
#[inline]
pub(crate) fn extent(row: &[f64], cut: f64) -> Option<(usize, usize)> {
    avx_first!(
        // SAFETY: the CPU supports AVX (the macro checked).
        unsafe { extent_avx(row, cut) }
    );
    extent_body(row, cut)
}

/// Calls `f(i, first, last)`, by increasing `i`, with the [`extent`] of every row `i` of the
/// grid `v` (rows of `w` cells) that has one; one dispatch for all the rows.
#[inline]
pub(crate) fn row_extents(v: &[f64], w: usize, cut: f64, mut f: impl FnMut(usize, usize, usize)) {
    avx_first!(
        // SAFETY: the CPU supports AVX (the macro checked).
        unsafe { row_extents_avx(v, w, cut, &mut f) }
    );
    for (i, row) in v.chunks_exact(w.max(1)).enumerate() {
        if let Some((a, b)) = extent_body(row, cut) {
            f(i, a, b);
        }
    }
}

/// [`row_extents`] with AVX comparisons.
///
/// # Safety
/// The CPU must support AVX.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
unsafe fn row_extents_avx(v: &[f64], w: usize, cut: f64, f: &mut impl FnMut(usize, usize, usize)) {
    for (i, row) in v.chunks_exact(w.max(1)).enumerate() {
        // SAFETY: AVX is enabled here as well.
        if let Some((a, b)) = unsafe { extent_avx(row, cut) } {
            f(i, a, b);
        }
    }
}

#[inline(always)]
fn passes(v: f64, cut: f64) -> bool {
    v >= cut && v > 0.0
}

#[inline(always)]
fn extent_body(row: &[f64], cut: f64) -> Option<(usize, usize)> {
    let f = row.iter().position(|&v| passes(v, cut))?;
    let l = row.iter().rposition(|&v| passes(v, cut)).unwrap_or(f);
    Some((f, l))
}

/// [`extent`] with AVX comparisons.
///
/// # Safety
/// The CPU must support AVX.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
unsafe fn extent_avx(row: &[f64], cut: f64) -> Option<(usize, usize)> {
    use std::arch::x86_64::{
        _CMP_GE_OQ, _CMP_GT_OQ, _mm256_and_pd, _mm256_cmp_pd, _mm256_loadu_pd, _mm256_movemask_pd,
        _mm256_set1_pd, _mm256_setzero_pd,
    };
    let n = row.len();
    let (zero, cutv) = (_mm256_setzero_pd(), _mm256_set1_pd(cut));
    // Bit l set when cell i + l passes (i + 4 ≤ n at every use).
    macro_rules! bits {
        ($i:expr) => {{
            // SAFETY: $i + 4 ≤ n (the loops' conditions).
            unsafe {
                let v = _mm256_loadu_pd(row.as_ptr().add($i));
                let m = _mm256_and_pd(
                    _mm256_cmp_pd::<_CMP_GE_OQ>(v, cutv),
                    _mm256_cmp_pd::<_CMP_GT_OQ>(v, zero),
                );
                _mm256_movemask_pd(m) as u32
            }
        }};
    }
    let mut first = None;
    let mut i = 0;
    while i + 4 <= n {
        let b = bits!(i);
        if b != 0 {
            first = Some(i + b.trailing_zeros() as usize);
            break;
        }
        i += 4;
    }
    let f = match first {
        Some(f) => f,
        None => (i..n).find(|&k| passes(row[k], cut))?,
    };
    // From the end: the 0–3 cells beyond the last full group of four (counted from the end)
    // one by one, then groups of four down to the first hit.
    let mut hi = n;
    while hi > f + 1 && !(hi - f - 1).is_multiple_of(4) {
        if passes(row[hi - 1], cut) {
            return Some((f, hi - 1));
        }
        hi -= 1;
    }
    while hi >= f + 5 {
        let b = bits!(hi - 4);
        if b != 0 {
            return Some((f, hi - 4 + 31 - b.leading_zeros() as usize));
        }
        hi -= 4;
    }
    Some((f, f))
}

/// Zeros on each side of the kernel given to [`conv_rows`].
pub(crate) const KPAD: usize = 15;

/// `kern` with [`KPAD`] zeros on each side, into `buf` (the form [`conv_rows`] takes).
pub(crate) fn pad_kernel(buf: &mut Vec<f64>, kern: &[f64]) {
    buf.clear();
    buf.extend_from_slice(&[0.0; KPAD]);
    buf.extend_from_slice(kern);
    buf.extend_from_slice(&[0.0; KPAD]);
}

/// Row convolution held in registers: for each of `n` rows,
/// `dst_row[j] = Σ_b src_row[b] · kern[j − b + base]` over `j < dc`, `b < sc` (rows at strides
/// `dc` and `ss`; taps outside `kern` are absent), the terms added by decreasing `b` starting
/// from `+0` — the order of [`axpy_taps`] with taps by increasing offset, so the values are
/// the same. `kpad` is `kern` with [`KPAD`] zeros on each side ([`pad_kernel`]); `src` must be
/// non-negative and finite. The AVX copy keeps a row of 9–16 outputs in four registers (lane
/// masks beyond it), or eight outputs in two registers (four for the last one to four), and
/// adds `src_row[b] · kpad[..]` for every `b` reaching any of them (an absent tap adds `+0`,
/// which leaves a non-negative sum unchanged): no stores between the terms.
#[allow(clippy::too_many_arguments)]
pub(crate) fn conv_rows(
    dst: &mut [f64],
    dc: usize,
    src: &[f64],
    ss: usize,
    sc: usize,
    n: usize,
    kpad: &[f64],
    base: i64,
) {
    let len = kpad.len() as i64 - 2 * KPAD as i64;
    assert!(len >= 1 && sc <= ss && dst.len() >= n * dc && src.len() >= n * ss);
    avx_first!(
        // SAFETY: the CPU supports AVX (the macro checked); buffers as asserted above.
        unsafe { conv_rows_avx(dst, dc, src, ss, sc, n, kpad, base) }
    );
    for r in 0..n {
        for j in 0..dc {
            let mut acc = 0.0;
            for b in (0..sc).rev() {
                let t = j as i64 - b as i64 + base;
                if (0..len).contains(&t) {
                    acc += src[r * ss + b] * kpad[t as usize + KPAD];
                }
            }
            dst[r * dc + j] = acc;
        }
    }
}

/// [`conv_rows`] with AVX intrinsics (no FMA).
///
/// # Safety
/// The CPU must support AVX; the buffers must be as [`conv_rows`] asserts.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[allow(clippy::too_many_arguments)]
unsafe fn conv_rows_avx(
    dst: &mut [f64],
    dc: usize,
    src: &[f64],
    ss: usize,
    sc: usize,
    n: usize,
    kpad: &[f64],
    base: i64,
) {
    use std::arch::x86_64::{
        __m256i, _mm256_add_pd, _mm256_broadcast_sd, _mm256_loadu_pd, _mm256_loadu_si256,
        _mm256_maskstore_pd, _mm256_mul_pd, _mm256_setzero_pd, _mm256_storeu_pd,
    };
    let len = kpad.len() as i64 - 2 * KPAD as i64;
    let p = KPAD as i64;
    for r in 0..n {
        let row = &src[r * ss..r * ss + sc];
        let d = dst[r * dc..].as_mut_ptr();
        if (9..=16).contains(&dc) {
            // The whole row of outputs in four registers (lane masks beyond dc): sources b with
            // t = lane − b + base ∈ [0, len) for some lane.
            let b_hi = (base + 15).min(sc as i64 - 1);
            let b_lo = (base - len + 1).max(0);
            let masks: [__m256i; 4] = std::array::from_fn(|l| {
                let k = dc.saturating_sub(4 * l).min(4);
                // SAFETY: a mask row holds four lanes.
                unsafe { _mm256_loadu_si256(FULL_MASKS[k].as_ptr().cast()) }
            });
            let mut acc = [_mm256_setzero_pd(); 4];
            let mut b = b_hi;
            while b >= b_lo {
                // t0 = −b + base ∈ [−15, len − 1]: the loads at t0 + 15 + 4l (four cells
                // each, l < 4) stay inside kpad (len + 30 cells).
                let t0 = base - b;
                // SAFETY: b < sc ≤ row length; kpad indices as derived just above.
                unsafe {
                    let q = _mm256_broadcast_sd(row.get_unchecked(b as usize));
                    let k = kpad.as_ptr().add((t0 + p) as usize);
                    for (l, a) in acc.iter_mut().enumerate() {
                        *a = _mm256_add_pd(*a, _mm256_mul_pd(q, _mm256_loadu_pd(k.add(4 * l))));
                    }
                }
                b -= 1;
            }
            for (l, a) in acc.iter().enumerate() {
                // SAFETY: the masks keep the lanes below dc.
                unsafe { _mm256_maskstore_pd(d.add(4 * l), masks[l], *a) };
            }
            continue;
        }
        let mut j = 0;
        // Eight outputs j..j + 8 while more than four remain (the upper four masked at the
        // end): sources b with t = j + lane − b + base ∈ [0, len) for some lane.
        while j + 4 < dc {
            let b_hi = (j as i64 + base + 7).min(sc as i64 - 1);
            let b_lo = (j as i64 + base - len + 1).max(0);
            let (mut lo, mut hi) = (_mm256_setzero_pd(), _mm256_setzero_pd());
            let mut b = b_hi;
            while b >= b_lo {
                // t0 = j − b + base ∈ [−7, len − 1]: the loads at t0 + KPAD and
                // t0 + KPAD + 4 (four cells each) stay inside kpad (len + 2·KPAD cells).
                let t0 = j as i64 - b + base;
                // SAFETY: b < sc ≤ row length; kpad indices as derived just above.
                unsafe {
                    let q = _mm256_broadcast_sd(row.get_unchecked(b as usize));
                    let k = kpad.as_ptr().add((t0 + p) as usize);
                    lo = _mm256_add_pd(lo, _mm256_mul_pd(q, _mm256_loadu_pd(k)));
                    hi = _mm256_add_pd(hi, _mm256_mul_pd(q, _mm256_loadu_pd(k.add(4))));
                }
                b -= 1;
            }
            // SAFETY: j + 4 < dc; the upper lanes are masked below dc.
            unsafe {
                _mm256_storeu_pd(d.add(j), lo);
                if j + 8 <= dc {
                    _mm256_storeu_pd(d.add(j + 4), hi);
                } else {
                    let m = _mm256_loadu_si256(TAIL_MASKS[dc - j - 4].as_ptr().cast());
                    _mm256_maskstore_pd(d.add(j + 4), m, hi);
                }
            }
            j += 8;
        }
        if j < dc {
            // The last one to four outputs.
            let b_hi = (j as i64 + base + 3).min(sc as i64 - 1);
            let b_lo = (j as i64 + base - len + 1).max(0);
            let mut acc = _mm256_setzero_pd();
            let mut b = b_hi;
            while b >= b_lo {
                // t0 ∈ [−3, len − 1]: the four-cell load at t0 + KPAD stays inside kpad.
                let t0 = j as i64 - b + base;
                // SAFETY: b < sc ≤ row length; kpad index as derived just above.
                unsafe {
                    let q = _mm256_broadcast_sd(row.get_unchecked(b as usize));
                    let k = _mm256_loadu_pd(kpad.as_ptr().add((t0 + p) as usize));
                    acc = _mm256_add_pd(acc, _mm256_mul_pd(q, k));
                }
                b -= 1;
            }
            // SAFETY: j + 4 ≤ dc, or the mask keeps the lanes below dc.
            unsafe {
                if j + 4 <= dc {
                    _mm256_storeu_pd(d.add(j), acc);
                } else {
                    let m = _mm256_loadu_si256(TAIL_MASKS[dc - j].as_ptr().cast());
                    _mm256_maskstore_pd(d.add(j), m, acc);
                }
            }
        }
    }
}

/// Column convolution added in place: for each of `n` output rows `i` (stride `nc`),
/// `out_row_i += Σ_a kern[i − a + base] · src_row_a` over the `m` source rows `a` (stride
/// `nc`) with the tap inside `kern`, the terms by increasing `a` — the order of one
/// contiguous axpy per tap by decreasing offset over all the rows it joins. The AVX copy
/// keeps a row of up to sixteen cells in four registers (lane masks beyond it), or eight
/// (then four, then one to three, masked) cells of a longer row, across all their terms: the
/// same products and additions per cell, one load and one store.
#[allow(clippy::too_many_arguments)]
pub(crate) fn conv_cols(
    out: &mut [f64],
    n: usize,
    src: &[f64],
    m: usize,
    nc: usize,
    kern: &[f64],
    base: i64,
) {
    assert!(out.len() >= n * nc && src.len() >= m * nc);
    avx_first!(
        // SAFETY: the CPU supports AVX (the macro checked); buffers as asserted above.
        unsafe { conv_cols_avx(out, n, src, m, nc, kern, base) }
    );
    conv_cols_body(out, n, src, m, nc, kern, base);
}

/// [`conv_cols`] as one axpy per tap, taps by decreasing offset.
#[inline(always)]
fn conv_cols_body(
    out: &mut [f64],
    n: usize,
    src: &[f64],
    m: usize,
    nc: usize,
    kern: &[f64],
    base: i64,
) {
    for (t, &k) in kern.iter().enumerate().rev() {
        // i − a = t − base: sources a with i = a + t − base in [0, n).
        let shift = t as i64 - base;
        let lo = 0i64.max(-shift);
        let hi = (m as i64).min(n as i64 - shift);
        if lo >= hi {
            continue;
        }
        let len = (hi - lo) as usize * nc;
        let s = &src[lo as usize * nc..][..len];
        let d = &mut out[(lo + shift) as usize * nc..][..len];
        axpy_body(d, s, k);
    }
}

/// [`conv_cols`] with AVX intrinsics (no FMA).
///
/// # Safety
/// The CPU must support AVX; the buffers must be as [`conv_cols`] asserts.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[allow(clippy::too_many_arguments)]
unsafe fn conv_cols_avx(
    out: &mut [f64],
    n: usize,
    src: &[f64],
    m: usize,
    nc: usize,
    kern: &[f64],
    base: i64,
) {
    use std::arch::x86_64::{
        __m256d, __m256i, _mm256_add_pd, _mm256_broadcast_sd, _mm256_loadu_pd, _mm256_loadu_si256,
        _mm256_maskload_pd, _mm256_maskstore_pd, _mm256_mul_pd, _mm256_storeu_pd,
    };
    let len = kern.len() as i64;
    for i in 0..n {
        // Sources a with t = i − a + base ∈ [0, len), a ∈ [0, m).
        let a_lo = (i as i64 + base - len + 1).max(0);
        let a_hi = (i as i64 + base + 1).min(m as i64);
        if a_lo >= a_hi {
            continue;
        }
        let (a_lo, a_hi) = (a_lo as usize, a_hi as usize);
        // SAFETY: output row i and source rows a < m lie within the buffers (asserted by the
        // caller); every tap index t = i − a + base is in [0, len) by the range of a. The
        // terms step the source down one row (nc cells) and the tap back one per `a`.
        let count = a_hi - a_lo;
        unsafe {
            let o = out.as_mut_ptr().add(i * nc);
            // kern[i − a + base] for a = a_lo, a_lo + 1, …: from k0 downwards.
            let k0 = kern
                .as_ptr()
                .offset(i as isize + base as isize - a_lo as isize);
            let s0 = src.as_ptr().add(a_lo * nc);
            if nc <= 16 {
                // The whole row in four registers (lane masks beyond nc): one broadcast per
                // term.
                let masks: [__m256i; 4] = std::array::from_fn(|l| {
                    let k = nc.saturating_sub(4 * l).min(4);
                    _mm256_loadu_si256(FULL_MASKS[k].as_ptr().cast())
                });
                let mut x: [__m256d; 4] =
                    std::array::from_fn(|l| _mm256_maskload_pd(o.add(4 * l), masks[l]));
                let (mut kp, mut sp) = (k0, s0);
                for _ in 0..count {
                    let kv = _mm256_broadcast_sd(&*kp);
                    for l in 0..4 {
                        let v = _mm256_maskload_pd(sp.add(4 * l), masks[l]);
                        x[l] = _mm256_add_pd(x[l], _mm256_mul_pd(kv, v));
                    }
                    kp = kp.wrapping_sub(1);
                    sp = sp.wrapping_add(nc);
                }
                for l in 0..4 {
                    _mm256_maskstore_pd(o.add(4 * l), masks[l], x[l]);
                }
                continue;
            }
            let mut j = 0;
            while j + 8 <= nc {
                let (mut x, mut y) = (_mm256_loadu_pd(o.add(j)), _mm256_loadu_pd(o.add(j + 4)));
                let (mut kp, mut sp) = (k0, s0.add(j));
                for _ in 0..count {
                    let kv = _mm256_broadcast_sd(&*kp);
                    x = _mm256_add_pd(x, _mm256_mul_pd(kv, _mm256_loadu_pd(sp)));
                    y = _mm256_add_pd(y, _mm256_mul_pd(kv, _mm256_loadu_pd(sp.add(4))));
                    kp = kp.wrapping_sub(1);
                    sp = sp.wrapping_add(nc);
                }
                _mm256_storeu_pd(o.add(j), x);
                _mm256_storeu_pd(o.add(j + 4), y);
                j += 8;
            }
            if j + 4 <= nc {
                let mut x = _mm256_loadu_pd(o.add(j));
                let (mut kp, mut sp) = (k0, s0.add(j));
                for _ in 0..count {
                    let kv = _mm256_broadcast_sd(&*kp);
                    x = _mm256_add_pd(x, _mm256_mul_pd(kv, _mm256_loadu_pd(sp)));
                    kp = kp.wrapping_sub(1);
                    sp = sp.wrapping_add(nc);
                }
                _mm256_storeu_pd(o.add(j), x);
                j += 4;
            }
            if j < nc {
                let mask = _mm256_loadu_si256(TAIL_MASKS[nc - j].as_ptr().cast());
                let mut x = _mm256_maskload_pd(o.add(j), mask);
                let (mut kp, mut sp) = (k0, s0.add(j));
                for _ in 0..count {
                    let kv = _mm256_broadcast_sd(&*kp);
                    x = _mm256_add_pd(x, _mm256_mul_pd(kv, _mm256_maskload_pd(sp, mask)));
                    kp = kp.wrapping_sub(1);
                    sp = sp.wrapping_add(nc);
                }
                _mm256_maskstore_pd(o.add(j), mask, x);
            }
        }
    }
}

/// Correlation of two non-negative finite sequences at consecutive shifts:
/// `out[i] = Σ_a m1[a] · m2[a + d_hi − i]` over the `a` where both exist, the terms added by
/// increasing `a` from `+0`. The AVX copy computes four shifts per register over the union
/// of their ranges, reading `m2` reversed and padded with zeros (`rev`, a work buffer): each
/// lane's extra terms are `+0`, which leave its non-negative sum unchanged, so the values are
/// the plain loop's.
pub(crate) fn correlate(out: &mut [f64], m1: &[f64], m2: &[f64], d_hi: i64, rev: &mut Vec<f64>) {
    if !out.is_empty() {
        avx_first!({
            rev.clear();
            rev.extend_from_slice(&[0.0; 4]);
            rev.extend(m2.iter().rev());
            rev.extend_from_slice(&[0.0; 4]);
            // SAFETY: the CPU supports AVX (the macro checked); `rev` is `m2` reversed with four
            // zeros on each side.
            unsafe { correlate_avx(out, m1, m2.len(), d_hi, rev) }
        });
    }
    let _ = rev;
    correlate_body(out, m1, m2, d_hi);
}

#[inline(always)]
fn correlate_body(out: &mut [f64], m1: &[f64], m2: &[f64], d_hi: i64) {
    let (n1, n2) = (m1.len() as i64, m2.len() as i64);
    for (i, o) in out.iter_mut().enumerate() {
        let d = d_hi - i as i64;
        let (a_lo, a_hi) = ((-d).max(0), n1.min(n2 - d));
        let mut c = 0.0;
        if a_lo < a_hi {
            let n = (a_hi - a_lo) as usize;
            for (&x, &y) in m1[a_lo as usize..][..n]
                .iter()
                .zip(&m2[(a_lo + d) as usize..][..n])
            {
                c += x * y;
            }
        }
        *o = c;
    }
}

/// [`correlate`] with AVX intrinsics (no FMA).
///
/// # Safety
/// The CPU must support AVX; `rev` must hold `m2` (of length `n2`) reversed with four zeros
/// on each side.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
unsafe fn correlate_avx(out: &mut [f64], m1: &[f64], n2: usize, d_hi: i64, rev: &[f64]) {
    use std::arch::x86_64::{
        _mm256_add_pd, _mm256_broadcast_sd, _mm256_loadu_pd, _mm256_mul_pd, _mm256_setzero_pd,
        _mm256_storeu_pd,
    };
    let (n1, n2i) = (m1.len() as i64, n2 as i64);
    let mut i0 = 0;
    while i0 < out.len() {
        // Lanes l = 0..4: shifts d = d_max − l. Lane l reads m2[a + d_max − l], which is
        // rev[n2 + 3 − a − d_max + l]: four consecutive cells. Over the union of the lanes'
        // ranges that index stays in [1, n2 + 7) (at most three cells beyond m2 either side).
        let d_max = d_hi - i0 as i64;
        let a_lo = (-d_max).max(0);
        let a_hi = n1.min(n2i - (d_max - 3));
        let mut acc = _mm256_setzero_pd();
        let mut a = a_lo;
        while a < a_hi {
            let j = n2i + 3 - a - d_max;
            // SAFETY: a < n1; j ∈ [1, n2 + 3] (so j + 4 ≤ rev.len() = n2 + 8), as derived above.
            unsafe {
                let x = _mm256_broadcast_sd(m1.get_unchecked(a as usize));
                let y = _mm256_loadu_pd(rev.as_ptr().add(j as usize));
                acc = _mm256_add_pd(acc, _mm256_mul_pd(x, y));
            }
            a += 1;
        }
        let mut lanes = [0.0f64; 4];
        // SAFETY: `lanes` holds four cells.
        unsafe { _mm256_storeu_pd(lanes.as_mut_ptr(), acc) };
        let m = (out.len() - i0).min(4);
        out[i0..i0 + m].copy_from_slice(&lanes[..m]);
        i0 += 4;
    }
}

/// `out[δ] += c · cols[v·stride + δ]` for every `(v, c)` in `cols`, in order (`out.len() ≤
/// stride`, `stride` a multiple of 16). The AVX copy holds sixteen outputs in four registers
/// across all the columns: the same products and additions per output, no stores between.
pub(crate) fn column_sum(out: &mut [f64], cols: &[f64], stride: usize, terms: &[(usize, f64)]) {
    assert!(stride.is_multiple_of(16) && out.len() <= stride);
    assert!(terms.iter().all(|&(v, _)| (v + 1) * stride <= cols.len()));
    avx_first!(
        // SAFETY: the CPU supports AVX (the macro checked); columns as asserted above.
        unsafe { column_sum_avx(out, cols, stride, terms) }
    );
    for &(v, c) in terms {
        axpy_body(out, &cols[v * stride..], c);
    }
}

/// [`column_sum`] with AVX intrinsics (no FMA).
///
/// # Safety
/// The CPU must support AVX; the buffers must be as [`column_sum`] asserts.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
unsafe fn column_sum_avx(out: &mut [f64], cols: &[f64], stride: usize, terms: &[(usize, f64)]) {
    use std::arch::x86_64::{
        __m256d, _mm256_add_pd, _mm256_loadu_pd, _mm256_mul_pd, _mm256_set1_pd, _mm256_storeu_pd,
    };
    let n = out.len();
    let mut j = 0;
    while j < n {
        let mut buf = [0.0f64; 16];
        let m = (n - j).min(16);
        buf[..m].copy_from_slice(&out[j..j + m]);
        // SAFETY: buf holds 16 cells; column cells j..j + 16 lie within the column's stride
        // (j < n ≤ stride, both multiples of 16 apart from n) and within `cols` (asserted).
        unsafe {
            let mut acc: [__m256d; 4] = [
                _mm256_loadu_pd(buf.as_ptr()),
                _mm256_loadu_pd(buf.as_ptr().add(4)),
                _mm256_loadu_pd(buf.as_ptr().add(8)),
                _mm256_loadu_pd(buf.as_ptr().add(12)),
            ];
            for &(v, c) in terms {
                let k = _mm256_set1_pd(c);
                let p = cols.as_ptr().add(v * stride + j);
                for (l, a) in acc.iter_mut().enumerate() {
                    *a = _mm256_add_pd(*a, _mm256_mul_pd(k, _mm256_loadu_pd(p.add(4 * l))));
                }
            }
            for (l, a) in acc.iter().enumerate() {
                _mm256_storeu_pd(buf.as_mut_ptr().add(4 * l), *a);
            }
        }
        out[j..j + m].copy_from_slice(&buf[..m]);
        j += 16;
    }
}

/// `out[j] += Σ_i v[i·w + j]` over the `h` rows of the `h × w` grid `v`, the rows added in
/// order (`out.len() == w`). The AVX copy holds sixteen columns in four registers across all
/// the rows (lane masks at the right edge): the same additions per column, no stores between.
pub(crate) fn column_totals(out: &mut [f64], v: &[f64], w: usize, h: usize) {
    assert!(out.len() == w && v.len() >= w * h);
    avx_first!(
        // SAFETY: the CPU supports AVX (the macro checked); the grid lies in `v` (asserted).
        unsafe { column_totals_avx(out, v, w, h) }
    );
    for row in v[..w * h].chunks_exact(w.max(1)) {
        axpy_body(out, row, 1.0);
    }
}

/// [`column_totals`] with AVX intrinsics.
///
/// # Safety
/// The CPU must support AVX; `v` must hold the grid and `out` one row.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
unsafe fn column_totals_avx(out: &mut [f64], v: &[f64], w: usize, h: usize) {
    use std::arch::x86_64::{
        __m256i, _mm256_add_pd, _mm256_loadu_si256, _mm256_maskload_pd, _mm256_maskstore_pd,
    };
    let mut j = 0;
    while j < w {
        // SAFETY: each mask keeps the lanes below w; rows lie within `v`.
        unsafe {
            let masks: [__m256i; 4] = std::array::from_fn(|l| {
                let k = w.saturating_sub(j + 4 * l).min(4);
                _mm256_loadu_si256(FULL_MASKS[k].as_ptr().cast())
            });
            let o = out.as_mut_ptr().add(j);
            let mut acc = [0usize, 1, 2, 3].map(|l| _mm256_maskload_pd(o.add(4 * l), masks[l]));
            for i in 0..h {
                let p = v.as_ptr().add(i * w + j);
                for l in 0..4 {
                    acc[l] = _mm256_add_pd(acc[l], _mm256_maskload_pd(p.add(4 * l), masks[l]));
                }
            }
            for l in 0..4 {
                _mm256_maskstore_pd(o.add(4 * l), masks[l], acc[l]);
            }
        }
        j += 16;
    }
}

/// Lane masks selecting the first `n` of four lanes (`n = 0..=4`).
#[cfg(target_arch = "x86_64")]
const FULL_MASKS: [[i64; 4]; 5] = [
    [0, 0, 0, 0],
    [-1, 0, 0, 0],
    [-1, -1, 0, 0],
    [-1, -1, -1, 0],
    [-1, -1, -1, -1],
];

/// Lane masks selecting the first `n` of four lanes (`n = 0..=3`).
#[cfg(target_arch = "x86_64")]
const TAIL_MASKS: [[i64; 4]; 4] = [[0, 0, 0, 0], [-1, 0, 0, 0], [-1, -1, 0, 0], [-1, -1, -1, 0]];

/// [`axpy_taps`] with AVX intrinsics (no FMA: a multiplication, then an addition).
///
/// # Safety
/// The CPU must support AVX; taps and rows must lie within the buffers.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
unsafe fn axpy_taps_avx(
    dst: &mut [f64],
    ds: usize,
    src: &[f64],
    ss: usize,
    n: usize,
    taps: &[Tap],
) {
    use std::arch::x86_64::{
        _mm256_add_pd, _mm256_loadu_pd, _mm256_loadu_si256, _mm256_maskload_pd,
        _mm256_maskstore_pd, _mm256_mul_pd, _mm256_set1_pd, _mm256_storeu_pd,
    };
    for r in 0..n {
        // SAFETY: rows and taps lie within the buffers (the caller's contract).
        unsafe {
            let d = dst.as_mut_ptr().add(r * ds);
            let s = src.as_ptr().add(r * ss);
            for &(b0, len, d0, k) in taps {
                let (d, s) = (d.add(d0), s.add(b0));
                let kv = _mm256_set1_pd(k);
                let mut i = 0;
                while i + 4 <= len {
                    let x = _mm256_loadu_pd(d.add(i));
                    let y = _mm256_mul_pd(kv, _mm256_loadu_pd(s.add(i)));
                    _mm256_storeu_pd(d.add(i), _mm256_add_pd(x, y));
                    i += 4;
                }
                if i < len {
                    // The 1–3 left-over cells through a lane mask (other lanes untouched).
                    let m = _mm256_loadu_si256(TAIL_MASKS[len - i].as_ptr().cast());
                    let x = _mm256_maskload_pd(d.add(i), m);
                    let y = _mm256_mul_pd(kv, _mm256_maskload_pd(s.add(i), m));
                    _mm256_maskstore_pd(d.add(i), m, _mm256_add_pd(x, y));
                }
            }
        }
    }
}

/// Sum with eight independent accumulators (vectorisable; differs from the sequential sum
/// only by rounding).
#[inline]
pub(crate) fn lane_sum(v: &[f64]) -> f64 {
    avx_first!(
        // SAFETY: the CPU supports AVX (the macro checked).
        unsafe { lane_sum_avx(v) }
    );
    lane_sum_body(v)
}

/// Largest value (0 for an empty slice or all values below 0), with eight lanes.
#[inline]
pub(crate) fn lane_max(v: &[f64]) -> f64 {
    avx_first!(
        // SAFETY: the CPU supports AVX (the macro checked).
        unsafe { lane_max_avx(v) }
    );
    lane_max_body(v)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
fn lane_sum_avx(v: &[f64]) -> f64 {
    lane_sum_body(v)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
fn lane_max_avx(v: &[f64]) -> f64 {
    lane_max_body(v)
}

/// Sum with eight independent accumulators (vectorisable; differs from the sequential sum
/// only by rounding).
#[inline(always)]
fn lane_sum_body(v: &[f64]) -> f64 {
    let mut acc = [0.0f64; 8];
    let mut chunks = v.chunks_exact(8);
    for c in &mut chunks {
        for (a, &x) in acc.iter_mut().zip(c) {
            *a += x;
        }
    }
    let rest: f64 = chunks.remainder().iter().sum();
    ((acc[0] + acc[4]) + (acc[1] + acc[5])) + ((acc[2] + acc[6]) + (acc[3] + acc[7])) + rest
}

/// Largest value (0 for an empty slice or all values below 0), with eight lanes.
#[inline(always)]
fn lane_max_body(v: &[f64]) -> f64 {
    let mut acc = [0.0f64; 8];
    let mut chunks = v.chunks_exact(8);
    for c in &mut chunks {
        for (a, &x) in acc.iter_mut().zip(c) {
            *a = a.max(x);
        }
    }
    let rest = chunks.remainder().iter().fold(0.0f64, |a, &b| a.max(b));
    acc.iter().fold(rest, |a, &b| a.max(b))
}

/// `out[i] *= b[i]` and the sum of the products, with eight accumulators.
#[inline(always)]
fn mul_sum_body(out: &mut [f64], b: &[f64]) -> f64 {
    let mut acc = [0.0f64; 8];
    let n = out.len().min(b.len());
    let (out, b) = (&mut out[..n], &b[..n]);
    let mut oc = out.chunks_exact_mut(8);
    let mut bc = b.chunks_exact(8);
    for (o, bb) in (&mut oc).zip(&mut bc) {
        for ((a, x), &y) in acc.iter_mut().zip(o.iter_mut()).zip(bb) {
            *x *= y;
            *a += *x;
        }
    }
    let mut rest = 0.0;
    for (x, &y) in oc.into_remainder().iter_mut().zip(bc.remainder()) {
        *x *= y;
        rest += *x;
    }
    ((acc[0] + acc[4]) + (acc[1] + acc[5])) + ((acc[2] + acc[6]) + (acc[3] + acc[7])) + rest
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_the_plain_loops_bit_for_bit() {
        for n in [0usize, 1, 3, 4, 7, 8, 15, 33] {
            let src: Vec<f64> = (0..n)
                .map(|i| (i as f64 * 0.37).sin().abs() / 3.0)
                .collect();
            let start: Vec<f64> = (0..n).map(|i| (i as f64 * 1.3).cos().abs()).collect();
            let k = 0.123456789;
            let (mut a, mut b) = (start.clone(), start.clone());
            axpy(&mut a, &src, k);
            axpy_body(&mut b, &src, k);
            assert_eq!(a, b);
            let want: Vec<f64> = start.iter().zip(&src).map(|(x, s)| x + k * s).collect();
            assert_eq!(a, want);
            scale_into(&mut a, &src, k);
            scale_body(&mut b, &src, k);
            assert_eq!(a, b);
            assert!(a.iter().zip(&src).all(|(x, s)| *x == k * s));
            assert_eq!(lane_sum(&src).to_bits(), lane_sum_body(&src).to_bits());
            assert_eq!(lane_max(&src), lane_max_body(&src));
            let (mut c, mut d) = (start.clone(), start.clone());
            let with = mul_sum_rows(&mut c, n, None, &src, n, 0, 1);
            assert_eq!(with.to_bits(), mul_sum_body(&mut d, &src).to_bits());
            assert_eq!(c, d);
            let exact: f64 = start.iter().zip(&src).map(|(x, s)| x * s).sum();
            assert!((mul_sum_body(&mut start.clone(), &src) - exact).abs() <= 1e-12);
            assert_eq!(lane_max(&src), src.iter().fold(0.0f64, |a, &b| a.max(b)));
        }
    }

    #[test]
    fn row_products_match_the_plain_loops_bit_for_bit() {
        for nc in [0usize, 1, 3, 4, 5, 7, 8, 9, 12, 15, 16, 17, 23] {
            let (bs, q0, n) = (nc + 5, 2, 3);
            let b: Vec<f64> = (0..bs * n).map(|i| (i as f64 * 0.77).sin().abs()).collect();
            let start: Vec<f64> = (0..nc * n)
                .map(|i| (i as f64 * 0.31).cos().abs() / 3.0)
                .collect();
            let mut got = start.clone();
            let m = mul_sum_rows(&mut got, nc, None, &b, bs, q0, n);
            // From a separate source with its own stride: the same values.
            let a: Vec<f64> = (0..n)
                .flat_map(|r| {
                    start[r * nc..(r + 1) * nc]
                        .iter()
                        .copied()
                        .chain([f64::NAN; 2])
                })
                .collect();
            let mut from = vec![0.0; nc * n];
            let m2 = mul_sum_rows(&mut from, nc, Some((&a, nc + 2)), &b, bs, q0, n);
            assert_eq!(from, got);
            assert_eq!(m2.to_bits(), m.to_bits());
            let mut want = start.clone();
            let mut mass = 0.0;
            for r in 0..n {
                let row = &mut want[r * nc..(r + 1) * nc];
                mass += mul_sum_body(row, &b[r * bs + q0..r * bs + q0 + nc]);
            }
            assert_eq!(got, want);
            assert_eq!(m.to_bits(), mass.to_bits());
        }
    }

    #[test]
    fn peak_candidates_match_the_scalar_test() {
        for n in [0usize, 1, 3, 4, 5, 9, 13] {
            let row = |s: f64| -> Vec<f64> {
                (0..n)
                    .map(|i| ((i as f64 * s).sin() * 2.0).max(-0.1))
                    .collect()
            };
            let (cur, above, below) = (row(0.9), row(1.3), row(0.4));
            for (up, down) in [
                (None, None),
                (Some(&above[..]), None),
                (None, Some(&below[..])),
                (Some(&above[..]), Some(&below[..])),
            ] {
                for cut in [0.0, 0.5, f64::NAN] {
                    let mut got = Vec::new();
                    peak_candidates(&cur, up, down, cut, |j| got.push(j));
                    let want: Vec<usize> = (0..n)
                        .filter(|&j| candidate(cur[j], up.map(|a| a[j]), down.map(|b| b[j]), cut))
                        .collect();
                    assert_eq!(got, want);
                    let plain: Vec<usize> = (0..n)
                        .filter(|&j| {
                            let v = cur[j];
                            !(v <= 0.0
                                || v < cut
                                || up.is_some_and(|a| a[j] >= v)
                                || down.is_some_and(|b| b[j] > v))
                        })
                        .collect();
                    assert_eq!(got, plain);
                }
            }
        }
    }

    #[test]
    fn register_row_convolution_matches_the_row_taps_bit_for_bit() {
        // One row convolution both ways: taps by increasing offset (axpy_taps) against four
        // outputs in a register (conv_rows); output column j = b + t − 3 for kernel tap t.
        let cases = [
            (9usize, 14usize),
            (12, 15),
            (3, 5),
            (15, 4),
            (7, 8),
            (5, 9),
            (20, 16),
            (12, 13),
            (4, 1),
        ];
        for ((ss, ds), klen) in cases
            .into_iter()
            .flat_map(|c| [1usize, 2, 11, 20].map(|k| (c, k)))
        {
            let n = 3;
            let src: Vec<f64> = (0..ss * n)
                .map(|i| (i as f64 * 0.71).sin().abs() / 7.0)
                .collect();
            let kern: Vec<f64> = (0..klen)
                .map(|i| (i as f64 * 0.37).cos().abs() / 5.0 + 0.01)
                .collect();
            let mut taps: Vec<Tap> = Vec::new();
            for (t, &k) in kern.iter().enumerate() {
                let b_lo = (3i64 - t as i64).max(0);
                let b_hi = (ds as i64 + 3 - t as i64).min(ss as i64);
                if b_lo < b_hi {
                    let d0 = (b_lo + t as i64 - 3) as usize;
                    taps.push((b_lo as usize, (b_hi - b_lo) as usize, d0, k));
                }
            }
            let mut a = vec![0.0; ds * n];
            axpy_taps(&mut a, ds, &src, ss, n, &taps);
            let mut kpad = Vec::new();
            pad_kernel(&mut kpad, &kern);
            let mut c = vec![f64::NAN; ds * n];
            conv_rows(&mut c, ds, &src, ss, ss, n, &kpad, 3);
            assert_eq!(a, c);
            // Some output is reached unless the shift of 3 moves every source before it.
            assert_eq!(
                a.iter().any(|&v| v > 0.0),
                ss + klen > 4,
                "{ss} {ds} {klen}"
            );
        }
    }

    #[test]
    fn column_sums_match_the_plain_loops_bit_for_bit() {
        for (w, stride) in [(1usize, 16usize), (13, 16), (33, 48), (16, 16), (40, 48)] {
            let cols: Vec<f64> = (0..stride * 5)
                .map(|i| (i as f64 * 0.61).sin().abs())
                .collect();
            let terms = [(3usize, 0.25), (0, 1.0 / 3.0), (4, 1e-3), (3, 0.7)];
            let start: Vec<f64> = (0..w).map(|i| i as f64 * 0.1).collect();
            let mut got = start.clone();
            column_sum(&mut got, &cols, stride, &terms);
            let mut want = start.clone();
            for &(v, c) in &terms {
                for (d, x) in want.iter_mut().enumerate() {
                    *x += c * cols[v * stride + d];
                }
            }
            assert_eq!(got, want);
        }
    }

    #[test]
    fn column_totals_match_the_plain_loops_bit_for_bit() {
        for (w, h) in [
            (0usize, 2usize),
            (1, 3),
            (5, 4),
            (13, 7),
            (16, 2),
            (17, 5),
            (37, 3),
        ] {
            let v: Vec<f64> = (0..w * h)
                .map(|i| (i as f64 * 0.83).sin().abs() / 3.0)
                .collect();
            let mut got = vec![0.0; w];
            column_totals(&mut got, &v, w, h);
            let mut want = vec![0.0; w];
            for i in 0..h {
                for j in 0..w {
                    want[j] += 1.0 * v[i * w + j];
                }
            }
            assert_eq!(got, want);
        }
    }

    #[test]
    fn extents_match_the_plain_scans() {
        for n in 0usize..19 {
            for pattern in 0u32..64 {
                // Cells from a few classes: zero, below the cut, at it, above it, NaN, negative.
                let row: Vec<f64> = (0..n)
                    .map(
                        |i| match (pattern >> (i % 6)).wrapping_mul(i as u32 + 7) % 6 {
                            0 | 1 => 0.0,
                            2 => 0.01,
                            3 => 0.5,
                            4 => f64::NAN,
                            _ => -1.0,
                        },
                    )
                    .collect();
                for cut in [0.0, 0.1, 0.5, f64::NAN] {
                    let want = row
                        .iter()
                        .position(|&v| v >= cut && v > 0.0)
                        .map(|f| (f, row.iter().rposition(|&v| v >= cut && v > 0.0).unwrap()));
                    assert_eq!(extent(&row, cut), want, "{row:?} {cut}");
                    assert_eq!(extent_body(&row, cut), want);
                    // The same row twice as a grid, with a row of zeros between.
                    let grid: Vec<f64> = row
                        .iter()
                        .chain(&vec![0.0; n])
                        .chain(&row)
                        .copied()
                        .collect();
                    let mut got = Vec::new();
                    row_extents(&grid, n, cut, |i, a, b| got.push((i, a, b)));
                    let want: Vec<_> = if n == 0 {
                        vec![]
                    } else {
                        [0, 2]
                            .iter()
                            .filter_map(|&i| want.map(|(a, b)| (i, a, b)))
                            .collect()
                    };
                    assert_eq!(got, want);
                }
            }
        }
    }

    #[test]
    fn correlation_matches_the_plain_loop_bit_for_bit() {
        let mut rev = Vec::new();
        for (n1, n2) in [(1usize, 1usize), (3, 12), (12, 3), (9, 9), (17, 5), (6, 23)] {
            let m1: Vec<f64> = (0..n1)
                .map(|i| (i as f64 * 0.91).sin().abs() / 3.0)
                .collect();
            let mut m2: Vec<f64> = (0..n2)
                .map(|i| (i as f64 * 0.47).cos().abs() / 7.0)
                .collect();
            m2[n2 / 2] = 0.0;
            // Shifts beyond either end (empty overlaps) included.
            for d_hi in [-(n1 as i64) - 3, -2, 0, 3, n2 as i64 + 2] {
                for count in [1usize, 3, 4, 7, 13, n1 + n2 + 6] {
                    let mut got = vec![f64::NAN; count];
                    correlate(&mut got, &m1, &m2, d_hi, &mut rev);
                    let mut want = vec![f64::NAN; count];
                    correlate_body(&mut want, &m1, &m2, d_hi);
                    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                    assert_eq!(bits(&got), bits(&want), "{n1} {n2} {d_hi} {count}");
                    for (i, &g) in got.iter().enumerate() {
                        let d = d_hi - i as i64;
                        let mut c = 0.0;
                        for a in 0..n1 as i64 {
                            if (0..n2 as i64).contains(&(a + d)) {
                                c += m1[a as usize] * m2[(a + d) as usize];
                            }
                        }
                        assert_eq!(g.to_bits(), c.to_bits());
                    }
                }
            }
        }
    }

    #[test]
    fn column_convolution_matches_the_tap_axpys_bit_for_bit() {
        for (n, m, nc, klen, base) in [
            (5usize, 7usize, 15usize, 9usize, 4i64),
            (12, 12, 16, 24, 13),
            (3, 9, 1, 5, 6),
            (9, 4, 13, 3, -2),
            (6, 6, 8, 30, 20),
            (4, 5, 3, 2, 0),
            (4, 6, 21, 7, 3),
            (7, 9, 17, 12, 8),
            (3, 3, 4, 4, 1),
        ] {
            let src: Vec<f64> = (0..m * nc)
                .map(|i| (i as f64 * 0.53).sin().abs() / 3.0)
                .collect();
            let kern: Vec<f64> = (0..klen)
                .map(|i| (i as f64 * 0.29).cos().abs() / 9.0)
                .collect();
            let start: Vec<f64> = (0..n * nc).map(|i| 1e-4 * (i % 5) as f64).collect();
            let (mut got, mut want) = (start.clone(), start.clone());
            conv_cols(&mut got, n, &src, m, nc, &kern, base);
            conv_cols_body(&mut want, n, &src, m, nc, &kern, base);
            assert_eq!(got, want, "{n} {m} {nc} {klen} {base}");
            // Against the definition, term by term in increasing a.
            for i in 0..n {
                for j in 0..nc {
                    let mut x = start[i * nc + j];
                    for a in 0..m {
                        let t = i as i64 - a as i64 + base;
                        if (0..klen as i64).contains(&t) {
                            x += kern[t as usize] * src[a * nc + j];
                        }
                    }
                    assert_eq!(got[i * nc + j].to_bits(), x.to_bits());
                }
            }
        }
    }

    #[test]
    fn row_taps_match_the_plain_loops_bit_for_bit() {
        let (ss, ds, n) = (13usize, 17usize, 3usize);
        let src: Vec<f64> = (0..ss * n).map(|i| (i as f64 * 0.71).sin() / 7.0).collect();
        let start: Vec<f64> = (0..ds * n).map(|i| (i as f64 * 0.3).cos()).collect();
        let taps: Vec<Tap> = vec![
            (0, 13, 4, 0.3),
            (2, 11, 0, 1.0 / 3.0),
            (5, 1, 16, 0.7),
            (1, 7, 9, 0.0),
        ];
        let mut got = start.clone();
        axpy_taps(&mut got, ds, &src, ss, n, &taps);
        let mut want = start.clone();
        for r in 0..n {
            for &(b0, len, d0, k) in &taps {
                for i in 0..len {
                    want[r * ds + d0 + i] += k * src[r * ss + b0 + i];
                }
            }
        }
        assert_eq!(got, want);
    }
}
