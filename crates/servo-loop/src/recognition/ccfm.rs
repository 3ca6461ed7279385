//! The channel-coded feature map model (`ccfm`, [`GripperModel`]; not on the servo path: the
//! servo percept is [`crate::TipModel`]): prototype channel-coded feature maps around the gripper point, learned
//! from the changed regions of gripper moves, and their localisation in new images.
//!
//! **Learning.** For every training view (the arm at some pose, one image with the gripper
//! open and one with it closed) and camera: the changed region ([`changed_region`]) gives the
//! gripper point; the `cells × cells × orientations` descriptor of each of the two images at
//! that point ([`FeatureMap::descriptor`]) is a sample of the gripper's appearance. Samples are
//! normalised to unit length and clustered (spherical k-means, deterministic farthest-point
//! start) into a few prototypes per camera: the gripper looks different from different sides.
//!
//! Each prototype then has the mean descriptor of background positions (a grid away from the
//! gripper) subtracted, and is normalised to zero mean and unit length.
//!
//! **Localisation.** The score of a position is the largest normalised cross-correlation
//! between its descriptor and a prototype. A coarse search (every second spatial channel over the image,
//! or every channel within a radius of a hint), hill climbing on the channel grid from the best
//! three coarse candidates, a 1-pixel grid over ±1 channel, and a parabola through the best
//! score and its neighbours give a sub-pixel position; its score is the certainty.

use image::GrayImage;
use serde::{Deserialize, Serialize};

use crate::error::{Result, ServoError};
use crate::recognition::change::{changed_mask, changed_region};
use crate::recognition::features::{FeatureMap, FeatureParams};
use crate::recognition::image::{FloatImage, half_resolution};
use crate::recognition::{Localisation, TrainingView, training_image_sizes};

/// Settings of recognition.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RecognitionConfig {
    /// Spatial channel spacing (half-resolution pixels; 3 = 6 full pixels).
    pub block: usize,
    /// Orientation channels.
    pub orientations: usize,
    /// Gradient magnitude of half weight (grey levels per half-resolution pixel).
    pub magnitude_half: f32,
    /// Grey-level channels (0 = gradients only).
    pub intensities: usize,
    /// Descriptor size in spatial channels per side.
    pub cells: usize,
    /// Prototypes per camera.
    pub prototypes: usize,
    /// Localisations with a lower certainty are failures.
    pub min_certainty: f64,
    /// Smallest changed region (half-resolution pixels) accepted as a training sample.
    pub min_change_pixels: usize,
    /// Search radius around a hint (full-resolution pixels).
    pub search_radius: f64,
}

impl Default for RecognitionConfig {
    fn default() -> Self {
        RecognitionConfig {
            block: 3,
            orientations: 8,
            magnitude_half: 40.0,
            intensities: 8,
            cells: 8,
            prototypes: 4,
            min_certainty: 0.6,
            min_change_pixels: 20,
            search_radius: 60.0,
        }
    }
}

impl RecognitionConfig {
    fn validate(&self) -> Result<()> {
        if self.block == 0 {
            return Err(ServoError::invalid("block", "must be at least 1"));
        }
        if self.orientations < 3 {
            return Err(ServoError::invalid("orientations", "must be at least 3"));
        }
        if !(self.magnitude_half.is_finite() && self.magnitude_half > 0.0) {
            return Err(ServoError::invalid(
                "magnitude_half",
                "must be finite and positive",
            ));
        }
        if self.cells == 0 || self.prototypes == 0 {
            return Err(ServoError::invalid(
                "cells",
                "cells and prototypes must be at least 1",
            ));
        }
        // A descriptor holds `cells² × channels` values (`FeatureMap::descriptor`): sizes
        // whose product overflows are refused here (learning sized descriptors by it).
        let Some(channels) = self.feature_params().channels() else {
            return Err(ServoError::invalid(
                "intensities",
                "too many channels per cell",
            ));
        };
        if channels
            .checked_mul(self.cells)
            .and_then(|n| n.checked_mul(self.cells))
            .is_none()
        {
            return Err(ServoError::invalid(
                "cells",
                "a descriptor of cells² × channels values overflows",
            ));
        }
        if !(0.0..=1.0).contains(&self.min_certainty) {
            return Err(ServoError::invalid("min_certainty", "must lie in [0, 1]"));
        }
        if !(self.search_radius.is_finite() && self.search_radius > 0.0) {
            return Err(ServoError::invalid(
                "search_radius",
                "must be finite and positive",
            ));
        }
        Ok(())
    }

    fn feature_params(&self) -> FeatureParams {
        FeatureParams {
            block: self.block,
            orientations: self.orientations,
            magnitude_half: self.magnitude_half,
            intensities: self.intensities,
        }
    }
}

/// What learning the model used.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct RecognitionReport {
    /// Views offered.
    pub views: usize,
    /// Per camera: views with a usable changed region.
    pub used: Vec<usize>,
    /// Per camera and used view: the gripper point from the change (full-resolution pixels).
    pub change_points: Vec<Vec<[f64; 2]>>,
}

/// The learned gripper appearance, per camera.
///
/// Deserialising checks the model as [`GripperModel::learn`] builds it: the settings (the
/// checks `learn` applies), at least one camera, and per camera at least one prototype, each
/// a finite descriptor of the settings' length (`cells² × (orientations + intensities)`); a
/// file that fails is an error, never a model that scores against truncated prototypes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "GripperModelFile")]
pub struct GripperModel {
    config: RecognitionConfig,
    /// Per camera, unit-length prototype descriptors.
    prototypes: Vec<Vec<Vec<f32>>>,
    image_size: [u32; 2],
}

/// The serialised form of a [`GripperModel`], checked on deserialisation.
#[derive(Deserialize)]
struct GripperModelFile {
    config: RecognitionConfig,
    prototypes: Vec<Vec<Vec<f32>>>,
    image_size: [u32; 2],
}

impl TryFrom<GripperModelFile> for GripperModel {
    type Error = ServoError;

    fn try_from(f: GripperModelFile) -> Result<Self> {
        f.config.validate()?;
        if f.prototypes.is_empty() {
            return Err(ServoError::invalid(
                "prototypes",
                "a gripper model needs at least one camera",
            ));
        }
        // The descriptor length of `FeatureMap::descriptor` with these settings (no prototype
        // can be as long when it overflows).
        let cells = f.config.cells;
        let len = f
            .config
            .feature_params()
            .channels()
            .and_then(|n| n.checked_mul(cells)?.checked_mul(cells))
            .unwrap_or(usize::MAX);
        for (cam, protos) in f.prototypes.iter().enumerate() {
            if protos.is_empty() {
                return Err(ServoError::invalid(
                    "prototypes",
                    &format!("camera {cam} has no prototype"),
                ));
            }
            if let Some(p) = protos
                .iter()
                .find(|p| p.len() != len || p.iter().any(|v| !v.is_finite()))
            {
                return Err(ServoError::invalid(
                    "prototypes",
                    &format!(
                        "camera {cam} has a prototype of {} values (finite ones, {len} expected)",
                        p.len()
                    ),
                ));
            }
        }
        Ok(GripperModel {
            config: f.config,
            prototypes: f.prototypes,
            image_size: f.image_size,
        })
    }
}

impl GripperModel {
    /// Learns the model from training views (module doc). Errors: no views, inconsistent
    /// camera counts or image sizes, or a camera without any usable changed region.
    pub fn learn(
        config: &RecognitionConfig,
        views: &[TrainingView],
    ) -> Result<(GripperModel, RecognitionReport)> {
        config.validate()?;
        let sizes = training_image_sizes(views)?;
        let cams = sizes.len();
        let size = sizes[0];
        if sizes.iter().any(|s| *s != size) {
            return Err(ServoError::InvalidParameter {
                name: "views",
                reason: "all cameras' images must have the same size".into(),
            });
        }
        let fp = config.feature_params();
        let mut samples: Vec<Vec<Vec<f32>>> = vec![Vec::new(); cams];
        let mut background: Vec<Vec<f32>> = vec![Vec::new(); cams];
        let mut n_background = vec![0usize; cams];
        let mut report = RecognitionReport {
            views: views.len(),
            used: vec![0; cams],
            change_points: vec![Vec::new(); cams],
        };
        for view in views {
            for cam in 0..cams {
                let (a, b) = (
                    half_resolution(&view.before[cam]),
                    half_resolution(&view.after[cam]),
                );
                let Some(region) = changed_region(&a, &b, config.min_change_pixels) else {
                    continue;
                };
                report.used[cam] += 1;
                report.change_points[cam].push(region.centroid);
                for img in [&a, &b] {
                    let map = FeatureMap::compute(img, &fp)?;
                    let mut d = Vec::new();
                    map.descriptor(
                        map.to_channel(region.centroid[0]),
                        map.to_channel(region.centroid[1]),
                        config.cells,
                        &mut d,
                    );
                    if normalise(&mut d) {
                        samples[cam].push(d.clone());
                    }
                    // Background samples: a grid of positions away from the gripper.
                    let (gx, gy) = (
                        map.to_channel(region.centroid[0]),
                        map.to_channel(region.centroid[1]),
                    );
                    let far = config.cells as f64;
                    for j in (0..map.blocks_y).step_by(4) {
                        for i in (0..map.blocks_x).step_by(4) {
                            if (i as f64 - gx).abs() < far && (j as f64 - gy).abs() < far {
                                continue;
                            }
                            map.descriptor(i as f64, j as f64, config.cells, &mut d);
                            if normalise(&mut d) {
                                let bg = &mut background[cam];
                                bg.resize(d.len(), 0.0);
                                bg.iter_mut().zip(&d).for_each(|(b, v)| *b += v);
                                n_background[cam] += 1;
                            }
                        }
                    }
                }
            }
        }
        let mut prototypes = Vec::with_capacity(cams);
        for (cam, s) in samples.iter().enumerate() {
            if s.is_empty() {
                return Err(ServoError::NotEnoughData(format!(
                    "no gripper move changed camera {cam}'s image"
                )));
            }
            // Discriminative prototypes: cluster centre minus the mean background descriptor.
            let mut protos = spherical_kmeans(s, config.prototypes);
            if n_background[cam] > 0 {
                let k = n_background[cam] as f32;
                for p in &mut protos {
                    p.iter_mut()
                        .zip(&background[cam])
                        .for_each(|(v, b)| *v -= b / k);
                    normalise(p);
                }
            }
            prototypes.push(protos);
        }
        Ok((
            GripperModel {
                config: config.clone(),
                prototypes,
                image_size: size,
            },
            report,
        ))
    }

    /// The configuration.
    pub fn config(&self) -> &RecognitionConfig {
        &self.config
    }

    /// Number of cameras the model knows.
    pub fn num_cameras(&self) -> usize {
        self.prototypes.len()
    }

    /// Image size `[width, height]` the model was learned on.
    pub fn image_size(&self) -> [u32; 2] {
        self.image_size
    }

    /// Prototypes of camera `cam` (unit-length descriptors); `None` for a camera the model
    /// does not have.
    pub fn prototypes(&self, cam: usize) -> Option<&[Vec<f32>]> {
        self.prototypes.get(cam).map(Vec::as_slice)
    }

    /// Camera `cam`'s prototypes, [`ServoError::DimensionMismatch`] (`camera index`) for a
    /// camera the model does not have; and a `hint`, when given, finite
    /// ([`ServoError::InvalidParameter`] `hint`; a non-finite one used to be taken as none,
    /// a search of the whole image).
    fn camera(&self, cam: usize, hint: Option<[f64; 2]>) -> Result<&[Vec<f32>]> {
        let protos = self.prototypes(cam).ok_or(ServoError::DimensionMismatch {
            what: "camera index",
            expected: self.prototypes.len(),
            got: cam,
        })?;
        if let Some(h) = hint.filter(|h| !h.iter().all(|v| v.is_finite())) {
            return Err(ServoError::InvalidParameter {
                name: "hint",
                reason: format!("{h:?}: a finite position expected"),
            });
        }
        Ok(protos)
    }

    /// Finds the gripper in camera `cam`'s image, searching within `search_radius` of `hint`
    /// if given, else everywhere. Errors: unknown camera, wrong image size, certainty below
    /// `min_certainty` ([`ServoError::RecognitionFailed`]), a non-finite hint.
    pub fn locate(
        &self,
        cam: usize,
        img: &GrayImage,
        hint: Option<[f64; 2]>,
    ) -> Result<Localisation> {
        let protos = self.camera(cam, hint)?;
        if [img.width(), img.height()] != self.image_size {
            return Err(ServoError::InvalidParameter {
                name: "image",
                reason: format!(
                    "size {}×{} differs from the trained {}×{}",
                    img.width(),
                    img.height(),
                    self.image_size[0],
                    self.image_size[1]
                ),
            });
        }
        let map = FeatureMap::compute(&half_resolution(img), &self.config.feature_params())?;
        let loc = self.search(&map, protos, hint, None);
        self.checked(cam, loc)
    }

    /// Finds the gripper in camera `cam`'s image `img`, taken after the arm moved from where
    /// it was in `previous` (action precedes perception once more): only positions within one
    /// spatial channel of a changed pixel are candidates, which rules out the static scene
    /// (clutter, table). Falls back to the whole image when nothing changed.
    pub fn locate_after_move(
        &self,
        cam: usize,
        img: &GrayImage,
        previous: &GrayImage,
    ) -> Result<Localisation> {
        if [previous.width(), previous.height()] != [img.width(), img.height()] {
            return Err(ServoError::InvalidParameter {
                name: "previous",
                reason: "the previous image has a different size".into(),
            });
        }
        // Size and camera checks as in `locate`.
        let protos = self.camera(cam, None)?;
        if [img.width(), img.height()] != self.image_size {
            return self.locate(cam, img, None);
        }
        let (a, b) = (half_resolution(previous), half_resolution(img));
        let map = FeatureMap::compute(&b, &self.config.feature_params())?;
        let allowed = changed_mask(&a, &b).and_then(|mask| {
            let (bx, by) = (map.blocks_x, map.blocks_y);
            let mut allowed = vec![false; bx * by];
            let blk = self.config.block;
            let mut any = false;
            for (i, _) in mask.iter().enumerate().filter(|(_, m)| **m) {
                let (x, y) = (i % a.width / blk, i / a.width / blk);
                for j in y.saturating_sub(1)..=(y + 1).min(by - 1) {
                    for k in x.saturating_sub(1)..=(x + 1).min(bx - 1) {
                        allowed[j * bx + k] = true;
                    }
                }
                any = true;
            }
            any.then_some(allowed)
        });
        let loc = self.search(&map, protos, None, allowed.as_deref());
        self.checked(cam, loc)
    }

    fn checked(&self, cam: usize, loc: Localisation) -> Result<Localisation> {
        if loc.certainty < self.config.min_certainty || !loc.certainty.is_finite() {
            return Err(ServoError::RecognitionFailed {
                camera: cam,
                certainty: if loc.certainty.is_finite() {
                    loc.certainty
                } else {
                    0.0
                },
                min: self.config.min_certainty,
            });
        }
        Ok(loc)
    }

    /// Localises in a precomputed half-resolution image (no certainty check). Errors: as
    /// [`Self::locate`] for the camera and the hint (an unknown camera used to panic).
    pub fn locate_unchecked(
        &self,
        cam: usize,
        img: &FloatImage,
        hint: Option<[f64; 2]>,
    ) -> Result<Localisation> {
        let protos = self.camera(cam, hint)?;
        let map = FeatureMap::compute(img, &self.config.feature_params())?;
        Ok(self.search(&map, protos, hint, None))
    }

    fn search(
        &self,
        map: &FeatureMap,
        protos: &[Vec<f32>],
        hint: Option<[f64; 2]>,
        allowed: Option<&[bool]>,
    ) -> Localisation {
        let cells = self.config.cells;
        let mut buf = Vec::new();
        let dim = protos.first().map_or(0, Vec::len) as f32;
        let mut score = |tx: f64, ty: f64| -> f64 {
            map.descriptor(tx, ty, cells, &mut buf);
            let (sum, sumsq) = buf
                .iter()
                .fold((0.0f32, 0.0f32), |(s, q), &v| (s + v, q + v * v));
            let var = sumsq - sum * sum / dim;
            if var <= 1e-12 {
                return 0.0;
            }
            let best = protos
                .iter()
                .map(|p| p.iter().zip(&buf).map(|(a, b)| a * b).sum::<f32>())
                .fold(f32::MIN, f32::max);
            f64::from(best / var.sqrt())
        };
        // Coarse candidates on the channel grid.
        let (bx, by) = (map.blocks_x as i64, map.blocks_y as i64);
        let (x0, x1, y0, y1, step) = match hint {
            // A hint is finite: every entry point checks it (`camera`).
            Some([u, v]) => {
                let r = self.config.search_radius / map.scale;
                let (cx, cy) = (map.to_channel(u), map.to_channel(v));
                (
                    ((cx - r).floor() as i64).max(0),
                    ((cx + r).ceil() as i64).min(bx - 1),
                    ((cy - r).floor() as i64).max(0),
                    ((cy + r).ceil() as i64).min(by - 1),
                    1,
                )
            }
            _ if allowed.is_some() => (0, bx - 1, 0, by - 1, 1),
            _ => (0, bx - 1, 0, by - 1, 2),
        };
        let mut coarse: Vec<(f64, i64, i64)> = Vec::new();
        let mut y = y0;
        while y <= y1 {
            let mut x = x0;
            while x <= x1 {
                if allowed.is_none_or(|a| a[(y * bx + x) as usize]) {
                    coarse.push((score(x as f64, y as f64), x, y));
                }
                x += step;
            }
            y += step;
        }
        if coarse.is_empty() {
            return Localisation {
                position: [f64::NAN, f64::NAN],
                certainty: 0.0,
            };
        }
        coarse.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
        let mut starts: Vec<(i64, i64)> = Vec::new();
        for &(_, x, y) in &coarse {
            if starts
                .iter()
                .all(|&(sx, sy)| (sx - x).abs() > 2 || (sy - y).abs() > 2)
            {
                starts.push((x, y));
                if starts.len() == 3 {
                    break;
                }
            }
        }
        // Hill climbing on the channel grid.
        let mut best = (f64::MIN, 0i64, 0i64);
        for (mut x, mut y) in starts {
            let mut s = score(x as f64, y as f64);
            for _ in 0..20 {
                let mut moved = false;
                for (dx, dy) in [
                    (-1, 0),
                    (1, 0),
                    (0, -1),
                    (0, 1),
                    (-1, -1),
                    (1, 1),
                    (-1, 1),
                    (1, -1),
                ] {
                    let (nx, ny) = (x + dx, y + dy);
                    if nx < 0 || ny < 0 || nx >= bx || ny >= by {
                        continue;
                    }
                    let ns = score(nx as f64, ny as f64);
                    if ns > s {
                        (s, x, y) = (ns, nx, ny);
                        moved = true;
                    }
                }
                if !moved {
                    break;
                }
            }
            if s > best.0 {
                best = (s, x, y);
            }
        }
        // 1-pixel grid over ±1 channel, then a parabola per axis.
        let (cu, cv) = (map.to_pixel(best.1 as f64), map.to_pixel(best.2 as f64));
        let half = map.scale.round() as i64;
        let mut fine = (f64::MIN, cu, cv);
        for dv in -half..=half {
            for du in -half..=half {
                let (u, v) = (cu + du as f64, cv + dv as f64);
                let s = score(map.to_channel(u), map.to_channel(v));
                if s > fine.0 {
                    fine = (s, u, v);
                }
            }
        }
        let (s0, u, v) = fine;
        let at = |u: f64, v: f64, score: &mut dyn FnMut(f64, f64) -> f64| {
            score(map.to_channel(u), map.to_channel(v))
        };
        let (su_m, su_p) = (at(u - 1.0, v, &mut score), at(u + 1.0, v, &mut score));
        let (sv_m, sv_p) = (at(u, v - 1.0, &mut score), at(u, v + 1.0, &mut score));
        let vertex = |m: f64, c: f64, p: f64| {
            let den = m - 2.0 * c + p;
            if den < 0.0 {
                (0.5 * (m - p) / den).clamp(-0.5, 0.5)
            } else {
                0.0
            }
        };
        Localisation {
            position: [u + vertex(su_m, s0, su_p), v + vertex(sv_m, s0, sv_p)],
            certainty: s0.clamp(0.0, 1.0),
        }
    }
}

/// Subtracts the mean and scales to unit length; false if the result is zero.
fn normalise(d: &mut [f32]) -> bool {
    let mean = d.iter().sum::<f32>() / d.len().max(1) as f32;
    d.iter_mut().for_each(|v| *v -= mean);
    let n: f32 = d.iter().map(|v| v * v).sum::<f32>().sqrt();
    if n > 0.0 && n.is_finite() {
        d.iter_mut().for_each(|v| *v /= n);
        true
    } else {
        false
    }
}

/// Spherical k-means with a deterministic farthest-point start: `k` unit prototypes.
fn spherical_kmeans(samples: &[Vec<f32>], k: usize) -> Vec<Vec<f32>> {
    let dim = samples[0].len();
    let dot = |a: &[f32], b: &[f32]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f32>();
    let mut mean = vec![0.0f32; dim];
    for s in samples {
        mean.iter_mut().zip(s).for_each(|(m, v)| *m += v);
    }
    normalise(&mut mean);
    let first = (0..samples.len())
        .max_by(|&a, &b| {
            dot(&samples[a], &mean)
                .total_cmp(&dot(&samples[b], &mean))
                .then(b.cmp(&a))
        })
        .unwrap_or(0);
    let mut protos = vec![samples[first].clone()];
    while protos.len() < k.min(samples.len()) {
        let far = (0..samples.len())
            .min_by(|&a, &b| {
                let sa = protos
                    .iter()
                    .map(|p| dot(p, &samples[a]))
                    .fold(f32::MIN, f32::max);
                let sb = protos
                    .iter()
                    .map(|p| dot(p, &samples[b]))
                    .fold(f32::MIN, f32::max);
                sa.total_cmp(&sb).then(a.cmp(&b))
            })
            .unwrap_or(0);
        protos.push(samples[far].clone());
    }
    for _ in 0..10 {
        let mut sums = vec![vec![0.0f32; dim]; protos.len()];
        for s in samples {
            let (best, _) = protos
                .iter()
                .enumerate()
                .map(|(i, p)| (i, dot(p, s)))
                .fold((0, f32::MIN), |acc, x| if x.1 > acc.1 { x } else { acc });
            sums[best].iter_mut().zip(s).for_each(|(m, v)| *m += v);
        }
        for (p, mut s) in protos.iter_mut().zip(sums) {
            if normalise(&mut s) {
                *p = s;
            }
        }
    }
    protos
}
