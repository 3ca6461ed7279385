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
//! - [`silhouette`]: the recogniser the servo pipeline uses ([`TipModel`]): the static scene
//!   learned from frames of random poses, the arm's silhouette in one new image, the end of
//!   the chain (told by gripper moves) and the tip at sub-pixel precision by a [`TipRule`].
//! - `end_face`: the middle of the end face from the outline of the far end (sub-pixel level
//!   crossings, convex hull, the far cap's outer corners), for [`TipRule::EndFace`].
//! - [`tip_correction`]: the [`TipRule::Learned`] tip, the far end corrected by an offset
//!   learned from the end-face rule at random poses (kernel regression on all cameras' far ends).
//! - [`model`]: the channel-coded appearance model learned from those regions (prototype feature maps around
//!   the gripper point) and its localisation in a new image with a certainty.

pub mod change;
mod end_face;
pub mod features;
pub mod image;
mod lighting;
pub mod model;
pub mod silhouette;
pub mod tip_correction;

pub use model::{GripperModel, Localisation, RecognitionConfig, TrainingView};
pub use silhouette::{EndEstimate, SilhouetteConfig, SilhouetteReport, TipModel, TipRule};
pub use tip_correction::{CorrectionReport, CorrectionSample, TipCorrection};
