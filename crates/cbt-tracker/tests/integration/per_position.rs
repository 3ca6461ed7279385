//! The velocity coupled to position (`Velocity::PerPosition`) through the tracker: it
//! tracks, it changes the result, it is saved with the tracker and validated on loading, and
//! only the stationary layout takes it.

use cbt_tracker::{CbtConfig, CbtModel, CbtTracker, Layout, Space, TrackError, Tracker, Velocity};
use serde_json::Value;

use crate::common;
use common::{H, W, data, stationary_spacing};

fn model(velocity: Velocity) -> CbtModel {
    let (train, _) = data();
    let s = stationary_spacing(&train);
    let cfg = CbtConfig {
        velocity,
        ..CbtConfig::stationary()
    };
    CbtModel::learn_sequences(Space::image(W, H, s).unwrap(), cfg, &train).unwrap()
}

/// The estimates of a tracker started at the first truth, on frames `1..n`.
fn run(t: &mut CbtTracker, n: usize) -> Vec<[f64; 2]> {
    let (_, test) = data();
    t.reset(test.frames[0].truth.unwrap()).unwrap();
    test.frames[1..n]
        .iter()
        .map(|f| t.step(&f.detections).unwrap().position)
        .collect()
}

#[test]
fn tracks_and_differs_from_the_factored_state() {
    let (_, test) = data();
    let coupled = run(&mut CbtTracker::new(model(Velocity::PerPosition)), 30);
    let factored = run(&mut CbtTracker::new(model(Velocity::Factored)), 30);
    assert_ne!(coupled, factored, "the option has no effect");
    // It follows the target: mean error well inside the image.
    let err: f64 = coupled
        .iter()
        .zip(&test.frames[1..])
        .map(|(e, f)| {
            let t = f.truth.unwrap();
            ((e[0] - t[0]).powi(2) + (e[1] - t[1]).powi(2)).sqrt()
        })
        .sum::<f64>()
        / coupled.len() as f64;
    assert!(err < 10.0, "mean error {err} px");
}

#[test]
fn a_saved_tracker_holds_its_velocities_and_continues_identically() {
    let (_, test) = data();
    let mut t = CbtTracker::new(model(Velocity::PerPosition));
    run(&mut t, 10);
    let json = serde_json::to_string(&t).unwrap();
    assert!(
        json.contains("\"coupled\""),
        "the per-position velocities are not saved"
    );
    let mut u: CbtTracker = serde_json::from_str(&json).unwrap();
    assert!(u == t);
    for f in &test.frames[10..] {
        assert_eq!(
            t.step(&f.detections).unwrap(),
            u.step(&f.detections).unwrap()
        );
    }
    // A factored tracker writes no such field (its files are as before the option).
    let mut f = CbtTracker::new(model(Velocity::Factored));
    run(&mut f, 10);
    assert!(!serde_json::to_string(&f).unwrap().contains("\"coupled\""));
    // The option is written in snake_case like every other; files written when it was
    // spelled as the variant still read, as the same tracker.
    assert!(json.contains("\"velocity\":\"per_position\""));
    let old = json.replace(
        "\"velocity\":\"per_position\"",
        "\"velocity\":\"PerPosition\"",
    );
    assert_ne!(old, json);
    let v: CbtTracker = serde_json::from_str(&old).unwrap();
    assert!(v == serde_json::from_str::<CbtTracker>(&json).unwrap());
    assert_eq!(
        serde_json::from_str::<Velocity>("\"Factored\"").unwrap(),
        Velocity::Factored
    );
}

#[test]
fn velocities_that_do_not_fit_the_window_are_corrupt() {
    let mut t = CbtTracker::new(model(Velocity::PerPosition));
    run(&mut t, 10);
    let mut v: Value = serde_json::to_value(&t).unwrap();
    let mut edited = 0;
    fn edit(v: &mut Value, n: &mut usize) {
        match v {
            Value::Object(m) => {
                if let Some(c) = m.get_mut("coupled") {
                    c["axes"][0]["v"].as_array_mut().unwrap().pop();
                    *n += 1;
                }
                m.values_mut().for_each(|x| edit(x, n));
            }
            Value::Array(a) => a.iter_mut().for_each(|x| edit(x, n)),
            _ => {}
        }
    }
    edit(&mut v, &mut edited);
    assert_eq!(edited, 1);
    let err = serde_json::from_value::<CbtTracker>(v)
        .unwrap_err()
        .to_string();
    assert!(err.contains("per-position velocities"), "{err}");
}

/// The current marginals saved with the window are the posterior's: ones of another length
/// or origin are corrupt. (They used to load, and the next step's per-position prediction
/// panicked slicing them: "range end index 11 out of range for slice of length 0".)
#[test]
fn current_marginals_that_do_not_fit_the_window_are_corrupt() {
    let (_, test) = data();
    let mut t = CbtTracker::new(model(Velocity::PerPosition));
    run(&mut t, 10);
    let v: Value = serde_json::to_value(&t).unwrap();
    for d in 0..2 {
        let cur = format!("/win/cur/{d}");
        let mut edits: Vec<Value> = Vec::new();
        let mut shorter = v.clone();
        shorter
            .pointer_mut(&format!("{cur}/1"))
            .unwrap()
            .as_array_mut()
            .unwrap()
            .pop();
        edits.push(shorter);
        let mut longer = v.clone();
        longer
            .pointer_mut(&format!("{cur}/1"))
            .unwrap()
            .as_array_mut()
            .unwrap()
            .push(0.0.into());
        edits.push(longer);
        let mut shifted = v.clone();
        let origin = shifted.pointer_mut(&format!("{cur}/0")).unwrap();
        *origin = (origin.as_u64().unwrap() + 1).into();
        edits.push(shifted);
        for w in edits {
            let err = match serde_json::from_value::<CbtTracker>(w) {
                Ok(mut u) => {
                    let e = test.frames[10..13]
                        .iter()
                        .map(|f| u.step(&f.detections).map(|e| e.position))
                        .collect::<Vec<_>>();
                    panic!("axis {d}: loaded, then stepped to {e:?}");
                }
                Err(e) => e.to_string(),
            };
            assert!(err.contains("current marginal"), "{err}");
        }
    }
    // Unedited, it loads and continues as the original.
    let mut u: CbtTracker = serde_json::from_value(v).unwrap();
    for f in &test.frames[10..] {
        assert_eq!(
            t.step(&f.detections).unwrap(),
            u.step(&f.detections).unwrap()
        );
    }
}

#[test]
fn only_the_stationary_layout_takes_it() {
    let cfg = CbtConfig {
        velocity: Velocity::PerPosition,
        layout: Layout::Separable,
        ..CbtConfig::default()
    };
    assert!(matches!(
        cfg.validate(),
        Err(TrackError::InvalidParameter {
            name: "velocity",
            ..
        })
    ));
}
