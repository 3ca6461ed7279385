//! The thesis's worked example (ch. 2): ten cos² channels on centres 1..10 with `a = π/3`.

use chan_repr::{ChannelBasis, Kernel};

fn basis() -> ChannelBasis {
    ChannelBasis::integer(10, Kernel::cos2_from_a(std::f64::consts::PI / 3.0).unwrap()).unwrap()
}

fn round2(v: f64) -> f64 {
    let r = (v * 100.0).round() / 100.0;
    if r == 0.0 { 0.0 } else { r } // no -0.0
}

#[test]
fn encoding_3_3_gives_eq_2_3() {
    let c: Vec<f64> = basis()
        .encode(3.3)
        .unwrap()
        .into_iter()
        .map(round2)
        .collect();
    assert_eq!(c, [0.0, 0.04, 0.90, 0.55, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
}

#[test]
fn decoding_3_3_gives_eq_2_6_and_2_7() {
    let b = basis();
    let windows = b.decode_windows(&b.encode(3.3).unwrap()).unwrap();
    // Windows without mass (r = 0) carry no estimate in our decoder; the thesis prints
    // x̂_l = l + 1 for them (arg 0), i.e. 5.00 … 8.00: the same rejected, zero-certainty entries.
    let x: Vec<f64> = windows
        .iter()
        .map(|w| round2(w.value.unwrap_or(w.start as f64 + 1.0)))
        .collect();
    let r: Vec<f64> = windows.iter().map(|w| round2(w.certainty)).collect();
    assert_eq!(x, [-0.02, 3.30, 3.31, 4.00, 5.00, 6.00, 7.00, 8.00]);
    assert_eq!(r, [0.95, 1.50, 1.46, 0.55, 0.0, 0.0, 0.0, 0.0]);
    let valid: Vec<usize> = windows
        .iter()
        .filter(|w| w.valid)
        .map(|w| w.start)
        .collect();
    assert_eq!(valid, [1], "only the second estimate, 3.30, is valid");
    let modes = b.decode(&b.encode(3.3).unwrap()).unwrap();
    assert_eq!(modes.len(), 1);
    assert!((modes[0].value - 3.3).abs() < 1e-12);
}

/// Eq. 2.8 of the thesis prints `c2 = [0 0 0 0 0 0 0.48 0.96 0.96 0]` for 6.8, which no cos²
/// encoding can produce: two neighbouring channels at 0.96 would both need `|x − k| < 0.2`, and
/// the channels of one value sum to `M/2 = 1.5`, not 2.4. The true encoding of 6.8 is
/// `B(0.8), B(−0.2), B(−1.2)` on centres 6, 7, 8 = `[.. 0.45 0.96 0.10 ..]`, asserted here;
/// the thesis's point — both values decode from the sum (eq. 2.9) — holds.
#[test]
fn soft_histogram_of_3_3_and_6_8_gives_eq_2_8_and_2_9() {
    let b = basis();
    let c1 = b.encode(3.3).unwrap();
    let c2 = b.encode(6.8).unwrap();
    let r2: Vec<f64> = c2.iter().copied().map(round2).collect();
    assert_eq!(r2, [0.0, 0.0, 0.0, 0.0, 0.0, 0.45, 0.96, 0.10, 0.0, 0.0]);
    let a = std::f64::consts::PI / 3.0;
    for (k, centre) in [(5, 6.0), (6, 7.0), (7, 8.0)] {
        assert!((c2[k] - (a * (6.8 - centre)).cos().powi(2)).abs() < 1e-14);
    }
    let c: Vec<f64> = c1.iter().zip(&c2).map(|(a, b)| a + b).collect();
    let rc: Vec<f64> = c.iter().copied().map(round2).collect();
    assert_eq!(rc, [0.0, 0.04, 0.90, 0.55, 0.0, 0.45, 0.96, 0.10, 0.0, 0.0]);
    let modes = b.decode(&c).unwrap();
    assert_eq!(modes.len(), 2);
    // Equal certainties: ties are ordered by value.
    assert!(
        (modes[0].value - 3.3).abs() < 1e-12 && (modes[1].value - 6.8).abs() < 1e-12,
        "{modes:?}"
    );
    for m in &modes {
        assert!((m.certainty - 1.5).abs() < 1e-12 && (m.weight - 1.0).abs() < 1e-12);
    }
}

#[test]
fn representable_domain_is_1_5_to_9_5() {
    assert_eq!(basis().representable_range(), (1.5, 9.5));
}
