//! Pictures: ellipses drawn on an image, and two images side by side with lines between
//! matched regions. Grey images are lightened so the coloured lines stand out; pictures wider
//! than a limit are scaled down (nearest neighbour).

use image::{GrayImage, Rgb, RgbImage};

use crate::scoring::overlap::Ellipse;

/// Green (correct matches, inliers).
pub const GREEN: Rgb<u8> = Rgb([0, 200, 0]);
/// Red (wrong matches, outliers).
pub const RED: Rgb<u8> = Rgb([230, 0, 0]);
/// Yellow (regions of one image).
pub const YELLOW: Rgb<u8> = Rgb([240, 200, 0]);

/// A 2×2 dot with its top-left corner at `(x, y)`, clipped to the image.
pub fn plot(img: &mut RgbImage, x: f64, y: f64, c: Rgb<u8>) {
    for (dx, dy) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)] {
        let (px, py) = (x + dx, y + dy);
        if px >= 0.0 && py >= 0.0 && (px as u32) < img.width() && (py as u32) < img.height() {
            img.put_pixel(px as u32, py as u32, c);
        }
    }
}

/// A line from `a` to `b`, two pixels wide (DDA).
pub fn line(img: &mut RgbImage, a: (f64, f64), b: (f64, f64), c: Rgb<u8>) {
    let steps = (b.0 - a.0).abs().max((b.1 - a.1).abs()).ceil().max(1.0);
    if !steps.is_finite() || steps > 1e5 {
        return;
    }
    let steps = steps as usize;
    for s in 0..=steps {
        let t = s as f64 / steps as f64;
        plot(img, a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1), c);
    }
}

/// The outline of an ellipse, scaled by `k` and shifted by `dx`.
pub fn outline(img: &mut RgbImage, e: &Ellipse, k: f64, dx: f64, c: Rgb<u8>) {
    // Points d with dᵀ M d = 1: d = M^(−1/2) (cos t, sin t), via the eigen-decomposition.
    let m = nalgebra::Matrix2::new(e.a, e.b, e.b, e.c);
    let eig = m.symmetric_eigen();
    if eig.eigenvalues.iter().any(|&l| l <= 0.0 || !l.is_finite()) {
        return;
    }
    let n = 64;
    let mut prev = None;
    for s in 0..=n {
        let t = 2.0 * std::f64::consts::PI * s as f64 / n as f64;
        let mut d = nalgebra::Vector2::zeros();
        for i in 0..2 {
            let w = if i == 0 { t.cos() } else { t.sin() };
            d += eig.eigenvectors.column(i) * (w / eig.eigenvalues[i].sqrt());
        }
        let p = (k * (e.u + d.x) + dx, k * (e.v + d.y));
        if let Some(q) = prev {
            line(img, q, p, c);
        }
        prev = Some(p);
    }
}

/// `a` and `b` side by side, lightened, scaled to at most `max_width`; returns the picture,
/// the scale and the x offset of `b`.
pub fn side_by_side(a: &GrayImage, b: &GrayImage, max_width: u32) -> (RgbImage, f64, f64) {
    let (w, h, scale, offset) = side_by_side_layout(a.dimensions(), b.dimensions(), max_width);
    let mut img = RgbImage::from_pixel(w, h, Rgb([255, 255, 255]));
    for y in 0..h {
        for x in 0..w {
            let (sx, sy) = ((x as f64 / scale) as u32, (y as f64 / scale) as u32);
            let g = if sx < a.width() {
                (sy < a.height()).then(|| a.get_pixel(sx, sy)[0])
            } else {
                let bx = sx - a.width();
                (bx < b.width() && sy < b.height()).then(|| b.get_pixel(bx, sy)[0])
            };
            if let Some(g) = g {
                let v = 64 + (g as u32 * 3 / 4) as u8;
                img.put_pixel(x, y, Rgb([v, v, v]));
            }
        }
    }
    (img, scale, offset)
}

/// The picture's size, scale and `b`'s x offset for [`side_by_side`] of images `a` and `b`
/// (width, height). In `f64`: the sum of two widths may exceed `u32` (it used to overflow).
/// `w ≤ max_width` whenever `scale < 1`.
fn side_by_side_layout(a: (u32, u32), b: (u32, u32), max_width: u32) -> (u32, u32, f64, f64) {
    let full_w = f64::from(a.0) + f64::from(b.0);
    let scale = (max_width as f64 / full_w).min(1.0);
    let w = ((full_w * scale).round() as u32).max(1);
    let h = ((a.1.max(b.1) as f64 * scale).round() as u32).max(1);
    (w, h, scale, f64::from(a.0) * scale)
}

/// One image (lightened) with ellipses outlined.
pub fn ellipses(img: &GrayImage, ellipses: &[Ellipse], c: Rgb<u8>) -> RgbImage {
    let mut out = RgbImage::from_fn(img.width(), img.height(), |x, y| {
        let v = 64 + (img.get_pixel(x, y)[0] as u32 * 3 / 4) as u8;
        Rgb([v, v, v])
    });
    for e in ellipses {
        outline(&mut out, e, 1.0, 0.0, c);
    }
    out
}

/// A matched pair: `(e1, e2, colour)` per match, drawn as both outlines and a line between the
/// centres, on `a` and `b` side by side.
pub fn matches(
    a: &GrayImage,
    b: &GrayImage,
    pairs: &[(Ellipse, Ellipse, Rgb<u8>)],
    max_width: u32,
) -> RgbImage {
    let (mut img, scale, offset) = side_by_side(a, b, max_width);
    for (e1, e2, c) in pairs {
        outline(&mut img, e1, scale, 0.0, *c);
        outline(&mut img, e2, scale, offset, *c);
        line(
            &mut img,
            (scale * e1.u, scale * e1.v),
            (scale * e2.u + offset, scale * e2.v),
            *c,
        );
    }
    img
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two images whose widths sum beyond `u32` make a picture `max_width` wide, `b` at half of
    /// it; the sum used to overflow (a panic in a debug build, a wrong scale in a release one).
    #[test]
    fn widths_summing_beyond_u32() {
        let (w, h, scale, offset) = side_by_side_layout((1 << 31, 1), (1 << 31, 1), 1600);
        assert_eq!((w, h), (1600, 1));
        assert_eq!((scale, offset), (1600.0 / 2f64.powi(32), 800.0));
        let (w, _, scale, _) = side_by_side_layout((u32::MAX, 7), (u32::MAX, 9), 1600);
        assert_eq!((w, scale), (1600, 1600.0 / (2.0 * f64::from(u32::MAX))));
    }
}
