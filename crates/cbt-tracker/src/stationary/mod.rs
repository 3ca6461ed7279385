//! The stationary layout ([`Layout::Stationary`](crate::Layout)): shift-invariant models and
//! the filter that runs them on the posterior's support only.
//!
//! - `model`: the models pooled by displacement (`S[δ]`, `T[δ | v]`, the joint kernel `A`);
//! - `window`: the windowed posterior and its step;
//! - `coupled`: the velocity coupled to position (one per row and column of the window);
//! - `cover`: exact passes over a grid whose non-zero cells lie in a few blocks;
//! - `pool`: large work buffers recycled across the trackers of a thread;
//! - `simd`: the inner loops, with AVX chosen at run time (bit-identical either way).

mod coupled;
mod cover;
mod model;
mod pool;
mod simd;
mod window;

pub(crate) use model::{
    StatObservation, StatSystem, check_space, coordinate_runs, fitted_slopes, motion_radius,
    sigma_radius, start_density,
};
pub(crate) use window::{Patch, WindowState};
