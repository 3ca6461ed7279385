//! The percept seam: a user's own recogniser plugs into [`VisualPlant`] through
//! [`Recogniser`]; a doubted percept is re-captured, then refused with a typed error; learning
//! skips and counts it; the servo loop never moves on it. The same for a percept the cameras
//! agree on but the commanded move does not explain ([`MotionCheck`]).

use image::{GrayImage, Luma};
use servo_loop::{
    ControlSpace, InverseModel, InverseModelConfig, LearnConfig, Localisation, MotionCheck,
    MotionConfig, PerceptPolicy, PerceptUse, Plant, RandomCommands, Recogniser, Robot, ServoConfig,
    ServoError, VisualPlant, learn_control, observe_averaged, observe_averaged_by, observe_checked,
    servo_lwpr,
};

/// Two servos; each capture shows the set-points as grey levels, a "doubt" flag for the
/// next `doubt` captures and a "gross" flag for the next `gross` captures.
struct Toy {
    y: [f64; 2],
    doubt: usize,
    gross: usize,
    captures: usize,
    commands: usize,
}

impl Robot for Toy {
    type Error = String;
    fn num_servos(&self) -> usize {
        2
    }
    fn servo_range(&self, _: usize) -> [f64; 2] {
        [0.0, 250.0]
    }
    fn command(&mut self, set_points: &[f64]) -> Result<(), String> {
        self.commands += 1;
        self.y = [set_points[0], set_points[1]];
        Ok(())
    }
    fn capture(&mut self) -> Result<Vec<GrayImage>, String> {
        self.captures += 1;
        let flag = if self.doubt > 0 {
            self.doubt -= 1;
            255
        } else {
            0
        };
        let gross = if self.gross > 0 {
            self.gross -= 1;
            255
        } else {
            0
        };
        Ok((0..2)
            .map(|cam| {
                let mut img = GrayImage::new(8, 8);
                img.put_pixel(0, 0, Luma([self.y[0].round() as u8]));
                img.put_pixel(1, 0, Luma([self.y[1].round() as u8]));
                img.put_pixel(2, 0, Luma([flag]));
                img.put_pixel(3, 0, Luma([cam]));
                img.put_pixel(4, 0, Luma([gross]));
                img
            })
            .collect())
    }
}

/// A user's recogniser: reads the grey levels back as a point; doubts flagged images; on
/// "gross" images it finds a point 30 px off in both cameras alike, with full confidence (the
/// views of another point: no cross-camera check can see it).
struct Reader;

impl Recogniser for Reader {
    fn num_cameras(&self) -> usize {
        2
    }
    fn image_size(&self, _: usize) -> [u32; 2] {
        [300, 300]
    }
    fn locate_all(&self, images: &[GrayImage]) -> servo_loop::Result<Vec<Localisation>> {
        Ok(images
            .iter()
            .map(|img| {
                let p = |x| f64::from(img.get_pixel(x, 0).0[0]);
                let cam = p(3);
                let off = if p(4) > 0.0 { 30.0 } else { 0.0 };
                Localisation {
                    position: [10.0 + p(0) + 5.0 * cam + off, 20.0 + p(1) - 3.0 * cam],
                    certainty: if p(2) > 0.0 { 0.01 } else { 0.9 },
                }
            })
            .collect())
    }
}

/// A recogniser that doubts flagged images only when the servo acts on them (as the learned
/// tip's spread cap with `cap_training` off).
struct ServoDoubter;

impl Recogniser for ServoDoubter {
    fn num_cameras(&self) -> usize {
        Reader.num_cameras()
    }
    fn image_size(&self, cam: usize) -> [u32; 2] {
        Reader.image_size(cam)
    }
    fn locate_all(&self, images: &[GrayImage]) -> servo_loop::Result<Vec<Localisation>> {
        Reader.locate_all(images)
    }
    fn locate_all_for(
        &self,
        images: &[GrayImage],
        used: PerceptUse,
    ) -> servo_loop::Result<Vec<Localisation>> {
        let mut locs = Reader.locate_all(images)?;
        if used == PerceptUse::Training {
            for l in &mut locs {
                l.certainty = l.certainty.max(0.9);
            }
        }
        Ok(locs)
    }
}

fn toy_space() -> ControlSpace {
    ControlSpace {
        controlled: vec![0, 1],
        rest: vec![100.0, 100.0],
        gripper: None,
    }
}

/// An untrained inverse model of the toy's scales and `moves` random training moves.
fn toy_learning(moves: usize) -> (InverseModel, LearnConfig) {
    let config = InverseModelConfig {
        percept_scale: 100.0,
        command_scale: 100.0,
        ..InverseModelConfig::default()
    };
    let learn = LearnConfig {
        moves,
        explore: vec![[20.0, 200.0]; 2],
        seed: 5,
        approach: None,
    };
    (InverseModel::new(4, 2, &config).unwrap(), learn)
}

fn plant(doubt: usize) -> VisualPlant<Toy, Reader> {
    let toy = Toy {
        y: [100.0, 100.0],
        doubt,
        gross: 0,
        captures: 0,
        commands: 0,
    };
    VisualPlant::new(toy, toy_space(), Reader).unwrap()
}

/// The plant passes its policy's use to the recogniser: training moves under
/// `PerceptUse::Training` keep percepts the servo's policy refuses.
#[test]
fn the_policy_says_what_a_percept_is_for() {
    let toy = Toy {
        y: [100.0, 100.0],
        doubt: usize::MAX,
        gross: 0,
        captures: 0,
        commands: 0,
    };
    let mut p = VisualPlant::new(toy, toy_space(), ServoDoubter).unwrap();
    assert_eq!(p.policy().used, PerceptUse::Servo, "the default use");
    p.set_policy(PerceptPolicy {
        used: PerceptUse::Training,
        ..PerceptPolicy::default()
    })
    .unwrap();
    let (mut model, learn) = toy_learning(50);
    let report = learn_control(&mut p, &mut model, &learn, |_, _| {}).unwrap();
    assert_eq!((report.refused, p.refused(), p.recaptured()), (0, 0, 0));
    // The same images as servo percepts: re-captured, then refused.
    p.set_policy(PerceptPolicy::default()).unwrap();
    assert!(matches!(
        p.observe(),
        Err(ServoError::PerceptRefused { .. })
    ));
    assert_eq!((p.refused(), p.recaptured()), (1, 1));
}

#[test]
fn a_users_recogniser_is_the_percept() {
    let mut p = plant(0);
    p.act(&[50.0, 60.0]).unwrap();
    let o = p.observe().unwrap();
    assert_eq!(o.x, vec![60.0, 80.0, 65.0, 77.0]);
    assert_eq!(o.certainty, 0.9);
    assert_eq!(p.percept_bounds().unwrap(), vec![[0.0, 299.0]; 4]);
}

#[test]
fn a_doubted_percept_is_recaptured_then_refused() {
    // One doubted capture: the re-capture is accepted.
    let mut p = plant(1);
    let o = p.observe().unwrap();
    assert_eq!(o.certainty, 0.9);
    assert_eq!((p.recaptured(), p.refused()), (1, 0));
    assert_eq!(p.robot().captures, 2);
    // Doubted on every attempt (2 captures per attempt, 1 re-capture): refused, typed.
    let mut p = plant(100);
    p.set_policy(PerceptPolicy {
        captures: 2,
        min_certainty: 0.05,
        recaptures: 1,
        used: PerceptUse::Servo,
    })
    .unwrap();
    let e = p.observe().unwrap_err();
    assert_eq!(
        e,
        ServoError::PerceptRefused {
            camera: 0,
            certainty: 0.01,
            min: 0.05,
            captures: 4
        }
    );
    assert_eq!((p.recaptured(), p.refused()), (1, 1));
    // An invalid policy is refused and changes nothing.
    let before = *p.policy();
    for bad in [
        PerceptPolicy {
            captures: 0,
            ..before
        },
        PerceptPolicy {
            min_certainty: 1.5,
            ..before
        },
    ] {
        assert!(p.set_policy(bad).is_err());
        assert_eq!(*p.policy(), before);
    }
}

#[test]
fn learning_skips_refused_percepts_and_the_servo_loop_never_moves_on_one() {
    let mut p = plant(0);
    let (mut model, learn) = toy_learning(200);
    learn_control(&mut p, &mut model, &learn, |_, _| {}).unwrap();
    // Ten doubted moves (two captures each with the re-capture) are skipped and counted.
    p.robot_mut().doubt = 20;
    let before = model.clone();
    let ten = LearnConfig {
        moves: 10,
        ..learn.clone()
    };
    assert!(matches!(
        learn_control(&mut p, &mut model, &ten, |_, _| {}),
        Err(ServoError::NotEnoughData(_))
    ));
    assert_eq!(model, before, "nothing learned from refused percepts");
    assert_eq!(p.refused(), 10);
    // A servo run whose second percept is refused stops there: one move, no second.
    let x_w = [10.0 + 120.0, 20.0 + 90.0, 15.0 + 120.0, 17.0 + 90.0];
    p.robot_mut().doubt = 0;
    let mut servo_model = model.clone();
    // The first guess is seen clearly; the next percept is doubted twice (refused).
    let run = servo_after_first(&mut p, &mut servo_model, &x_w, false);
    assert!(matches!(run, ServoError::PerceptRefused { .. }), "{run}");
}

/// An LWPR servo run to `x_w` on `p` whose percepts after the first move are doubted (or
/// gross, [`DoubtAfterFirst`]): it must stop after the first guess (no move after the
/// refusal); gives the error it stopped with.
fn servo_after_first(
    p: &mut VisualPlant<Toy, Reader>,
    model: &mut InverseModel,
    x_w: &[f64],
    gross: bool,
) -> ServoError {
    let cfg = ServoConfig {
        tolerance: 0.0,
        ..ServoConfig::default()
    };
    let commands = p.robot().commands;
    let run = servo_lwpr(
        &mut DoubtAfterFirst {
            plant: &mut *p,
            moves: 0,
            gross,
        },
        model,
        x_w,
        &cfg,
    )
    .unwrap_err();
    assert_eq!(run.run.steps.len(), 1, "only the first guess was recorded");
    assert_eq!(
        p.robot().commands,
        commands + 2,
        "no move after the refusal"
    );
    run.error
}

/// The toy plant, with every percept after the first move doubted (or, with `gross`, found
/// 30 px off with full confidence).
struct DoubtAfterFirst<'a> {
    plant: &'a mut VisualPlant<Toy, Reader>,
    moves: usize,
    gross: bool,
}

impl Plant for DoubtAfterFirst<'_> {
    fn percept_dim(&self) -> usize {
        self.plant.percept_dim()
    }
    fn command_dim(&self) -> usize {
        self.plant.command_dim()
    }
    fn command_range(&self, j: usize) -> [f64; 2] {
        self.plant.command_range(j)
    }
    fn act(&mut self, y: &[f64]) -> servo_loop::Result<()> {
        self.moves += 1;
        if self.moves >= 2 {
            if self.gross {
                self.plant.robot_mut().gross = 100;
            } else {
                self.plant.robot_mut().doubt = 100;
            }
        }
        self.plant.act(y)
    }
    fn observe(&mut self) -> servo_loop::Result<servo_loop::Observation> {
        self.plant.observe()
    }
    fn percept_bounds(&self) -> Option<Vec<[f64; 2]>> {
        self.plant.percept_bounds()
    }
}

/// `n` training samples `(percept, command)` of the toy plant at random commands.
fn toy_samples(p: &mut VisualPlant<Toy, Reader>, n: usize) -> Vec<(Vec<f64>, Vec<f64>)> {
    let mut commands = RandomCommands::new(&[[20.0, 200.0]; 2], 11).unwrap();
    (0..n)
        .map(|_| {
            let y = commands.next_command();
            p.act(&y).unwrap();
            (p.observe().unwrap().x, y)
        })
        .collect()
}

/// A gross percept both cameras agree on (so it lies on the epipolar line) is refused by the
/// motion check, typed, after a re-capture; a one-off one is recovered by the re-capture;
/// training percepts are not judged; accepted servo percepts are remembered.
#[test]
fn a_gross_percept_the_cameras_agree_on_is_refused_by_the_motion_check() {
    let mut p = plant(0);
    let samples = toy_samples(&mut p, 300);
    let check = MotionCheck::learn(&samples, &MotionConfig::default()).unwrap();
    // The toy's only error is the grey levels' rounding (≤ 0.5 per coordinate).
    assert!(check.threshold() < 4.0, "{}", check.threshold());
    p.set_motion_check(Some(check)).unwrap();
    let remembered = p.motion_check().unwrap().remembered();
    // A clean percept passes and is remembered.
    p.act(&[100.0, 120.0]).unwrap();
    let clean = p.observe().unwrap();
    assert_eq!(clean.x, vec![110.0, 140.0, 115.0, 137.0]);
    assert_eq!(p.motion_check().unwrap().remembered(), remembered + 1);
    // The planted gross percept on every capture: re-captured once, then refused, typed.
    p.act(&[101.0, 121.0]).unwrap();
    p.robot_mut().gross = 10;
    let captures = p.robot().captures;
    match p.observe() {
        Err(ServoError::PerceptInconsistent {
            residual,
            threshold,
        }) => assert!(residual > 25.0 && threshold < 4.0, "{residual} {threshold}"),
        other => panic!("expected a refusal, got {other:?}"),
    }
    assert_eq!((p.inconsistent(), p.recaptured(), p.refused()), (1, 1, 0));
    assert_eq!(
        p.robot().captures,
        captures + 2,
        "one capture and its re-capture"
    );
    assert_eq!(
        p.motion_check().unwrap().remembered(),
        remembered + 1,
        "not remembered"
    );
    // A one-off gross percept: the re-capture is accepted.
    p.robot_mut().gross = 1;
    let o = p.observe().unwrap();
    assert_eq!(o.x, vec![111.0, 141.0, 116.0, 138.0]);
    assert_eq!((p.inconsistent(), p.recaptured()), (1, 2));
    // Training percepts are neither judged nor remembered.
    p.set_policy(PerceptPolicy {
        used: PerceptUse::Training,
        ..PerceptPolicy::default()
    })
    .unwrap();
    p.robot_mut().gross = 1;
    assert_eq!(p.observe().unwrap().x[0], 141.0);
    assert_eq!(p.motion_check().unwrap().remembered(), remembered + 2);
    // Without the check the gross percept is taken (the comparison).
    p.set_policy(PerceptPolicy::default()).unwrap();
    p.set_motion_check(None).unwrap();
    p.robot_mut().gross = 1;
    assert_eq!(p.observe().unwrap().x[0], 141.0);
    // A check of another dimension is refused.
    let other: Vec<(Vec<f64>, Vec<f64>)> = samples
        .iter()
        .map(|(x, y)| (x[..2].to_vec(), y.clone()))
        .collect();
    let other = MotionCheck::learn(&other, &MotionConfig::default()).unwrap();
    assert!(matches!(
        p.set_motion_check(Some(other)),
        Err(ServoError::DimensionMismatch { .. })
    ));
}

/// `VisualPlant::act` refuses a command that does not fit the controlled servos (its length,
/// a non-finite value, a value outside a servo's range) before anything is sent, and the
/// refusal changes no state: the next percept is judged by the motion check against the last
/// executed command, as on a twin plant that never saw the bad command. (A command of another
/// length used to forget the last executed command, so the next percept went unjudged and
/// unremembered; a NaN or out-of-range one reached the robot.)
#[test]
fn a_refused_command_changes_nothing_in_the_visual_plant() {
    let mut p = plant(0);
    let samples = toy_samples(&mut p, 300);
    let check = MotionCheck::learn(&samples, &MotionConfig::default()).unwrap();
    let mut twin = plant(0);
    for q in [&mut p, &mut twin] {
        q.set_motion_check(Some(check.clone())).unwrap();
        q.act(&[100.0, 120.0]).unwrap();
    }
    let commands = p.robot().commands;
    for bad in [
        vec![100.0],
        vec![100.0, 120.0, 5.0],
        vec![f64::NAN, 120.0],
        vec![100.0, 250.5],
        vec![-1.0, 120.0],
    ] {
        assert!(p.act(&bad).is_err(), "{bad:?}: accepted");
        assert_eq!(p.robot().commands, commands, "{bad:?}: sent");
        assert_eq!(p.robot().y, [100.0, 120.0], "{bad:?}: moved");
    }
    // The next percept is judged and remembered as on the twin, a gross one refused alike.
    assert_eq!(p.observe().unwrap(), twin.observe().unwrap());
    let remembered = |q: &VisualPlant<Toy, Reader>| q.motion_check().map(|c| c.remembered());
    assert_eq!(remembered(&p), remembered(&twin), "percepts remembered");
    assert!(
        p.motion_check() == twin.motion_check(),
        "motion check differs"
    );
    assert_eq!(p.last_localisations(), twin.last_localisations());
    assert!(p.act(&[f64::INFINITY, 0.0]).is_err());
    p.robot_mut().gross = 10;
    twin.robot_mut().gross = 10;
    let (a, b) = (p.observe().unwrap_err(), twin.observe().unwrap_err());
    assert!(matches!(a, ServoError::PerceptInconsistent { .. }), "{a}");
    assert_eq!(a, b);
    assert_eq!(
        (p.inconsistent(), p.recaptured(), p.refused()),
        (twin.inconsistent(), twin.recaptured(), twin.refused())
    );
}

/// Refused settings change nothing: `set_captures(0)` and an invalid policy keep the policy, a
/// motion check of another dimension keeps the check (and every percept it remembered), and
/// `observe_checked` with an invalid policy grabs, locates and counts nothing.
#[test]
fn refused_settings_change_nothing_in_the_visual_plant() {
    let mut p = plant(0);
    let samples = toy_samples(&mut p, 300);
    let check = MotionCheck::learn(&samples, &MotionConfig::default()).unwrap();
    p.set_motion_check(Some(check.clone())).unwrap();
    let policy = PerceptPolicy {
        captures: 2,
        min_certainty: 0.1,
        recaptures: 2,
        used: PerceptUse::Servo,
    };
    p.set_policy(policy).unwrap();
    assert!(matches!(
        p.set_captures(0),
        Err(ServoError::InvalidParameter {
            name: "captures",
            ..
        })
    ));
    assert_eq!(*p.policy(), policy, "set_captures(0)");
    let bad_policies = [
        PerceptPolicy {
            captures: 0,
            ..policy
        },
        PerceptPolicy {
            min_certainty: -0.1,
            ..policy
        },
        PerceptPolicy {
            min_certainty: f64::NAN,
            ..policy
        },
    ];
    for bad in bad_policies {
        assert!(p.set_policy(bad).is_err(), "{bad:?}: accepted");
        assert_eq!(*p.policy(), policy, "{bad:?}: policy changed");
    }
    let two: Vec<(Vec<f64>, Vec<f64>)> = samples
        .iter()
        .map(|(x, y)| (x[..2].to_vec(), y.clone()))
        .collect();
    let other = MotionCheck::learn(&two, &MotionConfig::default()).unwrap();
    assert!(p.set_motion_check(Some(other)).is_err());
    assert!(p.motion_check() == Some(&check), "check replaced");
    assert_eq!(
        (p.inconsistent(), p.recaptured(), p.refused()),
        (0, 0, 0),
        "counters"
    );
    for bad in bad_policies {
        let (mut grabbed, mut located, mut recaptures) = (0, 0, 0);
        let e = observe_checked(
            &Reader,
            &bad,
            || {
                grabbed += 1;
                Ok(vec![
                    reader_image(0, 1, 1, false),
                    reader_image(1, 1, 1, false),
                ])
            },
            |imgs| {
                located += 1;
                Reader.locate_all(imgs)
            },
            || recaptures += 1,
        )
        .unwrap_err();
        assert!(matches!(e, ServoError::InvalidParameter { .. }), "{e}");
        assert_eq!((grabbed, located, recaptures), (0, 0, 0), "{bad:?}");
    }
}

/// The servo loop never moves on a percept the motion check refused: the run stops with the
/// typed error after the first guess.
#[test]
fn the_servo_loop_never_moves_on_a_motion_refused_percept() {
    let mut p = plant(0);
    let (mut model, learn) = toy_learning(200);
    learn_control(&mut p, &mut model, &learn, |_, _| {}).unwrap();
    let samples = toy_samples(&mut p, 300);
    p.set_motion_check(Some(
        MotionCheck::learn(&samples, &MotionConfig::default()).unwrap(),
    ))
    .unwrap();
    let x_w = [10.0 + 120.0, 20.0 + 90.0, 15.0 + 120.0, 17.0 + 90.0];
    let run = servo_after_first(&mut p, &mut model, &x_w, true);
    assert!(
        matches!(run, ServoError::PerceptInconsistent { .. }),
        "{run}"
    );
    assert_eq!(p.inconsistent(), 1);
}

/// Behind the percept seam every recogniser gets the recovery move: a user's recogniser doubts
/// the first guess's percept (and its re-capture); with a recovery the loop makes one small
/// known move instead of stopping, and goes on from its accepted percept.
#[test]
fn a_users_recogniser_gets_the_recovery_move() {
    let mut p = plant(0);
    let (mut model, learn) = toy_learning(200);
    learn_control(&mut p, &mut model, &learn, |_, _| {}).unwrap();
    let x_w = [10.0 + 120.0, 20.0 + 90.0, 15.0 + 120.0, 17.0 + 90.0];
    let recovery = servo_loop::Recovery {
        step: 10.0,
        tries: 2,
        workspace: learn.explore.clone(),
        seed: 1,
    };
    let cfg = ServoConfig {
        tolerance: 0.0,
        max_iterations: 4,
        recovery: Some(recovery.clone()),
        ..ServoConfig::default()
    };
    let (refused, commands) = (p.refused(), p.robot().commands);
    // The first guess's capture and its re-capture are doubted: refused.
    p.robot_mut().doubt = 2;
    let run = servo_lwpr(&mut p, &mut model.clone(), &x_w, &cfg).unwrap();
    assert_eq!(p.refused(), refused + 1);
    assert_eq!(run.refused.len(), 1);
    assert_eq!(run.recovery_moves, 1);
    let y0 = run.refused[0].command.clone();
    assert_eq!(
        run.steps[0].command,
        recovery.command(&y0, 0, |j| p.command_range(j)).unwrap()
    );
    assert!(run.moves() <= 5, "the budget: the first guess and 4 moves");
    assert!(
        run.steps.len() >= 2,
        "a correction after the recovered percept"
    );
    assert_eq!(p.robot().commands, commands + run.moves());
    // Without it the run stops at the refused first guess.
    p.robot_mut().doubt = 2;
    let cfg = ServoConfig {
        recovery: None,
        ..cfg
    };
    let abort = servo_lwpr(&mut p, &mut model, &x_w, &cfg).unwrap_err();
    assert!(matches!(abort.error, ServoError::PerceptRefused { .. }));
    assert_eq!(abort.run.moves(), 1);
}

/// Camera `cam`'s image that [`Reader`] reads as the point `(10 + a + 5 cam, 20 + b − 3 cam)`,
/// doubted (certainty 0.01, else 0.9) when `doubt`.
fn reader_image(cam: u8, a: u8, b: u8, doubt: bool) -> GrayImage {
    let mut img = GrayImage::new(8, 8);
    img.put_pixel(0, 0, Luma([a]));
    img.put_pixel(1, 0, Luma([b]));
    img.put_pixel(2, 0, Luma([if doubt { 255 } else { 0 }]));
    img.put_pixel(3, 0, Luma([cam]));
    img
}

/// `observe_averaged`: the mean position of the captures and the smallest certainty per
/// camera, with the last capture's images; a capture or a localisation of another camera
/// count is a typed error. `observe_checked` names the least certain camera and counts every
/// capture made.
#[test]
fn observations_average_the_captures_and_name_the_least_certain_camera() {
    let frames = [
        [(10, 20, false), (30, 40, false)],
        [(20, 40, false), (50, 60, true)],
        [(30, 30, false), (40, 50, false)],
    ];
    let images = |k: usize| -> Vec<GrayImage> {
        (0..2)
            .map(|cam| {
                let (a, b, d) = frames[k % 3][cam];
                reader_image(cam as u8, a, b, d)
            })
            .collect()
    };
    let mut k = 0;
    let (locs, last) = observe_averaged(&Reader, 3, || {
        k += 1;
        Ok(images(k - 1))
    })
    .unwrap();
    assert_eq!(k, 3);
    assert_eq!(
        locs,
        vec![
            Localisation {
                position: [30.0, 50.0],
                certainty: 0.9
            },
            Localisation {
                position: [55.0, 67.0],
                certainty: 0.01
            },
        ]
    );
    assert_eq!(last, images(2));
    // No capture asked for: an error before anything is grabbed.
    let mut grabbed = 0;
    assert!(matches!(
        observe_averaged(&Reader, 0, || {
            grabbed += 1;
            Ok(images(0))
        }),
        Err(ServoError::InvalidParameter {
            name: "captures",
            ..
        })
    ));
    assert_eq!(grabbed, 0);
    // Another camera count, in the capture or in the localisations.
    assert!(matches!(
        observe_averaged(&Reader, 1, || Ok(vec![reader_image(0, 1, 1, false)])),
        Err(ServoError::DimensionMismatch {
            what: "camera images",
            expected: 2,
            got: 1
        })
    ));
    assert!(matches!(
        observe_averaged_by(
            &Reader,
            1,
            || Ok(images(0)),
            |imgs| Ok(Reader.locate_all(imgs)?[..1].to_vec())
        ),
        Err(ServoError::DimensionMismatch {
            what: "camera localisations",
            expected: 2,
            got: 1
        })
    ));
    // Camera 1 doubted on every capture: refused after 2 attempts of 2 captures, naming it.
    let policy = PerceptPolicy {
        captures: 2,
        min_certainty: 0.5,
        recaptures: 1,
        used: PerceptUse::Servo,
    };
    let (mut grabbed, mut recaptures) = (0, 0);
    let e = observe_checked(
        &Reader,
        &policy,
        || {
            grabbed += 1;
            Ok(vec![
                reader_image(0, 1, 1, false),
                reader_image(1, 1, 1, true),
            ])
        },
        |imgs| Reader.locate_all(imgs),
        || recaptures += 1,
    )
    .unwrap_err();
    assert_eq!(
        e,
        ServoError::PerceptRefused {
            camera: 1,
            certainty: 0.01,
            min: 0.5,
            captures: 4
        }
    );
    assert_eq!((grabbed, recaptures), (4, 1));
}
