//! The silhouette recogniser's model type ([`TipModel`]), its settings and what learning
//! found; the method is described in the `silhouette` module.

use image::GrayImage;
use serde::{Deserialize, Serialize};

use crate::error::{Result, ServoError};
use crate::recognition::change::changed_region;
use crate::recognition::cross_camera::choose_consistent;
use crate::recognition::end_face::CoverageGrid;
use crate::recognition::epipolar::{EpipolarGeometry, EpipolarReport};
use crate::recognition::image::{
    half_resolution, halve, largest_component, smoothed_magnitude, to_f32,
};
use crate::recognition::lighting::{fit_lighting, residual};
use crate::recognition::scene::{CameraScene, MIN_SIDE, learn_scene};
use crate::recognition::silhouette::{
    EndFit, FACE_WINDOW, Silhouette, end_face_centre, farthest, learn_root, pixel_cdf,
};
use crate::recognition::tip_correction::{CorrectionReport, CorrectionSample, TipCorrection};
use crate::recognition::tip_rule::{EndEstimate, TipRule, far_end};
use crate::recognition::{Localisation, PerceptUse, TrainingView, training_image_sizes};
use crate::stats::quantile_rank;

/// Settings of the silhouette recogniser.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SilhouetteConfig {
    /// Threshold multiple `k` of the learned noise `σ` for silhouette pixels.
    pub noise_multiple: f32,
    /// Smallest silhouette threshold `d_min` (grey levels).
    pub min_threshold: f32,
    /// Smallest arm silhouette (pixels).
    pub min_pixels: usize,
    /// Localisations with a lower certainty are failures.
    pub min_certainty: f64,
    /// Which point of the gripper's far end is the tip. (Files written before the learned rule
    /// existed have no `tip`; for them it is `far_end`, as it was then.)
    #[serde(default = "far_end")]
    pub tip: TipRule,
    /// Random poses [`learn_recognition`](crate::learn_recognition) captures after the gripper
    /// moves to learn the `Learned` rule's correction (0: none is learned).
    #[serde(default = "default_correction_poses")]
    pub correction_poses: usize,
    /// Whether every camera's tip is chosen among its candidates (the rule's tip and the
    /// end-face tip) by the cross-camera consistency (`cross_camera` module), once a
    /// consistency is learned. Off by default: on the development seeds it lowered the
    /// recognition p90 but made the servo worse on two of three arms (docs/methods.md,
    /// *Cross-camera choice*). Files without the field have it off.
    #[serde(default)]
    pub cross_camera_choice: bool,
    /// The `Learned` rule's gate `k`: each camera's tip moves towards its end-face tip by at
    /// most `max(0.5 px, k σ_c)`, `σ_c` the correction's local spread there
    /// ([`TipCorrection::tips_gated`]; the `tip_correction` module, *the correction's own
    /// certainty*). 0 (the default, and files without the field): at most 0.5 px everywhere.
    /// An opt-in: 1 (with `spread_scale` 1.25 px) improved recognition on the development
    /// seeds; with the cap on training moves too it made the headline seed 2009 worse, with
    /// the cap on servo percepts only (`cap_training` false) it did not hurt the servo on the
    /// development seeds, and `eval servo` uses that (docs/methods.md, *Gated learned tip*).
    /// The library's default stays 0: the FD + CBT pipeline study learns with it.
    #[serde(default)]
    pub face_gate: f64,
    /// The `Learned` rule's spread scale `s` (pixels): a camera that shows no end face has a
    /// certainty of at most `exp(−½ (σ_c / s)²)` (below a percept policy's 0.05 for
    /// `σ_c > 2.45 s`). 0 (the default, and files without the field): no cap.
    #[serde(default)]
    pub spread_scale: f64,
    /// Whether the spread cap ([`SilhouetteConfig::spread_scale`]) also doubts training
    /// percepts ([`PerceptUse::Training`]). `true` (the default, and files without the field):
    /// every percept is capped. `false`: training moves keep their percepts (a refused one
    /// leaves a hole in the learned inverse model where the correction is unsure) and only
    /// the percepts the servo acts on are capped (docs/methods.md, *Gated learned tip*).
    #[serde(default = "cap_everywhere")]
    pub cap_training: bool,
}

fn cap_everywhere() -> bool {
    true
}

fn default_correction_poses() -> usize {
    1000
}

/// The opt-in's [`SilhouetteConfig::face_gate`] measured on the development seeds
/// (docs/methods.md, *Gated learned tip*; the default is 0, off).
pub const MEASURED_FACE_GATE: f64 = 1.0;
/// The opt-in's [`SilhouetteConfig::spread_scale`] (pixels) measured with it (the default is
/// 0, off).
pub const MEASURED_SPREAD_SCALE: f64 = 1.25;

impl Default for SilhouetteConfig {
    fn default() -> Self {
        SilhouetteConfig {
            noise_multiple: 5.0,
            min_threshold: 8.0,
            min_pixels: 50,
            min_certainty: 0.3,
            tip: TipRule::default(),
            correction_poses: default_correction_poses(),
            cross_camera_choice: false,
            face_gate: 0.0,
            spread_scale: 0.0,
            cap_training: cap_everywhere(),
        }
    }
}

impl SilhouetteConfig {
    /// The checks [`TipModel::learn`] applies (also before any training move of
    /// [`learn_recognition`](crate::learn_recognition)).
    pub(crate) fn validate(&self) -> Result<()> {
        if !(self.noise_multiple.is_finite() && self.noise_multiple > 0.0) {
            return Err(ServoError::invalid(
                "noise_multiple",
                "must be finite and positive",
            ));
        }
        if !(self.min_threshold.is_finite() && self.min_threshold >= 0.0) {
            return Err(ServoError::invalid(
                "min_threshold",
                "must be finite and non-negative",
            ));
        }
        if !(0.0..=1.0).contains(&self.min_certainty) {
            return Err(ServoError::invalid("min_certainty", "must lie in [0, 1]"));
        }
        if !(self.face_gate.is_finite() && self.face_gate >= 0.0) {
            return Err(ServoError::invalid(
                "face_gate",
                "must be finite and non-negative",
            ));
        }
        if !(self.spread_scale.is_finite() && self.spread_scale >= 0.0) {
            return Err(ServoError::invalid(
                "spread_scale",
                "must be finite and non-negative",
            ));
        }
        Ok(())
    }
}

/// What learning found, per camera.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct SilhouetteReport {
    /// Frames used for the static scene.
    pub frames: usize,
    /// Gripper moves whose change was found (per camera).
    pub gripper_changes: Vec<usize>,
    /// Fraction of training frames whose gripper change lay within the end window of the
    /// silhouette's far end (the end-of-chain rule agrees with the action), per camera.
    pub end_agrees: Vec<f64>,
    /// The `Learned` rule's correction, when one was learned.
    #[serde(default)]
    pub correction: Option<CorrectionReport>,
    /// The cross-camera consistency (camera 0 with camera `k`, `k ≥ 1`), when learned.
    #[serde(default)]
    pub consistency: Vec<EpipolarReport>,
}

/// The silhouette-based gripper-tip recogniser (see the module docs).
///
/// Deserialising checks the model as [`TipModel::learn`] would have built it: the settings
/// (the checks `learn` applies), at least one camera, every [`CameraScene`]
/// ([`CameraScene::check`]), the learned correction ([`TipCorrection`]'s own checks, and
/// learned for the model's number of cameras) and the learned consistency (none, or one
/// geometry per camera `k ≥ 1`); a file that fails them is an error, never a recogniser that
/// panics or misreads later.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "TipModelFile")]
pub struct TipModel {
    config: SilhouetteConfig,
    cameras: Vec<CameraScene>,
    /// The `Learned` rule's correction (`tip_correction`), once learned.
    #[serde(default)]
    correction: Option<TipCorrection>,
    /// The epipolar geometry of camera 0 with camera `k` (entry `k − 1`), once learned
    /// ([`TipModel::learn_consistency`]): every localisation's certainty is at most its pair's
    /// consistency.
    #[serde(default)]
    consistency: Vec<EpipolarGeometry>,
}

/// The serialised form of a [`TipModel`], checked on deserialisation (its scenes and
/// correction check themselves as they are read).
#[derive(Deserialize)]
struct TipModelFile {
    config: SilhouetteConfig,
    cameras: Vec<CameraScene>,
    #[serde(default)]
    correction: Option<TipCorrection>,
    #[serde(default)]
    consistency: Vec<EpipolarGeometry>,
}

impl TryFrom<TipModelFile> for TipModel {
    type Error = ServoError;

    fn try_from(f: TipModelFile) -> Result<Self> {
        f.config.validate()?;
        if f.cameras.is_empty() {
            return Err(ServoError::invalid(
                "cameras",
                "a tip model needs at least one camera",
            ));
        }
        let cams = f.cameras.len();
        if f.correction
            .as_ref()
            .is_some_and(|c| c.num_cameras() != cams)
        {
            return Err(ServoError::invalid(
                "correction",
                "learned for another number of cameras than the model's",
            ));
        }
        // `learn_consistency` writes one geometry per camera k ≥ 1 (none for one camera).
        if !f.consistency.is_empty() && f.consistency.len() != cams - 1 {
            return Err(ServoError::invalid(
                "consistency",
                "must hold one geometry per camera after the first, or none",
            ));
        }
        Ok(TipModel {
            config: f.config,
            cameras: f.cameras,
            correction: f.correction,
            consistency: f.consistency,
        })
    }
}

impl TipModel {
    /// Learns every camera's static scene, the chain's root and the gripper end's size from
    /// training views (see the module docs). Errors: no views, differing image sizes or
    /// camera counts, no arm silhouette.
    pub fn learn(
        config: &SilhouetteConfig,
        views: &[TrainingView],
    ) -> Result<(TipModel, SilhouetteReport)> {
        config.validate()?;
        let sizes = training_image_sizes(views)?;
        let cams = sizes.len();
        let mut report = SilhouetteReport {
            frames: 2 * views.len(),
            ..SilhouetteReport::default()
        };
        let mut cameras = Vec::with_capacity(cams);
        for cam in 0..cams {
            let (w, h) = (sizes[cam][0] as usize, sizes[cam][1] as usize);
            if w < MIN_SIDE || h < MIN_SIDE {
                return Err(ServoError::InvalidParameter {
                    name: "image",
                    reason: format!("{w}×{h} is too small"),
                });
            }
            let mut frames = Vec::with_capacity(2 * views.len());
            for v in views {
                for set in [&v.before, &v.after] {
                    frames.push(to_f32(&set[cam]));
                }
            }
            let mut scene = learn_scene(&frames, w, h);
            // Noise: robust spread of frame residuals against the scene.
            let mut spread = Vec::new();
            for f in frames.iter().take(6) {
                let coef = fit_lighting(f, &scene.background, w, h);
                let r = residual(f, &scene.background, w, h, coef);
                spread.extend(r.iter().step_by(7).map(|v| f64::from(v.abs())));
            }
            scene.noise_sigma = (1.4826 * quantile_rank(&mut spread, 0.5)).max(0.5) as f32;
            // Root: the point from which the gripper, as revealed by the gripper moves, is the
            // silhouette's farthest pixel in most training views (action precedes perception).
            let model_one = TipModel {
                config: config.clone(),
                cameras: vec![scene.clone()],
                correction: None,
                consistency: Vec::new(),
            };
            let mut silhouettes = Vec::with_capacity(frames.len());
            for f in &frames {
                silhouettes.push(model_one.silhouette(0, f.clone()));
            }
            let mut changes = Vec::with_capacity(views.len());
            for v in views {
                let a = half_resolution(&v.before[cam]);
                let b = half_resolution(&v.after[cam]);
                changes.push(changed_region(&a, &b, 20).map(|r| r.centroid));
            }
            scene.root = learn_root(&silhouettes, &changes, w, h).ok_or_else(|| {
                ServoError::NotEnoughData(format!(
                    "no arm silhouette with a gripper change in camera {cam}'s training frames"
                ))
            })?;
            // Gripper size from the gripper moves: distance of the change from the far end.
            let mut reach = Vec::new();
            let mut far_points = Vec::new();
            for k in 0..views.len() {
                let s = &silhouettes[2 * k];
                let Some(far) = farthest(&s.component, scene.root) else {
                    far_points.push(None);
                    continue;
                };
                far_points.push(Some(far));
                if let Some(g) = changes[k] {
                    reach.push((g[0] - far[0]).hypot(g[1] - far[1]));
                }
            }
            report.gripper_changes.push(reach.len());
            if reach.is_empty() {
                return Err(ServoError::NotEnoughData(format!(
                    "no gripper move changed camera {cam}'s image"
                )));
            }
            let typical = quantile_rank(&mut reach.clone(), 0.5);

            scene.end_length = (2.0 * typical).clamp(8.0, 80.0);
            report.end_agrees.push(
                reach.iter().filter(|&&r| r <= scene.end_length).count() as f64
                    / views.len() as f64,
            );
            let mut areas = Vec::new();
            let one = TipModel {
                config: config.clone(),
                cameras: vec![scene.clone()],
                correction: None,
                consistency: Vec::new(),
            };
            for s in silhouettes.iter().step_by(2) {
                if let Some(fit) = one.fit_end(0, s, false) {
                    areas.push(fit.area);
                }
            }
            scene.end_area = quantile_rank(&mut areas, 0.5).max(1.0);
            cameras.push(scene);
        }
        Ok((
            TipModel {
                config: config.clone(),
                cameras,
                correction: None,
                consistency: Vec::new(),
            },
            report,
        ))
    }

    /// Number of cameras.
    pub fn num_cameras(&self) -> usize {
        self.cameras.len()
    }

    /// Camera `cam`'s learned scene.
    pub fn camera(&self, cam: usize) -> Option<&CameraScene> {
        self.cameras.get(cam)
    }

    /// Image size `[width, height]` (of camera 0).
    pub fn image_size(&self) -> [u32; 2] {
        self.cameras
            .first()
            .map_or([0, 0], |c| [c.width as u32, c.height as u32])
    }

    /// The configuration.
    pub fn config(&self) -> &SilhouetteConfig {
        &self.config
    }

    /// The same learned model reporting the tip by `rule` (nothing is relearned: the rule only
    /// chooses the point of the far end).
    pub fn with_tip_rule(&self, rule: TipRule) -> TipModel {
        TipModel {
            config: SilhouetteConfig {
                tip: rule,
                ..self.config.clone()
            },
            cameras: self.cameras.clone(),
            correction: self.correction.clone(),
            consistency: self.consistency.clone(),
        }
    }

    /// The same learned model with the cross-camera choice of the tip on or off
    /// ([`SilhouetteConfig::cross_camera_choice`]; nothing is relearned).
    pub fn with_cross_camera_choice(&self, on: bool) -> TipModel {
        TipModel {
            config: SilhouetteConfig {
                cross_camera_choice: on,
                ..self.config.clone()
            },
            ..self.clone()
        }
    }

    /// Finds the gripper tip in camera `cam`'s image by the configured single-image rule
    /// (`FarEnd` or `EndFace`). Errors: unknown camera, wrong image size, no silhouette or a
    /// certainty below the configured minimum ([`ServoError::RecognitionFailed`]); the
    /// `Learned` rule, which needs every camera's image ([`TipModel::locate_all`]).
    pub fn locate(&self, cam: usize, img: &GrayImage) -> Result<Localisation> {
        if self.config.tip == TipRule::Learned {
            return Err(ServoError::invalid(
                "tip",
                "the learned rule locates every camera's image at once: use locate_all",
            ));
        }
        let end = self.estimate_end(cam, img)?;
        Ok(Localisation {
            position: end.single_image_tip(self.config.tip),
            certainty: end.certainty,
        })
    }

    /// Finds the gripper tip in every camera's image (one image per camera, in camera order)
    /// by the configured rule. Errors as [`TipModel::locate`] for any camera; for the
    /// `Learned` rule, a model without a learned correction ([`TipModel::learn_correction`]).
    pub fn locate_all(&self, images: &[GrayImage]) -> Result<Vec<Localisation>> {
        self.locate_all_for(images, PerceptUse::Servo)
    }

    /// As [`TipModel::locate_all`], for a percept of the given use ([`TipModel::tips_for`]).
    pub fn locate_all_for(
        &self,
        images: &[GrayImage],
        used: PerceptUse,
    ) -> Result<Vec<Localisation>> {
        self.check_ready()?;
        self.check_image_count(images)?;
        let ends = images
            .iter()
            .enumerate()
            .map(|(cam, img)| self.estimate_end(cam, img))
            .collect::<Result<Vec<_>>>()?;
        self.tips_for(&ends, used)
    }

    /// The tips of every camera by the configured rule from their end estimates (in camera
    /// order; [`TipModel::estimate_end`] of each camera, e.g. computed in parallel). With
    /// [`SilhouetteConfig::cross_camera_choice`] and a learned consistency, each camera's tip
    /// is its rule's tip or its end-face tip, whichever pair is the most consistent between
    /// the cameras (`cross_camera` module; ties keep the rule's tip). Every certainty is at
    /// most its camera pair's consistency. Errors: a camera count other than the model's; the
    /// `Learned` rule without a correction.
    pub fn tips(&self, ends: &[EndEstimate]) -> Result<Vec<Localisation>> {
        self.tips_for(ends, PerceptUse::Servo)
    }

    /// As [`TipModel::tips`], for a percept of the given use: a training percept's certainty is
    /// not capped by the correction's spread unless [`SilhouetteConfig::cap_training`] (the
    /// cross-camera consistency caps every percept).
    pub fn tips_for(&self, ends: &[EndEstimate], used: PerceptUse) -> Result<Vec<Localisation>> {
        if ends.len() != self.cameras.len() {
            return Err(ServoError::DimensionMismatch {
                what: "camera end estimates",
                expected: self.cameras.len(),
                got: ends.len(),
            });
        }
        self.check_ready()?;
        let mut locs: Vec<Localisation> = match (&self.correction, self.config.tip) {
            (Some(correction), TipRule::Learned) => {
                let far: Vec<[f64; 2]> = ends.iter().map(|e| e.far_end).collect();
                let faces: Vec<Option<[f64; 2]>> = ends.iter().map(|e| e.end_face).collect();
                correction
                    .tips_gated(&far, &faces, self.config.face_gate)?
                    .into_iter()
                    .zip(ends)
                    .map(|(t, e)| Localisation {
                        position: t.position,
                        certainty: self.spread_certainty(e, t.spread, used),
                    })
                    .collect()
            }
            (_, rule) => ends
                .iter()
                .map(|e| Localisation {
                    position: e.single_image_tip(rule),
                    certainty: e.certainty,
                })
                .collect(),
        };
        if self.config.cross_camera_choice && !self.consistency.is_empty() {
            // Every camera's candidates: the rule's tip, then the end-face tip where the
            // outline shows one and it differs (`cross_camera` module).
            let candidates: Vec<Vec<[f64; 2]>> = locs
                .iter()
                .zip(ends)
                .map(|(l, e)| {
                    let mut c = vec![l.position];
                    c.extend(e.end_face.filter(|f| *f != l.position));
                    c
                })
                .collect();
            let choice = choose_consistent(&candidates, &self.consistency)?;
            for ((l, c), &i) in locs.iter_mut().zip(&candidates).zip(&choice.chosen) {
                l.position = c[i];
            }
        }
        for (k, geometry) in self.consistency.iter().enumerate() {
            if k + 1 >= locs.len() {
                break;
            }
            let c = geometry.consistency(locs[0].position, locs[k + 1].position);
            locs[0].certainty = locs[0].certainty.min(c);
            locs[k + 1].certainty = locs[k + 1].certainty.min(c);
        }
        Ok(locs)
    }

    /// A learned tip's certainty: the end's, capped by `exp(−½ (σ / s)²)` for the correction's
    /// spread `σ` where the camera shows no end face ([`SilhouetteConfig::spread_scale`] `s`;
    /// 0 = no cap; a training percept only with [`SilhouetteConfig::cap_training`]).
    fn spread_certainty(&self, end: &EndEstimate, spread: f64, used: PerceptUse) -> f64 {
        let s = self.config.spread_scale;
        let capped = used == PerceptUse::Servo || self.config.cap_training;
        if s > 0.0 && capped && end.end_face.is_none() {
            let r = spread / s;
            end.certainty.min((-0.5 * r * r).exp())
        } else {
            end.certainty
        }
    }

    /// Learns the cross-camera consistency ([`crate::recognition::epipolar`]) from `samples`
    /// (the correction poses: every camera's tip by this model's rule), replacing any earlier
    /// one; one geometry per camera `k ≥ 1` with camera 0. Errors: fewer than
    /// [`epipolar::MIN_PAIRS`](crate::recognition::epipolar::MIN_PAIRS) usable poses, a
    /// degenerate set of poses, samples with another camera count. A single-camera model
    /// learns nothing.
    pub fn learn_consistency(
        &mut self,
        samples: &[CorrectionSample],
        seed: u64,
    ) -> Result<Vec<EpipolarReport>> {
        let cams = self.cameras.len();
        let mut tips: Vec<Vec<[f64; 2]>> = vec![Vec::with_capacity(samples.len()); cams];
        for s in samples {
            if s.far_ends.len() != cams || s.end_faces.len() != cams {
                return Err(ServoError::DimensionMismatch {
                    what: "correction sample cameras",
                    expected: cams,
                    got: s.far_ends.len(),
                });
            }
            let positions: Vec<[f64; 2]> = match (&self.correction, self.config.tip) {
                (Some(correction), TipRule::Learned) => correction
                    .tips_gated(&s.far_ends, &s.end_faces, self.config.face_gate)?
                    .into_iter()
                    .map(|t| t.position)
                    .collect(),
                (_, rule) => s
                    .far_ends
                    .iter()
                    .zip(&s.end_faces)
                    .map(|(&far_end, &end_face)| {
                        EndEstimate {
                            far_end,
                            end_face,
                            certainty: 1.0,
                        }
                        .single_image_tip(rule)
                    })
                    .collect(),
            };
            for (t, p) in tips.iter_mut().zip(positions) {
                t.push(p);
            }
        }
        let mut geometries = Vec::new();
        let mut reports = Vec::new();
        for k in 1..cams {
            let (g, r) = EpipolarGeometry::fit(&tips[0], &tips[k], seed ^ k as u64)?;
            geometries.push(g);
            reports.push(r);
        }
        self.consistency = geometries;
        Ok(reports)
    }

    /// The learned cross-camera consistency (camera 0 with camera `k`, entry `k − 1`).
    pub fn consistency(&self) -> &[EpipolarGeometry] {
        &self.consistency
    }

    /// Learns the `Learned` rule's correction from `samples` ([`TipModel::correction_sample`]
    /// of images at random poses; `tip_correction` module), replacing any earlier one. Errors:
    /// fewer than 20 poses with an end face in every camera within its end window.
    pub fn learn_correction(&mut self, samples: &[CorrectionSample]) -> Result<CorrectionReport> {
        let windows: Vec<f64> = self
            .cameras
            .iter()
            .map(|c| FACE_WINDOW * c.end_length)
            .collect();
        let (correction, report) = TipCorrection::learn(samples, &windows)?;
        self.correction = Some(correction);
        Ok(report)
    }

    /// The learned correction, if any.
    pub fn correction(&self) -> Option<&TipCorrection> {
        self.correction.as_ref()
    }

    /// Whether the configured rule can locate: the `Learned` rule needs a learned correction
    /// of every camera. Errors: [`ServoError::NotEnoughData`] otherwise.
    pub fn check_ready(&self) -> Result<()> {
        if self.config.tip != TipRule::Learned {
            return Ok(());
        }
        match &self.correction {
            Some(c) if c.num_cameras() == self.cameras.len() => Ok(()),
            Some(_) => Err(ServoError::NotEnoughData(
                "the learned correction was learned for another number of cameras".into(),
            )),
            None => Err(ServoError::NotEnoughData(
                "the learned tip rule needs a learned correction (learn_correction)".into(),
            )),
        }
    }

    fn check_image_count(&self, images: &[GrayImage]) -> Result<()> {
        if images.len() == self.cameras.len() {
            return Ok(());
        }
        Err(ServoError::DimensionMismatch {
            what: "camera images",
            expected: self.cameras.len(),
            got: images.len(),
        })
    }

    /// One training sample of the correction: every camera's far end and end-face tip in
    /// `images` (one per camera). Errors as [`TipModel::locate_all`].
    pub fn correction_sample(&self, images: &[GrayImage]) -> Result<CorrectionSample> {
        self.check_image_count(images)?;
        let mut sample = CorrectionSample {
            far_ends: Vec::with_capacity(images.len()),
            end_faces: Vec::with_capacity(images.len()),
        };
        for (cam, img) in images.iter().enumerate() {
            let e = self.estimate_end_with(cam, img, true)?;
            sample.far_ends.push(e.far_end);
            sample.end_faces.push(e.end_face);
        }
        Ok(sample)
    }

    /// Camera `cam`'s far end, and its end-face tip when the rule uses it (`EndFace`,
    /// `Learned`). Errors as [`TipModel::locate`], except that any rule is accepted.
    pub fn estimate_end(&self, cam: usize, img: &GrayImage) -> Result<EndEstimate> {
        self.estimate_end_with(cam, img, self.config.tip != TipRule::FarEnd)
    }

    fn estimate_end_with(
        &self,
        cam: usize,
        img: &GrayImage,
        with_face: bool,
    ) -> Result<EndEstimate> {
        let scene = self.cameras.get(cam).ok_or(ServoError::DimensionMismatch {
            what: "camera index",
            expected: self.cameras.len(),
            got: cam,
        })?;
        if img.width() as usize != scene.width || img.height() as usize != scene.height {
            return Err(ServoError::InvalidParameter {
                name: "image",
                reason: format!(
                    "size {}×{} differs from the trained {}×{}",
                    img.width(),
                    img.height(),
                    scene.width,
                    scene.height
                ),
            });
        }
        let s = self.silhouette(cam, to_f32(img));
        let fail = |certainty: f64| ServoError::RecognitionFailed {
            camera: cam,
            certainty,
            min: self.config.min_certainty,
        };
        if s.component.len() < self.config.min_pixels {
            return Err(fail(0.0));
        }
        let fit = self.fit_end(cam, &s, with_face).ok_or_else(|| fail(0.0))?;
        let ratio = fit.area / scene.end_area;
        let certainty = if ratio > 1.0 { 1.0 / ratio } else { ratio };
        if certainty.is_nan() || certainty < self.config.min_certainty {
            return Err(fail(certainty.max(0.0)));
        }
        Ok(EndEstimate {
            far_end: fit.tip,
            end_face: fit.face,
            certainty,
        })
    }

    fn silhouette(&self, cam: usize, img: Vec<f32>) -> Silhouette {
        let scene = &self.cameras[cam];
        let (w, h) = (scene.width, scene.height);
        let coef = fit_lighting(&img, &scene.background, w, h);
        // Detection at half resolution (2×2 means of frame and scene; the gain field is
        // smooth, so it is evaluated at the 2×2 block's centre).
        let (hw2, hh2) = (w / 2, h / 2);
        let half_img = halve(&img, w, h);
        let r = residual(&half_img, &scene.half_background, hw2, hh2, coef);
        let threshold =
            (self.config.noise_multiple * 0.5 * scene.noise_sigma).max(self.config.min_threshold);
        let smooth = smoothed_magnitude(&r, hw2, hh2);
        let mask: Vec<bool> = smooth.iter().map(|&v| v > threshold).collect();
        let component = largest_component(&mask, hw2, hh2)
            .into_iter()
            .map(|p| [2.0 * (p % hw2) as f64 + 0.5, 2.0 * (p / hw2) as f64 + 0.5])
            .collect();
        Silhouette {
            image: img,
            coef,
            component,
            threshold,
        }
    }

    /// Sub-pixel end analysis around the silhouette's far end (module docs).
    /// With `with_face`, also the end-face centre (`end_face`).
    fn fit_end(&self, cam: usize, s: &Silhouette, with_face: bool) -> Option<EndFit> {
        let scene = &self.cameras[cam];
        let (w, h) = (scene.width, scene.height);
        let far = farthest(&s.component, scene.root)?;
        let l = scene.end_length;
        let noise = 3.0 * scene.noise_sigma;
        // Contrast of the end: median |r| of silhouette pixels within L of the far end.
        let mut near: Vec<f64> = s
            .component
            .iter()
            .filter(|p| (p[0] - far[0]).hypot(p[1] - far[1]) <= l)
            .map(|p| f64::from(s.residual(scene, p[0] as usize, p[1] as usize).abs()))
            .collect();
        let contrast = (quantile_rank(&mut near, 0.5) as f32)
            .max(s.threshold)
            .max(noise + 1.0);
        // Covered pixels (coverage > 0) of a box around the far end, computed once.
        let reach = l + 8.0;
        let (x0, x1) = (
            (far[0] - reach).floor().max(0.0) as usize,
            ((far[0] + reach).ceil().max(0.0) as usize).min(w - 1),
        );
        let (y0, y1) = (
            (far[1] - reach).floor().max(0.0) as usize,
            ((far[1] + reach).ceil().max(0.0) as usize).min(h - 1),
        );
        let (hw, hh) = (0.5 * w as f32, 0.5 * h as f32);
        let [ca, cb, cc] = s.coef.map(|v| v as f32);
        let inv = 1.0 / (contrast - noise);
        // Coverage of every box pixel from the median contrast of the end (the frame minus
        // the lit scene `gB`; a mixing fraction for a gripper of uniform grey). (Estimating
        // the gripper's grey locally for exact fractions was tried: it was more accurate on
        // synthetic bars but three times noisier frame to frame on the rendered arm.)
        let mut covered: Vec<(f64, f64, f64)> = Vec::new();
        // The whole window's coverage, zeros included, only for the end-face rule's outline.
        let keep_grid = with_face;
        let (gw, gh) = (x1 + 1 - x0, y1 + 1 - y0);
        let mut grid = CoverageGrid {
            x0,
            y0,
            width: gw,
            height: gh,
            values: Vec::with_capacity(if keep_grid { gw * gh } else { 0 }),
        };
        for y in y0..=y1 {
            let row = ca + cc * (y as f32 + 0.5 - hh) / hh;
            let (img, bg) = (&s.image[y * w..], &scene.background[y * w..]);
            for x in x0..=x1 {
                let g = row + cb * (x as f32 + 0.5 - hw) / hw;
                let c = (((img[x] - g * bg[x]).abs() - noise) * inv).min(1.0);
                if keep_grid {
                    grid.values.push(c.max(0.0));
                }
                if c > 0.0 {
                    covered.push((x as f64, y as f64, f64::from(c)));
                }
            }
        }
        // Direction away from the root to start with; refined from the end's second moments.
        let mut d = [far[0] - scene.root[0], far[1] - scene.root[1]];
        let dn = d[0].hypot(d[1]);
        if dn < 1e-9 {
            return None;
        }
        d = [d[0] / dn, d[1] / dn];
        let mut origin = far;
        let mut result = None;
        for pass in 0..3 {
            // (s, t, coverage) in the end window.
            let mut pts = Vec::new();
            for &(x, y, c) in &covered {
                let (dx, dy) = (x - origin[0], y - origin[1]);
                let sa = dx * d[0] + dy * d[1];
                let ta = -dx * d[1] + dy * d[0];
                if sa >= -l && sa <= 6.0 && ta.abs() <= l {
                    pts.push((sa, ta, c));
                }
            }
            if pts.len() < 4 {
                return None;
            }
            if pass == 0 {
                // Principal axis of the end window.
                let sw: f64 = pts.iter().map(|p| p.2).sum();
                let ms = pts.iter().map(|p| p.2 * p.0).sum::<f64>() / sw;
                let mt = pts.iter().map(|p| p.2 * p.1).sum::<f64>() / sw;
                let (mut css, mut ctt, mut cst) = (0.0, 0.0, 0.0);
                for &(sa, ta, c) in &pts {
                    css += c * (sa - ms) * (sa - ms);
                    ctt += c * (ta - mt) * (ta - mt);
                    cst += c * (sa - ms) * (ta - mt);
                }
                let angle = 0.5 * (2.0 * cst).atan2(css - ctt);
                let (sn, cs) = angle.sin_cos();
                // Rotate d by `angle` (the major axis in (s, t) coordinates).
                let nd = [d[0] * cs - d[1] * sn, d[0] * sn + d[1] * cs];
                d = if nd[0] * d[0] + nd[1] * d[1] >= 0.0 {
                    nd
                } else {
                    [-nd[0], -nd[1]]
                };
                continue;
            }
            // End along d from areas.
            let cut = -0.5 * l.min(12.0);
            let band = 4.0;
            // A pixel's area, projected on d, is spread as the sum of two uniform variables
            // of widths |d_x| and |d_y| (a trapezoid); its share between two cuts is exact
            // for straight edges, so the cuts' sub-pixel positions do not bias the areas.
            let cdf = pixel_cdf(d);
            let share = |sa: f64, lo: f64, hi: f64| cdf(hi - sa) - cdf(lo - sa);
            let beyond: f64 = pts
                .iter()
                .map(|p| p.2 * share(p.0, cut, f64::INFINITY))
                .sum();
            let width: f64 = pts
                .iter()
                .map(|p| p.2 * share(p.0, cut - band, cut))
                .sum::<f64>()
                / band;
            if width <= 0.0 {
                return None;
            }
            let s_end = cut + beyond / width;
            let (mut sw, mut st) = (0.0, 0.0);
            for &(sa, ta, c) in &pts {
                let wgt = c * share(sa, cut - band, s_end);
                sw += wgt;
                st += wgt * ta;
            }
            let t_mid = if sw > 0.0 { st / sw } else { 0.0 };
            let area: f64 = pts.iter().map(|p| p.2).sum();
            let tip = [
                origin[0] + s_end * d[0] - t_mid * d[1],
                origin[1] + s_end * d[1] + t_mid * d[0],
            ];
            if !(tip[0].is_finite() && tip[1].is_finite()) {
                return None;
            }
            origin = tip;
            result = Some(EndFit {
                tip,
                face: None,
                area,
            });
        }
        let fit = result?;
        if !with_face {
            return Some(fit);
        }
        // The end-face centre from the far cap's outer corners (`end_face`), in the end
        // window behind the area estimate of the end; none when the outline shows no two
        // sides (a foreshortened gripper, or another part of the arm).
        Some(EndFit {
            face: end_face_centre(&grid, fit.tip, d, l),
            ..fit
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::recognition::end_face::tests::{
        polygon_coverage, supersampled_coverage, swept_face,
    };
    use crate::recognition::lighting::tests::texture;

    fn scene(bg: Vec<f32>, w: usize, h: usize, root: [f64; 2]) -> TipModel {
        TipModel {
            config: SilhouetteConfig {
                tip: TipRule::FarEnd,
                ..SilhouetteConfig::default()
            },
            correction: None,
            consistency: Vec::new(),
            cameras: vec![CameraScene {
                width: w,
                height: h,
                half_background: halve(&bg, w, h),
                background: bg,
                noise_sigma: 1.0,
                root,
                end_length: 40.0,
                end_area: 1.0,
            }],
        }
    }

    /// The tip of a single-image rule, as `locate` picks it.
    fn rule_tip(m: &TipModel, s: &Silhouette) -> [f64; 2] {
        let fit = m
            .fit_end(0, s, m.config.tip != TipRule::FarEnd)
            .expect("an end");
        match m.config.tip {
            TipRule::EndFace => fit.face.unwrap_or(fit.tip),
            _ => fit.tip,
        }
    }

    /// Renders a bar of half-width `half` along the unit direction `d` from `a` to the end
    /// point `end` (grey 230) over `bg`, with exact-ish anti-aliasing (16×16 supersampling).
    fn bar(bg: &[f32], w: usize, h: usize, a: [f64; 2], end: [f64; 2], half: f64) -> Vec<f32> {
        let (dx, dy) = (end[0] - a[0], end[1] - a[1]);
        let len = dx.hypot(dy);
        let d = [dx / len, dy / len];
        let inside = |p: [f64; 2]| {
            let (px, py) = (p[0] - a[0], p[1] - a[1]);
            let s = px * d[0] + py * d[1];
            let t = -px * d[1] + py * d[0];
            (0.0..=len).contains(&s) && t.abs() <= half
        };
        over(bg, &supersampled_coverage(w, h, inside))
    }

    /// The grey-230 object of coverage `c` drawn over `bg`.
    fn over(bg: &[f32], c: &[f32]) -> Vec<f32> {
        bg.iter()
            .zip(c)
            .map(|(&b, &c)| c * 230.0 + (1.0 - c) * b)
            .collect()
    }

    /// The end of an axis-aligned bar over a textured table is found within 0.2 px wherever it
    /// falls between pixel centres (measured 0.06–0.13 px; the coverage comes from the median
    /// contrast, so the table's grain biases partly covered pixels slightly).
    #[test]
    fn end_of_an_axis_aligned_bar_is_sub_pixel_exact() {
        let (w, h) = (200, 120);
        let bg = texture(w, h);
        let model = scene(bg.clone(), w, h, [5.0, 60.0]);
        for frac in [0.0, 0.2, 0.5, 0.75] {
            let end = [150.0 + frac, 60.3];
            let img = bar(&bg, w, h, [20.0, 60.3], end, 6.0);
            let s = model.silhouette(0, img);
            let tip = rule_tip(&model, &s);
            let err = (tip[0] - end[0]).hypot(tip[1] - end[1]);
            assert!(err < 0.2, "end {end:?}: found {tip:?}");
        }
    }

    /// An oblique bar (any direction) over a textured table: the middle of its end within a
    /// quarter pixel.
    #[test]
    fn end_of_an_oblique_bar_is_sub_pixel() {
        let (w, h) = (200, 160);
        let bg = texture(w, h);
        for (k, angle) in [20.0f64, 110.0, 200.0, 290.0, 45.0].into_iter().enumerate() {
            let (s, c) = angle.to_radians().sin_cos();
            let centre = [100.0, 80.0];
            let a = [centre[0] - 60.0 * c, centre[1] - 60.0 * s];
            let end = [centre[0] + 50.0 * c + 0.01 * k as f64, centre[1] + 50.0 * s];
            let model = scene(bg.clone(), w, h, a);
            let img = bar(&bg, w, h, a, end, 5.0);
            let sil = model.silhouette(0, img);
            let tip = rule_tip(&model, &sil);
            let err = (tip[0] - end[0]).hypot(tip[1] - end[1]);
            assert!(err < 0.25, "angle {angle}: end {end:?}, found {tip:?}");
        }
    }

    /// Renders the gripper end of the `end_face` module's geometry (grey 230, 16×16
    /// supersampled) over `bg`: the end face, a parallelogram with centre `e` and half-edges
    /// `u`, `v`, swept back `len` pixels along the unit direction `d`.
    #[allow(clippy::too_many_arguments)]
    fn prism(
        bg: &[f32],
        w: usize,
        h: usize,
        e: [f64; 2],
        u: [f64; 2],
        v: [f64; 2],
        d: [f64; 2],
        len: f64,
    ) -> Vec<f32> {
        let outline = swept_face(e, u, v, d, len);
        over(bg, &polygon_coverage(&outline, w, h).values)
    }

    /// An oblique end face (the prism of the `end_face` module over a textured table): the
    /// end-face rule finds its centre within a quarter pixel (measured 0.03–0.12 px); the far-end
    /// rule is off by pixels (3.7–5.1 px), as the far outline is a corner of the face, not its
    /// middle.
    #[test]
    fn end_face_rule_finds_the_centre_of_an_oblique_end_face() {
        let (w, h) = (200, 160);
        let bg = texture(w, h);
        for (angle, u, v) in [
            (20.0f64, [3.0, 8.0], [5.0, -2.0]),
            (135.0, [6.0, 2.0], [-1.0, 5.0]),
            (250.0, [2.5, -7.0], [4.0, 3.0]),
        ] {
            let (sn, cs) = angle.to_radians().sin_cos();
            let d = [cs, sn];
            let e = [100.3 + 30.0 * cs, 80.6 + 30.0 * sn];
            let root = [e[0] - 90.0 * cs, e[1] - 90.0 * sn];
            let img = prism(&bg, w, h, e, u, v, d, 60.0);
            let far_end = scene(bg.clone(), w, h, root);
            let end_face = far_end.with_tip_rule(TipRule::EndFace);
            let err = |m: &TipModel| {
                let sil = m.silhouette(0, img.clone());
                let tip = rule_tip(m, &sil);
                (tip[0] - e[0]).hypot(tip[1] - e[1])
            };
            let (good, old) = (err(&end_face), err(&far_end));
            assert!(good < 0.25, "angle {angle}: end-face rule {good} px");
            assert!(old > 1.0, "angle {angle}: far-end rule {old} px");
        }
    }

    /// Both rules agree on the straight end of a bar (an end face seen edge-on).
    #[test]
    fn end_face_rule_on_a_bar_is_the_middle_of_its_end() {
        let (w, h) = (200, 160);
        let bg = texture(w, h);
        for angle in [20.0f64, 110.0, 200.0, 290.0] {
            let (sn, cs) = angle.to_radians().sin_cos();
            let centre = [100.0, 80.0];
            let a = [centre[0] - 60.0 * cs, centre[1] - 60.0 * sn];
            let end = [centre[0] + 50.0 * cs, centre[1] + 50.0 * sn];
            let model = scene(bg.clone(), w, h, a).with_tip_rule(TipRule::EndFace);
            let sil = model.silhouette(0, bar(&bg, w, h, a, end, 6.0));
            let tip = rule_tip(&model, &sil);
            let err = (tip[0] - end[0]).hypot(tip[1] - end[1]);
            assert!(err < 0.25, "angle {angle}: end {end:?}, found {tip:?}");
        }
    }

    /// Settings written before the learned rule (no `tip`, no `correction_poses`) keep the
    /// far-end rule they had; the current defaults round-trip.
    #[test]
    fn settings_files_without_the_new_fields_keep_the_far_end() {
        let old = r#"{"noise_multiple": 5.0, "min_threshold": 8.0, "min_pixels": 50,
                      "min_certainty": 0.3}"#;
        let c: SilhouetteConfig = serde_json::from_str(old).expect("an old file");
        assert_eq!((c.tip, c.correction_poses), (TipRule::FarEnd, 1000));
        assert!(!c.cross_camera_choice);
        // Files written before the gate keep the 0.5 px clip and no spread cap (and a cap,
        // where one is set, doubts training percepts too, as it did when it was written).
        assert_eq!((c.face_gate, c.spread_scale), (0.0, 0.0));
        assert!(c.cap_training);
        let learned = r#"{"noise_multiple": 5.0, "min_threshold": 8.0, "min_pixels": 50,
                          "min_certainty": 0.3, "tip": "learned", "correction_poses": 500,
                          "cross_camera_choice": false}"#;
        let c: SilhouetteConfig = serde_json::from_str(learned).expect("last round's file");
        assert_eq!(
            (c.tip, c.face_gate, c.spread_scale),
            (TipRule::Learned, 0.0, 0.0)
        );
        // An opt-in: off by default.
        let d = SilhouetteConfig::default();
        assert_eq!((d.face_gate, d.spread_scale), (0.0, 0.0));
        assert!(!SilhouetteConfig::default().cross_camera_choice);
        let now = SilhouetteConfig::default();
        let back: SilhouetteConfig =
            serde_json::from_str(&serde_json::to_string(&now).unwrap()).unwrap();
        assert_eq!((back, now.tip), (now.clone(), TipRule::Learned));
    }

    /// Two cameras of the epipolar tests' pinhole scene: at every pose one camera's rule tip is
    /// wrong (12 px off the other view's epipolar line) and its end-face tip right. With the
    /// cross-camera choice the consistent pair is reported with a high certainty; without
    /// it, the wrong tip is reported and doubted.
    #[test]
    fn the_cross_camera_choice_takes_the_consistent_candidate() {
        use crate::recognition::epipolar::tests::scene as two_views;
        let (a, b) = two_views(200, 1);
        let (g, _) = EpipolarGeometry::fit(&a, &b, 7).unwrap();
        let one = scene(vec![0.0; 64 * 64], 64, 64, [0.0, 0.0]);
        let model = TipModel {
            cameras: vec![one.cameras[0].clone(), one.cameras[0].clone()],
            consistency: vec![g.clone()],
            ..one
        }
        .with_cross_camera_choice(true);
        let off = |p: [f64; 2], q: [f64; 2]| {
            let l = g.matrix() * nalgebra::Vector3::new(p[0], p[1], 1.0);
            let n = l[0].hypot(l[1]);
            [q[0] + 12.0 * l[0] / n, q[1] + 12.0 * l[1] / n]
        };
        let (na, nb) = two_views(8, 31);
        for (k, (p, q)) in na.iter().zip(&nb).enumerate() {
            let end = |far_end, end_face| EndEstimate {
                far_end,
                end_face,
                certainty: 0.9,
            };
            // Alternate the camera whose rule tip is wrong; the other has no end face.
            let ends = if k % 2 == 0 {
                [end(*p, None), end(off(*p, *q), Some(*q))]
            } else {
                let wrong0 = [p[0] + 13.0, p[1] - 9.0];
                [end(wrong0, Some(*p)), end(*q, None)]
            };
            let chosen = model.tips(&ends).unwrap();
            assert_eq!(chosen[0].position, *p);
            assert_eq!(chosen[1].position, *q);
            assert!(chosen.iter().all(|l| l.certainty > 0.85), "{chosen:?}");
            let plain = model.with_cross_camera_choice(false).tips(&ends).unwrap();
            assert_eq!(plain[0].position, ends[0].far_end);
            assert_eq!(plain[1].position, ends[1].far_end);
            assert!(plain.iter().all(|l| l.certainty < 0.05), "{plain:?}");
        }
    }

    /// A one-camera learned model whose correction is sure well below `u = 250` and unsure beyond
    /// (offsets alternating 8 px apart from pose to pose there).
    fn gated_model(spread_scale: f64) -> TipModel {
        let samples: Vec<CorrectionSample> = (0..400)
            .map(|k| {
                let (i, j) = (k / 20, k % 20);
                let f = [100.0 + 10.0 * i as f64, 80.0 + 8.0 * j as f64];
                let o = match (f[0] >= 250.0, (i + j) % 2) {
                    (true, 0) => 4.0,
                    (true, _) => -4.0,
                    (false, _) => 1.0,
                };
                CorrectionSample {
                    far_ends: vec![f],
                    end_faces: vec![Some([f[0] + o, f[1]])],
                }
            })
            .collect();
        let (correction, _) = TipCorrection::learn(&samples, &[10.0]).unwrap();
        let one = scene(vec![0.0; 64 * 64], 64, 64, [0.0, 0.0]);
        TipModel {
            config: SilhouetteConfig {
                tip: TipRule::Learned,
                spread_scale,
                ..SilhouetteConfig::default()
            },
            correction: Some(correction),
            ..one
        }
    }

    /// Where the camera shows no end face, an unsure correction caps the certainty (so a
    /// percept policy re-captures and refuses it); a sure one, or an end face, leaves it.
    #[test]
    fn an_unsure_correction_without_an_end_face_is_doubted() {
        let model = gated_model(MEASURED_SPREAD_SCALE);
        let end = |far_end, end_face| EndEstimate {
            far_end,
            end_face,
            certainty: 0.9,
        };
        let sure = model.tips(&[end([105.0, 120.0], None)]).unwrap()[0];
        assert!(sure.certainty > 0.85, "{sure:?}");
        let unsure = model.tips(&[end([275.0, 120.0], None)]).unwrap()[0];
        assert!(unsure.certainty < 0.05, "{unsure:?}");
        let face = model
            .tips(&[end([275.0, 120.0], Some([276.0, 120.0]))])
            .unwrap()[0];
        assert_eq!(face.certainty, 0.9);
        // Without the cap (scale 0, as in files written before it) nothing is doubted.
        let off = gated_model(0.0).tips(&[end([275.0, 120.0], None)]).unwrap()[0];
        assert_eq!(off.certainty, 0.9);
    }

    /// With `cap_training` off, a training move's percept keeps its certainty where the servo's
    /// is capped (same ends, same tip); with it on (the default), both are capped.
    #[test]
    fn the_spread_cap_can_spare_training_percepts() {
        let end = |far_end| EndEstimate {
            far_end,
            end_face: None,
            certainty: 0.9,
        };
        let unsure = [end([275.0, 120.0])];
        let capped_everywhere = gated_model(MEASURED_SPREAD_SCALE);
        assert!(capped_everywhere.config().cap_training);
        for used in [PerceptUse::Servo, PerceptUse::Training] {
            let l = capped_everywhere.tips_for(&unsure, used).unwrap()[0];
            assert!(l.certainty < 0.05, "{used:?} {l:?}");
        }
        let servo_only = TipModel {
            config: SilhouetteConfig {
                cap_training: false,
                ..capped_everywhere.config().clone()
            },
            ..capped_everywhere.clone()
        };
        let servo = servo_only.tips_for(&unsure, PerceptUse::Servo).unwrap()[0];
        let training = servo_only.tips_for(&unsure, PerceptUse::Training).unwrap()[0];
        assert!(servo.certainty < 0.05, "{servo:?}");
        assert_eq!(training.certainty, 0.9);
        assert_eq!(training.position, servo.position);
        // `tips` and `locate_all` are the servo's percept.
        assert_eq!(servo_only.tips(&unsure).unwrap()[0], servo);
        // A sure correction is not capped for either use.
        let sure = [end([105.0, 120.0])];
        for used in [PerceptUse::Servo, PerceptUse::Training] {
            assert!(servo_only.tips_for(&sure, used).unwrap()[0].certainty > 0.85);
        }
    }

    #[test]
    fn bad_settings_and_empty_training_are_typed_errors() {
        for (bad, name) in [
            (
                SilhouetteConfig {
                    face_gate: -1.0,
                    ..SilhouetteConfig::default()
                },
                "face_gate",
            ),
            (
                SilhouetteConfig {
                    spread_scale: f64::NAN,
                    ..SilhouetteConfig::default()
                },
                "spread_scale",
            ),
        ] {
            assert!(matches!(
                TipModel::learn(&bad, &[]),
                Err(ServoError::InvalidParameter { name: n, .. }) if n == name
            ));
        }
        let bad = SilhouetteConfig {
            noise_multiple: f32::NAN,
            ..SilhouetteConfig::default()
        };
        assert!(matches!(
            TipModel::learn(&bad, &[]),
            Err(ServoError::InvalidParameter {
                name: "noise_multiple",
                ..
            })
        ));
        assert!(matches!(
            TipModel::learn(&SilhouetteConfig::default(), &[]),
            Err(ServoError::NotEnoughData(_))
        ));
    }
}
