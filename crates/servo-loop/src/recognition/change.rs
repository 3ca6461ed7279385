//! Action precedes perception: the image region that changed when (only) the gripper servo
//! moved is the gripper's fingers.
//!
//! Between two half-resolution images `a` (before) and `b` (after): compensate a global
//! lighting gain (`b` is compared with `(Σb/Σa)·a`), take the absolute difference, smooth it
//! with a 3×3 box, threshold it at `max(k·σ̂, d_min)` where `σ̂ = 1.4826·median` is a robust
//! estimate of the unchanged pixels' difference noise, keep the largest 8-connected component,
//! and return its difference-weighted centroid (the *gripper point*).

use crate::recognition::features::check_image;
use crate::recognition::image::{FloatImage, half_to_full};

/// The changed region.
#[derive(Debug, Clone, PartialEq)]
pub struct ChangeRegion {
    /// Difference-weighted centroid, full-resolution pixels `[u, v]`.
    pub centroid: [f64; 2],
    /// Number of (half-resolution) pixels in the region.
    pub pixels: usize,
    /// The threshold used (grey levels).
    pub threshold: f32,
}

/// Noise multiple `k` of the threshold.
pub const NOISE_MULTIPLE: f32 = 6.0;
/// Smallest threshold `d_min` (grey levels).
pub const MIN_THRESHOLD: f32 = 8.0;

/// The largest changed region between `a` and `b`, or `None` when fewer than `min_pixels`
/// pixels changed (or the sizes differ, or an image's `data` is not `width × height` values).
pub fn changed_region(a: &FloatImage, b: &FloatImage, min_pixels: usize) -> Option<ChangeRegion> {
    if !comparable(a, b) {
        return None;
    }
    let (w, h) = (a.width, a.height);
    let (smooth, threshold) = smoothed_difference(a, b);
    let mask: Vec<bool> = smooth.iter().map(|&v| v > threshold).collect();
    // Largest 8-connected component.
    let mut label = vec![0u32; w * h];
    let mut best: Option<(usize, f64, f64, f64)> = None;
    let mut next = 0u32;
    let mut stack = Vec::new();
    for start in 0..w * h {
        if !mask[start] || label[start] != 0 {
            continue;
        }
        next += 1;
        label[start] = next;
        stack.push(start);
        let (mut n, mut sw, mut sx, mut sy) = (0usize, 0.0f64, 0.0f64, 0.0f64);
        while let Some(p) = stack.pop() {
            let (x, y) = (p % w, p / w);
            let wt = f64::from(smooth[p] - threshold);
            n += 1;
            sw += wt;
            sx += wt * x as f64;
            sy += wt * y as f64;
            for dy in -1i64..=1 {
                for dx in -1i64..=1 {
                    let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                    if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
                        continue;
                    }
                    let q = ny as usize * w + nx as usize;
                    if mask[q] && label[q] == 0 {
                        label[q] = next;
                        stack.push(q);
                    }
                }
            }
        }
        if best.is_none_or(|b| n > b.0) {
            best = Some((n, sw, sx, sy));
        }
    }
    let (n, sw, sx, sy) = best?;
    if n < min_pixels || sw <= 0.0 {
        return None;
    }
    Some(ChangeRegion {
        centroid: [half_to_full(sx / sw), half_to_full(sy / sw)],
        pixels: n,
        threshold,
    })
}

/// The pixels that changed between `a` and `b` (same rule as [`changed_region`], every
/// component), or `None` when the sizes differ, the images are smaller than 3×3 or an image's
/// `data` is not `width × height` values.
pub fn changed_mask(a: &FloatImage, b: &FloatImage) -> Option<Vec<bool>> {
    if !comparable(a, b) {
        return None;
    }
    let (smooth, threshold) = smoothed_difference(a, b);
    Some(smooth.iter().map(|&v| v > threshold).collect())
}

/// Two images of one size, at least 3×3, each holding its `width × height` values (a
/// `FloatImage`'s fields are public: shorter data was indexed past its end).
fn comparable(a: &FloatImage, b: &FloatImage) -> bool {
    a.width == b.width
        && a.height == b.height
        && a.width >= 3
        && a.height >= 3
        && check_image(a).is_ok()
        && check_image(b).is_ok()
}

/// Gain-compensated, 3×3-smoothed absolute difference and its robust threshold.
fn smoothed_difference(a: &FloatImage, b: &FloatImage) -> (Vec<f32>, f32) {
    let (w, h) = (a.width, a.height);
    let sa: f64 = a.data.iter().map(|&v| f64::from(v)).sum();
    let sb: f64 = b.data.iter().map(|&v| f64::from(v)).sum();
    let gain = if sa > 0.0 { (sb / sa) as f32 } else { 1.0 };
    let diff: Vec<f32> = a
        .data
        .iter()
        .zip(&b.data)
        .map(|(&x, &y)| (y - gain * x).abs())
        .collect();
    let mut smooth = vec![0.0f32; w * h];
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let mut s = 0.0;
            for dy in 0..3 {
                let r = &diff[(y + dy - 1) * w + x - 1..][..3];
                s += r[0] + r[1] + r[2];
            }
            smooth[y * w + x] = s / 9.0;
        }
    }
    let mut sorted = smooth.clone();
    let mid = sorted.len() / 2;
    let median = *sorted.select_nth_unstable_by(mid, f32::total_cmp).1;
    let threshold = (NOISE_MULTIPLE * 1.4826 * median).max(MIN_THRESHOLD);
    (smooth, threshold)
}
