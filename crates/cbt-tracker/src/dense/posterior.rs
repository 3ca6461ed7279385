//! The posterior of the dense layouts ([`Layout::Separable`](crate::Layout),
//! [`Layout::SparseJoint`](crate::Layout)) over every cell of the joint grid, and one step
//! of the filter on it (the numbered steps of [`CbtTracker`](crate::CbtTracker)).

use crate::config::{Clutter, Layout, Order};
use crate::encode::{Encoded, encode_detections};
use crate::integrity::{corrupt, len, nonneg, unit_mass};
use crate::model::{ObservationModel, SystemModel};
use crate::tracker::{Estimate, Hypothesis};
use crate::{CbtModel, Detection, Point, Space, TrackError};

use super::decode_posterior;

/// `q_k⁺` and `q_{k−1}⁺` over the joint grid, their per-axis marginals, and the step's work
/// buffers.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct DensePosterior {
    /// `q_k⁺` (joint).
    pub post: Vec<f64>,
    /// `q_{k−1}⁺` (joint; used by the joint second-order layout).
    pub prev: Vec<f64>,
    /// Per-axis marginals of `q_k⁺` and `q_{k−1}⁺`.
    pub marg: Vec<Vec<f64>>,
    pub marg_prev: Vec<Vec<f64>>,
    scratch: Scratch,
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

/// The uniform per-axis marginals of `space` (what a tracker starts from; the stationary
/// layout, which has no use for them, saves these).
pub(crate) fn uniform_marginals(space: &Space) -> Vec<Vec<f64>> {
    (0..space.dims())
        .map(|d| vec![1.0 / space.axis_len(d) as f64; space.axis_len(d)])
        .collect()
}

impl DensePosterior {
    /// The uniform posterior over the grid of `space`.
    pub fn uniform(space: &Space) -> Self {
        let g = space.cells();
        let marg = uniform_marginals(space);
        DensePosterior {
            post: vec![1.0 / g as f64; g],
            prev: vec![1.0 / g as f64; g],
            marg_prev: marg.clone(),
            marg,
            scratch: Scratch::default(),
        }
    }

    /// A posterior as read from a file, checked against `space`.
    pub fn restore(
        space: &Space,
        post: Vec<f64>,
        prev: Vec<f64>,
        marg: Vec<Vec<f64>>,
        marg_prev: Vec<Vec<f64>>,
    ) -> Result<Self, TrackError> {
        for (what, v) in [("posterior", &post), ("previous posterior", &prev)] {
            len(what, v.len(), space.cells())?;
            nonneg(what, v)?;
            unit_mass(what, v)?;
        }
        check_marginals(space, &marg, &marg_prev)?;
        // The separable prediction reads the marginals, the estimate the posterior: they must
        // agree (as `update_marginals` leaves them; the uniform start's `1/N` differs from the
        // summed marginal by rounding only).
        for (what, m, q) in [
            ("marginals", &marg, &post),
            ("previous marginals", &marg_prev, &prev),
        ] {
            let want = marginals_of(space, q);
            let off = m
                .iter()
                .flatten()
                .zip(want.iter().flatten())
                .any(|(a, b)| (a - b).abs() > 1e-9);
            if off {
                return Err(corrupt(format!(
                    "the saved {what} are not the marginals of the saved posterior"
                )));
            }
        }
        Ok(DensePosterior {
            post,
            prev,
            marg,
            marg_prev,
            scratch: Scratch::default(),
        })
    }

    /// Starts from `density` (validated by the caller) divided by its mass `s`; both
    /// previous posteriors are set to it.
    pub fn start(&mut self, space: &Space, density: &[f64], s: f64) {
        self.post = density.iter().map(|v| v / s).collect();
        self.prev = self.post.clone();
        self.update_marginals(space);
        self.marg_prev = self.marg.clone();
    }

    /// The prior `q_k⁻` of the next step (step 1: prediction and lost-track mixing) at time
    /// index `time`, without changing the posterior.
    pub fn predict(&self, model: &CbtModel, time: u64) -> Vec<f64> {
        let mut prior = Vec::new();
        let mut axis = Vec::new();
        self.predict_into(model, time, &mut prior, &mut axis);
        prior
    }

    fn predict_into(
        &self,
        model: &CbtModel,
        time: u64,
        prior: &mut Vec<f64>,
        axis: &mut Vec<Vec<f64>>,
    ) {
        let space = model.space();
        let cfg = *model.config();
        let g = space.cells();
        prior.resize(g, 0.0);
        match &model.sys {
            SystemModel::Separable {
                first,
                second,
                phased,
            } => {
                axis.resize(space.dims(), Vec::new());
                // `time < u64::MAX`: `CbtTracker` keeps it there (`set_time`, `filter`, and
                // its deserialiser refuse the last index).
                let phase = cfg.input.map(|i| i.weights(time + 1));
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
            SystemModel::Stationary(_) => {
                unreachable!("a dense posterior belongs to a model of a dense layout")
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

    /// The likelihood `ℓ[g] = Σ_i w_i · p(z_i | x̃_g)` of an encoded detection set (step 2),
    /// into the work buffer.
    fn likelihood(
        &mut self,
        model: &CbtModel,
        z: &Encoded,
        dets: &[Detection],
    ) -> Result<(), TrackError> {
        let space = model.space();
        let cfg = *model.config();
        let g = space.cells();
        let s = &mut self.scratch;
        s.lik.clear();
        s.lik.resize(g, 0.0);
        match &model.obs {
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
                // The stationary layout is filtered in its window (module `stationary`); a
                // model whose system layout differs is rejected when it is built or read.
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

    /// The update's likelihood `ℓ[g]` of a detection set over the joint grid, `None` for an
    /// empty set; the detections are validated first (an error changes nothing but the work
    /// buffer).
    pub fn grid_likelihood(
        &mut self,
        model: &CbtModel,
        detections: &[Detection],
    ) -> Result<Option<&[f64]>, TrackError> {
        let joint = model.config().layout == Layout::SparseJoint;
        let z = encode_detections(model.space(), detections, 1.0, joint)?;
        if z.is_empty() {
            return Ok(None);
        }
        self.likelihood(model, &z, detections)?;
        Ok(Some(&self.scratch.lik))
    }

    /// The likelihood the last [`grid_likelihood`](Self::grid_likelihood) computed.
    pub fn last_likelihood(&self) -> &[f64] {
        &self.scratch.lik
    }

    /// Prediction and update with `detections` at time index `time` (the caller advances
    /// it); on error (non-finite or off-grid detection) the posterior is unchanged.
    pub fn step(
        &mut self,
        model: &CbtModel,
        time: u64,
        detections: &[Detection],
    ) -> Result<(), TrackError> {
        let joint = model.config().layout == Layout::SparseJoint;
        // Validate (and, for the joint layout, encode) everything before changing state.
        let z = encode_detections(model.space(), detections, 1.0, joint)?;
        if !z.is_empty() {
            self.likelihood(model, &z, detections)?;
        }
        let mut prior = std::mem::take(&mut self.scratch.prior);
        let mut axis = std::mem::take(&mut self.scratch.axis);
        self.predict_into(model, time, &mut prior, &mut axis);
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
        self.prev = std::mem::replace(&mut self.post, new_post);
        std::mem::swap(&mut self.marg, &mut self.marg_prev);
        self.update_marginals(model.space());
        Ok(())
    }

    fn update_marginals(&mut self, space: &Space) {
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

    /// Decodes the posterior (step 3): best mode, its certainty, and up to `runner_ups`
    /// runner-ups.
    pub fn decode(&self, space: &Space, runner_ups: usize) -> Estimate {
        let modes = decode_posterior(space, &self.post, runner_ups + 1);
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
                    .take(runner_ups)
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

/// The per-axis marginals of a joint density `q` over the grid of `space` (of the right
/// length), for checking saved ones.
fn marginals_of(space: &Space, q: &[f64]) -> Vec<Vec<f64>> {
    if space.dims() == 1 {
        return vec![q.to_vec()];
    }
    let (nx, ny) = (space.axis_len(0), space.axis_len(1));
    let (mut mx, mut my) = (vec![0.0; nx], vec![0.0; ny]);
    for (i, row) in q.chunks_exact(ny).enumerate() {
        for (j, &v) in row.iter().enumerate() {
            mx[i] += v;
            my[j] += v;
        }
    }
    vec![mx, my]
}

/// The saved marginals' sizes against `space`, their values non-negative (checked for
/// every layout: the stationary layout saves the uniform ones).
pub(crate) fn check_marginals(
    space: &Space,
    marg: &[Vec<f64>],
    marg_prev: &[Vec<f64>],
) -> Result<(), TrackError> {
    for (what, m) in [("marginals", marg), ("previous marginals", marg_prev)] {
        len(what, m.len(), space.dims())?;
        for (d, v) in m.iter().enumerate() {
            len(what, v.len(), space.axis_len(d))?;
            nonneg(what, v)?;
        }
    }
    Ok(())
}
