//! Bad input gets typed errors, and a tracker given a bad frame keeps its previous state.

use cbt_tracker::sim::{Level, Scenario, generate};
use cbt_tracker::{
    Calibration, CbtConfig, CbtModel, CbtTracker, Detection, KalmanParams, KalmanTracker, Layout,
    LearnedParticleFilter, MAX_MODEL_VALUES, MAX_PARTICLES, Order, ParticleFilter, PfModel, Scales,
    Space, TrackError, Tracker, TrainingFrame,
};
use chan_repr::{ChanError, ChannelBasis, Kernel};

fn setup() -> (CbtModel, Vec<cbt_tracker::Sequence>) {
    let sc = Scenario::default();
    let train = generate(&sc, &Level::preset(1), 2, 200, 5).unwrap();
    let space = Space::image(sc.width, sc.height, 10.0).unwrap();
    (
        CbtModel::learn_sequences(space, CbtConfig::default(), &train).unwrap(),
        train,
    )
}

#[test]
fn learning_rejects_bad_training_data() {
    let space = Space::image(100.0, 100.0, 10.0).unwrap();
    let cfg = CbtConfig::default();
    assert!(matches!(
        CbtModel::learn(space.clone(), cfg, &[]),
        Err(TrackError::EmptyTraining { .. })
    ));
    // States but no detections: no observation sample.
    let no_dets: Vec<TrainingFrame> = (0..5)
        .map(|k| TrainingFrame {
            states: vec![[10.0 + k as f64, 50.0]],
            detections: vec![],
        })
        .collect();
    assert!(matches!(
        CbtModel::learn(space.clone(), cfg, &[no_dets]),
        Err(TrackError::EmptyTraining { .. })
    ));
    // Two frames: no triple for the second-order model.
    let two: Vec<TrainingFrame> = (0..2)
        .map(|k| TrainingFrame {
            states: vec![[10.0 + k as f64, 50.0]],
            detections: vec![Detection::new(10.0, 50.0)],
        })
        .collect();
    assert!(matches!(
        CbtModel::learn(space.clone(), cfg, &[two]),
        Err(TrackError::EmptyTraining { .. })
    ));
    let outside = vec![TrainingFrame {
        states: vec![[150.0, 50.0]],
        detections: vec![],
    }];
    assert!(matches!(
        CbtModel::learn(space.clone(), cfg, &[outside]),
        Err(TrackError::OutsideGrid { what: "state", .. })
    ));
    let nan = vec![TrainingFrame {
        states: vec![[50.0, 50.0]],
        detections: vec![Detection::new(f64::NAN, 3.0)],
    }];
    assert!(matches!(
        CbtModel::learn(space, cfg, &[nan]),
        Err(TrackError::NonFinite { .. })
    ));
}

#[test]
fn bad_spaces_and_parameters_are_errors() {
    assert!(matches!(
        Space::image(100.0, 100.0, 0.0),
        Err(TrackError::InvalidParameter { .. })
    ));
    assert!(matches!(
        Space::image(100.0, f64::NAN, 5.0),
        Err(TrackError::InvalidParameter { .. })
    ));
    // Zero channels.
    assert!(matches!(
        ChannelBasis::integer(0, Kernel::Cos2 { m: 3 }).map_err(TrackError::from),
        Err(TrackError::Chan(ChanError::TooFewChannels { got: 0, .. }))
    ));
    let b = ChannelBasis::integer(10, Kernel::Cos2 { m: 3 }).unwrap();
    assert!(matches!(
        Space::new(vec![], vec![]),
        Err(TrackError::Mismatch(_))
    ));
    assert!(matches!(
        Space::new(vec![b.clone()], vec![b.clone(), b.clone()]),
        Err(TrackError::Mismatch(_))
    ));
    let space = Space::new(vec![b.clone()], vec![b]).unwrap();
    for cfg in [
        CbtConfig {
            mixing: 1.0,
            ..Default::default()
        },
        CbtConfig {
            prior_weight: 0.0,
            ..Default::default()
        },
        CbtConfig {
            observation_floor: f64::NAN,
            ..Default::default()
        },
    ] {
        assert!(matches!(
            CbtModel::untrained(space.clone(), cfg),
            Err(TrackError::InvalidParameter { .. })
        ));
    }
    assert!(
        ParticleFilter::new(
            PfModel::Ungm {
                process_var: 10.0,
                meas_var: 1.0,
                init_sigma: 1.0
            },
            0,
            1
        )
        .is_err()
    );
    assert!(
        KalmanTracker::new(KalmanParams {
            accel_sigma: -1.0,
            meas_sigma: 1.0,
            init_vel_sigma: 1.0,
            gate: 9.0
        })
        .is_err()
    );
}

#[test]
fn trackers_keep_their_state_on_a_bad_frame() {
    let (model, train) = setup();
    let cal = Calibration::estimate(&train, 32.0).unwrap();
    let s = &train[0];
    let mut cbt = CbtTracker::new(model);
    let mut kf = KalmanTracker::new(KalmanParams::from_calibration(&cal)).unwrap();
    let mut pf =
        ParticleFilter::new(PfModel::from_calibration(&cal, 320.0 * 240.0), 200, 4).unwrap();
    let bad_frames = [
        vec![Detection::new(100.0, 100.0), Detection::new(f64::NAN, 1.0)],
        vec![Detection::new(100.0, f64::INFINITY)],
        vec![Detection {
            pos: [100.0, 100.0],
            weight: -1.0,
        }],
    ];
    for t in [&mut cbt as &mut dyn Tracker, &mut kf, &mut pf] {
        t.reset(s.frames[0].truth.unwrap()).unwrap();
        for f in &s.frames[1..10] {
            t.step(&f.detections).unwrap();
        }
    }
    let before = (
        serde_json::to_string(&cbt).unwrap(),
        serde_json::to_string(&kf).unwrap(),
        serde_json::to_string(&pf).unwrap(),
    );
    for bad in &bad_frames {
        assert!(cbt.step(bad).is_err());
        assert!(kf.step(bad).is_err());
        assert!(pf.step(bad).is_err());
    }
    // Off the grid: only CBT has a grid.
    assert!(matches!(
        cbt.step(&[Detection::new(500.0, 10.0)]),
        Err(TrackError::OutsideGrid {
            what: "detection",
            ..
        })
    ));
    assert!(matches!(
        cbt.learn_online(&[[10.0, 1e6]], &[]),
        Err(TrackError::OutsideGrid { what: "state", .. })
    ));
    let after = (
        serde_json::to_string(&cbt).unwrap(),
        serde_json::to_string(&kf).unwrap(),
        serde_json::to_string(&pf).unwrap(),
    );
    assert_eq!(before, after);
    // And they carry on.
    for f in &s.frames[10..15] {
        cbt.step(&f.detections).unwrap();
    }
    assert!(matches!(
        cbt.reset([f64::NAN, 1.0]),
        Err(TrackError::NonFinite { .. })
    ));
    assert!(cbt.reset_to(&[1.0, 2.0]).is_err());
}

#[test]
fn impossible_particle_counts_are_errors_before_allocating() {
    let ungm = PfModel::Ungm {
        process_var: 10.0,
        meas_var: 1.0,
        init_sigma: 1.0,
    };
    let (_, train) = setup();
    let space = Space::image(320.0, 240.0, 20.0).unwrap();
    let first = CbtConfig {
        order: Order::First,
        ..CbtConfig::default()
    };
    let model = CbtModel::learn_sequences(space, first, &train).unwrap();
    // usize::MAX used to be a capacity-overflow panic, 2^40 an allocation abort.
    for n in [usize::MAX, 1 << 40, MAX_PARTICLES + 1] {
        assert!(matches!(
            ParticleFilter::new(ungm, n, 1),
            Err(TrackError::InvalidParameter {
                name: "particles",
                ..
            })
        ));
        assert!(matches!(
            LearnedParticleFilter::new(model.clone(), n, 1),
            Err(TrackError::InvalidParameter {
                name: "particles",
                ..
            })
        ));
    }
    assert!(ParticleFilter::new(ungm, 1, 1).is_ok());
    assert!(LearnedParticleFilter::new(model, 1, 1).is_ok());
}

#[test]
fn training_statistics_refuse_bad_bounds() {
    let (_, train) = setup();
    // Calibration used to return meas_sigma NaN (or 0) for these, and Scales a noise of 0.
    for bad in [f64::NAN, f64::INFINITY, 0.0, -5.0] {
        assert!(matches!(
            Calibration::estimate(&train, bad),
            Err(TrackError::InvalidParameter {
                name: "max_residual",
                ..
            })
        ));
        assert!(matches!(
            Scales::estimate(&train, bad),
            Err(TrackError::InvalidParameter { name: "extent", .. })
        ));
    }
    assert!(Calibration::estimate(&train, 32.0).is_ok());
    assert!(Scales::estimate(&train, 320.0).is_ok());
}

#[test]
fn spacing_refuses_bad_extent_or_scales() {
    let (_, train) = setup();
    let scales = Scales::estimate(&train, 320.0).unwrap();
    // A NaN or negative extent used to panic in `f64::clamp`.
    for bad in [f64::NAN, f64::INFINITY, 0.0, -5.0] {
        for r in [scales.spacing(bad), scales.fine_spacing(bad)] {
            assert!(matches!(
                r,
                Err(TrackError::InvalidParameter { name: "extent", .. })
            ));
        }
    }
    // Hand-built scales: a NaN noise used to give a NaN spacing or the clamp's bound silently.
    let nan = Scales {
        noise: f64::NAN,
        accel: 1.0,
    };
    assert!(matches!(
        nan.spacing(240.0),
        Err(TrackError::InvalidParameter { name: "noise", .. })
    ));
    let negative = Scales {
        noise: 1.0,
        accel: -1.0,
    };
    assert!(matches!(
        negative.fine_spacing(240.0),
        Err(TrackError::InvalidParameter { name: "accel", .. })
    ));
    let s = scales.spacing(240.0).unwrap();
    assert!((240.0 / 48.0..=240.0 / 12.0).contains(&s));
    let f = scales.fine_spacing(240.0).unwrap();
    assert!((240.0 / 1000.0..=240.0 / 12.0).contains(&f));
}

#[test]
fn scoring_refuses_mismatched_or_bad_input() {
    use cbt_tracker::metrics::score;
    let truth = [Some([0.0, 0.0]), Some([1.0, 0.0]), Some([2.0, 0.0])];
    let est = [[0.0, 0.0], [1.0, 3.0], [2.0, 4.0]];
    // Used to be scored silently over the shorter slice.
    assert!(matches!(
        score(&est[..2], &truth, 2, 3.5),
        Err(TrackError::Mismatch(_))
    ));
    // Used to panic indexing a point's third coordinate.
    assert!(matches!(
        score(&est, &truth, 3, 3.5),
        Err(TrackError::InvalidParameter { name: "dims", .. })
    ));
    assert!(score(&est, &truth, 0, 3.5).is_err());
    assert!(score(&est, &truth, 2, f64::NAN).is_err());
    assert!(score(&est, &truth, 2, -1.0).is_err());
    // A NaN estimate used to give rmse NaN with no frame lost.
    let nan = [[0.0, 0.0], [f64::NAN, 3.0], [2.0, 4.0]];
    assert!(matches!(
        score(&nan, &truth, 2, 3.5),
        Err(TrackError::NonFinite { .. })
    ));
    // A NaN where there is no truth, or beyond the scored dims, is not scored.
    let unscored = [Some([0.0, 0.0]), None, Some([2.0, f64::NAN])];
    assert_eq!(score(&nan, &unscored, 1, 3.5).unwrap().frames, 1);
    let s = score(&est, &truth, 2, 3.5).unwrap();
    assert_eq!((s.frames, s.loss_share), (2, 0.5));
    assert!(score(&est, &truth, 2, f64::INFINITY).is_ok());
}

#[test]
fn an_edited_calibration_is_refused_on_reading() {
    let (_, train) = setup();
    let cal = Calibration::estimate(&train, 32.0).unwrap();
    assert!(cal.validate().is_ok());
    let text = serde_json::to_string(&cal).unwrap();
    assert_eq!(serde_json::from_str::<Calibration>(&text).unwrap(), cal);
    // Each used to load; a negative or NaN clutter rate then became 0.01 silently in the
    // particle filter's model.
    for (field, value) in [
        ("accel_sigma", "0"),
        ("meas_sigma", "-1"),
        ("p_detect", "5"),
        ("clutter_rate", "-3"),
    ] {
        let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
        v[field] = serde_json::from_str(value).unwrap();
        let edited = v.to_string();
        let e = serde_json::from_str::<Calibration>(&edited)
            .expect_err(field)
            .to_string();
        assert!(e.contains(field), "{field}: {e}");
    }
}

#[test]
fn simulation_refuses_bad_levels_scenarios_and_areas() {
    use cbt_tracker::sim::{MAX_CLUTTER_RATE, Ungm, generate_one, observe};
    let sc = Scenario::default();
    let bad_level = |f: fn(&mut Level)| {
        let mut l = Level::preset(2);
        f(&mut l);
        l
    };
    // A clutter rate of 1e30 used to panic in the Poisson sampler; a NaN one, P_D or σ gave
    // sequences without clutter or with NaN detections.
    for (level, name) in [
        (bad_level(|l| l.clutter_rate = 1e30), "clutter_rate"),
        (
            bad_level(|l| l.clutter_rate = 2.0 * MAX_CLUTTER_RATE),
            "clutter_rate",
        ),
        (bad_level(|l| l.clutter_rate = f64::NAN), "clutter_rate"),
        (bad_level(|l| l.clutter_rate = -1.0), "clutter_rate"),
        (bad_level(|l| l.p_detect = f64::NAN), "p_detect"),
        (bad_level(|l| l.p_detect = 1.5), "p_detect"),
        (bad_level(|l| l.noise_sigma = f64::NAN), "noise_sigma"),
    ] {
        let e = generate(&sc, &level, 1, 5, 1).unwrap_err();
        assert!(
            matches!(e, TrackError::InvalidParameter { name: n, .. } if n == name),
            "{e}"
        );
        assert!(generate_one(&sc, &level, 5, 1, 0).is_err());
        let track = generate(&sc, &Level::preset(0), 1, 5, 1).unwrap().remove(0);
        assert!(observe(&track, &level, [0.0, 320.0, 0.0, 240.0], 1, 0).is_err());
    }
    // A scenario whose margin leaves no room used to panic in `f64::clamp`.
    for (scenario, name) in [
        (
            Scenario {
                margin: 200.0,
                ..sc
            },
            "margin",
        ),
        (Scenario { width: 1.0, ..sc }, "width"),
        (
            Scenario {
                height: f64::NAN,
                ..sc
            },
            "height",
        ),
        (
            Scenario {
                accel_sigma: f64::NAN,
                ..sc
            },
            "accel_sigma",
        ),
        (Scenario { damping: 2.0, ..sc }, "damping"),
        (
            Scenario {
                shake_memory: 1.0,
                ..sc
            },
            "shake_memory",
        ),
    ] {
        let e = generate(&scenario, &Level::preset(1), 1, 5, 1).unwrap_err();
        assert!(
            matches!(e, TrackError::InvalidParameter { name: n, .. } if n == name),
            "{e}"
        );
    }
    let track = generate(&sc, &Level::preset(0), 1, 5, 1).unwrap().remove(0);
    for area in [
        [0.0, f64::NAN, 0.0, 240.0],
        [320.0, 0.0, 0.0, 240.0],
        [0.0, 320.0, 0.0, f64::INFINITY],
    ] {
        assert!(matches!(
            observe(&track, &Level::preset(1), area, 1, 0),
            Err(TrackError::InvalidParameter { name: "area", .. })
        ));
    }
    let ungm = Ungm {
        process_var: -1.0,
        ..Ungm::default()
    };
    assert!(ungm.generate(1, 5, 1).is_err());
    let ungm = Ungm {
        x0: f64::NAN,
        ..Ungm::default()
    };
    assert!(matches!(
        ungm.generate(1, 5, 1),
        Err(TrackError::NonFinite { .. })
    ));
    // The largest accepted rate still generates.
    let busy = bad_level(|l| l.clutter_rate = MAX_CLUTTER_RATE);
    assert_eq!(generate(&sc, &busy, 1, 1, 1).unwrap()[0].frames.len(), 1);
}

#[test]
fn kalman_refuses_non_finite_state_and_measurements() {
    use nalgebra::{Matrix4, Vector2, Vector4};
    let (_, train) = setup();
    let cal = Calibration::estimate(&train, 32.0).unwrap();
    let mut kf = KalmanTracker::new(KalmanParams::from_calibration(&cal)).unwrap();
    kf.reset([100.0, 80.0]).unwrap();
    let before = kf.clone();
    // Both used to be stored, and the next step estimated NaN.
    let x_nan = Vector4::new(1.0, f64::NAN, 0.0, 0.0);
    assert!(matches!(
        kf.set_state(x_nan, Matrix4::identity()),
        Err(TrackError::NonFinite {
            what: "Kalman state",
            ..
        })
    ));
    let mut p_inf = Matrix4::identity();
    p_inf[(2, 3)] = f64::INFINITY;
    assert!(matches!(
        kf.set_state(Vector4::zeros(), p_inf),
        Err(TrackError::NonFinite {
            what: "Kalman covariance",
            ..
        })
    ));
    assert!(matches!(
        kf.set_state(Vector4::zeros(), -Matrix4::identity()),
        Err(TrackError::InvalidParameter {
            name: "covariance diagonal",
            ..
        })
    ));
    assert!(matches!(
        kf.correct(Vector2::new(f64::NAN, 3.0)),
        Err(TrackError::NonFinite {
            what: "measurement",
            ..
        })
    ));
    assert_eq!(kf, before);
    kf.set_state(Vector4::new(1.0, 2.0, 0.5, 0.0), Matrix4::identity())
        .unwrap();
    kf.correct(Vector2::new(1.5, 2.0)).unwrap();
    assert!(kf.state().iter().all(|v| v.is_finite()));
}

/// A one-dimensional tracker (the second coordinate of a detection unused) on a sine track.
fn one_d_tracker() -> CbtTracker {
    let b = cbt_tracker::axis(0.0, 100.0, 5.0, cbt_tracker::DEFAULT_KERNEL).unwrap();
    let space = Space::new(vec![b.clone()], vec![b]).unwrap();
    let frames: Vec<TrainingFrame> = (0..200)
        .map(|k| {
            let x = 50.0 + 30.0 * (k as f64 * 0.1).sin();
            TrainingFrame {
                states: vec![[x, 0.0]],
                detections: vec![Detection::new(x + 0.5, 0.0)],
            }
        })
        .collect();
    let cfg = CbtConfig {
        order: Order::First,
        ..CbtConfig::default()
    };
    CbtTracker::new(CbtModel::learn(space, cfg, &[frames]).unwrap())
}

#[test]
fn step_on_grid_drops_off_grid_detections_in_one_dimension_whatever_their_y() {
    // The 1-D error reports y = 0, so a detection off the grid whose unused y was not 0 (or
    // NaN) was not recognised, and the whole frame failed with `OutsideGrid`.
    let mut t = one_d_tracker();
    t.reset([50.0, 0.0]).unwrap();
    for y in [7.0, -1.0, f64::NAN, 0.0] {
        let mut reference = t.clone();
        let expected = reference.step(&[Detection::new(52.0, y)]).unwrap();
        let dets = [
            Detection::new(1000.0, y),
            Detection::new(52.0, y),
            Detection::new(-3.0, 0.0),
        ];
        let (e, dropped) = cbt_tracker::step_on_grid(&mut t, &dets).unwrap();
        assert_eq!((e, dropped), (expected, 2), "y = {y}");
        assert_eq!(t, reference, "y = {y}");
    }
}

#[test]
fn training_statistics_refuse_non_finite_or_overflowing_data() {
    // A NaN truth made Calibration's accel_sigma silently 1e-6 (NaN.max(1e-6)) and Scales'
    // accel NaN; an infinite or huge one gave accel_sigma = ∞, which `validate` refuses.
    let (_, train) = setup();
    let mut nan_truth = train.clone();
    nan_truth[0].frames[10].truth = Some([f64::NAN, 3.0]);
    let mut infinite_detection = train.clone();
    infinite_detection[1].frames[3]
        .detections
        .push(Detection::new(5.0, f64::INFINITY));
    for edited in [nan_truth, infinite_detection] {
        assert!(matches!(
            Calibration::estimate(&edited, 32.0),
            Err(TrackError::NonFinite { .. })
        ));
        assert!(matches!(
            Scales::estimate(&edited, 320.0),
            Err(TrackError::NonFinite { .. })
        ));
    }
    let mut edited = train.clone();
    edited[0].frames[10].truth = Some([1e300, 3.0]);
    assert!(matches!(
        Calibration::estimate(&edited, 32.0),
        Err(TrackError::InvalidParameter {
            name: "accel_sigma",
            ..
        })
    ));
    assert!(matches!(
        Scales::estimate(&edited, 320.0),
        Err(TrackError::InvalidParameter { name: "accel", .. })
    ));
    Calibration::estimate(&train, 32.0)
        .unwrap()
        .validate()
        .unwrap();
}

#[test]
fn a_grid_too_fine_for_the_layout_is_an_error_not_an_abort() {
    // 10⁵ channels per axis: the separable layout's observation matrix alone would be 10¹⁰
    // numbers, an allocation that aborted the process (as a Python `CBT.learn` did).
    let space = Space::image(1e5, 1e5, 1.0).unwrap();
    let frame = TrainingFrame {
        states: vec![[10.0, 10.0]],
        detections: vec![Detection::new(10.5, 9.5)],
    };
    let seqs = vec![vec![frame.clone(), frame]];
    for layout in [Layout::Separable, Layout::SparseJoint] {
        let cfg = CbtConfig {
            layout,
            ..CbtConfig::default()
        };
        for r in [
            CbtModel::learn(space.clone(), cfg, &seqs).map(|_| ()),
            CbtModel::untrained(space.clone(), cfg).map(|_| ()),
        ] {
            match r {
                Err(TrackError::ModelTooLarge { layout: l, values }) => {
                    assert_eq!(l, layout);
                    assert!(values > MAX_MODEL_VALUES, "{values}");
                }
                other => panic!("{layout:?}: {other:?}"),
            }
        }
    }
    // The message says what to do.
    let e = CbtModel::untrained(space, CbtConfig::default()).unwrap_err();
    assert!(e.to_string().contains("coarser spacing"), "{e}");
}

/// A configuration field: its name, a setter, values it refuses and values it takes.
type RangeCase = (
    &'static str,
    fn(&mut CbtConfig, f64),
    &'static [f64],
    &'static [f64],
);

/// `CbtConfig::validate` checks every parameter's range: each out-of-range value is an
/// `InvalidParameter` naming its field (and the ends of each range are as documented: the
/// `[0, 1)` parameters take 0 and refuse 1, `obs_radius` takes 1..=64).
#[test]
fn every_configuration_range_is_checked_by_its_name() {
    let space = Space::image(100.0, 100.0, 10.0).unwrap();
    let base = CbtConfig::default();
    let cases: [RangeCase; 7] = [
        (
            "prior_weight",
            |c, v| c.prior_weight = v,
            &[0.0, -1.0, f64::NAN, f64::INFINITY],
            &[1e-9, 1e6],
        ),
        (
            "fallback_sigma",
            |c, v| c.fallback_sigma = v,
            &[0.0, -1.0, f64::NAN, f64::INFINITY],
            &[1e-3, 20.0],
        ),
        (
            "observation_floor",
            |c, v| c.observation_floor = v,
            &[1.0, -1e-9, f64::NAN, 2.0],
            &[0.0, 0.5],
        ),
        (
            "mixing",
            |c, v| c.mixing = v,
            &[1.0, -1e-9, f64::NAN, f64::INFINITY],
            &[0.0, 0.999],
        ),
        (
            "prune",
            |c, v| c.prune = v,
            &[1.0, -0.5, f64::NAN],
            &[0.0, 0.5],
        ),
        (
            "online_weight",
            |c, v| c.online_weight = v,
            &[0.0, -2.0, f64::NAN, f64::INFINITY],
            &[0.01, 5.0],
        ),
        (
            "support",
            |c, v| c.support = v,
            &[1.0, -0.1, f64::NAN],
            &[0.0, 0.2],
        ),
    ];
    for (name, set, bad, good) in cases {
        for &v in bad {
            let mut c = base;
            set(&mut c, v);
            for r in [
                c.validate(),
                CbtModel::untrained(space.clone(), c).map(|_| ()),
            ] {
                assert!(
                    matches!(r, Err(TrackError::InvalidParameter { name: n, .. }) if n == name),
                    "{name} = {v}: {r:?}"
                );
            }
        }
        for &v in good {
            let mut c = base;
            set(&mut c, v);
            assert!(c.validate().is_ok(), "{name} = {v}");
        }
    }
    for (r, ok) in [(0usize, false), (1, true), (64, true), (65, false)] {
        let c = CbtConfig {
            obs_radius: r,
            ..CbtConfig::stationary()
        };
        match c.validate() {
            Ok(()) => assert!(ok, "obs_radius = {r}"),
            Err(TrackError::InvalidParameter {
                name: "obs_radius", ..
            }) => assert!(!ok, "obs_radius = {r}"),
            Err(e) => panic!("obs_radius = {r}: {e}"),
        }
    }
}

/// A system fallback width far beyond the grid is a model (the displacement radius is capped)
/// and an infinite one an `InvalidParameter`, not an arithmetic overflow; an off-grid state in
/// stationary training is `OutsideGrid` however far off it lies.
#[test]
fn huge_fallback_widths_and_far_states_do_not_overflow() {
    let space = Space::image(100.0, 100.0, 10.0).unwrap();
    for layout in [Layout::Separable, Layout::Stationary] {
        let cfg = CbtConfig {
            layout,
            fallback_sigma: f64::INFINITY,
            ..CbtConfig::default()
        };
        // Used to panic with "attempt to add with overflow" before the range check.
        assert!(matches!(
            CbtModel::untrained(space.clone(), cfg),
            Err(TrackError::InvalidParameter {
                name: "fallback_sigma",
                ..
            })
        ));
    }
    for layout in [Layout::Separable, Layout::SparseJoint] {
        let huge = CbtConfig {
            layout,
            fallback_sigma: 1e300,
            ..CbtConfig::default()
        };
        assert!(
            CbtModel::untrained(space.clone(), huge).is_ok(),
            "{layout:?}"
        );
    }
    // The untrained stationary layout's kernels follow σ: too wide a σ is refused before the
    // allocation (which used to abort the process), a modest one is not.
    for sigma in [1e300, 1e4, 1400.0] {
        let huge = CbtConfig {
            fallback_sigma: sigma,
            ..CbtConfig::stationary()
        };
        assert!(
            matches!(
                CbtModel::untrained(space.clone(), huge),
                Err(TrackError::InvalidParameter {
                    name: "fallback_sigma",
                    ..
                })
            ),
            "σ = {sigma}"
        );
    }
    let modest = CbtConfig {
        fallback_sigma: 30.0,
        ..CbtConfig::stationary()
    };
    assert!(CbtModel::untrained(space.clone(), modest).is_ok());
    let walk: Vec<TrainingFrame> = (0..12)
        .map(|k| {
            let p = [20.0 + 3.0 * k as f64, 50.0];
            TrainingFrame {
                states: vec![p],
                detections: vec![Detection::new(p[0], p[1])],
            }
        })
        .collect();
    let stationary = CbtConfig {
        fallback_sigma: 1e300,
        ..CbtConfig::stationary()
    };
    assert!(CbtModel::learn(space.clone(), stationary, std::slice::from_ref(&walk)).is_ok());
    let mut far = walk;
    far[5].states = vec![[1e300, 50.0]];
    assert!(matches!(
        CbtModel::learn(space, CbtConfig::stationary(), &[far]),
        Err(TrackError::OutsideGrid { what: "state", .. })
    ));
}

/// The particle filter's models are checked when a filter is built: `P_D ∈ (0, 1]`, `λ > 0`,
/// positive noise and non-negative initial velocity spread (constant velocity), positive
/// variances and spread (UNGM); each refusal names its field.
#[test]
fn particle_filter_models_are_checked_by_field() {
    let good = PfModel::ConstantVelocity {
        accel_sigma: 1.0,
        meas_sigma: 2.0,
        p_detect: 0.9,
        clutter_density: 1e-4,
        init_vel_sigma: 3.0,
    };
    let cv = |f: fn(&mut [f64; 5])| {
        let mut v = [1.0, 2.0, 0.9, 1e-4, 3.0];
        f(&mut v);
        PfModel::ConstantVelocity {
            accel_sigma: v[0],
            meas_sigma: v[1],
            p_detect: v[2],
            clutter_density: v[3],
            init_vel_sigma: v[4],
        }
    };
    assert!(ParticleFilter::new(good, 10, 1).is_ok());
    for (ok, model) in [
        (true, cv(|v| v[2] = 1.0)),
        (true, cv(|v| v[4] = 0.0)),
        (false, cv(|v| v[2] = 0.0)),
    ] {
        assert_eq!(ParticleFilter::new(model, 10, 1).is_ok(), ok, "{model:?}");
    }
    let ungm = |process_var, meas_var, init_sigma| PfModel::Ungm {
        process_var,
        meas_var,
        init_sigma,
    };
    for (model, name) in [
        (cv(|v| v[0] = 0.0), "accel_sigma"),
        (cv(|v| v[1] = f64::NAN), "meas_sigma"),
        (cv(|v| v[2] = 0.0), "p_detect"),
        (cv(|v| v[2] = 1.5), "p_detect"),
        (cv(|v| v[3] = 0.0), "clutter_density"),
        (cv(|v| v[3] = f64::INFINITY), "clutter_density"),
        (cv(|v| v[4] = -1.0), "init_vel_sigma"),
        (ungm(0.0, 1.0, 1.0), "process_var"),
        (ungm(10.0, -1.0, 1.0), "meas_var"),
        (ungm(10.0, 1.0, 0.0), "init_sigma"),
    ] {
        let r = ParticleFilter::new(model, 10, 1);
        assert!(
            matches!(r, Err(TrackError::InvalidParameter { name: n, .. }) if n == name),
            "{name}: {r:?}"
        );
    }
}

/// `axis` refuses a spacing that is not finite and positive (`spacing`), a range that is not
/// finite with `hi > lo` (`range`), and more than a million channels on one axis (`spacing`),
/// before any basis is built; a million cells are accepted.
#[test]
fn axes_refuse_bad_ranges_and_more_than_a_million_channels() {
    use cbt_tracker::{DEFAULT_KERNEL, axis};
    for (lo, hi, spacing, name) in [
        (0.0, 10.0, 0.0, "spacing"),
        (0.0, 10.0, f64::NAN, "spacing"),
        (0.0, 10.0, -1.0, "spacing"),
        (10.0, 10.0, 1.0, "range"),
        (10.0, 0.0, 1.0, "range"),
        (f64::NAN, 10.0, 1.0, "range"),
        (0.0, f64::INFINITY, 1.0, "range"),
        (0.0, 1e6 + 1.0, 1.0, "spacing"),
        (0.0, 1.0, 1e-7, "spacing"),
    ] {
        let r = axis(lo, hi, spacing, DEFAULT_KERNEL);
        assert!(
            matches!(r, Err(TrackError::InvalidParameter { name: n, .. }) if n == name),
            "[{lo}, {hi}] at {spacing}: {r:?}"
        );
    }
    let b = axis(0.0, 1e6, 1.0, DEFAULT_KERNEL).unwrap();
    // One channel per cell plus the kernel's window less one.
    assert_eq!(b.len(), 1_000_000 + 2);
    assert!(b.spacing() <= 1.0);
}

/// Audit: `runner_ups` and `decode_radius` were unbounded. `runner_ups = usize::MAX` panicked
/// with "attempt to add with overflow" in both layouts' decoding (`runner_ups + 1`), and a
/// large one reserved that many hypotheses per step; `decode_radius = usize::MAX` became the
/// radius −1 (`as i64`), so the stationary estimate was a bare cell centre with certainty 0,
/// and `1 << 63` overflowed. Both are now `InvalidParameter`s naming the field.
#[test]
fn runner_ups_and_decode_radius_are_bounded() {
    let space = Space::image(100.0, 100.0, 10.0).unwrap();
    for (base, layout) in [
        (CbtConfig::default(), "separable"),
        (CbtConfig::stationary(), "stationary"),
    ] {
        for n in [usize::MAX, 1 << 40, cbt_tracker::MAX_RUNNER_UPS + 1] {
            let c = CbtConfig {
                runner_ups: n,
                ..base
            };
            for r in [
                c.validate(),
                CbtModel::untrained(space.clone(), c).map(|_| ()),
            ] {
                assert!(
                    matches!(
                        r,
                        Err(TrackError::InvalidParameter {
                            name: "runner_ups",
                            ..
                        })
                    ),
                    "{layout}: runner_ups = {n}: {r:?}"
                );
            }
        }
        for n in [usize::MAX, 1 << 63, (1 << 24) + 1] {
            let c = CbtConfig {
                decode_radius: n,
                ..base
            };
            assert!(
                matches!(
                    c.validate(),
                    Err(TrackError::InvalidParameter {
                        name: "decode_radius",
                        ..
                    })
                ),
                "{layout}: decode_radius = {n}"
            );
        }
        let widest = CbtConfig {
            runner_ups: cbt_tracker::MAX_RUNNER_UPS,
            decode_radius: 1 << 24,
            ..base
        };
        assert!(widest.validate().is_ok(), "{layout}");
    }
}

/// A 1-D model with a periodic input (its tracker counts a time index).
fn periodic_model() -> CbtModel {
    use cbt_tracker::{DEFAULT_KERNEL, ObservationFallback, PeriodicInput, axis};
    let state = axis(-30.0, 30.0, 2.0, DEFAULT_KERNEL).unwrap();
    let meas = axis(-5.0, 50.0, 2.0, DEFAULT_KERNEL).unwrap();
    let cfg = CbtConfig {
        order: Order::First,
        observation_fallback: ObservationFallback::Uniform,
        input: Some(PeriodicInput {
            omega: 1.2,
            channels: 12,
        }),
        ..CbtConfig::default()
    };
    let mut train = cbt_tracker::sim::Ungm::default()
        .generate(4, 40, 3)
        .unwrap();
    for f in train.iter_mut().flat_map(|s| &mut s.frames) {
        if let Some(t) = f.truth.as_mut() {
            t[0] = t[0].clamp(-29.0, 29.0);
        }
        for d in &mut f.detections {
            d.pos[0] = d.pos[0].clamp(-4.0, 49.0);
        }
    }
    let space = Space::new(vec![state], vec![meas]).unwrap();
    CbtModel::learn_sequences(space, cfg, &train).unwrap()
}

/// Audit: a tracker's time index (periodic input) could be set to `u64::MAX`, where the
/// next prediction's `time + 1` panicked with "attempt to add with overflow" (`predict`,
/// `step`; a release build wrapped to the phase of time 0). The index now stays below
/// `u64::MAX`: `set_time(u64::MAX)` is refused, and a step that would reach it is refused
/// and leaves the tracker unchanged.
#[test]
fn the_time_index_stays_below_its_largest_value() {
    let mut t = CbtTracker::new(periodic_model());
    t.reset([0.1, 0.0]).unwrap();
    let dets = [Detection::new(3.0, 0.0)];
    t.set_time(7).unwrap();
    assert!(matches!(
        t.set_time(u64::MAX),
        Err(TrackError::InvalidParameter { name: "time", .. })
    ));
    assert_eq!(t.time(), 7);
    assert_eq!(t.predict().len(), t.model().space().cells());
    t.set_time(u64::MAX - 2).unwrap();
    t.step(&dets).unwrap();
    assert_eq!(t.time(), u64::MAX - 1);
    let before = t.clone();
    let json = serde_json::to_string(&t).unwrap();
    assert_eq!(t.predict().len(), t.model().space().cells());
    for r in [t.step(&dets).map(drop), t.filter(&dets)] {
        assert!(
            matches!(r, Err(TrackError::InvalidParameter { name: "time", .. })),
            "{r:?}"
        );
        assert!(t == before);
        assert_eq!(serde_json::to_string(&t).unwrap(), json);
    }
    // A saved tracker at the largest index does not load.
    let text = json.replace(
        &format!("\"time\":{}", u64::MAX - 1),
        &format!("\"time\":{}", u64::MAX),
    );
    assert_ne!(text, json);
    let e = serde_json::from_str::<CbtTracker>(&text).unwrap_err();
    assert!(e.to_string().contains("time"), "{e}");
}

/// Audit: a density whose values are each finite but whose sum overflows to ∞ passed
/// `reset_to`'s checks and was divided by ∞: a posterior of zeros, silently. It is now an
/// `InvalidParameter` and the tracker is unchanged.
#[test]
fn reset_to_refuses_a_density_whose_mass_overflows() {
    let (model, train) = setup();
    let sc = Scenario::default();
    let stat_space = Space::image(sc.width, sc.height, 4.0).unwrap();
    let stat = CbtModel::learn_sequences(stat_space, CbtConfig::stationary(), &train).unwrap();
    for m in [model, stat] {
        let mut t = CbtTracker::new(m);
        t.reset([100.0, 100.0]).unwrap();
        let before = t.clone();
        let huge = vec![f64::MAX / 2.0; t.model().space().cells()];
        let r = t.reset_to(&huge);
        assert!(
            matches!(
                r,
                Err(TrackError::InvalidParameter {
                    name: "density",
                    ..
                })
            ),
            "{r:?}"
        );
        assert!(t == before);
        // A large mass that fits is a density like any other.
        let mut big = vec![0.0; t.model().space().cells()];
        big[40] = f64::MAX / 2.0;
        t.reset_to(&big).unwrap();
        assert!((t.posterior().iter().sum::<f64>() - 1.0).abs() < 1e-12);
    }
}

/// Audit: the generators collected `count` sequences into a vector reserved up front, so a
/// huge count panicked with "capacity overflow" (or aborted on the allocation), and a huge
/// frame count ran until memory ran out. Both are now bounded by `MAX_FRAMES` in total.
#[test]
fn generators_refuse_more_frames_than_they_can_hold() {
    use cbt_tracker::sim::{MAX_FRAMES, Ungm, generate_one};
    let sc = Scenario::default();
    let level = Level::preset(0);
    let refused = |r: Result<usize, TrackError>| {
        assert!(
            matches!(r, Err(TrackError::InvalidParameter { name: "frames", .. })),
            "{r:?}"
        );
    };
    refused(generate(&sc, &level, usize::MAX, 0, 1).map(|s| s.len()));
    refused(generate(&sc, &level, usize::MAX, 2, 1).map(|s| s.len()));
    refused(Ungm::default().generate(usize::MAX, 0, 1).map(|s| s.len()));
    refused(generate(&sc, &level, 2, MAX_FRAMES / 2 + 1, 1).map(|s| s.len()));
    refused(
        Ungm::default()
            .generate(1, MAX_FRAMES + 1, 1)
            .map(|s| s.len()),
    );
    refused(generate_one(&sc, &level, MAX_FRAMES + 1, 1, 0).map(|s| s.frames.len()));
    assert_eq!(generate(&sc, &level, 3, 0, 1).unwrap().len(), 3);
}

/// Audit: `observe` checked that its area is finite but not its width, so
/// `[-1e308, 1e308]` drew clutter at ±∞ (its width overflows) without an error.
#[test]
fn observe_refuses_an_area_whose_width_overflows() {
    use cbt_tracker::sim::observe;
    let sc = Scenario::default();
    let track = generate(&sc, &Level::preset(0), 1, 20, 1)
        .unwrap()
        .remove(0);
    for area in [
        [-1e308, 1e308, 0.0, 240.0],
        [0.0, 320.0, -f64::MAX, f64::MAX],
    ] {
        let r = observe(&track, &Level::preset(4), area, 1, 0);
        assert!(
            matches!(r, Err(TrackError::InvalidParameter { name: "area", .. })),
            "{area:?}: {:?}",
            r.map(|s| s
                .frames
                .iter()
                .flat_map(|f| f.detections.clone())
                .find(|d| !d.pos[0].is_finite() || !d.pos[1].is_finite()))
        );
    }
}

/// Audit: `Space::cell_centre` of a cell past the grid wrapped around it (cell `G` gave the
/// centre of cell 0); it now panics like slice indexing, as documented.
#[test]
#[should_panic(expected = "outside the grid")]
fn cell_centre_past_the_grid_panics() {
    let s = Space::image(96.0, 72.0, 8.0).unwrap();
    assert_eq!(s.cell_centre(0), [-4.0, -4.0]);
    let _ = s.cell_centre(s.cells());
}

/// Audit: a periodic input's frequency was only required to be finite and positive; with
/// `ω = 1e308` the phase `ω·k` is ∞ from `k = 2` on, the phase weights come out empty and every
/// prediction was the uniform one, silently. `ω·k` must now be finite for every `u64` `k`.
#[test]
fn a_periodic_input_whose_phase_overflows_is_refused() {
    use cbt_tracker::PeriodicInput;
    for omega in [1e308, 1e290] {
        let input = PeriodicInput {
            omega,
            channels: 12,
        };
        assert!(
            matches!(
                input.validate(),
                Err(TrackError::InvalidParameter {
                    name: "input omega",
                    ..
                })
            ),
            "ω = {omega}: weights(2) = {:?}",
            input.weights(2)
        );
    }
    let fine = PeriodicInput {
        omega: 1e280,
        channels: 12,
    };
    fine.validate().unwrap();
    assert!(!fine.weights(u64::MAX).is_empty());
}

/// Audit: the sparse joint layout's fallback Gaussians (one per channel of each axis, up to
/// `2⌈3σ⌉ + 1` values each) were left out of the size check, so a long state axis with a
/// short measurement axis and a wide `fallback_sigma` passed it and then allocated
/// `N · min(N, 6σ)` numbers (here about 2.9 · 10⁸, over `MAX_MODEL_VALUES`; more channels
/// or a wider σ aborted the process). Learning, an untrained model and a model read back with
/// serde now refuse it as `ModelTooLarge`.
#[test]
fn sparse_joint_fallback_gaussians_count_towards_the_size_limit() {
    use cbt_tracker::{DEFAULT_KERNEL, axis};
    let state = axis(0.0, 16_998.0, 1.0, DEFAULT_KERNEL).unwrap();
    let meas = axis(0.0, 1.0, 1.0, DEFAULT_KERNEL).unwrap();
    let space = Space::new(vec![state], vec![meas]).unwrap();
    let narrow = CbtConfig {
        layout: Layout::SparseJoint,
        order: Order::First,
        ..CbtConfig::default()
    };
    let wide = CbtConfig {
        fallback_sigma: 1e4,
        ..narrow
    };
    match CbtModel::untrained(space.clone(), wide) {
        Err(TrackError::ModelTooLarge { values, .. }) => assert!(values > MAX_MODEL_VALUES),
        other => panic!("{:?}", other.map(|m| m.space().axis_len(0))),
    }
    // The same space with a narrow σ fits, and its file edited to the wide σ is refused.
    let m = CbtModel::untrained(space, narrow).unwrap();
    let mut v = serde_json::to_value(&m).unwrap();
    v["config"]["fallback_sigma"] = serde_json::Value::from(1e4);
    let e = serde_json::from_value::<CbtModel>(v)
        .map(|_| ())
        .unwrap_err();
    assert!(e.to_string().contains("SparseJoint"), "{e}");
}
