//! [`check_image_target`]: a user's pixel target is checked against what the learner knows
//! before any move: its length and values, the cameras' learned epipolar consistency (every
//! camera `k ≥ 1` against camera 0) and the learned inverse model's coverage; it returns the
//! first guess `f̂(x_w)`.

use crate::common::rectified;
use crate::common::tip_model;

use rectified::{Rectified, learned, model_config};
use servo_loop::{InverseModel, ServoError, check_image_target};
use tip_model::{rectified, tip_model};

/// The inverse model of the two-camera plant, learned from 300 random moves.
fn trained() -> InverseModel {
    learned(2, 300, 5)
}

#[test]
fn a_consistent_target_inside_the_model_gives_the_first_guess() {
    let tips = tip_model(2, vec![rectified()]);
    let model = trained();
    let y = [0.4, 0.6];
    let x_w = Rectified::at(2, y).percept(&y);
    let first = check_image_target(&tips, &model, &x_w, 0.5).unwrap();
    assert_eq!(first, model.predict(&x_w).unwrap());
    assert!(
        (first[0] - y[0]).abs() < 0.05 && (first[1] - y[1]).abs() < 0.05,
        "{first:?}"
    );
    // A one-camera recogniser needs no consistency.
    let one = learned(1, 200, 5);
    assert_eq!(
        check_image_target(&tip_model(1, vec![]), &one, &x_w[..2], 1.0).unwrap(),
        one.predict(&x_w[..2]).unwrap()
    );
}

#[test]
fn a_target_whose_cameras_disagree_is_inconsistent() {
    let tips = tip_model(2, vec![rectified()]);
    // Camera 1's point 3 px below camera 0's row: Sampson distance 3/√2 px, scale 1 px.
    let x_w = [200.0, 175.0, 220.0, 178.0];
    let d = 3.0 / 2f64.sqrt();
    let want = (-0.5 * d * d).exp();
    match check_image_target(&tips, &trained(), &x_w, 0.5) {
        Err(ServoError::TargetInconsistent {
            camera,
            distance_px,
            consistency,
            min,
        }) => {
            assert_eq!(camera, 1);
            assert!((distance_px - d).abs() < 1e-9, "{distance_px}");
            assert!((consistency - want).abs() < 1e-12, "{consistency}");
            assert_eq!(min, 0.5);
        }
        other => panic!("{other:?}"),
    }
    // The threshold is inclusive: the same target passes at its own consistency, and at 0.
    check_image_target(&tips, &trained(), &x_w, want).unwrap();
    check_image_target(&tips, &trained(), &x_w, 0.0).unwrap();
    // With three cameras, camera 2 is checked against camera 0 by the second geometry.
    let three = tip_model(3, vec![rectified(), rectified()]);
    let mut model = InverseModel::new(6, 2, &model_config()).unwrap();
    let x3 = [200.0, 175.0, 220.0, 175.0, 240.0, 171.0];
    assert!(matches!(
        check_image_target(&three, &model, &x3, 0.5),
        Err(ServoError::TargetInconsistent { camera: 2, .. })
    ));
    // The consistency is checked before the model's coverage.
    model = InverseModel::new(4, 2, &model_config()).unwrap();
    assert!(matches!(
        check_image_target(&tips, &model, &x_w, 0.5),
        Err(ServoError::TargetInconsistent { camera: 1, .. })
    ));
}

#[test]
fn bad_targets_and_unready_recognisers_are_typed_errors() {
    let tips = tip_model(2, vec![rectified()]);
    let model = trained();
    let x_w = [200.0, 175.0, 220.0, 175.0];
    assert!(matches!(
        check_image_target(&tips, &model, &x_w[..3], 0.5),
        Err(ServoError::DimensionMismatch {
            what: "target",
            expected: 4,
            got: 3
        })
    ));
    assert!(matches!(
        check_image_target(&tips, &model, &[200.0, 175.0, f64::NAN, 175.0], 0.5),
        Err(ServoError::NonFinite {
            what: "target",
            index: 2
        })
    ));
    for bad in [-0.1, 1.5, f64::NAN] {
        assert!(
            matches!(
                check_image_target(&tips, &model, &x_w, bad),
                Err(ServoError::InvalidParameter {
                    name: "min_consistency",
                    ..
                })
            ),
            "{bad}"
        );
    }
    // A model of another percept than the recogniser's cameras give.
    assert!(matches!(
        check_image_target(&tip_model(1, vec![]), &model, &x_w, 0.5),
        Err(ServoError::DimensionMismatch { what: "target", .. })
    ));
    // Two or more cameras without the learned consistency.
    assert!(matches!(
        check_image_target(&tip_model(2, vec![]), &model, &x_w, 0.5),
        Err(ServoError::NotEnoughData(_))
    ));
    // Consistent, but outside what the model learned.
    let empty = InverseModel::new(4, 2, &model_config()).unwrap();
    assert_eq!(
        check_image_target(&tips, &empty, &x_w, 0.5),
        Err(ServoError::OutsideModel)
    );
}
