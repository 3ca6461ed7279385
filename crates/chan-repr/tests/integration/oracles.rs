//! Independent oracles for the encoders and decoders, written out from the formulas the docs
//! state (eq. 2.1, 2.2, 2.4, 2.5 and the B-spline and Gaussian decoders of the crate doc): the
//! kernels in closed form, every window's estimate recomputed, exact recovery of a weighted
//! value on the smallest bases (`N` = the window), wide cos² windows and wide Gaussians, the
//! outer product and row-major layout of n-D grids, a 1-D grid against its basis, and
//! histograms as sums of encodings.

use std::f64::consts::PI;

use chan_repr::{ChannelBasis, ChannelGrid, Kernel, PeriodicBasis, SoftHistogram, SparseHistogram};
use proptest::prelude::*;

/// `B(d)` from the docs, written out here: cos²(π/m·d) for `|d| < m/2`, the quadratic B-spline
/// `¾ − d²` / `½(|d| − 3/2)²` for `|d| < 3/2`, `exp(−d²/2σ²)` for `|d| < 4σ`; 0 elsewhere.
fn kernel_value(k: Kernel, d: f64) -> f64 {
    let a = d.abs();
    match k {
        Kernel::Cos2 { m } => {
            let m = f64::from(m);
            if a < m / 2.0 {
                (PI / m * d).cos().powi(2)
            } else {
                0.0
            }
        }
        Kernel::BSpline2 => {
            if a <= 0.5 {
                0.75 - a * a
            } else if a < 1.5 {
                0.5 * (a - 1.5) * (a - 1.5)
            } else {
                0.0
            }
        }
        Kernel::Gaussian { sigma } => {
            if a < 4.0 * sigma {
                (-d * d / (2.0 * sigma * sigma)).exp()
            } else {
                0.0
            }
        }
    }
}

/// Kernels including the unusual ones the docs allow: wide cos² windows, the narrowest and
/// wide Gaussians.
fn kernel() -> impl Strategy<Value = Kernel> {
    prop_oneof![
        (3u32..=16).prop_map(|m| Kernel::Cos2 { m }),
        Just(Kernel::BSpline2),
        prop_oneof![Just(0.5f64), 0.5f64..2.0, 2.0f64..12.0]
            .prop_map(|sigma| Kernel::Gaussian { sigma }),
    ]
}

fn window(k: Kernel) -> usize {
    match k {
        Kernel::Cos2 { m } => m as usize,
        _ => 3,
    }
}

/// A basis of `N` = window … window + 8 channels (the smallest first) with any first centre and
/// spacing.
fn basis() -> impl Strategy<Value = ChannelBasis> {
    (
        kernel(),
        0usize..9,
        -50.0f64..50.0,
        prop_oneof![Just(1.0f64), 1e-3f64..100.0],
    )
        .prop_map(|(k, extra, first, spacing)| {
            let n = if extra >= 6 {
                window(k)
            } else {
                window(k) + extra
            };
            ChannelBasis::new(first, spacing, n, k).unwrap()
        })
}

/// A position in `[0, 1]`, the ends often.
fn unit() -> impl Strategy<Value = f64> {
    prop_oneof![4 => 0.0f64..=1.0, 1 => Just(0.0), 1 => Just(1.0)]
}

fn at(b: &ChannelBasis, u: f64) -> f64 {
    let (lo, hi) = b.representable_range();
    (lo + u * (hi - lo)).clamp(lo, hi)
}

/// A window's estimate (relative to its first channel) from the docs' formulas.
fn window_offset(k: Kernel, c: &[f64]) -> Option<f64> {
    match k {
        Kernel::Cos2 { m } => {
            let a2 = 2.0 * PI / f64::from(m);
            let (mut re, mut im) = (0.0, 0.0);
            for (j, v) in c.iter().enumerate() {
                re += v * (a2 * j as f64).cos();
                im += v * (a2 * j as f64).sin();
            }
            (re != 0.0 || im != 0.0).then(|| im.atan2(re) / a2)
        }
        Kernel::BSpline2 => {
            let s: f64 = c.iter().sum();
            (s > 0.0).then(|| 1.0 + (c[2] - c[0]) / s)
        }
        Kernel::Gaussian { .. } => {
            if c.iter().any(|&v| v <= 0.0) {
                return None;
            }
            // The vertex of the parabola through (0, ln c₀), (1, ln c₁), (2, ln c₂).
            let (y0, y1, y2) = (c[0].ln(), c[1].ln(), c[2].ln());
            let curv = y0 - 2.0 * y1 + y2;
            (curv < 0.0).then(|| 1.0 - (y2 - y0) / (2.0 * curv))
        }
    }
}

/// The next index of a row-major odometer over `0..lens[d]` (last dimension fastest); false
/// after the last.
fn next(idx: &mut [usize], lens: &[usize]) -> bool {
    for d in (0..idx.len()).rev() {
        idx[d] += 1;
        if idx[d] < lens[d] {
            return true;
        }
        idx[d] = 0;
    }
    false
}

fn config(cases: u32) -> ProptestConfig {
    ProptestConfig {
        failure_persistence: None,
        ..crate::seeded(cases)
    }
}

proptest! {
    #![proptest_config(config(256))]

    /// Encoding (eq. 2.1) is `w · B((x − x̃_k)/Δ)` channel by channel, with `B` in closed form,
    /// anywhere in the representable range of the smallest and larger bases; `accumulate` adds
    /// exactly that.
    #[test]
    fn encoding_is_the_weighted_kernel_of_each_centre_distance(
        b in basis(), u in unit(), w in prop_oneof![Just(0.0f64), Just(1.0), 1e-3f64..1e3],
    ) {
        let x = at(&b, u);
        let c = b.encode_weighted(x, w).unwrap();
        prop_assert_eq!(c.len(), b.len());
        let mut out = vec![0.25; b.len()];
        b.accumulate(x, w, &mut out).unwrap();
        for (k, (&ck, &ok)) in c.iter().zip(&out).enumerate() {
            let d = (x - (b.spacing() * k as f64 + b.centre(0))) / b.spacing();
            let want = w * kernel_value(b.kernel(), d);
            prop_assert!((ck - want).abs() <= 1e-12 * w.max(1.0), "k {}: {} vs {}", k, ck, want);
            prop_assert!((ok - 0.25 - ck).abs() <= 1e-12 * w.max(1.0));
        }
    }

    /// A single weighted value is recovered exactly (the crate doc's "exact" decoders): one
    /// mode, at `x`, with weight `w`, and certainty the sum of the channels of a window that
    /// holds it; `decode_best` is that mode. On the smallest bases (`N` = the window, a single
    /// window), wide cos² windows and Gaussians up to σ = 12.
    #[test]
    fn a_weighted_value_is_recovered_exactly(b in basis(), u in unit(), w in 1e-3f64..1e3) {
        let x = at(&b, u);
        let c = b.encode_weighted(x, w).unwrap();
        let modes = b.decode(&c).unwrap();
        prop_assert_eq!(modes.len(), 1, "{:?} x {}: {:?}", b, x, modes);
        let m = modes[0];
        prop_assert!((m.value - x).abs() <= 1e-9 * b.spacing().max(1.0), "{} vs {}", m.value, x);
        prop_assert!((m.weight - w).abs() <= 1e-9 * w, "weight {} vs {}", m.weight, w);
        let wsize = window(b.kernel());
        let sums: Vec<f64> = (0..=b.len() - wsize).map(|l| c[l..l + wsize].iter().sum()).collect();
        prop_assert!(sums.iter().any(|s| (s - m.certainty).abs() <= 1e-12 * s), "{} not in {:?}", m.certainty, sums);
        prop_assert_eq!(b.decode_best(&c).unwrap(), Some(m));
    }

    /// Every window of an arbitrary non-negative channel vector (not only encodings): the
    /// certainty is the window's sum (eq. 2.5), the value `from_index(l + offset)` with the
    /// offset of the docs' decoder (eq. 2.4 for cos², the B-spline ratio, the Gaussian
    /// log-parabola vertex), valid exactly when the offset lies in `valid_offsets` and the
    /// window holds mass.
    #[test]
    fn every_window_estimate_follows_the_documented_decoder(
        b in basis(),
        raw in prop::collection::vec(prop_oneof![2 => Just(0.0f64), 3 => 0.0f64..1.0, 1 => 1e-6f64..1e-3], 24),
    ) {
        let c: Vec<f64> = raw[..b.len().min(24)].to_vec();
        prop_assume!(c.len() == b.len());
        let k = b.kernel();
        let wsize = window(k);
        let windows = b.decode_windows(&c).unwrap();
        prop_assert_eq!(windows.len(), b.len() - wsize + 1);
        let mid = (wsize as f64 - 1.0) / 2.0;
        for (l, e) in windows.iter().enumerate() {
            prop_assert_eq!(e.start, l);
            let win = &c[l..l + wsize];
            let sum: f64 = win.iter().sum();
            prop_assert!((e.certainty - sum).abs() <= 1e-12 * sum.max(1.0));
            let want = window_offset(k, win);
            prop_assert_eq!(e.value.is_some(), want.is_some(), "window {}: {:?} vs {:?}", l, e, want);
            if let (Some(v), Some(mut o)) = (e.value, want) {
                // atan2 lands on −m/2 for a value at the top of the range: the same point.
                if let Kernel::Cos2 { m } = k
                    && o <= -f64::from(m) / 2.0 + 1e-9
                {
                    o += f64::from(m);
                }
                let tol = 1e-9 * (1.0 + o.abs());
                prop_assert!((b.to_index(v) - (l as f64 + o)).abs() <= tol + 1e-9, "window {}: {} vs {}", l, b.to_index(v), l as f64 + o);
                // Away from the borders of the valid range (where the slack decides).
                if (o - (mid - 0.5)).abs() > 1e-6 && (o - (mid + 0.5)).abs() > 1e-6 {
                    let valid = sum > 0.0 && o > mid - 0.5 && o < mid + 0.5;
                    prop_assert_eq!(e.valid, valid, "window {}: offset {}", l, o);
                }
            } else {
                prop_assert!(!e.valid);
            }
        }
    }

    /// Periodic bases: encoding is the kernel of the circular distance to each centre, from
    /// the smallest `N` the kernel allows, for values many turns away from `[0, P)`; the value
    /// decodes back (modulo `P`) with its weight.
    #[test]
    fn periodic_encoding_and_decoding_follow_the_circular_distance(
        k in prop_oneof![(3u32..=8).prop_map(|m| Kernel::Cos2 { m }), Just(Kernel::BSpline2), (0.5f64..1.5).prop_map(|sigma| Kernel::Gaussian { sigma })],
        extra in 0usize..6,
        period in prop_oneof![Just(PI), Just(360.0f64), 0.01f64..1e3],
        turns in -5i32..5,
        u in 0.0f64..1.0,
        w in 1e-3f64..1e3,
    ) {
        // From the smallest N the constructor accepts: every accepted basis must decode.
        let smallest = (1..64).find(|&n| PeriodicBasis::new(period, n, k).is_ok()).unwrap();
        let b = PeriodicBasis::new(period, smallest + extra, k).unwrap();
        let x = (u + f64::from(turns)) * period;
        let c = b.encode_weighted(x, w).unwrap();
        let spacing = period / b.len() as f64;
        for (j, &cj) in c.iter().enumerate() {
            let d = (x - j as f64 * spacing).rem_euclid(period);
            let d = d.min(period - d) / spacing;
            let want = w * kernel_value(k, d);
            prop_assert!((cj - want).abs() <= 1e-9 * w, "channel {}: {} vs {}", j, cj, want);
        }
        let modes = b.decode(&c).unwrap();
        prop_assert_eq!(modes.len(), 1, "{:?}", modes);
        let d = (modes[0].value - x).rem_euclid(period);
        prop_assert!(d.min(period - d) <= 1e-9 * period, "{} vs {}", modes[0].value, x);
        prop_assert!((0.0..period).contains(&modes[0].value));
        prop_assert!((modes[0].weight - w).abs() <= 1e-9 * w);
    }
}

proptest! {
    #![proptest_config(config(96))]

    /// n-D grids: the encoding is the outer product of the bases' encodings laid out row-major
    /// (last dimension fastest, indices computed here), `flat_index` is that layout, a weighted
    /// vector decodes to itself with its weight, a 1-D grid decodes as its basis does, and a
    /// soft (dense or sparse) histogram is the sum of its weighted encodings and decodes as
    /// the grid decodes that sum.
    #[test]
    fn grids_and_histograms_follow_the_outer_product(
        bases in prop::collection::vec(basis(), 1..=3),
        us in prop::collection::vec(unit(), 3),
        pts in prop::collection::vec((prop::collection::vec(unit(), 3), 0.0f64..5.0), 0..6),
        w in 1e-3f64..1e3,
    ) {
        prop_assume!(bases.iter().map(|b| b.len()).product::<usize>() <= 20_000);
        let grid = ChannelGrid::new(bases.clone()).unwrap();
        let x: Vec<f64> = bases.iter().zip(&us).map(|(b, &u)| at(b, u)).collect();
        let c = grid.encode_weighted(&x, w).unwrap();
        let per: Vec<Vec<f64>> = bases.iter().zip(&x).map(|(b, &xi)| b.encode(xi).unwrap()).collect();
        // Row-major odometer over the per-dimension indices, last dimension fastest.
        let lens: Vec<usize> = bases.iter().map(|b| b.len()).collect();
        let mut idx = vec![0usize; bases.len()];
        let mut flat = 0usize;
        loop {
            let want = w * idx.iter().enumerate().map(|(d, &i)| per[d][i]).product::<f64>();
            prop_assert!((c[flat] - want).abs() <= 1e-12 * w.max(1.0), "{:?}: {} vs {}", idx, c[flat], want);
            prop_assert_eq!(grid.flat_index(&idx).unwrap(), flat);
            flat += 1;
            if !next(&mut idx, &lens) {
                break;
            }
        }
        prop_assert_eq!(flat, grid.len());
        let modes = grid.decode(&c).unwrap();
        prop_assert_eq!(modes.len(), 1, "{:?}", modes);
        for (d, b) in bases.iter().enumerate() {
            prop_assert!((modes[0].value[d] - x[d]).abs() <= 1e-9 * b.spacing().max(1.0));
        }
        prop_assert!((modes[0].weight - w).abs() <= 1e-9 * w, "weight {} vs {}", modes[0].weight, w);
        if bases.len() == 1 {
            let one = bases[0].decode(&c).unwrap();
            prop_assert_eq!(one.len(), modes.len());
            for (a, m) in one.iter().zip(&modes) {
                prop_assert!((a.value - m.value[0]).abs() <= 1e-12 * a.value.abs().max(1.0));
                prop_assert!((a.certainty - m.certainty).abs() <= 1e-12 * a.certainty);
                prop_assert!((a.weight - m.weight).abs() <= 1e-12 * a.weight);
            }
        }
        // Histograms: the sum of the weighted encodings.
        let mut dense = SoftHistogram::new(grid.clone()).unwrap();
        let mut sparse = SparseHistogram::new(grid.clone());
        let mut sum = vec![0.0; grid.len()];
        let mut total = 0.0;
        for (u, wi) in &pts {
            let xi: Vec<f64> = bases.iter().zip(u).map(|(b, &s)| at(b, s)).collect();
            dense.add(&xi, *wi).unwrap();
            sparse.add(&xi, *wi).unwrap();
            for (s, e) in sum.iter_mut().zip(grid.encode(&xi).unwrap()) {
                *s += wi * e;
            }
            total += wi;
        }
        prop_assert!((dense.total_weight() - total).abs() <= 1e-12 * total.max(1.0));
        prop_assert!((sparse.total_weight() - total).abs() <= 1e-12 * total.max(1.0));
        for (k, (&h, &s)) in dense.counts().iter().zip(&sum).enumerate() {
            prop_assert!((h - s).abs() <= 1e-12 * total.max(1.0), "channel {}: {} vs {}", k, h, s);
            prop_assert!((sparse.get(k) - s).abs() <= 1e-12 * total.max(1.0));
        }
        let want = grid.decode(&sum).unwrap();
        let got = dense.decode().unwrap();
        prop_assert_eq!(got.len(), want.len());
        for (g, m) in got.iter().zip(&want) {
            for (a, b) in g.value.iter().zip(&m.value) {
                prop_assert!((a - b).abs() <= 1e-9 * a.abs().max(1.0));
            }
            prop_assert!((g.weight - m.weight).abs() <= 1e-9 * m.weight.max(1.0));
        }
    }
}

/// `max_active` is the most channels one value touches: counted by brute force over dense
/// positions in a long basis (it bounds the grid's size check, and was one too many for cos²,
/// the B-spline and Gaussians with an integer `8σ`).
#[test]
fn max_active_bounds_the_channels_one_value_touches() {
    let kernels = [
        Kernel::Cos2 { m: 3 },
        Kernel::Cos2 { m: 4 },
        Kernel::Cos2 { m: 9 },
        Kernel::BSpline2,
        Kernel::Gaussian { sigma: 0.5 },
        Kernel::Gaussian { sigma: 0.8 },
        Kernel::Gaussian { sigma: 2.3 },
        Kernel::Gaussian { sigma: 4.0 },
    ];
    for k in kernels {
        let b = ChannelBasis::integer(80, k).unwrap();
        let mut most = 0;
        for i in 0..=4000 {
            let t = 30.0 + 2.0 * f64::from(i) / 4000.0;
            let mut count = 0;
            b.for_each_active(t, |_, v| {
                assert!(v > 0.0);
                count += 1;
            });
            // Every channel with a non-zero closed-form value, and only those.
            let want = (0..80)
                .filter(|&j| kernel_value(k, t - j as f64) > 0.0)
                .count();
            assert_eq!(count, want, "{k:?} at {t}");
            most = most.max(count);
        }
        assert_eq!(most, k.max_active(), "{k:?}");
    }
}

/// Periodic quadratic B-splines need 5 channels: with 3, a value encoded at 0.44 P decoded to
/// two modes of equal certainty, the first (`decode_best`) half a turn away at 0.1 P; with 4,
/// a value at 0 also gave a spurious mode at P/2. Such bases are refused; from 5 channels every
/// value of the circle decodes to itself alone.
#[test]
fn periodic_b_splines_with_fewer_than_5_channels_are_refused() {
    for n in [3, 4] {
        assert!(matches!(
            PeriodicBasis::new(360.0, n, Kernel::BSpline2),
            Err(chan_repr::ChanError::TooFewChannels { got, needed: 5 }) if got == n
        ));
    }
    let b = PeriodicBasis::new(360.0, 5, Kernel::BSpline2).unwrap();
    for i in 0..2000 {
        let x = 360.0 * f64::from(i) / 2000.0;
        let modes = b.decode(&b.encode(x).unwrap()).unwrap();
        assert_eq!(modes.len(), 1, "x = {x}: {modes:?}");
        let d = (modes[0].value - x).rem_euclid(360.0);
        assert!(d.min(360.0 - d) < 1e-9, "x = {x}: {modes:?}");
    }
}

/// A basis covering `[lo, hi]` accepts both ends however fine its channels are next to the
/// coordinates' magnitude: the index `(x − first)/spacing` of a far value rounds by a few ulps
/// of `|x|/spacing` channels, more than the range test's 1e-9 once channels are finer than
/// about 1e-6 of the coordinates (an axis at −664 with channels of 2e-5 refused its own end).
#[test]
fn a_covering_basis_accepts_its_ends_at_any_magnitude() {
    let mut s = 0x2545_F491_4F6C_DD1Du64;
    let mut uniform = |lo: f64, hi: f64| {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        lo + (hi - lo) * ((s >> 11) as f64 / (1u64 << 53) as f64)
    };
    let kernels = [
        Kernel::Cos2 { m: 3 },
        Kernel::BSpline2,
        Kernel::Gaussian { sigma: 1.5 },
    ];
    let mut checked = 0;
    for i in 0..2000 {
        let magnitude = 10f64.powf(uniform(0.0, 12.0));
        let lo = uniform(-1.0, 1.0) * magnitude;
        let n = 5 + (uniform(0.0, 300.0) as usize);
        let width = magnitude * 10f64.powf(uniform(-9.0, 0.0)) * n as f64;
        let hi = lo + width;
        if hi <= lo {
            continue;
        }
        let kernel = kernels[i % kernels.len()];
        let Ok(b) = ChannelBasis::covering(lo, hi, n, kernel) else {
            continue;
        };
        assert!(
            b.checked_index(lo).is_ok() && b.checked_index(hi).is_ok(),
            "covering({lo:e}, {hi:e}, {n}, {kernel:?}): {:?} {:?}",
            b.checked_index(lo),
            b.checked_index(hi)
        );
        // Beyond the ends by a part in a million of the width: still refused.
        assert!(
            b.checked_index(hi + 1e-6 * width).is_err(),
            "{lo:e} {hi:e} {n}"
        );
        checked += 1;
    }
    assert!(checked > 1900, "{checked} of 2000 bases built");
    let b = ChannelBasis::covering(
        -664.4752303073518,
        -664.4679115648704,
        350,
        Kernel::Gaussian { sigma: 1.5 },
    )
    .unwrap();
    assert!(b.checked_index(-664.4679115648704).is_ok());
}
