//! Periodic channel bases: `N` channels evenly spaced around a circle of period `P` (angles,
//! orientations, phases). Channel `k` is centred at `k·P/N` and a value's distance to a
//! centre is measured around the circle, so `x` and `x + P` encode identically and decoding
//! wraps: a value near `P` shares channels with values near 0.
//!
//! In channel-index units (`t = x·N/P`, taken modulo `N`) encoding is the bounded basis's
//! (eq. 2.1) with the channel index read modulo `N`; decoding looks at all `N` windows of `W`
//! consecutive channels (modulo `N`) and keeps the estimates inside each window's valid range
//! (eq. 2.4–2.7). Every value of the circle is representable: there is no edge.

use serde::{Deserialize, Serialize};

use crate::basis::MAX_CHANNELS;
use crate::decode::{check_channels, merge_modes, window_estimates};
use crate::{ChanError, Kernel, Mode, WindowEstimate};

/// Largest `|x| / P` (whole turns) a periodic basis accepts: beyond it `x·N/P` has lost the
/// sub-channel precision that wrapping needs (the turn count of 1e300 rad is rounding noise),
/// so such values are rejected with [`ChanError::OutOfRange`] rather than wrapped to noise.
pub const PERIODIC_MAX_TURNS: f64 = 1e6;

/// `N` channels evenly spaced on a circle of period `P`, channel `k` centred at `k·P/N`.
///
/// The kernel's support must not wrap onto itself: `N ≥ 2·r` for support radius `r` (in
/// channel spacings) and `N ≥ W`, the decoding window; e.g. cos² with `m = 3` needs 3
/// channels, a Gaussian with `σ = 1` needs 8. The quadratic B-spline needs 5: with 3 or 4, a
/// window sees one value from both sides of the circle and decodes a spurious mode.
///
/// ```
/// use chan_repr::{Kernel, PeriodicBasis};
/// use std::f64::consts::TAU;
/// let b = PeriodicBasis::new(TAU, 8, Kernel::Cos2 { m: 3 }).unwrap();
/// // An angle just below 2π lights the last and the first channels.
/// let c = b.encode(TAU - 0.1).unwrap();
/// assert!(c[7] > 0.0 && c[0] > 0.0);
/// assert_eq!(c, b.encode(-0.1).unwrap());
/// let mode = b.decode_best(&c).unwrap().unwrap();
/// assert!((mode.value - (TAU - 0.1)).abs() < 1e-12); // decoded into [0, 2π)
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "PeriodicSpec", into = "PeriodicSpec")]
pub struct PeriodicBasis {
    kernel: Kernel,
    n: usize,
    period: f64,
    spacing: f64,
    /// The kernel's cached phase step (see `Kernel::phase_step`).
    step: (f64, f64),
}

/// The serialised form of a [`PeriodicBasis`], validated on deserialisation.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct PeriodicSpec {
    kernel: Kernel,
    channels: usize,
    period: f64,
}

impl TryFrom<PeriodicSpec> for PeriodicBasis {
    type Error = ChanError;
    fn try_from(s: PeriodicSpec) -> Result<Self, ChanError> {
        PeriodicBasis::new(s.period, s.channels, s.kernel)
    }
}

impl From<PeriodicBasis> for PeriodicSpec {
    fn from(b: PeriodicBasis) -> Self {
        PeriodicSpec {
            kernel: b.kernel,
            channels: b.n,
            period: b.period,
        }
    }
}

impl PeriodicBasis {
    /// `n` channels on a circle of period `period` (e.g. `2π` for directions, `π` for
    /// orientations of lines), channel `k` centred at `k·period/n`.
    pub fn new(period: f64, n: usize, kernel: Kernel) -> Result<Self, ChanError> {
        kernel.validate()?;
        if !(period.is_finite() && period > 0.0) {
            return Err(ChanError::InvalidParameter {
                name: "period",
                value: period,
                reason: "must be finite and positive",
            });
        }
        let needed = kernel
            .window()
            .max((2.0 * kernel.support_radius()).ceil() as usize)
            .max(match kernel {
                // A B-spline window of 3 channels spans 2 spacings and a value's support 3, so
                // with fewer than 5 channels a window sees the value from both sides of the
                // circle and its ratio decoder reports a spurious valid estimate (with 3
                // channels as certain as the true one, half a turn away).
                Kernel::BSpline2 => 5,
                _ => 0,
            });
        if n < needed {
            return Err(ChanError::TooFewChannels { got: n, needed });
        }
        if n > MAX_CHANNELS {
            return Err(ChanError::TooManyChannels {
                got: n,
                max: MAX_CHANNELS,
            });
        }
        let spacing = period / n as f64;
        if !spacing.is_normal() {
            return Err(ChanError::InvalidParameter {
                name: "period",
                value: period,
                reason: "period / channels underflows to a subnormal spacing",
            });
        }
        Ok(PeriodicBasis {
            kernel,
            n,
            period,
            spacing,
            step: kernel.phase_step(),
        })
    }

    /// The kernel.
    pub fn kernel(&self) -> Kernel {
        self.kernel
    }

    /// Number of channels `N`.
    pub fn len(&self) -> usize {
        self.n
    }

    /// Always false: a basis has at least one decoding window of channels.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// The period `P`.
    pub fn period(&self) -> f64 {
        self.period
    }

    /// Distance between neighbouring channel centres, `P/N`.
    pub fn spacing(&self) -> f64 {
        self.spacing
    }

    /// Centre of channel `k` (0-based), `k·P/N`.
    pub fn centre(&self, k: usize) -> f64 {
        k as f64 * self.spacing
    }

    /// `x` wrapped into `[0, P)`.
    pub fn wrap(&self, x: f64) -> f64 {
        let w = x.rem_euclid(self.period);
        // rem_euclid of a tiny negative number rounds up to P itself.
        if w >= self.period { 0.0 } else { w }
    }

    /// Value → channel-index coordinate in `[0, N)` (channel `k` is centred at `t = k`).
    #[inline]
    pub fn to_index(&self, x: f64) -> f64 {
        let t = (x / self.spacing).rem_euclid(self.n as f64);
        if t >= self.n as f64 { 0.0 } else { t }
    }

    /// Channel-index coordinate → value in `[0, P)`.
    #[inline]
    pub fn from_index(&self, t: f64) -> f64 {
        self.wrap(t * self.spacing)
    }

    /// Checks `x` is finite and within [`PERIODIC_MAX_TURNS`] turns of 0; returns its index
    /// coordinate in `[0, N)`.
    pub fn checked_index(&self, x: f64) -> Result<f64, ChanError> {
        if !x.is_finite() {
            return Err(ChanError::NonFinite {
                what: "value",
                value: x,
            });
        }
        let bound = PERIODIC_MAX_TURNS * self.period;
        if x.abs() > bound {
            return Err(ChanError::OutOfRange {
                value: x,
                lo: -bound,
                hi: bound,
            });
        }
        Ok(self.to_index(x))
    }

    /// Calls `f(k, B(d_k))` for every channel `k` with a non-zero value at index coordinate
    /// `t ∈ [0, N)`, where `d_k` is the circular distance from `t` to `k`: O(active channels),
    /// no allocation, each channel at most once. `t` is not validated.
    #[inline]
    pub fn for_each_active(&self, t: f64, mut f: impl FnMut(usize, f64)) {
        let r = self.kernel.support_radius();
        let n = self.n as i64;
        let lo = (t - r).ceil() as i64;
        let hi = (t + r).floor() as i64;
        // `N ≥ 2r`: the open support covers fewer than N + 1 integers, no channel twice.
        // Saturating: far outside `[0, N)` the saturated `lo` plus `N − 1` overflowed.
        let hi = hi.min(lo.saturating_add(n - 1));
        self.kernel
            .for_each_in(self.step, t, lo, hi, |k, v| f(k.rem_euclid(n) as usize, v));
    }

    /// Encodes `x` into a dense channel vector (eq. 2.1 around the circle).
    pub fn encode(&self, x: f64) -> Result<Vec<f64>, ChanError> {
        self.encode_weighted(x, 1.0)
    }

    /// Encodes `x` with certainty `weight ≥ 0`: the channel vector scaled by the weight.
    pub fn encode_weighted(&self, x: f64, weight: f64) -> Result<Vec<f64>, ChanError> {
        crate::encode::encode_weighted(self, x, weight)
    }

    /// Adds `weight ·` the channel vector of `x` into `out` (length `N`), touching only the
    /// active channels. A rejected value leaves `out` unchanged.
    pub fn accumulate(&self, x: f64, weight: f64, out: &mut [f64]) -> Result<(), ChanError> {
        crate::encode::accumulate(self, x, weight, out)
    }

    /// Every window's estimate and certainty, valid or not: `N` windows of `W` consecutive
    /// channels, window `l` covering channels `l, l+1, …, l+W−1` modulo `N`; values in `[0, P)`.
    pub fn decode_windows(&self, c: &[f64]) -> Result<Vec<WindowEstimate>, ChanError> {
        check_channels(c, self.n)?;
        Ok(window_estimates(self.kernel, c, true, |t| {
            self.from_index(t)
        }))
    }

    /// All modes of the channel vector `c`, values in `[0, P)`, sorted by decreasing certainty
    /// (ties: by value). Certainty and weight as for [`crate::ChannelBasis::decode`].
    ///
    /// ```
    /// use chan_repr::{Kernel, PeriodicBasis};
    /// let b = PeriodicBasis::new(180.0, 12, Kernel::BSpline2).unwrap(); // line orientations, degrees
    /// let mut c = b.encode_weighted(179.0, 2.0).unwrap();
    /// b.accumulate(90.0, 1.0, &mut c).unwrap();
    /// let modes = b.decode(&c).unwrap();
    /// assert_eq!(modes.len(), 2);
    /// assert!((modes[0].value - 179.0).abs() < 1e-9 && (modes[0].weight - 2.0).abs() < 1e-9);
    /// assert!((modes[1].value - 90.0).abs() < 1e-9);
    /// ```
    pub fn decode(&self, c: &[f64]) -> Result<Vec<Mode>, ChanError> {
        let windows = self.decode_windows(c)?;
        Ok(merge_modes(self.kernel, &windows, Some(self.n), |v| {
            self.to_index(v)
        }))
    }

    /// The mode with the highest certainty, if any.
    pub fn decode_best(&self, c: &[f64]) -> Result<Option<Mode>, ChanError> {
        Ok(self.decode(c)?.into_iter().next())
    }
}

impl crate::encode::Line for PeriodicBasis {
    #[inline]
    fn channels(&self) -> usize {
        self.n
    }
    #[inline]
    fn index(&self, x: f64) -> Result<f64, ChanError> {
        self.checked_index(x)
    }
    #[inline]
    fn each_active(&self, t: f64, f: impl FnMut(usize, f64)) {
        self.for_each_active(t, f)
    }
}

#[cfg(test)]
mod tests {
    use std::f64::consts::{PI, TAU};

    use super::*;

    fn kernels() -> [Kernel; 4] {
        [
            Kernel::Cos2 { m: 3 },
            Kernel::Cos2 { m: 5 },
            Kernel::BSpline2,
            Kernel::Gaussian { sigma: 0.8 },
        ]
    }

    /// Circular distance in value space.
    fn circ(a: f64, b: f64, p: f64) -> f64 {
        let d = (a - b).rem_euclid(p);
        d.min(p - d)
    }

    #[test]
    fn encoding_is_the_kernel_of_the_circular_distance() {
        // Brute force: every channel's value from the distance to its nearest image.
        for kernel in kernels() {
            let b = PeriodicBasis::new(TAU, 9, kernel).unwrap();
            for i in 0..200 {
                let x = -3.0 * TAU + 6.0 * TAU * i as f64 / 199.0;
                let c = b.encode(x).unwrap();
                for (k, &ck) in c.iter().enumerate() {
                    let d = circ(x, b.centre(k), TAU) / b.spacing();
                    assert!(
                        (ck - kernel.value(d)).abs() < 1e-12,
                        "{kernel:?} x={x} k={k}"
                    );
                }
            }
        }
    }

    #[test]
    fn round_trip_everywhere_on_the_circle() {
        for kernel in kernels() {
            for n in [8usize, 13, 36] {
                let b = PeriodicBasis::new(PI, n, kernel).unwrap();
                for i in 0..=400 {
                    let x = -PI + 3.0 * PI * i as f64 / 400.0;
                    let modes = b.decode(&b.encode_weighted(x, 0.7).unwrap()).unwrap();
                    assert_eq!(modes.len(), 1, "{kernel:?} n={n} x={x}: {modes:?}");
                    assert!(circ(modes[0].value, x, PI) < 1e-9, "{kernel:?} n={n} x={x}");
                    assert!((0.0..PI).contains(&modes[0].value));
                    assert!((modes[0].weight - 0.7).abs() < 1e-9);
                }
            }
        }
    }

    #[test]
    fn values_near_the_wrap_are_neighbours() {
        // Two values either side of 0 give one histogram peak between them, not two far apart.
        let b = PeriodicBasis::new(360.0, 24, Kernel::Cos2 { m: 3 }).unwrap();
        let mut c = b.encode(359.0).unwrap();
        b.accumulate(1.0, 1.0, &mut c).unwrap();
        let best = b.decode_best(&c).unwrap().unwrap();
        assert!(circ(best.value, 0.0, 360.0) < 0.5, "{best:?}");
        assert!((best.weight - 2.0).abs() < 0.05);
    }

    #[test]
    fn smallest_bases_work() {
        let b = PeriodicBasis::new(TAU, 3, Kernel::Cos2 { m: 3 }).unwrap();
        for i in 0..50 {
            let x = TAU * i as f64 / 50.0;
            let c = b.encode(x).unwrap();
            assert!((c.iter().sum::<f64>() - 1.5).abs() < 1e-12);
            let m = b.decode(&c).unwrap();
            assert_eq!(m.len(), 1);
            assert!(circ(m[0].value, x, TAU) < 1e-9);
        }
    }

    #[test]
    fn invalid_bases_and_values_are_errors() {
        let k = Kernel::Cos2 { m: 3 };
        assert_eq!(
            PeriodicBasis::new(TAU, 2, k),
            Err(ChanError::TooFewChannels { got: 2, needed: 3 })
        );
        assert_eq!(
            PeriodicBasis::new(TAU, 7, Kernel::Gaussian { sigma: 1.0 }),
            Err(ChanError::TooFewChannels { got: 7, needed: 8 })
        );
        assert!(PeriodicBasis::new(0.0, 8, k).is_err());
        assert!(PeriodicBasis::new(f64::INFINITY, 8, k).is_err());
        assert!(PeriodicBasis::new(TAU, 8, Kernel::Cos2 { m: 2 }).is_err());
        assert!(matches!(
            PeriodicBasis::new(TAU, usize::MAX, k),
            Err(ChanError::TooManyChannels { .. })
        ));
        let b = PeriodicBasis::new(TAU, 8, k).unwrap();
        let mut c = b.encode(1.0).unwrap();
        let before = c.clone();
        assert!(matches!(
            b.accumulate(f64::NAN, 1.0, &mut c),
            Err(ChanError::NonFinite { .. })
        ));
        assert!(matches!(
            b.accumulate(1e300, 1.0, &mut c),
            Err(ChanError::OutOfRange { .. })
        ));
        assert!(b.accumulate(1.0, -1.0, &mut c).is_err());
        assert!(b.accumulate(1.0, f64::INFINITY, &mut c).is_err());
        assert_eq!(c, before);
        assert!(b.decode(&[0.0; 7]).is_err());
        assert!(b.decode(&[-1.0; 8]).is_err());
        assert!(b.decode(&[0.0; 8]).unwrap().is_empty());
    }

    #[test]
    fn serde_round_trip_validates() {
        let b = PeriodicBasis::new(PI, 12, Kernel::Gaussian { sigma: 0.7 }).unwrap();
        let json = serde_json::to_string(&b).unwrap();
        assert_eq!(serde_json::from_str::<PeriodicBasis>(&json).unwrap(), b);
        for bad in [
            r#"{"kernel":{"cos2":{"m":3}},"channels":2,"period":1.0}"#,
            r#"{"kernel":{"cos2":{"m":3}},"channels":8,"period":-1.0}"#,
            r#"{"kernel":{"cos2":{"m":3}},"channels":8,"period":1.0,"first":0}"#,
            r#"{"kernel":"b_spline2","channels":99999999999,"period":1.0}"#,
        ] {
            assert!(serde_json::from_str::<PeriodicBasis>(bad).is_err(), "{bad}");
        }
    }
}
