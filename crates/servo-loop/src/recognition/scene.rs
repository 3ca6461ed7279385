//! One camera's learned static scene: the lighting-normalised per-pixel median of frames with
//! the arm at random poses, the chain's root and the gripper end's size (`silhouette` module
//! docs, steps 1–3).

use serde::{Deserialize, Serialize};

use crate::recognition::image::halve;
use crate::recognition::lighting::{fit_lighting, lighting_field};

/// One camera's learned scene and gripper size.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
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

impl CameraScene {
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
