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
//! first guess), so iteration counts are comparable: one iteration = one executed move.

use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use crate::approach::{Approach, ApproachState};
use crate::error::{Result, ServoError, check_finite, check_len};
use crate::inverse::InverseModel;
use crate::plant::{Observation, Plant, check_command, check_target};

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
        }
    }
}

impl ServoConfig {
    /// Checks `tolerance ≥ 0`, `damping ∈ (0, 1]` and the approach settings.
    pub fn validate(&self) -> Result<()> {
        if let Some(a) = &self.approach {
            a.validate()?;
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
    /// One entry per executed move; `steps[0]` is the first guess.
    pub steps: Vec<ServoStep>,
    /// Whether the error reached the tolerance.
    pub converged: bool,
}

impl ServoRun {
    /// Error after the last executed move (`∞` when nothing was executed).
    pub fn final_error(&self) -> f64 {
        self.steps.last().map_or(f64::INFINITY, |s| s.error)
    }

    /// Number of corrections executed after the first guess.
    pub fn iterations(&self) -> usize {
        self.steps.len().saturating_sub(1)
    }

    /// Error after iteration `k`, holding the last value after the run stopped (`∞` when
    /// nothing was executed).
    pub fn error_at(&self, k: usize) -> f64 {
        if self.steps.is_empty() {
            return f64::INFINITY;
        }
        self.steps[k.min(self.steps.len() - 1)].error
    }
}

/// A run that stopped on an error, with everything executed up to that point.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("servoing stopped after {} move(s): {error}", run.steps.len())]
pub struct ServoAbort {
    /// Why it stopped.
    pub error: ServoError,
    /// The moves executed before.
    pub run: ServoRun,
}

/// Result of a servo run.
pub type ServoResult = std::result::Result<ServoRun, ServoAbort>;

/// The image error between percept `x` and target `x_w`: `‖x − x_w‖ / √(n/2)`, i.e. for a
/// visual plant (`n = 2 × cameras`) the RMS over cameras of the per-camera pixel distance.
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
            run: self.run,
        }
    }

    /// Applies the range policy (and the approach), executes `y`, observes and records.
    fn execute(&mut self, mut y: Vec<f64>) -> Result<Observation> {
        if let Some(a) = &self.config.approach {
            y = a.round(&y);
        }
        if self.config.range == RangePolicy::Clamp {
            for (j, v) in y.iter_mut().enumerate() {
                let [lo, hi] = self.plant.command_range(j);
                if v.is_finite() {
                    *v = v.clamp(lo, hi);
                }
            }
        }
        check_command(&*self.plant, &y)?;
        let pre_position = match &self.config.approach {
            Some(a) => {
                // An unchanged command while still above the tolerance: re-seat every joint
                // (a fresh draw of the servos' end noise) instead of stalling.
                let reseat = self.approach.last() == Some(&y[..]);
                self.approach.execute(&mut *self.plant, a, &y, reseat)?
            }
            None => {
                self.plant.act(&y)?;
                None
            }
        };
        let obs = self.plant.observe()?;
        check_len("percept", &obs.x, self.x_w.len())?;
        let error = image_error(&obs.x, self.x_w)?;
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

    fn deviation(&self, x: &[f64]) -> DVector<f64> {
        DVector::from_iterator(x.len(), x.iter().zip(self.x_w).map(|(a, b)| a - b))
    }

    fn last_command(&self) -> DVector<f64> {
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
        run: ServoRun::default(),
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
        run: ServoRun::default(),
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
    for _ in 0..config.max_iterations {
        if r.run.converged {
            break;
        }
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
/// below `1e-9 σ_max`). Starts by executing `y0`.
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
        run: ServoRun::default(),
    })?;
    let mut x = match r.execute(y0.to_vec()) {
        Ok(o) => o.x,
        Err(e) => return Err(r.abort(e)),
    };
    for _ in 0..config.max_iterations {
        if r.run.converged {
            break;
        }
        let y = r.last_command();
        let dy = match image_jacobian(y.as_slice())
            .and_then(|j| least_squares_step(&j, &r.deviation(&x)))
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
/// that would leave the range), then Broyden steps. Probes count as iterations.
pub fn servo_broyden<P: Plant + ?Sized>(
    plant: &mut P,
    y0: &[f64],
    x_w: &[f64],
    config: &ServoConfig,
    broyden: &BroydenConfig,
) -> ServoResult {
    let mut r = Runner::new(plant, x_w, config).map_err(|e| ServoAbort {
        error: e,
        run: ServoRun::default(),
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
    let mut probes = 0;
    for j in 0..m {
        if r.run.converged || probes >= config.max_iterations {
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
        // The probe as executed (rounded with an approach).
        let delta = r.last_command()[j] - y0r[j];
        probes += 1;
        if delta != 0.0 {
            for i in 0..n {
                b[(i, j)] = (x[i] - x0[i]) / delta;
            }
        }
        y = r.last_command();
    }
    let mut x_prev = x.clone();
    let mut y_prev = y.clone();
    for _ in probes..config.max_iterations {
        if r.run.converged {
            break;
        }
        let dy = match least_squares_step(&b, &r.deviation(&x)) {
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
fn least_squares_step(j: &DMatrix<f64>, d: &DVector<f64>) -> Result<DVector<f64>> {
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
    let svd = j.clone().svd(true, true);
    let smax = svd.singular_values.max();
    svd.solve(d, 1e-9 * smax.max(f64::MIN_POSITIVE))
        .map_err(|e| ServoError::InvalidParameter {
            name: "image Jacobian",
            reason: e.to_string(),
        })
}
