//! How many numbers a model's layout holds on a grid, checked before anything is allocated.
//!
//! The dense layouts grow with the grid: the separable layout holds per axis `d` an
//! observation matrix of `N_z,d · N_d` cells (counts, model and fallback), a first-order
//! system matrix of `N_d²` (twice, counts and model; once more per phase channel of a
//! [`crate::PeriodicInput`]) and, for the second order, a tensor of `N_d³` (twice); the sparse
//! joint layout builds a dense `N_z,d · N_d` fallback table per axis while it starts, keeps
//! per axis `N_d` system fallback Gaussians of up to `2⌈3σ⌉ + 1` values (`σ` the
//! `fallback_sigma`), and a few numbers per joint cell; both hold the posterior over the
//! `G = Π N_d` joint cells. A grid of 640 channels on an axis (640 px at a spacing of 1 px)
//! asks the separable second order for 2 · 640³ ≈ 5 · 10⁸ numbers (4 GB), and 10⁵ channels
//! ask the observation matrix alone for 10¹⁰: an allocation that aborts the process rather
//! than returning. So learning, and reading a model back, refuse a layout whose estimate
//! exceeds [`MAX_MODEL_VALUES`] with [`TrackError::ModelTooLarge`]. The stationary layout
//! holds displacement kernels and the posterior's window, whose sizes follow the motion and
//! the noise, not the grid: learning caps the kernels' radius, and an untrained model, whose
//! radius follows `fallback_sigma` alone, is checked by [`check_kernels`].

use crate::config::{CbtConfig, Layout, Order};
use crate::{Space, TrackError};

/// The most numbers (`f64`-sized values) a dense layout may hold: 2²⁸, 2 GiB.
pub const MAX_MODEL_VALUES: f64 = 268_435_456.0;

/// Numbers per joint cell of the sparse joint layout beyond its posterior: the fallback's
/// product of the per-axis active channels (3 × 3 for the default kernel, 12 bytes each), a
/// normaliser, the first-order column's header and the background sums (an upper estimate).
const JOINT_PER_CELL: f64 = 24.0;

/// An estimate of the numbers `config`'s layout holds on `space` (computed in `f64`, so it
/// cannot overflow); 0 for the stationary layout.
pub(crate) fn model_values(space: &Space, config: &CbtConfig) -> f64 {
    let dims = space.dims();
    let axis = |d: usize| space.axis_len(d) as f64;
    let meas = |d: usize| space.meas_len(d) as f64;
    let cells: f64 = (0..dims).map(axis).product();
    match config.layout {
        Layout::Stationary => 0.0,
        Layout::Separable => {
            let phases = config.input.map_or(0, |i| i.channels) as f64;
            let per_axis: f64 = (0..dims)
                .map(|d| {
                    let (n, nz) = (axis(d), meas(d));
                    let observation = 3.0 * nz * n + nz + n;
                    let first = 2.0 * n * n * (1.0 + phases);
                    let second = if config.order == Order::Second {
                        2.0 * n * n * n + n * n
                    } else {
                        0.0
                    };
                    observation + first + second
                })
                .sum();
            per_axis + 2.0 * cells
        }
        Layout::SparseJoint => {
            let tables: f64 = (0..dims).map(|d| meas(d) * axis(d)).sum();
            let gz: f64 = (0..dims).map(meas).product();
            // The system fallback's Gaussians: per axis one per channel, of `2⌈3σ⌉ + 1`
            // values at most (cut to the axis). Left out, a long state axis with a short
            // measurement axis and a wide σ passed the check and then allocated N·min(N, 6σ).
            let width = 2.0 * (3.0 * config.fallback_sigma).ceil() + 1.0;
            let gauss: f64 = (0..dims).map(|d| axis(d) * axis(d).min(width)).sum();
            tables + gauss + 5.0 * gz + (JOINT_PER_CELL + 2.0) * cells
        }
    }
}

/// [`TrackError::ModelTooLarge`] when [`model_values`] exceeds [`MAX_MODEL_VALUES`]; for models
/// built here and read back with serde alike (a model read back rebuilds the sparse joint
/// layout's Gaussians).
pub(crate) fn check(space: &Space, config: &CbtConfig) -> Result<(), TrackError> {
    let values = model_values(space, config);
    if values > MAX_MODEL_VALUES {
        return Err(TrackError::ModelTooLarge {
            layout: config.layout,
            values,
        });
    }
    Ok(())
}

/// Numbers the stationary layout's displacement kernels of radius `r` hold, over `dims` axes:
/// per axis the first-order counts and sums and the start column (`3w`) and the second-order
/// counts and model (`2w²`), `w = 2r + 1` (in `f64`, so a saturated `r` cannot overflow).
fn kernel_values(r: usize, dims: usize) -> f64 {
    let w = 2.0 * r as f64 + 1.0;
    dims as f64 * (2.0 * w * w + 3.0 * w)
}

/// An untrained stationary model's kernels of radius `r = ⌈3σ⌉ + 1` (σ the `fallback_sigma`):
/// [`TrackError::InvalidParameter`] `fallback_sigma` when they would hold more than
/// [`MAX_MODEL_VALUES`] numbers (σ above about 1,365 channels on a 2-D grid), instead of an
/// allocation that aborts the process.
pub(crate) fn check_kernels(r: usize, dims: usize, config: &CbtConfig) -> Result<(), TrackError> {
    if kernel_values(r, dims) > MAX_MODEL_VALUES {
        return Err(TrackError::InvalidParameter {
            name: "fallback_sigma",
            value: config.fallback_sigma,
            reason: "an untrained stationary model's displacement kernels (radius 3σ + 1) \
                     would hold more than 2^28 numbers",
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn config(layout: Layout, order: Order) -> CbtConfig {
        CbtConfig {
            layout,
            order,
            ..CbtConfig::default()
        }
    }

    #[test]
    fn the_separable_estimate_counts_its_matrices() {
        // One axis of N channels: 3 N_z N + N_z + N observation, 2 N² first order, 2 N³ + N²
        // second order, 2 N posterior.
        let b = crate::axis(0.0, 10.0, 1.0, crate::DEFAULT_KERNEL).unwrap();
        let space = Space::new(vec![b.clone()], vec![b]).unwrap();
        let n = space.axis_len(0) as f64;
        let nz = space.meas_len(0) as f64;
        let first = 3.0 * nz * n + nz + n + 2.0 * n * n + 2.0 * n;
        assert_eq!(
            model_values(&space, &config(Layout::Separable, Order::First)),
            first
        );
        assert_eq!(
            model_values(&space, &config(Layout::Separable, Order::Second)),
            first + 2.0 * n * n * n + n * n
        );
    }

    #[test]
    fn fine_grids_are_refused_by_layout() {
        // 640 × 480 px at 1 px: the separable second order needs about 5 · 10⁸ numbers.
        let fine = Space::image(640.0, 480.0, 1.0).unwrap();
        for (layout, order, refused) in [
            (Layout::Separable, Order::Second, true),
            (Layout::Separable, Order::First, false),
            (Layout::Stationary, Order::Second, false),
        ] {
            let r = check(&fine, &config(layout, order));
            assert_eq!(r.is_err(), refused, "{layout:?} {order:?}: {r:?}");
        }
        // The same image at 8 px: every layout fits.
        let coarse = Space::image(640.0, 480.0, 8.0).unwrap();
        for layout in [Layout::Separable, Layout::SparseJoint, Layout::Stationary] {
            assert!(check(&coarse, &config(layout, Order::Second)).is_ok());
        }
    }
}
