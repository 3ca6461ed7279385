//! Unidirectional approach: how commands are executed on servos with a deadband and gear
//! backlash.
//!
//! A hobby RC servo does not go where it is told. Its motor stops as soon as it is inside the
//! deadband around the commanded angle (analog servos specify 4–8 µs of pulse width), and the
//! output shaft lags the motor by the gear backlash in the direction of the last move
//! (plastic gears: 0.2–1°, i.e. 2–11 µs at the usual 0.09°/µs). Where a joint ends therefore
//! depends on the direction it came from: from below it stops `deadband/2 + backlash/2` short
//! of the set-point, from above as much beyond it — a hysteresis of a full `deadband +
//! backlash`. Worse for a servo loop, a correction *against* the direction of the last move
//! that is smaller than the deadband does not move the motor at all, and one smaller than
//! deadband + backlash moves the motor but not the shaft: a loop with small corrections stalls.
//!
//! The standard cure on such machines (the "unidirectional positioning" of machine tools and
//! low-cost arms) is to end every final approach of a joint in the **same direction**: a joint
//! whose set-point increases (for [`ApproachDirection::Up`]) simply moves there; a joint whose
//! set-point decreases, or whose last direction is unknown, is first sent to a **pre-position**
//! `overshoot` beyond the set-point on the other side and then to the set-point. With
//! `overshoot > deadband + backlash` the second move always happens and always ends in the
//! approach direction, so the joint lands at the set-point minus a fixed offset (which the
//! learned model absorbs) plus the servo's own end noise. Every executed set-point is rounded
//! to the controller's `resolution` (e.g. the SSC-32's 1 µs), so the loop knows when a
//! correction would not change the command at all; a loop that is still above its tolerance
//! then **re-seats** every joint (pre-position and back to the same set-point), which draws a
//! fresh sample of the end noise instead of stalling.
//!
//! [`Approach::hobby_servo`] takes its numbers from the data-sheet ranges above, not from any
//! evaluation: overshoot 20 µs ≥ 8 µs (widest deadband) + 11.1 µs (1° backlash at 0.09°/µs),
//! resolution 1 µs.
//!
//! **Why** (an ablation on `arm-sim`, development seeds, the true tip + 0.1 px as the percept, 5
//! corrections): with every servo fault on, the plain loop ends at a median 0.5–0.6 px; switching
//! off deadband and backlash alone brings it to 0.3 px, near the floor of the servos' end noise
//! (≈ 0.25 px); switching off the set-point quantum or the sag does not. With this approach the
//! same default arm reaches the no-deadband, no-backlash figure.

use serde::{Deserialize, Serialize};

use crate::error::{Result, ServoError};
use crate::plant::{Plant, check_command};

/// The direction in which every final approach of a joint ends.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ApproachDirection {
    /// Final moves increase the set-point (pre-positions lie below).
    Up,
    /// Final moves decrease the set-point (pre-positions lie above).
    Down,
}

impl ApproachDirection {
    fn sign(self) -> f64 {
        match self {
            ApproachDirection::Up => 1.0,
            ApproachDirection::Down => -1.0,
        }
    }
}

/// Smallest non-zero [`Approach::resolution`] accepted (command units): finer than any
/// servo controller (1 µs on the SSC-32, 0.1° or a 12-bit step elsewhere), and coarse
/// enough that commands up to `2⁵²·10⁻⁹ ≈ 4.5·10⁶` units are rounded to exact multiples.
/// A subnormal resolution such as `1e-320` divided every command to infinity.
pub const MIN_RESOLUTION: f64 = 1e-9;

/// Largest [`Approach::resolution`] accepted (command units): far coarser than any controller,
/// and small enough that a rounded command never leaves the finite numbers.
pub const MAX_RESOLUTION: f64 = 1e9;

/// Settings of the unidirectional approach (module doc).
///
/// Deserialisation applies [`Approach::validate`] (and refuses unknown fields).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "ApproachSpec")]
pub struct Approach {
    /// Distance of the pre-position from the set-point (command units); must exceed the servos'
    /// deadband + backlash expressed in command units.
    pub overshoot: f64,
    /// Direction of every final approach.
    pub direction: ApproachDirection,
    /// Set-point resolution of the controller (command units): 0 = continuous, otherwise
    /// between [`MIN_RESOLUTION`] and [`MAX_RESOLUTION`] (inclusive). Executed set-points are
    /// rounded to multiples of it ([`Approach::round`]).
    pub resolution: f64,
}

/// The serialised form of an [`Approach`], checked by [`Approach::validate`] on
/// deserialisation.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ApproachSpec {
    overshoot: f64,
    direction: ApproachDirection,
    resolution: f64,
}

impl TryFrom<ApproachSpec> for Approach {
    type Error = ServoError;
    fn try_from(s: ApproachSpec) -> Result<Self> {
        let a = Approach {
            overshoot: s.overshoot,
            direction: s.direction,
            resolution: s.resolution,
        };
        a.validate()?;
        Ok(a)
    }
}

impl Approach {
    /// Settings for hobby RC servos on a 1 µs controller (module doc): overshoot 20 µs,
    /// approach from below, resolution 1 µs.
    pub fn hobby_servo() -> Self {
        Approach {
            overshoot: 20.0,
            direction: ApproachDirection::Up,
            resolution: 1.0,
        }
    }

    /// Checks `overshoot > 0` (finite) and `resolution` either 0 or between
    /// [`MIN_RESOLUTION`] and [`MAX_RESOLUTION`] inclusive (NaN and ±∞ refused):
    /// [`ServoError::InvalidParameter`] otherwise.
    pub fn validate(&self) -> Result<()> {
        if !(self.overshoot.is_finite() && self.overshoot > 0.0) {
            return Err(ServoError::invalid(
                "overshoot",
                &format!("must be finite and positive, got {}", self.overshoot),
            ));
        }
        // NaN fails both tests.
        let r = self.resolution;
        if !(r == 0.0 || (MIN_RESOLUTION..=MAX_RESOLUTION).contains(&r)) {
            return Err(ServoError::invalid(
                "resolution",
                &format!(
                    "must be 0 (continuous) or in [{MIN_RESOLUTION:e}, {MAX_RESOLUTION:e}], got {r:e}"
                ),
            ));
        }
        Ok(())
    }

    /// `y` rounded to the controller's resolution: each set-point to the nearest multiple of
    /// it (halves away from zero), unchanged with resolution 0. A command so large against the
    /// resolution that the division or the product overflows is returned as it is: it is
    /// already a multiple to `f64` precision (the multiples are denser than the `f64` numbers
    /// there), so a finite command never becomes infinite. Expects a
    /// [validated](Self::validate) approach (a hand-built one with a non-positive or NaN
    /// resolution leaves `y` unchanged).
    pub fn round(&self, y: &[f64]) -> Vec<f64> {
        let r = self.resolution;
        if r > 0.0 {
            y.iter()
                .map(|&v| {
                    let q = (v / r).round() * r;
                    if q.is_finite() || !v.is_finite() {
                        q
                    } else {
                        v
                    }
                })
                .collect()
        } else {
            y.to_vec()
        }
    }
}

/// What the executor knows about the joints between commands: the last executed set-points
/// and whether each joint's last move is known to have ended in the approach direction.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ApproachState {
    last: Option<Vec<f64>>,
    /// Per joint: the direction its last move is known to have ended in.
    seated: Vec<Option<ApproachDirection>>,
}

impl ApproachState {
    /// Nothing known (every joint is approached from its pre-position on the next move).
    pub fn new() -> Self {
        ApproachState::default()
    }

    /// The last executed set-points, if any.
    pub fn last(&self) -> Option<&[f64]> {
        self.last.as_deref()
    }

    /// The pre-position for moving to `y` (already rounded), or `None` when every joint can
    /// move straight there. `reseat` approaches every joint anew. Errors: a `y` that fails
    /// [`check_command`] (another length than the plant's command, not finite, outside the
    /// range, or a plant range that is not a range), checked first: the pre-position is
    /// clamped into the plant's range, and `f64::clamp` panics on a range that is not one.
    pub fn pre_position<P: Plant + ?Sized>(
        &self,
        plant: &P,
        approach: &Approach,
        y: &[f64],
        reseat: bool,
    ) -> Result<Option<Vec<f64>>> {
        check_command(plant, y)?;
        let s = approach.direction.sign();
        let mut pre = y.to_vec();
        let mut any = false;
        for (j, v) in pre.iter_mut().enumerate() {
            // `seated` and `last` are set together from one command (`execute`): a joint with a
            // seat has a last set-point, so `last[j]` is in bounds.
            let straight = !reseat
                && self.seated.get(j).copied().flatten() == Some(approach.direction)
                && self
                    .last
                    .as_ref()
                    .is_some_and(|last| s * (y[j] - last[j]) >= 0.0);
            if !straight {
                // A range (`lo ≤ hi`, no NaN): `check_command` above refused any other.
                let [lo, hi] = plant.command_range(j);
                *v = (y[j] - s * approach.overshoot).clamp(lo, hi);
                any = true;
            }
        }
        Ok(any.then_some(pre))
    }

    /// Executes `y` (already rounded with [`Approach::round`]) on `plant` with the
    /// unidirectional approach: checks it, sends the pre-position if one is needed, then `y`.
    /// Returns the pre-position. A `y` or a pre-position that fails the check
    /// ([`check_command`]; a pre-position fails it only where `y ∓ overshoot` overflows on a plant
    /// without bounds) is refused before anything is sent and changes no state; on an error of the
    /// plant (a move may have been made) every joint counts as unseated.
    pub fn execute<P: Plant + ?Sized>(
        &mut self,
        plant: &mut P,
        approach: &Approach,
        y: &[f64],
        reseat: bool,
    ) -> Result<Option<Vec<f64>>> {
        let pre = self.plan(&*plant, approach, y, reseat)?;
        self.send(plant, approach, y, pre.as_deref())?;
        Ok(pre)
    }

    /// The checks of [`execute`](Self::execute), nothing sent and no state changed: `y`
    /// ([`check_command`], in [`pre_position`](Self::pre_position)) and its pre-position, which
    /// is returned.
    pub(crate) fn plan<P: Plant + ?Sized>(
        &self,
        plant: &P,
        approach: &Approach,
        y: &[f64],
        reseat: bool,
    ) -> Result<Option<Vec<f64>>> {
        let pre = self.pre_position(plant, approach, y, reseat)?;
        if let Some(p) = &pre {
            check_command(plant, p)?;
        }
        Ok(pre)
    }

    /// The moves of [`execute`](Self::execute) once [`plan`](Self::plan) passed: the
    /// pre-position `pre`, if any, then `y`; on an error of the plant (a move may have been
    /// made) every joint counts as unseated.
    pub(crate) fn send<P: Plant + ?Sized>(
        &mut self,
        plant: &mut P,
        approach: &Approach,
        y: &[f64],
        pre: Option<&[f64]>,
    ) -> Result<()> {
        self.seated.clear();
        self.last = None;
        if let Some(p) = pre {
            plant.act(p)?;
        }
        plant.act(y)?;
        self.seated = vec![Some(approach.direction); y.len()];
        self.last = Some(y.to_vec());
        Ok(())
    }
}
