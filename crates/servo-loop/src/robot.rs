//! The robot interface: the only two things the learner may do with an arm.

use image::GrayImage;

/// A robot seen through cameras: send one set-point per servo, capture one grey image per
/// camera. Nothing else — no joint read-back, no kinematic model, no ground truth (Paper C's
/// low-cost arm has no joint feedback).
///
/// `servo-loop` does not depend on any simulator; `arm-sim`'s `ArmSim` implements this trait in
/// a few lines (see the crate's integration tests and the xtask).
pub trait Robot {
    /// The robot's own error type; its message is kept in [`crate::ServoError::Robot`].
    type Error: std::fmt::Display;

    /// Number of servos (length of every command).
    fn num_servos(&self) -> usize;

    /// The accepted set-point range `[min, max]` of servo `i`.
    fn servo_range(&self, i: usize) -> [f64; 2];

    /// Sends one set-point per servo and waits until the arm has settled.
    fn command(&mut self, set_points: &[f64]) -> Result<(), Self::Error>;

    /// One image per camera of the current scene (always the same number of cameras).
    fn capture(&mut self) -> Result<Vec<GrayImage>, Self::Error>;
}
