//! The control space and exploration box of the default arm, and its heuristic percept as the
//! tests learn it, shared by the tests that drive `servo-loop` on `arm-sim`.

use servo_loop::{ControlSpace, Robot, SilhouetteConfig, TipModel, learn_recognition};

/// Base, shoulder and elbow set-point ranges explored (µs).
pub const EXPLORE: [[f64; 2]; 3] = [[1167.0, 1833.0], [1389.0, 1833.0], [1111.0, 1611.0]];

/// Base, shoulder and elbow controlled; wrist and gripper held; the gripper moves 2100 ↔ 1000 µs
/// when learning.
pub fn space() -> ControlSpace {
    ControlSpace {
        controlled: vec![0, 1, 2],
        rest: vec![1500.0, 1500.0, 1500.0, 1944.0, 1500.0, 1500.0],
        gripper: Some((5, [2100.0, 1000.0])),
    }
}

/// The heuristic percept (servo-loop's learned silhouette tip) learned on `robot` with `config`
/// from 8 training views of seed 11 in [`EXPLORE`].
pub fn heuristic<R: Robot>(robot: &mut R, config: &SilhouetteConfig) -> TipModel {
    learn_recognition(robot, &space(), &EXPLORE, 8, 11, config)
        .unwrap()
        .0
}
