//! Float images at half resolution (2×2 box average), the working resolution of recognition.

use image::GrayImage;

/// A float grey image, row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct FloatImage {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// `height × width` values.
    pub data: Vec<f32>,
}

impl FloatImage {
    /// The value at column `x`, row `y`.
    #[inline]
    pub fn at(&self, x: usize, y: usize) -> f32 {
        self.data[y * self.width + x]
    }
}

/// Half-resolution image: pixel `(i, j)` is the mean of full-resolution pixels `2i…2i+1 ×
/// 2j…2j+1`, so its centre lies at full-resolution coordinate `2i + 0.5` (pixel centres at
/// integers). Odd trailing rows/columns are dropped.
pub fn half_resolution(img: &GrayImage) -> FloatImage {
    let (w, h) = (img.width() as usize / 2, img.height() as usize / 2);
    let src = img.as_raw();
    let fw = img.width() as usize;
    let mut data = vec![0.0f32; w * h];
    for y in 0..h {
        let r0 = &src[2 * y * fw..2 * y * fw + fw];
        let r1 = &src[(2 * y + 1) * fw..(2 * y + 1) * fw + fw];
        let out = &mut data[y * w..y * w + w];
        for (x, o) in out.iter_mut().enumerate() {
            let s = u32::from(r0[2 * x])
                + u32::from(r0[2 * x + 1])
                + u32::from(r1[2 * x])
                + u32::from(r1[2 * x + 1]);
            *o = s as f32 * 0.25;
        }
    }
    FloatImage {
        width: w,
        height: h,
        data,
    }
}

/// Full-resolution coordinate of half-resolution coordinate `h`.
#[inline]
pub fn half_to_full(h: f64) -> f64 {
    2.0 * h + 0.5
}

/// Half-resolution coordinate of full-resolution coordinate `f`.
#[inline]
pub fn full_to_half(f: f64) -> f64 {
    (f - 0.5) / 2.0
}

/// The grey values of `img` as floats, row-major.
pub(crate) fn to_f32(img: &GrayImage) -> Vec<f32> {
    img.as_raw().iter().map(|&v| f32::from(v)).collect()
}

/// 2×2 means (odd trailing row/column dropped).
pub(crate) fn halve(img: &[f32], w: usize, h: usize) -> Vec<f32> {
    let (hw, hh) = (w / 2, h / 2);
    let mut out = vec![0.0f32; hw * hh];
    for y in 0..hh {
        let (r0, r1) = (&img[2 * y * w..][..w], &img[(2 * y + 1) * w..][..w]);
        for (x, o) in out[y * hw..(y + 1) * hw].iter_mut().enumerate() {
            *o = 0.25 * (r0[2 * x] + r0[2 * x + 1] + r1[2 * x] + r1[2 * x + 1]);
        }
    }
    out
}

/// 3×3 box mean of `|r|` (borders zero).
pub(crate) fn smoothed_magnitude(r: &[f32], w: usize, h: usize) -> Vec<f32> {
    let mut rows = vec![0.0f32; w * h];
    for y in 0..h {
        let src = &r[y * w..(y + 1) * w];
        let dst = &mut rows[y * w..(y + 1) * w];
        for x in 1..w.saturating_sub(1) {
            dst[x] = src[x - 1].abs() + src[x].abs() + src[x + 1].abs();
        }
    }
    let mut out = vec![0.0f32; w * h];
    for y in 1..h.saturating_sub(1) {
        for x in 0..w {
            out[y * w + x] =
                (rows[(y - 1) * w + x] + rows[y * w + x] + rows[(y + 1) * w + x]) / 9.0;
        }
    }
    out
}

/// Pixels of the largest 8-connected component of `mask`.
pub(crate) fn largest_component(mask: &[bool], w: usize, h: usize) -> Vec<usize> {
    let mut seen = vec![false; w * h];
    let mut best: Vec<usize> = Vec::new();
    let mut stack = Vec::new();
    for start in 0..w * h {
        if !mask[start] || seen[start] {
            continue;
        }
        seen[start] = true;
        stack.push(start);
        let mut comp = Vec::new();
        while let Some(p) = stack.pop() {
            comp.push(p);
            let (x, y) = (p % w, p / w);
            for ny in y.saturating_sub(1)..=(y + 1).min(h - 1) {
                for nx in x.saturating_sub(1)..=(x + 1).min(w - 1) {
                    let q = ny * w + nx;
                    if mask[q] && !seen[q] {
                        seen[q] = true;
                        stack.push(q);
                    }
                }
            }
        }
        if comp.len() > best.len() {
            best = comp;
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn halve_averages_two_by_two_blocks() {
        let img: Vec<f32> = (0..4 * 3).map(|v| v as f32).collect();
        // 4×3 → 2×1: rows 0–1 only.
        assert_eq!(halve(&img, 4, 3), vec![2.5, 4.5]);
    }

    #[test]
    fn largest_component_is_eight_connected_and_the_largest() {
        // A diagonal chain (8-connected) of 3 pixels, a vertical pair and a lone pixel.
        let (w, h) = (5, 4);
        let mut mask = vec![false; w * h];
        for p in [0, 6, 12, 4, 9, 19] {
            mask[p] = true;
        }
        let mut c = largest_component(&mask, w, h);
        c.sort_unstable();
        assert_eq!(c, vec![0, 6, 12]);
        assert!(largest_component(&vec![false; w * h], w, h).is_empty());
    }
}
