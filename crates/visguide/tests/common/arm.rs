//! The control space and exploration box of the default arm, shared by the tests that drive
//! `servo-loop` on `arm-sim` (included with `#[path]`).

use servo_loop::ControlSpace;

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
