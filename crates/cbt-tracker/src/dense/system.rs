//! The system model, learned from the unordered state sets of consecutive frames
//! (docs/methods.md § Tracking):
//!
//! ```text
//! first order:   C₁[m, n]    = Σ_t a_t[m] · a_{t−1}[n]
//! second order:  T[m, n, o]  = Σ_t a_t[m] · a_{t−1}[n] · a_{t−2}[o]
//! ```
//!
//! with `a_t = Σ_j b(x_t^j)` the summed channel vectors of frame `t`'s states. Each column
//! (fixed `n`, or fixed pair `(n, o)`) is normalised over `m` with the Dirichlet fallback
//! `p = (C + α·F)/(Σ C + α)` of [`CbtConfig`]: `F` is a Gaussian of `fallback_sigma`
//! channels around `n` (first order) or around the constant-velocity extrapolation
//! `2n − o` (second order; or the first-order column, [`SystemFallback::FirstOrder`]).
//!
//! Prediction (eq. 3.3 as a sum over grid points, and the marginal approximation
//! `p(x_{k−1}, x_{k−2} | z) ≈ p(x_{k−1} | z_{1:k−1}) · p(x_{k−2} | z_{1:k−2})`):
//!
//! ```text
//! q⁻[m] = Σ_n S[m, n] q₁[n]                 q⁻[m] = Σ_{n,o} T[m, n, o] q₁[n] q₂[o]
//! ```

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::observation::{add_sorted, split};
use crate::config::{CbtConfig, SystemFallback};
use crate::integrity::{corrupt, len, nonneg, nonneg1, sparse};
use crate::{Space, TrackError};

/// Normalised Gaussian column of `n` cells around integer `centre`, truncated at 3σ:
/// `(first index, values)`.
fn gaussian(n: usize, centre: usize, sigma: f64) -> (usize, Vec<f64>) {
    let r = (3.0 * sigma).ceil() as usize;
    let lo = centre.saturating_sub(r);
    // Saturating: `r` is `usize::MAX` for a huge `sigma`.
    let hi = centre.saturating_add(r).min(n - 1);
    let mut v: Vec<f64> = (lo..=hi)
        .map(|m| {
            let d = m as f64 - centre as f64;
            (-d * d / (2.0 * sigma * sigma)).exp()
        })
        .collect();
    let s: f64 = v.iter().sum();
    v.iter_mut().for_each(|x| *x /= s);
    (lo, v)
}

/// Constant-velocity target index `2n − o`, clamped to `[0, len)`.
#[inline]
fn extrapolate(n: usize, o: usize, len: usize) -> usize {
    (2 * n as i64 - o as i64).clamp(0, len as i64 - 1) as usize
}

/// First-order model of one axis: dense `N × N`, column-major (`[n·N + m]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct AxisSystem1 {
    n: usize,
    counts: Vec<f64>,
    model: Vec<f64>,
}

impl AxisSystem1 {
    pub fn new(n: usize, cfg: &CbtConfig) -> Self {
        let mut s = AxisSystem1 {
            n,
            counts: vec![0.0; n * n],
            model: vec![0.0; n * n],
        };
        s.normalise_columns(&(0..n).collect::<Vec<_>>(), cfg);
        s
    }

    /// Consistency of a deserialised model with an axis of `n` channels.
    pub fn check(&self, n: usize) -> Result<(), TrackError> {
        len("first-order model", self.n, n)?;
        for (what, v) in [
            ("first-order counts", &self.counts),
            ("first-order model", &self.model),
        ] {
            len(what, v.len(), n * n)?;
            nonneg(what, v)?;
        }
        Ok(())
    }

    /// Adds `a_t ⊗ a_{t−1}`.
    pub fn add(&mut self, now: &[(usize, f64)], prev: &[(usize, f64)]) {
        for &(n, vp) in prev {
            let col = &mut self.counts[n * self.n..(n + 1) * self.n];
            for &(m, v) in now {
                col[m] += v * vp;
            }
        }
    }

    /// Adds `w · a_t ⊗ a_{t−1}` (a phase channel's share of a transition).
    pub fn add_weighted(&mut self, now: &[(usize, f64)], prev: &[(usize, f64)], w: f64) {
        for &(n, vp) in prev {
            let col = &mut self.counts[n * self.n..(n + 1) * self.n];
            for &(m, v) in now {
                col[m] += w * (v * vp);
            }
        }
    }

    pub fn normalise_columns(&mut self, cols: &[usize], cfg: &CbtConfig) {
        let alpha = cfg.prior_weight;
        for &n in cols {
            let c = &self.counts[n * self.n..(n + 1) * self.n];
            let mass: f64 = c.iter().sum();
            let (lo, f) = gaussian(self.n, n, cfg.fallback_sigma);
            let col = &mut self.model[n * self.n..(n + 1) * self.n];
            for (m, out) in col.iter_mut().enumerate() {
                let fm = if m >= lo && m - lo < f.len() {
                    f[m - lo]
                } else {
                    0.0
                };
                *out = (c[m] + alpha * fm) / (mass + alpha);
            }
        }
    }

    /// `out = S · q`, skipping the cells [`kept`] drops and spreading their mass uniformly.
    pub fn predict(&self, q: &[f64], prune: f64, out: &mut [f64]) {
        out.iter_mut().for_each(|v| *v = 0.0);
        let mut dropped = 0.0;
        let cut = prune / q.len() as f64;
        for (n, &w) in q.iter().enumerate() {
            if w < cut || w == 0.0 {
                dropped += w;
                continue;
            }
            let col = &self.model[n * self.n..(n + 1) * self.n];
            for (o, s) in out.iter_mut().zip(col) {
                *o += w * s;
            }
        }
        spread(dropped, out);
    }

    /// Normalised column `p(· | n)`.
    pub fn column(&self, n: usize) -> &[f64] {
        &self.model[n * self.n..(n + 1) * self.n]
    }

    /// The normalised model, column-major `[n·N + m]`.
    pub fn model(&self) -> &[f64] {
        &self.model
    }
}

/// Second-order model of one axis: dense `N × N × N` tensor stored as `[(o·N + n)·N + m]`,
/// with the non-zero band `[lo, hi)` of every column for the pruned prediction.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct AxisSystem2 {
    n: usize,
    counts: Vec<f64>,
    model: Vec<f64>,
    band: Vec<(u32, u32)>,
}

impl AxisSystem2 {
    pub fn new(n: usize, cfg: &CbtConfig, first: &AxisSystem1) -> Self {
        let mut s = AxisSystem2 {
            n,
            counts: vec![0.0; n * n * n],
            model: vec![0.0; n * n * n],
            band: vec![(0, 0); n * n],
        };
        s.normalise_columns(&(0..n * n).collect::<Vec<_>>(), cfg, first);
        s
    }

    /// Consistency of a deserialised model with an axis of `n` channels.
    pub fn check(&self, n: usize) -> Result<(), TrackError> {
        len("second-order model", self.n, n)?;
        for (what, v) in [
            ("second-order counts", &self.counts),
            ("second-order model", &self.model),
        ] {
            len(what, v.len(), n * n * n)?;
            nonneg(what, v)?;
        }
        len("second-order bands", self.band.len(), n * n)?;
        if let Some(c) = self
            .band
            .iter()
            .position(|&(lo, hi)| lo > hi || hi as usize > n)
        {
            return Err(corrupt(format!(
                "second-order band of column {c} is {:?}, outside 0..={n}",
                self.band[c]
            )));
        }
        Ok(())
    }

    /// Adds `a_t ⊗ a_{t−1} ⊗ a_{t−2}`; returns the touched columns `o·N + n`.
    pub fn add(
        &mut self,
        now: &[(usize, f64)],
        prev: &[(usize, f64)],
        prev2: &[(usize, f64)],
        touched: &mut Vec<usize>,
    ) {
        let n_ = self.n;
        for &(o, vo) in prev2 {
            for &(n, vn) in prev {
                let c = o * n_ + n;
                touched.push(c);
                let col = &mut self.counts[c * n_..(c + 1) * n_];
                for &(m, v) in now {
                    col[m] += v * vn * vo;
                }
            }
        }
    }

    pub fn normalise_columns(&mut self, cols: &[usize], cfg: &CbtConfig, first: &AxisSystem1) {
        let (n_, alpha) = (self.n, cfg.prior_weight);
        for &c in cols {
            let (o, n) = (c / n_, c % n_);
            let counts = &self.counts[c * n_..(c + 1) * n_];
            let mass: f64 = counts.iter().sum();
            let col = &mut self.model[c * n_..(c + 1) * n_];
            match cfg.system_fallback {
                SystemFallback::ConstantVelocity => {
                    let (lo, f) = gaussian(n_, extrapolate(n, o, n_), cfg.fallback_sigma);
                    for (m, out) in col.iter_mut().enumerate() {
                        let fm = if m >= lo && m - lo < f.len() {
                            f[m - lo]
                        } else {
                            0.0
                        };
                        *out = (counts[m] + alpha * fm) / (mass + alpha);
                    }
                }
                SystemFallback::FirstOrder => {
                    let f = first.column(n);
                    for (m, out) in col.iter_mut().enumerate() {
                        *out = (counts[m] + alpha * f[m]) / (mass + alpha);
                    }
                }
            }
            let lo = col.iter().position(|&v| v != 0.0).unwrap_or(0);
            let hi = col.iter().rposition(|&v| v != 0.0).map_or(0, |h| h + 1);
            self.band[c] = (lo as u32, hi as u32);
        }
    }

    /// `out[m] = Σ_{n,o} T[m, n, o] q1[n] q2[o]` over the cells [`kept`] by the pruning;
    /// the mass of the skipped pairs is spread uniformly.
    pub fn predict(&self, q1: &[f64], q2: &[f64], prune: f64, out: &mut [f64]) {
        let n_ = self.n;
        out.iter_mut().for_each(|v| *v = 0.0);
        let (k1, m1) = kept(q1, prune);
        let (k2, m2) = kept(q2, prune);
        for &(o, w2) in &k2 {
            for &(n, w1) in &k1 {
                let w = w1 * w2;
                let c = o * n_ + n;
                let (lo, hi) = (self.band[c].0 as usize, self.band[c].1 as usize);
                let col = &self.model[c * n_ + lo..c * n_ + hi];
                for (dst, s) in out[lo..hi].iter_mut().zip(col) {
                    *dst += w * s;
                }
            }
        }
        let total = q1.iter().sum::<f64>() * q2.iter().sum::<f64>();
        spread((total - m1 * m2).max(0.0), out);
    }

    /// The normalised tensor, `[(o·N + n)·N + m]`.
    pub fn model(&self) -> &[f64] {
        &self.model
    }
}

/// A sparse column of soft counts with its mass.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub(crate) struct Column {
    mass: f64,
    entries: Vec<(u32, f64)>,
}

impl Column {
    fn add(&mut self, m: u32, v: f64) {
        self.mass += v;
        add_sorted(&mut self.entries, m, v);
    }
}

/// Per-axis normalised Gaussian prior columns for every centre index.
fn axis_gaussians(space: &Space, sigma: f64) -> Vec<Vec<(usize, Vec<f64>)>> {
    (0..space.dims())
        .map(|d| {
            let n = space.axis_len(d);
            (0..n).map(|c| gaussian(n, c, sigma)).collect()
        })
        .collect()
}

/// Adds `w ·` the joint product of per-axis Gaussians centred at `centre` into `out`.
fn add_product(
    g: &[Vec<(usize, Vec<f64>)>],
    centre: [usize; 2],
    len: [usize; 2],
    w: f64,
    out: &mut [f64],
) {
    let (lo0, f0) = &g[0][centre[0]];
    if g.len() == 1 {
        for (i, v) in f0.iter().enumerate() {
            out[lo0 + i] += w * v;
        }
        return;
    }
    let (lo1, f1) = &g[1][centre[1]];
    for (i, v0) in f0.iter().enumerate() {
        let row = (lo0 + i) * len[1] + lo1;
        for (j, v1) in f1.iter().enumerate() {
            out[row + j] += w * v0 * v1;
        }
    }
}

/// The system model over the joint grid, stored sparsely.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct JointSystem {
    cells: usize,
    first: Vec<Column>,
    /// Second-order columns keyed by `n·G + o` (only those with training mass).
    second: BTreeMap<u64, Column>,
    order2: bool,
    gauss: Vec<Vec<(usize, Vec<f64>)>>,
}

impl JointSystem {
    pub fn new(space: &Space, cfg: &CbtConfig, order2: bool) -> Self {
        JointSystem {
            cells: space.cells(),
            first: vec![Column::default(); space.cells()],
            second: BTreeMap::new(),
            order2,
            gauss: axis_gaussians(space, cfg.fallback_sigma),
        }
    }

    /// Consistency of a deserialised model with `space` (the cached fallback Gaussians are
    /// rebuilt by [`Self::prepare`], not checked).
    pub fn check(&self, space: &Space, order2: bool) -> Result<(), TrackError> {
        let g = space.cells();
        len("joint system model", self.cells, g)?;
        len("joint first-order columns", self.first.len(), g)?;
        if self.order2 != order2 {
            return Err(corrupt(
                "joint system model of another order than its configuration",
            ));
        }
        let cols = self.first.iter().map(|c| (None, c));
        let cols = cols.chain(self.second.iter().map(|(k, c)| (Some(*k), c)));
        for (key, c) in cols {
            if key.is_some_and(|k| k >= (g as u64) * (g as u64)) {
                return Err(corrupt(format!(
                    "joint second-order column key {} beyond the grid's {g}² pairs",
                    key.unwrap_or(0)
                )));
            }
            nonneg1("joint system column mass", c.mass)?;
            sparse("joint system column", &c.entries, g)?;
        }
        Ok(())
    }

    /// Rebuilds caches after deserialisation.
    pub fn prepare(&mut self, space: &Space, cfg: &CbtConfig) {
        self.gauss = axis_gaussians(space, cfg.fallback_sigma);
    }

    pub fn add(
        &mut self,
        now: &[(usize, f64)],
        prev: &[(usize, f64)],
        prev2: Option<&[(usize, f64)]>,
    ) {
        for &(n, vp) in prev {
            for &(m, v) in now {
                self.first[n].add(m as u32, v * vp);
            }
        }
        if let (true, Some(prev2)) = (self.order2, prev2) {
            for &(o, vo) in prev2 {
                for &(n, vn) in prev {
                    let col = self.second.entry((n * self.cells + o) as u64).or_default();
                    for &(m, v) in now {
                        col.add(m as u32, v * vn * vo);
                    }
                }
            }
        }
    }

    /// Adds `w · p(· | n)` (first order) into `out`.
    fn add_first(&self, space: &Space, n: usize, w: f64, alpha: f64, out: &mut [f64]) {
        let col = &self.first[n];
        let s = w / (col.mass + alpha);
        for &(m, c) in &col.entries {
            out[m as usize] += s * c;
        }
        let (idx, len) = split(space, n);
        add_product(&self.gauss, idx, len, s * alpha, out);
    }

    /// First-order prediction `out = S q` over the [`kept`] cells.
    pub fn predict1(&self, space: &Space, q: &[f64], cfg: &CbtConfig, out: &mut [f64]) {
        out.iter_mut().for_each(|v| *v = 0.0);
        let (k, m) = kept(q, cfg.prune);
        for &(n, w) in &k {
            self.add_first(space, n, w, cfg.prior_weight, out);
        }
        spread((q.iter().sum::<f64>() - m).max(0.0), out);
    }

    /// Second-order prediction with the marginal approximation over the [`kept`] cells.
    pub fn predict2(
        &self,
        space: &Space,
        q1: &[f64],
        q2: &[f64],
        cfg: &CbtConfig,
        out: &mut [f64],
    ) {
        out.iter_mut().for_each(|v| *v = 0.0);
        let alpha = cfg.prior_weight;
        let (keep1, m1) = kept(q1, cfg.prune);
        let (keep2, m2) = kept(q2, cfg.prune);
        for &(n, w1) in &keep1 {
            let (ni, len) = split(space, n);
            for &(o, w2) in &keep2 {
                let w = w1 * w2;
                let key = (n * self.cells + o) as u64;
                let (mass, entries) = match self.second.get(&key) {
                    Some(c) => (c.mass, &c.entries[..]),
                    None => (0.0, &[][..]),
                };
                let s = w / (mass + alpha);
                for &(m, c) in entries {
                    out[m as usize] += s * c;
                }
                match cfg.system_fallback {
                    SystemFallback::ConstantVelocity => {
                        let (oi, _) = split(space, o);
                        let mut centre = [0; 2];
                        for d in 0..space.dims() {
                            centre[d] = extrapolate(ni[d], oi[d], len[d]);
                        }
                        add_product(&self.gauss, centre, len, s * alpha, out);
                    }
                    SystemFallback::FirstOrder => {
                        self.add_first(space, n, s * alpha, alpha, out);
                    }
                }
            }
        }
        let total: f64 = q1.iter().sum::<f64>() * q2.iter().sum::<f64>();
        spread((total - m1 * m2).max(0.0), out);
    }

    /// Number of stored second-order columns.
    pub fn second_columns(&self) -> usize {
        self.second.len()
    }
}

/// The cells of `q` the pruned prediction uses: those with `q[n] ≥ prune · Σq / len` (the
/// dropped ones hold at most `prune` of the mass together), with their total mass.
pub(crate) fn kept(q: &[f64], prune: f64) -> (Vec<(usize, f64)>, f64) {
    let total: f64 = q.iter().sum();
    let cut = prune * total / q.len() as f64;
    let mut mass = 0.0;
    let k = q
        .iter()
        .enumerate()
        .filter(|(_, w)| **w > 0.0 && **w >= cut)
        .map(|(i, w)| {
            mass += w;
            (i, *w)
        })
        .collect();
    (k, mass)
}

/// Adds `mass` spread uniformly over `out`.
fn spread(mass: f64, out: &mut [f64]) {
    if mass > 0.0 {
        let u = mass / out.len() as f64;
        out.iter_mut().for_each(|v| *v += u);
    }
}
