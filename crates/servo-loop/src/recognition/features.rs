//! Channel-coded feature maps (docs/methods.md § Servoing): a soft histogram over image position
//! and gradient orientation. Every pixel of the (half-resolution) image contributes
//!
//! ```text
//! w(p) · B₂(t_x(p) − i) · B₂(t_y(p) − j) · cos²-channel_o(φ(p))
//! ```
//!
//! to spatial channel `(i, j)` and orientation channel `o`, where `B₂` is the quadratic
//! B-spline (chan-repr [`Kernel::BSpline2`], channel spacing = `block` pixels), `φ = 2·atan2(g_y,
//! g_x)` is the double-angle gradient orientation (a line and its reversed-contrast twin give
//! the same channel, so the map survives lighting and background changes), coded with cyclic
//! cos² channels (`m = 3`, chan-repr [`PeriodicBasis`] with [`Kernel::Cos2`], channel `o`
//! centred at `φ = 2π·o/orientations`), and `w = |g| / (|g| + g₀)` a saturated
//! gradient magnitude (strong clutter edges cannot dominate; global gain changes cancel in the
//! normalised comparison of [`crate::recognition::ccfm`]). Finally every orientation channel
//! is divided by its mean over the image (plus 10 % of the overall mean): orientations present
//! everywhere (a striped table) are background and weigh less.
//!
//! Channel coordinates: spatial channel `k` is centred at half-resolution pixel
//! `(k + 0.5)·block − 0.5`, i.e. `t = (x_full + 0.5) / (2·block) − 0.5` for a full-resolution
//! coordinate `x_full`.

use chan_repr::{ChannelBasis, Kernel, PeriodicBasis};

use std::f64::consts::TAU;

use crate::error::{Result, ServoError};
use crate::recognition::image::FloatImage;

/// Parameters of the feature map.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FeatureParams {
    /// Spatial channel spacing in half-resolution pixels.
    pub block: usize,
    /// Number of orientation channels (over the double angle, cyclic).
    pub orientations: usize,
    /// Gradient magnitude of half weight, `g₀` (grey levels per half-resolution pixel).
    pub magnitude_half: f32,
    /// Number of grey-level channels (cos², over 0–255; 0 = none), each pixel weighted 1.
    pub intensities: usize,
}

impl FeatureParams {
    /// Channels per spatial cell of the map, `max(orientations, 3) + intensities` (the map's
    /// `orientations`; a descriptor holds `cells²` times as many); `None` when that overflows.
    pub fn channels(&self) -> Option<usize> {
        self.orientations.max(3).checked_add(self.intensities)
    }
}

/// The cyclic cos² orientation channels (chan-repr [`PeriodicBasis`] over `[0, 2π)`) of the
/// double-angle orientation `φ = 2·atan2(g_y, g_x)` of gradient `(g_x, g_y)`, each value times
/// `weight`: at most 3 active `(channel, value)` pairs and their count.
#[inline]
fn orientation_channels(
    basis: &PeriodicBasis,
    gx: f32,
    gy: f32,
    weight: f32,
) -> ([(usize, f32); 3], usize) {
    let phi = f64::from(gy * gx * 2.0).atan2(f64::from(gx * gx - gy * gy));
    let mut oc = [(0usize, 0.0f32); 3];
    let mut n = 0;
    basis.for_each_active(basis.to_index(phi), |k, val| {
        if n < 3 {
            oc[n] = (k, val as f32 * weight);
            n += 1;
        }
    });
    (oc, n)
}

/// Checks that `img` holds `width × height` values (its fields are public).
pub(crate) fn check_image(img: &FloatImage) -> Result<()> {
    if img.width.checked_mul(img.height) != Some(img.data.len()) {
        return Err(ServoError::InvalidParameter {
            name: "image",
            reason: format!(
                "{} values for a {} × {} image",
                img.data.len(),
                img.width,
                img.height
            ),
        });
    }
    Ok(())
}

/// A dense channel-coded feature map: `blocks_y × blocks_x × channels` values (the
/// orientation channels, then the grey-level channels).
#[derive(Debug, Clone, PartialEq)]
pub struct FeatureMap {
    /// Spatial channels along x.
    pub blocks_x: usize,
    /// Spatial channels along y.
    pub blocks_y: usize,
    /// Feature channels per spatial channel (orientations + grey levels).
    pub orientations: usize,
    /// Full-resolution pixels per spatial channel (`2·block`).
    pub scale: f64,
    /// Values, index `(j·blocks_x + i)·orientations + o`.
    pub data: Vec<f32>,
}

impl FeatureMap {
    /// Computes the map of a half-resolution image (see the module doc). Errors: an image
    /// whose `data` is not `width × height` values ([`ServoError::InvalidParameter`] `image`;
    /// it was indexed past its end), too many channels per cell, or a map of more values than
    /// memory can address.
    pub fn compute(img: &FloatImage, p: &FeatureParams) -> Result<FeatureMap> {
        check_image(img)?;
        let (w, h, b, no0) = (img.width, img.height, p.block.max(1), p.orientations.max(3));
        let ni = p.intensities;
        let no = p
            .channels()
            .ok_or_else(|| ServoError::invalid("intensities", "too many channels per cell"))?;
        let grey = if ni >= 3 {
            Some(ChannelBasis::covering(
                0.0,
                255.0,
                ni,
                Kernel::Cos2 { m: 3 },
            )?)
        } else {
            None
        };
        let bx = w.div_ceil(b).max(1);
        let by = h.div_ceil(b).max(1);
        let sx = ChannelBasis::integer(bx.max(3), Kernel::BSpline2)?;
        let sy = ChannelBasis::integer(by.max(3), Kernel::BSpline2)?;
        let orient = PeriodicBasis::new(TAU, no0, Kernel::Cos2 { m: 3 })?;
        let tcoord = |x: usize| (x as f64 + 0.5) / b as f64 - 0.5;
        let weights = |basis: &ChannelBasis, t: f64, n: usize| {
            let mut v = [(0usize, 0.0f32); 3];
            let mut c = 0;
            basis.for_each_active(t, |k, val| {
                if k < n && c < 3 {
                    v[c] = (k, val as f32);
                    c += 1;
                }
            });
            (v, c)
        };
        let col_w: Vec<_> = (0..w).map(|x| weights(&sx, tcoord(x), bx)).collect();
        let size = bx
            .checked_mul(by)
            .and_then(|n| n.checked_mul(no))
            .ok_or_else(|| ServoError::invalid("intensities", "too many channels per map"))?;
        let mut data = vec![0.0f32; size];
        let mut row = vec![0.0f32; bx * no];
        for y in 1..h.saturating_sub(1) {
            row.iter_mut().for_each(|v| *v = 0.0);
            let mut any = false;
            #[allow(clippy::needless_range_loop)]
            // Saturating: an image 0 pixels wide (and at least 3 high) underflowed.
            for x in 1..w.saturating_sub(1) {
                let gx = 0.5 * (img.at(x + 1, y) - img.at(x - 1, y));
                let gy = 0.5 * (img.at(x, y + 1) - img.at(x, y - 1));
                let (xw, nxw) = &col_w[x];
                if let Some(gb) = &grey {
                    let t = gb.to_index(f64::from(img.at(x, y)).clamp(0.0, 255.0));
                    gb.for_each_active(t, |k, val| {
                        for &(kx, vx) in &xw[..*nxw] {
                            row[kx * no + no0 + k] += vx * val as f32;
                        }
                    });
                    any = true;
                }
                let m2 = gx * gx + gy * gy;
                if m2 < 1e-6 {
                    continue;
                }
                let m = m2.sqrt();
                let wgt = m / (m + p.magnitude_half);
                let (oc, n_oc) = orientation_channels(&orient, gx, gy, wgt);
                for &(kx, vx) in &xw[..*nxw] {
                    let base = kx * no;
                    for &(o, vo) in &oc[..n_oc] {
                        row[base + o] += vx * vo;
                    }
                }
                any = true;
            }
            if !any {
                continue;
            }
            let (yw, nyw) = weights(&sy, tcoord(y), by);
            for &(ky, vy) in &yw[..nyw] {
                let dst = &mut data[ky * bx * no..(ky + 1) * bx * no];
                for (d, r) in dst.iter_mut().zip(&row) {
                    *d += vy * r;
                }
            }
        }
        // Background normalisation: divide every orientation channel by its mean over the
        // image, so an orientation that is everywhere (a striped table, a lighting gradient)
        // carries no more weight than a rare one.
        let cells_total = (bx * by) as f32;
        let mut mean = vec![0.0f32; no];
        for cell in data.chunks_exact(no) {
            mean.iter_mut().zip(cell).for_each(|(m, v)| *m += v);
        }
        let total: f32 = mean.iter().sum::<f32>() / (cells_total * no as f32);
        let inv: Vec<f32> = mean
            .iter()
            .map(|m| 1.0 / (m / cells_total + 0.1 * total + 1e-6))
            .collect();
        for cell in data.chunks_exact_mut(no) {
            cell.iter_mut().zip(&inv).for_each(|(v, s)| *v *= s);
        }
        Ok(FeatureMap {
            blocks_x: bx,
            blocks_y: by,
            orientations: no,
            scale: 2.0 * b as f64,
            data,
        })
    }

    /// Channel coordinate of full-resolution coordinate `x`.
    #[inline]
    pub fn to_channel(&self, x: f64) -> f64 {
        (x + 0.5) / self.scale - 0.5
    }

    /// Full-resolution coordinate of channel coordinate `t`.
    #[inline]
    pub fn to_pixel(&self, t: f64) -> f64 {
        (t + 0.5) * self.scale - 0.5
    }

    /// The `cells × cells × orientations` descriptor centred at channel coordinates `(tx,
    /// ty)`: cell `(a, b)` is the map bilinearly interpolated at `(tx + a − c, ty + b − c)`,
    /// `c = (cells − 1)/2`; zero outside the map.
    pub fn descriptor(&self, tx: f64, ty: f64, cells: usize, out: &mut Vec<f32>) {
        let no = self.orientations;
        out.clear();
        out.resize(cells * cells * no, 0.0);
        let c = (cells as f64 - 1.0) / 2.0;
        let (fx, fy) = ((tx - c).floor(), (ty - c).floor());
        let (ax, ay) = ((tx - c - fx) as f32, (ty - c - fy) as f32);
        let (ix0, iy0) = (fx as i64, fy as i64);
        let (bx, by) = (self.blocks_x as i64, self.blocks_y as i64);
        let cells_i = cells as i64;
        for b in 0..cells_i {
            for (dy, wy) in [(0i64, 1.0 - ay), (1, ay)] {
                let j = iy0 + b + dy;
                if wy == 0.0 || j < 0 || j >= by {
                    continue;
                }
                for (dx, wx) in [(0i64, 1.0 - ax), (1, ax)] {
                    let wt = wx * wy;
                    if wt == 0.0 {
                        continue;
                    }
                    // Columns a with 0 ≤ ix0 + dx + a < bx.
                    let a_lo = (-(ix0 + dx)).clamp(0, cells_i);
                    let a_hi = (bx - ix0 - dx).clamp(0, cells_i);
                    if a_lo >= a_hi {
                        continue;
                    }
                    let s0 = ((j * bx + ix0 + dx + a_lo) as usize) * no;
                    let len = (a_hi - a_lo) as usize * no;
                    let src = &self.data[s0..s0 + len];
                    let d0 = ((b * cells_i + a_lo) as usize) * no;
                    for (d, v) in out[d0..d0 + len].iter_mut().zip(src) {
                        *d += wt * v;
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The hand-written cyclic channels this module used before chan-repr had periodic bases:
    /// an integer cos² basis of `no0 + 3` channels at `t = φ/2π·no0 + 1`, channel `k` folded
    /// to `(k + no0 − 1) mod no0`.
    fn folded_integer_channels(no0: usize, gx: f32, gy: f32, weight: f32) -> Vec<f32> {
        let basis = ChannelBasis::integer(no0 + 3, Kernel::Cos2 { m: 3 }).unwrap();
        let phi = f64::from(gy * gx * 2.0).atan2(f64::from(gx * gx - gy * gy));
        let phi = if phi < 0.0 { phi + TAU } else { phi };
        let mut out = vec![0.0f32; no0];
        basis.for_each_active(phi / TAU * no0 as f64 + 1.0, |k, v| {
            out[(k + no0 - 1) % no0] += v as f32 * weight
        });
        out
    }

    #[test]
    fn periodic_orientation_channels_equal_the_folded_integer_basis() {
        for no0 in [3usize, 4, 8, 12] {
            let basis = PeriodicBasis::new(TAU, no0, Kernel::Cos2 { m: 3 }).unwrap();
            let mut worst = 0.0f32;
            for i in 0..20_000 {
                // Gradient directions all around the circle, the axes and diagonals exactly.
                let a = TAU * f64::from(i) / 20_000.0;
                let (gx, gy) = ((3.0 * a.cos()) as f32, (3.0 * a.sin()) as f32);
                let w = 0.25 + (i % 7) as f32 / 10.0;
                let (oc, n) = orientation_channels(&basis, gx, gy, w);
                assert!((1..=3).contains(&n));
                let mut dense = vec![0.0f32; no0];
                for &(o, v) in &oc[..n] {
                    assert!(o < no0);
                    dense[o] += v;
                }
                let want = folded_integer_channels(no0, gx, gy, w);
                for (d, e) in dense.iter().zip(&want) {
                    worst = worst.max((d - e).abs());
                }
                // cos² with m = 3: the active channels sum to 1.5 (times the weight).
                assert!((dense.iter().sum::<f32>() - 1.5 * w).abs() < 1e-5);
            }
            assert!(worst < 1e-6, "no0 = {no0}: largest difference {worst}");
        }
    }
}
