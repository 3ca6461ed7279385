//! Recovery from a refused percept ([`servo_loop::Recovery`]): a percept planted to be refused
//! at one pose is answered by a small known move and a fresh percept; the loop never computes a
//! command from the refused percept; tries and the move budget are bounded; every move made is
//! recorded and counted; failure is typed. On a linear plant (three joints, two "cameras").

use nalgebra::DMatrix;
use servo_loop::{
    BroydenConfig, InverseModel, InverseModelConfig, LearnConfig, Observation, Plant, Recovery,
    ServoConfig, ServoError, ServoRun, learn_control, servo_broyden, servo_image_jacobian,
    servo_lwpr,
};

const A: [[f64; 3]; 4] = [
    [0.5, 0.1, 0.0],
    [0.0, 0.4, 0.2],
    [0.45, 0.0, 0.15],
    [0.1, 0.35, 0.1],
];
const C: [f64; 4] = [-450.0, -500.0, -420.0, -480.0];
const RANGE: [f64; 2] = [1000.0, 2000.0];

fn forward(y: &[f64]) -> Vec<f64> {
    (0..4)
        .map(|i| C[i] + (0..3).map(|j| A[i][j] * y[j]).sum::<f64>())
        .collect()
}

fn jacobian() -> DMatrix<f64> {
    DMatrix::from_fn(4, 3, |i, j| A[i][j])
}

/// The linear plant; its percept is refused (as a recogniser's doubt would be) whenever the
/// command lies within `radius` of `bad`. Logs every command sent and every observation.
struct Planted {
    y: Vec<f64>,
    bad: Vec<f64>,
    radius: f64,
    sent: Vec<Vec<f64>>,
    observed: Vec<(Vec<f64>, bool)>,
}

impl Planted {
    fn new(bad: &[f64], radius: f64) -> Self {
        Planted {
            y: vec![1500.0; 3],
            bad: bad.to_vec(),
            radius,
            sent: Vec::new(),
            observed: Vec::new(),
        }
    }

    fn refuses(&self, y: &[f64]) -> bool {
        let d: f64 = y.iter().zip(&self.bad).map(|(a, b)| (a - b).powi(2)).sum();
        d.sqrt() <= self.radius
    }
}

impl Plant for Planted {
    fn percept_dim(&self) -> usize {
        4
    }
    fn command_dim(&self) -> usize {
        3
    }
    fn command_range(&self, _: usize) -> [f64; 2] {
        RANGE
    }
    fn act(&mut self, y: &[f64]) -> servo_loop::Result<()> {
        self.sent.push(y.to_vec());
        self.y = y.to_vec();
        Ok(())
    }
    fn observe(&mut self) -> servo_loop::Result<Observation> {
        let refused = self.refuses(&self.y);
        self.observed.push((self.y.clone(), refused));
        if refused {
            return Err(ServoError::PerceptRefused {
                camera: 1,
                certainty: 0.01,
                min: 0.05,
                captures: 2,
            });
        }
        Ok(Observation {
            x: forward(&self.y),
            certainty: 0.9,
        })
    }
    fn percept_bounds(&self) -> Option<Vec<[f64; 2]>> {
        Some(vec![[0.0, 639.0], [0.0, 479.0], [0.0, 639.0], [0.0, 479.0]])
    }
}

fn recovery(tries: usize) -> Recovery {
    Recovery {
        step: 20.0,
        tries,
        workspace: vec![[1100.0, 1900.0]; 3],
        seed: 3,
    }
}

fn config(recovery: Option<Recovery>, max_iterations: usize) -> ServoConfig {
    ServoConfig {
        max_iterations,
        tolerance: 0.01,
        recovery,
        ..ServoConfig::default()
    }
}

const Y0: [f64; 3] = [1450.0, 1550.0, 1500.0];
const GOAL: [f64; 3] = [1500.0, 1500.0, 1520.0];

fn true_jacobian_run(plant: &mut Planted, cfg: &ServoConfig) -> Result<ServoRun, ServoError> {
    servo_image_jacobian(plant, &Y0, &forward(&GOAL), cfg, |_| Ok(jacobian())).map_err(|a| a.error)
}

#[test]
fn a_percept_refused_at_one_pose_is_recovered_by_a_small_known_move() {
    // Refused exactly at the first guess (radius 1 µs), accepted 20 µs away.
    let mut plant = Planted::new(&Y0, 1.0);
    let r = recovery(2);
    let run = true_jacobian_run(&mut plant, &config(Some(r.clone()), 10)).unwrap();
    assert!(run.converged, "{run:?}");
    // The refused move is recorded as move 0, then the recovery move is move 1: the known
    // command `y0 + 20 µs · d`, computed from the refused command alone.
    assert_eq!(run.refused.len(), 1);
    assert_eq!(run.refused[0].at_move, 0);
    assert_eq!(run.refused[0].command, Y0.to_vec());
    assert!(run.refused[0].reason.contains("refused"));
    let known = r.command(&Y0, 0, |_| RANGE).unwrap();
    assert_eq!(plant.sent[1], known);
    assert_eq!(run.steps[0].command, known);
    let moved: f64 = known.iter().zip(&Y0).map(|(a, b)| (a - b).powi(2)).sum();
    assert!((moved.sqrt() - 20.0).abs() < 1e-9);
    assert_eq!(run.recovery_moves, 1);
    // Every move made counts: the refused first guess, the recovery move, the corrections.
    assert_eq!(run.moves(), plant.sent.len());
    assert_eq!(run.moves(), run.steps.len() + 1);
    assert_eq!(run.iterations(), run.moves() - 1);
    // The error by moves: nothing accepted after move 0, the recovery percept's after move 1.
    assert_eq!(run.error_at(0), f64::INFINITY);
    assert_eq!(run.error_at(1), run.steps[0].error);
    assert_eq!(run.error_at(100), run.final_error());
}

#[test]
fn without_recovery_the_loop_stops_on_the_refused_percept_and_records_it() {
    let mut plant = Planted::new(&Y0, 1.0);
    let abort = servo_image_jacobian(&mut plant, &Y0, &forward(&GOAL), &config(None, 10), |_| {
        Ok(jacobian())
    })
    .unwrap_err();
    assert!(matches!(abort.error, ServoError::PerceptRefused { .. }));
    assert_eq!(plant.sent, vec![Y0.to_vec()], "no move after the refusal");
    assert!(abort.run.steps.is_empty());
    assert_eq!(abort.run.refused.len(), 1);
    assert_eq!((abort.run.moves(), abort.run.recovery_moves), (1, 0));
    assert!(abort.to_string().contains("after 1 move(s)"), "{abort}");
}

#[test]
fn the_loop_never_computes_a_command_from_a_refused_percept() {
    // Refused at the first correction's pose too: whatever the plant would have seen there,
    // the next commands are the recovery moves from the refused command, nothing else.
    let mut probe = Planted::new(&[0.0; 3], 0.0);
    let clean = true_jacobian_run(&mut probe, &config(None, 10)).unwrap();
    let y1 = clean.steps[1].command.clone();
    let r = recovery(2);
    let mut plant = Planted::new(&y1, 0.5);
    let run = true_jacobian_run(&mut plant, &config(Some(r.clone()), 10)).unwrap();
    assert_eq!(plant.sent[1], y1);
    assert!(plant.observed[1].1, "refused at the correction's pose");
    assert_eq!(plant.sent[2], r.command(&y1, 0, |_| RANGE).unwrap());
    assert!(!plant.observed[2].1);
    assert_eq!(run.refused[0].at_move, 1);
    // The exact Jacobian lands on the goal, the refused pose, after every recovery: each
    // refusal is followed by the same known move, never by a correction, until the budget ends.
    assert!(run.refused.len() > 1);
    for refused in &run.refused {
        assert!(plant.refuses(&refused.command));
        assert_eq!(plant.sent[refused.at_move], refused.command);
        assert_eq!(
            plant.sent[refused.at_move + 1],
            r.command(&refused.command, 0, |_| RANGE).unwrap()
        );
    }
    assert!(!run.converged);
    assert_eq!(run.moves(), 11);
    // Deterministic: the same run again gives the same record.
    let mut again = Planted::new(&y1, 0.5);
    assert_eq!(
        true_jacobian_run(&mut again, &config(Some(r), 10)).unwrap(),
        run
    );
    assert_eq!(again.sent, plant.sent);
}

#[test]
fn recovery_tries_are_bounded_and_failure_is_typed() {
    // Refused everywhere within 100 µs: each try is refused; after 2 the run stops.
    let mut plant = Planted::new(&Y0, 100.0);
    let r = recovery(2);
    let abort = servo_image_jacobian(
        &mut plant,
        &Y0,
        &forward(&GOAL),
        &config(Some(r.clone()), 10),
        |_| Ok(jacobian()),
    )
    .unwrap_err();
    match &abort.error {
        ServoError::RecoveryFailed { tries, last } => {
            assert_eq!(*tries, 2);
            assert!(matches!(**last, ServoError::PerceptRefused { .. }));
        }
        other => panic!("expected RecoveryFailed, got {other:?}"),
    }
    assert!(abort.error.is_refused_percept());
    assert_eq!(
        plant.sent.len(),
        3,
        "the first guess and two recovery moves"
    );
    assert_eq!(plant.sent[1], r.command(&Y0, 0, |_| RANGE).unwrap());
    assert_eq!(plant.sent[2], r.command(&Y0, 1, |_| RANGE).unwrap());
    assert_eq!((abort.run.moves(), abort.run.recovery_moves), (3, 2));
    assert!(abort.run.steps.is_empty());
}

#[test]
fn recovery_moves_count_against_the_move_budget() {
    // Budget 1 move after the first guess: one recovery move, no more.
    let mut plant = Planted::new(&Y0, 100.0);
    let abort = true_jacobian_run(&mut plant, &config(Some(recovery(3)), 1)).unwrap_err();
    assert!(
        matches!(abort, ServoError::RecoveryFailed { tries: 1, .. }),
        "{abort}"
    );
    assert_eq!(plant.sent.len(), 2);
    // No move left after the first guess: the refusal stops the run as without recovery.
    let mut plant = Planted::new(&Y0, 100.0);
    let e = true_jacobian_run(&mut plant, &config(Some(recovery(3)), 0)).unwrap_err();
    assert!(matches!(e, ServoError::PerceptRefused { .. }), "{e}");
    assert_eq!(plant.sent.len(), 1);
    // Recovered: the recovery move and the corrections together stay within the budget.
    for budget in 1..6 {
        let mut plant = Planted::new(&Y0, 1.0);
        let run = true_jacobian_run(&mut plant, &config(Some(recovery(2)), budget)).unwrap();
        assert!(run.moves() <= budget + 1, "{budget}: {}", run.moves());
        assert_eq!(plant.sent.len(), run.moves());
    }
}

#[test]
fn broyden_recovers_a_refused_probe_and_converges() {
    // The first probe's pose (y0 + 20 µs on joint 0) is refused.
    let probe = [Y0[0] + 20.0, Y0[1], Y0[2]];
    let mut plant = Planted::new(&probe, 0.5);
    let cfg = config(Some(recovery(2)), 20);
    let run = servo_broyden(
        &mut plant,
        &Y0,
        &forward(&GOAL),
        &cfg,
        &BroydenConfig { probe: 20.0 },
    )
    .unwrap();
    assert_eq!(run.refused.len(), 1);
    assert_eq!(run.refused[0].at_move, 1);
    assert_eq!(run.recovery_moves, 1);
    assert!(run.converged, "{:?}", run.final_error());
    // Without recovery the same run stops at the probe.
    let mut plant = Planted::new(&probe, 0.5);
    let abort = servo_broyden(
        &mut plant,
        &Y0,
        &forward(&GOAL),
        &config(None, 20),
        &BroydenConfig { probe: 20.0 },
    )
    .unwrap_err();
    assert!(matches!(abort.error, ServoError::PerceptRefused { .. }));
    assert_eq!(plant.sent.len(), 2);
}

#[test]
fn the_learned_servo_recovers_and_learns_only_accepted_percepts() {
    let mut model = InverseModel::new(
        4,
        3,
        &InverseModelConfig {
            percept_scale: 100.0,
            command_scale: 100.0,
            ..InverseModelConfig::default()
        },
    )
    .unwrap();
    let learn = LearnConfig {
        moves: 400,
        explore: vec![[1100.0, 1900.0]; 3],
        seed: 9,
        approach: None,
    };
    learn_control(
        &mut Planted::new(&[0.0; 3], 0.0),
        &mut model,
        &learn,
        |_, _| {},
    )
    .unwrap();
    let x_w = forward(&GOAL);
    let y0 = model.predict(&x_w).unwrap();
    let before = model.n_data();
    let mut plant = Planted::new(&y0, 1e-6);
    let run = servo_lwpr(&mut plant, &mut model, &x_w, &config(Some(recovery(2)), 10)).unwrap();
    assert_eq!(run.refused.len(), 1);
    assert_eq!(run.refused[0].command, y0);
    assert!(run.final_error() < 0.5, "{}", run.final_error());
    assert_eq!(
        model.n_data(),
        before + run.steps.len() as u64,
        "refined with the accepted moves only"
    );
}

#[test]
fn recovery_settings_are_checked_and_read_from_files() {
    let bad = config(
        Some(Recovery {
            tries: 0,
            ..recovery(1)
        }),
        10,
    );
    let mut plant = Planted::new(&Y0, 1.0);
    let e = true_jacobian_run(&mut plant, &bad).unwrap_err();
    assert!(matches!(e, ServoError::InvalidParameter { .. }), "{e}");
    assert!(plant.sent.is_empty(), "nothing sent");
    // A workspace of another dimension than the command: typed, before the recovery move.
    let wrong = config(
        Some(Recovery {
            workspace: vec![[1100.0, 1900.0]; 2],
            ..recovery(1)
        }),
        10,
    );
    let mut plant = Planted::new(&Y0, 1.0);
    let e = true_jacobian_run(&mut plant, &wrong).unwrap_err();
    assert!(matches!(e, ServoError::DimensionMismatch { .. }), "{e}");
    assert_eq!(plant.sent.len(), 1);
    // A config file without the field has no recovery; with it, the same settings.
    let text = serde_json::to_string(&config(None, 10)).unwrap();
    let without: serde_json::Value = serde_json::from_str(&text).unwrap();
    let mut map = without.as_object().unwrap().clone();
    map.remove("recovery");
    let read: ServoConfig = serde_json::from_value(serde_json::Value::Object(map)).unwrap();
    assert_eq!(read.recovery, None);
    let with = config(Some(recovery(2)), 10);
    let back: ServoConfig = serde_json::from_str(&serde_json::to_string(&with).unwrap()).unwrap();
    assert_eq!(back, with);
}
