//! Exact geometry on hand-checkable regions: the ellipse convention and the contour's start,
//! orientation and corner handling.

use mser::{GrayView, MserParams, Polarities, detect};

fn one_dark_region(px: &[u8], w: usize, h: usize) -> (GrayView<'_>, mser::Region) {
    let img = GrayView::packed(px, w, h).unwrap();
    let p = MserParams {
        min_area: 1,
        polarities: Polarities::Dark,
        ..Default::default()
    };
    let mut rs = detect(&img, &p).unwrap();
    assert_eq!(rs.len(), 1);
    (img, rs.remove(0))
}

#[test]
fn rectangle_ellipse_has_the_uniform_ellipse_moments() {
    // A 6x3 dark rectangle at x 2..8, y 1..4: pixel-centre variances (6²−1)/12 and (3²−1)/12,
    // plus 1/12 for the unit squares: W²/12 and H²/12. M = (4Σ)⁻¹: a = 3/W², c = 3/H², b = 0.
    let (w, h) = (10, 6);
    let mut px = vec![200u8; w * h];
    for y in 1..4 {
        for x in 2..8 {
            px[y * w + x] = 10;
        }
    }
    let (_, r) = one_dark_region(&px, w, h);
    assert_eq!((r.area, r.seed, r.level), (18, (2, 1), 10));
    assert_eq!(
        (r.bbox.x_min, r.bbox.y_min, r.bbox.x_max, r.bbox.y_max),
        (2, 1, 7, 3)
    );
    assert_eq!((r.bbox.width(), r.bbox.height()), (6, 3));
    let e = r.ellipse().unwrap();
    assert!((e.u - 4.5).abs() < 1e-12 && (e.v - 2.0).abs() < 1e-12);
    assert!((e.a - 3.0 / 36.0).abs() < 1e-12, "{e:?}");
    assert!(e.b.abs() < 1e-12);
    assert!((e.c - 3.0 / 9.0).abs() < 1e-12);
    // VLFeat frame (k = 1): M = Σ⁻¹, four times larger coefficients.
    let f = r.ellipse_scaled(1.0).unwrap();
    assert!((f.a - 12.0 / 36.0).abs() < 1e-12 && (f.c - 12.0 / 9.0).abs() < 1e-12);
    // Bad scales are typed errors (they were an assertion or an `expect` panic).
    for bad in [0.0, -1.0, f64::NAN, f64::INFINITY, 1e-200, 1e200] {
        assert!(
            matches!(
                r.ellipse_scaled(bad),
                Err(mser::MserError::InvalidParameter { name: "k", .. })
            ),
            "k = {bad}"
        );
    }
    let [sxx, sxy, syy] = r.moments.covariance();
    assert!(
        (sxx - 35.0 / 12.0).abs() < 1e-12 && sxy.abs() < 1e-12 && (syy - 8.0 / 12.0).abs() < 1e-12
    );
}

#[test]
fn contour_of_an_l_shape_is_counter_clockwise_and_cuts_the_concave_corner() {
    // Dark L: column x = 1 for y = 1..=3 and row y = 3 for x = 1..=3.
    //   . . . . .
    //   . # . . .
    //   . # . . .
    //   . # # # .
    //   . . . . .
    let (w, h) = (5, 5);
    let mut px = vec![200u8; w * h];
    for (x, y) in [(1, 1), (1, 2), (1, 3), (2, 3), (3, 3)] {
        px[y * w + x] = 10;
    }
    let (img, r) = one_dark_region(&px, w, h);
    let c = r.contour(&img).unwrap();
    // Down the left side, along the bottom, back along the top of the foot and up the right
    // side of the stem: counter-clockwise on screen, every pixel on the boundary.
    assert_eq!(
        c,
        vec![(1, 1), (1, 2), (1, 3), (2, 3), (3, 3), (2, 3), (1, 2)]
    );
    let f = r.contour_f64(&img).unwrap();
    assert_eq!(f[0], (1.0, 1.0));
}

#[test]
fn contour_skips_a_pixel_without_outside_4_neighbour_and_ignores_holes() {
    // A 5x5 dark square with a bright 1-pixel hole in the middle: the contour is the 16 pixels of
    // the outer ring; the ring around the hole is not part of it.
    let (w, h) = (7, 7);
    let mut px = vec![200u8; w * h];
    for y in 1..6 {
        for x in 1..6 {
            px[y * w + x] = 10;
        }
    }
    px[3 * w + 3] = 200;
    let img = GrayView::packed(&px, w, h).unwrap();
    let p = MserParams {
        min_area: 1,
        polarities: Polarities::Dark,
        ..Default::default()
    };
    let r = detect(&img, &p)
        .unwrap()
        .into_iter()
        .find(|r| r.area == 24)
        .unwrap();
    let c = r.contour(&img).unwrap();
    assert_eq!(c.len(), 16);
    assert_eq!(c[0], (1, 1));
    assert_eq!(c[1], (1, 2)); // heading down first: counter-clockwise on screen
    assert!(c.iter().all(|&(x, y)| x == 1 || x == 5 || y == 1 || y == 5));
}

#[test]
fn bounding_box_sizes_neither_overflow_nor_underflow() {
    use mser::BoundingBox;
    let bb = |x_min, y_min, x_max, y_max| BoundingBox {
        x_min,
        y_min,
        x_max,
        y_max,
    };
    // The whole u32 plane: 2³² columns and rows (this overflowed u32: a panic in debug builds, 0
    // in release builds).
    let full = bb(0, 0, u32::MAX, u32::MAX);
    assert_eq!(full.width(), 1 << 32);
    assert_eq!(full.height(), 1 << 32);
    let single = bb(u32::MAX, 7, u32::MAX, 7);
    assert_eq!((single.width(), single.height()), (1, 1));
    // An inverted box holds no column or row (it underflowed).
    let inverted = bb(5, 9, 4, 2);
    assert_eq!((inverted.width(), inverted.height()), (0, 0));
    let inverted = bb(u32::MAX, u32::MAX, 0, 0);
    assert_eq!((inverted.width(), inverted.height()), (0, 0));
}

/// `Ellipse::area`, `semi_axes` (larger first) and `contains` (strictly inside) on an ellipse
/// with known axes, rotated and axis-aligned.
#[test]
fn ellipse_area_semi_axes_and_strict_containment() {
    use mser::Ellipse;
    // x²/16 + y²/4 = 1 around (10, 20): semi-axes 4 and 2, area 8π.
    let e = Ellipse {
        u: 10.0,
        v: 20.0,
        a: 1.0 / 16.0,
        b: 0.0,
        c: 1.0 / 4.0,
    };
    let (l_max, l_min) = e.semi_axes();
    assert!((l_max - 4.0).abs() < 1e-12 && (l_min - 2.0).abs() < 1e-12);
    assert!((e.area() - 8.0 * std::f64::consts::PI).abs() < 1e-12);
    assert!(e.contains(10.0, 20.0) && e.contains(13.9, 20.0) && e.contains(10.0, 21.9));
    // On the boundary is not inside (dᵀ M d = 1 exactly), beyond it neither.
    assert!(!e.contains(14.0, 20.0) && !e.contains(10.0, 22.0) && !e.contains(6.0, 20.0));
    assert!(!e.contains(14.1, 20.0) && !e.contains(13.0, 21.5));
    // The same ellipse turned by 90°: the axes keep their order.
    let t = Ellipse {
        a: e.c,
        c: e.a,
        ..e
    };
    assert_eq!(t.semi_axes(), e.semi_axes());
    // Turned by 30° (M = R diag(1/16, 1/4) Rᵀ): same axes and area.
    let (s, c) = (30f64.to_radians().sin(), 30f64.to_radians().cos());
    let (p, q) = (1.0 / 16.0, 1.0 / 4.0);
    let r = Ellipse {
        a: p * c * c + q * s * s,
        b: (p - q) * c * s,
        c: p * s * s + q * c * c,
        ..e
    };
    let (l_max, l_min) = r.semi_axes();
    assert!((l_max - 4.0).abs() < 1e-12 && (l_min - 2.0).abs() < 1e-12);
    assert!((r.area() - e.area()).abs() < 1e-12);
    // The long axis now points along (cos 30°, sin 30°).
    assert!(r.contains(10.0 + 3.9 * c, 20.0 + 3.9 * s));
    assert!(!r.contains(10.0 + 3.9 * -s, 20.0 + 3.9 * c));
}

/// One-pixel-wide regions: the boundary passes their pixels twice, so the contour lists them
/// again and its shoelace sum is 0, not negative; a one-pixel region gives one point.
#[test]
fn contours_of_one_pixel_wide_regions_retrace_and_have_zero_area() {
    let shoelace = |c: &[(u32, u32)]| -> i64 {
        (0..c.len())
            .map(|i| {
                let (a, b) = (c[i], c[(i + 1) % c.len()]);
                a.0 as i64 * b.1 as i64 - b.0 as i64 * a.1 as i64
            })
            .sum()
    };
    // A vertical bar of three pixels at x = 2, y = 1..=3.
    let (w, h) = (5, 5);
    let mut px = vec![200u8; w * h];
    for y in 1..4 {
        px[y * w + 2] = 10;
    }
    let (img, r) = one_dark_region(&px, w, h);
    let c = r.contour(&img).unwrap();
    assert_eq!(c, vec![(2, 1), (2, 2), (2, 3), (2, 2)]);
    assert_eq!(shoelace(&c), 0);
    // A single pixel: one point, the seed.
    let mut px = vec![200u8; w * h];
    px[3 * w + 1] = 10;
    let (img, r) = one_dark_region(&px, w, h);
    let c = r.contour(&img).unwrap();
    assert_eq!(c, vec![(1, 3)]);
    assert_eq!(shoelace(&c), 0);
    // A solid region has a negative sum (counter-clockwise on screen).
    let mut px = vec![200u8; w * h];
    for y in 1..3 {
        for x in 1..3 {
            px[y * w + x] = 10;
        }
    }
    let (img, r) = one_dark_region(&px, w, h);
    let c = r.contour(&img).unwrap();
    assert_eq!(c, vec![(1, 1), (1, 2), (2, 2), (2, 1)]);
    assert!(shoelace(&c) < 0);
}
