//! A tracker saved to JSON and loaded back is the same tracker: it compares equal to the
//! original, and both continue bit-identically on the same frames — for every layout and
//! order, with and without self-learning (whose online-learning history is part of the state).

use cbt_tracker::{CbtTracker, Layout, Order, Sequence, TrackError, Tracker};
use serde_json::Value;

use crate::common;
use common::{data, model};

fn round_trip(t: &CbtTracker) -> CbtTracker {
    let json = serde_json::to_string(t).unwrap();
    let back: CbtTracker = serde_json::from_str(&json).unwrap();
    let again = serde_json::to_string(&back).unwrap();
    assert!(again == json, "{}: saved again, the text differs", t.name());
    back
}

#[test]
fn saved_trackers_continue_identically() {
    let (train, test) = data();
    for layout in [Layout::Separable, Layout::SparseJoint, Layout::Stationary] {
        for order in [Order::First, Order::Second] {
            let m = model(&train, layout, order);
            for online in [false, true] {
                let mut t = CbtTracker::new(m.clone());
                if online {
                    t = t.with_self_learning();
                }
                let what = format!("{layout:?} {order:?} online {online}");
                t.reset(test.frames[0].truth.unwrap()).unwrap();
                for f in &test.frames[1..8] {
                    t.step(&f.detections).unwrap();
                }
                let mut u = round_trip(&t);
                assert!(u == t, "{what}: a loaded tracker differs from its original");
                for (k, f) in test.frames[8..].iter().enumerate() {
                    let a = t.step(&f.detections).unwrap();
                    let b = u.step(&f.detections).unwrap();
                    assert_eq!(a, b, "{what}: estimates differ {k} steps after loading");
                    assert!(u == t, "{what}: trackers differ {k} steps after loading");
                }
                // Saved again mid-way (a second generation) still continues identically.
                let mut v = round_trip(&u);
                assert!(v == u, "{what}: second load differs");
                let f = &test.frames[test.frames.len() - 1];
                assert_eq!(
                    u.step(&f.detections).unwrap(),
                    v.step(&f.detections).unwrap()
                );
                assert!(u == v, "{what}");
            }
        }
    }
}

/// A self-learning tracker after a few steps, and its saved JSON.
fn online_saved(layout: Layout) -> (CbtTracker, Value, Sequence) {
    let (train, test) = data();
    let mut t = CbtTracker::new(model(&train, layout, Order::Second)).with_self_learning();
    t.reset(test.frames[0].truth.unwrap()).unwrap();
    for f in &test.frames[1..8] {
        t.step(&f.detections).unwrap();
    }
    let v = serde_json::to_value(&t).unwrap();
    (t, v, test)
}

#[test]
fn files_without_a_learning_history_still_load() {
    // Files written before the history was saved lack the field: they load with an empty
    // history (the next online frame starts a new chain, as loading them always did), and
    // without self-learning they continue exactly as the original.
    let (train, test) = data();
    let mut t = CbtTracker::new(model(&train, Layout::SparseJoint, Order::Second));
    t.reset(test.frames[0].truth.unwrap()).unwrap();
    for f in &test.frames[1..8] {
        t.step(&f.detections).unwrap();
    }
    let mut v = serde_json::to_value(&t).unwrap();
    assert!(v.as_object_mut().unwrap().remove("history").is_some());
    let mut u: CbtTracker = serde_json::from_value(v).unwrap();
    assert!(u == t);
    for f in &test.frames[8..] {
        assert_eq!(
            t.step(&f.detections).unwrap(),
            u.step(&f.detections).unwrap()
        );
    }
    let (_, mut v, _) = online_saved(Layout::SparseJoint);
    assert!(v.as_object_mut().unwrap().remove("history").is_some());
    serde_json::from_value::<CbtTracker>(v).unwrap();
}

#[test]
fn the_learning_history_is_saved_and_validated() {
    for layout in [Layout::Separable, Layout::SparseJoint, Layout::Stationary] {
        let (t, v, test) = online_saved(layout);
        // Both previous frames' states are in the file.
        let h = &v["history"];
        assert_eq!(h["prev"].as_array().unwrap().len(), 1, "{layout:?}");
        assert_eq!(h["prev2"].as_array().unwrap().len(), 1, "{layout:?}");
        // Dropping it changes how the loaded tracker continues: the saved history matters.
        let mut w = v.clone();
        w["history"] = serde_json::json!({});
        let mut a = t.clone();
        let mut b: CbtTracker = serde_json::from_value(w).unwrap();
        assert!(a != b, "{layout:?}");
        let differs = test.frames[8..]
            .iter()
            .any(|f| a.step(&f.detections).unwrap() != b.step(&f.detections).unwrap());
        assert!(differs, "{layout:?}");
        // A state off the grid or not a number is a corrupt file, not a panic later.
        for bad in [
            serde_json::json!([[1e6, 10.0]]),
            serde_json::json!([[-1e6, 10.0]]),
            serde_json::json!([[null, 10.0]]),
        ] {
            let mut w = v.clone();
            w["history"]["prev2"] = bad.clone();
            match serde_json::from_value::<CbtTracker>(w) {
                Err(e) => assert!(
                    e.to_string().contains("history") || bad[0][0].is_null(),
                    "{layout:?}: {e}"
                ),
                Ok(_) => panic!("{layout:?}: history {bad} accepted"),
            }
        }
        // The typed error, through `TrackError`.
        let mut w = v.clone();
        w["history"]["prev"] = serde_json::json!([[1e6, 10.0]]);
        let e = serde_json::from_value::<CbtTracker>(w)
            .unwrap_err()
            .to_string();
        let want = TrackError::Corrupt(String::new()).to_string();
        assert!(e.starts_with(want.trim_end()), "{e} / {want}");
    }
}

#[test]
fn manual_online_learning_chains_across_a_save_at_every_point() {
    // Frames with two states, none, one: the history keeps an empty last frame and drops
    // the one before it, and a save at any point continues as the original.
    let (train, test) = data();
    for layout in [Layout::Separable, Layout::SparseJoint, Layout::Stationary] {
        let m = model(&train, layout, Order::Second);
        let states: Vec<Vec<[f64; 2]>> = (0..12)
            .map(|k| match k % 4 {
                0 => vec![[20.0 + k as f64, 30.0], [60.0, 20.0 + k as f64]],
                1 => vec![],
                _ => vec![[24.0 + 2.0 * k as f64, 33.0]],
            })
            .collect();
        for cut in 0..states.len() {
            let mut t = CbtTracker::new(m.clone());
            for (s, f) in states[..cut].iter().zip(&test.frames) {
                t.learn_online(s, &f.detections).unwrap();
            }
            let mut u = round_trip(&t);
            assert!(u == t, "{layout:?} cut {cut}");
            for (s, f) in states[cut..].iter().zip(&test.frames[cut..]) {
                t.learn_online(s, &f.detections).unwrap();
                u.learn_online(s, &f.detections).unwrap();
            }
            assert!(u == t, "{layout:?} cut {cut}");
            assert_eq!(u.model().stats(), t.model().stats());
        }
    }
}
