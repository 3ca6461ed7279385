//! Bad input: typed errors that leave the model exactly as it was; outliers; determinism.

use crate::harness;

use harness::*;
use lwpr::{Kernel, Lwpr, LwprBuilder, LwprError, MAX_ABS_VALUE};

fn model() -> Lwpr {
    LwprBuilder::new(2, 2)
        .init_d_spherical(30.0)
        .w_gen(0.2)
        .norm_in(&[1.0, 2.0])
        .build()
        .unwrap()
}

fn good(i: usize) -> ([f64; 2], [f64; 2]) {
    let a = ((i * 37) % 101) as f64 / 50.0 - 1.0;
    let b = ((i * 61) % 103) as f64 / 51.0 - 1.0;
    ([a, b], [cross(a, b), a * b])
}

#[test]
fn bad_samples_between_good_ones_change_nothing() {
    let (mut clean, mut dirty) = (model(), model());
    let bad_x: Vec<Vec<f64>> = vec![
        vec![f64::NAN, 0.0],
        vec![0.0, f64::INFINITY],
        vec![f64::NEG_INFINITY, 1.0],
        vec![0.0],
        vec![0.0, 0.0, 0.0],
        vec![],
    ];
    for i in 0..3000 {
        let (x, y) = good(i);
        let a = clean.update(&x, &y).unwrap();
        let k = i % bad_x.len();
        // A bad x with a good y, a good x with a bad y, and wrong output lengths.
        assert!(dirty.update(&bad_x[k], &y).is_err());
        assert!(matches!(
            dirty.update(&x, &[f64::NAN, 0.0]),
            Err(LwprError::NonFinite {
                what: "y",
                index: 0
            })
        ));
        assert!(matches!(
            dirty.update(&x, &[0.0]),
            Err(LwprError::DimensionMismatch {
                what: "y",
                expected: 2,
                got: 1
            })
        ));
        let mut short = [0.0; 1];
        assert!(dirty.update_into(&x, &y, &mut short).is_err());
        let b = dirty.update(&x, &y).unwrap();
        assert_eq!(a, b, "sample {i}");
    }
    assert_eq!(clean, dirty);
    assert_eq!(clean.to_binary(), dirty.to_binary());
    assert!(clean.num_rfs()[0] > 5);
}

#[test]
fn normalised_overflow_is_rejected() {
    let mut m = LwprBuilder::new(1, 1).norm_in(&[1e-300]).build().unwrap();
    let before = m.clone();
    assert!(matches!(
        m.update(&[1e10], &[0.0]),
        Err(LwprError::TooLarge {
            what: "x / norm_in",
            ..
        })
    ));
    assert_eq!(m, before);
    assert_eq!(m.n_data(), 0);
}

#[test]
fn predict_validates_arguments() {
    let m = model();
    assert!(matches!(
        m.predict(&[0.0], 0.001),
        Err(LwprError::DimensionMismatch { what: "x", .. })
    ));
    assert!(matches!(
        m.predict(&[f64::NAN, 0.0], 0.001),
        Err(LwprError::NonFinite { what: "x", .. })
    ));
    assert!(matches!(
        m.predict(&[0.0, 0.0], f64::NAN),
        Err(LwprError::NonFinite { what: "cutoff", .. })
    ));
    assert!(m.predict_with_jacobian(&[0.0], 0.001).is_err());
    assert!(
        m.predict_with_confidence(&[0.0, f64::INFINITY], 0.001)
            .is_err()
    );
    assert!(m.predict_batch(&[0.0, 0.0, 0.0], 0.001).is_err());
    assert!(m.predict_batch(&[0.0, 0.0, f64::NAN, 0.0], 0.001).is_err());
    let mut out = [0.0; 3];
    assert!(m.predict_into(&[0.0, 0.0], 0.001, &mut out).is_err());
}

#[test]
fn empty_model_predicts_zero_with_infinite_confidence() {
    let m = model();
    assert_eq!(m.predict(&[0.3, 0.1], 0.001).unwrap(), vec![0.0, 0.0]);
    let c = m.predict_with_confidence(&[0.3, 0.1], 0.001).unwrap();
    assert_eq!(c.y, vec![0.0, 0.0]);
    assert!(c.confidence.iter().all(|v| v.is_infinite()));
    let j = m.predict_with_jacobian(&[0.3, 0.1], 0.001).unwrap();
    assert_eq!(j.jacobian.shape(), (2, 2));
    assert!(j.jacobian.iter().all(|&v| v == 0.0));
    assert_eq!(m.predict_batch(&[], 0.001).unwrap(), Vec::<f64>::new());
}

#[test]
fn invalid_parameters_are_named() {
    let name = |b: LwprBuilder| match b.build() {
        Err(LwprError::InvalidParameter { name, .. }) => name,
        other => panic!("expected InvalidParameter, got {other:?}"),
    };
    let b = || LwprBuilder::new(2, 1);
    assert_eq!(name(LwprBuilder::new(0, 1)), "n_in");
    assert_eq!(name(LwprBuilder::new(2, 0)), "n_out");
    assert_eq!(name(b().init_d_spherical(0.0)), "init_D");
    assert_eq!(name(b().init_d_spherical(f64::NAN)), "init_D");
    assert_eq!(name(b().init_d_diagonal(&[1.0])), "init_D");
    // A size refused on the spot is kept, whatever valid value is set after it.
    for late in [
        b().init_d_diagonal(&[1.0]).init_d_spherical(1.0),
        b().init_d_diagonal(&[1.0]).init_d(&[1.0, 0.0, 0.0, 1.0]),
        b().init_d_diagonal(&[1.0]).init_d_diagonal(&[1.0, 1.0]),
    ] {
        assert_eq!(name(late), "init_D");
    }
    assert_eq!(name(LwprBuilder::new(0, 1).init_alpha(10.0)), "n_in");
    assert_eq!(name(b().init_d(&[1.0, 0.5, 0.5, 1.0])), "init_D"); // not diagonal with diag_only
    assert!(
        b().init_d(&[1.0, 0.5, 0.5, 1.0])
            .diag_only(false)
            .build()
            .is_ok()
    );
    assert_eq!(
        name(b().init_d(&[1.0, 2.0, 2.0, 1.0]).diag_only(false)),
        "init_D"
    ); // indefinite
    assert_eq!(
        name(b().init_d(&[1.0, 0.5, 0.4, 1.0]).diag_only(false)),
        "init_D"
    ); // asymmetric
    assert_eq!(name(b().init_alpha(-1.0)), "init_alpha");
    assert_eq!(name(b().w_gen(0.0)), "w_gen");
    assert_eq!(name(b().w_gen(1.0)), "w_gen");
    assert_eq!(name(b().w_prune(0.0)), "w_prune");
    assert_eq!(name(b().init_lambda(1.5)), "init_lambda");
    assert_eq!(name(b().final_lambda(0.0)), "final_lambda");
    assert_eq!(name(b().tau_lambda(-0.1)), "tau_lambda");
    assert_eq!(name(b().init_s2(0.0)), "init_S2");
    assert_eq!(name(b().add_threshold(f64::INFINITY)), "add_threshold");
    assert_eq!(name(b().penalty(-1.0)), "penalty");
    assert_eq!(name(b().meta_rate(0.0)), "meta_rate");
    assert_eq!(name(b().norm_in(&[1.0])), "norm_in");
    assert_eq!(name(b().norm_in(&[1.0, 0.0])), "norm_in");
    assert_eq!(name(b().norm_out(&[-1.0])), "norm_out");
}

#[test]
fn defaults_are_the_reference_defaults() {
    let m = LwprBuilder::new(3, 1).build().unwrap();
    let p = m.params();
    assert_eq!(
        p.init_d,
        vec![25.0, 0.0, 0.0, 0.0, 25.0, 0.0, 0.0, 0.0, 25.0]
    );
    assert_eq!(p.init_m[0], 5.0);
    assert!(p.init_alpha.iter().all(|&a| a == 50.0));
    assert_eq!((p.w_gen, p.w_prune), (0.1, 1.0));
    assert_eq!(
        (p.init_lambda, p.final_lambda, p.tau_lambda),
        (0.999, 0.99999, 0.9999)
    );
    assert_eq!(
        (p.init_s2, p.add_threshold, p.penalty, p.meta_rate),
        (1e-10, 0.5, 1e-6, 250.0)
    );
    assert!(p.diag_only && p.update_d && !p.meta);
    assert_eq!(p.kernel, Kernel::Gaussian);
    assert_eq!(p.prune_rule, lwpr::PruneRule::ReferenceC);
}

#[test]
fn outliers_of_1e6_produce_no_nan() {
    for kernel in [Kernel::Gaussian, Kernel::BiSquare] {
        let mut m = setting_a_builder(2)
            .diag_only(false)
            .meta(true)
            .kernel(kernel)
            .build()
            .unwrap();
        let (x, y) = cross_samples(9, 5000, 0.1);
        for (i, (a, b)) in x.chunks(2).zip(&y).enumerate() {
            let yy = if i % 7 == 3 {
                if i % 2 == 0 { 1e6 } else { -1e6 }
            } else {
                *b
            };
            let yp = m.update(a, &[yy]).unwrap();
            assert!(yp[0].is_finite(), "update {i} predicted {}", yp[0]);
        }
        // Loading checks every stored number for finiteness.
        Lwpr::from_binary(&m.to_binary()).expect("model holds only finite numbers");
        let (gx, _) = cross_grid();
        for x in gx.chunks(2) {
            assert!(m.predict(x, 0.001).unwrap()[0].is_finite());
            let j = m.predict_with_jacobian(x, 0.001).unwrap();
            assert!(j.jacobian.iter().all(|v| v.is_finite()));
            let c = m.predict_with_confidence(x, 0.001).unwrap();
            assert!(!c.confidence[0].is_nan());
        }
    }
}

#[test]
fn training_is_deterministic_and_batch_prediction_thread_independent() {
    let train = || {
        let mut m = model();
        for i in 0..2000 {
            let (x, y) = good(i);
            m.update(&x, &y).unwrap();
        }
        m
    };
    let (a, b) = (train(), train());
    assert_eq!(a.to_binary(), b.to_binary());
    let (gx, _) = cross_grid();
    let single: Vec<f64> = gx
        .chunks(2)
        .flat_map(|x| a.predict(x, 0.001).unwrap())
        .collect();
    for threads in [1, 2, 3] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let batch = pool.install(|| a.predict_batch(&gx, 0.001).unwrap());
        assert!(
            batch
                .iter()
                .zip(&single)
                .all(|(p, q)| p.to_bits() == q.to_bits()),
            "{threads} threads"
        );
    }
}

#[test]
fn inspection_reports_fields() {
    let mut m = model();
    for i in 0..500 {
        let (x, y) = good(i);
        m.update(&x, &y).unwrap();
    }
    assert_eq!(m.n_data(), 500);
    let rfs = m.receptive_fields(0);
    assert_eq!(rfs.len(), m.num_rfs()[0]);
    assert!(m.receptive_fields(5).is_empty());
    for rf in &rfs {
        let c = rf.centre();
        // Centres are in input units: inputs live in [-1, 1]².
        assert!(c.iter().all(|v| (-1.0..=1.0).contains(v)), "{c:?}");
        assert!((1..=2).contains(&rf.pls_dims()));
        assert_eq!(rf.metric().len(), 4);
        assert_eq!(rf.metric()[1], 0.0, "diagonal metric");
    }
    assert!(rfs.iter().any(|r| r.trustworthy()));
    assert!(m.var_x().iter().all(|&v| v > 0.1));
}

#[test]
fn pruning_rules_remove_the_documented_field() {
    for (rule, survivor) in [
        (lwpr::PruneRule::Published, 0.6),
        (lwpr::PruneRule::ReferenceC, 0.0),
    ] {
        let mut m = LwprBuilder::new(1, 1)
            .w_gen(0.5)
            .w_prune(0.3)
            .update_d(false)
            .prune_rule(rule)
            .build()
            .unwrap();
        m.update(&[0.0], &[0.0]).unwrap(); // field at 0 with D = 25
        m.update(&[0.6], &[0.0]).unwrap(); // activation exp(-4.5) < w_gen: field at 0.6
        assert_eq!(m.num_rfs(), vec![2]);
        // Make the field at 0.6 wider (D = 4) through the serialised form.
        let mut v: serde_json::Value = serde_json::from_str(&m.to_json()).unwrap();
        let rf = &mut v["model"]["sub"][0]["rfs"][1];
        rf["d"] = serde_json::json!([4.0]);
        rf["m"] = serde_json::json!([2.0]);
        let mut m = Lwpr::from_json(&v.to_string()).unwrap();
        // At 0.15 both activations (0.75 and 0.67) exceed w_prune.
        m.update(&[0.15], &[0.0]).unwrap();
        assert_eq!(m.num_rfs(), vec![1], "{rule:?}");
        assert_eq!(m.num_pruned(), vec![1]);
        assert_eq!(
            m.receptive_fields(0)[0].centre(),
            vec![survivor],
            "{rule:?}"
        );
    }
}

#[test]
fn input_statistics_follow_the_documented_recurrence() {
    // `mean_x` is the exact running mean; `var_x` the reference's running estimate
    // v ← (k·v + (x − x̄_new)²)/(k + 1), which for 0, 2, 4 is 5/3 (the population variance
    // would be 8/3).
    let mut m = LwprBuilder::new(2, 1).build().unwrap();
    let mut expected = [(0.0, 0.0); 2];
    for (k, x) in [[0.0, -1.0], [2.0, 3.0], [4.0, 0.5]].iter().enumerate() {
        m.update(x, &[0.0]).unwrap();
        for (i, e) in expected.iter_mut().enumerate() {
            let kf = k as f64;
            let mean = (e.0 * kf + x[i]) / (kf + 1.0);
            let var = (e.1 * kf + (x[i] - mean).powi(2)) / (kf + 1.0);
            *e = (mean, var);
        }
    }
    assert_eq!(m.n_data(), 3);
    for (i, &(mean, var)) in expected.iter().enumerate() {
        assert!((m.mean_x()[i] - mean).abs() < 1e-12, "mean_x[{i}]");
        assert!((m.var_x()[i] - var).abs() < 1e-12, "var_x[{i}]");
    }
    assert!((m.mean_x()[0] - 2.0).abs() < 1e-12);
    assert!((m.var_x()[0] - 5.0 / 3.0).abs() < 1e-12);
}

#[test]
fn fields_at_exactly_the_cutoff_are_ignored() {
    // "receptive fields with activation ≤ cutoff are ignored": with one field, a cutoff equal
    // to its activation leaves no active field (prediction 0, Jacobian 0, confidence ∞) and
    // the next smaller cutoff keeps it.
    let mut m = LwprBuilder::new(1, 1)
        .init_d_spherical(0.01)
        .build()
        .unwrap();
    for i in 0..400 {
        let x = (i % 100) as f64 / 100.0;
        m.update(&[x], &[2.0 * x + 1.0]).unwrap();
    }
    assert_eq!(m.num_rfs(), vec![1]);
    let x = [0.7];
    let (y, w) = m.predict_with_max_activation(&x, 0.001).unwrap();
    let w = w[0];
    assert!(w > 0.001 && w < 1.0, "activation {w}");
    assert!((y[0] - 2.4).abs() < 0.1, "{y:?}");

    assert_eq!(m.predict(&x, w).unwrap(), vec![0.0]);
    let c = m.predict_with_confidence(&x, w).unwrap();
    assert_eq!(c.y, vec![0.0]);
    assert!(c.confidence[0].is_infinite());
    let j = m.predict_with_jacobian(&x, w).unwrap();
    assert_eq!(j.y, vec![0.0]);
    assert_eq!(j.jacobian[(0, 0)], 0.0);

    let below = w.next_down();
    assert_eq!(m.predict(&x, below).unwrap(), y);
    assert!(m.predict_with_confidence(&x, below).unwrap().confidence[0].is_finite());
    assert_eq!(m.predict_with_jacobian(&x, below).unwrap().y, y);
}

#[test]
fn field_views_report_input_units_and_the_metric_factor() {
    // A new field is centred at the sample that created it; `centre` reports it in input units
    // whatever `norm_in` (the field stores it normalised).
    let mut m = LwprBuilder::new(2, 1)
        .norm_in(&[4.0, 0.5])
        .diag_only(false)
        .init_d(&[30.0, 5.0, 5.0, 20.0])
        .build()
        .unwrap();
    m.update(&[2.0, -1.0], &[0.5]).unwrap();
    assert_eq!(m.receptive_fields(0)[0].centre(), vec![2.0, -1.0]);
    for i in 0..300 {
        let (x, y) = good(i);
        m.update(&[4.0 * x[0], 0.5 * x[1]], &[y[0]]).unwrap();
    }
    // `metric_factor` is the upper-triangular M of `metric` D = MᵀM (column-major).
    for rf in m.receptive_fields(0) {
        let (d, f) = (rf.metric(), rf.metric_factor());
        assert_eq!(f[1], 0.0, "M is upper triangular: {f:?}");
        for i in 0..2 {
            for j in 0..2 {
                let mtm: f64 = (0..2).map(|k| f[k + i * 2] * f[k + j * 2]).sum();
                let scale = (d[i + i * 2] * d[j + j * 2]).sqrt();
                assert!(
                    (d[i + j * 2] - mtm).abs() <= 1e-9 * scale,
                    "D = {d:?}, M = {f:?}"
                );
            }
        }
    }
}

#[test]
fn refused_calls_leave_the_callers_output_buffers_unchanged() {
    // `update_into` and `predict_into` write into the caller's buffer: a refused call must
    // leave it (as well as the model) exactly as it was, whichever argument is refused.
    let mut m = model();
    for i in 0..300 {
        let (x, y) = good(i);
        m.update(&x, &y).unwrap();
    }
    let (x, y) = good(300);
    let sentinel = [7.25, -3.5, 11.0];
    let bits = |v: &[f64]| v.iter().map(|a| a.to_bits()).collect::<Vec<_>>();

    // (x, y, length of y_pred): each refused by `update_into`.
    let updates: Vec<(Vec<f64>, Vec<f64>, usize)> = vec![
        (vec![f64::NAN, 0.1], y.to_vec(), 2),
        (vec![0.1, f64::INFINITY], y.to_vec(), 2),
        (vec![0.1], y.to_vec(), 2),
        (vec![0.1, 0.2, 0.3], y.to_vec(), 2),
        (x.to_vec(), vec![0.5, f64::NAN], 2),
        (x.to_vec(), vec![0.5], 2),
        (x.to_vec(), vec![0.5, 0.5, 0.5], 2),
        (vec![2.0 * MAX_ABS_VALUE, 0.1], y.to_vec(), 2),
        (x.to_vec(), vec![0.5, -2.0 * MAX_ABS_VALUE], 2),
        (x.to_vec(), y.to_vec(), 1),
        (x.to_vec(), y.to_vec(), 3),
    ];
    let before = m.clone();
    for (bx, by, len) in &updates {
        let mut out = sentinel[..*len].to_vec();
        assert!(
            m.update_into(bx, by, &mut out).is_err(),
            "{bx:?} {by:?} {len}"
        );
        assert_eq!(bits(&out), bits(&sentinel[..*len]), "{bx:?} {by:?} {len}");
        assert_eq!(m, before, "{bx:?} {by:?} {len}");
    }

    // (x, cutoff, length of out): each refused by `predict_into`.
    let predictions: Vec<(Vec<f64>, f64, usize)> = vec![
        (vec![f64::NAN, 0.1], 0.001, 2),
        (vec![0.1, f64::NEG_INFINITY], 0.001, 2),
        (vec![0.1], 0.001, 2),
        (vec![0.1, 0.2, 0.3], 0.001, 2),
        (x.to_vec(), f64::NAN, 2),
        (x.to_vec(), f64::INFINITY, 2),
        (x.to_vec(), 0.001, 1),
        (x.to_vec(), 0.001, 3),
    ];
    for (bx, cutoff, len) in &predictions {
        let mut out = sentinel[..*len].to_vec();
        assert!(
            m.predict_into(bx, *cutoff, &mut out).is_err(),
            "{bx:?} {cutoff} {len}"
        );
        assert_eq!(bits(&out), bits(&sentinel[..*len]), "{bx:?} {cutoff} {len}");
    }

    // The buffers still receive what a model that never saw the refused calls gives.
    let mut twin = before.clone();
    let (mut a, mut b) = ([0.0; 2], [0.0; 2]);
    m.update_into(&x, &y, &mut a).unwrap();
    twin.update_into(&x, &y, &mut b).unwrap();
    assert_eq!(bits(&a), bits(&b));
    m.predict_into(&x, 0.001, &mut a).unwrap();
    twin.predict_into(&x, 0.001, &mut b).unwrap();
    assert_eq!(bits(&a), bits(&b));
    assert_eq!(m, twin);
}

/// `check_sample` refuses exactly what `update` refuses, with the same error, and `update`
/// accepts what it accepts: the one home of a sample's checks, for callers that refuse a batch
/// before learning any of it.
#[test]
fn check_sample_refuses_what_update_refuses() {
    let mut m = LwprBuilder::new(2, 1)
        .norm_in(&[1e-10, 1.0])
        .build()
        .unwrap();
    let samples: [(&[f64], &[f64]); 9] = [
        (&[0.1, 0.2], &[0.3]),
        (&[0.1], &[0.3]),
        (&[0.1, 0.2], &[0.3, 0.4]),
        (&[f64::NAN, 0.2], &[0.3]),
        (&[0.1, 0.2], &[f64::INFINITY]),
        (&[1e31, 0.2], &[0.3]),
        (&[1e21, 0.2], &[0.3]),
        (&[0.1, 1e21], &[0.3]),
        (&[0.1, 0.2], &[-1e31]),
    ];
    for (x, y) in samples {
        let checked = m.check_sample(x, y).map_err(|e| e.to_string());
        let updated = m.update(x, y).map(drop).map_err(|e| e.to_string());
        assert_eq!(checked, updated, "{x:?} {y:?}");
    }
}
