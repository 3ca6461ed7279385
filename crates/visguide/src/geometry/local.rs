//! A local affine (and similarity) estimate per match, from the two regions' frame ellipses and
//! the rotation the contour correlation recovered.
//!
//! A frame `dᵀ M d = 1` (`M = Σ⁻¹`) is the image of the unit circle under `Σ^{1/2}`, so every
//! affine map taking frame 1 onto frame 2 is `A(θ) = Σ₂^{1/2} R(θ) Σ₁^{−1/2}` for some rotation
//! `R(θ)`: the ellipses fix A up to that one angle. The contours fix it: the Fourier-descriptor
//! correlation of the two contours (Paper A eq. 12) gives the rotation `φ` with
//! `c₂ ≈ s e^{iφ} c₁` (complex `x + iy`, image coordinates), and θ is chosen so that the rotation
//! of A's polar decomposition `A = R(φ) S` (`S` symmetric positive definite) is exactly `φ`. For
//! a 2×2 matrix with positive determinant that rotation angle is `atan2(a₂₁ − a₁₂, a₁₁ + a₂₂)`;
//! with `A(θ) = cos θ X + sin θ Y` (`X = Σ₂^{1/2} Σ₁^{−1/2}`, `Y = Σ₂^{1/2} J Σ₁^{−1/2}`,
//! `J` = rotation by 90°) the condition is linear in `(cos θ, sin θ)` and has the two solutions
//! θ and θ + π, of which the one with the polar angle φ (not φ + π) is taken. When the true map
//! is affine, `A` is exactly it (up to the errors of the frames and of φ); the similarity is
//! `√|det A|` with rotation φ. Translation: centre to centre.

use nalgebra::{Matrix2, Vector2};

use crate::scoring::overlap::Ellipse;

/// `x' = to + A (x − from)`: the local affine map of one match.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocalAffine {
    /// The linear part.
    pub a: Matrix2<f64>,
    /// Centre in image 1.
    pub from: (f64, f64),
    /// Centre in image 2.
    pub to: (f64, f64),
}

impl LocalAffine {
    /// The image of a point.
    pub fn map(&self, x: f64, y: f64) -> (f64, f64) {
        let d = self.a * Vector2::new(x - self.from.0, y - self.from.1);
        (self.to.0 + d.x, self.to.1 + d.y)
    }

    /// Isotropic scale `√|det A|` of the similarity part.
    pub fn scale(&self) -> f64 {
        self.a.determinant().abs().sqrt()
    }

    /// The rotation of the polar decomposition `A = R S`, radians in `(−π, π]`.
    pub fn rotation(&self) -> f64 {
        let a = &self.a;
        (a[(1, 0)] - a[(0, 1)]).atan2(a[(0, 0)] + a[(1, 1)])
    }
}

/// `M^{p}` of a symmetric positive definite matrix, for `p = ±1/2`.
fn spd_power(m: &Matrix2<f64>, p: f64) -> Option<Matrix2<f64>> {
    let eig = m.symmetric_eigen();
    if eig.eigenvalues.iter().any(|&l| !(l > 0.0 && l.is_finite())) {
        return None;
    }
    let d = Matrix2::from_diagonal(&eig.eigenvalues.map(|l| l.powf(p)));
    Some(eig.eigenvectors * d * eig.eigenvectors.transpose())
}

/// The affine map taking frame `e1` onto frame `e2` whose polar rotation is `rotation`; `None`
/// for a degenerate ellipse or rotation.
pub fn local_affine(e1: &Ellipse, e2: &Ellipse, rotation: f64) -> Option<LocalAffine> {
    if !rotation.is_finite() {
        return None;
    }
    let m1 = Matrix2::new(e1.a, e1.b, e1.b, e1.c);
    let m2 = Matrix2::new(e2.a, e2.b, e2.b, e2.c);
    // Σ₂^{1/2} = M₂^{−1/2}, Σ₁^{−1/2} = M₁^{1/2}.
    let p = spd_power(&m2, -0.5)?;
    let q = spd_power(&m1, 0.5)?;
    let j = Matrix2::new(0.0, -1.0, 1.0, 0.0);
    let (x, y) = (p * q, p * j * q);
    let (alpha, beta) = (x[(1, 0)] - x[(0, 1)], y[(1, 0)] - y[(0, 1)]);
    let (gamma, delta) = (x[(0, 0)] + x[(1, 1)], y[(0, 0)] + y[(1, 1)]);
    let (c, s) = (rotation.cos(), rotation.sin());
    // (α cos θ + β sin θ) c − (γ cos θ + δ sin θ) s = 0.
    let (k1, k2) = (alpha * c - gamma * s, beta * c - delta * s);
    let theta = (-k1).atan2(k2);
    let a_of = |t: f64| x * t.cos() + y * t.sin();
    let mut a = a_of(theta);
    // Pick the solution whose polar angle is φ, not φ + π.
    if (a[(1, 0)] - a[(0, 1)]) * s + (a[(0, 0)] + a[(1, 1)]) * c < 0.0 {
        a = a_of(theta + std::f64::consts::PI);
    }
    a.iter().all(|v| v.is_finite()).then_some(LocalAffine {
        a,
        from: (e1.u, e1.v),
        to: (e2.u, e2.v),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn mapped(e: &Ellipse, a: &Matrix2<f64>, t: (f64, f64)) -> Ellipse {
        let ai = a.try_inverse().unwrap();
        let m = ai.transpose() * Matrix2::new(e.a, e.b, e.b, e.c) * ai;
        Ellipse {
            u: a[(0, 0)] * e.u + a[(0, 1)] * e.v + t.0,
            v: a[(1, 0)] * e.u + a[(1, 1)] * e.v + t.1,
            a: m[(0, 0)],
            b: 0.5 * (m[(0, 1)] + m[(1, 0)]),
            c: m[(1, 1)],
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 256, rng_seed: proptest::test_runner::RngSeed::Fixed(2009), ..ProptestConfig::default() })]
        /// For a true affine map with positive determinant, the frames and the map's own polar
        /// rotation give back exactly the map.
        #[test]
        fn recovers_a_true_affine_map(
            s in 0.3f64..3.0, rot in -3.1f64..3.1, shear in -0.6f64..0.6, aniso in 0.5f64..2.0,
            ea in 0.001f64..0.1, eb in -0.3f64..0.3, ec in 0.001f64..0.1,
        ) {
            let r = Matrix2::new(rot.cos(), -rot.sin(), rot.sin(), rot.cos());
            let a = r * Matrix2::new(s * aniso, shear, 0.0, s / aniso);
            let e1 = Ellipse { u: 10.0, v: 20.0, a: ea, b: eb * (ea * ec).sqrt(), c: ec };
            let e2 = mapped(&e1, &a, (5.0, -3.0));
            let want = LocalAffine { a, from: (0.0, 0.0), to: (0.0, 0.0) };
            let got = local_affine(&e1, &e2, want.rotation()).unwrap();
            prop_assert!((got.a - a).abs().max() < 1e-8 * a.abs().max().max(1.0), "{} vs {}", got.a, a);
            let (x, y) = got.map(13.0, 17.0);
            let (wx, wy) = (a[(0, 0)] * 13.0 + a[(0, 1)] * 17.0 + 5.0, a[(1, 0)] * 13.0 + a[(1, 1)] * 17.0 - 3.0);
            prop_assert!((x - wx).abs() < 1e-7 && (y - wy).abs() < 1e-7);
            prop_assert!((got.scale() - a.determinant().sqrt()).abs() < 1e-9);
        }
    }

    #[test]
    fn degenerate_frames_give_none() {
        let good = Ellipse {
            u: 0.0,
            v: 0.0,
            a: 1.0,
            b: 0.0,
            c: 1.0,
        };
        let bad = Ellipse { a: -1.0, ..good };
        assert!(local_affine(&good, &bad, 0.0).is_none());
        assert!(local_affine(&good, &good, f64::NAN).is_none());
        assert_eq!(
            local_affine(&good, &good, 0.0).unwrap().a,
            Matrix2::identity()
        );
    }
}
