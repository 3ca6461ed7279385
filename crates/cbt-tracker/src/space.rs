//! The tracking space: one channel basis per state axis and per measurement axis, and the
//! joint state grid (outer product of the state bases) on which posteriors live.

use chan_repr::{ChannelBasis, ChannelGrid, Kernel};
use serde::{Deserialize, Serialize};

use crate::data::{Point, Sequence};
use crate::error::{non_negative, positive};
use crate::{Detection, TrackError};

/// The default kernel: the thesis's windowed cos² with `a = π/3` (eq. 2.2).
pub const DEFAULT_KERNEL: Kernel = Kernel::Cos2 { m: 3 };

/// State and measurement channel bases (one per axis, 1 or 2 axes) and the joint state grid.
///
/// Joint grid cell `(i, j)` of a 2-D space has the flat index `i·N_y + j` (row-major, as in
/// [`ChannelGrid`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "SpaceSpec", into = "SpaceSpec")]
pub struct Space {
    state: Vec<ChannelBasis>,
    meas: Vec<ChannelBasis>,
    grid: ChannelGrid,
}

#[derive(Serialize, Deserialize)]
struct SpaceSpec {
    state: Vec<ChannelBasis>,
    measurement: Vec<ChannelBasis>,
}

impl TryFrom<SpaceSpec> for Space {
    type Error = TrackError;
    fn try_from(s: SpaceSpec) -> Result<Self, TrackError> {
        Space::new(s.state, s.measurement)
    }
}

impl From<Space> for SpaceSpec {
    fn from(s: Space) -> Self {
        SpaceSpec {
            state: s.state,
            measurement: s.meas,
        }
    }
}

impl Space {
    /// A space from per-axis state and measurement bases (1 or 2 axes, same count).
    pub fn new(state: Vec<ChannelBasis>, meas: Vec<ChannelBasis>) -> Result<Self, TrackError> {
        if state.is_empty() || state.len() > 2 || state.len() != meas.len() {
            return Err(TrackError::Mismatch(format!(
                "a space needs 1 or 2 state axes and as many measurement axes (got {} and {})",
                state.len(),
                meas.len()
            )));
        }
        let grid = ChannelGrid::new(state.clone())?;
        Ok(Space { state, meas, grid })
    }

    /// Image tracking: state and measurement are both the position in a `width × height`
    /// image, each axis covered by channels of at most `spacing` pixels.
    ///
    /// ```
    /// use cbt_tracker::Space;
    /// let s = Space::image(320.0, 240.0, 8.0).unwrap();
    /// assert_eq!((s.axis_len(0), s.axis_len(1)), (42, 32));
    /// ```
    pub fn image(width: f64, height: f64, spacing: f64) -> Result<Self, TrackError> {
        Space::image_with_kernel(width, height, spacing, DEFAULT_KERNEL)
    }

    /// [`Space::image`] with a chosen kernel.
    pub fn image_with_kernel(
        width: f64,
        height: f64,
        spacing: f64,
        kernel: Kernel,
    ) -> Result<Self, TrackError> {
        let x = axis(0.0, width, spacing, kernel)?;
        let y = axis(0.0, height, spacing, kernel)?;
        Space::new(vec![x.clone(), y.clone()], vec![x, y])
    }

    /// Number of axes (1 or 2).
    pub fn dims(&self) -> usize {
        self.state.len()
    }

    /// State basis of axis `d`. Panics if `d >= dims()`, like slice indexing.
    pub fn state_basis(&self, d: usize) -> &ChannelBasis {
        &self.state[d]
    }

    /// Measurement basis of axis `d`. Panics if `d >= dims()`, like slice indexing.
    pub fn meas_basis(&self, d: usize) -> &ChannelBasis {
        &self.meas[d]
    }

    /// The joint state grid.
    pub fn grid(&self) -> &ChannelGrid {
        &self.grid
    }

    /// Number of state channels on axis `d`. Panics if `d >= dims()`, like slice indexing.
    pub fn axis_len(&self, d: usize) -> usize {
        self.state[d].len()
    }

    /// Number of measurement channels on axis `d`. Panics if `d >= dims()`, like slice
    /// indexing.
    pub fn meas_len(&self, d: usize) -> usize {
        self.meas[d].len()
    }

    /// Number of joint state cells `G = Π N_d`.
    pub fn cells(&self) -> usize {
        self.grid.len()
    }

    /// Channel-index coordinates of a state, or a typed error when it is non-finite or off
    /// the grid.
    pub(crate) fn state_index(&self, p: &Point) -> Result<[f64; 2], TrackError> {
        index(&self.state, p, "state")
    }

    /// Channel-index coordinates of a detection (validated).
    pub(crate) fn detection_index(&self, det: &Detection) -> Result<[f64; 2], TrackError> {
        det.validate(self.dims())?;
        index(&self.meas, &det.pos, "detection")
    }

    /// Centre of joint cell `g` (value space). Panics if `g >= cells()`, like slice indexing
    /// (a cell past the grid used to wrap around it: cell `G` gave the centre of cell 0).
    pub fn cell_centre(&self, g: usize) -> Point {
        assert!(
            g < self.cells(),
            "cell {g} outside the grid of {} cells",
            self.cells()
        );
        let mut p = [0.0; 2];
        let mut rest = g;
        for d in (0..self.dims()).rev() {
            let n = self.state[d].len();
            p[d] = self.state[d].centre(rest % n);
            rest /= n;
        }
        p
    }
}

/// One axis covering `[lo, hi]` with channels at most `spacing` apart.
pub fn axis(lo: f64, hi: f64, spacing: f64, kernel: Kernel) -> Result<ChannelBasis, TrackError> {
    positive("spacing", spacing)?;
    if !(lo.is_finite() && hi.is_finite() && hi > lo) {
        return Err(TrackError::InvalidParameter {
            name: "range",
            value: hi - lo,
            reason: "an axis needs a finite range with hi > lo",
        });
    }
    let w = kernel.window();
    let cells = ((hi - lo) / spacing).ceil().max(1.0);
    if cells > 1e6 {
        return Err(TrackError::InvalidParameter {
            name: "spacing",
            value: spacing,
            reason: "gives more than a million channels on one axis",
        });
    }
    Ok(ChannelBasis::covering(
        lo,
        hi,
        cells as usize + w - 1,
        kernel,
    )?)
}

fn index(bases: &[ChannelBasis], p: &Point, what: &'static str) -> Result<[f64; 2], TrackError> {
    let mut t = [0.0; 2];
    for (d, b) in bases.iter().enumerate() {
        if !p[d].is_finite() {
            return Err(TrackError::NonFinite {
                what: if what == "state" {
                    "state coordinate"
                } else {
                    "detection coordinate"
                },
                value: p[d],
            });
        }
        t[d] = b.checked_index(p[d]).map_err(|_| outside(bases, p, what))?;
    }
    Ok(t)
}

fn outside(bases: &[ChannelBasis], p: &Point, what: &'static str) -> TrackError {
    let (lo_x, hi_x) = bases[0].representable_range();
    let (lo_y, hi_y) = bases.get(1).map_or((0.0, 0.0), |b| b.representable_range());
    TrackError::OutsideGrid {
        what,
        x: p[0],
        y: if bases.len() > 1 { p[1] } else { 0.0 },
        lo_x,
        hi_x,
        lo_y,
        hi_y,
    }
}

/// The motion and noise scales of a training set, per axis, from which the default channel
/// spacing is chosen ([`Scales::spacing`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Scales {
    /// RMS of the truth's second differences (the part of the motion a constant-velocity
    /// extrapolation cannot predict), over both axes' differences pooled: one scale for both
    /// axes, as the spacing is one for both.
    pub accel: f64,
    /// Robust standard deviation (1.4826 · median absolute residual) of the detection nearest
    /// to the truth, over both axes' residuals pooled; the median is the upper one of an even
    /// count (residuals beyond 1/10 of the extent are ignored as clutter).
    pub noise: f64,
}

impl Scales {
    /// Estimates the scales from training sequences with ground truth.
    /// `extent` must be finite and positive, and every truth and detection coordinate finite
    /// ([`TrackError::NonFinite`]); scales that overflow are
    /// [`TrackError::InvalidParameter`] errors.
    pub fn estimate(train: &[Sequence], extent: f64) -> Result<Scales, TrackError> {
        positive("extent", extent)?;
        crate::data::check_sequences(train)?;
        let mut acc = Vec::new();
        let mut res = Vec::new();
        for s in train {
            for w in s.frames.windows(3) {
                if let (Some(a), Some(b), Some(c)) = (w[0].truth, w[1].truth, w[2].truth) {
                    for d in 0..2 {
                        acc.push(c[d] - 2.0 * b[d] + a[d]);
                    }
                }
            }
            for f in &s.frames {
                let Some(t) = f.truth else { continue };
                let near = f
                    .detections
                    .iter()
                    .min_by(|a, b| dist2(&a.pos, &t).total_cmp(&dist2(&b.pos, &t)));
                if let Some(det) = near {
                    for (p, t) in det.pos.iter().zip(&t) {
                        if (p - t).abs() < extent / 10.0 {
                            res.push((p - t).abs());
                        }
                    }
                }
            }
        }
        if acc.is_empty() {
            return Err(TrackError::EmptyTraining {
                reason: "no three consecutive frames with truth to measure the motion scale",
            });
        }
        let accel = (acc.iter().map(|a| a * a).sum::<f64>() / acc.len() as f64).sqrt();
        let noise = if res.is_empty() {
            0.0
        } else {
            res.sort_by(f64::total_cmp);
            1.4826 * res[res.len() / 2]
        };
        // Finite coordinates can still overflow (a jump of 1e300 squares to ∞).
        non_negative("accel", accel)?;
        non_negative("noise", noise)?;
        Ok(Scales { accel, noise })
    }

    /// Default spacing for an axis of length `extent`:
    /// `clamp(1.5 · max(noise, accel), extent/48, extent/12)`. With the cos² kernel
    /// (`a = π/3`, support ±1.5 spacings) a detection then activates the channels within
    /// ±2.25 noise standard deviations of it, and one unpredictable step moves the state by
    /// less than one spacing; the clamp bounds the grid to 14–50 channels per axis, which keeps
    /// a second-order prediction (`O(N³)` dense, far less when pruned) cheap.
    ///
    /// Errors ([`TrackError::InvalidParameter`]): `extent` not finite and positive (`extent`),
    /// or a hand-built `Scales` whose `noise` or `accel` is not finite and non-negative.
    pub fn spacing(&self, extent: f64) -> Result<f64, TrackError> {
        self.clamped(1.5 * self.noise.max(self.accel), extent, 48.0)
    }

    /// Spacing for the stationary layout ([`Layout::Stationary`](crate::Layout)), whose
    /// storage does not grow with the channel count: `clamp(0.75·noise, extent/1000,
    /// extent/12)`. The cos² channels (`a = π/3`, variance 0.29 spacing² each) blur the
    /// likelihood three times (state and detection encodings in learning, detection encoding
    /// in filtering): at 0.75 σ that adds half the noise variance, so the update stays about as
    /// sharp as the detector (its width is 1.22 σ), while the step's cost, which follows the
    /// number of cells the posterior and prediction cover, stays small.
    ///
    /// Errors as [`spacing`](Self::spacing).
    pub fn fine_spacing(&self, extent: f64) -> Result<f64, TrackError> {
        self.clamped(0.75 * self.noise, extent, 1000.0)
    }

    /// `spacing` clamped to `[extent/finest, extent/12]`, after checking the extent and the
    /// scales (a NaN or negative extent used to panic in `f64::clamp`).
    fn clamped(&self, spacing: f64, extent: f64, finest: f64) -> Result<f64, TrackError> {
        positive("extent", extent)?;
        non_negative("noise", self.noise)?;
        non_negative("accel", self.accel)?;
        Ok(spacing.clamp(extent / finest, extent / 12.0))
    }
}

fn dist2(a: &Point, b: &Point) -> f64 {
    (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)
}
