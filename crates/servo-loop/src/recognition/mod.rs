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
//! - [`cross_camera`]: every camera's tip chosen among its candidates (the rule's tip, the
//!   end-face tip) by that consistency ([`choose_consistent`]).
//! - [`ccfm`]: the channel-coded feature map model ([`GripperModel`]) learned from those regions
//!   (prototype feature maps around the gripper point) and its localisation in a new image with
//!   a certainty; it stands aside from the servo path (the servo percept is [`TipModel`]).
//!
//! The types every recogniser shares, [`Localisation`] and [`TrainingView`], live here.

pub mod ccfm;
pub mod change;
pub mod cross_camera;
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
pub use cross_camera::{PairChoice, choose_consistent};
pub use epipolar::{EpipolarGeometry, EpipolarReport};
pub use scene::CameraScene;
pub use tip_correction::{CorrectedTip, CorrectionReport, CorrectionSample, TipCorrection};
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

/// Checks a set of training views before a model learns from it (shared by
/// [`GripperModel::learn`] and [`TipModel::learn`]): at least one view, at least one camera
/// image in the first view, every view with that many images in both states, and each
/// camera's images all of one size. Returns each camera's image size `[width, height]`.
pub(crate) fn training_image_sizes(views: &[TrainingView]) -> crate::Result<Vec<[u32; 2]>> {
    let first = views
        .first()
        .ok_or_else(|| crate::ServoError::NotEnoughData("no training views".into()))?;
    let cams = first.before.len();
    if cams == 0 {
        return Err(crate::ServoError::NotEnoughData(
            "training views without camera images".into(),
        ));
    }
    let sizes: Vec<[u32; 2]> = first
        .before
        .iter()
        .map(|i| [i.width(), i.height()])
        .collect();
    for view in views {
        for images in [&view.before, &view.after] {
            if images.len() != cams {
                return Err(crate::ServoError::DimensionMismatch {
                    what: "camera images per training view",
                    expected: cams,
                    got: images.len(),
                });
            }
            if images
                .iter()
                .zip(&sizes)
                .any(|(i, s)| [i.width(), i.height()] != *s)
            {
                return Err(crate::ServoError::InvalidParameter {
                    name: "views",
                    reason: "a camera's training images differ in size".into(),
                });
            }
        }
    }
    Ok(sizes)
}

/// What a percept is for: the learner's training moves or the servo loop's corrections (and
/// everything the servo acts on: targets, recognition checks). A recogniser may doubt the two
/// differently: the learned tip's spread cap ([`SilhouetteConfig::spread_scale`]) can be left
/// off training moves ([`SilhouetteConfig::cap_training`]), where a refused percept only
/// leaves a hole in the learned model, while the servo never moves on an uncertain one.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PerceptUse {
    /// A percept the servo loop acts on (the default).
    #[default]
    Servo,
    /// A training move's percept (the learner pairs it with its command).
    Training,
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
    /// As [`Recogniser::locate_all`], for a percept of the given use ([`PerceptUse`]; a
    /// [`crate::VisualPlant`] passes its policy's). The default ignores the use.
    fn locate_all_for(
        &self,
        images: &[::image::GrayImage],
        used: PerceptUse,
    ) -> crate::Result<Vec<Localisation>> {
        let _ = used;
        self.locate_all(images)
    }
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
    fn locate_all_for(
        &self,
        images: &[::image::GrayImage],
        used: PerceptUse,
    ) -> crate::Result<Vec<Localisation>> {
        TipModel::locate_all_for(self, images, used)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ServoError;

    fn view(sizes: &[(u32, u32)], after: &[(u32, u32)]) -> TrainingView {
        let imgs = |s: &[(u32, u32)]| s.iter().map(|&(w, h)| GrayImage::new(w, h)).collect();
        TrainingView {
            before: imgs(sizes),
            after: imgs(after),
        }
    }

    /// Both learners open with the same checks, so the same bad views give the same error.
    fn both_refuse(views: &[TrainingView]) -> ServoError {
        let a = training_image_sizes(views).unwrap_err();
        let g = GripperModel::learn(&RecognitionConfig::default(), views).unwrap_err();
        let t = TipModel::learn(&SilhouetteConfig::default(), views).unwrap_err();
        assert_eq!(a.to_string(), g.to_string());
        assert_eq!(a.to_string(), t.to_string());
        a
    }

    #[test]
    fn training_views_are_checked_in_one_place() {
        let two = [(32, 24), (40, 30)];
        assert_eq!(
            training_image_sizes(&[view(&two, &two), view(&two, &two)]).unwrap(),
            vec![[32, 24], [40, 30]]
        );
        assert!(matches!(both_refuse(&[]), ServoError::NotEnoughData(_)));
        assert!(matches!(
            both_refuse(&[view(&[], &[])]),
            ServoError::NotEnoughData(_)
        ));
        assert!(matches!(
            both_refuse(&[view(&two, &two), view(&two, &two[..1])]),
            ServoError::DimensionMismatch {
                expected: 2,
                got: 1,
                ..
            }
        ));
        assert!(matches!(
            both_refuse(&[view(&two, &two), view(&two, &[(32, 24), (40, 31)])]),
            ServoError::InvalidParameter { name: "views", .. }
        ));
        // The feature-map model also needs one size for all cameras.
        assert!(matches!(
            GripperModel::learn(&RecognitionConfig::default(), &[view(&two, &two)]),
            Err(ServoError::InvalidParameter { name: "views", .. })
        ));
    }
}
