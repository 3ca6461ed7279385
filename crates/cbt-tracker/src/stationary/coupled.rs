//! The velocity coupled to position ([`Velocity::PerPosition`](crate::Velocity)): the
//! second-order state `q(x, y)·c_x(v_x | x)·c_y(v_y | y)` instead of the factored
//! `q(x, y)·c_x(v_x)·c_y(v_y)` of module `window` (step 5 there).
//!
//! Every row `a` of the posterior's window carries its own x-velocity distribution
//! `c_x(· | a)`, every column `b` its own y-velocity distribution, so two hypotheses at
//! different positions (one that followed the true detections, one that took clutter) are
//! predicted with their own velocities, as a particle filter's particles are.
//!
//! - **Kernels.** Per row, `D_x(δ | a) = Σ_v c_x(v | a)·T_x[δ | v]` (per column likewise; the
//!   same band and tail cuts as the factored kernel); a cell without a velocity (after a
//!   start) takes the factored step's kernel.
//! - **Prediction** `q⁻[i, j] = γ/G + (1 − γ)·Σ_{a,b} q[a, b]·D_x(i − a | a)·D_y(j − b | b)`:
//!   still separable (a y pass with a kernel per source column, then an x pass with a kernel
//!   per source row).
//! - **Velocity update.** With the update `u[i, j] = q⁻[i, j]·L[i, j]` (`L` the mixture
//!   likelihood, read as `u / q⁻`), the joint posterior of the new row `i` and the x
//!   displacement `δ` just made is, summed over the columns,
//!   `p(i, δ) = Σ_j L[i, j]·(1 − γ)·D_x(δ | i − δ)·Σ_b q[i − δ, b]·D_y(j − b | b)
//!   + γ/G·Σ_j L[i, j]·S_x[δ]` (the uniform recovery share knows no velocity: the learned
//!   marginal `S`); `c_x(· | i) = p(i, ·)/Σ_δ p(i, δ)`, and per column likewise. Exact for the
//!   coupled state: the brute-force sums over `(a, b, δ_x, δ_y)` in the tests agree.
//!
//! Cost: the update needs the prediction twice more on its rectangle (both pass orders), in
//! plain loops (not the factored step's SIMD passes).

use serde::{Deserialize, Serialize};

use super::model::StatSystem;
use super::window::{DispWork, Kernel1, Patch, Rect, displacement_from};
use crate::TrackError;
use crate::config::Order;
use crate::integrity::{corrupt, nonneg};

/// Entries of a carried velocity distribution below this share of its mass are dropped.
const VEL_CUT: f64 = 1e-9;

/// The velocity distributions of one axis, one per cell along it: cell `first + k`'s
/// `c[v + r]` at `v[k·width + v + r]` (`width = 2r + 1`).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub(crate) struct AxisVelocity {
    pub first: usize,
    pub cells: usize,
    pub width: usize,
    pub v: Vec<f64>,
}

impl AxisVelocity {
    /// Cell `c`'s distribution, when carried.
    fn of(&self, c: usize) -> Option<&[f64]> {
        (c >= self.first && c < self.first + self.cells)
            .then(|| &self.v[(c - self.first) * self.width..][..self.width])
    }

    /// Keeps cells `first..first + cells` (within the carried ones).
    fn crop(&mut self, first: usize, cells: usize) {
        let (lo, hi) = (
            first.max(self.first),
            (first + cells).min(self.first + self.cells),
        );
        if lo >= hi {
            *self = AxisVelocity::default();
            return;
        }
        let w = self.width;
        self.v.truncate((hi - self.first) * w);
        self.v.drain(..(lo - self.first) * w);
        (self.first, self.cells) = (lo, hi - lo);
    }
}

/// The per-position velocities of the posterior's window (empty: none carried, after a start
/// or with the factored state).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub(crate) struct PositionVelocity {
    pub axes: [AxisVelocity; 2],
}

impl PositionVelocity {
    /// Whether no velocity is carried.
    pub fn is_empty(&self) -> bool {
        self.axes.iter().all(|a| a.cells == 0)
    }

    /// Consistency with the posterior window `post` and the system models `sys` (one per
    /// axis) of deserialised files: one distribution per row or column of the window, each
    /// over its axis's `2r + 1` velocities (any other width used to be taken silently as
    /// unknown, and a huge one overflowed `cells · width`).
    pub fn check(&self, post: &Patch, sys: &[StatSystem]) -> Result<(), TrackError> {
        if self.is_empty() {
            return Ok(());
        }
        for (d, (a, s)) in self.axes.iter().zip(sys).enumerate() {
            let (o, n) = if d == 0 {
                (post.i0, post.h)
            } else {
                (post.j0, post.w)
            };
            // `n` is at most the axis length and the width `2r + 1` at most 2^15 + 1
            // (`StatSystem::check`): the product fits.
            if a.first != o
                || a.cells != n
                || a.width != 2 * s.radius() + 1
                || a.v.len() != n * a.width
            {
                return Err(corrupt(format!(
                    "per-position velocities of axis {d} do not match the posterior window"
                )));
            }
            nonneg("per-position velocity", &a.v)?;
            // Every step leaves each cell's distribution with mass 1 (or the learned `S`); an
            // empty one gave a kernel of zeros, which dropped that row's or column's mass.
            if let Some(c) =
                a.v.chunks_exact(a.width)
                    .position(|c| c.iter().sum::<f64>() <= 0.0)
            {
                return Err(corrupt(format!(
                    "the per-position velocity of cell {} on axis {d} has no mass",
                    a.first + c
                )));
            }
        }
        Ok(())
    }

    /// Keeps the rows and columns of `post` (the cropped posterior).
    pub fn crop(&mut self, post: &Patch) {
        self.axes[0].crop(post.i0, post.h);
        self.axes[1].crop(post.j0, post.w);
    }
}

/// A displacement kernel per cell along one axis: cell `first + k`'s kernel over offsets
/// `lo..lo + len` at `v[k·len..]`.
#[derive(Debug, Clone, Default, PartialEq)]
pub(super) struct PosKernels {
    pub first: usize,
    pub cells: usize,
    pub lo: i64,
    pub len: usize,
    pub v: Vec<f64>,
}

impl PosKernels {
    fn of(&self, c: usize) -> &[f64] {
        &self.v[(c - self.first) * self.len..][..self.len]
    }

    /// The kernels of cells `first..first + weights.len()` from the carried velocities
    /// `vel` (a cell without one takes `fallback`), and their average weighted by `weights`
    /// (the posterior's marginal along the axis; uniform when it has no mass): the kernel
    /// whose extent bounds every cell's.
    pub fn build(
        sys: &StatSystem,
        vel: &AxisVelocity,
        first: usize,
        weights: &[f64],
        fallback: &Kernel1,
        work: &mut DispWork,
    ) -> (PosKernels, Kernel1) {
        let w = 2 * sys.radius() + 1;
        let mut each = Vec::with_capacity(weights.len());
        for c in first..first + weights.len() {
            match vel.of(c).filter(|v| v.len() == w) {
                Some(cv) => {
                    let mut k = Kernel1::default();
                    displacement_from(sys, cv, Order::Second, None, work, &mut k);
                    each.push(k);
                }
                None => each.push(fallback.clone()),
            }
        }
        let lo = each.iter().map(|k| k.lo).min().unwrap_or(fallback.lo);
        let hi = each.iter().map(|k| k.hi()).max().unwrap_or(fallback.hi());
        let len = (hi - lo + 1) as usize;
        let mut v = vec![0.0; each.len() * len];
        let mut avg = vec![0.0; len];
        let total: f64 = weights.iter().sum();
        for (k, (kern, &m)) in each.iter().zip(weights).enumerate() {
            let off = (kern.lo - lo) as usize;
            v[k * len + off..][..kern.v.len()].copy_from_slice(&kern.v);
            let wt = if total > 0.0 {
                m / total
            } else {
                1.0 / weights.len() as f64
            };
            for (a, &x) in avg[off..].iter_mut().zip(&kern.v) {
                *a += wt * x;
            }
        }
        let s: f64 = avg.iter().sum();
        if s > 0.0 {
            avg.iter_mut().for_each(|x| *x /= s);
        }
        let pk = PosKernels {
            first,
            cells: each.len(),
            lo,
            len,
            v,
        };
        (pk, Kernel1 { lo, v: avg })
    }
}

/// The posterior's y pass onto the columns of `rect`: `rows[a·nc + j − b0] =
/// Σ_b q[a, b]·D_y(j − b | b)` for every row `a` of the window (relative to its first).
fn y_pass(post: &Patch, ky: &PosKernels, rect: Rect, rows: &mut Vec<f64>) {
    let nc = rect.cols();
    rows.clear();
    rows.resize(post.h * nc, 0.0);
    for a in 0..post.h {
        let dst = &mut rows[a * nc..(a + 1) * nc];
        for (bi, &q) in post.v[a * post.w..(a + 1) * post.w].iter().enumerate() {
            if q == 0.0 {
                continue;
            }
            let b = post.j0 + bi;
            let j0 = b as i64 + ky.lo;
            for (t, &k) in ky.of(b).iter().enumerate() {
                let j = j0 + t as i64;
                if j >= rect.b0 as i64 && j < rect.b1 as i64 {
                    dst[j as usize - rect.b0] += q * k;
                }
            }
        }
    }
}

/// The x taps reaching `rect`'s rows from the window's rows: `(a, δ, i − a0, D_x(δ | a))` for
/// every window row `a` (relative to its first) and offset `δ` with `i = i0 + a + δ` in
/// `rect` and a non-zero tap.
fn x_taps<'a>(
    post: &'a Patch,
    kx: &'a PosKernels,
    rect: Rect,
) -> impl Iterator<Item = (usize, i64, usize, f64)> + 'a {
    (0..post.h).flat_map(move |a| {
        let ra = post.i0 + a;
        kx.of(ra).iter().enumerate().filter_map(move |(t, &k)| {
            let delta = kx.lo + t as i64;
            let i = ra as i64 + delta;
            (k != 0.0 && i >= rect.a0 as i64 && i < rect.a1 as i64)
                .then(|| (a, delta, i as usize - rect.a0, k))
        })
    })
}

/// The prediction on `rect` from the y pass `rows` (module doc): `γ/G + keep·Σ_a
/// D_x(i − a | a)·rows[a]`, row-major over the rect, into `out`.
fn x_pass(
    post: &Patch,
    kx: &PosKernels,
    rows: &[f64],
    keep: f64,
    u: f64,
    rect: Rect,
    out: &mut Vec<f64>,
) {
    let nc = rect.cols();
    out.clear();
    out.resize(rect.rows() * nc, u);
    for (a, _, ir, k) in x_taps(post, kx, rect) {
        let c = keep * k;
        let dst = &mut out[ir * nc..][..nc];
        for (d, &s) in dst.iter_mut().zip(&rows[a * nc..(a + 1) * nc]) {
            *d += c * s;
        }
    }
}

/// The prediction with the per-position kernels on `rect` (module doc), into `out`
/// (`rows`: a work buffer).
pub(super) fn predict(
    post: &Patch,
    kern: &(PosKernels, PosKernels),
    keep: f64,
    u: f64,
    rect: Rect,
    rows: &mut Vec<f64>,
    out: &mut Vec<f64>,
) {
    y_pass(post, &kern.1, rect, rows);
    x_pass(post, &kern.0, rows, keep, u, rect, out);
}

/// The per-position velocities of the posterior after the update `upd` (unnormalised, on
/// its own rectangle) of the prediction from `post` with `kern` (module doc): one per row
/// and one per column of `upd`'s rectangle.
pub(super) fn update(
    post: &Patch,
    kern: &(PosKernels, PosKernels),
    keep: f64,
    u: f64,
    upd: &Patch,
    sys: &[StatSystem],
) -> PositionVelocity {
    let (kx, ky) = kern;
    let rect = Rect {
        a0: upd.i0,
        a1: upd.i0 + upd.h,
        b0: upd.j0,
        b1: upd.j0 + upd.w,
    };
    let nc = rect.cols();
    let (mut rows, mut pr) = (Vec::new(), Vec::new());
    y_pass(post, ky, rect, &mut rows);
    x_pass(post, kx, &rows, keep, u, rect, &mut pr);
    // L = u / q⁻ per cell.
    let lik: Vec<f64> = upd
        .v
        .iter()
        .zip(&pr)
        .map(|(&x, &p)| if p > 0.0 { x / p } else { 0.0 })
        .collect();
    let wd = |d: usize| 2 * sys[d].radius() + 1;
    let (rx, ry) = (sys[0].radius() as i64, sys[1].radius() as i64);
    // x: p(i, δ) = Σ_j L[i, j]·keep·D_x(δ | i − δ)·rows[i − δ, j].
    let mut cx = vec![0.0; rect.rows() * wd(0)];
    for (a, delta, ir, k) in x_taps(post, kx, rect) {
        let dot: f64 = lik[ir * nc..(ir + 1) * nc]
            .iter()
            .zip(&rows[a * nc..(a + 1) * nc])
            .map(|(l, s)| l * s)
            .sum();
        cx[ir * wd(0) + (delta + rx) as usize] += keep * k * dot;
    }
    // y: the x pass first, cols[i, b] = Σ_a D_x(i − a | a)·q[a, b], then
    // p(j, δ) = Σ_i L[i, j]·keep·D_y(δ | j − δ)·cols[i, j − δ].
    let mut cols = vec![0.0; rect.rows() * post.w];
    for (a, _, ir, k) in x_taps(post, kx, rect) {
        let dst = &mut cols[ir * post.w..][..post.w];
        for (d, &s) in dst.iter_mut().zip(&post.v[a * post.w..(a + 1) * post.w]) {
            *d += k * s;
        }
    }
    let mut cy = vec![0.0; nc * wd(1)];
    for ir in 0..rect.rows() {
        let l = &lik[ir * nc..(ir + 1) * nc];
        for (bi, &cv) in cols[ir * post.w..(ir + 1) * post.w].iter().enumerate() {
            if cv == 0.0 {
                continue;
            }
            let b = post.j0 + bi;
            for (t, &k) in ky.of(b).iter().enumerate() {
                let delta = ky.lo + t as i64;
                let j = b as i64 + delta;
                if k == 0.0 || j < rect.b0 as i64 || j >= rect.b1 as i64 {
                    continue;
                }
                let jr = j as usize - rect.b0;
                cy[jr * wd(1) + (delta + ry) as usize] += l[jr] * keep * k * cv;
            }
        }
    }
    // The uniform share knows no velocity: S_d, weighted by γ/G·Σ L.
    let (mut ux, mut uy) = (vec![0.0; rect.rows()], vec![0.0; nc]);
    for (ir, row) in lik.chunks_exact(nc.max(1)).enumerate() {
        for (jr, &l) in row.iter().enumerate() {
            ux[ir] += u * l;
            uy[jr] += u * l;
        }
    }
    let finish = |c: &mut Vec<f64>, un: &[f64], s: &[f64], w: usize| {
        for (cell, &m) in c.chunks_exact_mut(w).zip(un) {
            for (x, &sv) in cell.iter_mut().zip(s) {
                *x += m * sv;
            }
            let total: f64 = cell.iter().sum();
            if total > 0.0 && total.is_finite() {
                let (cut, inv) = (VEL_CUT * total, 1.0 / total);
                for x in cell.iter_mut() {
                    *x = if *x > cut { *x * inv } else { 0.0 };
                }
            } else {
                cell.copy_from_slice(s);
            }
        }
    };
    finish(&mut cx, &ux, sys[0].first(), wd(0));
    finish(&mut cy, &uy, sys[1].first(), wd(1));
    PositionVelocity {
        axes: [
            AxisVelocity {
                first: rect.a0,
                cells: rect.rows(),
                width: wd(0),
                v: cx,
            },
            AxisVelocity {
                first: rect.b0,
                cells: nc,
                width: wd(1),
                v: cy,
            },
        ],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::CbtConfig;
    use proptest::prelude::*;

    /// A deterministic pseudo-random value in (0, 1] for index `k` and salt `s`.
    fn val(k: usize, s: usize) -> f64 {
        (((k * 7919 + s * 104_729) % 997) as f64 + 1.0) / 997.0
    }

    fn patch(i0: usize, j0: usize, h: usize, w: usize, s: usize) -> Patch {
        let mut v: Vec<f64> = (0..h * w).map(|k| val(k, s)).collect();
        // Some exact zeros, as a cropped posterior has.
        v.iter_mut().skip(2).step_by(5).for_each(|x| *x = 0.0);
        let t: f64 = v.iter().sum();
        v.iter_mut().for_each(|x| *x /= t);
        Patch { i0, j0, h, w, v }
    }

    /// Normalised kernels over `lo..lo + len` for cells `first..first + cells`.
    fn kernels(first: usize, cells: usize, lo: i64, len: usize, s: usize) -> PosKernels {
        let mut v: Vec<f64> = (0..cells * len).map(|k| val(k, s)).collect();
        for c in v.chunks_exact_mut(len) {
            let t: f64 = c.iter().sum();
            c.iter_mut().for_each(|x| *x /= t);
        }
        PosKernels {
            first,
            cells,
            lo,
            len,
            v,
        }
    }

    /// A system model of radius `r` whose `T[δ | v]` is all but exactly `δ = v`.
    fn constant_velocity(r: usize) -> StatSystem {
        let cfg = CbtConfig::stationary();
        let mut sys = StatSystem::new(r, &cfg);
        let c = 10 + r;
        for v in -(r as i64)..=r as i64 {
            let at = |k: i64| [((c as i64 + k * v) as usize, 100.0)];
            sys.add(&at(2), &at(1), Some(&at(0)));
        }
        sys.normalise(&cfg);
        sys
    }

    fn rect(a0: usize, a1: usize, b0: usize, b1: usize) -> Rect {
        Rect { a0, a1, b0, b1 }
    }

    fn predicted(
        post: &Patch,
        k: &(PosKernels, PosKernels),
        keep: f64,
        u: f64,
        r: Rect,
    ) -> Vec<f64> {
        let mut out = Vec::new();
        predict(post, k, keep, u, r, &mut Vec::new(), &mut out);
        out
    }

    /// The brute-force terms of the prediction at cell `(i, j)`: per source cell `(a, b)`
    /// within the kernels' reach, `(δx, δy, q[a, b]·D_x(δx | a)·D_y(δy | b))`.
    fn terms(
        post: &Patch,
        k: &(PosKernels, PosKernels),
        i: usize,
        j: usize,
    ) -> Vec<(i64, i64, f64)> {
        let mut out = Vec::new();
        for a in 0..post.h {
            for b in 0..post.w {
                let (ra, rb) = (post.i0 + a, post.j0 + b);
                let (dx, dy) = (i as i64 - ra as i64, j as i64 - rb as i64);
                let (tx, ty) = (dx - k.0.lo, dy - k.1.lo);
                if (0..k.0.len as i64).contains(&tx) && (0..k.1.len as i64).contains(&ty) {
                    let m =
                        post.v[a * post.w + b] * k.0.of(ra)[tx as usize] * k.1.of(rb)[ty as usize];
                    out.push((dx, dy, m));
                }
            }
        }
        out
    }

    #[test]
    fn prediction_matches_the_brute_force_sum() {
        let post = patch(6, 9, 5, 7, 1);
        let k = (kernels(6, 5, -2, 5, 2), kernels(9, 7, -3, 6, 3));
        let (keep, u) = (0.9, 1e-3);
        let rect = rect(3, 12, 8, 17);
        let out = predicted(&post, &k, keep, u, rect);
        for i in rect.a0..rect.a1 {
            for j in rect.b0..rect.b1 {
                let want = u + keep * terms(&post, &k, i, j).iter().map(|t| t.2).sum::<f64>();
                let got = out[(i - rect.a0) * rect.cols() + j - rect.b0];
                assert!(
                    (got - want).abs() < 1e-14,
                    "({i}, {j}): {got} against {want}"
                );
            }
        }
    }

    #[test]
    fn velocity_update_matches_the_brute_force_joint_posterior() {
        let r = 3;
        let sys = [constant_velocity(r), constant_velocity(r)];
        let post = patch(6, 9, 4, 5, 4);
        let k = (kernels(6, 4, -2, 5, 5), kernels(9, 5, -3, 7, 6));
        let (keep, u) = (0.95, 2e-3);
        let rect = rect(5, 11, 7, 15);
        // An update: the prediction times a likelihood.
        let pr = predicted(&post, &k, keep, u, rect);
        let lik: Vec<f64> = (0..pr.len()).map(|c| val(c, 7)).collect();
        let upd = Patch {
            i0: rect.a0,
            j0: rect.b0,
            h: rect.rows(),
            w: rect.cols(),
            v: pr.iter().zip(&lik).map(|(p, l)| p * l).collect(),
        };
        let got = update(&post, &k, keep, u, &upd, &sys);
        // The joint posterior of (i, j, δx, δy), summed per axis.
        let w = 2 * r + 1;
        let mut px = vec![0.0; rect.rows() * w];
        let mut py = vec![0.0; rect.cols() * w];
        for i in rect.a0..rect.a1 {
            for j in rect.b0..rect.b1 {
                let l = lik[(i - rect.a0) * rect.cols() + j - rect.b0];
                for (dx, dy, m) in terms(&post, &k, i, j) {
                    px[(i - rect.a0) * w + (dx + r as i64) as usize] += l * keep * m;
                    py[(j - rect.b0) * w + (dy + r as i64) as usize] += l * keep * m;
                }
                for e in 0..w {
                    px[(i - rect.a0) * w + e] += u * l * sys[0].first()[e];
                    py[(j - rect.b0) * w + e] += u * l * sys[1].first()[e];
                }
            }
        }
        for (d, want) in [px, py].iter().enumerate() {
            let ax = &got.axes[d];
            assert_eq!((ax.cells, ax.width), (want.len() / w, w));
            for (c, (g, p)) in ax.v.chunks_exact(w).zip(want.chunks_exact(w)).enumerate() {
                let t: f64 = p.iter().sum();
                for (e, (&g, &p)) in g.iter().zip(p).enumerate() {
                    assert!(
                        (g - p / t).abs() < 1e-12,
                        "axis {d} cell {c} δ {e}: {g} vs {}",
                        p / t
                    );
                }
            }
        }
    }

    /// Two hypotheses at different rows moving apart: each keeps its own velocity through a
    /// missed frame. With one velocity shared by both (the factored state), each would be
    /// predicted both ways.
    #[test]
    fn each_hypothesis_keeps_its_own_velocity() {
        let r = 4;
        let sys = [constant_velocity(r), constant_velocity(r)];
        // Mass at rows 10 and 20 (column 10); row 10 moves +2, row 20 moves −2, y stands.
        let mut v = vec![0.0; 11];
        v[0] = 0.5;
        v[10] = 0.5;
        let post = Patch {
            i0: 10,
            j0: 10,
            h: 11,
            w: 1,
            v,
        };
        let w = 2 * r + 1;
        let mut vx = vec![0.0; 11 * w];
        vx[r + 2] = 1.0;
        vx[10 * w + r - 2] = 1.0;
        for c in 1..10 {
            vx[c * w + r] = 1.0;
        }
        let mut vy = vec![0.0; w];
        vy[r] = 1.0;
        let mut vel = PositionVelocity {
            axes: [
                AxisVelocity {
                    first: 10,
                    cells: 11,
                    width: w,
                    v: vx,
                },
                AxisVelocity {
                    first: 10,
                    cells: 1,
                    width: w,
                    v: vy,
                },
            ],
        };
        let rect = rect(0, 32, 0, 21);
        let mut post = post;
        let mut work = DispWork::default();
        let marg = |p: &Patch| -> [Vec<f64>; 2] {
            let mut m = [vec![0.0; p.h], vec![0.0; p.w]];
            for i in 0..p.h {
                for j in 0..p.w {
                    m[0][i] += p.v[i * p.w + j];
                    m[1][j] += p.v[i * p.w + j];
                }
            }
            m
        };
        let fallback = Kernel1 {
            lo: 0,
            v: vec![1.0],
        };
        // Two missed frames (the update is the prediction itself).
        for _ in 0..2 {
            let m = marg(&post);
            let kx = PosKernels::build(&sys[0], &vel.axes[0], post.i0, &m[0], &fallback, &mut work);
            let ky = PosKernels::build(&sys[1], &vel.axes[1], post.j0, &m[1], &fallback, &mut work);
            let k = (kx.0, ky.0);
            let mut pr = Vec::new();
            predict(&post, &k, 1.0, 0.0, rect, &mut Vec::new(), &mut pr);
            let upd = Patch {
                i0: 0,
                j0: 0,
                h: rect.rows(),
                w: rect.cols(),
                v: pr,
            };
            vel = update(&post, &k, 1.0, 0.0, &upd, &sys);
            post = upd;
        }
        let row = |i: usize| -> f64 { post.v[i * post.w..(i + 1) * post.w].iter().sum() };
        // Rows 14 and 16 (each moved twice its own way), not 10 or 20 (the shared mixture).
        assert!(row(14) > 0.49 && row(16) > 0.49, "{} {}", row(14), row(16));
        assert!(row(10) + row(20) + row(12) + row(18) < 1e-3);
        let c = |i: usize, v: i64| vel.axes[0].v[i * w + (v + r as i64) as usize];
        assert!(c(14, 2) > 0.99 && c(16, -2) > 0.99);
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 32, rng_seed: proptest::test_runner::RngSeed::Fixed(2009), ..ProptestConfig::default() })]
        /// The prediction over the whole reach keeps `keep` of the mass plus `γ/G` per
        /// cell, and every carried velocity is a distribution.
        #[test]
        fn masses_are_kept_and_velocities_normalised(
            h in 1usize..6, w in 1usize..6, s in 0usize..1000, lx in -3i64..1, ly in -3i64..1,
            nx in 1usize..6, ny in 1usize..6,
        ) {
            let r = 4;
            let sys = [constant_velocity(r), constant_velocity(r)];
            let post = patch(8, 8, h, w, s);
            let k = (kernels(8, h, lx, nx, s + 1), kernels(8, w, ly, ny, s + 2));
            let rect = Rect { a0: 4, a1: 8 + h + 6, b0: 4, b1: 8 + w + 6 };
            let (keep, u) = (0.99, 1e-4);
            let pr = predicted(&post, &k, keep, u, rect);
            let mass: f64 = pr.iter().sum();
            let want = keep + u * (rect.rows() * rect.cols()) as f64;
            prop_assert!((mass - want).abs() < 1e-12);
            let lik: Vec<f64> = (0..pr.len()).map(|c| val(c, s + 3)).collect();
            let upd = Patch {
                i0: rect.a0, j0: rect.b0, h: rect.rows(), w: rect.cols(),
                v: pr.iter().zip(&lik).map(|(p, l)| p * l).collect(),
            };
            let vel = update(&post, &k, keep, u, &upd, &sys);
            for ax in &vel.axes {
                for c in ax.v.chunks_exact(ax.width) {
                    prop_assert!(c.iter().all(|&x| x >= 0.0));
                    prop_assert!((c.iter().sum::<f64>() - 1.0).abs() < 1e-12);
                }
            }
        }
    }
}
