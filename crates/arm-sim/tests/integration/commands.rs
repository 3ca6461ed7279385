//! Bad commands are typed errors that leave the arm where it was; limits and the table stall it.

use arm_sim::servo::nominal_pulse;
use arm_sim::{ArmSim, ArmSimError, SimConfig};

fn sim() -> ArmSim {
    ArmSim::new(SimConfig::default().with_image_scale(0.25)).unwrap()
}

#[test]
fn non_finite_out_of_range_and_wrong_length_are_typed_errors() {
    let mut s = sim();
    s.command(&[1500.0, 1400.0, 1600.0, 1500.0, 1500.0, 1500.0])
        .unwrap();
    let before = s.inspect().joint_angles();
    let mut bad = [1500.0; 6];
    bad[3] = f64::NAN;
    assert!(matches!(
        s.command(&bad),
        Err(ArmSimError::NonFiniteCommand { servo: 3, .. })
    ));
    bad[3] = f64::NEG_INFINITY;
    assert!(matches!(
        s.command(&bad),
        Err(ArmSimError::NonFiniteCommand { servo: 3, .. })
    ));
    bad[3] = 1500.0;
    bad[0] = 499.9;
    assert!(matches!(
        s.command(&bad),
        Err(ArmSimError::CommandOutOfRange {
            servo: 0,
            min: 500.0,
            max: 2500.0,
            ..
        })
    ));
    bad[0] = 1500.0;
    bad[5] = 2500.5;
    assert!(matches!(
        s.command(&bad),
        Err(ArmSimError::CommandOutOfRange { servo: 5, .. })
    ));
    assert!(matches!(
        s.command(&[1500.0; 5]),
        Err(ArmSimError::WrongCommandLength {
            expected: 6,
            got: 5
        })
    ));
    assert_eq!(s.inspect().joint_angles(), before);
    // The ends of the range are valid.
    s.command(&[500.0, 1500.0, 1500.0, 2500.0, 500.0, 2500.0])
        .unwrap();
}

#[test]
fn joint_limit_clamps_and_reports() {
    let mut s = ArmSim::new(SimConfig::ideal().with_image_scale(0.25)).unwrap();
    // The elbow servo reaches 0°..180°; its bracket stops it at 150°.
    let p = nominal_pulse(&s.inspect().config().servos[2], 170.0);
    // (Shoulder leaning back 40° so that the folded arm stays above the table.)
    let back = nominal_pulse(&s.inspect().config().servos[1], -40.0);
    s.command(&[1500.0, back, p, 1500.0, 1500.0, 1500.0])
        .unwrap();
    assert!(!s.inspect().last_move().table_contact);
    assert!(s.inspect().last_move().limited[2]);
    assert_eq!(s.inspect().joint_angles()[2], 150.0);
    s.command(&[1500.0; 6]).unwrap();
    assert!(!s.inspect().last_move().limited.iter().any(|&l| l));
}

#[test]
fn table_stops_the_arm() {
    let mut s = ArmSim::new(SimConfig::default().with_image_scale(0.25)).unwrap();
    // Shoulder far forward with the elbow at 90°: the forearm points down into the table.
    let set = [1500.0, 2400.0, 1500.0, 1500.0, 1500.0, 1500.0];
    s.command(&set).unwrap();
    let r = s.inspect().last_move().clone();
    assert!(r.table_contact, "{r:?}");
    assert!(r.executed_fraction > 0.0 && r.executed_fraction < 1.0);
    let pose = s.inspect().pose().clone();
    assert!(pose.tip.z > 0.0 && pose.wrist.z > 0.0 && pose.elbow.z > 0.0);
    assert!(pose.finger_ends.iter().all(|e| e.z > 0.0));
    // It stalled close to the table (within a few mm of touching).
    let lowest = pose
        .finger_ends
        .iter()
        .map(|e| e.z)
        .fold(f64::INFINITY, f64::min);
    assert!(lowest < 15.0, "{lowest}");
    // Backing off works normally.
    s.command(&[1500.0; 6]).unwrap();
    assert!(!s.inspect().last_move().table_contact);
}
