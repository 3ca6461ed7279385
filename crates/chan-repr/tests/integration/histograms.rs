//! What the histograms' docs promise beyond encoding and decoding: a rejected value or batch
//! changes no state (sparse as well as dense), `clear` gives an empty histogram, and
//! `from_counts` refuses each bad input with its typed error.

use chan_repr::{
    ChanError, ChannelBasis, ChannelGrid, Kernel, MAX_MASS, SoftHistogram, SparseHistogram,
};

fn grid2() -> ChannelGrid {
    let b = ChannelBasis::integer(10, Kernel::BSpline2).unwrap();
    ChannelGrid::new(vec![b.clone(), b]).unwrap()
}

#[test]
fn a_rejected_value_leaves_a_sparse_histogram_unchanged() {
    let mut h = SparseHistogram::new(grid2());
    h.add(&[4.0, 5.5], 1.0).unwrap();
    let before = h.clone();
    let stored: Vec<(usize, f64)> = h.iter().collect();
    for (x, w) in [
        (vec![f64::NAN, 4.0], 1.0),
        (vec![4.0, f64::INFINITY], 1.0),
        (vec![4.0, 40.0], 1.0),
        (vec![-3.0, 4.0], 1.0),
        (vec![4.0], 1.0),
        (vec![4.0, 4.0, 4.0], 1.0),
        (vec![4.0, 4.0], -1.0),
        (vec![4.0, 4.0], f64::NAN),
        (vec![4.0, 4.0], 2.0 * MAX_MASS),
    ] {
        assert!(h.add(&x, w).is_err(), "{x:?} {w}");
        assert_eq!(h, before, "{x:?} {w}");
        assert_eq!(h.iter().collect::<Vec<_>>(), stored, "{x:?} {w}");
        assert_eq!(h.total_weight(), 1.0);
    }
    // Still usable, and the same as if the rejected values had never been offered.
    h.add(&[6.0, 2.0], 0.5).unwrap();
    let mut fresh = SparseHistogram::new(grid2());
    fresh.add(&[4.0, 5.5], 1.0).unwrap();
    fresh.add(&[6.0, 2.0], 0.5).unwrap();
    assert_eq!(h, fresh);
}

#[test]
fn clear_gives_an_empty_histogram() {
    let mut h = SoftHistogram::new(grid2()).unwrap();
    h.add(&[4.0, 5.5], 0.6 * MAX_MASS).unwrap();
    h.clear();
    assert_eq!(h, SoftHistogram::new(grid2()).unwrap());
    assert!(h.counts().iter().all(|&c| c == 0.0));
    assert_eq!(h.total_weight(), 0.0);
    assert!(h.decode().unwrap().is_empty());
    // The mass limit starts afresh too: this is the first 0.6·MAX_MASS of the cleared one.
    h.add(&[6.0, 2.0], 0.6 * MAX_MASS).unwrap();
    assert_eq!(h.total_weight(), 0.6 * MAX_MASS);
}

#[test]
fn extend_1d_refuses_grids_of_more_dimensions() {
    let mut h = SoftHistogram::new(grid2()).unwrap();
    h.add(&[4.0, 5.5], 1.0).unwrap();
    let before = h.clone();
    assert_eq!(
        h.extend_1d(&[4.0, 5.0]),
        Err(ChanError::LengthMismatch {
            what: "dimensions",
            expected: 2,
            got: 1
        })
    );
    assert_eq!(h, before);
}

#[test]
fn to_dense_refuses_grids_too_large_for_a_dense_vector() {
    let b = ChannelBasis::integer(1000, Kernel::Cos2 { m: 3 }).unwrap();
    let mut h = SparseHistogram::new(ChannelGrid::new(vec![b.clone(), b.clone(), b]).unwrap());
    h.add(&[10.0, 500.0, 990.0], 1.0).unwrap();
    // `matches!`, not `assert_eq!`: a failure must not print a dense vector of 10⁹ zeros.
    let dense = h.to_dense();
    assert!(
        matches!(
            dense,
            Err(ChanError::TooManyChannels { got: 1_000_000_000, max }) if max == chan_repr::MAX_CHANNELS
        ),
        "to_dense of a 10⁹-channel grid was not refused"
    );
}

#[test]
fn from_counts_refuses_each_bad_input_with_its_error() {
    let grid = ChannelGrid::new(vec![ChannelBasis::integer(6, Kernel::BSpline2).unwrap()]).unwrap();
    let good = vec![0.0, 0.125, 0.75, 0.125, 0.0, 0.0]; // one value at 2
    assert!(SoftHistogram::from_counts(grid.clone(), good.clone(), 1.0).is_ok());
    let with = |k: usize, v: f64| {
        let mut c = good.clone();
        c[k] = v;
        c
    };
    /// Counts, total weight, and the error they must give.
    type Case = (Vec<f64>, f64, fn(&ChanError) -> bool);
    let cases: [Case; 8] = [
        (good[..5].to_vec(), 1.0, |e| {
            matches!(
                e,
                ChanError::LengthMismatch {
                    expected: 6,
                    got: 5,
                    ..
                }
            )
        }),
        (with(4, f64::NAN), 1.0, |e| {
            matches!(e, ChanError::NonFinite { .. })
        }),
        (with(4, f64::INFINITY), 1.0, |e| {
            matches!(e, ChanError::NonFinite { .. })
        }),
        (with(4, -0.25), 1.0, |e| {
            matches!(e, ChanError::Negative { .. })
        }),
        (with(4, 2.0 * MAX_MASS), 1.0, |e| {
            matches!(e, ChanError::TooLarge { .. })
        }),
        (vec![0.0; 6], -1.0, |e| {
            matches!(e, ChanError::Negative { .. })
        }),
        (good.clone(), f64::NAN, |e| {
            matches!(e, ChanError::NonFinite { .. })
        }),
        (good.clone(), 2.0 * MAX_MASS, |e| {
            matches!(e, ChanError::TooLarge { .. })
        }),
    ];
    for (counts, total, expected) in cases {
        let err = SoftHistogram::from_counts(grid.clone(), counts.clone(), total)
            .expect_err(&format!("{counts:?} {total}"));
        assert!(expected(&err), "{counts:?} {total}: {err:?}");
    }
}

/// The dense and the sparse histogram as the mass-limit test below uses them.
trait Histogram: Clone + PartialEq + std::fmt::Debug {
    fn add_value(&mut self, x: &[f64], weight: f64) -> Result<(), ChanError>;
}

impl Histogram for SoftHistogram {
    fn add_value(&mut self, x: &[f64], weight: f64) -> Result<(), ChanError> {
        self.add(x, weight)
    }
}

impl Histogram for SparseHistogram {
    fn add_value(&mut self, x: &[f64], weight: f64) -> Result<(), ChanError> {
        self.add(x, weight)
    }
}

/// `h` and a twin that never saw the refused calls must accept and refuse the same later
/// values: the hidden bound of the O(1) mass-limit test moves with accepted values only.
fn refused_adds_leave_the_mass_limit(mut h: impl Histogram) {
    let big = 0.3 * MAX_MASS;
    h.add_value(&[4.0, 5.5], big).unwrap();
    let mut twin = h.clone();
    for x in [
        vec![f64::NAN, 4.0],
        vec![4.0, f64::INFINITY],
        vec![4.0, 40.0],
        vec![0.2, 4.0],
        vec![4.0],
        vec![4.0, 4.0, 4.0],
    ] {
        // Each would raise the bound by 0.3·MAX_MASS if it were stored before the value's
        // checks: two such calls would make the next two accepted values below overflow it.
        assert!(h.add_value(&x, big).is_err(), "{x:?}");
        assert_eq!(h, twin, "{x:?}");
    }
    assert!(matches!(
        h.add_value(&[4.0, 4.0], 2.0 * MAX_MASS),
        Err(ChanError::TooLarge { .. })
    ));
    // 0.3 + 0.3 + 0.3 of MAX_MASS is accepted, a fourth 0.3 is not: by both.
    for (x, accepted) in [([6.0, 2.0], true), ([2.0, 6.0], true), ([5.0, 5.0], false)] {
        assert_eq!(h.add_value(&x, big).is_ok(), accepted, "{x:?}");
        assert_eq!(twin.add_value(&x, big).is_ok(), accepted, "twin {x:?}");
        assert_eq!(h, twin, "{x:?}");
    }
}

#[test]
fn a_refused_add_leaves_the_mass_limit_where_it_was() {
    refused_adds_leave_the_mass_limit(SoftHistogram::new(grid2()).unwrap());
    refused_adds_leave_the_mass_limit(SparseHistogram::new(grid2()));
}
