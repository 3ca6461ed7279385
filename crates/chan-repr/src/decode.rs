//! Local decoding of 1-D channel vectors (eq. 2.4, 2.5): every window of `W` consecutive
//! channels gives an estimate and a certainty; estimates outside their window's valid range are
//! rejected, the rest are the modes of the represented distribution.

use serde::{Deserialize, Serialize};

use crate::{ChanError, ChannelBasis, Kernel};

/// Slack (in channel spacings) on the valid-range test, so that a value exactly on the border
/// between two windows is not lost to rounding; the duplicate it creates is merged.
pub(crate) const VALID_SLACK: f64 = 1e-9;

/// One decoded mode of a 1-D channel vector.
///
/// Deserialisation checks what the decoders produce ([`ChanError::InvalidParameter`] naming
/// the field otherwise): a finite value, a finite certainty `> 0` (a valid window's sum) and a
/// finite weight `≥ 0`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "ModeSpec")]
pub struct Mode {
    /// The decoded value (value space).
    pub value: f64,
    /// Certainty `r_l`: the sum of the window's channel coefficients (eq. 2.5).
    pub certainty: f64,
    /// The encoded weight this certainty corresponds to: `r_l` divided by the window sum of a
    /// single value of weight 1 at the decoded position (1 for a plain encoded value).
    pub weight: f64,
}

/// The raw output of one decoding window, before rejection (eq. 2.6, 2.7).
///
/// Deserialisation checks what the decoders produce ([`ChanError::InvalidParameter`] naming
/// the field otherwise): a finite certainty `≥ 0`, and for a window marked valid an estimate
/// that is finite and a certainty `> 0`. (An invalid window's estimate carries no promise.)
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "WindowEstimateSpec")]
pub struct WindowEstimate {
    /// First channel of the window (0-based).
    pub start: usize,
    /// The estimate `x̂_l` in value space (`None` for a window without an estimate, e.g. all zero).
    pub value: Option<f64>,
    /// The certainty `r_l = Σ c_k` over the window.
    pub certainty: f64,
    /// Whether the estimate lies inside the window's valid range.
    pub valid: bool,
}

/// The serialised form of a [`Mode`] (the same fields), checked by [`check_mode`].
#[derive(Deserialize)]
struct ModeSpec {
    value: f64,
    certainty: f64,
    weight: f64,
}

impl TryFrom<ModeSpec> for Mode {
    type Error = ChanError;
    fn try_from(s: ModeSpec) -> Result<Self, ChanError> {
        check_mode(&[s.value], s.certainty, s.weight)?;
        Ok(Mode {
            value: s.value,
            certainty: s.certainty,
            weight: s.weight,
        })
    }
}

/// The serialised form of a [`WindowEstimate`] (the same fields), checked on deserialisation.
#[derive(Deserialize)]
struct WindowEstimateSpec {
    start: usize,
    value: Option<f64>,
    certainty: f64,
    valid: bool,
}

impl TryFrom<WindowEstimateSpec> for WindowEstimate {
    type Error = ChanError;
    fn try_from(s: WindowEstimateSpec) -> Result<Self, ChanError> {
        // NaN fails every comparison.
        if !(s.certainty.is_finite() && s.certainty >= 0.0) {
            return Err(ChanError::InvalidParameter {
                name: "certainty",
                value: s.certainty,
                reason: "a window's certainty (the sum of its coefficients) is finite and >= 0",
            });
        }
        if s.valid {
            let Some(value) = s.value else {
                // `valid` is true (reported as 1); what is missing is the estimate.
                return Err(ChanError::InvalidParameter {
                    name: "valid",
                    value: 1.0,
                    reason: "a window marked valid (1 = true) has an estimate, but `value` is null",
                });
            };
            check_mode(&[value], s.certainty, 0.0)?;
        }
        Ok(WindowEstimate {
            start: s.start,
            value: s.value,
            certainty: s.certainty,
            valid: s.valid,
        })
    }
}

/// Checks the numbers of a decoded mode as every decoder produces them (1-D, periodic and
/// n-D): at least one coordinate, every coordinate finite, the certainty finite and `> 0` (the
/// sum of a valid window, which holds mass) and the weight finite and `≥ 0`. The one home of
/// that rule for deserialised results ([`Mode`], [`WindowEstimate`], [`crate::ModeNd`]).
pub(crate) fn check_mode(value: &[f64], certainty: f64, weight: f64) -> Result<(), ChanError> {
    if value.is_empty() {
        return Err(ChanError::LengthMismatch {
            what: "dimensions (at least)",
            expected: 1,
            got: 0,
        });
    }
    if let Some(&v) = value.iter().find(|v| !v.is_finite()) {
        return Err(ChanError::InvalidParameter {
            name: "value",
            value: v,
            reason: "a decoded value is finite",
        });
    }
    // NaN fails both range tests.
    if !(certainty.is_finite() && certainty > 0.0) {
        return Err(ChanError::InvalidParameter {
            name: "certainty",
            value: certainty,
            reason: "a mode's certainty (its window's sum) is finite and > 0",
        });
    }
    if !(weight.is_finite() && weight >= 0.0) {
        return Err(ChanError::InvalidParameter {
            name: "weight",
            value: weight,
            reason: "a mode's weight is finite and >= 0",
        });
    }
    Ok(())
}

impl ChannelBasis {
    /// Every window's estimate and certainty, valid or not: `N − W + 1` entries (eq. 2.4–2.7).
    ///
    /// ```
    /// use chan_repr::{ChannelBasis, Kernel};
    /// let b = ChannelBasis::integer(10, Kernel::Cos2 { m: 3 }).unwrap();
    /// let w = b.decode_windows(&b.encode(3.3).unwrap()).unwrap();
    /// assert_eq!(w.len(), 8);
    /// assert!((w[1].value.unwrap() - 3.3).abs() < 1e-12 && w[1].valid);
    /// assert!(!w[2].valid);
    /// ```
    pub fn decode_windows(&self, c: &[f64]) -> Result<Vec<WindowEstimate>, ChanError> {
        check_channels(c, self.len())?;
        Ok(window_estimates(self.kernel(), c, false, |t| {
            self.from_index(t)
        }))
    }

    /// All modes of the channel vector `c`, sorted by decreasing certainty (ties: by value).
    ///
    /// ```
    /// use chan_repr::{ChannelBasis, Kernel};
    /// let b = ChannelBasis::integer(10, Kernel::Cos2 { m: 3 }).unwrap();
    /// let mut c = b.encode(3.3).unwrap();
    /// b.accumulate(6.8, 1.0, &mut c).unwrap(); // the soft histogram of eq. 2.9
    /// let modes = b.decode(&c).unwrap();
    /// assert_eq!(modes.len(), 2);
    /// let mut values: Vec<f64> = modes.iter().map(|m| m.value).collect();
    /// values.sort_by(f64::total_cmp);
    /// assert!((values[0] - 3.3).abs() < 1e-9 && (values[1] - 6.8).abs() < 1e-9);
    /// ```
    pub fn decode(&self, c: &[f64]) -> Result<Vec<Mode>, ChanError> {
        let windows = self.decode_windows(c)?;
        Ok(merge_modes(self.kernel(), &windows, None, |v| {
            self.to_index(v)
        }))
    }

    /// The mode with the highest certainty, if any.
    pub fn decode_best(&self, c: &[f64]) -> Result<Option<Mode>, ChanError> {
        Ok(self.decode(c)?.into_iter().next())
    }
}

/// The windowed local decoding shared by the linear and the periodic bases (eq. 2.4–2.7):
/// window `l` covers channels `l, …, l+W−1` of `c` (modulo `N = c.len()` when `wrap`); its
/// estimate is `from_index(l + offset)`. Linear: `N − W + 1` windows (needs `N ≥ W`, which
/// every basis guarantees); periodic: `N` windows.
pub(crate) fn window_estimates(
    kernel: Kernel,
    c: &[f64],
    wrap: bool,
    from_index: impl Fn(f64) -> f64,
) -> Vec<WindowEstimate> {
    let n = c.len();
    let w = kernel.window();
    let (lo, hi) = kernel.valid_offsets();
    let count = if wrap { n } else { n + 1 - w };
    let mut win = vec![0.0; w];
    (0..count)
        .map(|l| {
            for (j, v) in win.iter_mut().enumerate() {
                *v = c[(l + j) % n];
            }
            let certainty: f64 = win.iter().sum();
            let offset = kernel.decode_window_unchecked(&win);
            WindowEstimate {
                start: l,
                value: offset.map(|o| from_index(l as f64 + o)),
                certainty,
                valid: certainty > 0.0
                    && offset.is_some_and(|o| o >= lo - VALID_SLACK && o <= hi + VALID_SLACK),
            }
        })
        .collect()
}

/// The modes of the valid window estimates (in window order), shared by the linear and the
/// periodic bases: the weight from the window sum of a unit value at the decoded position,
/// twins where neighbouring windows meet merged (keeping the more certain one), with
/// `period = Some(N)` also across the wrap (an estimate below its window's start counts `N`
/// further on); sorted by decreasing certainty, ties by value. `to_index` maps a value to
/// its channel coordinate.
pub(crate) fn merge_modes(
    kernel: Kernel,
    windows: &[WindowEstimate],
    period: Option<usize>,
    to_index: impl Fn(f64) -> f64,
) -> Vec<Mode> {
    // (unwrapped channel coordinate, mode): windows in order give increasing coordinates.
    let mut modes: Vec<(f64, Mode)> = Vec::new();
    for e in windows.iter().filter(|e| e.valid) {
        let Some(value) = e.value else { continue };
        let mut t = to_index(value);
        if let Some(n) = period
            && t < e.start as f64 - VALID_SLACK
        {
            t += n as f64;
        }
        let mode = Mode {
            value,
            certainty: e.certainty,
            weight: e.certainty / kernel.unit_window_sum(t - e.start as f64),
        };
        // Neighbouring windows meet at their valid ranges' borders: merge twins.
        match modes.last_mut() {
            Some((prev_t, prev)) if (t - *prev_t).abs() <= 2.0 * VALID_SLACK => {
                if mode.certainty > prev.certainty {
                    *prev = mode;
                    *prev_t = t;
                }
            }
            _ => modes.push((t, mode)),
        }
    }
    // … and, on a circle, the last window meets the first one across the wrap.
    if let Some(n) = period
        && modes.len() > 1
    {
        let (first_t, first) = modes[0];
        let (last_t, last) = modes[modes.len() - 1];
        if (first_t + n as f64 - last_t).abs() <= 2.0 * VALID_SLACK {
            if last.certainty > first.certainty {
                modes[0].1 = last;
            }
            modes.pop();
        }
    }
    let mut modes: Vec<Mode> = modes.into_iter().map(|(_, m)| m).collect();
    sort_modes(&mut modes, |m| m.certainty, |m| m.value);
    modes
}

/// Checks a channel vector's length, finiteness and sign.
pub(crate) fn check_channels(c: &[f64], expected: usize) -> Result<(), ChanError> {
    if c.len() != expected {
        return Err(ChanError::LengthMismatch {
            what: "channel coefficients",
            expected,
            got: c.len(),
        });
    }
    for &v in c {
        check_coefficient(v)?;
    }
    Ok(())
}

/// Checks one channel coefficient is finite, non-negative and at most [`crate::MAX_MASS`].
pub(crate) fn check_coefficient(v: f64) -> Result<(), ChanError> {
    if !v.is_finite() {
        return Err(ChanError::NonFinite {
            what: "channel coefficient",
            value: v,
        });
    }
    if v < 0.0 {
        return Err(ChanError::Negative {
            what: "channel coefficient",
            value: v,
        });
    }
    crate::basis::check_mass("channel coefficient", v)
}

/// Sorts by decreasing certainty, ties broken by increasing key (deterministic order).
/// Certainties equal to single precision count as ties, so that modes of equal mass come out
/// in value order whatever the last bits of their sums; the order stays total.
pub(crate) fn sort_modes<M, K: PartialOrd>(
    modes: &mut [M],
    certainty: impl Fn(&M) -> f64,
    key: impl Fn(&M) -> K,
) {
    modes.sort_by(|a, b| {
        let (ca, cb) = (certainty(a), certainty(b));
        (cb as f32)
            .total_cmp(&(ca as f32))
            .then_with(|| {
                key(a)
                    .partial_cmp(&key(b))
                    .unwrap_or(std::cmp::Ordering::Equal)
            })
            .then_with(|| cb.total_cmp(&ca))
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_channel_vectors_are_errors() {
        let b = ChannelBasis::integer(10, Kernel::Cos2 { m: 3 }).unwrap();
        assert!(matches!(
            b.decode(&[0.0; 9]),
            Err(ChanError::LengthMismatch { .. })
        ));
        let mut c = vec![0.0; 10];
        c[3] = f64::NAN;
        assert!(matches!(b.decode(&c), Err(ChanError::NonFinite { .. })));
        c[3] = -0.5;
        assert!(matches!(b.decode(&c), Err(ChanError::Negative { .. })));
        // Three coefficients of 1e308 would sum to infinity in a window.
        let huge = vec![1e308; 10];
        assert!(matches!(b.decode(&huge), Err(ChanError::TooLarge { .. })));
    }

    #[test]
    fn zero_vector_has_no_modes() {
        let b = ChannelBasis::integer(10, Kernel::BSpline2).unwrap();
        assert!(b.decode(&[0.0; 10]).unwrap().is_empty());
        assert_eq!(b.decode_best(&[0.0; 10]).unwrap(), None);
    }

    #[test]
    fn border_values_give_one_mode() {
        // 4.5 lies exactly on the border between two windows' valid ranges.
        for kernel in [
            Kernel::Cos2 { m: 3 },
            Kernel::Cos2 { m: 4 },
            Kernel::BSpline2,
            Kernel::Gaussian { sigma: 1.0 },
        ] {
            let b = ChannelBasis::integer(10, kernel).unwrap();
            let (lo, hi) = b.representable_range();
            for x in [lo, 4.5, 5.0, hi] {
                let modes = b.decode(&b.encode(x).unwrap()).unwrap();
                assert_eq!(modes.len(), 1, "{kernel:?} at {x}: {modes:?}");
                assert!((modes[0].value - x).abs() < 1e-9);
                assert!((modes[0].weight - 1.0).abs() < 1e-9);
            }
        }
    }
}
