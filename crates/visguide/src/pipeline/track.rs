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
/// the tracker learned restarts the tracks from the votes.
#[derive(Debug)]
pub struct MoveNotifier {
    state: Shared,
    motion: Option<Arc<MotionModel>>,
    reset_us: f64,
    last: Option<Vec<f64>>,
    /// The forward model's prediction at `last`.
    last_predicted: Option<Vec<[f64; 2]>>,
}

impl MoveNotifier {
    /// A command was sent (the full set-points, as the robot was given them).
    pub fn commanded(&mut self, set_points: &[f64]) {
        let predicted = self
            .motion
            .as_ref()
            .and_then(|m| m.predict(set_points).ok().flatten());
        // `g(y') − g(y)`, as `MotionModel::shift`, with `g(y)` kept from the last command.
        let shift = match (&self.last_predicted, &predicted) {
            (Some(a), Some(b)) => Some(MotionModel::difference(a, b)),
            _ => None,
        };
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

/// A robot whose accepted commands are told to a [`MoveNotifier`].
#[derive(Debug)]
pub struct Notifying<R> {
    /// The robot.
    pub robot: R,
    /// The recogniser's handle.
    pub notifier: MoveNotifier,
}

impl<R: Robot> Robot for Notifying<R> {
    type Error = R::Error;
    fn num_servos(&self) -> usize {
        self.robot.num_servos()
    }
    fn servo_range(&self, i: usize) -> [f64; 2] {
        self.robot.servo_range(i)
    }
    fn command(&mut self, set_points: &[f64]) -> std::result::Result<(), R::Error> {
        self.robot.command(set_points)?;
        self.notifier.commanded(set_points);
        Ok(())
    }
    fn capture(&mut self) -> std::result::Result<Vec<GrayImage>, R::Error> {
        self.robot.capture()
    }
}

fn failed(camera: usize, certainty: f64, min: f64) -> ServoError {
    ServoError::RecognitionFailed {
        camera,
        certainty,
        min,
    }
}

fn check_images(
    images: &[GrayImage],
    shapes: &ShapeModel,
    size: [u32; 2],
) -> servo_loop::Result<()> {
    if images.len() != shapes.num_cameras() {
        return Err(ServoError::DimensionMismatch {
            what: "images",
            expected: shapes.num_cameras(),
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

impl Recogniser for FdRecogniser {
    fn num_cameras(&self) -> usize {
        self.shapes.num_cameras()
    }
    fn image_size(&self, _cam: usize) -> [u32; 2] {
        self.size
    }
    fn locate_all(&self, images: &[GrayImage]) -> servo_loop::Result<Vec<Localisation>> {
        // The settings are public fields: checked here, as the percept's input.
        self.config.validate().map_err(percept_error)?;
        check_images(images, &self.shapes, self.size)?;
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
    pub fn new(fd: FdRecogniser, model: CbtModel) -> Self {
        let n = fd.shapes.num_cameras();
        FdCbtRecogniser {
            fd,
            model,
            motion: None,
            prior: None,
            state: shared(n),
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
        // (a NaN kernel width on a restart), while the other cameras' tracks advanced.
        self.fd.config.validate().map_err(percept_error)?;
        check_images(images, &self.fd.shapes, self.fd.size)?;
        // The prediction at the last command: the prior's centre and the search windows'.
        let predicted = lock(&self.state).predicted.clone();
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
        FdCbtRecogniser::new(fd, model)
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
}
