//! # lwpr — Locally Weighted Projection Regression
//!
//! Incremental, online regression from `n` inputs to `m` outputs (Vijayakumar, D'Souza and
//! Schaal, *Incremental Online Learning in High Dimensions*, Neural Computation 17(12), 2005),
//! written to reproduce the reference C library (Klanke & Vijayakumar, LWPR 1.2.6) number for
//! number and to be faster than it. Paper C of Larsson's thesis learns an arm's inverse
//! kinematics and its Jacobian with it (papers.md §3.2); [`Lwpr::predict_with_jacobian`] is
//! that Jacobian.
//!
//! ## The model (papers.md §4.2)
//! One independent sub-model per output. Each holds receptive fields `k` with centre `c_k`,
//! distance metric `D_k = M_kᵀM_k` (`M_k` upper triangular, or diagonal with `diag_only`) and
//! activation `w_k = exp(−½ (x−c_k)ᵀD_k(x−c_k))` (Gaussian) or `(1 − q/4)²` (BiSquare). Each
//! field fits a local linear model by incremental partial least squares on `z = x − x̄_k`:
//! `ŷ_k = β₀ + Σ_r β_r s_r`, `s_r = u_rᵀz_r`, `z_{r+1} = z_r − p_r s_r`. The prediction is the
//! normalised weighted mean `ŷ = Σ w_k ŷ_k / Σ w_k` over trustworthy fields with `w_k > cutoff`.
//!
//! ## Training (papers.md §4.3–4.4)
//! Every update normalises `x` and `y` by `norm_in`/`norm_out`, then for each field with
//! `w > 0.001`: forgetting-weighted means, one PLS step with its own forgetting factor per
//! direction (annealed from `init_lambda` to `final_lambda` with `tau_lambda`), a gradient step
//! on the penalised leave-one-out cost for `M` (learning rates `alpha`, optionally meta-learned
//! by IDBD), and the `add_threshold` test for another PLS direction. A field is created at `x`
//! when no activation exceeds `w_gen` (copying the metric of the most active field if that one
//! is trustworthy and has activation above `0.1·w_gen`); one of the two most active fields is
//! removed when the second activation exceeds `w_prune` ([`PruneRule`]).
//!
//! ## Faithfulness to the reference
//! The update performs the reference's floating-point operations in the reference's order
//! (including its dot-product order, see `linalg`), so with the same parameters and samples the
//! learned model is bit-identical to the C library's (checked on the cross function by
//! `tests/reference.rs` and `cargo xtask bench lwpr`). Deliberate differences:
//! - **Pruning**: the reference removes the *wider* field ("TODO: ORIGINAL LOGIC WAS REVERSED"
//!   in its code); we follow the published rule (remove the narrower) unless
//!   [`PruneRule::ReferenceC`] is chosen. With the default `w_prune = 1` and a Gaussian kernel
//!   pruning never fires.
//! - **Prediction** uses a cached slope `∂ŷ_k/∂z` per field (updated after every change)
//!   instead of recomputing the PLS projections, the way the reference does after
//!   `lwpr_predict_J` has run. The two are equal up to rounding (≈1e-16 relative).
//! - With one immature PLS direction the reference reads one element before its CV-error array
//!   (never used afterwards); we use the first element.
//! - Where no trustworthy field is active, the confidence bound is `+∞` (reference: 1e20).
//! - `init_D` must be diagonal when `diag_only` is set (the reference silently mixes them).
//!
//! ## Robustness
//! Non-finite or wrongly sized inputs and invalid parameters return [`LwprError`] and leave the
//! model untouched. Models save to JSON or a compact checksummed binary form with a format
//! version ([`Lwpr::to_json`], [`Lwpr::to_binary`]); loading validates everything.
//!
//! ```
//! use lwpr::LwprBuilder;
//! let mut model = LwprBuilder::new(2, 1).init_d_spherical(50.0).init_alpha(250.0).w_gen(0.2).build()?;
//! let f = |x: f64, y: f64| (-10.0 * x * x).exp().max((-50.0 * y * y).exp());
//! let mut state = 1u64;
//! let mut rnd = || { state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407); (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0 };
//! for _ in 0..3000 {
//!     let (a, b) = (rnd(), rnd());
//!     model.update(&[a, b], &[f(a, b)])?;
//! }
//! let p = model.predict_with_jacobian(&[0.0, 0.5], 0.001)?;
//! assert!((p.y[0] - 1.0).abs() < 0.2);
//! # Ok::<(), lwpr::LwprError>(())
//! ```

#![deny(missing_docs)]
// The numerical kernels index column-major matrices the way the formulas (and the reference) do.
#![allow(clippy::needless_range_loop)]

mod error;
mod io;
mod linalg;
mod metric;
mod model;
mod params;
mod rf;
mod workspace;

pub use error::{LwprError, Result};
pub use io::BINARY_FORMAT_VERSION;
pub use model::{Lwpr, PredictionWithConfidence, PredictionWithJacobian, RfView};
pub use params::{Kernel, LwprBuilder, Params, PruneRule};
