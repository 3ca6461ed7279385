//! Descriptors and matches of two images' regions (Paper A §4): each region's outer contour is
//! resampled and described ([`describe`], crate `fd-match`), optionally preselected (eq. 18,
//! [`preselected`]), and the two sets are matched symmetrically with the ratio test (eq. 19,
//! [`match_regions`]). Indices are *region* indices (into [`Features`]), not descriptor
//! indices, so a match points straight at its regions.
//!
//! [`match_images`] runs the whole chain on two images and adds the geometry: for every
//! accepted match the rotation between the two contours (the FD correlation's φ on
//! affine-arc-length samples, eq. 12: the match's own when the combination is FD Corr/Affine,
//! otherwise a correlation of just that pair) and the local affine map of its frames
//! ([`crate::geometry::local_affine`]); and a robust homography from the accepted matches'
//! centres ([`crate::geometry::fit_homography`]).

use fd_match::{
    Alignment, DescriptorConfig, DescriptorSet, Method, Sampling, match_sets, min_errors_within,
    preselect,
};
use image::GrayImage;
use mser::MserParams;
use serde::{Deserialize, Serialize};

use crate::combination::Combination;
use crate::error::{Result, VisguideError};
use crate::features::{Features, detect};
use crate::geometry::{HomographyFit, LocalAffine, RansacConfig, fit_homography, local_affine};

/// One symmetric match between region `i` of image 1 and region `j` of image 2.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RegionMatch {
    /// Region of image 1.
    pub i: usize,
    /// Region of image 2.
    pub j: usize,
    /// The pair's error (eq. 10 for FD Corr).
    pub error: f64,
    /// The larger of the two error ratios `e_min / e_sec` (eq. 19).
    pub ratio: f64,
    /// Rotation and start shift (FD Corr only).
    pub alignment: Option<Alignment>,
}

/// Describes every region's contour with `sampling` (Paper A's descriptor setting otherwise);
/// degenerate contours are left out (`set.source(k)` is the region index).
pub fn describe(features: &Features, sampling: Sampling) -> Result<DescriptorSet> {
    Ok(fd_match::describe_all(
        DescriptorConfig::with_sampling(sampling),
        &features.contours,
    )?
    .set)
}

/// The descriptors that survive preselection with threshold `t_err` (eq. 18).
pub fn preselected(set: &DescriptorSet, method: Method, t_err: f64) -> Result<DescriptorSet> {
    let keep = preselect(&min_errors_within(set, method)?, t_err)?;
    Ok(set.select(&keep)?)
}

/// All symmetric matches of two descriptor sets, unthresholded, ascending in `i`.
pub fn match_regions(
    a: &DescriptorSet,
    b: &DescriptorSet,
    method: Method,
) -> Result<Vec<RegionMatch>> {
    Ok(match_sets(a, b, method)?
        .into_iter()
        .map(|m| RegionMatch {
            i: a.source(m.query),
            j: b.source(m.target),
            error: m.error,
            ratio: m.ratio,
            alignment: m.alignment,
        })
        .collect())
}

/// What [`match_images`] does.
#[derive(Debug, Clone, PartialEq)]
pub struct MatchSettings {
    /// Detector parameters of image 1 and image 2.
    pub mser: (MserParams, MserParams),
    /// Descriptor and sampling.
    pub combination: Combination,
    /// Ratio threshold `T_r`: a match is accepted when `ratio < T_r`. Paper A: 0.5.
    pub ratio_threshold: f64,
    /// Preselection threshold `T_err` (eq. 18), if any.
    pub preselection: Option<f64>,
    /// Robust homography fit; `None` skips it.
    pub ransac: Option<RansacConfig>,
}

impl MatchSettings {
    /// Paper A's setting: `larsson2009` regions, FD Corr/Affine, `T_r = 0.5`, no preselection,
    /// a homography with the default RANSAC setting.
    pub fn paper() -> Self {
        MatchSettings {
            mser: (MserParams::larsson2009(), MserParams::larsson2009()),
            combination: Combination::SHOWN,
            ratio_threshold: crate::scoring::pr::PAPER_T_R,
            preselection: None,
            ransac: Some(RansacConfig::default()),
        }
    }

    /// Checks the setting ([`match_images`] does before any work): `T_r` positive (not NaN),
    /// the preselection threshold finite and non-negative, the RANSAC setting valid
    /// ([`RansacConfig::validate`]). The MSER parameters are checked by the detector.
    pub fn validate(&self) -> Result<()> {
        if self.ratio_threshold.is_nan() || self.ratio_threshold <= 0.0 {
            return Err(VisguideError::Invalid {
                name: "ratio threshold",
                reason: format!("T_r {} is not a positive number", self.ratio_threshold),
            });
        }
        if let Some(t) = self.preselection
            && !(t.is_finite() && t >= 0.0)
        {
            return Err(VisguideError::Invalid {
                name: "preselection threshold",
                reason: format!("T_err {t} is not a finite number >= 0"),
            });
        }
        if let Some(r) = &self.ransac {
            r.validate()?;
        }
        Ok(())
    }
}

/// One accepted match with its geometry.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GeometricMatch {
    /// The match.
    pub m: RegionMatch,
    /// Rotation between the contours (radians, image coordinates), if it could be measured.
    pub rotation: Option<f64>,
    /// Local affine map of the frames with that rotation.
    pub local: Option<LocalAffine>,
}

/// Everything [`match_images`] finds.
#[derive(Debug, Clone)]
pub struct PairMatches {
    /// Regions of image 1.
    pub features1: Features,
    /// Regions of image 2.
    pub features2: Features,
    /// Descriptors that took part (after preselection) in image 1 and image 2.
    pub described: (usize, usize),
    /// Every symmetric match, before the ratio test.
    pub all: Vec<RegionMatch>,
    /// The accepted matches (`ratio < T_r`) with their geometry, ascending in `i`.
    pub accepted: Vec<GeometricMatch>,
    /// The homography from the accepted matches' centres, when asked for and possible.
    pub homography: Option<HomographyFit>,
}

/// Rotation `φ` between two contours from their affine-arc-length FDs (eq. 12): the FD Corr
/// match of the two one-descriptor sets.
fn pair_rotation(a: &[(u32, u32)], b: &[(u32, u32)]) -> Option<f64> {
    let cfg = DescriptorConfig::with_sampling(Sampling::AffineArcLength);
    let da = fd_match::describe_all(cfg, &[a]).ok()?.set;
    let db = fd_match::describe_all(cfg, &[b]).ok()?.set;
    let m = match_sets(&da, &db, Method::FdCorr).ok()?;
    m.first()?.alignment.map(|al| al.rotation)
}

/// Regions, descriptors, matches and geometry of two images.
///
/// Settings [`MatchSettings::validate`] refuses are an error before any work.
pub fn match_images(img1: &GrayImage, img2: &GrayImage, s: &MatchSettings) -> Result<PairMatches> {
    s.validate()?;
    let (f1, f2) = rayon::join(|| detect(img1, &s.mser.0), || detect(img2, &s.mser.1));
    let (f1, f2) = (f1?, f2?);
    let c = s.combination;
    let (mut a, mut b) = (describe(&f1, c.sampling)?, describe(&f2, c.sampling)?);
    if let Some(t) = s.preselection {
        a = preselected(&a, c.method, t)?;
        b = preselected(&b, c.method, t)?;
    }
    let all = match_regions(&a, &b, c.method)?;
    let own_rotation = c.method == Method::FdCorr && c.sampling == Sampling::AffineArcLength;
    let accepted: Vec<GeometricMatch> = all
        .iter()
        .filter(|m| m.ratio < s.ratio_threshold)
        .map(|m| {
            let rotation = if own_rotation {
                m.alignment.map(|al| al.rotation)
            } else {
                pair_rotation(&f1.contours[m.i], &f2.contours[m.j])
            };
            let local = rotation.and_then(|r| local_affine(&f1.frames[m.i], &f2.frames[m.j], r));
            GeometricMatch {
                m: *m,
                rotation,
                local,
            }
        })
        .collect();
    let homography = match &s.ransac {
        Some(cfg) if accepted.len() >= 4 => {
            let src: Vec<(f64, f64)> = accepted
                .iter()
                .map(|g| (f1.frames[g.m.i].u, f1.frames[g.m.i].v))
                .collect();
            let dst: Vec<(f64, f64)> = accepted
                .iter()
                .map(|g| (f2.frames[g.m.j].u, f2.frames[g.m.j].v))
                .collect();
            fit_homography(&src, &dst, cfg).ok()
        }
        _ => None,
    };
    Ok(PairMatches {
        described: (a.len(), b.len()),
        features1: f1,
        features2: f2,
        all,
        accepted,
        homography,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `all` holds every symmetric match once, ascending in `i`, with region indices; the
    /// accepted ones are exactly those with `ratio < T_r` (strictly), in the same order: a
    /// threshold equal to a match's ratio leaves that match out.
    #[test]
    fn accepted_is_the_strict_ratio_test_of_all_in_ascending_i() {
        // Four distinct blobs; in the second image shifted, and two of them resized.
        let scene = |dx: u32, k: f64| {
            GrayImage::from_fn(200, 140, |x, y| {
                let (x, y) = (x as f64 - dx as f64, y as f64);
                let square = (20.0..50.0).contains(&x) && (30.0..60.0).contains(&y);
                let blob = ((x - 100.0) / (25.0 * k)).powi(2) + ((y - 70.0) / 12.0).powi(2) < 1.0;
                let disc = (x - 40.0).powi(2) + ((y - 110.0) / k).powi(2) < 144.0;
                let bar = (130.0..180.0).contains(&x) && (20.0..32.0).contains(&y);
                image::Luma([if square || blob || disc || bar {
                    40
                } else {
                    200
                }])
            })
        };
        let (a, b) = (scene(0, 1.0), scene(5, 1.15));
        let all = match_images(&a, &b, &MatchSettings::paper()).unwrap().all;
        let t = all.iter().map(|m| m.ratio).fold(0.0, f64::max);
        assert!(all.len() >= 3 && t > 0.0, "{all:?}");
        for s in [
            MatchSettings::paper(),
            MatchSettings {
                ratio_threshold: t,
                ..MatchSettings::paper()
            },
        ] {
            let pair = match_images(&a, &b, &s).unwrap();
            assert_eq!(pair.all, all);
            assert!(pair.all.windows(2).all(|w| w[0].i < w[1].i));
            assert!(
                pair.all
                    .iter()
                    .all(|m| m.i < pair.features1.len() && m.j < pair.features2.len())
            );
            let want: Vec<RegionMatch> = all
                .iter()
                .filter(|m| m.ratio < s.ratio_threshold)
                .copied()
                .collect();
            let got: Vec<RegionMatch> = pair.accepted.iter().map(|g| g.m).collect();
            assert_eq!(got, want);
        }
    }

    /// Bad settings are an error before any work; a bad RANSAC setting used to be swallowed
    /// (no homography, no error) and a NaN `T_r` to accept nothing silently.
    #[test]
    fn bad_settings_are_refused() {
        let scene = |dx: u32| {
            GrayImage::from_fn(160, 120, |x, y| {
                let (x, y) = (x as f64 - dx as f64, y as f64);
                let square = (20.0..50.0).contains(&x) && (30.0..60.0).contains(&y);
                let blob = ((x - 100.0) / 25.0).powi(2) + ((y - 70.0) / 12.0).powi(2) < 1.0;
                image::Luma([if square || blob { 40 } else { 200 }])
            })
        };
        let (a, b) = (scene(0), scene(7));
        let good = MatchSettings::paper();
        assert!(match_images(&a, &b, &good).is_ok());
        let ransac = |f: fn(&mut RansacConfig)| {
            let mut r = RansacConfig::default();
            f(&mut r);
            MatchSettings {
                ransac: Some(r),
                ..MatchSettings::paper()
            }
        };
        for bad in [
            MatchSettings {
                ratio_threshold: f64::NAN,
                ..MatchSettings::paper()
            },
            MatchSettings {
                ratio_threshold: 0.0,
                ..MatchSettings::paper()
            },
            MatchSettings {
                preselection: Some(f64::NAN),
                ..MatchSettings::paper()
            },
            MatchSettings {
                preselection: Some(-1.0),
                ..MatchSettings::paper()
            },
            ransac(|r| r.threshold = f64::NAN),
            ransac(|r| r.threshold = 0.0),
            ransac(|r| r.confidence = 1.0),
            ransac(|r| r.max_iterations = 0),
        ] {
            assert!(
                matches!(
                    match_images(&a, &b, &bad),
                    Err(VisguideError::Invalid { .. })
                ),
                "{bad:?}"
            );
        }
    }
}
