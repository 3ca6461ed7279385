//! Pixel lists on demand: a flood fill from a region's seed, confined to its bounding box.

use crate::error::{MserError, Result};
use crate::image::GrayView;
use crate::region::{BoundingBox, Polarity};

/// The pixels of the 4-connected component of `{p : polarity.contains(I(p), level)}` through
/// `seed`, in raster order. `bbox` must contain the component (it only bounds the work; a box
/// reaching outside the image is clipped to it). A seed outside the image, one that does not
/// pass the threshold, or a box that cuts the component (a component pixel outside it) is a
/// [`MserError::RegionImageMismatch`].
///
/// ```
/// use mser::{BoundingBox, GrayView, Polarity, flood_pixels};
/// let img = GrayView::packed(&[9, 0, 0, 9], 2, 2).unwrap();
/// let all = BoundingBox { x_min: 0, y_min: 0, x_max: 1, y_max: 1 };
/// assert_eq!(flood_pixels(&img, (1, 0), 0, Polarity::Dark, all).unwrap(), vec![(1, 0)]);
/// assert!(flood_pixels(&img, (5, 0), 0, Polarity::Dark, all).is_err());
/// ```
pub fn flood_pixels(
    img: &GrayView,
    seed: (u32, u32),
    level: u8,
    polarity: Polarity,
    bbox: BoundingBox,
) -> Result<Vec<(u32, u32)>> {
    if seed.0 as usize >= img.width() || seed.1 as usize >= img.height() {
        return Err(MserError::RegionImageMismatch {
            reason: "seed outside the image",
        });
    }
    if !polarity.contains(img.at(seed.0 as usize, seed.1 as usize), level) {
        return Err(MserError::RegionImageMismatch {
            reason: "seed pixel does not pass the region's threshold",
        });
    }
    // Clamp the box to the image so a wrong box cannot index outside.
    let x0 = bbox.x_min.min(seed.0) as usize;
    let y0 = bbox.y_min.min(seed.1) as usize;
    let x1 = (bbox.x_max.max(seed.0) as usize).min(img.width() - 1);
    let y1 = (bbox.y_max.max(seed.1) as usize).min(img.height() - 1);
    let bw = x1 - x0 + 1;
    let bh = y1 - y0 + 1;
    let mut seen = vec![false; bw * bh];
    let mut todo = vec![(seed.0 as usize, seed.1 as usize)];
    seen[(seed.1 as usize - y0) * bw + seed.0 as usize - x0] = true;
    let mut out = Vec::new();
    let (last_x, last_y) = (img.width() - 1, img.height() - 1);
    while let Some((x, y)) = todo.pop() {
        out.push((x as u32, y as u32));
        let mut visit = |nx: usize, ny: usize| {
            let k = (ny - y0) * bw + nx - x0;
            if !seen[k] && polarity.contains(img.at(nx, ny), level) {
                seen[k] = true;
                todo.push((nx, ny));
            }
        };
        if x > x0 {
            visit(x - 1, y);
        }
        if x < x1 {
            visit(x + 1, y);
        }
        if y > y0 {
            visit(x, y - 1);
        }
        if y < y1 {
            visit(x, y + 1);
        }
        // A component pixel just outside the box (inside the image): the box cuts the
        // component, and the pixels found would be only part of it.
        let cut = x == x0 && x > 0 && polarity.contains(img.at(x - 1, y), level)
            || x == x1 && x < last_x && polarity.contains(img.at(x + 1, y), level)
            || y == y0 && y > 0 && polarity.contains(img.at(x, y - 1), level)
            || y == y1 && y < last_y && polarity.contains(img.at(x, y + 1), level);
        if cut {
            return Err(MserError::RegionImageMismatch {
                reason: "the bounding box does not contain the component through the seed",
            });
        }
    }
    out.sort_unstable_by_key(|&(x, y)| (y, x));
    Ok(out)
}
