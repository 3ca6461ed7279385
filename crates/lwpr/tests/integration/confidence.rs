//! The reference's confidence bounds cover the noise-free function.

use crate::harness;

use harness::*;

/// Setting A of the cross function: the noise-free target lies within ±2 confidence bounds
/// of the prediction on at least 90 % of the 41×41 grid (the share stated in the crate docs).
#[test]
fn two_sigma_bounds_cover_at_least_ninety_percent() {
    let (x, y) = cross_samples(1, 20_000, 0.1);
    let mut m = setting_a_builder(2).build().unwrap();
    train(&mut m, &x, &y).unwrap();
    let (gx, gy) = cross_grid();
    let (mut inside, mut total_width) = (0usize, 0.0);
    for (p, t) in gx.chunks(2).zip(&gy) {
        let c = m.predict_with_confidence(p, 0.001).unwrap();
        assert!((c.y[0] - m.predict(p, 0.001).unwrap()[0]).abs() < 1e-12);
        assert!(c.confidence[0].is_finite() && c.confidence[0] > 0.0);
        total_width += c.confidence[0];
        if (c.y[0] - t).abs() <= 2.0 * c.confidence[0] {
            inside += 1;
        }
    }
    let share = inside as f64 / gy.len() as f64;
    let mean_width = total_width / gy.len() as f64;
    eprintln!("±2σ coverage {share:.3}, mean σ {mean_width:.4}");
    assert!(share >= 0.90, "coverage {share}");
    // Not vacuous: the bounds are of the order of the noise (σ = 0.1), not huge.
    assert!(mean_width < 0.2, "mean bound {mean_width}");
}
