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
    // Wide Gaussian channels: a small window, but one value would touch 32² = 1,024 channels
    // (strictly inside 4σ = 16) per pair of dimensions, 32⁵ ≈ 3.4e7 > 2²⁴ in five.
    let g = ChannelBasis::integer(40, Kernel::Gaussian { sigma: 4.0 }).unwrap();
    assert!(ChannelGrid::new(vec![g.clone(); 4]).is_ok());
    assert!(matches!(
        ChannelGrid::new(vec![g; 5]),
        Err(ChanError::GridTooLarge { what, got, .. }) if what.contains("touches") && got == 32usize.pow(5)
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

#[test]
fn periodic_values_are_accepted_up_to_exactly_the_turn_limit() {
    // `PERIODIC_MAX_TURNS` is the largest |x| / P accepted: the limit itself encodes, the next
    // number beyond it is refused with the bound in the error.
    use chan_repr::PERIODIC_MAX_TURNS;
    let period = 360.0;
    let b = PeriodicBasis::new(period, 24, Kernel::Cos2 { m: 3 }).unwrap();
    let bound = PERIODIC_MAX_TURNS * period;
    for x in [bound, -bound] {
        let c = b.encode(x).unwrap();
        assert_eq!(c, b.encode(0.0).unwrap(), "{x}"); // a whole number of turns
    }
    for x in [bound.next_up(), (-bound).next_down(), 1.5 * bound] {
        assert_eq!(
            b.encode(x),
            Err(ChanError::OutOfRange {
                value: x,
                lo: -bound,
                hi: bound
            }),
            "{x}"
        );
    }
}

#[test]
fn wrapping_never_returns_the_period_itself() {
    // rem_euclid of a tiny negative number rounds up to P: `wrap` and `to_index` promise
    // [0, P) and [0, N).
    let b = PeriodicBasis::new(std::f64::consts::TAU, 8, Kernel::Cos2 { m: 3 }).unwrap();
    for x in [-1e-300, -1e-17, -0.0, 0.0, -f64::MIN_POSITIVE] {
        let w = b.wrap(x);
        assert!((0.0..b.period()).contains(&w), "wrap({x}) = {w}");
        let t = b.to_index(x);
        assert!((0.0..8.0).contains(&t), "to_index({x}) = {t}");
    }
}

#[test]
fn gaussians_are_accepted_from_exactly_the_minimum_width() {
    use chan_repr::GAUSSIAN_MIN_SIGMA;
    assert_eq!(
        Kernel::Gaussian {
            sigma: GAUSSIAN_MIN_SIGMA
        }
        .validate(),
        Ok(())
    );
    let b = ChannelBasis::integer(
        12,
        Kernel::Gaussian {
            sigma: GAUSSIAN_MIN_SIGMA,
        },
    )
    .unwrap();
    let mode = b.decode_best(&b.encode(6.3).unwrap()).unwrap().unwrap();
    assert!((mode.value - 6.3).abs() < 1e-9, "{mode:?}");
    let below = GAUSSIAN_MIN_SIGMA.next_down();
    assert!(matches!(
        Kernel::Gaussian { sigma: below }.validate(),
        Err(ChanError::TooNarrow { .. })
    ));
}

#[test]
fn grid_deserialisation_runs_the_constructors_checks() {
    // A grid is serialised as its list of bases; a list `ChannelGrid::new` refuses is a serde
    // error carrying the constructor's message.
    let b = ChannelBasis::integer(4, Kernel::BSpline2).unwrap();
    for bases in [vec![], vec![b.clone(); 8]] {
        let typed = ChannelGrid::new(bases.clone()).unwrap_err();
        let json = serde_json::to_string(&bases).unwrap();
        let err = serde_json::from_str::<ChannelGrid>(&json)
            .unwrap_err()
            .to_string();
        assert!(err.starts_with(&typed.to_string()), "{err}");
    }
    let g = ChannelGrid::new(vec![b.clone(); 7]).unwrap();
    let back: ChannelGrid = serde_json::from_str(&serde_json::to_string(&g).unwrap()).unwrap();
    assert_eq!(back, g);
    assert_eq!(back.strides(), g.strides());
}

#[test]
fn gaussians_are_exactly_zero_from_four_sigma() {
    // "truncated to exactly 0 beyond 4σ": the support radius is 4σ and the kernel is 0 there,
    // so encoding stays sparse; just inside it is the Gaussian itself.
    use chan_repr::GAUSSIAN_SUPPORT_SIGMAS;
    assert_eq!(GAUSSIAN_SUPPORT_SIGMAS, 4.0);
    for sigma in [0.5, 1.0, 2.5] {
        let k = Kernel::Gaussian { sigma };
        let r = 4.0 * sigma;
        assert_eq!(k.support_radius(), r);
        for d in [r, -r, r + 1e-9, 10.0 * r] {
            assert_eq!(k.value(d), 0.0, "σ = {sigma}, d = {d}");
        }
        let inside = r.next_down();
        assert_eq!(
            k.value(inside),
            (-inside * inside / (2.0 * sigma * sigma)).exp()
        );
    }
    // A value on a channel centre touches exactly the channels strictly inside 4σ.
    let b = ChannelBasis::integer(40, Kernel::Gaussian { sigma: 1.0 }).unwrap();
    let c = b.encode(20.0).unwrap();
    let active: Vec<usize> = (0..40).filter(|&k| c[k] != 0.0).collect();
    assert_eq!(active, (16..=22).collect::<Vec<_>>()); // centres 17..=23, |d| < 4
}

#[test]
fn cos2_from_a_accepts_pi_over_a_within_1e_9_of_an_integer() {
    use std::f64::consts::PI;
    assert_eq!(
        Kernel::cos2_from_a(PI / (3.0 + 5e-10)),
        Ok(Kernel::Cos2 { m: 3 })
    );
    assert_eq!(
        Kernel::cos2_from_a(PI / (4.0 - 5e-10)),
        Ok(Kernel::Cos2 { m: 4 })
    );
    for a in [PI / (3.0 + 2e-9), PI / (4.0 - 2e-9)] {
        assert!(
            matches!(
                Kernel::cos2_from_a(a),
                Err(ChanError::InvalidParameter { name: "a", .. })
            ),
            "a = {a}"
        );
    }
}

#[test]
fn periodic_windows_are_all_n_windows_with_values_on_the_circle() {
    // "N windows …, window l covering channels l, …, l+W−1 modulo N; values in [0, P)",
    // valid or not.
    use std::f64::consts::TAU;
    for kernel in [
        Kernel::Cos2 { m: 3 },
        Kernel::Cos2 { m: 5 },
        Kernel::BSpline2,
    ] {
        let b = PeriodicBasis::new(TAU, 10, kernel).unwrap();
        for i in 0..=60 {
            let x = TAU * i as f64 / 60.0 - 1e-13;
            let mut c = b.encode(x).unwrap();
            b.accumulate(x + 2.0, 0.5, &mut c).unwrap();
            let windows = b.decode_windows(&c).unwrap();
            assert_eq!(windows.len(), 10, "{kernel:?}");
            for (l, w) in windows.iter().enumerate() {
                assert_eq!(w.start, l);
                if let Some(v) = w.value {
                    assert!((0.0..TAU).contains(&v), "{kernel:?} x={x} window {l}: {v}");
                }
            }
            assert!(windows.iter().any(|w| w.valid), "{kernel:?} x={x}");
        }
    }
}

/// Every way `accumulate` can refuse a call into an output of `n` channels: the value `x` (one
/// coordinate per dimension), the weight and the output length, with the error it must give.
/// `good` is an accepted value, `near` a value just outside the representable range whose
/// kernel still reaches channels inside it (so a range check done too late would write there),
/// `far` one far outside it.
type AccumulateCase = (Vec<f64>, f64, usize, fn(&ChanError) -> bool);

fn accumulate_refusals(good: &[f64], near: &[f64], far: &[f64], n: usize) -> Vec<AccumulateCase> {
    let with = |d: usize, v: f64| {
        let mut x = good.to_vec();
        x[d] = v;
        x
    };
    let last = good.len() - 1;
    let non_finite = |e: &ChanError| matches!(e, ChanError::NonFinite { .. });
    let out_of_range = |e: &ChanError| matches!(e, ChanError::OutOfRange { .. });
    let negative = |e: &ChanError| matches!(e, ChanError::Negative { .. });
    let too_large = |e: &ChanError| matches!(e, ChanError::TooLarge { .. });
    let length = |e: &ChanError| matches!(e, ChanError::LengthMismatch { .. });
    vec![
        (with(last, f64::NAN), 1.0, n, non_finite),
        (with(0, f64::INFINITY), 1.0, n, non_finite),
        (with(last, f64::NEG_INFINITY), 1.0, n, non_finite),
        (near.to_vec(), 1.0, n, out_of_range),
        (far.to_vec(), 1.0, n, out_of_range),
        (good.to_vec(), -1.0, n, negative),
        (good.to_vec(), f64::NAN, n, non_finite),
        (good.to_vec(), f64::INFINITY, n, non_finite),
        (good.to_vec(), 2.0 * chan_repr::MAX_MASS, n, too_large),
        (good.to_vec(), 1.0, n - 1, length),
        (good.to_vec(), 1.0, n + 1, length),
    ]
}

/// Runs every refusal of [`accumulate_refusals`] through `accumulate` on an output already
/// holding one encoded value, and checks that each is refused with its error and leaves the
/// output exactly as it was (bit for bit), whatever its length.
fn check_refusals(
    name: &str,
    n: usize,
    cases: Vec<AccumulateCase>,
    accumulate: impl Fn(&[f64], f64, &mut [f64]) -> Result<(), ChanError>,
    start: &[f64],
) {
    for (x, weight, len, expected) in cases {
        let mut out: Vec<f64> = (0..len)
            .map(|k| start.get(k).copied().unwrap_or(0.25))
            .collect();
        let before: Vec<u64> = out.iter().map(|v| v.to_bits()).collect();
        let err = accumulate(&x, weight, &mut out).expect_err(&format!(
            "{name}: x {x:?}, weight {weight}, {len} of {n} channels"
        ));
        assert!(
            expected(&err),
            "{name}: x {x:?}, weight {weight}, len {len}: {err:?}"
        );
        let after: Vec<u64> = out.iter().map(|v| v.to_bits()).collect();
        assert_eq!(
            after, before,
            "{name}: x {x:?}, weight {weight}, len {len} changed the output"
        );
    }
}

#[test]
fn a_refused_accumulate_leaves_the_output_unchanged() {
    // "A rejected value leaves `out` unchanged", for the bounded, periodic and n-D encoders:
    // every check (weight, output length, value) comes before the first channel is written.
    let b = ChannelBasis::integer(10, Kernel::Cos2 { m: 3 }).unwrap(); // representable [1.5, 9.5]
    let start = b.encode(3.3).unwrap();
    check_refusals(
        "ChannelBasis",
        10,
        accumulate_refusals(&[4.2], &[1.2], &[40.0], 10),
        |x, w, out| b.accumulate(x[0], w, out),
        &start,
    );

    let p = PeriodicBasis::new(std::f64::consts::TAU, 8, Kernel::BSpline2).unwrap();
    let bound = chan_repr::PERIODIC_MAX_TURNS * std::f64::consts::TAU;
    let start = p.encode(1.0).unwrap();
    check_refusals(
        "PeriodicBasis",
        8,
        accumulate_refusals(&[2.0], &[bound.next_up()], &[1e300], 8),
        |x, w, out| p.accumulate(x[0], w, out),
        &start,
    );

    let g = ChannelGrid::new(vec![
        b.clone(),
        ChannelBasis::integer(6, Kernel::BSpline2).unwrap(), // representable [1.5, 5.5]
    ])
    .unwrap();
    let start = g.encode(&[3.3, 2.0]).unwrap();
    let mut cases = accumulate_refusals(&[4.2, 3.0], &[4.2, 5.6], &[4.2, 60.0], g.len());
    // Wrong numbers of coordinates, and a bad coordinate after a good one.
    let length = |e: &ChanError| matches!(e, ChanError::LengthMismatch { .. });
    cases.push((vec![4.2], 1.0, g.len(), length));
    cases.push((vec![4.2, 3.0, 3.0], 1.0, g.len(), length));
    cases.push((vec![1.2, 3.0], 1.0, g.len(), |e| {
        matches!(e, ChanError::OutOfRange { .. })
    }));
    check_refusals(
        "ChannelGrid",
        g.len(),
        cases,
        |x, w, out| g.accumulate(x, w, out),
        &start,
    );

    // The outputs still take values as before: the accepted twin of each call.
    let mut out = b.encode(3.3).unwrap();
    b.accumulate(4.2, 0.5, &mut out).unwrap();
    let mut twin = b.encode(3.3).unwrap();
    for (k, v) in b.encode_weighted(4.2, 0.5).unwrap().into_iter().enumerate() {
        twin[k] += v;
    }
    assert_eq!(out, twin);
}

#[test]
fn every_basis_fits_a_one_dimensional_histogram() {
    // `SoftHistogram::one_d` builds a 1-D grid of any basis and expected that never to fail,
    // but a cos² window wider than `MAX_WINDOW_CHANNELS` (m = 4097, so at least 4097
    // channels) made `ChannelGrid::new` refuse the grid: `one_d` panicked. Such bases are now
    // refused where they are made, with the grid's error.
    use chan_repr::{MAX_WINDOW_CHANNELS, SoftHistogram};
    let widest = MAX_WINDOW_CHANNELS as u32;
    for m in [widest, widest + 1, 2 * widest] {
        if let Ok(b) = ChannelBasis::integer(m as usize + 2, Kernel::Cos2 { m }) {
            let _ = SoftHistogram::one_d(b);
        }
    }
    let refused = |r: Result<ChannelBasis, ChanError>| {
        matches!(
            r,
            Err(ChanError::GridTooLarge { got, max, .. })
                if got == widest as usize + 1 && max == MAX_WINDOW_CHANNELS
        )
    };
    let m = widest + 1;
    assert!(refused(ChannelBasis::integer(
        m as usize + 2,
        Kernel::Cos2 { m }
    )));
    assert!(refused(ChannelBasis::covering(
        0.0,
        1.0,
        m as usize + 2,
        Kernel::Cos2 { m }
    )));
    let json = format!(
        r#"{{"kernel":{{"cos2":{{"m":{m}}}}},"channels":{},"first_centre":0.0,"spacing":1.0}}"#,
        m + 2
    );
    let err = serde_json::from_str::<ChannelBasis>(&json).unwrap_err();
    assert!(err.to_string().contains("decoding window"), "{err}");
    // The kernel itself is still valid (periodic bases do not make grids), and the widest
    // window accepted works end to end.
    assert!(Kernel::Cos2 { m }.validate().is_ok());
    let b = ChannelBasis::integer(widest as usize + 2, Kernel::Cos2 { m: widest }).unwrap();
    let mut h = SoftHistogram::one_d(b.clone());
    let x = b.representable_range().0 + 0.25;
    h.add(&[x], 1.0).unwrap();
    let modes = h.decode().unwrap();
    assert!((modes[0].value[0] - x).abs() < 1e-6, "{modes:?}");
}

#[test]
fn periodic_active_channels_of_huge_coordinates_do_not_overflow() {
    // `PeriodicBasis::for_each_active` takes an unvalidated coordinate; beyond about 9.2e18
    // the saturated first channel plus N − 1 overflowed (a panic in debug builds, nothing
    // visited after wrapping in release builds). Out of its domain it now visits at most N
    // channels, each once; inside it nothing changed.
    use std::f64::consts::TAU;
    for kernel in [Kernel::Cos2 { m: 3 }, Kernel::BSpline2] {
        let p = PeriodicBasis::new(TAU, 8, kernel).unwrap();
        for t in [
            9.3e18,
            1e300,
            f64::MAX,
            f64::INFINITY,
            -1e300,
            f64::NEG_INFINITY,
            f64::NAN,
        ] {
            let mut seen = Vec::new();
            p.for_each_active(t, |k, v| seen.push((k, v)));
            assert!(seen.len() <= 8, "{kernel:?} at {t}: {seen:?}");
        }
        let mut inside = Vec::new();
        p.for_each_active(p.to_index(1.0), |k, v| inside.push((k, v)));
        let c = p.encode(1.0).unwrap();
        assert!(!inside.is_empty());
        for (k, v) in inside {
            assert_eq!(c[k], v);
        }
    }
}
