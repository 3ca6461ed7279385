//! Filtering with the stationary models on the posterior's support only
//! ([`Layout::Stationary`](crate::Layout)).
//!
//! The posterior `q_k⁺` is held jointly on the 2-D grid, but only on a window (a rectangle of
//! cells) outside which it is below `support × max` (dropped). One step:
//!
//! 1. **Displacement kernel.** Per axis `d`, the velocity distribution `c_d[v]` carried from
//!    the previous step (step 5) gives the predicted displacement
//!    `D_d[δ] = Σ_v c_d[v] T_d[δ | v]`; first order: `D_d = S_d`, the learned displacement
//!    distribution (the velocities' marginal). The first step after a start (a position
//!    without a velocity) predicts with the start density `S₀_d` learned from the training
//!    runs' first displacements ([`StartMotion::Learned`](crate::StartMotion); with
//!    [`StartMotion::Pooled`](crate::StartMotion) the axes' average) or with `S_d`
//!    ([`StartMotion::Marginal`](crate::StartMotion)), rather than `T_d[· | v = 0]`, which
//!    would claim the target stands still. The velocity is part of the filter's state (`(x, v)` factored as
//!    `q(x)·c_x(v_x)·c_y(v_y)`), not re-derived from the last two posteriors: a correlation of
//!    those, after a missed detection, is the prediction's own spread and loses the walking
//!    velocity exactly when it is needed (measured on the pedestrian study's validation
//!    scenes). Truncations (stated approximations, far below the `support` and crop
//!    thresholds): each column `T_d[· | v]` is summed over the band outside which each tail
//!    holds at most 1e-9 of its mass, and each tail of `D_d` holding at most 1e-5 of its mass
//!    is dropped (`D_d` renormalised).
//! 2. **Prediction** `q⁻ = (1 − γ)·q_{k−1}⁺ ⊛ (D_x ⊗ D_y) + γ/G`: a separable convolution of
//!    the joint posterior (no ghost combinations of one mode's x with another's y), evaluated
//!    lazily only on the cells the update needs.
//! 3. **Update** with the mixture likelihood of [`super::model`]: the floor part
//!    `floor·q⁻` (kept only when it holds more than `support` of the posterior mass, i.e. when
//!    no detection explains the prediction) and one bump per detection `q⁻ ⊙ (b(z_i) ⋆ A)` on
//!    the `(2 r_A + 3)²` cells around it (kept when it holds more than `support` of the mass).
//!    A detection far from the track meets the uniform `γ/G` of the prior: that is the
//!    lost-track recovery.
//! 4. **Estimate**: the best mode is the highest cell's neighbourhood (`decode_radius`
//!    channels), decoded by the first moment of the cos² channel coefficients
//!    (`Σ_n K(x − x̃_n) = 1.5` for every `x`, so the coefficients' mass is the density's; their
//!    first moment is off by up to 0.04 channels for a single point, periodic in its position,
//!    and by far less for a spread density: 0.007 channels for a Gaussian of s.d. 0.3
//!    channels, below 0.001 from 0.5 on), certainty its posterior mass; runner-ups the next
//!    local maxima outside it.
//! 5. **Velocity.** The displacement just made, given the frame: a mixture over the update's
//!    hypotheses with their posterior masses `π` (the miss, i.e. the floor part, and each
//!    significant detection `i`): `c_d ∝ π_miss·D_d + Σ_i π_i·(D_d ⊙ ℓ_{i,d})/|D_d ⊙ ℓ_{i,d}|`,
//!    `ℓ_{i,d}[δ] = Σ_n q_{k−1,d}[n]·β_{i,d}[n + δ]` with `β_{i,d}` the detection's likelihood
//!    along axis `d` (its channels convolved with the kernel's marginal). A miss carries the
//!    predicted velocity on through the learned `T` (as a particle filter carries it in its
//!    particles), a detection sharpens it; one no displacement of `D_d` reaches (lost-track
//!    recovery) contributes `S_d`. With [`Velocity::PerPosition`](crate::Velocity) the
//!    velocity is carried per row and per column instead (module `coupled`: each row's and
//!    column's own kernel in steps 1–2, and the exact joint posterior of the new position
//!    and the displacement as step 5).
//!
//! **Speed.** Every pass is a contiguous `y += k·x` over whole row blocks where the strides
//! allow it (the prediction's x pass: one per kernel tap; the bump: the reflected kernel is
//! stored padded to the bump's row stride, so that its two separable passes are one axpy per
//! active channel), and the inner loops run with AVX when the CPU has it (module `simd`,
//! run-time dispatch, bit-identical to the baseline build). Short rows use AVX intrinsics
//! with lane-mask tails; the prediction's y pass (kernel long against the rows), its x pass
//! (kernel long against the rect), the velocity correlation and the displacement sum (`T`
//! zeroed outside its bands, derived) hold their outputs in registers across all their terms,
//! added in the same order as the plain loops. A posterior whose parts lie far apart (a
//! lost-track hypothesis beside the track: a wide window of mostly exact zeros) is predicted
//! from each row's non-zero extent and runs of non-zero rows only, and its update's sums,
//! maximum, crop and marginals visit the parts' blocks only (module `cover`); exact zeros add
//! `+0` to the non-negative sums, so the values are the dense passes'. Large work buffers come
//! from, and return to, a per-thread pool (module `pool`).

use serde::{Deserialize, Serialize};

use super::coupled::{self, PosKernels, PositionVelocity};
use super::cover::{self, Block};
use super::model::{StatObservation, StatSystem, start_density, tail_band};
use super::pool::{self, refill};
use super::simd::{
    Tap, axpy, axpy_inline, axpy_taps, column_sum, column_totals, conv_cols, conv_rows, correlate,
    lane_max, lane_sum, lane_sum_inline, mul_sum_rows, pad_kernel, peak_candidates, row_extents,
    scale_into, with_avx,
};
use crate::config::{CbtConfig, Order, Velocity};
use crate::integrity::{corrupt, len, nonneg};
use crate::tracker::{Estimate, Hypothesis};
use crate::{Detection, Point, Space, TrackError};

/// Cells below this share of the posterior's maximum are cropped from the window.
const CROP: f64 = 1e-4;
// The peak scan skips cells outside each row's crop extent: they are below its cut.
const _: () = assert!(crate::dense::MIN_SHARE >= 10.0 * CROP);

/// Windows of at least this many cells keep their rows' crop extents for the peak scan
/// (below it, the bookkeeping costs more than the scan it saves).
const EXTENTS_FROM: usize = 1024;

/// Each tail of a displacement kernel holding at most this share of its mass is dropped (the
/// kernel is renormalised): far below the crop and support thresholds, and it shortens a
/// Gaussian kernel of `σ` channels to `± 4.3 σ`.
const KERNEL_TAIL: f64 = 1e-5;

/// Entries of a carried velocity distribution below this share of its mass are dropped.
const VEL_CUT: f64 = 1e-9;

/// A dense rectangle of the joint grid: rows `i0..i0 + h` (axis 0), columns `j0..j0 + w`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub(crate) struct Patch {
    pub i0: usize,
    pub j0: usize,
    pub h: usize,
    pub w: usize,
    pub v: Vec<f64>,
}

impl Patch {
    /// The channel encoding of a (validated, on-grid) point.
    pub fn at_point(space: &Space, p: Point) -> Patch {
        let mut ax: [Vec<(usize, f64)>; 2] = [Vec::new(), Vec::new()];
        for (d, a) in ax.iter_mut().enumerate() {
            let b = space.state_basis(d);
            b.for_each_active(b.to_index(p[d]), |k, v| a.push((k, v)));
        }
        let (i0, j0) = (ax[0][0].0, ax[1][0].0);
        let (h, w) = (ax[0].len(), ax[1].len());
        let mut v = vec![0.0; h * w];
        for &(i, a) in &ax[0] {
            for &(j, b) in &ax[1] {
                v[(i - i0) * w + j - j0] = a * b;
            }
        }
        Patch { i0, j0, h, w, v }
    }

    /// The bounding rectangle of the positive cells of a (validated, non-negative, with
    /// positive mass) joint density over a grid of rows of `ny` cells, with its values.
    pub fn support_of(density: &[f64], ny: usize) -> Patch {
        let (mut a0, mut a1, mut b0, mut b1) = (usize::MAX, 0, usize::MAX, 0);
        for (k, &v) in density.iter().enumerate() {
            if v > 0.0 {
                let (i, j) = (k / ny, k % ny);
                a0 = a0.min(i);
                a1 = a1.max(i + 1);
                b0 = b0.min(j);
                b1 = b1.max(j + 1);
            }
        }
        let mut v = Vec::with_capacity((a1 - a0) * (b1 - b0));
        for i in a0..a1 {
            v.extend_from_slice(&density[i * ny + b0..i * ny + b1]);
        }
        Patch {
            i0: a0,
            j0: b0,
            h: a1 - a0,
            w: b1 - b0,
            v,
        }
    }
}

/// A kernel over offsets `lo..lo + v.len()`.
#[derive(Debug, Clone, Default, PartialEq)]
pub(super) struct Kernel1 {
    pub lo: i64,
    pub v: Vec<f64>,
}

impl Kernel1 {
    pub fn hi(&self) -> i64 {
        self.lo + self.v.len() as i64 - 1
    }
}

/// Half-open rectangle of cells `[a0, a1) × [b0, b1)`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(super) struct Rect {
    pub a0: usize,
    pub a1: usize,
    pub b0: usize,
    pub b1: usize,
}

impl Rect {
    fn union(self, o: Rect) -> Rect {
        Rect {
            a0: self.a0.min(o.a0),
            a1: self.a1.max(o.a1),
            b0: self.b0.min(o.b0),
            b1: self.b1.max(o.b1),
        }
    }
    pub fn rows(&self) -> usize {
        self.a1 - self.a0
    }
    pub fn cols(&self) -> usize {
        self.b1 - self.b0
    }
}

/// The windowed posterior and the marginals of the previous one.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub(crate) struct WindowState {
    pub post: Patch,
    /// Marginals of `q_{k−1}⁺`: `(origin, values)` per axis.
    prev: [(usize, Vec<f64>); 2],
    /// Marginals of `q_k⁺`.
    #[serde(default)]
    cur: [(usize, Vec<f64>); 2],
    /// Set by [`Self::start`] until the first step: the velocity is unknown (a start gives a
    /// position only), so that step predicts with the learned displacement distribution
    /// `S_d` (the velocities' marginal) instead of `T_d[· | v = 0]`, which would claim the
    /// target stands still.
    #[serde(default)]
    fresh: bool,
    /// The velocity distribution carried from step to step (second order), per axis:
    /// `c_d[v]` for `v = −r..=r` at index `v + r` (empty: unknown, after a start or in files
    /// from before it was carried; the step then predicts with `S_d`).
    #[serde(default)]
    vel: [Vec<f64>; 2],
    /// With [`Velocity::PerPosition`]: the velocity per row and per column of the window
    /// instead of `vel` (module `coupled`; empty after a start).
    #[serde(default, skip_serializing_if = "PositionVelocity::is_empty")]
    coupled: PositionVelocity,
    #[serde(skip)]
    scratch: Scratch,
}

/// Reused buffers: not part of the filter's state (equal whatever they hold).
#[derive(Debug, Clone, Default)]
struct Scratch {
    rows: Vec<f64>,
    prior: Vec<f64>,
    bump: Vec<f64>,
    row: Vec<f64>,
    /// Per part: its rectangle, its mass and its values.
    parts: Vec<(Rect, f64, Vec<f64>)>,
    far: Vec<(usize, f64)>,
    nears: Vec<(usize, Rect)>,
    shared: Vec<f64>,
    out: Vec<f64>,
    enc: Vec<Det>,
    /// The displacement kernels of the step (x, y) and their work buffer.
    kernels: (Kernel1, Kernel1),
    disp: DispWork,
    /// Kernel taps of the prediction's y pass: (first source column, length, first output
    /// column, weight).
    taps: Vec<Tap>,
    /// The y kernel with `simd::KPAD` zeros on each side (prediction's y pass).
    kpad: Vec<f64>,
    /// Whether the posterior may hold large regions of exact zeros (its parts cover under
    /// half its rectangle): the prediction then looks for them (an exact shortcut: false
    /// only costs time).
    sparse_post: bool,
    /// Runs of non-zero posterior rows (sparse prediction).
    runs: Vec<Run>,
    /// The blocks of the assembled update outside which it is zero (parts far apart).
    blocks: Vec<Block>,
    /// Those blocks within the posterior, valid while `sparse_post`.
    post_blocks: Vec<Block>,
    /// The non-zero blocks (relative to its rect) of the last prediction computed without
    /// `γ/G` by the sparse path; `None` when not known.
    prior_blocks: Option<Vec<Block>>,
    /// The x kernel times `1 − γ` (prediction's x pass).
    kk: Vec<f64>,
    /// The detection of each update part (index into `enc`), parallel to `parts`.
    part_det: Vec<usize>,
    /// The significant hypotheses of the update: (detection, mass) (velocity step).
    hyps: Vec<(usize, f64)>,
    /// With [`Velocity::PerPosition`], during a step: the per-row and per-column
    /// displacement kernels of the posterior (module `coupled`); the prediction uses them.
    pos: Option<Box<(PosKernels, PosKernels)>>,
    /// Per posterior row, the columns `[first, last + 1)` of its cells that passed the crop
    /// (`≥ CROP × max` before normalising), or empty when not known: the peak scan's
    /// candidates (`≥ MIN_SHARE × max`) lie within them.
    post_ext: Vec<(u32, u32)>,
    /// The velocity step's work buffers (`carry_velocity`).
    vel: VelWork,
}

/// Work buffers of the velocity step: the observation kernel's marginals per axis and the
/// per-hypothesis `β`, `ℓ` and the correlation's padded copy.
#[derive(Debug, Clone, Default)]
struct VelWork {
    am: [Vec<f64>; 2],
    beta: Vec<f64>,
    c: Vec<f64>,
    rev: Vec<f64>,
}

impl Drop for Scratch {
    /// The large buffers go back to the thread's pool (module `pool`).
    fn drop(&mut self) {
        for v in [
            &mut self.rows,
            &mut self.prior,
            &mut self.bump,
            &mut self.row,
            &mut self.shared,
            &mut self.out,
        ] {
            pool::give(std::mem::take(v));
        }
        for (_, _, v) in &mut self.parts {
            pool::give(std::mem::take(v));
        }
    }
}

impl Drop for WindowState {
    /// The posterior's buffer goes back to the thread's pool (module `pool`).
    fn drop(&mut self) {
        pool::give(std::mem::take(&mut self.post.v));
    }
}

impl PartialEq for Scratch {
    fn eq(&self, _: &Scratch) -> bool {
        true
    }
}

/// Work buffers of the displacement kernel: the kernel before its tails are cut and the
/// velocity terms `(v + r, c[v])`.
#[derive(Debug, Clone, Default)]
pub(super) struct DispWork {
    out: Vec<f64>,
    terms: Vec<(usize, f64)>,
}

/// What steps 2 and 3 of [`WindowState::step`] found before the update is assembled: the
/// prediction's support, where its shared prior was made, and the masses of the update's
/// parts and floor.
struct Bumps {
    /// The prediction's support (the posterior's window grown by the kernels).
    full: Rect,
    /// Where the shared prior was made: the near bumps' span, or the whole support when they
    /// cover much of it (`None`: no detection near the support).
    span: Option<Rect>,
    /// The near bumps cover little of their span: each made its own prior, the shared one
    /// was not made.
    per_bump: bool,
    /// `1 − γ`.
    keep: f64,
    /// `γ/G`.
    u: f64,
    /// The parts in use: the first `n_parts` of the scratch's `parts`.
    n_parts: usize,
    /// Mass of the parts, of the far detections and of the floor.
    total: f64,
    /// Mass of the floor part (the miss).
    floor_mass: f64,
    /// `support`: a part holding more than this share of `total` is significant.
    eps: f64,
    /// Whether the floor part is kept (no detection, no mass, or a significant floor).
    use_floor: bool,
}

impl Bumps {
    /// Whether a part of mass `m` is significant.
    fn significant(&self, m: f64) -> bool {
        self.total > 0.0 && m > self.eps * self.total
    }
}

/// One detection in channel-index coordinates, its active channels per axis and its weight.
#[derive(Debug, Clone, Default)]
struct Det {
    ax: Active,
    ay: Active,
    /// Detection weight over its encoding's mass.
    w: f64,
    /// Detection weight.
    weight: f64,
}

fn dets_weight(d: &Det) -> f64 {
    d.weight
}

/// The active channels of one coordinate (consecutive, at most 3 for the cos² kernel with
/// `a = π/3` the stationary layout requires).
#[derive(Debug, Clone, Copy, Default)]
struct Active {
    k0: usize,
    n: usize,
    v: [f64; 3],
}

impl Active {
    fn of(basis: &chan_repr::ChannelBasis, t: f64) -> Active {
        let mut a = Active {
            k0: 0,
            n: 0,
            v: [0.0; 3],
        };
        basis.for_each_active(t, |k, v| {
            if a.n == 0 {
                a.k0 = k;
            }
            if a.n < 3 {
                a.v[a.n] = v;
                a.n += 1;
            }
        });
        a
    }
    fn first(&self) -> usize {
        self.k0
    }
    fn last(&self) -> usize {
        self.k0 + self.n - 1
    }
    fn mass(&self) -> f64 {
        self.v[..self.n].iter().sum()
    }
}

#[inline(never)]
fn marginals(p: &Patch) -> [(usize, Vec<f64>); 2] {
    let mut m = [(0, Vec::new()), (0, Vec::new())];
    marginals_into(p, &mut m);
    m
}

/// Per-axis marginals of a patch into reused buffers.
fn marginals_into(p: &Patch, m: &mut [(usize, Vec<f64>); 2]) {
    let [(ox, mx), (oy, my)] = m;
    *ox = p.i0;
    *oy = p.j0;
    mx.clear();
    mx.resize(p.h, 0.0);
    my.clear();
    my.resize(p.w, 0.0);
    column_totals(my, &p.v, p.w, p.h);
    with_avx(|| {
        for (i, row) in p.v.chunks_exact(p.w.max(1)).enumerate() {
            mx[i] = lane_sum_inline(row);
        }
    });
}

impl WindowState {
    /// Consistency of a deserialised window with `space` and the model's system models `sys`
    /// (one per axis); the current marginals, which older files lack, are recomputed from the
    /// posterior when missing, and must otherwise cover the posterior window's rows and
    /// columns exactly (as every step leaves them). A carried velocity distribution is empty
    /// (unknown) or, as every step leaves it, one entry per velocity of its axis's system
    /// model (`2r + 1`) with positive mass: one of another length used to be taken silently
    /// as unknown.
    pub fn check(&mut self, space: &Space, sys: &[StatSystem]) -> Result<(), TrackError> {
        let p = &self.post;
        let (nx, ny) = (space.axis_len(0), space.axis_len(1));
        // `origin + cells ≤ axis length`, without overflowing on a huge saved origin or size
        // (which panicked, or wrapped into range in a release build).
        let fits = |o: usize, n: usize, axis: usize| o.checked_add(n).is_some_and(|e| e <= axis);
        if p.h == 0 || p.w == 0 || !fits(p.i0, p.h, nx) || !fits(p.j0, p.w, ny) {
            return Err(corrupt(format!(
                "posterior window {}×{} at ({}, {}) does not fit the {nx}×{ny} grid",
                p.h, p.w, p.i0, p.j0
            )));
        }
        // Within the grid now, whose cell count fits a usize (`ChannelGrid::new`).
        len("posterior window", p.v.len(), p.h * p.w)?;
        nonneg("posterior window", &p.v)?;
        if p.v.iter().sum::<f64>() <= 0.0 {
            return Err(corrupt("the posterior window has no mass"));
        }
        // Every start and step leaves the window normalised: a scaled one reported scaled
        // certainties.
        crate::integrity::unit_mass("the posterior window", &p.v)?;
        if self.cur[0].1.is_empty() && self.cur[1].1.is_empty() {
            self.cur = marginals(&self.post);
        }
        for (d, (o, n)) in [(p.i0, p.h), (p.j0, p.w)].into_iter().enumerate() {
            let (co, cv) = &self.cur[d];
            if (*co, cv.len()) != (o, n) {
                return Err(corrupt(format!(
                    "current marginal of axis {d} ({} cells from {co}) does not match the \
                     posterior window ({n} cells from {o})",
                    cv.len()
                )));
            }
        }
        for (what, m) in [("previous", &self.prev), ("current", &self.cur)] {
            for (d, (o, v)) in m.iter().enumerate() {
                if !fits(*o, v.len(), space.axis_len(d)) {
                    return Err(corrupt(format!(
                        "{what} marginal of axis {d} ({} cells from {o}) beyond the grid",
                        v.len()
                    )));
                }
                nonneg("posterior marginal", v)?;
            }
        }
        len("system models", sys.len(), 2)?;
        for (d, v) in self.vel.iter().enumerate() {
            nonneg("velocity distribution", v)?;
            if v.is_empty() {
                continue;
            }
            len("velocity distribution", v.len(), 2 * sys[d].radius() + 1)?;
            if v.iter().sum::<f64>() <= 0.0 {
                return Err(corrupt(format!(
                    "the velocity distribution of axis {d} has no mass"
                )));
            }
        }
        self.coupled.check(&self.post, sys)
    }

    /// Starts from a joint density given on a patch (normalised, cropped here).
    pub fn start(&mut self, mut p: Patch) {
        let s: f64 = p.v.iter().sum();
        p.v.iter_mut().for_each(|v| *v /= s);
        self.post = p;
        self.scratch.sparse_post = false;
        self.scratch.post_ext.clear();
        self.cur = marginals(&self.post);
        self.prev = self.cur.clone();
        self.fresh = true;
        self.vel = Default::default();
        self.coupled = Default::default();
    }

    /// Displacement kernel of axis `d` (step 1 of the module doc) into `k`, with `work` as
    /// the work buffers; `start`: the start density (the first step after a start).
    fn displacement_into(
        &self,
        sys: &StatSystem,
        d: usize,
        order: Order,
        start: Option<&[f64]>,
        work: &mut DispWork,
        k: &mut Kernel1,
    ) {
        displacement_from(sys, &self.vel[d], order, start, work, k);
    }

    /// `(1 − γ)·(q ⊛ D)` on `rect`, plus `γ/G`, into `out` (row-major over the rect).
    fn prior(&mut self, kx: &Kernel1, ky: &Kernel1, keep: f64, u: f64, rect: Rect) -> Vec<f64> {
        let mut out = Vec::new();
        self.prior_into(kx, ky, keep, u, rect, &mut out);
        out
    }

    /// [`Self::prior`] into a reused buffer.
    #[inline(never)]
    fn prior_into(
        &mut self,
        kx: &Kernel1,
        ky: &Kernel1,
        keep: f64,
        u: f64,
        rect: Rect,
        out: &mut Vec<f64>,
    ) {
        self.scratch.prior_blocks = None;
        if let Some(pk) = self.scratch.pos.as_deref() {
            coupled::predict(&self.post, pk, keep, u, rect, &mut self.scratch.rows, out);
            return;
        }
        let p = &self.post;
        refill(out, rect.rows() * rect.cols(), u);
        // Rows a of the posterior reaching rect: i = a + δ, δ ∈ [kx.lo, kx.hi].
        let a_lo = (rect.a0 as i64 - kx.hi()).max(p.i0 as i64);
        let a_hi = (rect.a1 as i64 - kx.lo).min((p.i0 + p.h) as i64);
        if a_lo >= a_hi {
            return;
        }
        let (a_lo, a_hi) = (a_lo as usize, a_hi as usize);
        let nc = rect.cols();
        let rows = &mut self.scratch.rows;
        refill(rows, (a_hi - a_lo) * nc, 0.0);
        // Along y: rows[a][j] = Σ_δ D_y[δ] q[a, j − δ], the terms by increasing δ (columns
        // b = j − δ − j0 of the posterior row). Kernel long against the rows: four outputs at
        // a time in a register; short: one contiguous axpy per kernel tap (module `simd`;
        // the same values either way).
        let src = &p.v[(a_lo - p.i0) * p.w..(a_hi - p.i0) * p.w];
        let n = a_hi - a_lo;
        // A posterior with large regions of exact zeros (parts far apart): each row's
        // non-zero cells only, and runs of non-zero rows only (see `sparse_prior`).
        if self.scratch.sparse_post {
            let runs = &mut self.scratch.runs;
            runs.clear();
            let mut cells = 0;
            row_extents(src, p.w, 0.0, |i, f, l| {
                cells += l + 1 - f;
                match runs.last_mut() {
                    Some(r) if r.end == i => {
                        r.end = i + 1;
                        r.ext.push((f, l));
                    }
                    _ => runs.push(Run {
                        start: i,
                        end: i + 1,
                        ext: vec![(f, l)],
                        cols: (0, 0),
                    }),
                }
            });
            if 2 * cells < n * p.w {
                let kpad = &mut self.scratch.kpad;
                pad_kernel(kpad, &ky.v);
                let base = rect.b0 as i64 - p.j0 as i64 - ky.lo;
                let mut runs = std::mem::take(&mut self.scratch.runs);
                sparse_prior(rows, src, p.w, nc, &mut runs, kpad, base);
                x_pass_runs(out, rows, nc, &mut runs, kx, keep, a_lo, rect);
                if u == 0.0 {
                    // Without γ/G the prediction is zero beyond each run's reach.
                    let (lo, hi) = (rect.a0 as i64, rect.a1 as i64);
                    let blocks = runs
                        .iter()
                        .filter_map(|run| {
                            let r0 = ((a_lo + run.start) as i64 + kx.lo).clamp(lo, hi);
                            let r1 = ((a_lo + run.end - 1) as i64 + kx.hi() + 1).clamp(lo, hi);
                            let (c0, c1) = run.cols;
                            (r0 < r1 && c0 < c1).then(|| Block {
                                r0: (r0 - lo) as usize,
                                r1: (r1 - lo) as usize,
                                c0,
                                c1,
                            })
                        })
                        .collect();
                    self.scratch.prior_blocks = Some(blocks);
                }
                self.scratch.runs = runs;
                return;
            }
        }
        if 2 * ky.v.len() > p.w {
            let kpad = &mut self.scratch.kpad;
            pad_kernel(kpad, &ky.v);
            let base = rect.b0 as i64 - p.j0 as i64 - ky.lo;
            conv_rows(rows, nc, src, p.w, p.w, n, kpad, base);
        } else {
            let taps: &mut Vec<Tap> = &mut self.scratch.taps;
            taps.clear();
            for (t, &k) in ky.v.iter().enumerate() {
                let delta = ky.lo + t as i64;
                let b_lo = (rect.b0 as i64 - p.j0 as i64 - delta).max(0);
                let b_hi = (rect.b1 as i64 - p.j0 as i64 - delta).min(p.w as i64);
                if b_lo >= b_hi || k == 0.0 {
                    continue;
                }
                let d0 = (p.j0 as i64 + b_lo + delta - rect.b0 as i64) as usize;
                taps.push((b_lo as usize, (b_hi - b_lo) as usize, d0, k));
            }
            axpy_taps(rows, nc, src, p.w, n, taps);
        }
        // Along x: out[i][j] += Σ_a (keep · D_x[i − a]) rows[a][j], each cell's terms by
        // increasing a (rows of `rows` and `out` share the stride `nc`). Kernel at least
        // 1.25 × as long as the rect's rows: each output row held in registers across its
        // terms; shorter: one contiguous axpy per tap δ = i − a over all the rows it joins,
        // taps by decreasing δ (module `simd`; the same values either way).
        if 4 * kx.v.len() >= 5 * rect.rows() {
            let kk = &mut self.scratch.kk;
            kk.clear();
            kk.extend(kx.v.iter().map(|&kv| keep * kv));
            // Tap t = δ − kx.lo with δ = i − a (absolute rows) = i_r − a_r + rect.a0 − a_lo.
            let base = rect.a0 as i64 - a_lo as i64 - kx.lo;
            conv_cols(out, rect.rows(), rows, n, nc, kk, base);
            return;
        }
        with_avx(|| {
            for (t, &kv) in kx.v.iter().enumerate().rev() {
                let delta = kx.lo + t as i64;
                let lo = (a_lo as i64).max(rect.a0 as i64 - delta);
                let hi = (a_hi as i64).min(rect.a1 as i64 - delta);
                if lo >= hi {
                    continue;
                }
                let k = keep * kv;
                let n = (hi - lo) as usize * nc;
                let src = &rows[(lo as usize - a_lo) * nc..][..n];
                let dst = &mut out[((lo + delta) as usize - rect.a0) * nc..][..n];
                axpy_inline(dst, src, k);
            }
        });
    }

    /// Part `q⁻ ⊙ (b(z) ⋆ A)` of one detection on `rect` into `out`; returns its mass.
    #[allow(clippy::too_many_arguments)]
    #[inline(never)]
    fn bump_part(
        &mut self,
        det: &Det,
        obs: &StatObservation,
        kx: &Kernel1,
        ky: &Kernel1,
        keep: f64,
        u: f64,
        rect: Rect,
        shared: Option<(Rect, &[f64])>,
        out: &mut Vec<f64>,
    ) -> f64 {
        // The prior on `rect`: read from the one computed on a rectangle holding it (no copy:
        // the products below read it there), or computed here into `out`.
        let src = match shared {
            Some((big, pr)) => {
                out.resize(rect.rows() * rect.cols(), 0.0);
                let first = (rect.a0 - big.a0) * big.cols() + rect.b0 - big.b0;
                Some((&pr[first..], big.cols()))
            }
            None => {
                self.prior_into(kx, ky, keep, u, rect, out);
                None
            }
        };
        let ra = obs.kernel_radius() as i64;
        // The point-reflected kernel F[p][q] = A[−(p − ra)][−(q − ra)]:
        // bump[i][j] += c · F[i − m_x + ra][j − m_y + ra], contiguous in j.
        let kw = (2 * ra + 1) as usize;
        let nc = rect.cols();
        // Separably: G[p][q] = Σ_t v_y[t] F[p][q − t] on the kernel's rows (q over the bump's
        // columns, first column m_y0 − ra), then bump row i = w · Σ_t v_x[t] G[i − m_x0 + ra − t].
        let (kx0, ky0) = (det.ax.first() as i64 - ra, det.ay.first() as i64 - ra);
        let ww = det.ay.n + kw - 1;
        // Rows of the bump B (first row kx0, stride ww) the rect needs, and the rows of G
        // they read. G and B as contiguous axpys over whole row blocks of stride ww: the
        // kernel padded to that stride (zeros in its last ww − kw columns catch the shifts
        // across rows).
        let (r0, r1) = (
            (rect.a0 as i64 - kx0) as usize,
            (rect.a1 as i64 - kx0) as usize,
        );
        let (p0, p1) = (r0.saturating_sub(det.ax.n - 1), r1.min(kw));
        let fpad = obs.padded_kernel(det.ay.n);
        // The first tap of each pass assigns (its range holds every row it writes to), so
        // neither buffer needs clearing; rows of G outside [p0, p1) are never read.
        let g = &mut self.scratch.bump;
        g.resize(kw * ww, 0.0);
        if p0 < p1 {
            let (lo, hi) = (p0 * ww, p1 * ww);
            for (t, &c) in det.ay.v[..det.ay.n].iter().enumerate() {
                let lo = lo.max(t);
                if t == 0 {
                    scale_into(&mut g[lo..hi], &fpad[lo..hi], c);
                } else {
                    axpy(&mut g[lo..hi], &fpad[lo - t..hi - t], c);
                }
            }
        }
        let b = &mut self.scratch.row;
        b.resize((r1 - r0) * ww, 0.0);
        // Rows the first tap does not reach start at zero.
        b[(r1.min(kw).max(r0) - r0) * ww..].fill(0.0);
        for (t, &vx) in det.ax.v[..det.ax.n].iter().enumerate() {
            // B row r = G row r − t, for r in [r0, r1) with r − t in [0, kw).
            let (lo, hi) = (r0.max(t), r1.min(t + kw));
            if lo >= hi {
                continue;
            }
            let c = det.w * vx;
            let n = (hi - lo) * ww;
            let src = &g[(lo - t) * ww..][..n];
            let dst = &mut b[(lo - r0) * ww..][..n];
            if t == 0 {
                scale_into(dst, src, c);
            } else {
                axpy(dst, src, c);
            }
        }
        // Columns of the rect within the bump's columns.
        let q0 = (rect.b0 as i64 - ky0) as usize;
        mul_sum_rows(out, nc, src, b, ww, q0, r1 - r0)
    }

    /// One predict + update step, in the phases of the module doc. Validates and encodes
    /// every detection first: on error the state is unchanged.
    pub fn step(
        &mut self,
        space: &Space,
        cfg: &CbtConfig,
        obs: &StatObservation,
        sys: &[StatSystem],
        dets: &[Detection],
    ) -> Result<(), TrackError> {
        let enc = self.encode(space, dets)?;
        let (kx, ky) = self.kernels(sys, cfg);
        let bumps = self.bumps(space, cfg, obs, &enc, &kx, &ky);
        let rect = self.hypotheses(cfg, obs, sys, &enc, (&kx, &ky), &bumps);
        let Some(rect) = rect else {
            // Nothing significant (cannot happen with a positive floor): keep the prior.
            self.scratch.enc = enc;
            self.scratch.kernels = (kx, ky);
            self.scratch.pos = None;
            return Ok(());
        };
        let (out, blocks, sparse) = self.assemble(&kx, &ky, &bumps, enc.is_empty(), rect);
        self.scratch.enc = enc;
        self.scratch.kernels = (kx, ky);
        // The per-position velocities from the update and the prediction (module `coupled`).
        let next = self
            .scratch
            .pos
            .take()
            .map(|pk| coupled::update(&self.post, &pk, bumps.keep, bumps.u, &out, sys));
        if self.normalise(out, blocks, sparse)
            && let Some(mut next) = next
        {
            next.crop(&self.post);
            self.coupled = next;
        }
        Ok(())
    }

    /// Validates every detection and encodes it in channel-index coordinates (detections of
    /// weight 0 or no channel mass are left out).
    fn encode(&mut self, space: &Space, dets: &[Detection]) -> Result<Vec<Det>, TrackError> {
        let mut enc = std::mem::take(&mut self.scratch.enc);
        enc.clear();
        for det in dets {
            let t = space.detection_index(det)?;
            if det.weight == 0.0 {
                continue;
            }
            let ax = Active::of(space.meas_basis(0), t[0]);
            let ay = Active::of(space.meas_basis(1), t[1]);
            let mass = ax.mass() * ay.mass();
            if mass > 0.0 {
                enc.push(Det {
                    ax,
                    ay,
                    w: det.weight / mass,
                    weight: det.weight,
                });
            }
        }
        Ok(enc)
    }

    /// Step 1 of the module doc: the displacement kernels `(D_x, D_y)` (first order on the
    /// first step after a start). With [`Velocity::PerPosition`] (second order) also the
    /// per-row and per-column kernels (module `coupled`, into the scratch space; cells
    /// without a velocity take the factored kernel), and `(D_x, D_y)` become their averages
    /// (whose extents bound them all).
    fn kernels(&mut self, sys: &[StatSystem], cfg: &CbtConfig) -> (Kernel1, Kernel1) {
        let (mut kx, mut ky) = std::mem::take(&mut self.scratch.kernels);
        let mut work = std::mem::take(&mut self.scratch.disp);
        let starts = self
            .fresh
            .then(|| [0, 1].map(|d| start_density(sys, d, cfg.start)));
        let start = |d: usize| starts.as_ref().map(|s| &s[d][..]);
        self.displacement_into(&sys[0], 0, cfg.order, start(0), &mut work, &mut kx);
        self.displacement_into(&sys[1], 1, cfg.order, start(1), &mut work, &mut ky);
        self.fresh = false;
        self.scratch.pos = None;
        if cfg.velocity == Velocity::PerPosition && cfg.order == Order::Second {
            let [(ox, mx), (oy, my)] = &self.cur;
            let (px, ax) =
                PosKernels::build(&sys[0], &self.coupled.axes[0], *ox, mx, &kx, &mut work);
            let (py, ay) =
                PosKernels::build(&sys[1], &self.coupled.axes[1], *oy, my, &ky, &mut work);
            (kx, ky) = (ax, ay);
            self.scratch.pos = Some(Box::new((px, py)));
        }
        self.scratch.disp = work;
        (kx, ky)
    }

    /// Steps 2 and 3 of the module doc up to the assembly: the prediction on the cells the
    /// update needs (the shared prior), and the update's parts (one per detection whose bump
    /// meets the prediction's support, and each significant far one) with their masses.
    fn bumps(
        &mut self,
        space: &Space,
        cfg: &CbtConfig,
        obs: &StatObservation,
        enc: &[Det],
        kx: &Kernel1,
        ky: &Kernel1,
    ) -> Bumps {
        let (nx, ny) = (space.axis_len(0), space.axis_len(1));
        let gamma = cfg.mixing;
        let keep = 1.0 - gamma;
        let u = gamma / space.cells() as f64;
        let p = &self.post;
        // The prediction's support (the posterior's window grown by the kernels).
        let full = Rect {
            a0: (p.i0 as i64 + kx.lo).max(0) as usize,
            a1: ((p.i0 + p.h) as i64 + kx.hi()).clamp(1, nx as i64) as usize,
            b0: (p.j0 as i64 + ky.lo).max(0) as usize,
            b1: ((p.j0 + p.w) as i64 + ky.hi()).clamp(1, ny as i64) as usize,
        };
        let full = Rect {
            a1: full.a1.max(full.a0 + 1),
            b1: full.b1.max(full.b0 + 1),
            ..full
        };
        let mut parts = std::mem::take(&mut self.scratch.parts);
        let mut part_det = std::mem::take(&mut self.scratch.part_det);
        part_det.clear();
        let mut n_parts = 0;
        let mut total = 0.0;
        let ra = obs.kernel_radius();
        let bump_rect = |det: &Det| Rect {
            a0: det.ax.first().saturating_sub(ra),
            a1: (det.ax.last() + ra + 1).min(nx),
            b0: det.ay.first().saturating_sub(ra),
            b1: (det.ay.last() + ra + 1).min(ny),
        };
        // Near detections (their bump meets the prediction's support): computed on the
        // intersection (outside it the prior is the uniform γ/G only). Far ones meet only
        // the uniform part: their mass is γ/G · w · P̂_D, computed below when significant.
        let mut far_mass = 0.0;
        let mut far = std::mem::take(&mut self.scratch.far);
        far.clear();
        let mut nears = std::mem::take(&mut self.scratch.nears);
        nears.clear();
        let mut span: Option<Rect> = None;
        for (k, det) in enc.iter().enumerate() {
            let r = bump_rect(det);
            let near = Rect {
                a0: r.a0.max(full.a0),
                a1: r.a1.min(full.a1),
                b0: r.b0.max(full.b0),
                b1: r.b1.min(full.b1),
            };
            if near.a0 >= near.a1 || near.b0 >= near.b1 {
                let m = u * dets_weight(det) * obs.p_detect();
                far_mass += m;
                far.push((k, m));
            } else {
                span = Some(span.map_or(near, |s| s.union(near)));
                nears.push((k, near));
            }
        }
        // The prior once on the span of the near bumps.
        // The prior once: on the whole prediction support when the bumps cover much of it
        // (it then also serves the floor part), else on the bumps' span.
        let area = |r: &Rect| r.rows() * r.cols();
        let span = span.map(|sp| {
            if 2 * area(&sp) > area(&full) {
                full
            } else {
                sp
            }
        });
        // Bumps covering little of their span (far apart): the prior on each bump's own
        // rect instead (the same values per cell); the one on the whole support is then made
        // only if the floor part needs it.
        let bump_cells: usize = nears.iter().map(|(_, r)| area(r)).sum();
        let per_bump = span.is_some_and(|sp| 4 * bump_cells < area(&sp));
        let mut shared = std::mem::take(&mut self.scratch.shared);
        if let Some(sp) = span.filter(|_| !per_bump) {
            self.prior_into(kx, ky, keep, u, sp, &mut shared);
        }
        for &(k, near) in &nears {
            if parts.len() <= n_parts {
                parts.push((near, 0.0, Vec::new()));
            }
            let mut buf = std::mem::take(&mut parts[n_parts].2);
            let sh = span.filter(|_| !per_bump).map(|sp| (sp, &shared[..]));
            let mass = self.bump_part(&enc[k], obs, kx, ky, keep, u, near, sh, &mut buf);
            parts[n_parts] = (near, mass, buf);
            part_det.push(k);
            n_parts += 1;
            total += mass;
        }
        self.scratch.shared = shared;
        self.scratch.nears = nears;
        total += far_mass;
        for &(k, m) in &far {
            if m > cfg.support * (total + obs.floor()) {
                let r = bump_rect(&enc[k]);
                if parts.len() <= n_parts {
                    parts.push((r, 0.0, Vec::new()));
                }
                let mut buf = std::mem::take(&mut parts[n_parts].2);
                let mass = self.bump_part(&enc[k], obs, kx, ky, keep, u, r, None, &mut buf);
                parts[n_parts] = (r, mass, buf);
                part_det.push(k);
                n_parts += 1;
            }
        }
        self.scratch.far = far;
        let floor_mass = obs.floor();
        total += floor_mass;
        let eps = cfg.support;
        let use_floor = enc.is_empty()
            || total.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater)
            || floor_mass > eps * total;
        self.scratch.parts = parts;
        self.scratch.part_det = part_det;
        Bumps {
            full,
            span,
            per_bump,
            keep,
            u,
            n_parts,
            total,
            floor_mass,
            eps,
            use_floor,
        }
    }

    /// Step 5 of the module doc: the hypotheses the posterior is made of (the miss, i.e. the
    /// floor part, and each significant detection, with their masses) carry the velocity to
    /// the next step (second order). Reads the marginals of `q_{k−1}⁺`, so it runs before
    /// they are replaced. Returns the update's rectangle (`None`: nothing significant).
    fn hypotheses(
        &mut self,
        cfg: &CbtConfig,
        obs: &StatObservation,
        sys: &[StatSystem],
        enc: &[Det],
        kernels: (&Kernel1, &Kernel1),
        b: &Bumps,
    ) -> Option<Rect> {
        let parts = std::mem::take(&mut self.scratch.parts);
        let part_det = std::mem::take(&mut self.scratch.part_det);
        let mut rect: Option<Rect> = None;
        if b.use_floor {
            rect = Some(b.full);
        }
        for &(r, mass, _) in &parts[..b.n_parts] {
            if b.significant(mass) {
                rect = Some(rect.map_or(r, |x| x.union(r)));
            }
        }
        let mut hyps = std::mem::take(&mut self.scratch.hyps);
        hyps.clear();
        let miss = if enc.is_empty() {
            1.0
        } else if b.use_floor {
            b.floor_mass
        } else {
            0.0
        };
        if !enc.is_empty() {
            for (&(_, mass, _), &k) in parts[..b.n_parts].iter().zip(&part_det) {
                if b.significant(mass) {
                    hyps.push((k, mass));
                }
            }
        }
        self.scratch.part_det = part_det;
        self.scratch.parts = parts;
        if cfg.order == Order::Second && self.scratch.pos.is_none() {
            self.carry_velocity(sys, obs, kernels, enc, &hyps, miss);
        }
        self.scratch.hyps = hyps;
        rect
    }

    /// Step 3 of the module doc, assembled: the floor part (when kept) and the significant
    /// parts added into the update on `rect`. Returns it, the blocks outside which it is
    /// zero (relative to `rect`), and whether they cover under half of it (parts far apart).
    fn assemble(
        &mut self,
        kx: &Kernel1,
        ky: &Kernel1,
        bu: &Bumps,
        no_dets: bool,
        rect: Rect,
    ) -> (Patch, Vec<Block>, bool) {
        let parts = std::mem::take(&mut self.scratch.parts);
        let mut buf = std::mem::take(&mut self.scratch.out);
        refill(&mut buf, rect.rows() * rect.cols(), 0.0);
        let mut out = Patch {
            i0: rect.a0,
            j0: rect.b0,
            h: rect.rows(),
            w: rect.cols(),
            v: buf,
        };
        // The blocks of `out` outside which it is zero, relative to `rect`; the floor part's
        // are its prior's non-zero blocks when known (a sparse prediction without γ/G).
        let rel = |r: &Rect| Block {
            r0: r.a0 - rect.a0,
            r1: r.a1 - rect.a0,
            c0: r.b0 - rect.b0,
            c1: r.b1 - rect.b0,
        };
        let mut blocks = std::mem::take(&mut self.scratch.blocks);
        blocks.clear();
        if bu.use_floor {
            let f = if no_dets { 1.0 } else { bu.floor_mass };
            let pr = if bu.span == Some(bu.full) {
                let mut pr = std::mem::take(&mut self.scratch.shared);
                if bu.per_bump {
                    // Not made above: the same prior on the whole support, γ/G included.
                    self.prior_into(kx, ky, bu.keep, bu.u, bu.full, &mut pr);
                }
                self.scratch.prior_blocks = None;
                pr
            } else {
                let mut pr = std::mem::take(&mut self.scratch.prior);
                self.prior_into(kx, ky, bu.keep, 0.0, bu.full, &mut pr);
                pr
            };
            let (di, dj) = (bu.full.a0 - rect.a0, bu.full.b0 - rect.b0);
            match &self.scratch.prior_blocks {
                // Elsewhere the prior is zero: `0 + f·0` leaves the zeros of `out` as they are.
                Some(pb) => {
                    for b in pb {
                        let dst = &mut out.v[(di + b.r0) * out.w..];
                        let src = &pr[b.r0 * bu.full.cols()..];
                        let tap = [(b.c0, b.c1 - b.c0, dj + b.c0, f)];
                        axpy_taps(dst, out.w, src, bu.full.cols(), b.r1 - b.r0, &tap);
                        blocks.push(Block {
                            r0: di + b.r0,
                            r1: di + b.r1,
                            c0: dj + b.c0,
                            c1: dj + b.c1,
                        });
                    }
                }
                None => {
                    let dst = &mut out.v[di * out.w..];
                    let tap = [(0, bu.full.cols(), dj, f)];
                    axpy_taps(dst, out.w, &pr, bu.full.cols(), bu.full.rows(), &tap);
                    blocks.push(rel(&bu.full));
                }
            }
            if bu.span == Some(bu.full) {
                self.scratch.shared = pr;
            } else {
                self.scratch.prior = pr;
            }
        }
        if !no_dets {
            for (r, mass, v) in &parts[..bu.n_parts] {
                if !bu.significant(*mass) {
                    continue;
                }
                let dst = &mut out.v[(r.a0 - rect.a0) * out.w..];
                let tap = [(0, r.cols(), r.b0 - rect.b0, 1.0)];
                axpy_taps(dst, out.w, v, r.cols(), r.rows(), &tap);
            }
        }
        for (r, mass, _) in &parts[..bu.n_parts] {
            if bu.significant(*mass) {
                blocks.push(rel(r));
            }
        }
        // Parts far apart (their blocks, overlaps counted twice, cover under half the rect):
        // the passes below visit the blocks only (module `cover`: the same values).
        let cover: usize = blocks.iter().map(|b| (b.r1 - b.r0) * (b.c1 - b.c0)).sum();
        let sparse = 2 * cover < rect.rows() * rect.cols();
        self.scratch.parts = parts;
        (out, blocks, sparse)
    }

    /// The update normalised and cropped into the new posterior (the crop is relative to the
    /// maximum), and its marginals (the previous ones kept for step 5); an update without
    /// mass leaves the posterior as it was (returns whether it was replaced).
    fn normalise(&mut self, out: Patch, blocks: Vec<Block>, sparse: bool) -> bool {
        let (s, max) = if sparse {
            (
                cover::lane_sum(&out.v, out.w, out.h, &blocks),
                cover::lane_max(&out.v, out.w, &blocks),
            )
        } else {
            (lane_sum(&out.v), lane_max(&out.v))
        };
        if !(s > 0.0 && s.is_finite()) {
            self.scratch.out = out.v;
            self.scratch.blocks = blocks;
            return false;
        }
        // The old posterior's buffer receives the cropped new one (the crop is relative to
        // the maximum, so it needs no normalised input); the uncropped one goes back to the
        // scratch space.
        let old = std::mem::take(&mut self.post.v);
        let mut post_blocks = std::mem::take(&mut self.scratch.post_blocks);
        let cov = sparse.then_some(&blocks[..]);
        let inv;
        (self.post, inv) = crop_into(
            &out,
            CROP,
            max,
            old,
            &mut self.scratch.post_ext,
            cov,
            &mut post_blocks,
        );
        self.scratch.sparse_post = sparse;
        self.scratch.out = out.v;
        self.scratch.blocks = blocks;
        std::mem::swap(&mut self.prev, &mut self.cur);
        if sparse {
            let p = &mut self.post;
            let [(ox, mx), (oy, my)] = &mut self.cur;
            (*ox, *oy) = (p.i0, p.j0);
            cover::normalise_marginals(&mut p.v, p.w, p.h, &post_blocks, inv, mx, my);
        } else {
            self.post.v.iter_mut().for_each(|x| *x *= inv);
            marginals_into(&self.post, &mut self.cur);
        }
        self.scratch.post_blocks = post_blocks;
        true
    }

    /// The velocity distribution of the next step (step 5 of the module doc): per axis, the
    /// mixture over the update's hypotheses of the displacement's posterior,
    /// `c_d ∝ π_miss·D_d + Σ_i π_i·(D_d ⊙ ℓ_{i,d}) / |D_d ⊙ ℓ_{i,d}|` with
    /// `ℓ_{i,d}[δ] = Σ_n q_{k−1,d}[n]·β_{i,d}[n + δ]` and `β_{i,d}` detection `i`'s likelihood
    /// along axis `d` (its active channels convolved with the kernel's marginal `A_d`); a
    /// detection no displacement in `D_d` reaches (a lost-track recovery) contributes `S_d`.
    /// Reads `self.cur` (the marginals of `q_{k−1}⁺`: called before they are replaced).
    fn carry_velocity(
        &mut self,
        sys: &[StatSystem],
        obs: &StatObservation,
        kernels: (&Kernel1, &Kernel1),
        enc: &[Det],
        hyps: &[(usize, f64)],
        miss: f64,
    ) {
        let ra = obs.kernel_radius();
        let kw = 2 * ra + 1;
        let a = obs.kernel();
        let mut work = std::mem::take(&mut self.scratch.vel);
        let VelWork { am, beta, c, rev } = &mut work;
        // The kernel's marginals A_x[δx] (sum over δy) and A_y[δy].
        for m in am.iter_mut() {
            m.clear();
            m.resize(kw, 0.0);
        }
        for (i, row) in a.chunks_exact(kw).enumerate() {
            for (j, &v) in row.iter().enumerate() {
                am[0][i] += v;
                am[1][j] += v;
            }
        }
        for d in 0..2 {
            let r = sys[d].radius() as i64;
            let w = (2 * r + 1) as usize;
            let k = if d == 0 { kernels.0 } else { kernels.1 };
            let mut next = std::mem::take(&mut self.vel[d]);
            next.clear();
            next.resize(w, 0.0);
            for (t, &kv) in k.v.iter().enumerate() {
                next[(k.lo + r) as usize + t] += miss * kv;
            }
            let (o, m) = (self.cur[d].0 as i64, &self.cur[d].1);
            for &(det, mass) in hyps {
                let act = if d == 0 { enc[det].ax } else { enc[det].ay };
                // β[n] = Σ_t v[t]·A_d[k0 + t − n] for n ∈ [b0, b0 + |β|).
                let b0 = act.first() as i64 - ra as i64;
                beta.clear();
                beta.resize(act.n + kw - 1, 0.0);
                for (t, &v) in act.v[..act.n].iter().enumerate() {
                    for (e, &av) in am[d].iter().enumerate() {
                        // n = k0 + t − (e − ra) = b0 + t + (kw − 1 − e).
                        beta[t + kw - 1 - e] += v * av;
                    }
                }
                // ℓ[δ] = Σ_j m[j]·β[j + o + δ − b0] for δ from the kernel's last offset down
                // to its first: c[i] = ℓ[δ_hi − i] (module `simd`).
                let n = k.v.len();
                let d_hi = k.hi() + o - b0;
                c.clear();
                c.resize(n, 0.0);
                correlate(c, m, beta, d_hi, rev);
                c.reverse();
                let mut s = 0.0;
                for (dst, &kv) in c.iter_mut().zip(&k.v) {
                    *dst *= kv;
                    s += *dst;
                }
                if s > 0.0 {
                    let f = mass / s;
                    for (t, &cv) in c.iter().enumerate() {
                        next[(k.lo + r) as usize + t] += f * cv;
                    }
                } else {
                    for (dst, &sv) in next.iter_mut().zip(sys[d].first()) {
                        *dst += mass * sv;
                    }
                }
            }
            let total: f64 = next.iter().sum();
            if total > 0.0 && total.is_finite() {
                // Entries below VEL_CUT of the total are dropped (fewer terms next step).
                let cut = VEL_CUT * total;
                let inv = 1.0 / total;
                for v in next.iter_mut() {
                    *v = if *v > cut { *v * inv } else { 0.0 };
                }
            } else {
                next.clear();
            }
            self.vel[d] = next;
        }
        self.scratch.vel = work;
    }

    /// Best mode and runner-ups (step 4 of the module doc).
    #[inline(never)]
    pub fn decode(&self, space: &Space, radius: usize, runner_ups: usize) -> Estimate {
        let p = &self.post;
        let r = radius as i64;
        let mut chosen: Vec<(usize, usize)> = Vec::with_capacity(runner_ups + 1);
        let mut hyps: Vec<Hypothesis> = Vec::with_capacity(runner_ups + 1);
        let window = |ci: usize, cj: usize| -> Hypothesis {
            let (mut m, mut sx, mut sy) = (0.0, 0.0, 0.0);
            let i_lo = (ci as i64 - r).max(0) as usize;
            let i_hi = ((ci as i64 + r + 1) as usize).min(p.h);
            let j_lo = (cj as i64 - r).max(0) as usize;
            let j_hi = ((cj as i64 + r + 1) as usize).min(p.w);
            let by = space.state_basis(1);
            for i in i_lo..i_hi {
                let x = space.state_basis(0).centre(p.i0 + i);
                let row = &p.v[i * p.w + j_lo..i * p.w + j_hi];
                let (mut rm, mut ry) = (0.0, 0.0);
                for (j, &v) in (j_lo..).zip(row) {
                    rm += v;
                    ry += v * by.centre(p.j0 + j);
                }
                m += rm;
                sx += rm * x;
                sy += ry;
            }
            let pos = if m > 0.0 {
                [sx / m, sy / m]
            } else {
                [
                    space.state_basis(0).centre(p.i0 + ci),
                    space.state_basis(1).centre(p.j0 + cj),
                ]
            };
            Hypothesis {
                position: pos,
                certainty: m,
            }
        };
        // Local maxima holding at least MIN_SHARE of the largest cell, by decreasing value.
        let max = if self.scratch.sparse_post {
            cover::lane_max(&p.v, p.w, &self.scratch.post_blocks)
        } else {
            lane_max(&p.v)
        };
        let cut = crate::dense::MIN_SHARE * max;
        let mut peaks: Vec<(f64, usize, usize)> = Vec::with_capacity(16);
        // Cells below the crop's share of the maximum cannot be candidates: only each row's
        // crop extent is scanned when known (the same candidates).
        let ext = &self.scratch.post_ext;
        if !ext.is_empty() && ext.len() == p.h {
            peak_scan::<true>(p, ext, cut, &mut peaks);
        } else {
            peak_scan::<false>(p, ext, cut, &mut peaks);
        }
        peaks.sort_by(|a, b| b.0.total_cmp(&a.0).then((a.1, a.2).cmp(&(b.1, b.2))));
        for &(_, i, j) in &peaks {
            if hyps.len() > runner_ups {
                break;
            }
            let far = chosen
                .iter()
                .all(|&(a, b)| (a as i64 - i as i64).abs() > r || (b as i64 - j as i64).abs() > r);
            if far {
                chosen.push((i, j));
                hyps.push(window(i, j));
            }
        }
        let best = hyps.first().copied().unwrap_or(Hypothesis {
            position: [
                space.state_basis(0).centre(p.i0),
                space.state_basis(1).centre(p.j0),
            ],
            certainty: 0.0,
        });
        Estimate {
            position: best.position,
            certainty: Some(best.certainty),
            runner_ups: hyps.into_iter().skip(1).collect(),
        }
    }

    /// The full-grid prior of the next step (for inspection; allocates `G` cells).
    pub fn dense_prior(&mut self, space: &Space, cfg: &CbtConfig, sys: &[StatSystem]) -> Vec<f64> {
        let (nx, ny) = (space.axis_len(0), space.axis_len(1));
        // The step's kernels without consuming the start (`kernels` clears `fresh`).
        let fresh = self.fresh;
        let (kx, ky) = self.kernels(sys, cfg);
        self.fresh = fresh;
        let u = cfg.mixing / space.cells() as f64;
        let rect = Rect {
            a0: 0,
            a1: nx,
            b0: 0,
            b1: ny,
        };
        let mut v = self.prior(&kx, &ky, 1.0 - cfg.mixing, u, rect);
        self.scratch.pos = None;
        let s: f64 = v.iter().sum();
        v.iter_mut().for_each(|x| *x /= s);
        v
    }
}

/// The displacement kernel of one axis (step 1 of the module doc) for the carried velocity
/// distribution `c` (`c[v + r]`; any other length: unknown, the first order's `S_d`), into
/// `k`, with `work` as the work buffers; `start`: the first step after a start, with this
/// start density (of `S_d`'s length).
pub(super) fn displacement_from(
    sys: &StatSystem,
    c: &[f64],
    order: Order,
    start: Option<&[f64]>,
    work: &mut DispWork,
    k: &mut Kernel1,
) {
    let DispWork { out, terms } = work;
    let r = sys.radius() as i64;
    let w = (2 * r + 1) as usize;
    out.clear();
    out.resize(w, 0.0);
    match (start, order) {
        (Some(s), _) => out.copy_from_slice(s),
        (None, Order::First) => out.copy_from_slice(sys.first()),
        (None, Order::Second) => {
            if c.len() == w {
                // Column v of T (zeroed outside its band: the zeros add +0) times c[v],
                // added to `out` by increasing v.
                terms.clear();
                terms.extend(
                    c.iter()
                        .enumerate()
                        .filter(|&(_, &cv)| cv > 0.0)
                        .map(|(i, &cv)| (i, cv)),
                );
                column_sum(out, sys.banded(), sys.banded_stride(), terms);
            } else {
                out.copy_from_slice(sys.first());
            }
        }
    }
    // Drop each tail holding at most KERNEL_TAIL of the mass.
    let (lo, hi) = tail_band(out, KERNEL_TAIL);
    k.lo = lo as i64 - r;
    k.v.clear();
    k.v.extend_from_slice(&out[lo..hi]);
    let s: f64 = k.v.iter().sum();
    if s > 0.0 {
        k.v.iter_mut().for_each(|x| *x /= s);
    }
}

/// The local maxima of `p` at or above `cut`, in raster order, into `peaks`: a cell is one
/// when no neighbour is larger and no neighbour earlier in raster order (the row above, the
/// cell to the left) is equal. With `EXT`, only each row's columns `ext[i]` (widened to the
/// scan's groups of four cells) are scanned: the caller guarantees no candidate lies outside.
#[inline(always)]
fn peak_scan<const EXT: bool>(
    p: &Patch,
    ext: &[(u32, u32)],
    cut: f64,
    peaks: &mut Vec<(f64, usize, usize)>,
) {
    let w = p.w;
    // `ext` is indexed only with EXT (it may be empty otherwise).
    #[allow(clippy::needless_range_loop)]
    for i in 0..p.h {
        let (f, l) = if EXT {
            let (f, l) = (ext[i].0 as usize, ext[i].1 as usize);
            if f >= l {
                continue;
            }
            (f & !3, l.next_multiple_of(4).min(w))
        } else {
            (0, w)
        };
        let cur = &p.v[i * w..(i + 1) * w];
        // Absent rows compare as an all-zero row (a candidate is positive).
        let above = if i > 0 { &p.v[(i - 1) * w..i * w] } else { cur };
        let below = if i + 1 < p.h {
            &p.v[(i + 1) * w..(i + 2) * w]
        } else {
            cur
        };
        let (has_above, has_below) = (i > 0, i + 1 < p.h);
        // The direct vertical neighbours first, four cells at a time (on a smooth hill, one
        // of them is higher); the survivors meet the other neighbours here.
        let (up, down) = (
            has_above.then_some(&above[f..l]),
            has_below.then_some(&below[f..l]),
        );
        peak_candidates(&cur[f..l], up, down, cut, |j| {
            let j = j + f;
            let v = cur[j];
            if (j > 0 && cur[j - 1] >= v) || (j + 1 < w && cur[j + 1] > v) {
                return;
            }
            if j > 0 && ((has_above && above[j - 1] >= v) || (has_below && below[j - 1] > v)) {
                return;
            }
            if j + 1 < w && ((has_above && above[j + 1] >= v) || (has_below && below[j + 1] > v)) {
                return;
            }
            peaks.push((v, i, j));
        });
    }
}

/// A run of consecutive posterior rows `start..end` (relative to the first source row of a
/// prediction) that hold non-zero cells: per row the first and last non-zero column, and the
/// columns `[c0, c1)` of the prediction's y pass those rows reach.
#[derive(Debug, Clone, Default)]
struct Run {
    start: usize,
    end: usize,
    ext: Vec<(usize, usize)>,
    cols: (usize, usize),
}

/// The prediction's y pass on a sparse posterior: for each row of each run, the convolution
/// of its non-zero cells only, into the output columns they reach (`rows` holds zeros
/// elsewhere; every other source cell is an exact zero, whose `+0` terms leave the
/// non-negative sums unchanged: the same values as the dense pass). Records each run's
/// output columns.
fn sparse_prior(
    rows: &mut [f64],
    src: &[f64],
    ss: usize,
    nc: usize,
    runs: &mut [Run],
    kpad: &[f64],
    base: i64,
) {
    let len = kpad.len() as i64 - 2 * super::simd::KPAD as i64;
    for run in runs {
        let (mut c0, mut c1) = (nc, 0);
        for (r, &(f, l)) in (run.start..run.end).zip(&run.ext) {
            // Output j takes source b ∈ [f, l] through tap t = j − b + base ∈ [0, len).
            let j0 = (f as i64 - base).clamp(0, nc as i64) as usize;
            let j1 = (l as i64 + len - base).clamp(0, nc as i64) as usize;
            if j0 >= j1 {
                continue;
            }
            (c0, c1) = (c0.min(j0), c1.max(j1));
            let row = &src[r * ss + f..=r * ss + l];
            let dst = &mut rows[r * nc + j0..r * nc + j1];
            conv_rows(
                dst,
                j1 - j0,
                row,
                row.len(),
                row.len(),
                1,
                kpad,
                base + j0 as i64 - f as i64,
            );
        }
        run.cols = (c0, c1.max(c0));
    }
}

/// The prediction's x pass over runs of non-zero rows only (the dense pass's terms from zero
/// rows are `+0`): per tap by decreasing offset, per run, one contiguous axpy over its rows,
/// or row by row over its output columns when those are under three quarters of the rect's.
#[allow(clippy::too_many_arguments)]
fn x_pass_runs(
    out: &mut [f64],
    rows: &[f64],
    nc: usize,
    runs: &mut [Run],
    kx: &Kernel1,
    keep: f64,
    a_lo: usize,
    rect: Rect,
) {
    with_avx(|| {
        for (t, &kv) in kx.v.iter().enumerate().rev() {
            let delta = kx.lo + t as i64;
            let k = keep * kv;
            for run in runs.iter() {
                let lo = ((a_lo + run.start) as i64).max(rect.a0 as i64 - delta);
                let hi = ((a_lo + run.end) as i64).min(rect.a1 as i64 - delta);
                if lo >= hi {
                    continue;
                }
                let (c0, c1) = run.cols;
                let first = lo as usize - a_lo;
                let dst0 = (lo + delta) as usize - rect.a0;
                let m = (hi - lo) as usize;
                if 4 * (c1 - c0) >= 3 * nc {
                    let src = &rows[first * nc..][..m * nc];
                    let dst = &mut out[dst0 * nc..][..m * nc];
                    axpy_inline(dst, src, k);
                } else {
                    for r in 0..m {
                        let src = &rows[(first + r) * nc + c0..(first + r) * nc + c1];
                        let dst = &mut out[(dst0 + r) * nc + c0..(dst0 + r) * nc + c1];
                        axpy_inline(dst, src, k);
                    }
                }
            }
        }
    });
}

/// Crops a patch whose largest cell is `max` to the bounding box of its cells `≥ eps · max`,
/// into `buf`, returned with the inverse of its sum (not normalised here); with `blocks`
/// (the patch is zero outside them), only those are visited and `crop_blocks` receives them
/// clipped to the crop. `ext` receives, per row of the crop, the columns `[first, last + 1)` of
/// its cells `≥ eps · max` (`(0, 0)` for none), or nothing when no cell passes or the patch
/// has fewer than [`EXTENTS_FROM`] cells.
#[allow(clippy::too_many_arguments)]
fn crop_into(
    p: &Patch,
    eps: f64,
    max: f64,
    mut buf: Vec<f64>,
    ext: &mut Vec<(u32, u32)>,
    blocks: Option<&[Block]>,
    crop_blocks: &mut Vec<Block>,
) -> (Patch, f64) {
    let cut = eps * max;
    let (mut a0, mut a1, mut b0, mut b1) = (usize::MAX, 0, usize::MAX, 0);
    ext.clear();
    // Worth keeping for large windows only (a wide posterior's peak scan).
    let keep = p.v.len() >= EXTENTS_FROM;
    if keep {
        ext.resize(p.h, (0, 0));
    }
    let on_row = |i: usize, f: usize, l: usize| {
        a0 = a0.min(i);
        a1 = a1.max(i + 1);
        b0 = b0.min(f);
        b1 = b1.max(l + 1);
        if keep {
            ext[i] = (f as u32, l as u32 + 1);
        }
    };
    match blocks {
        Some(bl) => cover::row_extents(&p.v, p.w, p.h, bl, cut, on_row),
        None => row_extents(&p.v, p.w, cut, on_row),
    }
    if a0 == usize::MAX {
        (a0, a1, b0, b1) = (0, p.h, 0, p.w);
        ext.clear();
    } else if keep {
        ext.truncate(a1);
        ext.drain(..a0);
        for e in ext.iter_mut().filter(|e| e.0 < e.1) {
            *e = (e.0 - b0 as u32, e.1 - b0 as u32);
        }
    }
    let (h, w) = (a1 - a0, b1 - b0);
    pool::reserve_empty(&mut buf, h * w);
    for i in a0..a1 {
        buf.extend_from_slice(&p.v[i * p.w + b0..i * p.w + b1]);
    }
    crop_blocks.clear();
    let s = 1.0
        / match blocks {
            Some(bl) => {
                crop_blocks.extend(bl.iter().filter_map(|b| b.clip(a0, a1, b0, b1)));
                cover::lane_sum(&buf, w, h, crop_blocks)
            }
            None => lane_sum(&buf),
        };
    let crop = Patch {
        i0: p.i0 + a0,
        j0: p.j0 + b0,
        h,
        w,
        v: buf,
    };
    (crop, s)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A posterior of three blobs with exact zeros between them: one pair shares rows, one
    /// is apart in rows.
    fn sparse_window() -> WindowState {
        let (h, w) = (40, 50);
        let mut v = vec![0.0; h * w];
        for (r0, r1, c0, c1) in [(2, 8, 3, 10), (4, 9, 40, 48), (25, 35, 20, 30)] {
            for i in r0..r1 {
                for j in c0..c1 {
                    v[i * w + j] = ((i * 7 + j * 3) % 11) as f64 * 0.01 + 1e-3;
                }
            }
        }
        let mut s = WindowState::default();
        s.start(Patch {
            i0: 30,
            j0: 20,
            h,
            w,
            v,
        });
        s
    }

    #[test]
    fn peak_scan_within_the_crop_extents_finds_the_same_peaks() {
        // Blobs with bumpy tops, cells between the crop's and the scan's shares, and cells
        // below the crop's share.
        let (h, w) = (45, 60);
        let mut v = vec![0.0; h * w];
        for (r0, r1, c0, c1, top) in [
            (3, 12, 5, 17, 1.0),
            (20, 31, 38, 55, 0.3),
            (35, 44, 1, 9, 0.05),
        ] {
            for i in r0..r1 {
                for j in c0..c1 {
                    v[i * w + j] = top * (1.0 + ((i * 13 + j * 7) % 5) as f64 * 0.1);
                }
            }
        }
        for k in (0..h * w).step_by(37) {
            if v[k] == 0.0 {
                v[k] = if k % 2 == 0 { 3e-5 } else { 2e-3 };
            }
        }
        let out = Patch {
            i0: 4,
            j0: 9,
            h,
            w,
            v,
        };
        let mut ext = Vec::new();
        let (mut post, inv) = crop_into(
            &out,
            CROP,
            lane_max(&out.v),
            Vec::new(),
            &mut ext,
            None,
            &mut Vec::new(),
        );
        post.v.iter_mut().for_each(|x| *x *= inv);
        assert_eq!(ext.len(), post.h, "a large window keeps its extents");
        let cut = crate::dense::MIN_SHARE * lane_max(&post.v);
        let (mut with, mut without) = (Vec::new(), Vec::new());
        peak_scan::<true>(&post, &ext, cut, &mut with);
        peak_scan::<false>(&post, &ext, cut, &mut without);
        assert!(without.len() > 3);
        assert_eq!(with, without);
        assert!(
            ext.iter().any(|e| e.1 - e.0 < post.w as u32 / 2),
            "some rows are narrow"
        );
    }

    #[test]
    fn sparse_prediction_matches_the_dense_one_bit_for_bit() {
        let mut s = sparse_window();
        let nonzero = s.post.v.iter().filter(|&&x| x > 0.0).count();
        assert!(
            2 * nonzero < s.post.v.len(),
            "the test posterior must be sparse"
        );
        let kern = |lo: i64, n: usize| Kernel1 {
            lo,
            v: (0..n).map(|i| 0.05 + ((i * 5) % 7) as f64 * 0.02).collect(),
        };
        // Short y kernel (row taps when dense) and long (register convolution), and rects
        // covering the whole prediction, crossing the blobs, or inside one.
        for ky in [kern(-2, 5), kern(-14, 30)] {
            let kx = kern(-4, 9);
            let full = Rect {
                a0: 26,
                a1: 75,
                b0: 6,
                b1: 86,
            };
            let rects = [
                full,
                Rect {
                    a0: 30,
                    a1: 45,
                    b0: 20,
                    b1: 80,
                },
                Rect {
                    a0: 50,
                    a1: 70,
                    b0: 35,
                    b1: 55,
                },
                Rect {
                    a0: 31,
                    a1: 36,
                    b0: 60,
                    b1: 70,
                },
            ];
            for rect in rects {
                for u in [0.0, 1e-6] {
                    s.scratch.sparse_post = false;
                    let dense = s.prior(&kx, &ky, 0.99, u, rect);
                    s.scratch.sparse_post = true;
                    let sparse = s.prior(&kx, &ky, 0.99, u, rect);
                    if u == 0.0 {
                        // The blocks it reports hold every non-zero cell.
                        let blocks = s.scratch.prior_blocks.clone().expect("sparse path taken");
                        let w = rect.cols();
                        for (k, &x) in sparse.iter().enumerate() {
                            let (i, j) = (k / w, k % w);
                            let inside = blocks
                                .iter()
                                .any(|b| b.r0 <= i && i < b.r1 && b.c0 <= j && j < b.c1);
                            assert!(inside || x == 0.0, "{rect:?} cell {i},{j}");
                        }
                    }
                    assert!(dense.iter().any(|&x| x > u));
                    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                    assert_eq!(bits(&sparse), bits(&dense), "{rect:?} {}", ky.v.len());
                }
            }
        }
    }
}
