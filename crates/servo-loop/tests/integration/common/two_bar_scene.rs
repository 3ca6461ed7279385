//! The recognition tests' synthetic scene: a deterministic low-contrast texture with a bright
//! two-bar object, and training views of it opening (a test module, not part of the
//! library).

use image::{GrayImage, Luma};
use servo_loop::recognition::TrainingView;

/// A `w × h` texture (varied by `seed`) with, when `square` is `(sx, sy, s)`, a two-bar object
/// of size `s` at `(sx, sy)`: its left and right thirds bright.
pub fn scene(w: u32, h: u32, square: Option<(u32, u32, u32)>, seed: u32) -> GrayImage {
    let mut img = GrayImage::from_fn(w, h, |x, y| {
        let v = 90 + ((x.wrapping_mul(7) ^ y.wrapping_mul(13) ^ seed) % 9) as u8;
        Luma([v])
    });
    if let Some((sx, sy, s)) = square {
        for y in sy..(sy + s).min(h) {
            for x in sx..(sx + s / 3).min(w) {
                img.put_pixel(x, y, Luma([220]));
            }
            for x in (sx + 2 * s / 3)..(sx + s).min(w) {
                img.put_pixel(x, y, Luma([220]));
            }
        }
    }
    img
}

/// One camera's training views: at four places the two-bar object "opens" (its bars move
/// apart, the object grows from 30 to 34 px).
pub fn opening_views() -> Vec<TrainingView> {
    [(60u32, 50u32), (180, 60), (100, 150), (220, 160)]
        .iter()
        .enumerate()
        .map(|(i, &(x, y))| TrainingView {
            before: vec![scene(320, 240, Some((x, y, 30)), i as u32)],
            after: vec![scene(320, 240, Some((x - 2, y, 34)), i as u32)],
        })
        .collect()
}
