//! The LWPR model: one sub-model of receptive fields per output; training, prediction,
//! confidence and Jacobian (docs/methods.md § LWPR).

use nalgebra::DMatrix;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::error::{LwprError, Result};
use crate::metric::update_distance_metric;
use crate::params::{Arithmetic, Kernel, MAX_ABS_VALUE, Params, PruneRule};
use crate::rf::{ReceptiveField, UPDATE_ACTIVATION, diag_distance, distance, kernel_eval};
use crate::workspace::Workspace;

/// The run-time dispatch of the update's and the prediction's AVX builds, written once: when
/// the CPU has `$feature`, evaluates `$call` (an `unsafe` call of a function compiled with
/// `#[target_feature(enable = …)]` for it) and returns its value from the enclosing function;
/// otherwise does nothing and the plain code after it runs. Compiled on x86-64 only (elsewhere
/// the plain code always runs); the standard library caches the CPU check. The crate's unit
/// tests can make a thread take the plain code (`plain_only`), to compare the two builds.
macro_rules! avx_first {
    ($feature:tt, $call:expr) => {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!($feature) && !plain_only() {
            return $call;
        }
    };
}

#[cfg(test)]
thread_local! {
    /// Set by a unit test: `avx_first!` takes the plain code on this thread.
    static PLAIN_ONLY: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Whether `avx_first!` must take the plain code: only in a unit test that asked for it.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn plain_only() -> bool {
    #[cfg(test)]
    return PLAIN_ONLY.with(std::cell::Cell::get);
    #[cfg(not(test))]
    false
}

/// Receptive fields of one output dimension.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct SubModel {
    pub rfs: Vec<ReceptiveField>,
    pub n_pruned: usize,
}

/// An LWPR model (create it with [`crate::LwprBuilder`]).
///
/// Every fallible method validates its arguments before touching the model, so an `Err` leaves
/// the model exactly as it was. Deserialising one (serde, [`Lwpr::from_json`],
/// [`Lwpr::from_binary`]) runs every check of a loaded model.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(try_from = "crate::io::LwprData")]
pub struct Lwpr {
    pub(crate) params: Params,
    pub(crate) n_data: u64,
    pub(crate) mean_x: Vec<f64>,
    pub(crate) var_x: Vec<f64>,
    pub(crate) sub: Vec<SubModel>,
    #[serde(skip)]
    pub(crate) ws: Workspace,
}

impl PartialEq for Lwpr {
    /// Two models are equal when every learned and configured number is equal (bit for bit,
    /// apart from `-0.0 == 0.0`); scratch space is ignored.
    fn eq(&self, other: &Self) -> bool {
        self.params == other.params
            && self.n_data == other.n_data
            && self.mean_x == other.mean_x
            && self.var_x == other.var_x
            && self.sub == other.sub
    }
}

/// A prediction together with its Jacobian.
#[derive(Debug, Clone, PartialEq)]
pub struct PredictionWithJacobian {
    /// The prediction `ŷ(x)` (`m` values).
    pub y: Vec<f64>,
    /// `∂ŷ/∂x`, `m × n` (row `i` is the gradient of output `i`).
    pub jacobian: DMatrix<f64>,
}

/// A prediction with the reference's confidence bounds.
#[derive(Debug, Clone, PartialEq)]
pub struct PredictionWithConfidence {
    /// The prediction `ŷ(x)` (`m` values).
    pub y: Vec<f64>,
    /// One standard-deviation-like confidence bound per output (docs/methods.md § LWPR); infinite
    /// where no trustworthy receptive field is active.
    pub confidence: Vec<f64>,
}

/// Read-only view of one receptive field.
#[derive(Debug, Clone, Copy)]
pub struct RfView<'a> {
    rf: &'a ReceptiveField,
    n: usize,
    norm_in: &'a [f64],
}

impl<'a> RfView<'a> {
    /// Centre in input units.
    pub fn centre(&self) -> Vec<f64> {
        self.rf
            .c
            .iter()
            .zip(self.norm_in)
            .map(|(c, s)| c * s)
            .collect()
    }
    /// Distance metric `D` in normalised input units (`n × n`, column-major).
    pub fn metric(&self) -> &'a [f64] {
        &self.rf.d
    }
    /// Upper-triangular factor `M` of `D = MᵀM` (column-major).
    pub fn metric_factor(&self) -> &'a [f64] {
        &self.rf.m
    }
    /// Number of PLS directions.
    pub fn pls_dims(&self) -> usize {
        self.rf.n_reg
    }
    /// Whether the field has seen enough data to predict.
    pub fn trustworthy(&self) -> bool {
        self.rf.trustworthy
    }
    /// Constant term `β₀` of the local model (normalised output units).
    pub fn beta0(&self) -> f64 {
        self.rf.beta0
    }
    /// PLS regression coefficients.
    pub fn beta(&self) -> &'a [f64] {
        &self.rf.beta
    }
    /// Activation in the last update (0 if inactive).
    pub fn last_activation(&self) -> f64 {
        self.rf.w
    }
    /// Discounted data count of the first PLS direction.
    pub fn n_data(&self) -> f64 {
        // Every field has at least one direction (training starts with one or two, loading
        // refuses `n_reg = 0` and checks the array lengths).
        self.rf.n_data[0]
    }
    /// Input dimension.
    pub fn n_in(&self) -> usize {
        self.n
    }
}

/// Largest and second-largest activations of one sub-model in an update.
struct Activity {
    w_max: f64,
    ind_max: Option<usize>,
    w_sec: f64,
    ind_sec: Option<usize>,
    yp: f64,
    sum_w: f64,
}

fn check_vec(what: &'static str, v: &[f64], expected: usize) -> Result<()> {
    if v.len() != expected {
        return Err(LwprError::DimensionMismatch {
            what,
            expected,
            got: v.len(),
        });
    }
    if let Some(index) = v.iter().position(|a| !a.is_finite()) {
        return Err(LwprError::NonFinite { what, index });
    }
    Ok(())
}

/// Checks `|v_i / norm_i| ≤ MAX_ABS_VALUE` (or `|v_i|` without norms); `v` is finite.
fn check_range(what: &'static str, v: &[f64], norm: Option<&[f64]>) -> Result<()> {
    for (index, &a) in v.iter().enumerate() {
        let value = norm.map_or(a, |s| a / s[index]);
        if value.is_nan() || value.abs() > MAX_ABS_VALUE {
            return Err(LwprError::TooLarge {
                what,
                index,
                value,
                bound: MAX_ABS_VALUE,
            });
        }
    }
    Ok(())
}

fn check_cutoff(cutoff: f64) -> Result<()> {
    if !cutoff.is_finite() {
        return Err(LwprError::NonFinite {
            what: "cutoff",
            index: 0,
        });
    }
    Ok(())
}

/// Small input buffer on the stack for the common dimensions.
const STACK_N: usize = 32;

impl Lwpr {
    pub(crate) fn from_valid_params(params: Params) -> Self {
        let (n, m) = (params.n_in, params.n_out);
        Lwpr {
            n_data: 0,
            mean_x: vec![0.0; n],
            var_x: vec![0.0; n],
            sub: (0..m)
                .map(|_| SubModel {
                    rfs: Vec::new(),
                    n_pruned: 0,
                })
                .collect(),
            ws: Workspace::new(n, m),
            params,
        }
    }

    /// Switches the arithmetic of further updates ([`Arithmetic`]); everything learned is kept.
    /// (`Arithmetic::Reference` makes the rest of training bit-identical to the C library's
    /// continuing from the same state.)
    pub fn set_arithmetic(&mut self, arithmetic: Arithmetic) {
        self.params.arithmetic = arithmetic;
    }

    /// Input dimension n.
    pub fn n_in(&self) -> usize {
        self.params.n_in
    }

    /// Output dimension m.
    pub fn n_out(&self) -> usize {
        self.params.n_out
    }

    /// The model's parameters.
    pub fn params(&self) -> &Params {
        &self.params
    }

    /// Number of training samples seen.
    pub fn n_data(&self) -> u64 {
        self.n_data
    }

    /// Running mean of the raw training inputs.
    pub fn mean_x(&self) -> &[f64] {
        &self.mean_x
    }

    /// Running spread of the raw training inputs, kept as the reference library keeps it: after
    /// sample `k + 1`, `v ← (k·v + (x − x̄)²) / (k + 1)` with the mean `x̄` already updated to
    /// include `x`. This is an estimate that the reference's files carry, not the exact
    /// population variance (the samples 0, 2, 4 give 5/3, not 8/3); inspection only.
    pub fn var_x(&self) -> &[f64] {
        &self.var_x
    }

    /// Number of receptive fields of each output's sub-model.
    pub fn num_rfs(&self) -> Vec<usize> {
        self.sub.iter().map(|s| s.rfs.len()).collect()
    }

    /// Number of receptive fields pruned so far, per output.
    pub fn num_pruned(&self) -> Vec<usize> {
        self.sub.iter().map(|s| s.n_pruned).collect()
    }

    /// The receptive fields of output `dim` (empty if `dim` is out of range).
    pub fn receptive_fields(&self, dim: usize) -> Vec<RfView<'_>> {
        self.sub
            .get(dim)
            .map(|s| {
                s.rfs
                    .iter()
                    .map(|rf| RfView {
                        rf,
                        n: self.params.n_in,
                        norm_in: &self.params.norm_in,
                    })
                    .collect()
            })
            .unwrap_or_default()
    }

    /// Trains on one sample and returns the prediction made while learning (over the
    /// trustworthy fields after they absorbed the sample, as the reference's `lwpr_update`).
    ///
    /// ```
    /// let mut model = lwpr::LwprBuilder::new(1, 1).build().unwrap();
    /// for i in 0..200 {
    ///     let x = i as f64 / 200.0;
    ///     model.update(&[x], &[2.0 * x]).unwrap();
    /// }
    /// assert!(model.update(&[f64::NAN], &[0.0]).is_err());
    /// ```
    pub fn update(&mut self, x: &[f64], y: &[f64]) -> Result<Vec<f64>> {
        let mut out = vec![0.0; self.params.n_out];
        self.update_into(x, y, &mut out)?;
        Ok(out)
    }

    /// The checks [`update`](Self::update) applies to a sample before it learns anything from
    /// it: `x` of `n_in` and `y` of `n_out` finite values, each within [`MAX_ABS_VALUE`] raw and
    /// divided by its normalisation factor (tiny factors could overflow). For callers that must
    /// refuse a batch before learning any of it.
    pub fn check_sample(&self, x: &[f64], y: &[f64]) -> Result<()> {
        check_vec("x", x, self.params.n_in)?;
        check_vec("y", y, self.params.n_out)?;
        check_range("x", x, None)?;
        check_range("x / norm_in", x, Some(&self.params.norm_in))?;
        check_range("y", y, None)?;
        check_range("y / norm_out", y, Some(&self.params.norm_out))
    }

    /// [`update`](Self::update) writing the prediction into `y_pred` (`m` values); performs no
    /// heap allocation unless a receptive field or PLS direction is added.
    pub fn update_into(&mut self, x: &[f64], y: &[f64], y_pred: &mut [f64]) -> Result<()> {
        let (n, m) = (self.params.n_in, self.params.n_out);
        self.check_sample(x, y)?;
        if y_pred.len() != m {
            return Err(LwprError::DimensionMismatch {
                what: "y_pred",
                expected: m,
                got: y_pred.len(),
            });
        }

        // Global statistics of the raw inputs (inspection only).
        let nd = self.n_data as f64;
        // No overflow: a model starts at 0 and loading refuses counts above 2^53
        // (`io::MAX_N_DATA`), 2^64 − 2^53 updates short of the limit.
        self.n_data += 1;
        let inv = 1.0 / self.n_data as f64;
        for i in 0..n {
            self.mean_x[i] = (self.mean_x[i] * nd + x[i]) * inv;
            let a = x[i] - self.mean_x[i];
            self.var_x[i] = (self.var_x[i] * nd + a * a) * inv;
        }
        let Lwpr {
            params, sub, ws, ..
        } = self;
        for i in 0..n {
            ws.xn[i] = x[i] / params.norm_in[i];
        }
        for i in 0..m {
            ws.yn[i] = y[i] / params.norm_out[i];
        }
        for dim in 0..m {
            let yn = ws.yn[dim];
            // The update compiled for the common small input dimensions (loops of known
            // length unroll and lose their bounds checks; same operations, same results).
            let s = &mut sub[dim];
            let act = match params.n_in {
                1 => Self::update_sub::<1>(params, s, yn, ws),
                2 => Self::update_sub::<2>(params, s, yn, ws),
                3 => Self::update_sub::<3>(params, s, yn, ws),
                4 => Self::update_sub::<4>(params, s, yn, ws),
                _ => Self::update_sub_any_n(params, s, yn, ws),
            };
            let yp = if act.sum_w > 0.0 {
                act.yp / act.sum_w
            } else {
                0.0
            };
            y_pred[dim] = yp * params.norm_out[dim];
            Self::add_or_prune(params, &mut sub[dim], &act, yn, &ws.xn);
        }
        Ok(())
    }

    /// [`Self::update_sub`] for any input dimension; on x86-64 CPUs with AVX compiled for
    /// them, so that the four-lane sums of the metric update and the activations run four
    /// lanes per instruction. Multiplies and adds stay separate instructions (no fused
    /// multiply-add), so the results are the same bits either way.
    fn update_sub_any_n(p: &Params, sub: &mut SubModel, yn: f64, ws: &mut Workspace) -> Activity {
        avx_first!(
            "avx2",
            // SAFETY: the CPU supports AVX2, hence AVX (the macro checked).
            unsafe { Self::update_sub_avx(p, sub, yn, ws) }
        );
        Self::update_sub::<0>(p, sub, yn, ws)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx,avx2")]
    fn update_sub_avx(p: &Params, sub: &mut SubModel, yn: f64, ws: &mut Workspace) -> Activity {
        Self::update_sub::<0>(p, sub, yn, ws)
    }

    /// One sub-model's update; `N` is the input dimension if it is known at compile time
    /// (else 0).
    #[inline(always)]
    fn update_sub<const N: usize>(
        p: &Params,
        sub: &mut SubModel,
        yn: f64,
        ws: &mut Workspace,
    ) -> Activity {
        let n = if N == 0 { p.n_in } else { N };
        let mut act = Activity {
            w_max: 0.0,
            ind_max: None,
            w_sec: 0.0,
            ind_sec: None,
            yp: 0.0,
            sum_w: 0.0,
        };
        let mut xn = std::mem::take(&mut ws.xn);
        let mut xmz = std::mem::take(&mut ws.xmz);
        // Activations below every threshold that matters (updating, creation template,
        // pruning) change nothing, so the exponential is skipped for them; the margin covers
        // rounding, so decisions are the reference's.
        let threshold = UPDATE_ACTIVATION.min(0.1 * p.w_gen).min(p.w_prune);
        let q_skip = match p.kernel {
            Kernel::Gaussian => -2.0 * threshold.ln() * (1.0 + 1e-9) + 1e-9,
            Kernel::BiSquare => f64::INFINITY,
        };
        let xn_n = &xn[..n];
        // Arithmetic::Fast for n ≥ 5 with a full metric: the vectorised module `fast`.
        let fast = N == 0 && !p.diag_only && p.arithmetic == Arithmetic::Fast;
        for (k, rf) in sub.rfs.iter_mut().enumerate() {
            let c = &rf.c[..n];
            let q = if p.diag_only {
                diag_distance(&rf.d, xn_n, c)
            } else if fast {
                let xc = &mut ws.xc[..n];
                for i in 0..n {
                    xc[i] = xn_n[i] - c[i];
                }
                crate::fast::distance_m(&rf.m, xc, &mut ws.dq, q_skip)
            } else {
                let xc = &mut ws.xc[..n];
                for i in 0..n {
                    xc[i] = xn_n[i] - c[i];
                }
                distance(&rf.d, xc, false)
            };
            if q > q_skip {
                rf.w = 0.0;
                continue;
            }
            let (w, dwdq, ddwdqdq) = kernel_eval(p.kernel, q);
            if w > act.w_sec {
                if w > act.w_max {
                    act.ind_sec = act.ind_max;
                    act.w_sec = act.w_max;
                    act.ind_max = Some(k);
                    act.w_max = w;
                } else {
                    act.ind_sec = Some(k);
                    act.w_sec = w;
                }
            }
            if w > UPDATE_ACTIVATION {
                rf.w = w;
                let ymz = rf.update_means(&xn[..n], yn, w, &mut xmz[..n]);
                let (yp_k, e_cv, e) = rf.update_regression(n, &xmz[..n], ymz, w, ws);
                if rf.trustworthy {
                    act.yp += w * yp_k;
                    act.sum_w += w;
                }
                if p.update_d {
                    update_distance_metric(
                        n,
                        rf,
                        p,
                        (w, dwdq, ddwdqdq),
                        e_cv,
                        e,
                        &xn[..n],
                        ws,
                        fast,
                    );
                }
                rf.check_add_projection(p);
                rf.anneal(p);
                rf.refresh_slope(n);
            } else {
                rf.w = 0.0;
            }
        }
        ws.xn = std::mem::take(&mut xn);
        ws.xmz = xmz;
        act
    }

    fn add_or_prune(p: &Params, sub: &mut SubModel, act: &Activity, yn: f64, xn: &[f64]) {
        if act.w_max <= p.w_gen {
            let template = match act.ind_max {
                Some(k) if act.w_max > 0.1 * p.w_gen && sub.rfs[k].trustworthy => Some(&sub.rfs[k]),
                _ => None,
            };
            let mut rf = ReceptiveField::new(p, template, xn, yn);
            rf.refresh_slope(p.n_in);
            sub.rfs.push(rf);
            return;
        }
        if act.w_sec > p.w_prune {
            let (Some(a), Some(b)) = (act.ind_max, act.ind_sec) else {
                return;
            };
            let n = p.n_in;
            let tr = |k: usize| {
                (0..n)
                    .map(|i| sub.rfs[k].d[i + i * n])
                    .fold(0.0, |s, v| s + v)
            };
            let (tr_max, tr_sec) = (tr(a), tr(b));
            let prune = match p.prune_rule {
                // Remove the narrower field (larger trace).
                PruneRule::Published => {
                    if tr_max > tr_sec {
                        a
                    } else {
                        b
                    }
                }
                // The C library: remove the field with the smaller trace.
                PruneRule::ReferenceC => {
                    if tr_max < tr_sec {
                        a
                    } else {
                        b
                    }
                }
            };
            sub.rfs.swap_remove(prune);
            // No overflow: at most one pruning per output and update keeps n_pruned ≤ n_data
            // (loading checks it), and n_data cannot overflow (`update_into`).
            sub.n_pruned += 1;
        }
    }

    /// Writes the normalised input into `buf` and returns it (stack buffer for small n).
    #[inline(always)]
    fn normalise<'b>(&self, x: &[f64], buf: &'b mut [f64]) -> &'b [f64] {
        for i in 0..x.len() {
            buf[i] = x[i] / self.params.norm_in[i];
        }
        &buf[..x.len()]
    }

    fn validate_x(&self, x: &[f64], cutoff: f64) -> Result<()> {
        check_vec("x", x, self.params.n_in)?;
        check_cutoff(cutoff)
    }

    /// Prediction of output `dim` at normalised `xn` (`xc` scratch of length 2n); returns
    /// `(ŷ, max activation)` in normalised units, the activation exact only when `need_max`
    /// (otherwise the exponential is skipped for fields too far away to pass `cutoff`).
    #[inline(always)]
    fn predict_dim(
        &self,
        dim: usize,
        xn: &[f64],
        cutoff: f64,
        xc: &mut [f64],
        need_max: bool,
    ) -> (f64, f64) {
        // Compiled for the common small input dimensions, and with AVX where available for
        // the others (same operations either way).
        match self.params.n_in {
            1 => self.predict_dim_n::<1>(dim, xn, cutoff, xc, need_max),
            2 => self.predict_dim_n::<2>(dim, xn, cutoff, xc, need_max),
            3 => self.predict_dim_n::<3>(dim, xn, cutoff, xc, need_max),
            4 => self.predict_dim_n::<4>(dim, xn, cutoff, xc, need_max),
            _ => {
                avx_first!(
                    "avx",
                    // SAFETY: the CPU supports AVX (the macro checked).
                    unsafe { self.predict_dim_avx(dim, xn, cutoff, xc, need_max) }
                );
                self.predict_dim_n::<0>(dim, xn, cutoff, xc, need_max)
            }
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    fn predict_dim_avx(
        &self,
        dim: usize,
        xn: &[f64],
        cutoff: f64,
        xc: &mut [f64],
        need_max: bool,
    ) -> (f64, f64) {
        self.predict_dim_n::<0>(dim, xn, cutoff, xc, need_max)
    }

    #[inline(always)]
    fn predict_dim_n<const N: usize>(
        &self,
        dim: usize,
        xn: &[f64],
        cutoff: f64,
        xc: &mut [f64],
        need_max: bool,
    ) -> (f64, f64) {
        let p = &self.params;
        let n = if N == 0 { p.n_in } else { N };
        let xn = &xn[..n];
        // Squared distances beyond `q_skip` give activations below `cutoff` (with a margin
        // for rounding), so their exponential is not needed unless the maximum is asked for.
        let q_skip = match p.kernel {
            Kernel::Gaussian if cutoff > 0.0 && !need_max => {
                -2.0 * cutoff.ln() * (1.0 + 1e-9) + 1e-9
            }
            _ => f64::INFINITY,
        };
        let mut yp = 0.0;
        let mut sum_w = 0.0;
        let mut w_max: f64 = 0.0;
        for rf in &self.sub[dim].rfs {
            let c = &rf.c[..n];
            let q = if p.diag_only {
                diag_distance(&rf.d, xn, c)
            } else if N == 0 {
                // n ≥ 5: the same |M (x − c)|² by row blocks, stopped as soon as the field is
                // known to be below the cutoff.
                let (xc, v) = xc.split_at_mut(n);
                for i in 0..n {
                    xc[i] = xn[i] - c[i];
                }
                crate::fast::distance_m(&rf.m, &xc[..n], v, q_skip)
            } else {
                // q = |M (x − c)|² with the triangular factor: half the work of (x−c)ᵀD(x−c),
                // equal up to rounding (training uses the reference's form).
                let (xc, v) = xc.split_at_mut(n);
                let v = &mut v[..n];
                for i in 0..n {
                    xc[i] = xn[i] - c[i];
                    v[i] = 0.0;
                }
                let m = &rf.m[..n * n];
                for j in 0..n {
                    let col = &m[j * n..j * n + j + 1];
                    let xj = xc[j];
                    for (vi, mij) in v[..=j].iter_mut().zip(col) {
                        *vi += mij * xj;
                    }
                }
                let mut q = 0.0;
                for &a in v.iter() {
                    q += a * a;
                }
                q
            };
            if q > q_skip {
                continue;
            }
            let w = kernel_eval(p.kernel, q).0;
            if w > w_max {
                w_max = w;
            }
            if w > cutoff && rf.trustworthy {
                let (slope, mean_x) = (&rf.slope[..n], &rf.mean_x[..n]);
                let mut v = 0.0;
                for i in 0..n {
                    v += slope[i] * (xn[i] - mean_x[i]);
                }
                yp += w * (rf.beta0 + v);
                sum_w += w;
            }
        }
        if sum_w > 0.0 {
            yp /= sum_w;
        }
        (yp, w_max)
    }

    /// Predicts `ŷ(x)`; receptive fields with activation ≤ `cutoff` are ignored (the reference
    /// examples use 0.001). Outputs with no trustworthy active field predict 0.
    pub fn predict(&self, x: &[f64], cutoff: f64) -> Result<Vec<f64>> {
        let mut out = vec![0.0; self.params.n_out];
        self.predict_into(x, cutoff, &mut out)?;
        Ok(out)
    }

    /// [`predict`](Self::predict) into `out` (`m` values), without heap allocation for
    /// `n ≤ 32`.
    pub fn predict_into(&self, x: &[f64], cutoff: f64, out: &mut [f64]) -> Result<()> {
        self.validate_x(x, cutoff)?;
        if out.len() != self.params.n_out {
            return Err(LwprError::DimensionMismatch {
                what: "out",
                expected: self.params.n_out,
                got: out.len(),
            });
        }
        self.predict_unchecked(x, cutoff, out, None);
        Ok(())
    }

    /// Also returns the largest activation per output (`lwpr_predict`'s `max_w`).
    pub fn predict_with_max_activation(
        &self,
        x: &[f64],
        cutoff: f64,
    ) -> Result<(Vec<f64>, Vec<f64>)> {
        self.validate_x(x, cutoff)?;
        let m = self.params.n_out;
        let (mut y, mut wm) = (vec![0.0; m], vec![0.0; m]);
        self.predict_unchecked(x, cutoff, &mut y, Some(&mut wm));
        Ok((y, wm))
    }

    fn predict_unchecked(
        &self,
        x: &[f64],
        cutoff: f64,
        out: &mut [f64],
        mut max_w: Option<&mut [f64]>,
    ) {
        let n = self.params.n_in;
        let mut heap;
        let mut stack = [0.0; 3 * STACK_N];
        let buf: &mut [f64] = if n <= STACK_N {
            &mut stack[..3 * n]
        } else {
            heap = vec![0.0; 3 * n];
            &mut heap
        };
        let (xbuf, xc) = buf.split_at_mut(n);
        let xn = self.normalise(x, xbuf);
        for dim in 0..self.params.n_out {
            let (y, w) = self.predict_dim(dim, xn, cutoff, xc, max_w.is_some());
            out[dim] = y * self.params.norm_out[dim];
            if let Some(mw) = max_w.as_deref_mut() {
                mw[dim] = w;
            }
        }
    }

    /// Predicts many inputs (`xs` holds them one after another, `k·n` values) in parallel with
    /// rayon; the result (`k·m` values) is identical to calling [`predict`](Self::predict) on
    /// each input, on any number of threads.
    pub fn predict_batch(&self, xs: &[f64], cutoff: f64) -> Result<Vec<f64>> {
        let (n, m) = (self.params.n_in, self.params.n_out);
        if !xs.len().is_multiple_of(n) {
            return Err(LwprError::DimensionMismatch {
                what: "xs (multiple of n_in)",
                expected: n * xs.len().div_ceil(n),
                got: xs.len(),
            });
        }
        check_cutoff(cutoff)?;
        if let Some(index) = xs.iter().position(|v| !v.is_finite()) {
            return Err(LwprError::NonFinite { what: "xs", index });
        }
        // `k·m` overflows only past 2^64 values: with `m ≤ MAX_OUTPUTS` (2^12) that needs
        // `xs` of more than 2^52 values (32 PiB), far beyond any memory.
        let mut out = vec![0.0; xs.len() / n * m];
        out.par_chunks_mut(m)
            .zip(xs.par_chunks(n))
            .with_min_len(64)
            .for_each(|(o, x)| self.predict_unchecked(x, cutoff, o, None));
        Ok(out)
    }

    /// Prediction with the reference's confidence bounds (`lwpr_predict` with `conf`): per
    /// field `σ_k² = E_cv/(W − S_p)·(1 + w Σ s_r²/SSs2_r)`, combined as
    /// `√|Σ w σ_k² + Σ w ŷ_k² − W ŷ²| / W`.
    ///
    /// # Errors
    /// [`LwprError::DimensionMismatch`] / [`LwprError::NonFinite`] for `x` or `cutoff` as
    /// [`predict`](Self::predict), and [`LwprError::NoConfidence`] where an active trustworthy
    /// field has no PLS direction mature enough for the bound.
    pub fn predict_with_confidence(
        &self,
        x: &[f64],
        cutoff: f64,
    ) -> Result<PredictionWithConfidence> {
        self.validate_x(x, cutoff)?;
        let (n, m) = (self.params.n_in, self.params.n_out);
        let mut xn = vec![0.0; n];
        self.normalise(x, &mut xn);
        let (mut xc, mut s, mut xu, mut z) =
            (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        let mut y = vec![0.0; m];
        let mut confidence = vec![0.0; m];
        for dim in 0..m {
            let (mut sum_w, mut sum_wy, mut sum_wyy, mut sum_conf) = (0.0, 0.0, 0.0, 0.0);
            for (field, rf) in self.sub[dim].rfs.iter().enumerate() {
                for i in 0..n {
                    xc[i] = xn[i] - rf.c[i];
                }
                let w = kernel_eval(
                    self.params.kernel,
                    distance(&rf.d, &xc, self.params.diag_only),
                )
                .0;
                if w > cutoff && rf.trustworthy {
                    let (yk, s2, nr) = rf.predict_projected(n, &xn, &mut s, &mut xu, &mut z);
                    if nr == 0 {
                        // One direction, immature (`n_data ≤ 2n`): `nr − 1` below would be −1.
                        return Err(LwprError::NoConfidence { output: dim, field });
                    }
                    let sigma2 =
                        rf.sum_e_cv2[nr - 1] / (rf.sum_w[nr - 1] - rf.ssp) * (1.0 + w * s2);
                    sum_wyy += w * yk * yk;
                    sum_conf += w * sigma2;
                    sum_wy += w * yk;
                    sum_w += w;
                }
            }
            let no = self.params.norm_out[dim];
            if sum_w > 0.0 {
                let yp = sum_wy / sum_w;
                y[dim] = yp * no;
                confidence[dim] = no * (sum_conf + sum_wyy - sum_wy * yp).abs().sqrt() / sum_w;
            } else {
                y[dim] = 0.0;
                confidence[dim] = f64::INFINITY;
            }
        }
        Ok(PredictionWithConfidence { y, confidence })
    }

    /// Prediction and its analytic Jacobian `∂ŷ/∂x` (`m × n`; docs/methods.md § LWPR):
    /// `∂ŷ/∂x = (1/W) Σ_k (w_k ∂ŷ_k/∂x + ŷ_k ∂w_k/∂x) − (ŷ/W) Σ_k ∂w_k/∂x`, with
    /// `∂w_k/∂x = 2 (dw/dq) D_k (x − c_k)`, scaled by `norm_out_i / norm_in_j`. Where no
    /// trustworthy field is active the prediction and the Jacobian are 0.
    ///
    /// ```
    /// let mut model = lwpr::LwprBuilder::new(1, 1).init_d_spherical(4.0).build().unwrap();
    /// for i in 0..2000 {
    ///     let x = (i % 100) as f64 / 100.0;
    ///     model.update(&[x], &[3.0 * x]).unwrap();
    /// }
    /// let p = model.predict_with_jacobian(&[0.5], 0.001).unwrap();
    /// assert!((p.y[0] - 1.5).abs() < 0.05);
    /// assert!((p.jacobian[(0, 0)] - 3.0).abs() < 0.2);
    /// ```
    pub fn predict_with_jacobian(&self, x: &[f64], cutoff: f64) -> Result<PredictionWithJacobian> {
        self.validate_x(x, cutoff)?;
        let (n, m) = (self.params.n_in, self.params.n_out);
        let mut xn = vec![0.0; n];
        self.normalise(x, &mut xn);
        let (mut xc, mut dx) = (vec![0.0; n], vec![0.0; n]);
        let (mut sum_dwdx, mut sum_ydw_wdy) = (vec![0.0; n], vec![0.0; n]);
        let mut y = vec![0.0; m];
        let mut jacobian = DMatrix::zeros(m, n);
        for dim in 0..m {
            sum_dwdx.iter_mut().for_each(|v| *v = 0.0);
            sum_ydw_wdy.iter_mut().for_each(|v| *v = 0.0);
            let (mut yp, mut sum_w) = (0.0, 0.0);
            for rf in &self.sub[dim].rfs {
                for i in 0..n {
                    xc[i] = xn[i] - rf.c[i];
                }
                let mut q = 0.0;
                for j in 0..n {
                    let dj = if self.params.diag_only {
                        rf.d[j + j * n] * xc[j]
                    } else {
                        crate::linalg::dot(&rf.d[j * n..j * n + n], &xc)
                    };
                    dx[j] = dj;
                    q += xc[j] * dj;
                }
                let (w, dwdq, _) = kernel_eval(self.params.kernel, q);
                if w > cutoff && rf.trustworthy {
                    let yk = rf.predict_slope(&xn);
                    yp += w * yk;
                    sum_w += w;
                    for j in 0..n {
                        let dw = 2.0 * dwdq * dx[j];
                        sum_dwdx[j] += dw;
                        sum_ydw_wdy[j] += yk * dw + w * rf.slope[j];
                    }
                }
            }
            let no = self.params.norm_out[dim];
            if sum_w > 0.0 {
                yp /= sum_w;
                y[dim] = yp * no;
                for j in 0..n {
                    let g = -yp / sum_w * sum_dwdx[j] + sum_ydw_wdy[j] / sum_w;
                    jacobian[(dim, j)] = g * no / self.params.norm_in[j];
                }
            }
        }
        Ok(PredictionWithJacobian { y, jacobian })
    }
}

#[cfg(test)]
mod tests {
    //! The AVX builds of the update and the prediction (`avx_first!`) against the plain code
    //! they replace: the docs promise "the same bits either way", so every prediction an update
    //! returns, every learned number and every prediction must be bit-identical.
    use super::*;
    use crate::params::LwprBuilder;

    /// `f` with `avx_first!` taking the plain code on this thread.
    fn plain<R>(f: impl FnOnce() -> R) -> R {
        PLAIN_ONLY.with(|p| p.set(true));
        let r = f();
        PLAIN_ONLY.with(|p| p.set(false));
        r
    }

    /// Inputs in `[-1, 1]^n` from a small LCG, and a smooth two-output target.
    fn samples(n: usize, k: usize, seed: u64) -> Vec<(Vec<f64>, [f64; 2])> {
        let mut s = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
        (0..k)
            .map(|_| {
                let x: Vec<f64> = (0..n)
                    .map(|_| {
                        s = s
                            .wrapping_mul(6364136223846793005)
                            .wrapping_add(1442695040888963407);
                        (s >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
                    })
                    .collect();
                let y = [
                    (2.0 * x[0]).sin() + x[1] * x[n / 2],
                    0.5 * x[n - 1] * x[n - 1] - x[2],
                ];
                (x, y)
            })
            .collect()
    }

    fn bits(v: &[f64]) -> Vec<u64> {
        v.iter().map(|a| a.to_bits()).collect()
    }

    /// Input dimensions from 5 (below, the update and prediction are compiled per dimension and
    /// not dispatched), full and diagonal metrics, meta learning on and off, both arithmetics
    /// and kernels, pruning, two outputs, normalised inputs and outputs.
    #[test]
    fn avx_update_and_prediction_are_bit_identical_to_the_plain_path() {
        #[cfg(target_arch = "x86_64")]
        let have_avx = std::arch::is_x86_feature_detected!("avx2");
        #[cfg(not(target_arch = "x86_64"))]
        let have_avx = false;
        if !have_avx {
            eprintln!("no AVX2 on this CPU: both models take the plain code");
        }
        use {Arithmetic::*, Kernel::*};
        for (n, diag, meta, arithmetic, kernel, w_prune) in [
            (5, false, true, Fast, Gaussian, 0.8),
            (5, false, false, Reference, BiSquare, 1.0),
            (6, true, true, Fast, Gaussian, 0.8),
            (7, false, false, Fast, BiSquare, 0.8),
            (9, false, true, Reference, Gaussian, 0.8),
            (11, true, false, Reference, BiSquare, 1.0),
            (13, false, true, Fast, Gaussian, 1.0),
        ] {
            let label = format!(
                "n = {n}, diag_only = {diag}, meta = {meta}, {arithmetic:?}, {kernel:?}, \
                 w_prune = {w_prune}"
            );
            let norm_in: Vec<f64> = (0..n).map(|i| 0.5 + 0.25 * i as f64).collect();
            let build = || {
                LwprBuilder::new(n, 2)
                    .init_d_spherical(if kernel == BiSquare { 0.5 } else { 2.0 })
                    .init_alpha(100.0)
                    .w_gen(0.2)
                    .w_prune(w_prune)
                    .diag_only(diag)
                    .meta(meta)
                    .kernel(kernel)
                    .arithmetic(arithmetic)
                    .norm_in(&norm_in)
                    .norm_out(&[1.0, 3.0])
                    .build()
                    .unwrap()
            };
            let (mut dispatched, mut reference) = (build(), build());
            for (x, y) in samples(n, 400, n as u64) {
                let a = dispatched.update(&x, &y).unwrap();
                let b = plain(|| reference.update(&x, &y).unwrap());
                assert_eq!(bits(&a), bits(&b), "{label}: update");
            }
            assert_eq!(dispatched, reference, "{label}: learned model");
            let nrf = reference.num_rfs();
            assert!(
                nrf.iter().all(|&k| k > 1)
                    && reference
                        .sub
                        .iter()
                        .all(|s| s.rfs.iter().any(|rf| rf.trustworthy)),
                "{label}: several fields, some trustworthy: {nrf:?}"
            );
            // Prediction at training-like and far-away inputs, with and without the early stop
            // of the distance, with and without the largest activation.
            let mut active = 0;
            for (x, _) in samples(n, 150, 1000 + n as u64) {
                for (scale, cutoff) in [(1.0, 0.001), (1.0, 0.0), (1.0, 0.3), (3.0, 0.001)] {
                    let x: Vec<f64> = x.iter().map(|v| scale * v).collect();
                    let a = reference.predict_with_max_activation(&x, cutoff).unwrap();
                    let b = plain(|| reference.predict_with_max_activation(&x, cutoff).unwrap());
                    assert_eq!(
                        (bits(&a.0), bits(&a.1)),
                        (bits(&b.0), bits(&b.1)),
                        "{label}: prediction with the largest activation at {x:?}, cutoff {cutoff}"
                    );
                    let a = reference.predict(&x, cutoff).unwrap();
                    let b = plain(|| reference.predict(&x, cutoff).unwrap());
                    assert_eq!(
                        bits(&a),
                        bits(&b),
                        "{label}: prediction at {x:?}, cutoff {cutoff}"
                    );
                    active += usize::from(a[0] != 0.0);
                }
            }
            assert!(active > 100, "{label}: {active} active predictions");
        }
    }
}
