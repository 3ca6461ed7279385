//! Small dense kernels on column-major `n × n` / `n × R` storage.
//!
//! [`dot`] fixes one summation order (blocks of four in ascending order, then the remaining
//! one to three terms in descending order). That is the order of the reference library's dot
//! product, which keeps our floating-point results bit-identical to it wherever the formulas
//! are the same (docs/methods.md § LWPR; see the crate docs, "Faithfulness").

/// `Σ a_i b_i` in the fixed order described in the module docs.
#[inline(always)]
pub(crate) fn dot(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut s = 0.0;
    let blocks = n / 4;
    for k in 0..blocks {
        let i = 4 * k;
        s += b[i] * a[i];
        s += b[i + 1] * a[i + 1];
        s += b[i + 2] * a[i + 2];
        s += b[i + 3] * a[i + 3];
    }
    let base = 4 * blocks;
    let mut r = n - base;
    while r > 0 {
        r -= 1;
        s += b[base + r] * a[base + r];
    }
    s
}

/// `acc_t += a · x_t` for `L` adjacent lanes: one multiply and one add per lane (no fused
/// multiply-add), so each lane rounds exactly as the scalar statement; the lanes vectorise.
#[inline(always)]
pub(crate) fn madd<const L: usize>(acc: &mut [f64; L], a: f64, x: &[f64]) {
    let x: &[f64; L] = x[..L].try_into().expect("L lanes");
    for t in 0..L {
        acc[t] += a * x[t];
    }
}

/// `L` sums at once: `acc_t = Σ_k coef_k · rows[k·stride + off + t]` (`t < L`), the terms taken
/// in the order of a length-`coef.len()` [`dot`] (or, with `dot_order = false`, plain
/// ascending `k`). Each lane has exactly the bits of that scalar sum; summing from contiguous
/// rows replaces `L` strided scalar chains by vector operations.
#[inline(always)]
pub(crate) fn sum_rows<const L: usize>(
    rows: &[f64],
    stride: usize,
    coef: &[f64],
    off: usize,
    dot_order: bool,
) -> [f64; L] {
    let len = coef.len();
    let base = if dot_order { 4 * (len / 4) } else { len };
    let mut acc = [0.0; L];
    for (row, &a) in rows.chunks_exact(stride).zip(&coef[..base]) {
        madd(&mut acc, a, &row[off..off + L]);
    }
    for k in (base..len).rev() {
        madd(
            &mut acc,
            coef[k],
            &rows[k * stride + off..k * stride + off + L],
        );
    }
    acc
}

/// Lane blocks for `sum_rows` over `count` columns: `(first column, width)` with widths 8 and 4
/// (a remainder of fewer than four columns is left to the caller).
#[inline(always)]
pub(crate) fn lane_blocks(start: usize, end: usize) -> (usize, usize) {
    let wide = start + 8 * ((end - start) / 8);
    let four = if end - wide >= 4 { wide + 4 } else { wide };
    (wide, four)
}

/// Upper-triangular `M` with `MᵀM = A` for a symmetric positive definite `n × n` matrix `A`
/// (column-major); `None` if `A` is not positive definite.
pub(crate) fn cholesky_upper(n: usize, a: &[f64]) -> Option<Vec<f64>> {
    let mut r = vec![0.0; n * n];
    for k in 0..n {
        for i in 0..k {
            let s = dot(&r[i * n..i * n + i], &r[k * n..k * n + i]);
            r[i + k * n] = (a[i + k * n] - s) / r[i + i * n];
        }
        let diag = a[k + k * n] - dot(&r[k * n..k * n + k], &r[k * n..k * n + k]);
        if diag.is_nan() || diag <= 0.0 || diag.is_infinite() {
            return None;
        }
        r[k + k * n] = diag.sqrt();
    }
    Some(r)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dot_matches_naive_sum_on_exact_values() {
        let a: Vec<f64> = (0..7).map(|i| i as f64).collect();
        let b: Vec<f64> = (0..7).map(|i| (i * 2) as f64).collect();
        assert_eq!(dot(&a, &b), (0..7).map(|i| (i * i * 2) as f64).sum::<f64>());
        assert_eq!(dot(&[], &[]), 0.0);
    }

    #[test]
    fn dot_remainder_is_summed_in_descending_order() {
        // 1 + 1e-16 + 1e-16 differs between orders: ascending gives 1, descending
        // (1e-16 + 1e-16 first is not what happens either: the accumulator starts at 0 and
        // adds index 2, 1, 0).
        let a = [1.0, 1e-16, 1e-16];
        let b = [1.0, 1.0, 1.0];
        let expected = ((0.0 + 1e-16) + 1e-16) + 1.0;
        assert_eq!(dot(&a, &b), expected);
    }

    #[test]
    fn four_lane_row_sums_are_bit_identical_to_scalar_sums() {
        for n in [1usize, 2, 3, 4, 5, 8, 11, 25] {
            let v = |k: usize| -> Vec<f64> {
                (0..n)
                    .map(|i| ((i * 7 + k * 13) % 17) as f64 / 3.0 - 2.7 + 1e-9 * i as f64)
                    .collect()
            };
            let a = v(1);
            let cols: Vec<Vec<f64>> = (0..4).map(|j| v(j + 2)).collect();
            // Row k holds one junk value, then the four columns' k-th elements.
            let stride = 6;
            let mut rows = vec![0.0; n * stride];
            for k in 0..n {
                rows[k * stride] = 1e300;
                for t in 0..4 {
                    rows[k * stride + 1 + t] = cols[t][k];
                }
            }
            let in_dot_order: [f64; 4] = sum_rows(&rows, stride, &a, 1, true);
            let ascending: [f64; 4] = sum_rows(&rows, stride, &a, 1, false);
            for t in 0..4 {
                assert_eq!(in_dot_order[t].to_bits(), dot(&cols[t], &a).to_bits());
                let mut q = 0.0;
                for k in 0..n {
                    q += cols[t][k] * a[k];
                }
                assert_eq!(ascending[t].to_bits(), q.to_bits());
            }
        }
    }

    #[test]
    fn cholesky_reconstructs_and_rejects_indefinite() {
        let a = [4.0, 2.0, 0.0, 2.0, 5.0, 1.0, 0.0, 1.0, 3.0];
        let m = cholesky_upper(3, &a).unwrap();
        for i in 0..3 {
            for j in 0..3 {
                let v: f64 = (0..3).map(|k| m[k + i * 3] * m[k + j * 3]).sum();
                assert!((v - a[i + j * 3]).abs() < 1e-12);
            }
            for k in i + 1..3 {
                assert_eq!(m[k + i * 3], 0.0, "lower triangle must be zero");
            }
        }
        assert!(cholesky_upper(2, &[1.0, 2.0, 2.0, 1.0]).is_none());
        assert_eq!(cholesky_upper(1, &[25.0]).unwrap(), vec![5.0]);
    }
}
