//! Distance-metric learning (docs/methods.md § LWPR): stochastic gradient descent on the penalised
//! leave-one-out cost
//! `J = 1/Σw · Σ w_i (y_i − ŷ_i)² / (1 − w_i s_iᵀP s_i)² + γ/n · Σ D_ij²`
//! with respect to the upper-triangular (or diagonal) factor `M` of `D = MᵀM`, optionally with
//! IDBD meta learning of the per-element learning rates (Sutton 1992).
//!
//! The arithmetic follows the reference operation by operation so results stay bit-identical.

use crate::fast::StepScalars;
use crate::linalg::{dot, lane_blocks, sum_rows};
use crate::params::Params;
use crate::rf::ReceptiveField;
use crate::workspace::Workspace;

/// First (and for meta learning second) derivatives of the activation `w` and of the penalty
/// `J₂ = γ' Σ D_ij²` with respect to the elements of `M` on the upper triangle (or diagonal).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn dist_derivatives(
    n: usize,
    ws: &mut Workspace,
    dwdq: f64,
    ddwdqdq: f64,
    d: &[f64],
    m: &[f64],
    diag_only: bool,
    penalty: f64,
    meta: bool,
) {
    let penalty = penalty + penalty;
    let dx = &ws.dx[..n];
    if diag_only {
        for k in 0..n {
            let kk = k + k * n;
            let aux = 2.0 * m[kk];
            let dqdm = dx[k] * dx[k] * aux;
            ws.dwdm[kk] = dqdm * dwdq;
            ws.dj2dm[kk] = penalty * d[kk] * aux;
            if meta {
                ws.ddwdmdm[kk] = ddwdqdq * dqdm * dqdm + 2.0 * dwdq * dx[k] * dx[k];
                ws.ddj2dmdm[kk] = penalty * (2.0 * d[kk] + aux * aux);
            }
        }
        return;
    }
    // Row r of M (elements r..n) is copied into a contiguous buffer, and the reference's
    // `dqdM` sum, which does not depend on the column, is computed once per row; every sum is
    // still accumulated in the reference's order, so the results are bit-identical.
    for r in 0..n {
        let mrow = &mut ws.mrow[..n - r];
        for (i, v) in mrow.iter_mut().enumerate() {
            *v = m[r + (r + i) * n];
        }
        let mut dq = 0.0;
        for (x, mv) in dx[r..].iter().zip(mrow.iter()) {
            dq += x * mv;
        }
        let mrow = &ws.mrow[..n - r];
        // sum_aux_c = Σ_{i≥r} D_ic M_ri (ascending i) for eight or four columns at a time: D
        // is exactly symmetric, so D_ic..D_i(c+7) is a contiguous piece of column i.
        let (wide, four) = lane_blocks(r, n);
        for c in (r..wide).step_by(8) {
            let acc: [f64; 8] = sum_rows(&d[r * n..n * n], n, mrow, c, false);
            ws.sum_aux[c..c + 8].copy_from_slice(&acc);
        }
        if four > wide {
            let acc: [f64; 4] = sum_rows(&d[r * n..n * n], n, mrow, wide, false);
            ws.sum_aux[wide..four].copy_from_slice(&acc);
        }
        // The last one to three columns: one more four-lane block ending at column n − 1 (its
        // overlap with the block before recomputes identical values).
        let c = if four < n && n - r >= 4 {
            let acc: [f64; 4] = sum_rows(&d[r * n..n * n], n, mrow, n - 4, false);
            ws.sum_aux[n - 4..n].copy_from_slice(&acc);
            n
        } else {
            four
        };
        for c in c..n {
            let mut acc = 0.0;
            for (i, &mv) in mrow.iter().enumerate() {
                acc += d[(r + i) * n + c] * mv;
            }
            ws.sum_aux[c] = acc;
        }
        if meta {
            // Σ_i M_ri² with the term i = c doubled, per column c. The reference sums from
            // i = r upwards, so all columns share the prefix sums; the suffixes are independent
            // chains, run four at a time.
            let len = n - r;
            let prefix = &mut ws.prefix[..=len];
            prefix[0] = 0.0;
            for (i, mv) in mrow.iter().enumerate() {
                prefix[i + 1] = prefix[i] + mv * mv;
            }
            let mut k0 = 0;
            while k0 < len {
                let g = (len - k0).min(4);
                let mut s = [0.0; 4];
                for t in 0..g {
                    let k = k0 + t;
                    s[t] = prefix[k] + 2.0 * mrow[k] * mrow[k];
                }
                // Columns k0..k0+g: the first suffix terms are only owed by the earlier
                // columns of the group.
                let head_end = (k0 + g).min(len);
                for i in k0 + 1..head_end {
                    let sq = mrow[i] * mrow[i];
                    for t in 0..i - k0 {
                        s[t] += sq;
                    }
                }
                // Past the group every chain takes every term (unused chains are ignored).
                for &mv in &mrow[head_end..] {
                    let sq = mv * mv;
                    for v in s.iter_mut() {
                        *v += sq;
                    }
                }
                ws.sum_aux1[r + k0..r + k0 + g].copy_from_slice(&s[..g]);
                k0 += g;
            }
        }
        // The penalty derivatives per element; the activation derivatives
        // `∂w/∂M_rc = dq_r · 2 dx_c · ∂w/∂q` (and the second ones) follow from `dq_r` where
        // they are used (`update_distance_metric`).
        ws.dq[r] = dq;
        for c in r..n {
            let off = r + c * n;
            ws.dj2dm[off] = 2.0 * penalty * ws.sum_aux[c];
            if meta {
                ws.ddj2dmdm[off] = 2.0 * penalty * (d[c + c * n] + ws.sum_aux1[c]);
            }
        }
    }
}

/// `max |M_ij|` of the `n × n` column-major factor `M` (its diagonal with `diag_only`, else
/// its upper triangle, rows `0..=j` of column `j` being contiguous): `0.1·max` limits the step
/// of every element in both arithmetics.
#[inline(always)]
fn max_abs_m(n: usize, m: &[f64], diag_only: bool) -> f64 {
    let mut max_m: f64 = 0.0;
    for j in 0..n {
        let rows = if diag_only { j..j + 1 } else { 0..j + 1 };
        for &v in &m[j * n + rows.start..j * n + rows.end] {
            let v = v.abs();
            if v > max_m {
                max_m = v;
            }
        }
    }
    max_m
}

/// One IDBD step on one element (log rate `b`, rate `alpha`, trace `h`).
#[inline(always)]
fn idbd(
    b: &mut f64,
    alpha: &mut f64,
    h: &mut f64,
    djdm: f64,
    ddjdmdm: f64,
    meta_rate: f64,
    trans_mul: f64,
) {
    let aux = (meta_rate * trans_mul * djdm * *h).clamp(-0.1, 0.1);
    let bv = (*b - aux).clamp(-10.0, 10.0);
    *b = bv;
    let a = bv.exp();
    *alpha = a;
    let mut aux = 1.0 - a * ddjdmdm * trans_mul;
    if aux < 0.0 {
        aux = 0.0;
    }
    *h = *h * aux - a * trans_mul * djdm;
}

/// Updates `M`, `D` (and with meta learning the rates) of an active field after its regression
/// update. `e_cv` is the CV residual, `e` the training residual, `xn` the normalised input.
/// Returns the transient multiplier (0 if the field is still too young).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn update_distance_metric(
    n: usize,
    rf: &mut ReceptiveField,
    p: &Params,
    (w, dwdq, ddwdqdq): (f64, f64, f64),
    e_cv: f64,
    e: f64,
    xn: &[f64],
    ws: &mut Workspace,
    fast: bool,
) -> f64 {
    let nr = rf.n_reg;
    // Arrays sliced once to their exact lengths (no bounds checks in the loops below).
    let (s, ss_s2) = (&rf.s[..nr], &rf.ss_s2[..nr]);
    let (tr_h, tr_r) = (&rf.tr_h[..nr], &rf.tr_r[..nr]);
    let (n_data, lambda, sum_e_cv2) = (&rf.n_data[..nr], &rf.lambda[..nr], &rf.sum_e_cv2[..nr]);
    let (deriv_ok, ps, pse) = (&mut ws.deriv_ok[..nr], &mut ws.ps[..nr], &mut ws.pse[..nr]);
    for i in 0..nr {
        deriv_ok[i] = n_data[i] * (1.0 - lambda[0]) > 0.1;
    }
    if !deriv_ok[0] {
        return 0.0;
    }
    let e2 = e * e;
    let e_cv2 = e_cv * e_cv;
    let mut h = 0.0;
    for i in 0..nr {
        if deriv_ok[i] {
            h += s[i] * s[i] / ss_s2[i];
        }
    }
    h *= w;
    let big_w = rf.sum_w[0];
    let big_e = if nr == 1 {
        sum_e_cv2[0]
    } else if n_data[nr - 1] > (2 * n) as f64 {
        sum_e_cv2[nr - 1]
    } else {
        sum_e_cv2[nr - 2]
    };
    let mut trans_mul = rf.sum_e2 / (big_e + 1e-10);
    trans_mul *= trans_mul;
    trans_mul *= trans_mul;
    if trans_mul > 1.0 {
        trans_mul = 1.0;
    }
    let mut dj1dw = -big_e / big_w + e_cv2;
    for i in 0..nr {
        if deriv_ok[i] {
            let psi = s[i] / ss_s2[i];
            let psei = e * psi;
            ps[i] = psi;
            pse[i] = psei;
            dj1dw -= 2.0 * psei * tr_h[i] + 2.0 * psi * psi * tr_r[i];
        } else {
            ps[i] = 0.0;
            pse[i] = 0.0;
        }
    }
    dj1dw /= big_w;
    let w_w = w / big_w;
    let (dx, c) = (&mut ws.dx[..n], &rf.c[..n]);
    for i in 0..n {
        dx[i] = xn[i] - c[i];
    }
    let ddj1dwdw = if p.meta {
        let mut s_pse = 0.0;
        for i in 0..nr {
            s_pse += s[i] * pse[i];
        }
        let mut v = 2.0 * (e2 * h / w - e_cv2 / big_w) + big_e / (big_w * big_w);
        for i in 0..nr {
            v += 4.0 * (pse[i] / big_w + ps[i] * s_pse) * tr_h[i];
        }
        v / big_w
    } else {
        0.0
    };
    let k = StepScalars {
        w_w,
        dj1dw,
        ddj1dwdw,
        dwdq,
        ddwdqdq,
        meta_rate: p.meta_rate,
        trans_mul,
        // From the old M: every element's step is limited by the same bound.
        limit: 0.1 * max_abs_m(n, &rf.m[..n * n], p.diag_only),
    };
    if fast {
        fast_metric_step(n, rf, p, ws, &k);
    } else {
        reference_metric_step(n, rf, p, ws, &k);
    }
    let (s, lambda) = (&rf.s[..nr], &rf.lambda[..nr]);
    let (tr_h, tr_r) = (&mut rf.tr_h[..nr], &mut rf.tr_r[..nr]);
    let deriv_ok = &ws.deriv_ok[..nr];
    for i in 0..nr {
        if deriv_ok[i] {
            let lam = lambda[i];
            tr_h[i] = lam * tr_h[i] + (w / (1.0 - h)) * s[i] * e_cv * trans_mul;
            tr_r[i] = lam * tr_r[i] + (w * w * e_cv2 / (1.0 - h)) * s[i] * s[i] * trans_mul;
        }
    }
    trans_mul
}

/// The metric step in the reference's order of operations (bit-identical to the C library).
#[inline(always)]
fn reference_metric_step(
    n: usize,
    rf: &mut ReceptiveField,
    p: &Params,
    ws: &mut Workspace,
    k: &StepScalars,
) {
    let &StepScalars {
        w_w,
        dj1dw,
        ddj1dwdw,
        dwdq,
        ddwdqdq,
        trans_mul,
        limit,
        ..
    } = k;
    let nn = n * n;
    dist_derivatives(
        n,
        ws,
        dwdq,
        ddwdqdq,
        &rf.d,
        &rf.m,
        p.diag_only,
        p.penalty / n as f64,
        p.meta,
    );

    let (m, d) = (&mut rf.m[..nn], &mut rf.d[..nn]);
    let (alpha, b, hh) = (&mut rf.alpha[..nn], &mut rf.b[..nn], &mut rf.h[..nn]);
    let (dj2dm, dwdm) = (&mut ws.dj2dm[..nn], &ws.dwdm[..nn]);
    let (ddj2dmdm, ddwdmdm) = (&ws.ddj2dmdm[..nn], &ws.ddwdmdm[..nn]);
    if p.diag_only {
        for j in 0..n {
            let off = j + j * n;
            dj2dm[off] = w_w * dj2dm[off] + dwdm[off] * dj1dw;
        }
        if p.meta {
            for j in 0..n {
                let off = j + j * n;
                let dd =
                    w_w * ddj2dmdm[off] + ddwdmdm[off] * dj1dw + dwdm[off] * dwdm[off] * ddj1dwdw;
                idbd(
                    &mut b[off],
                    &mut alpha[off],
                    &mut hh[off],
                    dj2dm[off],
                    dd,
                    p.meta_rate,
                    trans_mul,
                );
            }
        }
        for j in 0..n {
            let off = j + j * n;
            let delta = alpha[off] * trans_mul * dj2dm[off];
            if delta > limit {
                alpha[off] *= 0.5;
            } else {
                m[off] -= delta;
            }
        }
        for j in 0..n {
            d[j + j * n] = m[j + j * n] * m[j + j * n];
        }
    } else {
        // Gradient, IDBD step and M step per element in one pass (each element's operations
        // in the reference's order; the elements are independent, and `limit` is taken from
        // the old M above).
        let meta = p.meta;
        let dq = &ws.dq[..n];
        let dx = &ws.dx[..n];
        for j in 0..n {
            let col = j * n..j * n + j + 1;
            let (g, ddj2) = (&mut dj2dm[col.clone()], &ddj2dmdm[col.clone()]);
            let (bc, ac) = (&mut b[col.clone()], &mut alpha[col.clone()]);
            let (hc, mc) = (&mut hh[col.clone()], &mut m[col]);
            let dxj2 = 2.0 * dx[j];
            for i in 0..=j {
                let dqdm = dq[i] * dxj2;
                let dw = dqdm * dwdq;
                let gi = w_w * g[i] + dj1dw * dw;
                g[i] = gi;
                if meta {
                    let ddw = ddwdqdq * dqdm * dqdm + 2.0 * dwdq * dx[j] * dx[j];
                    let dd = w_w * ddj2[i] + ddw * dj1dw + dw * dw * ddj1dwdw;
                    idbd(
                        &mut bc[i],
                        &mut ac[i],
                        &mut hc[i],
                        gi,
                        dd,
                        p.meta_rate,
                        trans_mul,
                    );
                }
                let delta = ac[i] * trans_mul * gi;
                if delta > limit {
                    ac[i] *= 0.5;
                } else {
                    mc[i] -= delta;
                }
            }
        }
        // D = MᵀM: D_ij (i ≥ j) is `dot(M_:i, M_:j)`, eight or four rows i at a time from the
        // rows of M (copied transposed, so M_k,i..M_k,i+7 are contiguous), in `dot`'s order.
        let mt = &mut ws.mt[..nn];
        for i in 0..n {
            for (row, &v) in mt.chunks_exact_mut(n).zip(&m[i * n..i * n + i + 1]) {
                row[i] = v;
            }
        }
        for j in 0..n {
            let (done, col) = d.split_at_mut(j * n);
            for (dv, row) in col[..j].iter_mut().zip(done.chunks_exact(n)) {
                *dv = row[j];
            }
            let mj = &m[j * n..j * n + j + 1];
            let (wide, four) = lane_blocks(j, n);
            for i in (j..wide).step_by(8) {
                let acc: [f64; 8] = sum_rows(mt, n, mj, i, true);
                d[i + j * n..i + j * n + 8].copy_from_slice(&acc);
            }
            if four > wide {
                let acc: [f64; 4] = sum_rows(mt, n, mj, wide, true);
                d[wide + j * n..four + j * n].copy_from_slice(&acc);
            }
            let i = if four < n && n - j >= 4 {
                let acc: [f64; 4] = sum_rows(mt, n, mj, n - 4, true);
                d[n - 4 + j * n..n + j * n].copy_from_slice(&acc);
                n
            } else {
                four
            };
            for i in i..n {
                d[i + j * n] = dot(&m[i * n..i * n + j + 1], mj);
            }
        }
    }
}

/// The metric step of [`crate::Arithmetic::Fast`] (full metric, `n ≥ 5`); `ws.dq` holds
/// `M(x−c)` from the activation ([`crate::fast::distance_m`]), `ws.dx` holds `x − c`.
#[inline(always)]
fn fast_metric_step(
    n: usize,
    rf: &mut ReceptiveField,
    p: &Params,
    ws: &mut Workspace,
    k: &StepScalars,
) {
    let penalty = p.penalty / n as f64;
    // The reference doubles the penalty inside its derivative routine.
    crate::fast::penalty_derivatives(
        n,
        &rf.m,
        &rf.d,
        penalty + penalty,
        p.meta,
        &mut ws.sum_aux1,
        &mut ws.dj2dm,
        &mut ws.ddj2dmdm,
    );
    let (dq, dx, g, ddj2) = (&ws.dq, &ws.dx, &mut ws.dj2dm, &ws.ddj2dmdm);
    let (b, alpha, h, m) = (&mut rf.b, &mut rf.alpha, &mut rf.h, &mut rf.m);
    if p.meta {
        crate::fast::metric_step::<true>(n, k, dq, dx, g, ddj2, b, alpha, h, m);
    } else {
        crate::fast::metric_step::<false>(n, k, dq, dx, g, ddj2, b, alpha, h, m);
    }
    crate::fast::gram(n, &rf.m, &mut ws.mt, &mut rf.d);
}
