//! Match pictures: img1 and imgK side by side (grey), each FD Corr/Affine match accepted at
//! `T_r = 0.5` drawn as a line between the two regions' centres, green when ground truth calls
//! it correct and red otherwise, with each region's moment ellipse outlined in the same colour
//! (the drawing is `visguide::output::draw`'s, also used by `visguide match --picture`).
//! Images wider than [`MAX_WIDTH`] side by side are scaled down (nearest neighbour).

use std::path::Path;

use image::RgbImage;
use visguide::output::draw::{self, GREEN, RED};

use super::evaluate::SequenceResult;
use super::sequence::Sequence;
use crate::Result;

/// Largest width of a picture.
pub const MAX_WIDTH: u32 = 1200;

/// Draws the picture of pair img1–imgK.
pub fn picture(seq: &Sequence, result: &SequenceResult, k: usize) -> RgbImage {
    let pair = &result.pairs[k - 2];
    // Wrong matches first, so correct ones are drawn on top.
    let mut shown = pair.shown.clone();
    shown.sort_by_key(|m| m.correct);
    let pairs: Vec<_> = shown
        .iter()
        .map(|m| {
            (
                result.features[0].frames[m.i],
                result.features[k - 1].frames[m.j],
                if m.correct { GREEN } else { RED },
            )
        })
        .collect();
    draw::matches(&seq.images[0], &seq.images[k - 1], &pairs, MAX_WIDTH)
}

/// Writes `<name>-img1-vs-imgK.png` for every pair into `dir`, each atomically
/// ([`crate::output::write_png`]): `dir` may be outside the staged output (real data's
/// pictures go to `--matches-dir`), so a failed write must leave the previous picture whole.
pub fn write_all(seq: &Sequence, result: &SequenceResult, dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    for k in seq.pairs() {
        let path = dir.join(format!("{}-img1-vs-img{k}.png", seq.name));
        crate::output::write_png(&path, &picture(seq, result, k))?;
    }
    Ok(())
}
