//! A rejected input changes no state: every refused call of the learning and servo loops sends
//! nothing to the plant, observes nothing and leaves the learned model exactly as it was; a
//! refused update of a learned recogniser leaves it exactly as it was.

use crate::common::rectified;
use crate::common::tip_model;

use nalgebra::DMatrix;
use rectified::{Rectified, learned, model_config};
use servo_loop::{
    Approach, BroydenConfig, CorrectionSample, InverseModel, LearnConfig, Observation, Plant,
    RangePolicy, Recovery, ServoConfig, ServoError, ServoResult, check_command, learn_control,
    learn_control_chained, open_loop_with, servo_broyden, servo_image_jacobian, servo_lwpr,
};
use tip_model::{rectified, tip_model};

/// The one-camera rectified plant in a 640 × 480 image, counting every call that could change
/// it or the world; optionally misbehaving, as a user's plant might.
struct Watched {
    inner: Rectified,
    acts: usize,
    observes: usize,
    /// Joint 0's range in place of the plant's (one that is not a range).
    range0: Option<[f64; 2]>,
    /// Whether its percepts lack their last value.
    short_percept: bool,
    /// The first call of `act` after this many observations fails, as an unplugged robot's
    /// would.
    act_fails_after: Option<usize>,
    /// Every command `act` was given, the failing one included.
    sent: Vec<Vec<f64>>,
}

impl Watched {
    fn new() -> Self {
        let mut inner = Rectified::at(1, [0.25, 0.25]);
        inner.bounds = Some(vec![[0.0, 639.0], [0.0, 479.0]]);
        Watched {
            inner,
            acts: 0,
            observes: 0,
            range0: None,
            short_percept: false,
            act_fails_after: None,
            sent: Vec::new(),
        }
    }

    /// Nothing was sent and nothing observed; the arm is where it started.
    fn assert_untouched(&self, what: &str) {
        assert_eq!((self.acts, self.observes), (0, 0), "{what}: plant used");
        assert_eq!(self.inner.y, vec![0.25, 0.25], "{what}: arm moved");
    }
}

impl Plant for Watched {
    fn percept_dim(&self) -> usize {
        self.inner.percept_dim()
    }
    fn command_dim(&self) -> usize {
        self.inner.command_dim()
    }
    fn command_range(&self, j: usize) -> [f64; 2] {
        match self.range0 {
            Some(r) if j == 0 => r,
            _ => self.inner.command_range(j),
        }
    }
    fn act(&mut self, y: &[f64]) -> servo_loop::Result<()> {
        self.acts += 1;
        self.sent.push(y.to_vec());
        if self.act_fails_after == Some(self.observes) {
            return Err(ServoError::Robot {
                during: "command",
                message: "unplugged".into(),
            });
        }
        self.inner.act(y)
    }
    fn observe(&mut self) -> servo_loop::Result<Observation> {
        self.observes += 1;
        let mut o = self.inner.observe()?;
        if self.short_percept {
            o.x.pop();
        }
        Ok(o)
    }
    fn percept_bounds(&self) -> Option<Vec<[f64; 2]>> {
        self.inner.percept_bounds()
    }
}

fn bad_approach() -> Option<Approach> {
    Some(Approach {
        overshoot: 0.0,
        ..Approach::hobby_servo()
    })
}

/// `learn_control` and `learn_control_chained` check their settings and the model before the
/// first move: a refused session moves nothing, observes nothing and learns nothing.
#[test]
fn a_refused_learning_session_moves_nothing_and_learns_nothing() {
    let ok = LearnConfig {
        moves: 20,
        explore: vec![[0.0, 1.0]; 2],
        seed: 3,
        approach: None,
    };
    let bad = [
        ("one range short", vec![[0.0, 1.0]], None),
        ("a NaN range", vec![[f64::NAN, 1.0], [0.0, 1.0]], None),
        ("a reversed range", vec![[0.6, 0.4], [0.0, 1.0]], None),
        ("beyond the servo", vec![[0.0, 1.0], [0.5, 1.5]], None),
        ("an invalid approach", ok.explore.clone(), bad_approach()),
    ];
    let trained = learned(1, 100, 5);
    for chain_block in [0, 7] {
        for (what, explore, approach) in &bad {
            let config = LearnConfig {
                explore: explore.clone(),
                approach: approach.clone(),
                ..ok.clone()
            };
            let mut plant = Watched::new();
            let mut model = trained.clone();
            let mut calls = 0;
            let e = learn_control_chained(&mut plant, &mut model, &config, chain_block, |_, _| {
                calls += 1
            });
            assert!(e.is_err(), "{what}: accepted");
            assert_eq!(model, trained, "{what}: model changed");
            assert_eq!(calls, 0, "{what}: a move reported");
            plant.assert_untouched(what);
        }
    }
    // A model of another percept dimension than the plant's.
    let mut plant = Watched::new();
    let two_cams = learned(2, 100, 5);
    let mut model = two_cams.clone();
    assert!(learn_control(&mut plant, &mut model, &ok, |_, _| {}).is_err());
    assert_eq!(model, two_cams);
    plant.assert_untouched("a two-camera model");
    // The same session with valid settings does move (the plant counts).
    let mut model = trained.clone();
    learn_control(&mut plant, &mut model, &ok, |_, _| {}).unwrap();
    assert_eq!((plant.acts, plant.observes), (20, 20));
}

/// An inverse model from the one-camera percept to three commands (the third constant), learned
/// on a grid: its first guess has one command too many for the plant.
fn three_command_model() -> InverseModel {
    let mut model = InverseModel::new(2, 3, &model_config()).unwrap();
    let plant = Rectified::at(1, [0.5, 0.5]);
    for _ in 0..3 {
        for i in 0..=10 {
            for j in 0..=10 {
                let y = [f64::from(i) / 10.0, f64::from(j) / 10.0];
                model
                    .update(&plant.percept(&y), &[y[0], y[1], 0.5])
                    .unwrap();
            }
        }
    }
    model
}

/// One refused servo run: a target, settings, the given first guess and the model; `only`
/// names the loops it applies to: `Some(true)` the learned ones (whose first guess is the
/// model's), `Some(false)` the others (whose first guess is given), `None` all.
struct Case {
    what: &'static str,
    x_w: Vec<f64>,
    config: ServoConfig,
    y0: Vec<f64>,
    model: InverseModel,
    only: Option<bool>,
}

/// A servo loop on the watched plant with a model.
type ServoLoop<'a> = dyn Fn(&mut Watched, &mut InverseModel) -> ServoResult + 'a;

/// Every servo loop refuses a bad target, bad settings or a first guess that does not fit the
/// plant before anything is sent: the run is empty, the plant untouched, the model unchanged.
#[test]
fn a_refused_servo_run_moves_nothing_and_learns_nothing() {
    let trained = learned(1, 300, 5);
    let target = Rectified::at(1, [0.5, 0.5]).percept(&[0.4, 0.6]);
    let ok = ServoConfig::default();
    let jacobian = |_: &[f64]| Ok(DMatrix::from_row_slice(2, 2, &[200.0, 0.0, 0.0, 150.0]));
    let targets = [
        ("a NaN target", vec![f64::NAN, target[1]]),
        ("a short target", vec![target[0]]),
        ("a target outside the image", vec![700.0, target[1]]),
    ];
    let configs = [
        (
            "damping 0",
            ServoConfig {
                damping: 0.0,
                ..ok.clone()
            },
        ),
        (
            "a negative tolerance",
            ServoConfig {
                tolerance: -1.0,
                ..ok.clone()
            },
        ),
        (
            "an invalid approach",
            ServoConfig {
                approach: bad_approach(),
                ..ok.clone()
            },
        ),
        (
            "no recovery tries",
            ServoConfig {
                recovery: Some(Recovery {
                    step: 0.05,
                    tries: 0,
                    workspace: Vec::new(),
                    seed: 0,
                }),
                ..ok.clone()
            },
        ),
    ];
    let case = |what, x_w: &[f64], config: &ServoConfig, y0: Vec<f64>, model, only| Case {
        what,
        x_w: x_w.to_vec(),
        config: config.clone(),
        y0,
        model,
        only,
    };
    let mut cases = Vec::new();
    for (what, x_w) in &targets {
        cases.push(case(what, x_w, &ok, vec![0.5; 2], trained.clone(), None));
    }
    for (what, config) in &configs {
        cases.push(case(
            what,
            &target,
            config,
            vec![0.5; 2],
            trained.clone(),
            None,
        ));
    }
    // First guesses the plant cannot take.
    for (what, y0) in [
        ("a first guess with a NaN", vec![f64::NAN, 0.5]),
        ("a first guess outside the range", vec![0.5, 1.5]),
    ] {
        cases.push(case(what, &target, &ok, y0, trained.clone(), Some(false)));
    }
    let three = three_command_model();
    cases.push(case(
        "a first guess of three commands",
        &target,
        &ok,
        vec![0.5; 3],
        three,
        None,
    ));
    let empty = InverseModel::new(2, 2, &model_config()).unwrap();
    cases.push(case(
        "an empty model",
        &target,
        &ok,
        vec![0.5; 2],
        empty,
        Some(true),
    ));
    for Case {
        what,
        x_w,
        config,
        y0,
        model,
        only,
    } in &cases
    {
        let loops: [(bool, &ServoLoop<'_>); 4] = [
            (true, &|p, m| open_loop_with(p, m, x_w, config)),
            (true, &|p, m| servo_lwpr(p, m, x_w, config)),
            (false, &|p, _| {
                servo_image_jacobian(p, y0, x_w, config, jacobian)
            }),
            (false, &|p, _| {
                servo_broyden(p, y0, x_w, config, &BroydenConfig::default())
            }),
        ];
        for (k, (learned_loop, run)) in loops.into_iter().enumerate() {
            if only.is_some_and(|l| l != learned_loop) {
                continue;
            }
            let mut plant = Watched::new();
            let mut m = model.clone();
            let abort = run(&mut plant, &mut m).expect_err(&format!("{what}, loop {k}: accepted"));
            assert_eq!(
                abort.run,
                Default::default(),
                "{what}, loop {k}: a move recorded"
            );
            assert_eq!(&m, model, "{what}, loop {k}: model changed");
            plant.assert_untouched(&format!("{what}, loop {k}"));
        }
    }
}

/// `n` correction poses of the two cameras, each with an end face 1.1 px from its far end.
fn correction_samples(n: usize) -> Vec<CorrectionSample> {
    (0..n)
        .map(|i| {
            let t = i as f64;
            let far_ends = vec![
                [2.0 + (t * 0.37) % 12.0, 1.0 + (t * 0.61) % 10.0],
                [1.0 + (t * 0.43) % 12.0, 1.0 + (t * 0.61) % 10.0],
            ];
            let end_faces = far_ends
                .iter()
                .map(|f| Some([f[0] + 1.0, f[1] + 0.5]))
                .collect();
            CorrectionSample {
                far_ends,
                end_faces,
            }
        })
        .collect()
}

/// `TipModel::learn_correction` and `learn_consistency` replace what was learned only when
/// learning succeeds: a refused call leaves the model exactly as it was (its correction and its
/// consistency included).
#[test]
fn a_refused_recogniser_update_leaves_the_tip_model_as_it_was() {
    let mut model = tip_model(2, vec![rectified()]);
    model.learn_correction(&correction_samples(40)).unwrap();
    assert!(model.correction().is_some() && model.consistency().len() == 1);
    let before = model.clone();
    let mut three = correction_samples(40);
    three[7].far_ends.push([1.0, 1.0]);
    three[7].end_faces.push(None);
    let mut one = correction_samples(40);
    one[7].far_ends.pop();
    one[7].end_faces.pop();
    for (what, samples) in [
        ("too few poses", correction_samples(5)),
        ("a pose of three cameras", three.clone()),
        ("a pose of one camera", one.clone()),
        ("no poses", Vec::new()),
    ] {
        assert!(
            model.learn_correction(&samples).is_err(),
            "{what}: accepted"
        );
        assert_eq!(model, before, "{what}: correction changed");
    }
    for (what, samples) in [
        ("too few poses", correction_samples(3)),
        ("a pose of three cameras", three),
        ("a pose of one camera", one),
        ("no poses", Vec::new()),
    ] {
        assert!(
            model.learn_consistency(&samples, 1).is_err(),
            "{what}: accepted"
        );
        assert_eq!(model, before, "{what}: consistency changed");
    }
}

/// A plant whose own range is not a range (a NaN end, or `min > max`) is a typed error naming
/// `command_range`, in the command check, the servo loops (with the clamping range policy and
/// with an approach, whose clamps used to panic in `f64::clamp`) and learning, and nothing is
/// sent to it.
#[test]
fn a_plant_range_that_is_not_a_range_is_refused_not_panicked_on() {
    let trained = learned(1, 300, 5);
    let target = Rectified::at(1, [0.5, 0.5]).percept(&[0.4, 0.6]);
    let is_range_error = |e: &ServoError| {
        matches!(
            e,
            ServoError::InvalidParameter {
                name: "command_range",
                ..
            }
        )
    };
    for range in [[f64::NAN, 1.0], [0.0, f64::NAN], [0.6, 0.4]] {
        let mut plant = Watched {
            range0: Some(range),
            ..Watched::new()
        };
        let e = check_command(&plant, &[0.5, 0.5]).unwrap_err();
        assert!(is_range_error(&e), "{range:?}: {e}");
        for config in [
            ServoConfig {
                range: RangePolicy::Clamp,
                ..ServoConfig::default()
            },
            ServoConfig {
                approach: Some(Approach::hobby_servo()),
                ..ServoConfig::default()
            },
            ServoConfig::default(),
        ] {
            let mut m = trained.clone();
            let abort = servo_lwpr(&mut plant, &mut m, &target, &config)
                .expect_err(&format!("{range:?}: accepted"));
            assert!(is_range_error(&abort.error), "{range:?}: {}", abort.error);
            assert_eq!(m, trained, "{range:?}: model changed");
            plant.assert_untouched(&format!("{range:?}"));
        }
        let config = LearnConfig {
            moves: 5,
            explore: vec![[0.0, 1.0]; 2],
            seed: 3,
            approach: None,
        };
        let mut m = trained.clone();
        let e = learn_control(&mut plant, &mut m, &config, |_, _| {}).unwrap_err();
        assert!(is_range_error(&e), "{range:?}: {e}");
        assert_eq!(m, trained);
        plant.assert_untouched(&format!("{range:?}, learning"));
    }
}

/// A move whose observation fails otherwise than by a refused percept (here a percept of the
/// wrong length) ends the run with that error, and is in neither of the run's lists, as
/// `ServoRun::moves` says: the move was made, and is not counted.
#[test]
fn a_move_whose_observation_fails_ends_the_run_uncounted() {
    let trained = learned(1, 300, 5);
    let target = Rectified::at(1, [0.5, 0.5]).percept(&[0.4, 0.6]);
    let mut plant = Watched {
        short_percept: true,
        ..Watched::new()
    };
    let mut m = trained.clone();
    let abort = servo_lwpr(&mut plant, &mut m, &target, &ServoConfig::default())
        .expect_err("a short percept was taken");
    assert!(
        matches!(abort.error, ServoError::DimensionMismatch { .. }),
        "{}",
        abort.error
    );
    assert_eq!((plant.acts, plant.observes), (1, 1), "the move was made");
    assert!(abort.run.steps.is_empty() && abort.run.refused.is_empty());
    assert_eq!(abort.run.moves(), 0);
    // It is recorded apart: the arm stands at its command.
    let failed = abort
        .run
        .failed_move
        .as_ref()
        .expect("the failed move recorded");
    assert_eq!(failed.at_move, 0);
    assert_eq!(
        failed.command, plant.inner.y,
        "the command the arm stands at"
    );
    assert_eq!(failed.pre_position, None);
    assert_eq!(failed.reason, abort.error.to_string());
    assert!(
        abort
            .to_string()
            .starts_with("servoing stopped after 0 move(s) and a failed one: "),
        "{abort}"
    );
}

/// A robot error while a command is sent, after accepted moves, ends the run with that move
/// recorded as `ServoRun::failed_move` (with the pre-position sent before it, under an approach),
/// after the accepted ones; every loop records it alike.
#[test]
fn a_move_the_robot_fails_is_recorded_where_it_was_made() {
    let trained = learned(1, 300, 5);
    let target = Rectified::at(1, [0.5, 0.5]).percept(&[0.4, 0.6]);
    let jacobian = |_: &[f64]| Ok(DMatrix::from_row_slice(2, 2, &[200.0, 0.0, 0.0, 150.0]));
    let approach = ServoConfig {
        approach: Some(Approach {
            overshoot: 0.05,
            resolution: 1e-6,
            ..Approach::hobby_servo()
        }),
        ..ServoConfig::default()
    };
    let mut pre_positions = 0;
    for (config, with_approach) in [(&ServoConfig::default(), false), (&approach, true)] {
        // No run converges before its third move.
        let config = &ServoConfig {
            tolerance: 0.0,
            damping: 0.5,
            ..config.clone()
        };
        let y0 = [0.45, 0.55];
        let loops: [&ServoLoop<'_>; 3] = [
            &|p, m| servo_lwpr(p, m, &target, config),
            &|p, _| servo_image_jacobian(p, &y0, &target, config, jacobian),
            &|p, _| servo_broyden(p, &y0, &target, config, &BroydenConfig { probe: 0.02 }),
        ];
        for (k, run) in loops.into_iter().enumerate() {
            // The third move's first act fails (its pre-position's, when it has one).
            let mut plant = Watched {
                act_fails_after: Some(2),
                ..Watched::new()
            };
            let mut m = trained.clone();
            let abort = run(&mut plant, &mut m).expect_err("the robot failed");
            let what = format!("loop {k}, approach {with_approach}");
            assert!(
                matches!(abort.error, ServoError::Robot { .. }),
                "{what}: {}",
                abort.error
            );
            assert_eq!(abort.run.steps.len(), 2, "{what}");
            assert_eq!(abort.run.moves(), 2, "{what}");
            let failed = abort.run.failed_move.as_ref().expect("recorded");
            assert_eq!(failed.at_move, 2, "{what}");
            assert_eq!(failed.command.len(), 2, "{what}");
            assert_ne!(
                failed.command, abort.run.steps[1].command,
                "{what}: a new command"
            );
            assert!(with_approach || failed.pre_position.is_none(), "{what}");
            // What the robot was given when it failed: the pre-position, if one was sent.
            assert_eq!(
                plant.sent.last(),
                Some(failed.pre_position.as_ref().unwrap_or(&failed.command)),
                "{what}"
            );
            pre_positions += usize::from(failed.pre_position.is_some());
            assert!(
                failed.reason.contains("unplugged"),
                "{what}: {}",
                failed.reason
            );
        }
    }
    assert!(pre_positions > 0, "no failed move had a pre-position");
}
