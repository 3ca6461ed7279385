//! Closed-loop servoing (thesis §5.3, docs/methods.md § Servoing) and its baselines.
//!
//! All methods start from the same first guess, normally the learned inverse kinematics at the
//! target, `y₀ = f̂(x_w)`, and then correct the command from the observed deviation:
//!
//! - [`servo_lwpr`]: `y ← y − λ J (x − x_w)` with the learned inverse image Jacobian
//!   `J = ∂f̂/∂x` (eq. 5.4 with the deviation `x − x_w`, see the sign note in
//!   docs/methods.md § Servoing), evaluated at the target (`J(x_w)`, a chord method: linear
//!   convergence) or at the current percept (`J(x)`, Newton-like: quadratic convergence where
//!   `f̂` is exact). Every executed move also refines the model online with the pair `(x, y)`.
//! - [`servo_image_jacobian`]: `y ← y − λ J_img(y)⁺ (x − x_w)` with a given forward image
//!   Jacobian `J_img = ∂x/∂y` (the analytic Jacobian of a known model: the upper bound).
//! - [`servo_broyden`]: uncalibrated servoing: `J_img` is estimated by `m` probing moves and
//!   then corrected after every move by Broyden's rank-one update
//!   `B ← B + (Δx − B Δy) Δyᵀ / (Δyᵀ Δy)`.
//! - [`open_loop`]: `y₀` only.
//!
//! Every run records the percept after each executed move ([`ServoRun::steps`], step 0 = the
//! first guess), so iteration counts are comparable: one iteration = one executed move. With
//! [`ServoConfig::recovery`] a refused percept is answered by a small known move
//! ([`crate::recovery`]); such moves are recorded ([`ServoRun::refused`],
//! [`ServoRun::recovery_moves`]) and count against the same budget: a run makes at most
//! `max_iterations` moves after the first guess, corrections and recovery moves together.
//! A run that fails after sending a command records that move apart
//! ([`ServoRun::failed_move`]), so the caller knows where the arm may stand.

use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use crate::approach::{Approach, ApproachState};
use crate::error::{Result, ServoError, check_finite, check_len};
use crate::inverse::InverseModel;
use crate::plant::{Observation, Plant, check_command, check_target, checked_range};
use crate::recovery::{Recovery, RefusedMove};

/// Where the learned Jacobian is evaluated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum JacobianAt {
    /// At the target percept `x_w` (the papers' first-iteration Jacobian; chord method).
    Target,
    /// At the current percept `x` (Newton-like).
    Current,
}

/// What to do when a corrected command leaves the servo range.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RangePolicy {
    /// Stop with [`ServoError::OutOfServoRange`] (nothing is sent).
    Stop,
    /// Clamp the command into the range and go on.
    Clamp,
}

/// Settings of a servo run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ServoConfig {
    /// Maximum number of corrections `K` after the first guess.
    pub max_iterations: usize,
    /// Stop when the image error ([`image_error`]) is at most this (percept units, pixels).
    pub tolerance: f64,
    /// Step factor `λ ∈ (0, 1]` (1 = undamped).
    pub damping: f64,
    /// Where the learned Jacobian is evaluated ([`servo_lwpr`] only).
    pub jacobian_at: JacobianAt,
    /// Refine the inverse model with every executed move ([`servo_lwpr`] only).
    pub refine_online: bool,
    /// Behaviour at the servo range.
    pub range: RangePolicy,
    /// How commands are executed: `None` sends each command as it is; `Some` executes it with
    /// the unidirectional approach of [`crate::approach`] (rounded to the controller's
    /// resolution, pre-positioned where a joint would otherwise end against the approach
    /// direction, and every joint re-seated when a correction leaves the command unchanged
    /// while the error is above the tolerance). For servos with a deadband and backlash.
    #[serde(default)]
    pub approach: Option<Approach>,
    /// What to do when a percept is refused: `None` stops the run there (the loop never moves
    /// on a refused percept); `Some` makes up to [`Recovery::tries`] small known moves, each
    /// followed by a fresh percept, and goes on from the first accepted one. Recovery moves
    /// count against `max_iterations` ([`crate::recovery`]).
    #[serde(default)]
    pub recovery: Option<Recovery>,
}

impl Default for ServoConfig {
    fn default() -> Self {
        ServoConfig {
            max_iterations: 10,
            tolerance: 0.25,
            damping: 1.0,
            jacobian_at: JacobianAt::Current,
            refine_online: true,
            range: RangePolicy::Stop,
            approach: None,
            recovery: None,
        }
    }
}

impl ServoConfig {
    /// Checks `tolerance ≥ 0`, `damping ∈ (0, 1]`, the approach and the recovery settings.
    pub fn validate(&self) -> Result<()> {
        if let Some(a) = &self.approach {
            a.validate()?;
        }
        if let Some(r) = &self.recovery {
            r.validate()?;
        }
        if !(self.tolerance.is_finite() && self.tolerance >= 0.0) {
            return Err(ServoError::InvalidParameter {
                name: "tolerance",
                reason: format!("must be finite and ≥ 0, got {}", self.tolerance),
            });
        }
        if !(self.damping > 0.0 && self.damping <= 1.0) {
            return Err(ServoError::InvalidParameter {
                name: "damping",
                reason: format!("must lie in (0, 1], got {}", self.damping),
            });
        }
        Ok(())
    }
}

/// One executed move and what was seen afterwards.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ServoStep {
    /// The command sent (controlled set-points).
    pub command: Vec<f64>,
    /// The pre-position sent before it, with [`ServoConfig::approach`] (not observed).
    #[serde(default)]
    pub pre_position: Option<Vec<f64>>,
    /// The percept observed after it.
    pub percept: Vec<f64>,
    /// Recognition certainty of the percept.
    pub certainty: f64,
    /// [`image_error`] of the percept against the target.
    pub error: f64,
}

/// The record of a servo run.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct ServoRun {
    /// One entry per executed move whose percept was accepted; `steps[0]` is the first
    /// accepted one (the first guess unless its percept was refused).
    pub steps: Vec<ServoStep>,
    /// Whether the error reached the tolerance.
    pub converged: bool,
    /// Every executed move whose percept was refused, in order ([`RefusedMove::at_move`]
    /// places it among all moves made).
    #[serde(default)]
    pub refused: Vec<RefusedMove>,
    /// Recovery moves made after refused percepts ([`ServoConfig::recovery`]; each is in
    /// `steps` when its percept was accepted, in `refused` otherwise).
    #[serde(default)]
    pub recovery_moves: usize,
    /// The move the run ended on when it failed after the command was sent: a plant error
    /// while moving or observing, or a percept of the wrong length or not finite. The arm may
    /// stand there, and nothing seen there was accepted or refused; [`RefusedMove::reason`]
    /// holds the error's message. `None` when the run ended otherwise (a command refused
    /// before it was sent, for one, moved nothing). Not counted in [`ServoRun::moves`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub failed_move: Option<Box<RefusedMove>>,
}

impl ServoRun {
    /// Error after the last executed move with an accepted percept (`∞` when there is none).
    pub fn final_error(&self) -> f64 {
        self.steps.last().map_or(f64::INFINITY, |s| s.error)
    }

    /// Moves made: executed commands, observed (pre-positions not counted), whether their
    /// percept was accepted or refused. A move whose observation failed otherwise (a plant
    /// error, or a percept of the wrong length or not finite) ends the run with that error and
    /// is in neither list, so it is not counted here: it is [`ServoRun::failed_move`].
    pub fn moves(&self) -> usize {
        self.steps.len() + self.refused.len()
    }

    /// Moves made after the first guess (corrections, and recovery moves after refused
    /// percepts).
    pub fn iterations(&self) -> usize {
        self.moves().saturating_sub(1)
    }

    /// Percept error after move `k` (0 = the first guess): that of the last accepted percept
    /// at or before move `k`, holding the last value after the run stopped (`∞` when no
    /// percept was accepted by then).
    pub fn error_at(&self, k: usize) -> f64 {
        let mut error = f64::INFINITY;
        let mut steps = self.steps.iter();
        for m in 0..=k.min(self.moves().saturating_sub(1)) {
            if self.refused.iter().any(|r| r.at_move == m) {
                continue;
            }
            match steps.next() {
                Some(s) => error = s.error,
                None => break,
            }
        }
        error
    }
}

/// A run that stopped on an error, with everything executed up to that point.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "servoing stopped after {} move(s){}: {error}",
    run.moves(),
    if run.failed_move.is_some() { " and a failed one" } else { "" }
)]
pub struct ServoAbort {
    /// Why it stopped.
    pub error: ServoError,
    /// The moves executed before (boxed: the error stays small).
    pub run: Box<ServoRun>,
}

/// Result of a servo run.
pub type ServoResult = std::result::Result<ServoRun, ServoAbort>;

/// The image error between percept `x` and target `x_w`: `‖x − x_w‖ / √max(n/2, 1)`, i.e.
/// for a visual plant (`n = 2 × cameras`) the RMS over cameras of the per-camera pixel
/// distance (and `‖x − x_w‖` for a one-component percept).
///
/// Errors: `x_w` not as long as `x` ([`ServoError::DimensionMismatch`] `target`; it used to be
/// compared over the shorter of the two), a non-finite value ([`ServoError::NonFinite`]).
pub fn image_error(x: &[f64], x_w: &[f64]) -> Result<f64> {
    check_len("target", x_w, x.len())?;
    check_finite("percept", x)?;
    check_finite("target", x_w)?;
    let ss: f64 = x.iter().zip(x_w).map(|(a, b)| (a - b) * (a - b)).sum();
    Ok((ss / (x.len() as f64 / 2.0).max(1.0)).sqrt())
}

/// Running state shared by the loops: executes, observes and records.
struct Runner<'a, P: Plant + ?Sized> {
    plant: &'a mut P,
    x_w: &'a [f64],
    config: &'a ServoConfig,
    run: ServoRun,
    approach: ApproachState,
}

impl<'a, P: Plant + ?Sized> Runner<'a, P> {
    fn new(plant: &'a mut P, x_w: &'a [f64], config: &'a ServoConfig) -> Result<Self> {
        config.validate()?;
        check_target(&*plant, x_w)?;
        Ok(Runner {
            plant,
            x_w,
            config,
            run: ServoRun::default(),
            approach: ApproachState::new(),
        })
    }

    fn abort(self, error: ServoError) -> ServoAbort {
        ServoAbort {
            error,
            run: Box::new(self.run),
        }
    }

    /// Whether the budget allows another move: the first guess and `max_iterations` moves
    /// after it, recovery moves included.
    fn budget_left(&self) -> bool {
        self.run.moves() <= self.config.max_iterations
    }

    /// Executes `y` and observes ([`Runner::execute_once`]); a refused percept is recorded and,
    /// with [`ServoConfig::recovery`] and budget left, answered by recovery moves from the
    /// refused command (each executed and observed alike) until one is accepted. Errors: the
    /// refusal when no recovery move was made, [`ServoError::RecoveryFailed`] when every one
    /// was refused, any other error as it came.
    fn execute(&mut self, y: Vec<f64>) -> Result<Observation> {
        let mut refusal = match self.execute_once(y) {
            Ok(obs) => return Ok(obs),
            Err(e) => e,
        };
        let Some(recovery) = self.config.recovery.clone() else {
            return Err(refusal);
        };
        if !refusal.is_refused_percept() {
            return Err(refusal);
        }
        // The command the refused percept was taken at (as executed, just recorded).
        let Some(refused) = self.run.refused.last().map(|r| r.command.clone()) else {
            return Err(refusal);
        };
        let mut tries = 0;
        while tries < recovery.tries && self.budget_left() {
            let y = recovery.command(&refused, tries, |j| self.plant.command_range(j))?;
            tries += 1;
            self.run.recovery_moves += 1;
            match self.execute_once(y) {
                Ok(obs) => return Ok(obs),
                Err(e) => refusal = e,
            }
            if !refusal.is_refused_percept() {
                // Not a refused percept (a robot or range error): stop with it.
                return Err(refusal);
            }
        }
        if tries == 0 {
            return Err(refusal);
        }
        Err(ServoError::RecoveryFailed {
            tries,
            last: Box::new(refusal),
        })
    }

    /// Applies the range policy (and the approach), executes `y`, observes and records: an
    /// accepted percept as a step, a refused one ([`ServoError::is_refused_percept`]) as a
    /// [`RefusedMove`] (returned as the error).
    fn execute_once(&mut self, mut y: Vec<f64>) -> Result<Observation> {
        if let Some(a) = &self.config.approach {
            y = a.round(&y);
        }
        if self.config.range == RangePolicy::Clamp {
            // The length first: the plant's range is asked for its own joints only (a longer
            // command asked for joints it does not have; a plant may panic there).
            check_len("command", &y, self.plant.command_dim())?;
            for (j, v) in y.iter_mut().enumerate() {
                let [lo, hi] = checked_range(&*self.plant, j)?;
                if v.is_finite() {
                    *v = v.clamp(lo, hi);
                }
            }
        }
        check_command(&*self.plant, &y)?;
        // An unchanged command while still above the tolerance: re-seat every joint (a fresh
        // draw of the servos' end noise) instead of stalling.
        let reseat = self.approach.last() == Some(&y[..]);
        // The checks of `ApproachState::execute`, nothing sent yet.
        let pre_position = match &self.config.approach {
            Some(a) => self.approach.plan(&*self.plant, a, &y, reseat)?,
            None => None,
        };
        // From here on the command is sent: an error ends the run with it recorded.
        let sent = match &self.config.approach {
            Some(a) => self
                .approach
                .send(&mut *self.plant, a, &y, pre_position.as_deref()),
            None => self.plant.act(&y),
        };
        if let Err(e) = sent {
            return Err(self.failed(y, pre_position, e));
        }
        let obs = match self.plant.observe() {
            Ok(obs) => obs,
            Err(e) if e.is_refused_percept() => {
                self.run.refused.push(RefusedMove {
                    at_move: self.run.moves(),
                    command: y,
                    pre_position,
                    reason: e.to_string(),
                });
                return Err(e);
            }
            Err(e) => return Err(self.failed(y, pre_position, e)),
        };
        let error = match check_len("percept", &obs.x, self.x_w.len())
            .and_then(|()| image_error(&obs.x, self.x_w))
        {
            Ok(error) => error,
            Err(e) => return Err(self.failed(y, pre_position, e)),
        };
        self.run.steps.push(ServoStep {
            command: y,
            pre_position,
            percept: obs.x.clone(),
            certainty: obs.certainty,
            error,
        });
        if error <= self.config.tolerance {
            self.run.converged = true;
        }
        Ok(obs)
    }

    /// Records `y`, sent, as the move the run ends on ([`ServoRun::failed_move`]) and returns
    /// `e`.
    fn failed(&mut self, y: Vec<f64>, pre_position: Option<Vec<f64>>, e: ServoError) -> ServoError {
        self.run.failed_move = Some(Box::new(RefusedMove {
            at_move: self.run.moves(),
            command: y,
            pre_position,
            reason: e.to_string(),
        }));
        e
    }

    fn deviation(&self, x: &[f64]) -> DVector<f64> {
        DVector::from_iterator(x.len(), x.iter().zip(self.x_w).map(|(a, b)| a - b))
    }

    fn last_command(&self) -> DVector<f64> {
        // Called after `execute` succeeded: an accepted percept pushes its step first.
        DVector::from_column_slice(&self.run.steps.last().expect("a step was executed").command)
    }
}

/// Open-loop positioning: executes `y₀ = f̂(x_w)` only.
pub fn open_loop<P: Plant + ?Sized>(
    plant: &mut P,
    model: &InverseModel,
    x_w: &[f64],
) -> ServoResult {
    open_loop_with(plant, model, x_w, &ServoConfig::default())
}

/// Open-loop positioning executed with `config`'s range policy and approach (its iteration
/// settings are ignored): executes `y₀ = f̂(x_w)` only.
pub fn open_loop_with<P: Plant + ?Sized>(
    plant: &mut P,
    model: &InverseModel,
    x_w: &[f64],
    config: &ServoConfig,
) -> ServoResult {
    let config = ServoConfig {
        max_iterations: 0,
        ..config.clone()
    };
    let mut r = Runner::new(plant, x_w, &config).map_err(|e| ServoAbort {
        error: e,
        run: Box::default(),
    })?;
    let y0 = match model.predict(x_w) {
        Ok(y) => y,
        Err(e) => return Err(r.abort(e)),
    };
    if let Err(e) = r.execute(y0) {
        return Err(r.abort(e));
    }
    Ok(r.run)
}

/// Servoing with the learned inverse image Jacobian (module doc). With
/// `config.refine_online` every executed move updates `model`; on an error the model holds
/// every completed move and nothing of the failing one.
pub fn servo_lwpr<P: Plant + ?Sized>(
    plant: &mut P,
    model: &mut InverseModel,
    x_w: &[f64],
    config: &ServoConfig,
) -> ServoResult {
    let mut r = Runner::new(plant, x_w, config).map_err(|e| ServoAbort {
        error: e,
        run: Box::default(),
    })?;
    let step = |r: &mut Runner<'_, P>, model: &mut InverseModel, y: Vec<f64>| -> Result<Vec<f64>> {
        let obs = r.execute(y)?;
        if r.config.refine_online {
            // The command as executed (rounded with an approach), not as asked.
            model.update(&obs.x, r.last_command().as_slice())?;
        }
        Ok(obs.x)
    };
    let y0 = match model.predict(x_w) {
        Ok(y) => y,
        Err(e) => return Err(r.abort(e)),
    };
    let mut x = match step(&mut r, model, y0) {
        Ok(x) => x,
        Err(e) => return Err(r.abort(e)),
    };
    while !r.run.converged && r.budget_left() {
        let at = match config.jacobian_at {
            JacobianAt::Target => x_w,
            JacobianAt::Current => &x[..],
        };
        let j = match model.predict_with_jacobian(at) {
            Ok(p) => p.jacobian,
            Err(e) => return Err(r.abort(e)),
        };
        let y = r.last_command() - config.damping * (&j * r.deviation(&x));
        x = match step(&mut r, model, y.as_slice().to_vec()) {
            Ok(x) => x,
            Err(e) => return Err(r.abort(e)),
        };
    }
    Ok(r.run)
}

/// Servoing with a given forward image Jacobian `J_img(y) = ∂x/∂y` (`n × m`), stepping
/// `y ← y − λ J_img(y)⁺ (x − x_w)` (least squares; the pseudo-inverse drops singular values
/// below `1e-9 σ_max`). Starts by executing `y0`. A Jacobian that is not finite or not
/// `n × m` (percept × command dimension) stops the run with a typed error.
pub fn servo_image_jacobian<P, F>(
    plant: &mut P,
    y0: &[f64],
    x_w: &[f64],
    config: &ServoConfig,
    mut image_jacobian: F,
) -> ServoResult
where
    P: Plant + ?Sized,
    F: FnMut(&[f64]) -> Result<DMatrix<f64>>,
{
    let mut r = Runner::new(plant, x_w, config).map_err(|e| ServoAbort {
        error: e,
        run: Box::default(),
    })?;
    let mut x = match r.execute(y0.to_vec()) {
        Ok(o) => o.x,
        Err(e) => return Err(r.abort(e)),
    };
    while !r.run.converged && r.budget_left() {
        let y = r.last_command();
        let dy = match image_jacobian(y.as_slice())
            .and_then(|j| least_squares_step(&j, &r.deviation(&x), y.len()))
        {
            Ok(dy) => dy,
            Err(e) => return Err(r.abort(e)),
        };
        let y_new = y - config.damping * dy;
        x = match r.execute(y_new.as_slice().to_vec()) {
            Ok(o) => o.x,
            Err(e) => return Err(r.abort(e)),
        };
    }
    Ok(r.run)
}

/// Settings of the Broyden baseline.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BroydenConfig {
    /// Size of each probing move (command units) used to initialise the image Jacobian; each
    /// probe is one executed move (one iteration).
    pub probe: f64,
}

impl Default for BroydenConfig {
    fn default() -> Self {
        BroydenConfig { probe: 20.0 }
    }
}

/// Uncalibrated servoing with a Broyden-updated image Jacobian (module doc). Executes `y0`,
/// then one probing move per command dimension (`y0 + probe·e_j`, flipped to `−probe` where
/// that would leave the range), then Broyden steps. Probes count as iterations. A probe whose
/// percept was refused and recovered ([`ServoConfig::recovery`]) updates the Jacobian by
/// Broyden's rank-one rule along the move made from `y0`.
pub fn servo_broyden<P: Plant + ?Sized>(
    plant: &mut P,
    y0: &[f64],
    x_w: &[f64],
    config: &ServoConfig,
    broyden: &BroydenConfig,
) -> ServoResult {
    let mut r = Runner::new(plant, x_w, config).map_err(|e| ServoAbort {
        error: e,
        run: Box::default(),
    })?;
    if !(broyden.probe.is_finite() && broyden.probe > 0.0) {
        return Err(r.abort(ServoError::InvalidParameter {
            name: "probe",
            reason: format!("must be finite and positive, got {}", broyden.probe),
        }));
    }
    let m = r.plant.command_dim();
    let n = x_w.len();
    let x0 = match r.execute(y0.to_vec()) {
        Ok(o) => o.x,
        Err(e) => return Err(r.abort(e)),
    };
    // The first guess as executed (rounded with an approach).
    let y0r = r.last_command();
    let mut b = DMatrix::zeros(n, m);
    let mut x = x0.clone();
    let mut y = y0r.clone();
    for j in 0..m {
        if r.run.converged || !r.budget_left() {
            break;
        }
        let [lo, hi] = r.plant.command_range(j);
        let mut yp = y0r.clone();
        let delta = if yp[j] + broyden.probe <= hi || yp[j] - broyden.probe < lo {
            broyden.probe
        } else {
            -broyden.probe
        };
        yp[j] += delta;
        x = match r.execute(yp.as_slice().to_vec()) {
            Ok(o) => o.x,
            Err(e) => return Err(r.abort(e)),
        };
        // The probe as executed (rounded with an approach; a recovery move after a refused
        // probe moves every joint: then a rank-one update along the move made).
        let dyv = r.last_command() - &y0r;
        let delta = dyv[j];
        if dyv.iter().enumerate().all(|(k, &v)| k == j || v == 0.0) {
            if delta != 0.0 {
                for i in 0..n {
                    b[(i, j)] = (x[i] - x0[i]) / delta;
                }
            }
        } else {
            let dxv = DVector::from_iterator(n, x.iter().zip(&x0).map(|(a, b)| a - b));
            b += (&dxv - &b * &dyv) * dyv.transpose() / dyv.dot(&dyv);
        }
        y = r.last_command();
    }
    let mut x_prev = x.clone();
    let mut y_prev = y.clone();
    while !r.run.converged && r.budget_left() {
        let dy = match least_squares_step(&b, &r.deviation(&x), m) {
            Ok(dy) => dy,
            Err(e) => return Err(r.abort(e)),
        };
        y = &y_prev - config.damping * dy;
        x = match r.execute(y.as_slice().to_vec()) {
            Ok(o) => o.x,
            Err(e) => return Err(r.abort(e)),
        };
        y = r.last_command();
        let dyv = &y - &y_prev;
        let dxv = DVector::from_iterator(n, x.iter().zip(&x_prev).map(|(a, b)| a - b));
        let denom = dyv.dot(&dyv);
        if denom > 0.0 {
            b += (&dxv - &b * &dyv) * dyv.transpose() / denom;
        }
        x_prev.clone_from(&x);
        y_prev = y.clone();
    }
    Ok(r.run)
}

/// `J⁺ d` by SVD (the minimum-norm least-squares solution).
fn least_squares_step(j: &DMatrix<f64>, d: &DVector<f64>, commands: usize) -> Result<DVector<f64>> {
    if j.iter().any(|v| !v.is_finite()) {
        return Err(ServoError::NonFinite {
            what: "image Jacobian",
            index: j.iter().position(|v| !v.is_finite()).unwrap_or(0),
        });
    }
    if j.nrows() != d.len() {
        return Err(ServoError::DimensionMismatch {
            what: "image Jacobian rows",
            expected: d.len(),
            got: j.nrows(),
        });
    }
    // A step of another length than the command used to panic subtracting it from the
    // command, and an empty matrix inside the SVD.
    if j.ncols() != commands {
        return Err(ServoError::DimensionMismatch {
            what: "image Jacobian columns",
            expected: commands,
            got: j.ncols(),
        });
    }
    if j.is_empty() {
        return Err(ServoError::InvalidParameter {
            name: "image Jacobian",
            reason: "empty (no percept or no command dimension)".into(),
        });
    }
    let svd = j.clone().svd(true, true);
    let smax = svd.singular_values.max();
    svd.solve(d, 1e-9 * smax.max(f64::MIN_POSITIVE))
        .map_err(|e| ServoError::InvalidParameter {
            name: "image Jacobian",
            reason: e.to_string(),
        })
}
