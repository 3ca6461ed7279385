//! Resampling a validated polygon to `L` points (Paper A, section 3).
//!
//! * [`Sampling::ArcLength`]: `L` points at equal arc-length steps, starting at the first vertex.
//! * [`Sampling::AffineArcLength`]: reparametrise by the first-order affine arc length of eq. 5,
//!   `t(l) = ½ ∫₀ˡ |x ẏ − y ẋ| dl'`, with `x, y` relative to the area centroid, and take `L`
//!   points at equal steps of `t`. The derivatives are regularised: the polygon is first
//!   resampled densely (`L₀` points, uniform in arc length) and differentiated in the Fourier
//!   domain with a Gaussian of standard deviation `σ` (arc-length units of the input, i.e.
//!   pixels for pixel contours; at least one dense sample spacing), so `ẋ, ẏ` are
//!   Gaussian-derivative filtered. Positions are interpolated linearly on the raw dense curve.
//!   Under an affine map `A` the parameter scales by `|det A|`, so sampling at equal *fractions*
//!   of the total `t` is affine covariant up to the start point (the property AFDs need).
//! * [`Sampling::Canonical`]: map the region by the similarity that moves its area centroid to
//!   the origin, its principal axis (largest second moment) onto the positive x axis and its
//!   area to 1, then sample uniformly in arc length, starting where the positive x axis leaves
//!   the region (the farthest crossing of the ray from the centroid; the vertex of largest x if
//!   the ray misses the contour, e.g. for a crescent). The principal axis is only defined up to
//!   sign: the sign is fixed by making the third moment `∫x³ dA` along it non-negative. For
//!   regions with (near) equal second moments or (near) zero skewness the frame's rotation is
//!   not stable; this is harmless for the rotation-invariant matchers (FD correlation, |FD|,
//!   AFDs), which is why Paper A pairs the canonical frame with them, and only affects the plain
//!   FD SSD reference ([`crate::Method::FdSsd`]).

use std::sync::Arc;

use rustfft::num_complex::Complex64;
use rustfft::{Fft, FftPlanner};
use serde::{Deserialize, Serialize};

use crate::contour::{moments, third_moment_x};

/// How a contour is resampled before its Fourier transform.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Sampling {
    /// Uniform in Euclidean arc length, from the first point.
    ArcLength,
    /// Uniform in first-order affine arc length (eq. 5), Paper A's "Affine".
    AffineArcLength,
    /// Uniform in arc length in the similarity-normalised canonical frame, Paper A's
    /// "Canonical".
    Canonical,
}

impl Sampling {
    /// Short name as in the paper's legends: `ArcLength`, `Affine`, `Canonical`.
    pub fn name(self) -> &'static str {
        match self {
            Sampling::ArcLength => "ArcLength",
            Sampling::AffineArcLength => "Affine",
            Sampling::Canonical => "Canonical",
        }
    }
}

/// Cumulative arc length at each vertex; `cum[n]` is the perimeter.
fn cumulative(poly: &[Complex64], cum: &mut Vec<f64>) {
    cum.clear();
    cum.push(0.0);
    let n = poly.len();
    let mut s = 0.0;
    for i in 0..n {
        s += (poly[(i + 1) % n] - poly[i]).norm_sqr().sqrt();
        cum.push(s);
    }
}

/// Fills `out` with points at arc lengths `start + k·P/L` (cyclic) along the polygon. The
/// positions increase monotonically, so the edge is found by walking forward (O(n + L)).
fn sample_arc_length(poly: &[Complex64], cum: &[f64], start: f64, out: &mut [Complex64]) {
    let n = poly.len();
    let per = cum[n];
    let step = per / out.len() as f64;
    let start = start - per * (start / per).floor();
    // Edge e with cum[e] <= start < cum[e + 1].
    let mut e = (cum.partition_point(|&c| c <= start).max(1) - 1).min(n - 1);
    let mut offset = 0.0; // multiples of the perimeter passed
    for (k, o) in out.iter_mut().enumerate() {
        let s = start + k as f64 * step - offset;
        let mut s = s;
        while s >= cum[e + 1] {
            e += 1;
            if e == n {
                e = 0;
                offset += per;
                s -= per;
            }
        }
        let len = cum[e + 1] - cum[e];
        let f = if len > 0.0 {
            ((s - cum[e]) / len).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let a = poly[e];
        let b = poly[(e + 1) % n];
        *o = a + (b - a) * f;
    }
}

/// Reusable state for resampling: buffers and the dense FFT plans of the affine sampler.
#[derive(Clone)]
pub(crate) struct Sampler {
    cum: Vec<f64>,
    frame: Vec<Complex64>,
    dense: Vec<Complex64>,
    smooth: Vec<Complex64>,
    deriv: Vec<Complex64>,
    t: Vec<f64>,
    scratch: Vec<Complex64>,
    fwd: Arc<dyn Fft<f64>>,
    inv: Arc<dyn Fft<f64>>,
    sigma: f64,
    /// Area centroid of the last polygon resampled by [`Sampling::AffineArcLength`], whose
    /// samples are relative to it.
    centroid: Complex64,
}

impl Sampler {
    /// A sampler whose affine mode uses `dense` points and smoothing `sigma`.
    pub(crate) fn new(planner: &mut FftPlanner<f64>, dense: usize, sigma: f64) -> Self {
        let fwd = planner.plan_fft_forward(dense);
        let inv = planner.plan_fft_inverse(dense);
        let scratch_len = fwd
            .get_inplace_scratch_len()
            .max(inv.get_inplace_scratch_len());
        let z = Complex64::new(0.0, 0.0);
        Sampler {
            cum: Vec::new(),
            frame: Vec::new(),
            dense: vec![z; dense],
            smooth: vec![z; dense],
            deriv: vec![z; dense],
            t: vec![0.0; dense + 1],
            scratch: vec![z; scratch_len],
            fwd,
            inv,
            sigma,
            centroid: z,
        }
    }

    /// Resamples the validated, positively oriented polygon `poly` into `out`; `poly` is the
    /// input scaled by `2^exponent` (module `contour`, "Range"), so the smoothing is scaled too.
    pub(crate) fn sample(
        &mut self,
        poly: &[Complex64],
        exponent: i32,
        how: Sampling,
        out: &mut [Complex64],
    ) {
        match how {
            Sampling::ArcLength => {
                cumulative(poly, &mut self.cum);
                sample_arc_length(poly, &self.cum, 0.0, out);
            }
            Sampling::Canonical => self.canonical(poly, out),
            Sampling::AffineArcLength => {
                self.affine(poly, crate::contour::scale_pow2(self.sigma, exponent), out)
            }
        }
    }

    fn canonical(&mut self, poly: &[Complex64], out: &mut [Complex64]) {
        let m = moments(poly);
        let theta = 0.5 * (2.0 * m.mu11).atan2(m.mu20 - m.mu02);
        let rot = Complex64::from_polar(1.0 / m.area.sqrt(), -theta);
        self.frame.clear();
        self.frame
            .extend(poly.iter().map(|&p| (p - m.centroid) * rot));
        if third_moment_x(&self.frame) < 0.0 {
            for q in self.frame.iter_mut() {
                *q = -*q;
            }
        }
        cumulative(&self.frame, &mut self.cum);
        let start = ray_exit(&self.frame, &self.cum);
        sample_arc_length(&self.frame, &self.cum, start, out);
    }

    /// The area centroid the samples of the last [`Sampling::AffineArcLength`] resampling are
    /// relative to (the samples plus it are in the polygon's coordinates).
    pub(crate) fn affine_centroid(&self) -> Complex64 {
        self.centroid
    }

    fn affine(&mut self, poly: &[Complex64], sigma: f64, out: &mut [Complex64]) {
        let m = moments(poly);
        self.centroid = m.centroid;
        cumulative(poly, &mut self.cum);
        let l0 = self.dense.len();
        let per = self.cum[poly.len()];
        sample_arc_length(poly, &self.cum, 0.0, &mut self.dense);
        for d in self.dense.iter_mut() {
            *d -= m.centroid;
        }
        // Regularised derivative in the Fourier domain.
        self.smooth.copy_from_slice(&self.dense);
        self.fwd
            .process_with_scratch(&mut self.smooth, &mut self.scratch);
        let h = per / l0 as f64;
        let sigma = sigma.max(h);
        // Gaussian exp(−½(ω_n σ)²) with ω_n = 2πn/P by the recurrence g_{n+1} = g_n·ρ_n,
        // ρ_{n+1} = ρ_n·exp(−2a) (a = ½(2πσ/P)²): two exp calls instead of one per bin.
        let a = 0.5 * (2.0 * std::f64::consts::PI * sigma / per).powi(2);
        let q = (-2.0 * a).exp();
        let (mut g, mut rho) = (1.0 / l0 as f64, (-a).exp());
        for n in 0..=l0 / 2 {
            let w = 2.0 * std::f64::consts::PI * n as f64 / per;
            for (k, sign) in [(n, 1.0), (l0 - n, -1.0)] {
                if k == l0 || (sign < 0.0 && (n == 0 || 2 * n == l0)) {
                    continue; // bin 0 and the Nyquist bin appear once
                }
                let c = self.smooth[k] * g;
                self.smooth[k] = c;
                self.deriv[k] = if 2 * k == l0 {
                    Complex64::new(0.0, 0.0)
                } else {
                    c * Complex64::new(0.0, sign * w)
                };
            }
            g *= rho;
            rho *= q;
        }
        self.inv
            .process_with_scratch(&mut self.smooth, &mut self.scratch);
        self.inv
            .process_with_scratch(&mut self.deriv, &mut self.scratch);
        // t_k = ½ ∫ |x ẏ − y ẋ| dl (trapezoid), x ẏ − y ẋ = Im(conj(c)·ċ).
        let w = |k: usize| (self.smooth[k].conj() * self.deriv[k]).im.abs();
        self.t[0] = 0.0;
        let mut prev = w(0);
        for k in 0..l0 {
            let next = w((k + 1) % l0);
            self.t[k + 1] = self.t[k] + 0.25 * h * (prev + next);
            prev = next;
        }
        let total = self.t[l0];
        let step = total / out.len() as f64;
        let mut k = 0;
        for (j, o) in out.iter_mut().enumerate() {
            let tau = j as f64 * step;
            while k + 1 < l0 && self.t[k + 1] <= tau {
                k += 1;
            }
            let dt = self.t[k + 1] - self.t[k];
            let f = if dt > 0.0 {
                ((tau - self.t[k]) / dt).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let a = self.dense[k];
            let b = self.dense[(k + 1) % l0];
            *o = a + (b - a) * f;
        }
    }
}

/// Arc-length position where the ray from the origin along +x leaves the polygon (farthest
/// crossing); the vertex of largest x if the ray crosses no edge.
fn ray_exit(poly: &[Complex64], cum: &[f64]) -> f64 {
    let n = poly.len();
    let mut best: Option<(f64, f64)> = None;
    for i in 0..n {
        let a = poly[i];
        let b = poly[(i + 1) % n];
        if (a.im <= 0.0) != (b.im <= 0.0) {
            let f = a.im / (a.im - b.im);
            let x = a.re + f * (b.re - a.re);
            if x > 0.0 && best.is_none_or(|(bx, _)| x > bx) {
                best = Some((x, cum[i] + f * (cum[i + 1] - cum[i])));
            }
        }
    }
    match best {
        Some((_, s)) => s,
        None => {
            let i = (0..n)
                .max_by(|&i, &j| poly[i].re.total_cmp(&poly[j].re))
                .unwrap_or(0);
            cum[i]
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square() -> Vec<Complex64> {
        [(0.0, 0.0), (2.0, 0.0), (2.0, 2.0), (0.0, 2.0)]
            .iter()
            .map(|&(x, y)| Complex64::new(x, y))
            .collect()
    }

    #[test]
    fn arc_length_sampling_walks_the_perimeter_evenly() {
        let p = square();
        let mut s = Sampler::new(&mut FftPlanner::new(), 64, 1.0);
        let mut out = vec![Complex64::new(0.0, 0.0); 8];
        s.sample(&p, 0, Sampling::ArcLength, &mut out);
        let want = [
            (0.0, 0.0),
            (1.0, 0.0),
            (2.0, 0.0),
            (2.0, 1.0),
            (2.0, 2.0),
            (1.0, 2.0),
            (0.0, 2.0),
            (0.0, 1.0),
        ];
        for (o, w) in out.iter().zip(want) {
            assert!(
                (o - Complex64::new(w.0, w.1)).norm() < 1e-12,
                "{o} vs {w:?}"
            );
        }
    }

    #[test]
    fn canonical_frame_of_a_rectangle_is_centred_axis_aligned_unit_area() {
        // 4 × 1 rectangle rotated by 30° and shifted: canonical frame is the axis-aligned
        // 2 × 0.5 rectangle (area 1), sampled from the middle of its right edge.
        let rot = Complex64::from_polar(1.0, std::f64::consts::FRAC_PI_6);
        let p: Vec<Complex64> = [(0.0, 0.0), (4.0, 0.0), (4.0, 1.0), (0.0, 1.0)]
            .iter()
            .map(|&(x, y)| Complex64::new(x, y) * rot + Complex64::new(10.0, -3.0))
            .collect();
        let mut s = Sampler::new(&mut FftPlanner::new(), 64, 1.0);
        let mut out = vec![Complex64::new(0.0, 0.0); 10];
        s.sample(&p, 0, Sampling::Canonical, &mut out);
        // Either sign of the axis is allowed for a symmetric rectangle; start is on the axis.
        assert!((out[0].re.abs() - 1.0).abs() < 1e-9 && out[0].im.abs() < 1e-9);
        for o in &out {
            assert!(o.re.abs() <= 1.0 + 1e-9 && o.im.abs() <= 0.25 + 1e-9);
        }
    }

    #[test]
    fn affine_sampling_of_a_circle_is_uniform() {
        // For a circle about its centre the affine arc length is proportional to the angle.
        let n = 720;
        let p: Vec<Complex64> = (0..n)
            .map(|k| Complex64::from_polar(50.0, 2.0 * std::f64::consts::PI * k as f64 / n as f64))
            .collect();
        let mut s = Sampler::new(&mut FftPlanner::new(), 1024, 1.0);
        let mut out = vec![Complex64::new(0.0, 0.0); 16];
        s.sample(&p, 0, Sampling::AffineArcLength, &mut out);
        for (k, o) in out.iter().enumerate() {
            let want = 2.0 * std::f64::consts::PI * k as f64 / 16.0;
            let d = (o.arg() - want + std::f64::consts::PI).rem_euclid(2.0 * std::f64::consts::PI)
                - std::f64::consts::PI;
            assert!(d.abs() < 1e-3, "sample {k}: angle {} vs {want}", o.arg());
        }
    }
}
