//! Learning on tiny hand-computed cases (1-D, five cos² channels on the integers 1..5,
//! `a = π/3`): `b(2) = [¼, 1, ¼, 0, 0]`, `b(3) = [0, ¼, 1, ¼, 0]`, `b(4) = [0, 0, ¼, 1, ¼]`.
//! Plus the shape of models learned from clean and cluttered synthetic data.

use cbt_tracker::sim::{Level, Scenario, generate};
use cbt_tracker::{
    CbtConfig, CbtModel, Clutter, Detection, Order, Scales, Space, SystemFallback, TrainingFrame,
};
use chan_repr::{ChannelBasis, Kernel};

const N: usize = 5;

fn space() -> Space {
    let b = ChannelBasis::integer(N, Kernel::Cos2 { m: 3 }).unwrap();
    Space::new(vec![b.clone()], vec![b]).unwrap()
}

fn b(x: f64) -> [f64; N] {
    match x as i64 {
        2 => [0.25, 1.0, 0.25, 0.0, 0.0],
        3 => [0.0, 0.25, 1.0, 0.25, 0.0],
        4 => [0.0, 0.0, 0.25, 1.0, 0.25],
        _ => unreachable!(),
    }
}

fn frame(state: f64, det: f64) -> TrainingFrame {
    TrainingFrame {
        states: vec![[state, 0.0]],
        detections: vec![Detection::new(det, 0.0)],
    }
}

/// The fallback Gaussian of σ = 1 channel around `c`, truncated at 3σ, normalised.
fn gauss(c: usize) -> [f64; N] {
    let mut g = [0.0; N];
    for (m, v) in g.iter_mut().enumerate() {
        let d = m as f64 - c as f64;
        if d.abs() <= 3.0 {
            *v = (-d * d / 2.0).exp();
        }
    }
    let s: f64 = g.iter().sum();
    g.map(|v| v / s)
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-12
}

fn config() -> CbtConfig {
    CbtConfig {
        observation_floor: 0.0,
        prior_weight: 1.0,
        ..CbtConfig::default()
    }
}

#[test]
fn observation_model_of_one_pair() {
    // One frame: state 2, detection 3. C = b(3) b(2)ᵀ.
    let cfg = CbtConfig {
        order: Order::First,
        ..config()
    };
    let frames = vec![frame(2.0, 3.0), frame(2.0, 3.0)];
    let m = CbtModel::learn(space(), cfg, &[frames]).unwrap();
    let c = m.observation_counts(0).unwrap();
    let o = m.observation_matrix(0).unwrap();
    let (bz, bx) = (b(3.0), b(2.0));
    for mm in 0..N {
        for n in 0..N {
            assert!(close(c[mm * N + n], 2.0 * bz[mm] * bx[n]), "C[{mm},{n}]");
        }
    }
    // Column 1 (state centre 2): mass 2·1.5 = 3; fallback = b(2)/1.5 (ideal sensor).
    for mm in 0..N {
        let want = (2.0 * bz[mm] + b(2.0)[mm] / 1.5) / (3.0 + 1.0);
        assert!(close(o[mm * N + 1], want), "O[{mm},1] = {}", o[mm * N + 1]);
    }
    // Column 0 (centre 1, outside the measurement range [1.5, 4.5]): uniform fallback.
    for mm in 0..N {
        let want = (2.0 * 0.25 * bz[mm] + 0.2) / (2.0 * 0.25 * 1.5 + 1.0);
        assert!(close(o[mm * N], want));
    }
    // Column 4 (centre 5): untouched and outside the range: exactly uniform.
    for mm in 0..N {
        assert!(close(o[mm * N + 4], 0.2));
    }
    // Every column sums to 1.
    for n in 0..N {
        let s: f64 = (0..N).map(|mm| o[mm * N + n]).sum();
        assert!(close(s, 1.0));
    }
}

#[test]
fn first_order_model_of_one_transition() {
    let cfg = CbtConfig {
        order: Order::First,
        ..config()
    };
    let m = CbtModel::learn(space(), cfg, &[vec![frame(2.0, 2.0), frame(3.0, 3.0)]]).unwrap();
    let s = m.first_order_matrix(0).unwrap();
    let (now, prev) = (b(3.0), b(2.0));
    for n in 0..N {
        let mass = 1.5 * prev[n];
        let g = gauss(n);
        for mm in 0..N {
            let want = (now[mm] * prev[n] + g[mm]) / (mass + 1.0);
            assert!(close(s[n * N + mm], want), "S[{mm},{n}]");
        }
    }
}

#[test]
fn second_order_model_of_one_triple() {
    for fallback in [SystemFallback::FirstOrder, SystemFallback::ConstantVelocity] {
        let cfg = CbtConfig {
            system_fallback: fallback,
            ..config()
        };
        let frames = vec![frame(2.0, 2.0), frame(3.0, 3.0), frame(4.0, 4.0)];
        let m = CbtModel::learn(space(), cfg, &[frames]).unwrap();
        let t = m.second_order_tensor(0).unwrap();
        let s = m.first_order_matrix(0).unwrap();
        // First order saw 2→3 and 3→4: column n = Σ b(next)[m] b(prev)[n].
        for n in 0..N {
            let mass = 1.5 * (b(2.0)[n] + b(3.0)[n]);
            let g = gauss(n);
            for mm in 0..N {
                let c = b(3.0)[mm] * b(2.0)[n] + b(4.0)[mm] * b(3.0)[n];
                assert!(close(s[n * N + mm], (c + g[mm]) / (mass + 1.0)));
            }
        }
        // Second order: T[m, n, o] = b(4)[m] b(3)[n] b(2)[o] with fallback per column.
        for o in 0..N {
            for n in 0..N {
                let w = b(3.0)[n] * b(2.0)[o];
                let mass = 1.5 * w;
                let f: Vec<f64> = match fallback {
                    SystemFallback::FirstOrder => (0..N).map(|mm| s[n * N + mm]).collect(),
                    SystemFallback::ConstantVelocity => {
                        let c = (2 * n as i64 - o as i64).clamp(0, N as i64 - 1) as usize;
                        gauss(c).to_vec()
                    }
                };
                for mm in 0..N {
                    let want = (b(4.0)[mm] * w + f[mm]) / (mass + 1.0);
                    let got = t[(o * N + n) * N + mm];
                    assert!(
                        close(got, want),
                        "{fallback:?} T[{mm},{n},{o}] = {got} vs {want}"
                    );
                }
            }
        }
    }
}

#[test]
fn unassociated_sets_count_every_pairing() {
    // Two states and two detections in one frame: C = (b(2)+b(4)) (b(2)+b(4))ᵀ — the true
    // pairs and the two wrong ones alike.
    let cfg = CbtConfig {
        order: Order::First,
        ..config()
    };
    let f = TrainingFrame {
        states: vec![[2.0, 0.0], [4.0, 0.0]],
        detections: vec![Detection::new(4.0, 0.0), Detection::new(2.0, 0.0)],
    };
    let m = CbtModel::learn(space(), cfg, &[vec![f.clone(), f]]).unwrap();
    let c = m.observation_counts(0).unwrap();
    let s: Vec<f64> = (0..N).map(|k| b(2.0)[k] + b(4.0)[k]).collect();
    for mm in 0..N {
        for n in 0..N {
            assert!(close(c[mm * N + n], 2.0 * s[mm] * s[n]));
        }
    }
}

/// Share of each trained column's mass within one channel of the diagonal, and the mean
/// value far from it (|m − n| > 3), over the columns with training mass.
fn diagonal_stats(level: usize) -> (f64, f64) {
    let sc = Scenario::default();
    let lv = Level::preset(level);
    let train = generate(&sc, &lv, 3, 300, 11).unwrap();
    let spacing = Scales::estimate(&train, sc.width)
        .unwrap()
        .spacing(sc.height)
        .unwrap();
    let space = Space::image(sc.width, sc.height, spacing).unwrap();
    let m = CbtModel::learn_sequences(space.clone(), CbtConfig::default(), &train).unwrap();
    let (o, c) = (
        m.observation_matrix(0).unwrap(),
        m.observation_counts(0).unwrap(),
    );
    let n = space.axis_len(0);
    let (mut band, mut cols, mut far, mut nfar) = (0.0, 0, 0.0, 0);
    for col in 0..n {
        let mass: f64 = (0..n).map(|r| c[r * n + col]).sum();
        if mass < 20.0 {
            continue;
        }
        cols += 1;
        band += (0..n)
            .filter(|r| r.abs_diff(col) <= 1)
            .map(|r| o[r * n + col])
            .sum::<f64>();
        for r in (0..n).filter(|r| r.abs_diff(col) > 3) {
            far += o[r * n + col];
            nfar += 1;
        }
    }
    assert!(cols > 10, "too few trained columns");
    (band / cols as f64, far / nfar as f64)
}

#[test]
fn clean_data_concentrate_on_the_diagonal_clutter_keeps_a_floor() {
    let (band_clean, far_clean) = diagonal_stats(0);
    let (band_clutter, far_clutter) = diagonal_stats(3);
    // Clean (σ = 1 px, no clutter): nearly all mass within one channel of the diagonal,
    // far entries at the ε-floor level (ε/N ≈ 1.5e-5).
    assert!(band_clean > 0.9, "clean band share {band_clean}");
    assert!(far_clean < 1e-4, "clean far mean {far_clean}");
    // Clutter (6 a frame): a broad floor from the wrong pairings.
    assert!(band_clutter < band_clean);
    assert!(
        far_clutter > 50.0 * far_clean,
        "clutter far mean {far_clutter} vs {far_clean}"
    );
}

#[test]
fn subtracting_the_background_removes_the_floor() {
    let sc = Scenario::default();
    let lv = Level::preset(3);
    let train = generate(&sc, &lv, 3, 300, 11).unwrap();
    let space = Space::image(sc.width, sc.height, 10.0).unwrap();
    let model = |clutter| {
        let cfg = CbtConfig {
            clutter,
            ..CbtConfig::default()
        };
        CbtModel::learn_sequences(space.clone(), cfg, &train).unwrap()
    };
    let (keep, sub) = (model(Clutter::Model), model(Clutter::Subtract));
    // Clutter::Uniform learns the same background-free matrix (its clutter term is added
    // at filtering time).
    assert_eq!(
        model(Clutter::Uniform).observation_matrix(0),
        sub.observation_matrix(0)
    );
    let n = space.axis_len(0);
    let far = |m: &CbtModel| {
        let o = m.observation_matrix(0).unwrap();
        let mut s = 0.0;
        for col in 5..n - 5 {
            for r in (0..n).filter(|r| r.abs_diff(col) > 4) {
                s += o[r * n + col];
            }
        }
        s
    };
    // The clamp at zero keeps the positive fluctuations of the clutter counts, so the far
    // mass drops by about half (measured 0.54), not to zero.
    assert!(
        far(&sub) < 0.65 * far(&keep),
        "{} vs {}",
        far(&sub),
        far(&keep)
    );
}
