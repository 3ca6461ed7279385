//! `visguide`: the whole pipeline of Larsson's thesis (*Methods for Visually Guided Robotic
//! Systems*, Linköping 2009) in one dependency, and the `visguide` command line on top of it.
//! It sits above the seven method crates (`mser`, `fd-match`, `cbt-tracker`, `lwpr`, …; none of
//! them depends on it) and holds the glue no single crate may hold.
//!
//! # Paper A: image → regions → descriptors → matches → geometry
//!
//! 1. [`load_gray`]: an image file (PNG, PGM, PPM) to 8-bit grey with BT.601 weights
//!    ([`mser::to_gray`]); [`GrayReader`] reads many files with the same result, keeping its
//!    buffers (8-bit grey PNGs decoded straight into them).
//! 2. [`features::detect`]: MSER regions ([`MserSettings`] / [`Preset`]: OpenCV's, Paper A's
//!    or VLFeat's setting, any parameter overridden), each with its frame ellipse
//!    `dᵀ Σ⁻¹ d = 1` (Σ the region's second moments) and its exact outer contour.
//! 3. [`matching`]: Fourier descriptors of the contours (Paper A §3, affine-arc-length or
//!    canonical sampling, 51 coefficients), correlation matching `e = 2 − 2 max_l |r₁₂(l)|`
//!    (eq. 10) with rotation `φ = arg r₁₂(l*)` (eq. 12) and start shift (eq. 11), optional
//!    preselection (eq. 18), the symmetric ratio test `e_min / e_sec < T_r` (eq. 19) — any of the
//!    eight descriptor/sampling [`Combination`]s of the paper's figures.
//! 4. [`geometry`]: per match the local affine map of the two frames whose rotation is the
//!    recovered φ (`A = Σ₂^{1/2} R(θ) Σ₁^{−1/2}`, θ fixed by the polar rotation of A being φ),
//!    and a robust homography from all accepted matches (seeded RANSAC on four-point samples
//!    with the normalised DLT, then least squares on the inliers).
//! 5. [`scoring`]: against a known homography, the overlap error of Mikolajczyk et al. (IJCV
//!    2005) in descriptor mode, the ground truth of a pair (pairs with ε < 50 % are correct; the
//!    greedy one-to-one set gives the existing matches), precision and recall, and
//!    precision–recall curves over `T_r` — the measures of Paper A §5, also used by
//!    `cargo xtask eval paper-a`, which runs on this glue.
//!
//! ```
//! use visguide::{MatchSettings, match_images};
//! // A dark square and a dark ellipse on a bright background; the second image is shifted.
//! let scene = |dx: u32| image::GrayImage::from_fn(160, 120, |x, y| {
//!     let (x, y) = (x as f64 - dx as f64, y as f64);
//!     let square = (20.0..50.0).contains(&x) && (30.0..60.0).contains(&y);
//!     let blob = ((x - 100.0) / 25.0).powi(2) + ((y - 70.0) / 12.0).powi(2) < 1.0;
//!     image::Luma([if square || blob { 40 } else { 200 }])
//! });
//! let pair = match_images(&scene(0), &scene(7), &MatchSettings::paper()).unwrap();
//! // The square and the blob are found again 7 pixels to the right (their regions do not touch
//! // the border, so their centres move exactly with the shift).
//! let shifted = pair
//!     .accepted
//!     .iter()
//!     .filter(|g| {
//!         let (a, b) = (&pair.features1.frames[g.m.i], &pair.features2.frames[g.m.j]);
//!         (b.u - a.u - 7.0).abs() < 1e-9 && (b.v - a.v).abs() < 1e-9
//!     })
//!     .count();
//! assert_eq!(shifted, 2);
//! ```
//!
//! # Paper B and C on a user's files
//!
//! [`tables`] reads the CSV files of the command line with errors that name the file, line and
//! what was expected; [`models`] wraps the CBT tracker and LWPR models in a versioned file
//! format. Every random draw is seeded; nothing depends on the number of threads, not even which
//! error a parallel run reports ([`parallel`]). Files are
//! written atomically ([`output::atomic`]): a failure leaves no partial file.
#![deny(missing_docs)]

#[cfg(feature = "cli")]
pub mod args;
pub mod combination;
pub mod error;
pub mod features;
pub mod geometry;
pub mod image_io;
pub mod matching;
pub mod models;
pub mod output;
pub mod parallel;
pub mod pipeline;
pub mod preset;
pub mod scoring;
pub mod sim_robot;
pub mod tables;
#[cfg(test)]
mod test_data;

pub use combination::Combination;
pub use error::{Result, VisguideError};
pub use features::{Features, detect};
pub use geometry::{Homography, HomographyFit, LocalAffine, RansacConfig, fit_homography};
pub use image_io::{GrayReader, decode_gray, load_gray};
pub use matching::{MatchSettings, PairMatches, RegionMatch, match_images, match_regions};
pub use preset::{MserSettings, Preset};
pub use sim_robot::SimRobot;
