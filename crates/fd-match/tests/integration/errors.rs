//! Bad input gives typed errors, never a panic; a refused call changes no state.

use crate::common;

use common::star;
use fd_match::*;

fn ex() -> Extractor {
    Extractor::new(DescriptorConfig::default()).unwrap()
}

#[test]
fn too_few_points() {
    assert_eq!(
        ex().describe::<(f64, f64)>(&[]).unwrap_err(),
        FdError::TooFewPoints { got: 0 }
    );
    assert_eq!(
        ex().describe(&[(1, 1), (2, 2)]).unwrap_err(),
        FdError::TooFewPoints { got: 2 }
    );
    // A single MSER pixel, closed explicitly.
    assert_eq!(
        ex().describe(&[(5u32, 5u32), (5, 5)]).unwrap_err(),
        FdError::TooFewPoints { got: 1 }
    );
}

#[test]
fn zero_area() {
    for c in [
        vec![(0.0, 0.0), (1.0, 1.0), (2.0, 2.0)],
        // A one-pixel-wide line traced out and back.
        vec![(0.0, 0.0), (1.0, 0.0), (2.0, 0.0), (1.0, 0.0)],
    ] {
        assert!(
            matches!(ex().describe(&c), Err(FdError::ZeroArea { .. })),
            "{c:?}"
        );
    }
}

#[test]
fn repeated_points() {
    assert_eq!(
        ex().describe(&[[0.0, 0.0], [3.0, 0.0], [3.0, 0.0], [0.0, 2.0]])
            .unwrap_err(),
        FdError::RepeatedPoint {
            index: 2,
            x: 3.0,
            y: 0.0
        }
    );
}

#[test]
fn non_finite_coordinates() {
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        assert!(matches!(
            ex().describe(&[(0.0, 0.0), (3.0, bad), (0.0, 2.0)]),
            Err(FdError::NonFinite { index: 1, .. })
        ));
    }
}

#[test]
fn invalid_configuration() {
    let cfg = DescriptorConfig {
        coefficients: 52,
        ..DescriptorConfig::default()
    };
    assert!(matches!(
        Extractor::new(cfg),
        Err(FdError::InvalidParameter {
            name: "coefficients",
            ..
        })
    ));
    assert!(describe_all(cfg, &[vec![(0, 0), (1, 0), (0, 1)]]).is_err());
}

#[test]
fn describe_all_collects_rejections_in_input_order() {
    let contours: Vec<Vec<(i32, i32)>> = vec![
        vec![(0, 0), (1, 1)],
        vec![(0, 0), (10, 0), (10, 7), (0, 7)],
        vec![(0, 0), (1, 0), (2, 0)],
        vec![(0, 0), (6, 1), (2, 5)],
    ];
    let d = describe_all(DescriptorConfig::default(), &contours).unwrap();
    assert_eq!(d.set.sources(), &[1, 3]);
    let idx: Vec<usize> = d.rejected.iter().map(|r| r.0).collect();
    assert_eq!(idx, vec![0, 2]);
    assert!(matches!(d.rejected[1].1, FdError::ZeroArea { .. }));
}

#[test]
fn accepted_descriptors_have_finite_afds() {
    // (The `DegenerateFirstHarmonic` error itself is unit-tested on an exact FD in `afd.rs`:
    // resampled polygons practically never hit it exactly.)
    let d = ex().describe(&[(0, 0), (9, 0), (9, 1), (0, 1)]).unwrap();
    assert!(d.afd0.iter().all(|v| v.is_finite()));
    assert!(d.afd1.iter().all(|v| v.re.is_finite() && v.im.is_finite()));
}

#[test]
fn pixel_contours_of_all_integer_types_are_accepted() {
    let sq32: Vec<(u32, u32)> = vec![
        (2, 2),
        (3, 2),
        (4, 2),
        (4, 3),
        (4, 4),
        (3, 4),
        (2, 4),
        (2, 3),
    ];
    let sqf: Vec<[f64; 2]> = sq32.iter().map(|&(x, y)| [x as f64, y as f64]).collect();
    let a = ex().describe(&sq32).unwrap();
    let b = ex().describe(&sqf).unwrap();
    assert_eq!(a, b);
    // Clockwise input is reoriented: same descriptor.
    let rev: Vec<(u32, u32)> = sq32.iter().rev().copied().collect();
    let c = ex().describe(&rev).unwrap();
    let e = Correlator::new(25, 256)
        .unwrap()
        .correlate(&a.fd, &c.fd)
        .unwrap()
        .error;
    assert!(e < 1e-9, "{e}");
}

/// Issue 24 #8: a sample count that would need a huge allocation is a typed error from
/// `validate()`, before anything is allocated; deserialising applies the same checks.
#[test]
fn huge_sample_counts_are_rejected_before_allocating() {
    for cfg in [
        DescriptorConfig {
            samples: usize::MAX,
            dense_samples: usize::MAX,
            ..DescriptorConfig::default()
        },
        DescriptorConfig {
            samples: MAX_SAMPLES + 1,
            dense_samples: MAX_DENSE_SAMPLES,
            ..DescriptorConfig::default()
        },
        DescriptorConfig {
            dense_samples: MAX_DENSE_SAMPLES + 1,
            ..DescriptorConfig::default()
        },
    ] {
        assert!(
            matches!(cfg.validate(), Err(FdError::InvalidParameter { .. })),
            "{cfg:?}"
        );
        assert!(Extractor::new(cfg).is_err());
        assert!(DescriptorSet::new(cfg).is_err());
        let json = serde_json::to_string(&cfg).unwrap();
        assert!(
            serde_json::from_str::<DescriptorConfig>(&json).is_err(),
            "{json}"
        );
    }
    // The limits themselves are accepted.
    let edge = DescriptorConfig {
        samples: MAX_SAMPLES,
        dense_samples: MAX_DENSE_SAMPLES,
        ..DescriptorConfig::default()
    };
    assert!(edge.validate().is_ok());
    let json = serde_json::to_string(&edge).unwrap();
    assert_eq!(
        serde_json::from_str::<DescriptorConfig>(&json).unwrap(),
        edge
    );
    // Every other check of `validate` also runs on deserialisation.
    let even = serde_json::to_string(&DescriptorConfig {
        coefficients: 50,
        ..DescriptorConfig::default()
    })
    .unwrap();
    assert!(serde_json::from_str::<DescriptorConfig>(&even).is_err());
}

/// Issue 24 #9: NaN, infinite or non-normalised descriptors are refused by `push`, which leaves
/// the set unchanged.
#[test]
fn push_refuses_non_finite_and_unnormalised_descriptors() {
    let good = ex().describe(&[(0, 0), (9, 0), (9, 4), (0, 4)]).unwrap();
    let mut set = DescriptorSet::new(DescriptorConfig::default()).unwrap();
    set.push(&good, 7).unwrap();
    let before = set.clone();
    let mut nan = good.clone();
    nan.fd[3].re = f64::NAN;
    assert_eq!(
        set.push(&nan, 8),
        Err(FdError::NonFiniteDescriptor {
            part: "fd",
            index: 3
        })
    );
    let mut inf = good.clone();
    inf.afd0[0] = f64::INFINITY;
    assert!(matches!(
        set.push(&inf, 8),
        Err(FdError::NonFiniteDescriptor { part: "afd0", .. })
    ));
    let mut nan1 = good.clone();
    nan1.afd1[5].im = f64::NAN;
    assert!(matches!(
        set.push(&nan1, 8),
        Err(FdError::NonFiniteDescriptor { part: "afd1", .. })
    ));
    let mut big = good.clone();
    big.fd.iter_mut().for_each(|c| *c *= 2.0);
    assert!(matches!(
        set.push(&big, 8),
        Err(FdError::NotUnitNorm { part: "fd", .. })
    ));
    assert_eq!(set, before);
}

/// Issue 24 #9: correlating FDs of different (or wrong) lengths or with NaN is a typed error,
/// not an error value of 2.0; the SSDs refuse different lengths instead of comparing a prefix.
#[test]
fn pair_errors_refuse_mismatched_inputs() {
    let a = ex().describe(&[(0, 0), (9, 0), (9, 4), (0, 4)]).unwrap();
    let mut cor = Correlator::new(25, 256).unwrap();
    assert!(matches!(
        cor.correlate(&a.fd, &a.fd[..10]),
        Err(FdError::LengthMismatch {
            left: 50,
            right: 10,
            expected: 50
        })
    ));
    assert!(matches!(
        cor.correlate(&a.fd[..10], &a.fd[..10]),
        Err(FdError::LengthMismatch { .. })
    ));
    let mut nan = a.fd.clone();
    nan[0].im = f64::NAN;
    assert!(matches!(
        cor.correlate(&a.fd, &nan),
        Err(FdError::NonFiniteDescriptor {
            part: "b",
            index: 0
        })
    ));
    assert!(matches!(
        cor.correlate_below(&a.fd, &a.fd[..1], 0.1),
        Err(FdError::LengthMismatch { .. })
    ));
    assert!(cor.correlate(&a.fd, &a.fd).unwrap().error < 1e-12);
    assert!(matches!(
        ssd_real(&[1.0, 2.0, 3.0], &[1.0]),
        Err(FdError::LengthMismatch {
            left: 3,
            right: 1,
            ..
        })
    ));
    assert!(matches!(
        ssd_complex(&a.fd, &a.fd[1..]),
        Err(FdError::LengthMismatch { .. })
    ));
    assert_eq!(ssd_real(&[1.0, 2.0], &[1.0, 4.0]), Ok(4.0));
}

/// Issue 24 #10: a valid square with coordinates near 1e200 (or 1e-200) is described like the
/// same square at unit size, not called "zero area"; `resample` returns the input's scale.
#[test]
fn extreme_coordinates_are_described_like_moderate_ones() {
    let unit: Vec<(f64, f64)> = vec![(0.0, 0.0), (3.0, 0.0), (3.0, 1.0), (1.0, 2.0), (0.0, 1.0)];
    for sampling in [
        Sampling::ArcLength,
        Sampling::AffineArcLength,
        Sampling::Canonical,
    ] {
        // σ = 0 (one dense sample spacing): every sampling is then scale invariant.
        let cfg = DescriptorConfig {
            smoothing: 0.0,
            ..DescriptorConfig::with_sampling(sampling)
        };
        let mut e = Extractor::new(cfg).unwrap();
        let want = e.describe(&unit).unwrap();
        for s in [1e200f64, 1e-200, 1e300, 1e-300, 1e30] {
            // A power-of-two scale is exact, so the shape is exactly the unit one...
            let p2 = 2f64.powi(s.log2().round() as i32);
            let scaled: Vec<(f64, f64)> = unit.iter().map(|&(x, y)| (x * p2, y * p2)).collect();
            let got = e
                .describe(&scaled)
                .unwrap_or_else(|err| panic!("{sampling:?} scale {s}: {err}"));
            let d = got
                .fd
                .iter()
                .zip(&want.fd)
                .map(|(a, b)| (a - b).norm())
                .fold(0.0, f64::max);
            assert!(d < 1e-12, "{sampling:?} scale {s}: FD differs by {d}");
            // ... and a decimal scale gives the same shape up to rounding.
            let dec: Vec<(f64, f64)> = unit.iter().map(|&(x, y)| (x * s, y * s)).collect();
            let got = e.describe(&dec).unwrap();
            let c = Correlator::new(25, 256)
                .unwrap()
                .correlate(&got.fd, &want.fd)
                .unwrap();
            assert!(c.error < 1e-9, "{sampling:?} scale {s}: error {}", c.error);
            if sampling != Sampling::Canonical {
                let r = e.resample(&scaled).unwrap();
                let top = r
                    .iter()
                    .map(|c| c.re.abs().max(c.im.abs()))
                    .fold(0.0, f64::max);
                assert!(
                    top > 0.3 * p2 && top < 4.0 * p2,
                    "{sampling:?}: {top} vs {p2}"
                );
            }
        }
    }
    // With the default σ of one pixel the affine sampling depends on the size (σ is in pixels):
    // a huge contour (σ far below a sample spacing) is described like one of 2^40 pixels.
    let mut e = Extractor::new(DescriptorConfig::default()).unwrap();
    let at = |p2: f64| -> Vec<(f64, f64)> { unit.iter().map(|&(x, y)| (x * p2, y * p2)).collect() };
    let big = e.describe(&at(2f64.powi(40))).unwrap();
    let huge = e.describe(&at(2f64.powi(660))).unwrap();
    let d = big
        .fd
        .iter()
        .zip(&huge.fd)
        .map(|(a, b)| (a - b).norm())
        .fold(0.0, f64::max);
    assert!(d < 1e-12, "affine, default σ: FD differs by {d}");
    // The square of the issue.
    let sq = [
        (1e200, 1e200),
        (2e200, 1e200),
        (2e200, 2e200),
        (1e200, 2e200),
    ];
    assert!(validate_contour(&sq).is_ok());
    assert!(ex().describe(&sq).is_ok());
}

/// A correlator's sizes are bounded like a configuration's: typed errors before allocating.
#[test]
fn correlator_sizes_are_bounded() {
    for (k, l) in [
        (0, 256),
        (256, 256),
        (usize::MAX / 2, usize::MAX),
        (25, MAX_SAMPLES + 1),
    ] {
        assert!(
            matches!(Correlator::new(k, l), Err(FdError::InvalidParameter { .. })),
            "k {k}, L {l}"
        );
    }
    assert!(matches!(
        Correlator::with_grid(25, 256, usize::MAX),
        Err(FdError::InvalidParameter { name: "m", .. })
    ));
    assert_eq!(Correlator::new(25, 256).unwrap().grid(), 128);
}

/// `Correlator::with_grid` accepted any grid of at least `2K + 1` points, but on grids that
/// coarse the refinement's lobe rule (samples within 1.5 steps of a refined peak belong to it)
/// skipped higher lobes: about one pair in seven of random FDs with `K = 2` at `M = 5` got a
/// peak too small by up to 0.26. Coarser grids than the default are now raised to it, and the
/// peak is the one a dense evaluation finds.
#[test]
fn coarse_grids_find_the_global_peak() {
    let k = 2;
    assert_eq!(Correlator::with_grid(k, 5, 5).unwrap().grid(), 16);
    assert_eq!(Correlator::with_grid(25, 256, 0).unwrap().grid(), 128);
    assert_eq!(Correlator::with_grid(25, 256, 200).unwrap().grid(), 200);
    let mut state = 4242u64;
    let mut unit_fd = || {
        let mut v: Vec<Complex64> = (0..4 * k)
            .map(|_| {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
            })
            .collect::<Vec<_>>()
            .chunks(2)
            .map(|c| Complex64::new(c[0], c[1]))
            .collect();
        let norm = v.iter().map(|z| z.norm_sqr()).sum::<f64>().sqrt();
        v.iter_mut().for_each(|z| *z /= norm);
        v
    };
    let mut cor = Correlator::with_grid(k, 5, 2 * k + 1).unwrap();
    for pair in 0..200 {
        let (a, b) = (unit_fd(), unit_fd());
        // max |r₁₂| on 2^12 points: below the true peak by at most S₂(π/2^12)²/2 < 1e-6.
        let dense = (0..1 << 12)
            .map(|j| {
                let theta = std::f64::consts::TAU * j as f64 / 4096.0;
                (0..2 * k)
                    .map(|i| {
                        let n = fd_frequency(i, k).unwrap() as f64;
                        a[i].conj() * b[i] * Complex64::from_polar(1.0, n * theta)
                    })
                    .sum::<Complex64>()
                    .norm()
            })
            .fold(0.0, f64::max);
        let c = cor.correlate(&a, &b).unwrap();
        assert!(
            c.peak >= dense - 1e-9,
            "pair {pair}: peak {} < {dense}",
            c.peak
        );
    }
}

/// `Correlator::correlate` documents unit-norm FDs but only checked lengths and finiteness: a
/// descriptor scaled by 2 matched itself with error 0 (2 − 2·4, clamped), claimed perfect, and
/// one scaled by 1e200 overflowed to a NaN error. Both are now `NotUnitNorm`.
#[test]
fn correlation_refuses_descriptors_that_are_not_unit_norm() {
    let a = ex().describe(&[(0, 0), (9, 0), (9, 4), (0, 4)]).unwrap();
    let b = ex().describe(&[(0, 0), (5, 0), (2, 6)]).unwrap();
    let mut cor = Correlator::new(25, 256).unwrap();
    let honest = cor.correlate(&a.fd, &b.fd).unwrap().error;
    assert!(honest > 0.01);
    for scale in [2.0, 1e200, 0.5, 0.0] {
        let scaled: Vec<Complex64> = b.fd.iter().map(|c| c * scale).collect();
        assert!(
            matches!(
                cor.correlate(&a.fd, &scaled),
                Err(FdError::NotUnitNorm { part: "b", .. })
            ),
            "scale {scale}"
        );
        assert!(matches!(
            cor.correlate_below(&scaled, &a.fd, 0.1),
            Err(FdError::NotUnitNorm { part: "a", .. })
        ));
    }
    assert_eq!(cor.correlate(&a.fd, &b.fd).unwrap().error, honest);
}

/// `DescriptorConfig::max_frequency` on an unvalidated configuration with `coefficients = 0`
/// computed `0 − 1` and panicked (debug builds) or wrapped to `usize::MAX / 2` (release).
#[test]
fn max_frequency_of_an_invalid_configuration_does_not_overflow() {
    let bad = DescriptorConfig {
        coefficients: 0,
        ..DescriptorConfig::default()
    };
    assert_eq!(bad.max_frequency(), 0);
    assert!(bad.validate().is_err());
    assert_eq!(DescriptorConfig::default().max_frequency(), 25);
}

#[test]
fn descriptor_rows_out_of_range_panic_instead_of_wrapping_to_another_row() {
    // `fd(i)` sliced `i·d .. (i+1)·d` unchecked: in a release build an index whose product
    // wraps around (here to 0) handed back descriptor 0's row instead of panicking.
    let contours: Vec<Vec<(i32, i32)>> = vec![vec![(0, 0), (10, 0), (10, 7), (0, 7)]];
    let set = describe_all(DescriptorConfig::default(), &contours)
        .unwrap()
        .set;
    assert_eq!(set.len(), 1);
    let d = set.fd_len();
    let wrapping = (usize::MAX / d).wrapping_add(1);
    for i in [1, wrapping, usize::MAX] {
        for call in [
            &(|s: &fd_match::DescriptorSet, i| s.fd(i).len())
                as &dyn Fn(&fd_match::DescriptorSet, usize) -> usize,
            &|s, i| s.magnitudes(i).len(),
            &|s, i| s.afd0(i).len(),
            &|s, i| s.afd1(i).len(),
        ] {
            let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| call(&set, i)));
            assert!(r.is_err(), "index {i} did not panic");
        }
        assert!(set.get(i).is_none());
    }
}

/// `Extractor::describe_into` refuses a set made with another configuration (same row lengths,
/// another sampling: the rows would be silently incomparable) and leaves the set unchanged on
/// every error; on success it appends exactly `describe`'s descriptor with the given source.
#[test]
fn describe_into_refuses_a_foreign_set_and_changes_nothing_on_error() {
    let square = [(0, 0), (9, 0), (9, 4), (0, 4)];
    let triangle = [(0, 0), (8, 1), (3, 6)];
    let mut ex = ex();
    let mut set = DescriptorSet::new(DescriptorConfig::default()).unwrap();
    ex.describe_into(&square, &mut set, 41).unwrap();
    let before = set.clone();
    let mut foreign =
        DescriptorSet::new(DescriptorConfig::with_sampling(Sampling::Canonical)).unwrap();
    assert_eq!(foreign.fd_len(), set.fd_len());
    assert!(matches!(
        ex.describe_into(&triangle, &mut foreign, 0),
        Err(FdError::IncompatibleSets { .. })
    ));
    assert!(foreign.is_empty());
    for bad in [
        vec![(0, 0), (1, 1)],
        vec![(0, 0), (1, 0), (2, 0)],
        vec![(0, 0), (5, 0), (5, 0), (0, 5)],
    ] {
        assert!(ex.describe_into(&bad, &mut set, 42).is_err(), "{bad:?}");
        assert_eq!(set, before);
    }
    ex.describe_into(&triangle, &mut set, 43).unwrap();
    assert_eq!(set.sources(), &[41, 43]);
    assert_eq!(set.get(0).unwrap(), ex.describe(&square).unwrap());
    assert_eq!(set.get(1).unwrap(), ex.describe(&triangle).unwrap());
}

const SAMPLINGS: [Sampling; 3] = [
    Sampling::ArcLength,
    Sampling::AffineArcLength,
    Sampling::Canonical,
];

/// `push` refuses rows of another length even when their values are finite and of unit norm
/// (so that only the length check can refuse them), and leaves the set unchanged.
#[test]
fn push_refuses_rows_of_another_length_and_keeps_the_set() {
    let good = ex().describe(&[(0, 0), (9, 0), (9, 4), (0, 4)]).unwrap();
    let mut set = DescriptorSet::new(DescriptorConfig::default()).unwrap();
    set.push(&good, 7).unwrap();
    let before = set.clone();
    let zero = Complex64::new(0.0, 0.0);
    let (mut long_fd, mut long_afd0, mut long_afd1) = (good.clone(), good.clone(), good.clone());
    long_fd.fd.push(zero);
    long_afd0.afd0.push(0.0);
    long_afd1.afd1.push(zero);
    let smaller = DescriptorConfig {
        coefficients: 31,
        ..DescriptorConfig::default()
    };
    let short = Extractor::new(smaller)
        .unwrap()
        .describe(&[(0, 0), (9, 0), (9, 4), (0, 4)])
        .unwrap();
    for (what, d) in [
        ("fd", long_fd),
        ("afd0", long_afd0),
        ("afd1", long_afd1),
        ("all", short),
    ] {
        assert!(
            matches!(set.push(&d, 8), Err(FdError::IncompatibleSets { .. })),
            "{what}"
        );
        assert_eq!(set, before, "{what}");
    }
    set.push(&good, 8).unwrap();
    assert_eq!(set.sources(), &[7, 8]);
}

/// `append` refuses a set of another configuration (other row lengths, or the same lengths
/// with another sampling or smoothing) and leaves the set unchanged.
#[test]
fn append_refuses_a_set_of_another_configuration_and_keeps_the_set() {
    let contours = vec![
        vec![(0.0, 0.0), (9.0, 0.0), (9.0, 4.0), (0.0, 4.0)],
        star(5, 70, 12.0),
    ];
    let cfg = DescriptorConfig::default();
    let mut set = describe_all(cfg, &contours).unwrap().set;
    assert_eq!(set.len(), 2);
    let before = set.clone();
    for other in [
        DescriptorConfig::with_sampling(Sampling::Canonical),
        DescriptorConfig {
            coefficients: 31,
            ..cfg
        },
        DescriptorConfig {
            smoothing: 2.0,
            ..cfg
        },
    ] {
        let foreign = describe_all(other, &contours).unwrap().set;
        assert_eq!(foreign.len(), 2, "{other:?}");
        assert!(
            matches!(set.append(&foreign), Err(FdError::IncompatibleSets { .. })),
            "{other:?}"
        );
        assert_eq!(set, before, "{other:?}");
    }
    set.append(&before).unwrap();
    assert_eq!(set.sources(), &[0, 1, 0, 1]);
    assert_eq!(set.select(&[0, 1]).unwrap(), before);
}

/// A square traced twice passes every check of the contour (distinct successive points,
/// positive area) but has only even harmonics, so its AFDs are refused
/// (`DegenerateFirstHarmonic`) after `describe_into` has filled its row in the set: the row is
/// rolled back, for every sampling, and the next contour lands where it would have.
#[test]
fn describe_into_rolls_back_a_degenerate_first_harmonic() {
    let square = [(0, 0), (9, 0), (9, 4), (0, 4)];
    let twice = [
        (0, 0),
        (4, 0),
        (4, 4),
        (0, 4),
        (0, 0),
        (4, 0),
        (4, 4),
        (0, 4),
    ];
    let triangle = [(0, 0), (8, 1), (3, 6)];
    assert!(validate_contour(&twice).is_ok());
    for sampling in SAMPLINGS {
        let cfg = DescriptorConfig::with_sampling(sampling);
        let mut ex = Extractor::new(cfg).unwrap();
        let mut set = DescriptorSet::new(cfg).unwrap();
        ex.describe_into(&square, &mut set, 1).unwrap();
        let before = set.clone();
        assert_eq!(
            ex.describe_into(&twice, &mut set, 2),
            Err(FdError::DegenerateFirstHarmonic),
            "{sampling:?}"
        );
        assert_eq!(set, before, "{sampling:?}");
        ex.describe_into(&triangle, &mut set, 3).unwrap();
        assert_eq!(set.sources(), &[1, 3], "{sampling:?}");
        let fresh = Extractor::new(cfg).unwrap().describe(&triangle).unwrap();
        assert_eq!(set.get(1).unwrap(), fresh, "{sampling:?}");
    }
}

/// A refused contour changes nothing in the extractor either: one that saw every kind of
/// refusal (by `describe`, `describe_into` and `resample`) resamples and describes the next
/// contours bit for bit like a twin that never saw them, for every sampling.
#[test]
fn a_refused_contour_leaves_the_extractor_as_it_was() {
    let good = [
        star(1, 60, 20.0),
        star(2, 90, 7.5),
        vec![(0.0, 0.0), (9.0, 0.0), (9.0, 4.0), (0.0, 4.0)],
    ];
    // Refused by the contour's checks (every entry point), then by the AFDs only.
    let bad_geometry: Vec<Vec<(f64, f64)>> = vec![
        vec![],
        vec![(0.0, 0.0), (1.0, 1.0)],
        vec![(0.0, 0.0), (1.0, 1.0), (2.0, 2.0)],
        vec![(0.0, 0.0), (3.0, 0.0), (3.0, 0.0), (0.0, 2.0)],
        vec![(0.0, 0.0), (3.0, f64::NAN), (0.0, 2.0)],
        vec![(0.0, 0.0), (f64::INFINITY, 1.0), (0.0, 2.0)],
    ];
    let twice = [(0.0, 0.0), (4.0, 0.0), (4.0, 4.0), (0.0, 4.0)].repeat(2);
    for sampling in SAMPLINGS {
        let cfg = DescriptorConfig::with_sampling(sampling);
        let (mut a, mut b) = (Extractor::new(cfg).unwrap(), Extractor::new(cfg).unwrap());
        // Both warm, so that the buffers hold a previous contour's values.
        a.describe(&good[0]).unwrap();
        b.describe(&good[0]).unwrap();
        let mut own = DescriptorSet::new(cfg).unwrap();
        for c in &bad_geometry {
            assert!(a.resample(c).is_err(), "{sampling:?} {c:?}");
            assert!(a.describe(c).is_err(), "{sampling:?} {c:?}");
            assert!(
                a.describe_into(c, &mut own, 0).is_err(),
                "{sampling:?} {c:?}"
            );
        }
        assert!(a.describe(&twice).is_err(), "{sampling:?}");
        assert!(
            a.describe_into(&twice, &mut own, 0).is_err(),
            "{sampling:?}"
        );
        let other = SAMPLINGS[(SAMPLINGS.iter().position(|&s| s == sampling).unwrap() + 1) % 3];
        let mut foreign = DescriptorSet::new(DescriptorConfig::with_sampling(other)).unwrap();
        assert!(a.describe_into(&good[1], &mut foreign, 0).is_err());
        assert!(own.is_empty() && foreign.is_empty());
        assert_eq!(a.config(), b.config());
        for c in &good {
            assert_eq!(
                a.resample(c).unwrap(),
                b.resample(c).unwrap(),
                "{sampling:?}"
            );
            assert_eq!(
                a.describe(c).unwrap(),
                b.describe(c).unwrap(),
                "{sampling:?}"
            );
        }
    }
}

/// A refused correlation changes nothing in the correlator: after refusals of every kind
/// (length, non-finite value, norm; in either argument) by `correlate` and by
/// `correlate_below` with and without a bound, it gives bit for bit the results of a twin that
/// never saw them, pruned or not.
#[test]
fn a_refused_correlation_leaves_the_correlator_as_it_was() {
    let mut ex = ex();
    let fds: Vec<Vec<Complex64>> = [
        star(3, 80, 10.0),
        star(4, 80, 10.0),
        vec![(0.0, 0.0), (9.0, 0.0), (9.0, 4.0), (0.0, 4.0)],
        vec![(0.0, 0.0), (8.0, 1.0), (3.0, 6.0)],
    ]
    .iter()
    .map(|c| ex.describe(c).unwrap().fd)
    .collect();
    let (mut a, mut b) = (
        Correlator::new(25, 256).unwrap(),
        Correlator::new(25, 256).unwrap(),
    );
    // Both warm.
    a.correlate(&fds[0], &fds[1]).unwrap();
    b.correlate(&fds[0], &fds[1]).unwrap();
    let good = &fds[2];
    let mut nan = good.clone();
    nan[7].re = f64::NAN;
    let mut inf = good.clone();
    inf[0].im = f64::INFINITY;
    let doubled: Vec<Complex64> = good.iter().map(|c| c * 2.0).collect();
    let short = good[..10].to_vec();
    let long: Vec<Complex64> = good
        .iter()
        .copied()
        .chain([Complex64::new(0.0, 0.0)])
        .collect();
    for x in [&nan, &inf, &doubled, &short, &long] {
        for (p, q) in [(good, x), (x, good), (x, x)] {
            assert!(a.correlate(p, q).is_err());
            for bound in [0.05, f64::INFINITY] {
                assert!(a.correlate_below(p, q, bound).is_err());
            }
        }
    }
    // A NaN bound, on valid descriptors: refused by name (+∞ is the way to say "no bound").
    for (p, q) in [(good, good), (&fds[0], &fds[1])] {
        assert!(matches!(
            a.correlate_below(p, q, f64::NAN),
            Err(FdError::InvalidParameter {
                name: "max_error",
                ..
            })
        ));
        assert!(a.correlate_below(p, q, f64::INFINITY).unwrap().is_some());
        b.correlate_below(p, q, f64::INFINITY).unwrap();
    }
    assert_eq!(a.grid(), b.grid());
    let mut pruned = 0;
    for x in &fds {
        for y in &fds {
            assert_eq!(a.correlate(x, y).unwrap(), b.correlate(x, y).unwrap());
            for bound in [1e-3, 0.05, 0.5] {
                let r = a.correlate_below(x, y, bound).unwrap();
                pruned += usize::from(r.is_none());
                assert_eq!(r, b.correlate_below(x, y, bound).unwrap());
            }
        }
    }
    // Both outcomes of the bound were compared.
    assert!(pruned > 0 && pruned < 3 * fds.len() * fds.len(), "{pruned}");
}

/// `fd_frequency` and `afd_frequency` computed `i − K (+1 or +2)` of any position and `K`:
/// positions near `isize::MAX` overflowed (a panic in debug builds, a wrapped frequency in
/// release builds), and every position `i ≥ 2K` gave a frequency that no descriptor stores.
#[test]
fn frequency_layouts_refuse_positions_outside_the_descriptor() {
    use fd_match::{MAX_SAMPLES, afd_frequency, fd_frequency};
    let out = |index, len| Err(FdError::IndexOutOfRange { index, len });
    // Near isize::MAX (the overflow) and just past the layout (a frequency above K).
    assert_eq!(
        fd_frequency(isize::MAX as usize, 0),
        out(isize::MAX as usize, 0)
    );
    assert_eq!(
        afd_frequency(isize::MAX as usize - 1, 0),
        out(isize::MAX as usize - 1, 0)
    );
    assert_eq!(fd_frequency(usize::MAX, 25), out(usize::MAX, 50));
    assert_eq!(fd_frequency(50, 25), out(50, 50));
    assert_eq!(afd_frequency(49, 25), out(49, 49));
    assert_eq!(afd_frequency(0, 0), out(0, 0));
    for k in [MAX_SAMPLES, usize::MAX / 2 + 1, usize::MAX] {
        for r in [fd_frequency(0, k), afd_frequency(0, k)] {
            assert!(
                matches!(r, Err(FdError::InvalidParameter { name: "k", .. })),
                "{k}: {r:?}"
            );
        }
    }
    // Every position of the layouts, as before; the largest K a descriptor can have.
    for k in [1, 2, 25, MAX_SAMPLES - 1] {
        let ends = [0, k - 1, k, 2 * k - 1];
        let fd: Vec<isize> = ends.iter().map(|&i| fd_frequency(i, k).unwrap()).collect();
        let k_i = k as isize;
        assert_eq!(fd, [-k_i, -1, 1, k_i]);
        if k >= 2 {
            let afd: Vec<isize> = [0, k - 1, k, 2 * k - 2]
                .iter()
                .map(|&i| afd_frequency(i, k).unwrap())
                .collect();
            assert_eq!(afd, [-k_i, -1, 2, k_i]);
        }
    }
}
