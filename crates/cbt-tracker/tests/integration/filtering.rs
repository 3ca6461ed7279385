//! Filtering behaviour: Kalman-optimal sanity bounds, lost-track recovery, empty frames,
//! online learning, the fast decoder against chan-repr's full decoder, serde round trips.

use cbt_tracker::sim::{Level, Scenario, generate, rng_for};
use cbt_tracker::{
    Calibration, CbtConfig, CbtModel, CbtTracker, Detection, Frame, KalmanParams, KalmanTracker,
    Layout, Order, ParticleFilter, PfModel, Scales, Sequence, Space, TrackError, Tracker, metrics,
};
use rand::RngExt;
use rand_distr::{Distribution, StandardNormal};

const W: f64 = 320.0;
const H: f64 = 240.0;
const ACCEL: f64 = 0.1;
const NOISE: f64 = 2.0;

/// Linear-Gaussian data: the Kalman filter's own constant-velocity model (σ_a = 0.1,
/// σ_z = 2 px), `P_D = 1`, no clutter. Sequences leaving the image are redrawn.
fn linear_sequences(count: usize, frames: usize, seed: u64) -> Vec<Sequence> {
    let mut out = Vec::new();
    let mut index = 0;
    while out.len() < count {
        let mut rng = rng_for(seed, index);
        index += 1;
        let n = |r: &mut _| -> f64 { StandardNormal.sample(r) };
        let mut p = [W / 2.0 + 40.0 * n(&mut rng), H / 2.0 + 30.0 * n(&mut rng)];
        let mut v = [0.5 * n(&mut rng), 0.5 * n(&mut rng)];
        let mut fs = Vec::new();
        let mut inside = true;
        for _ in 0..frames {
            for d in 0..2 {
                let a = ACCEL * n(&mut rng);
                p[d] += v[d] + 0.5 * a;
                v[d] += a;
            }
            let z = [p[0] + NOISE * n(&mut rng), p[1] + NOISE * n(&mut rng)];
            inside &= z[0] > 5.0 && z[0] < W - 5.0 && z[1] > 5.0 && z[1] < H - 5.0;
            fs.push(Frame {
                truth: Some(p),
                detections: vec![Detection::new(z[0], z[1])],
            });
        }
        let _ = rng.random::<f64>();
        if inside {
            out.push(Sequence {
                name: format!("linear-{index}"),
                first_frame: 0,
                frames: fs,
            });
        }
    }
    out
}

fn run(t: &mut dyn Tracker, s: &Sequence) -> f64 {
    t.reset(s.frames[0].truth.unwrap()).unwrap();
    let mut est = vec![s.frames[0].truth.unwrap()];
    for f in &s.frames[1..] {
        est.push(t.step(&f.detections).unwrap().position);
    }
    let truths: Vec<_> = s.frames.iter().map(|f| f.truth).collect();
    metrics::score(&est, &truths, 2, 20.0).unwrap().rmse
}

#[test]
fn kalman_optimal_sanity_bounds() {
    let train = linear_sequences(6, 200, 1);
    let test = linear_sequences(4, 150, 2);
    let kp = KalmanParams {
        accel_sigma: ACCEL,
        meas_sigma: NOISE,
        init_vel_sigma: 0.5,
        gate: 1e9,
    };
    let spacing = Scales::estimate(&train, W).unwrap().spacing(H).unwrap();
    let space = Space::image(W, H, spacing).unwrap();
    let model = CbtModel::learn_sequences(space, CbtConfig::default(), &train).unwrap();
    let pf_model = PfModel::ConstantVelocity {
        accel_sigma: ACCEL,
        meas_sigma: NOISE,
        p_detect: 0.999,
        clutter_density: 0.01 / (W * H),
        init_vel_sigma: 0.5,
    };
    let (mut kf, mut cbt, mut pf) = (0.0, 0.0, 0.0);
    for (i, s) in test.iter().enumerate() {
        kf += run(&mut KalmanTracker::new(kp).unwrap(), s);
        cbt += run(&mut CbtTracker::new(model.clone()), s);
        pf += run(
            &mut ParticleFilter::new(pf_model, 10_000, 5 + i as u64).unwrap(),
            s,
        );
    }
    let n = test.len() as f64;
    let (kf, cbt, pf) = (kf / n, cbt / n, pf / n);
    eprintln!("RMSE Kalman {kf:.3}, CBT {cbt:.3}, PF-10000 {pf:.3}");
    // The Kalman filter is optimal here; its RMSE is below the detection noise.
    assert!(kf < NOISE * std::f64::consts::SQRT_2);
    // Stated factors: PF with 10,000 particles within 1.1× of it (measured 1.00), CBT (learned
    // models, a channel spacing of several pixels) within 2× (measured 1.56).
    assert!(pf <= 1.1 * kf, "PF {pf} vs Kalman {kf}");
    assert!(cbt <= 2.0 * kf, "CBT {cbt} vs Kalman {kf}");
}

fn trained(level: usize, cfg: CbtConfig) -> (CbtModel, Vec<Sequence>) {
    let sc = Scenario::default();
    let lv = Level::preset(level);
    let train = generate(&sc, &lv, 3, 300, 21).unwrap();
    let spacing = Scales::estimate(&train, sc.width)
        .unwrap()
        .spacing(sc.height)
        .unwrap();
    let space = Space::image(sc.width, sc.height, spacing).unwrap();
    let test = generate(&sc, &lv, 2, 120, 22).unwrap();
    (CbtModel::learn_sequences(space, cfg, &train).unwrap(), test)
}

#[test]
fn recovers_a_lost_track_by_uniform_mixing() {
    let (model, test) = trained(0, CbtConfig::default());
    let s = &test[0];
    let truth0 = s.frames[0].truth.unwrap();
    // Start 100 px away from the target: the prior there is only the mixing floor.
    let wrong = [(truth0[0] + 100.0) % W, (truth0[1] + 80.0) % H];
    let mut t = CbtTracker::new(model);
    t.reset(wrong).unwrap();
    let mut err = f64::INFINITY;
    for f in &s.frames[1..30] {
        let e = t.step(&f.detections).unwrap();
        let tr = f.truth.unwrap();
        err = (e.position[0] - tr[0]).hypot(e.position[1] - tr[1]);
    }
    assert!(err < 6.0, "still lost after 29 frames: error {err}");
}

#[test]
fn empty_frames_keep_the_prediction() {
    let (model, test) = trained(1, CbtConfig::default());
    let s = &test[0];
    let mut t = CbtTracker::new(model);
    t.reset(s.frames[0].truth.unwrap()).unwrap();
    for f in &s.frames[1..10] {
        t.step(&f.detections).unwrap();
    }
    let prior = t.predict();
    t.step(&[]).unwrap();
    for (a, b) in t.posterior().iter().zip(&prior) {
        assert!((a - b).abs() < 1e-15);
    }
    // Zero-weight detections carry no information either.
    let prior = t.predict();
    t.step(&[Detection {
        pos: [100.0, 100.0],
        weight: 0.0,
    }])
    .unwrap();
    for (a, b) in t.posterior().iter().zip(&prior) {
        assert!((a - b).abs() < 1e-15);
    }
}

#[test]
fn estimate_reports_runner_ups_for_two_targets() {
    let (model, _) = trained(0, CbtConfig::default());
    let mut t = CbtTracker::new(model);
    t.reset([100.0, 100.0]).unwrap();
    // Two equally good detections 60 px apart, repeatedly: the posterior keeps two modes.
    let mut density = vec![0.0; t.model().space().cells()];
    let g = t.model().space().grid().clone();
    g.accumulate(&[100.0, 100.0], 1.0, &mut density).unwrap();
    g.accumulate(&[160.0, 100.0], 1.0, &mut density).unwrap();
    t.reset_to(&density).unwrap();
    let e = t.estimate();
    assert!(!e.runner_ups.is_empty());
    let mut xs = vec![e.position[0], e.runner_ups[0].position[0]];
    xs.sort_by(f64::total_cmp);
    assert!(
        (xs[0] - 100.0).abs() < 1e-6 && (xs[1] - 160.0).abs() < 1e-6,
        "{xs:?}"
    );
    assert!(e.certainty.unwrap() >= e.runner_ups[0].certainty);
}

/// A new tracker, before any reset: the dense layouts hold the uniform posterior over the
/// grid, the stationary layout a sharp start at the centre of the grid (`CbtTracker::new`).
#[test]
fn a_new_tracker_is_uniform_or_at_the_centre() {
    let space = Space::image(100.0, 80.0, 10.0).unwrap();
    let joint = CbtConfig {
        layout: Layout::SparseJoint,
        ..CbtConfig::default()
    };
    for cfg in [CbtConfig::default(), joint, CbtConfig::stationary()] {
        let t = CbtTracker::new(CbtModel::untrained(space.clone(), cfg).unwrap());
        let q = t.posterior();
        if cfg.layout == Layout::Stationary {
            let centre: Vec<f64> = (0..2)
                .map(|d| {
                    let (lo, hi) = space.state_basis(d).representable_range();
                    0.5 * (lo + hi)
                })
                .collect();
            let p = t.estimate().position;
            assert!((p[0] - centre[0]).abs() < 1e-9 && (p[1] - centre[1]).abs() < 1e-9);
            assert!((q.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        } else {
            let g = space.cells() as f64;
            assert_eq!(q.len(), space.cells());
            assert!(q.iter().all(|&v| (v - 1.0 / g).abs() < 1e-15), "{cfg:?}");
        }
    }
}

/// `reset_to` refuses a density of the wrong length (`Mismatch`), with a non-finite value
/// (`NonFinite`), a negative value (`NegativeWeight`) or without mass (`InvalidParameter`
/// `density`), each leaving the tracker unchanged; an accepted density is normalised and both
/// previous posteriors are set to it: a tracker that had been stepping is then equal to a new
/// one started from the same density, and steps identically. Dense and stationary layouts.
#[test]
fn reset_to_validates_normalises_and_forgets_the_past() {
    for cfg in [CbtConfig::default(), CbtConfig::stationary()] {
        let (model, test) = trained(1, cfg);
        let s = &test[0];
        let space = model.space().clone();
        let g = space.cells();
        let mut fresh = CbtTracker::new(model.clone());
        let mut t = CbtTracker::new(model);
        t.reset(s.frames[0].truth.unwrap()).unwrap();
        for f in &s.frames[1..8] {
            t.step(&f.detections).unwrap();
        }
        // An unnormalised density: three times a channel encoding away from the track.
        let density: Vec<f64> = space
            .grid()
            .encode(&[150.0, 100.0])
            .unwrap()
            .iter()
            .map(|v| 3.0 * v)
            .collect();
        assert_eq!(density.len(), g);
        let before = t.clone();
        let with = |k: usize, v: f64| {
            let mut d = density.clone();
            d[k] = v;
            d
        };
        let k = density.iter().position(|&v| v > 0.0).unwrap();
        for (bad, what) in [
            (vec![1.0; g - 1], "length"),
            (vec![1.0; g + 1], "length"),
            (with(k, f64::NAN), "non-finite"),
            (with(k, f64::INFINITY), "non-finite"),
            (with(0, -1e-9), "negative"),
            (vec![0.0; g], "no mass"),
        ] {
            let r = t.reset_to(&bad);
            let ok = match what {
                "length" => matches!(r, Err(TrackError::Mismatch(_))),
                "non-finite" => matches!(
                    r,
                    Err(TrackError::NonFinite {
                        what: "density",
                        ..
                    })
                ),
                "negative" => matches!(r, Err(TrackError::NegativeWeight(_))),
                _ => matches!(
                    r,
                    Err(TrackError::InvalidParameter {
                        name: "density",
                        ..
                    })
                ),
            };
            assert!(ok, "{cfg:?} {what}: {r:?}");
            assert_eq!(t, before, "{what}");
        }
        t.reset_to(&density).unwrap();
        fresh.reset_to(&density).unwrap();
        assert_eq!(t, fresh);
        let q = t.posterior();
        assert!((q.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        if cfg.layout == Layout::Separable {
            let total: f64 = density.iter().sum();
            for (a, d) in q.iter().zip(&density) {
                assert!((a - d / total).abs() <= 1e-15, "{a} vs {}", d / total);
            }
        }
        for f in &s.frames[8..14] {
            assert_eq!(
                t.step(&f.detections).unwrap(),
                fresh.step(&f.detections).unwrap()
            );
        }
        assert_eq!(t, fresh);
    }
}

#[test]
fn online_learning_updates_both_models_and_chains_frames() {
    let (model, test) = trained(1, CbtConfig::default());
    let mut t = CbtTracker::new(model.clone());
    let s = &test[0];
    for f in &s.frames[..5] {
        t.learn_online(&[f.truth.unwrap()], &f.detections).unwrap();
    }
    let (a, b) = (model.stats(), t.model().stats());
    assert_eq!(b.observation_frames, a.observation_frames + 5);
    assert_eq!(b.transitions, a.transitions + 4);
    assert_eq!(b.triples, a.triples + 3);
    assert_ne!(model.observation_matrix(0), t.model().observation_matrix(0));
    assert_ne!(
        model.second_order_tensor(0),
        t.model().second_order_tensor(0)
    );
    // The incrementally renormalised model equals a batch model of the same frames.
    let frames: Vec<Vec<_>> = vec![s.frames[..5].to_vec()]
        .into_iter()
        .map(|f| {
            Sequence {
                name: String::new(),
                first_frame: 0,
                frames: f,
            }
            .training_frames()
        })
        .collect();
    let mut batch_frames = Vec::new();
    let sc = Scenario::default();
    for tr in generate(&sc, &Level::preset(1), 3, 300, 21).unwrap() {
        batch_frames.push(tr.training_frames());
    }
    batch_frames.extend(frames);
    let batch = CbtModel::learn(
        t.model().space().clone(),
        *t.model().config(),
        &batch_frames,
    )
    .unwrap();
    for (x, y) in batch
        .second_order_tensor(0)
        .unwrap()
        .iter()
        .zip(t.model().second_order_tensor(0).unwrap())
    {
        assert!((x - y).abs() < 1e-12);
    }
    for (x, y) in batch
        .observation_matrix(1)
        .unwrap()
        .iter()
        .zip(t.model().observation_matrix(1).unwrap())
    {
        assert!((x - y).abs() < 1e-12);
    }
}

#[test]
fn trackers_survive_a_serde_round_trip() {
    let (model, test) = trained(2, CbtConfig::default());
    let s = &test[0];
    let sc = Scenario::default();
    let cal =
        Calibration::estimate(&generate(&sc, &Level::preset(2), 2, 200, 3).unwrap(), 32.0).unwrap();
    let mut trackers: Vec<(Box<dyn Tracker>, String)> = Vec::new();
    let mut cbt = CbtTracker::new(model.clone());
    let mut joint = CbtTracker::new(
        CbtModel::learn_sequences(
            model.space().clone(),
            CbtConfig {
                layout: Layout::SparseJoint,
                order: Order::First,
                ..Default::default()
            },
            &generate(&sc, &Level::preset(2), 1, 100, 21).unwrap(),
        )
        .unwrap(),
    );
    let mut pf = ParticleFilter::new(PfModel::from_calibration(&cal, W * H), 300, 9).unwrap();
    let mut kf = KalmanTracker::new(KalmanParams::from_calibration(&cal)).unwrap();
    let start = s.frames[0].truth.unwrap();
    for t in [&mut cbt as &mut dyn Tracker, &mut joint, &mut pf, &mut kf] {
        t.reset(start).unwrap();
        for f in &s.frames[1..20] {
            t.step(&f.detections).unwrap();
        }
    }
    let json = serde_json::to_string(&cbt).unwrap();
    trackers.push((
        Box::new(serde_json::from_str::<CbtTracker>(&json).unwrap()),
        json,
    ));
    let json = serde_json::to_string(&joint).unwrap();
    trackers.push((
        Box::new(serde_json::from_str::<CbtTracker>(&json).unwrap()),
        json,
    ));
    let json = serde_json::to_string(&pf).unwrap();
    trackers.push((
        Box::new(serde_json::from_str::<ParticleFilter>(&json).unwrap()),
        json,
    ));
    let json = serde_json::to_string(&kf).unwrap();
    trackers.push((
        Box::new(serde_json::from_str::<KalmanTracker>(&json).unwrap()),
        json,
    ));
    let originals: [&mut dyn Tracker; 4] = [&mut cbt, &mut joint, &mut pf, &mut kf];
    for (orig, (copy, _)) in originals.into_iter().zip(trackers.iter_mut()) {
        // serde_json reads floats to within an ulp or so, not always bit-exactly.
        for f in &s.frames[20..40] {
            let a = orig.step(&f.detections).unwrap();
            let b = copy.step(&f.detections).unwrap();
            for d in 0..2 {
                assert!(
                    (a.position[d] - b.position[d]).abs() < 1e-9,
                    "{}",
                    orig.name()
                );
            }
            assert_eq!(a.runner_ups.len(), b.runner_ups.len());
        }
    }
    // A model alone, too.
    let json = serde_json::to_string(&model).unwrap();
    let back = serde_json::from_str::<CbtModel>(&json).unwrap();
    assert_eq!(back.stats(), model.stats());
    for (a, b) in back
        .second_order_tensor(0)
        .unwrap()
        .iter()
        .zip(model.second_order_tensor(0).unwrap())
    {
        assert!((a - b).abs() <= 1e-15 * b.abs().max(1.0));
    }
}
