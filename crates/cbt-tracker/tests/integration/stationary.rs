//! The stationary layout: learning on hand-computed cases, the learned clutter statistics, the
//! windowed posterior's invariants, shift equivariance, recovery, accuracy against the Kalman
//! filter, bad input.

use cbt_tracker::sim::{Level, Scenario, generate};
use cbt_tracker::{
    CbtConfig, CbtModel, CbtTracker, Detection, Layout, Order, Scales, Sequence, Space, TrackError,
    Tracker, TrainingFrame, axis,
};
use chan_repr::{ChannelBasis, Kernel};
use proptest::prelude::*;

fn stationary() -> CbtConfig {
    CbtConfig {
        layout: Layout::Stationary,
        ..CbtConfig::default()
    }
}

/// A 2-D space with channel centres at the integers 1..=n on both axes.
fn integer_space(n: usize) -> Space {
    let b = ChannelBasis::integer(n, cbt_tracker::DEFAULT_KERNEL).unwrap();
    Space::new(vec![b.clone(), b.clone()], vec![b.clone(), b]).unwrap()
}

/// The cos² (a = π/3) vector of a point on a channel centre is (1/4, 1, 1/4); its
/// autocorrelation at lags −2..=2 is (1/16, 1/2, 9/8, 1/2, 1/16) (sum 2.25 = 1.5²).
const AUTO: [f64; 5] = [0.0625, 0.5, 1.125, 0.5, 0.0625];

#[test]
fn learns_displacement_models_exactly_on_a_hand_computed_case() {
    // A target moving +1 channel per frame along x, detected exactly, no clutter.
    let space = integer_space(40);
    let frames: Vec<TrainingFrame> = (0..20)
        .map(|k| {
            let p = [10.0 + k as f64, 20.0];
            TrainingFrame {
                states: vec![p],
                detections: vec![Detection::new(p[0], p[1])],
            }
        })
        .collect();
    let cfg = CbtConfig {
        prior_weight: 1e-12,
        ..stationary()
    };
    let model = CbtModel::learn(space, cfg, &[frames]).unwrap();
    // Observation kernel: A[δ] = AUTO[δx]·AUTO[δy] / 1.5⁴, all mass on |δ| ≤ 2: P̂_D = 1,
    // no clutter.
    let (p_d, background, _) = model.stationary_observation().unwrap();
    assert!((p_d - 1.0).abs() < 1e-12 && background == 0.0);
    let (a, ra) = model.stationary_kernel().unwrap();
    let w = 2 * ra + 1;
    for i in 0..w {
        for j in 0..w {
            let (dx, dy) = (i as i64 - ra as i64, j as i64 - ra as i64);
            let want = if dx.abs() <= 2 && dy.abs() <= 2 {
                AUTO[(dx + 2) as usize] * AUTO[(dy + 2) as usize] / 1.5f64.powi(4)
            } else {
                0.0
            };
            assert!((a[i * w + j] - want).abs() < 1e-12, "A[{dx}, {dy}]");
        }
    }
    // First order along x: S[δ] = AUTO[δ − 1]/2.25 (every step is +1); along y: AUTO[δ]/2.25.
    let (sx, tx) = model.stationary_system(0).unwrap();
    let (sy, _) = model.stationary_system(1).unwrap();
    let r = (sx.len() - 1) / 2;
    for (i, (&vx, &vy)) in sx.iter().zip(sy).enumerate() {
        let d = i as i64 - r as i64;
        let at = |k: i64| {
            if k.abs() <= 2 {
                AUTO[(k + 2) as usize] / 2.25
            } else {
                0.0
            }
        };
        assert!((vx - at(d - 1)).abs() < 1e-9, "S_x[{d}]");
        assert!((vy - at(d)).abs() < 1e-9, "S_y[{d}]");
    }
    // Second order along x, given the previous step v = +1 (the only one seen with its
    // neighbours v = 0, 2 of the encoding): T[δ | v] ∝ Σ over the triple's channel products.
    // Its column for v = 1 peaks at δ = 1 and is symmetric about it.
    let w2 = 2 * r + 1;
    let col = &tx[(r + 1) * w2..(r + 2) * w2];
    let peak = col
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(b.1))
        .unwrap()
        .0;
    assert_eq!(peak, r + 1);
    for k in 1..r - 1 {
        assert!((col[r + 1 - k] - col[r + 1 + k]).abs() < 1e-9);
    }
    assert!((col.iter().sum::<f64>() - 1.0).abs() < 1e-12);
}

fn level_space(train: &[Sequence], sc: &Scenario) -> Space {
    let extent = sc.width.min(sc.height);
    let sp = Scales::estimate(train, extent)
        .unwrap()
        .fine_spacing(extent)
        .unwrap();
    let k = cbt_tracker::DEFAULT_KERNEL;
    let (bx, by) = (
        axis(0.0, sc.width, sp, k).unwrap(),
        axis(0.0, sc.height, sp, k).unwrap(),
    );
    Space::new(vec![bx.clone(), by.clone()], vec![bx, by]).unwrap()
}

#[test]
fn learns_detection_probability_and_clutter_density_from_unassociated_sets() {
    let sc = Scenario::default();
    let lv = Level::preset(3); // P_D = 0.8, 6 clutter a frame
    let train = generate(&sc, &lv, 4, 300, 31).unwrap();
    let space = level_space(&train, &sc);
    let model = CbtModel::learn_sequences(space.clone(), stationary(), &train).unwrap();
    let (p_d, b, _) = model.stationary_observation().unwrap();
    // Clutter per frame over the grid (the measurement cells cover the image).
    let clutter = b * space.cells() as f64;
    assert!((p_d - 0.8).abs() < 0.06, "P_D {p_d}");
    assert!((clutter - 6.0).abs() < 1.2, "clutter {clutter}");
}

fn trained(level: usize, cfg: CbtConfig) -> (CbtModel, Vec<Sequence>) {
    let sc = Scenario::default();
    let lv = Level::preset(level);
    let train = generate(&sc, &lv, 3, 300, 41).unwrap();
    let space = level_space(&train, &sc);
    let test = generate(&sc, &lv, 2, 100, 42).unwrap();
    (CbtModel::learn_sequences(space, cfg, &train).unwrap(), test)
}

fn rmse(t: &mut dyn Tracker, s: &Sequence) -> f64 {
    t.reset(s.frames[0].truth.unwrap()).unwrap();
    let mut e2 = 0.0;
    for f in &s.frames[1..] {
        let p = t.step(&f.detections).unwrap().position;
        let tr = f.truth.unwrap();
        e2 += (p[0] - tr[0]).powi(2) + (p[1] - tr[1]).powi(2);
    }
    (e2 / (s.frames.len() - 1) as f64).sqrt()
}

#[test]
fn tracks_within_the_detection_noise_at_every_level() {
    // RMSE (Euclidean) below 1.6 × the per-axis detection σ (the raw detections' Euclidean
    // error is 1.41 σ) on clean to mid-clutter data, first and second order.
    for (level, sigma) in [(0usize, 1.0), (1, 2.0), (2, 4.0)] {
        for order in [Order::First, Order::Second] {
            let (model, test) = trained(
                level,
                CbtConfig {
                    order,
                    ..stationary()
                },
            );
            for s in &test {
                let e = rmse(&mut CbtTracker::new(model.clone()), s);
                assert!(e < 1.6 * sigma, "L{level} {order:?}: {e}");
            }
        }
    }
}

#[test]
fn posterior_window_is_a_normalised_density_and_bad_frames_change_nothing() {
    let (model, test) = trained(3, stationary());
    let mut t = CbtTracker::new(model);
    let s = &test[0];
    t.reset(s.frames[0].truth.unwrap()).unwrap();
    for (k, f) in s.frames[1..].iter().enumerate() {
        // Every fifth frame is empty: prediction only.
        let dets: &[Detection] = if k % 5 == 4 { &[] } else { &f.detections };
        let e = t.step(dets).unwrap();
        let q = t.posterior();
        let ([i0, j0], [h, w]) = t.posterior_window().unwrap();
        assert_eq!(q.len(), h * w);
        assert!(i0 + h <= t.model().space().axis_len(0));
        assert!(j0 + w <= t.model().space().axis_len(1));
        assert!(q.iter().all(|v| v.is_finite() && *v >= 0.0));
        assert!((q.iter().sum::<f64>() - 1.0).abs() < 1e-9);
        let c = e.certainty.unwrap();
        assert!(c > 0.0 && c <= 1.0 + 1e-12);
        assert!(e.runner_ups.iter().all(|r| r.certainty <= c + 1e-12));
    }
    // A NaN or off-grid detection is an error and leaves the tracker unchanged.
    let before = t.clone();
    let bad = [Detection::new(f64::NAN, 3.0)];
    assert!(matches!(t.step(&bad), Err(TrackError::NonFinite { .. })));
    let off = [Detection::new(5000.0, 3.0)];
    assert!(matches!(t.step(&off), Err(TrackError::OutsideGrid { .. })));
    assert_eq!(t, before);
}

/// `step_on_grid` leaves out exactly the detections off the grid (the others are used: the
/// step equals one on them alone), counts them, steps without detections when none is left,
/// and returns any other error with the tracker unchanged; for both layouts.
#[test]
fn a_frame_keeps_its_detections_on_the_grid_when_others_are_off_it() {
    for layout in [Layout::Stationary, Layout::Separable] {
        let (model, test) = trained(
            2,
            CbtConfig {
                layout,
                ..CbtConfig::default()
            },
        );
        let s = &test[0];
        let mut t = CbtTracker::new(model);
        t.reset(s.frames[0].truth.unwrap()).unwrap();
        let mut dropped_total = 0;
        for (k, f) in s.frames[1..30].iter().enumerate() {
            // Off-grid detections mixed in on every other frame (one or two, anywhere).
            let mut dets = f.detections.clone();
            let off = [Detection::new(-5000.0, 3.0), Detection::new(10.0, 1e6)];
            let n_off = k % 3;
            for (i, d) in off[..n_off.min(2)].iter().enumerate() {
                dets.insert(i * dets.len() / 2, *d);
            }
            let mut reference = t.clone();
            let expected = reference.step(&f.detections).unwrap();
            let (e, dropped) = cbt_tracker::step_on_grid(&mut t, &dets).unwrap();
            assert_eq!(dropped, n_off.min(2), "{layout:?} frame {k}");
            assert_eq!(e, expected, "{layout:?} frame {k}");
            assert_eq!(t, reference, "{layout:?} frame {k}");
            dropped_total += dropped;
        }
        assert!(dropped_total >= 20);
        // Every detection off the grid: a step without detections.
        let mut reference = t.clone();
        let expected = reference.step(&[]).unwrap();
        let off = [Detection::new(-5000.0, 3.0), Detection::new(-4000.0, 3.0)];
        assert_eq!(
            cbt_tracker::step_on_grid(&mut t, &off).unwrap(),
            (expected, 2)
        );
        // Any other bad input is still an error, and changes nothing.
        let before = t.clone();
        let bad = [Detection::new(-5000.0, 3.0), Detection::new(f64::NAN, 3.0)];
        assert!(matches!(
            cbt_tracker::step_on_grid(&mut t, &bad),
            Err(TrackError::NonFinite { .. })
        ));
        assert_eq!(t, before);
    }
}

#[test]
fn recovers_a_lost_track_by_uniform_mixing() {
    let (model, test) = trained(0, stationary());
    let s = &test[0];
    let t0 = s.frames[0].truth.unwrap();
    let wrong = [(t0[0] + 100.0) % 320.0, (t0[1] + 80.0) % 240.0];
    let mut t = CbtTracker::new(model);
    t.reset(wrong).unwrap();
    let mut err = f64::INFINITY;
    for f in &s.frames[1..20] {
        let e = t.step(&f.detections).unwrap();
        let tr = f.truth.unwrap();
        err = (e.position[0] - tr[0]).hypot(e.position[1] - tr[1]);
    }
    assert!(err < 5.0, "still lost: {err}");
}

#[test]
fn layout_requirements_are_typed_errors() {
    let b = ChannelBasis::integer(20, cbt_tracker::DEFAULT_KERNEL).unwrap();
    let one = Space::new(vec![b.clone()], vec![b.clone()]).unwrap();
    assert!(matches!(
        CbtModel::untrained(one, stationary()),
        Err(TrackError::Mismatch(_))
    ));
    let other = ChannelBasis::integer(30, cbt_tracker::DEFAULT_KERNEL).unwrap();
    let mixed = Space::new(vec![b.clone(), b.clone()], vec![b.clone(), other]).unwrap();
    assert!(matches!(
        CbtModel::untrained(mixed, stationary()),
        Err(TrackError::Mismatch(_))
    ));
    let spline = ChannelBasis::integer(20, Kernel::BSpline2).unwrap();
    let sp = Space::new(
        vec![spline.clone(), spline.clone()],
        vec![spline.clone(), spline],
    )
    .unwrap();
    assert!(matches!(
        CbtModel::untrained(sp, stationary()),
        Err(TrackError::Mismatch(_))
    ));
    let bad = CbtConfig {
        obs_radius: 0,
        ..stationary()
    };
    assert!(matches!(
        CbtModel::untrained(integer_space(20), bad),
        Err(TrackError::InvalidParameter { .. })
    ));
}

#[test]
fn serde_round_trip_continues_identically() {
    let (model, test) = trained(2, stationary());
    let s = &test[0];
    let mut a = CbtTracker::new(model);
    a.reset(s.frames[0].truth.unwrap()).unwrap();
    for f in &s.frames[1..30] {
        a.step(&f.detections).unwrap();
    }
    let json = serde_json::to_string(&a).unwrap();
    let mut b: CbtTracker = serde_json::from_str(&json).unwrap();
    for f in &s.frames[30..60] {
        let (ea, eb) = (
            a.step(&f.detections).unwrap(),
            b.step(&f.detections).unwrap(),
        );
        // serde_json parses floats to within an ulp.
        assert!((ea.position[0] - eb.position[0]).abs() < 1e-9);
        assert!((ea.position[1] - eb.position[1]).abs() < 1e-9);
    }
}

proptest! {
    #![proptest_config(crate::seeded(12))]

    /// Shifting all training and test data by a whole number of channels shifts every
    /// estimate by the same amount (the models depend on displacements only; the data stay
    /// far from the grid's ends, so no displacement window is cut by them).
    #[test]
    fn shifting_by_whole_channels_shifts_the_estimates(kx in -6i64..=6, ky in -6i64..=6, seed in 0u64..1000) {
        let space = integer_space(120);
        let sc = Scenario { width: 40.0, height: 30.0, margin: 4.0, ..Scenario::default() };
        let lv = Level::preset(2);
        let shift = |s: &Sequence, dx: f64, dy: f64| -> Sequence {
            let mut s = s.clone();
            for f in &mut s.frames {
                if let Some(t) = f.truth.as_mut() {
                    t[0] += dx;
                    t[1] += dy;
                }
                for d in &mut f.detections {
                    d.pos[0] += dx;
                    d.pos[1] += dy;
                }
            }
            // Clutter of the small scene stays inside it; keep detections on the grid.
            s
        };
        let train = generate(&sc, &lv, 2, 120, seed).unwrap();
        let test = &generate(&sc, &lv, 1, 40, seed + 1).unwrap()[0];
        let base = 40.0;
        let run = |dx: f64, dy: f64| -> Vec<[f64; 2]> {
            let tr: Vec<Sequence> = train.iter().map(|s| shift(s, base + dx, base + dy)).collect();
            let model = CbtModel::learn_sequences(space.clone(), stationary(), &tr).unwrap();
            let te = shift(test, base + dx, base + dy);
            let mut t = CbtTracker::new(model);
            t.reset(te.frames[0].truth.unwrap()).unwrap();
            te.frames[1..].iter().map(|f| t.step(&f.detections).unwrap().position).collect()
        };
        let a = run(0.0, 0.0);
        let b = run(kx as f64, ky as f64);
        for (p, q) in a.iter().zip(&b) {
            prop_assert!((q[0] - p[0] - kx as f64).abs() < 1e-6, "{p:?} {q:?}");
            prop_assert!((q[1] - p[1] - ky as f64).abs() < 1e-6, "{p:?} {q:?}");
        }
    }
}

/// Half the training targets stand still, half walk +3 channels a frame along x: `T[· | 0]`
/// says "stays", the displacement distribution `S` says "stays or walks".
fn standing_and_walking() -> (Space, Vec<Vec<TrainingFrame>>) {
    let space = integer_space(80);
    let seqs = (0..6)
        .map(|i| {
            let speed = if i % 2 == 0 { 0.0 } else { 3.0 };
            (0..15)
                .map(|k| {
                    let p = [10.0 + speed * k as f64, 10.0 + 8.0 * i as f64];
                    TrainingFrame {
                        states: vec![p],
                        detections: vec![Detection::new(p[0], p[1])],
                    }
                })
                .collect()
        })
        .collect();
    (space, seqs)
}

#[test]
fn a_start_has_no_velocity_so_the_first_step_predicts_with_the_displacement_distribution() {
    let (space, seqs) = standing_and_walking();
    let second = CbtModel::learn(space.clone(), stationary(), &seqs).unwrap();
    let first = CbtModel::learn(
        space,
        CbtConfig {
            order: Order::First,
            ..stationary()
        },
        &seqs,
    )
    .unwrap();
    let (t2, t1) = (
        second.stationary_system(0).unwrap(),
        first.stationary_system(0).unwrap(),
    );
    assert_eq!(t2.0, t1.0, "both models learn the same S");
    let mut a = CbtTracker::new(second);
    let mut b = CbtTracker::new(first);
    a.reset([20.0, 40.0]).unwrap();
    b.reset([20.0, 40.0]).unwrap();
    // A walker's first detection, 3 channels ahead: the first step of the second-order
    // tracker is exactly the first-order one (S), and it follows the detection.
    let det = [Detection::new(23.0, 40.0)];
    let (ea, eb) = (a.step(&det).unwrap(), b.step(&det).unwrap());
    assert_eq!(ea, eb);
    assert_eq!(a.posterior(), b.posterior());
    assert!((ea.position[0] - 23.0).abs() < 0.5, "{:?}", ea.position);
    // From the second step on it uses the velocity it carries (the first step's displacement
    // given the detection, +3): T[· | +3] says "walks on", so a detection straight ahead is
    // followed again, and the two trackers differ.
    let det = [Detection::new(26.0, 40.0)];
    let (ea, eb) = (a.step(&det).unwrap(), b.step(&det).unwrap());
    assert!((ea.position[0] - 26.0).abs() < 0.5, "{:?}", ea.position);
    assert_ne!(a.posterior(), b.posterior());
    assert_ne!(ea, eb);
}

#[test]
fn a_saved_tracker_remembers_that_it_has_just_started() {
    let (space, seqs) = standing_and_walking();
    let model = CbtModel::learn(space, stationary(), &seqs).unwrap();
    let mut a = CbtTracker::new(model);
    a.reset([20.0, 40.0]).unwrap();
    let mut b: CbtTracker = serde_json::from_str(&serde_json::to_string(&a).unwrap()).unwrap();
    // The same first step (within rounding: a loaded tracker's work buffers start empty):
    // the loaded one also predicts with S and follows the walker.
    let det = [Detection::new(23.0, 40.0)];
    let (ea, eb) = (a.step(&det).unwrap(), b.step(&det).unwrap());
    for d in 0..2 {
        assert!(
            (ea.position[d] - eb.position[d]).abs() < 1e-9,
            "{ea:?} {eb:?}"
        );
    }
    assert!((eb.position[0] - 23.0).abs() < 0.5, "{eb:?}");
}

#[test]
fn the_velocity_is_carried_through_missed_detections() {
    let (space, seqs) = standing_and_walking();
    let mut a = CbtTracker::new(CbtModel::learn(space, stationary(), &seqs).unwrap());
    a.reset([20.0, 40.0]).unwrap();
    for x in [23.0, 26.0, 29.0] {
        let e = a.step(&[Detection::new(x, 40.0)]).unwrap();
        assert!((e.position[0] - x).abs() < 0.5, "{x}: {:?}", e.position);
    }
    // Four frames without a detection: the state's velocity (+3, learned T[· | +3] says
    // "walks on") moves the estimate on, one walking step a frame; a filter that lost the
    // velocity would stay at 29 (the standing walkers' T[· | 0]).
    for x in [32.0, 35.0, 38.0, 41.0] {
        let e = a.step(&[]).unwrap();
        assert!(
            (e.position[0] - x).abs() < 1.0,
            "miss, {x}: {:?}",
            e.position
        );
        assert!((e.position[1] - 40.0).abs() < 0.5, "{:?}", e.position);
    }
    // The walker is picked up again where the carried velocity put it.
    let e = a.step(&[Detection::new(44.0, 40.0)]).unwrap();
    assert!((e.position[0] - 44.0).abs() < 0.5, "{:?}", e.position);
}

/// The order of the estimate's hypotheses (`Estimate::runner_ups`): the dense layouts give the
/// modes by decreasing certainty (window mass), the stationary layout by the height of their
/// highest cell (module `stationary::window`, step 4), so there a sharp, high cell is the
/// estimate even when a broad mode holds more mass, and that mode is a runner-up with the
/// larger certainty.
#[test]
fn hypotheses_are_ordered_by_mass_in_dense_layouts_and_by_peak_in_the_stationary_one() {
    let n = 40;
    let space = integer_space(n);
    // A single high cell at channel (11, 11) (index 10) and a broad plateau around (29, 29)
    // whose own peak is lower.
    let mut d = vec![0.0; n * n];
    d[10 * n + 10] = 1.0;
    for i in 26..=30 {
        for j in 26..=30 {
            d[i * n + j] = 0.5;
        }
    }
    d[28 * n + 28] = 0.9;
    for cfg in [CbtConfig::default(), CbtConfig::stationary()] {
        let mut t = CbtTracker::new(CbtModel::untrained(space.clone(), cfg).unwrap());
        t.reset_to(&d).unwrap();
        let e = t.estimate();
        let c = e.certainty.unwrap();
        assert!(!e.runner_ups.is_empty(), "{:?}", cfg.layout);
        if cfg.layout == Layout::Stationary {
            assert_eq!(e.position, [11.0, 11.0]);
            let broad = &e.runner_ups[0];
            assert_eq!(broad.position, [29.0, 29.0]);
            assert!(broad.certainty > 10.0 * c, "{c} vs {}", broad.certainty);
        } else {
            assert!((e.position[0] - 29.0).abs() < 1e-9 && (e.position[1] - 29.0).abs() < 1e-9);
            let mut last = c;
            for r in &e.runner_ups {
                assert!(r.certainty <= last, "{:?}", e.runner_ups);
                last = r.certainty;
            }
        }
    }
}
