//! The first prediction after a start ([`StartMotion`]): the start density learned from the
//! training runs' first displacements, its broad prior with little data, the saved form, and
//! typed errors.

use cbt_tracker::{
    CbtConfig, CbtModel, CbtTracker, Detection, Layout, Space, StartMotion, TrackError, Tracker,
    TrainingFrame,
};
use chan_repr::ChannelBasis;

/// A 2-D space with channel centres at the integers 1..=n on both axes.
fn integer_space(n: usize) -> Space {
    let b = ChannelBasis::integer(n, cbt_tracker::DEFAULT_KERNEL).unwrap();
    Space::new(vec![b.clone(), b.clone()], vec![b.clone(), b]).unwrap()
}

/// Runs that enter walking `step` channels a frame along x for `walk` frames and then stand
/// for `stand` frames (the pedestrians' case: most training steps are standing, every run
/// starts walking); detected exactly.
fn enter_and_stand(n: usize, step: f64, walk: usize, stand: usize) -> Vec<Vec<TrainingFrame>> {
    (0..n)
        .map(|i| {
            let mut p = [40.0, 20.0 + 3.0 * i as f64];
            (0..walk + stand)
                .map(|k| {
                    let f = TrainingFrame {
                        states: vec![p],
                        detections: vec![Detection::new(p[0], p[1])],
                    };
                    if k < walk {
                        p[0] += step;
                    }
                    f
                })
                .collect()
        })
        .collect()
}

fn learned() -> CbtConfig {
    CbtConfig {
        start: StartMotion::Learned,
        ..CbtConfig::stationary()
    }
}

fn pooled() -> CbtConfig {
    CbtConfig {
        start: StartMotion::Pooled,
        ..CbtConfig::stationary()
    }
}

fn marginal() -> CbtConfig {
    CbtConfig {
        start: StartMotion::Marginal,
        ..CbtConfig::stationary()
    }
}

/// Index of the largest entry, as a displacement `δ = i − r`.
fn mode(v: &[f64]) -> i64 {
    let i = (0..v.len()).max_by(|&a, &b| v[a].total_cmp(&v[b])).unwrap();
    i as i64 - (v.len() / 2) as i64
}

#[test]
fn the_start_density_is_learned_from_first_displacements() {
    let train = enter_and_stand(20, 4.0, 2, 30);
    let space = integer_space(120);
    let m = CbtModel::learn(space.clone(), learned(), &train).unwrap();
    let (s, _) = m.stationary_system(0).unwrap();
    let s0 = m.stationary_start(0).unwrap();
    // S is held by the standing frames, the start density by the entries.
    assert_eq!(mode(s), 0);
    assert_eq!(mode(s0), 4);
    assert!((s0.iter().sum::<f64>() - 1.0).abs() < 1e-12);
    // Along y nobody moves: both at zero.
    assert_eq!(mode(m.stationary_start(1).unwrap()), 0);
    // The marginal start is S itself.
    let marg = CbtModel::learn(space, marginal(), &train).unwrap();
    assert_eq!(
        marg.stationary_start(0).unwrap(),
        marg.stationary_system(0).unwrap().0
    );
}

#[test]
fn few_runs_give_a_broad_start_not_the_spike() {
    // Two runs: the counts of two first steps (mass 4.5) against the prior's α = 10.
    let train = enter_and_stand(2, 4.0, 2, 60);
    let m = CbtModel::learn(integer_space(120), learned(), &train).unwrap();
    let (s, _) = m.stationary_system(0).unwrap();
    let s0 = m.stationary_start(0).unwrap();
    let r = (s.len() / 2) as i64;
    let var = |v: &[f64]| -> f64 {
        v.iter()
            .enumerate()
            .map(|(i, &p)| p * (i as f64 - r as f64).powi(2))
            .sum()
    };
    // S is spiky at zero (most steps stand); the start density is at least as wide as S and
    // holds less mass at zero displacement.
    assert!(var(s0) >= var(s), "{} < {}", var(s0), var(s));
    let (a, b) = (s0[r as usize], s[r as usize]);
    assert!(a < 0.75 * b, "S₀[0] = {a}, S[0] = {b}");
}

#[test]
fn a_walking_start_is_predicted_to_walk() {
    let train = enter_and_stand(20, 4.0, 2, 30);
    let space = integer_space(120);
    for (cfg, walks) in [(learned(), true), (marginal(), false)] {
        let m = CbtModel::learn(space.clone(), cfg, &train).unwrap();
        let mut t = CbtTracker::new(m);
        t.reset([40.0, 60.0]).unwrap();
        let prior = t.predict();
        let ny = space.axis_len(1);
        let best = (0..prior.len())
            .max_by(|&a, &b| prior[a].total_cmp(&prior[b]))
            .unwrap();
        // Channel index i holds the centre i + 1 on the integer grid.
        let x = (best / ny) as f64 + 1.0;
        if walks {
            assert_eq!(x, 44.0);
        } else {
            assert_eq!(x, 40.0);
        }
        // From the second step on the carried velocity decides (same for both).
        t.step(&[Detection::new(44.0, 60.0)]).unwrap();
        assert!((t.estimate().position[0] - 44.0).abs() < 1.0);
    }
}

#[test]
fn saved_form_and_checks() {
    let train = enter_and_stand(5, 4.0, 2, 10);
    let space = integer_space(120);
    // The marginal start writes nothing new.
    let m = CbtModel::learn(space.clone(), marginal(), &train).unwrap();
    let text = serde_json::to_string(&m).unwrap();
    for key in ["\"start\"", "\"c0\"", "\"s0\""] {
        assert!(!text.contains(key), "{key} in a marginal-start model");
    }
    // A learned start round-trips.
    let m = CbtModel::learn(space.clone(), learned(), &train).unwrap();
    let text = serde_json::to_string(&m).unwrap();
    assert!(text.contains("\"start\":\"learned\""));
    let back: CbtModel = serde_json::from_str(&text).unwrap();
    assert_eq!(back.stationary_start(0), m.stationary_start(0));
    // A learned-start model without its start density, or a marginal one with one, is corrupt.
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    let strip = |v: &mut serde_json::Value| {
        let mut n = 0;
        walk(v, &mut |o| {
            if o.remove("s0").is_some() {
                n += 1;
            }
        });
        n
    };
    assert!(strip(&mut v) > 0);
    assert!(matches!(
        serde_json::from_value::<CbtModel>(v).map_err(|e| e.to_string()),
        Err(e) if e.contains("start density")
    ));
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    walk(&mut v, &mut |o| {
        if o.get("start") == Some(&serde_json::json!("learned")) {
            o.remove("start");
        }
    });
    assert!(matches!(
        serde_json::from_value::<CbtModel>(v).map_err(|e| e.to_string()),
        Err(e) if e.contains("start")
    ));
}

/// Calls `f` on every object of `v`.
fn walk(
    v: &mut serde_json::Value,
    f: &mut dyn FnMut(&mut serde_json::Map<String, serde_json::Value>),
) {
    match v {
        serde_json::Value::Object(o) => {
            f(o);
            for x in o.values_mut() {
                walk(x, f);
            }
        }
        serde_json::Value::Array(a) => a.iter_mut().for_each(|x| walk(x, f)),
        _ => {}
    }
}

#[test]
fn the_image_tracking_configuration_learns_its_start() {
    assert_eq!(CbtConfig::stationary().start, StartMotion::Learned);
    assert_eq!(CbtConfig::default().start, StartMotion::Marginal);
}

#[test]
fn a_learned_start_needs_the_stationary_layout() {
    for start in [StartMotion::Learned, StartMotion::Pooled] {
        let cfg = CbtConfig {
            start,
            layout: Layout::Separable,
            ..CbtConfig::default()
        };
        assert!(matches!(
            cfg.validate(),
            Err(TrackError::InvalidParameter { name: "start", .. })
        ));
        let train = enter_and_stand(3, 4.0, 2, 10);
        assert!(matches!(
            CbtModel::learn(integer_space(60), cfg, &train),
            Err(TrackError::InvalidParameter { name: "start", .. })
        ));
    }
}

/// The average of the axes' start densities for axis `d`, aligned by displacement and cut
/// to axis `d`'s radius (brute force).
fn axes_average(m: &CbtModel, d: usize) -> Vec<f64> {
    let own = m.stationary_start(d).unwrap();
    let r = (own.len() / 2) as i64;
    let mut out = vec![0.0; own.len()];
    for e in 0..2 {
        let v = m.stationary_start(e).unwrap();
        let re = (v.len() / 2) as i64;
        for delta in -r..=r {
            if delta.abs() <= re {
                out[(delta + r) as usize] += v[(delta + re) as usize];
            }
        }
    }
    let s: f64 = out.iter().sum();
    out.iter().map(|x| x / s).collect()
}

#[test]
fn a_pooled_start_predicts_with_the_axes_average() {
    // Walkers entering along x only: the per-axis start densities differ (x at +4, y at 0).
    let train = enter_and_stand(20, 4.0, 2, 30);
    let space = integer_space(120);
    let l = CbtModel::learn(space.clone(), learned(), &train).unwrap();
    let p = CbtModel::learn(space.clone(), pooled(), &train).unwrap();
    for d in 0..2 {
        // The same per-axis learning; the learned start's first step is the axis's own.
        assert_eq!(p.stationary_start(d), l.stationary_start(d));
        assert_eq!(
            l.stationary_first_step(d).unwrap(),
            l.stationary_start(d).unwrap()
        );
        let (got, want) = (p.stationary_first_step(d).unwrap(), axes_average(&p, d));
        assert_eq!(got.len(), want.len());
        for (a, b) in got.iter().zip(&want) {
            assert!((a - b).abs() < 1e-15, "{a} against {b}");
        }
    }
    // Along y nobody entered, but the pooled start walks there as along x.
    let (sx, sy) = (
        p.stationary_first_step(0).unwrap(),
        p.stationary_first_step(1).unwrap(),
    );
    assert_eq!(sx, sy);
    let r = sy.len() / 2;
    let walking = |v: &[f64]| v[r + 3..=r + 5].iter().sum::<f64>();
    assert!(walking(&sy) > 0.3, "{}", walking(&sy));
    assert!(walking(l.stationary_first_step(1).as_deref().unwrap()) < 0.05);
    assert!(p.stationary_first_step(2).is_none());
}

#[test]
fn the_first_prediction_is_the_pooled_convolution() {
    // Brute force over the grid: q⁻[i, j] = (1 − γ)·Σ_{a,b} q[a, b]·S̄(i − a)·S̄(j − b) + γ/G
    // with S̄ the axes' average start density; the filter cuts tails of at most 1e-5.
    let train = enter_and_stand(12, 3.0, 2, 20);
    let space = integer_space(64);
    let m = CbtModel::learn(space.clone(), pooled(), &train).unwrap();
    let gamma = m.config().mixing;
    let k = [
        m.stationary_first_step(0).unwrap(),
        m.stationary_first_step(1).unwrap(),
    ];
    let r = [(k[0].len() / 2) as i64, (k[1].len() / 2) as i64];
    let mut t = CbtTracker::new(m);
    t.reset([20.0, 17.0]).unwrap();
    let ([i0, j0], [h, w]) = t.posterior_window().unwrap();
    let q = t.posterior().to_vec();
    let (nx, ny) = (space.axis_len(0), space.axis_len(1));
    let g = (nx * ny) as f64;
    let mut want = vec![gamma / g; nx * ny];
    for a in 0..h {
        for b in 0..w {
            let v = q[a * w + b];
            for i in 0..nx as i64 {
                let dx = i - (i0 + a) as i64;
                if dx.abs() > r[0] {
                    continue;
                }
                for j in 0..ny as i64 {
                    let dy = j - (j0 + b) as i64;
                    if dy.abs() <= r[1] {
                        want[i as usize * ny + j as usize] += (1.0 - gamma)
                            * v
                            * k[0][(dx + r[0]) as usize]
                            * k[1][(dy + r[1]) as usize];
                    }
                }
            }
        }
    }
    let s: f64 = want.iter().sum();
    want.iter_mut().for_each(|x| *x /= s);
    let got = t.predict();
    let max = want.iter().cloned().fold(0.0, f64::max);
    for (a, b) in got.iter().zip(&want) {
        assert!((a - b).abs() <= 1e-4 * max, "{a} against {b}");
    }
    // And so a target entering along y (nobody did in training) is predicted to walk: the
    // prior's y marginal holds mass two and more channels ahead of the start.
    let ahead: f64 = (0..nx)
        .flat_map(|i| (18..ny).map(move |j| (i, j)))
        .map(|(i, j)| got[i * ny + j])
        .sum();
    assert!(ahead > 0.3, "{ahead}");
}

#[test]
fn a_pooled_start_round_trips() {
    let train = enter_and_stand(5, 4.0, 2, 10);
    let m = CbtModel::learn(integer_space(120), pooled(), &train).unwrap();
    let text = serde_json::to_string(&m).unwrap();
    assert!(text.contains("\"start\":\"pooled\""));
    let back: CbtModel = serde_json::from_str(&text).unwrap();
    assert_eq!(back, m);
    assert_eq!(back.stationary_first_step(1), m.stationary_first_step(1));
}
