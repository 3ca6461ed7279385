//! Ground-truth homographies of the Oxford affine benchmark (`H1toNp` files).
//!
//! A file holds a 3×3 matrix as three rows of three whitespace-separated numbers in any float
//! notation (`8.7976964e-01`, `4.08E-6`, `1`). It maps 0-based pixel coordinates of img1 to imgN:
//! `[s, t, w]ᵀ = H [x, y, 1]ᵀ`, then `(s/w, t/w)`. The matrices are NOT normalised: leuven's
//! have h33 ≈ 0.58 and `leuven/H1to5p` is negated (h33 ≈ −0.576), so nothing here assumes
//! h33 = 1 or w > 0; every quantity computed is invariant to the scale (and sign) of H.

use nalgebra::{Matrix2, Matrix3};

use crate::error::VisguideError;

/// A plane projective transformation, kept exactly as read (no normalisation), except that a
/// matrix whose largest entry is beyond 2^±64 is scaled by a power of two (see
/// [`Homography::from_row_major`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Homography {
    m: Matrix3<f64>,
}

/// Relative size of `|det H|` (against the product of the row norms) below which H counts as
/// singular.
const SINGULAR_EPS: f64 = 1e-12;

/// Largest binary exponent of the largest entry kept as read. H and cH are the same map, but a
/// matrix with entries like 1e150 overflows (its determinant is `inf − inf`, its inverse NaN,
/// so scoring against it silently found no correct match) and one with entries like 1e-150
/// underflows (refused as singular); such a matrix is scaled by a power of two, which changes
/// no mantissa, so every mapped point is what the matrix as read gives.
const SCALE_EXP_LIMIT: i32 = 64;

/// `x · 2^k` for |k| up to about 2100, exact unless the result under- or overflows (in two
/// steps, as 2^k alone overflows for |k| > 1023).
fn times_pow2(x: f64, k: i32) -> f64 {
    x * 2f64.powi(k / 2) * 2f64.powi(k - k / 2)
}

/// Homogeneous weights with `|w|` below this (relative to the row norm) map to infinity.
const HORIZON_EPS: f64 = 1e-12;

impl Homography {
    /// Parses the text of an `H1toNp` file: exactly nine finite numbers separated by whitespace.
    pub fn parse(text: &str) -> Result<Self, VisguideError> {
        let mut v = Vec::with_capacity(9);
        for tok in text.split_whitespace() {
            let x: f64 = tok.parse().map_err(|_| VisguideError::Homography {
                reason: format!("`{tok}` is not a number"),
            })?;
            if !x.is_finite() {
                return Err(VisguideError::Homography {
                    reason: format!("`{tok}` is not finite"),
                });
            }
            v.push(x);
        }
        if v.len() != 9 {
            return Err(VisguideError::Homography {
                reason: format!("expected 9 numbers, found {}", v.len()),
            });
        }
        Self::from_row_major(&v)
    }

    /// A homography from its nine entries in row-major order; fails if any is non-finite or
    /// the matrix is (numerically) singular.
    pub fn from_row_major(v: &[f64]) -> Result<Self, VisguideError> {
        if v.len() != 9 || v.iter().any(|x| !x.is_finite()) {
            return Err(VisguideError::Homography {
                reason: "need nine finite entries".into(),
            });
        }
        let largest = v.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        let exp = if largest > 0.0 {
            largest.log2().floor() as i32
        } else {
            0
        };
        let mut m = Matrix3::from_row_slice(v);
        if exp.abs() > SCALE_EXP_LIMIT {
            m.apply(|x| *x = times_pow2(*x, -exp));
        }
        let scale: f64 = (0..3).map(|r| m.row(r).norm()).product();
        if scale == 0.0 || m.determinant().abs() <= SINGULAR_EPS * scale {
            return Err(VisguideError::Homography {
                reason: "the matrix is singular".into(),
            });
        }
        Ok(Homography { m })
    }

    /// A homography from a matrix; fails as [`Self::from_row_major`] does.
    pub fn from_matrix(m: &Matrix3<f64>) -> Result<Self, VisguideError> {
        let v: Vec<f64> = m.transpose().iter().copied().collect();
        Self::from_row_major(&v)
    }

    /// The matrix as read (or estimated).
    pub fn matrix(&self) -> &Matrix3<f64> {
        &self.m
    }

    /// The nine entries in row-major order.
    pub fn to_row_major(&self) -> [f64; 9] {
        let m = &self.m;
        [
            m[(0, 0)],
            m[(0, 1)],
            m[(0, 2)],
            m[(1, 0)],
            m[(1, 1)],
            m[(1, 2)],
            m[(2, 0)],
            m[(2, 1)],
            m[(2, 2)],
        ]
    }

    /// The text of an `H1toNp` file: three rows of three numbers, shortest round-trip
    /// formatting, so [`Self::parse`] reads back the same matrix.
    pub fn to_text(&self) -> String {
        (0..3)
            .map(|r| {
                format!(
                    "{:e} {:e} {:e}\n",
                    self.m[(r, 0)],
                    self.m[(r, 1)],
                    self.m[(r, 2)]
                )
            })
            .collect()
    }

    /// The largest distance between `self(p)` and `other(p)` over the four corners `p` of a
    /// `width × height` image (pixel centres `(0, 0)` … `(width − 1, height − 1)`): the usual
    /// "corner error" of a homography estimate. Infinite when a corner maps to infinity.
    pub fn corner_error(&self, other: &Homography, width: u32, height: u32) -> f64 {
        let (w, h) = (width.max(1) as f64 - 1.0, height.max(1) as f64 - 1.0);
        [(0.0, 0.0), (w, 0.0), (0.0, h), (w, h)]
            .iter()
            .map(|&(x, y)| match (self.map(x, y), other.map(x, y)) {
                (Some(p), Some(q)) => ((p.0 - q.0).powi(2) + (p.1 - q.1).powi(2)).sqrt(),
                _ => f64::INFINITY,
            })
            .fold(0.0, f64::max)
    }

    /// The matrix inverse (maps imgN back to img1).
    pub fn inverse(&self) -> Homography {
        // `from_row_major` refused `|det| ≤ 1e-12 · Π‖row‖` (so det ≠ 0), and `try_inverse`
        // fails only on a zero determinant computed by the same 3×3 formula.
        Homography {
            m: self
                .m
                .try_inverse()
                .expect("checked non-singular at construction"),
        }
    }

    /// `(s, t, w)` of a point.
    fn homogeneous(&self, x: f64, y: f64) -> (f64, f64, f64) {
        let m = &self.m;
        (
            m[(0, 0)] * x + m[(0, 1)] * y + m[(0, 2)],
            m[(1, 0)] * x + m[(1, 1)] * y + m[(1, 2)],
            m[(2, 0)] * x + m[(2, 1)] * y + m[(2, 2)],
        )
    }

    fn at_horizon(&self, x: f64, y: f64, w: f64) -> bool {
        let row = self.m.row(2);
        let size = row[0].abs() * x.abs() + row[1].abs() * y.abs() + row[2].abs();
        let limit = HORIZON_EPS * size;
        w.is_nan() || limit.is_nan() || w.abs() <= limit
    }

    /// The image of `(x, y)`, or `None` when it maps to (or near) the line at infinity.
    pub fn map(&self, x: f64, y: f64) -> Option<(f64, f64)> {
        let (s, t, w) = self.homogeneous(x, y);
        if self.at_horizon(x, y, w) {
            return None;
        }
        let p = (s / w, t / w);
        (p.0.is_finite() && p.1.is_finite()).then_some(p)
    }

    /// The Jacobian of the map at `(x, y)` (docs/methods.md § Overlap error, step 1):
    /// `J = 1/w² [[h11 w − s h31, h12 w − s h32], [h21 w − t h31, h22 w − t h32]]`.
    /// `None` at the line at infinity.
    pub fn jacobian(&self, x: f64, y: f64) -> Option<Matrix2<f64>> {
        let (s, t, w) = self.homogeneous(x, y);
        if self.at_horizon(x, y, w) {
            return None;
        }
        let m = &self.m;
        let w2 = w * w;
        let j = Matrix2::new(
            (m[(0, 0)] * w - s * m[(2, 0)]) / w2,
            (m[(0, 1)] * w - s * m[(2, 1)]) / w2,
            (m[(1, 0)] * w - t * m[(2, 0)]) / w2,
            (m[(1, 1)] * w - t * m[(2, 1)]) / w2,
        );
        j.iter().all(|v| v.is_finite()).then_some(j)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SAMPLE: &str =
        "   8.5e-01   2.1E-01  9.9\n  -2.1e-01   8.6e-01  1.3e+02\n 2.0e-06   1.2e-06   1.0\n";

    /// A matrix with huge or tiny entries is the same map as the one with ordinary entries: it
    /// used to overflow (entries around 1e150: a NaN inverse, infinite corner errors, so
    /// scoring silently found nothing) or underflow (around 1e-150: refused as singular).
    #[test]
    fn scaled_matrices_are_the_same_map() {
        let h = Homography::parse(SAMPLE).unwrap();
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * (1.0 + a.abs().max(b.abs()));
        for k in [1e150, -1e150, 1e-150, 1e300, 1e-300, 1e-310] {
            let v: Vec<f64> = h.to_row_major().iter().map(|x| x * k).collect();
            let g = Homography::from_row_major(&v).unwrap_or_else(|e| panic!("{k}: {e}"));
            for (x, y) in [(0.0, 0.0), (123.0, 456.0), (800.0, 600.0)] {
                let (p, q) = (h.map(x, y).unwrap(), g.map(x, y).unwrap());
                assert!(close(p.0, q.0) && close(p.1, q.1), "{k}: {p:?} vs {q:?}");
                let (jh, jg) = (h.jacobian(x, y).unwrap(), g.jacobian(x, y).unwrap());
                assert!(jh.iter().zip(jg.iter()).all(|(a, b)| close(*a, *b)), "{k}");
                let (p, q) = (
                    h.inverse().map(x, y).unwrap(),
                    g.inverse().map(x, y).unwrap(),
                );
                assert!(close(p.0, q.0) && close(p.1, q.1), "{k}: {p:?} vs {q:?}");
            }
            assert!(g.corner_error(&h, 800, 600) < 1e-6, "{k}");
        }
        // Ordinary matrices are kept exactly as read.
        let v = [1e10, 2.0, 3.0, 4.0, 5e-10, 6.0, 7.0, 8.0, 9.0];
        assert_eq!(Homography::from_row_major(&v).unwrap().to_row_major(), v);
        assert!(
            Homography::from_row_major(&[1e-300, 0.0, 0.0, 0.0, 1e-300, 0.0, 0.0, 0.0, 0.0])
                .is_err()
        );
    }

    /// `to_text` is what `parse` reads back to the very same matrix (bit for bit), for entries
    /// that no short decimal holds, tiny and huge ones, and a matrix rescaled on construction.
    #[test]
    fn text_round_trips_bit_for_bit() {
        for v in [
            [
                1.0 / 3.0,
                0.1,
                -2.5e-7,
                2.0 / 7.0,
                1e10,
                -123.456_789_012_345,
                1e-17,
                -3e-9,
                0.7,
            ],
            [1e200, 3.3e199, 0.0, -1e200, 7e200, 1.0, 0.0, 1e190, 9.1e200],
        ] {
            let h = Homography::from_row_major(&v).unwrap();
            let back = Homography::parse(&h.to_text()).unwrap();
            assert_eq!(
                back.to_row_major().map(f64::to_bits),
                h.to_row_major().map(f64::to_bits),
                "{}",
                h.to_text()
            );
            assert_eq!(h.to_text().lines().count(), 3);
        }
    }

    /// The corner error is infinite, not a finite number or NaN, when a corner maps to the line
    /// at infinity under either homography.
    #[test]
    fn corner_error_is_infinite_when_a_corner_maps_to_infinity() {
        let id = Homography::parse("1 0 0 0 1 0 0 0 1").unwrap();
        // (x, y) ↦ (x / y, 1 / y): the corner (0, 0) lies on the line at infinity.
        let g = Homography::parse("1 0 0 0 0 1 0 1 0").unwrap();
        assert_eq!(g.corner_error(&id, 640, 480), f64::INFINITY);
        assert_eq!(id.corner_error(&g, 640, 480), f64::INFINITY);
        assert_eq!(id.corner_error(&id, 640, 480), 0.0);
    }

    #[test]
    fn parses_mixed_float_notation() {
        let h = Homography::parse(SAMPLE).unwrap();
        assert_eq!(h.matrix()[(0, 1)], 0.21);
        assert_eq!(h.matrix()[(1, 2)], 130.0);
        assert_eq!(h.matrix()[(2, 0)], 2.0e-6);
        assert_eq!(
            Homography::parse("1 0 0 0 1 0 0 0 1")
                .unwrap()
                .map(3.0, 4.0),
            Some((3.0, 4.0))
        );
    }

    #[test]
    fn rejects_malformed_text() {
        for bad in [
            "",
            "1 0 0 0 1 0 0 0",
            "1 0 0 0 1 0 0 0 1 5",
            "1 0 0 0 x 0 0 0 1",
            "1 0 0 0 NaN 0 0 0 1",
            "1 0 0 0 inf 0 0 0 1",
            "1 2 3 2 4 6 0 0 1",
            "0 0 0 0 0 0 0 0 0",
        ] {
            assert!(
                matches!(
                    Homography::parse(bad),
                    Err(VisguideError::Homography { .. })
                ),
                "{bad:?} accepted"
            );
        }
    }

    #[test]
    fn scale_and_sign_do_not_change_the_map_or_jacobian() {
        let h = Homography::parse(SAMPLE).unwrap();
        let v: Vec<f64> = h.matrix().transpose().iter().map(|x| -0.576 * x).collect();
        let g = Homography::from_row_major(&v).unwrap();
        for &(x, y) in &[(0.0, 0.0), (400.0, 300.0), (899.0, 599.0)] {
            let (p, q) = (h.map(x, y).unwrap(), g.map(x, y).unwrap());
            assert!((p.0 - q.0).abs() < 1e-9 && (p.1 - q.1).abs() < 1e-9);
            let (jh, jg) = (h.jacobian(x, y).unwrap(), g.jacobian(x, y).unwrap());
            assert!((jh - jg).norm() < 1e-12);
        }
    }

    #[test]
    fn jacobian_matches_finite_differences() {
        let h = Homography::parse(SAMPLE).unwrap();
        let (x, y, e) = (250.0, 410.0, 1e-4);
        let j = h.jacobian(x, y).unwrap();
        let d = |dx: f64, dy: f64| {
            let (p, q) = (
                h.map(x + dx, y + dy).unwrap(),
                h.map(x - dx, y - dy).unwrap(),
            );
            ((p.0 - q.0) / (2.0 * e), (p.1 - q.1) / (2.0 * e))
        };
        let (cx, cy) = (d(e, 0.0), d(0.0, e));
        assert!((j[(0, 0)] - cx.0).abs() < 1e-7 && (j[(1, 0)] - cx.1).abs() < 1e-7);
        assert!((j[(0, 1)] - cy.0).abs() < 1e-7 && (j[(1, 1)] - cy.1).abs() < 1e-7);
    }

    #[test]
    fn inverse_round_trips_and_horizon_is_none() {
        let h = Homography::parse(SAMPLE).unwrap();
        let (p, q) = h.map(123.0, 456.0).unwrap();
        let back = h.inverse().map(p, q).unwrap();
        assert!((back.0 - 123.0).abs() < 1e-9 && (back.1 - 456.0).abs() < 1e-9);
        // w = x/1000 + 1 vanishes on x = −1000.
        let g =
            Homography::from_row_major(&[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1e-3, 0.0, 1.0]).unwrap();
        assert_eq!(g.map(-1000.0, 5.0), None);
        assert_eq!(g.jacobian(-1000.0, 5.0), None);
    }
}
