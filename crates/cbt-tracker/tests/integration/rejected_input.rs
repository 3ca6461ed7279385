//! A rejected input changes no state, for every public call that can refuse its input and has
//! something to change: `CbtTracker`'s `step`, `filter`, `reset`, `reset_to` and
//! `learn_online` (every layout and order, the velocity per position, a periodic input's time
//! index, self-learning, an online-learning history that is not empty), and the baselines'
//! `reset` (Kalman, particle filter in 2-D and 1-D, learned particle filter; their refused
//! steps are in `errors.rs` and `input.rs`).
//!
//! Each refused call is checked three ways: the tracker compares equal to a copy taken before
//! it (`PartialEq`: model counts, posterior, history, time, RNG), its saved JSON is the same,
//! and after every bad call it continues bit-identically with a twin that never saw them (which
//! also catches state neither compared nor saved).

use cbt_tracker::{
    Calibration, CbtConfig, CbtModel, CbtTracker, Detection, KalmanParams, KalmanTracker, Layout,
    LearnedParticleFilter, Order, ParticleFilter, PeriodicInput, PfModel, Point, Sequence, Space,
    TrackError, Tracker, Velocity,
};

use crate::common;
use common::{H, W, data, model, stationary_spacing};

/// One model per kind of tracker state: every layout and order, the velocity per position,
/// and a periodic input (whose time index is part of the state).
fn models(train: &[Sequence]) -> Vec<(String, CbtModel)> {
    let mut out = Vec::new();
    for layout in [Layout::Separable, Layout::SparseJoint, Layout::Stationary] {
        for order in [Order::First, Order::Second] {
            out.push((format!("{layout:?} {order:?}"), model(train, layout, order)));
        }
    }
    let learn = |cfg, spacing| {
        CbtModel::learn_sequences(Space::image(W, H, spacing).unwrap(), cfg, train).unwrap()
    };
    out.push((
        "Stationary per-position velocity".into(),
        learn(
            CbtConfig {
                velocity: Velocity::PerPosition,
                ..CbtConfig::stationary()
            },
            stationary_spacing(train),
        ),
    ));
    out.push((
        "Separable First periodic input".into(),
        learn(
            CbtConfig {
                order: Order::First,
                input: Some(PeriodicInput {
                    omega: 1.2,
                    channels: 12,
                }),
                ..CbtConfig::default()
            },
            8.0,
        ),
    ));
    out
}

/// A call that must be refused: its name, and the call on the tracker.
type BadCall = (
    &'static str,
    Box<dyn Fn(&mut CbtTracker) -> Result<(), TrackError>>,
);

/// Every bad input of every refusing call, given a valid state `good` and valid detections.
fn bad_calls(good: Point, dets: Vec<Detection>) -> Vec<BadCall> {
    let nan = Detection::new(f64::NAN, 10.0);
    let inf_y = Detection::new(10.0, f64::INFINITY);
    let negative = Detection {
        pos: [20.0, 20.0],
        weight: -1.0,
    };
    let nan_weight = Detection {
        pos: [20.0, 20.0],
        weight: f64::NAN,
    };
    let off = Detection::new(5000.0, 10.0);
    let (o1, o2) = (dets.clone(), dets.clone());
    let with = move |bad: Detection| {
        let mut v = dets.clone();
        // The bad one last: every good detection before it has been looked at.
        v.push(bad);
        v
    };
    let (d_nan, d_inf, d_neg, d_nanw, d_off) = (
        with(nan),
        with(inf_y),
        with(negative),
        with(nan_weight),
        with(off),
    );
    let (l_nan, l_off, l_neg) = (d_nan.clone(), d_off.clone(), d_neg.clone());
    let (f_nan, f_off) = (d_nan.clone(), d_off.clone());
    let calls: Vec<BadCall> = vec![
        (
            "step NaN detection",
            Box::new(move |t| t.step(&d_nan).map(drop)),
        ),
        (
            "step infinite y",
            Box::new(move |t| t.step(&d_inf).map(drop)),
        ),
        (
            "step negative weight",
            Box::new(move |t| t.step(&d_neg).map(drop)),
        ),
        (
            "step NaN weight",
            Box::new(move |t| t.step(&d_nanw).map(drop)),
        ),
        (
            "step off the grid",
            Box::new(move |t| t.step(&d_off).map(drop)),
        ),
        ("filter NaN detection", Box::new(move |t| t.filter(&f_nan))),
        ("filter off the grid", Box::new(move |t| t.filter(&f_off))),
        ("reset NaN", Box::new(|t| t.reset([f64::NAN, 10.0]))),
        (
            "reset infinite y",
            Box::new(|t| t.reset([10.0, f64::INFINITY])),
        ),
        ("reset off the grid", Box::new(|t| t.reset([10.0, 1e6]))),
        (
            "reset_to short",
            Box::new(|t| {
                let g = t.model().space().cells();
                t.reset_to(&vec![1.0; g - 1])
            }),
        ),
        (
            "reset_to NaN",
            Box::new(|t| {
                let mut d = vec![1.0; t.model().space().cells()];
                let last = d.len() - 1;
                d[last] = f64::NAN;
                t.reset_to(&d)
            }),
        ),
        (
            "reset_to negative",
            Box::new(|t| {
                let mut d = vec![1.0; t.model().space().cells()];
                let last = d.len() - 1;
                d[last] = -1e-9;
                t.reset_to(&d)
            }),
        ),
        (
            "reset_to no mass",
            Box::new(|t| t.reset_to(&vec![0.0; t.model().space().cells()])),
        ),
        (
            "learn_online state off the grid",
            Box::new(move |t| t.learn_online(&[good, [10.0, 1e6]], &o1)),
        ),
        (
            "learn_online NaN state",
            Box::new(move |t| t.learn_online(&[good, [f64::NAN, 10.0]], &o2)),
        ),
        (
            "learn_online NaN detection",
            Box::new(move |t| t.learn_online(&[good], &l_nan)),
        ),
        (
            "learn_online detection off the grid",
            Box::new(move |t| t.learn_online(&[good], &l_off)),
        ),
        (
            "learn_online negative weight",
            Box::new(move |t| t.learn_online(&[good], &l_neg)),
        ),
    ];
    calls
}

/// Every refused call on a `CbtTracker` leaves it exactly as it was: equal, saved the same,
/// and continuing (steps and online learning) bit-identically with a twin that never saw
/// them. For every layout and order, the velocity per position, a periodic input, with and
/// without self-learning, and with an online-learning history of two frames.
#[test]
fn a_refused_call_leaves_a_cbt_tracker_unchanged() {
    let (train, test) = data();
    for (what, model) in models(&train) {
        for online in [false, true] {
            let what = format!("{what}, self-learning {online}");
            let mut t = CbtTracker::new(model.clone());
            if online {
                t = t.with_self_learning();
            }
            t.reset(test.frames[0].truth.unwrap()).unwrap();
            for f in &test.frames[1..6] {
                t.step(&f.detections).unwrap();
            }
            // A history of two frames (and the models' counts) that a refusal could lose.
            for f in &test.frames[6..8] {
                t.learn_online(&[f.truth.unwrap()], &f.detections).unwrap();
            }
            if model.config().input.is_some() {
                assert!(t.time() > 0, "{what}: the time index is not exercised");
            }
            let twin = t.clone();
            let json = serde_json::to_string(&t).unwrap();
            let f = &test.frames[8];
            for (call, bad) in bad_calls(f.truth.unwrap(), f.detections.clone()) {
                let r = bad(&mut t);
                assert!(r.is_err(), "{what}: {call} was accepted");
                assert!(t == twin, "{what}: {call} changed the tracker");
                assert_eq!(
                    serde_json::to_string(&t).unwrap(),
                    json,
                    "{what}: {call} changed the saved tracker"
                );
            }
            let mut u = twin;
            for (k, f) in test.frames[8..14].iter().enumerate() {
                let a = t.step(&f.detections).unwrap();
                let b = u.step(&f.detections).unwrap();
                assert_eq!(
                    a, b,
                    "{what}: estimates differ {k} steps after the refusals"
                );
                t.learn_online(&[f.truth.unwrap()], &f.detections).unwrap();
                u.learn_online(&[f.truth.unwrap()], &f.detections).unwrap();
                assert!(
                    t == u,
                    "{what}: trackers differ {k} steps after the refusals"
                );
            }
            assert_eq!(
                serde_json::to_string(&t).unwrap(),
                serde_json::to_string(&u).unwrap(),
                "{what}"
            );
        }
    }
}

/// The baselines' refused resets (a non-finite start) change nothing, the particle filters'
/// random state included: each continues bit-identically with a twin that never saw them.
/// (Their refused steps: `errors.rs` and `input.rs`.)
#[test]
fn a_refused_reset_leaves_the_baselines_unchanged() {
    let (train, test) = data();
    let cal = Calibration::estimate(&train, 32.0).unwrap();
    let mut kf = KalmanTracker::new(KalmanParams::from_calibration(&cal)).unwrap();
    let mut pf = ParticleFilter::new(PfModel::from_calibration(&cal, W * H), 200, 7).unwrap();
    let ungm = PfModel::Ungm {
        process_var: 10.0,
        meas_var: 1.0,
        init_sigma: 2.0,
    };
    let mut pf1 = ParticleFilter::new(ungm, 100, 8).unwrap();
    let learned = CbtModel::learn_sequences(
        Space::image(W, H, 8.0).unwrap(),
        CbtConfig {
            order: Order::First,
            ..CbtConfig::default()
        },
        &train,
    )
    .unwrap();
    let mut lpf = LearnedParticleFilter::new(learned, 100, 9).unwrap();
    let start = test.frames[0].truth.unwrap();
    let bad_starts = [
        [f64::NAN, 10.0],
        [10.0, f64::NAN],
        [f64::INFINITY, 10.0],
        [10.0, f64::NEG_INFINITY],
    ];
    let one_d = |dets: &[Detection]| -> Vec<Detection> {
        dets.iter()
            .map(|d| Detection::new(d.pos[0] / 10.0, 0.0))
            .collect()
    };
    kf.reset(start).unwrap();
    pf.reset(start).unwrap();
    pf1.reset([start[0] / 10.0, 0.0]).unwrap();
    lpf.reset(start).unwrap();
    for f in &test.frames[1..6] {
        kf.step(&f.detections).unwrap();
        pf.step(&f.detections).unwrap();
        pf1.step(&one_d(&f.detections)).unwrap();
        lpf.step(&f.detections).unwrap();
    }
    let before = (kf.clone(), pf.clone(), pf1.clone(), lpf.clone());
    for bad in bad_starts {
        assert!(kf.reset(bad).is_err(), "Kalman: reset {bad:?} accepted");
        assert!(pf.reset(bad).is_err(), "PF: reset {bad:?} accepted");
        assert!(
            lpf.reset(bad).is_err(),
            "learned PF: reset {bad:?} accepted"
        );
        // The 1-D filter looks at x only.
        if !bad[0].is_finite() {
            assert!(pf1.reset(bad).is_err(), "PF 1-D: reset {bad:?} accepted");
        }
        assert!(kf == before.0, "Kalman: reset {bad:?} changed it");
        assert!(pf == before.1, "PF: reset {bad:?} changed it");
        assert!(pf1 == before.2, "PF 1-D: reset {bad:?} changed it");
        assert!(lpf == before.3, "learned PF: reset {bad:?} changed it");
    }
    // Off the learned model's grid.
    assert!(matches!(
        lpf.reset([10.0, 1e6]),
        Err(TrackError::OutsideGrid { .. })
    ));
    assert!(lpf == before.3);
    let (mut kf2, mut pf2, mut pf12, mut lpf2) = before;
    for f in &test.frames[6..12] {
        let one = one_d(&f.detections);
        assert_eq!(
            kf.step(&f.detections).unwrap(),
            kf2.step(&f.detections).unwrap()
        );
        assert_eq!(
            pf.step(&f.detections).unwrap(),
            pf2.step(&f.detections).unwrap()
        );
        assert_eq!(pf1.step(&one).unwrap(), pf12.step(&one).unwrap());
        assert_eq!(
            lpf.step(&f.detections).unwrap(),
            lpf2.step(&f.detections).unwrap()
        );
    }
    assert!(kf == kf2 && pf == pf2 && pf1 == pf12 && lpf == lpf2);
}
