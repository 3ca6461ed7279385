//! Channel based tracking of the tip (Paper B, crate `cbt-tracker`) on the shape model's
//! votes, and the two percepts the servo loop can take through its seam
//! ([`servo_loop::Recogniser`]): [`FdRecogniser`] (the votes' mode, frame by frame) and
//! [`FdCbtRecogniser`] (the votes tracked by CBT).
//!
//! The tracker's models are learned as Paper B learns them, from unordered sets: per frame of
//! the training walks (small random moves, as the servo makes them) the heuristic percept is
//! the state and the frame's votes (true and clutter alike) are the detections, with no
//! association between them. The layout is CBT's stationary one on the image (shift-invariant
//! models, the grid spacing [`cbt_tracker::Scales::fine_spacing`] of the training votes'
//! noise), second order. One model serves both cameras; each camera has its own tracker.
//!
//! A track starts at the first frame whose vote mode has certainty ≥ `start_certainty`; it is
//! started again there when the tracker's own certainty falls below `lost_certainty`.
//! [`FdCbtRecogniser::reset`] forgets every track (call it before a new, unrelated run).
//!
//! The parts must fit one another: the shape model's cameras and their image size, the
//! tracker's canvas, the forward model's and the prior's cameras. [`FdCbtRecogniser::new`],
//! [`FdCbtRecogniser::with_motion`] and [`FdCbtRecogniser::with_prior`] refuse parts that do
//! not; as the percept's fields are public, every capture checks them again (and the captured
//! images against them) before any track moves.
//!
//! **Errors of a capture** (`locate_all` of either percept), in the order checked, the first
//! one found: settings out of range ([`PerceptConfig::validate`]), then parts that do not fit
//! one another, each check in one place (the shape model's image size against the percept's
//! `size` for both percepts; for FD + CBT also the tracker model's canvas, and the tracks', the
//! forward model's and the prior's cameras against the shape model's), both as
//! [`ServoError::InvalidParameter`] `percept` whose reason names the setting or the part
//! (`shapes`, `model`, `tracks`, `motion`, `prior`); only then the images against the
//! percept: another count than the shape model's cameras ([`ServoError::DimensionMismatch`]
//! `images`), an image of another size than `size` ([`ServoError::InvalidParameter`]
//! `image`). A broken part is thus reported as such whatever the images are.
//!
//! The commanded move is a known input ([`super::motion`]): with a forward model
//! ([`FdCbtRecogniser::with_motion`]) each commanded move, told by [`Notifying`], adds its
//! predicted shift to the track's offset `c`, and the tracker runs on the votes at `z − c`
//! (learned on walks compensated the same way), so a servo move of any size keeps the track.
//! Without one, or where the forward model has no prediction, a move larger than `reset_us`
//! restarts the tracks from the votes. With a prior on the votes' position
//! ([`FdCbtRecogniser::with_prior`], [`super::prior`]), the notifier also keeps the forward
//! model's prediction at the last command, and every frame's votes are weighed by it before the
//! tracker (or a track start) sees them; with [`PerceptConfig::search_window`] (the default)
//! they are the votes of the window around that prediction alone ([`super::window`]).

use std::fmt;
use std::sync::{Arc, Mutex};

use cbt_tracker::{
    CbtConfig, CbtModel, CbtTracker, Detection, Frame, Layout, Scales, Sequence, Space, Tracker,
};
use image::GrayImage;
use servo_loop::{Localisation, Recogniser, Robot, ServoError};

use super::error::{PipelineError, Result, check_unit_interval};
use super::motion::MotionModel;
use super::prior::PositionPrior;
use super::shapes::ShapeModel;
use super::vote::{Vote, mode};
use super::window::{SearchWindow, search_window};

/// Settings of the percepts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PerceptConfig {
    /// Kernel width of the vote mode (pixels).
    pub mode_sigma_px: f64,
    /// A track starts on a vote mode at least this certain.
    pub start_certainty: f64,
    /// Below this certainty of the tracker the track is started again from the votes.
    pub lost_certainty: f64,
    /// With a forward model, weigh the FD + CBT percept's votes (and its training walks') by
    /// their agreement with the forward model's predicted tip ([`super::prior`]).
    pub position_prior: bool,
    /// Where the prior applies, look for the gripper's regions only in the window around the
    /// predicted tip outside which every vote would weigh the prior's floor
    /// ([`super::window`]), in tracking and in the training walks alike.
    pub search_window: bool,
}

impl PerceptConfig {
    /// Checks the settings: `mode_sigma_px` finite and positive, both certainties in `[0, 1]`.
    /// (A NaN or zero kernel width made every frame's mode empty, so nothing was ever
    /// recognised.)
    pub fn validate(&self) -> Result<()> {
        if !(self.mode_sigma_px.is_finite() && self.mode_sigma_px > 0.0) {
            return Err(PipelineError::InvalidParameter {
                name: "mode_sigma_px",
                reason: format!("{} must lie in (0, ∞)", self.mode_sigma_px),
            });
        }
        check_unit_interval("start_certainty", self.start_certainty)?;
        check_unit_interval("lost_certainty", self.lost_certainty)
    }
}

impl Default for PerceptConfig {
    fn default() -> Self {
        PerceptConfig {
            mode_sigma_px: 2.0,
            start_certainty: 0.3,
            lost_certainty: 0.05,
            position_prior: true,
            search_window: true,
        }
    }
}

/// The votes as tracker detections.
pub fn detections(votes: &[Vote]) -> Vec<Detection> {
    votes
        .iter()
        .map(|v| Detection {
            pos: v.position,
            weight: v.weight,
        })
        .collect()
}

/// `p` in the coordinates compensated by `offset` (module docs), or `None` when it falls off
/// the `size` image canvas the tracker covers (its edges included): such a vote is far from
/// the track and dropped, in learning and in tracking alike.
pub(crate) fn compensated(p: [f64; 2], offset: [f64; 2], size: [u32; 2]) -> Option<[f64; 2]> {
    let q = [p[0] - offset[0], p[1] - offset[1]];
    ((0.0..=f64::from(size[0])).contains(&q[0]) && (0.0..=f64::from(size[1])).contains(&q[1]))
        .then_some(q)
}

/// One training walk of one camera: per frame the heuristic percept (if any) and the votes.
pub type Walk = Vec<(Option<[f64; 2]>, Vec<Vote>)>;

/// Learns the tracker's model from training walks on images of `size` (see the module docs).
pub fn learn_tracker(size: [u32; 2], walks: &[Walk]) -> Result<CbtModel> {
    let sequences: Vec<Sequence> = walks
        .iter()
        .enumerate()
        .map(|(k, w)| Sequence {
            name: format!("walk-{k}"),
            first_frame: 0,
            frames: w
                .iter()
                .map(|(truth, votes)| Frame {
                    truth: *truth,
                    detections: detections(votes),
                })
                .collect(),
        })
        .collect();
    let frames: usize = sequences
        .iter()
        .map(|s| s.frames.iter().filter(|f| f.truth.is_some()).count())
        .sum();
    if frames < 10 {
        return Err(PipelineError::NotEnoughData(format!(
            "{frames} training frames with a percept (need 10)"
        )));
    }
    let extent = f64::from(size[0].max(size[1]));
    let spacing = Scales::estimate(&sequences, extent)?.fine_spacing(extent)?;
    let space = Space::image(f64::from(size[0]), f64::from(size[1]), spacing)?;
    let config = CbtConfig {
        layout: Layout::Stationary,
        ..CbtConfig::default()
    };
    Ok(CbtModel::learn_sequences(space, config, &sequences)?)
}

/// One camera's track: the tracker, running in coordinates compensated by `offset`, the sum of
/// the commanded moves' predicted shifts since it started (module docs).
#[derive(Debug, Clone)]
struct Track {
    tracker: CbtTracker,
    offset: [f64; 2],
}

/// What the percept and its notifiers share: each camera's track, and the forward model's
/// predicted tip at the last command (`None` without a forward model or outside it).
#[derive(Debug, Clone)]
struct State {
    tracks: Vec<Option<Track>>,
    predicted: Option<Vec<[f64; 2]>>,
}

type Shared = Arc<Mutex<State>>;

fn shared(cameras: usize) -> Shared {
    Arc::new(Mutex::new(State {
        tracks: vec![None; cameras],
        predicted: None,
    }))
}

fn lock(state: &Mutex<State>) -> std::sync::MutexGuard<'_, State> {
    state.lock().unwrap_or_else(|p| p.into_inner())
}

fn forget(state: &Mutex<State>) {
    lock(state).tracks.iter_mut().for_each(|x| *x = None);
}

/// Tells an [`FdCbtRecogniser`] of the commanded moves: with a forward model, each move shifts
/// the tracks by its predicted image motion and sets the centre of the prior on the votes'
/// position ([`FdCbtRecogniser::predicted`]); without one (or outside it), a move larger than
/// the tracker learned restarts the tracks from the votes. A command it refuses
/// ([`MoveNotifier::commanded`]) changes nothing.
#[derive(Debug)]
pub struct MoveNotifier {
    state: Shared,
    motion: Option<Arc<MotionModel>>,
    reset_us: f64,
    last: Option<Vec<f64>>,
    /// The forward model's prediction at `last`.
    last_predicted: Option<Vec<[f64; 2]>>,
}

/// What telling a checked command does: the forward model's prediction at it and the shift
/// from the last one (`MoveNotifier::check`).
#[derive(Debug)]
struct Told {
    predicted: Option<Vec<[f64; 2]>>,
    shift: Option<Vec<[f64; 2]>>,
}

impl MoveNotifier {
    /// A command was sent (the full set-points, as the robot was given them).
    ///
    /// Errors ([`PipelineError::InvalidParameter`]), with the tracks, the prior's centre and
    /// the last command left as they were: an empty command, a set-point that is not finite, a
    /// command of another length than the last one told (`set_points`), or one the forward
    /// model cannot read (too short for the servos it reads, `command`). (A NaN set-point
    /// used to be taken: the forward model had no prediction for it, so the prior lost its
    /// centre, and every later move compared with it looked small, so a move of any size kept
    /// the tracks.)
    pub fn commanded(&mut self, set_points: &[f64]) -> Result<()> {
        let told = self.check(set_points)?;
        self.tell(set_points, told);
        Ok(())
    }

    /// The checks of [`Self::commanded`] and what telling `set_points` does, changing
    /// nothing.
    fn check(&self, set_points: &[f64]) -> Result<Told> {
        let refuse = |reason: String| {
            Err(PipelineError::InvalidParameter {
                name: "set_points",
                reason,
            })
        };
        if set_points.is_empty() {
            return refuse("an empty command".into());
        }
        if let Some((i, v)) = set_points.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return refuse(format!("set-point {i} is {v}, not finite"));
        }
        if let Some(l) = self.last.as_ref().filter(|l| l.len() != set_points.len()) {
            return refuse(format!(
                "{} set-points, the last command told had {}",
                set_points.len(),
                l.len()
            ));
        }
        let predicted = match &self.motion {
            Some(m) => m.predict(set_points)?,
            None => None,
        };
        // `g(y') − g(y)`, as `MotionModel::shift`, with `g(y)` kept from the last command.
        let shift = match (&self.last_predicted, &predicted) {
            (Some(a), Some(b)) => Some(MotionModel::difference(a, b)?),
            _ => None,
        };
        Ok(Told { predicted, shift })
    }

    /// Tells the tracks of the checked command `set_points`.
    fn tell(&mut self, set_points: &[f64], told: Told) {
        let Told { predicted, shift } = told;
        lock(&self.state).predicted.clone_from(&predicted);
        if let Some(d) = shift {
            let mut state = lock(&self.state);
            for (track, d) in state.tracks.iter_mut().zip(&d) {
                if let Some(track) = track {
                    track.offset[0] += d[0];
                    track.offset[1] += d[1];
                }
            }
        } else {
            let far = self.last.as_ref().is_none_or(|l| {
                l.len() != set_points.len()
                    || l.iter()
                        .zip(set_points)
                        .any(|(a, b)| (a - b).abs() > self.reset_us)
            });
            if far {
                forget(&self.state);
            }
        }
        self.last = Some(set_points.to_vec());
        self.last_predicted = predicted;
    }
}

/// A robot whose accepted commands are told to a [`MoveNotifier`]: a command the notifier
/// refuses ([`MoveNotifier::commanded`]) is not sent, and one the robot refuses is not told.
#[derive(Debug)]
pub struct Notifying<R> {
    /// The robot.
    pub robot: R,
    /// The recogniser's handle.
    pub notifier: MoveNotifier,
}

/// Why a [`Notifying`] robot refused a command or a capture.
#[derive(Debug)]
pub enum NotifyingError<E> {
    /// The notifier refused the command; it was not sent to the robot, and nothing changed.
    Notifier(PipelineError),
    /// The robot's own error (a command it refused was not told to the notifier). Its message
    /// is the robot's.
    Robot(E),
}

impl<E: fmt::Display> fmt::Display for NotifyingError<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            NotifyingError::Notifier(e) => write!(f, "the percept's notifier refused it: {e}"),
            NotifyingError::Robot(e) => e.fmt(f),
        }
    }
}

impl<E: fmt::Debug + fmt::Display> std::error::Error for NotifyingError<E> {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            NotifyingError::Notifier(e) => Some(e),
            NotifyingError::Robot(_) => None,
        }
    }
}

impl<R: Robot> Robot for Notifying<R> {
    type Error = NotifyingError<R::Error>;
    fn num_servos(&self) -> usize {
        self.robot.num_servos()
    }
    fn servo_range(&self, i: usize) -> [f64; 2] {
        self.robot.servo_range(i)
    }
    fn command(&mut self, set_points: &[f64]) -> std::result::Result<(), Self::Error> {
        // Checked before the robot moves: a command told after the robot took it can no
        // longer be refused without the tracks missing a move.
        let told = self
            .notifier
            .check(set_points)
            .map_err(NotifyingError::Notifier)?;
        self.robot
            .command(set_points)
            .map_err(NotifyingError::Robot)?;
        self.notifier.tell(set_points, told);
        Ok(())
    }
    fn capture(&mut self) -> std::result::Result<Vec<GrayImage>, Self::Error> {
        self.robot.capture().map_err(NotifyingError::Robot)
    }
}

fn failed(camera: usize, certainty: f64, min: f64) -> ServoError {
    ServoError::RecognitionFailed {
        camera,
        certainty,
        min,
    }
}

/// `Ok` when the captured `images` fit the percept: one per camera of the shape model
/// ([`ServoError::DimensionMismatch`] `images` otherwise), each of the percept's `size`
/// ([`ServoError::InvalidParameter`] `image`). The parts are checked before, on their own
/// ([`FdRecogniser::check_parts`], [`FdCbtRecogniser::check_parts`]).
fn check_images(images: &[GrayImage], cameras: usize, size: [u32; 2]) -> servo_loop::Result<()> {
    if images.len() != cameras {
        return Err(ServoError::DimensionMismatch {
            what: "images",
            expected: cameras,
            got: images.len(),
        });
    }
    for img in images {
        if [img.width(), img.height()] != size {
            return Err(ServoError::InvalidParameter {
                name: "image",
                reason: format!(
                    "{}×{} px, the model was learned on {}×{}",
                    img.width(),
                    img.height(),
                    size[0],
                    size[1]
                ),
            });
        }
    }
    Ok(())
}

/// `Ok` when every camera of `shapes` was learned on images of `size`.
fn check_shape_sizes(shapes: &ShapeModel, size: [u32; 2]) -> Result<()> {
    match (0..shapes.num_cameras())
        .map(|cam| (cam, shapes.image_size(cam)))
        .find(|(_, s)| *s != Some(size))
    {
        None => Ok(()),
        Some((cam, learned)) => Err(PipelineError::InvalidParameter {
            name: "shapes",
            reason: format!(
                "camera {cam}'s shape model was learned on {} images, the percept's are {}×{}",
                learned.map_or("no".into(), |s| format!("{}×{}", s[0], s[1])),
                size[0],
                size[1]
            ),
        }),
    }
}

/// `Ok` when the tracker's model covers the canvas of an image of `size`, `[0, w] × [0, h]`,
/// as [`learn_tracker`] makes it (its state and measurement channels alike).
fn check_tracker_size(model: &CbtModel, size: [u32; 2]) -> Result<()> {
    let space = model.space();
    let ranges: Vec<(f64, f64)> = (0..space.dims())
        .flat_map(|d| {
            [
                space.state_basis(d).representable_range(),
                space.meas_basis(d).representable_range(),
            ]
        })
        .collect();
    let fits = space.dims() == 2
        && ranges.iter().enumerate().all(|(k, &(lo, hi))| {
            let want = f64::from(size[k / 2]);
            // `ChannelBasis::covering` rounds its ends by far less than this.
            let slack = 1e-9 * want.max(1.0);
            lo.abs() <= slack && (hi - want).abs() <= slack
        });
    if fits {
        return Ok(());
    }
    Err(PipelineError::InvalidParameter {
        name: "model",
        reason: format!(
            "a tracker model of the canvas {ranges:?} (state and measurement per axis), the \
             percept's images are {}×{} (learn it on their size, `learn_tracker`)",
            size[0], size[1]
        ),
    })
}

/// A pipeline error in a percept, as the servo library's (the percept's settings or votes were
/// refused).
fn percept_error(e: PipelineError) -> ServoError {
    ServoError::InvalidParameter {
        name: "percept",
        reason: e.to_string(),
    }
}

fn votes_of(
    shapes: &ShapeModel,
    cam: usize,
    img: &GrayImage,
    window: Option<&SearchWindow>,
) -> servo_loop::Result<Vec<Vote>> {
    shapes
        .votes_in(cam, img, window)
        .map_err(|e| ServoError::InvalidParameter {
            name: "image",
            reason: e.to_string(),
        })
}

/// The FD-only percept: per camera the mode of the frame's votes.
#[derive(Debug, Clone)]
pub struct FdRecogniser {
    /// The shape model.
    pub shapes: ShapeModel,
    /// Image size of every camera.
    pub size: [u32; 2],
    /// Settings.
    pub config: PerceptConfig,
}

impl FdRecogniser {
    /// `Ok` when the shape model was learned on images of `size` on every camera
    /// ([`PipelineError::InvalidParameter`] `shapes` otherwise; the fields are public).
    fn check_parts(&self) -> Result<()> {
        check_shape_sizes(&self.shapes, self.size)
    }
}

impl Recogniser for FdRecogniser {
    fn num_cameras(&self) -> usize {
        self.shapes.num_cameras()
    }
    fn image_size(&self, _cam: usize) -> [u32; 2] {
        self.size
    }
    fn locate_all(&self, images: &[GrayImage]) -> servo_loop::Result<Vec<Localisation>> {
        // The settings and the shape model are public fields: checked here, before the images
        // are compared with them (module docs, *Errors of a capture*).
        self.config.validate().map_err(percept_error)?;
        self.check_parts().map_err(percept_error)?;
        check_images(images, self.shapes.num_cameras(), self.size)?;
        images
            .iter()
            .enumerate()
            .map(|(cam, img)| {
                let votes = votes_of(&self.shapes, cam, img, None)?;
                let m = mode(&votes, self.config.mode_sigma_px)
                    .map_err(percept_error)?
                    .ok_or(failed(cam, 0.0, 0.0))?;
                Ok(Localisation {
                    position: m.position,
                    certainty: m.certainty,
                })
            })
            .collect()
    }
}

/// The FD + CBT percept: per camera the votes tracked by CBT (module docs). The tracks are
/// state behind a mutex, so the percept seam's `&self` calls advance them.
#[derive(Debug)]
pub struct FdCbtRecogniser {
    /// The FD-only percept whose votes are tracked.
    pub fd: FdRecogniser,
    model: CbtModel,
    motion: Option<Arc<MotionModel>>,
    prior: Option<PositionPrior>,
    state: Shared,
}

impl FdCbtRecogniser {
    /// The percept with `model` learned by [`learn_tracker`]; no track yet, no forward model.
    /// It keeps a track for each of the shape model's cameras.
    ///
    /// Errors ([`PipelineError::InvalidParameter`]): a shape model learned on images of
    /// another size than `fd.size` on any camera (`shapes`), or a tracker model whose canvas
    /// is not that of `fd.size` images (`model`; one learned on larger images used to be
    /// taken silently, one on smaller images refused every frame whose tip lay outside it).
    /// What only a capture shows (the robot's camera count and image size) is checked by
    /// every capture, before any track moves.
    pub fn new(fd: FdRecogniser, model: CbtModel) -> Result<Self> {
        fd.check_parts()?;
        check_tracker_size(&model, fd.size)?;
        let n = fd.shapes.num_cameras();
        Ok(FdCbtRecogniser {
            fd,
            model,
            motion: None,
            prior: None,
            state: shared(n),
        })
    }

    /// `Ok` when the parts still fit one another (the percept's fields are public): the
    /// shape model ([`FdRecogniser::check_parts`]) and the tracker model of `fd.size` images
    /// (as [`Self::new`] checks), and the shape model's cameras those of the `tracks` this
    /// percept keeps, of the forward model and of the prior; the first that does not is the
    /// error ([`PipelineError::InvalidParameter`] naming it: `shapes`, `model`, `tracks`,
    /// `motion`, `prior`).
    fn check_parts(&self, tracks: usize) -> Result<()> {
        self.fd.check_parts()?;
        check_tracker_size(&self.model, self.fd.size)?;
        let n = self.fd.shapes.num_cameras();
        let counts = [
            ("tracks", Some(tracks)),
            ("motion", self.motion.as_ref().map(|m| m.num_cameras())),
            ("prior", self.prior.as_ref().map(PositionPrior::num_cameras)),
        ];
        match counts.into_iter().find(|(_, c)| c.is_some_and(|c| c != n)) {
            None => Ok(()),
            Some((name, c)) => Err(PipelineError::InvalidParameter {
                name,
                reason: format!(
                    "{} cameras, the shape model has {n} (the percept's parts must agree)",
                    c.unwrap_or(0)
                ),
            }),
        }
    }

    /// With the forward model that predicts each commanded move's image shift (module docs);
    /// `model` must have been learned on walks compensated by it ([`super::learn_by_action`]
    /// does both). Errors: a forward model for another number of cameras.
    pub fn with_motion(mut self, motion: MotionModel) -> Result<Self> {
        if motion.num_cameras() != self.fd.shapes.num_cameras() {
            return Err(PipelineError::InvalidParameter {
                name: "motion",
                reason: format!(
                    "a forward model of {} cameras, the shape model has {}",
                    motion.num_cameras(),
                    self.fd.shapes.num_cameras()
                ),
            });
        }
        self.motion = Some(Arc::new(motion));
        Ok(self)
    }

    /// With the prior on the votes' position ([`super::prior`]), applied to every frame whose
    /// last command the forward model predicts; `model` must have been learned on walks
    /// weighed the same way ([`super::learn_by_action`] does both). Errors: no forward model
    /// yet, or a prior for another number of cameras.
    pub fn with_prior(mut self, prior: PositionPrior) -> Result<Self> {
        if self.motion.is_none() || prior.num_cameras() != self.fd.shapes.num_cameras() {
            return Err(PipelineError::InvalidParameter {
                name: "prior",
                reason: format!(
                    "a prior of {} cameras needs a forward model and {} cameras",
                    prior.num_cameras(),
                    self.fd.shapes.num_cameras()
                ),
            });
        }
        self.prior = Some(prior);
        Ok(self)
    }

    /// The prior on the votes' position, if any.
    pub fn prior(&self) -> Option<&PositionPrior> {
        self.prior.as_ref()
    }

    /// The forward model's predicted tip in every camera at the last command a notifier was
    /// told of (the centre of the prior on the votes' position), `None` before any, without a
    /// forward model, or where it has no prediction.
    pub fn predicted(&self) -> Option<Vec<[f64; 2]>> {
        lock(&self.state).predicted.clone()
    }

    /// The same percept (shape, tracker and forward models) with no track, independent of
    /// this one's tracks and notifiers.
    pub fn fresh(&self) -> Self {
        FdCbtRecogniser {
            fd: self.fd.clone(),
            model: self.model.clone(),
            motion: self.motion.clone(),
            prior: self.prior.clone(),
            state: shared(self.fd.shapes.num_cameras()),
        }
    }

    /// The tracker's learned model.
    pub fn model(&self) -> &CbtModel {
        &self.model
    }

    /// The forward model of the commanded moves, if any.
    pub fn motion(&self) -> Option<&MotionModel> {
        self.motion.as_deref()
    }

    /// Per camera, the running track's offset `c` (the summed predicted shifts of the
    /// commanded moves since it started; module docs), `None` where no track runs.
    pub fn offsets(&self) -> Vec<Option<[f64; 2]>> {
        lock(&self.state)
            .tracks
            .iter()
            .map(|x| x.as_ref().map(|t| t.offset))
            .collect()
    }

    /// Forgets every track (the next frame starts them from the votes).
    pub fn reset(&self) {
        forget(&self.state);
    }

    /// A handle told of every commanded move (see [`Notifying`]): with a forward model it
    /// shifts the tracks by the move's predicted image motion; without one, or where the
    /// forward model has no prediction, it forgets the tracks when the move exceeds `reset_us`
    /// on any servo (the tracker's learned motion covers small moves only).
    ///
    /// Errors: `reset_us` NaN or negative ([`PipelineError::InvalidParameter`]; a NaN used to
    /// mean "never reset", a negative value "always"). An infinite `reset_us` never resets.
    pub fn notifier(&self, reset_us: f64) -> Result<MoveNotifier> {
        if reset_us.is_nan() || reset_us < 0.0 {
            return Err(PipelineError::InvalidParameter {
                name: "reset_us",
                reason: format!("{reset_us} must be non-negative"),
            });
        }
        Ok(MoveNotifier {
            state: Arc::clone(&self.state),
            motion: self.motion.clone(),
            reset_us,
            last: None,
            last_predicted: None,
        })
    }

    /// One camera's step: start (or restart) from the vote mode, or track.
    fn step(
        &self,
        cam: usize,
        votes: &[Vote],
        track: &mut Option<Track>,
    ) -> servo_loop::Result<Localisation> {
        let cfg = &self.fd.config;
        let tracker_error = |e: cbt_tracker::TrackError| ServoError::InvalidParameter {
            name: "tracker",
            reason: e.to_string(),
        };
        let start = |track: &mut Option<Track>| -> servo_loop::Result<Localisation> {
            *track = None;
            let m = mode(votes, cfg.mode_sigma_px)
                .map_err(percept_error)?
                .ok_or(failed(cam, 0.0, cfg.start_certainty))?;
            if m.certainty < cfg.start_certainty {
                return Err(failed(cam, m.certainty, cfg.start_certainty));
            }
            let mut tracker = CbtTracker::new(self.model.clone());
            tracker.reset(m.position).map_err(tracker_error)?;
            *track = Some(Track {
                tracker,
                offset: [0.0; 2],
            });
            Ok(Localisation {
                position: m.position,
                certainty: m.certainty,
            })
        };
        let Some(t) = track.as_mut() else {
            return start(track);
        };
        let seen: Vec<Detection> = votes
            .iter()
            .filter_map(|v| {
                Some(Detection {
                    pos: compensated(v.position, t.offset, self.fd.size)?,
                    weight: v.weight,
                })
            })
            .collect();
        let e = t.tracker.step(&seen).map_err(tracker_error)?;
        let certainty = e.certainty.unwrap_or(0.0).clamp(0.0, 1.0);
        if certainty < cfg.lost_certainty {
            return start(track);
        }
        Ok(Localisation {
            position: [e.position[0] + t.offset[0], e.position[1] + t.offset[1]],
            certainty,
        })
    }
}

impl Recogniser for FdCbtRecogniser {
    fn num_cameras(&self) -> usize {
        self.fd.num_cameras()
    }
    fn image_size(&self, cam: usize) -> [u32; 2] {
        self.fd.image_size(cam)
    }
    fn locate_all(&self, images: &[GrayImage]) -> servo_loop::Result<Vec<Localisation>> {
        // Before any track moves: settings out of range (public fields) used to restart or
        // keep tracks silently (a NaN certainty threshold), or forget a track and then fail
        // (a NaN kernel width on a restart), while the other cameras' tracks advanced. So did
        // parts that no longer fit (a shape model of more cameras than the tracks panicked).
        self.fd.config.validate().map_err(percept_error)?;
        // The prediction at the last command: the prior's centre and the search windows'.
        let (predicted, tracks) = {
            let state = lock(&self.state);
            (state.predicted.clone(), state.tracks.len())
        };
        self.check_parts(tracks).map_err(percept_error)?;
        check_images(images, self.fd.shapes.num_cameras(), self.fd.size)?;
        let mut votes: Vec<Vec<Vote>> = images
            .iter()
            .enumerate()
            .map(|(cam, img)| {
                let window = match (&self.prior, &predicted) {
                    (Some(prior), Some(p)) if self.fd.config.search_window => {
                        search_window(&self.fd.shapes, prior, cam, p[cam], self.fd.size)
                    }
                    _ => None,
                };
                votes_of(&self.fd.shapes, cam, img, window.as_ref())
            })
            .collect::<servo_loop::Result<_>>()?;
        if let (Some(prior), Some(predicted)) = (&self.prior, &predicted) {
            for (cam, v) in votes.iter_mut().enumerate() {
                prior.weigh(cam, predicted[cam], v).map_err(percept_error)?;
            }
        }
        let mut state = lock(&self.state);
        // Every camera's track takes the frame, also when another camera's percept fails.
        let steps: Vec<_> = votes
            .iter()
            .enumerate()
            .map(|(cam, v)| self.step(cam, v, &mut state.tracks[cam]))
            .collect();
        steps.into_iter().collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::shapes::tests::{L0, one_l_model, scene, tip};

    /// The FD + CBT percept of one camera that sees the shape tests' L (its one-view shape
    /// model; the tracker learned on a synthetic walk around the tip, one vote near it per
    /// frame).
    fn percept() -> FdCbtRecogniser {
        let (shapes, _, rest) = one_l_model();
        let size = [rest.width(), rest.height()];
        let t0 = tip(L0.0, L0.1);
        let walk: Walk = (0..30)
            .map(|k| {
                let t = [
                    t0[0] - 5.0 + f64::from(k % 7),
                    t0[1] - 4.0 + f64::from(k % 5),
                ];
                let vote = Vote {
                    position: [t[0] + 0.3 * f64::from(k % 3), t[1] - 0.2 * f64::from(k % 2)],
                    weight: 0.8,
                    error: 0.05,
                    rotation: 0.0,
                    region: 0,
                };
                (Some(t), vec![vote])
            })
            .collect();
        let model = learn_tracker(size, &[walk]).unwrap();
        let fd = FdRecogniser {
            shapes,
            size,
            config: PerceptConfig::default(),
        };
        FdCbtRecogniser::new(fd, model).unwrap()
    }

    /// Settings out of range (the percept's fields are public) are refused before any track
    /// moves: a kernel width of NaN with a loss threshold above 1 used to forget the running
    /// track and then fail, and a NaN start threshold started a track on any vote mode.
    #[test]
    fn bad_settings_are_refused_and_leave_the_tracks_as_they_were() {
        let mut p = percept();
        let frame = [scene([L0.0[0] + 5.0, L0.0[1] + 2.0], L0.1, true)];
        p.locate_all(&frame).unwrap();
        assert_eq!(p.offsets(), vec![Some([0.0, 0.0])]);
        p.fd.config.mode_sigma_px = f64::NAN;
        p.fd.config.lost_certainty = 2.0;
        assert!(matches!(
            p.locate_all(&frame),
            Err(ServoError::InvalidParameter {
                name: "percept",
                ..
            })
        ));
        assert_eq!(p.offsets(), vec![Some([0.0, 0.0])], "the track was kept");

        let mut fresh = p.fresh();
        fresh.fd.config = PerceptConfig {
            start_certainty: f64::NAN,
            ..PerceptConfig::default()
        };
        assert!(fresh.locate_all(&frame).is_err());
        assert_eq!(fresh.offsets(), vec![None]);
        // The FD-only percept checks its settings too.
        assert!(fresh.fd.locate_all(&frame).is_err());
    }

    /// The L scene with the L moved from its training pose by `dx`.
    fn frame(dx: f64) -> [GrayImage; 1] {
        [scene([L0.0[0] + dx, L0.0[1] + 2.0], L0.1, true)]
    }

    /// A one-camera tracker walk around the L's tip on the shape tests' images, scaled by `k`
    /// (to learn a tracker model on images `k` times the size).
    fn walk(k: f64) -> Walk {
        let t0 = tip(L0.0, L0.1);
        (0..30)
            .map(|i| {
                let t = [
                    k * (t0[0] - 5.0 + f64::from(i % 7)),
                    k * (t0[1] - 4.0 + f64::from(i % 5)),
                ];
                let vote = Vote {
                    position: t,
                    weight: 0.8,
                    error: 0.05,
                    rotation: 0.0,
                    region: 0,
                };
                (Some(t), vec![vote])
            })
            .collect()
    }

    /// The shape model of the L seen by two cameras (the same pair for both).
    fn two_camera_shapes(config: &crate::pipeline::ShapeConfig) -> ShapeModel {
        let (rest, moved) = (scene(L0.0, L0.1, true), scene(L0.0, L0.1, false));
        let pair = |camera| crate::pipeline::ActionPair {
            camera,
            rest: &rest,
            moved: &moved,
            tip: Some(tip(L0.0, L0.1)),
        };
        ShapeModel::learn(config, 2, &[pair(0), pair(1)]).unwrap().0
    }

    /// A one-camera forward model of servo 0: the tip moves 0.1 px per µs along x.
    fn motion() -> MotionModel {
        let mut m = MotionModel::new(&[0], 1, &crate::pipeline::MotionConfig::default()).unwrap();
        let t0 = tip(L0.0, L0.1);
        for i in 0..200 {
            let y = 1300.0 + 2.0 * f64::from(i);
            m.update(&[y], &[[t0[0] + 0.1 * (y - 1500.0), t0[1]]])
                .unwrap();
        }
        m
    }

    /// A tracker model or a shape model of another image size than the percept's is refused at
    /// construction. (A tracker model of larger images used to be taken silently; one of
    /// smaller images refused every frame whose tip lay outside its canvas, after forgetting
    /// the track.)
    #[test]
    fn parts_of_another_image_size_are_refused_at_construction() {
        let p = percept();
        let size = p.fd.size;
        for k in [2.0, 0.5] {
            let other = [
                (f64::from(size[0]) * k) as u32,
                (f64::from(size[1]) * k) as u32,
            ];
            let model = learn_tracker(other, &[walk(k)]).unwrap();
            assert!(
                matches!(
                    FdCbtRecogniser::new(p.fd.clone(), model.clone()),
                    Err(PipelineError::InvalidParameter { name: "model", .. })
                ),
                "a tracker model of {other:?} images"
            );
            // A shape model learned on `size` images, in a percept of `other` images (with a
            // tracker model of those).
            let fd = FdRecogniser {
                size: other,
                ..p.fd.clone()
            };
            assert!(
                matches!(
                    FdCbtRecogniser::new(fd, model),
                    Err(PipelineError::InvalidParameter { name: "shapes", .. })
                ),
                "a shape model of {size:?} images in a percept of {other:?}"
            );
        }
        // The parts of the right size are taken.
        assert!(
            FdCbtRecogniser::new(p.fd.clone(), learn_tracker(size, &[walk(1.0)]).unwrap()).is_ok()
        );
    }

    /// Parts changed after construction (the percept's fields are public) are refused by the
    /// next capture, a typed error before any track moves: a shape model of two cameras in a
    /// percept built with one used to panic (the tracks' index), a percept image size that
    /// fits neither the shape model nor the tracker model used to be taken.
    #[test]
    fn parts_changed_after_construction_are_refused_before_any_track_moves() {
        let mut p = percept().with_motion(motion()).unwrap();
        let mut notifier = p.notifier(50.0).unwrap();
        notifier.commanded(&[1500.0]).unwrap();
        p.locate_all(&frame(5.0)).unwrap();
        let (offsets, predicted) = (p.offsets(), p.predicted());
        assert_eq!(offsets, vec![Some([0.0, 0.0])]);
        assert!(predicted.is_some());
        let is_refused = |r: servo_loop::Result<Vec<Localisation>>| {
            matches!(
                r,
                Err(ServoError::InvalidParameter {
                    name: "percept",
                    ..
                })
            )
        };

        let one = p.fd.shapes.clone();
        p.fd.shapes = two_camera_shapes(one.config());
        let [f] = frame(5.0);
        assert!(is_refused(p.locate_all(&[f.clone(), f.clone()])));
        assert!(is_refused(p.locate_all(&[f])));
        p.fd.shapes = one;

        let size = p.fd.size;
        p.fd.size = [size[0] / 2, size[1] / 2];
        let small = [GrayImage::new(size[0] / 2, size[1] / 2)];
        assert!(is_refused(p.locate_all(&small)));
        assert!(is_refused(p.fd.locate_all(&small)));
        p.fd.size = size;

        assert_eq!(p.offsets(), offsets, "the track was kept");
        assert_eq!(p.predicted(), predicted);
        assert!(p.locate_all(&frame(6.0)).is_ok());
    }

    /// Which error a capture gives (module docs, *Errors of a capture*): parts that do not fit
    /// one another first (`percept`, the reason naming the part), before the images are
    /// compared with the percept (`images`: their count; `image`: their size). The FD-only
    /// percept used to compare the image count before its shape model's image size, so a
    /// broken shape model with a wrong count of images was reported as the images' fault.
    #[test]
    fn a_capture_reports_parts_that_do_not_fit_before_the_images() {
        /// `percept: <part>`, `images` (count) or `image` (size).
        fn kind(r: servo_loop::Result<Vec<Localisation>>) -> String {
            match r {
                Err(ServoError::InvalidParameter {
                    name: "percept",
                    reason,
                }) => {
                    let part = reason.split('`').nth(1).unwrap_or("?");
                    format!("percept: {part}")
                }
                Err(ServoError::DimensionMismatch { what, .. }) => what.to_string(),
                Err(ServoError::InvalidParameter { name, .. }) => name.to_string(),
                other => format!("{other:?}"),
            }
        }
        let mut p = percept();
        let [f] = frame(5.0);
        let size = p.fd.size;
        let small = GrayImage::new(size[0] / 2, size[1] / 2);
        // The parts fit: the images' count, then their size.
        for r in [&p.fd as &dyn Recogniser, &p] {
            assert_eq!(kind(r.locate_all(&[])), "images");
            assert_eq!(kind(r.locate_all(&[f.clone(), f.clone()])), "images");
            assert_eq!(
                kind(r.locate_all(&[small.clone(), small.clone()])),
                "images"
            );
            assert_eq!(kind(r.locate_all(std::slice::from_ref(&small))), "image");
        }
        assert_eq!(p.offsets(), vec![None]);
        // The shape model no longer fits the percept's image size: the parts' error, whatever
        // the images (of the shape model's size or the percept's, too many or too few).
        p.fd.size = [size[0] / 2, size[1] / 2];
        for r in [&p.fd as &dyn Recogniser, &p] {
            for images in [
                vec![small.clone()],
                vec![f.clone()],
                vec![],
                vec![small.clone(), small.clone()],
            ] {
                assert_eq!(kind(r.locate_all(&images)), "percept: shapes");
            }
        }
        p.fd.size = size;
        // Two parts of the FD + CBT percept that do not fit each other: a shape model of two
        // cameras in a percept that keeps one track, with one image or two.
        let one = p.fd.shapes.clone();
        p.fd.shapes = two_camera_shapes(one.config());
        for images in [vec![f.clone()], vec![f.clone(), f.clone()]] {
            assert_eq!(kind(p.locate_all(&images)), "percept: tracks");
        }
        p.fd.shapes = one;
        assert_eq!(p.offsets(), vec![None], "no track moved");
        assert!(p.locate_all(&[f]).is_ok());
    }

    /// Every refused capture leaves the tracks exactly as they were, the tracker's posterior
    /// included (which `offsets` does not show): a percept that saw refused captures between
    /// its frames (images of another count or size, settings out of range, parts that no
    /// longer fit) localises every later frame bit for bit as a twin that never saw them.
    #[test]
    fn refused_captures_change_no_later_localisation() {
        let p = percept().with_motion(motion()).unwrap();
        let twin = p.fresh();
        let (mut n, mut m) = (p.notifier(50.0).unwrap(), twin.notifier(50.0).unwrap());
        let size = p.fd.size;
        let small = GrayImage::new(size[0] / 2, size[1] / 2);
        let large = GrayImage::new(size[0] * 2, size[1]);
        /// A refused capture of `p`, by one change of what it is given or holds.
        type Bad = fn(&mut FdCbtRecogniser, &GrayImage, &GrayImage) -> bool;
        let bad: [(&str, Bad); 6] = [
            ("no image", |p, _, _| p.locate_all(&[]).is_err()),
            ("two images", |p, _, _| {
                let [f] = frame(5.0);
                p.locate_all(&[f.clone(), f]).is_err()
            }),
            ("a small image", |p, small, _| {
                p.locate_all(std::slice::from_ref(small)).is_err()
            }),
            ("a large image", |p, _, large| {
                p.locate_all(std::slice::from_ref(large)).is_err()
            }),
            ("a NaN kernel width", |p, _, _| {
                p.fd.config.mode_sigma_px = f64::NAN;
                let refused = p.locate_all(&frame(5.0)).is_err();
                p.fd.config = PerceptConfig::default();
                refused
            }),
            ("a percept size the models do not fit", |p, small, _| {
                let size = p.fd.size;
                p.fd.size = [small.width(), small.height()];
                let refused = p.locate_all(std::slice::from_ref(small)).is_err();
                p.fd.size = size;
                refused
            }),
        ];
        let mut p = p;
        for (k, dx) in [5.0, 6.0, 6.5, 7.5, 8.0, 9.0, 9.5].into_iter().enumerate() {
            let command = [1500.0 + 2.0 * k as f64];
            n.commanded(&command).unwrap();
            m.commanded(&command).unwrap();
            let got = p.locate_all(&frame(dx));
            let want = twin.locate_all(&frame(dx));
            assert_eq!(format!("{got:?}"), format!("{want:?}"), "frame {k}");
            assert!(got.is_ok(), "frame {k}: {got:?}");
            for (what, refuse) in &bad {
                assert!(
                    refuse(&mut p, &small, &large),
                    "frame {k}: {what} was taken"
                );
                assert_eq!(p.offsets(), twin.offsets(), "frame {k}: {what}");
                assert_eq!(p.predicted(), twin.predicted(), "frame {k}: {what}");
            }
        }
    }

    /// A command that is not finite (or empty, or of another length than the last) is refused
    /// by the notifier, and nothing changes. A NaN set-point used to be taken: with a forward
    /// model the prior lost its centre, and every later move compared with the NaN looked
    /// small, so a move far beyond `reset_us` kept the tracks.
    #[test]
    fn a_non_finite_command_is_refused_and_changes_nothing() {
        // Without a forward model: the restart on a large move.
        let p = percept();
        let mut notifier = p.notifier(50.0).unwrap();
        notifier.commanded(&[1500.0]).unwrap();
        p.locate_all(&frame(5.0)).unwrap();
        assert_eq!(p.offsets(), vec![Some([0.0, 0.0])]);
        for bad in [
            &[f64::NAN][..],
            &[f64::INFINITY],
            &[-f64::INFINITY],
            &[],
            &[1500.0, 1500.0],
        ] {
            assert!(
                matches!(
                    notifier.commanded(bad),
                    Err(PipelineError::InvalidParameter {
                        name: "set_points",
                        ..
                    })
                ),
                "{bad:?}"
            );
            assert_eq!(p.offsets(), vec![Some([0.0, 0.0])], "{bad:?}");
        }
        // The last command is still 1500: a 1000 µs move restarts the track.
        notifier.commanded(&[2500.0]).unwrap();
        assert_eq!(p.offsets(), vec![None]);

        // With a forward model: the prior's centre and the tracks' offset stay.
        let p = percept().with_motion(motion()).unwrap();
        let mut notifier = p.notifier(50.0).unwrap();
        notifier.commanded(&[1500.0]).unwrap();
        p.locate_all(&frame(5.0)).unwrap();
        let predicted = p.predicted();
        assert!(predicted.is_some());
        assert!(notifier.commanded(&[f64::NAN]).is_err());
        assert_eq!(p.predicted(), predicted);
        assert_eq!(p.offsets(), vec![Some([0.0, 0.0])]);
        // The next move's shift is from 1500 (0.1 px per µs).
        notifier.commanded(&[1520.0]).unwrap();
        let dx = p.offsets()[0].expect("a track")[0];
        assert!((dx - 2.0).abs() < 0.2, "{dx}");
    }

    /// A robot that takes commands up to 2000 µs and counts them.
    #[derive(Debug, Default)]
    struct Picky {
        sent: Vec<Vec<f64>>,
    }

    impl Robot for Picky {
        type Error = String;
        fn num_servos(&self) -> usize {
            1
        }
        fn servo_range(&self, _: usize) -> [f64; 2] {
            [1000.0, 2000.0]
        }
        fn command(&mut self, set_points: &[f64]) -> std::result::Result<(), String> {
            if set_points.iter().any(|v| *v > 2000.0) {
                return Err(format!("{set_points:?} out of range"));
            }
            self.sent.push(set_points.to_vec());
            Ok(())
        }
        fn capture(&mut self) -> std::result::Result<Vec<GrayImage>, String> {
            Err("no camera".into())
        }
    }

    /// Through [`Notifying`]: a command the robot refuses is not told (the track is kept), and
    /// one the notifier refuses is not sent (the robot never sees a NaN set-point, and the
    /// tracks are not poisoned by it: a large move after it still restarts them).
    #[test]
    fn notifying_tells_only_the_commands_the_robot_took_and_sends_none_the_notifier_refuses() {
        let p = percept();
        let mut robot = Notifying {
            robot: Picky::default(),
            notifier: p.notifier(50.0).unwrap(),
        };
        robot.command(&[1500.0]).unwrap();
        p.locate_all(&frame(5.0)).unwrap();
        let refused = robot.command(&[3000.0]).unwrap_err();
        assert!(matches!(&refused, NotifyingError::Robot(m) if m.contains("out of range")));
        assert_eq!(refused.to_string(), "[3000.0] out of range");
        assert_eq!(p.offsets(), vec![Some([0.0, 0.0])], "not told");

        let refused = robot.command(&[f64::NAN]).unwrap_err();
        assert!(matches!(
            refused,
            NotifyingError::Notifier(PipelineError::InvalidParameter {
                name: "set_points",
                ..
            })
        ));
        assert_eq!(robot.robot.sent, vec![vec![1500.0]], "not sent");
        assert_eq!(p.offsets(), vec![Some([0.0, 0.0])]);
        robot.command(&[1900.0]).unwrap();
        assert_eq!(p.offsets(), vec![None], "a 400 µs move restarts the track");
        assert!(matches!(robot.capture(), Err(NotifyingError::Robot(_))));
    }
}
