//! Learned CBT models: the observation model and the system model of one tracking space,
//! learned in batch ([`CbtModel::learn`]) or frame by frame (online).

use serde::{Deserialize, Serialize};

use crate::config::{CbtConfig, Displacements, Layout, Order, SystemFallback};
use crate::dense::{AxisObservation, AxisSystem1, AxisSystem2, JointObservation, JointSystem};
use crate::displacement_choice;
use crate::encode::{encode_detections, encode_states};
use crate::history::History;
use crate::integrity::{corrupt, len};
use crate::observation_smoothing::{
    ObservationChoice, ObservationGrid, ObservationSmoothing, select_observation,
};
use crate::smoothing::{Smoothing, SmoothingGrid, select};
use crate::stationary::{StatObservation, StatSystem, check_space, fitted_slopes, motion_radius};
use crate::{Sequence, Space, TrackError, TrainingFrame};

/// The observation model in one of the two layouts.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) enum ObservationModel {
    Separable(Vec<AxisObservation>),
    Joint(JointObservation),
    Stationary(StatObservation),
}

/// The system model in one of the two layouts (first order always learned: it is the
/// first-order tracker's model and the second order's optional fallback).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) enum SystemModel {
    Separable {
        first: Vec<AxisSystem1>,
        second: Option<Vec<AxisSystem2>>,
        /// With a [`crate::PeriodicInput`]: the first-order model per phase channel `p`
        /// (`phased[p][d]`, module `input`); empty without.
        #[serde(default, skip_serializing_if = "Vec::is_empty")]
        phased: Vec<Vec<AxisSystem1>>,
    },
    Joint(JointSystem),
    Stationary(Vec<StatSystem>),
}

/// What learning has counted, for reporting.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct LearnStats {
    /// Frames with at least one state and one detection (observation-model samples).
    pub observation_frames: usize,
    /// Consecutive-frame pairs with states (first-order samples).
    pub transitions: usize,
    /// Consecutive-frame triples with states (second-order samples).
    pub triples: usize,
}

/// The two learned models of Channel Based Tracking on one [`Space`].
///
/// ```
/// use cbt_tracker::{CbtConfig, CbtModel, Detection, Space, TrainingFrame};
/// let space = Space::image(100.0, 100.0, 10.0).unwrap();
/// // A target moving right by 2 px per frame, detected exactly, no clutter.
/// let frames: Vec<TrainingFrame> = (0..30)
///     .map(|k| {
///         let p = [20.0 + 2.0 * k as f64, 50.0];
///         TrainingFrame { states: vec![p], detections: vec![Detection::new(p[0], p[1])] }
///     })
///     .collect();
/// let model = CbtModel::learn(space, CbtConfig::default(), &[frames]).unwrap();
/// assert_eq!(model.stats().triples, 28);
/// ```
///
/// A model read back with serde is validated as a whole (its configuration, that both models
/// have the configured layout, every size against the space, every value finite and
/// non-negative): a corrupted or hand-edited file is a [`TrackError::Corrupt`] (or the
/// configuration's [`TrackError::InvalidParameter`]) in the deserialiser's error, never a
/// panic later in the filter.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "CbtModelRaw")]
pub struct CbtModel {
    space: Space,
    config: CbtConfig,
    pub(crate) obs: ObservationModel,
    pub(crate) sys: SystemModel,
    stats: LearnStats,
}

/// A [`CbtModel`] as read, before its consistency check.
#[derive(Deserialize)]
struct CbtModelRaw {
    space: Space,
    config: CbtConfig,
    obs: ObservationModel,
    sys: SystemModel,
    stats: LearnStats,
}

impl TryFrom<CbtModelRaw> for CbtModel {
    type Error = TrackError;

    fn try_from(raw: CbtModelRaw) -> Result<Self, TrackError> {
        let CbtModelRaw {
            space,
            config,
            mut obs,
            mut sys,
            stats,
        } = raw;
        config.validate()?;
        // What learning would refuse: the sparse joint layout rebuilds its fallback
        // Gaussians below (`prepare`), whose size follows the space and `fallback_sigma`.
        crate::footprint::check(&space, &config)?;
        let layout = |l: Layout| {
            corrupt(format!(
                "a {:?} model in a file configured for the {:?} layout",
                l, config.layout
            ))
        };
        let dims = space.dims();
        match &mut obs {
            ObservationModel::Separable(axes) if config.layout == Layout::Separable => {
                len("separable observation axes", axes.len(), dims)?;
                for (d, o) in axes.iter().enumerate() {
                    o.check(&space, d)?;
                }
            }
            ObservationModel::Joint(o) if config.layout == Layout::SparseJoint => {
                o.check(&space)?
            }
            ObservationModel::Stationary(o) if config.layout == Layout::Stationary => {
                check_space(&space)?;
                o.check(&space)?;
            }
            ObservationModel::Separable(_) => return Err(layout(Layout::Separable)),
            ObservationModel::Joint(_) => return Err(layout(Layout::SparseJoint)),
            ObservationModel::Stationary(_) => return Err(layout(Layout::Stationary)),
        }
        let second_order = config.order == Order::Second;
        match &mut sys {
            SystemModel::Separable {
                first,
                second,
                phased,
            } if config.layout == Layout::Separable => {
                len("first-order axes", first.len(), dims)?;
                for (d, s) in first.iter().enumerate() {
                    s.check(space.axis_len(d))?;
                }
                len(
                    "phase channels of the system model",
                    phased.len(),
                    config.input.map_or(0, |i| i.channels),
                )?;
                for p in phased.iter() {
                    len("phase-channel first-order axes", p.len(), dims)?;
                    for (d, s) in p.iter().enumerate() {
                        s.check(space.axis_len(d))?;
                    }
                }
                match second {
                    Some(second) if second_order => {
                        len("second-order axes", second.len(), dims)?;
                        for (d, s) in second.iter().enumerate() {
                            s.check(space.axis_len(d))?;
                        }
                    }
                    None if !second_order => {}
                    _ => {
                        return Err(corrupt(
                            "the second-order tensors do not match the configured order",
                        ));
                    }
                }
            }
            SystemModel::Joint(s) if config.layout == Layout::SparseJoint => {
                s.check(&space, second_order)?;
                s.prepare(&space, &config);
            }
            SystemModel::Stationary(s) if config.layout == Layout::Stationary => {
                len("displacement model axes", s.len(), dims)?;
                s.iter_mut().try_for_each(|s| s.check(&config))?;
            }
            SystemModel::Separable { .. } => return Err(layout(Layout::Separable)),
            SystemModel::Joint(_) => return Err(layout(Layout::SparseJoint)),
            SystemModel::Stationary(_) => return Err(layout(Layout::Stationary)),
        }
        Ok(CbtModel {
            space,
            config,
            obs,
            sys,
            stats,
        })
    }
}

impl CbtModel {
    /// An untrained model: every column is its fallback prior.
    pub fn untrained(space: Space, config: CbtConfig) -> Result<Self, TrackError> {
        // Saturating: an infinite `fallback_sigma` (refused by the validation below) used to
        // overflow here.
        let r = crate::stationary::sigma_radius(config.fallback_sigma);
        CbtModel::untrained_with_radius(space, config, r)
    }

    /// [`CbtModel::untrained`] with the stationary layout's displacement radius `r`.
    fn untrained_with_radius(
        space: Space,
        config: CbtConfig,
        r: usize,
    ) -> Result<Self, TrackError> {
        config.validate()?;
        crate::footprint::check(&space, &config)?;
        let dims = space.dims();
        let (obs, sys) = match config.layout {
            Layout::Separable => {
                let obs = (0..dims)
                    .map(|d| AxisObservation::new(&space, d, &config))
                    .collect();
                let first: Vec<AxisSystem1> = (0..dims)
                    .map(|d| AxisSystem1::new(space.axis_len(d), &config))
                    .collect();
                let second = (config.order == Order::Second).then(|| {
                    (0..dims)
                        .map(|d| AxisSystem2::new(space.axis_len(d), &config, &first[d]))
                        .collect()
                });
                let phased = vec![first.clone(); config.input.map_or(0, |i| i.channels)];
                (
                    ObservationModel::Separable(obs),
                    SystemModel::Separable {
                        first,
                        second,
                        phased,
                    },
                )
            }
            Layout::Stationary => {
                check_space(&space)?;
                crate::footprint::check_kernels(r, dims, &config)?;
                (
                    ObservationModel::Stationary(StatObservation::new(&space, &config)),
                    SystemModel::Stationary(
                        (0..dims).map(|_| StatSystem::new(r, &config)).collect(),
                    ),
                )
            }
            Layout::SparseJoint => (
                ObservationModel::Joint(JointObservation::new(&space, &config)),
                SystemModel::Joint(JointSystem::new(
                    &space,
                    &config,
                    config.order == Order::Second,
                )),
            ),
        };
        Ok(CbtModel {
            space,
            config,
            obs,
            sys,
            stats: LearnStats::default(),
        })
    }

    /// Learns both models from training sequences, each a list of frames with unordered state
    /// and detection sets (docs/methods.md § Tracking). Every state and detection must lie on
    /// the grid; errors name the first that does not. With [`Smoothing::HeldOut`] the system
    /// model's `α` and `σ` are first chosen by held-out likelihood
    /// ([`crate::smoothing::select`]); the model's configuration holds the chosen values.
    /// Likewise with [`Displacements::Selected`] the counting is first chosen by held-out
    /// tracking ([`crate::displacement_choice::select`]) and recorded, and with
    /// [`Displacements::Fitted`] its slopes are fitted on `sequences` before counting.
    pub fn learn(
        space: Space,
        config: CbtConfig,
        sequences: &[Vec<TrainingFrame>],
    ) -> Result<Self, TrackError> {
        let mut config = config;
        // Before the selections below, which build models of this size too.
        crate::footprint::check(&space, &config)?;
        if config.displacements == Displacements::Selected {
            config.validate()?;
            config.displacements = displacement_choice::select(&space, &config, sequences)?.pick;
        }
        if config.smoothing == Smoothing::HeldOut {
            let pick = select(&space, &config, sequences, &SmoothingGrid::default())?;
            config.prior_weight = pick.prior_weight;
            config.fallback_sigma = pick.fallback_sigma;
        }
        let mut model = if config.layout == Layout::Stationary {
            config.validate()?;
            check_space(&space)?;
            let r = motion_radius(&space, sequences, &config);
            CbtModel::untrained_with_radius(space, config, r)?
        } else {
            CbtModel::untrained(space, config)?
        };
        if config.displacements == Displacements::Fitted
            && let SystemModel::Stationary(s) = &mut model.sys
        {
            let slopes = fitted_slopes(&model.space, sequences)?;
            for (s, b) in s.iter_mut().zip(slopes) {
                s.set_slope(b);
            }
        }
        if config.observation_smoothing == ObservationSmoothing::HeldOut {
            let pick = select_observation(
                &model.space,
                &config,
                sequences,
                &ObservationGrid::default(),
            )?;
            if let ObservationModel::Stationary(o) = &mut model.obs {
                o.set_choice(Some(pick.choice));
            }
        }
        for seq in sequences {
            let mut h = History::default();
            for (k, f) in seq.iter().enumerate() {
                model.add_frame(&mut h, &f.states, &f.detections, 1.0, false, k as u64)?;
            }
        }
        if model.stats.observation_frames == 0 {
            return Err(TrackError::EmptyTraining {
                reason: "no frame has both a state and a detection",
            });
        }
        let needed = match model.config.order {
            Order::First => model.stats.transitions,
            Order::Second => model.stats.triples,
        };
        if needed == 0 {
            return Err(TrackError::EmptyTraining {
                reason: "no run of consecutive frames with states long enough for the system model",
            });
        }
        model.normalise_all();
        Ok(model)
    }

    /// [`CbtModel::learn`] from [`Sequence`]s (the truth is each frame's state).
    pub fn learn_sequences(
        space: Space,
        config: CbtConfig,
        sequences: &[Sequence],
    ) -> Result<Self, TrackError> {
        let frames: Vec<Vec<TrainingFrame>> =
            sequences.iter().map(Sequence::training_frames).collect();
        CbtModel::learn(space, config, &frames)
    }

    /// The observation model's held-out choice of kernel width, detection probability and
    /// clutter ([`ObservationSmoothing::HeldOut`]); `None` when it is as counted.
    pub fn observation_choice(&self) -> Option<ObservationChoice> {
        match &self.obs {
            ObservationModel::Stationary(o) => o.choice(),
            _ => None,
        }
    }

    /// The tracking space.
    pub fn space(&self) -> &Space {
        &self.space
    }

    /// The configuration.
    pub fn config(&self) -> &CbtConfig {
        &self.config
    }

    /// What learning has counted.
    pub fn stats(&self) -> LearnStats {
        self.stats
    }

    /// Adds one frame's soft counts with weight `weight`; with `renormalise`, updates the
    /// normalised columns the frame touched (online learning). `time` is the frame's time
    /// index (the phase of a [`crate::PeriodicInput`]; unused without one). All input is
    /// validated before anything is counted, so an error leaves the model unchanged.
    pub(crate) fn add_frame(
        &mut self,
        h: &mut History,
        states: &[crate::Point],
        dets: &[crate::Detection],
        weight: f64,
        renormalise: bool,
        time: u64,
    ) -> Result<(), TrackError> {
        let joint = self.config.layout == Layout::SparseJoint;
        let x = encode_states(&self.space, states, weight, joint)?;
        let z = encode_detections(&self.space, dets, 1.0, joint)?;
        let dims = self.space.dims();
        if !x.is_empty() && !z.is_empty() {
            self.stats.observation_frames += 1;
            match &mut self.obs {
                ObservationModel::Separable(axes) => {
                    for (d, o) in axes.iter_mut().enumerate() {
                        o.add(&z, &x, d);
                        if renormalise {
                            let cols: Vec<usize> = x.axes[d].iter().map(|e| e.0).collect();
                            o.normalise_columns(&cols, &self.config);
                        }
                    }
                }
                ObservationModel::Joint(o) => {
                    o.add(&z, &x);
                    if renormalise {
                        o.normalise(&self.config);
                    }
                }
                ObservationModel::Stationary(o) => {
                    o.add(&z, &x);
                    if renormalise {
                        o.normalise(&self.config);
                    }
                }
            }
        }
        let (prev, prev2) = h.take();
        if let (false, Some(p1)) = (x.is_empty(), prev.as_ref()) {
            self.stats.transitions += 1;
            let p2 = prev2.as_ref();
            if p2.is_some() {
                self.stats.triples += 1;
            }
            let cfg = self.config;
            match &mut self.sys {
                SystemModel::Separable {
                    first,
                    second,
                    phased,
                } => {
                    let phase = cfg.input.map(|i| i.weights(time)).unwrap_or_default();
                    for d in 0..dims {
                        first[d].add(&x.axes[d], &p1.axes[d]);
                        let cols: Vec<usize> = p1.axes[d].iter().map(|e| e.0).collect();
                        if renormalise {
                            first[d].normalise_columns(&cols, &cfg);
                        }
                        for &(p, w) in &phase {
                            phased[p][d].add_weighted(&x.axes[d], &p1.axes[d], w);
                            if renormalise {
                                phased[p][d].normalise_columns(&cols, &cfg);
                            }
                        }
                        let Some(second) = second.as_mut() else {
                            continue;
                        };
                        let mut touched = Vec::new();
                        if let Some(p2) = p2 {
                            second[d].add(&x.axes[d], &p1.axes[d], &p2.axes[d], &mut touched);
                        }
                        if renormalise {
                            if cfg.system_fallback == SystemFallback::FirstOrder {
                                // Every column (·, n) falls back on the changed column n.
                                let len = self.space.axis_len(d);
                                for &n in &cols {
                                    touched.extend((0..len).map(|o| o * len + n));
                                }
                            }
                            touched.sort_unstable();
                            touched.dedup();
                            second[d].normalise_columns(&touched, &cfg, &first[d]);
                        }
                    }
                }
                SystemModel::Joint(s) => {
                    s.add(&x.joint, &p1.joint, p2.map(|p| &p.joint[..]));
                }
                SystemModel::Stationary(s) => {
                    for (d, s) in s.iter_mut().enumerate() {
                        s.add_frames(&cfg, d, &x, p1, p2);
                        if renormalise {
                            s.normalise(&cfg);
                        }
                    }
                }
            }
        }
        h.push(states, x, prev);
        Ok(())
    }

    /// Recomputes every normalised column from the counts.
    pub(crate) fn normalise_all(&mut self) {
        let cfg = self.config;
        match &mut self.obs {
            ObservationModel::Separable(axes) => {
                axes.iter_mut().for_each(|o| o.normalise_all(&cfg))
            }
            ObservationModel::Joint(o) => o.normalise(&cfg),
            ObservationModel::Stationary(o) => o.normalise(&cfg),
        }
        match &mut self.sys {
            SystemModel::Separable {
                first,
                second,
                phased,
            } => {
                for (d, f) in first.iter_mut().enumerate() {
                    let n = self.space.axis_len(d);
                    f.normalise_columns(&(0..n).collect::<Vec<_>>(), &cfg);
                    if let Some(s) = second.as_mut() {
                        s[d].normalise_columns(&(0..n * n).collect::<Vec<_>>(), &cfg, f);
                    }
                    for p in phased.iter_mut() {
                        p[d].normalise_columns(&(0..n).collect::<Vec<_>>(), &cfg);
                    }
                }
            }
            SystemModel::Joint(s) => s.prepare(&self.space, &cfg),
            SystemModel::Stationary(s) => s.iter_mut().for_each(|s| s.normalise(&cfg)),
        }
    }

    /// The normalised observation matrix of axis `d` (separable layout), row-major
    /// `O[m·N_x + n] ≈ p(z = z̃_m | x = x̃_n)`; `None` for the joint layout.
    pub fn observation_matrix(&self, d: usize) -> Option<&[f64]> {
        match &self.obs {
            ObservationModel::Separable(axes) => axes.get(d).map(|o| o.model()),
            ObservationModel::Joint(_) | ObservationModel::Stationary(_) => None,
        }
    }

    /// The raw soft counts `C_zx` of axis `d` (separable layout), row-major.
    pub fn observation_counts(&self, d: usize) -> Option<&[f64]> {
        match &self.obs {
            ObservationModel::Separable(axes) => axes.get(d).map(|o| o.counts()),
            ObservationModel::Joint(_) | ObservationModel::Stationary(_) => None,
        }
    }

    /// The normalised first-order matrix of axis `d` (separable layout), column-major
    /// `S[n·N + m] ≈ p(x_k = x̃_m | x_{k−1} = x̃_n)`.
    pub fn first_order_matrix(&self, d: usize) -> Option<&[f64]> {
        match &self.sys {
            SystemModel::Separable { first, .. } => first.get(d).map(|s| s.model()),
            SystemModel::Joint(_) | SystemModel::Stationary(_) => None,
        }
    }

    /// The normalised first-order matrix of phase channel `p` and axis `d` (separable layout
    /// with a [`crate::PeriodicInput`]), laid out as [`first_order_matrix`](Self::first_order_matrix).
    pub fn phase_matrix(&self, p: usize, d: usize) -> Option<&[f64]> {
        match &self.sys {
            SystemModel::Separable { phased, .. } => {
                phased.get(p).and_then(|s| s.get(d)).map(|s| s.model())
            }
            SystemModel::Joint(_) | SystemModel::Stationary(_) => None,
        }
    }

    /// The first-order column `p(x_k | x_{k−1} = x̃_n)` of axis `d` for a step into time
    /// index `k` (separable layout): with a [`crate::PeriodicInput`] the phase channels' mix
    /// `Σ_p β_p(φ_k) S_p[·, n]`, else the column of `S`. Written into `out` (length `N_d`).
    pub(crate) fn transition_column(&self, d: usize, n: usize, k: u64, out: &mut [f64]) {
        let SystemModel::Separable { first, phased, .. } = &self.sys else {
            return;
        };
        match self.config.input {
            Some(i) if !phased.is_empty() => {
                out.iter_mut().for_each(|v| *v = 0.0);
                for (p, w) in i.weights(k) {
                    for (o, s) in out.iter_mut().zip(phased[p][d].column(n)) {
                        *o += w * s;
                    }
                }
            }
            _ => out.copy_from_slice(first[d].column(n)),
        }
    }

    /// The normalised second-order tensor of axis `d` (separable layout, second order),
    /// `T[(o·N + n)·N + m] ≈ p(x_k = x̃_m | x_{k−1} = x̃_n, x_{k−2} = x̃_o)`.
    pub fn second_order_tensor(&self, d: usize) -> Option<&[f64]> {
        match &self.sys {
            SystemModel::Separable { second, .. } => {
                second.as_ref().and_then(|s| s.get(d)).map(|s| s.model())
            }
            SystemModel::Joint(_) | SystemModel::Stationary(_) => None,
        }
    }

    /// The stationary layout's learned observation statistics: `(P̂_D, clutter per cell and
    /// frame B, kernel radius)`; `None` for the other layouts.
    pub fn stationary_observation(&self) -> Option<(f64, f64, usize)> {
        match &self.obs {
            ObservationModel::Stationary(o) => {
                Some((o.p_detect(), o.background(), o.kernel_radius()))
            }
            _ => None,
        }
    }

    /// The stationary layout's learned observation kernel `A[δ]` over `|δ|∞ ≤ r_A`, row-major
    /// `[(δx + r_A)·(2r_A + 1) + δy + r_A]`, with `r_A`; `None` for the other layouts.
    pub fn stationary_kernel(&self) -> Option<(&[f64], usize)> {
        match &self.obs {
            ObservationModel::Stationary(o) => Some((o.kernel(), o.kernel_radius())),
            _ => None,
        }
    }

    /// The stationary layout's per-axis displacement models `(S[δ], T[δ | v])` of axis `d`
    /// (`δ, v ∈ [−r, r]`, `T` as `[(v + r)·(2r + 1) + δ + r]`); `None` for other layouts.
    pub fn stationary_system(&self, d: usize) -> Option<(&[f64], &[f64])> {
        match &self.sys {
            SystemModel::Stationary(s) => s.get(d).map(|s| (s.first(), s.second())),
            _ => None,
        }
    }

    /// The stationary layout's start density of axis `d` (`δ ∈ [−r, r]`): the axis's own
    /// `S₀` with [`StartMotion::Learned`](crate::StartMotion) or
    /// [`StartMotion::Pooled`](crate::StartMotion), `S` otherwise; `None` for other layouts.
    /// What the filter's first step uses: [`Self::stationary_first_step`].
    pub fn stationary_start(&self, d: usize) -> Option<&[f64]> {
        match &self.sys {
            SystemModel::Stationary(s) => s.get(d).map(|s| s.start()),
            _ => None,
        }
    }

    /// The displacement distribution the stationary filter's first step after a start uses
    /// on axis `d` (`δ ∈ [−r, r]`): [`Self::stationary_start`], or with
    /// [`StartMotion::Pooled`](crate::StartMotion) the average over the axes of theirs;
    /// `None` for other layouts or a missing axis.
    pub fn stationary_first_step(&self, d: usize) -> Option<Vec<f64>> {
        match &self.sys {
            SystemModel::Stationary(s) if d < s.len() => {
                Some(crate::stationary::start_density(s, d, self.config.start))
            }
            _ => None,
        }
    }

    /// Stored entries of the sparse joint models `(observation counts, second-order columns)`.
    pub fn sparse_size(&self) -> Option<(usize, usize)> {
        match (&self.obs, &self.sys) {
            (ObservationModel::Joint(o), SystemModel::Joint(s)) => {
                Some((o.stored(), s.second_columns()))
            }
            _ => None,
        }
    }
}
