//! Channel kernels `B(·)` and their local decoders, in channel-index units (spacing 1).

use std::f64::consts::PI;

use serde::{Deserialize, Serialize};

use crate::ChanError;

/// Support radius of the truncated Gaussian, in standard deviations.
pub const GAUSSIAN_SUPPORT_SIGMAS: f64 = 4.0;
/// Smallest Gaussian width (in channel spacings) whose 3-channel decoding window is always active.
pub const GAUSSIAN_MIN_SIGMA: f64 = 0.5;
/// Largest Gaussian width (in channel spacings) accepted (1e6); wider kernels are refused with
/// [`ChanError::TooLarge`]. The Gaussian decoder reads the curvature `1/σ²` of `ln c` over a
/// window of responses that all lie within `~1/σ²` of 1, so its rounding error grows like
/// `ε·σ²` channel spacings: the worst error measured over a basis is 7e-5 spacings at this
/// bound, 5e-3 at `σ = 1e7` and 0.55 at `σ = 1e8` (the decoded value is noise); from about
/// `σ = 1e10` every response rounds to exactly 1 and nothing decodes, and beyond `~4.5e307`
/// the support radius `4σ` overflows to infinity.
pub const GAUSSIAN_MAX_SIGMA: f64 = 1e6;

/// A channel kernel (basis function), measured in units of the channel spacing.
///
/// - [`Kernel::Cos2`]: the windowed cos² of eq. 2.2, `B(d) = cos²(a·d)` for `|d| ≤ π/(2a)`,
///   with `a = π/m`: `m` channels overlap any point and the local decoder (eq. 2.4) looks at
///   windows of `m` channels. The thesis's example uses `m = 3` (`a = π/3`).
/// - [`Kernel::BSpline2`]: the quadratic B-spline, support `|d| < 3/2`, three active channels.
/// - [`Kernel::Gaussian`]: `exp(−d²/(2σ²))`, truncated to exactly 0 beyond `4σ`, with
///   [`GAUSSIAN_MIN_SIGMA`] `≤ σ ≤` [`GAUSSIAN_MAX_SIGMA`].
///
/// Deserialisation applies [`Kernel::validate`]: a kernel it refuses (e.g. `{"cos2":{"m":0}}`)
/// is a deserialisation error carrying the [`ChanError`] message, never a kernel that encodes
/// zeros.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", try_from = "KernelSpec")]
pub enum Kernel {
    /// Windowed cos² with `a = π/m`; `m ≥ 3` channels per decoding window.
    Cos2 {
        /// Channels per decoding window, `M = π/a` in eq. 2.4.
        m: u32,
    },
    /// Quadratic B-spline (support 3 channels).
    BSpline2,
    /// Truncated Gaussian with standard deviation `sigma` channel spacings
    /// (`0.5 ≤ sigma ≤ 1e6`, [`GAUSSIAN_MIN_SIGMA`] and [`GAUSSIAN_MAX_SIGMA`]).
    Gaussian {
        /// Standard deviation in channel spacings.
        sigma: f64,
    },
}

/// The serialised form of a [`Kernel`] (the same shape), checked by [`Kernel::validate`] on
/// deserialisation.
#[derive(Deserialize)]
#[serde(rename_all = "snake_case")]
enum KernelSpec {
    Cos2 { m: u32 },
    BSpline2,
    Gaussian { sigma: f64 },
}

impl TryFrom<KernelSpec> for Kernel {
    type Error = ChanError;
    fn try_from(s: KernelSpec) -> Result<Self, ChanError> {
        let kernel = match s {
            KernelSpec::Cos2 { m } => Kernel::Cos2 { m },
            KernelSpec::BSpline2 => Kernel::BSpline2,
            KernelSpec::Gaussian { sigma } => Kernel::Gaussian { sigma },
        };
        kernel.validate()?;
        Ok(kernel)
    }
}

impl Kernel {
    /// The cos² kernel of eq. 2.2 given its frequency `a`; `π/a` must be an integer `≥ 3`
    /// (within 1e-9) for the local decoder of eq. 2.4 to be exact.
    ///
    /// ```
    /// use chan_repr::Kernel;
    /// assert_eq!(Kernel::cos2_from_a(std::f64::consts::PI / 3.0).unwrap(), Kernel::Cos2 { m: 3 });
    /// assert!(Kernel::cos2_from_a(1.0).is_err());
    /// ```
    pub fn cos2_from_a(a: f64) -> Result<Kernel, ChanError> {
        if !a.is_finite() || a <= 0.0 {
            return Err(ChanError::InvalidParameter {
                name: "a",
                value: a,
                reason: "must be finite and positive",
            });
        }
        let m = PI / a;
        let rounded = m.round();
        if (m - rounded).abs() > 1e-9 {
            return Err(ChanError::InvalidParameter {
                name: "a",
                value: a,
                reason: "π/a must be an integer for exact local decoding",
            });
        }
        // `as u32` saturates: a tiny `a` would silently become `m = u32::MAX`.
        if rounded > f64::from(u32::MAX) {
            return Err(ChanError::InvalidParameter {
                name: "a",
                value: a,
                reason: "π/a is too large for a channel window (at most u32::MAX)",
            });
        }
        let kernel = Kernel::Cos2 { m: rounded as u32 };
        kernel.validate()?;
        Ok(kernel)
    }

    /// Checks the kernel's width leaves enough overlapping channels to decode locally
    /// ([`ChanError::TooNarrow`]) and, for a Gaussian, that `sigma` is finite
    /// ([`ChanError::InvalidParameter`]) and at most [`GAUSSIAN_MAX_SIGMA`]
    /// ([`ChanError::TooLarge`]: wider ones decode to rounding noise).
    pub fn validate(&self) -> Result<(), ChanError> {
        match *self {
            Kernel::Cos2 { m } if m < 3 => Err(ChanError::TooNarrow {
                reason: format!(
                    "cos² with m = {m} (a = π/{m}) overlaps fewer than 3 channels; eq. 2.4 needs m ≥ 3"
                ),
            }),
            Kernel::Gaussian { sigma } if !sigma.is_finite() => Err(ChanError::InvalidParameter {
                name: "sigma",
                value: sigma,
                reason: "must be finite",
            }),
            Kernel::Gaussian { sigma } if sigma < GAUSSIAN_MIN_SIGMA => Err(ChanError::TooNarrow {
                reason: format!(
                    "Gaussian sigma = {sigma} < {GAUSSIAN_MIN_SIGMA} leaves fewer than 3 active channels"
                ),
            }),
            Kernel::Gaussian { sigma } if sigma > GAUSSIAN_MAX_SIGMA => Err(ChanError::TooLarge {
                what: "Gaussian sigma",
                value: sigma,
                max: GAUSSIAN_MAX_SIGMA,
            }),
            _ => Ok(()),
        }
    }

    /// `B(d)` at offset `d` (channel spacings) from a channel centre.
    #[inline]
    pub fn value(&self, d: f64) -> f64 {
        let ad = d.abs();
        if ad >= self.support_radius() {
            return 0.0;
        }
        match *self {
            Kernel::Cos2 { m } => {
                let c = (PI / f64::from(m) * d).cos();
                c * c
            }
            Kernel::BSpline2 => {
                if ad <= 0.5 {
                    0.75 - ad * ad
                } else {
                    let t = ad - 1.5;
                    0.5 * t * t
                }
            }
            Kernel::Gaussian { sigma } => (-d * d / (2.0 * sigma * sigma)).exp(),
        }
    }

    /// `(cos, sin)` of the cos² kernel's phase step `2a = 2π/m` between neighbouring channels
    /// (`(1, 0)` for the other kernels, which do not use it): cached by the bases so that
    /// encoding evaluates one `sin_cos` per value, not per channel.
    pub(crate) fn phase_step(&self) -> (f64, f64) {
        match *self {
            Kernel::Cos2 { m } => {
                let (s, c) = (std::f64::consts::TAU / f64::from(m)).sin_cos();
                (c, s)
            }
            _ => (1.0, 0.0),
        }
    }

    /// Calls `f(k, B(t − k))` for every integer `k` in `lo..=hi` where the kernel is non-zero,
    /// in increasing `k`; `step` is [`phase_step`](Self::phase_step). The one encoding loop of
    /// the crate: bounded bases clip `lo..=hi` to their channels, periodic ones wrap `k`.
    #[inline]
    pub(crate) fn for_each_in(
        &self,
        step: (f64, f64),
        t: f64,
        lo: i64,
        hi: i64,
        mut f: impl FnMut(i64, f64),
    ) {
        if hi < lo {
            return;
        }
        if let Kernel::Cos2 { m } = *self {
            let phasor = (std::f64::consts::TAU / f64::from(m) * (t - lo as f64)).sin_cos();
            cos2_from_phasor(m, step, phasor, t, lo, hi, f);
            return;
        }
        for k in lo..=hi {
            let v = self.value(t - k as f64);
            if v > 0.0 {
                f(k, v);
            }
        }
    }

    /// [`for_each_in`](Self::for_each_in) for the cos² kernel with `m` channels per window,
    /// with the starting phasor from [`sin_cos_reduced`] instead of libm's `sin_cos`: equal up
    /// to a few ulps, and about 10 ns a value cheaper. The batch encoder
    /// (`SoftHistogram::extend_1d`) uses it; the per-value paths keep libm's, so the values
    /// every other caller (the trackers among them) receives are bit-for-bit unchanged.
    #[inline]
    pub(crate) fn for_each_cos2_reduced(
        m: u32,
        step: (f64, f64),
        t: f64,
        lo: i64,
        hi: i64,
        f: impl FnMut(i64, f64),
    ) {
        if hi < lo {
            return;
        }
        // The phase 2a·(t − lo) = 2a·d + 2a·j with d = t − round(t) ∈ [−½, ½] and
        // j = round(t) − lo ∈ [0, m/2 + ½]: evaluate the small part, rotate forward j steps.
        let nearest = t.round();
        let (cs, sn) = step;
        let (mut s, mut c) = sin_cos_reduced(std::f64::consts::TAU / f64::from(m) * (t - nearest));
        for _ in 0..(nearest as i64 - lo) {
            (c, s) = (c * cs - s * sn, s * cs + c * sn);
        }
        cos2_from_phasor(m, step, (s, c), t, lo, hi, f);
    }

    /// Radius (channel spacings) beyond which the kernel is exactly zero.
    #[inline]
    pub fn support_radius(&self) -> f64 {
        match *self {
            Kernel::Cos2 { m } => 0.5 * f64::from(m),
            Kernel::BSpline2 => 1.5,
            Kernel::Gaussian { sigma } => GAUSSIAN_SUPPORT_SIGMAS * sigma,
        }
    }

    /// Number of consecutive channels the local decoder looks at (`M` of eq. 2.4).
    #[inline]
    pub fn window(&self) -> usize {
        match *self {
            Kernel::Cos2 { m } => m as usize,
            Kernel::BSpline2 | Kernel::Gaussian { .. } => 3,
        }
    }

    /// Sum of the window's channels when a single value of weight 1 lies at `offset` from the
    /// window's first channel (inside the valid range): the normaliser that turns a decoded
    /// certainty into the encoded weight. Constant `m/2` for cos², 1 for the B-spline.
    pub fn unit_window_sum(&self, offset: f64) -> f64 {
        match *self {
            Kernel::Cos2 { m } => 0.5 * f64::from(m),
            Kernel::BSpline2 => 1.0,
            Kernel::Gaussian { .. } => (0..3).map(|j| self.value(offset - j as f64)).sum(),
        }
    }

    /// Bounds `(lo, hi)` on the sum of **all** channel values of one value of weight 1 encoded
    /// anywhere in a basis's representable range (its channel mass). cos²: exactly `m/2` (the
    /// kernel's shifted copies sum to a constant); B-spline: exactly 1 (partition of unity).
    /// Gaussian: at most `1 + σ√(2π)` (a unimodal function's samples at unit spacing sum to at
    /// most its maximum plus its integral) and at least `exp(−1/(8σ²))` (a representable value
    /// lies within half a spacing of a channel, whose response alone is that much).
    pub fn unit_mass_bounds(&self) -> (f64, f64) {
        match *self {
            Kernel::Cos2 { m } => (0.5 * f64::from(m), 0.5 * f64::from(m)),
            Kernel::BSpline2 => (1.0, 1.0),
            Kernel::Gaussian { sigma } => (
                (-1.0 / (8.0 * sigma * sigma)).exp(),
                1.0 + sigma * (2.0 * PI).sqrt(),
            ),
        }
    }

    /// The most channels one encoded value can touch in a basis of unbounded length: those
    /// strictly inside the support, at most `⌈2r⌉` for support radius `r` (an open interval of
    /// length `2r` holds that many integers, and some position reaches it), saturating: `m` for
    /// cos², 3 for the B-spline.
    pub fn max_active(&self) -> usize {
        // (`⌊2r⌋ + 1` was used before: one too many when `2r` is an integer.)
        let span = (2.0 * self.support_radius()).ceil();
        if span >= usize::MAX as f64 {
            usize::MAX
        } else {
            span as usize
        }
    }

    /// The half-open valid range of a decoded offset, relative to the window's first channel:
    /// `[(W−1)/2 − 1/2, (W−1)/2 + 1/2]`, the interval where every channel of the window is
    /// inside the kernel's support of the encoded value (for the thesis's `m = 3`:
    /// `[l + 0.5, l + 1.5]` with 0-based `l`).
    #[inline]
    pub fn valid_offsets(&self) -> (f64, f64) {
        let mid = (self.window() as f64 - 1.0) / 2.0;
        (mid - 0.5, mid + 0.5)
    }

    /// Local decoding of one window of `W = self.window()` channel coefficients: the estimated
    /// position relative to the window's first channel, or `None` when the window carries no
    /// estimate (zero mass, or a Gaussian window without a peak).
    ///
    /// - cos² (eq. 2.4): `arg(Σ_j c_j e^{i2aj}) / (2a)`, arg in (−π, π].
    /// - B-spline: `1 + (c₂ − c₀)/(c₀ + c₁ + c₂)`.
    /// - Gaussian: the vertex of the parabola through `ln c₀, ln c₁, ln c₂`.
    ///
    /// All three are exact for a single encoded value inside the valid range.
    ///
    /// Errors: a window whose length is not [`window`](Self::window)
    /// ([`ChanError::LengthMismatch`]), or a coefficient that is non-finite, negative or above
    /// [`crate::MAX_MASS`] (as for [`crate::ChannelBasis::decode`]).
    ///
    /// ```
    /// use chan_repr::Kernel;
    /// assert_eq!(Kernel::BSpline2.decode_window(&[0.0, 1.0, 0.0]), Ok(Some(1.0)));
    /// assert!(Kernel::BSpline2.decode_window(&[1.0]).is_err());
    /// ```
    pub fn decode_window(&self, c: &[f64]) -> Result<Option<f64>, ChanError> {
        crate::decode::check_channels(c, self.window())?;
        Ok(self.decode_window_unchecked(c))
    }

    /// [`decode_window`](Self::decode_window) for a window the caller has checked (the
    /// decoders' inner loop).
    #[inline]
    pub(crate) fn decode_window_unchecked(&self, c: &[f64]) -> Option<f64> {
        debug_assert_eq!(c.len(), self.window());
        match *self {
            Kernel::Cos2 { m } => {
                let step = 2.0 * PI / f64::from(m);
                let (mut re, mut im) = (0.0, 0.0);
                for (j, &cj) in c.iter().enumerate() {
                    let (s, co) = (step * j as f64).sin_cos();
                    re += cj * co;
                    im += cj * s;
                }
                if re == 0.0 && im == 0.0 {
                    return None;
                }
                let offset = im.atan2(re) / step;
                // arg wraps at ±π, i.e. offset ±m/2, which is exactly the top of the valid
                // range: a value there may come out as −m/2 through rounding of `im`.
                let half = 0.5 * f64::from(m);
                Some(if offset <= -half + 1e-9 {
                    offset + 2.0 * half
                } else {
                    offset
                })
            }
            Kernel::BSpline2 => {
                let sum = c[0] + c[1] + c[2];
                (sum > 0.0).then(|| 1.0 + (c[2] - c[0]) / sum)
            }
            Kernel::Gaussian { .. } => {
                if c.iter().any(|&v| v <= 0.0) {
                    return None;
                }
                let (l0, l1, l2) = (c[0].ln(), c[1].ln(), c[2].ln());
                let curvature = 2.0 * l1 - l0 - l2;
                (curvature > 0.0).then(|| 1.0 + (l2 - l0) / (2.0 * curvature))
            }
        }
    }
}

/// The one cos² encoding loop: cos²(a·d) = (1 + cos(2a·d))/2, and the phase 2a·(t − k) falls
/// by 2a per channel, so one unit phasor `(sin, cos)` of the phase at `lo` is rotated by `step`
/// (`(cos 2a, sin 2a)`) instead of calling cos for every channel.
#[inline]
fn cos2_from_phasor(
    m: u32,
    step: (f64, f64),
    (mut s, mut c): (f64, f64),
    t: f64,
    lo: i64,
    hi: i64,
    mut f: impl FnMut(i64, f64),
) {
    let half = 0.5 * f64::from(m);
    let (cs, sn) = step;
    for k in lo..=hi {
        let d = t - k as f64;
        if d.abs() < half {
            let v = 0.5 * (1.0 + c);
            if v > 0.0 {
                f(k, v);
            }
        }
        (c, s) = (c * cs + s * sn, s * cs - c * sn);
    }
}

/// `(sin φ, cos φ)` for `|φ| ≤ π/3` (the phase range of a cos² kernel with `m ≥ 3` around its
/// nearest channel) by their Taylor polynomials to degree 17 and 18: the first omitted terms
/// are `(π/3)¹⁹/19! < 2·10⁻¹⁷` and `(π/3)²⁰/20! ≈ 1.03·10⁻¹⁸`, so the error is rounding, a few
/// ulps (tested against libm). Not valid beyond `π/3`.
#[inline]
pub(crate) fn sin_cos_reduced(phi: f64) -> (f64, f64) {
    // 1/n! for odd (sin) and even (cos) n.
    const SIN: [f64; 9] = [
        1.0,
        -1.0 / 6.0,
        1.0 / 120.0,
        -1.0 / 5_040.0,
        1.0 / 362_880.0,
        -1.0 / 39_916_800.0,
        1.0 / 6_227_020_800.0,
        -1.0 / 1_307_674_368_000.0,
        1.0 / 355_687_428_096_000.0,
    ];
    const COS: [f64; 10] = [
        1.0,
        -1.0 / 2.0,
        1.0 / 24.0,
        -1.0 / 720.0,
        1.0 / 40_320.0,
        -1.0 / 3_628_800.0,
        1.0 / 479_001_600.0,
        -1.0 / 87_178_291_200.0,
        1.0 / 20_922_789_888_000.0,
        -1.0 / 6_402_373_705_728_000.0,
    ];
    let x2 = phi * phi;
    let horner = |coef: &[f64]| coef.iter().rev().fold(0.0, |acc, &a| acc * x2 + a);
    (phi * horner(&SIN), horner(&COS))
}

#[cfg(test)]
mod tests {
    #[test]
    fn sin_cos_reduced_agrees_with_libm() {
        let range = std::f64::consts::PI / 3.0;
        let mut worst = 0.0f64;
        for i in 0..=200_000 {
            let phi = (f64::from(i) / 100_000.0 - 1.0) * range;
            let (s, c) = super::sin_cos_reduced(phi);
            let (s0, c0) = phi.sin_cos();
            worst = worst.max((s - s0).abs()).max((c - c0).abs());
        }
        assert!(worst <= 1e-15, "largest difference {worst:e}");
        assert_eq!(super::sin_cos_reduced(0.0), (0.0, 1.0));
    }

    use super::*;

    #[test]
    fn cos2_matches_eq_2_2() {
        let k = Kernel::Cos2 { m: 3 };
        let a = PI / 3.0;
        for d in [-1.4, -0.3, 0.0, 0.7, 1.49] {
            assert!((k.value(d) - (a * d).cos().powi(2)).abs() < 1e-15);
        }
        assert_eq!(k.value(1.5), 0.0);
        assert_eq!(k.value(-2.0), 0.0);
    }

    #[test]
    fn bspline_partitions_unity() {
        for t in [0.0, 0.1, 0.37, 0.5, 0.99] {
            let s: f64 = (-3..=3).map(|k| Kernel::BSpline2.value(t - k as f64)).sum();
            assert!((s - 1.0).abs() < 1e-15, "t = {t}: {s}");
        }
    }

    #[test]
    fn cos2_window_sum_is_half_m() {
        for m in 3..8 {
            let k = Kernel::Cos2 { m };
            let (lo, hi) = k.valid_offsets();
            for i in 0..=10 {
                let x = lo + (hi - lo) * i as f64 / 10.0;
                let s: f64 = (0..m).map(|j| k.value(x - j as f64)).sum();
                assert!((s - k.unit_window_sum(x)).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn narrow_kernels_are_rejected() {
        assert!(matches!(
            Kernel::Cos2 { m: 2 }.validate(),
            Err(ChanError::TooNarrow { .. })
        ));
        assert!(matches!(
            Kernel::Gaussian { sigma: 0.2 }.validate(),
            Err(ChanError::TooNarrow { .. })
        ));
        assert!(Kernel::Gaussian { sigma: f64::NAN }.validate().is_err());
        assert!(Kernel::cos2_from_a(PI / 2.5).is_err());
        assert!(Kernel::cos2_from_a(-1.0).is_err());
    }

    #[test]
    fn window_decoders_are_exact() {
        for k in [
            Kernel::Cos2 { m: 3 },
            Kernel::Cos2 { m: 5 },
            Kernel::BSpline2,
            Kernel::Gaussian { sigma: 0.8 },
        ] {
            let (lo, hi) = k.valid_offsets();
            for i in 0..=20 {
                let x = lo + (hi - lo) * i as f64 / 20.0;
                let c: Vec<f64> = (0..k.window()).map(|j| k.value(x - j as f64)).collect();
                let got = k.decode_window(&c).unwrap().unwrap();
                assert!((got - x).abs() < 1e-12, "{k:?}: {x} decoded as {got}");
            }
        }
    }

    #[test]
    fn serde_round_trips_valid_kernels_unchanged() {
        for (k, json) in [
            (Kernel::Cos2 { m: 3 }, r#"{"cos2":{"m":3}}"#),
            (Kernel::Cos2 { m: 7 }, r#"{"cos2":{"m":7}}"#),
            (Kernel::BSpline2, r#""b_spline2""#),
            (
                Kernel::Gaussian { sigma: 0.5 },
                r#"{"gaussian":{"sigma":0.5}}"#,
            ),
            (
                Kernel::Gaussian { sigma: 1.3 },
                r#"{"gaussian":{"sigma":1.3}}"#,
            ),
        ] {
            assert_eq!(serde_json::to_string(&k).unwrap(), json);
            assert_eq!(serde_json::from_str::<Kernel>(json).unwrap(), k);
        }
    }

    #[test]
    fn serde_refuses_kernels_that_validate_refuses() {
        for bad in [
            r#"{"cos2":{"m":0}}"#,
            r#"{"cos2":{"m":2}}"#,
            r#"{"gaussian":{"sigma":0.49}}"#,
            r#"{"gaussian":{"sigma":-1.0}}"#,
            r#"{"gaussian":{"sigma":0.0}}"#,
        ] {
            let err = serde_json::from_str::<Kernel>(bad)
                .expect_err(bad)
                .to_string();
            assert!(err.contains("kernel too narrow"), "{bad}: {err}");
        }
        // The message names the rule (the same text as `validate`).
        let err = serde_json::from_str::<Kernel>(r#"{"cos2":{"m":0}}"#).unwrap_err();
        assert!(err.to_string().contains("m = 0"), "{err}");
        // Malformed input is still a (serde) error, as before.
        for bad in [r#"{"cos2":{"m":-3}}"#, r#""cos2""#, r#"{"bspline":{}}"#] {
            assert!(serde_json::from_str::<Kernel>(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn empty_windows_carry_no_estimate() {
        assert_eq!(Kernel::Cos2 { m: 3 }.decode_window(&[0.0; 3]), Ok(None));
        assert_eq!(Kernel::BSpline2.decode_window(&[0.0; 3]), Ok(None));
        assert_eq!(
            Kernel::Gaussian { sigma: 1.0 }.decode_window(&[0.0, 1.0, 0.5]),
            Ok(None)
        );
    }
}
