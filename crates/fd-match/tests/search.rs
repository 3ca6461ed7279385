//! The pruned all-pairs search equals brute force; preselection and symmetric matching.

mod common;

use common::*;
use fd_match::*;
use rand::{RngExt, SeedableRng, rngs::StdRng};

/// Image A: 40 random shapes. Image B: similarity copies with vertex jitter of 25 of them (in a
/// scrambled order), 15 unrelated shapes, and an exact duplicate (to exercise ties).
type Contour = Vec<(f64, f64)>;

/// Image A, image B and the true pairs `(index in A, index in B)`.
type Images = (Vec<Contour>, Vec<Contour>, Vec<(usize, usize)>);

fn images(seed: u64) -> Images {
    let mut rng = StdRng::seed_from_u64(seed);
    let a: Vec<_> = (0..40).map(|i| star(seed * 1000 + i, 200, 30.0)).collect();
    let mut b = Vec::new();
    let mut truth = Vec::new();
    for i in (0..25).rev() {
        let phi = rng.random_range(-3.0..3.0);
        let s = rng.random_range(0.5..2.0);
        let mut c = similarity(&a[i], phi, s, (rng.random_range(0.0..100.0), 7.0));
        for p in c.iter_mut() {
            p.0 += rng.random_range(-0.05..0.05);
            p.1 += rng.random_range(-0.05..0.05);
        }
        truth.push((i, b.len()));
        b.push(rotate_start(&c, rng.random_range(0..200)));
    }
    for j in 0..15 {
        b.push(star(seed * 1000 + 500 + j, 180, 25.0));
    }
    b.push(b[3].clone());
    (a, b, truth)
}

fn sets(sampling: Sampling, seed: u64) -> (DescriptorSet, DescriptorSet, Vec<(usize, usize)>) {
    let (a, b, truth) = images(seed);
    let cfg = DescriptorConfig::with_sampling(sampling);
    (
        describe_all(cfg, &a).unwrap().set,
        describe_all(cfg, &b).unwrap().set,
        truth,
    )
}

const ALL: [Method; 5] = [
    Method::FdCorr,
    Method::AbsFdSsd,
    Method::Afd0Ssd,
    Method::Afd1Ssd,
    Method::FdSsd,
];

#[test]
fn fast_search_is_identical_to_brute_force() {
    for (sampling, seed) in [
        (Sampling::ArcLength, 1),
        (Sampling::AffineArcLength, 2),
        (Sampling::Canonical, 3),
    ] {
        let (a, b, _) = sets(sampling, seed);
        for method in ALL {
            for (q, t) in [(&a, &b), (&b, &a), (&a, &a)] {
                let (fast, stats) = best_two_with_stats(q, t, method).unwrap();
                let brute = best_two_brute_force(q, t, method).unwrap();
                assert_eq!(fast, brute, "{method:?} {sampling:?}");
                assert_eq!(stats.pairs, (q.len() * t.len()) as u64);
                if method == Method::FdCorr {
                    assert!(stats.evaluated < stats.pairs, "{stats:?}");
                }
            }
        }
    }
}

#[test]
fn search_results_equal_the_public_correlator_bit_for_bit() {
    // The search feeds the sets' stored magnitudes to the correlator; `Correlator::correlate`
    // recomputes them. Both must give the same bits, also for a set built from owned
    // descriptors (`DescriptorSet::push`).
    let (a, b, _) = sets(Sampling::Canonical, 4);
    let mut pushed = DescriptorSet::new(*b.config()).unwrap();
    for j in 0..b.len() {
        pushed.push(&b.get(j).unwrap(), b.source(j)).unwrap();
    }
    let k = a.config().max_frequency();
    let mut cor = Correlator::new(k, a.config().samples).unwrap();
    for t in [&b, &pushed] {
        for (i, r) in best_two(&a, t, Method::FdCorr).unwrap().iter().enumerate() {
            for c in [r.best, r.second].into_iter().flatten() {
                let direct = cor.correlate(a.fd(i), t.fd(c.index)).unwrap();
                assert_eq!(c.error, direct.error);
                assert_eq!(c.alignment, Some(direct.alignment));
            }
        }
    }
}

#[test]
fn ties_are_broken_by_the_lower_index() {
    let (a, b, truth) = sets(Sampling::ArcLength, 4);
    // b[40] duplicates b[3]; their query in A finds both with identical errors.
    let src = truth.iter().find(|t| t.1 == 3).unwrap().0;
    let r = &best_two(&a, &b, Method::FdCorr).unwrap()[src];
    let (best, second) = (r.best.unwrap(), r.second.unwrap());
    assert_eq!((best.index, second.index), (3, 40));
    assert_eq!(best.error, second.error);
    assert_eq!(r.ratio(), Some(1.0));
}

#[test]
fn min_errors_within_matches_a_direct_loop() {
    let (a, b, _) = sets(Sampling::AffineArcLength, 5);
    let mut all = a.clone();
    all.append(&b).unwrap();
    for method in ALL {
        let fast = min_errors_within(&all, method).unwrap();
        let pair = best_two_brute_force(&all, &all, method).unwrap();
        for (i, e) in fast.iter().enumerate() {
            // Brute force over the set includes the self pair (error 0 or nearly): use its
            // non-self entry.
            let r = &pair[i];
            let want = [r.best.unwrap(), r.second.unwrap()]
                .iter()
                .find(|c| c.index != i)
                .unwrap()
                .error;
            let direct = (0..all.len())
                .filter(|&j| j != i)
                .map(|j| {
                    best_two_brute_force(
                        &all.select(&[i]).unwrap(),
                        &all.select(&[j]).unwrap(),
                        method,
                    )
                    .unwrap()[0]
                        .best
                        .unwrap()
                        .error
                })
                .fold(f64::INFINITY, f64::min);
            assert_eq!(*e, direct, "{method:?} descriptor {i}");
            assert!(want <= *e || r.best.unwrap().index == i);
        }
    }
}

#[test]
fn results_do_not_depend_on_the_thread_count() {
    let (a, b, _) = sets(Sampling::Canonical, 6);
    let run = |threads| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                let (ca, cb, _) = images(6);
                let cfg = DescriptorConfig::with_sampling(Sampling::Canonical);
                let da = describe_all(cfg, &ca).unwrap().set;
                let db = describe_all(cfg, &cb).unwrap().set;
                (
                    da.clone(),
                    best_two(&da, &db, Method::FdCorr).unwrap(),
                    min_errors_within(&da, Method::FdCorr).unwrap(),
                )
            })
    };
    let one = run(1);
    let three = run(3);
    assert_eq!(one, three);
    assert_eq!(one.0, a);
    assert_eq!(one.1, best_two(&a, &b, Method::FdCorr).unwrap());
}

#[test]
fn symmetric_matching_finds_the_true_pairs_with_correlation() {
    let (a, b, truth) = sets(Sampling::ArcLength, 7);
    let m = match_sets(&a, &b, Method::FdCorr).unwrap();
    let accepted: Vec<_> = m
        .iter()
        .filter(|m| m.accepted(DEFAULT_RATIO_THRESHOLD))
        .collect();
    // All 25 true pairs except the duplicated one (ratio 1) pass; nothing false passes.
    for m in &accepted {
        assert!(truth.contains(&(m.query, m.target)), "false match {m:?}");
    }
    assert_eq!(accepted.len(), 24);
    // The recovered rotation of an accepted match maps A's shape onto B's.
    assert!(accepted.iter().all(|m| m.alignment.is_some()));
}

#[test]
fn preselection_removes_near_duplicates_within_an_image() {
    let (_, b, _) = sets(Sampling::ArcLength, 8);
    let e = min_errors_within(&b, Method::FdCorr).unwrap();
    let keep = preselect(&e, 1e-3);
    // b[3] and b[40] are identical: both removed, everything else kept.
    assert!(!keep.contains(&3) && !keep.contains(&40));
    assert_eq!(keep.len(), b.len() - 2);
    let reduced = b.select(&keep).unwrap();
    assert_eq!(reduced.sources(), keep.as_slice());
}

#[test]
fn incompatible_sets_are_rejected() {
    let (a, _, _) = sets(Sampling::ArcLength, 9);
    let cfg = DescriptorConfig {
        coefficients: 31,
        ..DescriptorConfig::with_sampling(Sampling::ArcLength)
    };
    let other = describe_all(cfg, &[star(1, 100, 10.0)]).unwrap().set;
    assert!(matches!(
        best_two(&a, &other, Method::FdCorr),
        Err(FdError::IncompatibleSets { .. })
    ));
    assert!(matches!(
        a.select(&[a.len()]),
        Err(FdError::IndexOutOfRange { .. })
    ));
}
