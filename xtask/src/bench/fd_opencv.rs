//! OpenCV's contrib `ximgproc::ContourFitting` (feature `opencv`), timed for information beside
//! `bench fd`. It is a different estimator (it fits rotation, start point *and scale* by
//! Newton–Raphson on the Fourier-descriptor distance of Persoon & Fu, with its own resampling),
//! so its output cannot equal ours and no ratio is reported: only its time per pair, with
//! `ctr = 256` resampled points and `fd = 51` descriptors (our `L` and `N`).

use opencv::core::{Mat, Point2d, Vector};
use opencv::prelude::*;

use super::cpu::thread_seconds;
use super::fd::Contour;
use crate::Result;

/// Queries × targets of the sample.
const SAMPLE: usize = 60;

/// Times `estimateTransformation` on the first `SAMPLE` × `SAMPLE` pairs of `a` × `b` and
/// prints the rate.
pub fn contour_fitting(a: &[Contour], b: &[Contour]) -> Result<()> {
    let mut cf = opencv::ximgproc::create_contour_fitting(256, 51)?;
    let to_cv =
        |c: &Contour| -> Vector<Point2d> { c.iter().map(|&(x, y)| Point2d::new(x, y)).collect() };
    let qa: Vec<Vector<Point2d>> = a.iter().take(SAMPLE).map(to_cv).collect();
    let qb: Vec<Vector<Point2d>> = b.iter().take(SAMPLE).map(to_cv).collect();
    let mut t = Mat::default();
    let mut dist = 0.0f64;
    let t0 = thread_seconds().ok_or("no thread CPU clock")?;
    let mut finite = 0;
    for x in &qa {
        for y in &qb {
            cf.estimate_transformation(x, y, &mut t, Some(&mut dist), false)?;
            finite += dist.is_finite() as usize;
        }
    }
    let secs = thread_seconds().ok_or("no thread CPU clock")? - t0;
    let pairs = (qa.len() * qb.len()) as f64;
    println!(
        "OpenCV {} ximgproc::ContourFitting::estimateTransformation (contours in, ctr 256, fd 51; a different estimator, not compared for equality): {:.1} us/pair = {:.4} Mpairs/CPU-s on {} pairs ({finite} finite distances), one thread",
        opencv::core::get_version_string()?,
        secs / pairs * 1e6,
        pairs / secs / 1e6,
        pairs as usize
    );
    Ok(())
}
