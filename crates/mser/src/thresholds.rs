//! A region's variation and its parent's, recomputed literally from the image by thresholding
//! (no component tree): the witness for OpenCV's parent-tie rule (crate docs, "OpenCV").
//!
//! OpenCV 4.x drops a region whose positive variation equals its parent's; we keep it. A
//! comparison with OpenCV (`tests/integration/opencv_crosscheck.rs`, `cargo xtask bench mser`)
//! excuses a region of ours that OpenCV lacks only when [`variations_by_thresholds`] shows such a
//! tie, as exact ratios of pixel counts. Cost: a few flood fills over the region's and its parent's
//! neighbourhood per level walked, O(Δ · |Q_{g+Δ}|) plus one copy of the image; meant for
//! checks, not detection.

use crate::error::{MserError, Result};
use crate::image::GrayView;
use crate::params::{MserParams, Variation};
use crate::region::{Polarity, Region};

/// A variation as the exact ratio `num / den` of pixel counts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Ratio {
    /// Numerator: `|Q_{g+Δ}| − |L|` (symmetric) or `|Q_{g+Δ}| − |S|` (upward).
    pub num: u64,
    /// Denominator: the region's area `|S|`.
    pub den: u64,
}

impl Ratio {
    /// Whether the two ratios are equal as rational numbers.
    pub fn equals(&self, o: &Ratio) -> bool {
        self.num as u128 * o.den as u128 == o.num as u128 * self.den as u128
    }

    /// The ratio as computed by the detector (`num as f64 / den as f64`).
    pub fn value(&self) -> f64 {
        self.num as f64 / self.den as f64
    }
}

/// The variations of a region and of its parent in the component tree, by thresholding.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Variations {
    /// The region's own variation.
    pub region: Ratio,
    /// The parent's grey level (image scale, like [`Region::level`]).
    pub parent_level: u8,
    /// The parent's area.
    pub parent_area: u64,
    /// The parent's variation.
    pub parent: Ratio,
}

impl Variations {
    /// OpenCV 4.x's reason to drop a region that we keep: a positive variation exactly equal
    /// to the parent's.
    pub fn is_positive_parent_tie(&self) -> bool {
        self.region.num > 0 && self.region.equals(&self.parent)
    }
}

/// Recomputes `r`'s variation and its parent's from `img` by thresholding at each level (the
/// definitions of the crate docs, with `params.delta` and `params.variation`): the region is the
/// 4-connected component of `{I ≤ g}` through its seed (dark; bright on `255 − I`), its parent
/// the component at the first higher threshold at which that component grows, and the lower end
/// `L` of the symmetric variation the walk down the largest children (ties: first pixel in
/// raster order) while their level is at least `g − Δ`.
///
/// Errors: parameters [`MserParams::validate`] refuses, a seed outside the image or whose pixel
/// does not pass the region's level, a region that is not the component at its level through
/// its seed (area mismatch), or the whole image (which has no parent).
pub fn variations_by_thresholds(
    img: &GrayView,
    r: &Region,
    params: &MserParams,
) -> Result<Variations> {
    params.validate()?;
    let (w, h) = (img.width(), img.height());
    let bad = |reason: String| MserError::InvalidParameter {
        name: "region",
        reason,
    };
    let (sx, sy) = (r.seed.0 as usize, r.seed.1 as usize);
    if sx >= w || sy >= h {
        return Err(bad(format!("seed {:?} outside the image", r.seed)));
    }
    let flip = if r.polarity == Polarity::Bright {
        255u8
    } else {
        0
    };
    let px: Vec<u8> = (0..h)
        .flat_map(|y| img.row(y).iter().map(move |&g| g ^ flip))
        .collect();
    let mut t = Thresholds {
        px: &px,
        w,
        h,
        mark: vec![0; w * h],
        stamp: 0,
    };
    let seed = sy * w + sx;
    let g = r.level ^ flip;
    // The fill takes its seed unconditionally, so a seed above the level would grow a set
    // that is no component at all (and could still have the region's area).
    if px[seed] > g {
        return Err(bad(format!(
            "seed {:?} has grey value {}, which does not pass the level {}",
            r.seed,
            img.get(sx, sy),
            r.level
        )));
    }
    let area = t.component(seed, g).len();
    if area != r.area as usize {
        return Err(bad(format!(
            "area {} but the component through the seed at its level has {area} pixels",
            r.area
        )));
    }
    let region = t.variation(seed, g, params);
    let (gp, parent_area) = (g as u32 + 1..=255)
        .map(|l| (l as u8, t.component(seed, l as u8).len()))
        .find(|&(_, n)| n > area)
        .ok_or_else(|| bad("the whole image has no parent".into()))?;
    let parent = t.variation(seed, gp, params);
    Ok(Variations {
        region,
        parent_level: gp ^ flip,
        parent_area: parent_area as u64,
        parent,
    })
}

/// Flood fills on one polarity's grey levels, with a reusable visit mark.
struct Thresholds<'a> {
    px: &'a [u8],
    w: usize,
    h: usize,
    /// The stamp of the fill that last reached each pixel.
    mark: Vec<u32>,
    stamp: u32,
}

impl Thresholds<'_> {
    /// The component of `{I ≤ t}` through `seed` (sorted), with a fresh stamp.
    fn component(&mut self, seed: usize, t: u8) -> Vec<usize> {
        self.stamp += 1;
        self.fill(seed, t)
    }

    /// The component of `{I ≤ t}` through `seed`, marking with the current stamp and skipping
    /// pixels already marked with it; sorted by index.
    fn fill(&mut self, seed: usize, t: u8) -> Vec<usize> {
        let (w, h, s) = (self.w, self.h, self.stamp);
        let (mut out, mut stack) = (Vec::new(), vec![seed]);
        self.mark[seed] = s;
        while let Some(p) = stack.pop() {
            out.push(p);
            let (x, y) = (p % w, p / w);
            let nbs = [
                (x > 0).then(|| p - 1),
                (x + 1 < w).then(|| p + 1),
                (y > 0).then(|| p - w),
                (y + 1 < h).then(|| p + w),
            ];
            for n in nbs.into_iter().flatten() {
                if self.mark[n] != s && self.px[n] <= t {
                    self.mark[n] = s;
                    stack.push(n);
                }
            }
        }
        out.sort_unstable();
        out
    }

    /// The variation of the region through `seed` at level `g` (the component of `{I ≤ g}`).
    fn variation(&mut self, seed: usize, g: u8, p: &MserParams) -> Ratio {
        let s = self.component(seed, g);
        let den = s.len() as u64;
        let up = self.component(seed, g.saturating_add(p.delta)).len();
        let lower = match p.variation {
            Variation::Upward => s.len(),
            Variation::Symmetric => self.lower_end(s, g, p.delta),
        };
        Ratio {
            num: (up - lower) as u64,
            den,
        }
    }

    /// `|L(S)|`: from `s` at level `g`, walk down the largest child (ties: first pixel in raster
    /// order) while its level is at least `g − Δ`.
    fn lower_end(&mut self, s: Vec<usize>, g: u8, delta: u8) -> usize {
        let (mut m, mut gm) = (s, g);
        while gm > 0 {
            // The children of `m` are the components of `{I < gm}` inside it.
            self.stamp += 1;
            let mut best: Option<Vec<usize>> = None;
            for &q in &m {
                if self.px[q] < gm && self.mark[q] != self.stamp {
                    let c = self.fill(q, gm - 1);
                    if best
                        .as_ref()
                        .is_none_or(|b| c.len() > b.len() || (c.len() == b.len() && c[0] < b[0]))
                    {
                        best = Some(c);
                    }
                }
            }
            let Some(c) = best else { break };
            let gc = c.iter().map(|&q| self.px[q]).max().expect("non-empty");
            if gc as u32 + (delta as u32) < g as u32 {
                break;
            }
            (m, gm) = (c, gc);
        }
        m.len()
    }
}
