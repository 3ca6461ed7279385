//! The methods' public names, labels and paper thresholds, and what their pair errors promise:
//! in `[0, 4]`, 0 for a perfect match, an alignment exactly when [`Method::aligns`].

use crate::common;

use common::*;
use fd_match::*;

#[test]
fn names_labels_and_paper_thresholds_are_the_papers() {
    let names: Vec<&str> = ALL.iter().map(|m| m.name()).collect();
    assert_eq!(
        names,
        ["FD Corr", "abs(FD) SSD", "AFD0 SSD", "AFD1 SSD", "FD SSD"]
    );
    assert_eq!(
        [
            Sampling::ArcLength,
            Sampling::AffineArcLength,
            Sampling::Canonical
        ]
        .map(Sampling::name),
        ["ArcLength", "Affine", "Canonical"]
    );
    assert_eq!(
        Method::FdCorr.label(Sampling::Canonical),
        "FD Corr/Canonical"
    );
    assert_eq!(
        Method::Afd1Ssd.label(Sampling::AffineArcLength),
        "AFD1 SSD/Affine"
    );
    assert_eq!(
        Method::PAPER,
        [
            Method::FdCorr,
            Method::AbsFdSsd,
            Method::Afd0Ssd,
            Method::Afd1Ssd
        ]
    );
    // Section 5.2: AFD0 SSD/Affine 1e-4, AFD1 SSD/Affine 5e-4, FD Corr 1e-3 (both samplings);
    // no other combination has one.
    for m in ALL {
        for s in [
            Sampling::ArcLength,
            Sampling::AffineArcLength,
            Sampling::Canonical,
        ] {
            let want = match (m, s) {
                (Method::Afd0Ssd, Sampling::AffineArcLength) => Some(1e-4),
                (Method::Afd1Ssd, Sampling::AffineArcLength) => Some(5e-4),
                (Method::FdCorr, Sampling::AffineArcLength | Sampling::Canonical) => Some(1e-3),
                _ => None,
            };
            assert_eq!(m.paper_preselection_threshold(s), want, "{m:?} {s:?}");
        }
    }
    assert_eq!(DEFAULT_RATIO_THRESHOLD, 0.5);
}

/// Every method's errors lie in `[0, 4]`, a descriptor matched against an identical copy of
/// itself has error 0, and candidates carry an alignment exactly for the method that
/// [`Method::aligns`].
#[test]
fn pair_errors_are_in_range_zero_for_copies_and_aligned_only_by_fd_corr() {
    let contours: Vec<_> = (0..12).map(|i| star(70 + i, 150, 20.0)).collect();
    let set = describe_all(DescriptorConfig::default(), &contours)
        .unwrap()
        .set;
    assert_eq!(set.len(), 12);
    let copy = set.clone();
    for m in ALL {
        assert_eq!(m.aligns(), m == Method::FdCorr);
        let found = best_two_brute_force(&set, &copy, m).unwrap();
        for (i, bt) in found.iter().enumerate() {
            let best = bt.best.as_ref().unwrap();
            let second = bt.second.as_ref().unwrap();
            assert_eq!(best.index, i, "{m:?}: query {i}");
            assert!(best.error.abs() < 1e-12, "{m:?}: self error {}", best.error);
            for c in [best, second] {
                assert!((0.0..=4.0).contains(&c.error), "{m:?}: {}", c.error);
                assert_eq!(c.alignment.is_some(), m.aligns(), "{m:?}");
            }
        }
        // The error to every other descriptor, not only the best two.
        let within = min_errors_within(&set, m).unwrap();
        assert!(
            within.iter().all(|e| (0.0..=4.0).contains(e) && *e > 0.0),
            "{m:?}"
        );
    }
}

/// The ranges [`Correlation`] and [`Alignment`] document: error in `[0, 2]` and equal to
/// `max(2 − 2·peak, 0)`, peak in `[0, 1]` up to rounding (identical shapes give a peak within a
/// few ulps of 1, often above it, and an error of 0 up to rounding), rotation in `(−π, π]`, shift in `[0, L)`; on
/// self-correlations (peak at θ ≈ 0, where a shift just below 0 must wrap into the range) and on
/// pairs of different shapes.
#[test]
fn correlation_results_lie_in_their_documented_ranges() {
    use std::f64::consts::PI;
    let contours: Vec<_> = (0..40).map(|i| star(300 + i, 150, 20.0)).collect();
    let cfg = DescriptorConfig::default();
    let set = describe_all(cfg, &contours).unwrap().set;
    let mut c = Correlator::new(cfg.max_frequency(), cfg.samples).unwrap();
    let l = cfg.samples as f64;
    let mut above_one = 0;
    for i in 0..set.len() {
        for j in [i, (i + 1) % set.len(), (i + 7) % set.len()] {
            let r = c.correlate(set.fd(i), set.fd(j)).unwrap();
            assert!((0.0..=2.0).contains(&r.error), "{i} {j}: {r:?}");
            assert!(r.peak >= 0.0 && r.peak <= 1.0 + 1e-12, "{i} {j}: {r:?}");
            assert_eq!(r.error, (2.0 - 2.0 * r.peak).max(0.0));
            let a = r.alignment;
            assert!(a.rotation > -PI && a.rotation <= PI, "{i} {j}: {a:?}");
            assert!((0.0..l).contains(&a.shift), "{i} {j}: {a:?}");
            if i == j {
                assert!(r.error <= 1e-12, "{i}: {r:?}");
                above_one += usize::from(r.peak > 1.0);
            }
        }
    }
    // Rounding does take the peak above 1 here: the clamp of the error is exercised.
    assert!(above_one > 0);
}
