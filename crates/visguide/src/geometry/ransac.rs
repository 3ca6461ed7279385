//! A robust homography from all matches: seeded RANSAC on minimal samples of four
//! correspondences (Fischler & Bolles 1981), then least squares on the inliers.
//!
//! 1. Draw four distinct correspondences (from a seeded [`Xoshiro256PlusPlus`], so the result
//!    depends only on the seed and the input, never on threads), skip samples with three
//!    (nearly) collinear points in either image, fit by the normalised DLT and count inliers:
//!    transfer error `‖π(H x) − x'‖ < threshold`. Keep the hypothesis with most inliers (ties:
//!    the smaller summed truncated squared error). The number of draws adapts to the inlier
//!    ratio `w` found so far: `N = log(1 − confidence) / log(1 − w⁴)`, capped by `max_iterations`.
//! 2. Re-fit by DLT on the inliers and recount, until the inlier set stops changing (at most 10
//!    rounds), then refine by Levenberg–Marquardt on the inliers' transfer error
//!    ([`super::fit::refine`]) and recount once more.

use rand::rngs::Xoshiro256PlusPlus;
use rand::{RngExt, SeedableRng};

use super::fit::{Point, dlt, refine, transfer_error};
use super::homography::Homography;
use crate::error::{Result, VisguideError};

/// Settings of [`fit_homography`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RansacConfig {
    /// Inlier threshold on the transfer error, pixels.
    pub threshold: f64,
    /// Largest number of samples drawn.
    pub max_iterations: usize,
    /// Probability of having drawn one outlier-free sample, for the adaptive stop.
    pub confidence: f64,
    /// Seed of the sampler.
    pub seed: u64,
}

impl Default for RansacConfig {
    /// 3 px, 5000 samples at most, confidence 0.999, seed 0.
    fn default() -> Self {
        RansacConfig {
            threshold: 3.0,
            max_iterations: 5000,
            confidence: 0.999,
            seed: 0,
        }
    }
}

impl RansacConfig {
    /// Checks the setting: a finite positive threshold, a confidence in (0, 1), at least one
    /// sample.
    pub fn validate(&self) -> Result<()> {
        let bad = |reason: String| {
            Err(VisguideError::Invalid {
                name: "RANSAC setting",
                reason,
            })
        };
        if !(self.threshold.is_finite() && self.threshold > 0.0) {
            return bad(format!(
                "threshold {} is not a positive number",
                self.threshold
            ));
        }
        if !(self.confidence > 0.0 && self.confidence < 1.0) {
            return bad(format!("confidence {} is not in (0, 1)", self.confidence));
        }
        if self.max_iterations == 0 {
            return bad("max_iterations is 0".into());
        }
        Ok(())
    }
}

/// A robustly fitted homography.
#[derive(Debug, Clone, PartialEq)]
pub struct HomographyFit {
    /// Maps image 1 to image 2.
    pub homography: Homography,
    /// Whether each correspondence is an inlier.
    pub inliers: Vec<bool>,
    /// Number of inliers.
    pub inlier_count: usize,
    /// Root mean square transfer error of the inliers, pixels.
    pub rms: f64,
    /// Samples drawn.
    pub iterations: usize,
}

fn inliers_of(
    h: &nalgebra::Matrix3<f64>,
    src: &[Point],
    dst: &[Point],
    t: f64,
) -> (Vec<bool>, f64) {
    let mut cost = 0.0;
    let flags = src
        .iter()
        .zip(dst)
        .map(|(&p, &q)| {
            let e = transfer_error(h, p, q);
            cost += e.min(t).powi(2);
            e < t
        })
        .collect();
    (flags, cost)
}

fn collinear(a: Point, b: Point, c: Point) -> bool {
    let cross = (b.0 - a.0) * (c.1 - a.1) - (b.1 - a.1) * (c.0 - a.0);
    let scale = ((b.0 - a.0).hypot(b.1 - a.1)) * ((c.0 - a.0).hypot(c.1 - a.1));
    cross.abs() <= 1e-3 * scale.max(1e-12)
}

fn degenerate(p: &[Point; 4]) -> bool {
    (0..4).any(|skip| {
        let t: Vec<Point> = (0..4).filter(|&k| k != skip).map(|k| p[k]).collect();
        collinear(t[0], t[1], t[2])
    })
}

fn pick<T: Copy>(v: &[T], idx: [usize; 4]) -> Vec<T> {
    idx.iter().map(|&k| v[k]).collect()
}

/// Fits a homography mapping `src[k]` to `dst[k]` robustly. Fails with fewer than four
/// correspondences or when no sample gives a homography; lists of different lengths, or a
/// non-finite coordinate, are [`VisguideError::Invalid`] `correspondences`.
pub fn fit_homography(src: &[Point], dst: &[Point], cfg: &RansacConfig) -> Result<HomographyFit> {
    cfg.validate()?;
    if src.len() != dst.len() {
        return Err(VisguideError::Invalid {
            name: "correspondences",
            reason: format!("{} source and {} target points", src.len(), dst.len()),
        });
    }
    if let Some(k) = (0..src.len()).find(|&k| {
        ![src[k].0, src[k].1, dst[k].0, dst[k].1]
            .iter()
            .all(|v| v.is_finite())
    }) {
        return Err(VisguideError::Invalid {
            name: "correspondences",
            reason: format!(
                "correspondence {k} has a non-finite coordinate: {:?} -> {:?}",
                src[k], dst[k]
            ),
        });
    }
    let n = src.len();
    if n < 4 {
        return Err(VisguideError::TooFewMatches(n));
    }
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(cfg.seed);
    let mut best: Option<(usize, f64, nalgebra::Matrix3<f64>)> = None;
    let mut needed = cfg.max_iterations;
    let mut it = 0;
    while it < needed.min(cfg.max_iterations) {
        it += 1;
        let mut idx = [0usize; 4];
        let mut k = 0;
        while k < 4 {
            let c = rng.random_range(0..n);
            if !idx[..k].contains(&c) {
                idx[k] = c;
                k += 1;
            }
        }
        let (s, d) = (pick(src, idx), pick(dst, idx));
        if degenerate(&[s[0], s[1], s[2], s[3]]) || degenerate(&[d[0], d[1], d[2], d[3]]) {
            continue;
        }
        let Some(h) = dlt(&s, &d) else { continue };
        let (flags, cost) = inliers_of(&h, src, dst, cfg.threshold);
        let count = flags.iter().filter(|&&f| f).count();
        let better = best
            .as_ref()
            .is_none_or(|b| count > b.0 || (count == b.0 && cost < b.1));
        if better {
            best = Some((count, cost, h));
            let w = count as f64 / n as f64;
            let p_good = w.powi(4);
            needed = if p_good >= 1.0 - 1e-12 {
                it
            } else if p_good <= 0.0 {
                cfg.max_iterations
            } else {
                let est = ((1.0 - cfg.confidence).ln() / (1.0 - p_good).ln()).ceil();
                if est.is_finite() {
                    est as usize
                } else {
                    cfg.max_iterations
                }
            };
        }
    }
    let Some((_, _, mut h)) = best else {
        return Err(VisguideError::TooFewMatches(n));
    };
    let (mut flags, _) = inliers_of(&h, src, dst, cfg.threshold);
    for _ in 0..10 {
        let (s, d): (Vec<Point>, Vec<Point>) = flags
            .iter()
            .zip(src.iter().zip(dst))
            .filter(|(f, _)| **f)
            .map(|(_, (p, q))| (*p, *q))
            .unzip();
        let Some(next) = dlt(&s, &d) else { break };
        let (nf, _) = inliers_of(&next, src, dst, cfg.threshold);
        if nf.iter().filter(|&&f| f).count() < s.len() {
            break;
        }
        let stable = nf == flags;
        h = next;
        flags = nf;
        if stable {
            break;
        }
    }
    let (s, d): (Vec<Point>, Vec<Point>) = flags
        .iter()
        .zip(src.iter().zip(dst))
        .filter(|(f, _)| **f)
        .map(|(_, (p, q))| (*p, *q))
        .unzip();
    let refined = refine(&h, &s, &d, 50);
    let (rf, _) = inliers_of(&refined, src, dst, cfg.threshold);
    if rf.iter().filter(|&&f| f).count() >= s.len() {
        h = refined;
        flags = rf;
    }
    let errs: Vec<f64> = flags
        .iter()
        .zip(src.iter().zip(dst))
        .filter(|(f, _)| **f)
        .map(|(_, (p, q))| transfer_error(&h, *p, *q))
        .collect();
    let inlier_count = errs.len();
    let rms = if errs.is_empty() {
        f64::NAN
    } else {
        (errs.iter().map(|e| e * e).sum::<f64>() / errs.len() as f64).sqrt()
    };
    Ok(HomographyFit {
        homography: Homography::from_matrix(&h)?,
        inliers: flags,
        inlier_count,
        rms,
        iterations: it,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand_free::*;

    /// Deterministic pseudo-random numbers without a generator (a Weyl sequence).
    mod rand_free {
        pub fn u(k: usize, salt: f64) -> f64 {
            ((k as f64 + 1.0) * (0.618_033_988_749_895 + salt)).fract()
        }
    }

    fn scene(n: usize, outlier_every: usize) -> (Homography, Vec<Point>, Vec<Point>) {
        let h = Homography::from_row_major(&[0.95, 0.1, 20.0, -0.08, 1.02, -15.0, 1e-4, 5e-5, 1.0])
            .unwrap();
        let mut src = Vec::new();
        let mut dst = Vec::new();
        for k in 0..n {
            let p = (u(k, 0.0) * 640.0, u(k, 0.1234) * 480.0);
            let q = h.map(p.0, p.1).unwrap();
            let noise = ((u(k, 0.3) - 0.5) * 0.6, (u(k, 0.7) - 0.5) * 0.6);
            src.push(p);
            if outlier_every > 0 && k % outlier_every == 0 {
                dst.push((u(k, 0.9) * 640.0, u(k, 0.45) * 480.0));
            } else {
                dst.push((q.0 + noise.0, q.1 + noise.1));
            }
        }
        (h, src, dst)
    }

    #[test]
    fn recovers_the_homography_with_forty_percent_outliers() {
        let (h, src, dst) = scene(100, 3);
        for seed in 0..5 {
            let fit = fit_homography(
                &src,
                &dst,
                &RansacConfig {
                    seed,
                    ..Default::default()
                },
            )
            .unwrap();
            assert!(fit.homography.corner_error(&h, 640, 480) < 1.0);
            for (k, &f) in fit.inliers.iter().enumerate() {
                // Every true inlier is found; random outliers may rarely land inside 3 px.
                if k % 3 != 0 {
                    assert!(f, "inlier {k} missed (seed {seed})");
                }
            }
            assert!(fit.inlier_count >= 66 && fit.inlier_count <= 68);
            assert!(fit.rms < 0.6);
        }
    }

    /// The number of draws adapts to the inlier ratio found (`N = log(1 − confidence) /
    /// log(1 − w⁴)`) and is capped by `max_iterations`: without outliers one good sample ends
    /// the search; with half of them outliers the formula asks for about 107 draws, so a cap of
    /// 7 stops at 7 and the default cap at the formula's count.
    #[test]
    fn draws_adapt_to_the_inlier_ratio_and_stop_at_the_cap() {
        let (_, src, _) = scene(60, 0);
        let h = Homography::from_row_major(&[0.95, 0.1, 20.0, -0.08, 1.02, -15.0, 1e-4, 5e-5, 1.0])
            .unwrap();
        let exact: Vec<Point> = src.iter().map(|p| h.map(p.0, p.1).unwrap()).collect();
        let clean = fit_homography(&src, &exact, &RansacConfig::default()).unwrap();
        assert_eq!(clean.inlier_count, 60);
        assert!(clean.iterations <= 3, "{} draws", clean.iterations);
        let (_, src, dst) = scene(60, 2);
        let capped = fit_homography(
            &src,
            &dst,
            &RansacConfig {
                max_iterations: 7,
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(capped.iterations, 7);
        let free = fit_homography(&src, &dst, &RansacConfig::default()).unwrap();
        let w = free.inlier_count as f64 / 60.0;
        let n = ((1.0f64 - 0.999).ln() / (1.0 - w.powi(4)).ln()).ceil() as usize;
        assert!(
            free.iterations >= n && free.iterations < 5000,
            "{} draws, formula {n}",
            free.iterations
        );
    }

    #[test]
    fn the_same_seed_gives_the_same_fit_and_bad_input_is_refused() {
        let (_, src, dst) = scene(40, 4);
        let cfg = RansacConfig::default();
        assert_eq!(
            fit_homography(&src, &dst, &cfg).unwrap(),
            fit_homography(&src, &dst, &cfg).unwrap()
        );
        assert!(matches!(
            fit_homography(&src[..3], &dst[..3], &cfg),
            Err(VisguideError::TooFewMatches(3))
        ));
        assert!(fit_homography(&src, &dst[..5], &cfg).is_err());
        // A non-finite coordinate anywhere names the correspondence (it used to end as "too
        // few matches", every sample holding it failing).
        for (k, bad) in [(0, f64::NAN), (3, f64::INFINITY)] {
            let mut s2 = src.clone();
            s2[k].1 = bad;
            for (a, b) in [(&s2, &dst), (&dst, &s2)] {
                match fit_homography(a, b, &cfg) {
                    Err(VisguideError::Invalid {
                        name: "correspondences",
                        reason,
                    }) => assert!(reason.contains(&format!("correspondence {k} ")), "{reason}"),
                    other => panic!("{other:?}"),
                }
            }
        }
        let bad = RansacConfig {
            threshold: -1.0,
            ..cfg
        };
        assert!(fit_homography(&src, &dst, &bad).is_err());
        // All points on a line: no homography.
        let line: Vec<Point> = (0..10).map(|k| (k as f64, k as f64)).collect();
        assert!(fit_homography(&line, &line, &cfg).is_err());
    }
}
