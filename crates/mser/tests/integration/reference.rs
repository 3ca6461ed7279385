//! The fast detector against the brute-force reference (threshold at every level, label
//! components, apply the definitions literally) on random small images.

use crate::common;

use mser::{GrayView, Mser, MserParams, Polarities, Variation};
use proptest::prelude::*;

fn params_strategy() -> impl Strategy<Value = MserParams> {
    (
        1u8..=6,
        1usize..=8,
        0usize..=150,
        prop_oneof![Just(0.1), Just(0.25), Just(0.5), Just(2.0), Just(100.0)],
        prop_oneof![Just(0.0), Just(0.2), Just(0.5), Just(1.0)],
        prop_oneof![Just(Variation::Symmetric), Just(Variation::Upward)],
    )
        .prop_map(
            |(delta, min_area, extra, max_variation, min_diversity, variation)| MserParams {
                delta,
                min_area,
                max_area: min_area + extra,
                max_variation,
                min_diversity,
                polarities: Polarities::Both,
                variation,
            },
        )
}

/// Images with few grey values (many plateaus and ties) or the full range.
fn image_strategy() -> impl Strategy<Value = (usize, usize, Vec<u8>)> {
    (
        1usize..=11,
        1usize..=11,
        prop_oneof![Just(4u8), Just(12u8), Just(0u8)],
    )
        .prop_flat_map(|(w, h, k)| {
            let px = if k == 0 {
                proptest::collection::vec(any::<u8>(), w * h).boxed()
            } else {
                proptest::collection::vec((0..k).prop_map(move |v| v * (255 / k)), w * h).boxed()
            };
            (Just(w), Just(h), px)
        })
}

proptest! {
    #![proptest_config(crate::seeded(2000))]

    #[test]
    fn fast_detector_equals_brute_force_reference((w, h, px) in image_strategy(), p in params_strategy()) {
        let img = GrayView::packed(&px, w, h).unwrap();
        let got = Mser::new(p.clone()).unwrap().detect(&img).unwrap();
        let want = common::reference(&px, w, h, &p);
        let got_sets: Vec<_> = got
            .iter()
            .map(|r| (r.polarity, r.level, r.pixels(&img).unwrap()))
            .collect();
        prop_assert_eq!(&got_sets, &want);
        // The one-pass pixel lists: the same regions, each with exactly the reference's pixels.
        let mut det = Mser::new(p.clone()).unwrap();
        let with = det.detect_with_pixels(&img).unwrap();
        prop_assert_eq!(with.regions(), &got[..]);
        for (i, (_, _, pixels)) in want.iter().enumerate() {
            let mut mine = with.pixels(i).to_vec();
            mine.sort_unstable_by_key(|&(x, y)| (y, x));
            prop_assert_eq!(&mine, pixels);
        }
        for (r, (_, _, pixels)) in got.iter().zip(&want) {
            prop_assert_eq!(r.area as usize, pixels.len());
            prop_assert_eq!(r.moments, mser::Moments::of_pixels(pixels).unwrap());
            prop_assert_eq!(r.seed, pixels[0]);
            let xs = pixels.iter().map(|p| p.0);
            let ys = pixels.iter().map(|p| p.1);
            prop_assert_eq!(
                (r.bbox.x_min, r.bbox.x_max, r.bbox.y_min, r.bbox.y_max),
                (xs.clone().min().unwrap(), xs.max().unwrap(), ys.clone().min().unwrap(), ys.max().unwrap())
            );
            common::check_contour(&r.contour(&img).unwrap(), pixels, w, h);
            // The variations recomputed by thresholding (the OpenCV tie witness): the region's
            // equals the detector's, and its parent's is not smaller (selection rule 2).
            let v = mser::variations_by_thresholds(&img, r, &p).unwrap();
            prop_assert_eq!(v.region.value(), r.variation);
            prop_assert_eq!(v.region.den, r.area as u64);
            prop_assert!(v.parent_area > r.area as u64);
            prop_assert!(v.parent.value() >= r.variation);
        }
    }
}

/// Parameters at the edges of what `MserParams::validate` allows: Δ up to 255 (windows past
/// both ends of the grey scale), `max_area` unlimited, `max_variation` 0 or huge, `min_diversity`
/// 0 or 1, and one polarity alone.
fn edge_params_strategy() -> impl Strategy<Value = MserParams> {
    (
        prop_oneof![1u8..=3, 100u8..=255, Just(255u8)],
        1usize..=4,
        prop_oneof![(0usize..=40).prop_map(Some), Just(None)],
        prop_oneof![Just(0.0), Just(0.5), Just(f64::MAX)],
        prop_oneof![Just(0.0), Just(0.5), Just(1.0)],
        prop_oneof![
            Just(Polarities::Dark),
            Just(Polarities::Bright),
            Just(Polarities::Both)
        ],
        prop_oneof![Just(Variation::Symmetric), Just(Variation::Upward)],
    )
        .prop_map(
            |(delta, min_area, extra, max_variation, min_diversity, polarities, variation)| {
                MserParams {
                    delta,
                    min_area,
                    max_area: extra.map_or(usize::MAX, |e| min_area + e),
                    max_variation,
                    min_diversity,
                    polarities,
                    variation,
                }
            },
        )
}

/// A `w × h` image (1 to 9 pixels each way, so single rows and columns) with grey values at the
/// ends of the scale (0 and 255 walls, which the flood treats apart), three levels, or any
/// byte; placed at `(x0, y0)` in a larger buffer of random bytes, so that it is a window with a
/// stride larger than its width and foreign bytes on every side.
#[allow(clippy::type_complexity)]
fn view_strategy() -> impl Strategy<Value = (usize, usize, Vec<u8>, usize, usize, usize, Vec<u8>)> {
    (
        1usize..=9,
        1usize..=9,
        0usize..=3,
        0usize..=2,
        0usize..=3,
        0u8..3,
    )
        .prop_flat_map(|(w, h, x0, y0, pad, kind)| {
            let px = match kind {
                0 => proptest::collection::vec(
                    prop_oneof![Just(0u8), Just(1), Just(128), Just(254), Just(255)],
                    w * h,
                )
                .boxed(),
                1 => proptest::collection::vec(prop_oneof![Just(40u8), Just(41), Just(200)], w * h)
                    .boxed(),
                _ => proptest::collection::vec(any::<u8>(), w * h).boxed(),
            };
            let outer_w = x0 + w + pad;
            let outer_h = y0 + h + 1;
            (
                Just(w),
                Just(h),
                px,
                Just(x0),
                Just(y0),
                Just(outer_w),
                proptest::collection::vec(any::<u8>(), outer_w * outer_h),
            )
        })
}

proptest! {
    #![proptest_config(crate::seeded(192))]

    /// The unusual inputs the docs allow, against the brute-force reference: windows of a
    /// strided buffer, 0/255 walls, Δ up to 255, unlimited `max_area`, one polarity alone, a
    /// detector whose buffers were last used on an image of another size. Also
    /// every region's variation as the reference's exact ratio, and `variations_by_thresholds`'
    /// region and parent (level, area, variation) as the reference's tree has them.
    #[test]
    fn unusual_inputs_equal_brute_force_reference(
        (w, h, px, x0, y0, outer_w, mut outer) in view_strategy(),
        p in edge_params_strategy(),
    ) {
        for y in 0..h {
            outer[(y0 + y) * outer_w + x0..][..w].copy_from_slice(&px[y * w..][..w]);
        }
        let outer_h = outer.len() / outer_w;
        let big = GrayView::packed(&outer, outer_w, outer_h).unwrap();
        let img = big.window(x0, y0, w, h).unwrap();
        // One detector, its buffers first used on the larger buffer (another size and content).
        let mut det = Mser::new(p.clone()).unwrap();
        det.detect(&big).unwrap();
        let got = det.detect(&img).unwrap();
        let want = common::reference_detail(&px, w, h, &p);
        let xy = |s: &[usize]| -> Vec<(u32, u32)> {
            s.iter().map(|&q| ((q % w) as u32, (q / w) as u32)).collect()
        };
        let got_sets: Vec<_> = got
            .iter()
            .map(|r| (r.polarity, r.level, r.pixels(&img).unwrap()))
            .collect();
        let want_sets: Vec<_> = want.iter().map(|d| (d.polarity, d.level, xy(&d.pixels))).collect();
        prop_assert_eq!(&got_sets, &want_sets);
        det.detect_with_pixels(&big).unwrap();
        let with = det.detect_with_pixels(&img).unwrap();
        prop_assert_eq!(with.regions(), &got[..]);
        for (i, d) in want.iter().enumerate() {
            let mut mine = with.pixels(i).to_vec();
            mine.sort_unstable_by_key(|&(x, y)| (y, x));
            prop_assert_eq!(mine, xy(&d.pixels));
        }
        for (r, d) in got.iter().zip(&want) {
            let pixels = xy(&d.pixels);
            prop_assert_eq!(r.moments, mser::Moments::of_pixels(&pixels).unwrap());
            prop_assert_eq!(r.seed, pixels[0]);
            prop_assert_eq!(r.variation.to_bits(), (d.var.0 as f64 / d.var.1 as f64).to_bits());
            let v = mser::variations_by_thresholds(&img, r, &p).unwrap();
            prop_assert_eq!((v.region.num, v.region.den), d.var);
            prop_assert_eq!((v.parent_level, v.parent_area), (d.parent_level, d.parent_area));
            prop_assert_eq!((v.parent.num, v.parent.den), d.parent_var);
            common::check_contour(&r.contour(&img).unwrap(), &pixels, w, h);
        }
    }
}

/// The parameters the fixtures use (OpenCV's defaults and the thesis setting), which need
/// regions of 50–60 pixels and more, on images large enough to have them (blobs with soft
/// edges, nested and touching the border, with noise), against the reference: regions,
/// pixels, variations and the parents' variations.
#[test]
fn fixture_parameters_on_blob_images_equal_brute_force_reference() {
    let (w, h) = (44usize, 31usize);
    let mut found = 0;
    for seed in 0..3u32 {
        let mut state = 0x9e37_79b9u32 ^ seed;
        let blobs = [
            (10.0 + seed as f64, 9.0, 6.0, 40.0),
            (30.0, 14.0 + seed as f64, 9.0, 210.0),
            (31.0, 15.0, 3.5, 90.0),
            (3.0, 27.0, 7.0, 20.0 + 30.0 * seed as f64),
        ];
        let px: Vec<u8> = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f64, (i / w) as f64);
                let mut v = 130.0;
                for &(cx, cy, r, g) in &blobs {
                    let d = ((x - cx).powi(2) + (y - cy).powi(2)).sqrt();
                    // A soft edge over two pixels.
                    let t = ((r + 1.0 - d) / 2.0).clamp(0.0, 1.0);
                    v += t * (g - v);
                }
                state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                (v + ((state >> 29) as f64 - 3.5) * 2.0).clamp(0.0, 255.0) as u8
            })
            .collect();
        let img = GrayView::packed(&px, w, h).unwrap();
        for p in [
            MserParams::default(),
            MserParams::larsson2009(),
            MserParams {
                min_diversity: 0.0,
                variation: Variation::Upward,
                ..MserParams::default()
            },
        ] {
            let got = Mser::new(p.clone()).unwrap().detect(&img).unwrap();
            let want = common::reference_detail(&px, w, h, &p);
            let xy = |s: &[usize]| -> Vec<(u32, u32)> {
                s.iter()
                    .map(|&q| ((q % w) as u32, (q / w) as u32))
                    .collect()
            };
            assert_eq!(got.len(), want.len(), "seed {seed}, {p:?}");
            for (r, d) in got.iter().zip(&want) {
                assert_eq!((r.polarity, r.level), (d.polarity, d.level), "{p:?}");
                let pixels = xy(&d.pixels);
                assert_eq!(r.pixels(&img).unwrap(), pixels, "{r:?}");
                assert_eq!(r.variation, d.var.0 as f64 / d.var.1 as f64, "{r:?}");
                let v = mser::variations_by_thresholds(&img, r, &p).unwrap();
                assert_eq!((v.parent.num, v.parent.den), d.parent_var, "{r:?}");
                common::check_contour(&r.contour(&img).unwrap(), &pixels, w, h);
                found += 1;
            }
        }
    }
    assert!(found >= 100, "{found} regions");
}
