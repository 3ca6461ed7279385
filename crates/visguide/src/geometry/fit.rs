//! Least-squares homographies from point correspondences `x ↦ x'`.
//!
//! [`dlt`]: the normalised direct linear transform (Hartley & Zisserman, Alg. 4.2). Both point
//! sets are translated to their centroid and scaled to mean distance √2; each correspondence
//! gives two rows of `A h = 0`,
//! `[0ᵀ, −wx̃ᵀ, y' x̃ᵀ]` and `[x̃ᵀ, 0ᵀ, −x' x̃ᵀ]` with `x̃ = (x, y, 1)`, and `h` is the eigenvector of
//! `AᵀA` with the smallest eigenvalue (the right singular vector of A); the result is
//! de-normalised, `H = T'⁻¹ Ĥ T`.
//!
//! [`refine`]: Gauss–Newton (Levenberg–Marquardt damped) on the transfer error
//! `Σ ‖π(H x) − x'‖²`, over the eight entries of H with `h₃₃` fixed by the start's scale: the
//! maximum-likelihood estimate when only the second image's positions are noisy.

use nalgebra::{DMatrix, Matrix3, SMatrix, SVector};

/// A 2-D point.
pub type Point = (f64, f64);

/// The similarity that moves the centroid of `pts` to the origin and their mean distance to √2.
fn normaliser(pts: &[Point]) -> Option<Matrix3<f64>> {
    let n = pts.len() as f64;
    let (cx, cy) = pts
        .iter()
        .fold((0.0, 0.0), |a, p| (a.0 + p.0 / n, a.1 + p.1 / n));
    let mean = pts
        .iter()
        .map(|p| ((p.0 - cx).powi(2) + (p.1 - cy).powi(2)).sqrt())
        .sum::<f64>()
        / n;
    if !(mean > 1e-12 && mean.is_finite()) {
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

fn apply(m: &Matrix3<f64>, p: Point) -> Point {
    let w = m[(2, 0)] * p.0 + m[(2, 1)] * p.1 + m[(2, 2)];
    (
        (m[(0, 0)] * p.0 + m[(0, 1)] * p.1 + m[(0, 2)]) / w,
        (m[(1, 0)] * p.0 + m[(1, 1)] * p.1 + m[(1, 2)]) / w,
    )
}

/// The normalised DLT homography of at least four correspondences (`src[k] ↦ dst[k]`), scaled
/// to unit Frobenius norm; `None` for fewer points, coincident points or a degenerate
/// (e.g. collinear) configuration.
pub fn dlt(src: &[Point], dst: &[Point]) -> Option<Matrix3<f64>> {
    if src.len() < 4 || src.len() != dst.len() {
        return None;
    }
    let (t, t2) = (normaliser(src)?, normaliser(dst)?);
    let mut ata = SMatrix::<f64, 9, 9>::zeros();
    for (&p, &q) in src.iter().zip(dst) {
        let (x, y) = apply(&t, p);
        let (u, v) = apply(&t2, q);
        let r1 =
            SVector::<f64, 9>::from_column_slice(&[0.0, 0.0, 0.0, -x, -y, -1.0, v * x, v * y, v]);
        let r2 =
            SVector::<f64, 9>::from_column_slice(&[x, y, 1.0, 0.0, 0.0, 0.0, -u * x, -u * y, -u]);
        ata += r1 * r1.transpose() + r2 * r2.transpose();
    }
    let eig = ata.symmetric_eigen();
    let (k, _) = eig
        .eigenvalues
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(b.1))?;
    // The null space must be one-dimensional: a second (near) zero eigenvalue means the points
    // do not pin H down.
    let mut sorted: Vec<f64> = eig.eigenvalues.iter().copied().collect();
    sorted.sort_by(f64::total_cmp);
    if sorted[1] <= 1e-10 * sorted[8].max(1e-300) {
        return None;
    }
    let h = eig.eigenvectors.column(k);
    let hn = Matrix3::new(h[0], h[1], h[2], h[3], h[4], h[5], h[6], h[7], h[8]);
    let m = t2.try_inverse()? * hn * t;
    let norm = m.norm();
    (norm > 0.0 && m.iter().all(|v| v.is_finite())).then(|| m / norm)
}

/// The transfer error `‖π(H p) − q‖` of one correspondence (infinite at the horizon).
pub fn transfer_error(h: &Matrix3<f64>, p: Point, q: Point) -> f64 {
    let w = h[(2, 0)] * p.0 + h[(2, 1)] * p.1 + h[(2, 2)];
    if w.abs() < 1e-300 {
        return f64::INFINITY;
    }
    let (x, y) = apply(h, p);
    let d = ((x - q.0).powi(2) + (y - q.1).powi(2)).sqrt();
    if d.is_finite() { d } else { f64::INFINITY }
}

/// Levenberg–Marquardt refinement of `h` on the transfer error of the correspondences
/// (at most `iterations` accepted steps); returns a matrix whose summed squared error is at most
/// the start's.
pub fn refine(h: &Matrix3<f64>, src: &[Point], dst: &[Point], iterations: usize) -> Matrix3<f64> {
    // Scale so that the largest entry of the last row ... keep h33 as the fixed entry when it
    // is not tiny; otherwise refine the unit-norm matrix as it is.
    let cost = |m: &Matrix3<f64>| -> f64 {
        src.iter()
            .zip(dst)
            .map(|(&p, &q)| transfer_error(m, p, q).powi(2))
            .sum()
    };
    let mut cur = *h;
    let mut c = cost(&cur);
    if !c.is_finite() || src.len() < 5 {
        return cur;
    }
    let mut lambda = 1e-3;
    // Parameters: all entries but the largest-magnitude one, which stays fixed (a gauge).
    let fixed = (0..9)
        .max_by(|&a, &b| {
            cur[(a / 3, a % 3)]
                .abs()
                .total_cmp(&cur[(b / 3, b % 3)].abs())
        })
        .unwrap_or(8);
    let free: Vec<usize> = (0..9).filter(|&k| k != fixed).collect();
    for _ in 0..iterations {
        let n = src.len();
        let mut jac = DMatrix::<f64>::zeros(2 * n, 8);
        let mut res = nalgebra::DVector::<f64>::zeros(2 * n);
        for (r, (&p, &q)) in src.iter().zip(dst).enumerate() {
            let xt = [p.0, p.1, 1.0];
            let s = cur[(0, 0)] * p.0 + cur[(0, 1)] * p.1 + cur[(0, 2)];
            let t = cur[(1, 0)] * p.0 + cur[(1, 1)] * p.1 + cur[(1, 2)];
            let w = cur[(2, 0)] * p.0 + cur[(2, 1)] * p.1 + cur[(2, 2)];
            res[2 * r] = s / w - q.0;
            res[2 * r + 1] = t / w - q.1;
            for (col, &k) in free.iter().enumerate() {
                let (row, c3) = (k / 3, k % 3);
                let d = xt[c3];
                match row {
                    0 => jac[(2 * r, col)] = d / w,
                    1 => jac[(2 * r + 1, col)] = d / w,
                    _ => {
                        jac[(2 * r, col)] = -s * d / (w * w);
                        jac[(2 * r + 1, col)] = -t * d / (w * w);
                    }
                }
            }
        }
        let jtj = jac.transpose() * &jac;
        let jtr = jac.transpose() * &res;
        let mut improved = false;
        for _ in 0..10 {
            let mut a = jtj.clone();
            for d in 0..8 {
                a[(d, d)] += lambda * jtj[(d, d)].max(1e-12);
            }
            let Some(step) = a.lu().solve(&(-&jtr)) else {
                lambda *= 10.0;
                continue;
            };
            let mut next = cur;
            for (col, &k) in free.iter().enumerate() {
                next[(k / 3, k % 3)] += step[col];
            }
            let nc = cost(&next);
            if nc.is_finite() && nc < c {
                let gain = (c - nc) / c.max(1e-300);
                cur = next;
                c = nc;
                lambda = (lambda / 10.0).max(1e-12);
                improved = gain > 1e-12;
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
    }
    cur / cur.norm()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn truth() -> Matrix3<f64> {
        Matrix3::new(0.9, 0.15, 12.0, -0.1, 1.05, -7.0, 2e-4, -1e-4, 1.0)
    }

    fn grid() -> Vec<Point> {
        (0..25)
            .map(|k| ((k % 5) as f64 * 90.0 + 5.0, (k / 5) as f64 * 70.0 + 3.0))
            .collect()
    }

    fn same(a: &Matrix3<f64>, b: &Matrix3<f64>) -> f64 {
        let (a, b) = (a / a[(2, 2)], b / b[(2, 2)]);
        (a - b).abs().max()
    }

    #[test]
    fn dlt_recovers_an_exact_homography_from_four_and_from_many() {
        let h = truth();
        let src = grid();
        let dst: Vec<Point> = src.iter().map(|&p| apply(&h, p)).collect();
        assert!(same(&dlt(&src, &dst).unwrap(), &h) < 1e-9);
        let four = [src[0], src[4], src[20], src[24]];
        let four_d = [dst[0], dst[4], dst[20], dst[24]];
        assert!(same(&dlt(&four, &four_d).unwrap(), &h) < 1e-9);
        // Scaled to unit Frobenius norm.
        for m in [dlt(&src, &dst).unwrap(), dlt(&four, &four_d).unwrap()] {
            assert!((m.norm() - 1.0).abs() < 1e-12, "{}", m.norm());
        }
        // Collinear, too few, or coincident points.
        let line: Vec<Point> = (0..6).map(|k| (k as f64, 2.0 * k as f64)).collect();
        assert!(dlt(&line, &line).is_none());
        assert!(dlt(&src[..3], &dst[..3]).is_none());
        assert!(dlt(&[(1.0, 1.0); 5], &[(2.0, 2.0); 5]).is_none());
    }

    #[test]
    fn refinement_does_not_increase_the_error_and_fixes_a_perturbed_start() {
        let h = truth();
        let src = grid();
        let dst: Vec<Point> = src.iter().map(|&p| apply(&h, p)).collect();
        let mut start = h;
        start[(0, 2)] += 3.0;
        start[(2, 0)] += 1e-4;
        let r = refine(&start, &src, &dst, 50);
        assert!(same(&r, &h) < 1e-6, "{}", same(&r, &h));
        let e: f64 = src
            .iter()
            .zip(&dst)
            .map(|(&p, &q)| transfer_error(&r, p, q))
            .fold(0.0, f64::max);
        assert!(e < 1e-6, "{e}");
    }
}
