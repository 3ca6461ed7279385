//! Regions of one image: MSER detection (crate `mser`), each region's ellipse for the ground
//! truth and its outer contour for the Fourier descriptors.
//!
//! **Ellipse convention.** A region's ellipse is its moment ellipse `dᵀ Σ⁻¹ d = 1`, Σ the
//! second central moments of the region as a union of unit pixel squares
//! (`mser::Region::ellipse_scaled(1.0)`): the frame VLFeat's MSER gives and VLBenchmarks passes
//! unchanged to the benchmark's overlap code (docs/methods.md § Paper A evaluation). Descriptor
//! mode then magnifies it ×3 (docs/methods.md § Overlap error, step 6), i.e. about 1.5 times the
//! region's own size. This was chosen from the benchmark's documented MSER convention before any
//! result was seen.

use image::GrayImage;
use mser::{GrayView, MserParams};

use super::overlap::{Ellipse, from_covariance};

/// The regions of one image, index-aligned: region `i` has `ellipses[i]` and `contours[i]`.
#[derive(Debug, Clone, Default)]
pub struct Features {
    /// Moment ellipse of each region.
    pub ellipses: Vec<Ellipse>,
    /// Outer contour of each region (closed, ordered pixel centres).
    pub contours: Vec<Vec<(u32, u32)>>,
}

impl Features {
    /// Number of regions.
    pub fn len(&self) -> usize {
        self.ellipses.len()
    }
}

/// Detects the MSERs of `img` with `params` and extracts ellipses and contours.
pub fn detect(img: &GrayImage, params: &MserParams) -> crate::Result<Features> {
    let view = GrayView::from_image(img)?;
    let regions = mser::detect(&view, params)?;
    let mut out = Features::default();
    for r in &regions {
        let (u, v) = r.centroid();
        let ellipse = from_covariance(u, v, r.moments.area_covariance())?;
        out.ellipses.push(ellipse);
        out.contours.push(r.contour(&view)?);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::paper_a::overlap::tests::half_extent;

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
        let k = if f.ellipses[0].area() < f.ellipses[1].area() {
            0
        } else {
            1
        };
        let e = f.ellipses[k];
        assert!((e.u - 40.0).abs() < 1e-9 && (e.v - 30.0).abs() < 1e-9);
        // A filled ellipse with semi-axes 20, 10 has standard deviations 10, 5.
        let (hx, hy) = half_extent(&e);
        assert!(
            (hx - 10.0).abs() < 0.3 && (hy - 5.0).abs() < 0.3,
            "{hx} {hy}"
        );
        assert!(f.contours[k].len() > 50);
    }
}
