//! Invariances: inverting swaps the polarities, an order-preserving remap with wide gaps keeps the
//! regions, rotating by 90° rotates them.

use crate::common;

use mser::{GrayView, Mser, MserParams, Polarities, Polarity, Region, Variation};
use proptest::prelude::*;

fn sets(img: &GrayView, rs: &[Region]) -> Vec<common::RefRegion> {
    rs.iter()
        .map(|r| (r.polarity, r.level, r.pixels(img).unwrap()))
        .collect()
}

fn small_params() -> MserParams {
    MserParams {
        delta: 2,
        min_area: 2,
        max_area: 400,
        max_variation: 1.0,
        min_diversity: 0.1,
        polarities: Polarities::Both,
        variation: Variation::Symmetric,
    }
}

fn images() -> impl Strategy<Value = (usize, usize, Vec<u8>)> {
    (2usize..=16, 2usize..=16)
        .prop_flat_map(|(w, h)| (Just(w), Just(h), proptest::collection::vec(0u8..6, w * h)))
}

proptest! {
    #![proptest_config(crate::seeded(300))]

    #[test]
    fn inverting_swaps_polarities((w, h, k) in images(), sym in any::<bool>()) {
        let px: Vec<u8> = k.iter().map(|&v| v * 40 + 7).collect();
        let inv: Vec<u8> = px.iter().map(|&g| 255 - g).collect();
        let mut p = small_params();
        if !sym { p.variation = Variation::Upward; }
        let a = GrayView::packed(&px, w, h).unwrap();
        let b = GrayView::packed(&inv, w, h).unwrap();
        let ra = Mser::new(p.clone()).unwrap().detect(&a).unwrap();
        let rb = Mser::new(p).unwrap().detect(&b).unwrap();
        let swap = |r: &Region| {
            let pol = if r.polarity == Polarity::Dark { Polarity::Bright } else { Polarity::Dark };
            (pol, 255 - r.level, r.area, r.moments, r.variation.to_bits())
        };
        let mut want: Vec<_> = rb.iter().map(swap).collect();
        want.sort_by_key(|t| (t.0, t.1, t.3.sy, t.3.sx));
        let mut got: Vec<_> = ra.iter().map(|r| (r.polarity, r.level, r.area, r.moments, r.variation.to_bits())).collect();
        got.sort_by_key(|t| (t.0, t.1, t.3.sy, t.3.sx));
        prop_assert_eq!(got, want);
    }

    /// Grey values 6 apart (> delta = 2) before and after a strictly increasing remap: no level
    /// lies within delta of another, so every variation, and hence the region set, is unchanged.
    #[test]
    fn wide_gap_monotone_remap_keeps_regions((w, h, k) in images(), gaps in proptest::collection::vec(3u8..=40, 6)) {
        let p = small_params();
        let before: Vec<u8> = k.iter().map(|&v| v * 6 + 10).collect();
        let mut map = [0u8; 6];
        let mut acc = 5u32;
        for i in 0..6 {
            map[i] = acc as u8;
            acc += gaps[i] as u32;
        }
        let after: Vec<u8> = k.iter().map(|&v| map[v as usize]).collect();
        let a = GrayView::packed(&before, w, h).unwrap();
        let b = GrayView::packed(&after, w, h).unwrap();
        let ra = Mser::new(p.clone()).unwrap().detect(&a).unwrap();
        let rb = Mser::new(p).unwrap().detect(&b).unwrap();
        let strip = |img: &GrayView, rs: &[Region]| -> Vec<(Polarity, Vec<(u32, u32)>)> {
            sets(img, rs).into_iter().map(|(pol, _, s)| (pol, s)).collect()
        };
        prop_assert_eq!(strip(&a, &ra), strip(&b, &rb));
        let levels = |rs: &[Region]| rs.iter().map(|r| r.level).collect::<Vec<_>>();
        let mapped: Vec<u8> = levels(&ra).iter().map(|&l| map[((l - 10) / 6) as usize]).collect();
        prop_assert_eq!(mapped, levels(&rb));
    }

    /// Rotation by 90° clockwise, (x, y) -> (h - 1 - y, x). With the upward measure no tie-break
    /// is involved, so the region sets rotate exactly.
    #[test]
    fn rotating_rotates_regions((w, h, k) in images()) {
        let mut p = small_params();
        p.variation = Variation::Upward;
        let px: Vec<u8> = k.iter().map(|&v| v * 30).collect();
        let (rw, rh) = (h, w);
        let mut rot = vec![0u8; w * h];
        for y in 0..h {
            for x in 0..w {
                rot[x * rw + (h - 1 - y)] = px[y * w + x];
            }
        }
        let a = GrayView::packed(&px, w, h).unwrap();
        let b = GrayView::packed(&rot, rw, rh).unwrap();
        let ra = Mser::new(p.clone()).unwrap().detect(&a).unwrap();
        let rb = Mser::new(p).unwrap().detect(&b).unwrap();
        let mut want: Vec<_> = sets(&a, &ra)
            .into_iter()
            .map(|(pol, l, s)| {
                let mut s: Vec<(u32, u32)> = s.into_iter().map(|(x, y)| (h as u32 - 1 - y, x)).collect();
                s.sort_by_key(|&(x, y)| (y, x));
                (pol, l, s)
            })
            .collect();
        let mut got = sets(&b, &rb);
        want.sort();
        got.sort();
        prop_assert_eq!(got, want);
    }
}
