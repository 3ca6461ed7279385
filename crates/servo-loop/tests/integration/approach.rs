//! The unidirectional approach on an analytic plant whose joints are hobby servos with a
//! deadband, gear backlash and a 1 µs controller: without it the loop stalls at corrections
//! smaller than the deadband; with it the loop converges to the resolution floor.

use nalgebra::DMatrix;
use servo_loop::{
    Approach, ApproachDirection, ApproachState, InverseModel, InverseModelConfig, LearnConfig,
    Observation, Plant, ServoConfig, ServoError, learn_control, servo_image_jacobian, servo_lwpr,
};

use servo_loop::stats::quantile_rank;

const DEG_PER_US: f64 = 0.09;
const DEADBAND_US: f64 = 4.0;
const BACKLASH_DEG: f64 = 0.3;
const QUANTUM_US: f64 = 1.0;
const L: [f64; 2] = [120.0, 120.0];
const RANGE: [f64; 2] = [500.0, 2500.0];
const EXPLORE: [[f64; 2]; 2] = [[1200.0, 1800.0], [1200.0, 1800.0]];

/// One servo (test copy of the physics described in `servo_loop::approach`): quantised
/// set-point, motor stops on entering the deadband, shaft lags by half the backlash.
#[derive(Clone, Copy)]
struct Servo {
    motor_deg: f64,
    dir: f64,
}

impl Servo {
    fn target_deg(us: f64) -> f64 {
        DEG_PER_US * (QUANTUM_US * (us / QUANTUM_US).round() - 1500.0)
    }
    fn step(&mut self, us: f64) {
        let t = Self::target_deg(us);
        let half = 0.5 * DEADBAND_US * DEG_PER_US;
        let e = t - self.motor_deg;
        if e.abs() > half {
            self.dir = e.signum();
            self.motor_deg = t - self.dir * half;
        }
    }
    fn output_deg(&self) -> f64 {
        self.motor_deg - self.dir * 0.5 * BACKLASH_DEG
    }
}

/// A planar two-link arm driven by two such servos, seen by an ideal camera (1 px per mm).
struct HobbyArm {
    servos: [Servo; 2],
    hysteresis: bool,
    acts: usize,
}

impl HobbyArm {
    fn new(hysteresis: bool) -> Self {
        HobbyArm {
            servos: [Servo {
                motor_deg: 0.0,
                dir: 0.0,
            }; 2],
            hysteresis,
            acts: 0,
        }
    }
    fn angles(&self) -> [f64; 2] {
        [
            (30.0 + self.servos[0].output_deg()).to_radians(),
            (60.0 + self.servos[1].output_deg()).to_radians(),
        ]
    }
    fn tip(&self) -> [f64; 2] {
        let [a, b] = self.angles();
        [
            320.0 + L[0] * a.cos() + L[1] * (a + b).cos(),
            400.0 - L[0] * a.sin() - L[1] * (a + b).sin(),
        ]
    }
}

impl Plant for HobbyArm {
    fn percept_dim(&self) -> usize {
        2
    }
    fn command_dim(&self) -> usize {
        2
    }
    fn command_range(&self, _: usize) -> [f64; 2] {
        RANGE
    }
    fn act(&mut self, y: &[f64]) -> servo_loop::Result<()> {
        self.acts += 1;
        for (s, &v) in self.servos.iter_mut().zip(y) {
            if self.hysteresis {
                s.step(v);
            } else {
                s.motor_deg = Servo::target_deg(v);
                s.dir = 0.0;
            }
        }
        Ok(())
    }
    fn observe(&mut self) -> servo_loop::Result<Observation> {
        Ok(Observation {
            x: self.tip().to_vec(),
            certainty: 1.0,
        })
    }
}

/// The arm's exact image Jacobian `∂x/∂y` (px per µs) of the ideal (hysteresis-free) model.
fn image_jacobian(y: &[f64]) -> servo_loop::Result<DMatrix<f64>> {
    let k = DEG_PER_US.to_radians();
    let a = (30.0 + DEG_PER_US * (y[0] - 1500.0)).to_radians();
    let b = (60.0 + DEG_PER_US * (y[1] - 1500.0)).to_radians();
    let (s1, s12, c1, c12) = (a.sin(), (a + b).sin(), a.cos(), (a + b).cos());
    Ok(DMatrix::from_row_slice(
        2,
        2,
        &[
            k * (-L[0] * s1 - L[1] * s12),
            k * (-L[1] * s12),
            k * (-L[0] * c1 - L[1] * c12),
            k * (-L[1] * c12),
        ],
    ))
}

/// Targets reached from alternating directions, each with its command and the first guess
/// (the target command off by a few µs, as an approximate inverse model gives it).
fn cases() -> Vec<([f64; 2], [f64; 2])> {
    (0..24)
        .map(|i| {
            let f = i as f64;
            let y = [1350.0 + 13.7 * f, 1700.0 - 11.3 * f];
            let off = [
                if i % 2 == 0 { 2.6 } else { -2.9 },
                if i % 3 == 0 { -3.3 } else { 2.2 },
            ];
            (y, [y[0] + off[0], y[1] + off[1]])
        })
        .collect()
}

fn config(approach: Option<Approach>) -> ServoConfig {
    ServoConfig {
        max_iterations: 8,
        tolerance: 0.05,
        approach,
        ..ServoConfig::default()
    }
}

/// Final image errors of the true-Jacobian loop over [`cases`].
fn final_errors(approach: Option<Approach>) -> Vec<f64> {
    let mut arm = HobbyArm::new(true);
    let mut out = Vec::new();
    for (k, (y, y0)) in cases().into_iter().enumerate() {
        // The target: where the arm ends when sent to `y` from above or from below.
        let side = if k % 2 == 0 { 40.0 } else { -40.0 };
        arm.act(&[y[0] + side, y[1] - side]).unwrap();
        arm.act(&y).unwrap();
        let x_w = arm.tip().to_vec();
        // Start the run from the other side, so the loop's corrections must reverse.
        arm.act(&[y0[0] - side, y0[1] + side]).unwrap();
        let run = servo_image_jacobian(&mut arm, &y0, &x_w, &config(approach.clone()), |y| {
            image_jacobian(y)
        })
        .unwrap();
        out.push(run.final_error());
    }
    out
}

/// The resolution floor: the largest image step of a half-quantum move of one joint.
fn resolution_floor() -> f64 {
    let j = image_jacobian(&[1500.0, 1500.0]).unwrap();
    0.5 * QUANTUM_US * (j.column(0).norm() + j.column(1).norm())
}

#[test]
fn plain_loop_stalls_on_deadband_and_backlash() {
    let plain = final_errors(None);
    // Corrections against the last direction smaller than the deadband do nothing: most runs
    // stop well above the resolution floor.
    let stalled = plain
        .iter()
        .filter(|&&e| e > 2.0 * resolution_floor())
        .count();
    assert!(
        stalled >= plain.len() / 2,
        "only {stalled} of {} runs stalled: {plain:?}",
        plain.len()
    );
}

#[test]
fn unidirectional_approach_converges_to_the_resolution_floor() {
    let floor = resolution_floor();
    let mut plain = final_errors(None);
    let mut approached = final_errors(Some(Approach::hobby_servo()));
    let worst = approached.iter().copied().fold(0.0, f64::max);
    assert!(
        worst <= floor,
        "worst {worst} > floor {floor}: {approached:?}"
    );
    assert!(quantile_rank(&mut approached, 0.5) < 0.5 * quantile_rank(&mut plain, 0.5));
}

#[test]
fn approach_converges_on_the_hysteresis_free_plant_too() {
    // On an ideal servo the approach costs nothing in accuracy (only the pre-moves).
    let mut arm = HobbyArm::new(false);
    let y = [1480.0, 1530.0];
    arm.act(&y).unwrap();
    let x_w = arm.tip().to_vec();
    arm.act(&[1600.0, 1400.0]).unwrap();
    let run = servo_image_jacobian(
        &mut arm,
        &[1487.0, 1521.0],
        &x_w,
        &config(Some(Approach::hobby_servo())),
        image_jacobian,
    )
    .unwrap();
    assert!(run.converged && run.final_error() < 1e-9, "{run:?}");
    assert_eq!(run.steps.last().unwrap().command, y.to_vec());
}

#[test]
fn learned_loop_with_approach_beats_the_plain_loop_on_the_hobby_arm() {
    let train = |approach: Option<Approach>| {
        let mut arm = HobbyArm::new(true);
        let mut model = InverseModel::new(
            2,
            2,
            &InverseModelConfig {
                percept_scale: 100.0,
                command_scale: 300.0,
                ..InverseModelConfig::default()
            },
        )
        .unwrap();
        let lc = LearnConfig {
            moves: 3000,
            explore: EXPLORE.to_vec(),
            seed: 5,
            approach,
        };
        learn_control(&mut arm, &mut model, &lc, |_, _| {}).unwrap();
        (arm, model)
    };
    let run_all = |approach: Option<Approach>| {
        let (mut arm, model) = train(approach.clone());
        let mut errors = Vec::new();
        for (k, (y, _)) in cases().into_iter().enumerate() {
            let side = if k % 2 == 0 { 40.0 } else { -40.0 };
            arm.act(&[y[0] + side, y[1] - side]).unwrap();
            arm.act(&y).unwrap();
            let x_w = arm.tip().to_vec();
            let mut m = model.clone();
            let run = servo_lwpr(&mut arm, &mut m, &x_w, &config(approach.clone())).unwrap();
            errors.push(run.error_at(5));
        }
        errors
    };
    let plain = run_all(None);
    let approached = run_all(Some(Approach::hobby_servo()));
    let max = |v: &[f64]| v.iter().copied().fold(0.0, f64::max);
    let floor = resolution_floor();
    // Every approached run ends within the resolution floor after 5 corrections; the plain
    // loop leaves runs stalled above it.
    assert!(max(&approached) <= floor, "approach {approached:?}");
    assert!(max(&plain) > 2.0 * floor, "plain {plain:?}");
}

#[test]
fn pre_positions_follow_the_approach_direction() {
    let mut arm = HobbyArm::new(true);
    let a = Approach::hobby_servo();
    let mut state = ApproachState::new();
    // Nothing known: every joint comes from 20 µs below.
    assert_eq!(
        state
            .pre_position(&arm, &a, &[1500.0, 1500.0], false)
            .unwrap(),
        Some(vec![1480.0, 1480.0])
    );
    assert_eq!(
        state
            .execute(&mut arm, &a, &[1500.0, 1500.0], false)
            .unwrap(),
        Some(vec![1480.0, 1480.0])
    );
    assert_eq!(arm.acts, 2);
    // Up (or unchanged) moves go straight; a joint going down is pre-positioned alone.
    assert_eq!(
        state
            .pre_position(&arm, &a, &[1503.0, 1500.0], false)
            .unwrap(),
        None
    );
    assert_eq!(
        state
            .pre_position(&arm, &a, &[1503.0, 1499.0], false)
            .unwrap(),
        Some(vec![1503.0, 1479.0])
    );
    // Re-seating approaches every joint anew; pre-positions stay in the servo range.
    assert_eq!(
        state
            .pre_position(&arm, &a, &[1500.0, 1500.0], true)
            .unwrap(),
        Some(vec![1480.0, 1480.0])
    );
    assert_eq!(
        state
            .pre_position(&arm, &a, &[510.0, 1500.0], true)
            .unwrap(),
        Some(vec![500.0, 1480.0])
    );
    let down = Approach {
        direction: ApproachDirection::Down,
        ..a.clone()
    };
    assert_eq!(
        state
            .pre_position(&arm, &down, &[1503.0, 1500.0], false)
            .unwrap(),
        Some(vec![1523.0, 1520.0])
    );
    // The joints really end on the approach side: from below, deadband/2 + backlash/2 short.
    let expect = Servo::target_deg(1500.0) - 0.5 * DEADBAND_US * DEG_PER_US - 0.5 * BACKLASH_DEG;
    assert!((arm.servos[1].output_deg() - expect).abs() < 1e-12);
}

#[test]
fn unchanged_command_above_tolerance_reseats_every_joint() {
    let mut arm = HobbyArm::new(true);
    arm.act(&[1500.0, 1500.0]).unwrap();
    let x_w = vec![0.0, 0.0]; // unreachable: the loop keeps going
    let run = servo_image_jacobian(
        &mut arm,
        &[1500.0, 1500.0],
        &x_w,
        &ServoConfig {
            max_iterations: 2,
            tolerance: 0.0,
            range: servo_loop::RangePolicy::Clamp,
            approach: Some(Approach::hobby_servo()),
            ..ServoConfig::default()
        },
        |_| Ok(DMatrix::from_element(2, 2, 1e9)), // steps far below the resolution
    )
    .unwrap();
    assert_eq!(run.steps.len(), 3);
    for s in &run.steps {
        assert_eq!(s.command, vec![1500.0, 1500.0]);
        assert_eq!(s.pre_position, Some(vec![1480.0, 1480.0]));
    }
}

#[test]
fn invalid_approach_is_a_typed_error() {
    for bad in [
        Approach {
            overshoot: 0.0,
            ..Approach::hobby_servo()
        },
        Approach {
            resolution: f64::NAN,
            ..Approach::hobby_servo()
        },
        // Divides every command to infinity.
        Approach {
            resolution: 1e-320,
            ..Approach::hobby_servo()
        },
    ] {
        let mut arm = HobbyArm::new(true);
        let err = servo_image_jacobian(
            &mut arm,
            &[1500.0, 1500.0],
            &[300.0, 200.0],
            &config(Some(bad)),
            image_jacobian,
        )
        .unwrap_err();
        assert!(matches!(err.error, ServoError::InvalidParameter { .. }));
        assert_eq!(arm.acts, 0);
    }
}

#[test]
fn resolutions_outside_the_documented_bounds_are_refused() {
    let with = |resolution| Approach {
        resolution,
        ..Approach::hobby_servo()
    };
    for ok in [0.0, 1e-9, 1e-3, 1.0, 20.0, 1e9] {
        with(ok).validate().unwrap();
    }
    for bad in [
        f64::NAN,
        f64::INFINITY,
        -1.0,
        -1e-9,
        1e-320,
        f64::MIN_POSITIVE,
        1e-10,
        1e10,
        f64::MAX,
    ] {
        assert!(
            matches!(
                with(bad).validate(),
                Err(ServoError::InvalidParameter {
                    name: "resolution",
                    ..
                })
            ),
            "resolution {bad}"
        );
    }
}

#[test]
fn rounding_never_overflows_and_is_unchanged_on_ordinary_commands() {
    // Ordinary commands: the nearest multiple, as always (halves away from zero).
    let hobby = Approach::hobby_servo();
    assert_eq!(
        hobby.round(&[1499.6, 1500.4, -0.5, 2.5, 0.0]),
        [1500.0, 1500.0, -1.0, 3.0, 0.0]
    );
    let fine = Approach {
        resolution: 0.25,
        ..hobby.clone()
    };
    assert_eq!(fine.round(&[1.1, 1.2, -7.9]), [1.0, 1.25, -8.0]);
    // Commands so large against the resolution that `v / resolution` (or the product)
    // overflows were rounded to ±∞; they are already multiples to f64 precision.
    let smallest = Approach {
        resolution: 1e-9,
        ..hobby.clone()
    };
    assert_eq!(smallest.round(&[1e300, -1e300]), [1e300, -1e300]);
    assert_eq!(hobby.round(&[f64::MAX, f64::MIN]), [f64::MAX, f64::MIN]);
    // Even a hand-built resolution that validation refuses never makes a command infinite.
    let tiny = Approach {
        resolution: 1e-320,
        ..hobby.clone()
    };
    assert_eq!(tiny.round(&[1500.0, -3.0]), [1500.0, -3.0]);
}

#[test]
fn deserialised_approaches_are_validated() {
    let good = r#"{"overshoot":20.0,"direction":"up","resolution":1.0}"#;
    let a: Approach = serde_json::from_str(good).unwrap();
    assert_eq!(a, Approach::hobby_servo());
    assert_eq!(serde_json::to_string(&a).unwrap(), good);
    let continuous = r#"{"overshoot":5.0,"direction":"down","resolution":0.0}"#;
    assert!(serde_json::from_str::<Approach>(continuous).is_ok());
    for (bad, what) in [
        (
            r#"{"overshoot":20.0,"direction":"up","resolution":1e-320}"#,
            "resolution",
        ),
        (
            r#"{"overshoot":20.0,"direction":"up","resolution":-1.0}"#,
            "resolution",
        ),
        (
            r#"{"overshoot":0.0,"direction":"up","resolution":1.0}"#,
            "overshoot",
        ),
        (
            r#"{"overshoot":20.0,"direction":"up","resolution":1.0,"extra":1}"#,
            "extra",
        ),
    ] {
        let err = serde_json::from_str::<Approach>(bad)
            .expect_err(bad)
            .to_string();
        assert!(err.contains(what), "{bad}: {err}");
    }
    // Also inside the configurations that embed it.
    let servo = r#"{"max_iterations":8,"tolerance":0.05,"damping":1.0,"jacobian_at":"current",
        "refine_online":true,"range":"stop",
        "approach":{"overshoot":20.0,"direction":"up","resolution":1e-320}}"#;
    let err = serde_json::from_str::<ServoConfig>(servo).unwrap_err();
    assert!(err.to_string().contains("resolution"), "{err}");
}

/// A plant of command range `range` that refuses its commands when told to (a robot error),
/// counting them.
struct Unplugged {
    fail: bool,
    acts: usize,
    range: [f64; 2],
}

impl Plant for Unplugged {
    fn percept_dim(&self) -> usize {
        2
    }
    fn command_dim(&self) -> usize {
        2
    }
    fn command_range(&self, _: usize) -> [f64; 2] {
        self.range
    }
    fn act(&mut self, _: &[f64]) -> servo_loop::Result<()> {
        self.acts += 1;
        if self.fail {
            return Err(ServoError::Robot {
                during: "command",
                message: "unplugged".into(),
            });
        }
        Ok(())
    }
    fn observe(&mut self) -> servo_loop::Result<Observation> {
        Ok(Observation {
            x: vec![0.0, 0.0],
            certainty: 1.0,
        })
    }
}

/// `ApproachState::execute`: a command the check refuses sends nothing and changes no state
/// (the joints stay seated); an error from the plant leaves every joint unseated (a move may
/// have been made), so the next move comes from the pre-position again.
#[test]
fn execute_errors_leave_the_state_as_documented() {
    let a = Approach::hobby_servo();
    let mut plant = Unplugged {
        fail: false,
        acts: 0,
        range: RANGE,
    };
    let mut state = ApproachState::new();
    state
        .execute(&mut plant, &a, &[1500.0, 1500.0], false)
        .unwrap();
    assert_eq!(
        state
            .pre_position(&plant, &a, &[1503.0, 1500.0], false)
            .unwrap(),
        None
    );
    let (before, acts) = (state.clone(), plant.acts);
    for bad in [vec![1500.0, 9000.0], vec![f64::NAN, 1500.0], vec![1500.0]] {
        assert!(
            state.execute(&mut plant, &a, &bad, false).is_err(),
            "{bad:?}"
        );
        assert_eq!(state, before, "{bad:?}: nothing changed");
        assert_eq!(plant.acts, acts, "{bad:?}: nothing sent");
    }
    plant.fail = true;
    let e = state
        .execute(&mut plant, &a, &[1503.0, 1500.0], false)
        .unwrap_err();
    assert!(matches!(e, ServoError::Robot { .. }), "{e}");
    plant.fail = false;
    assert_eq!(state.last(), None);
    assert_eq!(
        state
            .pre_position(&plant, &a, &[1503.0, 1500.0], false)
            .unwrap(),
        Some(vec![1483.0, 1480.0]),
        "every joint unseated"
    );
}

/// `ApproachState::execute`: a pre-position the check refuses (a finite command whose
/// pre-position overflows to −∞ on a plant without a lower bound) is refused before anything
/// is sent and changes no state, as a refused command does. (It used to forget the last command
/// and unseat every joint first.)
#[test]
fn a_refused_pre_position_changes_no_state() {
    let a = Approach {
        overshoot: 1e308,
        direction: ApproachDirection::Up,
        resolution: 0.0,
    };
    a.validate().unwrap();
    // Without bounds on its commands.
    let mut plant = Unplugged {
        fail: false,
        acts: 0,
        range: [f64::NEG_INFINITY, f64::INFINITY],
    };
    let mut state = ApproachState::new();
    state.execute(&mut plant, &a, &[0.0, 0.0], false).unwrap();
    let (before, acts) = (state.clone(), plant.acts);
    assert_eq!(acts, 2, "a pre-position and the command");
    let e = state
        .execute(&mut plant, &a, &[-1e308, 0.0], false)
        .unwrap_err();
    assert!(
        matches!(
            e,
            ServoError::NonFinite {
                what: "command",
                index: 0
            }
        ),
        "{e}"
    );
    assert_eq!(state, before, "state changed");
    assert_eq!(plant.acts, acts, "sent");
    // Still seated: a move up in every joint goes straight there.
    assert_eq!(
        state.pre_position(&plant, &a, &[1.0, 1.0], false).unwrap(),
        None
    );
}
