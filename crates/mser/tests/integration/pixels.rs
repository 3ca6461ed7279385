//! `Mser::detect_with_pixels`: the pixel lists are the regions' pixels (as `Region::pixels`
//! floods them) on images of several sizes in turn with one detector (its buffers are reused),
//! and the parallel variant gives the same result; `flood_pixels` from any seed against labelling.

use crate::common;

use mser::{GrayView, Mser, MserParams, Polarities, Region};
use proptest::prelude::*;

fn pattern(w: usize, h: usize, seed: u32) -> Vec<u8> {
    (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f64, (i / w) as f64);
            let v = 128.0
                + 60.0 * (x * 0.21 + seed as f64).sin() * (y * 0.17).cos()
                + 40.0 * ((x + y) * 0.05 + seed as f64 * 0.3).sin();
            v as u8
        })
        .collect()
}

fn sorted(px: &[(u32, u32)]) -> Vec<(u32, u32)> {
    let mut v = px.to_vec();
    v.sort_unstable_by_key(|&(x, y)| (y, x));
    v
}

fn check(img: &GrayView, regions: &[Region], lists: impl Iterator<Item = Vec<(u32, u32)>>) {
    let mut n = 0;
    for (r, px) in regions.iter().zip(lists) {
        assert_eq!(sorted(&px), r.pixels(img).unwrap(), "{r:?}");
        n += 1;
    }
    assert_eq!(n, regions.len());
}

#[test]
fn pixel_lists_equal_flooded_pixels_with_reused_buffers() {
    for polarities in [Polarities::Both, Polarities::Dark, Polarities::Bright] {
        let p = MserParams {
            min_area: 5,
            min_diversity: 0.0,
            polarities,
            ..Default::default()
        };
        let mut det = Mser::new(p.clone()).unwrap();
        let mut total = 0;
        for (seed, (w, h)) in [(90, 70), (40, 33), (120, 50), (90, 70)]
            .into_iter()
            .enumerate()
        {
            let px = pattern(w, h, seed as u32);
            let img = GrayView::packed(&px, w, h).unwrap();
            let plain = det.detect(&img).unwrap();
            let with = det.detect_with_pixels(&img).unwrap();
            assert_eq!(with.regions(), &plain[..]);
            assert_eq!(with.len(), plain.len());
            check(&img, &plain, with.iter().map(|(_, px)| px.to_vec()));
            total += plain.len();
        }
        assert!(total > 20, "{polarities:?}: only {total} regions");
    }
}

#[cfg(feature = "rayon")]
#[test]
fn parallel_pixel_lists_equal_sequential() {
    let p = MserParams {
        min_area: 5,
        min_diversity: 0.0,
        ..Default::default()
    };
    let mut seq = Mser::new(p.clone()).unwrap();
    let mut par = Mser::new(p).unwrap();
    for seed in 0..4 {
        let px = pattern(80, 60, seed);
        let img = GrayView::packed(&px, 80, 60).unwrap();
        let a = seq.detect_with_pixels(&img).unwrap();
        let b = par.detect_with_pixels_parallel(&img).unwrap();
        assert!(!a.is_empty());
        assert_eq!(a.regions(), b.regions());
        for i in 0..a.len() {
            assert_eq!(a.pixels(i), b.pixels(i), "region {i}");
        }
    }
}

/// `Region::translated`: a region found in a window of a larger image and moved by the
/// window's corner is the larger image's region there: the same pixels (flooded on the larger
/// image), contour and moments, for every region that does not touch the window's edges; a
/// move past the `u32` coordinates is an error.
#[test]
fn a_region_found_in_a_window_moved_to_the_image_is_the_images_region() {
    // Discs of several sizes and grey levels on a mid-grey ground, some cut by the window.
    let (w, h) = (90usize, 70usize);
    let px: Vec<u8> = (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as i64, (i / w) as i64);
            let (cx, cy) = (x / 12 * 12 + 6, y / 12 * 12 + 6);
            let k = (x / 12 + 7 * (y / 12)) as u8;
            let r2 = 6 + i64::from(k % 4) * 6;
            if (x - cx).pow(2) + (y - cy).pow(2) <= r2 {
                if k.is_multiple_of(2) {
                    40 + 10 * (k % 5)
                } else {
                    200 + 10 * (k % 5)
                }
            } else {
                128
            }
        })
        .collect();
    let full = GrayView::packed(&px, w, h).unwrap();
    let (x0, y0, ww, wh) = (17usize, 11usize, 60usize, 45usize);
    let window = full.window(x0, y0, ww, wh).unwrap();
    assert_eq!(window.get(3, 2), full.get(x0 + 3, y0 + 2));
    let p = MserParams {
        min_area: 5,
        max_area: 300,
        min_diversity: 0.0,
        polarities: Polarities::Both,
        ..MserParams::default()
    };
    let mut checked = 0;
    for r in mser::detect(&window, &p).unwrap() {
        let b = r.bbox;
        if b.x_min == 0 || b.y_min == 0 || b.x_max + 1 == ww as u32 || b.y_max + 1 == wh as u32 {
            continue;
        }
        let moved = r.translated(x0 as u32, y0 as u32).unwrap();
        let shift = |v: Vec<(u32, u32)>| -> Vec<(u32, u32)> {
            v.into_iter()
                .map(|(x, y)| (x + x0 as u32, y + y0 as u32))
                .collect()
        };
        let pixels = moved.pixels(&full).unwrap();
        assert_eq!(pixels, sorted(&shift(r.pixels(&window).unwrap())), "{r:?}");
        assert_eq!(
            moved.contour(&full).unwrap(),
            shift(r.contour(&window).unwrap())
        );
        assert_eq!(moved.moments, mser::Moments::of_pixels(&pixels).unwrap());
        assert_eq!(
            (moved.level, moved.area, moved.variation, moved.polarity),
            (r.level, r.area, r.variation, r.polarity)
        );
        checked += 1;
    }
    assert!(checked >= 10, "{checked} regions inside the window");
    let r = mser::detect(&window, &p).unwrap().remove(0);
    assert!(matches!(
        r.translated(u32::MAX, 0),
        Err(mser::MserError::InvalidParameter { name: "offset", .. })
    ));
}

/// The detector of the `RegionsWithPixels` tests: regions of at least 5 pixels, the rest
/// OpenCV's defaults.
fn detector() -> Mser {
    Mser::new(MserParams {
        min_area: 5,
        ..Default::default()
    })
    .unwrap()
}

/// `RegionsWithPixels::into_regions` gives `detect`'s regions and `is_empty` agrees with them.
#[test]
fn regions_with_pixels_release_the_regions_they_hold() {
    let px = pattern(60, 40, 7);
    let img = GrayView::packed(&px, 60, 40).unwrap();
    let mut det = detector();
    let plain = det.detect(&img).unwrap();
    assert!(!plain.is_empty());
    let with = det.detect_with_pixels(&img).unwrap();
    assert!(!with.is_empty());
    assert_eq!(with.into_regions(), plain);
    // A flat image has no region.
    let flat = vec![9u8; 100];
    let flat = GrayView::packed(&flat, 10, 10).unwrap();
    let none = det.detect_with_pixels(&flat).unwrap();
    assert_eq!(none.len(), 0);
    assert!(none.is_empty() && none.into_regions().is_empty());
}

/// `RegionsWithPixels::pixels(i)` for `i >= len()` panics like slice indexing instead of
/// returning another region's run.
#[test]
#[should_panic(expected = "out of bounds")]
fn regions_with_pixels_refuse_an_index_past_the_end() {
    let px = pattern(60, 40, 7);
    let img = GrayView::packed(&px, 60, 40).unwrap();
    let mut det = detector();
    let with = det.detect_with_pixels(&img).unwrap();
    assert!(!with.is_empty());
    let _ = with.pixels(with.len());
}

proptest! {
    #![proptest_config(crate::seeded(256))]

    /// `flood_pixels` from any pixel of a component (not only its first in raster order), at any
    /// level that pixel passes, both polarities, with the component's own box, the whole image or
    /// a box reaching far outside it (clipped), on a strided view: exactly the component that
    /// labelling the whole thresholded image gives, in raster order.
    #[test]
    fn flood_pixels_from_any_seed_is_the_labelled_component(
        (w, h, px) in (1usize..=9, 1usize..=9).prop_flat_map(|(w, h)| {
            (Just(w), Just(h), proptest::collection::vec(prop_oneof![Just(0u8), Just(90), Just(160), Just(255)], w * h))
        }),
        at in any::<proptest::sample::Index>(),
        bright in any::<bool>(),
        bump in any::<u8>(),
        boxing in 0u8..3,
        pad in 0usize..3,
    ) {
        use mser::{BoundingBox, Polarity};
        let q = at.index(w * h);
        let seed = ((q % w) as u32, (q / w) as u32);
        let polarity = if bright { Polarity::Bright } else { Polarity::Dark };
        let level = match polarity {
            Polarity::Dark => px[q].saturating_add(bump % 100),
            Polarity::Bright => px[q].saturating_sub(bump % 100),
        };
        let want = common::component(&px, w, h, seed, level, polarity);
        let bbox = match boxing {
            0 => BoundingBox {
                x_min: want.iter().map(|p| p.0).min().unwrap(),
                y_min: want[0].1,
                x_max: want.iter().map(|p| p.0).max().unwrap(),
                y_max: want[want.len() - 1].1,
            },
            1 => BoundingBox { x_min: 0, y_min: 0, x_max: w as u32 - 1, y_max: h as u32 - 1 },
            _ => BoundingBox { x_min: 0, y_min: 0, x_max: u32::MAX, y_max: u32::MAX },
        };
        // The same pixels behind a stride, with bytes that would join the component if read.
        let stride = w + pad;
        let mut strided = vec![if bright { 255u8 } else { 0 }; stride * h];
        for y in 0..h {
            strided[y * stride..][..w].copy_from_slice(&px[y * w..][..w]);
        }
        let img = GrayView::new(&strided, w, h, stride).unwrap();
        prop_assert_eq!(mser::flood_pixels(&img, seed, level, polarity, bbox).unwrap(), want);
    }
}
