//! # chan-repr: the channel representation
//!
//! Channel coding (thesis ch. 2) turns a compact value `x` into a sparse, localised, non-negative
//! vector of `N` overlapping kernel responses (eq. 2.1)
//!
//! ```text
//! c = [B(x − x̃₁), B(x − x̃₂), …, B(x − x̃_N)]ᵀ
//! ```
//!
//! with kernel `B` and channel centres `x̃_k` ([`ChannelBasis`]). Kernels ([`Kernel`]): the
//! windowed cos² of eq. 2.2, `B(x) = cos²(a x)` for `|x| ≤ π/(2a)`, with `a = π/M`; the
//! quadratic B-spline; and a Gaussian (truncated at 4σ so that encoding stays sparse).
//!
//! **Decoding** is local: every window of `M` consecutive channels `l … l+M−1` gives an estimate
//! and a certainty. For cos² (eq. 2.4, 2.5)
//!
//! ```text
//! x̂_l = l + arg( Σ_{k=l}^{l+M−1} c_k · e^{i·2a·(k−l)} ) / (2a),     r_l = Σ_{k=l}^{l+M−1} c_k
//! ```
//!
//! with `arg ∈ (−π, π]`. An estimate is kept only inside its window's valid range (where every
//! channel of the window lies inside the kernel's support: `[l + M/2 − 1, l + M/2]` in 0-based
//! index units); the kept estimates are the modes, sorted by certainty. For a single encoded
//! value the decoders are exact (the cos² sum is `(M/4)·e^{i2a(x−l)}` since the `M`-th roots of
//! unity sum to zero): decoding returns the value to rounding error anywhere in the
//! representable range `[x̃₁ + (M/2 − 1)·Δ, x̃_N − (M/2 − 1)·Δ]`. The B-spline decoder is
//! `x̂ = l + 1 + (c_{l+2} − c_l) / Σ c` and the Gaussian one the vertex of the parabola
//! through `ln c`, both exact too.
//!
//! **Certainty:** encoding with a weight scales the vector by it; decoded modes report the raw
//! window sum `r_l` (eq. 2.5) and the `weight` it corresponds to.
//!
//! **Periodic channels** ([`PeriodicBasis`]): for angles and orientations, `N` channels on a
//! circle of period `P`, channel `k` centred at `k·P/N`; a value's distance to a centre is
//! measured around the circle, so encoding is the same for `x` and `x + P` and decoding looks
//! at all `N` windows modulo `N`, returning values in `[0, P)`. Line orientations use `P = π`
//! (or the double angle `2φ` on `P = 2π`, as the thesis's orientation channels do).
//!
//! **n-D and soft histograms:** [`ChannelGrid`] encodes vectors by the outer product of 1-D
//! channel vectors (separable), and decodes window by window using the window's per-dimension
//! marginals (exact for separable encodings). Summing channel vectors gives a soft histogram
//! (eq. 2.9): [`SoftHistogram`] (dense) and [`SparseHistogram`] (ordered map of the touched
//! channels); adding a value costs O(active channels), not O(N).
//!
//! ## The thesis's worked example (eq. 2.3–2.9)
//! ```
//! use chan_repr::{ChannelBasis, Kernel};
//! let basis = ChannelBasis::integer(10, Kernel::Cos2 { m: 3 }).unwrap(); // a = π/3
//! let c = basis.encode(3.3).unwrap();
//! let rounded: Vec<f64> = c.iter().map(|v| (v * 100.0).round() / 100.0).collect();
//! assert_eq!(rounded, [0.0, 0.04, 0.90, 0.55, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
//! let modes = basis.decode(&c).unwrap();
//! assert_eq!(modes.len(), 1);
//! assert!((modes[0].value - 3.3).abs() < 1e-12);
//! assert!((modes[0].certainty - 1.5).abs() < 1e-12);
//! ```
//!
//! Errors are typed ([`ChanError`]): out-of-range or non-finite values, negative weights or
//! coefficients, too few channels, kernels too narrow to decode (or, for a Gaussian wider than
//! [`GAUSSIAN_MAX_SIGMA`], too wide: its decoding would be rounding noise).
//!
//! **Limits** (checked before anything is allocated or added): at most [`MAX_CHANNELS`]
//! (2²⁴) channels per basis and per dense vector or histogram (sparse histograms may span
//! larger grids), and per encoded value of an n-D grid; at most [`MAX_WINDOW_CHANNELS`]
//! (2¹²) channels per decoding window of a basis or an n-D grid, which bounds the number of
//! dimensions (and the cos² window `m` of a [`ChannelBasis`]); weights, coefficients and
//! histogram totals at most [`MAX_MASS`] (1e200), so
//! that no window sum can overflow. A rejected value leaves a histogram unchanged.
//!
//! **Deserialisation** runs the same checks as the constructors: a basis, grid, histogram or
//! kernel that they refuse is a serde error carrying the [`ChanError`] message, and so is a
//! decoded result ([`Mode`], [`WindowEstimate`], [`ModeNd`]) with values no decoder produces.
#![deny(missing_docs)]

mod basis;
mod decode;
mod encode;
mod error;
mod grid;
mod histogram;
mod kernel;
mod periodic;

pub use basis::{ChannelBasis, MAX_CHANNELS, MAX_MASS};
pub use decode::{Mode, WindowEstimate};
pub use error::ChanError;
pub use grid::{ChannelGrid, MAX_WINDOW_CHANNELS, ModeNd};
pub use histogram::{SoftHistogram, SparseHistogram};
pub use kernel::{GAUSSIAN_MAX_SIGMA, GAUSSIAN_MIN_SIGMA, GAUSSIAN_SUPPORT_SIGMAS, Kernel};
pub use periodic::{PERIODIC_MAX_TURNS, PeriodicBasis};
