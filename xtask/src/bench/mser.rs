//! `cargo xtask bench mser`: our MSER against OpenCV's `MSER::detectRegions` on graf and boat img1,
//! both polarities, default (OpenCV) parameters, one thread, median of 15 runs after 3 warm-ups.
//!
//! The OpenCV half needs the xtask feature `opencv`
//! (`cargo run -p xtask --release --features opencv -- bench mser`); without it the bench says so
//! and still times ours (peer and ratio are then NaN).

use mser::{GrayView, Mser, MserParams};

use super::BenchArgs;
use crate::Result;
use crate::report::{BenchRow, time_median};

const WARMUP: usize = 3;
const RUNS: usize = 15;

/// Runs the bench.
pub fn run(args: &BenchArgs) -> Result<Vec<BenchRow>> {
    let root = args
        .data
        .as_ref()
        .ok_or("set VISGUIDE_DATA (or --data) to the folder holding oxford-affine/")?
        .join("oxford-affine");
    let params = MserParams::default();
    #[cfg(feature = "opencv")]
    {
        mser::set_opencv_threads(1)?;
        println!("peer: OpenCV {} (one thread)", mser::opencv_version());
    }
    #[cfg(not(feature = "opencv"))]
    println!(
        "peer unavailable: OpenCV's MSER needs the xtask feature `opencv` \
         (cargo run -p xtask --release --features opencv -- bench mser); timing ours only"
    );
    let mut rows = Vec::new();
    for seq in ["graf", "boat"] {
        let gray = mser::load_gray(root.join(seq).join("img1.png"))?;
        let img = GrayView::from_image(&gray)?;
        let pixels = (img.width() * img.height()) as f64;
        let mut det = Mser::new(params.clone())?;
        let mut n_ours = 0;
        let ours = time_median(WARMUP, RUNS, || {
            n_ours = det.detect(&img).expect("valid image").len();
        });
        let (peer, n_peer) = peer_time(&img, &params)?;
        println!(
            "{seq} img1 {}x{}: ours {n_ours} regions, peer {n_peer} regions",
            img.width(),
            img.height()
        );
        rows.push(BenchRow::lower_is_better(
            format!("{seq} img1, both polarities"),
            ours * 1e3,
            peer * 1e3,
            "ms",
        ));
        rows.push(BenchRow::lower_is_better(
            format!("{seq} img1, per pixel"),
            ours / pixels * 1e9,
            peer / pixels * 1e9,
            "ns/pixel",
        ));
    }
    Ok(rows)
}

/// OpenCV's median time in seconds and its region count.
#[cfg(feature = "opencv")]
fn peer_time(img: &GrayView, params: &MserParams) -> Result<(f64, usize)> {
    let mut cv = mser::OpenCvMser::new(params)?;
    let mat = mser::OpenCvMser::mat(img)?;
    let mut n = 0;
    let t = time_median(WARMUP, RUNS, || {
        n = cv.detect_mat(&mat).expect("OpenCV MSER runs");
    });
    Ok((t, n))
}

/// Without the feature there is no peer.
#[cfg(not(feature = "opencv"))]
fn peer_time(_img: &GrayView, _params: &MserParams) -> Result<(f64, usize)> {
    Ok((f64::NAN, 0))
}
