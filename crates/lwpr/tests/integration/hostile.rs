//! Issue 24's reproductions for this crate (#4 plain serde, #5 huge finite samples, #6
//! inconsistent loaded models, #7 size limits): each was a panic, a poisoned model or an
//! unbounded allocation, and is now a typed error that leaves everything as it was.

use crate::harness;

use harness::*;
use lwpr::{Lwpr, LwprBuilder, LwprError, MAX_ABS_VALUE, MAX_INPUTS, MAX_OUTPUTS};
use serde_json::{Value, json};

/// A 2-D model with a full metric and meta learning, trained on the cross function.
fn trained(full: bool) -> Lwpr {
    let mut m = LwprBuilder::new(2, 1)
        .init_d_spherical(40.0)
        .w_gen(0.2)
        .diag_only(!full)
        .meta(full)
        .build()
        .unwrap();
    let (x, y) = cross_samples(3, 800, 0.05);
    train(&mut m, &x, &y).unwrap();
    m
}

/// The model part of `to_json`'s envelope.
fn model_json(m: &Lwpr) -> Value {
    let v: Value = serde_json::from_str(&m.to_json()).unwrap();
    v["model"].clone()
}

/// The first receptive field of the first output.
fn rf(v: &mut Value) -> &mut Value {
    &mut v["sub"][0]["rfs"][0]
}

/// Loads an edited model through both routes: `from_json` and plain serde.
fn load_both(model: &Value) -> (Result<Lwpr, LwprError>, Result<Lwpr, serde_json::Error>) {
    let env = json!({"format": "lwpr-rs", "version": lwpr::BINARY_FORMAT_VERSION, "model": model});
    (
        Lwpr::from_json(&env.to_string()),
        serde_json::from_value::<Lwpr>(model.clone()),
    )
}

#[test]
fn plain_serde_validates_and_the_loaded_model_predicts() {
    // #4: a valid model read with plain serde used to lack its derived data (slopes,
    // workspace) and panic in `predict`.
    let m = trained(true);
    let text = serde_json::to_string(&m).unwrap();
    let mut back: Lwpr = serde_json::from_str(&text).unwrap();
    assert_eq!(back, m);
    let (gx, _) = cross_grid();
    assert_eq!(
        back.predict_batch(&gx, 0.001).unwrap(),
        m.predict_batch(&gx, 0.001).unwrap()
    );
    back.update(&[0.1, 0.2], &[0.3]).unwrap();
    // … and an invalid one is refused by plain serde as by `from_json`.
    let mut v: Value = serde_json::from_str(&text).unwrap();
    v["params"]["w_gen"] = json!(1.5);
    assert!(serde_json::from_value::<Lwpr>(v.clone()).is_err());
    assert!(serde_json::from_value::<lwpr::Params>(v["params"].clone()).is_err());
    let ok: lwpr::Params = serde_json::from_value(model_json(&m)["params"].clone()).unwrap();
    assert_eq!(&ok, m.params());
}

#[test]
fn huge_finite_samples_are_refused_and_change_nothing() {
    // #5: `update([1e200, 0], [0])` made var_x infinite (the saved model no longer loaded);
    // `y = 1e160` made a prediction at a trained point drop to 0.
    let mut m = trained(false);
    let before = m.clone();
    for (x, y) in [
        ([1e200, 0.0], [0.0]),
        ([0.1, 0.1], [1e160]),
        ([-2e30, 0.0], [0.0]),
        ([0.0, 0.0], [-1.5e30]),
    ] {
        let e = m.update(&x, &y).unwrap_err();
        assert!(
            matches!(e, LwprError::TooLarge { bound, .. } if bound == MAX_ABS_VALUE),
            "{e}"
        );
        assert!(e.to_string().contains("1e30"), "{e}");
    }
    assert_eq!(m, before);
    // Normalisation counts too: a small norm factor makes a moderate value too large.
    let mut n = LwprBuilder::new(1, 1).norm_in(&[1e-10]).build().unwrap();
    assert!(matches!(
        n.update(&[1e25], &[0.0]),
        Err(LwprError::TooLarge {
            what: "x / norm_in",
            ..
        })
    ));
    assert_eq!(n.n_data(), 0);
}

#[test]
fn samples_at_the_bound_keep_the_model_finite_and_loadable() {
    // The bound is one the arithmetic survives: extreme samples at ±MAX_ABS_VALUE mixed into
    // ordinary ones, with a full metric and meta learning, leave a finite model that saves,
    // loads and still predicts the ordinary data.
    for full in [false, true] {
        let mut m = trained(full);
        let b = MAX_ABS_VALUE;
        let extremes = [
            ([b, 0.0], [0.0]),
            ([0.0, 0.0], [b]),
            ([0.01, -0.01], [-b]),
            ([-b, b], [b]),
            ([0.5, 0.5], [b]),
        ];
        let (x, y) = cross_samples(9, 400, 0.05);
        for (k, (p, q)) in x.chunks(2).zip(&y).enumerate() {
            m.update(p, &[*q]).unwrap();
            if k % 40 == 0 {
                let (ex, ey) = extremes[(k / 40) % extremes.len()];
                let yp = m.update(&ex, &ey).unwrap();
                assert!(yp[0].is_finite());
            }
        }
        assert!(m.var_x().iter().all(|v| v.is_finite()));
        let back = Lwpr::from_json(&m.to_json()).expect("a model trained on bounded samples loads");
        assert_eq!(back, m);
        assert_eq!(Lwpr::from_binary(&m.to_binary()).unwrap(), m);
        let p = m.predict(&[0.0, 0.0], 0.001).unwrap();
        assert!(p[0].is_finite());
    }
}

/// A named edit of a saved model.
type Edit = (&'static str, Box<dyn Fn(&mut Value)>);

#[test]
fn inconsistent_models_are_refused_on_loading() {
    // #6: from_json accepted a non-positive-definite D, an M that is not chol(D), a negative
    // var_x and lambda = 5.
    let m = trained(true);
    let good = model_json(&m);
    let edits: Vec<Edit> = vec![
        (
            "D not positive definite (M with a negative diagonal, D = MᵀM)",
            Box::new(|v| {
                let r = rf(v);
                let m0 = r["m"][0].as_f64().unwrap();
                r["m"][0] = json!(-m0);
            }),
        ),
        (
            "D indefinite, M unchanged",
            Box::new(|v| {
                let r = rf(v);
                r["d"][0] = json!(-1.0);
            }),
        ),
        (
            "M not chol(D)",
            Box::new(|v| {
                let r = rf(v);
                let m3 = r["m"][3].as_f64().unwrap();
                r["m"][3] = json!(m3 * 1.01);
            }),
        ),
        (
            "M not upper triangular",
            Box::new(|v| {
                let r = rf(v);
                r["m"][1] = json!(0.5);
            }),
        ),
        (
            "negative model var_x",
            Box::new(|v| v["var_x"][0] = json!(-1.0)),
        ),
        (
            "negative field var_x",
            Box::new(|v| rf(v)["var_x"][1] = json!(-0.5)),
        ),
        ("lambda = 5", Box::new(|v| rf(v)["lambda"][0] = json!(5.0))),
        (
            "init_lambda = 5",
            Box::new(|v| v["params"]["init_lambda"] = json!(5.0)),
        ),
        (
            "zero learning rate",
            Box::new(|v| rf(v)["alpha"][0] = json!(0.0)),
        ),
        ("activation 3", Box::new(|v| rf(v)["w"] = json!(3.0))),
        (
            "centre beyond the bound",
            Box::new(|v| rf(v)["c"][0] = json!(1e200)),
        ),
        (
            "init_M not chol(init_D)",
            Box::new(|v| v["params"]["init_m"][0] = json!(1.0)),
        ),
        (
            "n_in beyond the limit",
            Box::new(|v| v["params"]["n_in"] = json!(1_000_000)),
        ),
    ];
    assert!(load_both(&good).0.is_ok());
    for (what, edit) in edits {
        let mut v = good.clone();
        edit(&mut v);
        let (a, b) = load_both(&v);
        assert!(a.is_err(), "from_json accepted: {what}");
        assert!(b.is_err(), "serde accepted: {what}");
    }
}

#[test]
fn sizes_beyond_the_limits_fail_before_allocating() {
    // #7: `LwprBuilder::new(10_000, 1).build()` ran for minutes and took ~1 GB.
    let e = LwprBuilder::new(10_000, 1)
        .init_d_spherical(2.0)
        .init_alpha(10.0)
        .build()
        .unwrap_err();
    assert_eq!(
        e,
        LwprError::TooBig {
            what: "n_in",
            got: 10_000,
            max: MAX_INPUTS
        }
    );
    assert!(matches!(
        LwprBuilder::new(1, MAX_OUTPUTS + 1).build(),
        Err(LwprError::TooBig { what: "n_out", .. })
    ));
    assert!(matches!(
        LwprBuilder::new(usize::MAX, usize::MAX).build(),
        Err(LwprError::TooBig { .. })
    ));
    let mut p = lwpr::Params::defaults(2, 1);
    p.n_in = MAX_INPUTS + 1;
    assert!(matches!(
        LwprBuilder::from_params(p).build(),
        Err(LwprError::TooBig { .. })
    ));
    assert!(LwprBuilder::new(MAX_INPUTS, 1).build().is_ok());
}

#[test]
fn huge_metrics_inconsistent_with_their_factor_are_refused() {
    // The D = MᵀM check scaled its tolerance by √(D_ii·D_jj), which overflows to +∞ once the
    // diagonal passes ~1e154: then any off-diagonal D was accepted, here an indefinite one
    // (D_01 = 3·D_00), whose negative distances gave the confidence bound w = e^{+huge} = ∞.
    let m = trained(true);
    let mut v = model_json(&m);
    let r = rf(&mut v);
    r["m"] = json!([1e100, 0.0, 0.0, 1e100]);
    r["d"] = json!([1e200, 3e200, 3e200, 1e200]);
    let (a, b) = load_both(&v);
    assert!(matches!(a, Err(LwprError::Format(_))), "{a:?}");
    assert!(b.is_err());
    // The consistent huge metric still loads.
    let r = rf(&mut v);
    r["d"] = json!([1e200, 0.0, 0.0, 1e200]);
    let (a, b) = load_both(&v);
    assert!(a.is_ok() && b.is_ok(), "{a:?}");
}

#[test]
fn a_rejected_validate_leaves_the_params_unchanged() {
    // `Params::validate` wrote the new Cholesky factor into `init_m` before checking the
    // remaining parameters, so a call that failed on `w_gen` had still changed `init_m`.
    let mut p = lwpr::Params::defaults(2, 1);
    p.init_d = vec![4.0, 0.0, 0.0, 4.0];
    p.w_gen = 2.0;
    let before = p.clone();
    assert!(matches!(
        p.validate(),
        Err(LwprError::InvalidParameter { name: "w_gen", .. })
    ));
    assert_eq!(p, before);
    p.w_gen = 0.2;
    p.validate().unwrap();
    assert_eq!(p.init_m, vec![2.0, 0.0, 0.0, 2.0]);
}

#[test]
fn every_refusal_of_validate_leaves_the_params_unchanged() {
    // The test above refuses `w_gen`, the first check after the Cholesky factor is computed;
    // each later check must leave `init_m` (and everything else) as it was too, and so must
    // the checks before it. `init_d` is changed first, so an early store would show.
    type Break = fn(&mut lwpr::Params);
    let cases: [(&str, Break); 16] = [
        ("init_D", |p| p.init_d[1] = 0.5),
        ("init_D", |p| p.init_d[0] = -1.0),
        ("init_alpha", |p| p.init_alpha[3] = 0.0),
        ("norm_in", |p| p.norm_in[1] = f64::NAN),
        ("norm_out", |p| p.norm_out[0] = -1.0),
        ("w_gen", |p| p.w_gen = 1.0),
        ("w_prune", |p| p.w_prune = f64::INFINITY),
        ("init_lambda", |p| p.init_lambda = 0.0),
        ("final_lambda", |p| p.final_lambda = 1.5),
        ("tau_lambda", |p| p.tau_lambda = f64::NAN),
        ("init_S2", |p| p.init_s2 = -1e-10),
        ("add_threshold", |p| p.add_threshold = 0.0),
        ("meta_rate", |p| p.meta_rate = f64::INFINITY),
        ("penalty", |p| p.penalty = -1e-6),
        ("penalty", |p| p.penalty = f64::NAN),
        ("n_out", |p| p.n_out = 0),
    ];
    for (name, break_it) in cases {
        let mut p = lwpr::Params::defaults(2, 1);
        p.init_d = vec![9.0, 0.0, 0.0, 4.0];
        break_it(&mut p);
        let before = p.clone();
        match p.validate() {
            Err(LwprError::InvalidParameter { name: got, .. }) => assert_eq!(got, name),
            other => panic!("{name}: expected InvalidParameter, got {other:?}"),
        }
        // Debug, not `==`: some cases hold a NaN, which is never equal to itself.
        assert_eq!(format!("{p:?}"), format!("{before:?}"), "{name}");
    }
    // The same parameters, repaired, validate and store the new factor.
    let mut p = lwpr::Params::defaults(2, 1);
    p.init_d = vec![9.0, 0.0, 0.0, 4.0];
    p.validate().unwrap();
    assert_eq!(p.init_m, vec![3.0, 0.0, 0.0, 2.0]);
}

#[test]
fn defaults_of_impossible_sizes_allocate_nothing() {
    // `Params::defaults(2^31, 1)` computed n² = 2^62 elements and panicked (capacity overflow,
    // or an index out of bounds where the product wrapped); now the sizes are kept, nothing is
    // allocated, and validation reports them.
    for (n_in, n_out) in [(1usize << 31, 1usize), (usize::MAX, 1), (2, usize::MAX)] {
        let p = lwpr::Params::defaults(n_in, n_out);
        assert_eq!((p.n_in, p.n_out), (n_in, n_out));
        assert!(matches!(
            LwprBuilder::from_params(p).build(),
            Err(LwprError::TooBig { .. })
        ));
    }
}

#[test]
fn concurrent_saves_to_one_path_all_succeed_and_leave_a_whole_file() {
    // The temporary file was named after the process only, so two threads saving to the same
    // path shared it: one renamed the other's half-written file into place, and the other's
    // rename then failed ("No such file or directory").
    let dir = std::env::temp_dir().join(format!("lwpr-concurrent-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("model.json");
    let m = trained(true);
    std::thread::scope(|s| {
        for _ in 0..8 {
            s.spawn(|| {
                for _ in 0..25 {
                    m.save(&path).unwrap();
                }
            });
        }
    });
    assert_eq!(Lwpr::load(&path).unwrap(), m);
    let left: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
    assert_eq!(left.len(), 1, "temporary files left behind");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn builder_setters_after_from_params_of_impossible_sizes_allocate_nothing() {
    // `LwprBuilder::from_params` did not check the sizes that `new` checks, so the setters
    // that build n × n matrices ran on them: `init_d_spherical` with 2^31 inputs asked for
    // 2^62 elements and panicked (capacity overflow; 100 000 inputs would ask for 80 GB).
    for n_in in [1usize << 31, MAX_INPUTS + 1] {
        let e = LwprBuilder::from_params(lwpr::Params::defaults(n_in, 1))
            .init_d_spherical(2.0)
            .init_alpha(10.0)
            .init_d_diagonal(&[1.0])
            .build()
            .unwrap_err();
        assert_eq!(
            e,
            LwprError::TooBig {
                what: "n_in",
                got: n_in,
                max: MAX_INPUTS
            }
        );
    }
    let e = LwprBuilder::from_params(lwpr::Params::defaults(2, MAX_OUTPUTS + 1))
        .init_alpha(10.0)
        .build()
        .unwrap_err();
    assert!(
        matches!(e, LwprError::TooBig { what: "n_out", .. }),
        "{e:?}"
    );
}

/// A 1-D model with two receptive fields (at 0 and 0.5) whose next update at 0.25 prunes one
/// of them (`w_prune` = 0.05, both activations ≈ 0.46).
fn about_to_prune() -> Lwpr {
    let mut m = LwprBuilder::new(1, 1).w_prune(0.05).build().unwrap();
    m.update(&[0.0], &[0.0]).unwrap();
    m.update(&[0.5], &[0.5]).unwrap();
    assert_eq!(m.num_rfs(), [2]);
    let mut probe = m.clone();
    probe.update(&[0.25], &[0.25]).unwrap();
    assert_eq!(probe.num_pruned(), [1], "the next update prunes");
    m
}

#[test]
fn sample_and_pruning_counts_beyond_training_are_refused_on_loading() {
    // A saved `n_data` of u64::MAX loaded, and the next update overflowed it (a panic in debug
    // builds; in release it wrapped to 0, and 1 / 0 turned the model's input statistics into
    // ∞ and NaN). The same for a per-output `n_pruned` of usize::MAX and the next pruning.
    // Training keeps n_pruned ≤ n_data (at most one pruning per output and update), and no
    // trained model reaches 2^53 samples.
    let m = about_to_prune();
    let good = model_json(&m);
    let edits: Vec<Edit> = vec![
        (
            "n_data = u64::MAX",
            Box::new(|v| v["n_data"] = json!(u64::MAX)),
        ),
        (
            "n_data = 2^53 + 1",
            Box::new(|v| v["n_data"] = json!((1u64 << 53) + 1)),
        ),
        (
            "n_pruned = u64::MAX",
            Box::new(|v| v["sub"][0]["n_pruned"] = json!(u64::MAX)),
        ),
        (
            "n_pruned > n_data",
            Box::new(|v| v["sub"][0]["n_pruned"] = json!(3)),
        ),
    ];
    for (what, edit) in edits {
        let mut v = good.clone();
        edit(&mut v);
        let (a, b) = load_both(&v);
        if let Ok(mut loaded) = a {
            // The symptom: the next update (which prunes) overflows a counter.
            let r = loaded.update(&[0.25], &[0.25]);
            panic!(
                "{what}: loaded; the update gave {r:?}, n_data {}, n_pruned {:?}, mean_x {:?}",
                loaded.n_data(),
                loaded.num_pruned(),
                loaded.mean_x()
            );
        }
        assert!(matches!(a, Err(LwprError::Format(_))), "{what}: {a:?}");
        assert!(b.is_err(), "serde accepted: {what}");
    }
    // The XML reader checks the same.
    let xml = m.to_xml();
    for (from, to) in [
        ("'n_data'> 2 <", format!("'n_data'> {} <", u64::MAX)),
        ("'n_pruned'> 0 <", format!("'n_pruned'> {} <", u64::MAX)),
    ] {
        assert_eq!(xml.matches(from).count(), 1, "{from}");
        let e = Lwpr::from_xml(&xml.replace(from, &to)).unwrap_err();
        assert!(matches!(e, LwprError::Format(_)), "{e:?}");
    }
    // The limits themselves load and train on.
    let mut v = good.clone();
    v["n_data"] = json!(1u64 << 53);
    v["sub"][0]["n_pruned"] = json!(1u64 << 53);
    let (a, b) = load_both(&v);
    assert!(b.is_ok());
    let mut loaded = a.unwrap();
    loaded.update(&[0.25], &[0.25]).unwrap();
    assert_eq!(loaded.n_data(), (1 << 53) + 1);
    assert_eq!(loaded.num_pruned(), [(1 << 53) + 1]);
}

#[test]
fn binary_counts_beyond_the_data_fail_before_allocating() {
    // The binary reader reserved room for `n_out` sub-models before checking `n_out` (a
    // capacity-overflow panic for 2^60), and for `k` receptive fields of ~600 bytes each when
    // `k` was at most the payload's length in bytes: a 64 MB file asked for 38 GB and aborted.
    fn fnv1a(data: &[u8]) -> u64 {
        data.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
            (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
        })
    }
    let frame = |header: &[u8], payload: &[u8]| {
        let mut out = header[..12].to_vec();
        out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
        out.extend_from_slice(payload);
        out.extend_from_slice(&fnv1a(payload).to_le_bytes());
        out
    };
    let bin = LwprBuilder::new(1, 1).build().unwrap().to_binary();
    let payload = &bin[20..bin.len() - 8];
    assert_eq!(frame(&bin, payload), bin);
    let n = payload.len();
    // An untrained 1 → 1 model ends with n_sub = 1, n_pruned = 0, k = 0; n_out is its second
    // number.
    let word = |at: usize| u64::from_le_bytes(payload[at..at + 8].try_into().unwrap());
    assert_eq!(
        (word(8), word(n - 24), word(n - 16), word(n - 8)),
        (1, 1, 0, 0)
    );

    let mut huge_out = payload.to_vec();
    huge_out[8..16].copy_from_slice(&(1u64 << 60).to_le_bytes());
    huge_out[n - 24..n - 16].copy_from_slice(&(1u64 << 60).to_le_bytes());
    let e = Lwpr::from_binary(&frame(&bin, &huge_out)).unwrap_err();
    assert!(matches!(e, LwprError::Format(_)), "{e:?}");

    let pad = 64 << 20;
    let mut many_rfs = payload.to_vec();
    many_rfs[n - 8..].copy_from_slice(&(pad as u64).to_le_bytes());
    many_rfs.resize(n + pad, 0);
    let e = Lwpr::from_binary(&frame(&bin, &many_rfs)).unwrap_err();
    assert!(matches!(e, LwprError::Format(_)), "{e:?}");
}

#[test]
fn confidence_without_a_mature_pls_direction_is_an_error() {
    // With one input a field has one PLS direction, used for prediction only while its
    // discounted data count exceeds 2·n_in = 2. A fast-forgetting model (final_lambda 0.01)
    // first counts past 2, so the field becomes trustworthy, then forgets back to ≈ 1.01:
    // `predict_with_confidence` then indexed its CV error at `0 − 1` and panicked (the
    // reference reads before the array there). A saved model in that state did the same.
    let mut m = LwprBuilder::new(1, 1)
        .init_lambda(1.0)
        .final_lambda(0.01)
        .tau_lambda(0.9)
        .build()
        .unwrap();
    for _ in 0..60 {
        m.update(&[0.0], &[1.0]).unwrap();
    }
    let rf = m.receptive_fields(0)[0];
    assert!(rf.trustworthy() && rf.n_data() <= 2.0, "{}", rf.n_data());
    let before = m.clone();
    let e = m.predict_with_confidence(&[0.0], 0.001).unwrap_err();
    assert_eq!(
        e,
        LwprError::NoConfidence {
            output: 0,
            field: 0
        }
    );
    assert_eq!(m, before);
    // The other predictions do not need the CV error: the field's offset, slope 0.
    assert!((m.predict(&[0.0], 0.001).unwrap()[0] - 1.0).abs() < 1e-12);
    assert!((m.predict_with_jacobian(&[0.0], 0.001).unwrap().y[0] - 1.0).abs() < 1e-12);
    // Where the field is not active the bound is the usual one (no active field: +∞).
    let far = m.predict_with_confidence(&[100.0], 0.001).unwrap();
    assert_eq!(far.confidence, [f64::INFINITY]);
    // Saved and loaded, the same.
    let mut v = model_json(&m);
    assert_eq!(rf_count(&mut v), 1);
    let (a, b) = load_both(&v);
    assert_eq!(
        a.unwrap().predict_with_confidence(&[0.0], 0.001),
        Err(LwprError::NoConfidence {
            output: 0,
            field: 0
        })
    );
    assert!(b.unwrap().predict_with_confidence(&[0.0], 0.001).is_err());
}

fn rf_count(v: &mut Value) -> usize {
    v["sub"][0]["rfs"].as_array().unwrap().len()
}
