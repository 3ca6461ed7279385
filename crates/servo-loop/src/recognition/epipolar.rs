//! Consistency between two cameras: the epipolar geometry the learner estimates from its own
//! percepts.
//!
//! Two views `a`, `b` (homogeneous pixels) of one 3-D point satisfy `bᵀ F a = 0` for the
//! fundamental matrix `F` of the camera pair (rank 2, defined up to scale). `F` is estimated
//! from the gripper points the learner found at its own random poses (no calibration): the
//! normalised 8-point algorithm (each view's points moved to their centroid and scaled to a
//! mean distance of √2; `f` the right singular vector of the smallest singular value of the
//! `n × 9` system `(b ⊗ a)ᵀ f = 0`; rank 2 enforced by zeroing `F`'s smallest singular value;
//! Hartley 1997) inside a seeded RANSAC (minimal samples of 8, inliers by the Sampson
//! distance), refitted on the inliers. The Sampson distance
//! `d² = (bᵀFa)² / ((Fa)₁² + (Fa)₂² + (Fᵀb)₁² + (Fᵀb)₂²)` is the first-order distance (pixels)
//! of the pair to the nearest consistent pair; its robust scale `σ` (1.4826 × the inliers'
//! median) measures how well the learned geometry (lens distortion included) fits.
//!
//! A percept pair's **consistency** is `exp(−½ (d / s)²)` with `s = max(K σ, s_min)`: a gripper
//! point found at the wrong end of the silhouette or on clutter in one camera is, unless it
//! happens to lie on the other view's epipolar line, far from consistent. (A wrong point *along*
//! the epipolar line is not caught by this check.)

use nalgebra::{DMatrix, Matrix3, Vector3};
use rand::SeedableRng;
use rand::rngs::Xoshiro256PlusPlus;
use rand::seq::index::sample;
use serde::{Deserialize, Serialize};

use crate::error::{Result, ServoError, check_finite};

/// RANSAC rounds of [`EpipolarGeometry::fit`].
const RANSAC_ROUNDS: usize = 400;
/// RANSAC inlier threshold on the Sampson distance (pixels).
const RANSAC_THRESHOLD: f64 = 3.0;
/// Fewest pairs [`EpipolarGeometry::fit`] accepts.
pub const MIN_PAIRS: usize = 16;
/// The consistency scale `s` in multiples `K` of the fit's robust residual scale `σ`.
const SCALE_MULTIPLE: f64 = 2.0;
/// Smallest consistency scale `s_min` (pixels).
const MIN_SCALE: f64 = 0.5;

/// A learned fundamental matrix of a camera pair and the scale of its residuals.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "EpipolarFile")]
pub struct EpipolarGeometry {
    /// `F`, row-major (unit norm when fitted).
    f: [f64; 9],
    /// Robust scale `σ` of the inliers' Sampson distances (pixels).
    sigma: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct EpipolarFile {
    f: [f64; 9],
    sigma: f64,
}

impl TryFrom<EpipolarFile> for EpipolarGeometry {
    type Error = ServoError;
    fn try_from(file: EpipolarFile) -> Result<Self> {
        check_finite("fundamental matrix", &file.f)?;
        let norm = file.f.iter().map(|v| v * v).sum::<f64>().sqrt();
        if !(norm > 0.0) {
            return Err(ServoError::invalid("f", "the fundamental matrix is zero"));
        }
        if !(file.sigma.is_finite() && file.sigma >= 0.0) {
            return Err(ServoError::invalid("sigma", "must be finite and ≥ 0"));
        }
        Ok(EpipolarGeometry {
            f: file.f,
            sigma: file.sigma,
        })
    }
}

/// What fitting found.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct EpipolarReport {
    /// Pairs offered.
    pub pairs: usize,
    /// Pairs within the RANSAC threshold of the final fit.
    pub inliers: usize,
    /// Median Sampson distance of the inliers (pixels).
    pub median_px: f64,
    /// The consistency scale `s` (pixels).
    pub scale_px: f64,
}

impl EpipolarGeometry {
    /// Fits `F` to point pairs (`a[i]` in the first camera, `b[i]` in the second; see the
    /// module docs), RANSAC seeded by `seed`. Errors: different lengths, non-finite points,
    /// fewer than [`MIN_PAIRS`] pairs or inliers, a degenerate configuration.
    pub fn fit(a: &[[f64; 2]], b: &[[f64; 2]], seed: u64) -> Result<(Self, EpipolarReport)> {
        if a.len() != b.len() {
            return Err(ServoError::DimensionMismatch {
                what: "epipolar point pairs",
                expected: a.len(),
                got: b.len(),
            });
        }
        check_finite("epipolar points", a.as_flattened())?;
        check_finite("epipolar points", b.as_flattened())?;
        if a.len() < MIN_PAIRS {
            return Err(ServoError::NotEnoughData(format!(
                "the epipolar geometry needs at least {MIN_PAIRS} point pairs, got {}",
                a.len()
            )));
        }
        let n = a.len();
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
        let mut best: Option<(usize, Matrix3<f64>)> = None;
        let mut sa = [[0.0; 2]; 8];
        let mut sb = [[0.0; 2]; 8];
        for _ in 0..RANSAC_ROUNDS {
            for (k, i) in sample(&mut rng, n, 8).into_iter().enumerate() {
                sa[k] = a[i];
                sb[k] = b[i];
            }
            let Some(f) = eight_point(&sa, &sb) else {
                continue;
            };
            let count = (0..n)
                .filter(|&i| sampson(&f, a[i], b[i]) < RANSAC_THRESHOLD)
                .count();
            if best.as_ref().is_none_or(|(c, _)| count > *c) {
                best = Some((count, f));
            }
        }
        let degenerate = || ServoError::NotEnoughData("the point pairs are degenerate".into());
        let (_, mut f) = best.ok_or_else(degenerate)?;
        // Refit on the inliers (twice: the inlier set settles).
        let mut inliers: Vec<usize> = Vec::new();
        for _ in 0..2 {
            inliers = (0..n)
                .filter(|&i| sampson(&f, a[i], b[i]) < RANSAC_THRESHOLD)
                .collect();
            if inliers.len() < MIN_PAIRS {
                return Err(ServoError::NotEnoughData(format!(
                    "only {} of {n} point pairs fit one epipolar geometry",
                    inliers.len()
                )));
            }
            let ia: Vec<[f64; 2]> = inliers.iter().map(|&i| a[i]).collect();
            let ib: Vec<[f64; 2]> = inliers.iter().map(|&i| b[i]).collect();
            f = eight_point(&ia, &ib).ok_or_else(degenerate)?;
        }
        let mut d: Vec<f64> = inliers.iter().map(|&i| sampson(&f, a[i], b[i])).collect();
        d.sort_by(f64::total_cmp);
        let median_px = d[d.len() / 2];
        let sigma = 1.4826 * median_px;
        let geometry = EpipolarGeometry {
            f: f.transpose().as_slice().try_into().expect("3 × 3"),
            sigma,
        };
        let report = EpipolarReport {
            pairs: n,
            inliers: inliers.len(),
            median_px,
            scale_px: geometry.scale(),
        };
        Ok((geometry, report))
    }

    /// `F` (`bᵀ F a = 0`).
    pub fn matrix(&self) -> Matrix3<f64> {
        Matrix3::from_row_slice(&self.f)
    }

    /// The robust residual scale `σ` of the fit (pixels).
    pub fn sigma(&self) -> f64 {
        self.sigma
    }

    /// The consistency scale `s = max(K σ, s_min)` (pixels).
    pub fn scale(&self) -> f64 {
        (SCALE_MULTIPLE * self.sigma).max(MIN_SCALE)
    }

    /// Sampson distance of the pair (`a` in the first camera, `b` in the second), pixels.
    pub fn distance(&self, a: [f64; 2], b: [f64; 2]) -> f64 {
        sampson(&self.matrix(), a, b)
    }

    /// Consistency of the pair in `[0, 1]`: `exp(−½ (d / s)²)` (module docs; 0 for
    /// non-finite points).
    pub fn consistency(&self, a: [f64; 2], b: [f64; 2]) -> f64 {
        let d = self.distance(a, b) / self.scale();
        if d.is_finite() {
            (-0.5 * d * d).exp()
        } else {
            0.0
        }
    }
}

/// The Sampson distance of a pair under `f` (pixels).
fn sampson(f: &Matrix3<f64>, a: [f64; 2], b: [f64; 2]) -> f64 {
    let ha = Vector3::new(a[0], a[1], 1.0);
    let hb = Vector3::new(b[0], b[1], 1.0);
    let fa = f * ha;
    let ftb = f.transpose() * hb;
    let e = hb.dot(&fa);
    let g = fa[0] * fa[0] + fa[1] * fa[1] + ftb[0] * ftb[0] + ftb[1] * ftb[1];
    if g > 0.0 {
        e.abs() / g.sqrt()
    } else {
        f64::INFINITY
    }
}

/// The similarity moving `points` to their centroid at mean distance √2 (Hartley), or `None`
/// when they coincide.
fn normaliser(points: &[[f64; 2]]) -> Option<Matrix3<f64>> {
    let n = points.len() as f64;
    let cx = points.iter().map(|p| p[0]).sum::<f64>() / n;
    let cy = points.iter().map(|p| p[1]).sum::<f64>() / n;
    let mean = points
        .iter()
        .map(|p| (p[0] - cx).hypot(p[1] - cy))
        .sum::<f64>()
        / n;
    if !(mean > 1e-12) {
        return None;
    }
    let s = std::f64::consts::SQRT_2 / mean;
    Some(Matrix3::new(
        s,
        0.0,
        -s * cx,
        0.0,
        s,
        -s * cy,
        0.0,
        0.0,
        1.0,
    ))
}

/// The normalised 8-point estimate of `F` from ≥ 8 pairs (rank 2, unit norm), or `None` for a
/// degenerate configuration.
fn eight_point(a: &[[f64; 2]], b: &[[f64; 2]]) -> Option<Matrix3<f64>> {
    let (ta, tb) = (normaliser(a)?, normaliser(b)?);
    // The normal equations AᵀA (9 × 9) of the system; their smallest eigenvector is `f`.
    let mut ata = DMatrix::<f64>::zeros(9, 9);
    for (pa, pb) in a.iter().zip(b) {
        let p = ta * Vector3::new(pa[0], pa[1], 1.0);
        let q = tb * Vector3::new(pb[0], pb[1], 1.0);
        let row = [
            q[0] * p[0],
            q[0] * p[1],
            q[0],
            q[1] * p[0],
            q[1] * p[1],
            q[1],
            p[0],
            p[1],
            1.0,
        ];
        for i in 0..9 {
            for j in 0..9 {
                ata[(i, j)] += row[i] * row[j];
            }
        }
    }
    let eig = ata.symmetric_eigen();
    let k = eig.eigenvalues.imin();
    let v = eig.eigenvectors.column(k);
    let f = Matrix3::from_row_slice(v.as_slice());
    // Rank 2.
    let svd = f.svd(true, true);
    let (u, vt) = (svd.u?, svd.v_t?);
    let mut s = svd.singular_values;
    let imin = s.imin();
    s[imin] = 0.0;
    let f2 = u * Matrix3::from_diagonal(&s) * vt;
    let f = tb.transpose() * f2 * ta;
    let norm = f.norm();
    (norm.is_finite() && norm > 0.0).then(|| f / norm)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Rotation3, Vector3};
    use rand_distr::{Distribution, Normal, Uniform};

    /// Two pinhole cameras looking at a box of points; returns the pixel pairs.
    fn scene(n: usize, seed: u64) -> (Vec<[f64; 2]>, Vec<[f64; 2]>) {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
        let u = Uniform::new(-200.0, 200.0).unwrap();
        let r1 = Rotation3::from_euler_angles(0.1, -0.5, 0.05);
        let t1 = Vector3::new(400.0, 0.0, 100.0);
        let project = |p: Vector3<f64>| [320.0 + 500.0 * p.x / p.z, 240.0 + 500.0 * p.y / p.z];
        let mut a = Vec::new();
        let mut b = Vec::new();
        for _ in 0..n {
            let p = Vector3::new(
                u.sample(&mut rng),
                u.sample(&mut rng),
                900.0 + u.sample(&mut rng),
            );
            a.push(project(p));
            b.push(project(r1 * p + t1));
        }
        (a, b)
    }

    #[test]
    fn exact_pairs_are_consistent_and_a_moved_point_is_not() {
        let (a, b) = scene(200, 1);
        let (g, report) = EpipolarGeometry::fit(&a, &b, 7).unwrap();
        assert_eq!(report.inliers, 200);
        for (p, q) in a.iter().zip(&b) {
            assert!(g.distance(*p, *q) < 1e-6, "{}", g.distance(*p, *q));
        }
        // A new point of the same scene is consistent; the same point shifted 30 px across
        // its epipolar line in the second view is not.
        let (na, nb) = scene(5, 99);
        for (p, q) in na.iter().zip(&nb) {
            assert!(g.consistency(*p, *q) > 0.99);
            let f = g.matrix();
            let line = f * Vector3::new(p[0], p[1], 1.0);
            let normal = [line[0], line[1]];
            let len = normal[0].hypot(normal[1]);
            let moved = [q[0] + 30.0 * normal[0] / len, q[1] + 30.0 * normal[1] / len];
            // Sampson's distance shares the shift between both views: at most 30 px.
            let d = g.distance(*p, moved);
            assert!(d > 5.0 && d < 30.0 + 1e-6, "{d}");
            assert!(g.consistency(*p, moved) < 1e-6);
        }
    }

    #[test]
    fn gross_outliers_do_not_move_the_fit() {
        let (a, mut b) = scene(300, 2);
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(3);
        let noise = Normal::new(0.0, 0.3).unwrap();
        for q in b.iter_mut() {
            q[0] += noise.sample(&mut rng);
            q[1] += noise.sample(&mut rng);
        }
        // One pair in ten is a gross error (another point of the image).
        let wild = Uniform::new(0.0, 640.0).unwrap();
        let mut outliers = Vec::new();
        for i in (0..300).step_by(10) {
            b[i] = [wild.sample(&mut rng), wild.sample(&mut rng) * 0.75];
            outliers.push(i);
        }
        let (g, report) = EpipolarGeometry::fit(&a, &b, 11).unwrap();
        assert!(report.inliers >= 265 && report.inliers <= 275, "{report:?}");
        // σ reflects the 0.3 px noise (Sampson distance of noise in one view only).
        assert!(g.sigma() > 0.1 && g.sigma() < 0.5, "{}", g.sigma());
        let caught = outliers
            .iter()
            .filter(|&&i| g.consistency(a[i], b[i]) < 0.05)
            .count();
        assert!(caught >= 27, "caught {caught} of {}", outliers.len());
        let clean_refused = (0..300)
            .filter(|i| i % 10 != 0 && g.consistency(a[*i], b[*i]) < 0.05)
            .count();
        assert!(clean_refused <= 3, "{clean_refused}");
    }

    #[test]
    fn bad_input_is_a_typed_error() {
        let (a, b) = scene(40, 4);
        assert!(matches!(
            EpipolarGeometry::fit(&a[..10], &b[..10], 0),
            Err(ServoError::NotEnoughData(_))
        ));
        assert!(matches!(
            EpipolarGeometry::fit(&a, &b[..39], 0),
            Err(ServoError::DimensionMismatch { .. })
        ));
        let mut nan = a.clone();
        nan[3][1] = f64::NAN;
        assert!(matches!(
            EpipolarGeometry::fit(&nan, &b, 0),
            Err(ServoError::NonFinite { .. })
        ));
        let same = vec![[5.0, 5.0]; 40];
        assert!(EpipolarGeometry::fit(&same, &same, 0).is_err());
    }

    #[test]
    fn a_saved_geometry_loads_with_its_checks() {
        let (a, b) = scene(60, 5);
        let (g, _) = EpipolarGeometry::fit(&a, &b, 1).unwrap();
        let json = serde_json::to_string(&g).unwrap();
        assert_eq!(serde_json::from_str::<EpipolarGeometry>(&json).unwrap(), g);
        let zero = r#"{"f":[0,0,0,0,0,0,0,0,0],"sigma":0.1}"#;
        assert!(serde_json::from_str::<EpipolarGeometry>(zero).is_err());
        let neg = r#"{"f":[1,0,0,0,0,0,0,0,0],"sigma":-1}"#;
        assert!(serde_json::from_str::<EpipolarGeometry>(neg).is_err());
    }
}
