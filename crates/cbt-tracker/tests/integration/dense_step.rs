//! The separable layout's filter step (`CbtTracker::predict`, `filter` / `step`) against a
//! brute-force filter written here from the equations of the crate docs and the model's
//! published matrices (`first_order_matrix`, `second_order_tensor`, `observation_matrix`)
//! with chan-repr's own encoding of the detections:
//!
//! ```text
//! per axis:  p_d = S_d m_d  (first order)  or  p_d[m] = Σ_{n,o} T_d[m | n, o] m_d[n] m'_d[o]
//!            (cells of a marginal below prune·mass/N skipped, their mass spread uniformly)
//! prior:     q⁻ = (1 − γ) (p_x ⊗ p_y) / Σ + γ / G
//! update:    q⁺ ∝ (Σ_i w_i (O_xᵀ b_x(z_i)) ⊗ (O_yᵀ b_y(z_i))) ⊙ q⁻   (q⁻ when no weight)
//! ```
//!
//! 1-D (a measurement basis other than the state's, as UNGM's) and non-square 2-D grids,
//! both orders, with and without pruning, the clutter handled by the model or subtracted,
//! weighted, zero-weight and empty detection sets. The sparse joint layout, whose models are
//! not published as matrices, is checked against the separable one where both must agree
//! (a 1-D space), with every clutter handling.

use crate::common;

use cbt_tracker::sim::{Ungm, rng_for};
use cbt_tracker::{
    CbtConfig, CbtModel, CbtTracker, Clutter, Detection, ObservationFallback, Order, Space, Tracker,
};
use chan_repr::{ChannelBasis, Kernel};
use rand::RngExt;

/// The per-axis prediction of marginal `m` (and the previous marginal `m2` for the second
/// order), pruned as documented.
fn predict_axis(model: &CbtModel, d: usize, m: &[f64], m2: &[f64]) -> Vec<f64> {
    let cfg = model.config();
    let n = m.len();
    let mut out = vec![0.0; n];
    let kept = |q: &[f64]| -> Vec<(usize, f64)> {
        let cut = cfg.prune * q.iter().sum::<f64>() / n as f64;
        q.iter()
            .copied()
            .enumerate()
            .filter(|&(_, w)| w > 0.0 && w >= cut)
            .collect()
    };
    let k1 = kept(m);
    let mass1: f64 = k1.iter().map(|e| e.1).sum();
    let dropped = match cfg.order {
        Order::First => {
            let s = model.first_order_matrix(d).unwrap();
            for &(j, w) in &k1 {
                for (i, o) in out.iter_mut().enumerate() {
                    *o += w * s[j * n + i];
                }
            }
            m.iter().sum::<f64>() - mass1
        }
        Order::Second => {
            let t = model.second_order_tensor(d).unwrap();
            let k2 = kept(m2);
            let mass2: f64 = k2.iter().map(|e| e.1).sum();
            for &(o, w2) in &k2 {
                for &(j, w1) in &k1 {
                    for (i, v) in out.iter_mut().enumerate() {
                        *v += w1 * w2 * t[(o * n + j) * n + i];
                    }
                }
            }
            (m.iter().sum::<f64>() * m2.iter().sum::<f64>() - mass1 * mass2).max(0.0)
        }
    };
    out.iter_mut().for_each(|v| *v += dropped / n as f64);
    out
}

/// Per-axis marginals of a joint posterior (x major: cell `i·N_y + j`).
fn marginals(space: &Space, q: &[f64]) -> Vec<Vec<f64>> {
    if space.dims() == 1 {
        return vec![q.to_vec()];
    }
    let (nx, ny) = (space.axis_len(0), space.axis_len(1));
    let mut m = vec![vec![0.0; nx], vec![0.0; ny]];
    for i in 0..nx {
        for j in 0..ny {
            m[0][i] += q[i * ny + j];
            m[1][j] += q[i * ny + j];
        }
    }
    m
}

/// The prior `q⁻` from the current and previous posteriors.
fn prior(model: &CbtModel, q: &[f64], q_prev: &[f64]) -> Vec<f64> {
    let space = model.space();
    let (m, m2) = (marginals(space, q), marginals(space, q_prev));
    let p: Vec<Vec<f64>> = (0..space.dims())
        .map(|d| predict_axis(model, d, &m[d], &m2[d]))
        .collect();
    let joint: Vec<f64> = if space.dims() == 1 {
        p[0].clone()
    } else {
        p[0].iter()
            .flat_map(|a| p[1].iter().map(move |b| a * b))
            .collect()
    };
    let total: f64 = joint.iter().sum();
    let (gamma, g) = (model.config().mixing, joint.len() as f64);
    joint
        .iter()
        .map(|v| (1.0 - gamma) * v / total + gamma / g)
        .collect()
}

/// `O_dᵀ b_d(z)` of axis `d`, with chan-repr's encoding of `z`.
fn axis_likelihood(model: &CbtModel, d: usize, z: f64) -> Vec<f64> {
    let space = model.space();
    let (nx, o) = (space.axis_len(d), model.observation_matrix(d).unwrap());
    let b = space.meas_basis(d).encode(z).unwrap();
    (0..nx)
        .map(|n| b.iter().enumerate().map(|(m, v)| v * o[m * nx + n]).sum())
        .collect()
}

/// The posterior after one step from `(q, q_prev)` with `dets`.
fn step(model: &CbtModel, q: &[f64], q_prev: &[f64], dets: &[Detection]) -> Vec<f64> {
    let prior = prior(model, q, q_prev);
    let live: Vec<&Detection> = dets.iter().filter(|d| d.weight > 0.0).collect();
    if live.is_empty() {
        return prior;
    }
    let mut lik = vec![0.0; prior.len()];
    for d in live {
        let lx = axis_likelihood(model, 0, d.pos[0]);
        let ly = if model.space().dims() == 2 {
            axis_likelihood(model, 1, d.pos[1])
        } else {
            vec![1.0]
        };
        for (i, a) in lx.iter().enumerate() {
            for (j, b) in ly.iter().enumerate() {
                lik[i * ly.len() + j] += d.weight * a * b;
            }
        }
    }
    let post: Vec<f64> = lik.iter().zip(&prior).map(|(l, p)| l * p).collect();
    let s: f64 = post.iter().sum();
    if s > 0.0 && s.is_finite() {
        post.iter().map(|v| v / s).collect()
    } else {
        prior
    }
}

/// Steps `t` through `frames` (each frame's detections reweighted at random, some dropped),
/// checking `predict` and the posterior after every step against the brute-force filter.
fn check(t: &mut CbtTracker, frames: &[Vec<Detection>], seed: u64, what: &str) {
    let model = t.model().clone();
    let space = model.space().clone();
    let mut rng = rng_for(seed, 0);
    let mut q_prev = t.posterior().to_vec();
    let mut updates = 0;
    for (k, dets) in frames.iter().enumerate() {
        let dets: Vec<Detection> = dets
            .iter()
            .filter(|d| {
                (0..space.dims()).all(|a| space.meas_basis(a).checked_index(d.pos[a]).is_ok())
            })
            .filter_map(|d| {
                let weight = match rng.random_range(0..6) {
                    0 => 0.0,
                    1 => rng.random_range(0.1..3.0),
                    _ => 1.0,
                };
                (rng.random_range(0..8) != 0).then_some(Detection { pos: d.pos, weight })
            })
            .collect();
        let q = t.posterior().to_vec();
        let want_prior = prior(&model, &q, &q_prev);
        for (a, b) in t.predict().iter().zip(&want_prior) {
            assert!((a - b).abs() < 1e-12, "{what} step {k}: prior {a} vs {b}");
        }
        let want = step(&model, &q, &q_prev, &dets);
        t.step(&dets).unwrap();
        let got = t.posterior();
        assert_eq!(got.len(), want.len());
        for (g, (a, b)) in got.iter().zip(&want).enumerate() {
            assert!(
                (a - b).abs() < 1e-12,
                "{what} step {k} cell {g}: {a} vs {b}"
            );
        }
        if dets.iter().any(|d| d.weight > 0.0) {
            updates += 1;
        }
        q_prev = q;
    }
    assert!(updates > frames.len() / 2, "{what}: {updates} updates");
}

fn config(order: Order, prune: f64, clutter: Clutter) -> CbtConfig {
    CbtConfig {
        order,
        prune,
        clutter,
        mixing: 0.01,
        ..CbtConfig::default()
    }
}

#[test]
fn separable_2d_steps_match_the_brute_force_filter() {
    let (train, test) = common::data();
    // A non-square grid: 12 × 10 channels of at most 11 px.
    let space = Space::image(common::W, common::H, 11.0).unwrap();
    assert_ne!(space.axis_len(0), space.axis_len(1));
    let frames: Vec<Vec<Detection>> = test.frames[1..16]
        .iter()
        .map(|f| f.detections.clone())
        .collect();
    for (i, (order, prune, clutter)) in [
        (Order::First, 0.0, Clutter::Model),
        (Order::First, 0.05, Clutter::Subtract),
        (Order::Second, 0.0, Clutter::Subtract),
        (Order::Second, 0.05, Clutter::Model),
    ]
    .into_iter()
    .enumerate()
    {
        let cfg = config(order, prune, clutter);
        let model = CbtModel::learn_sequences(space.clone(), cfg, &train).unwrap();
        let mut t = CbtTracker::new(model);
        t.reset(test.frames[0].truth.unwrap()).unwrap();
        check(&mut t, &frames, 90 + i as u64, &format!("{cfg:?}"));
    }
}

#[test]
fn separable_1d_steps_match_the_brute_force_filter() {
    // UNGM: the state x on 36 channels over [−35, 35], the measurement x²/20 on 24 over
    // [−5, 50] (another basis, another length).
    let ungm = Ungm::default();
    let train = ungm.generate(4, 120, 5).unwrap();
    let test = ungm.generate(1, 25, 6).unwrap().remove(0);
    let kernel = Kernel::Cos2 { m: 3 };
    let sb = ChannelBasis::covering(-35.0, 35.0, 36, kernel).unwrap();
    let mb = ChannelBasis::covering(-5.0, 50.0, 24, kernel).unwrap();
    let space = Space::new(vec![sb], vec![mb]).unwrap();
    let frames: Vec<Vec<Detection>> = test.frames[1..]
        .iter()
        .map(|f| f.detections.clone())
        .collect();
    for (i, order) in [Order::First, Order::Second].into_iter().enumerate() {
        let cfg = CbtConfig {
            observation_fallback: ObservationFallback::Uniform,
            ..config(order, 0.02, Clutter::Model)
        };
        let model = CbtModel::learn_sequences(space.clone(), cfg, &train).unwrap();
        let mut t = CbtTracker::new(model);
        t.reset(test.frames[0].truth.unwrap()).unwrap();
        check(&mut t, &frames, 70 + i as u64, &format!("1-D {order:?}"));
    }
}

/// On a 1-D space the sparse joint layout's grid is the separable layout's axis, and its
/// models are learned from the same soft counts (here with clutter in the training frames):
/// both layouts must filter alike. The
/// separable one is the brute-force-checked reference here; this also covers
/// [`Clutter::Uniform`] (whose learned clutter share the brute-force filter cannot read) and
/// the joint layout's pruning, both orders.
#[test]
fn sparse_joint_1d_agrees_with_the_brute_force_checked_separable_layout() {
    let ungm = Ungm::default();
    let mut rng = rng_for(17, 0);
    // UNGM with clutter in half of the training frames (a positive learned clutter share).
    let mut train = ungm.generate(4, 120, 5).unwrap();
    for f in train.iter_mut().flat_map(|s| s.frames.iter_mut()) {
        if rng.random_range(0..2) == 0 {
            f.detections
                .push(Detection::new(rng.random_range(0.0..40.0), 0.0));
        }
    }
    let test = ungm.generate(1, 30, 6).unwrap().remove(0);
    let kernel = Kernel::Cos2 { m: 3 };
    let sb = ChannelBasis::covering(-35.0, 35.0, 36, kernel).unwrap();
    let mb = ChannelBasis::covering(-5.0, 50.0, 24, kernel).unwrap();
    let space = Space::new(vec![sb], vec![mb]).unwrap();
    let mut compared = 0;
    for order in [Order::First, Order::Second] {
        for clutter in [Clutter::Model, Clutter::Subtract, Clutter::Uniform] {
            for prune in [0.0, 0.02] {
                let cfg = CbtConfig {
                    observation_fallback: ObservationFallback::Uniform,
                    ..config(order, prune, clutter)
                };
                let joint = CbtConfig {
                    layout: cbt_tracker::Layout::SparseJoint,
                    ..cfg
                };
                let learn = |c| CbtModel::learn_sequences(space.clone(), c, &train).unwrap();
                let (mut a, mut b) = (CbtTracker::new(learn(cfg)), CbtTracker::new(learn(joint)));
                let start = test.frames[0].truth.unwrap();
                a.reset(start).unwrap();
                b.reset(start).unwrap();
                for (k, f) in test.frames[1..].iter().enumerate() {
                    // Reweighted detections, and a clutter detection every third frame.
                    let mut dets: Vec<Detection> = f
                        .detections
                        .iter()
                        .filter(|d| space.meas_basis(0).checked_index(d.pos[0]).is_ok())
                        .map(|d| Detection {
                            pos: d.pos,
                            weight: [0.0, 0.5, 1.0, 2.0][rng.random_range(0..4usize)],
                        })
                        .collect();
                    if k % 3 == 0 {
                        dets.push(Detection::new(rng.random_range(0.0..40.0), 0.0));
                    }
                    assert_eq!(a.predict().len(), b.predict().len());
                    for (x, y) in a.predict().iter().zip(&b.predict()) {
                        assert!(
                            (x - y).abs() < 1e-12,
                            "{joint:?} step {k}: prior {x} vs {y}"
                        );
                    }
                    a.step(&dets).unwrap();
                    b.step(&dets).unwrap();
                    for (x, y) in a.posterior().iter().zip(b.posterior()) {
                        assert!((x - y).abs() < 1e-12, "{joint:?} step {k}: {x} vs {y}");
                    }
                    let (ea, eb) = (a.estimate().position[0], b.estimate().position[0]);
                    assert!((ea - eb).abs() < 1e-9, "{joint:?} step {k}: {ea} vs {eb}");
                    compared += 1;
                }
            }
        }
    }
    assert_eq!(compared, 12 * 29);
}
