//! The Channel Based Tracking filter (docs/methods.md § Tracking): grid-based Bayesian
//! filtering (eq. 3.3, 3.4) on channel-coded densities with learned models.

use serde::{Deserialize, Serialize};

use crate::config::{Layout, Order};
use crate::dense::{DensePosterior, check_marginals, uniform_marginals};
use crate::history::{self, History};
use crate::model::{ObservationModel, SystemModel};
use crate::stationary::{Patch, StatObservation, StatSystem, WindowState};
use crate::tracker::{Estimate, Tracker};
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
/// The stationary layout runs the same steps on the window of the posterior's support
/// (module `stationary`, its own numbered steps).
///
/// A tracker read back with serde is validated: its model as [`CbtModel`] is, and its
/// posterior's sizes against the model's space, its values finite and non-negative, the
/// states of its online-learning history on the grid ([`TrackError::Corrupt`] otherwise).
/// Work buffers are neither saved nor compared: a loaded tracker equals its original.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(try_from = "CbtTrackerRaw")]
pub struct CbtTracker {
    model: CbtModel,
    name: String,
    /// The posterior, held as the model's layout needs it.
    state: LayoutState,
    /// Learn from every step's own estimate.
    self_learning: bool,
    /// The last two frames of [`learn_online`](Self::learn_online) (saved as their states).
    history: History,
    /// Time index of the posterior (a [`crate::PeriodicInput`]'s `k`; stays 0 without one).
    /// Always below `u64::MAX`, so that the next prediction's `time + 1` exists
    /// ([`set_time`](Self::set_time), [`filter`](Self::filter) and the deserialiser refuse
    /// it).
    time: u64,
}

/// The per-layout state of a [`CbtTracker`]: which one follows from the model's layout.
#[derive(Debug, Clone, PartialEq)]
enum LayoutState {
    /// [`Layout::Separable`] and [`Layout::SparseJoint`]: the posterior over every cell.
    Dense(DensePosterior),
    /// [`Layout::Stationary`]: the posterior on the window of its support.
    Stationary(Box<WindowState>),
}

/// A [`CbtTracker`] as saved: every layout's fields side by side (the form files have
/// always had; the layout that does not use a field saves its starting value: the
/// stationary layout empty posteriors and uniform marginals, the dense ones an empty window).
#[derive(Serialize)]
struct CbtTrackerSaved<'a> {
    model: &'a CbtModel,
    name: &'a str,
    post: &'a [f64],
    prev: &'a [f64],
    marg: &'a [Vec<f64>],
    marg_prev: &'a [Vec<f64>],
    self_learning: bool,
    win: &'a WindowState,
    history: &'a history::Saved,
    #[serde(skip_serializing_if = "is_zero")]
    time: u64,
}

fn is_zero(v: &u64) -> bool {
    *v == 0
}

impl Serialize for CbtTracker {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let (empty_win, uniform);
        let (post, prev, marg, marg_prev, win) = match &self.state {
            LayoutState::Dense(d) => {
                empty_win = WindowState::default();
                (
                    &d.post[..],
                    &d.prev[..],
                    &d.marg[..],
                    &d.marg_prev[..],
                    &empty_win,
                )
            }
            LayoutState::Stationary(w) => {
                uniform = uniform_marginals(self.model.space());
                (&[][..], &[][..], &uniform[..], &uniform[..], &**w)
            }
        };
        CbtTrackerSaved {
            model: &self.model,
            name: &self.name,
            post,
            prev,
            marg,
            marg_prev,
            self_learning: self.self_learning,
            win,
            history: self.history.saved(),
            time: self.time,
        }
        .serialize(s)
    }
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
        let space = raw.model.space();
        let cfg = raw.model.config();
        if raw.time == u64::MAX {
            return Err(crate::integrity::corrupt(
                "time index u64::MAX: the next step has no time index to predict into",
            ));
        }
        let history = History::restore(
            raw.history,
            space,
            cfg.online_weight,
            cfg.layout == Layout::SparseJoint,
        )?;
        let state = if cfg.layout == Layout::Stationary {
            let mut win = raw.win;
            let (_, sys) = stationary_models(&raw.model)?;
            win.check(space, sys)?;
            check_marginals(space, &raw.marg, &raw.marg_prev)?;
            LayoutState::Stationary(Box::new(win))
        } else {
            LayoutState::Dense(DensePosterior::restore(
                space,
                raw.post,
                raw.prev,
                raw.marg,
                raw.marg_prev,
            )?)
        };
        Ok(CbtTracker {
            model: raw.model,
            name: raw.name,
            state,
            self_learning: raw.self_learning,
            history,
            time: raw.time,
        })
    }
}

/// The stationary models (present exactly when the layout is stationary: a model whose
/// observation and system layouts differ from its configuration is rejected when it is
/// built or read).
fn stationary_models(model: &CbtModel) -> Result<(&StatObservation, &[StatSystem]), TrackError> {
    match (&model.obs, &model.sys) {
        (ObservationModel::Stationary(obs), SystemModel::Stationary(sys)) => Ok((obs, sys)),
        _ => Err(TrackError::Mismatch(
            "the stationary layout needs the stationary models".into(),
        )),
    }
}

impl CbtTracker {
    /// A tracker with the given model, not yet placed: the dense layouts start from the
    /// uniform posterior over the grid, the stationary layout at the centre of the grid.
    /// [`reset`](Tracker::reset) or [`reset_to`](Self::reset_to) places the track.
    pub fn new(model: CbtModel) -> Self {
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
        let state = if model.config().layout == Layout::Stationary {
            // Started at the centre of the grid (a sharp prior; `reset` places it).
            let c: Vec<f64> = (0..2)
                .map(|d| {
                    let (lo, hi) = model.space().state_basis(d).representable_range();
                    0.5 * (lo + hi)
                })
                .collect();
            let mut win = WindowState::default();
            win.start(Patch::at_point(model.space(), [c[0], c[1]]));
            LayoutState::Stationary(Box::new(win))
        } else {
            LayoutState::Dense(DensePosterior::uniform(model.space()))
        };
        CbtTracker {
            name,
            state,
            model,
            self_learning: false,
            history: History::default(),
            time: 0,
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
        match &self.state {
            LayoutState::Dense(d) => &d.post,
            LayoutState::Stationary(w) => &w.post.v,
        }
    }

    /// The stationary layout's window: first cell `(i0, j0)` and size `(rows, cols)` of the
    /// rectangle [`posterior`](Self::posterior) covers (row-major, rows along axis 0); outside
    /// it the posterior is below `support × max` and taken as 0. `None` for other layouts.
    pub fn posterior_window(&self) -> Option<([usize; 2], [usize; 2])> {
        match &self.state {
            LayoutState::Dense(_) => None,
            LayoutState::Stationary(w) => {
                let p = &w.post;
                Some(([p.i0, p.j0], [p.h, p.w]))
            }
        }
    }

    /// The time index of the posterior: 0 after a reset, one more after each step (only
    /// counted when the model has a [`crate::PeriodicInput`]; 0 otherwise).
    pub fn time(&self) -> u64 {
        self.time
    }

    /// Sets the time index of the posterior (a track that starts at frame `k` of a
    /// sequence whose input phase is `ω·k`); the next step predicts into `k + 1`. No effect
    /// on a model without a [`crate::PeriodicInput`].
    ///
    /// Errors ([`TrackError::InvalidParameter`] `time`, the tracker unchanged): `k = u64::MAX`,
    /// which has no next index to predict into.
    pub fn set_time(&mut self, k: u64) -> Result<(), TrackError> {
        if k == u64::MAX {
            return Err(last_time_index(k));
        }
        if self.model.config().input.is_some() {
            self.time = k;
        }
        Ok(())
    }

    /// Starts from a given joint density (normalised here; must be non-negative, finite, of
    /// length `G`, with a positive mass that is finite too); both previous posteriors are set
    /// to it.
    pub fn reset_to(&mut self, density: &[f64]) -> Result<(), TrackError> {
        let space = self.model.space();
        let g = space.cells();
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
        // A sum of finite values can still overflow: dividing by ∞ left a posterior of zeros.
        if !(s > 0.0 && s.is_finite()) {
            return Err(TrackError::InvalidParameter {
                name: "density",
                value: s,
                reason: "must have a positive, finite mass",
            });
        }
        self.history = History::default();
        match &mut self.state {
            LayoutState::Dense(d) => {
                d.start(space, density, s);
                self.time = 0;
            }
            LayoutState::Stationary(w) => w.start(Patch::support_of(density, space.axis_len(1))),
        }
        Ok(())
    }

    /// The prior `q_k⁻` of the next step (prediction and lost-track mixing), without
    /// changing the tracker.
    pub fn predict(&self) -> Vec<f64> {
        match &self.state {
            LayoutState::Dense(d) => d.predict(&self.model, self.time),
            LayoutState::Stationary(w) => match stationary_models(&self.model) {
                Ok((_, sys)) => w
                    .clone()
                    .dense_prior(self.model.space(), self.model.config(), sys),
                Err(_) => unreachable!("a stationary tracker's model has the stationary models"),
            },
        }
    }

    /// The update's likelihood `ℓ[g]` of a detection set over the joint grid (dense layouts),
    /// `None` for an empty set; the detections are validated first (an error changes nothing
    /// but the work buffer).
    pub(crate) fn grid_likelihood(
        &mut self,
        detections: &[Detection],
    ) -> Result<Option<&[f64]>, TrackError> {
        match &mut self.state {
            LayoutState::Dense(d) => d.grid_likelihood(&self.model, detections),
            LayoutState::Stationary(_) => Err(TrackError::Mismatch(
                "the grid likelihood is the dense layouts'".into(),
            )),
        }
    }

    /// The likelihood the last [`grid_likelihood`](Self::grid_likelihood) computed (empty
    /// for the stationary layout).
    pub(crate) fn last_likelihood(&self) -> &[f64] {
        match &self.state {
            LayoutState::Dense(d) => d.last_likelihood(),
            LayoutState::Stationary(_) => &[],
        }
    }

    /// Prediction and update with `detections`; on error (non-finite or off-grid
    /// detection, or with a [`crate::PeriodicInput`] a step into the time index `u64::MAX`,
    /// [`TrackError::InvalidParameter`] `time`) the tracker is unchanged.
    pub fn filter(&mut self, detections: &[Detection]) -> Result<(), TrackError> {
        let model = &self.model;
        match &mut self.state {
            LayoutState::Dense(d) => {
                let time = if model.config().input.is_some() {
                    // The index after this step must have a successor of its own.
                    match self.time.checked_add(1) {
                        Some(next) if next < u64::MAX => next,
                        _ => return Err(last_time_index(self.time)),
                    }
                } else {
                    self.time
                };
                d.step(model, self.time, detections)?;
                self.time = time;
                Ok(())
            }
            LayoutState::Stationary(w) => {
                let (obs, sys) = stationary_models(model)?;
                w.step(model.space(), model.config(), obs, sys, detections)
            }
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
        let cfg = self.model.config();
        match &self.state {
            LayoutState::Dense(d) => d.decode(space, cfg.runner_ups),
            LayoutState::Stationary(w) => w.decode(space, cfg.decode_radius, cfg.runner_ups),
        }
    }
}

/// The refusal of a time index without a successor.
fn last_time_index(k: u64) -> TrackError {
    TrackError::InvalidParameter {
        name: "time",
        value: k as f64,
        reason: "the time index must stay below u64::MAX (the next step predicts into k + 1)",
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
        match &mut self.state {
            LayoutState::Dense(_) => {
                let c = space.grid().encode(&start[..space.dims()])?;
                self.reset_to(&c)
            }
            LayoutState::Stationary(w) => {
                w.start(Patch::at_point(space, start));
                self.history = History::default();
                Ok(())
            }
        }
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
