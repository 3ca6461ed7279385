//! The fast detector against the brute-force reference (threshold at every level, label
//! components, apply the definitions literally) on random small images.

mod common;

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
    #![proptest_config(ProptestConfig { cases: 2000, ..ProptestConfig::default() })]

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
