//! Forward kinematics and gravity torques against hand-computed values.

use arm_sim::kinematics::{FINGER_THICKNESS_MM, GRAVITY, gripper_opening};
use arm_sim::{ArmGeometry, SagConfig, apply_sag, forward_kinematics, gravity_torques};
use nalgebra::Vector3;

fn close(a: &Vector3<f64>, b: [f64; 3]) {
    let b = Vector3::from(b);
    assert!((a - b).norm() < 1e-9, "{a:?} != {b:?}");
}

#[test]
fn upright_chain_stacks_the_links() {
    let g = ArmGeometry::default();
    let p = forward_kinematics(&g, &[0.0; 6]);
    close(&p.shoulder, [0.0, 0.0, 75.0]);
    close(&p.elbow, [0.0, 0.0, 195.0]);
    close(&p.wrist, [0.0, 0.0, 315.0]);
    close(&p.tip, [0.0, 0.0, 415.0]);
    close(&p.approach, [0.0, 0.0, 1.0]);
    close(&p.pitch_axis, [0.0, 1.0, 0.0]);
}

#[test]
fn home_pose_has_horizontal_forearm() {
    // Elbow servo centred = 90°: the forearm and hand point straight forward.
    let g = ArmGeometry::default();
    let p = forward_kinematics(&g, &[0.0, 0.0, 90.0, 0.0, 0.0, 0.0]);
    close(&p.elbow, [0.0, 0.0, 195.0]);
    close(&p.wrist, [120.0, 0.0, 195.0]);
    close(&p.tip, [220.0, 0.0, 195.0]);
}

#[test]
fn stretched_forward_and_yawed() {
    let g = ArmGeometry::default();
    let p = forward_kinematics(&g, &[0.0, 90.0, 0.0, 0.0, 0.0, 0.0]);
    close(&p.tip, [340.0, 0.0, 75.0]);
    // Base yaw 90° turns the arm plane to +y.
    let p = forward_kinematics(&g, &[90.0, 90.0, 0.0, 0.0, 0.0, 0.0]);
    close(&p.tip, [0.0, 340.0, 75.0]);
    close(&p.pitch_axis, [-1.0, 0.0, 0.0]);
}

#[test]
fn mixed_angles_by_hand() {
    // φ1 = 30°, φ2 = 90°, φ3 = 135°:
    // E = (120 sin30, 0, 75 + 120 cos30) = (60, 0, 178.923…),
    // W = E + 120 (1, 0, 0), T = W + 100 (sin135, 0, cos135).
    let g = ArmGeometry::default();
    let p = forward_kinematics(&g, &[0.0, 30.0, 60.0, 45.0, 0.0, 0.0]);
    let c30 = 3f64.sqrt() / 2.0;
    let h = 0.5f64.sqrt();
    close(&p.elbow, [60.0, 0.0, 75.0 + 120.0 * c30]);
    close(&p.wrist, [180.0, 0.0, 75.0 + 120.0 * c30]);
    close(
        &p.tip,
        [180.0 + 100.0 * h, 0.0, 75.0 + 120.0 * c30 - 100.0 * h],
    );
    // Yaw −30° rotates the same pose about z.
    let q = forward_kinematics(&g, &[-30.0, 30.0, 60.0, 45.0, 0.0, 0.0]);
    let r = 180.0 + 100.0 * h;
    close(&q.tip, [r * c30, -r * 0.5, p.tip.z]);
}

#[test]
fn wrist_roll_turns_fingers_not_tip() {
    let g = ArmGeometry::default();
    let a = forward_kinematics(&g, &[10.0, 20.0, 70.0, 30.0, 0.0, 0.0]);
    let b = forward_kinematics(&g, &[10.0, 20.0, 70.0, 30.0, 90.0, 0.0]);
    assert!((a.tip - b.tip).norm() < 1e-9);
    assert!(a.opening_axis.dot(&b.opening_axis).abs() < 1e-9);
    assert!(b.opening_axis.dot(&b.approach).abs() < 1e-9);
    // Fingers symmetric about the tool point pushed forward by the pad.
    let mid = (b.finger_ends[0] + b.finger_ends[1]) * 0.5;
    assert!((mid - (b.tip + b.approach * g.finger_pad_mm)).norm() < 1e-9);
    let gap = (b.finger_ends[0] - b.finger_ends[1]).norm();
    assert!((gap - (b.opening_mm + FINGER_THICKNESS_MM)).abs() < 1e-9);
}

#[test]
fn finger_middle_is_the_mean_of_the_finger_ends() {
    // Brute force over a grid of poses (yaw, shoulder, elbow, wrist pitch, roll, gripper):
    // the mean of the two ends coordinate by coordinate, bit for bit, and 8 mm (the pad)
    // ahead of the tool point.
    let g = ArmGeometry::default();
    let steps = [-75.0, -20.0, 0.0, 35.0, 80.0];
    let mut checked = 0;
    for &yaw in &steps {
        for &q1 in &steps {
            for &q2 in &steps {
                for &q3 in &steps {
                    let roll = q1 + q2;
                    let grip = q3 - yaw;
                    let p = forward_kinematics(&g, &[yaw, q1, q2, q3, roll, grip]);
                    let [a, b] = p.finger_ends;
                    let mean =
                        Vector3::new((a.x + b.x) / 2.0, (a.y + b.y) / 2.0, (a.z + b.z) / 2.0);
                    assert_eq!(p.finger_middle(), mean);
                    let ahead = (mean - p.tip).dot(&p.approach);
                    assert!((ahead - g.finger_pad_mm).abs() < 1e-9, "{ahead}");
                    checked += 1;
                }
            }
        }
    }
    assert_eq!(checked, 625);
}

#[test]
fn gripper_opening_is_linear_in_servo_angle() {
    let g = ArmGeometry::default();
    assert_eq!(gripper_opening(&g, -90.0), 0.0);
    assert!((gripper_opening(&g, 0.0) - 16.0).abs() < 1e-12);
    assert_eq!(gripper_opening(&g, 90.0), 32.0);
    assert_eq!(gripper_opening(&g, 120.0), 32.0);
}

#[test]
fn gravity_torques_of_horizontal_arm_by_hand() {
    // Stretched horizontally: levers from the shoulder are 60 (upper arm), 120 (elbow servo),
    // 180 (forearm), 240 (wrist servos), 290 (hand) mm.
    let g = ArmGeometry::default();
    let sag = SagConfig {
        compliance_deg_per_nm: [1.0, 1.0, 1.0],
        masses_kg: [0.1, 0.2, 0.3, 0.4, 0.5],
    };
    let t = gravity_torques(&g, &sag, &[0.0, 90.0, 0.0, 0.0, 0.0, 0.0]);
    let shoulder =
        GRAVITY * 1e-3 * (0.1 * 60.0 + 0.3 * 120.0 + 0.2 * 180.0 + 0.4 * 240.0 + 0.5 * 290.0);
    let elbow = GRAVITY * 1e-3 * (0.2 * 60.0 + 0.4 * 120.0 + 0.5 * 170.0);
    let wrist = GRAVITY * 1e-3 * (0.5 * 50.0);
    assert!((t[0] - shoulder).abs() < 1e-12, "{t:?}");
    assert!((t[1] - elbow).abs() < 1e-12);
    assert!((t[2] - wrist).abs() < 1e-12);
    // Upright: no lever, no torque, no sag.
    let t0 = gravity_torques(&g, &sag, &[0.0; 6]);
    assert!(t0.iter().all(|v| v.abs() < 1e-12));
    assert_eq!(apply_sag(&g, &sag, &[0.0; 6])[1..4], [0.0; 3]);
}

mod properties {
    use arm_sim::{ArmGeometry, forward_kinematics};
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(crate::seeded(128))]
        /// Rigid links: joint distances are the link lengths for any angles, the hand frame is
        /// orthonormal, and the tip's horizontal direction is the base yaw.
        #[test]
        fn links_are_rigid(q in prop::array::uniform6(-90.0f64..90.0)) {
            let g = ArmGeometry::default();
            let p = forward_kinematics(&g, &q);
            prop_assert!(((p.elbow - p.shoulder).norm() - g.upper_arm_mm).abs() < 1e-9);
            prop_assert!(((p.wrist - p.elbow).norm() - g.forearm_mm).abs() < 1e-9);
            prop_assert!(((p.tip - p.wrist).norm() - g.hand_mm).abs() < 1e-9);
            prop_assert!((p.approach.norm() - 1.0).abs() < 1e-12);
            prop_assert!(p.approach.dot(&p.opening_axis).abs() < 1e-12);
            // Everything lies in the vertical plane of the base yaw.
            let n = p.pitch_axis;
            for v in [p.elbow, p.wrist, p.tip] {
                prop_assert!(v.dot(&n).abs() < 1e-9);
            }
        }
    }
}

#[test]
fn an_impossible_gripper_size_gives_a_nan_opening_not_a_panic() {
    // `forward_kinematics` (and `gravity_torques`, `apply_sag`, which call it) is public and
    // takes any `ArmGeometry`: a negative or NaN `max_opening_mm` (which
    // `SimConfig::validate` refuses) made `f64::clamp(0, max)` panic ("min > max, or either
    // was NaN"). The opening is now NaN; the rest of the pose does not depend on it.
    let good = forward_kinematics(&ArmGeometry::default(), &[10.0, 20.0, 70.0, 30.0, 0.0, 0.0]);
    for bad in [-1.0, f64::NAN, f64::NEG_INFINITY] {
        let g = ArmGeometry {
            max_opening_mm: bad,
            ..ArmGeometry::default()
        };
        assert!(gripper_opening(&g, 0.0).is_nan(), "{bad}");
        let p = forward_kinematics(&g, &[10.0, 20.0, 70.0, 30.0, 0.0, 0.0]);
        assert!(p.opening_mm.is_nan(), "{bad}");
        assert_eq!((p.tip, p.approach), (good.tip, good.approach), "{bad}");
        let sag = SagConfig {
            compliance_deg_per_nm: [4.0, 5.0, 6.0],
            masses_kg: [0.035, 0.030, 0.055, 0.060, 0.050],
        };
        let q = [0.0, 90.0, 0.0, 0.0, 0.0, 0.0];
        let default = ArmGeometry::default();
        assert_eq!(
            gravity_torques(&g, &sag, &q),
            gravity_torques(&default, &sag, &q)
        );
        assert_eq!(apply_sag(&g, &sag, &q), apply_sag(&default, &sag, &q));
    }
    // A gripper that cannot open at all is valid: the opening is 0.
    let g = ArmGeometry {
        max_opening_mm: 0.0,
        ..ArmGeometry::default()
    };
    assert_eq!(gripper_opening(&g, 45.0), 0.0);
}
