//! Property tests: round trips for every kernel and dimension, separation of two values,
//! linearity of certainty in the weight, sparse = dense.

use chan_repr::{ChannelBasis, ChannelGrid, Kernel, SoftHistogram, SparseHistogram};
use proptest::prelude::*;

fn kernel() -> impl Strategy<Value = Kernel> {
    prop_oneof![
        (3u32..8).prop_map(|m| Kernel::Cos2 { m }),
        Just(Kernel::BSpline2),
        (0.5f64..1.5).prop_map(|sigma| Kernel::Gaussian { sigma }),
    ]
}

/// A basis with `n` channels over a random range.
fn basis() -> impl Strategy<Value = ChannelBasis> {
    (kernel(), 10usize..40, -100.0f64..100.0, 0.1f64..50.0)
        .prop_map(|(k, n, lo, width)| ChannelBasis::covering(lo, lo + width, n, k).unwrap())
}

fn close(a: f64, b: f64, scale: f64) -> bool {
    (a - b).abs() <= 1e-9 * scale.max(1.0)
}

proptest! {
    #![proptest_config(crate::seeded(256))]

    #[test]
    fn one_d_round_trip(b in basis(), u in 0.0f64..=1.0, w in 0.01f64..100.0) {
        let (lo, hi) = b.representable_range();
        let x = lo + u * (hi - lo);
        let modes = b.decode(&b.encode_weighted(x, w).unwrap()).unwrap();
        prop_assert_eq!(modes.len(), 1, "{:?}", modes);
        prop_assert!(close(modes[0].value, x, b.spacing()), "{} != {}", modes[0].value, x);
        prop_assert!((modes[0].weight - w).abs() <= 1e-9 * w);
    }

    #[test]
    fn n_d_round_trip(bases in prop::collection::vec(basis(), 2..=3), us in prop::collection::vec(0.0f64..=1.0, 3)) {
        let grid = ChannelGrid::new(bases.clone()).unwrap();
        let x: Vec<f64> = bases.iter().zip(&us).map(|(b, u)| {
            let (lo, hi) = b.representable_range();
            lo + u * (hi - lo)
        }).collect();
        let modes = grid.decode(&grid.encode(&x).unwrap()).unwrap();
        prop_assert_eq!(modes.len(), 1, "{:?}", modes);
        for (d, b) in bases.iter().enumerate() {
            prop_assert!(close(modes[0].value[d], x[d], b.spacing()));
        }
    }

    #[test]
    fn two_separated_values_are_both_recovered(b in basis(), u in 0.0f64..=1.0, v in 0.0f64..=1.0) {
        // Two values at least 3 channel spacings apart (and beyond the other's support) are
        // the two most certain modes, both decoded exactly. Windows that straddle the two
        // values' tails may add weak spurious modes (the local decoder's known behaviour).
        let (lo, hi) = b.representable_index_range();
        let gap = 3.0f64.max(2.0 * b.kernel().support_radius());
        prop_assume!(hi - lo > gap);
        let t1 = lo + u * (hi - lo - gap);
        let t2 = t1 + gap + v * (hi - lo - gap - (t1 - lo));
        let (x1, x2) = (b.from_index(t1), b.from_index(t2));
        let mut c = b.encode(x1).unwrap();
        b.accumulate(x2, 1.0, &mut c).unwrap();
        let modes = b.decode(&c).unwrap();
        prop_assert!(modes.len() >= 2, "{:?}", modes);
        let mut values: Vec<f64> = modes[..2].iter().map(|m| m.value).collect();
        values.sort_by(f64::total_cmp);
        prop_assert!(close(values[0], x1, b.spacing()) && close(values[1], x2, b.spacing()));
    }

    #[test]
    fn certainty_is_linear_in_weight(b in basis(), u in 0.0f64..=1.0, w in 0.01f64..100.0) {
        let (lo, hi) = b.representable_range();
        let x = lo + u * (hi - lo);
        let one = b.decode(&b.encode(x).unwrap()).unwrap()[0];
        let weighted = b.decode(&b.encode_weighted(x, w).unwrap()).unwrap()[0];
        prop_assert!((weighted.certainty - w * one.certainty).abs() <= 1e-9 * w * one.certainty);
    }

    #[test]
    fn sparse_histogram_equals_dense(bases in prop::collection::vec(basis(), 1..=2),
                                     pts in prop::collection::vec((0.0f64..=1.0, 0.0f64..=1.0, 0.0f64..5.0), 1..20)) {
        let grid = ChannelGrid::new(bases.clone()).unwrap();
        let mut dense = SoftHistogram::new(grid.clone()).unwrap();
        let mut sparse = SparseHistogram::new(grid);
        for (u, v, w) in pts {
            let x: Vec<f64> = bases.iter().zip([u, v]).map(|(b, s)| {
                let (lo, hi) = b.representable_range();
                lo + s * (hi - lo)
            }).collect();
            dense.add(&x, w).unwrap();
            sparse.add(&x, w).unwrap();
        }
        let as_dense = sparse.to_dense().unwrap();
        prop_assert_eq!(as_dense.counts(), dense.counts());
        prop_assert_eq!(sparse.decode().unwrap(), dense.decode().unwrap());
    }
}

/// A basis whose Gaussian kernels reach wider than [`basis`]'s, for the mass bounds.
fn wide_basis() -> impl Strategy<Value = ChannelBasis> {
    let k = prop_oneof![
        (3u32..8).prop_map(|m| Kernel::Cos2 { m }),
        Just(Kernel::BSpline2),
        (0.5f64..4.0).prop_map(|sigma| Kernel::Gaussian { sigma }),
    ];
    (k, 10usize..40, -100.0f64..100.0, 0.1f64..50.0)
        .prop_map(|(k, n, lo, width)| ChannelBasis::covering(lo, lo + width, n, k).unwrap())
}

/// A position in `[0, 1]` with the ends of the range often, where Gaussian channels lose mass.
fn unit_or_end() -> impl Strategy<Value = f64> {
    prop_oneof![3 => 0.0f64..=1.0, 1 => Just(0.0), 1 => Just(1.0)]
}

proptest! {
    #![proptest_config(crate::seeded(256))]

    /// Every histogram built by adding values passes `from_counts` with its own total (and so
    /// the serde round trip), and each single value's channel mass lies in the grid's bounds.
    #[test]
    fn a_histograms_own_total_is_consistent(
        bases in prop::collection::vec(wide_basis(), 1..=2),
        pts in prop::collection::vec((unit_or_end(), unit_or_end(), 0.0f64..5.0), 1..20),
    ) {
        let grid = ChannelGrid::new(bases.clone()).unwrap();
        let (lo, hi) = grid.unit_mass_bounds();
        let mut h = SoftHistogram::new(grid.clone()).unwrap();
        for (u, v, w) in pts {
            let x: Vec<f64> = bases.iter().zip([u, v]).map(|(b, s)| {
                let (lo, hi) = b.representable_range();
                lo + s * (hi - lo)
            }).collect();
            let mass: f64 = grid.encode(&x).unwrap().iter().sum();
            prop_assert!(mass >= lo * (1.0 - 1e-12) && mass <= hi * (1.0 + 1e-12),
                "mass {} outside [{}, {}] at {:?}", mass, lo, hi, x);
            h.add(&x, w).unwrap();
        }
        let again = SoftHistogram::from_counts(grid, h.counts().to_vec(), h.total_weight()).unwrap();
        prop_assert_eq!(&again, &h);
        // JSON may move the last bit of a float; the check must still accept it.
        let json = serde_json::to_string(&h).unwrap();
        let back = serde_json::from_str::<SoftHistogram>(&json).unwrap();
        prop_assert!(close(back.total_weight(), h.total_weight(), h.total_weight()));
    }
}

/// A value in or around a basis's representable range, or a non-finite one.
fn probe(lo: f64, hi: f64) -> impl Strategy<Value = f64> {
    let w = hi - lo;
    prop_oneof![
        8 => (-0.2f64..1.2).prop_map(move |u| lo + u * w),
        1 => Just(lo),
        1 => Just(hi),
        1 => prop_oneof![Just(f64::NAN), Just(f64::INFINITY), Just(f64::NEG_INFINITY), Just(1e308), Just(-1e308)],
    ]
}

proptest! {
    #![proptest_config(crate::seeded(256))]

    /// The batch check refuses exactly what the value-by-value check refuses, with the error of
    /// the first refused value.
    #[test]
    fn check_all_equals_value_by_value(
        (b, xs) in basis().prop_flat_map(|b| {
            let (lo, hi) = b.representable_range();
            (Just(b), prop::collection::vec(probe(lo, hi), 0..200))
        })
    ) {
        let one_by_one = xs.iter().try_for_each(|&x| b.checked_index(x).map(|_| ()));
        prop_assert_eq!(format!("{:?}", b.check_all(&xs)), format!("{:?}", one_by_one));
    }
}

proptest! {
    #![proptest_config(crate::seeded(256))]

    /// A batch equals its values added one by one: exactly for the Gaussian, which shares the
    /// per-value path, up to rounding for the batch paths of the quadratic B-spline (closed
    /// form on the nearest channel) and cos² (polynomial starting phasor). The range ends are
    /// drawn often, where the B-spline path skips the channel past the last.
    #[test]
    fn a_batch_equals_its_values_one_by_one(
        (b, xs) in basis().prop_flat_map(|b| {
            let (lo, hi) = b.representable_range();
            let w = hi - lo;
            let x = prop_oneof![
                4 => (0.0f64..=1.0).prop_map(move |u| lo + u * w),
                1 => Just(lo),
                1 => Just(hi),
            ];
            (Just(b), prop::collection::vec(x, 0..100))
        })
    ) {
        let mut batch = SoftHistogram::one_d(b.clone());
        batch.extend_1d(&xs).unwrap();
        let mut each = SoftHistogram::one_d(b.clone());
        for &x in &xs {
            each.add(&[x], 1.0).unwrap();
        }
        prop_assert_eq!(batch.total_weight(), each.total_weight());
        let exact = matches!(b.kernel(), Kernel::Gaussian { .. });
        for (k, (p, q)) in batch.counts().iter().zip(each.counts()).enumerate() {
            if exact {
                prop_assert_eq!(p, q, "channel {}", k);
            } else {
                prop_assert!((p - q).abs() <= 1e-12 * (xs.len() as f64).max(1.0), "channel {}: {} vs {}", k, p, q);
            }
        }
    }
}
