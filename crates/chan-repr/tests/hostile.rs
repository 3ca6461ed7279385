//! Hostile inputs to the public API: each must give a typed error (or a correct answer), never
//! a panic, an infinite or NaN value claimed valid, or a silently empty encoding.

use chan_repr::{ChanError, ChannelBasis, ChannelGrid, Kernel, PeriodicBasis};

#[test]
fn decode_window_checks_its_window() {
    // A window of the wrong length used to index past its end (B-spline, Gaussian) and
    // NaN or negative coefficients gave an estimate.
    for k in [
        Kernel::Cos2 { m: 3 },
        Kernel::BSpline2,
        Kernel::Gaussian { sigma: 1.0 },
    ] {
        for short in [&[][..], &[0.5][..], &[0.1, 0.9][..]] {
            assert!(
                matches!(
                    k.decode_window(short),
                    Err(ChanError::LengthMismatch { .. })
                ),
                "{k:?} {short:?}"
            );
        }
        assert!(matches!(
            k.decode_window(&[0.2, f64::NAN, 0.3]),
            Err(ChanError::NonFinite { .. })
        ));
        assert!(matches!(
            k.decode_window(&[0.2, -0.5, 0.3]),
            Err(ChanError::Negative { .. })
        ));
        // A valid window still decodes exactly.
        let (lo, hi) = k.valid_offsets();
        let x = 0.5 * (lo + hi) + 0.1;
        let c: Vec<f64> = (0..k.window()).map(|j| k.value(x - j as f64)).collect();
        assert!((k.decode_window(&c).unwrap().unwrap() - x).abs() < 1e-12);
    }
}

#[test]
fn grid_basis_out_of_range_is_none() {
    let b = ChannelBasis::integer(5, Kernel::BSpline2).unwrap();
    let g = ChannelGrid::new(vec![b.clone(), b.clone()]).unwrap();
    assert_eq!(g.basis(1), Some(&b));
    assert_eq!(g.basis(2), None);
}

#[test]
fn bases_whose_centres_overflow_are_refused() {
    // The last centre 1e308 + 9·1e308 is infinite: decoding a vector with mass there gave a
    // mode at +∞.
    assert!(matches!(
        ChannelBasis::new(1e308, 1e308, 10, Kernel::Cos2 { m: 3 }),
        Err(ChanError::InvalidParameter { .. })
    ));
    assert!(ChannelBasis::new(-1e308, 1e307, 10, Kernel::BSpline2).is_ok());
    // Every accepted basis decodes its channels to finite values.
    let b = ChannelBasis::new(1e307, 1e307, 10, Kernel::Cos2 { m: 3 }).unwrap();
    let mut c = vec![0.0; 10];
    c[7] = 1.0;
    c[8] = 1.0;
    for m in b.decode(&c).unwrap() {
        assert!(m.value.is_finite(), "{m:?}");
    }
}

#[test]
fn subnormal_spacings_are_refused() {
    // A period of 1e-320 over 2^24 channels has a spacing that underflows to 0: every value
    // then encoded to the zero vector, with no error. Subnormal spacings (1e-302 / 2^24) have
    // lost most of their precision.
    for period in [1e-320, 1e-302] {
        assert!(matches!(
            PeriodicBasis::new(period, 1 << 24, Kernel::Cos2 { m: 3 }),
            Err(ChanError::InvalidParameter { .. })
        ));
    }
    assert!(matches!(
        PeriodicBasis::new(1e-320, 8, Kernel::Cos2 { m: 3 }),
        Err(ChanError::InvalidParameter { .. })
    ));
    assert!(matches!(
        ChannelBasis::new(0.0, 1e-320, 8, Kernel::BSpline2),
        Err(ChanError::InvalidParameter { .. })
    ));
    // Tiny but normal spacings still work.
    let p = PeriodicBasis::new(1e-290, 16, Kernel::Cos2 { m: 3 }).unwrap();
    let c = p.encode(3e-291).unwrap();
    assert!((c.iter().sum::<f64>() - 1.5).abs() < 1e-12);
}

#[test]
fn grids_of_very_many_dimensions_are_refused_not_left_to_hang() {
    // 40 dimensions of 3 B-spline channels fit a usize (3⁴⁰ ≈ 1.2e19 channels), so a sparse
    // histogram accepted the grid and one `add` then visited 3⁴⁰ channels: practically forever.
    let b = ChannelBasis::integer(3, Kernel::BSpline2).unwrap();
    for dims in [8, 12, 40] {
        assert!(
            matches!(
                ChannelGrid::new(vec![b.clone(); dims]),
                Err(ChanError::GridTooLarge { what, .. }) if what.contains("window")
            ),
            "{dims} dimensions"
        );
    }
    // Wide Gaussian channels: a small window, but one value would touch 33² = 1,089 channels
    // per pair of dimensions, 33⁵ ≈ 3.9e7 > 2²⁴ in five.
    let g = ChannelBasis::integer(40, Kernel::Gaussian { sigma: 4.0 }).unwrap();
    assert!(ChannelGrid::new(vec![g.clone(); 4]).is_ok());
    assert!(matches!(
        ChannelGrid::new(vec![g; 5]),
        Err(ChanError::GridTooLarge { what, got, .. }) if what.contains("touches") && got == 33usize.pow(5)
    ));
    // The largest grid allowed still works end to end, quickly.
    let grid = ChannelGrid::new(vec![b.clone(); 7]).unwrap();
    let mut h = chan_repr::SparseHistogram::new(grid);
    h.add(&[2.0; 7], 1.0).unwrap();
    let modes = h.decode().unwrap();
    assert_eq!(modes.len(), 1);
    assert!(modes[0].value.iter().all(|v| (v - 2.0).abs() < 1e-12));
}

#[test]
fn histogram_totals_must_match_their_coefficients() {
    // `from_counts` (and so deserialising) accepted any total weight beside any coefficients.
    let grid = ChannelGrid::new(vec![
        ChannelBasis::integer(8, Kernel::Cos2 { m: 3 }).unwrap(),
    ])
    .unwrap();
    let mut h = chan_repr::SoftHistogram::new(grid.clone()).unwrap();
    h.add(&[3.3], 2.0).unwrap();
    h.add(&[5.0], 0.5).unwrap();
    let counts = h.counts().to_vec();
    assert!(chan_repr::SoftHistogram::from_counts(grid.clone(), counts.clone(), 2.5).is_ok());
    for bad in [0.0, 1.0, 2.4, 2.6, 100.0] {
        assert!(
            matches!(
                chan_repr::SoftHistogram::from_counts(grid.clone(), counts.clone(), bad),
                Err(ChanError::InconsistentTotal { .. })
            ),
            "total {bad}"
        );
    }
    // Empty coefficients need a zero total.
    let zeros = vec![0.0; grid.len()];
    assert!(chan_repr::SoftHistogram::from_counts(grid.clone(), zeros.clone(), 0.0).is_ok());
    assert!(chan_repr::SoftHistogram::from_counts(grid, zeros, 1.0).is_err());
    // The same check guards deserialising.
    let json = serde_json::to_string(&h).unwrap().replace("2.5", "9.5");
    assert!(serde_json::from_str::<chan_repr::SoftHistogram>(&json).is_err());
}

#[test]
fn cos2_from_a_refuses_windows_beyond_u32() {
    // π/a = 2³² (or 3e300 for a = 1e-300) used to saturate silently to m = u32::MAX.
    for a in [std::f64::consts::PI / 4_294_967_296.0, 1e-300] {
        assert!(
            matches!(
                Kernel::cos2_from_a(a),
                Err(ChanError::InvalidParameter { name: "a", .. })
            ),
            "a = {a}: {:?}",
            Kernel::cos2_from_a(a)
        );
    }
    assert_eq!(
        Kernel::cos2_from_a(std::f64::consts::PI / 4_294_967_295.0),
        Ok(Kernel::Cos2 { m: u32::MAX })
    );
}
