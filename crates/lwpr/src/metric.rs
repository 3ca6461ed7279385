//! Distance-metric learning (papers.md §4.4): stochastic gradient descent on the penalised
//! leave-one-out cost
//! `J = 1/Σw · Σ w_i (y_i − ŷ_i)² / (1 − w_i s_iᵀP s_i)² + γ/n · Σ D_ij²`
//! with respect to the upper-triangular (or diagonal) factor `M` of `D = MᵀM`, optionally with
//! IDBD meta learning of the per-element learning rates (Sutton 1992).
//!
//! The arithmetic follows the reference operation by operation so results stay bit-identical.

use crate::linalg::{dot, dot4, seq_dot4};
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
        // sum_aux for four columns at a time (independent chains, each in ascending order).
        let mut c = r;
        while c < n {
            let k = (n - c).min(4);
            let col = |t: usize| &d[(c + t.min(k - 1)) * n + r..(c + t.min(k - 1)) * n + n];
            let sums = seq_dot4([col(0), col(1), col(2), col(3)], mrow);
            ws.sum_aux[c..c + k].copy_from_slice(&sums[..k]);
            c += k;
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
        for c in r..n {
            let sum_aux = ws.sum_aux[c];
            let off = r + c * n;
            let dqdm = dq * (2.0 * dx[c]);
            ws.dwdm[off] = dqdm * dwdq;
            ws.dj2dm[off] = 2.0 * penalty * sum_aux;
            if meta {
                let sum_aux1 = ws.sum_aux1[c];
                ws.ddwdmdm[off] = ddwdqdq * dqdm * dqdm + 2.0 * dwdq * dx[c] * dx[c];
                ws.ddj2dmdm[off] = 2.0 * penalty * (d[c + c * n] + sum_aux1);
            }
        }
    }
}

/// One IDBD step on element `off` (log rate `b`, rate `alpha`, trace `h`).
#[inline(always)]
fn idbd(
    rf: &mut ReceptiveField,
    off: usize,
    djdm: f64,
    ddjdmdm: f64,
    meta_rate: f64,
    trans_mul: f64,
) {
    let aux = (meta_rate * trans_mul * djdm * rf.h[off]).clamp(-0.1, 0.1);
    let b = (rf.b[off] - aux).clamp(-10.0, 10.0);
    rf.b[off] = b;
    let alpha = b.exp();
    rf.alpha[off] = alpha;
    let mut aux = 1.0 - alpha * ddjdmdm * trans_mul;
    if aux < 0.0 {
        aux = 0.0;
    }
    rf.h[off] = rf.h[off] * aux - alpha * trans_mul * djdm;
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
    w: f64,
    dwdq: f64,
    ddwdqdq: f64,
    e_cv: f64,
    e: f64,
    xn: &[f64],
    ws: &mut Workspace,
) -> f64 {
    let nr = rf.n_reg;
    let penalty = p.penalty / n as f64;
    for i in 0..nr {
        ws.deriv_ok[i] = rf.n_data[i] * (1.0 - rf.lambda[0]) > 0.1;
    }
    if !ws.deriv_ok[0] {
        return 0.0;
    }
    let e2 = e * e;
    let e_cv2 = e_cv * e_cv;
    let mut h = 0.0;
    for i in 0..nr {
        if ws.deriv_ok[i] {
            h += rf.s[i] * rf.s[i] / rf.ss_s2[i];
        }
    }
    h *= w;
    let big_w = rf.sum_w[0];
    let big_e = if nr == 1 {
        rf.sum_e_cv2[0]
    } else if rf.n_data[nr - 1] > (2 * n) as f64 {
        rf.sum_e_cv2[nr - 1]
    } else {
        rf.sum_e_cv2[nr - 2]
    };
    let mut trans_mul = rf.sum_e2 / (big_e + 1e-10);
    trans_mul *= trans_mul;
    trans_mul *= trans_mul;
    if trans_mul > 1.0 {
        trans_mul = 1.0;
    }
    let mut dj1dw = -big_e / big_w + e_cv2;
    for i in 0..nr {
        if ws.deriv_ok[i] {
            let ps = rf.s[i] / rf.ss_s2[i];
            let pse = e * ps;
            ws.ps[i] = ps;
            ws.pse[i] = pse;
            dj1dw -= 2.0 * pse * rf.tr_h[i] + 2.0 * ps * ps * rf.tr_r[i];
        } else {
            ws.ps[i] = 0.0;
            ws.pse[i] = 0.0;
        }
    }
    dj1dw /= big_w;
    let w_w = w / big_w;
    for i in 0..n {
        ws.dx[i] = xn[i] - rf.c[i];
    }
    dist_derivatives(
        n,
        ws,
        dwdq,
        ddwdqdq,
        &rf.d,
        &rf.m,
        p.diag_only,
        penalty,
        p.meta,
    );

    let ddj1dwdw = if p.meta {
        let mut s_pse = 0.0;
        for i in 0..nr {
            s_pse += rf.s[i] * ws.pse[i];
        }
        let mut v = 2.0 * (e2 * h / w - e_cv2 / big_w) + big_e / (big_w * big_w);
        for i in 0..nr {
            v += 4.0 * (ws.pse[i] / big_w + ws.ps[i] * s_pse) * rf.tr_h[i];
        }
        v / big_w
    } else {
        0.0
    };

    if p.diag_only {
        let mut max_m: f64 = 0.0;
        for j in 0..n {
            let v = rf.m[j + j * n].abs();
            if v > max_m {
                max_m = v;
            }
        }
        for j in 0..n {
            let off = j + j * n;
            ws.dj2dm[off] = w_w * ws.dj2dm[off] + ws.dwdm[off] * dj1dw;
        }
        if p.meta {
            for j in 0..n {
                let off = j + j * n;
                let dd = w_w * ws.ddj2dmdm[off]
                    + ws.ddwdmdm[off] * dj1dw
                    + ws.dwdm[off] * ws.dwdm[off] * ddj1dwdw;
                idbd(rf, off, ws.dj2dm[off], dd, p.meta_rate, trans_mul);
            }
        }
        for j in 0..n {
            let off = j + j * n;
            let delta = rf.alpha[off] * trans_mul * ws.dj2dm[off];
            if delta > 0.1 * max_m {
                rf.alpha[off] *= 0.5;
            } else {
                rf.m[off] -= delta;
            }
        }
        for j in 0..n {
            rf.d[j + j * n] = rf.m[j + j * n] * rf.m[j + j * n];
        }
    } else {
        let mut max_m: f64 = 0.0;
        for j in 0..n {
            for i in 0..=j {
                let v = rf.m[i + j * n].abs();
                if v > max_m {
                    max_m = v;
                }
            }
        }
        for j in 0..n {
            for i in 0..=j {
                let off = i + j * n;
                ws.dj2dm[off] = w_w * ws.dj2dm[off] + dj1dw * ws.dwdm[off];
            }
        }
        if p.meta {
            for j in 0..n {
                for i in 0..=j {
                    let off = i + j * n;
                    let dwdm = ws.dwdm[off];
                    let dd =
                        w_w * ws.ddj2dmdm[off] + ws.ddwdmdm[off] * dj1dw + dwdm * dwdm * ddj1dwdw;
                    idbd(rf, off, ws.dj2dm[off], dd, p.meta_rate, trans_mul);
                }
            }
        }
        for j in 0..n {
            for i in 0..=j {
                let off = i + j * n;
                let delta = rf.alpha[off] * trans_mul * ws.dj2dm[off];
                if delta > 0.1 * max_m {
                    rf.alpha[off] *= 0.5;
                } else {
                    rf.m[off] -= delta;
                }
            }
        }
        for j in 0..n {
            for i in 0..j {
                rf.d[i + j * n] = rf.d[j + i * n];
            }
            let mj = &rf.m[j * n..j * n + j + 1];
            let mut i = j;
            while i + 4 <= n {
                let col = |k: usize| &rf.m[k * n..k * n + j + 1];
                let s = dot4([col(i), col(i + 1), col(i + 2), col(i + 3)], mj);
                rf.d[i + j * n..i + j * n + 4].copy_from_slice(&s);
                i += 4;
            }
            for i in i..n {
                rf.d[i + j * n] = dot(&rf.m[i * n..i * n + j + 1], mj);
            }
        }
    }

    for i in 0..nr {
        if ws.deriv_ok[i] {
            let lam = rf.lambda[i];
            rf.tr_h[i] = lam * rf.tr_h[i] + (w / (1.0 - h)) * rf.s[i] * e_cv * trans_mul;
            rf.tr_r[i] =
                lam * rf.tr_r[i] + (w * w * e_cv2 / (1.0 - h)) * rf.s[i] * rf.s[i] * trans_mul;
        }
    }
    trans_mul
}
