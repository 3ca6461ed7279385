//! The gripper's shape model: Fourier descriptors (Paper A, crate `fd-match`) of the MSER
//! regions that change when the gripper moves, per camera, each with the offset from its
//! centre to the tip, and descriptors of the regions that do not change (the background the
//! ratio test compares against).
//!
//! **Learning by action** ([`ShapeModel::learn`]): for each training pose the arm is seen with
//! the gripper at its servoing set-point (`rest`) and again after only the gripper servo moved
//! (`moved`). A region of `rest` is *unchanged* when `moved` has a region of the same polarity
//! with its centroid within `same_px` and its area within a factor `1 ± same_area`; otherwise
//! it changed with the action. A changed region whose centre lies within `reach_px` of the
//! heuristic percept of the same capture (servo-loop's learned silhouette tip, the only tip the
//! learner has; no ground truth) is a gripper view: its contour, centre, area and the offset
//! `o = tip − centre` are stored. Changed regions farther away (something else moved, e.g. a
//! distractor) are dropped, and so is a near one that at least two other captures (the arm
//! elsewhere) show unchanged at the same place (a scene region that flickered with noise or
//! light); unchanged ones become the background set (at most `max_background` per camera,
//! evenly subsampled).
//!
//! **Recognition** ([`ShapeModel::votes`]): MSER → outer contours → FDs (affine arc length,
//! 51 coefficients) → for each region the best gripper view by FD correlation (eq. 10) with
//! its rotation φ (eq. 12), and the best background region *of the region's size*. The ratio
//! test (eq. 19) takes that background region as the second-best: `r = e_grip / e_background <
//! T_r` (the gripper's several views of one part are all near each other, so Paper A's
//! second-best among them would refuse every true match). A region whose best match is within
//! `max_error` votes once per stored view `j` within `view_error_factor` of its best error
//! (`e_j ≤ f · e_best`) that passes the tests itself: for the tip at `c + s · R(−φ_j) o_j` (`c`
//! the region's centre, `s = √(area / area_j)`, `R(−φ_j)` the rotation back from the view to
//! this region), with weight `(1 − r_j / T_r) / (1 + |o_j| / d₀)`; views with `|φ_j|` above
//! `max_rotation` are dropped (the gripper's boxy parts are nearly point-symmetric: their φ is
//! ambiguous by π, and the stored views already cover the poses), and so are views of another
//! size, `s` outside `[1 / m, m]` with `m = max_scale` (1.25). Voting with the near-best views
//! rather than the best one alone is a generalised Hough transform: the contour of a boxy part
//! says little about where on the gripper it is, so the single best view's offset is often
//! another part's or another pose's (development seed 101: the gripper regions' votes were
//! 11–17 px off in the median, although some stored view's offset fitted within 1.5–1.7 px;
//! docs/methods.md); the near-best views of the frame's several regions agree mostly at the tip.
//!
//! **Size-aware matching** ([`ShapeConfig::max_scale`]): FDs are normalised for scale, so by
//! shape alone a small boxy background region competes with a gripper part of any size, and a
//! view stored at one size votes for a region of any other size with its offset scaled to fit.
//! The gripper's size in an image changes little over the workspace, so both the votes and the
//! ratio test's competitor are limited to regions within a factor `m` in linear size (a
//! background region "of the region's size" is one whose scale against it lies in `[1/m, m]`;
//! an infinite `m` matches by shape only, as before). With a finite `m` the best view overall
//! need not pass the ratio test (it may be of another size); every voting view still must.
//! Adopted by a rule on development seeds 119–122 (docs/methods.md, *Size-aware matching*).
//!
//! **Within a polarity** ([`ShapeConfig::same_polarity`]): MSER tells whether a region is
//! darker or brighter than its surround, and a gripper part keeps that as it moves, so a view
//! votes only for regions of its own polarity, and the ratio test's competitor is the best
//! background region of the region's polarity (and size): a dark background region shaped
//! like a bright gripper part neither votes as that part nor refuses it. Adopted by a rule on
//! development seeds 134–137 (docs/methods.md, *Matching within a polarity*).
//!
//! **In a window** ([`ShapeModel::votes_in`]): the same on the regions MSER finds in a window of
//! the image ([`super::window`]), dropping those that touch one of its edges inside the image;
//! the votes are in the image's coordinates. [`ShapeModel::reach`], the farthest contour pixel
//! of any stored view from its training tip, bounds how far from the tip it votes for a region
//! seen again as one of the views lies.

use fd_match::{DescriptorConfig, DescriptorSet, Method, Sampling, best_two};
use image::GrayImage;
use mser::{BoundingBox, GrayView, MserParams, Polarities};
use serde::{Deserialize, Serialize};

use super::error::{PipelineError, Result};
use super::vote::Vote;
use super::window::SearchWindow;
use crate::features::{Features, detect, detect_view};

/// Settings of the shape model.
#[derive(Debug, Clone, PartialEq)]
pub struct ShapeConfig {
    /// MSER parameters (both polarities; areas sized for the gripper's parts).
    pub mser: MserParams,
    /// Ratio threshold `T_r` of `e_grip / e_background` (Paper A: 0.5).
    pub ratio_threshold: f64,
    /// Largest accepted FD correlation error against the gripper views (eq. 10, in `[0, 2]`).
    pub max_error: f64,
    /// A changed region within this distance (px) of the training percept is a gripper view.
    pub reach_px: f64,
    /// Unchanged: a region of the other capture with its centroid this close (px)…
    pub same_px: f64,
    /// …and its area within `1 ± same_area` of this one's.
    pub same_area: f64,
    /// Background regions kept per camera.
    pub max_background: usize,
    /// Largest accepted rotation |φ| between a stored view and a region (radians): the
    /// stored views already cover the poses, and the gripper's boxy parts are nearly
    /// point-symmetric, so a large φ is usually the π-ambiguity of a symmetric contour.
    pub max_rotation: f64,
    /// Offset scale `d₀` (px): a vote's weight is divided by `1 + |o| / d₀` (a region far from
    /// the tip carries its rotation and scale errors over a longer lever).
    pub offset_scale_px: f64,
    /// A region votes with every view whose error is at most this factor times its best
    /// view's (≥ 1; 1 votes with the best view only).
    pub view_error_factor: f64,
    /// Size-aware matching (≥ 1; default 1.25; infinite: by shape only): a view votes for a
    /// region only when the region's linear scale against it, `s = √(area / area_j)`, lies
    /// within `[1 / max_scale, max_scale]`, and the ratio test's background competitor is the
    /// best background region whose scale against the region lies in the same range.
    pub max_scale: f64,
    /// Matching within a polarity (default on; off: by shape and size only): a view votes for
    /// a region only when both are of one MSER polarity (darker or brighter than their
    /// surround), and the ratio test's background competitor is the best background region of
    /// the region's polarity (and size).
    pub same_polarity: bool,
}

impl Default for ShapeConfig {
    fn default() -> Self {
        ShapeConfig {
            mser: MserParams {
                min_area: 40,
                max_area: 6000,
                polarities: Polarities::Both,
                ..MserParams::default()
            },
            ratio_threshold: 0.5,
            max_error: 0.3,
            reach_px: 70.0,
            same_px: 1.5,
            same_area: 0.1,
            max_background: 600,
            max_rotation: 0.6,
            offset_scale_px: 20.0,
            view_error_factor: 3.0,
            max_scale: 1.25,
            same_polarity: true,
        }
    }
}

impl ShapeConfig {
    /// Checks every setting's range.
    pub fn validate(&self) -> Result<()> {
        let bad = |name: &'static str, reason: &str| {
            Err(PipelineError::InvalidParameter {
                name,
                reason: reason.into(),
            })
        };
        self.mser
            .validate()
            .map_err(|e| PipelineError::InvalidParameter {
                name: "mser",
                reason: e.to_string(),
            })?;
        if !(self.ratio_threshold > 0.0 && self.ratio_threshold <= 1.0) {
            return bad("ratio_threshold", "must lie in (0, 1]");
        }
        if !(self.max_error > 0.0 && self.max_error <= 2.0) {
            return bad("max_error", "must lie in (0, 2]");
        }
        if !(self.view_error_factor.is_finite() && self.view_error_factor >= 1.0) {
            return bad("view_error_factor", "must be finite and ≥ 1");
        }
        if self.max_scale.is_nan() || self.max_scale < 1.0 {
            return bad("max_scale", "must be ≥ 1 (infinite: off)");
        }
        for (name, v) in [
            ("max_rotation", self.max_rotation),
            ("offset_scale_px", self.offset_scale_px),
            ("reach_px", self.reach_px),
            ("same_px", self.same_px),
            ("same_area", self.same_area),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return bad(name, "must be finite and > 0");
            }
        }
        Ok(())
    }
}

/// One stored gripper view: a region that changed with the gripper, near the tip.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GripperView {
    /// Its outer contour.
    pub contour: Vec<(u32, u32)>,
    /// Its area (pixels).
    pub area: f64,
    /// The tip minus its centre (pixels), in the training image.
    pub offset: [f64; 2],
    /// Whether the region is brighter than its surround (MSER's bright polarity).
    pub bright: bool,
}

/// One camera's part of the model.
#[derive(Debug, Clone)]
struct CameraShapes {
    views: Vec<GripperView>,
    grip: DescriptorSet,
    background: DescriptorSet,
    /// Per background descriptor, its region's area (for the size-aware ratio test,
    /// [`ShapeConfig::max_scale`]).
    background_area: Vec<f64>,
    /// The background descriptors' indices by ascending area (ties by index).
    background_by_area: Vec<usize>,
    /// Per background descriptor, whether its region is of the bright polarity.
    background_bright: Vec<bool>,
    /// The farthest contour pixel of any stored view from its training tip (px).
    reach: f64,
    /// Width and height of the camera's training captures (px).
    size: [u32; 2],
}

/// One training capture of one camera: the gripper at its servoing set-point, the same pose
/// after only the gripper moved, and the heuristic tip on the first (if it found one).
#[derive(Debug, Clone, Copy)]
pub struct ActionPair<'a> {
    /// Camera index.
    pub camera: usize,
    /// The gripper at its servoing set-point.
    pub rest: &'a GrayImage,
    /// After only the gripper servo moved.
    pub moved: &'a GrayImage,
    /// The heuristic percept's tip on `rest`.
    pub tip: Option<[f64; 2]>,
}

/// What learning found, per camera.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ShapeReport {
    /// Gripper views stored.
    pub views: Vec<usize>,
    /// Changed regions dropped because they lay far from the percept.
    pub far_changes: Vec<usize>,
    /// Background regions kept (after subsampling).
    pub background: Vec<usize>,
    /// Changed regions near the tip dropped because at least two other captures show them
    /// unchanged at the same place (scene regions that flickered).
    pub static_dropped: Vec<usize>,
}

/// The gripper shape model of every camera.
#[derive(Debug, Clone)]
pub struct ShapeModel {
    config: ShapeConfig,
    cameras: Vec<CameraShapes>,
}

fn descriptor_config() -> DescriptorConfig {
    DescriptorConfig::with_sampling(Sampling::AffineArcLength)
}

fn centre(f: &Features, i: usize) -> [f64; 2] {
    [f.frames[i].u, f.frames[i].v]
}

/// An unchanged region of a training capture (a background region).
#[derive(Debug, Clone, Copy)]
struct Unchanged {
    capture: usize,
    centre: [f64; 2],
    area: f64,
    /// Of the bright polarity.
    bright: bool,
}

/// Whether region `i` is of the bright polarity.
fn bright(f: &Features, i: usize) -> bool {
    f.regions[i].polarity == mser::Polarity::Bright
}

impl ShapeModel {
    /// Learns the model from action pairs of `cameras` cameras (see the module docs); it keeps
    /// each camera's image size ([`Self::image_size`]).
    /// Errors: an invalid configuration, a camera index out of range, a pair whose `rest` and
    /// `moved` differ in size, pairs of one camera of different sizes
    /// ([`PipelineError::InvalidParameter`]), fewer pairs than cameras,
    /// or a camera left without any gripper view or background region
    /// ([`PipelineError::NotEnoughData`]).
    pub fn learn(
        config: &ShapeConfig,
        cameras: usize,
        pairs: &[ActionPair<'_>],
    ) -> Result<(ShapeModel, ShapeReport)> {
        config.validate()?;
        if cameras == 0 {
            return Err(PipelineError::InvalidParameter {
                name: "cameras",
                reason: "need at least one".into(),
            });
        }
        // Every camera needs a pair (else it has no view): checked before anything is sized by
        // `cameras` (a huge count used to panic allocating the per-camera lists).
        if cameras > pairs.len() {
            return Err(PipelineError::NotEnoughData(format!(
                "{cameras} cameras, {} action pairs",
                pairs.len()
            )));
        }
        // A pair's captures are compared pixel by pixel: of another size, every region would
        // look changed (they used to be learned as gripper views).
        if let Some((k, p)) = pairs
            .iter()
            .enumerate()
            .find(|(_, p)| p.rest.dimensions() != p.moved.dimensions())
        {
            return Err(PipelineError::InvalidParameter {
                name: "pairs",
                reason: format!(
                    "pair {k}: rest is {}×{} px, moved {}×{}",
                    p.rest.width(),
                    p.rest.height(),
                    p.moved.width(),
                    p.moved.height()
                ),
            });
        }
        // One image size per camera: its views' offsets and reach are in its pixels.
        let mut sizes: Vec<Option<[u32; 2]>> = vec![None; cameras];
        for (k, p) in pairs.iter().enumerate() {
            let Some(size) = sizes.get_mut(p.camera) else {
                continue; // refused below, with the camera's index
            };
            let this = [p.rest.width(), p.rest.height()];
            match *size {
                Some(first) if first != this => {
                    return Err(PipelineError::InvalidParameter {
                        name: "pairs",
                        reason: format!(
                            "pair {k}: camera {} captures {}×{} px, its first pair {}×{}",
                            p.camera, this[0], this[1], first[0], first[1]
                        ),
                    });
                }
                Some(_) => {}
                None => *size = Some(this),
            }
        }
        let mut views: Vec<Vec<GripperView>> = vec![Vec::new(); cameras];
        // Per candidate view: its capture, centre and area (for the static check below).
        let mut placed: Vec<Vec<(usize, [f64; 2])>> = vec![Vec::new(); cameras];
        let mut background: Vec<Vec<Vec<(u32, u32)>>> = vec![Vec::new(); cameras];
        let mut still: Vec<Vec<Unchanged>> = vec![Vec::new(); cameras];
        let mut report = ShapeReport {
            views: vec![0; cameras],
            far_changes: vec![0; cameras],
            background: vec![0; cameras],
            static_dropped: vec![0; cameras],
        };
        for (capture, p) in pairs.iter().enumerate() {
            if p.camera >= cameras {
                return Err(PipelineError::InvalidParameter {
                    name: "camera",
                    reason: format!("camera {} of {cameras}", p.camera),
                });
            }
            let (rest, moved) = (
                detect(p.rest, &config.mser)?,
                detect(p.moved, &config.mser)?,
            );
            for i in 0..rest.len() {
                let c = centre(&rest, i);
                let area = f64::from(rest.regions[i].area);
                let unchanged = (0..moved.len()).any(|j| {
                    let d = centre(&moved, j);
                    rest.regions[i].polarity == moved.regions[j].polarity
                        && (c[0] - d[0]).hypot(c[1] - d[1]) <= config.same_px
                        && (f64::from(moved.regions[j].area) / area - 1.0).abs() <= config.same_area
                });
                if unchanged {
                    background[p.camera].push(rest.contours[i].clone());
                    still[p.camera].push(Unchanged {
                        capture,
                        centre: c,
                        area,
                        bright: bright(&rest, i),
                    });
                    continue;
                }
                match p.tip {
                    Some(t) if (t[0] - c[0]).hypot(t[1] - c[1]) <= config.reach_px => {
                        placed[p.camera].push((capture, c));
                        views[p.camera].push(GripperView {
                            contour: rest.contours[i].clone(),
                            area,
                            offset: [t[0] - c[0], t[1] - c[1]],
                            bright: bright(&rest, i),
                        });
                    }
                    _ => report.far_changes[p.camera] += 1,
                }
            }
        }
        // A "changed" region that other captures (the arm elsewhere) show unchanged at the same
        // place is part of the scene that flickered (noise, lighting), not the gripper.
        let mut reach = vec![0.0_f64; cameras];
        for cam in 0..cameras {
            let keep: Vec<bool> = views[cam]
                .iter()
                .zip(&placed[cam])
                .map(|(v, &(capture, c))| {
                    let elsewhere = still[cam]
                        .iter()
                        .filter(|u| {
                            let (k, d, a) = (u.capture, u.centre, u.area);
                            k != capture
                                && (c[0] - d[0]).hypot(c[1] - d[1]) <= 2.0 * config.same_px
                                && (a / v.area - 1.0).abs() <= 2.0 * config.same_area
                        })
                        .count();
                    elsewhere < 2
                })
                .collect();
            report.static_dropped[cam] = keep.iter().filter(|&&k| !k).count();
            for ((v, &(_, c)), _) in views[cam]
                .iter()
                .zip(&placed[cam])
                .zip(&keep)
                .filter(|(_, k)| **k)
            {
                let tip = [c[0] + v.offset[0], c[1] + v.offset[1]];
                for &(x, y) in &v.contour {
                    reach[cam] =
                        reach[cam].max((f64::from(x) - tip[0]).hypot(f64::from(y) - tip[1]));
                }
            }
            let mut k = keep.iter();
            views[cam].retain(|_| *k.next().expect("one flag per view"));
        }
        let mut out = Vec::with_capacity(cameras);
        for (cam, (v, bg)) in views.into_iter().zip(&background).enumerate() {
            // The background regions kept: all, or evenly subsampled to `max_background`.
            let n = bg.len();
            let kept: Vec<usize> = if n > config.max_background {
                // `k · n < n²`: no overflow below 2^32 background regions (regions in memory).
                (0..config.max_background)
                    .map(|k| k * n / config.max_background)
                    .collect()
            } else {
                (0..n).collect()
            };
            let grip = fd_match::describe_all(
                descriptor_config(),
                &v.iter().map(|g| g.contour.as_slice()).collect::<Vec<_>>(),
            )?
            .set;
            let background = fd_match::describe_all(
                descriptor_config(),
                &kept.iter().map(|&i| bg[i].as_slice()).collect::<Vec<_>>(),
            )?
            .set;
            let (Some(size), false) = (sizes[cam], grip.is_empty() || background.is_empty()) else {
                return Err(PipelineError::NotEnoughData(format!(
                    "camera {cam}: {} gripper views, {} background regions",
                    grip.len(),
                    background.len()
                )));
            };
            report.views[cam] = grip.len();
            report.background[cam] = background.len();
            let background_area: Vec<f64> = (0..background.len())
                .map(|d| still[cam][kept[background.source(d)]].area)
                .collect();
            let background_bright: Vec<bool> = (0..background.len())
                .map(|d| still[cam][kept[background.source(d)]].bright)
                .collect();
            let mut background_by_area: Vec<usize> = (0..background.len()).collect();
            background_by_area.sort_by(|&a, &b| {
                background_area[a]
                    .total_cmp(&background_area[b])
                    .then(a.cmp(&b))
            });
            out.push(CameraShapes {
                views: v,
                grip,
                background,
                background_area,
                background_by_area,
                background_bright,
                reach: reach[cam],
                size,
            });
        }
        Ok((
            ShapeModel {
                config: config.clone(),
                cameras: out,
            },
            report,
        ))
    }

    /// Number of cameras.
    pub fn num_cameras(&self) -> usize {
        self.cameras.len()
    }

    /// Width and height (px) of camera `cam`'s training captures, the images its views and
    /// offsets are measured in (`None` for an unknown camera).
    pub fn image_size(&self, cam: usize) -> Option<[u32; 2]> {
        self.cameras.get(cam).map(|c| c.size)
    }

    /// The settings it was learned with.
    pub fn config(&self) -> &ShapeConfig {
        &self.config
    }

    /// The stored gripper views of camera `cam` (empty for an unknown camera).
    pub fn views(&self, cam: usize) -> &[GripperView] {
        self.cameras.get(cam).map_or(&[], |c| &c.views)
    }

    /// The farthest contour pixel of any stored view of camera `cam` from its training tip
    /// (px; `None` for an unknown camera): a region seen again as one of the views, at scale
    /// `s` against it, lies within `s` times this of the tip it votes for.
    pub fn reach(&self, cam: usize) -> Option<f64> {
        self.cameras.get(cam).map(|c| c.reach)
    }

    /// The tip votes of one image of camera `cam` (module docs), each inside the image; an
    /// empty list when nothing matched. Errors as [`votes_in`](Self::votes_in)'s. The image
    /// may be of any size (a crop, say): the views' offsets are distances in pixels at the
    /// training captures' scale, whatever the image's size.
    pub fn votes(&self, cam: usize, img: &GrayImage) -> Result<Vec<Vote>> {
        Ok(self.votes_with_boxes(cam, img, None)?.0)
    }

    /// The votes of the regions found in `window` of the image alone ([`super::window`]: MSER
    /// runs on the window; a region touching one of its edges inside the image is dropped);
    /// with `None`, [`votes`](Self::votes). The votes' positions are the image's. Errors
    /// ([`PipelineError::InvalidParameter`]): an unknown camera, a window of another image
    /// size, or one that is not a non-empty part of the image.
    pub fn votes_in(
        &self,
        cam: usize,
        img: &GrayImage,
        window: Option<&SearchWindow>,
    ) -> Result<Vec<Vote>> {
        Ok(self.votes_with_boxes(cam, img, window)?.0)
    }

    /// The votes of [`votes_in`](Self::votes_in) and, per vote, its region's bounding box in
    /// the image's coordinates.
    pub(crate) fn votes_with_boxes(
        &self,
        cam: usize,
        img: &GrayImage,
        window: Option<&SearchWindow>,
    ) -> Result<(Vec<Vote>, Vec<BoundingBox>)> {
        let shapes = self
            .cameras
            .get(cam)
            .ok_or_else(|| PipelineError::InvalidParameter {
                name: "camera",
                reason: format!("camera {cam} of {}", self.cameras.len()),
            })?;
        if let Some(win) = window
            && win.size != [img.width(), img.height()]
        {
            return Err(PipelineError::InvalidParameter {
                name: "window",
                reason: format!(
                    "a window of a {}×{} image, the image is {}×{}",
                    win.size[0],
                    win.size[1],
                    img.width(),
                    img.height()
                ),
            });
        }
        // The window's fields are public: one inverted, empty or reaching past the image is
        // refused here (an inverted one used to panic computing its extent).
        if let Some(win) = window
            && !(win.x0 < win.x1
                && win.x1 <= win.size[0]
                && win.y0 < win.y1
                && win.y1 <= win.size[1])
        {
            return Err(PipelineError::InvalidParameter {
                name: "window",
                reason: format!(
                    "columns {}..{} and rows {}..{} are not a non-empty part of a {}×{} image",
                    win.x0, win.x1, win.y0, win.y1, win.size[0], win.size[1]
                ),
            });
        }
        let (mut features, origin) = match window.filter(|w| !w.is_whole()) {
            None => (detect(img, &self.config.mser)?, [0, 0]),
            Some(win) => {
                let [ew, eh] = win.extent();
                let view = GrayView::from_image(img)
                    .and_then(|v| {
                        v.window(win.x0 as usize, win.y0 as usize, ew as usize, eh as usize)
                    })
                    .map_err(|e| PipelineError::InvalidParameter {
                        name: "window",
                        reason: e.to_string(),
                    })?;
                (detect_view(&view, &self.config.mser)?, [win.x0, win.y0])
            }
        };
        // Back to the image's coordinates (the contours stay the window's: the descriptors
        // do not depend on position).
        if origin != [0, 0] {
            for (f, r) in features.frames.iter_mut().zip(&mut features.regions) {
                f.u += f64::from(origin[0]);
                f.v += f64::from(origin[1]);
                *r = r
                    .translated(origin[0], origin[1])
                    .map_err(crate::VisguideError::from)?;
            }
        }
        let used: Vec<usize> = (0..features.len())
            .filter(|&i| window.is_none_or(|w| w.keeps(&features.regions[i].bbox)))
            .collect();
        let set = fd_match::describe_all(
            descriptor_config(),
            &used
                .iter()
                .map(|&i| features.contours[i].as_slice())
                .collect::<Vec<_>>(),
        )?
        .set;
        let mut boxes = Vec::new();
        if set.is_empty() {
            return Ok((Vec::new(), boxes));
        }
        let grip = best_two(&set, &shapes.grip, Method::FdCorr)?;
        let bg = best_two(&set, &shapes.background, Method::FdCorr)?;
        let t_r = self.config.ratio_threshold;
        let (w, h) = (f64::from(img.width()), f64::from(img.height()));
        let mut votes = Vec::new();
        let dc = descriptor_config();
        let mut corr = fd_match::Correlator::new(dc.max_frequency(), dc.samples)?;
        let max_scale = self.config.max_scale;
        let sized = max_scale.is_finite();
        let polar = self.config.same_polarity;
        let less = |r: f64| r.partial_cmp(&t_r) == Some(std::cmp::Ordering::Less);
        // Per region: the views that may vote, `(view, error, rotation, scale)`.
        let mut candidates: Vec<(usize, f64, f64, f64)> = Vec::new();
        for (k, (g, b)) in grip.iter().zip(&bg).enumerate() {
            let Some(best) = g.best else { continue };
            if best.error > self.config.max_error {
                continue;
            }
            let region = used[set.source(k)];
            let c = centre(&features, region);
            let area = f64::from(features.regions[region].area);
            // Every view's error is at least the best one's, so a background error at or
            // below `e_best / T_r` fails them all: the region does not vote, and the sized
            // search may stop there.
            // With matching within a polarity, only views and background regions of the
            // region's polarity take part.
            let polarity = polar.then(|| bright(&features, region));
            let fits = |c: &fd_match::Candidate| {
                shapes.same_size(c.index, area, max_scale)
                    && polarity.is_none_or(|p| shapes.background_bright[c.index] == p)
            };
            let e_bg = match (b.best, b.second) {
                (None, _) => f64::INFINITY,
                // The best background region overall is the best of any subset holding it.
                (Some(c), _) if (!sized && !polar) || fits(&c) => c.error,
                // The best is of another size (or polarity) and the second fits: the second
                // is the best of the rest.
                (Some(_), Some(c)) if fits(&c) => c.error,
                _ => shapes.background_error(
                    &mut corr,
                    set.fd(k),
                    area,
                    max_scale,
                    polarity,
                    best.error / t_r,
                )?,
            };
            let ratio = |e: f64| if e_bg > 0.0 { e / e_bg } else { f64::INFINITY };
            if !less(ratio(best.error)) {
                continue;
            }
            // The views of the region's size within the factor of the best error, with a
            // rotation within the limit (the size is checked first: it needs no correlation);
            // a view above `T_r · e_bg` fails the ratio test, so the correlations stop there
            // (with a margin for rounding: the test below decides).
            let limit = (self.config.view_error_factor * best.error)
                .min(self.config.max_error)
                .min(t_r * e_bg * (1.0 + 1e-9));
            candidates.clear();
            for j in 0..shapes.grip.len() {
                let view = &shapes.views[shapes.grip.source(j)];
                let s = (area / view.area).sqrt();
                if !(s * max_scale >= 1.0 && s <= max_scale)
                    || polarity.is_some_and(|p| view.bright != p)
                {
                    continue;
                }
                let (error, rotation) = if j == best.index {
                    let Some(al) = best.alignment else { continue };
                    (best.error, al.rotation)
                } else {
                    match corr.correlate_below(set.fd(k), shapes.grip.fd(j), limit)? {
                        Some(cj) if cj.error <= limit => (cj.error, cj.alignment.rotation),
                        _ => continue,
                    }
                };
                if rotation.abs() <= self.config.max_rotation {
                    candidates.push((j, error, rotation, s));
                }
            }
            for &(j, error, rotation, s) in &candidates {
                let r = ratio(error);
                if !less(r) {
                    continue;
                }
                let [ox, oy] = shapes.views[shapes.grip.source(j)].offset;
                let (sn, cs) = (-rotation).sin_cos();
                let position = [
                    c[0] + s * (cs * ox - sn * oy),
                    c[1] + s * (sn * ox + cs * oy),
                ];
                // A tip voted outside the image is not a percept of this camera.
                if !(position[0] >= 0.0 && position[1] >= 0.0 && position[0] < w && position[1] < h)
                {
                    continue;
                }
                votes.push(Vote {
                    position,
                    weight: (1.0 - r / t_r).clamp(1e-6, 1.0)
                        / (1.0 + ox.hypot(oy) / self.config.offset_scale_px),
                    error,
                    rotation,
                    region: k,
                });
                boxes.push(features.regions[region].bbox);
            }
        }
        Ok((votes, boxes))
    }
}

impl CameraShapes {
    /// Whether background descriptor `d`'s scale against a region of `area` pixels lies within
    /// `[1 / max_scale, max_scale]`.
    fn same_size(&self, d: usize, area: f64, max_scale: f64) -> bool {
        let m2 = max_scale * max_scale;
        let a = self.background_area[d];
        a * m2 >= area && a <= area * m2
    }

    /// The smallest FD correlation error between `fd` (a region of `area` pixels) and the
    /// background regions whose linear scale against it lies within `[1 / max_scale,
    /// max_scale]` and, given a polarity (`bright`), of that polarity (infinite when there is
    /// none); or, as soon as one is found at or below `floor`, that one's error (the caller
    /// needs no more then).
    fn background_error(
        &self,
        corr: &mut fd_match::Correlator,
        fd: &[fd_match::Complex64],
        area: f64,
        max_scale: f64,
        bright: Option<bool>,
        floor: f64,
    ) -> Result<f64> {
        let (lo, hi) = (area / (max_scale * max_scale), area * max_scale * max_scale);
        let first = self
            .background_by_area
            .partition_point(|&d| self.background_area[d] < lo);
        let mut best = f64::INFINITY;
        for &d in &self.background_by_area[first..] {
            if self.background_area[d] > hi {
                break;
            }
            if !self.same_size(d, area, max_scale)
                || bright.is_some_and(|b| self.background_bright[d] != b)
            {
                continue;
            }
            if let Some(c) = corr.correlate_below(fd, self.background.fd(d), best)? {
                best = best.min(c.error);
                if best <= floor {
                    break;
                }
            }
        }
        Ok(best)
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use image::Luma;

    /// An asymmetric bright "L" (local frame: a 40 × 10 bar and a 10 × 24 foot) rotated by
    /// `angle` about `centre`, a bright static square, on a dark background; 4 × 4 supersampled.
    pub(crate) fn scene(centre: [f64; 2], angle: f64, with_l: bool) -> GrayImage {
        scene_with([240, 200], with_l.then_some((centre, angle, 1.0)), None)
    }

    /// As [`scene`], on a `size` image: the L `(centre, angle, scale)` if any, and a static
    /// upright L `(centre, scale)` if any, beside the square.
    fn scene_with(
        size: [u32; 2],
        l: Option<([f64; 2], f64, f64)>,
        static_l: Option<([f64; 2], f64)>,
    ) -> GrayImage {
        let inside = |x: f64, y: f64, centre: [f64; 2], angle: f64, scale: f64| {
            let (s, c) = angle.sin_cos();
            let (dx, dy) = ((x - centre[0]) / scale, (y - centre[1]) / scale);
            let (u, v) = (c * dx + s * dy, -s * dx + c * dy);
            ((-20.0..20.0).contains(&u) && (-5.0..5.0).contains(&v))
                || ((10.0..20.0).contains(&u) && (5.0..24.0).contains(&v))
        };
        let square = |x: f64, y: f64| (20.0..44.0).contains(&x) && (150.0..174.0).contains(&y);
        GrayImage::from_fn(size[0], size[1], |x, y| {
            let mut hits = 0;
            for i in 0..4 {
                for j in 0..4 {
                    let (px, py) = (
                        f64::from(x) + (f64::from(i) + 0.5) / 4.0 - 0.5,
                        f64::from(y) + (f64::from(j) + 0.5) / 4.0 - 0.5,
                    );
                    let on_l = l.is_some_and(|(c, a, k)| inside(px, py, c, a, k));
                    let on_static = static_l.is_some_and(|(c, k)| inside(px, py, c, 0.0, k));
                    if on_l || on_static || square(px, py) {
                        hits += 1;
                    }
                }
            }
            Luma([(40 + hits * 180 / 16) as u8])
        })
    }

    /// The tip in the L's local frame: the far end of its foot.
    pub(crate) fn tip(centre: [f64; 2], angle: f64) -> [f64; 2] {
        let (s, c) = angle.sin_cos();
        let (u, v) = (15.0, 24.0);
        [centre[0] + c * u - s * v, centre[1] + s * u + c * v]
    }

    /// The training pose of [`one_l_model`]'s L.
    pub(crate) const L0: ([f64; 2], f64) = ([100.0, 80.0], 0.2);

    /// The shape model of one L at pose [`L0`] (small regions, any rotation), its report and
    /// the training image with the L.
    pub(crate) fn one_l_model() -> (ShapeModel, ShapeReport, GrayImage) {
        let config = ShapeConfig {
            mser: MserParams {
                min_area: 30,
                max_area: 3000,
                ..MserParams::default()
            },
            max_rotation: std::f64::consts::PI,
            ..ShapeConfig::default()
        };
        let (c0, a0) = L0;
        let (rest, moved) = (scene(c0, a0, true), scene(c0, a0, false));
        let pair = ActionPair {
            camera: 0,
            rest: &rest,
            moved: &moved,
            tip: Some(tip(c0, a0)),
        };
        let (model, report) = ShapeModel::learn(&config, 1, &[pair]).unwrap();
        (model, report, rest)
    }

    #[test]
    fn a_rotated_shifted_view_votes_for_the_rotated_tip() {
        let (c0, a0) = L0;
        let (model, report, rest) = one_l_model();
        assert!(
            report.views[0] >= 1 && report.background[0] >= 1,
            "{report:?}"
        );
        assert_eq!(model.views(0).len(), report.views[0]);
        for (c1, a1) in [([130.0, 100.0], 0.9), ([120.0, 90.0], -0.6)] {
            let query = scene(c1, a1, true);
            let votes = model.votes(0, &query).unwrap();
            let best = super::super::vote::mode(&votes, 2.0)
                .unwrap()
                .expect("votes");
            let t = tip(c1, a1);
            let err = (best.position[0] - t[0]).hypot(best.position[1] - t[1]);
            assert!(err < 1.5, "tip error {err:.2} px at {a1} rad ({votes:?})");
            // The recovered rotation is the L's turn (either sign convention would pass the
            // position test only by accident; check it too).
            let turn = votes
                .iter()
                .map(|v| v.rotation)
                .fold(f64::NAN, |a, r| if a.is_nan() { r } else { a });
            let d = (turn.abs() - (a1 - a0).abs()).abs();
            assert!(d < 0.1, "rotation {turn:.3} vs {:.3}", a1 - a0);
        }
        // Without the L only the background is left: no vote.
        assert!(model.votes(0, &scene(c0, a0, false)).unwrap().is_empty());
        // An unknown camera is a typed error.
        assert!(matches!(
            model.votes(1, &rest),
            Err(PipelineError::InvalidParameter { name: "camera", .. })
        ));
    }

    #[test]
    fn a_window_finds_the_votes_of_the_regions_inside_it_and_its_reach_covers_them() {
        let (model, _, _) = one_l_model();
        // The reach: the farthest pixel of the L from its tip (the bar's far end, about 45 px;
        // contour pixel centres lie half a pixel inside the L's outline).
        let reach = model.reach(0).unwrap();
        assert!((40.0..46.0).contains(&reach), "reach {reach:.2}");
        assert_eq!(model.reach(1), None);

        let size = [400, 300];
        let (c1, a1) = ([260.0, 170.0], 0.7);
        let query = scene_with(size, Some((c1, a1, 1.0)), None);
        type Key = ([f64; 2], f64, f64, f64);
        let key = |v: &Vote| -> Key { (v.position, v.weight, v.error, v.rotation) };
        // Equal up to rounding: the contours are the window's, shifted, and the descriptors'
        // FFTs round differently in the last bits.
        let same = |a: &[Key], b: &[Key]| {
            let close = |x: f64, y: f64| (x - y).abs() <= 1e-9 * (1.0 + y.abs());
            a.len() == b.len()
                && a.iter().zip(b).all(|(x, y)| {
                    close(x.0[0], y.0[0])
                        && close(x.0[1], y.0[1])
                        && close(x.1, y.1)
                        && close(x.2, y.2)
                        && close(x.3, y.3)
                })
        };
        let whole: Vec<_> = model.votes(0, &query).unwrap().iter().map(key).collect();
        assert!(!whole.is_empty());
        let t = tip(c1, a1);
        // A window holding the L gives the same votes (the regions' indices aside).
        let around = SearchWindow::around(t, reach + 5.0, size).unwrap();
        assert!(!around.is_whole());
        let (votes, boxes) = model.votes_with_boxes(0, &query, Some(&around)).unwrap();
        let found: Vec<Key> = votes.iter().map(key).collect();
        assert!(same(&found, &whole), "{found:?} vs {whole:?}");
        // Each vote's region box is the image's, inside the window.
        assert_eq!(boxes.len(), votes.len());
        assert!(boxes.iter().all(|b| around.keeps(b)), "{boxes:?}");
        let (_, whole_boxes) = model.votes_with_boxes(0, &query, None).unwrap();
        assert_eq!(boxes, whole_boxes);
        // The whole image as a window is the whole image.
        let all = SearchWindow::around([200.0, 150.0], 500.0, size).unwrap();
        let w: Vec<_> = model
            .votes_in(0, &query, Some(&all))
            .unwrap()
            .iter()
            .map(key)
            .collect();
        assert_eq!(w, whole, "the whole image is searched as without a window");
        // A window that cuts the L (its tip end inside, the bar's far end outside) and one
        // away from it: no vote.
        let cut = SearchWindow::around(t, 0.5 * reach, size).unwrap();
        assert!(model.votes_in(0, &query, Some(&cut)).unwrap().is_empty());
        let away = SearchWindow::around([60.0, 60.0], 40.0, size).unwrap();
        assert!(model.votes_in(0, &query, Some(&away)).unwrap().is_empty());
        // A window of another image size is refused.
        let other = SearchWindow::around(t, reach, [640, 480]).unwrap();
        assert!(matches!(
            model.votes_in(0, &query, Some(&other)),
            Err(PipelineError::InvalidParameter { name: "window", .. })
        ));
        // So are windows that are not a non-empty part of the image (the fields are public;
        // an inverted one used to panic).
        for (x0, y0, x1, y1) in [
            (60, 60, 50, 90),
            (60, 90, 80, 60),
            (60, 60, 60, 90),
            (300, 60, 420, 90),
            (0, 0, 401, 300),
        ] {
            let bad = SearchWindow {
                x0,
                y0,
                x1,
                y1,
                size,
            };
            assert!(
                matches!(
                    model.votes_in(0, &query, Some(&bad)),
                    Err(PipelineError::InvalidParameter { name: "window", .. })
                ),
                "{bad:?}"
            );
        }
    }

    #[test]
    fn a_region_votes_with_every_near_best_view_and_all_agree() {
        let config = |view_error_factor| ShapeConfig {
            mser: MserParams {
                min_area: 30,
                max_area: 3000,
                ..MserParams::default()
            },
            max_rotation: std::f64::consts::PI,
            view_error_factor,
            ..ShapeConfig::default()
        };
        // Two training poses of the same L: two views of it with different offsets.
        let poses = [([100.0, 80.0], 0.45), ([140.0, 110.0], 0.55)];
        let images: Vec<(GrayImage, GrayImage)> = poses
            .iter()
            .map(|&(c, a)| (scene(c, a, true), scene(c, a, false)))
            .collect();
        let pairs: Vec<ActionPair<'_>> = images
            .iter()
            .zip(&poses)
            .map(|((rest, moved), &(c, a))| ActionPair {
                camera: 0,
                rest,
                moved,
                tip: Some(tip(c, a)),
            })
            .collect();
        let (c1, a1) = ([120.0, 95.0], 0.5);
        let query = scene(c1, a1, true);
        let t = tip(c1, a1);
        let count = |factor: f64| {
            let (model, report) = ShapeModel::learn(&config(factor), 1, &pairs).unwrap();
            assert!(report.views[0] >= 2, "{report:?}");
            let votes = model.votes(0, &query).unwrap();
            for v in &votes {
                let err = (v.position[0] - t[0]).hypot(v.position[1] - t[1]);
                assert!(err < 2.0, "vote {v:?} is {err:.2} px from the tip");
            }
            votes.len()
        };
        let (single, multi) = (count(1.0), count(3.0));
        assert!(single >= 1 && multi > single, "{single} vs {multi} votes");
    }

    /// The shape model of one L at scale 1 (pose `([100, 80], 0.2)`), learned with
    /// `max_scale`, on `size` images with `static_l` in the background.
    fn sized_model(
        max_scale: f64,
        size: [u32; 2],
        static_l: Option<([f64; 2], f64)>,
    ) -> ShapeModel {
        let config = ShapeConfig {
            mser: MserParams {
                min_area: 30,
                max_area: 6000,
                ..MserParams::default()
            },
            max_rotation: std::f64::consts::PI,
            max_scale,
            ..ShapeConfig::default()
        };
        let (c0, a0) = ([100.0, 80.0], 0.2);
        let rest = scene_with(size, Some((c0, a0, 1.0)), static_l);
        let moved = scene_with(size, None, static_l);
        let pair = ActionPair {
            camera: 0,
            rest: &rest,
            moved: &moved,
            tip: Some(tip(c0, a0)),
        };
        ShapeModel::learn(&config, 1, &[pair]).unwrap().0
    }

    #[test]
    fn with_max_scale_a_view_votes_only_for_regions_of_about_its_size() {
        let (c1, a1) = ([120.0, 95.0], 0.5);
        for (scale, max_scale, votes_expected) in [
            (1.1, 1.25, true),
            (1.6, 1.25, false),
            (1.6, f64::INFINITY, true),
            (0.7, 1.25, false),
        ] {
            let model = sized_model(max_scale, [240, 200], None);
            let query = scene_with([240, 200], Some((c1, a1, scale)), None);
            let votes = model.votes(0, &query).unwrap();
            assert_eq!(
                !votes.is_empty(),
                votes_expected,
                "L at scale {scale}, max_scale {max_scale}: {votes:?}"
            );
            if let Some(m) = super::super::vote::mode(&votes, 2.0).unwrap() {
                // The tip of the scaled L: its local tip offset scaled about the centre.
                let t0 = tip([0.0, 0.0], a1);
                let t = [c1[0] + scale * t0[0], c1[1] + scale * t0[1]];
                let err = (m.position[0] - t[0]).hypot(m.position[1] - t[1]);
                assert!(
                    err < 2.0,
                    "scale {scale}: tip error {err:.2} px ({votes:?})"
                );
            }
        }
    }

    #[test]
    fn with_max_scale_the_ratio_test_competes_only_with_background_of_the_regions_size() {
        // A static L twice the gripper's size in the background: shape alone cannot tell
        // them apart (ratio near 1, the gripper refused); by size they differ.
        let size = [320, 260];
        let static_l = Some(([250.0, 190.0], 2.0));
        let (c1, a1) = ([120.0, 95.0], 0.5);
        let query = scene_with(size, Some((c1, a1, 1.0)), static_l);
        let shape_only = sized_model(f64::INFINITY, size, static_l);
        assert!(
            shape_only.votes(0, &query).unwrap().is_empty(),
            "the big static L should make the ratio test refuse the gripper"
        );
        let sized = sized_model(1.25, size, static_l);
        let votes = sized.votes(0, &query).unwrap();
        let best = super::super::vote::mode(&votes, 2.0)
            .unwrap()
            .expect("with the size gate the gripper votes");
        let t = tip(c1, a1);
        let err = (best.position[0] - t[0]).hypot(best.position[1] - t[1]);
        assert!(err < 1.5, "tip error {err:.2} px ({votes:?})");
        // The static L itself does not vote: it is background, of its own size.
        let alone = scene_with(size, None, static_l);
        assert!(sized.votes(0, &alone).unwrap().is_empty());
    }

    /// The image with every grey level `g` replaced by `255 − g`.
    fn invert(img: &GrayImage) -> GrayImage {
        let mut out = img.clone();
        out.pixels_mut().for_each(|p| p.0[0] = 255 - p.0[0]);
        out
    }

    /// Matching within a polarity: the views and background regions keep their polarity; an L
    /// of the other polarity (the image inverted: a dark L on a bright ground) votes for the
    /// tip by shape alone, and not at all when views vote only for regions of their polarity.
    #[test]
    fn within_a_polarity_a_region_of_the_other_polarity_does_not_vote() {
        let (mut model, _, _) = one_l_model();
        let shapes = &model.cameras[0];
        assert!(shapes.views.iter().all(|v| v.bright), "the L is bright");
        let (c1, a1) = ([130.0, 100.0], 0.4);
        let t = tip(c1, a1);
        let near = |votes: &[Vote]| {
            votes
                .iter()
                .filter(|v| (v.position[0] - t[0]).hypot(v.position[1] - t[1]) < 5.0)
                .count()
        };
        let same = scene(c1, a1, true);
        let inverted = invert(&same);
        // Within a polarity (the default).
        assert!(model.config.same_polarity);
        assert!(near(&model.votes(0, &same).unwrap()) > 0);
        assert!(model.votes(0, &inverted).unwrap().is_empty());
        // By shape (and size) alone.
        model.config.same_polarity = false;
        assert!(near(&model.votes(0, &same).unwrap()) > 0);
        assert!(
            near(&model.votes(0, &inverted).unwrap()) > 0,
            "by shape alone"
        );
    }

    #[test]
    fn the_sized_background_error_is_the_brute_force_minimum_over_regions_of_that_size() {
        let size = [320, 260];
        let static_l = Some(([250.0, 190.0], 2.0));
        // Learned from the scene and from its inverse too, so that the background holds regions
        // of both polarities.
        let model = {
            let config = sized_model(1.25, size, static_l).config;
            let (c0, a0) = ([100.0, 80.0], 0.2);
            let rest = scene_with(size, Some((c0, a0, 1.0)), static_l);
            let moved = scene_with(size, None, static_l);
            let (rest_inv, moved_inv) = (invert(&rest), invert(&moved));
            let pair = |rest, moved| ActionPair {
                camera: 0,
                rest,
                moved,
                tip: Some(tip(c0, a0)),
            };
            let pairs = [pair(&rest, &moved), pair(&rest_inv, &moved_inv)];
            ShapeModel::learn(&config, 1, &pairs).unwrap().0
        };
        let shapes = &model.cameras[0];
        assert!(shapes.background.len() >= 2, "{}", shapes.background.len());
        let polarities = &shapes.background_bright;
        assert!(polarities.contains(&true) && polarities.contains(&false));
        let query = scene_with(size, Some(([120.0, 95.0], 0.5, 1.0)), static_l);
        let features = detect(&query, &model.config.mser).unwrap();
        let set = fd_match::describe_all(descriptor_config(), &features.contours)
            .unwrap()
            .set;
        let dc = descriptor_config();
        let mut corr = fd_match::Correlator::new(dc.max_frequency(), dc.samples).unwrap();
        let mut compared = 0;
        for k in 0..set.len() {
            let area = f64::from(features.regions[set.source(k)].area);
            // Of the region's size, and of either polarity or of one.
            let kinds = [1.1, 1.25, 2.0, 4.0]
                .into_iter()
                .flat_map(|m| [None, Some(false), Some(true)].map(|b| (m, b)));
            for (max_scale, bright) in kinds {
                let fast = shapes
                    .background_error(&mut corr, set.fd(k), area, max_scale, bright, -1.0)
                    .unwrap();
                let brute = (0..shapes.background.len())
                    .filter(|&d| {
                        shapes.same_size(d, area, max_scale)
                            && bright.is_none_or(|b| shapes.background_bright[d] == b)
                    })
                    .map(|d| {
                        corr.correlate(set.fd(k), shapes.background.fd(d))
                            .unwrap()
                            .error
                    })
                    .fold(f64::INFINITY, f64::min);
                assert_eq!(fast, brute, "region {k}, max_scale {max_scale}, {bright:?}");
                // With a floor the search may stop early, but on the same side of it.
                for floor in [0.5 * brute, brute, 1.5 * brute] {
                    let early = shapes
                        .background_error(&mut corr, set.fd(k), area, max_scale, bright, floor)
                        .unwrap();
                    assert!(
                        early >= brute,
                        "region {k}: {early} below the minimum {brute}"
                    );
                    assert_eq!(early <= floor, brute <= floor, "region {k}, floor {floor}");
                }
                compared += usize::from(brute.is_finite());
            }
        }
        assert!(
            compared > 0,
            "no region had a background region of its size"
        );
    }

    /// A pair whose moved capture is of another size than its rest capture is refused: its
    /// regions cannot be compared (every region of `rest` used to count as changed, so the
    /// L's surroundings were learned as gripper views).
    #[test]
    fn a_pair_of_captures_of_different_sizes_is_refused() {
        let (c0, a0) = L0;
        let rest = scene(c0, a0, true);
        let moved = scene_with([200, 160], None, None);
        let pair = ActionPair {
            camera: 0,
            rest: &rest,
            moved: &moved,
            tip: Some(tip(c0, a0)),
        };
        match ShapeModel::learn(&ShapeConfig::default(), 1, &[pair]) {
            Err(PipelineError::InvalidParameter { name, reason }) => {
                assert_eq!(name, "pairs");
                assert!(
                    reason.contains("240×200") && reason.contains("200×160"),
                    "{reason}"
                );
            }
            other => panic!("{:?}", other.map(|(_, r)| r)),
        }
    }

    /// The model keeps each camera's image size, and refuses pairs of one camera of different
    /// sizes (the views' offsets and reach would mix two images' pixels).
    #[test]
    fn the_image_size_is_kept_and_one_cameras_pairs_of_two_sizes_are_refused() {
        let (model, _, rest) = one_l_model();
        assert_eq!(model.image_size(0), Some([rest.width(), rest.height()]));
        assert_eq!(model.image_size(1), None);
        let (c0, a0) = L0;
        let (small_rest, small_moved) = (
            scene_with([200, 160], Some((c0, a0, 1.0)), None),
            scene_with([200, 160], None, None),
        );
        let moved = scene(c0, a0, false);
        let pair = |camera, rest, moved| ActionPair {
            camera,
            rest,
            moved,
            tip: Some(tip(c0, a0)),
        };
        match ShapeModel::learn(
            model.config(),
            1,
            &[pair(0, &rest, &moved), pair(0, &small_rest, &small_moved)],
        ) {
            Err(PipelineError::InvalidParameter { name, reason }) => {
                assert_eq!(name, "pairs");
                assert!(reason.contains("pair 1"), "{reason}");
            }
            other => panic!("{:?}", other.map(|(_, r)| r)),
        }
        // Two cameras of different sizes are fine, each with its own.
        let (two, _) = ShapeModel::learn(
            model.config(),
            2,
            &[pair(0, &rest, &moved), pair(1, &small_rest, &small_moved)],
        )
        .unwrap();
        assert_eq!(two.image_size(0), Some([240, 200]));
        assert_eq!(two.image_size(1), Some([200, 160]));
    }

    #[test]
    fn nothing_changed_is_not_enough_data_and_bad_settings_are_refused() {
        let img = scene([100.0, 80.0], 0.0, true);
        let pair = ActionPair {
            camera: 0,
            rest: &img,
            moved: &img,
            tip: Some([100.0, 80.0]),
        };
        assert!(matches!(
            ShapeModel::learn(&ShapeConfig::default(), 1, &[pair]),
            Err(PipelineError::NotEnoughData(_))
        ));
        let d = ShapeConfig::default;
        for (bad, name) in [
            (
                ShapeConfig {
                    ratio_threshold: 0.0,
                    ..d()
                },
                "ratio_threshold",
            ),
            (
                ShapeConfig {
                    max_scale: 0.9,
                    ..d()
                },
                "max_scale",
            ),
            (
                ShapeConfig {
                    view_error_factor: 0.5,
                    ..d()
                },
                "view_error_factor",
            ),
        ] {
            match ShapeModel::learn(&bad, 1, &[pair]) {
                Err(PipelineError::InvalidParameter { name: got, .. }) => assert_eq!(got, name),
                other => panic!("{name}: {other:?}"),
            }
        }
        // More cameras than pairs: some camera has no view (a huge count used to panic
        // allocating the per-camera lists).
        for cameras in [2, usize::MAX] {
            assert!(matches!(
                ShapeModel::learn(&ShapeConfig::default(), cameras, &[pair]),
                Err(PipelineError::NotEnoughData(_))
            ));
        }
        let far = ActionPair { camera: 3, ..pair };
        assert!(matches!(
            ShapeModel::learn(&ShapeConfig::default(), 1, &[far]),
            Err(PipelineError::InvalidParameter { name: "camera", .. })
        ));
    }
}
