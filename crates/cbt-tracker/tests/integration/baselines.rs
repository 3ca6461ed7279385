//! Independent oracles for the baselines: the Kalman filter against a scalar closed-form
//! filter per axis written here (the constant-velocity model decouples the axes), with the
//! nearest-neighbour gate evaluated by hand; the particle filter's one-step estimate against
//! the closed-form posterior mean of its Gaussian prior under the clutter-aware mixture
//! likelihood (constant velocity) and against quadrature (UNGM); the learned particle
//! filter's one-step estimate against quadrature over the learned densities; the calibration
//! statistics and the baselines' parameters against a plain reading of their definitions.

use crate::common;

use cbt_tracker::sim::rng_for;
use cbt_tracker::{
    Calibration, CbtConfig, CbtModel, Clutter, Detection, GATE_99, KalmanParams, KalmanTracker,
    LearnedParticleFilter, Order, ParticleFilter, PfModel, Sequence, Space, Tracker,
};
use nalgebra::Vector2;
use rand::RngExt;

/// One axis of the constant-velocity Kalman filter, state `(p, v)`, covariance
/// `[[a, b], [b, c]]`, in scalars.
#[derive(Debug, Clone, Copy)]
struct Axis {
    p: f64,
    v: f64,
    a: f64,
    b: f64,
    c: f64,
}

impl Axis {
    /// `F = [[1, 1], [0, 1]]`, `Q = σ_a² [[1/4, 1/2], [1/2, 1]]`.
    fn predict(&mut self, q: f64) {
        self.p += self.v;
        let (a, b, c) = (self.a, self.b, self.c);
        self.a = a + 2.0 * b + c + q / 4.0;
        self.b = b + c + q / 2.0;
        self.c = c + q;
    }

    /// `H = [1, 0]`, `R = r`.
    fn correct(&mut self, z: f64, r: f64) {
        let s = self.a + r;
        let (k0, k1) = (self.a / s, self.b / s);
        let nu = z - self.p;
        self.p += k0 * nu;
        self.v += k1 * nu;
        let (a, b, c) = (self.a, self.b, self.c);
        self.a = a - k0 * a;
        self.b = b - k0 * b;
        self.c = c - k1 * b;
    }
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * a.abs().max(b.abs()).max(1.0)
}

/// Checks the filter's state and covariance against the two scalar axes (the cross-axis
/// blocks stay zero).
fn same(kf: &KalmanTracker, ax: &[Axis; 2], what: &str) {
    let (x, p) = (kf.state(), kf.covariance());
    for d in 0..2 {
        assert!(close(x[d], ax[d].p, 1e-10), "{what}: position {d}");
        assert!(close(x[d + 2], ax[d].v, 1e-10), "{what}: velocity {d}");
        assert!(close(p[(d, d)], ax[d].a, 1e-10), "{what}: var p {d}");
        assert!(close(p[(d, d + 2)], ax[d].b, 1e-10), "{what}: cov {d}");
        assert!(close(p[(d + 2, d)], ax[d].b, 1e-10), "{what}: cov {d}");
        assert!(
            close(p[(d + 2, d + 2)], ax[d].c, 1e-10),
            "{what}: var v {d}"
        );
    }
    for (i, j) in [(0, 1), (0, 3), (1, 2), (2, 3)] {
        assert!(
            p[(i, j)].abs() < 1e-12 && p[(j, i)].abs() < 1e-12,
            "{what}: ({i}, {j})"
        );
    }
}

/// `reset`, `predict`, `correct` and the gated `step` against the scalar filter, for random
/// parameters, starts and detection sets (empty frames, zero-weight detections, detections
/// inside and outside the gate), over many steps. The gate takes the smallest squared
/// Mahalanobis distance `Σ_d ν_d² / (a_d + r)` among the positive-weight detections within
/// it; frames with a distance within 1e-6 of the gate are redrawn (no rounding ties).
#[test]
fn kalman_matches_a_scalar_filter_per_axis() {
    for case in 0..40u64 {
        let mut rng = rng_for(1000 + case, 0);
        let params = KalmanParams {
            accel_sigma: rng.random_range(0.05..3.0),
            meas_sigma: rng.random_range(0.2..5.0),
            init_vel_sigma: rng.random_range(0.1..6.0),
            gate: if case % 4 == 0 {
                1e12
            } else {
                rng.random_range(1.0..12.0)
            },
        };
        let (q, r) = (params.accel_sigma.powi(2), params.meas_sigma.powi(2));
        let start = [rng.random_range(-50.0..50.0), rng.random_range(-50.0..50.0)];
        let mut kf = KalmanTracker::new(params).unwrap();
        kf.reset(start).unwrap();
        let axis = |p: f64| Axis {
            p,
            v: 0.0,
            a: r,
            b: 0.0,
            c: params.init_vel_sigma.powi(2),
        };
        let mut ax = [axis(start[0]), axis(start[1])];
        same(&kf, &ax, "reset");
        let mut used = 0;
        for k in 0..30 {
            // Explicit predict and correct on every third step.
            if k % 3 == 0 {
                kf.predict();
                ax.iter_mut().for_each(|a| a.predict(q));
                same(&kf, &ax, "predict");
                let z = [rng.random_range(-60.0..60.0), rng.random_range(-60.0..60.0)];
                kf.correct(Vector2::new(z[0], z[1])).unwrap();
                ax[0].correct(z[0], r);
                ax[1].correct(z[1], r);
                same(&kf, &ax, "correct");
                continue;
            }
            let mut pred = ax;
            pred.iter_mut().for_each(|a| a.predict(q));
            let maha = |d: &Detection| {
                (0..2)
                    .map(|i| (d.pos[i] - pred[i].p).powi(2) / (pred[i].a + r))
                    .sum::<f64>()
            };
            let dets: Vec<Detection> = loop {
                let n = rng.random_range(0..5usize);
                let dets: Vec<Detection> = (0..n)
                    .map(|_| {
                        let spread = rng.random_range(0.2..4.0) * (pred[0].a + r).sqrt();
                        Detection {
                            pos: [
                                pred[0].p + spread * rng.random_range(-1.0..1.0),
                                pred[1].p + spread * rng.random_range(-1.0..1.0),
                            ],
                            weight: if rng.random_range(0..4) == 0 {
                                0.0
                            } else {
                                rng.random_range(0.1..2.0)
                            },
                        }
                    })
                    .collect();
                if dets.iter().all(|d| (maha(d) - params.gate).abs() > 1e-6) {
                    break dets;
                }
            };
            let best = dets
                .iter()
                .filter(|d| d.weight > 0.0 && maha(d) <= params.gate)
                .min_by(|a, b| maha(a).total_cmp(&maha(b)));
            ax = pred;
            if let Some(d) = best {
                ax[0].correct(d.pos[0], r);
                ax[1].correct(d.pos[1], r);
                used += 1;
            }
            let e = kf.step(&dets).unwrap();
            same(&kf, &ax, &format!("case {case} step {k}"));
            assert_eq!(e.position, [kf.state()[0], kf.state()[1]]);
        }
        assert!(used > 0, "case {case}: no detection was ever used");
    }
}

/// The particle filter's first estimate after a start, for the constant-velocity model: the
/// particles start at `N(s, σ_z²)` with velocities `N(0, σ_v²)`, so the propagated positions
/// are `N(s, Σ)` per axis with `Σ = σ_z² + σ_v² + σ_a²/4`, and the estimate is the posterior
/// mean under `(1 − P_D) + P_D/λ · Σ_i w_i N(z_i; x, σ_z² I)`: a mixture of the prior mean
/// (weight `1 − P_D`) and each detection's Kalman posterior mean (weight
/// `P_D/λ · w_i · N(z_i; s, (Σ + σ_z²) I)`). Zero-weight detections carry nothing; no
/// detection leaves the prior mean; `P_D = 1` with one detection is the Kalman update.
#[test]
fn particle_filter_first_estimate_is_the_closed_form_posterior_mean() {
    let n = 100_000;
    let cases: [(f64, f64, &[Detection]); 6] = [
        (1.0, 1e-4, &[Detection::new(13.0, 8.0)]),
        (0.7, 1e-3, &[Detection::new(13.0, 8.0)]),
        (
            0.9,
            2e-3,
            &[
                Detection::new(13.0, 8.0),
                Detection {
                    pos: [6.0, 12.0],
                    weight: 0.5,
                },
                Detection {
                    pos: [10.0, 10.0],
                    weight: 0.0,
                },
            ],
        ),
        (0.5, 1e-2, &[Detection::new(15.0, 5.0)]),
        (0.8, 1e-3, &[]),
        (
            0.8,
            1e-3,
            &[Detection {
                pos: [14.0, 7.0],
                weight: 0.0,
            }],
        ),
    ];
    let (sa, sz, sv) = (1.0f64, 2.0f64, 1.5f64);
    let s = [10.0, 10.0];
    let big = sz * sz + sv * sv + sa * sa / 4.0;
    for (i, &(pd, lambda, dets)) in cases.iter().enumerate() {
        let model = PfModel::ConstantVelocity {
            accel_sigma: sa,
            meas_sigma: sz,
            p_detect: pd,
            clutter_density: lambda,
            init_vel_sigma: sv,
        };
        let mut pf = ParticleFilter::new(model, n, 40 + i as u64).unwrap();
        pf.reset(s).unwrap();
        let got = pf.step(dets).unwrap().position;
        let tot = big + sz * sz;
        let gain = big / tot;
        let (mut w, mut m) = (1.0 - pd, [(1.0 - pd) * s[0], (1.0 - pd) * s[1]]);
        let live: Vec<&Detection> = dets.iter().filter(|d| d.weight > 0.0).collect();
        if live.is_empty() {
            (w, m) = (1.0, s);
        }
        for d in live {
            let e2 = (d.pos[0] - s[0]).powi(2) + (d.pos[1] - s[1]).powi(2);
            let c = pd / lambda * d.weight * (-0.5 * e2 / tot).exp()
                / (2.0 * std::f64::consts::PI * tot);
            w += c;
            for k in 0..2 {
                m[k] += c * (s[k] + gain * (d.pos[k] - s[k]));
            }
        }
        let want = [m[0] / w, m[1] / w];
        for k in 0..2 {
            assert!(
                (got[k] - want[k]).abs() < 0.05,
                "case {i}: {got:?} against {want:?}"
            );
        }
    }
}

/// A plain reading of [`Calibration`]'s definitions: `σ_a = sqrt(2 · mean)` of the squared
/// second differences over every window of three frames with truth (both axes pooled);
/// `σ_z = 1.4826 ·` the middle (upper of the two for an even count) of the sorted absolute
/// residuals of the detection nearest (Euclidean) to the truth among those within
/// `max_residual` on both axes, `max_residual / 3` without any; `P_D` the share of truth
/// frames with a detection within `3σ_z` on both axes, clamped to `[0.01, 0.999]`; the
/// clutter rate the other detections per truth frame.
fn calibration_reference(train: &[Sequence], max_r: f64) -> Calibration {
    let (mut s2, mut n2) = (0.0, 0usize);
    for s in train {
        for k in 2..s.frames.len() {
            if let (Some(a), Some(b), Some(c)) = (
                s.frames[k - 2].truth,
                s.frames[k - 1].truth,
                s.frames[k].truth,
            ) {
                for d in 0..2 {
                    s2 += (c[d] - 2.0 * b[d] + a[d]).powi(2);
                    n2 += 1;
                }
            }
        }
    }
    let accel_sigma = (2.0 * s2 / n2 as f64).sqrt().max(1e-6);
    let mut res = Vec::new();
    for s in train {
        for f in &s.frames {
            let Some(t) = f.truth else { continue };
            let mut best: Option<(f64, f64, f64)> = None;
            for d in &f.detections {
                let (rx, ry) = ((d.pos[0] - t[0]).abs(), (d.pos[1] - t[1]).abs());
                let e = rx.hypot(ry);
                if rx < max_r && ry < max_r && best.is_none_or(|b| e < b.2) {
                    best = Some((rx, ry, e));
                }
            }
            if let Some((rx, ry, _)) = best {
                res.extend([rx, ry]);
            }
        }
    }
    res.sort_by(f64::total_cmp);
    let meas_sigma = if res.is_empty() {
        max_r / 3.0
    } else {
        (1.4826 * res[res.len() / 2]).max(1e-3)
    };
    let (mut frames, mut hits, mut dets) = (0usize, 0usize, 0usize);
    for s in train {
        for f in s.frames.iter().filter(|f| f.truth.is_some()) {
            let t = f.truth.unwrap();
            frames += 1;
            dets += f.detections.len();
            if f.detections.iter().any(|d| {
                (d.pos[0] - t[0]).abs() <= 3.0 * meas_sigma
                    && (d.pos[1] - t[1]).abs() <= 3.0 * meas_sigma
            }) {
                hits += 1;
            }
        }
    }
    Calibration {
        accel_sigma,
        meas_sigma,
        p_detect: (hits as f64 / frames as f64).clamp(0.01, 0.999),
        clutter_rate: (dets - hits) as f64 / frames as f64,
    }
}

#[test]
fn calibration_follows_its_definitions() {
    let mut checked = 0;
    for seed in 0..300 {
        let train = common::lattice_sequences(seed, 0);
        let max_r = [2.0, 5.0, 12.0][seed as usize % 3];
        let Ok(got) = Calibration::estimate(&train, max_r) else {
            // Only when no three consecutive frames have a truth.
            assert!(train.iter().all(|s| {
                s.frames
                    .windows(3)
                    .all(|w| w.iter().any(|f| f.truth.is_none()))
            }));
            continue;
        };
        let want = calibration_reference(&train, max_r);
        for (a, b, what) in [
            (got.accel_sigma, want.accel_sigma, "accel"),
            (got.meas_sigma, want.meas_sigma, "meas"),
            (got.p_detect, want.p_detect, "p_detect"),
            (got.clutter_rate, want.clutter_rate, "clutter"),
        ] {
            assert!(close(a, b, 1e-12), "seed {seed} {what}: {a} vs {b}");
        }
        // The baselines' parameters from it, as documented.
        let k = KalmanParams::from_calibration(&got);
        assert_eq!(
            (k.accel_sigma, k.meas_sigma, k.init_vel_sigma, k.gate),
            (
                got.accel_sigma,
                got.meas_sigma,
                5.0 * got.accel_sigma,
                GATE_99
            )
        );
        let area = 96.0 * 72.0;
        assert_eq!(
            PfModel::from_calibration(&got, area),
            PfModel::ConstantVelocity {
                accel_sigma: got.accel_sigma,
                meas_sigma: got.meas_sigma,
                p_detect: got.p_detect,
                clutter_density: got.clutter_rate.max(0.01) / area,
                init_vel_sigma: 5.0 * got.accel_sigma,
            }
        );
        checked += 1;
    }
    assert!(checked > 200, "{checked}");
}

/// The particle filter's UNGM estimate after one step from a (nearly) exact start `s`: the
/// propagated particles are `N(f(s, 1), σ_v²)` with `f` the written recursion, and the
/// estimate is the posterior mean under `Σ_i w_i N(z_i; x²/20, σ_n²)`, here by quadrature.
/// Two detections of different weights (the likelihood is bimodal in `x`), a zero-weight
/// one, and one alone.
#[test]
fn particle_filter_ungm_estimate_is_the_quadrature_posterior_mean() {
    let f = |x: f64, k: u64| x / 2.0 + 25.0 * x / (1.0 + x * x) + 8.0 * (1.2 * k as f64).cos();
    let (qv, rv) = (10.0f64, 2.0f64);
    let det = |z: f64, weight: f64| Detection {
        pos: [z, 0.0],
        weight,
    };
    let cases: [(f64, &[Detection]); 4] = [
        (0.1, &[det(5.0, 1.0)]),
        (0.1, &[det(5.0, 1.0), det(12.0, 0.3)]),
        (-4.0, &[det(3.0, 2.5), det(9.0, 1.0), det(20.0, 0.0)]),
        (2.0, &[det(1.0, 0.7)]),
    ];
    for (i, &(s, dets)) in cases.iter().enumerate() {
        let model = PfModel::Ungm {
            process_var: qv,
            meas_var: rv,
            init_sigma: 1e-9,
        };
        let mut pf = ParticleFilter::new(model, 100_000, 60 + i as u64).unwrap();
        pf.reset([s, 0.0]).unwrap();
        let got = pf.step(dets).unwrap().position[0];
        let mu = f(s, 1);
        let (mut z0, mut z1) = (0.0, 0.0);
        for j in -40_000..=40_000 {
            let x = mu + f64::from(j) * 2.5e-4 * qv.sqrt();
            let prior = (-(x - mu).powi(2) / (2.0 * qv)).exp();
            let lik: f64 = dets
                .iter()
                .map(|d| d.weight * (-(d.pos[0] - x * x / 20.0).powi(2) / (2.0 * rv)).exp())
                .sum();
            z0 += prior * lik;
            z1 += prior * lik * x;
        }
        let want = z1 / z0;
        // Monte Carlo error (seeded): about 0.01 here.
        assert!((got - want).abs() < 0.05, "case {i}: {got} against {want}");
    }
}

/// One axis of the learned particle filter's first step by quadrature over the channel
/// index `t`: the start is drawn from its channel density `Σ_n b_n(s) K(t − n)`, moved to
/// a channel `n` with probability `b̂_n(t)` (the normalised channel values) and then to
/// `m + u` with `m ∝ S[m | n]` and `u ∝ K`; a detection `z` weighs it by
/// `ℓ(t) = Σ_k b̂_k(t) Σ_m b_m(z) O[m, k]`. Returns the posterior mean (value space).
fn learned_axis_mean(model: &CbtModel, d: usize, start: f64, z: f64) -> f64 {
    let space = model.space();
    let b = space.state_basis(d);
    let kernel = b.kernel();
    let n = space.axis_len(d);
    let s = model.first_order_matrix(d).unwrap();
    let o = model.observation_matrix(d).unwrap();
    let bz = space.meas_basis(d).encode(z).unwrap();
    let lik: Vec<f64> = (0..n)
        .map(|k| bz.iter().enumerate().map(|(m, v)| v * o[m * n + k]).sum())
        .collect();
    let hat = |t: f64| {
        let mut a = Vec::new();
        b.for_each_active(t, |k, v| a.push((k, v)));
        let sum: f64 = a.iter().map(|e| e.1).sum();
        a.into_iter().map(move |(k, v)| (k, v / sum))
    };
    let dt = 1e-3;
    // Channel probabilities after the start's draw.
    let q = b.encode(start).unwrap();
    let t0 = b.to_index(start);
    let mut pn = vec![0.0; n];
    for i in -3000..=3000 {
        let t = t0 + f64::from(i) * dt;
        let dens: f64 = q
            .iter()
            .enumerate()
            .map(|(j, v)| v * kernel.value(t - j as f64))
            .sum();
        for (k, v) in hat(t) {
            pn[k] += dens * v;
        }
    }
    // The predicted channel weights `Σ_n pn[n] S[m | n]`, each spread by `K`, times `ℓ`.
    let pm: Vec<f64> = (0..n)
        .map(|m| (0..n).map(|j| pn[j] * s[j * n + m]).sum())
        .collect();
    let (mut z0, mut z1) = (0.0, 0.0);
    let (lo, hi) = b.representable_index_range();
    let steps = ((hi - lo) / dt) as i64;
    for i in 0..=steps {
        let t = lo + i as f64 * dt;
        let pred: f64 = pm
            .iter()
            .enumerate()
            .map(|(m, w)| w * kernel.value(t - m as f64))
            .sum();
        let l: f64 = hat(t).map(|(k, v)| v * lik[k]).sum();
        z0 += pred * l;
        z1 += pred * l * b.from_index(t);
    }
    z1 / z0
}

/// The learned particle filter's first estimate with one detection, against the quadrature
/// of [`learned_axis_mean`] per axis (the prediction draws each axis on its own and the
/// likelihood of one detection is a product over the axes, so the posterior mean is the
/// per-axis one), on a non-square 2-D grid.
#[test]
fn learned_particle_filter_first_estimate_is_the_quadrature_posterior_mean() {
    let (train, _) = common::data();
    let space = Space::image(common::W, common::H, 9.0).unwrap();
    assert_ne!(space.axis_len(0), space.axis_len(1));
    let cfg = CbtConfig {
        order: Order::First,
        clutter: Clutter::Subtract,
        ..CbtConfig::default()
    };
    let model = CbtModel::learn_sequences(space, cfg, &train).unwrap();
    for (i, (start, z)) in [([48.0, 36.0], [55.0, 31.0]), ([40.3, 30.2], [36.0, 38.5])]
        .into_iter()
        .enumerate()
    {
        let mut pf = LearnedParticleFilter::new(model.clone(), 100_000, 80 + i as u64).unwrap();
        pf.reset(start).unwrap();
        let got = pf.step(&[Detection::new(z[0], z[1])]).unwrap().position;
        // Monte Carlo error (seeded): up to 0.05 px here, on a 9 px grid.
        for d in 0..2 {
            let want = learned_axis_mean(&model, d, start[d], z[d]);
            assert!(
                (got[d] - want).abs() < 0.1,
                "case {i} axis {d}: {} against {want}",
                got[d]
            );
        }
    }
}
