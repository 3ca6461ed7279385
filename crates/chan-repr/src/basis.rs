//! One-dimensional channel bases: `N` channel centres `x̃_k = first + k·spacing` and a kernel.

use serde::{Deserialize, Serialize};

use crate::{ChanError, Kernel, MAX_WINDOW_CHANNELS};

/// Least slack (channel spacings) on the representable-range test (`ChannelBasis::slack`).
const RANGE_SLACK: f64 = 1e-9;

/// Most channels one basis may have (2²⁴ ≈ 16.8 million, 128 MiB as a dense `f64` vector):
/// larger requests are refused with [`ChanError::TooManyChannels`] before anything is allocated.
/// Also the limit of a dense n-D channel vector ([`crate::ChannelGrid::encode`],
/// [`crate::SoftHistogram`]); sparse histograms may span larger grids.
pub const MAX_CHANNELS: usize = 1 << 24;

/// Largest weight, channel coefficient or histogram total accepted (1e200): sums over any
/// decoding window (at most ~1e100 channels' worth of mass) then stay finite. Larger finite
/// numbers are refused with [`ChanError::TooLarge`] rather than left to overflow to infinity.
pub const MAX_MASS: f64 = 1e200;

/// `N` uniformly spaced channels with one kernel: maps values to channel-index space
/// (`t = (x − first)/spacing`, channel `k` centred at `t = k`, 0-based) and back.
///
/// The representable range is where every decoding window is complete:
/// `t ∈ [W/2 − 1, N − W/2]` for a window of `W` channels; for the thesis's ten cos² channels on
/// centres 1..10 with `a = π/3` that is `[1.5, 9.5]` in value space.
///
/// ```
/// use chan_repr::{ChannelBasis, Kernel};
/// let basis = ChannelBasis::integer(10, Kernel::Cos2 { m: 3 }).unwrap();
/// assert_eq!(basis.representable_range(), (1.5, 9.5));
/// let c = basis.encode(3.3).unwrap();
/// assert!((c[2] - 0.9045).abs() < 1e-4);
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "BasisSpec", into = "BasisSpec")]
pub struct ChannelBasis {
    kernel: Kernel,
    n: usize,
    first: f64,
    spacing: f64,
    /// `(cos, sin)` of the cos² kernel's phase step `2a = 2π/m` between neighbouring channels
    /// (unused by the other kernels): encoding evaluates one `sin_cos` per value, not per channel.
    step: (f64, f64),
    /// Slack (channel spacings) on the representable-range test, so that the ends given to
    /// [`covering`](Self::covering) are accepted whatever the rounding of `first`, `spacing` and
    /// `(x − first)/spacing`: 1e-9, plus a few ulps of the index of a value as far from 0 as the
    /// basis reaches. The second term matters only for channels finer than about 1e-6 of the
    /// coordinates' magnitude (an axis at x ≈ −664 with spacing 2e-5 refused its own end).
    /// Derived from the fields above when the basis is made, as `step` is.
    slack: f64,
}

/// The serialised form of a [`ChannelBasis`], validated on deserialisation.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct BasisSpec {
    kernel: Kernel,
    channels: usize,
    first_centre: f64,
    spacing: f64,
}

impl TryFrom<BasisSpec> for ChannelBasis {
    type Error = ChanError;
    fn try_from(s: BasisSpec) -> Result<Self, ChanError> {
        ChannelBasis::new(s.first_centre, s.spacing, s.channels, s.kernel)
    }
}

impl From<ChannelBasis> for BasisSpec {
    fn from(b: ChannelBasis) -> Self {
        BasisSpec {
            kernel: b.kernel,
            channels: b.n,
            first_centre: b.first,
            spacing: b.spacing,
        }
    }
}

impl ChannelBasis {
    /// `n` channels centred at `first, first + spacing, …`. Errors: an invalid kernel,
    /// first centre or spacing; fewer channels than one decoding window or more than
    /// [`MAX_CHANNELS`]; a decoding window of more than [`crate::MAX_WINDOW_CHANNELS`] channels
    /// ([`ChanError::GridTooLarge`], as for a 1-D [`crate::ChannelGrid`]).
    pub fn new(first: f64, spacing: f64, n: usize, kernel: Kernel) -> Result<Self, ChanError> {
        kernel.validate()?;
        if !first.is_finite() {
            return Err(ChanError::InvalidParameter {
                name: "first_centre",
                value: first,
                reason: "must be finite",
            });
        }
        // Normal (≥ 2.2e-308), not subnormal: a subnormal spacing has lost the precision that
        // index coordinates need.
        if !(spacing.is_normal() && spacing > 0.0) {
            return Err(ChanError::InvalidParameter {
                name: "spacing",
                value: spacing,
                reason: "must be finite, positive and not subnormal",
            });
        }
        if n < kernel.window() {
            return Err(ChanError::TooFewChannels {
                got: n,
                needed: kernel.window(),
            });
        }
        if n > MAX_CHANNELS {
            return Err(ChanError::TooManyChannels {
                got: n,
                max: MAX_CHANNELS,
            });
        }
        // Every basis is a valid 1-D grid (`SoftHistogram::one_d` relies on it): its decoding
        // window is held to the grid's limit. (A cos² window of m > 4096 used to be accepted
        // here and made `one_d` panic.)
        if kernel.window() > MAX_WINDOW_CHANNELS {
            return Err(ChanError::GridTooLarge {
                what: "channels in one decoding window",
                got: kernel.window(),
                max: MAX_WINDOW_CHANNELS,
            });
        }
        // Every decoded value (valid or not) lies within one window of the centres, so those
        // positions must be finite numbers: otherwise a decoded mode could be ±∞.
        let reach = kernel.window() as f64;
        for t in [-reach, n as f64 + reach] {
            if !(first + t * spacing).is_finite() {
                return Err(ChanError::InvalidParameter {
                    name: "spacing",
                    value: spacing,
                    reason: "the channel centres (extended by one decoding window) overflow",
                });
            }
        }
        Ok(ChannelBasis {
            kernel,
            n,
            first,
            spacing,
            step: kernel.phase_step(),
            slack: RANGE_SLACK
                + 4.0 * f64::EPSILON * first.abs().max((first + n as f64 * spacing).abs())
                    / spacing,
        })
    }

    /// The thesis's layout: `n` channels centred on the integers `1, 2, …, n` (Figure 2.1).
    pub fn integer(n: usize, kernel: Kernel) -> Result<Self, ChanError> {
        ChannelBasis::new(1.0, 1.0, n, kernel)
    }

    /// `n` channels spaced so that the representable range is exactly `[lo, hi]`.
    ///
    /// ```
    /// use chan_repr::{ChannelBasis, Kernel};
    /// let b = ChannelBasis::covering(0.0, 640.0, 34, Kernel::BSpline2).unwrap();
    /// let (lo, hi) = b.representable_range();
    /// assert!((lo - 0.0).abs() < 1e-9 && (hi - 640.0).abs() < 1e-9);
    /// ```
    pub fn covering(lo: f64, hi: f64, n: usize, kernel: Kernel) -> Result<Self, ChanError> {
        kernel.validate()?;
        if !(lo.is_finite() && hi.is_finite() && hi > lo) {
            return Err(ChanError::InvalidParameter {
                name: "hi",
                value: hi,
                reason: "the range must be finite with hi > lo",
            });
        }
        let w = kernel.window();
        if n < w {
            return Err(ChanError::TooFewChannels { got: n, needed: w });
        }
        let spacing = (hi - lo) / (n - w + 1) as f64;
        let first = lo - spacing * (w as f64 / 2.0 - 1.0);
        ChannelBasis::new(first, spacing, n, kernel)
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

    /// Distance between neighbouring channel centres, in value units.
    pub fn spacing(&self) -> f64 {
        self.spacing
    }

    /// Centre `x̃_k` of channel `k` (0-based).
    pub fn centre(&self, k: usize) -> f64 {
        self.first + k as f64 * self.spacing
    }

    /// Value → channel-index coordinate `t` (channel `k` is centred at `t = k`).
    #[inline]
    pub fn to_index(&self, x: f64) -> f64 {
        (x - self.first) / self.spacing
    }

    /// Channel-index coordinate → value.
    #[inline]
    pub fn from_index(&self, t: f64) -> f64 {
        self.first + t * self.spacing
    }

    /// Representable range in index space: `[W/2 − 1, N − W/2]`.
    pub fn representable_index_range(&self) -> (f64, f64) {
        let half = self.kernel.window() as f64 / 2.0;
        (half - 1.0, self.n as f64 - half)
    }

    /// Representable range in value space: values that encode and decode exactly.
    pub fn representable_range(&self) -> (f64, f64) {
        let (lo, hi) = self.representable_index_range();
        (self.from_index(lo), self.from_index(hi))
    }

    /// Checks `x` is finite and representable; returns its index coordinate.
    pub fn checked_index(&self, x: f64) -> Result<f64, ChanError> {
        if !x.is_finite() {
            return Err(ChanError::NonFinite {
                what: "value",
                value: x,
            });
        }
        // Tested in index space with a slack (`slack`).
        let (tlo, thi) = self.representable_index_range();
        let t = self.to_index(x);
        if t < tlo - self.slack || t > thi + self.slack {
            let (lo, hi) = self.representable_range();
            return Err(ChanError::OutOfRange { value: x, lo, hi });
        }
        Ok(t.clamp(tlo, thi))
    }

    /// Checks every value of `xs` as [`checked_index`](Self::checked_index) does and returns
    /// the error of the first one refused. One branch-free pass (it vectorises) that only falls
    /// back to the value-by-value check when some value fails: validating a batch up front costs
    /// a small fraction of encoding it.
    pub fn check_all(&self, xs: &[f64]) -> Result<(), ChanError> {
        let (tlo, thi) = self.representable_index_range();
        let (lo, hi) = (tlo - self.slack, thi + self.slack);
        // A non-finite value gives a non-finite or NaN index, which fails `lo <= t && t <= hi`
        // (every comparison with NaN is false), so this one test covers both refusals.
        let all_ok = xs.chunks(64).all(|chunk| {
            chunk.iter().fold(true, |ok, &x| {
                let t = self.to_index(x);
                ok & (t >= lo) & (t <= hi)
            })
        });
        if all_ok {
            return Ok(());
        }
        for &x in xs {
            self.checked_index(x)?;
        }
        Ok(())
    }

    /// Calls `f(k, B(t − k))` for every channel `k` with a non-zero value at index coordinate
    /// `t`, in increasing `k`: O(active channels), no allocation. `t` is not validated.
    #[inline]
    pub fn for_each_active(&self, t: f64, mut f: impl FnMut(usize, f64)) {
        let r = self.kernel.support_radius();
        let lo = (t - r).ceil().max(0.0) as i64;
        let hi = ((t + r).floor() as i64).min(self.n as i64 - 1);
        self.kernel
            .for_each_in(self.step, t, lo, hi, |k, v| f(k as usize, v));
    }

    /// [`for_each_active`](Self::for_each_active) for a cos² basis with `m` channels per window
    /// (the caller has matched the kernel), with the batch encoder's cheaper starting phasor
    /// (`Kernel::for_each_cos2_reduced`): the same channels, values equal up to a few ulps.
    #[inline]
    pub(crate) fn for_each_active_cos2_reduced(
        &self,
        m: u32,
        t: f64,
        mut f: impl FnMut(usize, f64),
    ) {
        let r = 0.5 * f64::from(m);
        let lo = (t - r).ceil().max(0.0) as i64;
        let hi = ((t + r).floor() as i64).min(self.n as i64 - 1);
        Kernel::for_each_cos2_reduced(m, self.step, t, lo, hi, |k, v| f(k as usize, v));
    }

    /// Encodes `x` into a dense channel vector (eq. 2.1).
    ///
    /// ```
    /// use chan_repr::{ChannelBasis, Kernel};
    /// let b = ChannelBasis::integer(10, Kernel::Cos2 { m: 3 }).unwrap();
    /// let c: Vec<f64> = b.encode(3.3).unwrap().iter().map(|v| (v * 100.0).round() / 100.0).collect();
    /// assert_eq!(c, [0.0, 0.04, 0.9, 0.55, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]); // eq. 2.3
    /// ```
    pub fn encode(&self, x: f64) -> Result<Vec<f64>, ChanError> {
        self.encode_weighted(x, 1.0)
    }

    /// Encodes `x` with certainty `weight ≥ 0`: the channel vector scaled by the weight.
    pub fn encode_weighted(&self, x: f64, weight: f64) -> Result<Vec<f64>, ChanError> {
        crate::encode::encode_weighted(self, x, weight)
    }

    /// Adds `weight ·` the channel vector of `x` into `out` (length `N`): one value of a soft
    /// histogram, touching only the active channels.
    pub fn accumulate(&self, x: f64, weight: f64, out: &mut [f64]) -> Result<(), ChanError> {
        crate::encode::accumulate(self, x, weight, out)
    }
}

impl crate::encode::Line for ChannelBasis {
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

/// Checks a certainty weight is finite, non-negative and at most [`MAX_MASS`].
pub(crate) fn check_weight(weight: f64) -> Result<(), ChanError> {
    if !weight.is_finite() {
        return Err(ChanError::NonFinite {
            what: "weight",
            value: weight,
        });
    }
    if weight < 0.0 {
        return Err(ChanError::Negative {
            what: "weight",
            value: weight,
        });
    }
    check_mass("weight", weight)
}

/// Checks a non-negative amount of mass is at most [`MAX_MASS`].
pub(crate) fn check_mass(what: &'static str, value: f64) -> Result<(), ChanError> {
    if value > MAX_MASS {
        return Err(ChanError::TooLarge {
            what,
            value,
            max: MAX_MASS,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn invalid_bases_are_errors() {
        let k = Kernel::Cos2 { m: 3 };
        assert_eq!(
            ChannelBasis::integer(0, k),
            Err(ChanError::TooFewChannels { got: 0, needed: 3 })
        );
        assert!(ChannelBasis::new(0.0, 0.0, 10, k).is_err());
        assert!(ChannelBasis::new(f64::NAN, 1.0, 10, k).is_err());
        assert!(ChannelBasis::covering(1.0, 1.0, 10, k).is_err());
        assert!(ChannelBasis::integer(10, Kernel::Cos2 { m: 2 }).is_err());
    }

    #[test]
    fn huge_bases_are_refused_before_allocation() {
        // Issue 24 #11: 10¹⁰ channels used to abort on allocation in `encode`.
        assert_eq!(
            ChannelBasis::integer(10_000_000_000, Kernel::Cos2 { m: 3 }),
            Err(ChanError::TooManyChannels {
                got: 10_000_000_000,
                max: MAX_CHANNELS
            })
        );
        assert!(ChannelBasis::covering(0.0, 1.0, MAX_CHANNELS + 1, Kernel::BSpline2).is_err());
        assert!(ChannelBasis::integer(MAX_CHANNELS, Kernel::BSpline2).is_ok());
        let json =
            r#"{"kernel":"b_spline2","channels":10000000000,"first_centre":0.0,"spacing":1.0}"#;
        assert!(serde_json::from_str::<ChannelBasis>(json).is_err());
    }

    #[test]
    fn weights_beyond_the_mass_limit_are_errors() {
        let b = ChannelBasis::integer(10, Kernel::Cos2 { m: 3 }).unwrap();
        assert!(matches!(
            b.encode_weighted(3.0, 1e308),
            Err(ChanError::TooLarge { .. })
        ));
        let c = b.encode_weighted(3.0, MAX_MASS).unwrap();
        assert!((b.decode_best(&c).unwrap().unwrap().weight / MAX_MASS - 1.0).abs() < 1e-12);
    }

    #[test]
    fn encode_rejects_bad_values() {
        let b = ChannelBasis::integer(10, Kernel::Cos2 { m: 3 }).unwrap();
        assert!(matches!(
            b.encode(f64::NAN),
            Err(ChanError::NonFinite { .. })
        ));
        assert!(matches!(b.encode(1.2), Err(ChanError::OutOfRange { .. })));
        assert!(matches!(b.encode(9.6), Err(ChanError::OutOfRange { .. })));
        assert!(matches!(
            b.encode_weighted(3.0, -1.0),
            Err(ChanError::Negative { .. })
        ));
        assert!(matches!(
            b.encode_weighted(3.0, f64::INFINITY),
            Err(ChanError::NonFinite { .. })
        ));
        let mut short = [0.0; 3];
        assert!(matches!(
            b.accumulate(3.0, 1.0, &mut short),
            Err(ChanError::LengthMismatch { .. })
        ));
    }

    #[test]
    fn sparse_and_dense_encoding_agree() {
        for kernel in [
            Kernel::Cos2 { m: 4 },
            Kernel::BSpline2,
            Kernel::Gaussian { sigma: 1.3 },
        ] {
            let b = ChannelBasis::covering(-2.0, 5.0, 20, kernel).unwrap();
            for i in 0..50 {
                let x = -2.0 + 7.0 * i as f64 / 49.0;
                let sparse = b.encode(x).unwrap();
                let t = b.to_index(x);
                let dense: Vec<f64> = (0..b.len()).map(|k| kernel.value(t - k as f64)).collect();
                for (s, d) in sparse.iter().zip(&dense) {
                    // cos² is evaluated by phasor rotation when sparse: equal to rounding.
                    assert!((s - d).abs() <= 1e-14, "{kernel:?} at {x}: {s} vs {d}");
                }
            }
        }
    }

    #[test]
    fn covering_accepts_its_own_ends() {
        for (lo, hi, n) in [(0.0, 640.0, 34), (-0.3, 0.7, 11), (1e-3, 123.456, 97)] {
            for kernel in [
                Kernel::Cos2 { m: 3 },
                Kernel::BSpline2,
                Kernel::Gaussian { sigma: 0.6 },
            ] {
                let b = ChannelBasis::covering(lo, hi, n, kernel).unwrap();
                for x in [lo, hi] {
                    let modes = b.decode(&b.encode(x).unwrap()).unwrap();
                    assert!((modes[0].value - x).abs() < 1e-9 * hi.abs().max(1.0));
                }
            }
        }
    }

    #[test]
    fn serde_round_trip_validates() {
        let b = ChannelBasis::covering(0.0, 1.0, 12, Kernel::Gaussian { sigma: 0.7 }).unwrap();
        let json = serde_json::to_string(&b).unwrap();
        assert_eq!(serde_json::from_str::<ChannelBasis>(&json).unwrap(), b);
        let bad = r#"{"kernel":{"cos2":{"m":3}},"channels":1,"first_centre":0.0,"spacing":1.0}"#;
        assert!(serde_json::from_str::<ChannelBasis>(bad).is_err());
    }
}
