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
//! **Lens distortion.** A fundamental matrix holds for pinhole cameras only: with radial lens
//! distortion the consistent pairs lie on curves, not lines. The geometry therefore may also
//! carry the **lifted** fundamental matrix `G` (6 × 6) of the division model of radial
//! distortion (Barreto & Daniilidis 2005): with the lifted coordinates
//! `λ(x, y) = (x², xy, y², x, y, 1)` of each view's normalised point, consistent pairs satisfy
//! `λ(b)ᵀ G λ(a) = 0` (exactly for division-model distortion about the normalisation centre, to
//! first order for mild polynomial distortion; `F` is the special case whose entries touch only
//! `(x, y, 1)`). `G` is the smallest eigenvector of the 36 × 36 normal equations on the pairs
//! within [`LIFTED_START`] px of the RANSAC `F` (gross errors gone), refitted on the pairs within
//! `RANSAC_THRESHOLD` (3) px of `G` itself; it is kept only when it fits at least as many pairs as
//! `F`. Its first-order (Sampson) distance is `|r| / ‖∇r‖` with
//! `r = λ(b)ᵀ G λ(a)` and the gradient over both views' pixel coordinates; the consistency
//! below then uses it, and `σ` is its robust scale; it needs [`MIN_LIFTED`] pairs. (On
//! `arm-sim`'s shipped arms the plain `F` already fits the *true* projections within 0.7 px,
//! development seed 1001, where `G` was not kept: most pairs beyond 3 px are wrong percepts,
//! not distortion. In the fixtures' evaluation run `G` fitted more pairs than `F` on 3 of 15
//! (arm, seed) runs, 3–18 more of ~500, and was kept there.)
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
/// The lifted fit starts from the pairs within this Sampson distance (pixels) of the RANSAC
/// `F`: wide enough for the bent epipolar curves, narrow against gross errors.
pub const LIFTED_START: f64 = 8.0;
/// Fewest pairs the lifted fit needs (35 unknowns up to scale; with fewer pairs than about
/// six per unknown it overfits and bends away from `F` between the pairs); below it the
/// geometry keeps `F` alone.
pub const MIN_LIFTED: usize = 200;
/// Size of the lifted coordinates.
const LIFT: usize = 6;
/// The consistency scale `s` in multiples `K` of the fit's robust residual scale `σ`.
const SCALE_MULTIPLE: f64 = 2.0;
/// Smallest consistency scale `s_min` (pixels).
const MIN_SCALE: f64 = 0.5;

/// A learned fundamental matrix of a camera pair, its distortion-aware lifted form and the
/// scale of its residuals.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "EpipolarFile")]
pub struct EpipolarGeometry {
    /// `F`, row-major (unit norm when fitted).
    f: [f64; 9],
    /// The lifted matrix `G` with each view's normalisation, when fitted (module docs).
    #[serde(default)]
    lifted: Option<Lifted>,
    /// Robust scale `σ` of the inliers' Sampson distances (pixels).
    sigma: f64,
}

/// The lifted fundamental matrix `G` (6 × 6, row-major, unit norm) on normalised points
/// `s (p − c)` of each view (`[cx, cy, s]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Lifted {
    g: Vec<f64>,
    norm_a: [f64; 3],
    norm_b: [f64; 3],
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct EpipolarFile {
    f: [f64; 9],
    #[serde(default)]
    lifted: Option<Lifted>,
    sigma: f64,
}

impl TryFrom<EpipolarFile> for EpipolarGeometry {
    type Error = ServoError;
    fn try_from(file: EpipolarFile) -> Result<Self> {
        check_finite("fundamental matrix", &file.f)?;
        let norm = file.f.iter().map(|v| v * v).sum::<f64>().sqrt();
        if !(norm.is_finite() && norm > 0.0) {
            return Err(ServoError::invalid("f", "the fundamental matrix is zero"));
        }
        if !(file.sigma.is_finite() && file.sigma >= 0.0) {
            return Err(ServoError::invalid("sigma", "must be finite and ≥ 0"));
        }
        if let Some(l) = &file.lifted {
            if l.g.len() != LIFT * LIFT {
                return Err(ServoError::invalid("lifted.g", "must hold 36 entries"));
            }
            check_finite("lifted fundamental matrix", &l.g)?;
            check_finite("lifted normalisation", &l.norm_a)?;
            check_finite("lifted normalisation", &l.norm_b)?;
            if l.g.iter().all(|v| *v == 0.0) {
                return Err(ServoError::invalid("lifted.g", "the lifted matrix is zero"));
            }
            if !(l.norm_a[2] > 0.0 && l.norm_b[2] > 0.0) {
                return Err(ServoError::invalid("lifted.norm", "scales must be > 0"));
            }
        }
        Ok(EpipolarGeometry {
            f: file.f,
            lifted: file.lifted,
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
    /// Pairs within the RANSAC threshold of the plain (undistorted) `F` alone, for comparison.
    #[serde(default)]
    pub inliers_plain: usize,
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
        let inliers_plain = inliers.len();
        let f_row: [f64; 9] = f.transpose().as_slice().try_into().expect("3 × 3");
        let mut geometry = EpipolarGeometry {
            f: f_row,
            lifted: None,
            sigma: 0.0,
        };
        // The distortion-aware lifted fit, started on the pairs near `F`.
        let mut set: Vec<usize> = (0..n)
            .filter(|&i| sampson(&f, a[i], b[i]) < LIFTED_START)
            .collect();
        for _ in 0..3 {
            if set.len() < MIN_LIFTED {
                break;
            }
            let ia: Vec<[f64; 2]> = set.iter().map(|&i| a[i]).collect();
            let ib: Vec<[f64; 2]> = set.iter().map(|&i| b[i]).collect();
            let Some(l) = lifted_fit(&ia, &ib) else {
                break;
            };
            let next: Vec<usize> = (0..n)
                .filter(|&i| l.distance(a[i], b[i]) < RANSAC_THRESHOLD)
                .collect();
            if next.len() < inliers.len() {
                break;
            }
            geometry.lifted = Some(l);
            inliers = next.clone();
            set = next;
        }
        let mut d: Vec<f64> = inliers
            .iter()
            .map(|&i| geometry.distance(a[i], b[i]))
            .collect();
        d.sort_by(f64::total_cmp);
        let median_px = d[d.len() / 2];
        geometry.sigma = 1.4826 * median_px;
        let report = EpipolarReport {
            pairs: n,
            inliers: inliers.len(),
            inliers_plain,
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

    /// Whether the distortion-aware lifted form was fitted (else `F` alone is used).
    pub fn is_lifted(&self) -> bool {
        self.lifted.is_some()
    }

    /// Sampson distance of the pair (`a` in the first camera, `b` in the second), pixels: of
    /// the lifted form when fitted, else of `F`.
    pub fn distance(&self, a: [f64; 2], b: [f64; 2]) -> f64 {
        match &self.lifted {
            Some(l) => l.distance(a, b),
            None => sampson(&self.matrix(), a, b),
        }
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

impl Lifted {
    /// First-order distance (pixels) of the pair to the lifted constraint (module docs).
    fn distance(&self, a: [f64; 2], b: [f64; 2]) -> f64 {
        let (pa, pb) = (normalise(self.norm_a, a), normalise(self.norm_b, b));
        let (la, lb) = (lift(pa), lift(pb));
        let mut ga = [0.0; LIFT]; // G λ(a)
        let mut gtb = [0.0; LIFT]; // Gᵀ λ(b)
        for i in 0..LIFT {
            for j in 0..LIFT {
                let g = self.g[i * LIFT + j];
                ga[i] += g * la[j];
                gtb[j] += g * lb[i];
            }
        }
        let r: f64 = lb.iter().zip(&ga).map(|(x, y)| x * y).sum();
        // ∂λ/∂x = (2x, y, 0, 1, 0, 0), ∂λ/∂y = (0, x, 2y, 0, 1, 0); chain rule to pixels.
        let grad = |u: &[f64; LIFT], p: [f64; 2], s: f64| {
            let dx = 2.0 * p[0] * u[0] + p[1] * u[1] + u[3];
            let dy = p[0] * u[1] + 2.0 * p[1] * u[2] + u[4];
            s * s * (dx * dx + dy * dy)
        };
        let g2 = grad(&gtb, pa, self.norm_a[2]) + grad(&ga, pb, self.norm_b[2]);
        if g2 > 0.0 {
            r.abs() / g2.sqrt()
        } else {
            f64::INFINITY
        }
    }
}

/// `s (p − c)` for a normalisation `[cx, cy, s]`.
fn normalise(n: [f64; 3], p: [f64; 2]) -> [f64; 2] {
    [n[2] * (p[0] - n[0]), n[2] * (p[1] - n[1])]
}

/// The lifted coordinates `(x², xy, y², x, y, 1)`.
fn lift(p: [f64; 2]) -> [f64; LIFT] {
    [p[0] * p[0], p[0] * p[1], p[1] * p[1], p[0], p[1], 1.0]
}

/// The normalisation `[cx, cy, s]` of `points` (Hartley's, as [`normaliser`]).
fn normalisation(points: &[[f64; 2]]) -> Option<[f64; 3]> {
    let t = normaliser(points)?;
    let s = t[(0, 0)];
    Some([-t[(0, 2)] / s, -t[(1, 2)] / s, s])
}

/// The linear least-squares lifted matrix of the pairs (smallest eigenvector of the normal
/// equations), or `None` for a degenerate configuration.
fn lifted_fit(a: &[[f64; 2]], b: &[[f64; 2]]) -> Option<Lifted> {
    let (norm_a, norm_b) = (normalisation(a)?, normalisation(b)?);
    const N: usize = LIFT * LIFT;
    let mut ata = DMatrix::<f64>::zeros(N, N);
    let mut row = [0.0; N];
    for (pa, pb) in a.iter().zip(b) {
        let (la, lb) = (lift(normalise(norm_a, *pa)), lift(normalise(norm_b, *pb)));
        for i in 0..LIFT {
            for j in 0..LIFT {
                row[i * LIFT + j] = lb[i] * la[j];
            }
        }
        for i in 0..N {
            for j in i..N {
                ata[(i, j)] += row[i] * row[j];
            }
        }
    }
    for i in 0..N {
        for j in 0..i {
            ata[(i, j)] = ata[(j, i)];
        }
    }
    let eig = ata.symmetric_eigen();
    let k = eig.eigenvalues.imin();
    let g: Vec<f64> = eig.eigenvectors.column(k).iter().copied().collect();
    let norm = g.iter().map(|v| v * v).sum::<f64>().sqrt();
    (norm.is_finite() && norm > 0.0).then(|| Lifted {
        g: g.iter().map(|v| v / norm).collect(),
        norm_a,
        norm_b,
    })
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
    if mean.is_nan() || mean <= 1e-12 {
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
pub(crate) mod tests {
    use super::*;
    use nalgebra::{Rotation3, Vector3};
    use rand_distr::{Distribution, Normal, Uniform};

    /// Two pinhole cameras looking at a box of points; returns the pixel pairs.
    pub(crate) fn scene(n: usize, seed: u64) -> (Vec<[f64; 2]>, Vec<[f64; 2]>) {
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

    /// As [`scene`], with radial lens distortion `p' = c + (p − c)(1 + k r²)` (`r` in units of
    /// 320 px) in both views, as `arm-sim`'s cameras have.
    fn distorted_scene(n: usize, seed: u64, k: f64) -> (Vec<[f64; 2]>, Vec<[f64; 2]>) {
        let distort = |p: [f64; 2]| {
            let (x, y) = ((p[0] - 320.0) / 320.0, (p[1] - 240.0) / 320.0);
            let f = 1.0 + k * (x * x + y * y);
            [320.0 + 320.0 * x * f, 240.0 + 320.0 * y * f]
        };
        let (a, b) = scene(n, seed);
        (
            a.into_iter().map(distort).collect(),
            b.into_iter().map(distort).collect(),
        )
    }

    #[test]
    fn lens_distortion_is_absorbed_by_the_lifted_form() {
        let (a, b) = distorted_scene(400, 6, -0.12);
        let (g, report) = EpipolarGeometry::fit(&a, &b, 8).unwrap();
        assert!(g.is_lifted());
        // The plain F leaves some pairs beyond 3 px; the lifted form keeps all, far tighter.
        let plain_median = {
            let mut d: Vec<f64> = a
                .iter()
                .zip(&b)
                .map(|(p, q)| sampson(&g.matrix(), *p, *q))
                .collect();
            d.sort_by(f64::total_cmp);
            d[d.len() / 2]
        };
        assert_eq!(report.inliers, 400, "{report:?}");
        assert!(
            report.median_px < 0.1 * plain_median,
            "{report:?} vs {plain_median}"
        );
        assert!(report.median_px < 0.2, "{report:?}");
        // A new point of the same scene is consistent; shifted 10 px across its (bent)
        // epipolar curve it is not.
        let (na, nb) = distorted_scene(20, 98, -0.12);
        for (p, q) in na.iter().zip(&nb) {
            assert!(g.consistency(*p, *q) > 0.5, "{}", g.distance(*p, *q));
            let e = 1e-3;
            let dx = g.distance(*p, [q[0] + e, q[1]]) - g.distance(*p, [q[0] - e, q[1]]);
            let dy = g.distance(*p, [q[0], q[1] + e]) - g.distance(*p, [q[0], q[1] - e]);
            // The distance grows fastest across the curve.
            let len = dx.hypot(dy);
            let moved = [q[0] + 10.0 * dx / len, q[1] + 10.0 * dy / len];
            let d = g.distance(*p, moved);
            assert!(d > 4.0 && d < 10.5, "{d}");
            assert!(g.consistency(*p, moved) < 0.05);
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
        let short = r#"{"f":[1,0,0,0,0,0,0,0,0],"sigma":1,
                        "lifted":{"g":[1,0],"norm_a":[0,0,1],"norm_b":[0,0,1]}}"#;
        assert!(serde_json::from_str::<EpipolarGeometry>(short).is_err());
        let mut g36 = vec![0.0; 36];
        g36[0] = 1.0;
        let bad_scale = format!(
            r#"{{"f":[1,0,0,0,0,0,0,0,0],"sigma":1,
                "lifted":{{"g":{g36:?},"norm_a":[0,0,0],"norm_b":[0,0,1]}}}}"#
        );
        assert!(serde_json::from_str::<EpipolarGeometry>(&bad_scale).is_err());
        let (a, b) = distorted_scene(200, 9, -0.1);
        let (g, _) = EpipolarGeometry::fit(&a, &b, 1).unwrap();
        assert!(g.is_lifted());
        let json = serde_json::to_string(&g).unwrap();
        assert_eq!(serde_json::from_str::<EpipolarGeometry>(&json).unwrap(), g);
    }
}
