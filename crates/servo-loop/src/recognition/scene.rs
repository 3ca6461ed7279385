//! One camera's learned static scene: the lighting-normalised per-pixel median of frames with
//! the arm at random poses, the chain's root and the gripper end's size (`silhouette` module
//! docs, steps 1–3).

use serde::{Deserialize, Serialize};

use crate::error::{Result, ServoError};
use crate::recognition::image::halve;
use crate::recognition::lighting::{fit_lighting, lighting_field};

/// Smallest image side (pixels) a scene is learned on ([`crate::TipModel::learn`]).
pub(super) const MIN_SIDE: usize = 8;

/// One camera's learned scene and gripper size.
///
/// Deserialising applies [`CameraScene::check`]: a scene read from an edited or truncated
/// file is an error, never a recogniser that panics on its first image.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "CameraSceneFile")]
pub struct CameraScene {
    pub(super) width: usize,
    pub(super) height: usize,
    /// The static scene (lighting-normalised median), row-major.
    pub(super) background: Vec<f32>,
    /// The same at half resolution (2×2 means).
    pub(super) half_background: Vec<f32>,
    /// Per-pixel noise of a frame against the scene (grey levels).
    pub(super) noise_sigma: f32,
    /// The least-moving part of the arm (pixels).
    pub(super) root: [f64; 2],
    /// Length of the gripper end window (pixels).
    pub(super) end_length: f64,
    /// Median covered area of the end window (pixels).
    pub(super) end_area: f64,
}

/// The serialised form of a [`CameraScene`], checked by [`CameraScene::check`] on
/// deserialisation.
#[derive(Deserialize)]
struct CameraSceneFile {
    width: usize,
    height: usize,
    background: Vec<f32>,
    half_background: Vec<f32>,
    noise_sigma: f32,
    root: [f64; 2],
    end_length: f64,
    end_area: f64,
}

impl TryFrom<CameraSceneFile> for CameraScene {
    type Error = ServoError;

    fn try_from(f: CameraSceneFile) -> Result<Self> {
        let scene = CameraScene {
            width: f.width,
            height: f.height,
            background: f.background,
            half_background: f.half_background,
            noise_sigma: f.noise_sigma,
            root: f.root,
            end_length: f.end_length,
            end_area: f.end_area,
        };
        scene.check()?;
        Ok(scene)
    }
}

impl CameraScene {
    /// Checks what learning guarantees ([`crate::TipModel::learn`]): both sides at least 8
    /// pixels, a finite scene of `width × height` grey levels and its half-resolution copy of
    /// `⌊width/2⌋ × ⌊height/2⌋`, a finite positive noise level, end length and end area, a
    /// finite root. [`ServoError::InvalidParameter`] (`camera scene`) otherwise.
    pub fn check(&self) -> Result<()> {
        let bad = |reason: String| Err(ServoError::invalid("camera scene", &reason));
        let (w, h) = (self.width, self.height);
        if w < MIN_SIDE || h < MIN_SIDE {
            return bad(format!("{w}×{h} is too small"));
        }
        let sizes = [
            ("background", &self.background, w.checked_mul(h)),
            (
                "half_background",
                &self.half_background,
                Some((w / 2) * (h / 2)),
            ),
        ];
        for (name, values, expected) in sizes {
            if Some(values.len()) != expected {
                return bad(format!(
                    "{name} has {} values, a {w}×{h} image needs {}",
                    values.len(),
                    expected.map_or("more".into(), |n| n.to_string())
                ));
            }
            if values.iter().any(|v| !v.is_finite()) {
                return bad(format!("{name} is not finite"));
            }
        }
        if !(self.noise_sigma.is_finite() && self.noise_sigma > 0.0) {
            return bad(format!(
                "noise_sigma {} must be finite and positive",
                self.noise_sigma
            ));
        }
        for (name, v) in [("end_length", self.end_length), ("end_area", self.end_area)] {
            if !(v.is_finite() && v > 0.0) {
                return bad(format!("{name} {v} must be finite and positive"));
            }
        }
        if !self.root.iter().all(|v| v.is_finite()) {
            return bad(format!("root {:?} is not finite", self.root));
        }
        Ok(())
    }

    /// The learned static scene (row-major grey levels, frame lighting normalised).
    pub fn background(&self) -> &[f32] {
        &self.background
    }

    /// The root of the chain (pixels).
    pub fn root(&self) -> [f64; 2] {
        self.root
    }

    /// The end window's length (pixels).
    pub fn end_length(&self) -> f64 {
        self.end_length
    }

    /// The learned per-pixel noise (grey levels).
    pub fn noise_sigma(&self) -> f32 {
        self.noise_sigma
    }

    /// Image width (pixels).
    pub fn width(&self) -> usize {
        self.width
    }

    /// Image height (pixels).
    pub fn height(&self) -> usize {
        self.height
    }
}

/// The static scene of one camera from frames with the arm at random poses: the per-pixel
/// median of lighting-normalised frames (two rounds).
pub(super) fn learn_scene(frames: &[Vec<f32>], w: usize, h: usize) -> CameraScene {
    let mut bg = pixel_median(frames, w * h, None);
    for _ in 0..2 {
        let gains: Vec<Vec<f32>> = frames
            .iter()
            .map(|f| {
                let coef = fit_lighting(f, &bg, w, h);
                lighting_field(w, h, coef)
            })
            .collect();
        bg = pixel_median(frames, w * h, Some(&gains));
    }
    CameraScene {
        width: w,
        height: h,
        half_background: halve(&bg, w, h),
        background: bg,
        noise_sigma: 1.0,
        root: [0.0, 0.0],
        end_length: 20.0,
        end_area: 1.0,
    }
}

/// Per-pixel median over frames (each divided by its gain field if given).
pub(super) fn pixel_median(frames: &[Vec<f32>], n: usize, gains: Option<&[Vec<f32>]>) -> Vec<f32> {
    let mut out = vec![0.0f32; n];
    let mut vals = vec![0.0f32; frames.len()];
    for (i, o) in out.iter_mut().enumerate() {
        for (k, f) in frames.iter().enumerate() {
            vals[k] = match gains {
                Some(g) if g[k][i] > 1e-3 => f[i] / g[k][i],
                _ => f[i],
            };
        }
        let mid = vals.len() / 2;
        *o = *vals.select_nth_unstable_by(mid, f32::total_cmp).1;
    }
    out
}
