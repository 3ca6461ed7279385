//! Image targets: a pixel position per camera (a point on an object, not a pose the arm has
//! visited), checked against what the learner knows before the arm moves.

use crate::error::{Result, ServoError, check_finite, check_len};
use crate::inverse::InverseModel;
use crate::recognition::TipModel;

/// Whether the image target `x_w` (`[u₀, v₀, u₁, v₁, …]`) lies inside the learned workspace:
/// its cameras' points must be views of one 3-D point (each camera `k ≥ 1` consistent with
/// camera 0 by the recogniser's learned epipolar geometry,
/// [`EpipolarGeometry::consistency`](crate::EpipolarGeometry::consistency) at least
/// `min_consistency`), and the learned inverse model must cover it (a trustworthy receptive
/// field for every command, [`InverseModel::predict`]). Returns the first guess `f̂(x_w)`.
///
/// Errors: a target of another length than the model's percept or not finite; a recogniser
/// without a learned consistency while it has two or more cameras
/// ([`ServoError::NotEnoughData`]); [`ServoError::TargetInconsistent`]; [`ServoError::OutsideModel`].
pub fn check_image_target(
    recogniser: &TipModel,
    model: &InverseModel,
    x_w: &[f64],
    min_consistency: f64,
) -> Result<Vec<f64>> {
    check_len("target", x_w, model.percept_dim())?;
    check_finite("target", x_w)?;
    if !(0.0..=1.0).contains(&min_consistency) {
        return Err(ServoError::invalid("min_consistency", "must lie in [0, 1]"));
    }
    let cams = recogniser.num_cameras();
    check_len("target", x_w, 2 * cams)?;
    let geometries = recogniser.consistency();
    if cams >= 2 && geometries.len() + 1 < cams {
        return Err(ServoError::NotEnoughData(
            "checking an image target needs the cameras' learned consistency".into(),
        ));
    }
    let point = |c: usize| [x_w[2 * c], x_w[2 * c + 1]];
    for (k, g) in geometries.iter().enumerate().take(cams.saturating_sub(1)) {
        let consistency = g.consistency(point(0), point(k + 1));
        if consistency < min_consistency {
            return Err(ServoError::TargetInconsistent {
                camera: k + 1,
                distance_px: g.distance(point(0), point(k + 1)),
                consistency,
                min: min_consistency,
            });
        }
    }
    model.predict(x_w)
}
