//! The FD + CBT pipeline on the simulated arm (`arm-sim` through [`SimRobot`]): learned by
//! action with the heuristic percept as its only teacher, then located on new poses and walks
//! the learner never saw; errors against the simulator's true tip. Also the typed errors.

use arm_sim::{ArmSim, SimConfig};
use servo_loop::{RandomCommands, Recogniser, ServoError, SilhouetteConfig, TipModel};
use visguide::SimRobot;
use visguide::pipeline::{
    ActionProtocol, FdCbtRecogniser, LearnReport, MotionConfig, MotionModel, PipelineError,
    PositionPrior, Vote, learn_by_action, mode, search_window,
};

use servo_loop::stats::quantile_rank;

use crate::common::arm;
use arm::{EXPLORE, heuristic, space};

type Learned = (SimRobot, TipModel, FdCbtRecogniser);

/// Random moves the forward model of the commanded moves is learned from.
const MOTION_MOVES: usize = 150;

/// The heuristic percept and the pipeline, learned once on the default arm (both tests share
/// it; each locks it for its whole run).
fn shared() -> std::sync::MutexGuard<'static, Learned> {
    static LEARNED: std::sync::OnceLock<std::sync::Mutex<Learned>> = std::sync::OnceLock::new();
    LEARNED
        .get_or_init(|| std::sync::Mutex::new(learned(SimConfig::default(), true).0))
        .lock()
        .unwrap_or_else(|p| p.into_inner())
}

/// The heuristic percept and the pipeline, learned on `config`'s arm (matching within a
/// polarity or not), and the learning's report.
fn learned(config: SimConfig, same_polarity: bool) -> (Learned, LearnReport) {
    let mut robot = SimRobot::new(ArmSim::new(config).unwrap());
    let heuristic = heuristic(
        &mut robot,
        &SilhouetteConfig {
            correction_poses: 120,
            ..SilhouetteConfig::default()
        },
    );
    let mut protocol = ActionProtocol {
        views: 24,
        walks: 4,
        steps: 10,
        ..ActionProtocol::default()
    };
    protocol.motion.moves = MOTION_MOVES;
    protocol.shapes.same_polarity = same_polarity;
    let (pipeline, report) =
        learn_by_action(&mut robot, &space(), &EXPLORE, &heuristic, &protocol).unwrap();
    eprintln!("{report:?}");
    assert_eq!(report.actions, 2 * 24 + MOTION_MOVES + 4 * 10);
    assert!(report.motion_pairs >= MOTION_MOVES * 9 / 10, "{report:?}");
    assert_eq!(
        pipeline.motion().map(|m| m.n_data()),
        Some(report.motion_pairs as u64)
    );
    assert!(report.shapes.views.iter().all(|&v| v >= 20), "{report:?}");
    // Without a prior there is no search window: no vote is left out of the walks.
    if !pipeline
        .prior()
        .is_some_and(|p| (0..2).any(|c| p.applies(c)))
    {
        assert_eq!(report.window_left_out, 0, "{report:?}");
    }
    ((robot, heuristic, pipeline), report)
}

/// Where the prior applies, the training walks keep only the votes of the regions the search
/// window would find. Matching across polarities (`same_polarity` off) votes from regions far
/// from the tip on this arm, so some walk votes lie outside the window and are left out; within
/// a polarity (the default) they may all lie inside it.
#[test]
fn the_walks_keep_only_the_votes_the_search_window_finds() {
    let ((_, _, pipeline), report) = learned(SimConfig::default(), false);
    assert!(
        pipeline
            .prior()
            .is_some_and(|p| (0..2).any(|c| p.applies(c))),
        "{report:?}"
    );
    assert!(report.window_left_out > 0, "{report:?}");
}

/// A default arm of its own, seeded (the shared one's state is the other tests').
fn own_arm(seed: u64) -> SimRobot {
    SimRobot::new(
        ArmSim::new(SimConfig {
            seed,
            ..SimConfig::default()
        })
        .unwrap(),
    )
}

fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

#[test]
fn fd_and_fd_cbt_find_the_tip_on_new_walks() {
    let mut guard = shared();
    let (robot, heuristic, pipeline) = &mut *guard;
    let mut commands = RandomCommands::new(&EXPLORE, 77).unwrap();
    let (mut fd, mut cbt, mut heur) = (Vec::new(), Vec::new(), Vec::new());
    let mut refused = 0;
    for _ in 0..4 {
        pipeline.reset();
        let mut y = commands.next_command();
        for step in 0..6 {
            y[step % 3] += 4.0;
            robot.0.command(&space().full_command(&y).unwrap()).unwrap();
            let images = robot.0.capture();
            let truth = robot.0.inspect().finger_middle_pixels().unwrap();
            match pipeline.fd.locate_all(&images) {
                Ok(l) => fd.extend((0..2).map(|c| dist(l[c].position, truth[c]))),
                Err(_) => refused += 1,
            }
            if let Ok(l) = pipeline.locate_all(&images) {
                cbt.extend((0..2).map(|c| dist(l[c].position, truth[c])));
            }
            if let Ok(l) = heuristic.locate_all(&images) {
                heur.extend((0..2).map(|c| dist(l[c].position, truth[c])));
            }
        }
    }
    let (m_fd, m_cbt, m_h) = (
        quantile_rank(&mut fd, 0.5),
        quantile_rank(&mut cbt, 0.5),
        quantile_rank(&mut heur, 0.5),
    );
    let (p_fd, p_cbt) = (quantile_rank(&mut fd, 0.9), quantile_rank(&mut cbt, 0.9));
    eprintln!(
        "FD median {m_fd:.2} p90 {p_fd:.2} ({} located, {refused} refused); FD+CBT median {m_cbt:.2} p90 {p_cbt:.2} ({}); heuristic median {m_h:.2}",
        fd.len(),
        cbt.len()
    );
    let near = |v: &[f64]| v.iter().filter(|&&e| e <= 5.0).count();
    eprintln!(
        "within 5 px: FD {} of {}, FD+CBT {} of {}",
        near(&fd),
        fd.len(),
        near(&cbt),
        cbt.len()
    );
    // Measured on this seed (with the multi-view voting and the forward model, no commands
    // told to the tracker here): FD and FD + CBT located 36 of 48 camera frames each, 6 and 6
    // within 5 px (medians 8.8 / 10.5 px; before the forward model, whose learning moves also
    // change what the simulator shows here: 34 and 36 located, 3 and 0 within 5 px, 10.0 / 9.0
    // px) while the heuristic teacher's median was 0.57 px: the
    // pipeline runs end to end but misses the accuracy goals (docs/methods.md § FD +
    // CBT as the servo percept says why). What is asserted is what holds: the teacher is accurate, every stored view lies within reach of its tip, and both
    // percepts return tips inside the image on many frames through the seam.
    assert!(m_h < 1.5, "heuristic median {m_h:.2} px");
    assert!(
        fd.len() >= 12 && cbt.len() >= 12,
        "{} {}",
        fd.len(),
        cbt.len()
    );
    assert!(
        cbt.len() >= fd.len(),
        "the tracker answers where the mode does"
    );
    let reach = pipeline.fd.shapes.config().reach_px;
    for cam in 0..2 {
        assert!(
            pipeline
                .fd
                .shapes
                .views(cam)
                .iter()
                .all(|v| v.offset[0].hypot(v.offset[1]) <= reach)
        );
    }
}

#[test]
fn commanded_moves_shift_the_tracks_by_the_learned_prediction() {
    let guard = shared();
    let (_, _, pipeline) = &*guard;
    let motion = pipeline
        .motion()
        .expect("learned with a forward model")
        .clone();
    // A simulator of its own (the shared one's state is the other tests').
    let robot = &mut own_arm(505);
    // The forward model against the simulator's true tip, on servo-sized moves it never made.
    let mut commands = RandomCommands::new(&EXPLORE, 404).unwrap();
    let (mut errors, mut moved) = (Vec::new(), Vec::new());
    let mut predicted = 0;
    for _ in 0..12 {
        let a = space().full_command(&commands.next_command()).unwrap();
        let b = space().full_command(&commands.next_command()).unwrap();
        robot.0.command(&a).unwrap();
        let ta = robot.0.inspect().finger_middle_pixels().unwrap();
        robot.0.command(&b).unwrap();
        let tb = robot.0.inspect().finger_middle_pixels().unwrap();
        if let Some(d) = motion.shift(&a, &b).unwrap() {
            predicted += 1;
            for c in 0..2 {
                let truth = [tb[c][0] - ta[c][0], tb[c][1] - ta[c][1]];
                errors.push(dist(d[c], truth));
                moved.push(truth[0].hypot(truth[1]));
            }
        }
    }
    let (m, shift) = (
        quantile_rank(&mut errors, 0.5),
        quantile_rank(&mut moved, 0.5),
    );
    eprintln!(
        "forward model: {predicted} of 12 moves predicted, shift error median {m:.2} px, \
         true shift median {shift:.2} px"
    );
    // Measured here (150 training moves, random moves across the workspace): error median
    // 19.7 px on shifts of median 101 px. The prediction removes most of the commanded motion
    // (a tracker without it sees the whole shift), no more.
    assert!(predicted >= 10, "{predicted}");
    assert!(
        m < 0.35 * shift,
        "shift error median {m:.2} px of {shift:.2} px"
    );

    // Through the notifier: a large move keeps the running tracks, shifted by the prediction;
    // without a forward model it forgets them.
    let fresh = pipeline.fresh();
    let plain = FdCbtRecogniser::new(pipeline.fd.clone(), pipeline.model().clone()).unwrap();
    for (recogniser, keeps) in [(&fresh, true), (&plain, false)] {
        let mut notifier = recogniser.notifier(30.0).unwrap();
        let mut started = false;
        let mut from = Vec::new();
        for _ in 0..20 {
            from = space().full_command(&commands.next_command()).unwrap();
            robot.0.command(&from).unwrap();
            notifier.commanded(&from).unwrap();
            let _ = recogniser.locate_all(&robot.0.capture());
            if recogniser.offsets().iter().any(Option::is_some) {
                started = true;
                break;
            }
        }
        assert!(started, "no track started in 20 poses");
        let before = recogniser.offsets();
        assert!(before.iter().flatten().all(|o| *o == [0.0; 2]));
        let mut to = from.clone();
        to[0] += 80.0;
        robot.0.command(&to).unwrap();
        notifier.commanded(&to).unwrap();
        let after = recogniser.offsets();
        if keeps {
            let d = motion.shift(&from, &to).unwrap().expect("inside the model");
            for c in 0..2 {
                assert_eq!(after[c], before[c].map(|_| d[c]), "camera {c}");
            }
        } else {
            assert!(after.iter().all(Option::is_none), "{after:?}");
        }
    }
    // A forward model of another camera count is refused.
    let one_camera = MotionModel::new(&[0, 1, 2], 1, &MotionConfig::default()).unwrap();
    assert!(matches!(
        pipeline.fresh().with_motion(one_camera),
        Err(PipelineError::InvalidParameter { name: "motion", .. })
    ));
}

/// The prior on the votes' position: learned on the default arm it applies on a camera,
/// the notifier sets its centre to the forward model's prediction at the command, and a fresh
/// track starts at the mode of the votes weighed by it (computed here by hand). Where it
/// applies, the votes are those of the search window around that prediction: each is a vote of
/// the whole image too, and no vote of the whole image that the prior weighs above its floor is
/// missing from them.
#[test]
fn the_prior_weighs_the_votes_around_the_last_commands_prediction() {
    let guard = shared();
    let (_, _, pipeline) = &*guard;
    let prior = pipeline.prior().expect("learned with a prior").clone();
    let motion = pipeline.motion().expect("a forward model").clone();
    // Learned here from 150 moves: σ 7.0 / 23.8 px, so camera 1's prior (47.6 px wide) is not
    // applied (its votes keep their weights; `weigh` below does the same).
    assert!((0..2).any(|c| prior.applies(c)), "{:?}", prior.sigmas());
    let sigma = pipeline.fd.config.mode_sigma_px;
    let robot = &mut own_arm(606);
    let mut commands = RandomCommands::new(&EXPLORE, 707).unwrap();
    let (mut checked, mut moved_mode, mut windowed, mut kept) = (0, 0, 0, 0);
    for _ in 0..16 {
        let y = space().full_command(&commands.next_command()).unwrap();
        robot.0.command(&y).unwrap();
        let images = robot.0.capture();
        let percept = pipeline.fresh();
        assert!(percept.predicted().is_none());
        let mut notifier = percept.notifier(30.0).unwrap();
        notifier.commanded(&y).unwrap();
        let Some(centre) = percept.predicted() else {
            continue;
        };
        assert_eq!(Some(centre.clone()), motion.predict(&y).unwrap());
        let Ok(got) = percept.locate_all(&images) else {
            continue;
        };
        checked += 1;
        for cam in 0..2 {
            let shapes = &pipeline.fd.shapes;
            let whole = shapes.votes(cam, &images[cam]).unwrap();
            let plain = mode(&whole, sigma).unwrap().expect("votes");
            let window = search_window(shapes, &prior, cam, centre[cam], pipeline.fd.size);
            assert_eq!(window.is_some(), prior.applies(cam), "camera {cam}");
            windowed += usize::from(window.is_some_and(|w| !w.is_whole()));
            let mut votes = shapes.votes_in(cam, &images[cam], window.as_ref()).unwrap();
            let same = |a: &Vote, b: &Vote| {
                dist(a.position, b.position) < 1e-9 && (a.weight - b.weight).abs() < 1e-9
            };
            assert!(
                votes.iter().all(|v| whole.iter().any(|w| same(v, w))),
                "camera {cam}: a vote of the window is not one of the whole image's"
            );
            for w in &whole {
                let above = prior.factor(cam, centre[cam], w.position).unwrap()
                    > visguide::pipeline::prior::FLOOR;
                assert!(
                    !above || votes.iter().any(|v| same(v, w)),
                    "camera {cam}: the window lost a vote above the prior's floor: {w:?}"
                );
                kept += usize::from(above);
            }
            prior.weigh(cam, centre[cam], &mut votes).unwrap();
            let weighed = mode(&votes, sigma).unwrap().expect("votes");
            assert_eq!(got[cam].position, weighed.position, "camera {cam}");
            assert_eq!(got[cam].certainty, weighed.certainty, "camera {cam}");
            moved_mode += usize::from(dist(plain.position, weighed.position) > 0.5);
        }
    }
    eprintln!(
        "prior: {checked} frames checked, mode moved by the prior on {moved_mode} camera frames, \
         {windowed} searched in a window, {kept} votes above the floor kept"
    );
    assert!(checked >= 4, "{checked} frames answered");
    assert!(
        windowed >= checked,
        "the window applied on {windowed} camera frames"
    );
    assert!(kept >= 1, "no vote above the prior's floor");
    assert!(moved_mode >= 1, "the prior never moved a mode");
    // A prior needs a forward model and the shape model's camera count.
    let plain = FdCbtRecogniser::new(pipeline.fd.clone(), pipeline.model().clone()).unwrap();
    assert!(matches!(
        plain.with_prior(prior.clone()),
        Err(PipelineError::InvalidParameter { name: "prior", .. })
    ));
    let one = PositionPrior::from_distances(&[vec![3.0]]).unwrap();
    assert!(matches!(
        pipeline.fresh().with_prior(one),
        Err(PipelineError::InvalidParameter { name: "prior", .. })
    ));
}

/// `MotionConfig::min_teacher_certainty`: the forward model learns only from teacher percepts
/// whose every camera is at least that certain. On the same moves (same seeds), the largest
/// threshold keeps fewer pairs than none; and with too few accepted walk frames the percept gets
/// no prior, which the report says. `ActionProtocol::min_teacher_certainty` does the same for
/// the shape model's tips and the tracker's training states.
#[test]
fn the_forward_model_can_learn_from_accepted_teacher_percepts_only() {
    let heuristic = {
        let guard = shared();
        guard.1.clone()
    };
    let learn = |(min_teacher_certainty, taught): (f64, f64)| {
        let mut robot = SimRobot::new(ArmSim::new(SimConfig::default()).unwrap());
        let mut protocol = ActionProtocol {
            views: 24,
            walks: 4,
            steps: 10,
            ..ActionProtocol::default()
        };
        protocol.motion.moves = 60;
        protocol.motion.min_teacher_certainty = min_teacher_certainty;
        protocol.min_teacher_certainty = taught;
        learn_by_action(&mut robot, &space(), &EXPLORE, &heuristic, &protocol).unwrap()
    };
    let runs: Vec<_> = [(0.0, 0.0), (0.5, 0.0), (1.0, 0.0), (0.0, 0.5)]
        .into_iter()
        .map(learn)
        .collect();
    let states: Vec<usize> = runs.iter().map(|(_, r)| r.track_frames).collect();
    let views: Vec<usize> = runs.iter().map(|(_, r)| r.shapes.views[0]).collect();
    eprintln!("training states {states:?}, camera 0 views {views:?}");
    // The forward model's threshold alone changes neither the tips nor the states.
    assert!(states[..3].iter().all(|&n| n == states[0]), "{states:?}");
    assert!(views[..3].iter().all(|&n| n == views[0]), "{views:?}");
    assert!(
        states[3] < states[0] && views[3] < views[0],
        "{states:?} {views:?}"
    );
    let runs = &runs[..3];
    let pairs: Vec<usize> = runs.iter().map(|(_, r)| r.motion_pairs).collect();
    let frames: Vec<&Vec<usize>> = runs.iter().map(|(_, r)| &r.prior_frames).collect();
    eprintln!("pairs {pairs:?}, prior frames {frames:?}");
    assert!(pairs[0] >= pairs[1] && pairs[1] >= pairs[2], "{pairs:?}");
    assert!(pairs[2] < pairs[0], "{pairs:?}");
    for (p, r) in runs {
        // A forward model that accepted no percept is no forward model.
        assert_eq!(
            p.motion().map(|m| m.n_data()),
            (r.motion_pairs > 0).then_some(r.motion_pairs as u64),
            "{r:?}"
        );
        let enough = r.prior_frames.len() == 2
            && r.prior_frames
                .iter()
                .all(|&n| n >= visguide::pipeline::MIN_PRIOR_FRAMES);
        assert_eq!(p.prior().is_some(), enough, "{r:?}");
    }
    assert!(runs[0].0.prior().is_some(), "{:?}", runs[0].1);
}

#[test]
fn the_pipeline_refuses_what_it_cannot_use() {
    let mut guard = shared();
    let (robot, heuristic, pipeline) = &mut *guard;
    // Images from a simulator of their own (the shared one's captures would change what the
    // other test sees, which then would depend on the order the tests run in).
    let images = ArmSim::new(SimConfig::default()).unwrap().capture();
    // One image too few, and the wrong size: typed errors before anything is tracked.
    assert!(matches!(
        pipeline.locate_all(&images[..1]),
        Err(ServoError::DimensionMismatch { .. })
    ));
    let small = vec![image::GrayImage::new(64, 48); 2];
    assert!(matches!(
        pipeline.locate_all(&small),
        Err(ServoError::InvalidParameter { name: "image", .. })
    ));
    // A blank frame has no gripper: refused, not guessed.
    let blank = vec![image::GrayImage::new(640, 480); 2];
    assert!(matches!(
        pipeline.fd.locate_all(&blank),
        Err(ServoError::RecognitionFailed { .. })
    ));
    // Learning without a gripper servo, or with an empty protocol, is refused.
    let mut no_gripper = space();
    no_gripper.gripper = None;
    assert!(matches!(
        learn_by_action(
            robot,
            &no_gripper,
            &EXPLORE,
            heuristic,
            &ActionProtocol::default()
        ),
        Err(PipelineError::InvalidParameter { name: "space", .. })
    ));
    let empty = ActionProtocol {
        views: 0,
        ..ActionProtocol::default()
    };
    assert!(matches!(
        learn_by_action(robot, &space(), &EXPLORE, heuristic, &empty),
        Err(PipelineError::InvalidParameter {
            name: "protocol",
            ..
        })
    ));
    // Refused before the robot moves (these used to move it: exploration ranges were zipped
    // with the controlled servos, a NaN step gave NaN commands, a NaN kernel width or a bad
    // shape setting was found only after the views were captured).
    let sent = robot.commands();
    let nan_step = ActionProtocol {
        step_us: f64::NAN,
        ..ActionProtocol::default()
    };
    let mut bad_percept = ActionProtocol::default();
    bad_percept.percept.mode_sigma_px = f64::NAN;
    let mut bad_shapes = ActionProtocol::default();
    bad_shapes.shapes.ratio_threshold = 2.0;
    let mut bad_motion = ActionProtocol::default();
    bad_motion.motion.w_gen = 2.0;
    let mut bad_motion_teacher = ActionProtocol::default();
    bad_motion_teacher.motion.min_teacher_certainty = -0.1;
    let bad_teacher = ActionProtocol {
        min_teacher_certainty: f64::NAN,
        ..ActionProtocol::default()
    };
    for (explore, protocol, name) in [
        (&EXPLORE[..2], &ActionProtocol::default(), None),
        (
            &[[0.0, 5000.0]; 3][..],
            &ActionProtocol::default(),
            Some("explore"),
        ),
        (&EXPLORE[..], &nan_step, Some("step_us")),
        (&EXPLORE[..], &bad_percept, Some("mode_sigma_px")),
        (&EXPLORE[..], &bad_shapes, Some("ratio_threshold")),
        (&EXPLORE[..], &bad_motion, Some("w_gen")),
        (
            &EXPLORE[..],
            &bad_motion_teacher,
            Some("min_teacher_certainty"),
        ),
        (&EXPLORE[..], &bad_teacher, Some("min_teacher_certainty")),
    ] {
        let e = learn_by_action(robot, &space(), explore, heuristic, protocol).unwrap_err();
        match name {
            None => assert!(
                matches!(
                    e,
                    PipelineError::Servo(ServoError::DimensionMismatch { .. })
                ),
                "{e}"
            ),
            Some("explore") => assert!(
                matches!(
                    e,
                    PipelineError::Servo(ServoError::InvalidParameter {
                        name: "explore",
                        ..
                    })
                ),
                "{e}"
            ),
            Some(want) => assert!(
                matches!(e, PipelineError::InvalidParameter { name, .. } if name == want),
                "{e}"
            ),
        }
    }
    assert_eq!(robot.commands(), sent);
    // A NaN reset threshold used to mean "never reset the tracks", a negative one "always".
    for bad in [f64::NAN, -1.0] {
        assert!(matches!(
            pipeline.notifier(bad),
            Err(PipelineError::InvalidParameter {
                name: "reset_us",
                ..
            })
        ));
    }
    assert!(pipeline.notifier(f64::INFINITY).is_ok());
}
