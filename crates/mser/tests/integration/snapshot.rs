//! Snapshot of the regions of a synthetic fixture (nested squares, a ring, a gradient disk and
//! noise from a fixed-seed LCG) with default and thesis parameters.

use mser::{GrayView, Mser, MserParams};

fn fixture() -> (usize, usize, Vec<u8>) {
    let (w, h) = (120, 90);
    let mut state = 12345u32;
    let mut px = vec![0u8; w * h];
    for y in 0..h {
        for x in 0..w {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            let noise = (state >> 28) as i32 - 8;
            let (fx, fy) = (x as f64, y as f64);
            let mut v: i32 = 180;
            if (10..50).contains(&x) && (10..50).contains(&y) {
                v = 110;
            }
            if (20..40).contains(&x) && (20..40).contains(&y) {
                v = 40;
            }
            let r = ((fx - 85.0).powi(2) + (fy - 30.0).powi(2)).sqrt();
            if (12.0..18.0).contains(&r) {
                v = 60;
            }
            let d = ((fx - 80.0).powi(2) + (fy - 70.0).powi(2)).sqrt();
            if d < 14.0 {
                v = 230 - (d * 3.0) as i32;
            }
            px[y * w + x] = (v + noise).clamp(0, 255) as u8;
        }
    }
    (w, h, px)
}

fn summary(p: MserParams) -> Vec<String> {
    let (w, h, px) = fixture();
    let img = GrayView::packed(&px, w, h).unwrap();
    Mser::new(p)
        .unwrap()
        .detect(&img)
        .unwrap()
        .iter()
        .map(|r| {
            let e = r.ellipse().unwrap();
            let c = r.contour(&img).unwrap();
            format!(
                "{:?} level {} area {} seed {:?} v {:.4} ellipse ({:.3}, {:.3}, {:.6}, {:.6}, {:.6}) contour {}",
                r.polarity, r.level, r.area, r.seed, r.variation, e.u, e.v, e.a, e.b, e.c, c.len()
            )
        })
        .collect()
}

#[test]
fn fixture_regions_default() {
    insta::assert_json_snapshot!(summary(MserParams::default()));
}

#[test]
fn fixture_regions_larsson2009() {
    insta::assert_json_snapshot!(summary(MserParams::larsson2009()));
}
