//! Independent oracles for every computed result, written out in the tests from the formulas
//! the docs state: a naive DFT for the descriptors (eq. 2), the AFD formulas of the `afd`
//! module doc, a naive arc-length walk for the resampling, a dense evaluation of the
//! correlation (and its closed form for `K = 1`) for the correlator (eq. 9–12), and an
//! exhaustive sort of every pair error for the searches, preselection and symmetric matching
//! (eq. 18–19). Small and unusual inputs throughout: the smallest configuration (`N = L = L₀ =
//! 5`), triangles, clockwise contours, explicit closing points, `K = 1` correlators, odd and
//! oversized grids, empty and single-element sets, exact ties.

use crate::common;

use std::f64::consts::{PI, TAU};

use common::*;
use fd_match::*;
use proptest::prelude::*;
use rand::{RngExt, SeedableRng, rngs::StdRng};

// ---------------------------------------------------------------------------------------------
// Descriptors: naive DFT of the resampled contour, and the AFD formulas.
// ---------------------------------------------------------------------------------------------

/// `Σ_l s_l e^{−i2πnl/L}` (eq. 2 without the `1/L`, which the normalisation cancels).
fn naive_dft(s: &[Complex64], n: isize) -> Complex64 {
    let l = s.len() as f64;
    s.iter()
        .enumerate()
        .map(|(j, z)| z * Complex64::from_polar(1.0, -TAU * n as f64 * j as f64 / l))
        .sum()
}

/// The normalised FD of the samples: `n = −K..−1, 1..K`, unit ℓ2 norm.
fn naive_fd(s: &[Complex64], k: usize) -> Vec<Complex64> {
    let ki = k as isize;
    let mut fd: Vec<Complex64> = (-ki..=ki)
        .filter(|&n| n != 0)
        .map(|n| naive_dft(s, n))
        .collect();
    let e = fd.iter().map(|c| c.norm_sqr()).sum::<f64>().sqrt();
    fd.iter_mut().for_each(|c| *c /= e);
    fd
}

/// AFD0 and AFD1 of an FD in the layout `n = −K..−1, 1..K`, straight from the `afd` module doc:
/// `X_n = (C(n) + conj C(−n))/2`, `Y_n = (C(n) − conj C(−n))/(2i)`,
/// `Δ_{k,1} = X_k conj Y_1 − Y_k conj X_1`, `q_k = Δ_{k,1}/Δ_{1,1}`, `I⁰_k = |q_k|`,
/// `I¹_k = q_k e^{−i(k−1) arg q₂}`, `k = −K..=K` without 0 and 1, each vector of unit norm.
fn naive_afd(fd: &[Complex64], k: usize) -> (Vec<f64>, Vec<Complex64>) {
    let ki = k as isize;
    let c = |n: isize| {
        let pos = if n < 0 { n + ki } else { n + ki - 1 };
        fd[pos as usize]
    };
    let two_i = Complex64::new(0.0, 2.0);
    let x = |n: isize| (c(n) + c(-n).conj()) / 2.0;
    let y = |n: isize| (c(n) - c(-n).conj()) / two_i;
    let delta = |n: isize| x(n) * y(1).conj() - y(n) * x(1).conj();
    let q = |n: isize| delta(n) / delta(1);
    let theta = q(2).arg();
    let ks: Vec<isize> = (-ki..=ki).filter(|&n| n != 0 && n != 1).collect();
    let mut a0: Vec<f64> = ks.iter().map(|&n| q(n).norm()).collect();
    let mut a1: Vec<Complex64> = ks
        .iter()
        .map(|&n| q(n) * Complex64::from_polar(1.0, -((n - 1) as f64) * theta))
        .collect();
    let n0 = a0.iter().map(|v| v * v).sum::<f64>().sqrt();
    let n1 = a1.iter().map(|v| v.norm_sqr()).sum::<f64>().sqrt();
    a0.iter_mut().for_each(|v| *v /= n0);
    a1.iter_mut().for_each(|v| *v /= n1);
    (a0, a1)
}

fn max_diff(a: &[Complex64], b: &[Complex64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).norm())
        .fold(0.0, f64::max)
}

/// Contours of unusual but valid shapes: a triangle, a clockwise pentagon with an explicit
/// closing point, a non-convex integer polygon, and a smooth star.
fn odd_contours() -> Vec<Vec<(f64, f64)>> {
    let mut cw = vec![(0.0, 0.0), (0.0, 4.0), (3.0, 5.0), (5.0, 2.0), (4.0, -1.0)];
    cw.push(cw[0]);
    vec![
        vec![(0.0, 0.0), (7.0, 1.0), (2.0, 5.0)],
        cw,
        vec![
            (0.0, 0.0),
            (6.0, 0.0),
            (6.0, 2.0),
            (2.0, 2.0),
            (2.0, 5.0),
            (0.0, 5.0),
        ],
        star(11, 97, 13.0),
    ]
}

fn configs() -> Vec<DescriptorConfig> {
    let mut out = Vec::new();
    for sampling in [
        Sampling::ArcLength,
        Sampling::AffineArcLength,
        Sampling::Canonical,
    ] {
        // The smallest valid configuration, an odd L, and the paper's.
        out.push(DescriptorConfig {
            sampling,
            samples: 5,
            coefficients: 5,
            smoothing: 0.0,
            dense_samples: 5,
        });
        out.push(DescriptorConfig {
            sampling,
            samples: 37,
            coefficients: 11,
            smoothing: 0.5,
            dense_samples: 101,
        });
        out.push(DescriptorConfig::with_sampling(sampling));
    }
    out
}

/// `describe` is the DFT of `resample`'s samples at `n = −K..=K` without 0, of unit norm, in
/// the layout of `fd_frequency`; `magnitudes` are their moduli; AFD0/AFD1 follow the formulas
/// of the `afd` module doc. For every sampling and the smallest configuration.
#[test]
fn descriptors_are_the_normalised_dft_of_the_samples_and_the_documented_afds() {
    let mut checked = 0;
    for cfg in configs() {
        let k = cfg.max_frequency();
        let mut ex = Extractor::new(cfg).unwrap();
        for contour in odd_contours() {
            let samples = ex.resample(&contour).unwrap().to_vec();
            assert_eq!(samples.len(), cfg.samples);
            let d = match ex.describe(&contour) {
                Ok(d) => d,
                // A degenerate first harmonic is the only refusal left for a valid contour.
                Err(FdError::DegenerateFirstHarmonic) => continue,
                Err(e) => panic!("{cfg:?}: {e}"),
            };
            let want = naive_fd(&samples, k);
            let dfd = max_diff(&d.fd, &want);
            assert!(dfd < 1e-12, "{cfg:?} {contour:?}: FD differs by {dfd:e}");
            for (i, c) in d.fd.iter().enumerate() {
                assert_eq!(fd_frequency(i, k).unwrap(), {
                    let ki = k as isize;
                    if (i as isize) < ki {
                        i as isize - ki
                    } else {
                        i as isize - ki + 1
                    }
                });
                assert!((d.magnitudes()[i] - c.norm()).abs() < 1e-15);
            }
            let (a0, a1) = naive_afd(&d.fd, k);
            let d0 = d
                .afd0
                .iter()
                .zip(&a0)
                .map(|(x, y)| (x - y).abs())
                .fold(0.0, f64::max);
            assert!(d0 < 1e-9, "{cfg:?} {contour:?}: AFD0 differs by {d0:e}");
            let d1 = max_diff(&d.afd1, &a1);
            assert!(d1 < 1e-9, "{cfg:?} {contour:?}: AFD1 differs by {d1:e}");
            // The set stores the same rows.
            let set = describe_all(cfg, std::slice::from_ref(&contour))
                .unwrap()
                .set;
            assert_eq!(set.fd(0), d.fd.as_slice());
            // (The set stores `sqrt(|c|²)`, `Descriptor::magnitudes` uses `hypot`: an ulp apart.)
            for (x, y) in set.magnitudes(0).iter().zip(d.magnitudes()) {
                assert!((x - y).abs() <= 1e-15);
            }
            checked += 1;
        }
    }
    assert!(checked >= 30, "only {checked} descriptors checked");
}

/// The AFD layout: `afd_frequency` lists `k = −K..−1, 2..K`.
#[test]
fn afd_frequencies_list_every_k_but_0_and_1_in_order() {
    for k in 2..8usize {
        let ki = k as isize;
        let want: Vec<isize> = (-ki..=ki).filter(|&n| n != 0 && n != 1).collect();
        let got: Vec<isize> = (0..2 * k - 1)
            .map(|i| afd_frequency(i, k).unwrap())
            .collect();
        assert_eq!(got, want, "K = {k}");
        let want: Vec<isize> = (-ki..=ki).filter(|&n| n != 0).collect();
        let got: Vec<isize> = (0..2 * k).map(|i| fd_frequency(i, k).unwrap()).collect();
        assert_eq!(got, want, "K = {k}");
    }
}

// ---------------------------------------------------------------------------------------------
// Arc-length resampling: a naive walk along the positively oriented polygon.
// ---------------------------------------------------------------------------------------------

/// The validated polygon as the docs describe it: closing point dropped, oriented so that its
/// signed area is positive (reversed otherwise).
fn oriented(contour: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut p = contour.to_vec();
    if p.len() > 1 && p[0] == p[p.len() - 1] {
        p.pop();
    }
    let n = p.len();
    let area: f64 = (0..n)
        .map(|i| {
            let (a, b) = (p[i], p[(i + 1) % n]);
            a.0 * b.1 - b.0 * a.1
        })
        .sum();
    if area < 0.0 {
        p.reverse();
    }
    p
}

/// The point at arc length `s` (from vertex 0) along the closed polygon, by walking its edges.
fn point_at(p: &[(f64, f64)], s: f64) -> (f64, f64) {
    let n = p.len();
    let mut left = s;
    for i in 0.. {
        let (a, b) = (p[i % n], p[(i + 1) % n]);
        let len = ((b.0 - a.0).powi(2) + (b.1 - a.1).powi(2)).sqrt();
        if left <= len {
            let f = left / len;
            return (a.0 + f * (b.0 - a.0), a.1 + f * (b.1 - a.1));
        }
        left -= len;
    }
    unreachable!()
}

/// `Sampling::ArcLength` gives `L` points at arc lengths `k·P/L` from the first vertex of the
/// oriented polygon, for `L` from 5 (fewer samples than vertices of the star) to 256, on
/// triangles, clockwise input with a closing point and integer contours.
#[test]
fn arc_length_resampling_walks_the_oriented_polygon() {
    for samples in [5, 6, 37, 256] {
        let cfg = DescriptorConfig {
            sampling: Sampling::ArcLength,
            samples,
            coefficients: 5,
            smoothing: 1.0,
            dense_samples: 256,
        };
        let mut ex = Extractor::new(cfg).unwrap();
        for contour in odd_contours() {
            let got = ex.resample(&contour).unwrap().to_vec();
            let p = oriented(&contour);
            let n = p.len();
            let per: f64 = (0..n)
                .map(|i| {
                    let (a, b) = (p[i], p[(i + 1) % n]);
                    ((b.0 - a.0).powi(2) + (b.1 - a.1).powi(2)).sqrt()
                })
                .sum();
            for (j, z) in got.iter().enumerate() {
                let want = point_at(&p, j as f64 * per / samples as f64);
                let d = ((z.re - want.0).powi(2) + (z.im - want.1).powi(2)).sqrt();
                assert!(d < 1e-9 * per, "L {samples}, sample {j}: {z} vs {want:?}");
            }
        }
    }
    // Integer input of another type gives the same samples.
    let mut ex = Extractor::new(DescriptorConfig::with_sampling(Sampling::ArcLength)).unwrap();
    let ints: Vec<(i32, i32)> = vec![(0, 0), (0, 3), (4, 3), (4, 0)]; // clockwise
    let floats: Vec<(f64, f64)> = ints.iter().map(|&(x, y)| (x as f64, y as f64)).collect();
    let a = ex.resample(&ints).unwrap().to_vec();
    let b = ex.resample(&floats).unwrap().to_vec();
    assert_eq!(a, b);
    let p = oriented(&floats);
    assert_eq!((a[0].re, a[0].im), p[0]);
}

// ---------------------------------------------------------------------------------------------
// The correlator: dense evaluation of r₁₂ and the closed form for K = 1.
// ---------------------------------------------------------------------------------------------

/// `r₁₂(θ) = Σ conj(C₁(n)) C₂(n) e^{inθ}` (eq. 9), summed directly.
fn r12(a: &[Complex64], b: &[Complex64], k: usize, theta: f64) -> Complex64 {
    (0..2 * k)
        .map(|i| {
            a[i].conj()
                * b[i]
                * Complex64::from_polar(1.0, fd_frequency(i, k).unwrap() as f64 * theta)
        })
        .sum()
}

fn unit_fd(rng: &mut StdRng, k: usize, decay: f64) -> Vec<Complex64> {
    let mut v: Vec<Complex64> = (0..2 * k)
        .map(|i| {
            let n = fd_frequency(i, k).unwrap().unsigned_abs() as f64;
            Complex64::from_polar(
                rng.random_range(0.0..1.0) * n.powf(-decay),
                rng.random_range(0.0..TAU),
            )
        })
        .collect();
    let e = v.iter().map(|c| c.norm_sqr()).sum::<f64>().sqrt();
    if e == 0.0 {
        v[0] = Complex64::new(1.0, 0.0);
        return v;
    }
    v.iter_mut().for_each(|c| *c /= e);
    v
}

proptest! {
    // Fixed seed, as the crate's other property tests.
    #![proptest_config(crate::seeded(128))]

    /// For `K` from 1, any `L > K`, the default, an odd, a coarser-than-default and a larger grid:
    /// the peak is the maximum of `|r₁₂|` on a dense grid (to that grid's slack), the error is
    /// `max(2 − 2·peak, 0)`, and `r₁₂` evaluated directly at the reported shift has modulus
    /// `peak` and argument `rotation`; `correlate_below` returns `None` only for errors above
    /// its bound and otherwise the same result.
    #[test]
    fn correlation_peak_and_alignment_agree_with_a_dense_evaluation(
        seed in 0u64..1_000_000,
        k in 1usize..7,
        extra in 1usize..40,
        grid in 0usize..4,
        decay in 0.0f64..2.0,
        copy in 0usize..3,
    ) {
        let mut rng = StdRng::seed_from_u64(seed);
        let samples = k + extra;
        let m = [0, 2 * k + 1, 4 * (2 * k + 1).next_power_of_two() + 3, 3][grid];
        let mut cor = Correlator::with_grid(k, samples, m).unwrap();
        let a = unit_fd(&mut rng, k, decay);
        // A random FD, or an exactly rotated and start-shifted copy of `a` (eq. 3–4).
        let b = if copy == 0 {
            let (phi, dl) = (rng.random_range(-PI..PI), rng.random_range(0.0..samples as f64));
            (0..2 * k)
                .map(|i| {
                    let n = fd_frequency(i, k).unwrap() as f64;
                    a[i] * Complex64::from_polar(1.0, phi - TAU * n * dl / samples as f64)
                })
                .collect()
        } else {
            unit_fd(&mut rng, k, decay)
        };
        let c = cor.correlate(&a, &b).unwrap();
        // Dense maximum: below the true one by at most S₂(π/D)²/2 ≤ K²(π/D)²/2.
        let dense_n = 1 << 13;
        let dense = (0..dense_n)
            .map(|j| r12(&a, &b, k, TAU * j as f64 / dense_n as f64).norm())
            .fold(0.0, f64::max);
        let slack = (k * k) as f64 * (PI / dense_n as f64).powi(2);
        prop_assert!(c.peak >= dense - 1e-9, "peak {} < dense {dense}", c.peak);
        prop_assert!(c.peak <= dense + slack + 1e-12, "peak {} > dense {dense} + {slack}", c.peak);
        if k == 1 {
            // |r(θ)| = |p₋₁e^{−iθ} + p₁e^{iθ}| is largest, |p₋₁| + |p₁|, where both align.
            let closed = (a[0].conj() * b[0]).norm() + (a[1].conj() * b[1]).norm();
            prop_assert!((c.peak - closed).abs() < 1e-12, "K = 1: {} vs {closed}", c.peak);
        }
        prop_assert_eq!(c.error, (2.0 - 2.0 * c.peak).max(0.0));
        let al = c.alignment;
        prop_assert!((0.0..samples as f64).contains(&al.shift), "{:?}", al);
        prop_assert!(al.rotation > -PI - 1e-15 && al.rotation <= PI, "{:?}", al);
        let at = r12(&a, &b, k, TAU * al.shift / samples as f64);
        prop_assert!((at.norm() - c.peak).abs() < 1e-9, "|r(shift)| {} vs peak {}", at.norm(), c.peak);
        if c.peak > 1e-6 {
            prop_assert!(wrap(at.arg() - al.rotation).abs() < 1e-6, "arg {} vs {}", at.arg(), al.rotation);
        }
        if copy == 0 {
            prop_assert!(c.error < 1e-12, "copy: error {}", c.error);
        }
        for t in [0.0, 0.5 * c.error, c.error - 1e-4, c.error, c.error + 1e-4, 4.0] {
            match cor.correlate_below(&a, &b, t).unwrap() {
                None => prop_assert!(c.error > t, "pruned at {t} although error {}", c.error),
                Some(d) => prop_assert_eq!(d, c),
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Searches, preselection and matching: an exhaustive sort of every pair error.
// ---------------------------------------------------------------------------------------------

fn unit_real(rng: &mut StdRng, n: usize) -> Vec<f64> {
    let mut v: Vec<f64> = (0..n).map(|_| rng.random_range(0.0..1.0)).collect();
    let e = v.iter().map(|x| x * x).sum::<f64>().sqrt();
    v.iter_mut().for_each(|x| *x /= e);
    v
}

fn unit_complex(rng: &mut StdRng, n: usize) -> Vec<Complex64> {
    let mut v: Vec<Complex64> = (0..n)
        .map(|_| Complex64::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)))
        .collect();
    let e = v.iter().map(|c| c.norm_sqr()).sum::<f64>().sqrt();
    v.iter_mut().for_each(|c| *c /= e);
    v
}

/// A random descriptor of `cfg` (every part unit norm), or a near copy of one in `pool`.
fn descriptor(rng: &mut StdRng, cfg: DescriptorConfig, pool: &[Descriptor]) -> Descriptor {
    let k = cfg.max_frequency();
    if !pool.is_empty() && rng.random_range(0..3) > 0 {
        let mut d = pool[rng.random_range(0..pool.len())].clone();
        match rng.random_range(0..3) {
            0 => {} // an exact duplicate: ties
            1 => {
                let (phi, theta) = (rng.random_range(-PI..PI), rng.random_range(0.0..TAU));
                for (i, c) in d.fd.iter_mut().enumerate() {
                    *c *= Complex64::from_polar(
                        1.0,
                        phi - fd_frequency(i, k).unwrap() as f64 * theta,
                    );
                }
            }
            _ => {
                // The same magnitudes, other phases: magnitude bound 0, error not.
                for c in d.fd.iter_mut() {
                    *c = Complex64::from_polar(c.norm(), rng.random_range(0.0..TAU));
                }
            }
        }
        return d;
    }
    let decay = rng.random_range(0.0..2.0);
    Descriptor {
        fd: unit_fd(rng, k, decay),
        afd0: unit_real(rng, 2 * k - 1),
        afd1: unit_complex(rng, 2 * k - 1),
    }
}

/// The error of a pair, from the definitions: FD Corr through the public correlator, the SSDs
/// summed here.
fn naive_error(method: Method, cor: &mut Correlator, a: &Descriptor, b: &Descriptor) -> f64 {
    let real = |x: &[f64], y: &[f64]| -> f64 {
        let mut s = 0.0;
        for (p, q) in x.iter().zip(y) {
            s += (p - q) * (p - q);
        }
        s
    };
    let complex = |x: &[Complex64], y: &[Complex64]| -> f64 {
        let mut s = 0.0;
        for (p, q) in x.iter().zip(y) {
            let d = p - q;
            s += d.re * d.re + d.im * d.im;
        }
        s
    };
    match method {
        Method::FdCorr => cor.correlate(&a.fd, &b.fd).unwrap().error,
        Method::AbsFdSsd => {
            // `|C(n)|` as a set stores it (`sqrt(|c|²)`).
            let mag =
                |d: &Descriptor| -> Vec<f64> { d.fd.iter().map(|c| c.norm_sqr().sqrt()).collect() };
            real(&mag(a), &mag(b))
        }
        Method::Afd0Ssd => real(&a.afd0, &b.afd0),
        Method::Afd1Ssd => complex(&a.afd1, &b.afd1),
        Method::FdSsd => complex(&a.fd, &b.fd),
    }
}

/// Every target sorted by (error, index): the best two are the first two.
fn naive_best_two(
    method: Method,
    cor: &mut Correlator,
    q: &Descriptor,
    targets: &[Descriptor],
    skip: Option<usize>,
) -> Vec<(usize, f64)> {
    let mut all: Vec<(usize, f64)> = targets
        .iter()
        .enumerate()
        .filter(|(j, _)| Some(*j) != skip)
        .map(|(j, t)| (j, naive_error(method, cor, q, t)))
        .collect();
    all.sort_by(|x, y| x.1.total_cmp(&y.1).then(x.0.cmp(&y.0)));
    all.truncate(2);
    all
}

fn naive_ratio(two: &[(usize, f64)]) -> Option<f64> {
    match two {
        [] => None,
        [_] => Some(0.0),
        [b, s, ..] => Some(if s.1 == 0.0 { 1.0 } else { b.1 / s.1 }),
    }
}

proptest! {
    #![proptest_config(crate::seeded(64))]

    /// `best_two` (and its stats), `best_two_brute_force`, `min_errors_within`, `preselect`,
    /// `mutual_matches` and `match_sets` against an exhaustive sort of every pair error, for
    /// every method, on sets of 0 to 7 descriptors with exact duplicates, rotated copies and
    /// phase-scrambled copies, with the smallest configuration (`N = 5`) and the paper's.
    #[test]
    fn searches_and_matches_equal_an_exhaustive_sort_of_pair_errors(
        seed in 0u64..1_000_000,
        na in 0usize..8,
        nb in 0usize..8,
        small in any::<bool>(),
    ) {
        let mut rng = StdRng::seed_from_u64(seed);
        let cfg = if small {
            DescriptorConfig { samples: 5, coefficients: 5, dense_samples: 5, ..Default::default() }
        } else {
            DescriptorConfig::default()
        };
        let mut pool: Vec<Descriptor> = Vec::new();
        let mut da = Vec::new();
        for _ in 0..na {
            let d = descriptor(&mut rng, cfg, &pool);
            pool.push(d.clone());
            da.push(d);
        }
        let mut db = Vec::new();
        for _ in 0..nb {
            let d = descriptor(&mut rng, cfg, &pool);
            pool.push(d.clone());
            db.push(d);
        }
        let build = |ds: &[Descriptor]| {
            let mut s = DescriptorSet::new(cfg).unwrap();
            for (i, d) in ds.iter().enumerate() {
                s.push(d, 100 + i).unwrap();
            }
            s
        };
        let (a, b) = (build(&da), build(&db));
        let mut cor = Correlator::new(cfg.max_frequency(), cfg.samples).unwrap();
        for method in ALL {
            let (fast, stats) = best_two_with_stats(&a, &b, method).unwrap();
            prop_assert_eq!(stats.pairs, (na * nb) as u64);
            prop_assert!(stats.evaluated <= stats.pairs);
            prop_assert_eq!(&fast, &best_two(&a, &b, method).unwrap());
            prop_assert_eq!(&fast, &best_two_brute_force(&a, &b, method).unwrap());
            prop_assert_eq!(fast.len(), na);
            let mut ab = Vec::new();
            for (i, r) in fast.iter().enumerate() {
                let want = naive_best_two(method, &mut cor, &da[i], &db, None);
                let got: Vec<(usize, f64)> =
                    [r.best, r.second].into_iter().flatten().map(|c| (c.index, c.error)).collect();
                prop_assert_eq!(&got, &want, "{:?} query {}", method, i);
                prop_assert_eq!(r.ratio(), naive_ratio(&want));
                for c in [r.best, r.second].into_iter().flatten() {
                    let direct = method.aligns().then(|| cor.correlate(&da[i].fd, &db[c.index].fd).unwrap().alignment);
                    prop_assert_eq!(c.alignment, direct);
                }
                ab.push(want);
            }
            // B → A and the symmetric matches (eq. 19, the larger ratio).
            let ba: Vec<Vec<(usize, f64)>> =
                db.iter().map(|q| naive_best_two(method, &mut cor, q, &da, None)).collect();
            let mut want = Vec::new();
            for (i, two) in ab.iter().enumerate() {
                let Some(&(j, e)) = two.first() else { continue };
                if ba[j].first().map(|c| c.0) == Some(i) {
                    let ratio = naive_ratio(two).unwrap().max(naive_ratio(&ba[j]).unwrap());
                    want.push((i, j, e, ratio));
                }
            }
            let got: Vec<(usize, usize, f64, f64)> = match_sets(&a, &b, method)
                .unwrap()
                .iter()
                .map(|m| (m.query, m.target, m.error, m.ratio))
                .collect();
            prop_assert_eq!(&got, &want, "{:?}", method);
            let via = mutual_matches(&fast, &best_two(&b, &a, method).unwrap());
            prop_assert_eq!(via, match_sets(&a, &b, method).unwrap());
            // Preselection (eq. 18): the minimum error against the other descriptors of A.
            let within = min_errors_within(&a, method).unwrap();
            prop_assert_eq!(within.len(), na);
            for (i, e) in within.iter().enumerate() {
                let want = naive_best_two(method, &mut cor, &da[i], &da, Some(i))
                    .first()
                    .map_or(f64::INFINITY, |c| c.1);
                prop_assert_eq!(*e, want, "{:?} within {}", method, i);
            }
            for t_err in [0.0, 1e-3, 0.5] {
                let keep = preselect(&within, t_err).unwrap();
                let want: Vec<usize> = (0..na).filter(|&i| within[i] >= t_err).collect();
                prop_assert_eq!(keep, want);
            }
        }
    }
}

/// The SSDs on hand-computed values, including empty vectors.
#[test]
fn ssds_equal_hand_computed_values() {
    let a = [Complex64::new(1.0, 2.0), Complex64::new(-1.0, 0.5)];
    let b = [Complex64::new(0.0, 0.0), Complex64::new(1.0, -0.5)];
    // |1 + 2i|² + |−2 + i|² = 5 + 5.
    assert_eq!(ssd_complex(&a, &b), Ok(10.0));
    assert_eq!(ssd_complex(&[], &[]), Ok(0.0));
    assert_eq!(ssd_real(&[], &[]), Ok(0.0));
    assert_eq!(ssd_real(&[0.5, -1.0, 3.0], &[0.5, 1.0, 0.0]), Ok(13.0));
    assert!(ssd_complex(&a, &b[..1]).is_err());
}

// ---------------------------------------------------------------------------------------------
// Canonical and affine-arc-length resampling: the frame recomputed, the ellipse in closed form.
// ---------------------------------------------------------------------------------------------

/// Area, centroid and central second moments of a polygon (Green's theorem, written out).
fn polygon_moments(p: &[(f64, f64)]) -> (f64, (f64, f64), f64, f64, f64) {
    let n = p.len();
    let (mut a, mut cx, mut cy) = (0.0, 0.0, 0.0);
    let (mut sxx, mut syy, mut sxy) = (0.0, 0.0, 0.0);
    for i in 0..n {
        let ((x0, y0), (x1, y1)) = (p[i], p[(i + 1) % n]);
        let cr = x0 * y1 - x1 * y0;
        a += cr / 2.0;
        cx += (x0 + x1) * cr / 6.0;
        cy += (y0 + y1) * cr / 6.0;
        sxx += (x0 * x0 + x0 * x1 + x1 * x1) * cr / 12.0;
        syy += (y0 * y0 + y0 * y1 + y1 * y1) * cr / 12.0;
        sxy += (x0 * y1 + 2.0 * x0 * y0 + 2.0 * x1 * y1 + x1 * y0) * cr / 24.0;
    }
    let (mx, my) = (cx / a, cy / a);
    (
        a,
        (mx, my),
        sxx - a * mx * mx,
        sxy - a * mx * my,
        syy - a * my * my,
    )
}

/// `Sampling::Canonical` from its description: centroid to the origin, principal axis (largest
/// second moment) onto +x, area 1, `∫x³ dA ≥ 0`, then uniform arc length from the farthest
/// point where the +x ray leaves the region. Recomputed here for triangles, clockwise input,
/// a non-convex polygon and a star, with `L` from 5.
#[test]
fn canonical_resampling_follows_its_described_frame() {
    let mut most_crossings = 0;
    for samples in [5, 37, 256] {
        let cfg = DescriptorConfig {
            samples,
            coefficients: 5,
            ..DescriptorConfig::with_sampling(Sampling::Canonical)
        };
        let mut ex = Extractor::new(cfg).unwrap();
        let mut contours = odd_contours();
        // A square with a deep slot from the top: the ray crosses the boundary three times.
        contours.push(vec![
            (-10.0, -10.0),
            (10.0, -10.0),
            (10.0, 10.0),
            (8.0, 10.0),
            (8.0, -6.0),
            (2.0, -6.0),
            (2.0, 10.0),
            (-10.0, 10.0),
        ]);
        for contour in contours {
            let got = ex.resample(&contour).unwrap().to_vec();
            let p = oriented(&contour);
            let (area, (mx, my), m20, m11, m02) = polygon_moments(&p);
            let theta = 0.5 * (2.0 * m11).atan2(m20 - m02);
            let (c, s, k) = (theta.cos(), theta.sin(), 1.0 / area.sqrt());
            let mut q: Vec<(f64, f64)> = p
                .iter()
                .map(|&(x, y)| {
                    let (x, y) = (x - mx, y - my);
                    (k * (c * x + s * y), k * (-s * x + c * y))
                })
                .collect();
            // ∫x³ dA over the polygon: fan of triangles from the origin, exact for cubics
            // (Green: ∫x³ dA = Σ (x0³ + x0²x1 + x0x1² + x1³)(x0y1 − x1y0)/20).
            let n = q.len();
            let skew: f64 = (0..n)
                .map(|i| {
                    let ((x0, y0), (x1, y1)) = (q[i], q[(i + 1) % n]);
                    (x0.powi(3) + x0 * x0 * x1 + x0 * x1 * x1 + x1.powi(3)) * (x0 * y1 - x1 * y0)
                })
                .sum::<f64>()
                / 20.0;
            if skew < 0.0 {
                q.iter_mut().for_each(|v| *v = (-v.0, -v.1));
            }
            let len = |i: usize| {
                let (a, b) = (q[i], q[(i + 1) % n]);
                ((b.0 - a.0).powi(2) + (b.1 - a.1).powi(2)).sqrt()
            };
            let per: f64 = (0..n).map(len).sum();
            // Farthest crossing of the +x axis (the vertex of largest x if none).
            let mut start = None::<(f64, f64)>;
            let mut crossings = 0;
            let mut walked = 0.0;
            for i in 0..n {
                let (a, b) = (q[i], q[(i + 1) % n]);
                if (a.1 <= 0.0) != (b.1 <= 0.0) {
                    let f = a.1 / (a.1 - b.1);
                    let x = a.0 + f * (b.0 - a.0);
                    crossings += usize::from(x > 0.0);
                    if x > 0.0 && start.is_none_or(|(bx, _)| x > bx) {
                        start = Some((x, walked + f * len(i)));
                    }
                }
                walked += len(i);
            }
            let start = start
                .expect("the ray from the centroid leaves these regions")
                .1;
            most_crossings = most_crossings.max(crossings);
            for (j, z) in got.iter().enumerate() {
                let want = point_at(&q, start + j as f64 * per / samples as f64);
                let d = ((z.re - want.0).powi(2) + (z.im - want.1).powi(2)).sqrt();
                assert!(
                    d < 1e-9,
                    "L {samples}, sample {j}: {z} vs {want:?} ({contour:?})"
                );
            }
            if samples == 256 {
                // The frame's invariants, on the samples themselves: sample 0 on the +x axis.
                assert!(got[0].im.abs() < 1e-9 && got[0].re > 0.0, "{:?}", got[0]);
            }
        }
    }
    assert!(
        most_crossings >= 3,
        "no region where the ray crosses more than once"
    );
}

/// `Sampling::AffineArcLength` on an ellipse `c + R(a cos t, b sin t)`: `x ẏ − y ẋ = ab` about
/// the centre, so equal steps of affine arc length are equal steps of `t`, from the first
/// vertex. Anisotropic, rotated, off-origin, with an odd `L`.
#[test]
fn affine_resampling_of_an_ellipse_is_uniform_in_its_parameter() {
    let (a, b, rot, centre) = (60.0, 20.0, 0.3f64, (140.0, -75.0));
    let at = |t: f64| {
        let (x, y) = (a * t.cos(), b * t.sin());
        (
            centre.0 + rot.cos() * x - rot.sin() * y,
            centre.1 + rot.sin() * x + rot.cos() * y,
        )
    };
    let n = 4000;
    let contour: Vec<(f64, f64)> = (0..n).map(|i| at(TAU * i as f64 / n as f64)).collect();
    for samples in [5, 37, 256] {
        let cfg = DescriptorConfig {
            samples,
            coefficients: 5,
            dense_samples: 4096,
            // σ of one dense spacing: the Gaussian (in arc length) smooths an ellipse, which
            // is not uniformly parametrised in arc length, into a slightly different curve.
            smoothing: 0.0,
            ..DescriptorConfig::with_sampling(Sampling::AffineArcLength)
        };
        let got = Extractor::new(cfg)
            .unwrap()
            .resample(&contour)
            .unwrap()
            .to_vec();
        for (j, z) in got.iter().enumerate() {
            let want = at(TAU * j as f64 / samples as f64);
            let d = ((z.re - want.0).powi(2) + (z.im - want.1).powi(2)).sqrt();
            // (2e-4 is reached: linear interpolation on the dense curve.)
            assert!(
                d < 1e-3,
                "L {samples}, sample {j}: {z} vs {want:?} (off by {d:e})"
            );
        }
    }
}
