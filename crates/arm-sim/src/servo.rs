//! The RC servo model: pulse width → quantised set-point → calibrated target → deadband →
//! backlash → move noise.
//!
//! With the set-point `p` (µs) the controller sends `p_q = c + δ·round((p − c)/δ)` (quantum δ,
//! centre c). The servo's electronics, with calibration offset `o` and gain `k`, aim at the
//! angle `θ* = θ_c + s·(o + k·(p_q − c))` (nominal slope `s` deg/µs). The motor, at `m`, only
//! moves when `|θ* − m| > b_d/2` (deadband `b_d`, in degrees `|s|·k·deadband_us`) and then stops
//! on entering the band: `m ← θ* − sign(θ* − m)·b_d/2`. The output shaft lags the motor by half
//! the gear backlash `b` in the direction of the last move: `θ = m − dir·b/2`, plus Gaussian
//! noise on every move that happens. Two of these terms depend on where the joint came from:
//! approaching a set-point from below ends `b_d/2 + b/2` below it, from above as much above.

use rand::Rng;
use rand_distr::{Distribution, Normal};

use crate::config::ServoConfig;
use crate::error::{ArmSimError, Result};

/// The nominal joint angle (degrees) of pulse width `pulse_us`: what the data sheet promises,
/// without any of the errors.
pub fn nominal_angle(cfg: &ServoConfig, pulse_us: f64) -> f64 {
    cfg.centre_deg + cfg.deg_per_us * (pulse_us - cfg.centre_us)
}

/// The nominal pulse width (µs) for a joint angle (degrees): the inverse of [`nominal_angle`].
pub fn nominal_pulse(cfg: &ServoConfig, angle_deg: f64) -> f64 {
    cfg.centre_us + (angle_deg - cfg.centre_deg) / cfg.deg_per_us
}

/// The set-point after the controller's quantisation (µs).
pub fn quantise(cfg: &ServoConfig, pulse_us: f64) -> f64 {
    if cfg.quantum_us > 0.0 {
        cfg.centre_us + cfg.quantum_us * ((pulse_us - cfg.centre_us) / cfg.quantum_us).round()
    } else {
        pulse_us
    }
}

/// The angle (degrees) the servo's electronics aim at for `pulse_us`: quantised and with the
/// calibration error.
pub fn calibrated_target(cfg: &ServoConfig, pulse_us: f64) -> f64 {
    let q = quantise(cfg, pulse_us);
    cfg.centre_deg + cfg.deg_per_us * (cfg.offset_us + cfg.gain * (q - cfg.centre_us))
}

/// What one servo remembers between commands (hidden from the learner).
#[derive(Clone, Debug, PartialEq)]
pub struct ServoState {
    /// Motor-side angle (degrees).
    pub motor_deg: f64,
    /// Output-shaft angle (degrees), before joint limits and sag.
    pub output_deg: f64,
    /// Direction of the last move: −1, 0 (never moved) or +1.
    pub direction: f64,
}

impl ServoState {
    /// A servo resting exactly at its target for `pulse_us` (as after power-up).
    pub fn at_rest(cfg: &ServoConfig, pulse_us: f64) -> Self {
        let a = calibrated_target(cfg, pulse_us);
        ServoState {
            motor_deg: a,
            output_deg: a,
            direction: 0.0,
        }
    }

    /// Deadband width in degrees.
    pub fn deadband_deg(cfg: &ServoConfig) -> f64 {
        (cfg.deg_per_us * cfg.gain).abs() * cfg.deadband_us
    }

    /// Executes one set-point; returns whether the servo moved. Noise is drawn from `rng` only
    /// when the servo moves and `end_noise_deg > 0`.
    ///
    /// # Errors
    /// [`ArmSimError::NonFinite`] for a pulse width that is not finite, and
    /// [`ArmSimError::InvalidConfig`] for a move noise that is negative or not finite; the state
    /// is then unchanged. (The pulse's range is the simulator's to check:
    /// [`crate::ArmSim::command`].)
    pub fn step<R: Rng + ?Sized>(
        &mut self,
        cfg: &ServoConfig,
        pulse_us: f64,
        rng: &mut R,
    ) -> Result<bool> {
        if !pulse_us.is_finite() {
            return Err(ArmSimError::NonFinite {
                what: "pulse width",
            });
        }
        if !(cfg.end_noise_deg.is_finite() && cfg.end_noise_deg >= 0.0) {
            return Err(ArmSimError::InvalidConfig {
                key: "end_noise_deg".into(),
                reason: format!("must be finite and >= 0, got {}", cfg.end_noise_deg),
            });
        }
        Ok(self.step_checked(cfg, pulse_us, rng))
    }

    /// [`step`](Self::step) on inputs already checked.
    fn step_checked<R: Rng + ?Sized>(
        &mut self,
        cfg: &ServoConfig,
        pulse_us: f64,
        rng: &mut R,
    ) -> bool {
        let target = calibrated_target(cfg, pulse_us);
        let half_band = 0.5 * Self::deadband_deg(cfg);
        let error = target - self.motor_deg;
        if error.abs() <= half_band || error == 0.0 {
            return false;
        }
        let dir = error.signum();
        self.motor_deg = target - dir * half_band;
        self.direction = dir;
        let mut out = self.motor_deg - dir * 0.5 * cfg.backlash_deg;
        if cfg.end_noise_deg > 0.0 {
            let n = Normal::new(0.0, cfg.end_noise_deg)
                .expect("end_noise_deg checked finite and >= 0 in `step`");
            out += n.sample(rng);
        }
        self.output_deg = out;
        true
    }

    /// Forces the output to `angle` (a mechanical stop or the table), keeping the motor consistent
    /// with the backlash side.
    ///
    /// # Errors
    /// [`ArmSimError::NonFinite`] for an angle that is not finite (it used to become the
    /// servo's output); the state is then unchanged.
    pub fn stall_at(&mut self, cfg: &ServoConfig, angle: f64) -> Result<()> {
        if !angle.is_finite() {
            return Err(ArmSimError::NonFinite {
                what: "stall angle",
            });
        }
        self.stall_at_checked(cfg, angle);
        Ok(())
    }

    /// [`stall_at`](Self::stall_at) at an angle already known to be finite.
    pub(crate) fn stall_at_checked(&mut self, cfg: &ServoConfig, angle: f64) {
        self.output_deg = angle;
        self.motor_deg = angle + self.direction * 0.5 * cfg.backlash_deg;
    }
}
