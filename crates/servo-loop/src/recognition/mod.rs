//! Gripper recognition learned from action (Paper C; docs/methods.md § Servoing).
//!
//! - [`image`]: grey images to half-resolution float images, and the raster steps of the
//!   silhouette (box smoothing, largest 8-connected component).
//! - `lighting`: the gain-and-gradient lighting model `I ≈ B (a + b u' + c v')` and its robust fit.
//! - [`features`]: the channel-coded feature map (CCFM) of an image: a soft histogram over
//!   (column, row, gradient orientation), weighted by a saturated gradient magnitude, with
//!   quadratic B-spline spatial channels and cyclic cos² orientation channels (chan-repr).
//! - [`change`]: the changed region between two images (the fingers, when only the gripper
//!   servo moved) and its robust centroid, the gripper point.
//! - [`silhouette`]: how the servo pipeline's recogniser works (module docs), the arm's
//!   silhouette in one image and the end analysis; [`scene`](CameraScene): one camera's learned
//!   static scene, the chain's root and the gripper end's size; [`tip_rule`]: which point of the
//!   far end is the tip ([`TipRule`], [`EndEstimate`]); [`tip_model`]: the model type
//!   ([`TipModel`]), its settings and report.
//! - `end_face`: the middle of the end face from the outline of the far end (sub-pixel level
//!   crossings, convex hull, the far cap's outer corners), for [`TipRule::EndFace`].
//! - [`tip_correction`]: the [`TipRule::Learned`] tip, the far end corrected by an offset
//!   learned from the end-face rule at random poses (kernel regression on all cameras' far ends).
//! - [`epipolar`]: consistency between cameras, the fundamental matrix learned from the
//!   learner's own percepts (normalised 8-point in RANSAC) and a pair's consistency.
//! - [`ccfm`]: the channel-coded feature map model ([`GripperModel`]) learned from those regions
//!   (prototype feature maps around the gripper point) and its localisation in a new image with
//!   a certainty; it stands aside from the servo path (the servo percept is [`TipModel`]).
//!
//! The types every recogniser shares, [`Localisation`] and [`TrainingView`], live here.

pub mod ccfm;
pub mod change;
mod end_face;
pub mod epipolar;
pub mod features;
pub mod image;
mod lighting;
mod scene;
pub mod silhouette;
pub mod tip_correction;
pub mod tip_model;
pub mod tip_rule;

pub use ccfm::{GripperModel, RecognitionConfig};
pub use epipolar::{EpipolarGeometry, EpipolarReport};
pub use scene::CameraScene;
pub use tip_correction::{CorrectionReport, CorrectionSample, TipCorrection};
pub use tip_model::{SilhouetteConfig, SilhouetteReport, TipModel};
pub use tip_rule::{EndEstimate, TipRule};

use ::image::GrayImage;
use serde::{Deserialize, Serialize};

/// Where the gripper was found.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Localisation {
    /// The gripper point, full-resolution pixels `[u, v]`.
    pub position: [f64; 2],
    /// Certainty in `[0, 1]` (e.g. the normalised cross-correlation of the `ccfm` model, the coverage and
    /// cross-camera consistency of the silhouette rules).
    pub certainty: f64,
}

/// One training view: the same pose seen with the gripper open and closed, one image per
/// camera each.
#[derive(Debug, Clone)]
pub struct TrainingView {
    /// Images with the gripper in its first state.
    pub before: Vec<GrayImage>,
    /// Images after only the gripper servo moved.
    pub after: Vec<GrayImage>,
}

/// The percept seam: anything that finds the gripper point in one image per camera, each with
/// a certainty in `[0, 1]`. [`crate::VisualPlant`] and the learning and servo loops see a
/// recogniser only through this trait, so a user's own detector plugs in without touching
/// them; [`TipModel`] (the learned silhouette recogniser, with its cross-camera consistency)
/// is the default.
pub trait Recogniser {
    /// Number of cameras (images per call of [`Recogniser::locate_all`]).
    fn num_cameras(&self) -> usize;
    /// Image size `[width, height]` of camera `cam` (the percept bounds of a visual plant).
    fn image_size(&self, cam: usize) -> [u32; 2];
    /// Whether the recogniser can locate at all (e.g. everything it needs was learned).
    fn check_ready(&self) -> crate::Result<()> {
        Ok(())
    }
    /// The gripper point in every camera's image (one image per camera, in camera order),
    /// each with its certainty. A recogniser that finds nothing returns
    /// [`crate::ServoError::RecognitionFailed`]; a found point it doubts is returned with a
    /// low certainty (the plant refuses it below its threshold).
    fn locate_all(&self, images: &[::image::GrayImage]) -> crate::Result<Vec<Localisation>>;
}

impl Recogniser for TipModel {
    fn num_cameras(&self) -> usize {
        TipModel::num_cameras(self)
    }
    fn image_size(&self, cam: usize) -> [u32; 2] {
        self.camera(cam)
            .map_or([0, 0], |c| [c.width() as u32, c.height() as u32])
    }
    fn check_ready(&self) -> crate::Result<()> {
        TipModel::check_ready(self)
    }
    fn locate_all(&self, images: &[::image::GrayImage]) -> crate::Result<Vec<Localisation>> {
        TipModel::locate_all(self, images)
    }
}
