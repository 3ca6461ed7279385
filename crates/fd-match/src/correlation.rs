//! Correlation matching of two FDs (Paper A, eq. 9–12) with accurate peak location.
//!
//! For normalised FDs `C₁, C₂` the correlation
//!
//! ```text
//! r₁₂(θ) = Σ_{0<|n|≤K} conj(C₁(n)) · C₂(n) · e^{inθ},      θ = 2π l / L
//! ```
//!
//! is a trigonometric polynomial of degree `K`. The least-squares error over rotations and
//! start-point shifts is `e = 2 − 2 max_θ |r₁₂(θ)|` (eq. 10), the shift is `Δl = L·θ*/2π`
//! (eq. 11) and the rotation `φ = arg r₁₂(θ*)` (eq. 12), for `c₂(l) = e^{iφ} c₁(l − Δl)`.
//!
//! **Finding the maximum.** `r₁₂` is evaluated on a grid of `M` points by one zero-padded
//! inverse FFT (`M` = 2 × the next power of two ≥ 2K + 1, i.e. 128 for K = 25). The best sample
//! is refined by Newton's method on the exact polynomial (derivatives summed directly, `O(K)`
//! per step, started at the vertex of the parabola through three samples). Every peak of
//! `f = |r₁₂|²` lies within half a grid step of a sample whose value is at most
//! `B = S₀S₂·(π/M)²` below it, so every
//! other sample with value above `best − B` is refined too (unless a refinement already
//! converged within half a step of it). Hence the returned maximum is the global maximum of
//! the truncated series up to Newton convergence: `θ*` to ~1e-13 rad and `e` to ~1e-14
//! (rounding), not to the grid spacing (one caveat: a second peak closer than 1.5 grid steps,
//! 0.07 rad, to a refined one is taken to be the same lobe). On 40,000 random pairs the result
//! equals that of a 4096-point grid to 2e-15.
//!
//! *Why `B`:* at a peak `θ*`, `f' = 0`, so a sample at distance `δ ≤ π/M` has
//! `f(θ*) = f(θ_j) − ½f''(ξ)δ²`, and only a negative `f''` lowers the sample: with
//! `f'' = 2 Re(r'' r̄) + 2|r'|²`, `−½f'' ≤ |r''||r| − |r'|² ≤ S₂S₀`, where
//! `S_j = Σ |n|^j |C₁(n)C₂(n)|` bounds `|r^{(j)}|`. (The bound of `|f''|/2` in both directions,
//! `S₁² + S₀S₂`, was used before; dropping `|r'|² ≥ 0` roughly halves the slack, and with it the
//! pairs the screening grid cannot decide.) The unit tests check this against a dense 2¹⁴-point
//! evaluation (found peak ≥ dense peak − 1e-12) and recover an exactly applied sub-sample
//! shift to 1e-9 samples and rotation to 1e-12 rad.

use std::f64::consts::PI;
use std::sync::Arc;

use rustfft::num_complex::Complex64;
use rustfft::{Fft, FftPlanner};
use serde::{Deserialize, Serialize};

use crate::descriptor::{MAX_SAMPLES, UNIT_NORM_TOLERANCE, fd_frequency_unchecked};
use crate::error::FdError;

/// The rigid part of a correlation match: `c₂(l) ≈ e^{iφ} c₁(l − Δl)` after normalisation.
///
/// Deserialisation checks the ranges the correlator produces: a rotation outside `[−π, π]`
/// or a shift outside `[0, MAX_SAMPLES)` (or either not finite) is an error
/// ([`FdError::InvalidParameter`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "AlignmentSpec")]
pub struct Alignment {
    /// `φ` in `(−π, π]` (`arg` of the correlation peak; `−π` itself when its imaginary part is
    /// `−0`): rotation (radians, counter-clockwise in a y-up frame) taking the first contour to
    /// the second (eq. 12).
    pub rotation: f64,
    /// `Δl` in `[0, L)`: start-point shift in samples of the resampled contour (eq. 11),
    /// sub-sample accurate.
    pub shift: f64,
}

/// The serialised form of an [`Alignment`], range-checked on deserialisation.
#[derive(Deserialize)]
struct AlignmentSpec {
    rotation: f64,
    shift: f64,
}

impl TryFrom<AlignmentSpec> for Alignment {
    type Error = FdError;
    fn try_from(s: AlignmentSpec) -> Result<Self, FdError> {
        // NaN fails both range tests.
        if !(-PI..=PI).contains(&s.rotation) {
            return Err(FdError::InvalidParameter {
                name: "rotation",
                value: s.rotation,
                reason: "an alignment's rotation lies in [-π, π]",
            });
        }
        if !(0.0..MAX_SAMPLES as f64).contains(&s.shift) {
            return Err(FdError::InvalidParameter {
                name: "shift",
                value: s.shift,
                reason: "an alignment's shift lies in [0, MAX_SAMPLES) samples",
            });
        }
        Ok(Alignment {
            rotation: s.rotation,
            shift: s.shift,
        })
    }
}

/// Result of [`Correlator::correlate`].
///
/// Deserialisation checks what the correlator produces ([`FdError::InvalidParameter`]
/// naming the field otherwise): a peak in `[0, (1 + UNIT_NORM_TOLERANCE)²]` (the largest
/// `|r₁₂|` of two FDs of unit norm within [`crate::UNIT_NORM_TOLERANCE`]), an error finite,
/// `≥ 0` and equal to `max(2 − 2·peak, 0)` to within `1e-9`, and the alignment's ranges
/// ([`Alignment`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "CorrelationSpec")]
pub struct Correlation {
    /// `e = max(2 − 2 max |r₁₂|, 0)` in `[0, 2]` (eq. 10), as `max |r₁₂|` lies in `[0, 1]` up to
    /// rounding; 0 for identical shapes, up to rounding.
    pub error: f64,
    /// `max |r₁₂|`, in `[0, 1]` up to rounding: for (nearly) identical shapes it can lie a few
    /// ulps above 1 (the error is then clamped to 0).
    pub peak: f64,
    /// Rotation and shift at the maximum.
    pub alignment: Alignment,
}

/// The serialised form of a [`Correlation`] (the same fields), checked on deserialisation.
#[derive(Deserialize)]
struct CorrelationSpec {
    error: f64,
    peak: f64,
    alignment: Alignment,
}

impl TryFrom<CorrelationSpec> for Correlation {
    type Error = FdError;
    fn try_from(s: CorrelationSpec) -> Result<Self, FdError> {
        // `|r₁₂| ≤ ‖C₁‖‖C₂‖` (Cauchy–Schwarz), each norm within the tolerance of 1; NaN fails
        // the range test.
        let max_peak = (1.0 + UNIT_NORM_TOLERANCE).powi(2) + ROUNDING_MARGIN;
        if !(0.0..=max_peak).contains(&s.peak) {
            return Err(FdError::InvalidParameter {
                name: "peak",
                value: s.peak,
                reason: "a correlation peak max |r12| of unit-norm FDs lies in [0, 1] (within the unit-norm tolerance)",
            });
        }
        crate::search::check_pair_error(s.error)?;
        // The error is computed from the peak (eq. 10); a text round trip may move either by
        // an ulp, far below the margin.
        if (s.error - correlation_error(s.peak)).abs() > ROUNDING_MARGIN {
            return Err(FdError::InvalidParameter {
                name: "error",
                value: s.error,
                reason: "a correlation error is max(2 - 2 peak, 0) (eq. 10)",
            });
        }
        Ok(Correlation {
            error: s.error,
            peak: s.peak,
            alignment: s.alignment,
        })
    }
}

/// The correlation error `e = 2 − 2·peak` of eq. 10, clamped at 0 (a peak a rounding above 1).
#[inline]
fn correlation_error(peak: f64) -> f64 {
    (2.0 - 2.0 * peak).max(0.0)
}

/// Correlates FDs of one configuration; owns the padded inverse-FFT plan and its buffers, so a
/// correlation allocates nothing. One per thread.
#[derive(Clone)]
pub struct Correlator {
    k: usize,
    samples: usize,
    ifft: Arc<dyn Fft<f64>>,
    buf: Vec<Complex64>,
    scratch: Vec<Complex64>,
    prod: Vec<Complex64>,
    /// Scratch for the magnitudes of [`Self::correlate_below`].
    mags: Vec<f64>,
    pow: Vec<f64>,
    /// FFT bin of each stored coefficient (`n mod M`).
    pos: Vec<usize>,
    /// `|n|` of each stored coefficient.
    freq: Vec<f64>,
    coarse_ifft: Arc<dyn Fft<f64>>,
    coarse: Vec<Complex64>,
    coarse_pos: Vec<usize>,
}

/// Slack for comparing error bounds with errors, far above the ~1e-14 rounding of either.
pub(crate) const ROUNDING_MARGIN: f64 = 1e-9;

impl Correlator {
    /// A correlator for FDs with highest frequency `k` (`K`) from contours resampled to
    /// `samples` points (`L`, the unit of [`Alignment::shift`]), with the default grid.
    /// `1 ≤ k < samples ≤` [`crate::MAX_SAMPLES`], else [`FdError::InvalidParameter`] (before
    /// anything is allocated).
    pub fn new(k: usize, samples: usize) -> Result<Self, FdError> {
        Self::with_grid(k, samples, 0)
    }

    /// As [`Self::new`] with an explicit FFT grid size `m`: larger grids need fewer
    /// refinements but cost more per FFT; at most `4 ·` [`crate::MAX_SAMPLES`]. Smaller values
    /// than the default grid `2 · next_power_of_two(2K + 1)` (e.g. 0) are raised to it: the
    /// refinement takes samples within 1.5 grid steps of a refined peak to belong to its lobe
    /// (module doc), and on coarser grids that step is comparable to the spacing of the lobes
    /// of `r₁₂`, so a higher lobe next to a refined one was skipped (at `M = 2K + 1`, 2–15 % of
    /// pairs of random unit FDs for `K` from 25 down to 2 got too small a `max |r₁₂|`, by up to
    /// 0.3). [`Self::grid`] is the size used.
    pub fn with_grid(k: usize, samples: usize, m: usize) -> Result<Self, FdError> {
        let bad = |name, value: usize, reason| {
            Err(FdError::InvalidParameter {
                name,
                value: value as f64,
                reason,
            })
        };
        if samples > MAX_SAMPLES {
            return bad("samples", samples, "must be at most MAX_SAMPLES = 2^20");
        }
        if k == 0 || k >= samples {
            return bad("k", k, "must be at least 1 and below `samples`");
        }
        if m > 4 * MAX_SAMPLES {
            return bad("m", m, "must be at most 4 MAX_SAMPLES = 2^22");
        }
        let m0 = (2 * k + 1).next_power_of_two();
        // The default grid; `k < samples <= MAX_SAMPLES`, so it is at most 4 MAX_SAMPLES.
        let m = m.max(2 * m0);
        let mut planner = FftPlanner::new();
        let ifft = planner.plan_fft_inverse(m);
        let coarse_ifft = planner.plan_fft_inverse(m0);
        let z = Complex64::new(0.0, 0.0);
        let bins = |m: usize| -> Vec<usize> {
            (0..2 * k)
                .map(|i| fd_frequency_unchecked(i, k).rem_euclid(m as isize) as usize)
                .collect()
        };
        Ok(Correlator {
            k,
            samples,
            buf: vec![z; m],
            scratch: vec![
                z;
                ifft.get_inplace_scratch_len()
                    .max(coarse_ifft.get_inplace_scratch_len())
            ],
            prod: vec![z; 2 * k],
            mags: Vec::with_capacity(4 * k),
            pow: vec![0.0; m],
            pos: bins(m),
            freq: (0..2 * k)
                .map(|i| fd_frequency_unchecked(i, k).unsigned_abs() as f64)
                .collect(),
            coarse: vec![z; m0],
            coarse_pos: bins(m0),
            coarse_ifft,
            ifft,
        })
    }

    /// Grid size `M` of the zero-padded inverse FFT.
    pub fn grid(&self) -> usize {
        self.buf.len()
    }

    /// Correlates `a` and `b` (FDs in the layout of [`crate::DescriptorSet::fd`], unit norm).
    /// Both must hold `2K` finite values of unit norm within [`crate::UNIT_NORM_TOLERANCE`]
    /// ([`FdError::LengthMismatch`], [`FdError::NonFiniteDescriptor`],
    /// [`FdError::NotUnitNorm`] otherwise): the error `2 − 2 max |r₁₂|` is meaningful only then.
    pub fn correlate(&mut self, a: &[Complex64], b: &[Complex64]) -> Result<Correlation, FdError> {
        Ok(self
            .correlate_below(a, b, f64::INFINITY)?
            .expect("every error is below infinity"))
    }

    /// Checks that `a` and `b` are FDs this correlator can compare.
    fn check(&self, a: &[Complex64], b: &[Complex64]) -> Result<(), FdError> {
        let want = 2 * self.k;
        if a.len() != want || b.len() != want {
            return Err(FdError::LengthMismatch {
                left: a.len(),
                right: b.len(),
                expected: want,
            });
        }
        for (part, v) in [("a", a), ("b", b)] {
            crate::descriptor::check_unit(v.iter().map(|c| [c.re, c.im]), part)?;
        }
        Ok(())
    }

    /// As [`Self::correlate`], but returns `None` early when the error provably exceeds
    /// `max_error`: a grid maximum plus its slack bounds the true peak from above. The bound is
    /// tried first on the smallest grid `M₀ ≥ 2K + 1` (64 for K = 25, a quarter of the cost),
    /// then on the fine grid before refinement, and after the refinement of the best sample
    /// the remaining lobes are refined only if one could still beat `max_error`. A `Some`
    /// result is bit-identical to [`Self::correlate`]. Input errors as for [`Self::correlate`];
    /// `max_error` may be `+∞` (no bound), a NaN is refused ([`FdError::InvalidParameter`]).
    pub fn correlate_below(
        &mut self,
        a: &[Complex64],
        b: &[Complex64],
        max_error: f64,
    ) -> Result<Option<Correlation>, FdError> {
        self.check(a, b)?;
        // A NaN bound prunes nothing, as +∞ would: refused, as it is a caller's mistake.
        if max_error.is_nan() {
            return Err(FdError::InvalidParameter {
                name: "max_error",
                value: max_error,
                reason: "a bound on the error is a number (+∞ for none)",
            });
        }
        let mut mags = std::mem::take(&mut self.mags);
        mags.clear();
        // `|C(n)|` exactly as the extractor stores it in a `DescriptorSet`.
        mags.extend(a.iter().chain(b).map(|c| c.norm_sqr().sqrt()));
        let (ma, mb) = mags.split_at(a.len());
        let out = self.correlate_known(a, b, ma, mb, max_error);
        self.mags = mags;
        Ok(out)
    }

    /// [`Self::correlate_below`] with the magnitudes `ma = |a(n)|`, `mb = |b(n)|` given (as a
    /// [`crate::DescriptorSet`] stores them), which saves their square roots.
    pub(crate) fn correlate_known(
        &mut self,
        a: &[Complex64],
        b: &[Complex64],
        ma: &[f64],
        mb: &[f64],
        max_error: f64,
    ) -> Option<Correlation> {
        let (k, m) = (self.k, self.buf.len());
        for ((slot, x), y) in self.prod.iter_mut().zip(a).zip(b) {
            *slot = x.conj() * y;
        }
        let (s0, s2) = spectral_sums(ma, mb, &self.freq);
        let curvature = s0 * s2;
        // Stage 1 (screening): the smallest grid M₀ ≥ 2K + 1 bounds the peak from above by its
        // maximum plus the slack of its spacing.
        if max_error.is_finite() {
            let m0 = self.coarse.len();
            self.coarse.fill(Complex64::new(0.0, 0.0));
            for (p, &pos) in self.prod.iter().zip(&self.coarse_pos) {
                self.coarse[pos] = *p;
            }
            self.coarse_ifft
                .process_with_scratch(&mut self.coarse, &mut self.scratch);
            let top = max_norm_sqr(&self.coarse);
            let h0 = PI / m0 as f64;
            let lower = 2.0 - 2.0 * (top + curvature * h0 * h0).sqrt();
            if lower - ROUNDING_MARGIN > max_error {
                return None;
            }
        }
        // Stage 2: the fine grid, its bound, and refinement.
        self.buf.fill(Complex64::new(0.0, 0.0));
        for (p, &pos) in self.prod.iter().zip(&self.pos) {
            self.buf[pos] = *p;
        }
        self.ifft
            .process_with_scratch(&mut self.buf, &mut self.scratch);
        let h = 2.0 * PI / m as f64;
        let slack = curvature * (0.5 * h) * (0.5 * h);
        // |r|² on the grid; the best sample (lowest index on ties), found without a branch per
        // sample: the maximum in four lanes, then its first position.
        for (z, pw) in self.buf.iter().zip(self.pow.iter_mut()) {
            *pw = z.norm_sqr();
        }
        let top = lane_max(&self.pow);
        let first = self.pow.iter().position(|&v| v == top).unwrap_or(0);
        let lower = 2.0 - 2.0 * (top + slack).sqrt();
        if lower - ROUNDING_MARGIN > max_error {
            return None;
        }
        // Refine the best sample first, then every other sample that could still lie within
        // half a grid step of a higher peak (value + slack above the best refined value),
        // unless an earlier refinement already converged within half a step of it.
        let (mut best_theta, mut best_f, mut best_r) =
            refine(&self.prod, k, &self.pow, first, h, self.buf[first]);
        if max_error.is_finite()
            && self.cannot_reach(max_error, best_theta, best_f, first, slack, h)
        {
            return None;
        }
        let mut peaks = [best_theta; 8];
        let mut npeaks = 1;
        let pow = &self.pow;
        for j in 0..m {
            let v = pow[j];
            if j == first || v + slack <= best_f {
                continue;
            }
            let tj = j as f64 * h;
            let seen = peaks[..npeaks].iter().any(|&t| {
                let d = (t - tj).rem_euclid(2.0 * PI);
                d.min(2.0 * PI - d) < 1.5 * h
            });
            if seen {
                continue;
            }
            let (t, fv, r) = refine(&self.prod, k, pow, j, h, self.buf[j]);
            if npeaks < peaks.len() {
                peaks[npeaks] = t;
                npeaks += 1;
            }
            if fv > best_f {
                (best_f, best_theta, best_r) = (fv, t, r);
            }
        }
        let peak = best_r.norm_sqr().sqrt();
        let theta = best_theta.rem_euclid(2.0 * PI);
        let mut shift = theta / (2.0 * PI) * self.samples as f64;
        if shift >= self.samples as f64 {
            shift = 0.0;
        }
        Some(Correlation {
            error: correlation_error(peak),
            peak,
            alignment: Alignment {
                rotation: best_r.arg(),
                shift,
            },
        })
    }

    /// After the best grid sample `first` has been refined to `best_f` at `best_theta`: true if
    /// the error provably exceeds `max_error`, i.e. the refined peak is below the `|r|²` that
    /// `max_error` needs and so is every other lobe the remaining refinements could find (each
    /// lies within half a step of a grid sample outside the refined lobe, whose value plus the
    /// slack bounds it; samples within 1.5 steps of `best_theta` belong to the refined lobe, the
    /// same rule the refinement loop applies). The remaining refinements, which decide nothing
    /// for such a pair, are then skipped.
    fn cannot_reach(
        &self,
        max_error: f64,
        best_theta: f64,
        best_f: f64,
        first: usize,
        slack: f64,
        h: f64,
    ) -> bool {
        let root = 0.5 * (2.0 - max_error - ROUNDING_MARGIN);
        if root <= 0.0 {
            return false;
        }
        let need = root * root;
        if best_f >= need {
            return false;
        }
        self.pow.iter().enumerate().all(|(j, &v)| {
            if j == first || v + slack < need {
                return true;
            }
            let d = (best_theta - j as f64 * h).rem_euclid(2.0 * PI);
            d.min(2.0 * PI - d) < 1.5 * h
        })
    }
}

/// The largest of `values` and −1, in four independent lanes of comparisons (no branch per
/// value, no serial chain). NaN values are ignored, as by a `>` scan from −1.
#[inline]
fn lane_max(values: &[f64]) -> f64 {
    let mut m = [-1.0f64; 4];
    let mut quads = values.chunks_exact(4);
    for q in &mut quads {
        for l in 0..4 {
            m[l] = if q[l] > m[l] { q[l] } else { m[l] };
        }
    }
    for &v in quads.remainder() {
        m[0] = if v > m[0] { v } else { m[0] };
    }
    let a = if m[1] > m[0] { m[1] } else { m[0] };
    let b = if m[3] > m[2] { m[3] } else { m[2] };
    if b > a { b } else { a }
}

/// The largest `|z|²` of `zs` (0 when all are 0 or `zs` is empty).
#[inline]
fn max_norm_sqr(zs: &[Complex64]) -> f64 {
    let mut m = [0.0f64; 4];
    let mut quads = zs.chunks_exact(4);
    for q in &mut quads {
        for l in 0..4 {
            let v = q[l].norm_sqr();
            m[l] = if v > m[l] { v } else { m[l] };
        }
    }
    for z in quads.remainder() {
        let v = z.norm_sqr();
        m[0] = if v > m[0] { v } else { m[0] };
    }
    m.iter().fold(0.0, |a, &b| if b > a { b } else { a })
}

/// `S_j = Σ |n|^j |C₁(n)||C₂(n)|` for `j = 0, 2` (the terms of the curvature bound), in four
/// independent lanes so the sums do not form one serial chain.
#[inline]
fn spectral_sums(ma: &[f64], mb: &[f64], freq: &[f64]) -> (f64, f64) {
    let mut acc = [[0.0f64; 4]; 2];
    let lanes = ma
        .chunks_exact(4)
        .zip(mb.chunks_exact(4))
        .zip(freq.chunks_exact(4));
    for ((x, y), f) in lanes {
        for l in 0..4 {
            let w = x[l] * y[l];
            acc[0][l] += w;
            acc[1][l] += f[l] * f[l] * w;
        }
    }
    let mut s = acc.map(|a| (a[0] + a[1]) + (a[2] + a[3]));
    let tail = ma.len().min(mb.len()).min(freq.len()) / 4 * 4;
    for ((x, y), f) in ma[tail..].iter().zip(&mb[tail..]).zip(&freq[tail..]) {
        let w = x * y;
        s[0] += w;
        s[1] += f * f * w;
    }
    (s[0], s[1])
}

/// `r(θ)`, `r'(θ)`, `r''(θ)` of `r(θ) = Σ p_n e^{inθ}` (layout of `fd_index`: `p[..K]` holds
/// `n = −K..−1`, `p[K..]` holds `n = 1..K`), pairing `n` with `−n` so one power `e^{inθ}` serves
/// both.
#[inline]
fn eval(p: &[Complex64], k: usize, theta: f64) -> (Complex64, Complex64, Complex64) {
    debug_assert_eq!(p.len(), 2 * k);
    let (neg, pos) = p.split_at(k);
    let z = Complex64::from_polar(1.0, theta);
    let mut w = z;
    let (mut r, mut r1, mut r2) = (
        Complex64::new(0.0, 0.0),
        Complex64::new(0.0, 0.0),
        Complex64::new(0.0, 0.0),
    );
    let mut nf = 0.0;
    for (a, b) in pos.iter().zip(neg.iter().rev()) {
        nf += 1.0;
        let pp = a * w;
        let pn = b * w.conj();
        let sum = pp + pn;
        let diff = pp - pn;
        r += sum;
        r1 += Complex64::new(-diff.im, diff.re) * nf;
        r2 -= sum * (nf * nf);
        w *= z;
    }
    (r, r1, r2)
}

/// Newton ascent on `|r|²` from grid sample `j` (value `r0`), started at the vertex of the
/// parabola through the sample and its neighbours, steps clamped to one grid spacing `h`.
/// Quadratic convergence: once a step below 1e-7 rad has been applied, `θ` is accurate to
/// ~1e-13. Returns `(θ, |r|², r)`, never worse than the grid sample.
fn refine(
    p: &[Complex64],
    k: usize,
    pow: &[f64],
    j: usize,
    h: f64,
    r0: Complex64,
) -> (f64, f64, Complex64) {
    let m = pow.len();
    let (fl, fc, fr) = (pow[(j + m - 1) % m], pow[j], pow[(j + 1) % m]);
    let den = fl - 2.0 * fc + fr;
    let start = if den < 0.0 {
        (0.5 * (fl - fr) / den).clamp(-0.5, 0.5)
    } else {
        0.0
    };
    let theta0 = j as f64 * h;
    let mut theta = theta0 + start * h;
    let zero = Complex64::new(0.0, 0.0);
    let (mut r, mut r1, mut r2) = (zero, zero, zero);
    // Step applied after the last evaluation (0: `r` is fresh at `theta`).
    let mut pending = 0.0;
    for _ in 0..16 {
        (r, r1, r2) = eval(p, k, theta);
        pending = 0.0;
        let g = 2.0 * (r.conj() * r1).re;
        let c = 2.0 * (r1.norm_sqr() + (r.conj() * r2).re);
        let step = if c < 0.0 {
            -g / c
        } else {
            0.5 * h * g.signum()
        };
        let step = step.clamp(-h, h);
        if step.abs() < 1e-13 {
            break;
        }
        theta += step;
        pending = step;
        if step.abs() < 1e-7 {
            break;
        }
    }
    if pending != 0.0 {
        r = if pending.abs() < 1e-7 {
            // Second-order Taylor step: its remainder `|r'''|·s³/6 < S₃·2e-22` is far below
            // rounding, so this equals a fresh evaluation without its cost.
            r + r1 * pending + r2 * (0.5 * pending * pending)
        } else {
            eval(p, k, theta).0
        };
    }
    if r.norm_sqr() >= r0.norm_sqr() {
        (theta, r.norm_sqr(), r)
    } else {
        (theta0, r0.norm_sqr(), r0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Dense brute force: max of |r| on 2^14 points.
    fn dense_max(a: &[Complex64], b: &[Complex64], k: usize) -> f64 {
        let p: Vec<Complex64> = a.iter().zip(b).map(|(x, y)| x.conj() * y).collect();
        let n = 1 << 14;
        (0..n)
            .map(|j| eval(&p, k, 2.0 * PI * j as f64 / n as f64).0.norm())
            .fold(0.0, f64::max)
    }

    fn pseudo_fd(seed: u64, k: usize, decay: f64) -> Vec<Complex64> {
        // Deterministic LCG; unit-norm FD with |C(n)| ~ |n|^-decay and scrambled phases.
        let mut s = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let mut next = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut v: Vec<Complex64> = (0..2 * k)
            .map(|i| {
                let n = crate::descriptor::fd_frequency(i, k)
                    .unwrap()
                    .unsigned_abs() as f64;
                Complex64::from_polar((0.2 + next()) * n.powf(-decay), 2.0 * PI * next())
            })
            .collect();
        let e = v.iter().map(|c| c.norm_sqr()).sum::<f64>().sqrt();
        v.iter_mut().for_each(|c| *c /= e);
        v
    }

    #[test]
    fn peak_matches_dense_search() {
        let k = 25;
        let mut cor = Correlator::new(k, 256).unwrap();
        for seed in 0..24 {
            let decay = [0.0, 0.5, 1.0, 2.0][seed as usize % 4];
            let a = pseudo_fd(seed, k, decay);
            let b = pseudo_fd(seed + 1000, k, decay);
            let c = cor.correlate(&a, &b).unwrap();
            let dense = dense_max(&a, &b, k);
            assert!(
                c.peak >= dense - 1e-12,
                "seed {seed}: {} < dense {dense}",
                c.peak
            );
            assert!(
                c.peak <= dense + 1e-4,
                "the dense grid comes within 1e-4 of the true peak"
            );
        }
    }

    #[test]
    fn early_exit_is_sound_and_bit_identical() {
        let k = 25;
        let mut cor = Correlator::new(k, 256).unwrap();
        let mut exits = 0;
        for seed in 0..60 {
            let a = pseudo_fd(seed, k, 1.0);
            let b = pseudo_fd(seed + 77, k, 1.0);
            let full = cor.correlate(&a, &b).unwrap();
            // Thresholds just below the error reach the refinement stage before exiting.
            let e = full.error;
            for t in [0.0, 0.5 * e, e - 1e-3, e - 1e-5, e, e + 1e-3, 3.0] {
                match cor.correlate_below(&a, &b, t).unwrap() {
                    None => {
                        exits += 1;
                        assert!(full.error > t, "exit although {} <= {t}", full.error);
                    }
                    Some(c) => assert_eq!(c, full),
                }
            }
        }
        assert!(exits > 60, "the bound should prune often, pruned {exits}");
    }

    #[test]
    fn lane_maxima_equal_a_scan() {
        // Lengths around the lane width, ties, zeros and a NaN (ignored by both).
        let mut s = 12345u64;
        for len in 0..40 {
            for round in 0..20 {
                let v: Vec<f64> = (0..len)
                    .map(|_| {
                        s = s.wrapping_mul(6364136223846793005).wrapping_add(1);
                        match (s >> 60, round % 3) {
                            (0, 2) => f64::NAN,
                            (x, _) => (x % 5) as f64 * 0.25,
                        }
                    })
                    .collect();
                let scan = v.iter().fold(-1.0, |a, &b| if b > a { b } else { a });
                assert_eq!(lane_max(&v), scan, "{v:?}");
                let zs: Vec<Complex64> = v.iter().map(|&x| Complex64::new(x.sqrt(), 0.0)).collect();
                let want = zs.iter().map(|z| z.norm_sqr()).fold(0.0, f64::max);
                assert_eq!(max_norm_sqr(&zs), want, "{v:?}");
            }
        }
    }

    #[test]
    fn recovers_subsample_shift_and_rotation() {
        let k = 25;
        let l = 256;
        let a = pseudo_fd(7, k, 1.0);
        let (phi, dl) = (-2.1, 37.318);
        let b: Vec<Complex64> = a
            .iter()
            .enumerate()
            .map(|(i, c)| {
                let n = crate::descriptor::fd_frequency(i, k).unwrap() as f64;
                c * Complex64::from_polar(1.0, phi - 2.0 * PI * n * dl / l as f64)
            })
            .collect();
        let c = Correlator::new(k, l).unwrap().correlate(&a, &b).unwrap();
        assert!(c.error < 1e-13, "error {}", c.error);
        assert!(
            (c.alignment.shift - dl).abs() < 1e-9,
            "{}",
            c.alignment.shift
        );
        assert!((c.alignment.rotation - phi).abs() < 1e-12);
    }
}
