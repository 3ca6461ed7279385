//! The non-idealities behave as specified, and the ideal arm has none of them.

use arm_sim::servo::{ServoState, calibrated_target, nominal_angle, nominal_pulse, quantise};
use arm_sim::{ArmSim, SimConfig, apply_sag, forward_kinematics};
use rand::SeedableRng;
use rand::rngs::Xoshiro256PlusPlus;

const HOME: [f64; 6] = [1500.0; 6];

/// Ideal arm plus one non-ideality set by `f`, small images (no rendering happens anyway).
fn sim_with(f: impl FnOnce(&mut SimConfig)) -> ArmSim {
    let mut c = SimConfig::ideal().with_image_scale(0.25);
    f(&mut c);
    ArmSim::new(c).unwrap()
}

fn with_servo(servo: usize, set: f64) -> [f64; 6] {
    let mut p = HOME;
    p[servo] = set;
    p
}

#[test]
fn nominal_mapping_and_calibration_by_hand() {
    let c = SimConfig::default().servos[2].clone();
    assert_eq!(nominal_angle(&c, 1500.0), 90.0);
    assert!((nominal_angle(&c, 2500.0) - 180.0).abs() < 1e-12);
    assert!((nominal_pulse(&c, 45.0) - 1000.0).abs() < 1e-9);
    // offset 18 µs, gain 1.05, quantum 1 µs: 1700.4 → 1700 → 90 + 0.09 (18 + 1.05·200).
    assert_eq!(quantise(&c, 1700.4), 1700.0);
    assert!((calibrated_target(&c, 1700.4) - (90.0 + 0.09 * (18.0 + 210.0))).abs() < 1e-12);
    let mut q = c.clone();
    q.quantum_us = 8.0;
    assert_eq!(quantise(&q, 1511.0), 1508.0);
    assert_eq!(quantise(&q, 1513.0), 1516.0);
}

#[test]
fn backlash_from_opposite_sides() {
    for servo in 0..5 {
        let mut sim = sim_with(|c| c.servos[servo].backlash_deg = 0.6);
        let set = 1600.0;
        sim.command(&with_servo(servo, 1300.0)).unwrap();
        sim.command(&with_servo(servo, set)).unwrap();
        let from_below = sim.inspect().unloaded_angles()[servo];
        sim.command(&with_servo(servo, 1900.0)).unwrap();
        sim.command(&with_servo(servo, set)).unwrap();
        let from_above = sim.inspect().unloaded_angles()[servo];
        let nominal = sim
            .inspect()
            .nominal_angles(&with_servo(servo, set))
            .unwrap()[servo];
        assert!(
            (from_above - from_below - 0.6).abs() < 1e-9,
            "servo {servo}"
        );
        assert!((0.5 * (from_above + from_below) - nominal).abs() < 1e-9);
    }
}

#[test]
fn deadband_ignores_small_changes_and_adds_hysteresis() {
    let mut sim = sim_with(|c| c.servos[1].deadband_us = 6.0);
    sim.command(&with_servo(1, 1700.0)).unwrap();
    let a = sim.inspect().unloaded_angles()[1];
    // Stops 3 µs short of the target when coming from below.
    assert!((a - 0.09 * 197.0).abs() < 1e-9, "{a}");
    // A set-point 2 µs from where the motor stopped (1697 µs) is inside the band: no move.
    sim.command(&with_servo(1, 1699.0)).unwrap();
    assert_eq!(sim.inspect().unloaded_angles()[1], a);
    assert!(!sim.inspect().last_move().moved[1]);
    // From above the same set-point ends 3 µs beyond it: total hysteresis = the deadband.
    sim.command(&with_servo(1, 1800.0)).unwrap();
    sim.command(&with_servo(1, 1700.0)).unwrap();
    let b = sim.inspect().unloaded_angles()[1];
    assert!((b - a - 0.09 * 6.0).abs() < 1e-9);
}

#[test]
fn move_noise_has_the_configured_spread_and_only_on_moves() {
    let mut cfg = SimConfig::ideal().servos[0].clone();
    cfg.end_noise_deg = 0.2;
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(1);
    let mut s = ServoState::at_rest(&cfg, 1500.0);
    let n = 4000;
    let (mut sum, mut sum2) = (0.0, 0.0);
    for k in 0..n {
        let set = if k % 2 == 0 { 1600.0 } else { 1400.0 };
        assert!(s.step(&cfg, set, &mut rng).unwrap());
        let e = s.output_deg - nominal_angle(&cfg, set);
        sum += e;
        sum2 += e * e;
    }
    let mean = sum / n as f64;
    let sd = (sum2 / n as f64 - mean * mean).sqrt();
    assert!(
        mean.abs() < 0.02 && (sd - 0.2).abs() < 0.02,
        "mean {mean} sd {sd}"
    );
    // Same set-point again: no move, no new noise.
    let before = s.output_deg;
    assert!(!s.step(&cfg, 1400.0, &mut rng).unwrap());
    assert_eq!(s.output_deg, before);
}

#[test]
fn sag_grows_with_reach() {
    let mut sim = sim_with(|c| c.sag = SimConfig::default().sag);
    let g = sim.inspect().config().arm.clone();
    let mut last_drop = -1.0;
    let mut last_reach = -1.0;
    // Shoulder leaning further forward with the forearm kept horizontal: the reach grows.
    for shoulder in [0.0, 15.0, 30.0, 45.0, 60.0, 75.0] {
        let angles = [0.0, shoulder, 90.0 - shoulder, 0.0, 0.0, 0.0];
        let set: [f64; 6] =
            std::array::from_fn(|i| nominal_pulse(&sim.inspect().config().servos[i], angles[i]));
        sim.command(&set).unwrap();
        let rigid = forward_kinematics(&g, &angles);
        let drop = rigid.tip.z - sim.inspect().tip().z;
        let reach = rigid.tip.x;
        assert!(
            reach > last_reach && drop > last_drop,
            "shoulder {shoulder}: drop {drop}"
        );
        assert!(drop > 0.0);
        last_drop = drop;
        last_reach = reach;
    }
    // At 75° forward, ~300 mm reach: the default compliances give a sag of millimetres.
    assert!(last_drop > 3.0 && last_drop < 30.0, "{last_drop}");
    // apply_sag agrees with the simulator.
    let angles = [0.0, 75.0, 15.0, 0.0, 0.0, 0.0];
    let sagged = apply_sag(&g, &sim.inspect().config().sag, &angles);
    assert!((sagged[1] - sim.inspect().joint_angles()[1]).abs() < 1e-9);
}

#[test]
fn ideal_arm_has_none_of_them() {
    let mut sim = sim_with(|_| {});
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(3);
    use rand::RngExt;
    for _ in 0..200 {
        let set: [f64; 6] = std::array::from_fn(|_| rng.random_range(1200.0..1800.0));
        sim.command(&set).unwrap();
        let r = sim.inspect().last_move().clone();
        if r.table_contact || r.limited.iter().any(|&l| l) {
            continue;
        }
        let nominal = sim.inspect().nominal_angles(&set).unwrap();
        assert_eq!(sim.inspect().joint_angles(), nominal);
        let pose = forward_kinematics(&sim.inspect().config().arm, &nominal);
        assert_eq!(sim.inspect().tip(), pose.tip);
    }
}

#[test]
fn default_arm_is_not_ideal_but_repeatable_per_seed() {
    let run = |seed| {
        let mut c = SimConfig::default().with_image_scale(0.25);
        c.seed = seed;
        let mut sim = ArmSim::new(c).unwrap();
        let set = [1550.0, 1400.0, 1650.0, 1450.0, 1500.0, 1500.0];
        sim.command(&set).unwrap();
        (
            sim.inspect().joint_angles(),
            sim.inspect().nominal_angles(&set).unwrap(),
        )
    };
    let (a, nominal) = run(5);
    assert_eq!(a, run(5).0);
    assert_ne!(a, run(6).0);
    // Calibration error alone moves the shoulder by degrees.
    assert!((a[1] - nominal[1]).abs() > 1.0);
}

/// A refused step changes neither the servo nor the random stream: the servo and its generator
/// equal what they were, and the next steps equal a twin's that never saw the refusals.
#[test]
fn servo_step_refuses_bad_input_and_keeps_its_state() {
    let good = SimConfig::default().servos[1].clone();
    assert!(good.end_noise_deg > 0.0, "moves draw noise");
    let mut cfg = good.clone();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(3);
    let mut s = ServoState::at_rest(&cfg, 1500.0);
    assert!(s.step(&cfg, 1620.0, &mut rng).unwrap());
    let (before, rng_before) = (s.clone(), rng.clone());
    for p in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        assert!(matches!(
            s.step(&cfg, p, &mut rng),
            Err(arm_sim::ArmSimError::NonFinite { .. })
        ));
        assert_eq!(s, before);
        assert_eq!(rng, rng_before);
    }
    for noise in [-0.1, f64::NAN, f64::INFINITY] {
        cfg.end_noise_deg = noise;
        assert!(matches!(
            s.step(&cfg, 1400.0, &mut rng),
            Err(arm_sim::ArmSimError::InvalidConfig { .. })
        ));
        assert_eq!(s, before);
        assert_eq!(rng, rng_before);
    }
    let (mut twin, mut twin_rng) = (before, rng_before);
    for p in [1400.0, 1700.0, 1690.0, 1300.0] {
        assert_eq!(
            s.step(&good, p, &mut rng).unwrap(),
            twin.step(&good, p, &mut twin_rng).unwrap()
        );
        assert_eq!(s, twin);
    }
}

/// A stall at an angle that is not finite is refused and changes nothing (it used to become the
/// servo's output); a finite one puts the output there.
#[test]
fn stall_at_refuses_an_angle_that_is_not_finite() {
    let cfg = SimConfig::default().servos[2].clone();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(4);
    let mut s = ServoState::at_rest(&cfg, 1500.0);
    assert!(s.step(&cfg, 1700.0, &mut rng).unwrap());
    let before = s.clone();
    for angle in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        assert!(matches!(
            s.stall_at(&cfg, angle),
            Err(arm_sim::ArmSimError::NonFinite {
                what: "stall angle"
            })
        ));
        assert_eq!(s, before);
    }
    s.stall_at(&cfg, 12.5).unwrap();
    assert_eq!(s.output_deg, 12.5);
}

#[test]
fn nominal_angles_refuse_what_command_refuses() {
    let mut sim = sim_with(|_| {});
    let home = sim.inspect().nominal_angles(&HOME).unwrap();
    for (servo, bad) in [(0, f64::NAN), (3, 1e6), (5, -1e6)] {
        let set = with_servo(servo, bad);
        let nominal = sim.inspect().nominal_angles(&set).unwrap_err();
        let command = sim.command(&set).unwrap_err();
        // Compared as text: a NaN set-point's error carries the NaN, which equals nothing.
        assert_eq!(
            nominal.to_string(),
            command.to_string(),
            "servo {servo}, set-point {bad}"
        );
    }
    assert_eq!(sim.inspect().nominal_angles(&HOME).unwrap(), home);
}
