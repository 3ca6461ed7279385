//! Baseline: SIR particle filter (Arulampalam et al.'s generic particle filter with
//! resampling at every step, systematic resampling), seeded.

use rand::rngs::Xoshiro256PlusPlus;
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

use super::calibrate::Calibration;
use crate::error::{non_negative, positive, unit};
use crate::integrity::{corrupt, finite, len, nonneg};
use crate::tracker::{Estimate, Tracker};
use crate::{Detection, Point, TrackError};

/// The particle filter's motion and measurement model.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PfModel {
    /// Image tracking: state `[x, y, vx, vy]`, discrete white-noise acceleration
    /// (`x += v + a/2, v += a`, `a ~ N(0, σ_a² I)`), measurement `z = (x, y) + N(0, σ_z² I)`,
    /// clutter-aware likelihood `(1 − P_D) + P_D/λ · Σ_i w_i N(z_i; (x, y), σ_z² I)` with
    /// clutter density `λ` (detections per pixel per frame).
    ConstantVelocity {
        /// Acceleration noise σ_a.
        accel_sigma: f64,
        /// Detection noise σ_z.
        meas_sigma: f64,
        /// Detection probability `P_D ∈ (0, 1]`.
        p_detect: f64,
        /// Clutter density `λ > 0` (clutter rate / image area).
        clutter_density: f64,
        /// Initial velocity spread (standard deviation).
        init_vel_sigma: f64,
    },
    /// The univariate non-stationary growth model (docs/methods.md § Tracking):
    /// `x_k = x/2 + 25x/(1 + x²) + 8 cos(1.2 k) + v`, `z = x²/20 + n`, likelihood
    /// `Σ_i w_i N(z_i; x²/20, σ_n²)`.
    Ungm {
        /// Process noise variance (10 in the benchmark).
        process_var: f64,
        /// Measurement noise variance (1 in the benchmark).
        meas_var: f64,
        /// Initial spread around the start (standard deviation).
        init_sigma: f64,
    },
}

impl PfModel {
    /// The image-tracking model from training statistics over an image of `area` px²
    /// (clutter density at least 0.01 per frame over the image, so that the likelihood keeps
    /// a floor).
    pub fn from_calibration(c: &Calibration, area: f64) -> Self {
        PfModel::ConstantVelocity {
            accel_sigma: c.accel_sigma,
            meas_sigma: c.meas_sigma,
            p_detect: c.p_detect,
            clutter_density: c.clutter_rate.max(0.01) / area,
            init_vel_sigma: 5.0 * c.accel_sigma,
        }
    }

    fn validate(&self) -> Result<(), TrackError> {
        match *self {
            PfModel::ConstantVelocity {
                accel_sigma,
                meas_sigma,
                p_detect,
                clutter_density,
                init_vel_sigma,
            } => {
                positive("accel_sigma", accel_sigma)?;
                positive("meas_sigma", meas_sigma)?;
                unit("p_detect", p_detect, false)?;
                positive("p_detect", p_detect)?;
                positive("clutter_density", clutter_density)?;
                non_negative("init_vel_sigma", init_vel_sigma)
            }
            PfModel::Ungm {
                process_var,
                meas_var,
                init_sigma,
            } => {
                positive("process_var", process_var)?;
                positive("meas_var", meas_var)?;
                positive("init_sigma", init_sigma)
            }
        }
    }

    fn dims(&self) -> usize {
        match self {
            PfModel::ConstantVelocity { .. } => 2,
            PfModel::Ungm { .. } => 1,
        }
    }
}

/// A SIR particle filter with `n` particles, systematic resampling after every update and a
/// seeded generator (`Xoshiro256++`, serialised with the filter, so a reloaded filter
/// continues the same random sequence).
///
/// A filter read back with serde is validated (model parameters, at least one particle, as
/// many weights as particles, finite values, weights summing to 1, a generator state that is
/// not all zeros): [`TrackError::Corrupt`] otherwise.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "ParticleFilterRaw")]
pub struct ParticleFilter {
    model: PfModel,
    particles: Vec<[f64; 4]>,
    weights: Vec<f64>,
    logw: Vec<f64>,
    rng: Xoshiro256PlusPlus,
    /// Time index of the current estimate (UNGM's `k`).
    k: u64,
    estimate: Point,
}

/// A [`ParticleFilter`] as read, before its consistency check.
#[derive(Deserialize)]
struct ParticleFilterRaw {
    model: PfModel,
    particles: Vec<[f64; 4]>,
    weights: Vec<f64>,
    logw: Vec<f64>,
    rng: RngState,
    k: u64,
    estimate: Point,
}

/// How far from 1 the weights of a deserialised filter may sum (rounding of `n · 1/n`).
const WEIGHT_SUM_SLACK: f64 = 1e-6;

impl TryFrom<ParticleFilterRaw> for ParticleFilter {
    type Error = TrackError;

    fn try_from(r: ParticleFilterRaw) -> Result<Self, TrackError> {
        r.model.validate()?;
        let rng = r.rng.generator()?;
        if r.particles.is_empty() {
            return Err(corrupt("a particle filter without particles"));
        }
        len("particle weights", r.weights.len(), r.particles.len())?;
        len("particle log-weights", r.logw.len(), r.particles.len())?;
        nonneg("particle weights", &r.weights)?;
        // Every step and reset leaves the weights normalised (1/n each); the estimate of a
        // step without detections is their weighted mean as they are, so weights that do not
        // sum to 1 (all zero, say) would give a silently wrong position.
        let sum: f64 = r.weights.iter().sum();
        if (sum - 1.0).abs() > WEIGHT_SUM_SLACK {
            return Err(corrupt(format!("particle weights sum to {sum}, not 1")));
        }
        finite("particles", r.particles.as_flattened())?;
        finite("estimate", &r.estimate)?;
        // Log-weights are scratch (rewritten before every use); −∞ is a valid value.
        Ok(ParticleFilter {
            model: r.model,
            particles: r.particles,
            weights: r.weights,
            logw: r.logw,
            rng,
            k: r.k,
            estimate: r.estimate,
        })
    }
}

/// The saved state of the filter's `Xoshiro256++` generator: the form its own `Deserialize`
/// reads (`{"s": [4 words]}`), checked before the generator is rebuilt.
#[derive(Deserialize)]
struct RngState {
    s: [u64; 4],
}

impl RngState {
    /// The generator with this state. All zeros is [`TrackError::Corrupt`]: xoshiro never
    /// reaches it (it would draw 0 forever, and the normal sampler then never returns).
    fn generator(&self) -> Result<Xoshiro256PlusPlus, TrackError> {
        if self.s == [0; 4] {
            return Err(corrupt(
                "random generator state of all zeros (it would draw 0 forever)",
            ));
        }
        // `from_seed` reads the words little-endian and keeps any state but all zeros: the
        // generator `Deserialize` would have built.
        let mut seed = [0u8; 32];
        for (chunk, w) in seed.chunks_exact_mut(8).zip(self.s) {
            chunk.copy_from_slice(&w.to_le_bytes());
        }
        Ok(Xoshiro256PlusPlus::from_seed(seed))
    }
}

/// The most particles a filter may have (2²⁴, about 0.8 GB of particle state): more is
/// refused with a typed error before anything is allocated.
pub const MAX_PARTICLES: usize = 1 << 24;

/// Checks a particle count: `1 ≤ n ≤` [`MAX_PARTICLES`].
pub(crate) fn check_particle_count(n: usize) -> Result<(), TrackError> {
    if n == 0 || n > MAX_PARTICLES {
        return Err(TrackError::InvalidParameter {
            name: "particles",
            value: n as f64,
            reason: "must lie in 1..=MAX_PARTICLES (2^24)",
        });
    }
    Ok(())
}

impl ParticleFilter {
    /// `1 ≤ n ≤` [`MAX_PARTICLES`] particles, all random draws from `seed`.
    pub fn new(model: PfModel, n: usize, seed: u64) -> Result<Self, TrackError> {
        model.validate()?;
        check_particle_count(n)?;
        let mut pf = ParticleFilter {
            model,
            particles: vec![[0.0; 4]; n],
            weights: vec![1.0 / n as f64; n],
            logw: vec![0.0; n],
            rng: Xoshiro256PlusPlus::seed_from_u64(seed),
            k: 0,
            estimate: [0.0; 2],
        };
        pf.reset([0.0, 0.0])?;
        Ok(pf)
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.particles.len()
    }

    /// Always false (at least one particle).
    pub fn is_empty(&self) -> bool {
        false
    }

    /// The particles `[x, y, vx, vy]` (1-D models use `x` only).
    pub fn particles(&self) -> &[[f64; 4]] {
        &self.particles
    }

    fn normal(&mut self) -> f64 {
        StandardNormal.sample(&mut self.rng)
    }

    fn propagate(&mut self) {
        self.k += 1;
        match self.model {
            PfModel::ConstantVelocity { accel_sigma, .. } => {
                for i in 0..self.particles.len() {
                    let ax = accel_sigma * self.normal();
                    let ay = accel_sigma * self.normal();
                    let p = &mut self.particles[i];
                    p[0] += p[2] + 0.5 * ax;
                    p[1] += p[3] + 0.5 * ay;
                    p[2] += ax;
                    p[3] += ay;
                }
            }
            PfModel::Ungm { process_var, .. } => {
                let s = process_var.sqrt();
                let drive = 8.0 * (1.2 * self.k as f64).cos();
                for i in 0..self.particles.len() {
                    let v = s * self.normal();
                    let p = &mut self.particles[i];
                    let x = p[0];
                    p[0] = 0.5 * x + 25.0 * x / (1.0 + x * x) + drive + v;
                }
            }
        }
    }

    /// Log-likelihood of every particle; `false` when there is no information (no detection).
    fn log_likelihoods(&mut self, dets: &[Detection]) -> bool {
        let dets: Vec<&Detection> = dets.iter().filter(|d| d.weight > 0.0).collect();
        if dets.is_empty() {
            return false;
        }
        match self.model {
            PfModel::ConstantVelocity {
                meas_sigma,
                p_detect,
                clutter_density,
                ..
            } => {
                let inv2 = 0.5 / (meas_sigma * meas_sigma);
                let norm = 1.0 / (2.0 * std::f64::consts::PI * meas_sigma * meas_sigma);
                let c = p_detect / clutter_density * norm;
                for (lw, p) in self.logw.iter_mut().zip(&self.particles) {
                    let mut s = 0.0;
                    for d in &dets {
                        let (dx, dy) = (d.pos[0] - p[0], d.pos[1] - p[1]);
                        s += d.weight * (-(dx * dx + dy * dy) * inv2).exp();
                    }
                    *lw = ((1.0 - p_detect) + c * s).ln();
                }
            }
            PfModel::Ungm { meas_var, .. } => {
                let inv2 = 0.5 / meas_var;
                for (lw, p) in self.logw.iter_mut().zip(&self.particles) {
                    let h = p[0] * p[0] / 20.0;
                    // log Σ_i w_i exp(−(z_i − h)²/2σ²), stable.
                    let terms = dets
                        .iter()
                        .map(|d| (d.weight.ln(), -(d.pos[0] - h).powi(2) * inv2));
                    let m = terms
                        .clone()
                        .map(|(a, b)| a + b)
                        .fold(f64::NEG_INFINITY, f64::max);
                    let s: f64 = terms.map(|(a, b)| (a + b - m).exp()).sum();
                    *lw = m + s.ln();
                }
            }
        }
        true
    }

    fn systematic_resample(&mut self) {
        systematic_resample(&mut self.particles, &mut self.weights, &mut self.rng);
    }
}

/// Systematic resampling (one uniform draw): `particles` replaced by `n` draws in proportion
/// to `weights` (normalised), every weight then `1/n`. Shared by the particle filters.
pub(crate) fn systematic_resample<P: Copy>(
    particles: &mut Vec<P>,
    weights: &mut [f64],
    rng: &mut Xoshiro256PlusPlus,
) {
    let n = particles.len();
    let u0: f64 = rng.random::<f64>() / n as f64;
    let mut out = Vec::with_capacity(n);
    let mut cum = weights[0];
    let mut i = 0;
    for j in 0..n {
        let u = u0 + j as f64 / n as f64;
        while u > cum && i + 1 < n {
            i += 1;
            cum += weights[i];
        }
        out.push(particles[i]);
    }
    *particles = out;
    weights.iter_mut().for_each(|w| *w = 1.0 / n as f64);
}

/// Multiplies `weights` by `exp(logw − max)` and normalises them; uniform weights when the
/// product has no mass. Shared by the particle filters.
pub(crate) fn reweight(weights: &mut [f64], logw: &[f64]) {
    let m = logw.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    if !m.is_finite() {
        return;
    }
    let mut s = 0.0;
    for (w, lw) in weights.iter_mut().zip(logw) {
        *w *= (lw - m).exp();
        s += *w;
    }
    if s > 0.0 && s.is_finite() {
        weights.iter_mut().for_each(|w| *w /= s);
    } else {
        let n = weights.len() as f64;
        weights.iter_mut().for_each(|w| *w = 1.0 / n);
    }
}

/// The weighted mean of the particles' positions.
pub(crate) fn weighted_mean(weights: &[f64], particles: impl Iterator<Item = Point>) -> Point {
    let mut e = [0.0; 2];
    for (w, p) in weights.iter().zip(particles) {
        e[0] += w * p[0];
        e[1] += w * p[1];
    }
    e
}

impl Tracker for ParticleFilter {
    fn name(&self) -> String {
        format!("PF {}", self.particles.len())
    }

    fn reset(&mut self, start: Point) -> Result<(), TrackError> {
        let dims = self.model.dims();
        crate::data::check_point("start coordinate", &start, dims)?;
        let (pos_sigma, vel_sigma) = match self.model {
            PfModel::ConstantVelocity {
                meas_sigma,
                init_vel_sigma,
                ..
            } => (meas_sigma, init_vel_sigma),
            PfModel::Ungm { init_sigma, .. } => (init_sigma, 0.0),
        };
        for i in 0..self.particles.len() {
            let r = [self.normal(), self.normal(), self.normal(), self.normal()];
            let p = &mut self.particles[i];
            p[0] = start[0] + pos_sigma * r[0];
            p[1] = if dims == 2 {
                start[1] + pos_sigma * r[1]
            } else {
                0.0
            };
            p[2] = if dims == 2 { vel_sigma * r[2] } else { 0.0 };
            p[3] = if dims == 2 { vel_sigma * r[3] } else { 0.0 };
        }
        let n = self.particles.len();
        self.weights.iter_mut().for_each(|w| *w = 1.0 / n as f64);
        self.k = 0;
        self.estimate = start;
        Ok(())
    }

    fn step(&mut self, detections: &[Detection]) -> Result<Estimate, TrackError> {
        for d in detections {
            d.validate(self.model.dims())?;
        }
        // Only a filter read back with the largest count gets here (a reset restarts it).
        if self.k == u64::MAX {
            return Err(TrackError::InvalidParameter {
                name: "k",
                value: self.k as f64,
                reason: "the time index is at u64::MAX: no step follows it (reset restarts it)",
            });
        }
        self.propagate();
        if self.log_likelihoods(detections) {
            reweight(&mut self.weights, &self.logw);
        }
        self.estimate = weighted_mean(&self.weights, self.particles.iter().map(|p| [p[0], p[1]]));
        self.systematic_resample();
        Ok(self.estimate())
    }

    fn estimate(&self) -> Estimate {
        Estimate::at(self.estimate)
    }
}
