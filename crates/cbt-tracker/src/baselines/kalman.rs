//! Baseline: constant-velocity Kalman filter with nearest-neighbour gating (thesis §3.2's
//! "most straightforward" association), in image coordinates.

use nalgebra::{Matrix2, Matrix2x4, Matrix4, Matrix4x2, Vector2, Vector4};
use serde::{Deserialize, Serialize};

use super::calibrate::Calibration;
use crate::data::check_finite;
use crate::error::{non_negative, positive};
use crate::integrity::{finite, nonneg};
use crate::tracker::{Estimate, Tracker};
use crate::{Detection, Point, TrackError};

/// χ² threshold of the 99 % gate for a 2-D innovation.
pub const GATE_99: f64 = 9.21;

/// Parameters of the constant-velocity Kalman filter (time step 1 frame).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct KalmanParams {
    /// Acceleration noise σ_a (px/frame²) of the discrete white-noise-acceleration model:
    /// `Q = σ_a² [[1/4, 1/2], [1/2, 1]]` per axis.
    pub accel_sigma: f64,
    /// Detection noise σ_z (px): `R = σ_z² I`.
    pub meas_sigma: f64,
    /// Initial velocity standard deviation (px/frame); the initial position is exact up to
    /// σ_z.
    pub init_vel_sigma: f64,
    /// Gate on the squared Mahalanobis distance of the innovation. Default [`GATE_99`].
    pub gate: f64,
}

impl KalmanParams {
    /// Parameters from training statistics: σ_a and σ_z as calibrated, initial velocity
    /// spread 5 σ_a, 99 % gate.
    pub fn from_calibration(c: &Calibration) -> Self {
        KalmanParams {
            accel_sigma: c.accel_sigma,
            meas_sigma: c.meas_sigma,
            init_vel_sigma: 5.0 * c.accel_sigma,
            gate: GATE_99,
        }
    }

    fn validate(&self) -> Result<(), TrackError> {
        positive("accel_sigma", self.accel_sigma)?;
        positive("meas_sigma", self.meas_sigma)?;
        positive("init_vel_sigma", self.init_vel_sigma)?;
        positive("gate", self.gate)
    }
}

/// Constant-velocity Kalman filter, state `[x, y, vx, vy]`, with nearest-neighbour gating.
///
/// Predict `x⁻ = F x`, `P⁻ = F P Fᵀ + Q`; among the detections whose innovation
/// `ν = z − H x⁻` has `νᵀ S⁻¹ ν ≤ gate` (`S = H P⁻ Hᵀ + R`) the closest is used:
/// `K = P⁻ Hᵀ S⁻¹`, `x = x⁻ + K ν`, `P = P⁻ − K H P⁻` (the form of OpenCV's
/// `KalmanFilter::correct`). No gated detection: `x = x⁻`, `P = P⁻`.
///
/// A filter read back with serde is validated (parameters, finite state and matrices, no
/// negative variance on the covariance's diagonal): [`TrackError::Corrupt`] otherwise.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "KalmanRaw")]
pub struct KalmanTracker {
    params: KalmanParams,
    x: Vector4<f64>,
    p: Matrix4<f64>,
    f: Matrix4<f64>,
    q: Matrix4<f64>,
    h: Matrix2x4<f64>,
    r: Matrix2<f64>,
}

/// A [`KalmanTracker`] as read, before its consistency check.
#[derive(Deserialize)]
struct KalmanRaw {
    params: KalmanParams,
    x: Vector4<f64>,
    p: Matrix4<f64>,
    f: Matrix4<f64>,
    q: Matrix4<f64>,
    h: Matrix2x4<f64>,
    r: Matrix2<f64>,
}

impl TryFrom<KalmanRaw> for KalmanTracker {
    type Error = TrackError;

    fn try_from(k: KalmanRaw) -> Result<Self, TrackError> {
        k.params.validate()?;
        finite("Kalman state", k.x.as_slice())?;
        finite("Kalman covariance", k.p.as_slice())?;
        // As `set_state` refuses: a negative variance poisons every later step.
        nonneg("Kalman covariance diagonal", k.p.diagonal().as_slice())?;
        finite("Kalman transition", k.f.as_slice())?;
        finite("Kalman process noise", k.q.as_slice())?;
        finite("Kalman measurement matrix", k.h.as_slice())?;
        finite("Kalman measurement noise", k.r.as_slice())?;
        Ok(KalmanTracker {
            params: k.params,
            x: k.x,
            p: k.p,
            f: k.f,
            q: k.q,
            h: k.h,
            r: k.r,
        })
    }
}

impl KalmanTracker {
    /// A filter with the given parameters, started at the origin.
    pub fn new(params: KalmanParams) -> Result<Self, TrackError> {
        params.validate()?;
        let f = Matrix4::new(
            1.0, 0.0, 1.0, 0.0, //
            0.0, 1.0, 0.0, 1.0, //
            0.0, 0.0, 1.0, 0.0, //
            0.0, 0.0, 0.0, 1.0,
        );
        let s2 = params.accel_sigma * params.accel_sigma;
        let q = Matrix4::new(
            0.25, 0.0, 0.5, 0.0, //
            0.0, 0.25, 0.0, 0.5, //
            0.5, 0.0, 1.0, 0.0, //
            0.0, 0.5, 0.0, 1.0,
        ) * s2;
        let h = Matrix2x4::new(1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0);
        let r = Matrix2::identity() * params.meas_sigma * params.meas_sigma;
        let mut k = KalmanTracker {
            params,
            x: Vector4::zeros(),
            p: Matrix4::identity(),
            f,
            q,
            h,
            r,
        };
        k.reset([0.0, 0.0])?;
        Ok(k)
    }

    /// State `[x, y, vx, vy]`.
    pub fn state(&self) -> Vector4<f64> {
        self.x
    }

    /// Covariance of the state.
    pub fn covariance(&self) -> Matrix4<f64> {
        self.p
    }

    /// Sets state and covariance (e.g. to match another implementation's start).
    ///
    /// Errors, leaving the filter unchanged: a non-finite element ([`TrackError::NonFinite`]),
    /// or a negative variance on the covariance's diagonal ([`TrackError::InvalidParameter`]
    /// `covariance diagonal`). (Both used to be stored and poison every later step.)
    pub fn set_state(&mut self, x: Vector4<f64>, p: Matrix4<f64>) -> Result<(), TrackError> {
        check_finite("Kalman state", x.as_slice())?;
        check_finite("Kalman covariance", p.as_slice())?;
        for v in p.diagonal().iter() {
            non_negative("covariance diagonal", *v)?;
        }
        self.x = x;
        self.p = p;
        Ok(())
    }

    /// Transition `F`, process noise `Q`, measurement matrix `H` and noise `R`.
    pub fn matrices(&self) -> (Matrix4<f64>, Matrix4<f64>, Matrix2x4<f64>, Matrix2<f64>) {
        (self.f, self.q, self.h, self.r)
    }

    /// Time update.
    pub fn predict(&mut self) {
        self.x = self.f * self.x;
        self.p = self.f * self.p * self.f.transpose() + self.q;
    }

    /// Innovation covariance `S = H P Hᵀ + R` and its inverse.
    fn innovation(&self) -> Option<(Matrix2<f64>, Matrix2<f64>)> {
        let s = self.h * self.p * self.h.transpose() + self.r;
        s.try_inverse().map(|si| (s, si))
    }

    /// Measurement update with `z` (no gating). A non-finite `z` is [`TrackError::NonFinite`]
    /// and leaves the filter unchanged (it used to turn the state into NaN).
    pub fn correct(&mut self, z: Vector2<f64>) -> Result<(), TrackError> {
        check_finite("measurement", z.as_slice())?;
        self.update(z);
        Ok(())
    }

    /// [`correct`](Self::correct) with a finite `z`.
    fn update(&mut self, z: Vector2<f64>) {
        let Some((_, si)) = self.innovation() else {
            return;
        };
        let k: Matrix4x2<f64> = self.p * self.h.transpose() * si;
        let nu = z - self.h * self.x;
        self.x += k * nu;
        self.p -= k * self.h * self.p;
    }
}

impl Tracker for KalmanTracker {
    fn name(&self) -> String {
        "Kalman + NN".into()
    }

    fn reset(&mut self, start: Point) -> Result<(), TrackError> {
        crate::data::check_point("start coordinate", &start, 2)?;
        self.x = Vector4::new(start[0], start[1], 0.0, 0.0);
        let (sp, sv) = (self.params.meas_sigma, self.params.init_vel_sigma);
        self.p = Matrix4::from_diagonal(&Vector4::new(sp * sp, sp * sp, sv * sv, sv * sv));
        Ok(())
    }

    fn step(&mut self, detections: &[Detection]) -> Result<Estimate, TrackError> {
        for d in detections {
            d.validate(2)?;
        }
        self.predict();
        if let Some((_, si)) = self.innovation() {
            let pred = self.h * self.x;
            let best = detections
                .iter()
                .filter(|d| d.weight > 0.0)
                .map(|d| {
                    let nu = Vector2::new(d.pos[0], d.pos[1]) - pred;
                    ((nu.transpose() * si * nu)[(0, 0)], d)
                })
                .filter(|(m, _)| *m <= self.params.gate)
                .min_by(|a, b| a.0.total_cmp(&b.0));
            if let Some((_, d)) = best {
                self.update(Vector2::new(d.pos[0], d.pos[1]));
            }
        }
        Ok(self.estimate())
    }

    fn estimate(&self) -> Estimate {
        Estimate::at([self.x[0], self.x[1]])
    }
}
