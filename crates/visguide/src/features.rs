//! Regions of one image: MSER detection (crate `mser`), each region's frame ellipse and its
//! outer contour for the Fourier descriptors.
//!
//! **Ellipse convention.** A region's *frame* is its moment ellipse `dᵀ Σ⁻¹ d = 1`, Σ the
//! second central moments of the region as a union of unit pixel squares
//! (`mser::Region::ellipse_scaled(1.0)`): the frame VLFeat's MSER gives and VLBenchmarks passes
//! unchanged to the benchmark's overlap code. The region files written by the command line use
//! [`mser::Region::ellipse`] instead (`M = (4Σ)⁻¹`, about the region's own area), the size the
//! Oxford detectors write; both have the same centre and shape.

use image::GrayImage;
use mser::{GrayView, MserParams, Region};

use crate::error::Result;
use crate::scoring::overlap::{Ellipse, from_covariance};

/// The regions of one image, index-aligned: region `i` has `regions[i]`, `frames[i]` and
/// `contours[i]`.
#[derive(Debug, Clone, Default)]
pub struct Features {
    /// The detector's regions (level, seed, area, moments …).
    pub regions: Vec<Region>,
    /// Moment ellipse (frame) of each region.
    pub frames: Vec<Ellipse>,
    /// Outer contour of each region (closed, ordered pixel centres, counter-clockwise on
    /// screen, starting at the seed).
    pub contours: Vec<Vec<(u32, u32)>>,
}

impl Features {
    /// Number of regions.
    pub fn len(&self) -> usize {
        self.regions.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.regions.is_empty()
    }
}

/// Detects the MSERs of `img` with `params` and extracts frames and contours.
pub fn detect(img: &GrayImage, params: &MserParams) -> Result<Features> {
    detect_view(&GrayView::from_image(img)?, params)
}

/// [`detect`] on a view (e.g. a window of a larger image: the regions' coordinates are the
/// view's).
pub fn detect_view(view: &GrayView, params: &MserParams) -> Result<Features> {
    let regions = mser::detect(view, params)?;
    let mut out = Features {
        frames: Vec::with_capacity(regions.len()),
        contours: Vec::with_capacity(regions.len()),
        regions: Vec::new(),
    };
    for r in &regions {
        let (u, v) = r.centroid();
        out.frames
            .push(from_covariance(u, v, r.moments.area_covariance())?);
        out.contours.push(r.contour(view)?);
    }
    out.regions = regions;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scoring::overlap::tests::half_extent;

    #[test]
    fn a_dark_disc_gives_its_moment_ellipse_and_contour() {
        let (w, h) = (80u32, 60u32);
        let img = GrayImage::from_fn(w, h, |x, y| {
            let (dx, dy) = (x as f64 - 40.0, y as f64 - 30.0);
            image::Luma([if dx * dx / 400.0 + dy * dy / 100.0 <= 1.0 {
                30
            } else {
                220
            }])
        });
        let params = MserParams::default();
        let f = detect(&img, &params).unwrap();
        // The dark disc and its bright complement.
        assert_eq!(f.len(), 2);
        let k = if f.frames[0].area() < f.frames[1].area() {
            0
        } else {
            1
        };
        let e = f.frames[k];
        assert!((e.u - 40.0).abs() < 1e-9 && (e.v - 30.0).abs() < 1e-9);
        // A filled ellipse with semi-axes 20, 10 has standard deviations 10, 5.
        let (hx, hy) = half_extent(&e);
        assert!(
            (hx - 10.0).abs() < 0.3 && (hy - 5.0).abs() < 0.3,
            "{hx} {hy}"
        );
        assert!(f.contours[k].len() > 50);
        // Every contour starts at its region's seed and runs counter-clockwise on screen (x
        // right, y down): a negative shoelace sum.
        for (c, r) in f.contours.iter().zip(&f.regions) {
            assert_eq!(c[0], r.seed);
            let twice_area: i64 = (0..c.len())
                .map(|n| {
                    let (p, q) = (c[n], c[(n + 1) % c.len()]);
                    p.0 as i64 * q.1 as i64 - q.0 as i64 * p.1 as i64
                })
                .sum();
            assert!(twice_area < 0, "{twice_area}");
        }
    }
}
