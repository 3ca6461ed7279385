//! Learning the pipeline by action on any [`servo_loop::Robot`] (Paper C's "action precedes
//! perception"; no ground truth): gripper moves at random poses give the shape model
//! ([`super::shapes`]), random moves the forward model of the commanded moves
//! ([`super::motion`]), and small random walks the tracker's training frames
//! ([`super::track`]), compensated by the forward model's predicted shifts. The heuristic
//! percept (servo-loop's learned silhouette recogniser, learned beforehand on the same robot)
//! supplies the tip on the training captures.

use servo_loop::{ControlSpace, Localisation, RandomCommands, Recogniser, Robot, TipModel};

use super::error::{PipelineError, Result, check_unit_interval};
use super::motion::{MotionConfig, MotionModel};
use super::prior::PositionPrior;
use super::shapes::{ActionPair, ShapeConfig, ShapeModel, ShapeReport};
use super::track::{
    FdCbtRecogniser, FdRecogniser, PerceptConfig, Walk, compensated, learn_tracker,
};
use super::vote::Vote;
use super::window::search_window;
use mser::BoundingBox;
use rand::SeedableRng;
use rand::rngs::Xoshiro256PlusPlus;
use rand_distr::{Distribution, StandardUniform};

/// The training protocol.
#[derive(Debug, Clone, PartialEq)]
pub struct ActionProtocol {
    /// Random poses seen with the gripper at rest and moved (two commands each). 80 by default:
    /// the shape model's coverage of poses is what limits the percept most (docs/methods.md,
    /// *Twice the training poses for the shape model*).
    pub views: usize,
    /// Random walks for the tracker.
    pub walks: usize,
    /// Steps per walk (one command each).
    pub steps: usize,
    /// Step size per controlled servo: uniform in `±step_us` (µs).
    pub step_us: f64,
    /// Seed of every random draw.
    pub seed: u64,
    /// The shape model takes a training capture's tip, and the tracker a walk frame's state,
    /// only from a teacher percept whose every camera is at least this certain (0: every
    /// percept). The forward model has its own threshold,
    /// [`MotionConfig::min_teacher_certainty`].
    pub min_teacher_certainty: f64,
    /// The forward model of the commanded moves (`moves` 0: none).
    pub motion: MotionConfig,
    /// Shape model settings.
    pub shapes: ShapeConfig,
    /// Percept settings.
    pub percept: PerceptConfig,
}

impl Default for ActionProtocol {
    fn default() -> Self {
        ActionProtocol {
            views: 80,
            walks: 6,
            steps: 15,
            step_us: 12.0,
            seed: 23,
            min_teacher_certainty: 0.0,
            motion: MotionConfig::default(),
            shapes: ShapeConfig::default(),
            percept: PerceptConfig::default(),
        }
    }
}

/// What learning did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LearnReport {
    /// Commands sent.
    pub actions: usize,
    /// The shape model's report.
    pub shapes: ShapeReport,
    /// Training frames for the tracker (both cameras) with a heuristic percept (at least
    /// [`ActionProtocol::min_teacher_certainty`] certain).
    pub track_frames: usize,
    /// Training pairs of the forward model (moves with a heuristic percept, at least
    /// [`MotionConfig::min_teacher_certainty`] certain).
    pub motion_pairs: usize,
    /// Per camera, the walk frames the prior's error scale was measured on (empty without a
    /// forward model or with the prior off). With fewer than [`MIN_PRIOR_FRAMES`] on a camera
    /// the percept has no prior ([`FdCbtRecogniser::prior`] is `None`).
    pub prior_frames: Vec<usize>,
    /// Walk votes left out because their regions lie outside the search window of their frame
    /// ([`PerceptConfig::search_window`]; 0 with it off or without a prior).
    pub window_left_out: usize,
}

/// Fewest walk frames per camera the prior's error scale is measured on (with fewer, the
/// percept has no prior).
pub const MIN_PRIOR_FRAMES: usize = 10;

/// Whether a teacher percept is at least `min` certain in every camera.
fn certain(percept: &[Localisation], min: f64) -> bool {
    percept.iter().all(|l| l.certainty >= min)
}

fn robot_err<E: std::fmt::Display>(during: &'static str) -> impl Fn(E) -> PipelineError {
    move |e| PipelineError::Robot {
        during,
        message: e.to_string(),
    }
}

/// Learns the FD + CBT percept on `robot` (module docs). The gripper servo of `space` is
/// moved to its first state for the "moved" captures; the servoing set-point is `space`'s rest.
///
/// Errors before the robot moves: a control space or exploration ranges that do not fit the
/// robot ([`ControlSpace::check_explore`]), no gripper servo, a protocol out of range (counts,
/// `step_us` not finite and non-negative, [`ShapeConfig::validate`],
/// [`PerceptConfig::validate`](super::track::PerceptConfig::validate)), a heuristic percept
/// without cameras or with cameras of different image sizes. Later: robot errors, a
/// capture with fewer images than the heuristic's cameras, captures of one camera of
/// different sizes or of another size than the heuristic's ([`ShapeModel::learn`],
/// [`FdCbtRecogniser::new`]), too little training data.
pub fn learn_by_action<R: Robot>(
    robot: &mut R,
    space: &ControlSpace,
    explore: &[[f64; 2]],
    heuristic: &TipModel,
    protocol: &ActionProtocol,
) -> Result<(FdCbtRecogniser, LearnReport)> {
    space.validate(robot)?;
    let Some((gripper, [open, _])) = space.gripper else {
        return Err(PipelineError::InvalidParameter {
            name: "space",
            reason: "learning by action needs a gripper servo".into(),
        });
    };
    space.check_explore(robot, explore)?;
    if protocol.views == 0 || protocol.walks == 0 || protocol.steps < 3 {
        return Err(PipelineError::InvalidParameter {
            name: "protocol",
            reason: "need views ≥ 1, walks ≥ 1 and steps ≥ 3".into(),
        });
    }
    check_unit_interval("min_teacher_certainty", protocol.min_teacher_certainty)?;
    if !(protocol.step_us.is_finite() && protocol.step_us >= 0.0) {
        return Err(PipelineError::InvalidParameter {
            name: "step_us",
            reason: format!("{} must be finite and non-negative", protocol.step_us),
        });
    }
    protocol.shapes.validate()?;
    protocol.percept.validate()?;
    protocol.motion.validate()?;
    let cams = heuristic.num_cameras();
    let size = Recogniser::image_size(heuristic, 0);
    // The percept takes one image size for every camera ([`FdRecogniser::size`]): a heuristic
    // whose cameras differ used to be learned from, giving a percept that refused every
    // capture of the other cameras.
    if cams == 0 {
        return Err(PipelineError::InvalidParameter {
            name: "heuristic",
            reason: "the heuristic percept has no camera".into(),
        });
    }
    if let Some(cam) = (1..cams).find(|&c| Recogniser::image_size(heuristic, c) != size) {
        let other = Recogniser::image_size(heuristic, cam);
        return Err(PipelineError::InvalidParameter {
            name: "heuristic",
            reason: format!(
                "camera {cam} sees {}×{} px, camera 0 {}×{}: the percept needs one image size",
                other[0], other[1], size[0], size[1]
            ),
        });
    }
    let mut report = LearnReport::default();
    let mut commands = RandomCommands::new(explore, protocol.seed)?;
    // Views: rest and moved captures per pose.
    let mut captures = Vec::new();
    for _ in 0..protocol.views {
        let rest_cmd = space.full_command(&commands.next_command())?;
        let mut moved_cmd = rest_cmd.clone();
        moved_cmd[gripper] = open;
        robot.command(&moved_cmd).map_err(robot_err("command"))?;
        let moved = robot.capture().map_err(robot_err("capture"))?;
        robot.command(&rest_cmd).map_err(robot_err("command"))?;
        let rest = robot.capture().map_err(robot_err("capture"))?;
        report.actions += 2;
        let tips = heuristic
            .locate_all(&rest)
            .ok()
            .filter(|t| certain(t, protocol.min_teacher_certainty));
        captures.push((rest, moved, tips));
    }
    let mut pairs = Vec::new();
    for (rest, moved, tips) in &captures {
        for cam in 0..cams.min(rest.len()).min(moved.len()) {
            pairs.push(ActionPair {
                camera: cam,
                rest: &rest[cam],
                moved: &moved[cam],
                tip: tips.as_ref().map(|t| t[cam].position),
            });
        }
    }
    let (shapes, shape_report) = ShapeModel::learn(&protocol.shapes, cams, &pairs)?;
    drop(pairs);
    drop(captures);
    report.shapes = shape_report;
    let capture = |robot: &mut R| -> Result<Vec<image::GrayImage>> {
        let images = robot.capture().map_err(robot_err("capture"))?;
        if images.len() < cams {
            return Err(PipelineError::Robot {
                during: "capture",
                message: format!(
                    "{} images, the heuristic percept has {cams} cameras",
                    images.len()
                ),
            });
        }
        Ok(images)
    };
    // The forward model: random moves (their own draws, so the walks do not depend on it).
    let motion = if protocol.motion.moves > 0 {
        let mut m = MotionModel::new(&space.controlled, cams, &protocol.motion)?;
        let mut draws = RandomCommands::new(explore, protocol.seed ^ 0x3071)?;
        for _ in 0..protocol.motion.moves {
            let full = space.full_command(&draws.next_command())?;
            robot.command(&full).map_err(robot_err("command"))?;
            report.actions += 1;
            let images = capture(robot)?;
            let accepted = heuristic
                .locate_all(&images)
                .ok()
                .filter(|t| certain(t, protocol.motion.min_teacher_certainty));
            if let Some(t) = accepted {
                let tips: Vec<[f64; 2]> = t.iter().take(cams).map(|l| l.position).collect();
                m.update(&full, &tips)?;
                report.motion_pairs += 1;
            }
        }
        // A model that learned nothing predicts nothing: every walk step would start a new
        // training sequence. The tracker then runs without one (`motion_pairs` says 0).
        (m.n_data() > 0).then_some(m)
    } else {
        None
    };
    // Walks: small random moves from random poses; per frame the percept and the votes, in
    // coordinates compensated by the predicted shifts since the walk's start (a move the
    // forward model cannot predict starts a new training sequence). The frames are kept in
    // image coordinates first, with the forward model's prediction, so that the prior on the
    // votes' position can be measured on all of them before it weighs them.
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(protocol.seed ^ 0x7A1C);
    let mut raw: Vec<Vec<RawFrame>> = Vec::new();
    for _ in 0..protocol.walks {
        let mut y = commands.next_command();
        let mut per_cam: Vec<Vec<RawFrame>> = vec![Vec::new(); cams];
        let mut offsets = vec![[0.0; 2]; cams];
        // The forward model's prediction at the walk's previous step (`None` before it).
        let mut last: Option<Option<Vec<[f64; 2]>>> = None;
        for _ in 0..protocol.steps {
            for (j, v) in y.iter_mut().enumerate() {
                let [lo, hi] = explore[j];
                let u: f64 = StandardUniform.sample(&mut rng);
                *v = (*v + (2.0 * u - 1.0) * protocol.step_us).clamp(lo, hi);
            }
            let full = space.full_command(&y)?;
            robot.command(&full).map_err(robot_err("command"))?;
            report.actions += 1;
            let predicted = match &motion {
                Some(m) => m.predict(&full)?,
                None => None,
            };
            // The move's predicted shift, `MotionModel::shift` from the kept prediction.
            if let (Some(_), Some(previous)) = (&motion, &last) {
                match (previous, &predicted) {
                    (Some(a), Some(b)) => offsets
                        .iter_mut()
                        .zip(MotionModel::difference(a, b)?)
                        .for_each(|(o, d)| {
                            o[0] += d[0];
                            o[1] += d[1];
                        }),
                    _ => {
                        raw.extend(per_cam.iter_mut().map(std::mem::take));
                        offsets.iter_mut().for_each(|o| *o = [0.0; 2]);
                    }
                }
            }
            last = Some(predicted.clone());
            let images = capture(robot)?;
            let tips = heuristic.locate_all(&images).ok();
            let accepted = tips
                .as_ref()
                .is_some_and(|t| certain(t, protocol.motion.min_teacher_certainty));
            let taught = tips
                .as_ref()
                .is_some_and(|t| certain(t, protocol.min_teacher_certainty));
            for (cam, walk) in per_cam.iter_mut().enumerate() {
                let teacher = tips.as_ref().map(|t| t[cam].position);
                let truth = teacher.filter(|_| taught);
                report.track_frames += usize::from(truth.is_some());
                let (votes, boxes) = shapes.votes_with_boxes(cam, &images[cam], None)?;
                walk.push(RawFrame {
                    camera: cam,
                    truth,
                    teacher: teacher.filter(|_| accepted),
                    votes,
                    boxes,
                    offset: offsets[cam],
                    predicted: predicted.as_ref().map(|p| p[cam]),
                });
            }
        }
        raw.extend(per_cam);
    }
    raw.retain(|w| !w.is_empty());
    // The forward model's error on the walks' frames (it learned from the random moves only).
    let prior = match &motion {
        Some(_) if protocol.percept.position_prior => {
            let mut distances = vec![Vec::new(); cams];
            for f in raw.iter().flatten() {
                if let (Some(t), Some(p)) = (f.teacher, f.predicted) {
                    distances[f.camera].push((t[0] - p[0]).hypot(t[1] - p[1]));
                }
            }
            report.prior_frames = distances.iter().map(Vec::len).collect();
            if distances.iter().all(|d| d.len() >= MIN_PRIOR_FRAMES) {
                Some(PositionPrior::from_distances(&distances)?)
            } else {
                None
            }
        }
        _ => None,
    };
    let walks: Vec<Walk> = raw
        .into_iter()
        .map(|walk| {
            walk.into_iter()
                .map(|mut f| {
                    if let (Some(prior), Some(p)) = (&prior, f.predicted) {
                        // The votes of the regions the search window would have found.
                        if protocol.percept.search_window
                            && let Some(w) = search_window(&shapes, prior, f.camera, p, size)
                        {
                            let mut b = f.boxes.iter();
                            let before = f.votes.len();
                            f.votes
                                .retain(|_| w.keeps(b.next().expect("one box per vote")));
                            report.window_left_out += before - f.votes.len();
                        }
                        prior.weigh(f.camera, p, &mut f.votes)?;
                    }
                    let shifted = |p: [f64; 2]| compensated(p, f.offset, size);
                    let votes = f
                        .votes
                        .into_iter()
                        .filter_map(|mut v| {
                            v.position = shifted(v.position)?;
                            Some(v)
                        })
                        .collect();
                    Ok((f.truth.and_then(shifted), votes))
                })
                .collect::<Result<Walk>>()
        })
        .collect::<Result<_>>()?;
    let model = learn_tracker(size, &walks)?;
    let fd = FdRecogniser {
        shapes,
        size,
        config: protocol.percept,
    };
    let recogniser = FdCbtRecogniser::new(fd, model)?;
    let recogniser = match motion {
        Some(m) => recogniser.with_motion(m)?,
        None => recogniser,
    };
    Ok((
        match prior {
            Some(p) => recogniser.with_prior(p)?,
            None => recogniser,
        },
        report,
    ))
}

/// One training frame of one camera before compensation: the teacher's tip (as the tracker's
/// state and as the forward model's reference), the votes and the forward model's prediction in
/// image coordinates, and the walk's summed predicted shifts.
#[derive(Debug, Clone)]
struct RawFrame {
    camera: usize,
    /// The tracker's training state: the teacher's tip, if certain enough
    /// ([`ActionProtocol::min_teacher_certainty`]).
    truth: Option<[f64; 2]>,
    /// The teacher's tip the prior's error scale is measured against, if certain enough for
    /// the forward model ([`MotionConfig::min_teacher_certainty`]).
    teacher: Option<[f64; 2]>,
    votes: Vec<Vote>,
    /// Per vote, its region's bounding box (for the search window, [`super::window`]).
    boxes: Vec<BoundingBox>,
    offset: [f64; 2],
    predicted: Option<[f64; 2]>,
}
