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

use std::sync::{Arc, Mutex};

use cbt_tracker::{
    CbtConfig, CbtModel, CbtTracker, Detection, Frame, Layout, Scales, Sequence, Space, Tracker,
};
use image::GrayImage;
use servo_loop::{Localisation, Recogniser, Robot, ServoError};

use super::error::{PipelineError, Result};
use super::shapes::ShapeModel;
use super::vote::{Vote, mode};

/// Settings of the percepts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PerceptConfig {
    /// Kernel width of the vote mode (pixels).
    pub mode_sigma_px: f64,
    /// A track starts on a vote mode at least this certain.
    pub start_certainty: f64,
    /// Below this certainty of the tracker the track is started again from the votes.
    pub lost_certainty: f64,
}

impl PerceptConfig {
    /// Checks the settings: `mode_sigma_px` finite and positive, both certainties in `[0, 1]`.
    /// (A NaN or zero kernel width made every frame's mode empty, so nothing was ever
    /// recognised.)
    pub fn validate(&self) -> Result<()> {
        let bad = |name: &'static str, value: f64, range: &str| {
            Err(PipelineError::InvalidParameter {
                name,
                reason: format!("{value} must lie in {range}"),
            })
        };
        if !(self.mode_sigma_px.is_finite() && self.mode_sigma_px > 0.0) {
            return bad("mode_sigma_px", self.mode_sigma_px, "(0, ∞)");
        }
        for (name, v) in [
            ("start_certainty", self.start_certainty),
            ("lost_certainty", self.lost_certainty),
        ] {
            if !(0.0..=1.0).contains(&v) {
                return bad(name, v, "[0, 1]");
            }
        }
        Ok(())
    }
}

impl Default for PerceptConfig {
    fn default() -> Self {
        PerceptConfig {
            mode_sigma_px: 2.0,
            start_certainty: 0.3,
            lost_certainty: 0.05,
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

fn forget(tracks: &Mutex<Vec<Option<CbtTracker>>>) {
    let mut t = tracks.lock().unwrap_or_else(|p| p.into_inner());
    t.iter_mut().for_each(|x| *x = None);
}

/// Tells an [`FdCbtRecogniser`] of the commanded moves: the one use this pipeline makes of the
/// known command (a move larger than the tracker learned restarts the tracks from the votes).
#[derive(Debug)]
pub struct MoveNotifier {
    tracks: Arc<Mutex<Vec<Option<CbtTracker>>>>,
    reset_us: f64,
    last: Option<Vec<f64>>,
}

impl MoveNotifier {
    /// A command was sent.
    pub fn commanded(&mut self, set_points: &[f64]) {
        let far = self.last.as_ref().is_none_or(|l| {
            l.len() != set_points.len()
                || l.iter()
                    .zip(set_points)
                    .any(|(a, b)| (a - b).abs() > self.reset_us)
        });
        if far {
            forget(&self.tracks);
        }
        self.last = Some(set_points.to_vec());
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

fn votes_of(shapes: &ShapeModel, cam: usize, img: &GrayImage) -> servo_loop::Result<Vec<Vote>> {
    shapes
        .votes(cam, img)
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
        check_images(images, &self.shapes, self.size)?;
        images
            .iter()
            .enumerate()
            .map(|(cam, img)| {
                let votes = votes_of(&self.shapes, cam, img)?;
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
    tracks: Arc<Mutex<Vec<Option<CbtTracker>>>>,
}

impl FdCbtRecogniser {
    /// The percept with `model` learned by [`learn_tracker`]; no track yet.
    pub fn new(fd: FdRecogniser, model: CbtModel) -> Self {
        let n = fd.shapes.num_cameras();
        FdCbtRecogniser {
            fd,
            model,
            tracks: Arc::new(Mutex::new(vec![None; n])),
        }
    }

    /// The tracker's learned model.
    pub fn model(&self) -> &CbtModel {
        &self.model
    }

    /// Forgets every track (the next frame starts them from the votes).
    pub fn reset(&self) {
        forget(&self.tracks);
    }

    /// A handle that forgets the tracks when a commanded move exceeds `reset_us` on any servo
    /// (see [`Notifying`]): the tracker's learned motion covers small moves only.
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
            tracks: Arc::clone(&self.tracks),
            reset_us,
            last: None,
        })
    }

    /// One camera's step: start (or restart) from the vote mode, or track.
    fn step(
        &self,
        cam: usize,
        votes: &[Vote],
        track: &mut Option<CbtTracker>,
    ) -> servo_loop::Result<Localisation> {
        let cfg = &self.fd.config;
        let start = |track: &mut Option<CbtTracker>| -> servo_loop::Result<Localisation> {
            *track = None;
            let m = mode(votes, cfg.mode_sigma_px)
                .map_err(percept_error)?
                .ok_or(failed(cam, 0.0, cfg.start_certainty))?;
            if m.certainty < cfg.start_certainty {
                return Err(failed(cam, m.certainty, cfg.start_certainty));
            }
            let mut t = CbtTracker::new(self.model.clone());
            t.reset(m.position)
                .map_err(|e| ServoError::InvalidParameter {
                    name: "tracker",
                    reason: e.to_string(),
                })?;
            *track = Some(t);
            Ok(Localisation {
                position: m.position,
                certainty: m.certainty,
            })
        };
        let Some(t) = track.as_mut() else {
            return start(track);
        };
        let e = t
            .step(&detections(votes))
            .map_err(|e| ServoError::InvalidParameter {
                name: "tracker",
                reason: e.to_string(),
            })?;
        let certainty = e.certainty.unwrap_or(0.0).clamp(0.0, 1.0);
        if certainty < cfg.lost_certainty {
            return start(track);
        }
        Ok(Localisation {
            position: e.position,
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
        check_images(images, &self.fd.shapes, self.fd.size)?;
        let votes: Vec<Vec<Vote>> = images
            .iter()
            .enumerate()
            .map(|(cam, img)| votes_of(&self.fd.shapes, cam, img))
            .collect::<servo_loop::Result<_>>()?;
        let mut tracks = self.tracks.lock().unwrap_or_else(|p| p.into_inner());
        let mut out = Vec::with_capacity(votes.len());
        for (cam, v) in votes.iter().enumerate() {
            out.push(self.step(cam, v, &mut tracks[cam])?);
        }
        Ok(out)
    }
}
