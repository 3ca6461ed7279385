//! Hostile inputs to the public API: each must give a typed error (or a correct answer), never
//! a panic, an infinite or NaN value claimed valid, or a silently empty encoding.

use chan_repr::{ChanError, ChannelBasis, ChannelGrid, Kernel};

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
