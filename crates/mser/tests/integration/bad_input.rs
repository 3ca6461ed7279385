//! Bad input gives typed errors or empty results, never a panic; a fuzz-style proptest runs the
//! detector, the pixel lists and the contour tracer on arbitrary bytes, sizes and parameters.

use crate::common;

use mser::{GrayView, Mser, MserError, MserParams, Polarities, Variation, detect};
use proptest::prelude::*;

#[test]
fn empty_images_are_rejected() {
    assert!(matches!(
        GrayView::new(&[], 0, 0, 0),
        Err(MserError::EmptyImage { .. })
    ));
    assert!(matches!(
        GrayView::new(&[1, 2], 0, 2, 1),
        Err(MserError::EmptyImage { .. })
    ));
    assert!(matches!(
        GrayView::new(&[1, 2], 2, 0, 2),
        Err(MserError::EmptyImage { .. })
    ));
}

#[test]
fn stride_smaller_than_width_is_rejected() {
    let px = [0u8; 16];
    assert!(matches!(
        GrayView::new(&px, 4, 4, 3),
        Err(MserError::StrideTooSmall {
            stride: 3,
            width: 4
        })
    ));
}

#[test]
fn short_buffer_is_rejected() {
    let px = [0u8; 15];
    assert!(matches!(
        GrayView::new(&px, 4, 4, 4),
        Err(MserError::BufferTooSmall {
            got: 15,
            needed: 16
        })
    ));
    // The last row needs only `width` bytes, not `stride`.
    assert!(GrayView::new(&px, 3, 4, 4).is_ok());
}

#[test]
fn huge_dimensions_are_rejected_without_allocating() {
    let px = [0u8; 4];
    assert!(GrayView::new(&px, usize::MAX, 2, usize::MAX).is_err());
    assert!(GrayView::new(&px, 1, usize::MAX / 2, 1).is_err());
}

#[test]
fn one_pixel_and_constant_images_give_no_regions() {
    let p = MserParams {
        min_area: 1,
        ..Default::default()
    };
    let one = GrayView::packed(&[77], 1, 1).unwrap();
    assert!(detect(&one, &p).unwrap().is_empty());
    let flat = vec![128u8; 50 * 40];
    let img = GrayView::packed(&flat, 50, 40).unwrap();
    for variation in [Variation::Symmetric, Variation::Upward] {
        let p = MserParams {
            min_area: 1,
            max_area: usize::MAX,
            variation,
            ..Default::default()
        };
        assert!(detect(&img, &p).unwrap().is_empty(), "{variation:?}");
    }
}

#[test]
fn contradictory_parameters_are_rejected() {
    let cases = [
        MserParams {
            min_area: 100,
            max_area: 99,
            ..Default::default()
        },
        MserParams {
            delta: 0,
            ..Default::default()
        },
        MserParams {
            min_area: 0,
            ..Default::default()
        },
        MserParams {
            max_variation: f64::NAN,
            ..Default::default()
        },
        MserParams {
            max_variation: -0.1,
            ..Default::default()
        },
        MserParams {
            min_diversity: 1.5,
            ..Default::default()
        },
        MserParams {
            min_diversity: f64::NAN,
            ..Default::default()
        },
    ];
    for p in cases {
        let err = Mser::new(p.clone()).unwrap_err();
        assert!(
            matches!(err, MserError::InvalidParameter { .. }),
            "{p:?}: {err}"
        );
    }
}

/// A `w × h` image, bright but for a dark square over `5..12` on both axes.
fn dark_square(w: usize, h: usize) -> Vec<u8> {
    let mut px = vec![200u8; w * h];
    for y in 5..12 {
        for x in 5..12 {
            px[y * w + x] = 10;
        }
    }
    px
}

/// The parameters that find the square of [`dark_square`], and its region.
fn square_region(img: &GrayView) -> (MserParams, mser::Region) {
    let p = MserParams {
        min_area: 10,
        ..Default::default()
    };
    let r = detect(img, &p).unwrap().remove(0);
    (p, r)
}

#[test]
fn regions_refuse_a_foreign_image() {
    let px = dark_square(20, 20);
    let img = GrayView::packed(&px, 20, 20).unwrap();
    let (_, r) = square_region(&img);
    let other = vec![100u8; 4];
    let small = GrayView::packed(&other, 2, 2).unwrap();
    assert!(matches!(
        r.contour(&small),
        Err(MserError::RegionImageMismatch { .. })
    ));
    assert!(matches!(
        r.pixels(&small),
        Err(MserError::RegionImageMismatch { .. })
    ));
    let flat = vec![0u8; 20 * 20];
    let flat = GrayView::packed(&flat, 20, 20).unwrap();
    assert!(r.pixels(&flat).is_err());
    assert!(r.contour(&flat).is_err());
}

fn any_params() -> impl Strategy<Value = MserParams> {
    (
        0u8..=20,
        0usize..=40,
        0usize..=3000,
        -0.1f64..3.0,
        -0.1f64..1.1,
        any::<u8>(),
    )
        .prop_map(
            |(delta, min_area, max_area, max_variation, min_diversity, sel)| MserParams {
                delta,
                min_area,
                max_area,
                max_variation,
                min_diversity,
                polarities: [Polarities::Dark, Polarities::Bright, Polarities::Both]
                    [sel as usize % 3],
                variation: if sel & 4 == 0 {
                    Variation::Symmetric
                } else {
                    Variation::Upward
                },
            },
        )
}

proptest! {
    #![proptest_config(crate::seeded(400))]

    #[test]
    fn fuzz_detector_and_contours(
        (w, h, pad, bytes) in (0usize..48, 0usize..48, 0usize..5).prop_flat_map(|(w, h, pad)| {
            let n = (w + pad) * h;
            // Mostly complete buffers, sometimes one byte short.
            (Just(w), Just(h), Just(pad), proptest::collection::vec(any::<u8>(), n.saturating_sub(1)..=n))
        }),
        p in any_params(),
    ) {
        let stride = w + pad;
        let Ok(img) = GrayView::new(&bytes, w, h, stride) else { return Ok(()); };
        let Ok(mut det) = Mser::new(p) else { return Ok(()); };
        let regions = det.detect(&img).unwrap();
        for r in &regions {
            let pixels = r.pixels(&img).unwrap();
            prop_assert_eq!(pixels.len(), r.area as usize);
            let c = r.contour(&img).unwrap();
            common::check_contour(&c, &pixels, w, h);
            let e = r.ellipse().unwrap();
            prop_assert!(e.a > 0.0 && e.a * e.c - e.b * e.b > 0.0);
        }
    }
}

/// Issue 24 #3: `flood_pixels` with a seed outside the image (or one that does not pass the
/// threshold) is a typed error, not a panic.
#[test]
fn flood_pixels_refuses_seeds_outside_the_image() {
    use mser::{BoundingBox, Polarity, flood_pixels};
    let px = vec![10u8; 6 * 4];
    let img = GrayView::packed(&px, 6, 4).unwrap();
    let bbox = BoundingBox {
        x_min: 0,
        y_min: 0,
        x_max: 5,
        y_max: 3,
    };
    for seed in [(6, 0), (0, 4), (u32::MAX, u32::MAX), (100, 1)] {
        assert!(
            matches!(
                flood_pixels(&img, seed, 10, Polarity::Dark, bbox),
                Err(MserError::RegionImageMismatch { .. })
            ),
            "{seed:?}"
        );
    }
    assert!(matches!(
        flood_pixels(&img, (1, 1), 9, Polarity::Dark, bbox),
        Err(MserError::RegionImageMismatch { .. })
    ));
    // A box larger than the image is clipped; the whole image is one component.
    let huge = BoundingBox {
        x_min: 0,
        y_min: 0,
        x_max: u32::MAX,
        y_max: u32::MAX,
    };
    assert_eq!(
        flood_pixels(&img, (2, 3), 10, Polarity::Dark, huge)
            .unwrap()
            .len(),
        24
    );
}

/// `trace_outer_contour` checks its seed as `Region::contour` does (it used to return a
/// one-point "contour" outside the image, or part of a boundary from a seed that is not the
/// first pixel).
#[test]
fn trace_outer_contour_refuses_bad_seeds() {
    use mser::{Polarity, trace_outer_contour};
    let (w, h) = (12, 10);
    let mut px = vec![200u8; w * h];
    for y in 3..7 {
        for x in 2..9 {
            px[y * w + x] = 10;
        }
    }
    let img = GrayView::packed(&px, w, h).unwrap();
    for (seed, level) in [
        ((12, 0), 10),       // outside
        ((u32::MAX, 3), 10), // far outside
        ((0, 0), 10),        // does not pass the threshold
        ((4, 4), 10),        // inside, but not the first pixel
        ((3, 3), 10),        // first row, but its left neighbour is in the region
    ] {
        assert!(
            matches!(
                trace_outer_contour(&img, seed, level, Polarity::Dark),
                Err(MserError::RegionImageMismatch { .. })
            ),
            "{seed:?}"
        );
    }
    let c = trace_outer_contour(&img, (2, 3), 10, Polarity::Dark).unwrap();
    assert_eq!((c.len(), c[0]), (2 * 7 + 2 * 4 - 4, (2, 3)));
}

/// `variations_by_thresholds` validates its parameters like every detection entry point (it
/// used to compute with Δ = 0).
#[test]
fn variations_by_thresholds_refuses_invalid_parameters() {
    let px = dark_square(20, 20);
    let img = GrayView::packed(&px, 20, 20).unwrap();
    let (p, r) = square_region(&img);
    assert!(mser::variations_by_thresholds(&img, &r, &p).is_ok());
    for bad in [
        MserParams { delta: 0, ..p },
        MserParams {
            max_variation: f64::NAN,
            ..p
        },
    ] {
        assert!(matches!(
            mser::variations_by_thresholds(&img, &r, &bad),
            Err(MserError::InvalidParameter { .. })
        ));
    }
}

/// `variations_by_thresholds` refuses a region whose seed pixel does not pass its level (it
/// used to flood from that seed anyway and report the variations of a set that is no extremal
/// region, whenever the set happened to have the region's area).
#[test]
fn variations_by_thresholds_refuses_a_seed_above_the_level() {
    let px = dark_square(20, 20);
    let img = GrayView::packed(&px, 20, 20).unwrap();
    let (p, mut r) = square_region(&img);
    // The square's pixels are 10, so at level 9 none passes; a fill that took the seed anyway
    // found the seed alone (its neighbours are 10 and 200), the 1 pixel claimed here.
    r.level = 9;
    r.area = 1;
    let err = mser::variations_by_thresholds(&img, &r, &p).unwrap_err();
    assert!(
        matches!(&err, MserError::InvalidParameter { name: "region", reason } if reason.contains("does not pass")),
        "{err:?}"
    );
    // Bright polarity: a dark seed never passes a bright level.
    r.polarity = mser::Polarity::Bright;
    r.level = 200;
    assert!(matches!(
        mser::variations_by_thresholds(&img, &r, &p),
        Err(MserError::InvalidParameter { name: "region", .. })
    ));
}

/// `GrayView::window` of zero pixels is an `EmptyImage` wherever it starts; at the far corner
/// (one past the last column and row) it used to slice the buffer past its end and panic.
#[test]
fn empty_windows_at_the_far_edge_are_errors() {
    let px: Vec<u8> = (0..12).collect();
    for (img, stride) in [
        (GrayView::packed(&px, 4, 3).unwrap(), 4),
        (GrayView::new(&px, 3, 3, 4).unwrap(), 4),
    ] {
        let (w, h) = (img.width(), img.height());
        for (x0, y0, ww, wh) in [
            (w, h, 0, 0),
            (w, h, 0, 1),
            (w, h, 1, 0),
            (0, h, 1, 0),
            (w, 0, 0, 1),
        ] {
            assert!(
                matches!(
                    img.window(x0, y0, ww, wh),
                    Err(MserError::EmptyImage { .. })
                ),
                "stride {stride}: {ww}×{wh} at ({x0}, {y0})"
            );
        }
        // One pixel past the edge is outside; the last pixel is a window.
        assert!(matches!(
            img.window(w, h - 1, 1, 1),
            Err(MserError::InvalidParameter { name: "window", .. })
        ));
        assert_eq!(
            img.window(w - 1, h - 1, 1, 1).unwrap().get(0, 0),
            img.get(w - 1, h - 1)
        );
    }
}

/// `Moments::of_pixels` refuses sums beyond `u64` (it used to panic with an overflow in a
/// debug build and wrap silently in a release build).
#[test]
fn moments_of_pixels_refuse_overflowing_sums() {
    use mser::Moments;
    for px in [
        vec![(u32::MAX, u32::MAX); 2],
        vec![(u32::MAX, 0), (u32::MAX, 0)],
        vec![(0, u32::MAX), (1, u32::MAX)],
    ] {
        assert!(matches!(
            Moments::of_pixels(&px),
            Err(MserError::InvalidParameter { name: "pixels", .. })
        ));
    }
    // One such pixel still fits: (2^32 − 1)² < 2^64.
    let one = Moments::of_pixels(&[(u32::MAX, u32::MAX)]).unwrap();
    assert_eq!((one.n, one.sxx), (1, u64::from(u32::MAX).pow(2)));
    let m = Moments::of_pixels(&[(1, 2), (3, 4)]).unwrap();
    assert_eq!(
        (m.n, m.sx, m.sy, m.sxx, m.sxy, m.syy),
        (2, 4, 6, 10, 14, 20)
    );
}

/// A hand-built region with no pixels used to panic in `ellipse()`; one whose moments give a
/// covariance that is not positive definite was blamed on the scale `k`.
#[test]
fn regions_without_an_ellipse_are_errors() {
    use mser::{BoundingBox, Ellipse, Moments, Polarity, Region};
    let region = |moments: Moments| Region {
        polarity: Polarity::Dark,
        level: 10,
        seed: (0, 0),
        area: moments.n as u32,
        variation: 0.0,
        bbox: BoundingBox {
            x_min: 0,
            y_min: 0,
            x_max: 0,
            y_max: 0,
        },
        moments,
    };
    let empty = region(Moments::of_pixels(&[]).unwrap());
    assert_eq!(empty.moments.n, 0);
    // Σx² far below (Σx)²/n: a negative variance.
    let impossible = region(Moments {
        n: 2,
        sx: 100,
        sy: 100,
        sxx: 1,
        sxy: 0,
        syy: 1,
    });
    for r in [&empty, &impossible] {
        assert!(matches!(
            r.ellipse(),
            Err(MserError::InvalidParameter { name: "region", .. })
        ));
        assert!(matches!(
            r.ellipse_scaled(1.0),
            Err(MserError::InvalidParameter { name: "region", .. })
        ));
    }
    let one = region(Moments::of_pixels(&[(3, 4)]).unwrap());
    let e = one.ellipse().unwrap();
    assert_eq!((e.u, e.v), (3.0, 4.0));
    // A NaN or infinite centre used to give an ellipse with that centre.
    for (u, v) in [(f64::NAN, 1.0), (1.0, f64::INFINITY)] {
        assert_eq!(Ellipse::from_covariance(u, v, [1.0, 0.0, 1.0], 1.0), None);
    }
    assert!(Ellipse::from_covariance(1.0, 2.0, [1.0, 0.0, 1.0], 1.0).is_some());
}

/// An image whose padded size exceeds the detector's 2^28 pixels, or whose size overflows
/// `usize`, is an `ImageTooLarge` naming its size (not just any error). The buffer is
/// zero-filled memory that is never touched, so the test costs nothing.
#[test]
fn oversized_images_are_image_too_large() {
    let w = 1usize << 27;
    let px = vec![0u8; w];
    // One row of 2^27 pixels: (1 + 2) padded rows of at least 2^27 + 1 bytes > 2^28.
    assert!(matches!(
        GrayView::new(&px, w, 1, w),
        Err(MserError::ImageTooLarge { width, height: 1 }) if width == w
    ));
    // Just below the limit: (w + padding) · 3 ≤ 2^28.
    let ok = (1usize << 28) / 3 - 64;
    assert!(GrayView::new(&px[..ok], ok, 1, ok).is_ok());
    // `stride · (height − 1) + width` overflows usize.
    assert!(matches!(
        GrayView::new(&px[..4], usize::MAX, 2, usize::MAX),
        Err(MserError::ImageTooLarge {
            width: usize::MAX,
            height: 2
        })
    ));
}

/// `GrayView::get` panics outside the image, also in the stride padding of a row, which the
/// buffer holds but the image does not.
#[test]
#[should_panic(expected = "outside the image")]
fn get_outside_the_width_panics_even_inside_the_stride() {
    let px = [1u8, 2, 3, 99, 4, 5, 6, 99];
    let img = GrayView::new(&px, 3, 2, 4).unwrap();
    assert_eq!(img.get(2, 0), 3);
    img.get(3, 0);
}

/// Audit: `GrayView::row` documents a panic for `y >= height` but used to return whatever bytes
/// the buffer held there (the next rows of a longer buffer, of a strided view's padding rows, of
/// the image a window was cut from) as if they were a row of the image.
#[test]
fn row_past_the_height_panics_instead_of_reading_beyond_the_image() {
    let px: Vec<u8> = (0..16).collect();
    // 3 × 2 pixels, stride 4: the buffer holds two more rows than the image.
    let strided = GrayView::new(&px, 3, 2, 4).unwrap();
    let full = GrayView::packed(&px, 4, 4).unwrap();
    // One row of the 4 × 4 image; its buffer continues into rows 1..4 of `full`.
    let window = full.window(1, 0, 2, 1).unwrap();
    assert_eq!(strided.row(1), &[4, 5, 6]);
    assert_eq!(window.row(0), &[1, 2]);
    for (img, y) in [
        (strided, 2),
        (strided, 3),
        (window, 1),
        (window, 3),
        (strided, usize::MAX),
    ] {
        let got = std::panic::catch_unwind(|| img.row(y).to_vec());
        let msg = match &got {
            Ok(bytes) => panic!("row {y} of a {}-row image gave {bytes:?}", img.height()),
            Err(e) => e
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| e.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default(),
        };
        assert!(msg.contains("outside the image"), "row {y}: {msg}");
    }
}

/// A dark region (grey 0) with a hole of two diagonal pixels (grey 9), 5 × 5 pixels. Pixel
/// (2, 3) lies below one hole pixel and right of the other, so both its upper and its left
/// neighbour fail the threshold, though it is not the region's first pixel in raster order.
fn ring_with_diagonal_hole() -> Vec<u8> {
    let mut px = vec![0u8; 5 * 5];
    px[2 * 5 + 2] = 9;
    px[3 * 5 + 1] = 9;
    px
}

/// Audit: `trace_outer_contour` (and `Region::contour`) from a seed whose upper and left
/// neighbours fail the threshold but which is not the component's first pixel in raster order
/// used to return a chain without an error: the boundary of a hole (which the contour never
/// includes), or the outer boundary started elsewhere than at the first pixel.
#[test]
fn contours_refuse_seeds_that_are_not_the_first_pixel() {
    use mser::{BoundingBox, Moments, Polarity, Region, trace_outer_contour};
    let px = ring_with_diagonal_hole();
    let img = GrayView::packed(&px, 5, 5).unwrap();
    // The true first pixel gives the outer boundary: the 16 border pixels.
    let outer = trace_outer_contour(&img, (0, 0), 0, Polarity::Dark).unwrap();
    assert_eq!((outer.len(), outer[0]), (16, (0, 0)));
    // Below the hole: its chain would run around the hole.
    let err = trace_outer_contour(&img, (2, 3), 0, Polarity::Dark);
    assert!(
        matches!(err, Err(MserError::RegionImageMismatch { .. })),
        "{err:?}"
    );
    let pixels: Vec<(u32, u32)> = (0..25)
        .filter(|&i| px[i] == 0)
        .map(|i| ((i % 5) as u32, (i / 5) as u32))
        .collect();
    let region = Region {
        polarity: Polarity::Dark,
        level: 0,
        seed: (2, 3),
        area: pixels.len() as u32,
        variation: 0.0,
        bbox: BoundingBox {
            x_min: 0,
            y_min: 0,
            x_max: 4,
            y_max: 4,
        },
        moments: Moments::of_pixels(&pixels).unwrap(),
    };
    assert!(matches!(
        region.contour(&img),
        Err(MserError::RegionImageMismatch { .. })
    ));
    assert!(region.contour_f64(&img).is_err());
    // A U: its right arm's top pixel (2, 0) has no region pixel above or left of it, but
    // (0, 0) comes first; the chain from (2, 0) is the outer boundary started elsewhere.
    let u = [0u8, 9, 0, 0, 0, 0];
    let img = GrayView::packed(&u, 3, 2).unwrap();
    assert!(trace_outer_contour(&img, (0, 0), 0, Polarity::Dark).is_ok());
    assert!(matches!(
        trace_outer_contour(&img, (2, 0), 0, Polarity::Dark),
        Err(MserError::RegionImageMismatch { .. })
    ));
}

/// Audit: `flood_pixels` with a box that cuts the component (it must contain it) used to
/// return the part inside the box as if it were the whole component.
#[test]
fn flood_pixels_refuses_a_box_that_cuts_the_component() {
    use mser::{BoundingBox, Polarity, flood_pixels};
    // A dark 4 × 2 bar at x 1..5, y 1..3 of a bright 6 × 4 image.
    let mut px = vec![200u8; 6 * 4];
    for y in 1..3 {
        for x in 1..5 {
            px[y * 6 + x] = 10;
        }
    }
    let img = GrayView::packed(&px, 6, 4).unwrap();
    let exact = BoundingBox {
        x_min: 1,
        y_min: 1,
        x_max: 4,
        y_max: 2,
    };
    assert_eq!(
        flood_pixels(&img, (1, 1), 10, Polarity::Dark, exact)
            .unwrap()
            .len(),
        8
    );
    for cut in [
        BoundingBox { x_max: 3, ..exact },
        BoundingBox { x_min: 2, ..exact },
        BoundingBox { y_max: 1, ..exact },
        BoundingBox { y_min: 2, ..exact },
        BoundingBox {
            x_min: 1,
            y_min: 1,
            x_max: 1,
            y_max: 1,
        },
    ] {
        // The box's top-left pixel is in the component (a seed outside the box widens it).
        let seed = (cut.x_min, cut.y_min);
        let got = flood_pixels(&img, seed, 10, Polarity::Dark, cut);
        assert!(
            matches!(got, Err(MserError::RegionImageMismatch { .. })),
            "{cut:?} from {seed:?}: {got:?}"
        );
    }
    // A box widened to a seed outside it still contains the component: no error.
    let left = BoundingBox { x_max: 3, ..exact };
    assert_eq!(
        flood_pixels(&img, (4, 2), 10, Polarity::Dark, left)
            .unwrap()
            .len(),
        8
    );
}
