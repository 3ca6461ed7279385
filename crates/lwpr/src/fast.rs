//! The vectorised arithmetic of [`crate::Arithmetic::Fast`] for a full distance metric with
//! `n ≥ 5` inputs: the same formulas as the reference (docs/methods.md § LWPR), with the sums
//! reordered so that they run as independent vector lanes instead of one long chain each.
//!
//! - activation distance `q = |M(x−c)|²` (triangular factor, half the work of
//!   `(x−c)ᵀD(x−c)`), four rows at a time from the bottom up, stopping as soon as the partial
//!   sum puts the field beyond every threshold; its `v = M(x−c)` kept as the metric gradient's
//!   `∂q/∂M` factor;
//! - the penalty gradient `Σ_i M_ri D_ic = (MD)_rc` and `D = MᵀM` as small register blocks
//!   (4 × 8 or 4 × 4 sums, each loaded column feeding all of them);
//! - the meta gradient's `Σ_i M_ri² + M_rc²` from one row sum instead of a suffix chain per
//!   element;
//! - the learning-rate exponentials of IDBD by [`exp_lanes`] (a polynomial, ≤ 2 ulp), which
//!   vectorises with the rest of the per-element step.
//!
//! Every operation is a separate multiply or add in a fixed order (no fused multiply-add), so
//! the results do not depend on the vector width (AVX2 or not) or the number of threads; they
//! differ from the reference order only by rounding. (The activation's `exp(−q/2)` still comes
//! from the platform's libm, as on the exact path.)
//!
//! **Why this order.** Kept in the reference's order, each `O(n²)`–`O(n³)` sum is one long chain
//! of dependent additions. A profile of the exact 25-D update with meta learning showed the CPU
//! waiting on add latencies, on store-to-load forwarding of short accumulator arrays (the meta
//! suffix sums), and on the library `exp` of the `n(n+1)/2` learning rates per active field (a
//! fifth of the time, and it kept the element loop scalar); memory was secondary. The order above
//! removes those chains and halves the CPU time of the 25-D update. Tried and dropped: two
//! accumulator chains per block, padding the metric step's columns to whole vectors, explicit
//! groups of four in the metric step, `MᵀM` blocks written transposed (all slower), and fused
//! multiply-adds (results would depend on the CPU).

/// `e^x` for `x ∈ [−10, 10]` (the clamped range of IDBD's log learning rates), within 2 ulp
/// of the correctly rounded value: `x = k ln 2 + r`, `|r| ≤ ln2/2`, degree-13 Taylor polynomial
/// of `e^r` (Estrin's scheme), scaled by `2^k` through the exponent bits. Branch-free, so
/// loops over it vectorise.
#[inline(always)]
pub(crate) fn exp_lanes(x: f64) -> f64 {
    const SHIFT: f64 = 6755399441055744.0; // 1.5 · 2^52: adding it rounds to an integer
    const LOG2E: f64 = std::f64::consts::LOG2_E;
    const LN2_HI: f64 = f64::from_bits(0x3fe6_2e42_fee0_0000); // ln 2, last 32 bits cleared
    const LN2_LO: f64 = f64::from_bits(0x3dea_39ef_3579_3c76); // ln 2 − LN2_HI
    let t = x * LOG2E + SHIFT;
    let k = t - SHIFT;
    let r = (x - k * LN2_HI) - k * LN2_LO;
    // e^r = Σ r^i / i!, i ≤ 13, by Estrin's scheme (a shallow tree instead of one chain).
    const C: [f64; 14] = [
        1.0,
        1.0,
        0.5,
        1.0 / 6.0,
        1.0 / 24.0,
        1.0 / 120.0,
        1.0 / 720.0,
        1.0 / 5040.0,
        1.0 / 40320.0,
        1.0 / 362880.0,
        1.0 / 3628800.0,
        1.0 / 39916800.0,
        1.0 / 479001600.0,
        1.0 / 6227020800.0,
    ];
    let r2 = r * r;
    let r4 = r2 * r2;
    let r8 = r4 * r4;
    let q = |i: usize| C[i] + C[i + 1] * r;
    let s0 = q(0) + q(2) * r2;
    let s1 = q(4) + q(6) * r2;
    let s2 = q(8) + q(10) * r2;
    let s3 = q(12);
    let p = (s0 + s1 * r4) + (s2 + s3 * r4) * r8;
    // The low bits of `t` hold k (two's complement modulo 2^12 after the shift): adding
    // k·2^52 to the bits of p multiplies it by 2^k (no overflow or underflow for |x| ≤ 10).
    f64::from_bits(p.to_bits().wrapping_add(t.to_bits() << 52))
}

/// `v = M xc` for upper-triangular `M` (column-major `n × n`, `n = xc.len()`) and returns
/// `q = |v|²`; stops early and returns a value `> q_stop` (with `v` incomplete) as soon as the
/// rows done so far prove `q > q_stop` (pass `f64::INFINITY` for the complete result).
/// Rows are taken from the bottom up, four at a time (`M_r..r+3,j` is a contiguous piece of
/// column `j`), so the cheap short rows come first.
#[inline(always)]
pub(crate) fn distance_m(m: &[f64], xc: &[f64], v: &mut [f64], q_stop: f64) -> f64 {
    let n = xc.len();
    let (m, v) = (&m[..n * n], &mut v[..n]);
    let blocks = n / 4;
    let mut q = 0.0;
    for r in (4 * blocks..n).rev() {
        let mut s = 0.0;
        for j in r..n {
            s += m[r + j * n] * xc[j];
        }
        v[r] = s;
        q += s * s;
    }
    for b in (0..blocks).rev() {
        let r0 = 4 * b;
        let mut acc = [0.0; 4];
        for j in r0..n {
            let col: &[f64; 4] = m[j * n + r0..j * n + r0 + 4].try_into().expect("4");
            let xj = xc[j];
            for t in 0..4 {
                acc[t] += col[t] * xj;
            }
        }
        v[r0..r0 + 4].copy_from_slice(&acc);
        q += (acc[0] * acc[0] + acc[1] * acc[1]) + (acc[2] * acc[2] + acc[3] * acc[3]);
        if q > q_stop {
            return q;
        }
    }
    q
}

/// The penalty derivatives `∂J₂/∂M_rc = 2γ'·(MD)_rc` into `dj2dm` and, with `meta`,
/// `∂²J₂/∂M_rc² = 2γ'·(D_cc + Σ_i M_ri² + M_rc²)` into `ddj2dmdm` (upper triangle, column-major;
/// `penalty` is γ' = 2γ/n as in the reference). `row_sq` is scratch of length `n`.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn penalty_derivatives(
    n: usize,
    m: &[f64],
    d: &[f64],
    penalty: f64,
    meta: bool,
    row_sq: &mut [f64],
    dj2dm: &mut [f64],
    ddj2dmdm: &mut [f64],
) {
    let nn = n * n;
    let (m, d) = (&m[..nn], &d[..nn]);
    let (dj2dm, ddj2dmdm) = (&mut dj2dm[..nn], &mut ddj2dmdm[..nn]);
    let two_pen = 2.0 * penalty;
    // (MD)_rc for r ≤ c in blocks of four rows × four columns held in registers: one column
    // of D (= its row, D is symmetric) feeds sixteen independent sums. M's lower triangle is
    // exactly zero, so the blocks may start their sums early (the extra terms add +0).
    for r0 in block_starts(0, n) {
        for (c0, wide) in lane_blocks(r0, n) {
            if wide {
                md_block::<8>(n, m, d, r0, c0, two_pen, dj2dm);
            } else {
                md_block::<4>(n, m, d, r0, c0, two_pen, dj2dm);
            }
        }
    }
    if meta {
        // Σ_i M_ri² per row, accumulated column by column (contiguous), then per element.
        let row_sq = &mut row_sq[..n];
        row_sq.fill(0.0);
        for i in 0..n {
            for (s, &v) in row_sq[..=i].iter_mut().zip(&m[i * n..i * n + i + 1]) {
                *s += v * v;
            }
        }
        for c in 0..n {
            let dcc = d[c + c * n];
            let col = c * n..c * n + c + 1;
            for ((o, &mrc), &rs) in ddj2dmdm[col.clone()].iter_mut().zip(&m[col]).zip(&*row_sq) {
                *o = two_pen * (dcc + (rs + mrc * mrc));
            }
        }
    }
}

/// `dj2dm_rc = two_pen · (MD)_rc` for rows `r0..r0+4` and columns `c0..c0+W`, the `W` column
/// pieces of four rows in registers (written whole: entries below the diagonal are scratch).
#[inline(always)]
fn md_block<const W: usize>(
    n: usize,
    m: &[f64],
    d: &[f64],
    r0: usize,
    c0: usize,
    two_pen: f64,
    dj2dm: &mut [f64],
) {
    let mut acc = [[0.0; 4]; W];
    for i in r0..n {
        let mv: &[f64; 4] = m[i * n + r0..i * n + r0 + 4].try_into().expect("4");
        let dv: &[f64; W] = d[i * n + c0..i * n + c0 + W].try_into().expect("W");
        for l in 0..W {
            for t in 0..4 {
                acc[l][t] += mv[t] * dv[l];
            }
        }
    }
    for l in 0..W {
        let c = c0 + l;
        for t in 0..4 {
            dj2dm[c * n + r0 + t] = two_pen * acc[l][t];
        }
    }
}

/// `D_ij = Σ_k M_ki M_kj` for columns `j0..j0+4` and rows `i0..i0+W` (`k < k_end`), the
/// `4 × W` sums in registers; `mt` holds the rows of `M`.
#[inline(always)]
fn gram_block<const W: usize>(
    n: usize,
    m: &[f64],
    mt: &[f64],
    (j0, i0, k_end): (usize, usize, usize),
    d: &mut [f64],
) {
    let mut acc = [[0.0; W]; 4];
    for k in 0..k_end {
        let rv: &[f64; W] = mt[k * n + i0..k * n + i0 + W].try_into().expect("W");
        for t in 0..4 {
            let a = m[k + (j0 + t) * n];
            for l in 0..W {
                acc[t][l] += a * rv[l];
            }
        }
    }
    for t in 0..4 {
        d[(j0 + t) * n + i0..(j0 + t) * n + i0 + W].copy_from_slice(&acc[t]);
    }
}

/// Blocks of lanes covering `lo..hi` (`hi − lo ≥ 4`): `(start, true)` for eight lanes while at
/// least eight remain, then `(start, false)` for four lanes, the last one ending at `hi`
/// (overlapping its predecessor when fewer than four remain).
#[inline(always)]
fn lane_blocks(lo: usize, hi: usize) -> impl Iterator<Item = (usize, bool)> {
    let wide = (hi - lo) / 8;
    let rest = lo + 8 * wide;
    let four = if hi - rest >= 4 { Some(rest) } else { None };
    let last = if !(hi - rest).is_multiple_of(4) {
        Some(hi - 4)
    } else {
        None
    };
    (0..wide)
        .map(move |b| (lo + 8 * b, true))
        .chain(four.map(|s| (s, false)))
        .chain(last.map(|s| (s, false)))
}

/// Starts of four-wide blocks covering `lo..hi` (`hi − lo ≥ 4`): `lo, lo + 4, …`, and a last
/// block ending at `hi` that overlaps its predecessor when `hi − lo` is not a multiple of 4.
#[inline(always)]
fn block_starts(lo: usize, hi: usize) -> impl Iterator<Item = usize> {
    let full = (hi - lo) / 4;
    let last = if !(hi - lo).is_multiple_of(4) {
        Some(hi - 4)
    } else {
        None
    };
    (0..full).map(move |b| lo + 4 * b).chain(last)
}

/// Scalars of one metric step shared by all elements of `M`.
pub(crate) struct StepScalars {
    pub w_w: f64,
    pub dj1dw: f64,
    pub ddj1dwdw: f64,
    pub dwdq: f64,
    pub ddwdqdq: f64,
    pub meta_rate: f64,
    pub trans_mul: f64,
    /// `0.1 · max |M_ij|` of the old `M`.
    pub limit: f64,
}

/// Gradient, IDBD step (with `META`) and `M` step for the upper triangle, column by column
/// (rows `0..=j` of column `j` are contiguous). `dq = M(x−c)`, `dx = x − c`; `g` holds
/// `∂J₂/∂M` on entry and `∂J/∂M` on exit.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn metric_step<const META: bool>(
    n: usize,
    k: &StepScalars,
    dq: &[f64],
    dx: &[f64],
    g: &mut [f64],
    ddj2: &[f64],
    b: &mut [f64],
    alpha: &mut [f64],
    h: &mut [f64],
    m: &mut [f64],
) {
    let nn = n * n;
    let (dq, dx) = (&dq[..n], &dx[..n]);
    let (g, ddj2) = (&mut g[..nn], &ddj2[..nn]);
    let (b, alpha, h, m) = (&mut b[..nn], &mut alpha[..nn], &mut h[..nn], &mut m[..nn]);
    let tm = k.trans_mul;
    let meta_tm = k.meta_rate * tm;
    for j in 0..n {
        let col = j * n..j * n + j + 1;
        let len = j + 1;
        let (gc, ddc) = (&mut g[col.clone()], &ddj2[col.clone()]);
        let (bc, ac) = (&mut b[col.clone()], &mut alpha[col.clone()]);
        let (hc, mc) = (&mut h[col.clone()], &mut m[col]);
        let dqc = &dq[..len];
        let dxj2 = 2.0 * dx[j];
        let ddw_x = 2.0 * k.dwdq * dx[j] * dx[j];
        for i in 0..len {
            let dqdm = dqc[i] * dxj2;
            let dw = dqdm * k.dwdq;
            let gi = k.w_w * gc[i] + k.dj1dw * dw;
            gc[i] = gi;
            let a = if META {
                let ddw = k.ddwdqdq * dqdm * dqdm + ddw_x;
                let dd = k.w_w * ddc[i] + ddw * k.dj1dw + dw * dw * k.ddj1dwdw;
                let aux = (meta_tm * gi * hc[i]).clamp(-0.1, 0.1);
                let bv = bc[i] - aux;
                let bv = bv.clamp(-10.0, 10.0);
                bc[i] = bv;
                let a = exp_lanes(bv);
                let f = 1.0 - a * dd * tm;
                let f = if f < 0.0 { 0.0 } else { f };
                hc[i] = hc[i] * f - a * tm * gi;
                a
            } else {
                ac[i]
            };
            let delta = a * tm * gi;
            let halve = delta > k.limit;
            ac[i] = if halve { 0.5 * a } else { a };
            mc[i] = if halve { mc[i] } else { mc[i] - delta };
        }
    }
}

/// `D = MᵀM` for upper-triangular `M`: column `j`, rows `j..n`, as `Σ_{k ≤ j} M_kj · (row k of
/// M)` from `mt` (rows of `M` contiguous, `mt[k·n + i] = M_ki` for `i ≥ k`), then mirrored, so
/// `D` is exactly symmetric.
#[inline(always)]
pub(crate) fn gram(n: usize, m: &[f64], mt: &mut [f64], d: &mut [f64]) {
    let nn = n * n;
    let (m, d) = (&m[..nn], &mut d[..nn]);
    let mt = &mut mt[..nn];
    for i in 0..n {
        for (k, &v) in m[i * n..i * n + i + 1].iter().enumerate() {
            mt[k * n + i] = v;
        }
    }
    // Blocks of four columns j × four rows i ≥ j0 in registers, summed over k ≤ j0 + 3
    // (M_kj = 0 for k > j and M_ki = 0 for k > i, so the extra terms add +0). Entries above
    // the diagonal are overwritten by the mirror below.
    for j0 in block_starts(0, n) {
        let k_end = (j0 + 4).min(n);
        for (i0, wide) in lane_blocks(j0, n) {
            if wide {
                gram_block::<8>(n, m, mt, (j0, i0, k_end), d);
            } else {
                gram_block::<4>(n, m, mt, (j0, i0, k_end), d);
            }
        }
    }
    for j in 1..n {
        let (done, col) = d.split_at_mut(j * n);
        for (dv, row) in col[..j].iter_mut().zip(done.chunks_exact(n)) {
            *dv = row[j];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ulps(a: f64, b: f64) -> u64 {
        (a.to_bits() as i64 - b.to_bits() as i64).unsigned_abs()
    }

    /// A random upper-triangular `M` (positive diagonal), `D = MᵀM` in plain ascending order,
    /// and a random `x − c`.
    fn random_case(n: usize, seed: u64) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let mut s = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
        let mut rnd = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let mut m = vec![0.0; n * n];
        for j in 0..n {
            for i in 0..j {
                m[i + j * n] = 0.3 * rnd();
            }
            m[j + j * n] = 1.0 + rnd().abs();
        }
        let mut d = vec![0.0; n * n];
        for j in 0..n {
            for i in 0..n {
                d[i + j * n] = (0..n).map(|k| m[k + i * n] * m[k + j * n]).sum();
            }
        }
        let xc = (0..n).map(|_| rnd()).collect();
        (m, d, xc)
    }

    fn close(a: f64, b: f64, scale: f64) -> bool {
        (a - b).abs() <= 1e-13 * scale
    }

    #[test]
    fn kernels_match_plain_sums_for_every_block_layout() {
        for n in 1..=30 {
            let (m, d, xc) = random_case(n, n as u64);
            let scale = 1.0 + d.iter().map(|v| v.abs()).sum::<f64>();
            // q = |M xc|² = xcᵀ D xc, and v = M xc.
            let mut v = vec![0.0; n];
            let q = distance_m(&m, &xc, &mut v, f64::INFINITY);
            let mut plain = 0.0;
            for j in 0..n {
                for i in 0..n {
                    plain += xc[i] * d[i + j * n] * xc[j];
                }
            }
            assert!(close(q, plain, scale), "n = {n}: q {q} vs {plain}");
            for r in 0..n {
                let vr: f64 = (r..n).map(|j| m[r + j * n] * xc[j]).sum();
                assert!(close(v[r], vr, scale));
            }
            if n < 4 {
                continue; // the block kernels need n ≥ 4 (the fast path runs for n ≥ 5)
            }
            // D = MᵀM: close to the plain sums and exactly symmetric.
            let mut d2 = vec![f64::NAN; n * n];
            let mut mt = vec![0.0; n * n];
            gram(n, &m, &mut mt, &mut d2);
            for j in 0..n {
                for i in 0..n {
                    assert!(close(d2[i + j * n], d[i + j * n], scale), "n = {n}");
                    assert_eq!(d2[i + j * n].to_bits(), d2[j + i * n].to_bits());
                }
            }
            // Penalty derivatives: 2p·(MD)_rc and 2p·(D_cc + Σ_i M_ri² + M_rc²), r ≤ c.
            let pen = 0.25;
            let (mut g, mut gg, mut row_sq) = (vec![0.0; n * n], vec![0.0; n * n], vec![0.0; n]);
            penalty_derivatives(n, &m, &d, pen, true, &mut row_sq, &mut g, &mut gg);
            for c in 0..n {
                for r in 0..=c {
                    let md: f64 = (0..n).map(|i| m[r + i * n] * d[i + c * n]).sum();
                    assert!(close(g[r + c * n], 2.0 * pen * md, scale), "n = {n}");
                    let sq: f64 = (r..n).map(|i| m[r + i * n] * m[r + i * n]).sum();
                    let want = 2.0 * pen * (d[c + c * n] + sq + m[r + c * n] * m[r + c * n]);
                    assert!(close(gg[r + c * n], want, scale), "n = {n}");
                }
            }
        }
    }

    #[test]
    fn exp_lanes_is_within_two_ulp_on_the_clamped_range() {
        let mut worst = 0;
        for i in 0..=200_000 {
            let x = -10.0 + 20.0 * i as f64 / 200_000.0;
            worst = worst.max(ulps(exp_lanes(x), x.exp()));
        }
        for x in [-10.0, 10.0, 0.0, -0.0, 1e-300, -1e-300, f64::MIN_POSITIVE] {
            worst = worst.max(ulps(exp_lanes(x), x.exp()));
        }
        assert!(worst <= 2, "worst error {worst} ulp");
    }
}
