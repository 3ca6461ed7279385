//! What the simulator promises about its own state: the home pose after `new`, a rejected
//! command changing nothing (not even the random stream), the frame counter, labels before the
//! first capture, the public servo ranges, camera indices and the image's half-pixel border.

use arm_sim::{ArmSim, ArmSimError, MoveReport, NUM_SERVOS, SimConfig, home_set_points};
use nalgebra::Vector3;

fn sim() -> ArmSim {
    ArmSim::new(SimConfig::default().with_image_scale(0.25)).unwrap()
}

/// Everything a rejected command could have touched, ground truth included.
fn state(s: &ArmSim) -> String {
    let i = s.inspect();
    format!(
        "{:?} {:?} {:?} {:?} {:?} {}",
        i.joint_angles(),
        i.unloaded_angles(),
        i.last_set_points(),
        i.last_move(),
        i.pose(),
        i.frames()
    )
}

#[test]
fn new_puts_every_servo_at_its_centre_with_no_frame() {
    let s = sim();
    let cfg = s.inspect().config().clone();
    let home = home_set_points(&cfg);
    for (i, servo) in cfg.servos.iter().enumerate() {
        assert_eq!(home[i], servo.centre_us, "servo {i}");
    }
    assert_eq!(s.inspect().last_set_points(), home);
    assert_eq!(s.inspect().frames(), 0);
    // No command yet: the report of no move.
    assert_eq!(*s.inspect().last_move(), MoveReport::default());
    assert_eq!(s.inspect().last_move().executed_fraction, 0.0);
    // Commanding the home set-points again: an ideal arm (no noise, deadband or backlash)
    // does not move from where `new` put it.
    let mut ideal = ArmSim::new(SimConfig::ideal().with_image_scale(0.25)).unwrap();
    let before = ideal.inspect().joint_angles();
    ideal
        .command(&home_set_points(ideal.inspect().config()))
        .unwrap();
    assert_eq!(ideal.inspect().joint_angles(), before);
    assert_eq!(ideal.inspect().last_move().moved, [false; NUM_SERVOS]);
    // A move the table does not stop is executed whole.
    ideal
        .command(&[1600.0, 1400.0, 1600.0, 1500.0, 1500.0, 1500.0])
        .unwrap();
    let report = ideal.inspect().last_move().clone();
    assert!(report.moved[0] && !report.table_contact);
    assert_eq!(report.executed_fraction, 1.0);
}

/// `Inspection::labels` before the first capture is an all-zero image of the camera's size (it
/// used to panic: the label buffer is only allocated with the first frame).
#[test]
fn labels_before_the_first_capture_are_all_zero() {
    let s = sim();
    let cfg = s.inspect().config().clone();
    for cam in 0..s.num_cameras() {
        let labels = s.inspect().labels(cam).unwrap();
        assert_eq!(
            (labels.width(), labels.height()),
            (cfg.cameras[cam].width, cfg.cameras[cam].height)
        );
        assert!(labels.as_raw().iter().all(|&l| l == 0), "camera {cam}");
    }
}

#[test]
fn frames_count_captures_and_labels_appear_with_the_first() {
    let mut s = sim();
    for n in 1..=3u64 {
        let images = s.capture();
        assert_eq!(images.len(), s.num_cameras());
        assert_eq!(s.inspect().frames(), n);
    }
    // Commands and inspection do not count as frames.
    s.command(&[1600.0, 1400.0, 1600.0, 1500.0, 1500.0, 1500.0])
        .unwrap();
    let _ = s.inspect().tip_pixels().unwrap();
    assert_eq!(s.inspect().frames(), 3);
    for cam in 0..s.num_cameras() {
        assert!(s.inspect().labels(cam).unwrap().iter().any(|&l| l != 0));
    }
}

/// A rejected command changes no state: the arm, the servos' hidden state, the last
/// set-points and move report, and the random streams (a twin that never saw the bad
/// commands moves and renders byte for byte the same afterwards).
#[test]
fn a_rejected_command_changes_nothing_not_even_the_random_stream() {
    let (mut a, mut b) = (sim(), sim());
    let first = [1500.0, 1400.0, 1650.0, 1450.0, 1500.0, 1300.0];
    a.command(&first).unwrap();
    b.command(&first).unwrap();
    let before = state(&a);
    // Each bad command moves other servos first in command order, so a servo stepped before
    // the check would show.
    let mut bad = [[1700.0, 1250.0, 1800.0, 1300.0, 1600.0, 1500.0]; 4];
    bad[0][3] = f64::NAN;
    bad[1][5] = f64::INFINITY;
    bad[2][4] = 2600.0;
    bad[3][5] = 499.0;
    for cmd in &bad {
        assert!(a.command(cmd).is_err(), "{cmd:?}");
        assert_eq!(state(&a), before, "{cmd:?}");
    }
    assert!(matches!(
        a.command(&[1700.0; 7]),
        Err(ArmSimError::WrongCommandLength { .. })
    ));
    assert_eq!(state(&a), before);
    // The same valid command on both: identical servo noise and identical images.
    let next = [1550.0, 1300.0, 1700.0, 1400.0, 1450.0, 1600.0];
    a.command(&next).unwrap();
    b.command(&next).unwrap();
    assert_eq!(state(&a), state(&b));
    let (ia, ib) = (a.capture(), b.capture());
    assert!(ia.iter().zip(&ib).all(|(x, y)| x.as_raw() == y.as_raw()));
}

#[test]
fn servo_ranges_are_the_configured_pulse_widths() {
    let s = sim();
    let cfg = s.inspect().config();
    assert_eq!(s.num_servos(), NUM_SERVOS);
    for i in 0..NUM_SERVOS {
        let c = &cfg.servos[i];
        assert_eq!(s.servo_range(i), Some([c.min_us, c.max_us]), "servo {i}");
    }
    assert_eq!(s.servo_range(0), Some([500.0, 2500.0]));
    assert_eq!(s.servo_range(NUM_SERVOS), None);
    assert_eq!(s.servo_range(usize::MAX), None);
}

/// Every per-camera accessor refuses an index past the cameras with `NoSuchCamera`.
#[test]
fn camera_indices_past_the_cameras_are_no_such_camera() {
    let s = sim();
    let n = s.num_cameras();
    assert_eq!(n, 2);
    let is_missing =
        |e: ArmSimError| matches!(e, ArmSimError::NoSuchCamera { camera, count: 2 } if camera >= n);
    for i in [n, n + 1, usize::MAX] {
        assert!(is_missing(s.inspect().camera(i).unwrap_err()));
        assert!(is_missing(s.inspect().labels(i).unwrap_err()));
        assert!(is_missing(
            s.inspect()
                .project(i, &Vector3::new(0.0, 0.0, 50.0))
                .unwrap_err()
        ));
    }
    assert!(s.inspect().camera(n - 1).is_ok());
}

/// `in_image`: pixel centres `0..=width−1` with a half-pixel border, so `[−0.5, width − 0.5)`.
#[test]
fn in_image_includes_the_half_pixel_border_on_the_near_sides_only() {
    let s = sim();
    let inspection = s.inspect();
    let cam = inspection.camera(0).unwrap();
    let (w, h) = (cam.width as f64, cam.height as f64);
    for uv in [
        [-0.5, -0.5],
        [0.0, 0.0],
        [w - 1.0, h - 1.0],
        [w - 0.5 - 1e-9, h - 0.5 - 1e-9],
    ] {
        assert!(cam.in_image(uv), "{uv:?}");
    }
    for uv in [
        [-0.5 - 1e-9, 0.0],
        [0.0, -0.5 - 1e-9],
        [w - 0.5, 0.0],
        [0.0, h - 0.5],
        [f64::NAN, 0.0],
    ] {
        assert!(!cam.in_image(uv), "{uv:?}");
    }
}
