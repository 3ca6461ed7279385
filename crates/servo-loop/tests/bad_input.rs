//! Regressions of the bad-input sweep (issue 24): a deserialised inverse model passes the
//! constructor's checks, and a plant with inconsistent percept bounds is a typed error.

use servo_loop::{
    InverseModel, InverseModelConfig, LearnConfig, Observation, Plant, ServoError, check_target,
    learn_control,
};

/// A linear two-joint plant seen as one camera point.
struct Line {
    y: Vec<f64>,
    bounds: Option<Vec<[f64; 2]>>,
}

impl Plant for Line {
    fn percept_dim(&self) -> usize {
        2
    }
    fn command_dim(&self) -> usize {
        2
    }
    fn command_range(&self, _: usize) -> [f64; 2] {
        [0.0, 1.0]
    }
    fn act(&mut self, y: &[f64]) -> servo_loop::Result<()> {
        self.y = y.to_vec();
        Ok(())
    }
    fn observe(&mut self) -> servo_loop::Result<Observation> {
        Ok(Observation {
            x: vec![100.0 + 200.0 * self.y[0], 100.0 + 150.0 * self.y[1]],
            certainty: 1.0,
        })
    }
    fn percept_bounds(&self) -> Option<Vec<[f64; 2]>> {
        self.bounds.clone()
    }
}

fn trained() -> InverseModel {
    let mut plant = Line {
        y: vec![0.5, 0.5],
        bounds: None,
    };
    let config = InverseModelConfig {
        percept_scale: 100.0,
        command_scale: 1.0,
        ..InverseModelConfig::default()
    };
    let mut model = InverseModel::new(2, 2, &config).unwrap();
    let learn = LearnConfig {
        moves: 300,
        explore: vec![[0.0, 1.0]; 2],
        seed: 3,
        progress: false,
        approach: None,
    };
    learn_control(&mut plant, &mut model, &learn, |_, _| {}).unwrap();
    model
}

#[test]
fn a_deserialised_inverse_model_predicts_like_the_original() {
    // Plain serde used to skip LWPR's loading step: the model then panicked in `predict`.
    let model = trained();
    let json = serde_json::to_string(&model).unwrap();
    let loaded: InverseModel = serde_json::from_str(&json).unwrap();
    let x = [200.0, 175.0];
    assert_eq!(loaded.predict(&x).unwrap(), model.predict(&x).unwrap());
    assert_eq!(
        loaded.predict_with_jacobian(&x).unwrap(),
        model.predict_with_jacobian(&x).unwrap()
    );
}

#[test]
fn a_deserialised_inverse_model_passes_the_constructor_checks() {
    let model = trained();
    let mut value: serde_json::Value = serde_json::to_value(&model).unwrap();
    for bad in [5.0, 0.0, -1.0] {
        value["cutoff"] = serde_json::json!(bad);
        let err = serde_json::from_value::<InverseModel>(value.clone()).unwrap_err();
        assert!(err.to_string().contains("cutoff"), "{err}");
    }
    // An LWPR part whose sizes disagree is refused, not stored.
    let mut value: serde_json::Value = serde_json::to_value(&model).unwrap();
    value["lwpr"]["mean_x"] = serde_json::json!([1.0]);
    assert!(serde_json::from_value::<InverseModel>(value).is_err());
}

#[test]
fn percept_bounds_shorter_than_the_percept_are_a_typed_error() {
    // Used to panic indexing the bounds.
    for bounds in [vec![], vec![[0.0, 639.0]], vec![[0.0, 639.0]; 3]] {
        let plant = Line {
            y: vec![0.5, 0.5],
            bounds: Some(bounds.clone()),
        };
        let err = check_target(&plant, &[10.0, 10.0]).unwrap_err();
        assert!(
            matches!(
                err,
                ServoError::DimensionMismatch {
                    what: "percept bounds",
                    expected: 2,
                    ..
                }
            ),
            "{bounds:?}: {err}"
        );
    }
    let plant = Line {
        y: vec![0.5, 0.5],
        bounds: Some(vec![[0.0, 639.0], [0.0, 479.0]]),
    };
    check_target(&plant, &[10.0, 10.0]).unwrap();
    assert!(matches!(
        check_target(&plant, &[10.0, 500.0]),
        Err(ServoError::TargetOutsideImage { camera: 0, .. })
    ));
}
