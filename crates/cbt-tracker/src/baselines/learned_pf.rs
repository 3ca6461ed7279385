//! Baseline: a SIR particle filter that knows only what CBT learned — its transition and
//! likelihood are the learned first-order channel densities of a [`CbtModel`] (separable
//! layout), evaluated at continuous particle positions. The like-for-like particle filter of
//! a benchmark whose true model CBT cannot be given (UNGM).
//!
//! Per axis `d`, a particle at `x` with state-channel values `b_n(x)` moves to a draw of the
//! learned density `p(x' | x) = Σ_n b̂_n(x) Σ_m S[m, n] B_m(x')` (`b̂ = b / Σ b`, `B_m` the
//! channel kernel; with a [`crate::PeriodicInput`] `S = S(φ_k)`, module `input`): a channel
//! `n ∝ b̂_n(x)`, then `m ∝ S[·, n]`, then `x' = x̃_m + u·spacing` with `u` drawn from the
//! kernel's shape (rejection sampling). Its weight is CBT's update likelihood at the grid
//! (`ℓ[g] = Σ_i w_i p(z_i | x̃_g)`, clutter handling and floor included) interpolated at the
//! particle, `Σ_g b̂_g(x) ℓ[g]`. The start is a draw of the start's channel encoding (CBT's
//! start). The estimate is the weighted mean; systematic resampling after every step.

use rand::rngs::Xoshiro256PlusPlus;
use rand::{RngExt, SeedableRng};

use super::particle::{systematic_resample, weighted_mean};
use crate::config::{Layout, Order};
use crate::tracker::{Estimate, Tracker};
use crate::{CbtModel, CbtTracker, Detection, Point, TrackError};

/// A particle filter on CBT's learned first-order models (module docs). Needs a
/// [`CbtModel`] of the separable layout and first order (optionally with a
/// [`crate::PeriodicInput`]). Seeded (`Xoshiro256++`); an input the step rejects leaves the
/// filter unchanged.
#[derive(Debug, Clone, PartialEq)]
pub struct LearnedParticleFilter {
    /// The learned models and CBT's likelihood code.
    cbt: CbtTracker,
    particles: Vec<Point>,
    weights: Vec<f64>,
    logw: Vec<f64>,
    rng: Xoshiro256PlusPlus,
    /// Time index of the particles (the input's `k`): 0 at reset.
    time: u64,
    estimate: Point,
    /// Work buffer: one transition column.
    col: Vec<f64>,
}

impl LearnedParticleFilter {
    /// `1 ≤ n ≤` [`MAX_PARTICLES`](crate::MAX_PARTICLES) particles on `model` (separable layout, first order), random draws from `seed`.
    pub fn new(model: CbtModel, n: usize, seed: u64) -> Result<Self, TrackError> {
        let cfg = model.config();
        if cfg.layout != Layout::Separable || cfg.order != Order::First {
            return Err(TrackError::Mismatch(
                "the learned particle filter needs a first-order model of the separable layout"
                    .into(),
            ));
        }
        super::particle::check_particle_count(n)?;
        let start = {
            let b = model.space().state_basis(0);
            let (lo, hi) = b.representable_range();
            let mut p = [0.5 * (lo + hi), 0.0];
            if model.space().dims() == 2 {
                let (lo, hi) = model.space().state_basis(1).representable_range();
                p[1] = 0.5 * (lo + hi);
            }
            p
        };
        let mut pf = LearnedParticleFilter {
            cbt: CbtTracker::new(model),
            particles: vec![[0.0; 2]; n],
            weights: vec![1.0 / n as f64; n],
            logw: vec![0.0; n],
            rng: Xoshiro256PlusPlus::seed_from_u64(seed),
            time: 0,
            estimate: start,
            col: Vec::new(),
        };
        pf.reset(start)?;
        Ok(pf)
    }

    /// The particles (1-D models use `x` only).
    pub fn particles(&self) -> &[Point] {
        &self.particles
    }

    /// A draw of the channel-coded density `Σ_m c_m B_m` on axis `d` (`c` need not be
    /// normalised; at least one positive entry).
    fn draw(&mut self, d: usize, c: impl Iterator<Item = (usize, f64)> + Clone) -> f64 {
        let total: f64 = c.clone().map(|e| e.1).sum();
        let mut u = self.rng.random::<f64>() * total;
        let mut m = 0;
        for (k, v) in c {
            m = k;
            if u < v {
                break;
            }
            u -= v;
        }
        let b = self.cbt.model().space().state_basis(d);
        let kernel = b.kernel();
        let r = kernel.support_radius();
        let peak = kernel.value(0.0);
        let off = loop {
            let t = (2.0 * self.rng.random::<f64>() - 1.0) * r;
            if self.rng.random::<f64>() * peak < kernel.value(t) {
                break t;
            }
        };
        let (lo, hi) = b.representable_range();
        b.from_index(m as f64 + off).clamp(lo, hi)
    }

    /// The normalised state-channel values `b̂_n(x)` of axis `d`.
    fn channels(&self, d: usize, x: f64) -> Vec<(usize, f64)> {
        let b = self.cbt.model().space().state_basis(d);
        let mut a = Vec::with_capacity(4);
        b.for_each_active(b.to_index(x), |n, v| {
            if v > 0.0 {
                a.push((n, v))
            }
        });
        let s: f64 = a.iter().map(|e| e.1).sum();
        a.iter_mut().for_each(|e| e.1 /= s);
        a
    }

    fn dims(&self) -> usize {
        self.cbt.model().space().dims()
    }
}

impl Tracker for LearnedParticleFilter {
    fn name(&self) -> String {
        let phase = if self.cbt.model().config().input.is_some() {
            " + phase"
        } else {
            ""
        };
        format!("PF {} learned{phase}", self.particles.len())
    }

    fn reset(&mut self, start: Point) -> Result<(), TrackError> {
        self.cbt.model().space().state_index(&start)?;
        for i in 0..self.particles.len() {
            let mut p = [0.0; 2];
            for (d, v) in p.iter_mut().enumerate().take(self.dims()) {
                let a = self.channels(d, start[d]);
                *v = self.draw(d, a.into_iter());
            }
            self.particles[i] = p;
        }
        let n = self.particles.len();
        self.weights.iter_mut().for_each(|w| *w = 1.0 / n as f64);
        self.time = 0;
        self.estimate = start;
        Ok(())
    }

    fn step(&mut self, detections: &[Detection]) -> Result<Estimate, TrackError> {
        // Validates every detection before anything changes.
        let informative = self.cbt.grid_likelihood(detections)?.is_some();
        // Counts steps since the last reset (not deserialisable): 2^64 steps never happen.
        self.time += 1;
        let k = self.time;
        let dims = self.dims();
        let mut col = std::mem::take(&mut self.col);
        for i in 0..self.particles.len() {
            let mut p = self.particles[i];
            for (d, v) in p.iter_mut().enumerate().take(dims) {
                // Not empty: every particle lies in the representable range (`draw` clamps
                // to it), where at least one channel is positive.
                let a = self.channels(d, *v);
                // A channel n ∝ b̂_n(x), then the learned column's density.
                let n = {
                    let mut u = self.rng.random::<f64>();
                    let mut pick = a[a.len() - 1].0;
                    for &(n, w) in &a {
                        if u < w {
                            pick = n;
                            break;
                        }
                        u -= w;
                    }
                    pick
                };
                col.resize(self.cbt.model().space().axis_len(d), 0.0);
                self.cbt.model().transition_column(d, n, k, &mut col);
                *v = self.draw(d, col.iter().copied().enumerate().filter(|e| e.1 > 0.0));
            }
            self.particles[i] = p;
        }
        self.col = col;
        if informative {
            let ny = if dims == 2 {
                self.cbt.model().space().axis_len(1)
            } else {
                1
            };
            let mut logw = std::mem::take(&mut self.logw);
            for (lw, p) in logw.iter_mut().zip(&self.particles) {
                let ax = self.channels(0, p[0]);
                let ay = if dims == 2 {
                    self.channels(1, p[1])
                } else {
                    vec![(0, 1.0)]
                };
                let lik = self.cbt.last_likelihood();
                let mut l = 0.0;
                for &(i, a) in &ax {
                    for &(j, b) in &ay {
                        l += a * b * lik[i * ny + j];
                    }
                }
                *lw = l.ln();
            }
            super::particle::reweight(&mut self.weights, &logw);
            self.logw = logw;
        }
        self.estimate = weighted_mean(&self.weights, self.particles.iter().copied());
        systematic_resample(&mut self.particles, &mut self.weights, &mut self.rng);
        Ok(self.estimate())
    }

    fn estimate(&self) -> Estimate {
        Estimate::at(self.estimate)
    }
}
