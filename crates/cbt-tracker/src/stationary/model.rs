//! Shift-invariant ("stationary") CBT models ([`Layout::Stationary`](crate::Layout)): the same
//! correspondence-free soft counts as the dense models (docs/methods.md § Tracking), pooled
//! over the grid by displacement, so that a model depends on `m − n` (and `n − o`) only:
//!
//! ```text
//! observation:   C_o[δ]     = Σ_t Σ_{i,j} Σ_{m − n = δ} b_m(z_t^i) b_n(x_t^j)          (δ ∈ ℤ², joint)
//! first order:   C_1[δ]     = Σ_t Σ_{m − n = δ} a_t[m] a_{t−1}[n]                     (per axis)
//! second order:  C_2[δ, v]  = Σ_t Σ_{m − n = δ, n − o = v} a_t[m] a_{t−1}[n] a_{t−2}[o]  (per axis)
//! ```
//!
//! Pooling uses every training frame for every grid position, so the grid can be as fine as
//! the detection noise asks for (the dense `N × N × N` tensor grows with the cube of the
//! channel count; these models do not grow with it at all).
//!
//! **Observation model.** Wrong within-frame pairs (clutter) spread uniformly over all
//! displacements; the true pairs pile up near `δ = 0`. With `C_o` normalised per state and
//! unit detection mass, the mean `B` over a ring of displacements beyond the peak
//! (`obs_radius < |δ|∞ ≤ obs_radius + 4`) is the learned clutter density per measurement cell
//! and frame, and `A[δ] = max(C_o[δ] − B, 0)` (`|δ|∞ ≤ obs_radius`) is the detection
//! kernel, whose sum is the learned detection probability `P̂_D`. The likelihood of a frame's
//! detection set `Z` is then the clutter-aware mixture (one target, Poisson clutter):
//!
//! ```text
//! p(Z | x = x̃_n) ∝ (1 − P̂_D)·B + ε/G_z + Σ_i w_i Σ_m (b_m(z_i)/|b(z_i)|) A[m − n]
//! ```
//!
//! with the floor `ε` ([`CbtConfig::observation_floor`](crate::CbtConfig)).
//!
//! **System model.** Per axis, `S[δ] = (C_1[δ] + α·F[δ]) / (Σ C_1 + α)` with a Gaussian `F`
//! of `fallback_sigma` channels, and `T[·, v]` the same with the fallback column `S`
//! ([`SystemFallback::FirstOrder`]) or a Gaussian around `δ = v`
//! ([`SystemFallback::ConstantVelocity`]). Displacements are bounded by the radius `r` the
//! batch training data need (largest step + kernel support). With
//! [`Displacements::Interpolated`] (the image-tracking default) `C_2` counts the
//! displacements of the states' channel coordinates, linearly interpolated onto the integer
//! displacements, instead of the channel products above (whose shared smear of `a_{t−1}`
//! biases `T[· | v]` toward the bulk of the training velocities). With
//! [`StartMotion::Learned`] the first displacement of every run is also counted into `C_0`,
//! and `S_0[δ] = (C_0[δ] + α·N(δ; 0, σ_0²)) / (Σ C_0 + α)` with `σ_0` the root mean square
//! displacement of `S` predicts the first step after a start; with [`StartMotion::Pooled`]
//! every axis's first step uses the average of the axes' `S_0` ([`start_density`]).

use serde::{Deserialize, Serialize};

use crate::config::{CbtConfig, Displacements, StartMotion, SystemFallback};
use crate::encode::{Encoded, encode_states};
use crate::history::History;
use crate::integrity::{corrupt, len, nonneg, nonneg1};
use crate::observation_smoothing::{ObservationChoice, bilinear};
use crate::{Space, TrackError, TrainingFrame};

/// Width (channels) of the ring beyond the observation kernel that measures the clutter floor.
pub(crate) const RING: usize = 4;

/// Checks that a space suits the stationary layout: two axes whose state and measurement
/// bases are the same (detections and states share units and channels).
pub(crate) fn check_space(space: &Space) -> Result<(), TrackError> {
    if space.dims() != 2 {
        return Err(TrackError::Mismatch(
            "the stationary layout needs a 2-D space (image tracking)".into(),
        ));
    }
    for d in 0..2 {
        if space.state_basis(d).kernel() != crate::DEFAULT_KERNEL {
            return Err(TrackError::Mismatch(
                "the stationary layout needs the cos² kernel with a = π/3 (DEFAULT_KERNEL)".into(),
            ));
        }
        if space.state_basis(d) != space.meas_basis(d) {
            return Err(TrackError::Mismatch(format!(
                "the stationary layout needs the same state and measurement channels on axis {d}"
            )));
        }
    }
    Ok(())
}

/// The joint 2-D observation displacement model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct StatObservation {
    /// Kernel radius `R` (channels); counts cover `|δ|∞ ≤ R + RING`.
    radius: usize,
    /// Soft counts `C_o`, `[(δx + R')·(2R' + 1) + δy + R']` with `R' = R + RING`.
    counts: Vec<f64>,
    /// Exposure `E[δ]`: Σ over frames and states of (state mass × unit detection mass) ×
    /// [`x + δ` lies on the measurement grid]; clutter uniform over the grid gives counts
    /// `λ·E[δ]` (fewer pairs at displacements that leave the image from where targets are).
    #[serde(default)]
    exposure: Vec<f64>,
    /// Normaliser: Σ over frames of (state mass × unit detection mass).
    norm: f64,
    /// Measurement cells `G_z`.
    cells: usize,
    /// Measurement channels per axis.
    #[serde(default)]
    len: [usize; 2],
    /// Learned kernel `A`, truncated to radius `ra` (≤ R): `[(δx + ra)·(2ra + 1) + δy + ra]`.
    kernel: Vec<f64>,
    /// `A` point-reflected (reversed), for the filter's contiguous inner loop.
    flipped: Vec<f64>,
    /// `flipped` with its rows padded by `n − 1` zeros to the stride `2ra + n` of a bump
    /// built from a detection with `n = 1, 2, 3` active channels (derived; rebuilt after
    /// loading).
    #[serde(skip)]
    padded: [Vec<f64>; 3],
    ra: usize,
    /// Learned clutter density per cell and frame `B`.
    background: f64,
    /// Learned detection probability `P̂_D = Σ A` (clamped to `[0, 1]`).
    p_detect: f64,
    /// Likelihood floor `(1 − P̂_D)·B + ε/G_z`.
    floor: f64,
    /// The held-out choice of width, detection probability and clutter applied by
    /// [`Self::normalise`] (module `observation_smoothing`); `None`: as counted (and in files
    /// written before it existed).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    choice: Option<ObservationChoice>,
}

impl StatObservation {
    pub fn new(space: &Space, cfg: &CbtConfig) -> Self {
        let r = cfg.obs_radius + RING;
        let mut o = StatObservation {
            radius: cfg.obs_radius,
            counts: vec![0.0; (2 * r + 1) * (2 * r + 1)],
            exposure: vec![0.0; (2 * r + 1) * (2 * r + 1)],
            norm: 0.0,
            cells: space.cells(),
            len: [space.meas_len(0), space.meas_len(1)],
            kernel: Vec::new(),
            flipped: Vec::new(),
            padded: Default::default(),
            ra: 0,
            background: 0.0,
            p_detect: 0.0,
            floor: 0.0,
            choice: None,
        };
        o.normalise(cfg);
        o
    }

    /// Sets the choice [`Self::normalise`] applies (`None`: as counted).
    pub fn set_choice(&mut self, choice: Option<ObservationChoice>) {
        self.choice = choice;
    }

    /// The choice [`Self::normalise`] applies.
    pub fn choice(&self) -> Option<ObservationChoice> {
        self.choice
    }

    /// Adds another model's counts (same space and radius) to this one's.
    pub fn merge(&mut self, other: &StatObservation) {
        for (a, b) in self.counts.iter_mut().zip(&other.counts) {
            *a += b;
        }
        for (a, b) in self.exposure.iter_mut().zip(&other.exposure) {
            *a += b;
        }
        self.norm += other.norm;
    }

    /// Consistency of a deserialised model with `space`; fills the fields older files lack
    /// (`exposure`: zeros, as [`Self::normalise`] reads a missing one; `len`: the space's).
    pub fn check(&mut self, space: &Space) -> Result<(), TrackError> {
        // Checked before `radius + RING`, which overflowed for a radius near usize::MAX.
        if self.radius == 0 || self.radius > 1000 - RING {
            return Err(corrupt(format!(
                "observation kernel radius {} outside 1..=996",
                self.radius
            )));
        }
        let ro = self.radius + RING;
        let n = (2 * ro + 1) * (2 * ro + 1);
        if self.exposure.is_empty() {
            self.exposure = vec![0.0; n];
        }
        if self.len == [0, 0] {
            self.len = [space.meas_len(0), space.meas_len(1)];
        }
        len("observation measurement cells", self.cells, space.cells())?;
        if self.len != [space.meas_len(0), space.meas_len(1)] {
            return Err(corrupt(format!(
                "observation model of a {:?}-channel grid, the space has {:?}",
                self.len,
                [space.meas_len(0), space.meas_len(1)]
            )));
        }
        for (what, v) in [
            ("observation counts", &self.counts),
            ("observation exposure", &self.exposure),
        ] {
            len(what, v.len(), n)?;
            nonneg(what, v)?;
        }
        if self.ra > self.radius {
            return Err(corrupt(format!(
                "truncated kernel radius {} beyond the kernel radius {}",
                self.ra, self.radius
            )));
        }
        let k = (2 * self.ra + 1) * (2 * self.ra + 1);
        len("observation kernel", self.kernel.len(), k)?;
        nonneg("observation kernel", &self.kernel)?;
        if !self.flipped.iter().eq(self.kernel.iter().rev()) {
            return Err(corrupt(
                "the reflected observation kernel is not the kernel's",
            ));
        }
        self.rebuild_padded();
        if let Some(c) = &self.choice {
            c.validate()
                .map_err(|e| corrupt(format!("observation choice: {e}")))?;
        }
        for v in [self.norm, self.background, self.floor] {
            nonneg1("observation statistic", v)?;
        }
        if !(0.0..=1.0).contains(&self.p_detect) {
            return Err(corrupt(format!(
                "detection probability {} outside [0, 1]",
                self.p_detect
            )));
        }
        Ok(())
    }

    /// Adds every (detection, state) pair of one frame.
    pub fn add(&mut self, z: &Encoded, x: &Encoded) {
        let r = (self.radius + RING) as i64;
        let w = 2 * r + 1;
        // Per-element encodings: `Encoded` keeps the per-axis lists of all elements in order,
        // each element contributing a run of consecutive channels; split them back.
        let zs = elements(z);
        let xs = elements(x);
        for (zx, zy) in &zs {
            for (xx, xy) in &xs {
                for &(mx, vmx) in *zx {
                    for &(nx, vnx) in *xx {
                        let dx = mx as i64 - nx as i64;
                        if dx.abs() > r {
                            continue;
                        }
                        let row = (dx + r) * w + r;
                        let vx = vmx * vnx;
                        for &(my, vmy) in *zy {
                            for &(ny, vny) in *xy {
                                let dy = my as i64 - ny as i64;
                                if dy.abs() <= r {
                                    self.counts[(row + dy) as usize] += vx * vmy * vny;
                                }
                            }
                        }
                    }
                }
            }
        }
        let mut xmass = 0.0;
        for (a, b) in &xs {
            let (ma, mb) = (
                a.iter().map(|e| e.1).sum::<f64>(),
                b.iter().map(|e| e.1).sum::<f64>(),
            );
            xmass += ma * mb;
            if ma <= 0.0 || mb <= 0.0 {
                continue;
            }
            // The state's channel coordinates (first moment of its run) and the box of
            // displacements that stay on the grid from there.
            let c = [
                a.iter().map(|e| e.0 as f64 * e.1).sum::<f64>() / ma,
                b.iter().map(|e| e.0 as f64 * e.1).sum::<f64>() / mb,
            ];
            let e = ma * mb * UNIT_MASS * UNIT_MASS;
            let lo: Vec<i64> = (0..2).map(|d| (-c[d].round() as i64).max(-r)).collect();
            let hi: Vec<i64> = (0..2)
                .map(|d| ((self.len[d] as f64 - 1.0 - c[d]).round() as i64).min(r))
                .collect();
            for dx in lo[0]..=hi[0] {
                let row = &mut self.exposure[((dx + r) * w) as usize..((dx + r + 1) * w) as usize];
                for v in &mut row[(lo[1] + r) as usize..=(hi[1] + r) as usize] {
                    *v += e;
                }
            }
        }
        // Per state and unit detection (mass 1.5 per axis of a cos² vector with m = 3).
        self.norm += xmass * UNIT_MASS * UNIT_MASS;
    }

    /// Recomputes `A`, `B`, `P̂_D` and the floor from the counts.
    pub fn normalise(&mut self, cfg: &CbtConfig) {
        let r = self.radius;
        let ro = r + RING;
        let w = 2 * ro + 1;
        let inv = if self.norm > 0.0 {
            1.0 / self.norm
        } else {
            0.0
        };
        // λ (clutter per cell and frame) from the ring: counts over exposure.
        let (mut ring, mut ring_e) = (0.0, 0.0);
        for i in 0..w {
            for j in 0..w {
                let d = (i as i64 - ro as i64)
                    .abs()
                    .max((j as i64 - ro as i64).abs()) as usize;
                if d > r {
                    ring += self.counts[i * w + j];
                    ring_e += self.exposure.get(i * w + j).copied().unwrap_or(0.0);
                }
            }
        }
        self.background = if ring_e > 0.0 { ring / ring_e } else { 0.0 };
        let kw = 2 * r + 1;
        let mut a = vec![0.0; kw * kw];
        for i in 0..kw {
            for j in 0..kw {
                let k = (i + RING) * w + j + RING;
                let e = self.exposure.get(k).copied().unwrap_or(0.0);
                a[i * kw + j] = (self.counts[k] - self.background * e) * inv;
            }
        }
        if let Some(c) = self.choice {
            self.background *= c.clutter_scale;
            if c.width_scale != 1.0 {
                // A_s(δ) = A(δ/s)/s², read bilinearly (a linear map: the noise of both
                // signs stays for the spread measure below).
                let s = c.width_scale;
                let src = a.clone();
                for i in 0..kw {
                    for j in 0..kw {
                        let (dx, dy) = (i as f64 - r as f64, j as f64 - r as f64);
                        a[i * kw + j] = bilinear(&src, r, dx / s, dy / s) / (s * s);
                    }
                }
            }
        }
        let total: f64 = a.iter().map(|v| v.max(0.0)).sum();
        if total <= 0.0 {
            // Untrained: an ideal sensor (the autocorrelation of the cos² kernel at δ = 0 is
            // approximated by a unit spike) detecting with probability 1 − ε.
            a.iter_mut().for_each(|v| *v = 0.0);
            a[r * kw + r] = 1.0 - cfg.observation_floor;
        }
        // Truncate to 3 standard deviations of the kernel (and one channel): beyond the
        // detection noise, `max(C − B, 0)` would keep only the positive half of the clutter
        // counts' noise, widening the kernel and inflating `P̂_D`. The spread is measured on
        // `C − B` (noise of both signs, averaging out) within the current radius, starting
        // small and growing while the truncated spread asks for more.
        let mut ra = r.min(3);
        for _ in 0..8 {
            let (mut m, mut sx, mut sy, mut sxx, mut syy) = (0.0, 0.0, 0.0, 0.0, 0.0);
            for i in r - ra..=r + ra {
                for j in r - ra..=r + ra {
                    let v = a[i * kw + j];
                    let (x, y) = (i as f64 - r as f64, j as f64 - r as f64);
                    m += v;
                    sx += v * x;
                    sy += v * y;
                    sxx += v * x * x;
                    syy += v * y * y;
                }
            }
            if m <= 0.0 {
                break;
            }
            let var = (sxx / m - (sx / m).powi(2)).max(syy / m - (sy / m).powi(2));
            let next = ((3.0 * var.max(0.0).sqrt()).ceil() as usize + 1).min(r);
            if next == ra {
                break;
            }
            ra = next;
        }
        a.iter_mut().for_each(|v| *v = v.max(0.0));
        let total: f64 = (r - ra..=r + ra)
            .flat_map(|i| (r - ra..=r + ra).map(move |j| (i, j)))
            .map(|(i, j)| a[i * kw + j])
            .sum();
        let aw = 2 * ra + 1;
        self.kernel = (0..aw)
            .flat_map(|i| (0..aw).map(move |j| (i, j)))
            .map(|(i, j)| a[(i + r - ra) * kw + j + r - ra])
            .collect();
        self.ra = ra;
        self.p_detect = total.clamp(0.0, 1.0);
        if let Some(c) = self.choice {
            if total > 0.0 {
                let f = c.p_detect / total;
                self.kernel.iter_mut().for_each(|v| *v *= f);
            }
            self.p_detect = c.p_detect;
        }
        self.flipped = self.kernel.iter().rev().copied().collect();
        self.rebuild_padded();
        self.floor =
            (1.0 - self.p_detect) * self.background + cfg.observation_floor / self.cells as f64;
    }

    /// Rebuilds the padded copies of the reflected kernel.
    fn rebuild_padded(&mut self) {
        let kw = 2 * self.ra + 1;
        for (n, p) in self.padded.iter_mut().enumerate() {
            p.clear();
            for row in self.flipped.chunks_exact(kw) {
                p.extend_from_slice(row);
                p.extend(std::iter::repeat_n(0.0, n));
            }
        }
    }

    /// The reflected kernel with rows padded to the stride `2ra + n` (`n = 1..=3`).
    pub fn padded_kernel(&self, n: usize) -> &[f64] {
        &self.padded[n - 1]
    }

    /// The learned kernel `A` (radius [`Self::kernel_radius`]), row-major over `(δx, δy)`.
    pub fn kernel(&self) -> &[f64] {
        &self.kernel
    }

    /// Radius of the truncated kernel.
    pub fn kernel_radius(&self) -> usize {
        self.ra
    }

    /// The likelihood floor `(1 − P̂_D)·B + ε/G_z`.
    pub fn floor(&self) -> f64 {
        self.floor
    }

    /// Learned detection probability.
    pub fn p_detect(&self) -> f64 {
        self.p_detect
    }

    /// Learned clutter density per measurement cell and frame.
    pub fn background(&self) -> f64 {
        self.background
    }
}

/// Mass of one unit cos² (`m = 3`) channel vector on one axis away from the grid ends.
pub(crate) const UNIT_MASS: f64 = 1.5;

/// One encoded element's per-axis channel runs.
type Element<'a> = (&'a [(usize, f64)], &'a [(usize, f64)]);

/// Per element of an encoded set: its channel coordinate on axis `d` (the first moment of its
/// channel run) and the run's mass.
pub(crate) fn coordinates(e: &Encoded, d: usize) -> Vec<(f64, f64)> {
    elements(e)
        .into_iter()
        .map(|el| if d == 0 { el.0 } else { el.1 })
        .filter_map(|run| {
            let m: f64 = run.iter().map(|e| e.1).sum();
            (m > 0.0).then(|| (run.iter().map(|e| e.0 as f64 * e.1).sum::<f64>() / m, m))
        })
        .collect()
}

/// The two integers nearest `x`, each with its linear-interpolation weight.
fn split(x: f64) -> [(i64, f64); 2] {
    let lo = x.floor();
    let f = x - lo;
    [(lo as i64, 1.0 - f), (lo as i64 + 1, f)]
}

/// Per axis, the slope of [`Displacements::Fitted`]: the least-squares slope of a step's
/// displacement `δ` on its previous displacement's offset `f = u − c` from the column `c` it is
/// counted in (the two nearest integers of `u`, linearly weighted, as
/// [`StatSystem::add_points_second`] counts), pooled within the columns over every triple of
/// consecutive frames with states in `sequences`:
/// `b = Σ_c (Σm·f·δ − Σm·f·Σm·δ/Σm) / Σ_c (Σm·f² − (Σm·f)²/Σm)`. `None` for an axis without
/// spread of the offsets to fit on.
pub(crate) fn fitted_slopes(
    space: &Space,
    sequences: &[Vec<TrainingFrame>],
) -> Result<[Option<f64>; 2], TrackError> {
    // Per axis and column: [Σm, Σm·f, Σm·f², Σm·δ, Σm·f·δ].
    let mut moments: [std::collections::BTreeMap<i64, [f64; 5]>; 2] = Default::default();
    for seq in sequences {
        // The frames chained into triples as `CbtModel::learn` chains them.
        let mut h = History::default();
        for f in seq {
            let x = encode_states(space, &f.states, 1.0, false)?;
            let (prev, prev2) = h.take();
            if let (false, Some(a), Some(b)) = (x.is_empty(), &prev, &prev2) {
                for (d, m) in moments.iter_mut().enumerate() {
                    for &(un, mn) in &coordinates(a, d) {
                        for &(um, mm) in &coordinates(&x, d) {
                            for &(uo, mo) in &coordinates(b, d) {
                                let (u, delta) = (un - uo, um - un);
                                for (c, w) in split(u) {
                                    if w <= 0.0 {
                                        continue;
                                    }
                                    let (w, f) = (mm * mn * mo * w, u - c as f64);
                                    let o = m.entry(c).or_default();
                                    o[0] += w;
                                    o[1] += w * f;
                                    o[2] += w * f * f;
                                    o[3] += w * delta;
                                    o[4] += w * f * delta;
                                }
                            }
                        }
                    }
                }
            }
            h.push(&f.states, x, prev);
        }
    }
    Ok(moments.map(|m| {
        let (mut num, mut den, mut mass) = (0.0, 0.0, 0.0);
        for o in m.values() {
            num += o[4] - o[1] * o[3] / o[0];
            den += o[2] - o[1] * o[1] / o[0];
            mass += o[0];
        }
        let b = num / den;
        (den > 1e-12 * mass && b.is_finite()).then_some(b)
    }))
}

/// Per element of an encoded set: its per-axis channel runs, each divided by its mass (unit
/// sum; an axis without mass gives an empty run).
pub(crate) fn coordinate_runs(e: &Encoded) -> Vec<[Vec<(usize, f64)>; 2]> {
    let unit = |run: &[(usize, f64)]| -> Vec<(usize, f64)> {
        let m: f64 = run.iter().map(|e| e.1).sum();
        if m > 0.0 {
            run.iter().map(|&(k, v)| (k, v / m)).collect()
        } else {
            Vec::new()
        }
    };
    elements(e)
        .into_iter()
        .map(|(a, b)| [unit(a), unit(b)])
        .collect()
}

/// Splits an encoded set back into its elements' per-axis channel runs.
fn elements(e: &Encoded) -> Vec<Element<'_>> {
    let mut start = [0usize; 2];
    e.ends
        .iter()
        .map(|end| {
            let el = (&e.axes[0][start[0]..end[0]], &e.axes[1][start[1]..end[1]]);
            start = *end;
            el
        })
        .collect()
}

/// The per-axis system model: first-order displacement distribution `S[δ]` and second-order
/// `T[δ | v]` for `δ, v ∈ [−r, r]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct StatSystem {
    r: usize,
    c1: Vec<f64>,
    /// `[(v + r)·(2r + 1) + δ + r]`.
    c2: Vec<f64>,
    s1: Vec<f64>,
    t: Vec<f64>,
    /// Start counts `C₀[δ]`: the first displacement of every run of frames with states
    /// ([`StartMotion::Learned`]; empty otherwise, and in files written before it existed).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    c0: Vec<f64>,
    /// The start density `S₀` (normalised `C₀`, [`StartMotion::Learned`]; empty otherwise).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    s0: Vec<f64>,
    /// The slope `b` of [`Displacements::Fitted`] for this axis, fitted on the batch of
    /// training runs ([`fitted_slopes`]); `None` otherwise (and without a batch, or without
    /// spread to fit on).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    slope: Option<f64>,
    /// Per `v`: the range `[lo, hi)` of `δ + r` outside which `T[· | v]` holds at most
    /// [`BAND_TAIL`] of its mass (derived from `t`; rebuilt after loading).
    #[serde(skip)]
    band: Vec<(u32, u32)>,
    /// `T` with each column zeroed outside its band and padded with zeros to
    /// [`Self::banded_stride`] (derived; rebuilt with the bands).
    #[serde(skip)]
    banded: Vec<f64>,
}

/// The band `[lo, hi)` of `v` outside which each tail holds at most `share` of its mass
/// (at least one entry kept).
pub(crate) fn tail_band(v: &[f64], share: f64) -> (usize, usize) {
    let cut = share * v.iter().sum::<f64>();
    let (mut lo, mut hi, mut acc) = (0, v.len(), 0.0);
    while lo + 1 < hi && acc + v[lo] <= cut {
        acc += v[lo];
        lo += 1;
    }
    acc = 0.0;
    while hi > lo + 1 && acc + v[hi - 1] <= cut {
        acc += v[hi - 1];
        hi -= 1;
    }
    (lo, hi)
}

/// The displacement distribution of the first step after a start on axis `d` (`δ = i − r_d`):
/// the axis's own [`StatSystem::start`], or with [`StartMotion::Pooled`] the average over the
/// axes of theirs, aligned by displacement, cut to axis `d`'s radius and renormalised.
pub(crate) fn start_density(sys: &[StatSystem], d: usize, start: StartMotion) -> Vec<f64> {
    let own = sys[d].start();
    if start != StartMotion::Pooled || sys.len() < 2 {
        return own.to_vec();
    }
    let r = sys[d].r as i64;
    let mut out = vec![0.0; own.len()];
    for s in sys {
        let (rs, v) = (s.r as i64, s.start());
        for (i, o) in out.iter_mut().enumerate() {
            let j = i as i64 - r + rs;
            if (0..v.len() as i64).contains(&j) {
                *o += v[j as usize];
            }
        }
    }
    let total: f64 = out.iter().sum();
    if total > 0.0 {
        out.iter_mut().for_each(|x| *x /= total);
    } else {
        out.copy_from_slice(own);
    }
    out
}

/// Mass share of `T[· | v]` the prediction may skip in each tail of a column.
const BAND_TAIL: f64 = 1e-9;

impl StatSystem {
    pub fn new(r: usize, cfg: &CbtConfig) -> Self {
        let w = 2 * r + 1;
        let mut s = StatSystem {
            r,
            c1: vec![0.0; w],
            c2: vec![0.0; w * w],
            s1: vec![0.0; w],
            t: vec![0.0; w * w],
            c0: if cfg.start.is_learned() {
                vec![0.0; w]
            } else {
                Vec::new()
            },
            s0: Vec::new(),
            slope: None,
            band: Vec::new(),
            banded: Vec::new(),
        };
        s.normalise(cfg);
        s
    }

    /// Consistency of a deserialised model with its configuration (and its derived bands
    /// rebuilt).
    pub fn check(&mut self, cfg: &CbtConfig) -> Result<(), TrackError> {
        let w = self
            .r
            .checked_mul(2)
            .and_then(|v| v.checked_add(1))
            .filter(|&w| w <= 1 << 15)
            .ok_or_else(|| corrupt(format!("displacement radius {} too large", self.r)))?;
        for (what, v, n) in [
            ("first-order displacement counts", &self.c1, w),
            ("first-order displacement model", &self.s1, w),
            ("second-order displacement counts", &self.c2, w * w),
            ("second-order displacement model", &self.t, w * w),
        ] {
            len(what, v.len(), n)?;
            nonneg(what, v)?;
        }
        let learned = cfg.start.is_learned();
        for (what, v) in [("start counts", &self.c0), ("start density", &self.s0)] {
            if learned {
                len(what, v.len(), w)?;
                nonneg(what, v)?;
            } else if !v.is_empty() {
                return Err(corrupt(format!(
                    "{what} in a model whose start motion is the marginal"
                )));
            }
        }
        match self.slope {
            Some(b) if !b.is_finite() => {
                return Err(corrupt(format!("fitted slope {b} is not finite")));
            }
            Some(_) if cfg.displacements != Displacements::Fitted => {
                return Err(corrupt(
                    "a fitted slope in a model whose displacements are not fitted",
                ));
            }
            _ => {}
        }
        self.rebuild_bands();
        Ok(())
    }

    /// Sets the slope of [`Displacements::Fitted`] (before any frame is counted).
    pub fn set_slope(&mut self, slope: Option<f64>) {
        self.slope = slope;
    }

    /// Radius `r`.
    pub fn radius(&self) -> usize {
        self.r
    }

    /// Adds `a_t ⊗ a_{t−1}` (and `⊗ a_{t−2}`) by displacement; without `a_{t−2}` (the first
    /// step of a run) also to the start counts, when kept.
    pub fn add(
        &mut self,
        now: &[(usize, f64)],
        prev: &[(usize, f64)],
        prev2: Option<&[(usize, f64)]>,
    ) {
        self.add_first(now, prev, prev2.is_none());
        let Some(p2) = prev2 else { return };
        let r = self.r as i64;
        let w = 2 * r + 1;
        for &(n, vn) in prev {
            for &(m, vm) in now {
                let d = m as i64 - n as i64;
                if d.abs() > r {
                    continue;
                }
                for &(o, vo) in p2 {
                    let v = n as i64 - o as i64;
                    if v.abs() <= r {
                        self.c2[((v + r) * w + d + r) as usize] += vm * vn * vo;
                    }
                }
            }
        }
    }

    /// Adds `a_t ⊗ a_{t−1}` by displacement to `C_1` and, for the first step of a run
    /// (`start`), to the start counts when kept.
    fn add_first(&mut self, now: &[(usize, f64)], prev: &[(usize, f64)], start: bool) {
        let r = self.r as i64;
        let start = start && !self.c0.is_empty();
        for &(n, vn) in prev {
            for &(m, vm) in now {
                let d = m as i64 - n as i64;
                if d.abs() > r {
                    continue;
                }
                self.c1[(d + r) as usize] += vm * vn;
                if start {
                    self.c0[(d + r) as usize] += vm * vn;
                }
            }
        }
    }

    /// Adds one transition of axis `d` (the states of a frame, the previous frame and, when
    /// it had states, the one before) as [`CbtConfig::displacements`] says.
    pub fn add_frames(
        &mut self,
        cfg: &CbtConfig,
        d: usize,
        now: &Encoded,
        prev: &Encoded,
        prev2: Option<&Encoded>,
    ) {
        match cfg.displacements {
            Displacements::Channels => {
                self.add(&now.axes[d], &prev.axes[d], prev2.map(|p| &p.axes[d][..]))
            }
            // `Selected` is resolved by `CbtModel::learn`, and `Fitted`'s slope fitted there; a
            // model built otherwise counts as interpolated.
            Displacements::Interpolated
            | Displacements::Aligned
            | Displacements::Selected
            | Displacements::Fitted => {
                // S and S₀ from the channel products (their smear is a symmetric widening,
                // no bias), T from the coordinates.
                self.add_first(&now.axes[d], &prev.axes[d], prev2.is_none());
                if let Some(p2) = prev2 {
                    let shift = match cfg.displacements {
                        Displacements::Aligned => Some(1.0),
                        Displacements::Fitted => self.slope,
                        _ => None,
                    };
                    self.add_points_second(
                        &coordinates(now, d),
                        &coordinates(prev, d),
                        &coordinates(p2, d),
                        shift,
                    );
                }
            }
        }
    }

    /// Adds the second-order displacements of states given as `(channel coordinate, mass)`
    /// per element ([`Displacements::Interpolated`](crate::Displacements)): every triple of
    /// elements of three consecutive frames, with the product of their masses, at the four
    /// nearest integer `(v, δ)` pairs by linear interpolation. With a `shift` `b`
    /// ([`Displacements::Aligned`](crate::Displacements): 1; `Fitted`: the fitted slope) a
    /// triple counted in column `v` is counted at `δ − b·(u − v)` (`u` its previous
    /// displacement), split linearly likewise.
    pub fn add_points_second(
        &mut self,
        now: &[(f64, f64)],
        prev: &[(f64, f64)],
        prev2: &[(f64, f64)],
        shift: Option<f64>,
    ) {
        let r = self.r as i64;
        let w = (2 * r + 1) as usize;
        // The two nearest integer displacements of `x` with their weights.
        if let Some(b) = shift {
            for &(un, mn) in prev {
                for &(um, mm) in now {
                    for &(uo, mo) in prev2 {
                        let u = un - uo;
                        for (v, wv) in split(u) {
                            if v.abs() > r || wv <= 0.0 {
                                continue;
                            }
                            for (d, wd) in split(um - un - b * (u - v as f64)) {
                                if d.abs() <= r && wd > 0.0 {
                                    self.c2[(v + r) as usize * w + (d + r) as usize] +=
                                        mm * mn * mo * wd * wv;
                                }
                            }
                        }
                    }
                }
            }
            return;
        }
        for &(un, mn) in prev {
            for &(um, mm) in now {
                for (d, wd) in split(um - un) {
                    if d.abs() > r || wd <= 0.0 {
                        continue;
                    }
                    for &(uo, mo) in prev2 {
                        for (v, wv) in split(un - uo) {
                            if v.abs() <= r && wv > 0.0 {
                                self.c2[(v + r) as usize * w + (d + r) as usize] +=
                                    mm * mn * mo * wd * wv;
                            }
                        }
                    }
                }
            }
        }
    }

    /// Recomputes the normalised `S` and `T` with their Dirichlet fallbacks.
    pub fn normalise(&mut self, cfg: &CbtConfig) {
        let (r, alpha) = (self.r, cfg.prior_weight);
        let w = 2 * r + 1;
        let gauss = |centre: i64| gaussian(w, r, centre, cfg.fallback_sigma);
        let g0 = gauss(0);
        let m1: f64 = self.c1.iter().sum();
        for ((s1, &c), &g) in self.s1.iter_mut().zip(&self.c1).zip(&g0) {
            *s1 = (c + alpha * g) / (m1 + alpha);
        }
        if cfg.start.is_learned() {
            // The broad prior: zero mean, as wide as S's root mean square displacement.
            let m2: f64 = self
                .s1
                .iter()
                .enumerate()
                .map(|(i, &p)| p * (i as f64 - r as f64).powi(2))
                .sum();
            let f = gaussian(w, r, 0, m2.sqrt().max(cfg.fallback_sigma));
            let m0: f64 = self.c0.iter().sum();
            self.s0 = self
                .c0
                .iter()
                .zip(&f)
                .map(|(&c, &g)| (c + alpha * g) / (m0 + alpha))
                .collect();
        } else {
            self.s0.clear();
        }
        for v in 0..w {
            let col = &self.c2[v * w..(v + 1) * w];
            let mass: f64 = col.iter().sum();
            let f = match cfg.system_fallback {
                SystemFallback::FirstOrder => self.s1.clone(),
                SystemFallback::ConstantVelocity => gauss(v as i64 - r as i64),
            };
            for i in 0..w {
                self.t[v * w + i] = (col[i] + alpha * f[i]) / (mass + alpha);
            }
        }
        self.rebuild_bands();
    }

    /// Recomputes the columns' bands from `T`.
    pub fn rebuild_bands(&mut self) {
        let w = 2 * self.r + 1;
        self.band.clear();
        for col in self.t.chunks_exact(w) {
            let (lo, hi) = tail_band(col, BAND_TAIL);
            self.band.push((lo as u32, hi as u32));
        }
        let stride = self.banded_stride();
        self.banded.clear();
        self.banded.resize(w * stride, 0.0);
        for (v, col) in self.t.chunks_exact(w).enumerate() {
            let (lo, hi) = self.band(v);
            self.banded[v * stride + lo..v * stride + hi].copy_from_slice(&col[lo..hi]);
        }
    }

    /// Column stride of [`Self::banded`]: `2r + 1` rounded up to a multiple of 16.
    pub fn banded_stride(&self) -> usize {
        (2 * self.r + 1).div_ceil(16) * 16
    }

    /// `T` with each column `v + r` zeroed outside its [band](Self::band), columns at
    /// [`Self::banded_stride`] (zero-padded).
    pub fn banded(&self) -> &[f64] {
        &self.banded
    }

    /// The band `[lo, hi)` of column `v + r` of `T` (the whole column when not built).
    #[inline]
    pub fn band(&self, vi: usize) -> (usize, usize) {
        self.band
            .get(vi)
            .map_or((0, 2 * self.r + 1), |&(lo, hi)| (lo as usize, hi as usize))
    }

    /// `S[δ]`, `δ = i − r`.
    pub fn first(&self) -> &[f64] {
        &self.s1
    }

    /// The displacement distribution of the first step after a start, `δ = i − r`: the
    /// start density `S₀` ([`StartMotion::Learned`]) or `S`.
    pub fn start(&self) -> &[f64] {
        if self.s0.is_empty() {
            &self.s1
        } else {
            &self.s0
        }
    }

    /// `T[δ | v]`, `[(v + r)·(2r + 1) + δ + r]`.
    pub fn second(&self) -> &[f64] {
        &self.t
    }
}

/// A normalised Gaussian of `sigma` channels around `centre` over the displacements `−r..=r`
/// (`w = 2r + 1` entries).
fn gaussian(w: usize, r: usize, centre: i64, sigma: f64) -> Vec<f64> {
    let mut g: Vec<f64> = (0..w as i64)
        .map(|i| {
            let d = (i - r as i64 - centre) as f64;
            (-d * d / (2.0 * sigma * sigma)).exp()
        })
        .collect();
    let s: f64 = g.iter().sum();
    g.iter_mut().for_each(|v| *v /= s);
    g
}

/// Displacement radius (channels) the training data need: the largest step of a state to the
/// nearest state of the previous frame, plus the kernel support and one channel of margin.
pub(crate) fn motion_radius(
    space: &Space,
    sequences: &[Vec<TrainingFrame>],
    cfg: &CbtConfig,
) -> usize {
    let mut max = 0.0f64;
    for seq in sequences {
        for w in seq.windows(2) {
            for s in &w[1].states {
                let near = w[0]
                    .states
                    .iter()
                    .map(|p| {
                        (0..2)
                            .map(|d| ((s[d] - p[d]) / space.state_basis(d).spacing()).abs())
                            .fold(0.0, f64::max)
                    })
                    .fold(f64::INFINITY, f64::min);
                if near.is_finite() {
                    max = max.max(near);
                }
            }
        }
    }
    // Saturating: an off-grid state (refused later, when it is counted) or a huge
    // `fallback_sigma` must not overflow here; the radius is capped anyway.
    let r = (max.ceil() as usize).saturating_add(3);
    r.max(sigma_radius(cfg.fallback_sigma)).min(96)
}

/// The displacement radius a Gaussian fallback of `sigma` channels needs, `⌈3σ⌉ + 1`
/// (saturating: a huge `sigma` gives `usize::MAX`, never an overflow).
pub(crate) fn sigma_radius(sigma: f64) -> usize {
    ((3.0 * sigma).ceil() as usize).saturating_add(1)
}
