//! Deserialised models and trackers are validated as a whole: mismatched layouts, truncated
//! vectors, negative or non-finite numbers and sizes that do not fit the space are errors,
//! never panics in the filter; a round trip still works; and no single mutation of a saved
//! tracker makes a later step panic.

use cbt_tracker::{
    CbtConfig, CbtModel, CbtTracker, Detection, KalmanParams, KalmanTracker, Layout, Order,
    ParticleFilter, PfModel, Space, Tracker,
};
use serde_json::Value;

use crate::common;
use common::{H, W, data, stationary_spacing};

fn model(layout: Layout, order: Order, spacing: f64) -> CbtModel {
    let (train, _) = data();
    let space = Space::image(W, H, spacing).unwrap();
    let cfg = CbtConfig {
        layout,
        order,
        ..CbtConfig::default()
    };
    CbtModel::learn_sequences(space, cfg, &train).unwrap()
}

fn stationary() -> CbtModel {
    let (train, _) = data();
    let spacing = stationary_spacing(&train);
    model(Layout::Stationary, Order::Second, spacing)
}

/// A tracker run for a few frames.
fn tracker(m: CbtModel) -> CbtTracker {
    let (_, test) = data();
    let mut t = CbtTracker::new(m);
    t.reset(test.frames[0].truth.unwrap()).unwrap();
    for f in &test.frames[1..6] {
        t.step(&f.detections).unwrap();
    }
    t
}

fn to_value<T: serde::Serialize>(t: &T) -> Value {
    serde_json::to_value(t).unwrap()
}

/// Loads `v` as `T`, expecting the crate's consistency error (not a JSON syntax error).
fn corrupt<T: serde::de::DeserializeOwned>(v: &Value) -> String {
    match serde_json::from_value::<T>(v.clone()) {
        Ok(_) => panic!("a corrupted value loaded: {v:.200}"),
        Err(e) => e.to_string(),
    }
}

fn pointer<'a>(v: &'a mut Value, p: &str) -> &'a mut Value {
    v.pointer_mut(p)
        .unwrap_or_else(|| panic!("no {p} in the JSON"))
}

#[test]
fn round_trips_still_load_and_continue_identically() {
    let (_, test) = data();
    for m in [
        stationary(),
        model(Layout::Separable, Order::Second, 8.0),
        model(Layout::SparseJoint, Order::First, 8.0),
    ] {
        let back: CbtModel = serde_json::from_str(&serde_json::to_string(&m).unwrap()).unwrap();
        assert_eq!(back.config(), m.config());
        assert_eq!(back.stats(), m.stats());
        let mut t = tracker(m);
        let mut u: CbtTracker = serde_json::from_str(&serde_json::to_string(&t).unwrap()).unwrap();
        for f in &test.frames[6..] {
            let (a, b) = (
                t.step(&f.detections).unwrap(),
                u.step(&f.detections).unwrap(),
            );
            for d in 0..2 {
                assert!((a.position[d] - b.position[d]).abs() < 1e-9);
            }
        }
    }
}

#[test]
fn mismatched_layouts_are_errors() {
    let stat = to_value(&stationary());
    let sep = to_value(&model(Layout::Separable, Order::Second, 8.0));
    let joint = to_value(&model(Layout::SparseJoint, Order::Second, 8.0));
    // An observation model of one layout with a system model of another.
    for (a, b) in [
        (&stat, &sep),
        (&sep, &joint),
        (&joint, &stat),
        (&stat, &joint),
    ] {
        let mut v = a.clone();
        v["obs"] = b["obs"].clone();
        let e = corrupt::<CbtModel>(&v);
        assert!(e.contains("corrupt") || e.contains("mismatch"), "{e}");
        let mut v = a.clone();
        v["sys"] = b["sys"].clone();
        corrupt::<CbtModel>(&v);
    }
    // Both models of one layout, the configuration of another.
    for (m, other) in [
        (&stat, "separable"),
        (&sep, "stationary"),
        (&joint, "separable"),
    ] {
        let mut v = m.clone();
        v["config"]["layout"] = Value::from(other);
        assert!(corrupt::<CbtModel>(&v).contains("layout"));
    }
    // Second-order tensors with a first-order configuration (and the reverse).
    let mut v = sep.clone();
    v["config"]["order"] = Value::from("first");
    assert!(corrupt::<CbtModel>(&v).contains("order"));
    // In a tracker, too.
    let mut t = to_value(&tracker(stationary()));
    t["model"]["obs"] = sep["obs"].clone();
    corrupt::<CbtTracker>(&t);
}

#[test]
fn truncated_vectors_are_errors() {
    let stat = to_value(&stationary());
    let sep = to_value(&model(Layout::Separable, Order::Second, 8.0));
    let joint = to_value(&model(Layout::SparseJoint, Order::Second, 8.0));
    let cases = [
        (&stat, "/obs/Stationary/kernel"),
        (&stat, "/obs/Stationary/flipped"),
        (&stat, "/obs/Stationary/counts"),
        (&stat, "/obs/Stationary/exposure"),
        (&stat, "/sys/Stationary/0/t"),
        (&stat, "/sys/Stationary/1/s1"),
        (&stat, "/sys/Stationary"),
        (&sep, "/obs/Separable/0/model"),
        (&sep, "/obs/Separable/1/background/zsum"),
        (&sep, "/sys/Separable/first/1/model"),
        (&sep, "/sys/Separable/second/0/model"),
        (&sep, "/sys/Separable/second/0/band"),
        (&sep, "/sys/Separable/second"),
        (&joint, "/obs/Joint/inv"),
        (&joint, "/obs/Joint/rows"),
        (&joint, "/sys/Joint/first"),
    ];
    for (m, p) in cases {
        let mut v = m.clone();
        let a = pointer(&mut v, p).as_array_mut().unwrap();
        assert!(!a.is_empty(), "{p}");
        a.pop();
        let e = corrupt::<CbtModel>(&v);
        assert!(e.contains("corrupt"), "{p}: {e}");
    }
    // Tracker state: the stationary window and the separable posterior.
    let mut t = to_value(&tracker(stationary()));
    pointer(&mut t, "/win/post/v").as_array_mut().unwrap().pop();
    assert!(corrupt::<CbtTracker>(&t).contains("posterior window"));
    let mut t = to_value(&tracker(model(Layout::Separable, Order::Second, 8.0)));
    pointer(&mut t, "/post").as_array_mut().unwrap().pop();
    assert!(corrupt::<CbtTracker>(&t).contains("posterior"));
}

/// A stationary tracker's carried velocity distribution is empty (unknown) or one entry per
/// velocity of its axis's system model, with mass: one entry more or fewer, or all zeros, used
/// to load and be taken silently as unknown (the first order's prediction).
#[test]
fn carried_velocities_of_another_length_or_without_mass_are_errors() {
    let t = to_value(&tracker(stationary()));
    for d in 0..2 {
        let at = format!("/win/vel/{d}");
        let n = pointer(&mut t.clone(), &at).as_array().unwrap().len();
        assert!(n > 1, "axis {d}: the run carries a velocity");
        let mut shorter = t.clone();
        pointer(&mut shorter, &at).as_array_mut().unwrap().pop();
        let mut longer = t.clone();
        pointer(&mut longer, &at)
            .as_array_mut()
            .unwrap()
            .push(0.0.into());
        for bad in [shorter, longer] {
            let e = corrupt::<CbtTracker>(&bad);
            assert!(e.contains("velocity distribution has"), "axis {d}: {e}");
        }
        let mut zeros = t.clone();
        for v in pointer(&mut zeros, &at).as_array_mut().unwrap() {
            *v = 0.0.into();
        }
        let e = corrupt::<CbtTracker>(&zeros);
        assert!(e.contains("no mass"), "axis {d}: {e}");
        // Unknown (empty) is what a start leaves: it loads.
        let mut unknown = t.clone();
        pointer(&mut unknown, &at).as_array_mut().unwrap().clear();
        serde_json::from_value::<CbtTracker>(unknown).unwrap();
    }
}

#[test]
fn negative_and_non_finite_numbers_are_errors() {
    let stat = to_value(&stationary());
    let sep = to_value(&model(Layout::Separable, Order::Second, 8.0));
    for (m, p) in [
        (&stat, "/obs/Stationary/kernel/0"),
        (&stat, "/obs/Stationary/p_detect"),
        (&stat, "/obs/Stationary/floor"),
        (&stat, "/sys/Stationary/0/t/3"),
        (&sep, "/obs/Separable/0/model/5"),
        (&sep, "/sys/Separable/second/1/model/7"),
    ] {
        let mut v = m.clone();
        *pointer(&mut v, p) = Value::from(-0.5);
        assert!(corrupt::<CbtModel>(&v).contains("corrupt"), "{p}");
        // JSON has no NaN: a hand-written `NaN`, or the `null` serde_json writes for one,
        // does not load either.
        *pointer(&mut v, p) = Value::Null;
        corrupt::<CbtModel>(&v);
        let text = serde_json::to_string(&v).unwrap().replace("null", "NaN");
        assert!(serde_json::from_str::<CbtModel>(&text).is_err());
    }
    let mut v = stat.clone();
    *pointer(&mut v, "/obs/Stationary/p_detect") = Value::from(1.5);
    assert!(corrupt::<CbtModel>(&v).contains("probability"));
    // An invalid configuration.
    let mut v = stat.clone();
    v["config"]["mixing"] = Value::from(-1.0);
    assert!(corrupt::<CbtModel>(&v).contains("mixing"));
    // The baselines.
    let pf = ungm_filter();
    let mut v = to_value(&pf);
    v["weights"][3] = Value::from(-1.0);
    assert!(corrupt::<ParticleFilter>(&v).contains("weights"));
    let mut v = to_value(&pf);
    v["weights"].as_array_mut().unwrap().pop();
    assert!(corrupt::<ParticleFilter>(&v).contains("weights"));
    // Weights that do not sum to 1 (all zero gave a step without detections the estimate
    // (0, 0)).
    for w in [0.0, 0.5] {
        let mut v = to_value(&pf);
        for x in v["weights"].as_array_mut().unwrap() {
            *x = Value::from(w);
        }
        assert!(corrupt::<ParticleFilter>(&v).contains("sum to"));
    }
    let mut v = to_value(&pf);
    v["particles"] = Value::Array(Vec::new());
    assert!(corrupt::<ParticleFilter>(&v).contains("particles"));
    let mut v = to_value(&pf);
    v["model"]["ungm"]["meas_var"] = Value::from(0.0);
    assert!(corrupt::<ParticleFilter>(&v).contains("meas_var"));
    let kf = KalmanTracker::new(KalmanParams {
        accel_sigma: 1.0,
        meas_sigma: 2.0,
        init_vel_sigma: 3.0,
        gate: 9.21,
    })
    .unwrap();
    let mut v = to_value(&kf);
    v["params"]["meas_sigma"] = Value::from(-2.0);
    assert!(corrupt::<KalmanTracker>(&v).contains("meas_sigma"));
    // A negative variance, which `set_state` refuses, used to be accepted on reading.
    let mut v = to_value(&kf);
    v["p"][5] = Value::from(-4.0);
    assert!(corrupt::<KalmanTracker>(&v).contains("covariance diagonal"));
}

#[test]
fn wrong_sizes_against_the_space_are_errors() {
    // Every part of a model sized for another grid than its space.
    let coarse = to_value(&model(Layout::Separable, Order::Second, 8.0));
    let fine = to_value(&model(Layout::Separable, Order::Second, 6.0));
    let mut v = coarse.clone();
    v["space"] = fine["space"].clone();
    assert!(corrupt::<CbtModel>(&v).contains("corrupt"));
    let stat = stationary();
    let mut v = to_value(&stat);
    v["space"] =
        to_value(&Space::image(W + 40.0, H, stat.space().state_basis(0).spacing()).unwrap());
    assert!(corrupt::<CbtModel>(&v).contains("corrupt"));
    // A window off the grid, a kernel radius beyond the kernel.
    let mut t = to_value(&tracker(stat.clone()));
    t["win"]["post"]["i0"] = Value::from(10_000);
    assert!(corrupt::<CbtTracker>(&t).contains("window"));
    let mut v = to_value(&stat);
    v["obs"]["Stationary"]["ra"] = Value::from(50);
    assert!(corrupt::<CbtModel>(&v).contains("corrupt"));
}

/// Every leaf of a JSON tree with its pointer.
fn leaves(v: &Value, path: String, out: &mut Vec<String>) {
    match v {
        Value::Array(a) => {
            out.push(path.clone());
            for (i, x) in a.iter().enumerate() {
                leaves(x, format!("{path}/{i}"), out);
            }
        }
        Value::Object(o) => {
            for (k, x) in o {
                leaves(x, format!("{path}/{k}"), out);
            }
        }
        _ => out.push(path),
    }
}

#[test]
fn no_single_mutation_of_a_saved_tracker_panics_later() {
    let (_, test) = data();
    let frames: Vec<Vec<Detection>> = test.frames[6..12]
        .iter()
        .map(|f| f.detections.clone())
        .collect();
    for t in [
        tracker(stationary()),
        tracker(model(Layout::Separable, Order::Second, 12.0)),
    ] {
        let v = to_value(&t);
        let mut paths = Vec::new();
        leaves(&v, String::new(), &mut paths);
        // A deterministic sample of the leaves (every one for small trees).
        let step = (paths.len() / 600).max(1);
        let mut loaded = 0;
        for p in paths.iter().step_by(step) {
            let muts: [fn(&mut Value); 5] = [
                |x| *x = Value::from(-1.0),
                |x| *x = Value::from(0),
                |x| *x = Value::from(3),
                |x| *x = Value::from(1e12),
                |x| {
                    if let Value::Array(a) = x {
                        a.pop();
                    }
                },
            ];
            for m in &muts {
                let mut w = v.clone();
                m(pointer(&mut w, p));
                if let Ok(mut u) = serde_json::from_value::<CbtTracker>(w) {
                    loaded += 1;
                    // Loaded: a consistent tracker, whatever its numbers; it must run.
                    let _ = u.estimate();
                    let _ = u.predict();
                    for f in &frames {
                        let _ = u.step(f);
                    }
                    let _ = u.learn_online(&[[10.0, 10.0]], &frames[0]);
                }
            }
        }
        assert!(loaded > 0);
    }
}

/// A stationary tracker after a few steps with the velocity per position (it carries a
/// velocity per row and column of its window).
fn per_position_tracker() -> CbtTracker {
    let (train, _) = data();
    let space = Space::image(W, H, stationary_spacing(&train)).unwrap();
    let cfg = CbtConfig {
        velocity: cbt_tracker::Velocity::PerPosition,
        ..CbtConfig::stationary()
    };
    tracker(CbtModel::learn_sequences(space, cfg, &train).unwrap())
}

/// Audit: the window's consistency check added and multiplied the saved sizes and origins as
/// they were, so `u64::MAX` in one of them panicked with "attempt to add with overflow" (a
/// release build wrapped and could accept the window); so did the observation kernel's radius
/// (`radius + RING`) and a per-position velocity's width (`cells · width`). A per-position
/// velocity whose width is not its axis's `2r + 1` used to load and be taken silently as
/// unknown. All are now `Corrupt` errors.
#[test]
fn huge_sizes_and_origins_in_a_saved_window_are_errors() {
    let t = to_value(&tracker(stationary()));
    for p in [
        "/win/post/i0",
        "/win/post/j0",
        "/win/post/h",
        "/win/post/w",
        "/win/prev/0/0",
        "/win/prev/1/0",
        "/win/cur/0/0",
        "/model/obs/Stationary/radius",
        "/model/obs/Stationary/ra",
    ] {
        for big in [u64::MAX, 1 << 63, 1 << 32] {
            let mut v = t.clone();
            *pointer(&mut v, p) = Value::from(big);
            let e = corrupt::<CbtTracker>(&v);
            assert!(e.contains("corrupt"), "{p} = {big}: {e}");
        }
    }
    let t = to_value(&per_position_tracker());
    for d in 0..2 {
        let at = format!("/win/coupled/axes/{d}");
        let cells = pointer(&mut t.clone(), &format!("{at}/cells"))
            .as_u64()
            .unwrap();
        let width = pointer(&mut t.clone(), &format!("{at}/width"))
            .as_u64()
            .unwrap();
        assert!(cells > 0 && width > 3, "axis {d} carries velocities");
        for big in [u64::MAX, 1 << 63] {
            let mut v = t.clone();
            *pointer(&mut v, &format!("{at}/width")) = Value::from(big);
            let e = corrupt::<CbtTracker>(&v);
            assert!(e.contains("velocities"), "axis {d}, width {big}: {e}");
        }
        // Three velocities per cell, consistent with the window but not with `T`.
        let mut v = t.clone();
        *pointer(&mut v, &format!("{at}/width")) = Value::from(3);
        *pointer(&mut v, &format!("{at}/v")) = Value::from(vec![1.0 / 3.0; 3 * cells as usize]);
        let e = corrupt::<CbtTracker>(&v);
        assert!(e.contains("velocities"), "axis {d}: {e}");
        // One cell's distribution all zeros (every step leaves each with mass 1): its kernel
        // was zeros, and the prediction silently dropped that row's or column's mass.
        let mut v = t.clone();
        for x in pointer(&mut v, &format!("{at}/v"))
            .as_array_mut()
            .unwrap()
            .iter_mut()
            .take(width as usize)
        {
            *x = Value::from(0.0);
        }
        let e = corrupt::<CbtTracker>(&v);
        assert!(e.contains("no mass"), "axis {d}: {e}");
    }
}

/// Audit: a particle filter read back with a step count of `u64::MAX` panicked in its next
/// step ("attempt to add with overflow"); that step is now refused and changes nothing. A
/// generator state of all zeros (which xoshiro never reaches: it draws 0 forever) loaded and
/// hung the next `reset` or `step` in the normal sampler; it is now `Corrupt`.
#[test]
fn a_particle_filter_at_its_last_step_or_with_a_dead_generator_is_refused() {
    let pf = ungm_filter();
    let mut v = to_value(&pf);
    v["k"] = Value::from(u64::MAX);
    let mut last: ParticleFilter = serde_json::from_value(v).unwrap();
    let before = last.clone();
    let r = last.step(&[Detection::new(3.0, 0.0)]);
    assert!(
        matches!(
            r,
            Err(cbt_tracker::TrackError::InvalidParameter { name: "k", .. })
        ),
        "{r:?}"
    );
    assert!(last == before);
    // A reset restarts the count.
    last.reset([0.0, 0.0]).unwrap();
    last.step(&[Detection::new(3.0, 0.0)]).unwrap();
    let mut v = to_value(&pf);
    v["rng"]["s"] = Value::from(vec![0u64; 4]);
    let e = corrupt::<ParticleFilter>(&v);
    assert!(e.contains("generator"), "{e}");
    // Any other state loads and continues as the original.
    let mut back: ParticleFilter = serde_json::from_value(to_value(&pf)).unwrap();
    let mut orig = pf.clone();
    assert_eq!(
        back.step(&[Detection::new(3.0, 0.0)]).unwrap(),
        orig.step(&[Detection::new(3.0, 0.0)]).unwrap()
    );
    assert!(back == orig);
}

/// Audit: a saved posterior was checked for its size and signs only, so one scaled by 10
/// loaded and reported ten times its certainty (window mass), one of zeros the centre of cell 0
/// with certainty 0; and the separable layout predicts from the saved marginals, which were
/// never compared with the posterior they belong to. Every step, start and reset leaves
/// posteriors summing to 1 and the marginals theirs: anything else is `Corrupt`.
#[test]
fn saved_posteriors_must_be_distributions_with_their_own_marginals() {
    let scaled = |v: &Value, p: &str, k: f64| {
        let mut v = v.clone();
        for x in pointer(&mut v, p).as_array_mut().unwrap() {
            *x = Value::from(x.as_f64().unwrap() * k);
        }
        v
    };
    let sep = to_value(&tracker(model(Layout::Separable, Order::Second, 8.0)));
    let stat = to_value(&tracker(stationary()));
    for (t, p) in [(&sep, "/post"), (&sep, "/prev"), (&stat, "/win/post/v")] {
        for k in [10.0, 0.5, 0.0] {
            let e = corrupt::<CbtTracker>(&scaled(t, p, k));
            assert!(
                e.contains("sums to") || e.contains("no mass"),
                "{p} × {k}: {e}"
            );
        }
        // Rounding is not an error.
        serde_json::from_value::<CbtTracker>(scaled(t, p, 1.0 + 1e-12)).unwrap();
    }
    for p in ["/marg/0", "/marg/1", "/marg_prev/0", "/marg_prev/1"] {
        let mut v = sep.clone();
        let m = pointer(&mut v, p).as_array_mut().unwrap();
        let at = |m: &Vec<Value>, f: fn(f64, f64) -> bool| {
            (0..m.len())
                .reduce(|a, b| {
                    if f(m[b].as_f64().unwrap(), m[a].as_f64().unwrap()) {
                        b
                    } else {
                        a
                    }
                })
                .unwrap()
        };
        let (hi, lo) = (at(m, |a, b| a > b), at(m, |a, b| a < b));
        m.swap(hi, lo);
        let e = corrupt::<CbtTracker>(&v);
        assert!(e.contains("not the marginals"), "{p}: {e}");
    }
}

/// A 20-particle filter of the UNGM model, seed 1.
fn ungm_filter() -> ParticleFilter {
    ParticleFilter::new(
        PfModel::Ungm {
            process_var: 10.0,
            meas_var: 1.0,
            init_sigma: 2.0,
        },
        20,
        1,
    )
    .unwrap()
}
