//! # fd-match: Fourier descriptors of local contours, matched by correlation
//!
//! Implements Paper A of Larsson's thesis (Larsson, Felsberg, Forssén, *Patch contour matching
//! by correlating Fourier descriptors*, DICTA 2009). Input: closed, ordered contours as point
//! lists (`&[(x, y)]`, integer or float, e.g. MSER outer contours; this crate does not depend on
//! an MSER detector). Output: descriptors, pair errors with rotation and start-point shift,
//! best/second-best searches, preselection and symmetric ratio-test matches.
//!
//! ## The math
//! A contour is the periodic complex signal `c(l) = x(l) + i·y(l)` (eq. 1), resampled to `L`
//! points ([`Sampling`]: uniform arc length, affine arc length `t = ½∫|xẏ − yẋ| dl` of eq. 5
//! with regularised derivatives, or uniform in a similarity-normalised canonical frame). Its
//! Fourier coefficients `C(n) = (1/L) Σ_l c(l) e^{−i2πnl/L}` (eq. 2, computed with rustfft)
//! are truncated to `n = −K..=K` (`N = 2K + 1 = 51` as in the paper), `C(0)` is dropped
//! (translation) and `‖C‖₂ = 1` (scale). Rotation multiplies `C` by `e^{iφ}` (eq. 3), a
//! start-point shift modulates it by `e^{−i2πnΔl/L}` (eq. 4).
//!
//! [`Method::FdCorr`] matches with the correlation `r₁₂ = F⁻¹{conj(C₁)·C₂}` (eq. 9): the
//! least-squares error over rotation and shift is `e = 2 − 2 max_l |r₁₂(l)|` (eq. 10), with
//! `Δl = argmax |r₁₂|` (eq. 11) and `φ = arg r₁₂(Δl)` (eq. 12). The maximum is found by a
//! zero-padded inverse FFT and Newton refinement on the exact trigonometric polynomial, so
//! `e`, `φ` and `Δl` are accurate to ~1e-12 rather than to the grid ([`Correlator`]).
//! Baselines: [`Method::AbsFdSsd`] (`|C(n)|`, phase neglected), [`Method::Afd0Ssd`] and
//! [`Method::Afd1Ssd`] (affine-invariant FDs after Arbter et al., see the `afd` module doc),
//! and plain [`Method::FdSsd`].
//!
//! Preselection (eq. 18) drops descriptors whose minimum error against the rest of their image
//! is below `T_err` ([`min_errors_within`], [`preselect`]). The ratio test (eq. 19) accepts a
//! match when `e_min / e_sec < T_r` (default 0.5); matching is symmetric, with the larger of the
//! two ratios ([`mutual_matches`]). The all-pairs search ([`best_two`]) skips pairs using the
//! bound `max_l |r₁₂(l)| ≤ Σ |C₁(n)||C₂(n)|`, i.e. abs(FD) SSD ≤ FD Corr error, with results
//! identical to brute force, in parallel (rayon) with deterministic output.
//!
//! ## Evaluating the paper's eight combinations
//! Describe each image's contours once per sampling, search once per method and direction,
//! then sweep `T_r` over the mutual matches without recomputing anything:
//! ```
//! use fd_match::{best_two, describe_all, mutual_matches, DescriptorConfig, Method, Sampling};
//! use std::f64::consts::PI;
//!
//! // Star-shaped test contours; image B holds the same shapes rotated, scaled and shifted.
//! let shape = |s: usize, rot: f64, scale: f64| -> Vec<(f64, f64)> {
//!     (0..120).map(|i| {
//!         let a = 2.0 * PI * i as f64 / 120.0;
//!         let r = 20.0 + 4.0 * ((s + 2) as f64 * a).cos() + 2.0 * (3.0 * a + s as f64).sin();
//!         let (x, y) = (r * a.cos(), r * a.sin());
//!         (scale * (x * rot.cos() - y * rot.sin()) + 50.0, scale * (x * rot.sin() + y * rot.cos()))
//!     }).collect()
//! };
//! let image_a: Vec<_> = (0..5).map(|s| shape(s, 0.0, 1.0)).collect();
//! let image_b: Vec<_> = (0..5).rev().map(|s| shape(s, 0.7, 1.5)).collect();
//!
//! for sampling in [Sampling::AffineArcLength, Sampling::Canonical] {
//!     let cfg = DescriptorConfig::with_sampling(sampling); // 51 coefficients
//!     let a = describe_all(cfg, &image_a).unwrap().set;
//!     let b = describe_all(cfg, &image_b).unwrap().set;
//!     for method in Method::PAPER {
//!         let ab = best_two(&a, &b, method).unwrap(); // best and second best per query
//!         let ba = best_two(&b, &a, method).unwrap();
//!         let matches = mutual_matches(&ab, &ba); // symmetric, unthresholded
//!         for t_r in [0.3, 0.5, 0.8] {
//!             let accepted = matches.iter().filter(|m| m.accepted(t_r));
//!             // correct when the contours correspond (here: index i of A is 4 − i of B)
//!             let correct = accepted.clone().filter(|m| b.source(m.target) == 4 - a.source(m.query));
//!             let _ = (method.label(sampling), accepted.count(), correct.count());
//!         }
//!         if method == Method::FdCorr {
//!             assert_eq!(matches.len(), 5);
//!             assert!(matches.iter().all(|m| b.source(m.target) == 4 - a.source(m.query)));
//!         }
//!     }
//! }
//! ```
//! With preselection: `let keep = preselect(&min_errors_within(&a, method)?, t_err)?;` then
//! `a.select(&keep)?` (the paper's thresholds: [`Method::paper_preselection_threshold`]).
//!
//! Bad contours (fewer than 3 points, NaN, repeated consecutive points, zero area) give a typed
//! [`FdError`]; [`describe_all`] collects them per contour instead of failing.
//! Every finite coordinate is accepted: contours far from unit size (beyond 2^±64) are scaled by
//! an exact power of two before the geometry, whose fourth powers would otherwise overflow
//! (module `contour`). Sizes are bounded before anything is allocated ([`MAX_SAMPLES`],
//! [`MAX_DENSE_SAMPLES`], also when a [`DescriptorConfig`] is deserialised); descriptors pushed
//! into a set must be finite and of unit norm, and pair errors of vectors of different lengths
//! are an [`FdError::LengthMismatch`], never a number; sets searched against each other must
//! share one [`DescriptorConfig`] ([`FdError::IncompatibleSets`] otherwise: descriptors of
//! another sampling have the same length but are not comparable).
#![deny(missing_docs)]

mod afd;
mod bound;
mod contour;
mod correlation;
mod descriptor;
mod error;
mod extract;
mod matching;
mod method;
mod point;
mod sampling;
mod search;

pub use contour::validate_contour;
pub use correlation::{Alignment, Correlation, Correlator};
pub use descriptor::{
    Descriptor, DescriptorConfig, DescriptorSet, MAX_DENSE_SAMPLES, MAX_SAMPLES,
    UNIT_NORM_TOLERANCE, afd_frequency, fd_frequency,
};
pub use error::FdError;
pub use extract::{Described, Extractor, describe_all};
pub use matching::{DEFAULT_RATIO_THRESHOLD, Match, match_sets, mutual_matches, preselect};
pub use method::{Method, ssd_complex, ssd_real};
pub use point::ContourPoint;
pub use rustfft::num_complex::Complex64;
pub use sampling::Sampling;
pub use search::{
    BestTwo, Candidate, SearchStats, best_two, best_two_brute_force, best_two_with_stats,
    min_errors_within,
};
