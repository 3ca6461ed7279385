//! The plant seen by the learning and servo loops: commands of the controlled joints in, a
//! percept (the gripper's image position in every camera) out.

use crate::error::{Result, ServoError, check_finite, check_len};

/// What one observation of the plant gives: the percept `x` (for a visual plant: `[u₀, v₀,
/// u₁, v₁, …]`, the gripper point in every camera, pixels) and its certainty in `[0, 1]`.
#[derive(Debug, Clone, PartialEq)]
pub struct Observation {
    /// The percept.
    pub x: Vec<f64>,
    /// Certainty of the recognition (1 for an analytic plant).
    pub certainty: f64,
}

/// A plant: the servo loop's view of a robot with its percept extraction. Implemented by
/// [`crate::VisualPlant`] (a [`crate::Robot`] with a learned [`crate::GripperModel`]) and by
/// analytic plants in tests.
pub trait Plant {
    /// Dimension of the percept `x`.
    fn percept_dim(&self) -> usize;
    /// Number of controlled set-points `y`.
    fn command_dim(&self) -> usize;
    /// Valid range `[min, max]` of controlled set-point `j`, `min ≤ max` (infinite ends allowed;
    /// a NaN end or `min > max` is refused by the loops, see [`check_command`]). Only asked for
    /// `j < command_dim()` (the loops check a command's length first); an implementation may
    /// panic beyond it, as [`crate::VisualPlant`]'s does, like slice indexing.
    fn command_range(&self, j: usize) -> [f64; 2];
    /// Executes the command `y` (controlled set-points only). Implementations may assume that
    /// `y` was checked with [`check_command`].
    fn act(&mut self, y: &[f64]) -> Result<()>;
    /// Observes the current percept.
    fn observe(&mut self) -> Result<Observation>;
    /// Bounds of the percept space, `[min, max]` per component, if known (the image size of a
    /// visual plant); targets outside are rejected with [`ServoError::TargetOutsideImage`].
    fn percept_bounds(&self) -> Option<Vec<[f64; 2]>> {
        None
    }
}

/// Validates a command against the plant: length, finiteness and servo range
/// ([`ServoError::OutOfServoRange`] names the first joint outside). A plant whose range is not
/// a range (a NaN end, or `min > max`) is an [`ServoError::InvalidParameter`] naming
/// `command_range`.
pub fn check_command<P: Plant + ?Sized>(plant: &P, y: &[f64]) -> Result<()> {
    check_len("command", y, plant.command_dim())?;
    check_finite("command", y)?;
    for (joint, &value) in y.iter().enumerate() {
        let [min, max] = checked_range(plant, joint)?;
        if value < min || value > max {
            return Err(ServoError::OutOfServoRange {
                joint,
                value,
                min,
                max,
            });
        }
    }
    Ok(())
}

/// The plant's range of set-point `joint`, refused when it is not a range: a NaN end, or
/// `min > max` ([`ServoError::InvalidParameter`] naming `command_range`). It comes from the
/// plant's own code, and clamping to it (`f64::clamp`) would panic.
pub(crate) fn checked_range<P: Plant + ?Sized>(plant: &P, joint: usize) -> Result<[f64; 2]> {
    let [min, max] = plant.command_range(joint);
    if min <= max {
        Ok([min, max])
    } else {
        Err(ServoError::InvalidParameter {
            name: "command_range",
            reason: format!("the plant's range of joint {joint} is [{min}, {max}], not a range"),
        })
    }
}

/// Validates a target percept: length, finiteness and (if the plant knows them) the percept
/// bounds; for a visual plant, components `2i, 2i+1` are camera `i`'s `(u, v)`. Errors:
/// [`ServoError::DimensionMismatch`] for a target, or a plant's bounds, of another length than
/// the percept; [`ServoError::TargetOutsideImage`] naming the first component's camera.
pub fn check_target<P: Plant + ?Sized>(plant: &P, x_w: &[f64]) -> Result<()> {
    check_len("target", x_w, plant.percept_dim())?;
    check_finite("target", x_w)?;
    let Some(bounds) = plant.percept_bounds() else {
        return Ok(());
    };
    if bounds.len() != x_w.len() {
        return Err(ServoError::DimensionMismatch {
            what: "percept bounds",
            expected: x_w.len(),
            got: bounds.len(),
        });
    }
    let outside = x_w
        .iter()
        .zip(&bounds)
        .position(|(&x, b)| !(x >= b[0] && x <= b[1]));
    if let Some(i) = outside {
        let cam = i / 2;
        let (u, v) = (
            x_w[2 * cam],
            x_w.get(2 * cam + 1).copied().unwrap_or(f64::NAN),
        );
        let size = |k: usize| {
            bounds
                .get(k)
                .map_or(0, |b| (b[1] + 1.0).round().max(0.0) as u32)
        };
        return Err(ServoError::TargetOutsideImage {
            camera: cam,
            u,
            v,
            width: size(2 * cam),
            height: size(2 * cam + 1),
        });
    }
    Ok(())
}
