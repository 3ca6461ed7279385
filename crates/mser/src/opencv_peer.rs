//! OpenCV's MSER as a peer (feature `opencv`): the same parameters, its regions as pixel lists.
//!
//! Used by the cross-check test and by `cargo xtask bench mser`. OpenCV finds both polarities of
//! a grey image in one `detectRegions` call (`pass2Only` keeps the bright ones only).

use opencv::core::{Mat, Point, Rect, Vector};
use opencv::prelude::*;

use crate::error::{MserError, Result};
use crate::image::GrayView;
use crate::params::{MserParams, Polarities};

/// The OpenCV version string the crate links (e.g. `4.6.0`).
pub fn opencv_version() -> String {
    opencv::core::get_version_string().unwrap_or_else(|_| "unknown".into())
}

/// An OpenCV `MSER` object with our parameters, and a packed copy of the image as a `Mat`.
pub struct OpenCvMser {
    mser: opencv::core::Ptr<opencv::features2d::MSER>,
    msers: Vector<Vector<Point>>,
    bboxes: Vector<Rect>,
}

impl OpenCvMser {
    /// Creates `cv::MSER::create(delta, min_area, max_area, max_variation, min_diversity)` (the
    /// colour-only parameters at their defaults). `Polarities::Dark` is not available in OpenCV
    /// and is rejected; `Bright` maps to `pass2Only`. The variation measure is OpenCV's own.
    pub fn new(p: &MserParams) -> Result<Self> {
        p.validate()?;
        let clamp = |a: usize| a.min(i32::MAX as usize) as i32;
        let mut mser = opencv::features2d::MSER::create(
            p.delta as i32,
            clamp(p.min_area),
            clamp(p.max_area),
            p.max_variation,
            p.min_diversity,
            200,
            1.01,
            0.003,
            5,
        )?;
        match p.polarities {
            Polarities::Both => {}
            Polarities::Bright => mser.set_pass2_only(true)?,
            Polarities::Dark => {
                return Err(MserError::InvalidParameter {
                    name: "polarities",
                    reason: "OpenCV cannot detect dark regions alone".into(),
                });
            }
        }
        Ok(OpenCvMser {
            mser,
            msers: Vector::new(),
            bboxes: Vector::new(),
        })
    }

    /// Wraps `img` as an OpenCV `Mat` (a packed copy).
    pub fn mat(img: &GrayView) -> Result<Mat> {
        let mut data = Vec::with_capacity(img.width() * img.height());
        for y in 0..img.height() {
            data.extend_from_slice(img.row(y));
        }
        let m = Mat::new_rows_cols_with_data(img.height() as i32, img.width() as i32, &data)?;
        Ok(m.try_clone()?)
    }

    /// Runs `detectRegions` on a `Mat` from [`mat`](Self::mat); returns the number of regions.
    pub fn detect_mat(&mut self, mat: &Mat) -> Result<usize> {
        self.mser
            .detect_regions(mat, &mut self.msers, &mut self.bboxes)?;
        Ok(self.msers.len())
    }

    /// Runs `detectRegions` and returns each region's pixels `(x, y)` in raster order.
    pub fn detect(&mut self, img: &GrayView) -> Result<Vec<Vec<(u32, u32)>>> {
        let mat = Self::mat(img)?;
        self.detect_mat(&mat)?;
        Ok(self
            .msers
            .iter()
            .map(|r| {
                let mut v: Vec<(u32, u32)> = r.iter().map(|p| (p.x as u32, p.y as u32)).collect();
                v.sort_unstable_by_key(|&(x, y)| (y, x));
                v
            })
            .collect())
    }
}

/// Sets OpenCV's worker-thread count (1 for single-core timing).
pub fn set_opencv_threads(n: i32) -> Result<()> {
    opencv::core::set_num_threads(n)?;
    Ok(())
}
