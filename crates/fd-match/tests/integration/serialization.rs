//! Search and matching results survive a serde round trip unchanged, and deserialising one
//! that breaks the invariants of the code that builds them is an error, not a silent value.

use crate::common;

use common::*;
use fd_match::*;

fn sets() -> (DescriptorSet, DescriptorSet) {
    let a: Vec<_> = (0..8).map(|i| star(100 + i, 120, 30.0)).collect();
    let mut b: Vec<_> = (0..5)
        .map(|i| similarity(&a[i], 0.3 * i as f64, 1.5, (4.0, -2.0)))
        .collect();
    b.push(star(900, 100, 20.0));
    let cfg = DescriptorConfig::with_sampling(Sampling::Canonical);
    (
        describe_all(cfg, &a).unwrap().set,
        describe_all(cfg, &b).unwrap().set,
    )
}

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
fn search_and_match_results_round_trip_unchanged() {
    let (a, b) = sets();
    for method in [Method::FdCorr, Method::AbsFdSsd, Method::Afd1Ssd] {
        let (best, stats) = best_two_with_stats(&a, &b, method).unwrap();
        assert!(best.iter().any(|t| t.second.is_some()));
        for t in &best {
            assert_eq!(&round_trip(t), t);
            if let Some(c) = t.best {
                assert_eq!(round_trip(&c), c);
            }
        }
        assert_eq!(round_trip(&stats), stats);
        assert_eq!(round_trip(&BestTwo::default()), BestTwo::default());
        let matches = match_sets(&a, &b, method).unwrap();
        assert!(!matches.is_empty());
        for m in &matches {
            assert_eq!(method.aligns(), m.alignment.is_some());
            assert_eq!(&round_trip(m), m);
        }
    }
    // A set of one searched against itself: no targets, nothing evaluated.
    let one = a.select(&[0]).unwrap();
    let (r, _) = best_two_with_stats(&one, &one, Method::FdCorr).unwrap();
    assert_eq!(round_trip(&r[0]), r[0]);
    // Hand-written extremes that the search can produce are accepted.
    for json in [
        r#"{"best":{"index":1,"error":0.0,"alignment":null},"second":{"index":3,"error":0.0,"alignment":null}}"#,
        r#"{"best":{"index":0,"error":0.2,"alignment":{"rotation":-3.141592653589793,"shift":0.0}},"second":null}"#,
        r#"{"best":null,"second":null}"#,
    ] {
        assert!(serde_json::from_str::<BestTwo>(json).is_ok(), "{json}");
    }
    let m = r#"{"query":0,"target":0,"error":0.0,"ratio":1.0,"alignment":{"rotation":3.141592653589793,"shift":0.5}}"#;
    assert!(serde_json::from_str::<Match>(m).is_ok());
    let s = r#"{"pairs":5,"evaluated":5}"#;
    assert!(serde_json::from_str::<SearchStats>(s).is_ok());
}

#[test]
fn candidates_and_alignments_with_impossible_values_are_refused() {
    for json in [
        r#"{"index":0,"error":-0.5,"alignment":null}"#,
        r#"{"index":0,"error":-0.0000001,"alignment":null}"#,
    ] {
        let err = refused::<Candidate>(json);
        assert!(err.contains("`error`"), "{json}: {err}");
    }
    for json in [
        r#"{"rotation":3.2,"shift":0.0}"#,
        r#"{"rotation":-4.0,"shift":0.0}"#,
        r#"{"rotation":0.0,"shift":-1.0}"#,
        r#"{"rotation":0.0,"shift":1e300}"#,
    ] {
        refused::<Alignment>(json);
        let c = format!(r#"{{"index":0,"error":0.1,"alignment":{json}}}"#);
        refused::<Candidate>(&c);
    }
}

#[test]
fn best_two_out_of_order_is_refused() {
    let c = |index: usize, error: f64| {
        format!(r#"{{"index":{index},"error":{error},"alignment":null}}"#)
    };
    let a = |index: usize, error: f64| {
        format!(r#"{{"index":{index},"error":{error},"alignment":{{"rotation":0.5,"shift":2.0}}}}"#)
    };
    for (json, what) in [
        // A second best without a best.
        (
            format!(r#"{{"best":null,"second":{}}}"#, c(1, 0.2)),
            "`second`",
        ),
        // The second beats the best.
        (
            format!(r#"{{"best":{},"second":{}}}"#, c(0, 0.5), c(1, 0.2)),
            "`second`",
        ),
        // A tie is broken by the smaller index.
        (
            format!(r#"{{"best":{},"second":{}}}"#, c(4, 0.3), c(2, 0.3)),
            "`second`",
        ),
        // One target twice.
        (
            format!(r#"{{"best":{},"second":{}}}"#, c(2, 0.3), c(2, 0.3)),
            "`second`",
        ),
        // Candidates of two methods (with and without alignment).
        (
            format!(r#"{{"best":{},"second":{}}}"#, a(0, 0.1), c(1, 0.2)),
            "`second`",
        ),
        // A candidate that is invalid on its own.
        (
            format!(r#"{{"best":{},"second":null}}"#, c(0, -1.0)),
            "`error`",
        ),
    ] {
        let err = refused::<BestTwo>(&json);
        assert!(err.contains(what), "{json}: {err}");
    }
}

#[test]
fn search_stats_with_more_evaluations_than_pairs_are_refused() {
    let err = refused::<SearchStats>(r#"{"pairs":3,"evaluated":4}"#);
    assert!(err.contains("`evaluated`"), "{err}");
}

#[test]
fn matches_with_impossible_values_are_refused() {
    let m = |error: &str, ratio: &str, alignment: &str| {
        format!(
            r#"{{"query":1,"target":2,"error":{error},"ratio":{ratio},"alignment":{alignment}}}"#
        )
    };
    for (json, what) in [
        (m("-0.1", "0.5", "null"), "`error`"),
        (m("0.1", "1.5", "null"), "`ratio`"),
        (m("0.1", "-0.5", "null"), "`ratio`"),
        (
            m("0.1", "0.5", r#"{"rotation":7.0,"shift":0.0}"#),
            "`rotation`",
        ),
    ] {
        let err = refused::<Match>(&json);
        assert!(err.contains(what), "{json}: {err}");
    }
}

#[test]
fn correlations_round_trip_unchanged() {
    let (a, b) = sets();
    let cfg = a.config();
    let mut cor = Correlator::new(cfg.max_frequency(), cfg.samples).unwrap();
    let mut seen = 0;
    for i in 0..a.len() {
        for j in 0..b.len() {
            let c = cor.correlate(a.fd(i), b.fd(j)).unwrap();
            assert_eq!(round_trip(&c), c);
            seen += 1;
        }
        // Identical FDs: the peak may round above 1, the error is clamped at 0.
        let c = cor.correlate(a.fd(i), a.fd(i)).unwrap();
        assert_eq!(round_trip(&c), c);
    }
    assert!(seen > 40);
    // The serialised form is unchanged.
    let c = Correlation {
        error: 0.5,
        peak: 0.75,
        alignment: serde_json::from_str(r#"{"rotation":0.25,"shift":3.5}"#).unwrap(),
    };
    let json = r#"{"error":0.5,"peak":0.75,"alignment":{"rotation":0.25,"shift":3.5}}"#;
    assert_eq!(serde_json::to_string(&c).unwrap(), json);
    assert_eq!(serde_json::from_str::<Correlation>(json).unwrap(), c);
    // A peak a rounding above 1 with the clamped error is what the correlator can produce.
    let top = r#"{"error":0.0,"peak":1.0000000000000002,"alignment":{"rotation":0.0,"shift":0.0}}"#;
    assert!(serde_json::from_str::<Correlation>(top).is_ok());
}

#[test]
fn correlations_with_impossible_values_are_refused() {
    let c = |error: &str, peak: &str, alignment: &str| {
        format!(r#"{{"error":{error},"peak":{peak},"alignment":{alignment}}}"#)
    };
    let ok = r#"{"rotation":0.5,"shift":2.0}"#;
    for (json, what) in [
        // A negative error, or one above what any peak gives.
        (c("-0.5", "1.0", ok), "`error`"),
        (c("3.5", "0.0", ok), "`error`"),
        // An error that does not follow from the peak (eq. 10).
        (c("0.0", "0.5", ok), "`error`"),
        (c("1.2", "0.5", ok), "`error`"),
        // A peak outside [0, 1] (beyond the unit-norm tolerance).
        (c("0.0", "1.5", ok), "`peak`"),
        (c("2.2", "-0.1", ok), "`peak`"),
        // The alignment is checked as an `Alignment`.
        (
            c("1.0", "0.5", r#"{"rotation":4.0,"shift":0.0}"#),
            "`rotation`",
        ),
    ] {
        let err = refused::<Correlation>(&json);
        assert!(err.contains(what), "{json}: {err}");
    }
    // The error is the crate's typed one.
    let v = serde_json::json!({"error": 0.0, "peak": 1.5, "alignment": {"rotation": 0.0, "shift": 0.0}});
    let err = serde_json::from_value::<Correlation>(v)
        .unwrap_err()
        .to_string();
    assert!(err.starts_with("invalid parameter `peak` = 1.5"), "{err}");
}
