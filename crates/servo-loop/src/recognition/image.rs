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
