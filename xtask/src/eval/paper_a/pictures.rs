//! Match pictures: img1 and imgK side by side (grey), each FD Corr/Affine match accepted at
//! `T_r = 0.5` drawn as a line between the two regions' centres, green when ground truth calls
//! it correct and red otherwise, with each region's moment ellipse outlined in the same colour.
//! Images wider than [`MAX_WIDTH`] side by side are scaled down (nearest neighbour).

use std::path::Path;

use image::{Rgb, RgbImage};

use super::evaluate::SequenceResult;
use super::overlap::Ellipse;
use super::sequence::Sequence;
use crate::Result;

/// Largest width of a picture.
pub const MAX_WIDTH: u32 = 1200;

const GREEN: Rgb<u8> = Rgb([0, 200, 0]);
const RED: Rgb<u8> = Rgb([230, 0, 0]);

/// A 2×2 dot with its top-left corner at `(x, y)`, clipped to the image.
fn plot(img: &mut RgbImage, x: f64, y: f64, c: Rgb<u8>) {
    for (dx, dy) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)] {
        let (px, py) = (x + dx, y + dy);
        if px >= 0.0 && py >= 0.0 && (px as u32) < img.width() && (py as u32) < img.height() {
            img.put_pixel(px as u32, py as u32, c);
        }
    }
}

/// A line from `a` to `b`, two pixels wide (DDA).
fn line(img: &mut RgbImage, a: (f64, f64), b: (f64, f64), c: Rgb<u8>) {
    let steps = (b.0 - a.0).abs().max((b.1 - a.1).abs()).ceil().max(1.0) as usize;
    for s in 0..=steps {
        let t = s as f64 / steps as f64;
        plot(img, a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1), c);
    }
}

/// The outline of an ellipse scaled by `k` and shifted by `dx`.
fn outline(img: &mut RgbImage, e: &Ellipse, k: f64, dx: f64, c: Rgb<u8>) {
    // Points d with dᵀ M d = 1: d = M^(−1/2) (cos t, sin t), via the eigen-decomposition.
    let m = nalgebra::Matrix2::new(e.a, e.b, e.b, e.c);
    let eig = m.symmetric_eigen();
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

/// Draws the picture of pair img1–imgK.
pub fn picture(seq: &Sequence, result: &SequenceResult, k: usize) -> RgbImage {
    let (a, b) = (&seq.images[0], &seq.images[k - 1]);
    let full_w = a.width() + b.width();
    let scale = (MAX_WIDTH as f64 / full_w as f64).min(1.0);
    let w = (full_w as f64 * scale).round() as u32;
    let h = (a.height().max(b.height()) as f64 * scale).round() as u32;
    let offset = a.width() as f64 * scale;
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
                // Lighten so the lines stand out.
                let v = 64 + (g as u32 * 3 / 4) as u8;
                img.put_pixel(x, y, Rgb([v, v, v]));
            }
        }
    }
    let pair = &result.pairs[k - 2];
    // Wrong matches first, so correct ones are drawn on top.
    let mut shown = pair.shown.clone();
    shown.sort_by_key(|m| m.correct);
    for m in &shown {
        let c = if m.correct { GREEN } else { RED };
        let (e1, e2) = (
            &result.features[0].ellipses[m.i],
            &result.features[k - 1].ellipses[m.j],
        );
        outline(&mut img, e1, scale, 0.0, c);
        outline(&mut img, e2, scale, offset, c);
        line(
            &mut img,
            (scale * e1.u, scale * e1.v),
            (scale * e2.u + offset, scale * e2.v),
            c,
        );
    }
    img
}

/// Writes `<name>-img1-vs-imgK.png` for every pair into `dir`.
pub fn write_all(seq: &Sequence, result: &SequenceResult, dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir)?;
    for k in seq.pairs() {
        let path = dir.join(format!("{}-img1-vs-img{k}.png", seq.name));
        picture(seq, result, k).save(&path)?;
    }
    Ok(())
}
