//! The pruned all-pairs search equals brute force; preselection and symmetric matching.

use crate::common;

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
    let keep = preselect(&e, 1e-3).unwrap();
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
    // Same lengths, another sampling: not comparable either.
    let canonical = describe_all(
        DescriptorConfig::with_sampling(Sampling::Canonical),
        &[star(1, 100, 10.0)],
    )
    .unwrap()
    .set;
    for m in [Method::FdCorr, Method::AbsFdSsd] {
        assert!(matches!(
            best_two(&a, &canonical, m),
            Err(FdError::IncompatibleSets { .. })
        ));
    }
    assert!(matches!(
        a.select(&[a.len()]),
        Err(FdError::IndexOutOfRange { .. })
    ));
}

/// A unit-norm FD with `|C(n)| ~ (0.2 + u)·|n|^-decay` and random phases, as a descriptor of
/// `cfg` (its AFDs are a fixed unit vector: the FD Corr search reads only the FD).
fn random_descriptor(rng: &mut StdRng, cfg: DescriptorConfig, decay: f64) -> Descriptor {
    let k = cfg.max_frequency();
    let mut fd: Vec<Complex64> = (0..2 * k)
        .map(|i| {
            let n = fd_frequency(i, k).unwrap().unsigned_abs() as f64;
            Complex64::from_polar(
                (0.2 + rng.random_range(0.0..1.0)) * n.powf(-decay),
                rng.random_range(0.0..std::f64::consts::TAU),
            )
        })
        .collect();
    normalise(&mut fd);
    let mut afd0 = vec![0.0; 2 * k - 1];
    afd0[0] = 1.0;
    let afd1 = afd0.iter().map(|&v| Complex64::new(v, 0.0)).collect();
    Descriptor { fd, afd0, afd1 }
}

fn normalise(fd: &mut [Complex64]) {
    let e = fd.iter().map(|c| c.norm_sqr()).sum::<f64>().sqrt();
    fd.iter_mut().for_each(|c| *c /= e);
}

/// `d` rotated by `phi` and start-shifted by `theta` (eq. 3–4): the same shape, error ≈ 0.
fn modulated(d: &Descriptor, k: usize, phi: f64, theta: f64) -> Descriptor {
    let mut d = d.clone();
    for (i, c) in d.fd.iter_mut().enumerate() {
        *c *= Complex64::from_polar(1.0, phi - fd_frequency(i, k).unwrap() as f64 * theta);
    }
    normalise(&mut d.fd);
    d
}

/// `d` with the phases of every frequency with `|n| > band` redrawn: the same magnitudes (the
/// magnitude bound is 0), a different shape in the high frequencies only.
fn rephased(rng: &mut StdRng, d: &Descriptor, k: usize, band: usize) -> Descriptor {
    let mut d = d.clone();
    for (i, c) in d.fd.iter_mut().enumerate() {
        if fd_frequency(i, k).unwrap().unsigned_abs() > band {
            *c = Complex64::from_polar(c.norm(), rng.random_range(0.0..std::f64::consts::TAU));
        }
    }
    d
}

/// Two small sets of random descriptors built to stress the pruned search: spectra from flat to
/// steep, modulated copies (near-zero errors), exact duplicates within a set and across sets
/// (exact ties), and copies that share all magnitudes but differ in the phases of the high or
/// of all frequencies (magnitude bound 0 while the error is not).
fn stress_sets(seed: u64, na: usize, nb: usize) -> (DescriptorSet, DescriptorSet) {
    let mut rng = StdRng::seed_from_u64(seed);
    let cfg = DescriptorConfig::with_sampling(Sampling::ArcLength);
    let k = cfg.max_frequency();
    let decay = [0.0, 0.5, 1.0, 1.5, 2.5][(seed % 5) as usize];
    let mut a = DescriptorSet::new(cfg).unwrap();
    let mut b = DescriptorSet::new(cfg).unwrap();
    let base: Vec<Descriptor> = (0..na)
        .map(|_| random_descriptor(&mut rng, cfg, decay))
        .collect();
    for (i, d) in base.iter().enumerate() {
        a.push(d, i).unwrap();
        if rng.random_range(0..4) == 0 {
            a.push(d, i).unwrap(); // a duplicate within A
        }
    }
    for j in 0..nb {
        let d = &base[rng.random_range(0..na)];
        let phi = rng.random_range(-3.0..3.0);
        let theta = rng.random_range(0.0..std::f64::consts::TAU);
        let e = match rng.random_range(0..6) {
            0 => random_descriptor(&mut rng, cfg, decay),
            1 => d.clone(),
            2 => modulated(d, k, phi, theta),
            3 => {
                let band = rng.random_range(0..8);
                rephased(&mut rng, d, k, band)
            }
            4 => rephased(&mut rng, d, k, 0),
            _ => modulated(&rephased(&mut rng, d, k, 7), k, phi, theta),
        };
        b.push(&e, j).unwrap();
        if rng.random_range(0..5) == 0 {
            b.push(&e, j).unwrap(); // a duplicate within B
        }
    }
    (a, b)
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig {
        cases: 64,
        rng_seed: proptest::test_runner::RngSeed::Fixed(2026),
        ..proptest::prelude::ProptestConfig::default()
    })]

    /// The pruned search (magnitude bound, band screens, early exits) equals brute force on
    /// small sets full of ties, near-ties and equal magnitudes, in both directions and within a
    /// set; so does `min_errors_within`.
    #[test]
    fn pruned_search_equals_brute_force_on_stress_sets(
        seed in 0u64..1_000_000,
        na in 1usize..10,
        nb in 1usize..14,
    ) {
        let (a, b) = stress_sets(seed, na, nb);
        for (q, t) in [(&a, &b), (&b, &a), (&a, &a), (&b, &b)] {
            let fast = best_two(q, t, Method::FdCorr).unwrap();
            let brute = best_two_brute_force(q, t, Method::FdCorr).unwrap();
            proptest::prop_assert_eq!(fast, brute);
        }
        for s in [&a, &b] {
            let fast = min_errors_within(s, Method::FdCorr).unwrap();
            let mut cor = Correlator::new(s.config().max_frequency(), s.config().samples).unwrap();
            for (i, e) in fast.iter().enumerate() {
                let direct = (0..s.len())
                    .filter(|&j| j != i)
                    .map(|j| cor.correlate(s.fd(i), s.fd(j)).unwrap().error)
                    .fold(f64::INFINITY, f64::min);
                proptest::prop_assert_eq!(*e, direct, "descriptor {}", i);
            }
        }
    }
}

/// Sets too small for a best or second best: `min_errors_within` is `+∞` for a descriptor alone
/// in its set (so preselection keeps it at any finite `T_err`), `best_two` has no best without
/// targets (ratio `None`) and no second with one target (ratio 0).
#[test]
fn lonely_descriptors_have_infinite_min_error_and_no_second() {
    let cfg = DescriptorConfig::default();
    let one = describe_all(cfg, &[star(9, 120, 15.0)]).unwrap().set;
    let empty = DescriptorSet::new(cfg).unwrap();
    for method in ALL {
        assert_eq!(min_errors_within(&one, method).unwrap(), [f64::INFINITY]);
        assert!(min_errors_within(&empty, method).unwrap().is_empty());
        let none = best_two(&one, &empty, method).unwrap();
        assert_eq!(none.len(), 1);
        assert!(none[0].best.is_none() && none[0].second.is_none());
        assert_eq!(none[0].ratio(), None);
        let single = best_two(&one, &one, method).unwrap();
        assert!(single[0].best.is_some() && single[0].second.is_none());
        assert_eq!(single[0].ratio(), Some(0.0));
    }
    assert_eq!(preselect(&[f64::INFINITY], 1e300).unwrap(), [0]);
}
