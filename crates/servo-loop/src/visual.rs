//! A [`Robot`] with a learned [`GripperModel`] as a [`Plant`]: the percept is the gripper point
//! in every camera, the command the set-points of the controlled servos.

use image::GrayImage;
use serde::{Deserialize, Serialize};

use crate::error::{Result, ServoError};
use crate::learn::RandomCommands;
use crate::motion::MotionCheck;
use crate::plant::{Observation, Plant, check_command};
use crate::recognition::TrainingView;
use crate::recognition::{
    Localisation, PerceptUse, Recogniser, SilhouetteConfig, SilhouetteReport, TipModel, TipRule,
};
use crate::robot::Robot;
use crate::temporal::Verdict;

/// Which servos are controlled, and how the others are held.
///
/// **Redundancy.** An arm such as the Lynx-6 has more joints (base, shoulder, elbow, wrist
/// pitch, wrist roll) than a gripper point has degrees of freedom (3), so the inverse map
/// percept → command is one-to-many and cannot be learned as a function. We resolve it the
/// simplest way Paper C's setting allows, without any kinematic model: only `controlled`
/// servos are commanded by the learner (e.g. base, shoulder, elbow), and every other servo is
/// held at its set-point in `rest` throughout (e.g. the wrist pitch at a fixed posture). The
/// gripper servo is only moved to learn recognition ([`ControlSpace::gripper`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControlSpace {
    /// Indices of the controlled servos, in command order.
    pub controlled: Vec<usize>,
    /// A full command: the held set-points of the uncontrolled servos (values at controlled
    /// indices are ignored).
    pub rest: Vec<f64>,
    /// The gripper servo and its two set-points `[open, closed]` used to learn recognition.
    pub gripper: Option<(usize, [f64; 2])>,
}

impl ControlSpace {
    /// Checks indices and set-points against the robot.
    pub fn validate<R: Robot>(&self, robot: &R) -> Result<()> {
        let n = robot.num_servos();
        if self.rest.len() != n {
            return Err(ServoError::DimensionMismatch {
                what: "rest command",
                expected: n,
                got: self.rest.len(),
            });
        }
        if self.controlled.is_empty() {
            return Err(ServoError::InvalidParameter {
                name: "controlled",
                reason: "at least one servo must be controlled".into(),
            });
        }
        for (k, &i) in self.controlled.iter().enumerate() {
            if i >= n || self.controlled[..k].contains(&i) {
                return Err(ServoError::InvalidParameter {
                    name: "controlled",
                    reason: format!("servo index {i} is out of range or repeated"),
                });
            }
        }
        for (i, &v) in self.rest.iter().enumerate() {
            let [lo, hi] = robot.servo_range(i);
            let held = !self.controlled.contains(&i);
            if held && !(v.is_finite() && v >= lo && v <= hi) {
                return Err(ServoError::OutOfServoRange {
                    joint: i,
                    value: v,
                    min: lo,
                    max: hi,
                });
            }
        }
        if let Some((g, states)) = self.gripper {
            if g >= n || self.controlled.contains(&g) {
                return Err(ServoError::InvalidParameter {
                    name: "gripper",
                    reason: format!("servo {g} is out of range or controlled"),
                });
            }
            let [lo, hi] = robot.servo_range(g);
            for v in states {
                if !(v.is_finite() && v >= lo && v <= hi) {
                    return Err(ServoError::OutOfServoRange {
                        joint: g,
                        value: v,
                        min: lo,
                        max: hi,
                    });
                }
            }
        }
        Ok(())
    }

    /// Checks exploration ranges for the controlled servos against the robot: one `[lo, hi]`
    /// per controlled servo, in order, finite, `lo ≤ hi`, inside that servo's range.
    /// [`ServoError::DimensionMismatch`] (`explore ranges`) or
    /// [`ServoError::InvalidParameter`] (`explore`) otherwise.
    pub fn check_explore<R: Robot>(&self, robot: &R, explore: &[[f64; 2]]) -> Result<()> {
        if explore.len() != self.controlled.len() {
            return Err(ServoError::DimensionMismatch {
                what: "explore ranges",
                expected: self.controlled.len(),
                got: explore.len(),
            });
        }
        for (j, (&i, &[lo, hi])) in self.controlled.iter().zip(explore).enumerate() {
            let [min, max] = robot.servo_range(i);
            if !(lo.is_finite() && hi.is_finite() && min <= lo && lo <= hi && hi <= max) {
                return Err(ServoError::InvalidParameter {
                    name: "explore",
                    reason: format!(
                        "range {j} = [{lo}, {hi}] is not a finite interval within servo {i}'s \
                         range [{min}, {max}]"
                    ),
                });
            }
        }
        Ok(())
    }

    /// The full command for controlled set-points `y`: `rest` with `y[k]` at servo
    /// `controlled[k]`. [`ServoError::DimensionMismatch`] (`controlled set-points`) when `y` has
    /// not one value per controlled servo (a missing value would leave a servo at rest, an extra
    /// one would be dropped); [`ServoError::InvalidParameter`] (`controlled`) when a controlled
    /// index is outside `rest` (a space that [`ControlSpace::validate`] would refuse).
    pub fn full_command(&self, y: &[f64]) -> Result<Vec<f64>> {
        if y.len() != self.controlled.len() {
            return Err(ServoError::DimensionMismatch {
                what: "controlled set-points",
                expected: self.controlled.len(),
                got: y.len(),
            });
        }
        let mut c = self.rest.clone();
        for (&i, &v) in self.controlled.iter().zip(y) {
            let slot = c.get_mut(i).ok_or_else(|| ServoError::InvalidParameter {
                name: "controlled",
                reason: format!(
                    "servo index {i} is outside the rest command ({} servos)",
                    self.rest.len()
                ),
            })?;
            *slot = v;
        }
        Ok(c)
    }
}

/// Action precedes perception: at `views` random poses (controlled servos uniform in
/// `explore`, seeded), capture with the gripper open, close it, capture again. The views teach
/// [`TipModel::learn`] and the channel-coded appearance model
/// ([`GripperModel::learn`](crate::GripperModel::learn)). Leaves the gripper at its `rest`
/// set-point. Errors, before the robot moves: a control space that does not fit the robot or
/// has no gripper servo, exploration ranges that do not ([`ControlSpace::check_explore`]); then
/// robot errors.
pub fn capture_training_views<R: Robot>(
    robot: &mut R,
    space: &ControlSpace,
    explore: &[[f64; 2]],
    views: usize,
    seed: u64,
) -> Result<Vec<TrainingView>> {
    space.validate(robot)?;
    let (g, [open, closed]) = space.gripper.ok_or(ServoError::InvalidParameter {
        name: "gripper",
        reason: "learning recognition needs the gripper servo and its two states".into(),
    })?;
    space.check_explore(robot, explore)?;
    let mut commands = RandomCommands::new(explore, seed)?;
    let mut training = Vec::new();
    for _ in 0..views {
        let mut c = space.full_command(&commands.next_command())?;
        c[g] = open;
        send(robot, &c)?;
        let before = grab(robot)?;
        c[g] = closed;
        send(robot, &c)?;
        let after = grab(robot)?;
        c[g] = space.rest[g];
        send(robot, &c)?;
        training.push(TrainingView { before, after });
    }
    Ok(training)
}

/// Learns the gripper recogniser by action (Paper C): the training views of
/// [`capture_training_views`] give the static scene, and the gripper change locates the end of
/// the chain ([`TipModel::learn`]). Then, unless `config.correction_poses` is 0, one capture at
/// each of that many further random poses teaches the `Learned` tip rule's correction
/// ([`TipModel::learn_correction`]), and with two or more cameras the same poses' tips teach
/// the cross-camera consistency ([`TipModel::learn_consistency`]; skipped when the poses are
/// too few or degenerate). Leaves the gripper at its `rest` set-point. Errors, before the robot
/// moves: invalid `config` settings (those [`TipModel::learn`] refuses), and those of
/// [`capture_training_views`]; then robot and learning errors.
pub fn learn_recognition<R: Robot>(
    robot: &mut R,
    space: &ControlSpace,
    explore: &[[f64; 2]],
    views: usize,
    seed: u64,
    config: &SilhouetteConfig,
) -> Result<(TipModel, SilhouetteReport)> {
    // Every setting is checked before the first move: a refused session moves nothing.
    config.validate()?;
    let training = capture_training_views(robot, space, explore, views, seed)?;
    let (mut model, mut report) = TipModel::learn(config, &training)?;
    drop(training);
    if config.correction_poses > 0 {
        // The learned tip's correction: both single-image rules at further random poses, the
        // gripper at rest (a pose where a camera does not recognise the arm is skipped).
        let mut poses = RandomCommands::new(explore, seed ^ 0xC0FF_EE00)?;
        let mut samples = Vec::new();
        for _ in 0..config.correction_poses {
            send(robot, &space.full_command(&poses.next_command())?)?;
            match model.correction_sample(&grab(robot)?) {
                Ok(sample) => samples.push(sample),
                Err(ServoError::RecognitionFailed { .. }) => {}
                Err(e) => return Err(e),
            }
        }
        match model.learn_correction(&samples) {
            Ok(mut correction) => {
                correction.poses = config.correction_poses;
                report.correction = Some(correction);
            }
            // Only the learned rule needs it; the single-image rules work without.
            Err(ServoError::NotEnoughData(_)) if config.tip != TipRule::Learned => {}
            Err(e) => return Err(e),
        }
        if model.num_cameras() >= 2 {
            match model.learn_consistency(&samples, seed ^ 0xE919) {
                Ok(reports) => report.consistency = reports,
                Err(ServoError::NotEnoughData(_)) => {}
                Err(e) => return Err(e),
            }
        }
    }
    Ok((model, report))
}

fn send<R: Robot>(robot: &mut R, c: &[f64]) -> Result<()> {
    robot.command(c).map_err(|e| ServoError::Robot {
        during: "command",
        message: e.to_string(),
    })
}

fn grab<R: Robot>(robot: &mut R) -> Result<Vec<GrayImage>> {
    robot.capture().map_err(|e| ServoError::Robot {
        during: "capture",
        message: e.to_string(),
    })
}

/// When a visual plant accepts a percept.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PerceptPolicy {
    /// Captures averaged per percept (the robot stands still between them; sensor noise
    /// averages out). At least 1.
    pub captures: usize,
    /// A percept whose lowest camera certainty is below this is re-captured, and refused
    /// ([`ServoError::PerceptRefused`]) when it stays below.
    pub min_certainty: f64,
    /// Further attempts (each `captures` captures) before a doubted percept is refused.
    pub recaptures: usize,
    /// What the percepts are for ([`Recogniser::locate_all_for`]): set
    /// [`PerceptUse::Training`] while learning to control, so a recogniser that doubts
    /// training percepts differently (the learned tip's [`SilhouetteConfig::cap_training`])
    /// can. Default (and files without the field): [`PerceptUse::Servo`].
    #[serde(default)]
    pub used: PerceptUse,
}

impl Default for PerceptPolicy {
    fn default() -> Self {
        PerceptPolicy {
            captures: 1,
            min_certainty: 0.05,
            recaptures: 1,
            used: PerceptUse::Servo,
        }
    }
}

/// `captures ≥ 1`: an observation needs at least one capture (the one home of this check).
fn check_captures(captures: usize) -> Result<()> {
    if captures == 0 {
        return Err(ServoError::invalid(
            "captures",
            "at least one capture per observation",
        ));
    }
    Ok(())
}

impl PerceptPolicy {
    /// Checks `captures ≥ 1` and `min_certainty ∈ [0, 1]`.
    pub fn validate(&self) -> Result<()> {
        check_captures(self.captures)?;
        if !(0.0..=1.0).contains(&self.min_certainty) {
            return Err(ServoError::invalid("min_certainty", "must lie in [0, 1]"));
        }
        Ok(())
    }
}

/// A robot seen through a gripper recogniser (by default the learned [`TipModel`]; any
/// [`Recogniser`] plugs in).
pub struct VisualPlant<R: Robot, Q: Recogniser = TipModel> {
    robot: R,
    space: ControlSpace,
    model: Q,
    policy: PerceptPolicy,
    refused: usize,
    recaptured: usize,
    motion: Option<MotionCheck>,
    inconsistent: usize,
    last_command: Option<Vec<f64>>,
    last_images: Vec<GrayImage>,
    last_localisations: Vec<Localisation>,
}

impl<R: Robot, Q: Recogniser> VisualPlant<R, Q> {
    /// Connects a robot, its control space and a gripper recogniser, with the default
    /// [`PerceptPolicy`]. Errors: a control space that does not fit the robot; a recogniser
    /// that cannot locate ([`Recogniser::check_ready`]: e.g. the learned rule without its
    /// correction).
    pub fn new(robot: R, space: ControlSpace, model: Q) -> Result<Self> {
        space.validate(&robot)?;
        model.check_ready()?;
        Ok(VisualPlant {
            robot,
            space,
            model,
            policy: PerceptPolicy::default(),
            refused: 0,
            recaptured: 0,
            motion: None,
            inconsistent: 0,
            last_command: None,
            last_images: Vec::new(),
            last_localisations: Vec::new(),
        })
    }

    /// Captures per observation (default 1): the robot stands still between them, so the
    /// percept is the mean of `n` localisations (sensor noise averages out). Errors: `n = 0`.
    pub fn set_captures(&mut self, n: usize) -> Result<()> {
        self.set_policy(PerceptPolicy {
            captures: n,
            ..self.policy
        })
    }

    /// Sets when a percept is accepted. Errors: an invalid policy (nothing changes).
    pub fn set_policy(&mut self, policy: PerceptPolicy) -> Result<()> {
        policy.validate()?;
        self.policy = policy;
        Ok(())
    }

    /// The percept policy.
    pub fn policy(&self) -> &PerceptPolicy {
        &self.policy
    }

    /// Percepts refused so far ([`ServoError::PerceptRefused`]).
    pub fn refused(&self) -> usize {
        self.refused
    }

    /// Doubted percepts re-captured so far (accepted or not in the end), by either check.
    pub fn recaptured(&self) -> usize {
        self.recaptured
    }

    /// Checks the servo's percepts ([`PerceptUse::Servo`]) against the commanded move
    /// ([`MotionCheck`]): an inconsistent percept is re-captured up to the policy's
    /// `recaptures` times, then refused with [`ServoError::PerceptInconsistent`]; an accepted
    /// one is remembered by the check. Training percepts are neither judged nor remembered.
    /// `None` removes the check. Errors: a check of another percept or command dimension.
    pub fn set_motion_check(&mut self, check: Option<MotionCheck>) -> Result<()> {
        if let Some(c) = &check {
            let (p, m) = (self.percept_dim(), self.command_dim());
            if c.percept_dim() != p || c.command_dim() != m {
                return Err(ServoError::DimensionMismatch {
                    what: "motion check (percept + command)",
                    expected: p + m,
                    got: c.percept_dim() + c.command_dim(),
                });
            }
        }
        self.motion = check;
        Ok(())
    }

    /// The motion check, with every percept it remembered.
    pub fn motion_check(&self) -> Option<&MotionCheck> {
        self.motion.as_ref()
    }

    /// Percepts refused by the motion check ([`ServoError::PerceptInconsistent`]).
    pub fn inconsistent(&self) -> usize {
        self.inconsistent
    }

    /// The robot.
    pub fn robot(&self) -> &R {
        &self.robot
    }

    /// The robot, mutably.
    pub fn robot_mut(&mut self) -> &mut R {
        &mut self.robot
    }

    /// The gripper recogniser.
    pub fn model(&self) -> &Q {
        &self.model
    }

    /// The control space.
    pub fn space(&self) -> &ControlSpace {
        &self.space
    }

    /// Images of the last capture.
    pub fn last_images(&self) -> &[GrayImage] {
        &self.last_images
    }

    /// Localisations of the last successful observation (averaged over its captures).
    pub fn last_localisations(&self) -> &[Localisation] {
        &self.last_localisations
    }

    /// Gives the robot back.
    pub fn into_robot(self) -> R {
        self.robot
    }

    /// One percept that passes the policy's certainty ([`observe_checked`]), refusals counted.
    fn observe_certain(&mut self) -> Result<(Vec<Localisation>, Vec<GrayImage>)> {
        let robot = &mut self.robot;
        let model = &self.model;
        let recaptured = &mut self.recaptured;
        let result = observe_checked(
            model,
            &self.policy,
            || grab(robot),
            |images| model.locate_all_for(images, self.policy.used),
            || *recaptured += 1,
        );
        if matches!(result, Err(ServoError::PerceptRefused { .. })) {
            self.refused += 1;
        }
        result
    }
}

/// Locates the tip in every camera image of `captures` captures and averages (certainty: the
/// smallest). Shared by [`VisualPlant`] and evaluation harnesses. `captures` 0 is an
/// [`ServoError::InvalidParameter`] `captures`, before anything is grabbed.
pub fn observe_averaged<Q, F>(
    model: &Q,
    captures: usize,
    grab_images: F,
) -> Result<(Vec<Localisation>, Vec<GrayImage>)>
where
    Q: Recogniser + ?Sized,
    F: FnMut() -> Result<Vec<GrayImage>>,
{
    observe_averaged_by(model, captures, grab_images, |images| {
        model.locate_all(images)
    })
}

/// As [`observe_averaged`], with each capture's images located by `locate` (one localisation
/// per camera of `model`), e.g. the cameras in parallel through [`TipModel::estimate_end`] and
/// [`TipModel::tips`]. Errors: `captures` 0 (before anything is grabbed), a capture or a
/// `locate` result with another camera count, and any error of `grab_images` or `locate`.
pub fn observe_averaged_by<Q, F, L>(
    model: &Q,
    captures: usize,
    mut grab_images: F,
    mut locate: L,
) -> Result<(Vec<Localisation>, Vec<GrayImage>)>
where
    Q: Recogniser + ?Sized,
    F: FnMut() -> Result<Vec<GrayImage>>,
    L: FnMut(&[GrayImage]) -> Result<Vec<Localisation>>,
{
    check_captures(captures)?;
    let cams = model.num_cameras();
    let mut sum = vec![[0.0f64; 2]; cams];
    let mut cert = vec![1.0f64; cams];
    let mut last = Vec::new();
    for _ in 0..captures {
        let images = grab_images()?;
        if images.len() != cams {
            return Err(ServoError::DimensionMismatch {
                what: "camera images",
                expected: cams,
                got: images.len(),
            });
        }
        let locs = locate(&images)?;
        if locs.len() != cams {
            return Err(ServoError::DimensionMismatch {
                what: "camera localisations",
                expected: cams,
                got: locs.len(),
            });
        }
        for (cam, l) in locs.into_iter().enumerate() {
            sum[cam][0] += l.position[0];
            sum[cam][1] += l.position[1];
            cert[cam] = cert[cam].min(l.certainty);
        }
        last = images;
    }
    let n = captures as f64;
    let locs = sum
        .iter()
        .zip(&cert)
        .map(|(s, &c)| Localisation {
            position: [s[0] / n, s[1] / n],
            certainty: c,
        })
        .collect();
    Ok((locs, last))
}

/// One percept under `policy`: [`observe_averaged_by`] with `policy.captures` captures, re-captured
/// up to `policy.recaptures` times while the lowest certainty is below `policy.min_certainty`,
/// then refused ([`ServoError::PerceptRefused`], naming the least certain camera). Shared by
/// [`VisualPlant`] and evaluation harnesses. `on_recapture` is called before each re-capture.
pub fn observe_checked<Q, F, L>(
    model: &Q,
    policy: &PerceptPolicy,
    mut grab_images: F,
    mut locate: L,
    mut on_recapture: impl FnMut(),
) -> Result<(Vec<Localisation>, Vec<GrayImage>)>
where
    Q: Recogniser + ?Sized,
    F: FnMut() -> Result<Vec<GrayImage>>,
    L: FnMut(&[GrayImage]) -> Result<Vec<Localisation>>,
{
    policy.validate()?;
    // Attempts `0..=recaptures` (counting `recaptures + 1` of them overflowed for
    // `usize::MAX`, and in release builds then made none).
    for attempt in 0..=policy.recaptures {
        let (locs, images) =
            observe_averaged_by(model, policy.captures, &mut grab_images, &mut locate)?;
        let (camera, certainty) = locs
            .iter()
            .enumerate()
            .map(|(c, l)| (c, l.certainty))
            .fold((0, 1.0), |a, b| if b.1 < a.1 { b } else { a });
        if certainty >= policy.min_certainty {
            return Ok((locs, images));
        }
        if attempt == policy.recaptures {
            return Err(ServoError::PerceptRefused {
                camera,
                certainty,
                min: policy.min_certainty,
                // The captures made (saturating: no count of them can overflow in practice).
                captures: attempt.saturating_add(1).saturating_mul(policy.captures),
            });
        }
        on_recapture();
    }
    unreachable!("the range 0..=recaptures is not empty and its last attempt returns")
}

impl<R: Robot, Q: Recogniser> Plant for VisualPlant<R, Q> {
    fn percept_dim(&self) -> usize {
        2 * self.model.num_cameras()
    }

    fn command_dim(&self) -> usize {
        self.space.controlled.len()
    }

    fn command_range(&self, j: usize) -> [f64; 2] {
        // `j < command_dim()` by the trait's contract (panics beyond it, like indexing).
        self.robot.servo_range(self.space.controlled[j])
    }

    /// Checks `y` ([`check_command`]: one finite value per controlled servo, inside its
    /// range) and sends the full command. A refused `y` sends nothing and changes no state; on
    /// a robot error (a move may have been made) the plant forgets its last command, so the
    /// next percept is not judged by the motion check.
    fn act(&mut self, y: &[f64]) -> Result<()> {
        check_command(&*self, y)?;
        let command = self.space.full_command(y)?;
        self.last_command = None;
        send(&mut self.robot, &command)?;
        self.last_command = Some(y.to_vec());
        Ok(())
    }

    fn observe(&mut self) -> Result<Observation> {
        let judged = self.policy.used == PerceptUse::Servo && self.motion.is_some();
        let command = self.last_command.clone();
        // Attempts `0..=recaptures` (as in `observe_checked`: `recaptures + 1` overflowed).
        let recaptures = if judged { self.policy.recaptures } else { 0 };
        for attempt in 0..=recaptures {
            let (locs, images) = self.observe_certain()?;
            let x: Vec<f64> = locs.iter().flat_map(|l| l.position).collect();
            if let (true, Some(y), Some(check)) = (judged, &command, &mut self.motion) {
                if let Verdict::Inconsistent {
                    residual,
                    threshold,
                } = check.judge(&x, y)?
                {
                    if attempt == recaptures {
                        self.inconsistent += 1;
                        return Err(ServoError::PerceptInconsistent {
                            residual,
                            threshold,
                        });
                    }
                    self.recaptured += 1;
                    continue;
                }
                check.remember(&x, y)?;
            }
            let certainty = locs.iter().map(|l| l.certainty).fold(1.0, f64::min);
            self.last_images = images;
            self.last_localisations = locs;
            return Ok(Observation { x, certainty });
        }
        unreachable!("the range 0..=recaptures is not empty and its last attempt returns")
    }

    fn percept_bounds(&self) -> Option<Vec<[f64; 2]>> {
        Some(
            (0..self.model.num_cameras())
                .flat_map(|cam| {
                    let [w, h] = self.model.image_size(cam);
                    [[0.0, f64::from(w) - 1.0], [0.0, f64::from(h) - 1.0]]
                })
                .collect(),
        )
    }
}
