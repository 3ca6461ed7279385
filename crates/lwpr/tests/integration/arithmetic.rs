//! `Arithmetic::Fast` against `Arithmetic::Reference`: bit-identical where the fast path does not
//! apply (n ≤ 4, diagonal metrics), and within rounding of it where it does (full metric,
//! n ≥ 5), with and without meta learning and pruning.

use lwpr::{Arithmetic, Lwpr, LwprBuilder};
use proptest::prelude::{prop_assert, prop_assert_eq, proptest};

/// A smooth target in `n` dimensions.
fn target(x: &[f64]) -> f64 {
    (2.0 * x[0]).sin() + x[1] * x[x.len() / 2] + 0.5 * x[x.len() - 1] * x[x.len() - 1]
}

/// `k` samples from a small LCG (inputs in [-1, 1]^n).
fn samples(n: usize, k: usize, seed: u64) -> Vec<Vec<f64>> {
    let mut s = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    (0..k)
        .map(|_| {
            (0..n)
                .map(|_| {
                    s = s
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    (s >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
                })
                .collect()
        })
        .collect()
}

fn model(n: usize, diag: bool, meta: bool, w_prune: f64, a: Arithmetic) -> Lwpr {
    LwprBuilder::new(n, 1)
        .init_d_spherical(2.0)
        .init_alpha(100.0)
        .w_gen(0.2)
        .w_prune(w_prune)
        .diag_only(diag)
        .meta(meta)
        .arithmetic(a)
        .build()
        .unwrap()
}

#[test]
fn small_inputs_and_diagonal_metrics_are_bit_identical_either_way() {
    for (n, diag) in [(2, false), (3, false), (4, false), (6, true)] {
        let mut fast = model(n, diag, true, 0.9, Arithmetic::Fast);
        let mut exact = model(n, diag, true, 0.9, Arithmetic::Reference);
        for x in samples(n, 1500, n as u64) {
            let y = [target(&x)];
            assert_eq!(fast.update(&x, &y).unwrap(), exact.update(&x, &y).unwrap());
        }
        assert_eq!(
            fast.receptive_fields(0).len(),
            exact.receptive_fields(0).len()
        );
        let mut fast_as_exact = fast.clone();
        fast_as_exact.set_arithmetic(Arithmetic::Reference);
        assert_eq!(fast_as_exact, exact, "n = {n}, diag_only = {diag}");
    }
}

proptest! {
    #![proptest_config(crate::seeded(12))]

    /// Full metric, n = 5..12: every prediction returned by `update` agrees to 1e-9 and the
    /// receptive fields are the same in number, centre and PLS dimension.
    #[test]
    fn fast_full_metric_stays_within_rounding_of_reference(
        n in 5usize..=12,
        seed in 0u64..1000,
        meta in proptest::bool::ANY,
        prune in proptest::bool::ANY,
    ) {
        let w_prune = if prune { 0.8 } else { 1.0 };
        let mut fast = model(n, false, meta, w_prune, Arithmetic::Fast);
        let mut exact = model(n, false, meta, w_prune, Arithmetic::Reference);
        for x in samples(n, 600, seed) {
            let y = [target(&x)];
            let (a, b) = (fast.update(&x, &y).unwrap()[0], exact.update(&x, &y).unwrap()[0]);
            prop_assert!((a - b).abs() <= 1e-9 * (1.0 + b.abs()), "update: {a} vs {b}");
        }
        let (rf, re) = (fast.receptive_fields(0), exact.receptive_fields(0));
        prop_assert_eq!(rf.len(), re.len());
        for (p, q) in rf.iter().zip(&re) {
            prop_assert_eq!(p.centre(), q.centre());
            prop_assert_eq!(p.pls_dims(), q.pls_dims());
            for (u, v) in p.metric().iter().zip(q.metric()) {
                prop_assert!((u - v).abs() <= 1e-9 * (1.0 + v.abs()), "metric {u} vs {v}");
            }
        }
    }
}

/// Prediction for n ≥ 5 stops summing a field's distance once it is known to be beyond the
/// cutoff; asking for the largest activation turns that off, and the prediction must not change.
#[test]
fn early_stopped_distances_do_not_change_predictions() {
    let n = 8;
    let mut m = model(n, false, true, 1.0, Arithmetic::Fast);
    for x in samples(n, 3000, 5) {
        m.update(&x, &[target(&x)]).unwrap();
    }
    assert!(
        m.receptive_fields(0).len() > 3,
        "a model with several fields"
    );
    let mut active = 0;
    for x in samples(n, 300, 99) {
        let fast = m.predict(&x, 0.001).unwrap();
        let (full, w_max) = m.predict_with_max_activation(&x, 0.001).unwrap();
        assert_eq!(fast[0].to_bits(), full[0].to_bits());
        active += usize::from(w_max[0] > 0.001);
    }
    assert!(active > 0, "some test inputs activate a field");
}
