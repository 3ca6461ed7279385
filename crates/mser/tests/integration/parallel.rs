//! Feature `rayon`: parallel detection gives exactly the sequential result.
#![cfg(feature = "rayon")]

use mser::{GrayView, Mser, MserParams, detect, detect_many};

fn pattern(w: usize, h: usize, seed: u32) -> Vec<u8> {
    (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f64, (i / w) as f64);
            let v = 128.0
                + 60.0 * (x * 0.21 + seed as f64).sin() * (y * 0.17).cos()
                + 40.0 * ((x + y) * 0.05).sin();
            v as u8
        })
        .collect()
}

#[test]
fn parallel_equals_sequential() {
    let p = MserParams {
        min_area: 10,
        ..Default::default()
    };
    let bufs: Vec<Vec<u8>> = (0..5).map(|s| pattern(90, 70, s)).collect();
    let imgs: Vec<GrayView> = bufs
        .iter()
        .map(|b| GrayView::packed(b, 90, 70).unwrap())
        .collect();
    let seq: Vec<_> = imgs.iter().map(|i| detect(i, &p).unwrap()).collect();
    assert!(seq.iter().all(|r| !r.is_empty()));
    assert_eq!(detect_many(&imgs, &p).unwrap(), seq);
    let mut m = Mser::new(p).unwrap();
    for (img, want) in imgs.iter().zip(&seq) {
        assert_eq!(&m.detect_parallel(img).unwrap(), want);
    }
}
