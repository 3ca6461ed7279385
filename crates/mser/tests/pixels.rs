//! `Mser::detect_with_pixels`: the pixel lists are the regions' pixels (as `Region::pixels`
//! floods them) on images of several sizes in turn with one detector (its buffers are reused),
//! and the parallel variant gives the same result.

use mser::{GrayView, Mser, MserParams, Polarities, Region};

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
