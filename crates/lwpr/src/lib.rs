//! # lwpr — Locally Weighted Projection Regression
//!
//! Incremental, online regression from `n` inputs to `m` outputs (Vijayakumar, D'Souza and
//! Schaal, *Incremental Online Learning in High Dimensions*, Neural Computation 17(12), 2005),
//! written to reproduce the reference C library (Klanke & Vijayakumar, LWPR 1.2.6) number for
//! number and to be faster than it. Paper C of Larsson's thesis learns an arm's inverse
//! kinematics and its Jacobian with it (docs/methods.md § LWPR); [`Lwpr::predict_with_jacobian`] is
//! that Jacobian.
//!
//! ## The model (docs/methods.md § LWPR)
//! One independent sub-model per output. Each holds receptive fields `k` with centre `c_k`,
//! distance metric `D_k = M_kᵀM_k` (`M_k` upper triangular, or diagonal with `diag_only`) and
//! activation `w_k = exp(−½ (x−c_k)ᵀD_k(x−c_k))` (Gaussian) or `(1 − q/4)²` (BiSquare). Each
//! field fits a local linear model by incremental partial least squares on `z = x − x̄_k`:
//! `ŷ_k = β₀ + Σ_r β_r s_r`, `s_r = u_rᵀz_r`, `z_{r+1} = z_r − p_r s_r`. The prediction is the
//! normalised weighted mean `ŷ = Σ w_k ŷ_k / Σ w_k` over trustworthy fields with `w_k > cutoff`.
//!
//! ## Training (docs/methods.md § LWPR)
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
//! For `n ≤ 4` inputs, for diagonal metrics, and always with [`Arithmetic::Reference`], the
//! update performs the reference's floating-point operations in the reference's order
//! (including its dot-product order: blocks of four, remainder backwards; see `linalg`), so with
//! the same parameters and samples the learned model is **bit-identical** to the C library's:
//! every prediction returned by `update` is equal, the receptive-field counts are equal and grid
//! predictions agree to ~4e-16 (`tests/integration/reference.rs`: cross setting A; full metric with
//! meta learning; BiSquare with two outputs and `norm_in`/`norm_out`; the 25-D rotation with full
//! metric, meta learning and pruning; also `cargo xtask bench lwpr`, which fails if that breaks).
//! Tests and bench build the reference with `cc -O3` (`PEER_CFLAGS` in `peer/harness.rs`), the
//! optimisation level of our release build, for the same baseline x86-64 target, no fast-math;
//! with `CI=true` a reference that cannot be built fails those tests instead of skipping them. Rust never fuses a
//! multiply and an add, so rounding is decided by the order of operations alone, and the
//! speed-ups of this exact path keep that order for every value:
//! - the update is compiled separately for input dimensions 1–4 (loops of constant length,
//!   unrolled), and for larger `n` with AVX2 where the CPU has it (runtime detection; separate
//!   multiplies and adds, four lanes per instruction);
//! - every array is sliced once to its exact length before the loops, so the inner loops carry
//!   no bounds checks and do not reload vector headers after each store;
//! - the `O(n³)` sums of the full metric (the activations' `D_:jᵀ(x−c)`, the penalty gradient's
//!   `Σ_i D_ic M_ri` and `D = MᵀM`) run eight or four independent sums side by side from
//!   contiguous rows instead of strided columns, each sum still adding its terms in the
//!   reference's order (this uses that `D` is exactly symmetric, which training keeps and
//!   loading checks);
//! - sums the reference repeats per column are computed once per row (or shared as prefix
//!   sums), and the exponential is skipped for fields whose squared distance puts them below
//!   every threshold that could matter (0.001, `0.1·w_gen`, `w_prune`).
//!
//! ### Full metric with `n ≥ 5`: [`Arithmetic::Fast`] (default)
//! Kept in the reference's order, each of these sums is one long chain of dependent additions,
//! and at `n = 25` with meta learning the update is dominated by them and by the `n(n+1)/2`
//! learning-rate exponentials per active field (a profile of the exact path: the CPU waits on
//! add latencies and on store-to-load forwarding of short accumulator arrays, and on the
//! library `exp` calls, which also keep the element loop from vectorising). The default
//! arithmetic computes the same formulas in an order that vectorises (module `fast`):
//! - the activation as `q = |M(x−c)|²` from the triangular factor (half the work of
//!   `(x−c)ᵀD(x−c)`, and stopped early for fields that are too far away), its `M(x−c)`
//!   reused as the metric gradient's `∂q/∂M` factor;
//! - `MD` (penalty gradient) and `D = MᵀM` as 4 × 8 / 4 × 4 register blocks over contiguous
//!   columns (the lower triangle of `M` is zero, so blocks may start early), `D` mirrored so it
//!   stays exactly symmetric; the meta term `Σ_i M_ri² + M_rc²` from one row sum;
//! - the IDBD step with a branch-free polynomial `exp` (≤ 2 ulp on IDBD's clamped range
//!   `[−10, 10]`), so gradient, IDBD and `M` step run four elements per instruction.
//!
//! Still no fused multiply-adds, so the results do not depend on the vector width or the number
//! of threads. Where the two arithmetics diverge: the first differing value is an
//! activation in its last bit (on the 25-D benchmark the first field's, at sample 2–19
//! depending on the seed; seed 5: sample 11, `0.8502838880516133` vs `0.8502838880516131`);
//! the first differing update prediction follows once that field is trustworthy (update
//! 54–56; seed 5: `0.44551127449819067` vs `0.44551127449819056`). The differences
//! stay at rounding level: on the 25-D cross benchmark (20 000 samples, seeds 1–8, both pruning
//! rules) the same receptive-field count as the reference in every case, nMSE equal to six
//! digits, grid predictions within 1e-12 (`tests/integration/reference.rs` checks 1e-6 against the
//! C library; `tests/integration/arithmetic.rs` checks 1e-9 against [`Arithmetic::Reference`]
//! for n = 5–12). The 25-D update takes about half the CPU time of the exact order
//! (`cargo xtask bench lwpr`: `docs/performance.md`, *lwpr*).
//!
//! Deliberate differences:
//! - **Pruning** follows the reference library, not the published algorithm, by default; see
//!   "Pruning" below.
//! - **Prediction** (`predict`, `predict_batch`) uses the triangular factor for the distance,
//!   `q = |M(x−c)|²` (half the work of `(x−c)ᵀD(x−c)`), and a cached slope `∂ŷ_k/∂z` per field
//!   (updated after every change) instead of recomputing the PLS projections, as the reference
//!   does after `lwpr_predict_J`. Both equal the reference's values up to rounding (≈1e-16).
//!   It is compiled like the update (n = 1–4, AVX) and skips the exponential of fields whose
//!   distance puts them below the cutoff; for `n ≥ 5` the distance is summed four rows at a
//!   time from the bottom up and stopped as soon as it passes that bound (as in
//!   [`Arithmetic::Fast`] training), so far-away fields cost a fraction of `n²/2`.
//! - With one immature PLS direction the reference reads one element before its CV-error array
//!   (never used afterwards); we use the first element.
//! - Where no trustworthy field is active, the confidence bound is `+∞` (reference: 1e20).
//! - Where an active trustworthy field's only PLS direction is immature (possible with one
//!   input and fast forgetting), the reference's confidence bound reads before its CV-error
//!   array; [`Lwpr::predict_with_confidence`] returns [`LwprError::NoConfidence`] there.
//! - `init_D` must be diagonal when `diag_only` is set (the reference silently mixes them).
//!
//! ## Pruning: the reference library's rule is the default
//! When the second-largest activation of an update exceeds `w_prune`, one of the two most
//! active fields is removed. The published algorithm (the 2005 paper, the library's own
//! documentation and its Matlab code) removes the *narrower* field, the one with the larger
//! `tr D`; the reference C library removes the *wider* one (its source says "TODO: ORIGINAL
//! LOGIC WAS REVERSED -- CHECK"). [`PruneRule::ReferenceC`] is the default and
//! [`PruneRule::Published`] an option, because the published rule was the less accurate one
//! on every sample stream measured: it removes fields that metric learning has shrunk onto
//! the data and keeps wide untrained ones, which then suppress the creation of new fields. On
//! the 25-D rotated cross (20 000 samples, full metric, meta learning, `w_prune = 0.7`; eight
//! sample streams, seeds 1–8, same settings, nothing tuned) its nMSE was higher in all eight
//! (median 0.035 against 0.025), and in one (seed 7) the wide field survived every pruning, no
//! field was created again and the model ended with a single field (nMSE 1.02 against 0.022).
//! Receptive fields / nMSE on the 41×41 grid per seed (measured at commit ab96433; the
//! reference C library gave the `ReferenceC` column exactly):
//!
//! | seed | 1 | 2 | 3 | 4 | 5 | 6 | 7 | 8 |
//! |---|---:|---:|---:|---:|---:|---:|---:|---:|
//! | `Published` | 43 / 0.0383 | 45 / 0.0269 | 46 / 0.0239 | 33 / 0.0898 | 55 / 0.0253 | 40 / 0.0358 | 1 / 1.018 | 45 / 0.0346 |
//! | `ReferenceC` | 47 / 0.0358 | 48 / 0.0258 | 51 / 0.0173 | 56 / 0.0213 | 46 / 0.0242 | 44 / 0.0298 | 57 / 0.0219 | 49 / 0.0273 |
//!
//! With the reference's rule the model also stays bit-identical to the C library when pruning
//! fires. With the default `w_prune = 1` and a Gaussian kernel pruning never fires, so the
//! choice matters only when `w_prune` is lowered.
//!
//! ## Confidence and Jacobian
//! [`Lwpr::predict_with_confidence`] returns the reference's bound (docs/methods.md § LWPR); it
//! includes the noise level, and on the cross function (setting A) the noise-free target lies
//! within ±2 bounds of the prediction on at least 90 % of the test grid (measured: 100 %;
//! `tests/integration/confidence.rs`). [`Lwpr::predict_with_jacobian`] returns the prediction and
//! the analytic `m × n` Jacobian (docs/methods.md § LWPR), which matches central finite
//! differences (`tests/integration/jacobian.rs`); servo-loop uses it as the inverse image Jacobian.
//!
//! ## Robustness
//! Non-finite or wrongly sized inputs and invalid parameters return [`LwprError`] and leave the
//! model untouched. Documented limits, checked before anything is allocated or stored:
//! `n_in ≤` [`MAX_INPUTS`] (256), `n_out ≤` [`MAX_OUTPUTS`] (4096), and training inputs and
//! outputs (raw and normalised) of magnitude at most [`MAX_ABS_VALUE`] (1e30; larger finite
//! values could overflow the squares and products in the model's statistics). Models save to
//! JSON or a compact checksummed binary form with a format version ([`Lwpr::to_json`],
//! [`Lwpr::to_binary`]), and to the reference library's XML model files ([`Lwpr::to_xml`],
//! [`Lwpr::from_xml`]: read and written by the C library too, `tests/integration/xml.rs`); loading
//! validates everything, and so does plain serde
//! deserialisation of an [`Lwpr`] or [`Params`] (the same checks, through `try_from`):
//! sizes, finiteness, ranges of the parameters and statistics, and each receptive field's
//! metric (`M` upper triangular with a positive diagonal and `D = MᵀM` within a relative
//! 1e-9, so `D` is positive definite).
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
mod fast;
mod io;
mod linalg;
mod metric;
mod model;
mod params;
mod rf;
mod workspace;
mod xml;

pub use error::{LwprError, Result};
pub use io::{BINARY_FORMAT_VERSION, METRIC_TOLERANCE};
pub use model::{Lwpr, PredictionWithConfidence, PredictionWithJacobian, RfView};
pub use params::{
    Arithmetic, Kernel, LwprBuilder, MAX_ABS_VALUE, MAX_INPUTS, MAX_OUTPUTS, Params, PruneRule,
    check_sizes,
};
