//! The observation model `p(z | x)`, learned without correspondences (docs/methods.md § Tracking):
//! the soft joint histogram `C_zx = Σ_t (Σ_i b(z_t^i)) (Σ_j b(x_t^j))ᵀ` of every within-frame
//! pairing of a detection with a state, column-normalised with the Dirichlet fallback of
//! [`CbtConfig`] and the floor `ε`:
//!
//! ```text
//! O[m, n] = (1 − ε) · (C[m, n] + α·F[m, n]) / (Σ_m C[m, n] + α) + ε / N_z
//! ```
//!
//! With [`Clutter::Subtract`], `C` is first replaced by `max(C − B, 0)` where the background
//! `B = s · μ_z μ_xᵀ` is the outer product of the detection and state marginals (each of unit
//! sum), scaled by the soft mass `s` of the expected wrong pairs (all pairs but one per state
//! in frames with detections).

use serde::{Deserialize, Serialize};

use crate::config::{CbtConfig, Clutter, ObservationFallback};
use crate::encode::Encoded;
use crate::integrity::{corrupt, len, nonneg, nonneg1, sparse};
use crate::{Space, TrackError};

/// Marginal statistics for the clutter background (shared by both layouts).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub(crate) struct Background {
    /// Σ of detection channel vectors (measurement cells).
    pub zsum: Vec<f64>,
    /// Σ of state channel vectors (state cells).
    pub xsum: Vec<f64>,
    /// Total soft mass of all pairs (Σ C).
    pub pair_mass: f64,
    /// Number of (weighted) detection–state pairs.
    pub pairs: f64,
    /// Expected number of wrong pairs.
    pub wrong: f64,
}

impl Background {
    fn new(nz: usize, nx: usize) -> Self {
        Background {
            zsum: vec![0.0; nz],
            xsum: vec![0.0; nx],
            ..Default::default()
        }
    }

    fn add(&mut self, z: &[(usize, f64)], x: &[(usize, f64)], n_states: f64, w_dets: f64) {
        let (mut sz, mut sx) = (0.0, 0.0);
        for &(m, v) in z {
            self.zsum[m] += v;
            sz += v;
        }
        for &(n, v) in x {
            self.xsum[n] += v;
            sx += v;
        }
        self.pair_mass += sz * sx;
        self.pairs += n_states * w_dets;
        self.wrong += n_states * (w_dets - w_dets.min(1.0));
    }

    /// Consistency of a deserialised background with `nz` measurement and `nx` state cells.
    fn check(&self, nz: usize, nx: usize) -> Result<(), TrackError> {
        len("observation background (detections)", self.zsum.len(), nz)?;
        len("observation background (states)", self.xsum.len(), nx)?;
        nonneg("observation background (detections)", &self.zsum)?;
        nonneg("observation background (states)", &self.xsum)?;
        for v in [self.pair_mass, self.pairs, self.wrong] {
            nonneg1("observation background mass", v)?;
        }
        Ok(())
    }

    /// The learned share `π` of wrong (clutter) pairs among all detection–state pairs.
    pub fn clutter_share(&self) -> f64 {
        if self.pairs > 0.0 {
            (self.wrong / self.pairs).clamp(0.0, 1.0)
        } else {
            0.0
        }
    }

    /// The factor `k` with `B[m, n] = k · zsum[m] · xsum[n]`.
    fn scale(&self) -> f64 {
        let (tz, tx): (f64, f64) = (self.zsum.iter().sum(), self.xsum.iter().sum());
        if self.pairs <= 0.0 || tz <= 0.0 || tx <= 0.0 {
            return 0.0;
        }
        self.wrong / self.pairs * self.pair_mass / (tz * tx)
    }
}

/// The observation model of one axis (separable layout), dense `N_z × N_x`, row-major
/// (`[m·N_x + n]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct AxisObservation {
    nz: usize,
    nx: usize,
    counts: Vec<f64>,
    background: Background,
    /// Prior columns `F` (each of unit sum), same layout.
    fallback: Vec<f64>,
    /// The normalised model `O`.
    model: Vec<f64>,
}

impl AxisObservation {
    pub fn new(space: &Space, d: usize, cfg: &CbtConfig) -> Self {
        let (nz, nx) = (space.meas_len(d), space.axis_len(d));
        let mut fallback = vec![0.0; nz * nx];
        for n in 0..nx {
            let col = fallback_column_1d(space, d, n, cfg.observation_fallback);
            for m in 0..nz {
                fallback[m * nx + n] = col[m];
            }
        }
        let mut o = AxisObservation {
            nz,
            nx,
            counts: vec![0.0; nz * nx],
            background: Background::new(nz, nx),
            fallback,
            model: vec![0.0; nz * nx],
        };
        o.normalise_all(cfg);
        o
    }

    /// Consistency of a deserialised model with axis `d` of `space`.
    pub fn check(&self, space: &Space, d: usize) -> Result<(), TrackError> {
        if (self.nz, self.nx) != (space.meas_len(d), space.axis_len(d)) {
            return Err(corrupt(format!(
                "observation model of axis {d} is {}×{}, the space has {}×{} channels",
                self.nz,
                self.nx,
                space.meas_len(d),
                space.axis_len(d)
            )));
        }
        let n = self.nz * self.nx;
        for (what, v) in [
            ("observation counts", &self.counts),
            ("observation fallback", &self.fallback),
            ("observation model", &self.model),
        ] {
            len(what, v.len(), n)?;
            nonneg(what, v)?;
        }
        self.background.check(self.nz, self.nx)
    }

    /// Adds the pairs of one frame's encoded detections and states on this axis.
    pub fn add(&mut self, z: &Encoded, x: &Encoded, d: usize) {
        for &(m, vz) in &z.axes[d] {
            let row = &mut self.counts[m * self.nx..(m + 1) * self.nx];
            for &(n, vx) in &x.axes[d] {
                row[n] += vz * vx;
            }
        }
        self.background
            .add(&z.axes[d], &x.axes[d], x.count, z.count);
    }

    /// Recomputes the normalised model from the counts.
    pub fn normalise_all(&mut self, cfg: &CbtConfig) {
        let cols: Vec<usize> = (0..self.nx).collect();
        self.normalise_columns(&cols, cfg);
    }

    /// Recomputes the given columns (all of them when the clutter background is subtracted,
    /// since the background depends on every frame).
    pub fn normalise_columns(&mut self, cols: &[usize], cfg: &CbtConfig) {
        let subtract = cfg.clutter != Clutter::Model;
        let k = if subtract {
            self.background.scale()
        } else {
            0.0
        };
        let all: Vec<usize>;
        let cols = if subtract {
            all = (0..self.nx).collect();
            &all[..]
        } else {
            cols
        };
        let (eps, alpha) = (cfg.observation_floor, cfg.prior_weight);
        let floor = eps / self.nz as f64;
        for &n in cols {
            let eff = |m: usize| {
                let c = self.counts[m * self.nx + n];
                if subtract {
                    (c - k * self.background.zsum[m] * self.background.xsum[n]).max(0.0)
                } else {
                    c
                }
            };
            let mass: f64 = (0..self.nz).map(eff).sum();
            let inv = (1.0 - eps) / (mass + alpha);
            for m in 0..self.nz {
                let i = m * self.nx + n;
                self.model[i] = (eff(m) + alpha * self.fallback[i]) * inv + floor;
            }
        }
    }

    /// `out[n] = Σ_m b_m · O[m, n]` for the sparse measurement encoding `b`.
    #[inline]
    pub fn likelihood(&self, b: &[(usize, f64)], out: &mut [f64]) {
        out.iter_mut().for_each(|v| *v = 0.0);
        for &(m, v) in b {
            let row = &self.model[m * self.nx..(m + 1) * self.nx];
            for (o, r) in out.iter_mut().zip(row) {
                *o += v * r;
            }
        }
    }

    /// The learned share of clutter pairs.
    pub fn clutter_share(&self) -> f64 {
        self.background.clutter_share()
    }

    /// The normalised model, row-major `[m·N_x + n]`.
    pub fn model(&self) -> &[f64] {
        &self.model
    }

    /// The raw soft counts, row-major `[m·N_x + n]`.
    pub fn counts(&self) -> &[f64] {
        &self.counts
    }
}

/// The prior column `F[:, n]` of state channel `n` on axis `d` (unit sum).
fn fallback_column_1d(space: &Space, d: usize, n: usize, kind: ObservationFallback) -> Vec<f64> {
    let nz = space.meas_len(d);
    let uniform = vec![1.0 / nz as f64; nz];
    if kind == ObservationFallback::Uniform {
        return uniform;
    }
    let x = space.state_basis(d).centre(n);
    match space.meas_basis(d).encode(x) {
        Ok(c) => {
            let s: f64 = c.iter().sum();
            if s > 0.0 {
                c.into_iter().map(|v| v / s).collect()
            } else {
                uniform
            }
        }
        Err(_) => uniform,
    }
}

/// The observation model over the joint grid (sparse layout): soft counts stored by
/// measurement cell (row) as sorted `(state cell, count)` lists.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct JointObservation {
    gz: usize,
    gx: usize,
    rows: Vec<Vec<(u32, f64)>>,
    background: Background,
    /// Prior rows: `F[m, n]` as sorted lists (empty when the fallback is uniform).
    fallback_rows: Vec<Vec<(u32, f64)>>,
    uniform_fallback: bool,
    /// Per state cell: `(1 − ε) / (Σ_m C_eff[m, n] + α)`.
    inv: Vec<f64>,
    /// Background factor used for the current `inv` (0 unless subtracting).
    k: f64,
}

impl JointObservation {
    pub fn new(space: &Space, cfg: &CbtConfig) -> Self {
        let gx = space.cells();
        let gz: usize = (0..space.dims()).map(|d| space.meas_len(d)).product();
        let uniform_fallback = cfg.observation_fallback == ObservationFallback::Uniform;
        let mut fallback_rows = vec![Vec::new(); gz];
        if !uniform_fallback {
            let cols: Vec<Vec<Vec<f64>>> = (0..space.dims())
                .map(|d| {
                    (0..space.axis_len(d))
                        .map(|n| fallback_column_1d(space, d, n, cfg.observation_fallback))
                        .collect()
                })
                .collect();
            for n in 0..gx {
                let (nd, md) = split(space, n);
                for (m, f) in product_column(&cols, &nd, &md) {
                    fallback_rows[m].push((n as u32, f));
                }
            }
        }
        let mut o = JointObservation {
            gz,
            gx,
            rows: vec![Vec::new(); gz],
            background: Background::new(gz, gx),
            fallback_rows,
            uniform_fallback,
            inv: vec![0.0; gx],
            k: 0.0,
        };
        o.normalise(cfg);
        o
    }

    /// Consistency of a deserialised model with `space`.
    pub fn check(&self, space: &Space) -> Result<(), TrackError> {
        let gz: usize = (0..space.dims()).map(|d| space.meas_len(d)).product();
        len("joint observation rows", self.rows.len(), gz)?;
        len(
            "joint observation fallback rows",
            self.fallback_rows.len(),
            gz,
        )?;
        len(
            "joint observation normalisers",
            self.inv.len(),
            space.cells(),
        )?;
        if (self.gz, self.gx) != (gz, space.cells()) {
            return Err(corrupt("joint observation model sized for another space"));
        }
        for row in self.rows.iter().chain(&self.fallback_rows) {
            sparse("joint observation row", row, self.gx)?;
        }
        nonneg("joint observation normalisers", &self.inv)?;
        nonneg1("joint observation background factor", self.k)?;
        self.background.check(self.gz, self.gx)
    }

    pub fn add(&mut self, z: &Encoded, x: &Encoded) {
        for &(m, vz) in &z.joint {
            let row = &mut self.rows[m];
            for &(n, vx) in &x.joint {
                add_sorted(row, n as u32, vz * vx);
            }
        }
        self.background.add(&z.joint, &x.joint, x.count, z.count);
    }

    /// Recomputes the per-column normalisers (O(stored entries)).
    pub fn normalise(&mut self, cfg: &CbtConfig) {
        self.k = if cfg.clutter != Clutter::Model {
            self.background.scale()
        } else {
            0.0
        };
        let mut mass = vec![0.0; self.gx];
        for (m, row) in self.rows.iter().enumerate() {
            for &(n, c) in row {
                mass[n as usize] += self.effective(m, n, c);
            }
        }
        for (inv, m) in self.inv.iter_mut().zip(mass) {
            *inv = (1.0 - cfg.observation_floor) / (m + cfg.prior_weight);
        }
    }

    #[inline]
    fn effective(&self, m: usize, n: u32, c: f64) -> f64 {
        if self.k > 0.0 {
            (c - self.k * self.background.zsum[m] * self.background.xsum[n as usize]).max(0.0)
        } else {
            c
        }
    }

    /// `out[n] += w · Σ_m b_m O[m, n]` for the sparse joint measurement encoding `b`.
    pub fn add_likelihood(&self, b: &[(usize, f64)], cfg: &CbtConfig, out: &mut [f64]) {
        let alpha = cfg.prior_weight;
        let mut total = 0.0;
        for &(m, v) in b {
            total += v;
            for &(n, c) in &self.rows[m] {
                out[n as usize] += v * self.effective(m, n, c) * self.inv[n as usize];
            }
            for &(n, f) in &self.fallback_rows[m] {
                out[n as usize] += v * alpha * f * self.inv[n as usize];
            }
        }
        let floor = total * cfg.observation_floor / self.gz as f64;
        if self.uniform_fallback {
            let u = total * alpha / self.gz as f64;
            for (o, inv) in out.iter_mut().zip(&self.inv) {
                *o += u * inv + floor;
            }
        } else {
            out.iter_mut().for_each(|o| *o += floor);
        }
    }

    /// The learned share of clutter pairs.
    pub fn clutter_share(&self) -> f64 {
        self.background.clutter_share()
    }

    /// Number of measurement cells.
    pub fn meas_cells(&self) -> usize {
        self.gz
    }

    /// Number of stored (non-zero) counts.
    pub fn stored(&self) -> usize {
        self.rows.iter().map(Vec::len).sum()
    }
}

/// Adds `v` to entry `n` of a sorted sparse list.
pub(crate) fn add_sorted(list: &mut Vec<(u32, f64)>, n: u32, v: f64) {
    match list.binary_search_by_key(&n, |e| e.0) {
        Ok(i) => list[i].1 += v,
        Err(i) => list.insert(i, (n, v)),
    }
}

/// Per-axis channel indices of joint state cell `g` (and the per-axis lengths).
pub(crate) fn split(space: &Space, g: usize) -> ([usize; 2], [usize; 2]) {
    let dims = space.dims();
    let mut idx = [0; 2];
    let mut len = [1; 2];
    let mut rest = g;
    for d in (0..dims).rev() {
        len[d] = space.axis_len(d);
        idx[d] = rest % len[d];
        rest /= len[d];
    }
    (idx, len)
}

/// The non-zero entries of the outer product of per-axis columns `cols[d][idx[d]]`, as
/// `(joint measurement cell, value)`.
fn product_column(
    cols: &[Vec<Vec<f64>>],
    idx: &[usize; 2],
    _len: &[usize; 2],
) -> Vec<(usize, f64)> {
    let a = &cols[0][idx[0]];
    if cols.len() == 1 {
        return a
            .iter()
            .enumerate()
            .filter(|(_, v)| **v > 0.0)
            .map(|(m, v)| (m, *v))
            .collect();
    }
    let b = &cols[1][idx[1]];
    let nb = b.len();
    let mut out = Vec::new();
    for (i, &va) in a.iter().enumerate() {
        if va == 0.0 {
            continue;
        }
        for (j, &vb) in b.iter().enumerate() {
            if vb > 0.0 {
                out.push((i * nb + j, va * vb));
            }
        }
    }
    out
}
