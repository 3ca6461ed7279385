//! `arm-sim`'s simulated arm as a `servo-loop` [`Robot`]: the one home of this glue. Neither
//! crate may depend on the other (docs/ARCHITECTURE.md), so the adapter lives here, above both;
//! the xtask's servo study, the pipeline, and the examples and tests that drive `servo-loop` on
//! the simulator all use it.

use arm_sim::{ArmSim, ArmSimError};
use image::GrayImage;
use servo_loop::Robot;

/// [`ArmSim`] as a [`Robot`] (a newtype: both the trait and the type are foreign to each
/// other's crates), counting the commands it is sent: `.0` is the simulator (ground truth
/// through `.0.inspect()`, for evaluation only), `.1` the number of commands sent so far.
pub struct SimRobot(pub ArmSim, pub usize);

impl SimRobot {
    /// The simulator with no command sent yet.
    pub fn new(sim: ArmSim) -> Self {
        SimRobot(sim, 0)
    }

    /// The simulator (ground truth through `sim().inspect()`).
    pub fn sim(&self) -> &ArmSim {
        &self.0
    }

    /// Commands sent so far (accepted or not; it stops at `usize::MAX`).
    pub fn commands(&self) -> usize {
        self.1
    }
}

impl Robot for SimRobot {
    type Error = ArmSimError;
    fn num_servos(&self) -> usize {
        self.0.num_servos()
    }
    /// The servo's pulse-width range; `[0, 0]` for a servo the arm does not have (the robot
    /// trait has no error here; `ControlSpace::validate` refuses such an index first).
    fn servo_range(&self, i: usize) -> [f64; 2] {
        self.0.servo_range(i).unwrap_or([0.0, 0.0])
    }
    fn command(&mut self, set_points: &[f64]) -> Result<(), ArmSimError> {
        // The count is a public field: at `usize::MAX` it stays there (it used to overflow).
        self.1 = self.1.saturating_add(1);
        self.0.command(set_points)
    }
    fn capture(&mut self) -> Result<Vec<GrayImage>, ArmSimError> {
        Ok(self.0.capture())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use arm_sim::SimConfig;

    #[test]
    fn forwards_to_the_simulator_and_counts_commands() {
        let mut robot = SimRobot::new(ArmSim::new(SimConfig::default()).unwrap());
        let n = robot.num_servos();
        assert_eq!(n, robot.sim().num_servos());
        assert_eq!(robot.servo_range(0), robot.sim().servo_range(0).unwrap());
        assert_eq!(robot.servo_range(n), [0.0, 0.0]);
        let mid: Vec<f64> = (0..n)
            .map(|i| {
                let [a, b] = robot.servo_range(i);
                0.5 * (a + b)
            })
            .collect();
        robot.command(&mid).unwrap();
        // A wrong-length command is the simulator's typed error, and it is still counted.
        assert!(robot.command(&mid[..2]).is_err());
        assert_eq!(robot.commands(), 2);
        let images = robot.capture().unwrap();
        assert_eq!(images.len(), robot.sim().num_cameras());
    }

    /// The count is a public field: one at `usize::MAX` stays there instead of overflowing
    /// (a panic in a debug build, a count of 0 in a release one).
    #[test]
    fn the_command_count_saturates() {
        let mut robot = SimRobot(ArmSim::new(SimConfig::default()).unwrap(), usize::MAX);
        let mid: Vec<f64> = (0..robot.num_servos())
            .map(|i| {
                let [a, b] = robot.servo_range(i);
                0.5 * (a + b)
            })
            .collect();
        robot.command(&mid).unwrap();
        assert_eq!(robot.commands(), usize::MAX);
    }
}
