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
    let cfg = CbtConfig {
        start: StartMotion::Learned,
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
