//! Exact outer contours by crack following.
//!
//! The boundary between a 4-connected region and the outside (8-connected) is a closed chain of
//! pixel edges ("cracks"). We walk it with the region on the left, which is counter-clockwise as
//! seen on screen (y down), and list the region pixel beside each crack, dropping immediate
//! repeats. A state is a region pixel `p` and the direction `d` of its non-region 4-neighbour;
//! looking at the pixel `a` ahead and the pixel `b` diagonally ahead on the outside:
//!
//! - `a` outside: convex corner, turn left around `p` (also at a diagonal pinch, because the
//!   region is 4-connected);
//! - `a` inside, `b` outside: go straight to `a`;
//! - `a` and `b` inside: concave corner, turn right onto `b` (`a` has no outside 4-neighbour here
//!   and is skipped, so the chain steps diagonally).
//!
//! Membership is the threshold test alone: every pixel tested is 4-adjacent to a region pixel, so
//! it is in the region exactly when it passes the threshold. The walk starts at the first region
//! pixel in raster order, whose upper neighbour belongs to the outside, and stops when it returns
//! to its first crack: O(perimeter) time, no mask.

use crate::error::{MserError, Result};
use crate::image::GrayView;
use crate::region::Polarity;

/// Unit steps east, north, west, south; a left turn is `+1`.
const DIRS: [(i64, i64); 4] = [(1, 0), (0, -1), (-1, 0), (0, 1)];

/// Checks that `seed` can start a region's walk: inside the image, passing the threshold, and
/// with upper and left neighbours that fail it (as the first pixel of its component in raster
/// order has; necessary, not sufficient: [`trace_outer_contour`] checks the rest on its chain);
/// otherwise a [`MserError::RegionImageMismatch`].
pub(crate) fn check_seed(
    img: &GrayView,
    seed: (u32, u32),
    level: u8,
    polarity: Polarity,
) -> Result<()> {
    let (x, y) = (seed.0 as usize, seed.1 as usize);
    if x >= img.width() || y >= img.height() {
        return Err(MserError::RegionImageMismatch {
            reason: "seed outside the image",
        });
    }
    if !polarity.contains(img.at(x, y), level) {
        return Err(MserError::RegionImageMismatch {
            reason: "seed pixel does not pass the region's threshold",
        });
    }
    if y > 0 && polarity.contains(img.at(x, y - 1), level)
        || x > 0 && polarity.contains(img.at(x - 1, y), level)
    {
        return Err(MserError::RegionImageMismatch {
            reason: "seed is not the region's first pixel in raster order",
        });
    }
    Ok(())
}

/// Traces the outer contour of the region through `seed` (its first pixel in raster order); see
/// [`Region::contour`](crate::Region::contour) for the guarantees. A seed outside the image,
/// failing the threshold, or not the first pixel of its component in raster order is a
/// [`MserError::RegionImageMismatch`].
pub fn trace_outer_contour(
    img: &GrayView,
    seed: (u32, u32),
    level: u8,
    polarity: Polarity,
) -> Result<Vec<(u32, u32)>> {
    check_seed(img, seed, level, polarity)?;
    let (w, h) = (img.width() as i64, img.height() as i64);
    let inside = |x: i64, y: i64| {
        x >= 0
            && y >= 0
            && x < w
            && y < h
            && polarity.contains(img.at(x as usize, y as usize), level)
    };
    let start = (seed.0 as i64, seed.1 as i64, 1usize);
    let (mut x, mut y, mut d) = start;
    let mut out = vec![seed];
    loop {
        let t = (d + 1) & 3;
        let (ax, ay) = (x + DIRS[t].0, y + DIRS[t].1);
        if !inside(ax, ay) {
            d = t;
        } else {
            let (bx, by) = (ax + DIRS[d].0, ay + DIRS[d].1);
            if inside(bx, by) {
                (x, y, d) = (bx, by, (d + 3) & 3);
            } else {
                (x, y) = (ax, ay);
            }
        }
        if (x, y, d) == start {
            break;
        }
        // A region pixel (every step lands on one), so inside the image and the u32 range.
        let p = (x as u32, y as u32);
        if *out.last().expect("starts with the seed") != p {
            out.push(p);
        }
    }
    // A seed below a hole, or atop a later arm of the region, passes `check_seed` but is not
    // the first pixel: its chain (the hole's boundary, or the outer one started elsewhere) then
    // holds a pixel before it in raster order. The first pixel's chain never does, and the
    // outer boundary always holds the first pixel (the row above it has no region pixel).
    if out.iter().any(|&(px, py)| (py, px) < (seed.1, seed.0)) {
        return Err(MserError::RegionImageMismatch {
            reason: "seed is not the region's first pixel in raster order",
        });
    }
    if out.len() > 1 && out.last() == out.first() {
        out.pop();
    }
    Ok(out)
}
