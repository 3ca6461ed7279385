//! The Channel Based Tracking filter (docs/methods.md § Tracking): grid-based Bayesian
//! filtering (eq. 3.3, 3.4) on channel-coded densities with learned models.

use serde::{Deserialize, Serialize};

use crate::config::{Clutter, Layout, Order};
use crate::encode::{Encoded, encode_detections};
use crate::history::{self, History};
use crate::integrity::{len, nonneg};
use crate::model::{ObservationModel, SystemModel};
use crate::stationary::{Patch, WindowState};
use crate::tracker::{Estimate, Hypothesis, Tracker};
use crate::{CbtModel, Detection, Point, TrackError};

/// A CBT tracker: a learned [`CbtModel`] and the posterior over the joint state grid.
///
/// The posterior `q_k⁺` is a non-negative vector over the `G` joint grid cells summing to 1
/// (the channel coefficients of the density: a Parzen estimate sampled at the grid points).
/// One step:
///
/// 1. **predict** — separable layout: per axis `d`, `p_d = T_d(q_{k−1,d}, q_{k−2,d})` on the
///    marginals of the last two posteriors (or `S_d q_{k−1,d}` for first order), prior
///    `⊗_d p_d`; joint layout: the same sums over the joint grid. Then the lost-track mixing
///    `q⁻ ← (1 − γ) q⁻ + γ/G`.
/// 2. **update** (eq. 3.4) with the mixture likelihood of the weighted detections
///    `ℓ = Σ_i w_i · Oᵀ b(z_i)` (per axis `Π_d O_dᵀ b_d(z_i,d)` in the separable layout):
///    `q⁺ ∝ ℓ ⊙ q⁻`; no detection leaves `q⁺ = q⁻`.
/// 3. **estimate**: the posterior decoded with `chan-repr`'s local decoder
///    ([`chan_repr::ChannelGrid::decode`]): best mode, certainty = its window mass, runner-ups.
///
/// A tracker read back with serde is validated: its model as [`CbtModel`] is, and its
/// posterior's sizes against the model's space, its values finite and non-negative, the
/// states of its online-learning history on the grid ([`TrackError::Corrupt`] otherwise).
/// Work buffers are neither saved nor compared: a loaded tracker equals its original.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "CbtTrackerRaw")]
pub struct CbtTracker {
    model: CbtModel,
    name: String,
    /// `q_k⁺` (joint).
    post: Vec<f64>,
    /// `q_{k−1}⁺` (joint; used by the joint second-order layout).
    prev: Vec<f64>,
    /// Per-axis marginals of `q_k⁺` and `q_{k−1}⁺`.
    marg: Vec<Vec<f64>>,
    marg_prev: Vec<Vec<f64>>,
    /// Learn from every step's own estimate.
    self_learning: bool,
    /// The windowed posterior of the stationary layout (`post`, `prev`, `marg*` unused).
    #[serde(default)]
    win: WindowState,
    /// The last two frames of [`learn_online`](Self::learn_online) (saved as their states).
    #[serde(serialize_with = "save_history")]
    history: History,
    /// Time index of the posterior (a [`crate::PeriodicInput`]'s `k`; stays 0 without one).
    #[serde(default, skip_serializing_if = "is_zero")]
    time: u64,
    #[serde(skip)]
    scratch: Scratch,
}

fn is_zero(v: &u64) -> bool {
    *v == 0
}

fn save_history<S: serde::Serializer>(h: &History, s: S) -> Result<S::Ok, S::Error> {
    h.saved().serialize(s)
}

/// A [`CbtTracker`] as read, before its consistency check.
#[derive(Deserialize)]
struct CbtTrackerRaw {
    model: CbtModel,
    name: String,
    post: Vec<f64>,
    prev: Vec<f64>,
    marg: Vec<Vec<f64>>,
    marg_prev: Vec<Vec<f64>>,
    self_learning: bool,
    #[serde(default)]
    win: WindowState,
    /// Absent in files from before it was saved: such a tracker's next online-learning frame
    /// starts a new chain (as it did when those files were loaded then).
    #[serde(default)]
    history: history::Saved,
    #[serde(default)]
    time: u64,
}

impl TryFrom<CbtTrackerRaw> for CbtTracker {
    type Error = TrackError;

    fn try_from(raw: CbtTrackerRaw) -> Result<Self, TrackError> {
        let mut t = CbtTracker {
            model: raw.model,
            name: raw.name,
            post: raw.post,
            prev: raw.prev,
            marg: raw.marg,
            marg_prev: raw.marg_prev,
            self_learning: raw.self_learning,
            win: raw.win,
            history: History::default(),
            time: raw.time,
            scratch: Scratch::default(),
        };
        let space = t.model.space();
        let cfg = t.model.config();
        t.history = History::restore(
            raw.history,
            space,
            cfg.online_weight,
            cfg.layout == Layout::SparseJoint,
        )?;
        if t.is_stationary() {
            t.win.check(space)?;
        } else {
            for (what, v) in [("posterior", &t.post), ("previous posterior", &t.prev)] {
                len(what, v.len(), space.cells())?;
                nonneg(what, v)?;
            }
        }
        for (what, m) in [("marginals", &t.marg), ("previous marginals", &t.marg_prev)] {
            len(what, m.len(), space.dims())?;
            for (d, v) in m.iter().enumerate() {
                len(what, v.len(), space.axis_len(d))?;
                nonneg(what, v)?;
            }
        }
        Ok(t)
    }
}

/// Reused work buffers of one step: not part of the filter's state (not saved, and equal
/// whatever they hold, so a tracker loaded from a file compares equal to its original).
#[derive(Debug, Clone, Default)]
struct Scratch {
    prior: Vec<f64>,
    lik: Vec<f64>,
    axis: Vec<Vec<f64>>,
    axis_lik: Vec<Vec<f64>>,
}

impl PartialEq for Scratch {
    fn eq(&self, _: &Scratch) -> bool {
        true
    }
}

impl CbtTracker {
    /// A tracker with the given model, started at the centre of the grid.
    pub fn new(model: CbtModel) -> Self {
        let g = model.space().cells();
        let dims = model.space().dims();
        let name = match (model.config().order, model.config().layout) {
            (Order::Second, Layout::Separable) => "CBT 2nd order",
            (Order::First, Layout::Separable) => "CBT 1st order",
            (Order::Second, Layout::SparseJoint) => "CBT 2nd order (joint)",
            (Order::First, Layout::SparseJoint) => "CBT 1st order (joint)",
            (Order::Second, Layout::Stationary) => "CBT 2nd order",
            (Order::First, Layout::Stationary) => "CBT 1st order",
        };
        let name = if model.config().input.is_some() {
            format!("{name} + phase")
        } else {
            name.to_string()
        };
        let stationary = model.config().layout == Layout::Stationary;
        let g = if stationary { 0 } else { g };
        let marg: Vec<Vec<f64>> = (0..dims)
            .map(|d| vec![1.0 / model.space().axis_len(d) as f64; model.space().axis_len(d)])
            .collect();
        let mut win = WindowState::default();
        if stationary {
            // Started at the centre of the grid (a sharp prior; `reset` places it).
            let c: Vec<f64> = (0..2)
                .map(|d| {
                    let (lo, hi) = model.space().state_basis(d).representable_range();
                    0.5 * (lo + hi)
                })
                .collect();
            win.start(point_patch(model.space(), [c[0], c[1]]));
        }
        CbtTracker {
            name,
            post: vec![1.0 / g as f64; g],
            prev: vec![1.0 / g as f64; g],
            marg_prev: marg.clone(),
            marg,
            win,
            model,
            self_learning: false,
            history: History::default(),
            time: 0,
            scratch: Scratch::default(),
        }
    }

    /// Makes every [`step`](Tracker::step) also call [`learn_online`](Self::learn_online)
    /// with the tracker's own estimate as the frame's state (self-supervised incremental
    /// learning), and renames the tracker accordingly.
    pub fn with_self_learning(mut self) -> Self {
        self.self_learning = true;
        self.name = format!("{} online", self.name);
        self
    }

    /// Renames the tracker.
    pub fn with_name(mut self, name: impl Into<String>) -> Self {
        self.name = name.into();
        self
    }

    /// The model.
    pub fn model(&self) -> &CbtModel {
        &self.model
    }

    /// The posterior `q_k⁺` over the joint grid (sums to 1). For the stationary layout, the
    /// posterior on its window only (see [`posterior_window`](Self::posterior_window)).
    pub fn posterior(&self) -> &[f64] {
        if self.is_stationary() {
            &self.win.post.v
        } else {
            &self.post
        }
    }

    /// The stationary layout's window: first cell `(i0, j0)` and size `(rows, cols)` of the
    /// rectangle [`posterior`](Self::posterior) covers (row-major, rows along axis 0); outside
    /// it the posterior is below `support × max` and taken as 0. `None` for other layouts.
    pub fn posterior_window(&self) -> Option<([usize; 2], [usize; 2])> {
        self.is_stationary().then(|| {
            let p = &self.win.post;
            ([p.i0, p.j0], [p.h, p.w])
        })
    }

    /// The time index of the posterior: 0 after a reset, one more after each step (only
    /// counted when the model has a [`crate::PeriodicInput`]; 0 otherwise).
    pub fn time(&self) -> u64 {
        self.time
    }

    /// Sets the time index of the posterior (a track that starts at frame `k` of a
    /// sequence whose input phase is `ω·k`); the next step predicts into `k + 1`. No effect
    /// on a model without a [`crate::PeriodicInput`].
    pub fn set_time(&mut self, k: u64) {
        if self.model.config().input.is_some() {
            self.time = k;
        }
    }

    fn is_stationary(&self) -> bool {
        self.model.config().layout == Layout::Stationary
    }

    /// Starts from a given joint density (normalised here; must be non-negative, finite, of
    /// length `G`, with positive mass); both previous posteriors are set to it.
    pub fn reset_to(&mut self, density: &[f64]) -> Result<(), TrackError> {
        let g = self.model.space().cells();
        if density.len() != g {
            return Err(TrackError::Mismatch(format!(
                "a density over {g} grid cells was expected, got {}",
                density.len()
            )));
        }
        let mut s = 0.0;
        for &v in density {
            if !v.is_finite() {
                return Err(TrackError::NonFinite {
                    what: "density",
                    value: v,
                });
            }
            if v < 0.0 {
                return Err(TrackError::NegativeWeight(v));
            }
            s += v;
        }
        if s <= 0.0 {
            return Err(TrackError::InvalidParameter {
                name: "density",
                value: s,
                reason: "must have positive mass",
            });
        }
        if self.is_stationary() {
            let ny = self.model.space().axis_len(1);
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
            self.win.start(Patch {
                i0: a0,
                j0: b0,
                h: a1 - a0,
                w: b1 - b0,
                v,
            });
            self.history = History::default();
            return Ok(());
        }
        self.post = density.iter().map(|v| v / s).collect();
        self.prev = self.post.clone();
        self.update_marginals();
        self.marg_prev = self.marg.clone();
        self.history = History::default();
        self.time = 0;
        Ok(())
    }

    /// The prior `q_k⁻` of the next step (prediction and lost-track mixing), without
    /// changing the tracker.
    pub fn predict(&self) -> Vec<f64> {
        if let SystemModel::Stationary(sys) = &self.model.sys {
            return self
                .win
                .clone()
                .dense_prior(self.model.space(), self.model.config(), sys);
        }
        let mut prior = Vec::new();
        let mut axis = Vec::new();
        self.predict_into(&mut prior, &mut axis);
        prior
    }

    fn predict_into(&self, prior: &mut Vec<f64>, axis: &mut Vec<Vec<f64>>) {
        let space = self.model.space();
        let cfg = *self.model.config();
        let g = space.cells();
        prior.resize(g, 0.0);
        match &self.model.sys {
            SystemModel::Separable {
                first,
                second,
                phased,
            } => {
                axis.resize(space.dims(), Vec::new());
                let phase = cfg.input.map(|i| i.weights(self.time + 1));
                for (d, p) in axis.iter_mut().enumerate() {
                    p.resize(space.axis_len(d), 0.0);
                    match (cfg.order, second, &phase) {
                        (Order::Second, Some(s), _) => {
                            s[d].predict(&self.marg[d], &self.marg_prev[d], cfg.prune, p)
                        }
                        (_, _, Some(phase)) => {
                            // S(φ_k) q = Σ_p β_p(φ_k) S_p q (module `input`).
                            let mut one = vec![0.0; p.len()];
                            p.iter_mut().for_each(|v| *v = 0.0);
                            for &(c, w) in phase {
                                phased[c][d].predict(&self.marg[d], cfg.prune, &mut one);
                                for (o, v) in p.iter_mut().zip(&one) {
                                    *o += w * v;
                                }
                            }
                        }
                        _ => first[d].predict(&self.marg[d], cfg.prune, p),
                    }
                }
                if space.dims() == 1 {
                    prior.copy_from_slice(&axis[0]);
                } else {
                    let ny = axis[1].len();
                    for (i, &a) in axis[0].iter().enumerate() {
                        for (dst, &b) in prior[i * ny..(i + 1) * ny].iter_mut().zip(&axis[1]) {
                            *dst = a * b;
                        }
                    }
                }
            }
            SystemModel::Joint(s) => match cfg.order {
                Order::Second => s.predict2(space, &self.post, &self.prev, &cfg, prior),
                Order::First => s.predict1(space, &self.post, &cfg, prior),
            },
            SystemModel::Stationary(sys) => {
                // Held on a window: the dense prior of its next step (normalised).
                *prior = self.win.clone().dense_prior(space, &cfg, sys);
                return;
            }
        }
        let total: f64 = prior.iter().sum();
        let gamma = cfg.mixing;
        let scale = if total > 0.0 {
            (1.0 - gamma) / total
        } else {
            0.0
        };
        let u = if total > 0.0 {
            gamma / g as f64
        } else {
            1.0 / g as f64
        };
        prior.iter_mut().for_each(|v| *v = *v * scale + u);
    }

    /// The likelihood `ℓ[g] = Σ_i w_i · p(z_i | x̃_g)` of an encoded detection set.
    fn likelihood(&mut self, z: &Encoded, dets: &[Detection]) -> Result<(), TrackError> {
        let space = self.model.space();
        let cfg = *self.model.config();
        let g = space.cells();
        let s = &mut self.scratch;
        s.lik.clear();
        s.lik.resize(g, 0.0);
        match &self.model.obs {
            ObservationModel::Separable(axes) => {
                // Clutter::Uniform: (1 − π)·Π_d O'_d + π·Π_d (Σ_m b_m / N_z,d) per detection.
                let (keep, uniform) = if cfg.clutter == Clutter::Uniform {
                    let pi = axes[0].clutter_share();
                    let mut u = pi;
                    for d in 0..space.dims() {
                        u /= space.meas_len(d) as f64;
                    }
                    (1.0 - pi, u)
                } else {
                    (1.0, 0.0)
                };
                s.axis_lik.resize(space.dims(), Vec::new());
                let mut per: [Vec<(usize, f64)>; 2] = [Vec::new(), Vec::new()];
                let mut umass = 0.0;
                for det in dets {
                    if det.weight == 0.0 {
                        continue;
                    }
                    let t = space.detection_index(det)?;
                    let mut mass = det.weight * uniform;
                    for d in 0..space.dims() {
                        per[d].clear();
                        space
                            .meas_basis(d)
                            .for_each_active(t[d], |k, v| per[d].push((k, v)));
                        mass *= per[d].iter().map(|e| e.1).sum::<f64>();
                        if d + 1 == space.dims() {
                            umass += mass;
                        }
                        s.axis_lik[d].resize(space.axis_len(d), 0.0);
                        axes[d].likelihood(&per[d], &mut s.axis_lik[d]);
                    }
                    let w = det.weight * keep;
                    if space.dims() == 1 {
                        for (l, a) in s.lik.iter_mut().zip(&s.axis_lik[0]) {
                            *l += w * a;
                        }
                    } else {
                        let ny = space.axis_len(1);
                        let (lx, ly) = (&s.axis_lik[0], &s.axis_lik[1]);
                        for (i, &a) in lx.iter().enumerate() {
                            let wa = w * a;
                            for (l, &b) in s.lik[i * ny..(i + 1) * ny].iter_mut().zip(ly) {
                                *l += wa * b;
                            }
                        }
                    }
                }
                if umass > 0.0 {
                    s.lik.iter_mut().for_each(|l| *l += umass);
                }
            }
            ObservationModel::Stationary(_) => {
                // `filter` updates the stationary layout in its window; a model whose system
                // layout differs is rejected when it is built or read.
                return Err(TrackError::Mismatch(
                    "the stationary observation model needs the stationary system model".into(),
                ));
            }
            ObservationModel::Joint(o) => {
                // `z.joint` holds every detection's weighted joint encoding; the likelihood
                // is linear in it, so one pass gives the mixture.
                o.add_likelihood(&z.joint, &cfg, &mut s.lik);
                if cfg.clutter == Clutter::Uniform {
                    let pi = o.clutter_share();
                    let total: f64 = z.joint.iter().map(|e| e.1).sum();
                    let u = pi * total / o.meas_cells() as f64;
                    s.lik.iter_mut().for_each(|l| *l = (1.0 - pi) * *l + u);
                }
            }
        }
        Ok(())
    }

    /// The update's likelihood `ℓ[g]` of a detection set over the joint grid (dense layouts),
    /// `None` for an empty set; the detections are validated first (an error changes nothing
    /// but the work buffer).
    pub(crate) fn grid_likelihood(
        &mut self,
        detections: &[Detection],
    ) -> Result<Option<&[f64]>, TrackError> {
        let joint = self.model.config().layout == Layout::SparseJoint;
        let z = encode_detections(self.model.space(), detections, 1.0, joint)?;
        if z.is_empty() {
            return Ok(None);
        }
        self.likelihood(&z, detections)?;
        Ok(Some(&self.scratch.lik))
    }

    /// The likelihood the last [`grid_likelihood`](Self::grid_likelihood) computed.
    pub(crate) fn last_likelihood(&self) -> &[f64] {
        &self.scratch.lik
    }

    /// Prediction and update with `detections`; on error (non-finite or off-grid
    /// detection) the tracker is unchanged.
    pub fn filter(&mut self, detections: &[Detection]) -> Result<(), TrackError> {
        if let (ObservationModel::Stationary(obs), SystemModel::Stationary(sys)) =
            (&self.model.obs, &self.model.sys)
        {
            return self.win.step(
                self.model.space(),
                self.model.config(),
                obs,
                sys,
                detections,
            );
        }
        let joint = self.model.config().layout == Layout::SparseJoint;
        // Validate (and, for the joint layout, encode) everything before changing state.
        let z = encode_detections(self.model.space(), detections, 1.0, joint)?;
        if !z.is_empty() {
            self.likelihood(&z, detections)?;
        }
        let mut prior = std::mem::take(&mut self.scratch.prior);
        let mut axis = std::mem::take(&mut self.scratch.axis);
        self.predict_into(&mut prior, &mut axis);
        self.scratch.axis = axis;
        let mut new_post = std::mem::take(&mut self.prev);
        new_post.clear();
        let mut updated = false;
        if !z.is_empty() {
            new_post.extend(self.scratch.lik.iter().zip(&prior).map(|(l, p)| l * p));
            let s: f64 = new_post.iter().sum();
            if s > 0.0 && s.is_finite() {
                new_post.iter_mut().for_each(|v| *v /= s);
                updated = true;
            } else {
                new_post.clear();
            }
        }
        if !updated {
            new_post.extend_from_slice(&prior);
        }
        self.scratch.prior = prior;
        if self.model.config().input.is_some() {
            self.time += 1;
        }
        self.prev = std::mem::replace(&mut self.post, new_post);
        std::mem::swap(&mut self.marg, &mut self.marg_prev);
        self.update_marginals();
        Ok(())
    }

    fn update_marginals(&mut self) {
        let space = self.model.space();
        let dims = space.dims();
        self.marg.resize(dims, Vec::new());
        if dims == 1 {
            self.marg[0].clear();
            self.marg[0].extend_from_slice(&self.post);
            return;
        }
        let (nx, ny) = (space.axis_len(0), space.axis_len(1));
        let (mx, my) = self.marg.split_at_mut(1);
        let (mx, my) = (&mut mx[0], &mut my[0]);
        mx.clear();
        mx.resize(nx, 0.0);
        my.clear();
        my.resize(ny, 0.0);
        for (i, row) in self.post.chunks_exact(ny).enumerate() {
            let mut s = 0.0;
            for (j, &v) in row.iter().enumerate() {
                s += v;
                my[j] += v;
            }
            mx[i] = s;
        }
    }

    /// Incremental learning (the thesis's future work): adds one frame's soft counts, with
    /// weight [`online_weight`](crate::CbtConfig::online_weight), to both models and
    /// renormalises the columns it touched. Consecutive calls chain into transitions.
    pub fn learn_online(
        &mut self,
        states: &[Point],
        detections: &[Detection],
    ) -> Result<(), TrackError> {
        let w = self.model.config().online_weight;
        let mut h = std::mem::take(&mut self.history);
        let r = self
            .model
            .add_frame(&mut h, states, detections, w, true, self.time);
        self.history = h;
        r
    }

    /// Decodes the posterior: best mode, its certainty, and runner-ups.
    pub fn decode(&self) -> Estimate {
        let space = self.model.space();
        if self.is_stationary() {
            let cfg = self.model.config();
            return self.win.decode(space, cfg.decode_radius, cfg.runner_ups);
        }
        let modes =
            crate::dense::decode_posterior(space, &self.post, self.model.config().runner_ups + 1);
        let to_point = |v: &[f64]| -> Point {
            let mut p = [0.0; 2];
            p[..v.len()].copy_from_slice(v);
            p
        };
        match modes.split_first() {
            Some((best, rest)) => Estimate {
                position: to_point(&best.value),
                certainty: Some(best.certainty),
                runner_ups: rest
                    .iter()
                    .take(self.model.config().runner_ups)
                    .map(|m| Hypothesis {
                        position: to_point(&m.value),
                        certainty: m.certainty,
                    })
                    .collect(),
            },
            None => {
                // No window with a valid estimate (e.g. a flat posterior): the best cell.
                let (g, &v) = self
                    .post
                    .iter()
                    .enumerate()
                    .max_by(|a, b| a.1.total_cmp(b.1))
                    .unwrap_or((0, &0.0));
                Estimate {
                    position: space.cell_centre(g),
                    certainty: Some(v),
                    runner_ups: Vec::new(),
                }
            }
        }
    }
}

impl Tracker for CbtTracker {
    fn name(&self) -> String {
        self.name.clone()
    }

    /// Starts from the channel encoding of `start` (a sharp, zero-velocity prior).
    fn reset(&mut self, start: Point) -> Result<(), TrackError> {
        let space = self.model.space();
        space.state_index(&start)?;
        if self.is_stationary() {
            self.win.start(point_patch(space, start));
            self.history = History::default();
            return Ok(());
        }
        let dims = space.dims();
        let c = space.grid().encode(&start[..dims])?;
        self.reset_to(&c)
    }

    fn step(&mut self, detections: &[Detection]) -> Result<Estimate, TrackError> {
        self.filter(detections)?;
        let e = self.decode();
        if self.self_learning {
            // The estimate is on the grid by construction; a failure here would only mean a
            // detection was rejected, which `filter` has already ruled out.
            let clamped = self.clamp_to_grid(e.position);
            self.learn_online(&[clamped], detections)?;
        }
        Ok(e)
    }

    fn estimate(&self) -> Estimate {
        self.decode()
    }
}

impl CbtTracker {
    fn clamp_to_grid(&self, p: Point) -> Point {
        let space = self.model.space();
        let mut q = p;
        for (d, v) in q.iter_mut().enumerate().take(space.dims()) {
            let (lo, hi) = space.state_basis(d).representable_range();
            *v = v.clamp(lo, hi);
        }
        q
    }
}

/// The channel encoding of a (validated, on-grid) point as a window patch.
fn point_patch(space: &crate::Space, p: Point) -> Patch {
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
