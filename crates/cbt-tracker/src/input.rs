//! A known periodic input of the system model: the phase `φ_k = ω·k mod 2π` of the time
//! index `k`, channel-coded on the circle (`chan_repr::PeriodicBasis`).
//!
//! With an input, the first-order model is learned per phase channel `p`,
//! `S_p ∝ Σ_t β_p(φ_t)·a_t a_{t−1}ᵀ` (the transition into frame `t` weighted by the phase
//! channel's normalised value `β_p(φ_t) = B_p(φ_t) / Σ_r B_r(φ_t)`), and a step into frame
//! `k` predicts with `S(φ_k) = Σ_p β_p(φ_k)·S_p`: a system model that depends on time through
//! a known periodic input, as UNGM's drive `8·cos(1.2k)` does.

use chan_repr::PeriodicBasis;
use serde::{Deserialize, Serialize};

use crate::TrackError;
use crate::space::DEFAULT_KERNEL;

/// A periodic input `φ_k = ω·k mod 2π` of the time index `k`, encoded in `channels` channels
/// on the circle ([`crate::DEFAULT_KERNEL`]).
///
/// The time index counts frames: in learning, frame `i` of a training sequence has `k = i`
/// (the transition into it uses `φ_i`); a tracker has `k = 0` at
/// [`reset`](crate::Tracker::reset) and `k + 1` at each step (the particle filter's `k`
/// likewise), or the value [`CbtTracker::set_time`](crate::CbtTracker::set_time) gives it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PeriodicInput {
    /// Angular frequency `ω` (radians per frame; UNGM: 1.2).
    pub omega: f64,
    /// Phase channels (at least the kernel's window, 3; at most chan-repr's maximum).
    pub channels: usize,
}

impl PeriodicInput {
    /// Checks `ω` is finite and positive, with `ω·k` finite for every `u64` time index `k`
    /// (`ω` up to about 9.7 · 10²⁸⁸), and the channel count valid.
    pub fn validate(&self) -> Result<(), TrackError> {
        crate::error::positive("input omega", self.omega)?;
        // Beyond, the phase of a later frame was ∞, its weights empty, and every prediction
        // into it the uniform one, silently.
        if !(self.omega * u64::MAX as f64).is_finite() {
            return Err(TrackError::InvalidParameter {
                name: "input omega",
                value: self.omega,
                reason: "the phase ω·k must be finite for every time index k (ω · 2^64 overflows)",
            });
        }
        self.basis().map(|_| ())
    }

    fn basis(&self) -> Result<PeriodicBasis, TrackError> {
        Ok(PeriodicBasis::new(
            std::f64::consts::TAU,
            self.channels,
            DEFAULT_KERNEL,
        )?)
    }

    /// The normalised phase-channel values `β_p(φ_k)` of time index `k` (sum 1), in
    /// increasing `p`.
    pub fn weights(&self, k: u64) -> Vec<(usize, f64)> {
        // Validated with the configuration; a basis that cannot be built has no weights.
        let Ok(b) = self.basis() else {
            return Vec::new();
        };
        let mut w = Vec::with_capacity(4);
        b.for_each_active(b.to_index(b.wrap(self.omega * k as f64)), |p, v| {
            if v > 0.0 {
                w.push((p, v))
            }
        });
        let s: f64 = w.iter().map(|e| e.1).sum();
        w.iter_mut().for_each(|e| e.1 /= s);
        w
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The weights sum to 1, sit on the channels around the phase, and the phase is periodic.
    #[test]
    fn weights_follow_the_phase() {
        let inp = PeriodicInput {
            omega: 1.2,
            channels: 12,
        };
        for k in 0..200u64 {
            let w = inp.weights(k);
            let s: f64 = w.iter().map(|e| e.1).sum();
            assert!((s - 1.0).abs() < 1e-12, "{k}: {s}");
            // The decoded phase (circular mean of the channel centres) is 1.2k mod 2π.
            let step = std::f64::consts::TAU / 12.0;
            let (mut c, mut sn) = (0.0, 0.0);
            for &(p, v) in &w {
                c += v * (p as f64 * step).cos();
                sn += v * (p as f64 * step).sin();
            }
            let phi = (1.2 * k as f64).rem_euclid(std::f64::consts::TAU);
            let d = (sn.atan2(c) - phi).rem_euclid(std::f64::consts::TAU);
            assert!(d.min(std::f64::consts::TAU - d) < 0.15, "{k}: {d}");
        }
        // Too few channels or a bad frequency: a typed error.
        assert!(
            PeriodicInput {
                omega: 1.2,
                channels: 2
            }
            .validate()
            .is_err()
        );
        assert!(
            PeriodicInput {
                omega: f64::NAN,
                channels: 12
            }
            .validate()
            .is_err()
        );
    }
}
