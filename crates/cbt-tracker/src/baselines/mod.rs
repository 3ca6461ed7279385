//! The baselines behind the same [`Tracker`](crate::Tracker) interface: a constant-velocity
//! Kalman filter, a SIR particle filter given the true model, and a particle filter that
//! knows only what CBT learned; and the training-set statistics that set their parameters.

mod calibrate;
mod kalman;
mod learned_pf;
mod particle;

pub use calibrate::Calibration;
pub use kalman::{GATE_99, KalmanParams, KalmanTracker};
pub use learned_pf::LearnedParticleFilter;
pub use particle::{MAX_PARTICLES, ParticleFilter, PfModel};
