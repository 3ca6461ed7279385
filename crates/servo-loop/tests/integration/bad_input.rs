//! Regressions of the bad-input sweep (issue 24): a deserialised inverse model passes the
//! constructor's checks, and a plant with inconsistent percept bounds is a typed error.

use crate::common::rectified;

use rectified::{Rectified, learned};
use servo_loop::{InverseModel, InverseModelConfig, ServoError, check_command, check_target};

/// The one-camera plant's inverse model, learned from 300 random moves.
fn trained() -> InverseModel {
    learned(1, 300, 3)
}

#[test]
fn a_deserialised_inverse_model_predicts_like_the_original() {
    // Plain serde used to skip LWPR's loading step: the model then panicked in `predict`.
    let model = trained();
    let json = serde_json::to_string(&model).unwrap();
    let loaded: InverseModel = serde_json::from_str(&json).unwrap();
    let x = [200.0, 175.0];
    assert_eq!(loaded.predict(&x).unwrap(), model.predict(&x).unwrap());
    assert_eq!(
        loaded.predict_with_jacobian(&x).unwrap(),
        model.predict_with_jacobian(&x).unwrap()
    );
}

#[test]
fn a_deserialised_inverse_model_passes_the_constructor_checks() {
    let model = trained();
    let mut value: serde_json::Value = serde_json::to_value(&model).unwrap();
    for bad in [5.0, 0.0, -1.0] {
        value["cutoff"] = serde_json::json!(bad);
        let err = serde_json::from_value::<InverseModel>(value.clone()).unwrap_err();
        assert!(err.to_string().contains("cutoff"), "{err}");
    }
    // An LWPR part whose sizes disagree is refused, not stored.
    let mut value: serde_json::Value = serde_json::to_value(&model).unwrap();
    value["lwpr"]["mean_x"] = serde_json::json!([1.0]);
    assert!(serde_json::from_value::<InverseModel>(value).is_err());
}

#[test]
fn percept_bounds_shorter_than_the_percept_are_a_typed_error() {
    // Used to panic indexing the bounds.
    for bounds in [vec![], vec![[0.0, 639.0]], vec![[0.0, 639.0]; 3]] {
        let plant = Rectified {
            cams: 1,
            y: vec![0.5, 0.5],
            bounds: Some(bounds.clone()),
        };
        let err = check_target(&plant, &[10.0, 10.0]).unwrap_err();
        assert!(
            matches!(
                err,
                ServoError::DimensionMismatch {
                    what: "percept bounds",
                    expected: 2,
                    ..
                }
            ),
            "{bounds:?}: {err}"
        );
    }
    let plant = Rectified {
        cams: 1,
        y: vec![0.5, 0.5],
        bounds: Some(vec![[0.0, 639.0], [0.0, 479.0]]),
    };
    check_target(&plant, &[10.0, 10.0]).unwrap();
    assert!(matches!(
        check_target(&plant, &[10.0, 500.0]),
        Err(ServoError::TargetOutsideImage { camera: 0, .. })
    ));
}

/// A three-servo robot (two controlled, one gripper) that counts its commands and captures.
#[derive(Default)]
struct Counting {
    commands: usize,
    captures: usize,
}

impl servo_loop::Robot for Counting {
    type Error = String;
    fn num_servos(&self) -> usize {
        3
    }
    fn servo_range(&self, _: usize) -> [f64; 2] {
        [0.0, 100.0]
    }
    fn command(&mut self, _: &[f64]) -> Result<(), String> {
        self.commands += 1;
        Ok(())
    }
    fn capture(&mut self) -> Result<Vec<image::GrayImage>, String> {
        self.captures += 1;
        Ok(vec![image::GrayImage::new(4, 4)])
    }
}

/// Exploration ranges that do not fit the controlled servos are refused before the robot
/// moves (they used to be zipped with the controlled servos: a missing range left a servo at
/// its rest value, an extra one was ignored; a range beyond the servo's moved the arm until a
/// command was refused).
#[test]
fn training_views_refuse_explore_ranges_that_do_not_fit() {
    use servo_loop::{ControlSpace, capture_training_views};
    let space = ControlSpace {
        controlled: vec![0, 1],
        rest: vec![50.0; 3],
        gripper: Some((2, [10.0, 90.0])),
    };
    let mut robot = Counting::default();
    for (explore, dims) in [
        (vec![[0.0, 100.0]], true),
        (vec![[0.0, 100.0]; 3], true),
        (vec![[0.0, 100.0], [-5.0, 50.0]], false),
        (vec![[0.0, 100.0], [20.0, 120.0]], false),
        (vec![[0.0, 100.0], [60.0, 40.0]], false),
        (vec![[f64::NAN, 100.0], [0.0, 100.0]], false),
    ] {
        let e = capture_training_views(&mut robot, &space, &explore, 3, 1).unwrap_err();
        if dims {
            assert!(
                matches!(
                    e,
                    ServoError::DimensionMismatch {
                        what: "explore ranges",
                        ..
                    }
                ),
                "{e}"
            );
        } else {
            assert!(
                matches!(
                    e,
                    ServoError::InvalidParameter {
                        name: "explore",
                        ..
                    }
                ),
                "{e}"
            );
        }
    }
    assert_eq!(robot.commands, 0);
    let views = capture_training_views(&mut robot, &space, &[[0.0, 100.0]; 2], 3, 1).unwrap();
    assert_eq!((views.len(), robot.commands), (3, 9));
}

/// A recognition session refused for its settings or its control space moves nothing and
/// captures nothing: `learn_recognition` checks the recogniser's settings before the training
/// moves (an invalid `SilhouetteConfig` used to be refused only by `TipModel::learn`, after
/// every training move and capture had been made).
#[test]
fn a_refused_recognition_session_moves_nothing() {
    use servo_loop::{ControlSpace, SilhouetteConfig, capture_training_views, learn_recognition};
    let space = ControlSpace {
        controlled: vec![0, 1],
        rest: vec![50.0; 3],
        gripper: Some((2, [10.0, 90.0])),
    };
    let explore = [[0.0, 100.0]; 2];
    let ok = SilhouetteConfig::default();
    for (name, config) in [
        (
            "noise_multiple",
            SilhouetteConfig {
                noise_multiple: f32::NAN,
                ..ok.clone()
            },
        ),
        (
            "min_threshold",
            SilhouetteConfig {
                min_threshold: -1.0,
                ..ok.clone()
            },
        ),
        (
            "min_certainty",
            SilhouetteConfig {
                min_certainty: 1.5,
                ..ok.clone()
            },
        ),
        (
            "face_gate",
            SilhouetteConfig {
                face_gate: f64::INFINITY,
                ..ok.clone()
            },
        ),
        (
            "spread_scale",
            SilhouetteConfig {
                spread_scale: -0.5,
                ..ok.clone()
            },
        ),
    ] {
        let mut robot = Counting::default();
        let e = learn_recognition(&mut robot, &space, &explore, 3, 1, &config).unwrap_err();
        assert!(
            matches!(&e, ServoError::InvalidParameter { name: n, .. } if *n == name),
            "{name}: {e}"
        );
        assert_eq!(
            (robot.commands, robot.captures),
            (0, 0),
            "{name}: robot used"
        );
    }
    let no_gripper = ControlSpace {
        gripper: None,
        ..space.clone()
    };
    let short_rest = ControlSpace {
        rest: vec![50.0; 2],
        ..space.clone()
    };
    let repeated = ControlSpace {
        controlled: vec![0, 0],
        ..space.clone()
    };
    for bad in [no_gripper, short_rest, repeated] {
        let mut robot = Counting::default();
        assert!(capture_training_views(&mut robot, &bad, &explore, 3, 1).is_err());
        assert!(learn_recognition(&mut robot, &bad, &explore, 3, 1, &ok).is_err());
        assert_eq!(
            (robot.commands, robot.captures),
            (0, 0),
            "{bad:?}: robot used"
        );
    }
}

/// The image error of a percept and a target of different lengths used to be taken over the
/// shorter one; a NaN gave a NaN error.
#[test]
fn image_error_refuses_mismatched_or_non_finite_points() {
    use servo_loop::image_error;
    assert!(matches!(
        image_error(&[1.0, 2.0, 3.0, 4.0], &[1.0, 2.0]),
        Err(ServoError::DimensionMismatch { what: "target", .. })
    ));
    assert!(matches!(
        image_error(&[1.0, f64::NAN], &[1.0, 2.0]),
        Err(ServoError::NonFinite {
            what: "percept",
            ..
        })
    ));
    assert!(matches!(
        image_error(&[1.0, 2.0], &[f64::INFINITY, 2.0]),
        Err(ServoError::NonFinite { what: "target", .. })
    ));
    assert_eq!(image_error(&[3.0, 4.0], &[0.0, 0.0]).unwrap(), 5.0);
    // Two cameras: the RMS over the cameras of the per-camera distance (5 px and 0 px).
    assert_eq!(
        image_error(&[3.0, 4.0, 7.0, 7.0], &[0.0, 0.0, 7.0, 7.0]).unwrap(),
        (12.5f64).sqrt()
    );
    // One component: divided by one, not by √½.
    assert_eq!(image_error(&[3.0], &[0.0]).unwrap(), 3.0);
}

/// A dimension beyond LWPR's limits is the builder's TooBig error, however large (usize::MAX
/// used to panic with a capacity overflow while the norm vectors were allocated).
#[test]
fn inverse_models_beyond_lwpr_limits_are_errors() {
    let config = InverseModelConfig::default();
    for (n, m, what) in [
        (usize::MAX, 2, "n_in"),
        (lwpr::MAX_INPUTS + 1, 2, "n_in"),
        (2, usize::MAX, "n_out"),
    ] {
        let e = InverseModel::new(n, m, &config).unwrap_err();
        assert!(
            matches!(e, ServoError::Lwpr(lwpr::LwprError::TooBig { what: w, .. }) if w == what),
            "{e}"
        );
    }
    assert!(InverseModel::new(4, 3, &config).is_ok());
}

/// `ControlSpace::full_command` pairs the set-points with the controlled servos: a length that
/// does not fit is an error (it used to be zipped: a missing value left a servo at rest, an extra
/// one was dropped), and so is an index outside the rest command (it used to panic).
#[test]
fn full_command_refuses_set_points_that_do_not_fit_the_control_space() {
    use servo_loop::ControlSpace;
    let space = ControlSpace {
        controlled: vec![0, 2],
        rest: vec![50.0; 3],
        gripper: None,
    };
    assert_eq!(
        space.full_command(&[10.0, 20.0]).unwrap(),
        vec![10.0, 50.0, 20.0]
    );
    // One value short would leave servo 2 at rest; one too many would be dropped.
    for y in [&[10.0][..], &[10.0, 20.0, 30.0][..]] {
        match space.full_command(y) {
            Err(ServoError::DimensionMismatch {
                expected: 2, got, ..
            }) => assert_eq!(got, y.len()),
            other => panic!("{y:?}: expected a dimension mismatch, got {other:?}"),
        }
    }
    // A hand-built space whose controlled index is outside its rest command.
    let bad = ControlSpace {
        controlled: vec![0, 5],
        rest: vec![50.0; 3],
        gripper: None,
    };
    assert!(matches!(
        bad.full_command(&[1.0, 2.0]),
        Err(ServoError::InvalidParameter {
            name: "controlled",
            ..
        })
    ));
}

/// A forward image Jacobian with another number of columns than the plant's commands (or none)
/// used to panic inside nalgebra (a dimension mismatch subtracting the step from the command,
/// or an SVD of an empty matrix); it is a typed error, after only the first guess was executed.
#[test]
fn image_jacobians_of_the_wrong_shape_are_a_typed_error() {
    use nalgebra::DMatrix;
    use servo_loop::{ServoConfig, servo_image_jacobian};
    for (rows, cols) in [(2, 3), (2, 1), (2, 0), (0, 0), (3, 2)] {
        let mut plant = Rectified::at(1, [0.5, 0.5]);
        let abort = servo_image_jacobian(
            &mut plant,
            &[0.5, 0.5],
            &[150.0, 150.0],
            &ServoConfig::default(),
            |_| Ok(DMatrix::from_element(rows, cols, 100.0)),
        )
        .unwrap_err();
        assert!(
            matches!(abort.error, ServoError::DimensionMismatch { .. }),
            "{rows}×{cols}: {}",
            abort.error
        );
        assert_eq!(abort.run.steps.len(), 1, "{rows}×{cols}");
        assert_eq!(plant.y, vec![0.5, 0.5]);
    }
}

/// An exploration range of finite ends whose width overflows used to be accepted and drew
/// infinite commands.
#[test]
fn exploration_ranges_whose_width_overflows_are_refused() {
    use servo_loop::RandomCommands;
    assert!(matches!(
        RandomCommands::new(&[[0.0, 1.0], [-1e308, 1e308]], 1),
        Err(ServoError::InvalidParameter {
            name: "explore",
            ..
        })
    ));
    let mut r = RandomCommands::new(&[[-1e307, 1e307]], 1).unwrap();
    assert!(r.next_command().iter().all(|v| v.is_finite()));
}

/// `check_command` checks the length, then finiteness, then the servo range, naming the first
/// joint outside.
#[test]
fn check_command_names_the_first_joint_outside_the_range() {
    let plant = Rectified::at(1, [0.5, 0.5]);
    check_command(&plant, &[0.0, 1.0]).unwrap();
    assert_eq!(
        check_command(&plant, &[0.5]),
        Err(ServoError::DimensionMismatch {
            what: "command",
            expected: 2,
            got: 1
        })
    );
    assert_eq!(
        check_command(&plant, &[7.0, f64::NAN]),
        Err(ServoError::NonFinite {
            what: "command",
            index: 1
        })
    );
    assert_eq!(
        check_command(&plant, &[-0.5, 1.5]),
        Err(ServoError::OutOfServoRange {
            joint: 0,
            value: -0.5,
            min: 0.0,
            max: 1.0
        })
    );
    assert_eq!(
        check_command(&plant, &[0.5, 1.5]),
        Err(ServoError::OutOfServoRange {
            joint: 1,
            value: 1.5,
            min: 0.0,
            max: 1.0
        })
    );
}

/// `InverseModelConfig::validate` checks every value (positive, finite scales; `w_gen` and
/// `cutoff` in `(0, 1)`), `InverseModel::new` refuses a zero dimension, and bad input to an
/// inverse model is a typed error that leaves the model untouched.
#[test]
fn inverse_model_settings_and_inputs_are_checked() {
    let ok = InverseModelConfig::default();
    ok.validate().unwrap();
    let bad: [(&str, InverseModelConfig); 10] = [
        (
            "percept_scale",
            InverseModelConfig {
                percept_scale: 0.0,
                ..ok.clone()
            },
        ),
        (
            "command_scale",
            InverseModelConfig {
                command_scale: -1.0,
                ..ok.clone()
            },
        ),
        (
            "command_scale",
            InverseModelConfig {
                command_scale: f64::INFINITY,
                ..ok.clone()
            },
        ),
        (
            "init_d",
            InverseModelConfig {
                init_d: f64::NAN,
                ..ok.clone()
            },
        ),
        (
            "init_alpha",
            InverseModelConfig {
                init_alpha: 0.0,
                ..ok.clone()
            },
        ),
        (
            "w_gen",
            InverseModelConfig {
                w_gen: 0.0,
                ..ok.clone()
            },
        ),
        (
            "w_gen",
            InverseModelConfig {
                w_gen: 1.0,
                ..ok.clone()
            },
        ),
        (
            "cutoff",
            InverseModelConfig {
                cutoff: 0.0,
                ..ok.clone()
            },
        ),
        (
            "cutoff",
            InverseModelConfig {
                cutoff: 1.0,
                ..ok.clone()
            },
        ),
        (
            "cutoff",
            InverseModelConfig {
                cutoff: f64::NAN,
                ..ok.clone()
            },
        ),
    ];
    for (name, config) in bad {
        for e in [
            config.validate(),
            InverseModel::new(2, 2, &config).map(|_| ()),
        ] {
            assert!(
                matches!(&e, Err(ServoError::InvalidParameter { name: n, .. }) if *n == name),
                "{name}: {e:?}"
            );
        }
    }
    for (n, m) in [(0, 2), (2, 0)] {
        assert!(matches!(
            InverseModel::new(n, m, &ok),
            Err(ServoError::InvalidParameter {
                name: "dimensions",
                ..
            })
        ));
    }
    let mut model = trained();
    let before = model.clone();
    for (x, y) in [
        (vec![200.0], vec![0.5, 0.5]),
        (vec![200.0, 175.0], vec![0.5]),
        (vec![f64::NAN, 175.0], vec![0.5, 0.5]),
        (vec![200.0, 175.0], vec![0.5, f64::INFINITY]),
    ] {
        assert!(model.update(&x, &y).is_err(), "{x:?} {y:?}");
    }
    assert_eq!(model, before, "invalid input leaves the model untouched");
    assert!(matches!(
        model.predict(&[200.0]),
        Err(ServoError::DimensionMismatch {
            what: "percept",
            expected: 2,
            got: 1
        })
    ));
    assert!(matches!(
        model.predict_with_jacobian(&[200.0, f64::NAN]),
        Err(ServoError::NonFinite {
            what: "percept",
            index: 1
        })
    ));
}

/// `ControlSpace::validate` checks the indices and set-points against the robot: a rest
/// command of every servo, at least one controlled servo, no index out of range or repeated,
/// held and gripper set-points finite and inside their servo's range, a gripper that is not
/// controlled.
#[test]
fn control_spaces_that_do_not_fit_the_robot_are_refused() {
    use servo_loop::ControlSpace;
    let robot = Counting::default();
    let ok = ControlSpace {
        controlled: vec![0, 1],
        rest: vec![50.0; 3],
        gripper: Some((2, [10.0, 90.0])),
    };
    ok.validate(&robot).unwrap();
    // A controlled servo's rest value is ignored.
    ControlSpace {
        rest: vec![f64::NAN, 500.0, 50.0],
        ..ok.clone()
    }
    .validate(&robot)
    .unwrap();
    let with = |f: &dyn Fn(&mut ControlSpace)| {
        let mut s = ok.clone();
        f(&mut s);
        s.validate(&robot).unwrap_err()
    };
    assert!(matches!(
        with(&|s| s.rest.pop().map(drop).unwrap()),
        ServoError::DimensionMismatch {
            what: "rest command",
            expected: 3,
            got: 2
        }
    ));
    for e in [
        with(&|s| s.controlled.clear()),
        with(&|s| s.controlled = vec![0, 3]),
        with(&|s| s.controlled = vec![1, 1]),
    ] {
        assert!(
            matches!(
                e,
                ServoError::InvalidParameter {
                    name: "controlled",
                    ..
                }
            ),
            "{e}"
        );
    }
    for e in [
        with(&|s| s.gripper = Some((3, [10.0, 90.0]))),
        with(&|s| s.gripper = Some((1, [10.0, 90.0]))),
    ] {
        assert!(
            matches!(
                e,
                ServoError::InvalidParameter {
                    name: "gripper",
                    ..
                }
            ),
            "{e}"
        );
    }
    assert!(matches!(
        with(&|s| s.rest[2] = 101.0),
        ServoError::OutOfServoRange { joint: 2, .. }
    ));
    assert!(matches!(
        with(&|s| {
            s.rest[2] = f64::NAN;
            s.gripper = None;
        }),
        ServoError::OutOfServoRange { joint: 2, .. }
    ));
    assert!(matches!(
        with(&|s| s.gripper = Some((2, [10.0, -1.0]))),
        ServoError::OutOfServoRange { joint: 2, .. }
    ));
}

/// `ServoConfig::validate`: `tolerance ≥ 0` (finite) and `damping ∈ (0, 1]`; a run with bad
/// settings, or a Broyden probe that is not finite and positive, sends nothing.
#[test]
fn servo_settings_are_checked_before_anything_is_sent() {
    use servo_loop::{BroydenConfig, ServoConfig, servo_broyden};
    let ok = ServoConfig::default();
    ok.validate().unwrap();
    ServoConfig {
        tolerance: 0.0,
        damping: 1.0,
        ..ok.clone()
    }
    .validate()
    .unwrap();
    for (name, bad) in [
        (
            "tolerance",
            ServoConfig {
                tolerance: -0.1,
                ..ok.clone()
            },
        ),
        (
            "tolerance",
            ServoConfig {
                tolerance: f64::NAN,
                ..ok.clone()
            },
        ),
        (
            "tolerance",
            ServoConfig {
                tolerance: f64::INFINITY,
                ..ok.clone()
            },
        ),
        (
            "damping",
            ServoConfig {
                damping: 0.0,
                ..ok.clone()
            },
        ),
        (
            "damping",
            ServoConfig {
                damping: 1.5,
                ..ok.clone()
            },
        ),
        (
            "damping",
            ServoConfig {
                damping: f64::NAN,
                ..ok.clone()
            },
        ),
    ] {
        let e = bad.validate().unwrap_err();
        assert!(
            matches!(&e, ServoError::InvalidParameter { name: n, .. } if *n == name),
            "{name}: {e}"
        );
    }
    for probe in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let mut plant = Rectified::at(1, [0.25, 0.25]);
        let abort = servo_broyden(
            &mut plant,
            &[0.5, 0.5],
            &[200.0, 175.0],
            &ok,
            &BroydenConfig { probe },
        )
        .unwrap_err();
        assert!(
            matches!(
                abort.error,
                ServoError::InvalidParameter { name: "probe", .. }
            ),
            "{probe}: {}",
            abort.error
        );
        assert!(abort.run.steps.is_empty());
        assert_eq!(plant.y, vec![0.25, 0.25], "nothing sent");
    }
}

/// A one- or two-joint plant whose `command_range(j)` indexes its ranges, as
/// [`servo_loop::VisualPlant`] indexes its controlled servos: asked for a joint it does not
/// have, it panics (the library must never ask). Its reported range can be any pair.
struct Indexed {
    ranges: Vec<[f64; 2]>,
    acts: usize,
}

impl Indexed {
    fn new(ranges: Vec<[f64; 2]>) -> Self {
        Indexed { ranges, acts: 0 }
    }
}

impl servo_loop::Plant for Indexed {
    fn percept_dim(&self) -> usize {
        2
    }
    fn command_dim(&self) -> usize {
        self.ranges.len()
    }
    fn command_range(&self, j: usize) -> [f64; 2] {
        self.ranges[j]
    }
    fn act(&mut self, _: &[f64]) -> servo_loop::Result<()> {
        self.acts += 1;
        Ok(())
    }
    fn observe(&mut self) -> servo_loop::Result<servo_loop::Observation> {
        Ok(servo_loop::Observation {
            x: vec![100.0, 100.0],
            certainty: 1.0,
        })
    }
}

/// `ApproachState::pre_position` clamped the pre-position into the plant's range with
/// `f64::clamp`, which panics for a range that is not one (a NaN end, `min > max`), and asked
/// for the range of every joint of `y`, also beyond the plant's.
#[test]
fn pre_positions_check_the_command_and_the_plant_range() {
    use servo_loop::{Approach, ApproachState};
    let a = Approach::hobby_servo();
    let state = ApproachState::new();
    for (ranges, y) in [
        (vec![[f64::NAN, 2000.0]], vec![1500.0]),
        (vec![[2000.0, 1000.0]], vec![1500.0]),
        (vec![[1000.0, 2000.0]], vec![1500.0, 1500.0]),
    ] {
        let plant = Indexed::new(ranges.clone());
        let e = state.pre_position(&plant, &a, &y, false).unwrap_err();
        let expected = if y.len() == ranges.len() {
            matches!(
                e,
                ServoError::InvalidParameter {
                    name: "command_range",
                    ..
                }
            )
        } else {
            matches!(
                e,
                ServoError::DimensionMismatch {
                    what: "command",
                    ..
                }
            )
        };
        assert!(expected, "{ranges:?} {y:?}: {e}");
    }
    // A command outside a good range is refused as `execute` refuses it; inside, planned.
    let plant = Indexed::new(vec![[1000.0, 2000.0]]);
    assert!(matches!(
        state.pre_position(&plant, &a, &[2500.0], false),
        Err(ServoError::OutOfServoRange { joint: 0, .. })
    ));
    assert_eq!(
        state.pre_position(&plant, &a, &[1500.0], false).unwrap(),
        Some(vec![1480.0])
    );
    assert_eq!(
        state.pre_position(&plant, &a, &[1010.0], false).unwrap(),
        Some(vec![1000.0])
    );
}

/// With `RangePolicy::Clamp` the loops clamped every component of a command into the plant's
/// range before checking its length: a command longer than the plant's asked for the range of
/// a joint the plant does not have.
#[test]
fn clamped_commands_of_another_length_are_refused_before_the_plant_is_asked() {
    use servo_loop::{
        BroydenConfig, RangePolicy, ServoConfig, servo_broyden, servo_image_jacobian,
    };
    let config = ServoConfig {
        range: RangePolicy::Clamp,
        ..ServoConfig::default()
    };
    let y0 = [0.5, 0.5, 0.5];
    let x_w = [120.0, 130.0];
    let refused = |abort: servo_loop::ServoAbort, plant: &Indexed| {
        assert!(
            matches!(
                abort.error,
                ServoError::DimensionMismatch {
                    what: "command",
                    expected: 2,
                    got: 3
                }
            ),
            "{}",
            abort.error
        );
        assert!(abort.run.steps.is_empty() && abort.run.failed_move.is_none());
        assert_eq!(plant.acts, 0, "nothing sent");
    };
    let mut plant = Indexed::new(vec![[0.0, 1.0]; 2]);
    let abort = servo_image_jacobian(&mut plant, &y0, &x_w, &config, |_| {
        Ok(nalgebra::DMatrix::identity(2, 2))
    })
    .unwrap_err();
    refused(abort, &plant);
    let mut plant = Indexed::new(vec![[0.0, 1.0]; 2]);
    let abort =
        servo_broyden(&mut plant, &y0, &x_w, &config, &BroydenConfig::default()).unwrap_err();
    refused(abort, &plant);
    // A command of the plant's length is clamped and sent, as before.
    let mut plant = Indexed::new(vec![[0.0, 1.0]; 2]);
    let run = servo_image_jacobian(&mut plant, &[1.5, 0.5], &x_w, &config, |_| {
        Ok(nalgebra::DMatrix::identity(2, 2))
    });
    assert!(plant.acts >= 1, "{run:?}");
}

/// `learn_control_chained` sized a block as `moves + 1 − k`: for `moves = usize::MAX` that
/// overflowed on the first move (a panic in debug builds).
#[test]
fn a_learning_session_of_usize_max_moves_does_not_overflow() {
    use servo_loop::{
        Approach, ApproachDirection, LearnConfig, Observation, Plant, learn_control_chained,
    };
    /// One joint in [0, 1]; every move fails.
    struct Unplugged;
    impl Plant for Unplugged {
        fn percept_dim(&self) -> usize {
            2
        }
        fn command_dim(&self) -> usize {
            1
        }
        fn command_range(&self, _: usize) -> [f64; 2] {
            [0.0, 1.0]
        }
        fn act(&mut self, _: &[f64]) -> servo_loop::Result<()> {
            Err(ServoError::Robot {
                during: "command",
                message: "unplugged".into(),
            })
        }
        fn observe(&mut self) -> servo_loop::Result<Observation> {
            unreachable!("nothing moved")
        }
    }
    let mut model = InverseModel::new(2, 1, &InverseModelConfig::default()).unwrap();
    let config = LearnConfig {
        moves: usize::MAX,
        explore: vec![[0.0, 1.0]],
        seed: 7,
        approach: Some(Approach {
            overshoot: 0.1,
            direction: ApproachDirection::Up,
            resolution: 0.0,
        }),
    };
    let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        learn_control_chained(&mut Unplugged, &mut model, &config, 4, |_, _| {})
    }));
    let e = r.expect("learning panicked").unwrap_err();
    assert!(matches!(e, ServoError::Robot { .. }), "{e}");
    assert_eq!(model.n_data(), 0);
}

/// A plant whose percept has `usize::MAX` components (its own code says so): the dimension
/// errors of `learn_control` and `TemporalPlant::new` multiplied its dimensions and
/// overflowed (a panic in debug builds, a wrapped count in release builds).
#[test]
fn dimension_errors_of_absurd_plants_do_not_overflow() {
    use servo_loop::{
        LearnConfig, Observation, Plant, TemporalCheck, TemporalPlant, learn_control,
    };
    struct Absurd;
    impl Plant for Absurd {
        fn percept_dim(&self) -> usize {
            usize::MAX
        }
        fn command_dim(&self) -> usize {
            2
        }
        fn command_range(&self, _: usize) -> [f64; 2] {
            [0.0, 1.0]
        }
        fn act(&mut self, _: &[f64]) -> servo_loop::Result<()> {
            Ok(())
        }
        fn observe(&mut self) -> servo_loop::Result<Observation> {
            unreachable!("nothing moved")
        }
    }
    let model = || InverseModel::new(2, 2, &InverseModelConfig::default()).unwrap();
    let config = LearnConfig {
        moves: 3,
        explore: vec![[0.0, 1.0]; 2],
        seed: 7,
        approach: None,
    };
    let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        learn_control(&mut Absurd, &mut model(), &config, |_, _| {})
    }));
    let e = r.expect("learn_control panicked").unwrap_err();
    assert!(matches!(e, ServoError::DimensionMismatch { .. }), "{e}");
    let check: TemporalCheck = serde_json::from_str(
        r#"{"config":{"max_move":60.0,"quantile":0.5,"factor":4.0,"bins":4},
            "offset":1.0,"slope":0.1,"pairs":40}"#,
    )
    .unwrap();
    let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        TemporalPlant::new(Absurd, model(), check).map(|_| ())
    }));
    let e = r.expect("TemporalPlant::new panicked").unwrap_err();
    assert!(matches!(e, ServoError::DimensionMismatch { .. }), "{e}");
}

/// One camera; always finds the gripper at (1, 2) with certainty 0.9.
struct Steady;

impl servo_loop::Recogniser for Steady {
    fn num_cameras(&self) -> usize {
        1
    }
    fn image_size(&self, _: usize) -> [u32; 2] {
        [4, 4]
    }
    fn locate_all(
        &self,
        images: &[image::GrayImage],
    ) -> servo_loop::Result<Vec<servo_loop::Localisation>> {
        Ok(images
            .iter()
            .map(|_| servo_loop::Localisation {
                position: [1.0, 2.0],
                certainty: 0.9,
            })
            .collect())
    }
}

/// A percept policy of `usize::MAX` re-captures (accepted by `PerceptPolicy::validate`): its
/// attempts were counted as `recaptures + 1`, which overflowed (a panic in debug builds; in
/// release builds no attempt was made and `unreachable!` panicked).
#[test]
fn percept_policies_of_usize_max_recaptures_do_not_overflow() {
    use servo_loop::{
        ControlSpace, MotionCheck, PerceptPolicy, PerceptUse, Plant, VisualPlant, observe_checked,
    };
    let policy = PerceptPolicy {
        captures: 1,
        min_certainty: 0.5,
        recaptures: usize::MAX,
        used: PerceptUse::Servo,
    };
    policy.validate().unwrap();
    let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        observe_checked(
            &Steady,
            &policy,
            || Ok(vec![image::GrayImage::new(4, 4)]),
            |images| servo_loop::Recogniser::locate_all(&Steady, images),
            || {},
        )
    }));
    let (locs, _) = r.expect("observe_checked panicked").unwrap();
    assert_eq!(locs[0].position, [1.0, 2.0]);

    // A visual plant with a motion check (remembering one percept: nothing is judged).
    let space = ControlSpace {
        controlled: vec![0, 1],
        rest: vec![50.0; 3],
        gripper: None,
    };
    let mut plant = VisualPlant::new(Counting::default(), space, Steady).unwrap();
    plant.set_policy(policy).unwrap();
    let check: MotionCheck = serde_json::from_str(
        r#"{"config":{"neighbours":4,"reach":10.0,"quantile":0.5,"factor":4.0},
            "percept_dim":2,"command_dim":2,"memory":[[[1.0,2.0],[10.0,20.0]]],
            "trained":1,"scale":1.0}"#,
    )
    .unwrap();
    plant.set_motion_check(Some(check)).unwrap();
    plant.act(&[10.0, 20.0]).unwrap();
    let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| plant.observe()));
    let obs = r.expect("VisualPlant::observe panicked").unwrap();
    assert_eq!(obs.x, vec![1.0, 2.0]);
}

/// `TemporalCheck::learn` allocated one bin per `TemporalConfig::bins` before looking at the
/// samples: `usize::MAX` bins (accepted by `validate`, which only asked for 2 or more) was a
/// capacity-overflow panic, and a few billion an allocation failure.
#[test]
fn temporal_checks_of_absurdly_many_bins_are_refused() {
    use servo_loop::{TemporalCheck, TemporalConfig};
    let model = InverseModel::new(2, 2, &InverseModelConfig::default()).unwrap();
    let samples = vec![(vec![100.0, 100.0], vec![0.5, 0.5]); 3];
    for bins in [
        usize::MAX,
        usize::MAX / 24 + 1,
        TemporalConfig::MAX_BINS + 1,
    ] {
        let config = TemporalConfig {
            bins,
            ..TemporalConfig::default()
        };
        let e = TemporalCheck::learn(&model, &samples, &config).unwrap_err();
        assert!(
            matches!(e, ServoError::InvalidParameter { name: "bins", .. }),
            "{bins}: {e}"
        );
        let json = format!(
            r#"{{"config":{{"max_move":60.0,"quantile":0.5,"factor":4.0,"bins":{bins}}},
                "offset":1.0,"slope":0.1,"pairs":40}}"#
        );
        assert!(
            serde_json::from_str::<TemporalCheck>(&json).is_err(),
            "{bins}"
        );
    }
    // The most bins accepted: learning runs (and finds too few pairs in these samples).
    let config = TemporalConfig {
        bins: TemporalConfig::MAX_BINS,
        ..TemporalConfig::default()
    };
    config.validate().unwrap();
    assert!(matches!(
        TemporalCheck::learn(&model, &samples, &config),
        Err(ServoError::NotEnoughData(_))
    ));
}

/// A saved motion check of `command_dim = usize::MAX` (or a percept and command dimension
/// that sum past it): reading it computed `command_dim + 2` and `percept_dim + command_dim`,
/// which overflowed (a panic in debug builds).
#[test]
fn motion_checks_of_absurd_dimensions_are_refused_when_read() {
    use servo_loop::MotionCheck;
    let file = |percept: usize, command: usize| {
        format!(
            r#"{{"config":{{"neighbours":4,"reach":10.0,"quantile":0.5,"factor":4.0}},
                "percept_dim":{percept},"command_dim":{command},
                "memory":[[[1.0,2.0],[10.0,20.0]]],"trained":1,"scale":1.0}}"#
        )
    };
    for (percept, command, what) in [
        (2, usize::MAX, "neighbours"),
        (usize::MAX - 1, 2, "motion check sample"),
    ] {
        let err = serde_json::from_str::<MotionCheck>(&file(percept, command)).unwrap_err();
        assert!(
            err.to_string().contains(what),
            "{percept} × {command}: {err}"
        );
    }
    assert!(serde_json::from_str::<MotionCheck>(&file(2, 2)).is_ok());
}

/// `FeatureMap::compute` looped over `1..width − 1`: a half-resolution image 0 pixels wide and
/// at least 3 high (a full-resolution image 1 pixel wide) underflowed; a `FloatImage` (public
/// fields) whose data is shorter than `width × height` was indexed past its end, there and in
/// `changed_region` / `changed_mask`.
#[test]
fn feature_maps_and_changes_of_degenerate_images_do_not_panic() {
    use servo_loop::recognition::change::{changed_mask, changed_region};
    use servo_loop::recognition::features::{FeatureMap, FeatureParams};
    use servo_loop::recognition::image::FloatImage;
    let params = FeatureParams {
        block: 3,
        orientations: 8,
        magnitude_half: 40.0,
        intensities: 8,
    };
    let thin = FloatImage {
        width: 0,
        height: 3,
        data: vec![],
    };
    // As wide as a 1- or 2-pixel image: one spatial channel, no gradient.
    let map = FeatureMap::compute(&thin, &params).unwrap();
    assert_eq!((map.blocks_x, map.blocks_y), (1, 1));
    assert!(map.data.iter().all(|v| v.is_finite()));
    for data in [vec![10.0; 3], vec![10.0; 17]] {
        let bad = FloatImage {
            width: 4,
            height: 4,
            data,
        };
        assert!(matches!(
            FeatureMap::compute(&bad, &params),
            Err(ServoError::InvalidParameter { name: "image", .. })
        ));
        let good = FloatImage {
            width: 4,
            height: 4,
            data: vec![10.0; 16],
        };
        assert_eq!(changed_region(&bad, &good, 1), None);
        assert_eq!(changed_region(&good, &bad, 1), None);
        assert_eq!(changed_mask(&bad, &good), None);
        assert_eq!(changed_mask(&good, &good), Some(vec![false; 16]));
    }
}

/// `RecognitionConfig::validate` let through `cells` whose descriptor, `cells² ×` channels
/// values, overflows: learning then sized its descriptors by an overflowing product (a panic
/// in debug builds, a wrapped length in release builds).
#[test]
fn recognition_settings_whose_descriptor_overflows_are_refused() {
    use image::{GrayImage, Luma};
    use servo_loop::recognition::TrainingView;
    use servo_loop::{GripperModel, RecognitionConfig};
    // A 10 × 10 block appears between the two images: a changed region to learn from.
    let before = GrayImage::from_pixel(64, 64, Luma([100]));
    let mut after = before.clone();
    for y in 20..30 {
        for x in 20..30 {
            after.put_pixel(x, y, Luma([250]));
        }
    }
    let views = vec![TrainingView {
        before: vec![before],
        after: vec![after],
    }];
    assert!(GripperModel::learn(&RecognitionConfig::default(), &views).is_ok());
    let config = RecognitionConfig {
        cells: 1 << 32,
        ..RecognitionConfig::default()
    };
    let e = GripperModel::learn(&config, &views).unwrap_err();
    assert!(
        matches!(e, ServoError::InvalidParameter { name: "cells", .. }),
        "{e}"
    );
    let config = RecognitionConfig {
        orientations: usize::MAX,
        intensities: 1,
        ..RecognitionConfig::default()
    };
    let e = GripperModel::learn(&config, &views).unwrap_err();
    assert!(
        matches!(
            e,
            ServoError::InvalidParameter {
                name: "intensities",
                ..
            }
        ),
        "{e}"
    );
}
