//! Validation of input contours and their polygon geometry (area, centroid, moments).
//!
//! A contour is a closed, ordered polygon. Validation converts it to complex numbers
//! `x + i·y` (eq. 1), rejects non-finite coordinates, cyclically repeated points, fewer than
//! three points and zero area, drops an explicit closing point equal to the first, and orients
//! the polygon so that its signed area is positive (counter-clockwise in a y-up frame; on an
//! image with y pointing down this is clockwise on screen). Orientation matters: reversing a
//! contour mirrors its Fourier spectrum (`C(n) ↦ C(−n)` up to a shift), so both images of a
//! match must use the same convention, which this normalisation guarantees.
//!
//! **Range.** Every finite coordinate is accepted. The geometry (areas, second moments, the
//! affine arc length's cross products) takes up to fourth powers of coordinates, which overflow
//! beyond about 1e77 and underflow below about 1e-77; so a contour whose largest coordinate
//! magnitude lies outside `[2⁻⁶⁴, 2⁶⁴]` is scaled by a power of two to bring it near 1. Such a
//! scaling is exact in floating point and every step is homogeneous in the scale (the smoothing
//! σ is scaled with it), so the descriptors are those of the unscaled computation, without its
//! overflow; [`crate::Extractor::resample`] scales its samples back.

use rustfft::num_complex::Complex64;

use crate::error::FdError;
use crate::point::ContourPoint;

/// Relative area below which a polygon counts as enclosing nothing (`|A| ≤ ε·P²`).
const ZERO_AREA_EPS: f64 = 1e-12;

/// Largest coordinate magnitudes left unscaled (module docs, "Range").
const UNSCALED: std::ops::RangeInclusive<f64> = 5.421010862427522e-20..=1.8446744073709552e19;

/// `x · 2^e`, exact unless the result leaves the normal range (two steps, so that `2^e` itself
/// need not be representable).
pub(crate) fn scale_pow2(x: f64, e: i32) -> f64 {
    let half = e / 2;
    x * 2f64.powi(half) * 2f64.powi(e - half)
}

/// Validates `contour` into `out` (cleared first; its capacity is reused). On success `out`
/// holds at least three points, pairwise distinct from their successors, with positive signed
/// area, scaled by `2^e` where `e` is the returned exponent (0 unless the coordinates lie
/// outside the range of the module docs).
pub(crate) fn load<P: ContourPoint>(
    contour: &[P],
    out: &mut Vec<Complex64>,
) -> Result<i32, FdError> {
    out.clear();
    for (index, p) in contour.iter().enumerate() {
        let (x, y) = p.xy();
        if !x.is_finite() || !y.is_finite() {
            return Err(FdError::NonFinite { index, x, y });
        }
        out.push(Complex64::new(x, y));
    }
    if out.len() > 1 && out[0] == out[out.len() - 1] {
        out.pop(); // explicit closing point
    }
    let largest = out
        .iter()
        .fold(0.0f64, |m, p| m.max(p.re.abs()).max(p.im.abs()));
    let mut exponent = 0;
    if largest > 0.0 && !UNSCALED.contains(&largest) {
        exponent = -(largest.log2().floor() as i32);
        for p in out.iter_mut() {
            *p = Complex64::new(scale_pow2(p.re, exponent), scale_pow2(p.im, exponent));
        }
    }
    let n = out.len();
    for i in 1..n {
        if out[i] == out[i - 1] {
            return Err(FdError::RepeatedPoint {
                index: i,
                x: out[i].re,
                y: out[i].im,
            });
        }
    }
    if n < 3 {
        return Err(FdError::TooFewPoints { got: n });
    }
    let area = signed_area(out);
    let perimeter = perimeter(out);
    if area.abs() <= ZERO_AREA_EPS * perimeter * perimeter {
        return Err(FdError::ZeroArea {
            area: area.abs(),
            perimeter,
        });
    }
    if area < 0.0 {
        out.reverse();
    }
    Ok(exponent)
}

/// Validates a contour without describing it: `Ok(())` exactly when [`crate::Extractor`]
/// accepts its geometry.
///
/// ```
/// use fd_match::{validate_contour, FdError};
/// assert!(validate_contour(&[(0, 0), (4, 0), (0, 3)]).is_ok());
/// assert!(matches!(validate_contour(&[(0, 0), (1, 1), (2, 2)]), Err(FdError::ZeroArea { .. })));
/// ```
pub fn validate_contour<P: ContourPoint>(contour: &[P]) -> Result<(), FdError> {
    load(contour, &mut Vec::with_capacity(contour.len())).map(|_| ())
}

/// Signed polygon area (shoelace), computed relative to the first vertex for accuracy.
pub(crate) fn signed_area(p: &[Complex64]) -> f64 {
    let o = p[0];
    let mut s = 0.0;
    for i in 1..p.len() - 1 {
        let a = p[i] - o;
        let b = p[i + 1] - o;
        s += a.re * b.im - a.im * b.re;
    }
    0.5 * s
}

/// Polygon perimeter (closed).
pub(crate) fn perimeter(p: &[Complex64]) -> f64 {
    let n = p.len();
    (0..n)
        .map(|i| (p[(i + 1) % n] - p[i]).norm_sqr().sqrt())
        .sum()
}

/// Area moments of a polygon region (Green's theorem), central up to order two, plus the
/// centroid.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Moments {
    /// Area (positive for the oriented polygons produced by [`load`]).
    pub area: f64,
    /// Area centroid.
    pub centroid: Complex64,
    /// Central second moments `∫x²`, `∫xy`, `∫y²` over the region (not divided by the area).
    pub mu20: f64,
    pub mu11: f64,
    pub mu02: f64,
}

/// Moments of an oriented polygon.
pub(crate) fn moments(p: &[Complex64]) -> Moments {
    // Work relative to the vertex mean to keep the sums well conditioned.
    let n = p.len();
    let o = p.iter().sum::<Complex64>() / n as f64;
    let (mut a, mut cx, mut cy, mut ixx, mut ixy, mut iyy) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    for i in 0..n {
        let q0 = p[i] - o;
        let q1 = p[(i + 1) % n] - o;
        let (x0, y0, x1, y1) = (q0.re, q0.im, q1.re, q1.im);
        let cr = x0 * y1 - x1 * y0;
        a += cr;
        cx += (x0 + x1) * cr;
        cy += (y0 + y1) * cr;
        ixx += (x0 * x0 + x0 * x1 + x1 * x1) * cr;
        iyy += (y0 * y0 + y0 * y1 + y1 * y1) * cr;
        ixy += (x0 * y1 + 2.0 * x0 * y0 + 2.0 * x1 * y1 + x1 * y0) * cr;
    }
    let area = 0.5 * a;
    let (mx, my) = (cx / (6.0 * area), cy / (6.0 * area));
    let (ixx, iyy, ixy) = (ixx / 12.0, iyy / 12.0, ixy / 24.0);
    Moments {
        area,
        centroid: o + Complex64::new(mx, my),
        mu20: ixx - area * mx * mx,
        mu11: ixy - area * mx * my,
        mu02: iyy - area * my * my,
    }
}

/// Third moment `∫x³ dA` of an oriented polygon about the origin.
pub(crate) fn third_moment_x(p: &[Complex64]) -> f64 {
    let n = p.len();
    let mut s = 0.0;
    for i in 0..n {
        let (x0, y0) = (p[i].re, p[i].im);
        let (x1, y1) = (p[(i + 1) % n].re, p[(i + 1) % n].im);
        let cr = x0 * y1 - x1 * y0;
        s += (x0 * x0 * x0 + x0 * x0 * x1 + x0 * x1 * x1 + x1 * x1 * x1) * cr;
    }
    s / 20.0
}

#[cfg(test)]
mod tests {
    use super::*;

    fn poly(pts: &[(f64, f64)]) -> Vec<Complex64> {
        pts.iter().map(|&(x, y)| Complex64::new(x, y)).collect()
    }

    #[test]
    fn rectangle_moments_are_exact() {
        // 4 × 2 rectangle with corner at (1, 1): area 8, centroid (3, 2),
        // μ20 = w³h/12 = 64·2/12, μ02 = w h³/12 = 4·8/12, μ11 = 0.
        let p = poly(&[(1.0, 1.0), (5.0, 1.0), (5.0, 3.0), (1.0, 3.0)]);
        let m = moments(&p);
        assert!((m.area - 8.0).abs() < 1e-12);
        assert!((m.centroid - Complex64::new(3.0, 2.0)).norm() < 1e-12);
        assert!((m.mu20 - 128.0 / 12.0).abs() < 1e-12);
        assert!((m.mu02 - 32.0 / 12.0).abs() < 1e-12);
        assert!(m.mu11.abs() < 1e-12);
    }

    #[test]
    fn triangle_third_moment_matches_integral() {
        // Right triangle (0,0),(1,0),(0,1): ∫x³ dA = ∫_0^1 x³ (1 − x) dx = 1/4 − 1/5 = 1/20.
        let p = poly(&[(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)]);
        assert!((third_moment_x(&p) - 0.05).abs() < 1e-15);
    }

    #[test]
    fn load_orients_and_drops_closing_point() {
        let mut out = Vec::new();
        let e = load(&[(0.0, 0.0), (0.0, 1.0), (1.0, 0.0), (0.0, 0.0)], &mut out).unwrap();
        assert_eq!(e, 0);
        assert_eq!(out.len(), 3);
        assert!(signed_area(&out) > 0.0);
    }

    #[test]
    fn load_rejects_bad_contours() {
        let mut out = Vec::new();
        assert_eq!(
            load(&[(0.0, 0.0), (1.0, 0.0)], &mut out),
            Err(FdError::TooFewPoints { got: 2 })
        );
        assert!(matches!(
            load(&[(0.0, 0.0), (1.0, f64::NAN), (0.0, 1.0)], &mut out),
            Err(FdError::NonFinite { index: 1, .. })
        ));
        assert!(matches!(
            load(&[(0.0, 0.0), (1.0, 0.0), (1.0, 0.0), (0.0, 1.0)], &mut out),
            Err(FdError::RepeatedPoint { index: 2, .. })
        ));
        assert!(matches!(
            load(&[(0, 0), (1, 0), (2, 0), (1, 0)], &mut out),
            Err(FdError::ZeroArea { .. })
        ));
        assert!(matches!(
            load::<(f64, f64)>(&[], &mut out),
            Err(FdError::TooFewPoints { got: 0 })
        ));
    }
}
