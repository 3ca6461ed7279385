//! Decoding results and kernels survive a serde round trip unchanged (and serialise as
//! before), and deserialising one that breaks what the code that builds them guarantees is a
//! typed error, not a silent value.

use chan_repr::{
    ChanError, ChannelBasis, ChannelGrid, GAUSSIAN_MAX_SIGMA, Kernel, Mode, ModeNd, PeriodicBasis,
    SoftHistogram, WindowEstimate,
};

/// Through a `serde_json::Value` (which keeps every `f64` exactly; serde_json's text parser
/// may be off by an ulp), after checking that the JSON text deserialises too.
fn round_trip<T>(v: &T) -> T
where
    T: serde::Serialize + serde::de::DeserializeOwned,
{
    serde_json::from_str::<T>(&serde_json::to_string(v).unwrap()).unwrap();
    serde_json::from_value(serde_json::to_value(v).unwrap()).unwrap()
}

/// The message of the deserialisation error of `json` as a `T`.
fn refused<T: serde::de::DeserializeOwned + std::fmt::Debug>(json: &str) -> String {
    serde_json::from_str::<T>(json).expect_err(json).to_string()
}

#[test]
fn decoding_results_round_trip_unchanged() {
    let kernels = [
        Kernel::Cos2 { m: 3 },
        Kernel::Cos2 { m: 5 },
        Kernel::BSpline2,
        Kernel::Gaussian { sigma: 0.8 },
    ];
    for kernel in kernels {
        let b = ChannelBasis::covering(0.0, 10.0, 16, kernel).unwrap();
        let mut c = b.encode(2.7).unwrap();
        b.accumulate(7.1, 0.5, &mut c).unwrap();
        let modes = b.decode(&c).unwrap();
        assert_eq!(modes.len(), 2, "{kernel:?}");
        for m in &modes {
            assert_eq!(&round_trip(m), m);
        }
        // Every window, valid or not, with or without an estimate.
        let windows = b.decode_windows(&c).unwrap();
        assert!(windows.iter().any(|w| !w.valid));
        for w in &windows {
            assert_eq!(&round_trip(w), w);
        }
        let p = PeriodicBasis::new(std::f64::consts::TAU, 16, kernel).unwrap();
        for m in p.decode(&p.encode(6.2).unwrap()).unwrap() {
            assert_eq!(round_trip(&m), m);
        }
        for w in p.decode_windows(&p.encode(0.1).unwrap()).unwrap() {
            assert_eq!(round_trip(&w), w);
        }
        let g = ChannelGrid::new(vec![b.clone(), b]).unwrap();
        let mut h = SoftHistogram::new(g.clone()).unwrap();
        h.add(&[1.5, 8.25], 2.0).unwrap();
        h.add(&[6.0, 3.0], 1.0).unwrap();
        let modes = h.decode().unwrap();
        assert_eq!(modes.len(), 2, "{kernel:?}");
        for m in &modes {
            assert_eq!(&round_trip(m), m);
        }
        for m in g.decode(&g.encode(&[4.0, 4.5]).unwrap()).unwrap() {
            assert_eq!(round_trip(&m), m);
        }
    }
    // The serialised form is unchanged.
    let m = Mode {
        value: 3.3,
        certainty: 1.5,
        weight: 1.0,
    };
    assert_eq!(
        serde_json::to_string(&m).unwrap(),
        r#"{"value":3.3,"certainty":1.5,"weight":1.0}"#
    );
    let w = WindowEstimate {
        start: 2,
        value: None,
        certainty: 0.0,
        valid: false,
    };
    assert_eq!(
        serde_json::to_string(&w).unwrap(),
        r#"{"start":2,"value":null,"certainty":0.0,"valid":false}"#
    );
    assert_eq!(round_trip(&w), w);
    let n = ModeNd {
        value: vec![1.0, -2.5],
        certainty: 0.25,
        weight: 0.0,
    };
    assert_eq!(
        serde_json::to_string(&n).unwrap(),
        r#"{"value":[1.0,-2.5],"certainty":0.25,"weight":0.0}"#
    );
    assert_eq!(round_trip(&n), n);
}

#[test]
fn modes_with_impossible_values_are_refused() {
    for (json, what) in [
        (
            r#"{"value":3.0,"certainty":-1.0,"weight":1.0}"#,
            "`certainty`",
        ),
        (
            r#"{"value":3.0,"certainty":0.0,"weight":0.0}"#,
            "`certainty`",
        ),
        (r#"{"value":3.0,"certainty":1.5,"weight":-0.5}"#, "`weight`"),
    ] {
        let err = refused::<Mode>(json);
        assert!(err.contains(what), "{json}: {err}");
    }
    // The error is the crate's typed one.
    let spec = serde_json::json!({"value": 3.0, "certainty": 1.5, "weight": -0.5});
    let err = serde_json::from_value::<Mode>(spec)
        .unwrap_err()
        .to_string();
    let typed = ChanError::InvalidParameter {
        name: "weight",
        value: -0.5,
        reason: "a mode's weight is finite and >= 0",
    };
    assert_eq!(err, typed.to_string());
    // Malformed input is still a (serde) error, as before.
    assert!(serde_json::from_str::<Mode>(r#"{"value":3.0,"certainty":1.5}"#).is_err());
}

#[test]
fn window_estimates_with_impossible_values_are_refused() {
    for (json, what) in [
        // Valid without an estimate.
        (
            r#"{"start":0,"value":null,"certainty":1.0,"valid":true}"#,
            "`valid`",
        ),
        // Valid with no mass in the window.
        (
            r#"{"start":0,"value":1.5,"certainty":0.0,"valid":true}"#,
            "`certainty`",
        ),
        // A negative window sum, valid or not.
        (
            r#"{"start":0,"value":1.5,"certainty":-2.0,"valid":false}"#,
            "`certainty`",
        ),
        (
            r#"{"start":0,"value":null,"certainty":-2.0,"valid":false}"#,
            "`certainty`",
        ),
    ] {
        let err = refused::<WindowEstimate>(json);
        assert!(err.contains(what), "{json}: {err}");
    }
    // What a decoder produces for an empty or a rejected window is accepted.
    for json in [
        r#"{"start":3,"value":null,"certainty":0.0,"valid":false}"#,
        r#"{"start":3,"value":-1e300,"certainty":0.5,"valid":false}"#,
    ] {
        assert!(
            serde_json::from_str::<WindowEstimate>(json).is_ok(),
            "{json}"
        );
    }
}

#[test]
fn n_d_modes_with_impossible_values_are_refused() {
    for (json, what) in [
        (r#"{"value":[],"certainty":1.0,"weight":1.0}"#, "dimensions"),
        (
            r#"{"value":[1.0,2.0],"certainty":-1.0,"weight":1.0}"#,
            "`certainty`",
        ),
        (
            r#"{"value":[1.0],"certainty":1.0,"weight":-3.0}"#,
            "`weight`",
        ),
    ] {
        let err = refused::<ModeNd>(json);
        assert!(err.contains(what), "{json}: {err}");
    }
}

#[test]
fn gaussians_too_wide_to_decode_are_refused() {
    // σ = 1e308 was accepted: every channel encoded as exactly 1 (its support radius was ∞)
    // and nothing ever decoded.
    for sigma in [1e308, 1e10, 1e8, 2.0 * GAUSSIAN_MAX_SIGMA] {
        let kernel = Kernel::Gaussian { sigma };
        let typed = ChanError::TooLarge {
            what: "Gaussian sigma",
            value: sigma,
            max: GAUSSIAN_MAX_SIGMA,
        };
        assert_eq!(kernel.validate(), Err(typed.clone()));
        assert_eq!(ChannelBasis::integer(40, kernel), Err(typed.clone()));
        assert_eq!(
            PeriodicBasis::new(std::f64::consts::TAU, 64, kernel),
            Err(typed.clone())
        );
        let json = format!(r#"{{"gaussian":{{"sigma":{sigma:e}}}}}"#);
        let err = refused::<Kernel>(&json);
        assert!(err.starts_with(&typed.to_string()), "{err}");
        let basis =
            format!(r#"{{"kernel":{json},"channels":40,"first_centre":1.0,"spacing":1.0}}"#);
        let err = refused::<ChannelBasis>(&basis);
        assert!(err.starts_with(&typed.to_string()), "{err}");
    }
    // At the limit a Gaussian is still accepted and decodes to well under a channel spacing.
    let kernel = Kernel::Gaussian {
        sigma: GAUSSIAN_MAX_SIGMA,
    };
    let b = ChannelBasis::integer(40, kernel).unwrap();
    let mode = b.decode_best(&b.encode(10.3).unwrap()).unwrap().unwrap();
    assert!((mode.value - 10.3).abs() < 1e-3, "{mode:?}");
    assert_eq!(round_trip(&kernel), kernel);
    assert_eq!(round_trip(&b), b);
}

#[test]
fn a_valid_window_without_an_estimate_names_the_missing_estimate() {
    // The error used to report `valid` = the window's certainty (here 0.75), a number that has
    // nothing to do with what is wrong: the estimate is missing.
    let json = r#"{"start":0,"value":null,"certainty":0.75,"valid":true}"#;
    let err = refused::<WindowEstimate>(json);
    let typed = ChanError::InvalidParameter {
        name: "valid",
        value: 1.0,
        reason: "a window marked valid (1 = true) has an estimate, but `value` is null",
    };
    assert_eq!(err, typed.to_string());
    assert!(!err.contains("0.75"), "{err}");
}

/// Deserialises a [`Mode`] from numbers serde_json cannot carry (NaN, ±∞), through serde's
/// own map deserialiser.
fn mode_from(fields: [(&'static str, f64); 3]) -> Result<Mode, String> {
    use serde::Deserialize;
    use serde::de::value::{Error, MapDeserializer};
    Mode::deserialize(MapDeserializer::<_, Error>::new(fields.into_iter()))
        .map_err(|e| e.to_string())
}

#[test]
fn modes_with_non_finite_numbers_are_refused() {
    // JSON cannot express NaN or infinity, but other serde formats can: the check is the
    // deserialiser's, not the format's.
    for v in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        for (i, name) in ["value", "certainty", "weight"].into_iter().enumerate() {
            let mut fields = [("value", 3.0), ("certainty", 1.5), ("weight", 1.0)];
            fields[i].1 = v;
            let err = mode_from(fields).expect_err(name);
            assert!(err.contains(&format!("`{name}`")), "{name} = {v}: {err}");
        }
    }
    let ok = mode_from([("value", 3.0), ("certainty", 1.5), ("weight", 1.0)]).unwrap();
    assert_eq!(
        ok,
        Mode {
            value: 3.0,
            certainty: 1.5,
            weight: 1.0
        }
    );
}
