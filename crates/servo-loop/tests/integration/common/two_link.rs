//! The analytic plant of servo-loop's tests: a planar two-link arm (links `L1`, `L2`) seen by
//! an ideal camera (`PX` pixels per unit length, origin at (320, 240)), commands in `RANGE`
//! (a test module, not part of the library).

use nalgebra::Matrix2;

pub const L1: f64 = 1.2;
pub const L2: f64 = 1.0;
/// Pixels per unit length.
pub const PX: f64 = 100.0;
/// Each joint's command range.
pub const RANGE: [[f64; 2]; 2] = [[0.1, 1.5], [0.3, 2.0]];

/// `x = g(y)`: the tip of the arm in pixels.
pub fn g(y: &[f64]) -> [f64; 2] {
    let (a, b) = (y[0], y[0] + y[1]);
    [
        320.0 + PX * (L1 * a.cos() + L2 * b.cos()),
        240.0 + PX * (L1 * a.sin() + L2 * b.sin()),
    ]
}

/// `∂g/∂y`.
pub fn jac_g(y: &[f64]) -> Matrix2<f64> {
    let (a, b) = (y[0], y[0] + y[1]);
    Matrix2::new(
        PX * (-L1 * a.sin() - L2 * b.sin()),
        PX * (-L2 * b.sin()),
        PX * (L1 * a.cos() + L2 * b.cos()),
        PX * (L2 * b.cos()),
    )
}
