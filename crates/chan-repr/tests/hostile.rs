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
