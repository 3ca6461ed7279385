//! One receptive field: a locally weighted linear model fitted by incremental PLS
//! (docs/methods.md § LWPR). Matrices are column-major; `n` is the input dimension, `R` the
//! number of PLS directions (`1 ≤ R ≤ n`).

use serde::{Deserialize, Serialize};

use crate::linalg::{dot, lane_blocks, sum_rows};
use crate::params::{Kernel, Params};
use crate::workspace::Workspace;

/// Activation at which a receptive field takes part in an update (hard-coded in the reference).
pub(crate) const UPDATE_ACTIVATION: f64 = 0.001;

/// A receptive field. Public read access goes through [`crate::RfView`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct ReceptiveField {
    pub n_reg: usize,
    pub trustworthy: bool,
    /// Activation of the last update (0 if the field was not active).
    pub w: f64,
    /// Accumulated (non-CV) training error.
    pub sum_e2: f64,
    pub beta0: f64,
    /// Statistics of the confidence bounds.
    pub ssp: f64,
    /// Distance metric `D = MᵀM` (`n × n`).
    pub d: Vec<f64>,
    /// Upper-triangular factor of `D`.
    pub m: Vec<f64>,
    /// Learning rates of `M`.
    pub alpha: Vec<f64>,
    /// Log learning rates (meta learning).
    pub b: Vec<f64>,
    /// IDBD memory trace (meta learning).
    pub h: Vec<f64>,
    /// Centre.
    pub c: Vec<f64>,
    /// Weighted input mean.
    pub mean_x: Vec<f64>,
    /// Weighted input variance.
    pub var_x: Vec<f64>,
    /// PLS statistics `SXresYres` (`n × R`).
    pub sxy: Vec<f64>,
    /// PLS statistics `SSXres` (`n × R`).
    pub ssx: Vec<f64>,
    /// PLS projection directions (`n × R`).
    pub u: Vec<f64>,
    /// PLS input reductions (`n × R`).
    pub p: Vec<f64>,
    pub beta: Vec<f64>,
    pub ss_s2: Vec<f64>,
    pub ss_y: Vec<f64>,
    /// CV-gradient memory traces `H_r`.
    pub tr_h: Vec<f64>,
    /// CV-gradient memory traces `r_r`.
    pub tr_r: Vec<f64>,
    pub sum_w: Vec<f64>,
    pub sum_e_cv2: Vec<f64>,
    pub n_data: Vec<f64>,
    pub lambda: Vec<f64>,
    /// Latest projections `s_r`.
    pub s: Vec<f64>,
    /// Cached gradient of the local prediction with respect to `x − x̄` (derived data, rebuilt
    /// after every change and after loading).
    #[serde(skip)]
    pub slope: Vec<f64>,
}

/// [`distance`] for a diagonal metric with `x − c` formed on the fly (the same bits as
/// `distance(d, x − c, true)`); `d` is the full `n × n` metric, `n = c.len()`.
#[inline(always)]
pub(crate) fn diag_distance(d: &[f64], x: &[f64], c: &[f64]) -> f64 {
    let n = c.len();
    let (d, x) = (&d[..n * n], &x[..n]);
    let mut dist = 0.0;
    for j in 0..n {
        let z = x[j] - c[j];
        dist += z * (d[j + j * n] * z);
    }
    dist
}

/// Squared Mahalanobis distance `(x−c)ᵀD(x−c)` in the reference's summation order.
#[inline(always)]
pub(crate) fn distance(d: &[f64], xc: &[f64], diag_only: bool) -> f64 {
    let n = xc.len();
    let mut dist = 0.0;
    if diag_only {
        // Off-diagonal elements are exactly zero, so the reference's column dot products reduce
        // to D_jj·xc_j without any rounding difference.
        for j in 0..n {
            dist += xc[j] * (d[j + j * n] * xc[j]);
        }
    } else {
        // The column dot products `D_:jᵀ xc` are independent: eight or four at a time, each
        // in the reference's order (D is exactly symmetric, so D_kj..D_k(j+7) is a contiguous
        // piece of column k), then accumulated in the reference's order.
        let (wide, four) = lane_blocks(0, n);
        for j in (0..wide).step_by(8) {
            let s: [f64; 8] = sum_rows(&d[..n * n], n, xc, j, true);
            for t in 0..8 {
                dist += xc[j + t] * s[t];
            }
        }
        if four > wide {
            let s: [f64; 4] = sum_rows(&d[..n * n], n, xc, wide, true);
            for t in 0..4 {
                dist += xc[wide + t] * s[t];
            }
        }
        let j = if four < n && n >= 4 {
            let s: [f64; 4] = sum_rows(&d[..n * n], n, xc, n - 4, true);
            for j in four..n {
                dist += xc[j] * s[j + 4 - n];
            }
            n
        } else {
            four
        };
        for j in j..n {
            dist += xc[j] * dot(&d[j * n..j * n + n], xc);
        }
    }
    dist
}

/// `(w, ∂w/∂q, ∂²w/∂q²)` for squared distance `q`.
#[inline(always)]
pub(crate) fn kernel_eval(kernel: Kernel, q: f64) -> (f64, f64, f64) {
    match kernel {
        Kernel::Gaussian => {
            let w = (-0.5 * q).exp();
            (w, -0.5 * w, 0.25 * w)
        }
        Kernel::BiSquare => {
            let a = 1.0 - 0.25 * q;
            if a < 0.0 {
                (0.0, 0.0, 0.0)
            } else {
                (a * a, -0.5 * a, 0.125)
            }
        }
    }
}

impl ReceptiveField {
    /// A new field centred at `xc` (normalised input) for normalised output `y`; with a
    /// template its metric, learning rates, offset and PLS dimension are copied.
    pub(crate) fn new(p: &Params, template: Option<&ReceptiveField>, xc: &[f64], y: f64) -> Self {
        let n = p.n_in;
        let (n_reg, d, m, alpha, beta0) = match template {
            None => (
                if n > 1 { 2 } else { 1 },
                p.init_d.clone(),
                p.init_m.clone(),
                p.init_alpha.clone(),
                y,
            ),
            Some(t) => (t.n_reg, t.d.clone(), t.m.clone(), t.alpha.clone(), t.beta0),
        };
        let mut b = vec![0.0; n * n];
        for j in 0..n {
            for i in 0..=j {
                b[i + j * n] = (alpha[i + j * n] + 1e-10).ln();
            }
        }
        let cap_nr = n * n;
        let mut rf = ReceptiveField {
            n_reg,
            trustworthy: false,
            w: 0.0,
            sum_e2: 0.0,
            beta0,
            ssp: 0.0,
            d,
            m,
            alpha,
            b,
            h: vec![0.0; n * n],
            c: xc.to_vec(),
            mean_x: vec![0.0; n],
            var_x: vec![0.0; n],
            sxy: Vec::with_capacity(cap_nr),
            ssx: Vec::with_capacity(cap_nr),
            u: Vec::with_capacity(cap_nr),
            p: Vec::with_capacity(cap_nr),
            beta: Vec::with_capacity(n),
            ss_s2: Vec::with_capacity(n),
            ss_y: Vec::with_capacity(n),
            tr_h: Vec::with_capacity(n),
            tr_r: Vec::with_capacity(n),
            sum_w: Vec::with_capacity(n),
            sum_e_cv2: Vec::with_capacity(n),
            n_data: Vec::with_capacity(n),
            lambda: Vec::with_capacity(n),
            s: Vec::with_capacity(n),
            slope: vec![0.0; n],
        };
        for r in 0..n_reg {
            rf.push_direction(n, r, p.init_s2, 1e-10, p.init_lambda);
        }
        rf
    }

    /// Appends PLS direction `r` (unit vector `e_r` for `u` and `p`).
    fn push_direction(&mut self, n: usize, r: usize, init_s2: f64, n_data: f64, lambda: f64) {
        let base = self.u.len();
        for v in [&mut self.sxy, &mut self.ssx, &mut self.u, &mut self.p] {
            v.resize(base + n, 0.0);
        }
        self.u[base + r] = 1.0;
        self.p[base + r] = 1.0;
        self.beta.push(0.0);
        self.ss_s2.push(init_s2);
        self.ss_y.push(0.0);
        self.tr_h.push(0.0);
        self.tr_r.push(0.0);
        self.sum_w.push(1e-10);
        self.sum_e_cv2.push(0.0);
        self.n_data.push(n_data);
        self.lambda.push(lambda);
        self.s.push(0.0);
    }

    /// Number of PLS directions used for prediction (the last one is skipped while its data
    /// count is at most `2n`).
    #[inline(always)]
    pub(crate) fn n_reg_pred(&self, n: usize) -> usize {
        let nr = self.n_reg;
        if self.n_data[nr - 1] <= (2 * n) as f64 {
            nr - 1
        } else {
            nr
        }
    }

    /// Weighted means with forgetting (§4.3 a); writes `x − x̄` to `xmz`, returns `y − β₀`.
    #[inline(always)]
    pub(crate) fn update_means(&mut self, x: &[f64], y: f64, w: f64, xmz: &mut [f64]) -> f64 {
        let swl = self.sum_w[0] * self.lambda[0];
        let inv_fac = 1.0 / (swl + w);
        let n = x.len();
        let (mean_x, var_x, xmz) = (&mut self.mean_x[..n], &mut self.var_x[..n], &mut xmz[..n]);
        for i in 0..n {
            let mx = (swl * mean_x[i] + w * x[i]) * inv_fac;
            mean_x[i] = mx;
            let z = x[i] - mx;
            xmz[i] = z;
            var_x[i] = (swl * var_x[i] + w * z * z) * inv_fac;
        }
        self.beta0 = (swl * self.beta0 + w * y) * inv_fac;
        y - self.beta0
    }

    /// Projections `s` of `x` with deflation, in place in `xu` (§4.2).
    #[inline(always)]
    fn project(
        n: usize,
        nr: usize,
        s: &mut [f64],
        x: &[f64],
        u: &[f64],
        p: &[f64],
        xu: &mut [f64],
    ) {
        let xu = &mut xu[..n];
        xu.copy_from_slice(&x[..n]);
        for j in 0..nr {
            let sj = dot(&u[j * n..j * n + n], xu);
            s[j] = sj;
            if j + 1 < nr {
                let pj = &p[j * n..j * n + n];
                for i in 0..n {
                    xu[i] += -sj * pj[i];
                }
            }
        }
    }

    /// Incremental PLS step (§4.3 b–f). `x` is `x − x̄`, `y` is `y − β₀`.
    /// Returns `(ŷ_k, e_cv_R, e)`.
    #[inline(always)]
    pub(crate) fn update_regression(
        &mut self,
        n: usize,
        x: &[f64],
        y: f64,
        w: f64,
        ws: &mut Workspace,
    ) -> (f64, f64, f64) {
        let nr = self.n_reg;
        let nrn = nr * n;
        // Every array sliced once to its exact length: the loops below then need no bounds
        // checks and no reloading of the vectors' headers after each store.
        let x = &x[..n];
        let (u, p) = (&mut self.u[..nrn], &mut self.p[..nrn]);
        let (sxy, ssx) = (&mut self.sxy[..nrn], &mut self.ssx[..nrn]);
        let s = &mut self.s[..nr];
        let beta = &mut self.beta[..nr];
        let lambda = &self.lambda[..nr];
        let sum_w = &mut self.sum_w[..nr];
        let ss_s2 = &mut self.ss_s2[..nr];
        let ss_y = &mut self.ss_y[..nr];
        let n_data = &self.n_data[..nr];
        let sum_e_cv2 = &mut self.sum_e_cv2[..nr];
        // Projections with the old U, P, keeping every residual input.
        let xres = &mut ws.xres[..nrn];
        xres[..n].copy_from_slice(x);
        for j in 0..nr {
            let (done, rest) = xres.split_at_mut((j + 1) * n);
            let xj = &done[j * n..];
            let sj = dot(&u[j * n..j * n + n], xj);
            s[j] = sj;
            if j + 1 < nr {
                let (next, pj) = (&mut rest[..n], &p[j * n..j * n + n]);
                for i in 0..n {
                    next[i] = xj[i] - pj[i] * sj;
                }
            }
        }
        let xres = &ws.xres[..nrn];
        let (yres, e_cv, ytarget) = (
            &mut ws.yres[..nr],
            &mut ws.e_cv[..nr],
            &mut ws.ytarget[..nr],
        );
        yres[0] = beta[0] * s[0];
        for i in 1..nr {
            yres[i] = beta[i] * s[i] + yres[i - 1];
        }
        for i in 0..nr {
            sum_w[i] = sum_w[i] * lambda[i] + w;
            e_cv[i] = y - yres[i];
        }
        ytarget[0] = y;
        ytarget[1..].copy_from_slice(&e_cv[..nr - 1]);
        let mut ws2_ss_s2 = 0.0;
        for j in 0..nr {
            let jn = j * n;
            let (sxy_j, u_j) = (&mut sxy[jn..jn + n], &mut u[jn..jn + n]);
            let (ssx_j, p_j) = (&mut ssx[jn..jn + n], &mut p[jn..jn + n]);
            let xres_j = &xres[jn..jn + n];
            let lam = lambda[j];
            let lambda_slow = 0.9 + 0.1 * lam;
            let wytar = w * ytarget[j];
            let wsj = w * s[j];
            let mut unorm = 0.0;
            for i in 0..n {
                let v = sxy_j[i] * lambda_slow + wytar * xres_j[i];
                sxy_j[i] = v;
                unorm += v * v;
            }
            if unorm > 1e-24 {
                let inv = 1.0 / unorm.sqrt();
                for i in 0..n {
                    u_j[i] = inv * sxy_j[i];
                }
            }
            ss_s2[j] = lam * ss_s2[j] + s[j] * wsj;
            ss_y[j] = lam * ss_y[j] + ytarget[j] * wsj;
            for i in 0..n {
                ssx_j[i] = lam * ssx_j[i] + wsj * xres_j[i];
            }
            let inv_ss_s2 = 1.0 / ss_s2[j];
            beta[j] = ss_y[j] * inv_ss_s2;
            for i in 0..n {
                p_j[i] = inv_ss_s2 * ssx_j[i];
            }
            ws2_ss_s2 += wsj * wsj * inv_ss_s2;
        }
        self.ssp = lambda[nr - 1] * self.ssp + ws2_ss_s2;

        // Projections with the new U, P.
        Self::project(n, nr, s, x, u, p, &mut ws.xu);

        let mature = n_data[nr - 1] > 2.0 * n as f64;
        let used = if mature { nr } else { nr - 1 };
        let mut ypred = 0.0;
        for j in 0..used {
            ypred += beta[j] * s[j];
        }
        // With a single immature direction the reference reads e_cv[-1]; that value is never
        // used (the metric update needs far more data first), we hand on the first residual.
        let e_cv_r = if used == 0 { e_cv[0] } else { e_cv[used - 1] };
        let e = y - ypred;
        if n_data[0] * (1.0 - lambda[0]) > 0.1 {
            self.sum_e2 = self.sum_e2 * lambda[nr - 1] + w * e * e;
            for i in 0..nr {
                sum_e_cv2[i] = sum_e_cv2[i] * lambda[i] + w * e_cv[i] * e_cv[i];
            }
        }
        if n_data[0] > 2.0 * n as f64 {
            self.trustworthy = true;
        }
        (ypred + self.beta0, e_cv_r, e)
    }

    /// Adds a PLS direction when the CV error says so (§4.3 h). Returns whether one was added.
    pub(crate) fn check_add_projection(&mut self, p: &Params) -> bool {
        let n = p.n_in;
        let nr = self.n_reg;
        if nr >= n || nr < 2 {
            return false;
        }
        let mse_r = self.sum_e_cv2[nr - 1] / self.sum_w[nr - 1] + 1e-10;
        let mse_r1 = self.sum_e_cv2[nr - 2] / self.sum_w[nr - 2] + 1e-10;
        if mse_r < p.add_threshold * mse_r1
            && self.n_data[nr - 1] > 0.99 * self.n_data[0]
            && self.n_data[nr - 1] * (1.0 - self.lambda[nr - 1]) > 0.5
        {
            self.push_direction(n, nr, p.init_s2, 0.0, p.init_lambda);
            self.n_reg = nr + 1;
            self.ssp = 0.0;
            true
        } else {
            false
        }
    }

    /// Data counts and forgetting-factor annealing (§4.3 i).
    #[inline(always)]
    pub(crate) fn anneal(&mut self, p: &Params) {
        let nr = self.n_reg;
        let (n_data, lambda) = (&mut self.n_data[..nr], &mut self.lambda[..nr]);
        for i in 0..nr {
            n_data[i] = n_data[i] * lambda[i] + 1.0;
            lambda[i] = p.tau_lambda * lambda[i] + p.final_lambda * (1.0 - p.tau_lambda);
        }
    }

    /// Recomputes the cached slope `∂ŷ_k/∂z` of the local model over the directions used for
    /// prediction, by reverse accumulation through the deflation
    /// (`g ← g + u_r (β_r − p_rᵀ g)`, from the last direction to the first).
    #[inline(always)]
    pub(crate) fn refresh_slope(&mut self, n: usize) {
        let nr = self.n_reg_pred(n);
        let slope = &mut self.slope[..n];
        for v in slope.iter_mut() {
            *v = 0.0;
        }
        for r in (0..nr).rev() {
            let u = &self.u[r * n..r * n + n];
            let p = &self.p[r * n..r * n + n];
            let mut pg = 0.0;
            for i in 0..n {
                pg += p[i] * slope[i];
            }
            let coef = self.beta[r] - pg;
            for i in 0..n {
                slope[i] += coef * u[i];
            }
        }
    }

    /// Local prediction at normalised `xn` by explicit projections (writes `s` into `s_out`).
    /// Returns `(ŷ_k, Σ s_r²/SSs2_r, number of directions used)`.
    pub(crate) fn predict_projected(
        &self,
        n: usize,
        xn: &[f64],
        s_out: &mut [f64],
        xu: &mut [f64],
        z: &mut [f64],
    ) -> (f64, f64, usize) {
        let nr = self.n_reg_pred(n);
        for i in 0..n {
            z[i] = xn[i] - self.mean_x[i];
        }
        Self::project(n, nr, s_out, z, &self.u, &self.p, xu);
        let mut yp = self.beta0;
        let mut s2 = 0.0;
        for i in 0..nr {
            yp += s_out[i] * self.beta[i];
            s2 += s_out[i] * s_out[i] / self.ss_s2[i];
        }
        (yp, s2, nr)
    }

    /// Local prediction from the cached slope.
    #[inline(always)]
    pub(crate) fn predict_slope(&self, xn: &[f64]) -> f64 {
        let mut v = 0.0;
        for i in 0..xn.len() {
            v += self.slope[i] * (xn[i] - self.mean_x[i]);
        }
        self.beta0 + v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `distance` against the reference's plain form `Σ_j xc_j · dot(D_:j, xc)` for every size
    /// (all combinations of eight-lane, four-lane and overlapping tail blocks).
    #[test]
    fn blocked_distance_is_bit_identical_to_column_dots() {
        let mut state = 12345u64;
        let mut rnd = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        for n in 1..=30 {
            let mut d = vec![0.0; n * n];
            for j in 0..n {
                for i in 0..=j {
                    let v = rnd();
                    d[i + j * n] = v;
                    d[j + i * n] = v;
                }
            }
            let xc: Vec<f64> = (0..n).map(|_| rnd()).collect();
            let mut plain = 0.0;
            for j in 0..n {
                plain += xc[j] * dot(&d[j * n..j * n + n], &xc);
            }
            assert_eq!(
                distance(&d, &xc, false).to_bits(),
                plain.to_bits(),
                "n = {n}"
            );
        }
    }
}
