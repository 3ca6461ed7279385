//! Exact geometry on hand-checkable regions: the ellipse convention and the contour's start,
//! orientation and corner handling; and, on random inputs, contours against a count of their
//! points at the grid vertices, moments and ellipses against a two-pass computation.

use crate::common;

use mser::{GrayView, MserParams, Polarities, Polarity, detect};
use proptest::prelude::*;

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

/// The multiset of points an outer contour lists, counted without following it: every vertex of
/// the pixel grid whose four pixels hold region pixels and outside ones (all outside pixels at a
/// vertex are 8-adjacent, so they are the outer background or none is) is passed by the walk
/// once per pair of boundary cracks it joins there. With the region on the left (counter-
/// clockwise on screen, y down: region above a horizontal crack means walking east, below
/// west; left of a vertical crack north, right of it south), a vertex with two 4-adjacent
/// region pixels moves on to the one ahead, a vertex with three (one outside corner) moves
/// diagonally to the far one, a vertex with one region pixel or two diagonal ones (a pinch)
/// only turns around a pixel. Each move lists its target once; a one-pixel region, which has no
/// move, lists its pixel once.
fn expected_contour_counts(
    pixels: &[(u32, u32)],
    w: usize,
    h: usize,
) -> std::collections::BTreeMap<(u32, u32), usize> {
    let common::Padded { m, out, pw, ph } = common::padded(pixels, w, h);
    let mut counts = std::collections::BTreeMap::new();
    // Vertex (i, j) in padded coordinates is the top-left corner of padded pixel (i, j).
    for j in 1..ph {
        for i in 1..pw {
            let px = |x: usize, y: usize| (x as u32 - 1, y as u32 - 1);
            let (nw, ne, sw, se) = ((i - 1, j - 1), (i, j - 1), (i - 1, j), (i, j));
            let r = |(x, y): (usize, usize)| m[y * pw + x];
            let o = |(x, y): (usize, usize)| out[y * pw + x];
            if ![nw, ne, sw, se].into_iter().any(o) {
                continue;
            }
            let target = match (r(nw), r(ne), r(sw), r(se)) {
                (true, true, false, false) => Some(ne),
                (false, false, true, true) => Some(sw),
                (true, false, true, false) => Some(nw),
                (false, true, false, true) => Some(se),
                (true, true, true, false) => Some(ne),
                (true, true, false, true) => Some(se),
                (true, false, true, true) => Some(nw),
                (false, true, true, true) => Some(sw),
                _ => None,
            };
            if let Some((x, y)) = target {
                *counts.entry(px(x, y)).or_insert(0) += 1;
            }
        }
    }
    if counts.is_empty() {
        counts.insert(pixels[0], 1);
    }
    counts
}

proptest! {
    #![proptest_config(crate::seeded(256))]

    /// `trace_outer_contour` (and `Region::contour`, `Region::contour_f64`) on every kind of
    /// component, not only selected regions: any threshold, both polarities, components touching
    /// the border, one pixel wide, with holes and pinches, on single rows and columns. Against
    /// the contour checker (points, set, start, 8-adjacency, orientation) and the number of times
    /// each pixel is listed, counted at the grid vertices (`expected_contour_counts`).
    #[test]
    fn contours_of_any_component_list_each_pixel_as_often_as_the_boundary_passes_it(
        (w, h, px) in (1usize..=9, 1usize..=9).prop_flat_map(|(w, h)| {
            (Just(w), Just(h), proptest::collection::vec(prop_oneof![Just(10u8), Just(20), Just(30)], w * h))
        }),
        at in any::<proptest::sample::Index>(),
        bright in any::<bool>(),
        level_pick in 0u8..3,
    ) {
        let img = GrayView::packed(&px, w, h).unwrap();
        let q = at.index(w * h);
        let g = px[q];
        let polarity = if bright { Polarity::Bright } else { Polarity::Dark };
        // A level that the picked pixel passes.
        let level = match polarity {
            Polarity::Dark => g.max(10 * (level_pick + 1)),
            Polarity::Bright => g.min(10 * (level_pick + 1)),
        };
        let pixels = common::component(&px, w, h, ((q % w) as u32, (q / w) as u32), level, polarity);
        let seed = pixels[0];
        let c = mser::trace_outer_contour(&img, seed, level, polarity).unwrap();
        common::check_contour(&c, &pixels, w, h);
        let mut got = std::collections::BTreeMap::new();
        for &p in &c {
            *got.entry(p).or_insert(0usize) += 1;
        }
        prop_assert_eq!(got, expected_contour_counts(&pixels, w, h));
        // The region's methods trace the same chain.
        let r = mser::Region {
            polarity,
            level,
            seed,
            area: pixels.len() as u32,
            variation: 0.0,
            bbox: mser::BoundingBox { x_min: 0, y_min: 0, x_max: w as u32 - 1, y_max: h as u32 - 1 },
            moments: mser::Moments::of_pixels(&pixels).unwrap(),
        };
        prop_assert_eq!(&r.contour(&img).unwrap(), &c);
        let f: Vec<(f64, f64)> = c.iter().map(|&(x, y)| (x as f64, y as f64)).collect();
        prop_assert_eq!(r.contour_f64(&img).unwrap(), f);
        prop_assert_eq!(r.pixels(&img).unwrap(), pixels);
    }

    /// `Moments::centroid`, `covariance`, `area_covariance` and `Region::ellipse_scaled` on
    /// arbitrary pixel sets (correlated, anti-correlated, collinear, single pixels, near the
    /// origin and as far from it as `u32` coordinates reach) against the centred sums computed
    /// exactly in integers, `Σ(n·x − Σx)(n·y − Σy) / n³`, and the matrix algebra of the
    /// definition: `M · k²Σ = I`, semi-axes `k √λ(Σ)`, area `π k² √det Σ`.
    #[test]
    fn moments_and_ellipses_equal_a_two_pass_computation(
        pixels in proptest::collection::btree_set((0u32..12, 0u32..12), 1..30),
        far in prop_oneof![Just(0u32), Just(1000), Just(1 << 14), Just(1 << 20), Just(1 << 26), Just(250_000_000)],
        k in prop_oneof![Just(1.0), Just(2.0), 0.25f64..5.0],
    ) {
        let pixels: Vec<(u32, u32)> = pixels.into_iter().map(|(x, y)| (x + far, y + 3 * far)).collect();
        let n = pixels.len() as f64;
        let (n_i, sx, sy) = pixels.iter().fold((0i128, 0i128, 0i128), |(n, sx, sy), &(x, y)| {
            (n + 1, sx + i128::from(x), sy + i128::from(y))
        });
        let (mx, my) = (sx as f64 / n, sy as f64 / n);
        let c = |f: &dyn Fn(i128, i128) -> i128| {
            let sum: i128 = pixels.iter().map(|&(x, y)| f(n_i * i128::from(x) - sx, n_i * i128::from(y) - sy)).sum();
            sum as f64 / (n * n * n)
        };
        let (sxx, sxy, syy) = (c(&|x, _| x * x), c(&|x, y| x * y), c(&|_, y| y * y));
        let m = mser::Moments::of_pixels(&pixels).unwrap();
        let close = |a: f64, b: f64, tol: f64| (a - b).abs() <= tol * (1.0 + b.abs());
        let (cx, cy) = m.centroid();
        prop_assert!(close(cx, mx, 1e-12) && close(cy, my, 1e-12), "{cx} {cy} vs {mx} {my}");
        // Near the origin the sums are centred in `f64`: a few ulps of the squared centroid
        // (under 2^-18 pixel² below `EXACT_CENTRING_FROM`). Beyond, exactly: a few ulps of the
        // result.
        let tol = if mx.max(my) < mser::EXACT_CENTRING_FROM {
            1e-12 + 4.0 * f64::EPSILON * (mx * mx + my * my)
        } else {
            1e-12
        };
        let [vxx, vxy, vyy] = m.covariance();
        let near = |a: f64, b: f64| (a - b).abs() <= tol;
        prop_assert!(near(vxx, sxx) && near(vxy, sxy) && near(vyy, syy),
            "{:?} vs {:?}", [vxx, vxy, vyy], [sxx, sxy, syy]);
        let [axx, axy, ayy] = m.area_covariance();
        prop_assert_eq!([axx, axy, ayy], [vxx + 1.0 / 12.0, vxy, vyy + 1.0 / 12.0]);
        let r = mser::Region {
            polarity: Polarity::Dark,
            level: 0,
            seed: pixels[0],
            area: pixels.len() as u32,
            variation: 0.0,
            bbox: mser::BoundingBox { x_min: 0, y_min: 0, x_max: 0, y_max: 0 },
            moments: m,
        };
        let e = r.ellipse_scaled(k).unwrap();
        prop_assert_eq!(r.ellipse_scaled(2.0).unwrap(), r.ellipse().unwrap());
        prop_assert_eq!((e.u, e.v), (cx, cy));
        // The plane figure's Σ (checked above), scaled: M · k²Σ = I.
        let (s11, s12, s22) = (k * k * axx, k * k * axy, k * k * ayy);
        let eye = [e.a * s11 + e.b * s12, e.a * s12 + e.b * s22, e.b * s11 + e.c * s12, e.b * s12 + e.c * s22];
        let itol = 1e-9;
        prop_assert!(close(eye[0], 1.0, itol) && eye[1].abs() < itol && eye[2].abs() < itol && close(eye[3], 1.0, itol),
            "M·k²Σ = {eye:?} for {e:?}");
        let half_tr = 0.5 * (s11 + s22);
        let disc = (0.25 * (s11 - s22).powi(2) + s12 * s12).sqrt();
        let (l_max, l_min) = e.semi_axes();
        prop_assert!(close(l_max, (half_tr + disc).sqrt(), itol) && close(l_min, (half_tr - disc).sqrt(), itol),
            "{l_max} {l_min} vs {} {}", (half_tr + disc).sqrt(), (half_tr - disc).sqrt());
        let area = std::f64::consts::PI * (s11 * s22 - s12 * s12).sqrt();
        prop_assert!(close(e.area(), area, itol));
        // The long axis: its end, just inside and just outside.
        let (vx, vy) = if s12.abs() > 1e-12 * half_tr {
            let lam = half_tr + disc;
            let (vx, vy) = (s12, lam - s11);
            let nrm = (vx * vx + vy * vy).sqrt();
            (vx / nrm, vy / nrm)
        } else if s11 >= s22 { (1.0, 0.0) } else { (0.0, 1.0) };
        prop_assert!(e.contains(e.u + 0.999 * l_max * vx, e.v + 0.999 * l_max * vy));
        prop_assert!(!e.contains(e.u + 1.001 * l_max * vx, e.v + 1.001 * l_max * vy));
    }
}
