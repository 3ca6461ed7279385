//! # servo-loop: learn to recognise and control an arm, then servo it (Paper C)
//!
//! Paper C of F. Larsson's thesis (*Methods for Visually Guided Robotic Systems*, Linköping
//! 2009; thesis chapter 5, notes in docs/methods.md § Servoing) lets a low-cost arm without joint
//! feedback learn, from its own random actions, what its gripper looks like and how commands move
//! it, and then position it in closed loop. This crate is that method, for any [`Robot`] (send a
//! command, capture images); it knows nothing about a particular arm or simulator.
//!
//! ## 1. Recognition learned from action ([`TipModel`], [`learn_recognition`])
//! Action precedes perception: the learner moves the arm at random and, at each pose, closes
//! and opens the gripper. From these frames each camera learns (a) the **static scene**, the
//! per-pixel median of the frames after normalising each frame's lighting (a gain and two
//! brightness gradients, robust least squares), so clutter and the table cancel; (b) which end
//! of the arm's silhouette is the **gripper**: the gripper move's image change (the fingers)
//! picks the *root* point from which the gripper is the farthest silhouette pixel; (c) the
//! gripper end's size. In one new image the lit scene is subtracted, the largest connected
//! silhouette is the arm, its pixel farthest from the root is the end of the chain, and the
//! **tip** (the middle of the gripper's far end, between the finger ends) follows at sub-pixel
//! precision by one of three rules ([`TipRule`], [`recognition::silhouette`]): `FarEnd` from
//! the soft coverage of the end (the end position along the gripper's principal axis from
//! covered areas, the centre across it as the coverage-weighted mean), smooth in the pose but
//! ahead of and beside the end face's centre; `EndFace` as the mean of the far cap's two outer
//! corners on the outline, the end face's centre for any viewing direction, but jumping by
//! 1–2.5 px where single outline pixels of the cap come and go; and `Learned` (the default and
//! the servo percept), which takes the far end and learns its offset from the end face: at
//! further random poses the offsets `e − f` of every camera are regressed on all cameras' far
//! ends (Nadaraya–Watson, bandwidth by leave-one-out; [`recognition::tip_correction`]), and the
//! corrected far end moves towards the end-face tip by at most 0.5 px (opt-in: by at most
//! `max(0.5 px, k σ)`, where `σ` is the regression's local spread of the offsets, its own
//! certainty, [`SilhouetteConfig::face_gate`]; a camera without an end face is then doubted
//! where `σ` is large, [`SilhouetteConfig::spread_scale`], by default in every percept, with
//! [`SilhouetteConfig::cap_training`] off only in those the servo acts on: training moves
//! ([`PerceptUse::Training`], [`PerceptPolicy::used`]) keep theirs, so the learned inverse
//! model has no holes where the correction is unsure; `eval servo` uses the gate that way).
//! How accurate each rule is
//! on `arm-sim` (median and 90th percentile per camera against the projected middle of the
//! finger ends, frame-to-frame repeatability, distance to `arm-sim`'s tool point, which lies
//! 8 mm behind the finger ends where nothing marks it): `fixtures/paper-c/summary.md`.
//! The **channel-coded feature map** recogniser ([`GripperModel`]: spatial B-spline × cos²
//! orientation channels of image gradients, chan-repr; docs/methods.md § Servoing), learned from
//! the same gripper moves ([`capture_training_views`]), is an appearance model with a certainty:
//! matched near the silhouette's tip it finds only the fingers' region, several pixels off, and
//! over the whole image it at times matches clutter (`eval servo` reports both:
//! `fixtures/paper-c/summary.md`, *Gripper recognition*, the `ccfm` rows), so the servo
//! pipeline does not use it.
//!
//! ## 2. Learning to control ([`learn_control`], [`InverseModel`])
//! `N` random commands `y` (the controlled servos; the redundant ones are held at fixed
//! set-points, see [`ControlSpace`]), the percept `x` each produces (the gripper point in every
//! camera), and LWPR trained incrementally on `x → y`: the learned inverse kinematics `f̂`, and
//! from LWPR's analytic derivative the inverse image Jacobian `J = ∂f̂/∂x` (eq. 5.2–5.3).
//!
//! ## 3. Servoing ([`servo_lwpr`])
//! `y₀ = f̂(x_w)`, then `y ← y − λ J (x − x_w)` (eq. 5.4 with the deviation taken as
//! `x − x_w`; docs/methods.md § Servoing, the sign), `J` at the target or at the current percept,
//! until the image error is below a tolerance or after `K` corrections, refining LWPR with every
//! executed move. Baselines: [`open_loop`], [`servo_broyden`] (uncalibrated, rank-one updated image
//! Jacobian) and [`servo_image_jacobian`] (a known analytic Jacobian).
//!
//! ## Knowing when the percept is wrong ([`Recogniser`], [`PerceptPolicy`], [`recognition::epipolar`])
//! The loops see a recogniser only through the [`Recogniser`] trait (a user's own detector plugs
//! in; the learned [`TipModel`] is the default), and every localisation carries a certainty.
//! The learned recogniser caps it by the cross-camera consistency: the fundamental matrix `F`
//! of each camera pair (`bᵀ F a = 0` for two views of one point) is estimated from the tips it
//! found at its own correction poses (normalised 8-point in a seeded RANSAC), and a pair's
//! consistency is `exp(−½ (d/s)²)` for its Sampson distance `d` and a scale `s` from the fit's
//! robust residuals, so a tip found at the wrong end of the silhouette or on clutter in one
//! camera is doubted (unless it lies on the other view's epipolar line). The same geometry
//! can also *choose* the tip ([`recognition::cross_camera`], opt-in
//! [`SilhouetteConfig::cross_camera_choice`]): each camera offers its rule's tip and its
//! end-face tip, and the pair with the smallest normalised Sampson distance (summed over the
//! camera pairs; ties keep the rule's tip) is reported. On the development seeds it lowered
//! the recognition p90 on every arm but made the servo worse on the default arm and the
//! second rig (sensor noise flips the hard choice between two tips a few pixels apart at one
//! pose, measured in [`recognition::cross_camera`]), so it is off by default; the learned
//! tip's gate (section 1, also an opt-in) takes the end face where the correction is unsure,
//! continuously (`docs/methods.md`, *Cross-camera choice*, *Gated learned tip*). A [`VisualPlant`]
//! re-captures a doubted percept and then refuses it ([`ServoError::PerceptRefused`],
//! counted): learning skips it and the servo loop stops rather than move on it.
//! A tip found at the wrong place *along* the epipolar line passes that check; the arm's own
//! move does not. The **motion check** ([`MotionCheck`], behind the percept seam:
//! [`VisualPlant::set_motion_check`], so any [`Recogniser`] gets it) remembers the percepts the
//! learner accepted with their commands (the training moves', then the servo's own, so the
//! previous accepted percept is the nearest reference while servoing) and predicts the percept
//! at a new command from the nearest ones moved by the commanded difference (a local linear
//! fit: the image Jacobian the learner's own moves show there); a servo percept
//! ([`PerceptUse::Servo`]) farther from that prediction than `κ` times the training moves'
//! median leave-one-out residual is re-captured, then refused
//! ([`ServoError::PerceptInconsistent`], counted by [`VisualPlant::inconsistent`]); the loop
//! never moves on it. Whether `eval servo` uses it, and what it measured:
//! `docs/methods.md`, *Motion check*. An earlier variant judges only short moves through the
//! learned inverse model ([`TemporalCheck`], [`TemporalPlant`]): with `(x₀, y₀)` the last accepted
//! percept and its command, a new percept `x` after command `y` is refused
//! ([`ServoError::PerceptInconsistent`]) when `‖(y − y₀) − (f̂(x) − f̂(x₀))‖` (to first order
//! `Δy − J Δx`) exceeds a threshold learned from the training moves' own residuals. It is an
//! opt-in: on our arms the recogniser's remaining errors are mostly systematic at a pose, so
//! consecutive percepts agree and pass, and what it refuses stops a run; measured, it made the
//! default arm's servo worse, so the study does not use it (`docs/methods.md`, *Temporal check*).
//! [`check_image_target`] checks a user's pixel target the same way (one 3-D point, inside
//! the learned model) before any move.
//!
//! A refused percept need not end a run: with [`ServoConfig::recovery`] ([`Recovery`],
//! [`recovery`]) every loop answers it with a small known move from the refused command (a
//! seeded direction, reflected into the learned workspace, executed like every move) and a
//! fresh percept, up to a bounded number of tries, and goes on from the first accepted one;
//! the refused percept itself is never used. Every such move is a move made: recorded
//! ([`ServoRun::refused`], [`ServoRun::recovery_moves`]) and counted against the run's budget
//! of `max_iterations` moves; when all tries are refused the run stops with
//! [`ServoError::RecoveryFailed`].
//!
//! ## 4. Executing moves on hobby servos ([`approach`])
//! A servo with a deadband and gear backlash ends where the direction it came from says, and
//! ignores reversing corrections smaller than its deadband: a plain loop stalls there (on
//! `arm-sim`, `eval servo` without the approach ended at lwpr 0.83 px and the true Jacobian
//! 1.00 px after 5 iterations: `fixtures/paper-c/summary.md` before commit 5bc3792, which
//! added it; the current figures, with it, are in that file). With
//! [`ServoConfig::approach`] (and [`LearnConfig::approach`]) every final approach of a joint
//! ends moving in one direction, from a pre-position more than deadband + backlash away
//! (20 µs for hobby servos by their data sheets), set-points are rounded to the controller's
//! resolution, and an unchanged command above the tolerance re-seats the joints (a fresh draw
//! of the end noise) instead of stalling; the error then falls to the servos' end-noise floor.
//!
//! ## Convergence (what the tests prove on an analytic plant)
//! With `x = g(y)` smooth and `J` the exact inverse Jacobian at the current point, the update
//! is Newton's method on `g(y) = x_w`: `e_{k+1} ≤ C e_k²`. With an approximate `J` it is a
//! chord method: `e_{k+1} ≈ ‖I − J_img J‖ e_k`, linear. (The exact Jacobian *of the target*,
//! held fixed, is exact at the solution, so it too converges superlinearly near it; the
//! learned one is only approximate, hence linear in practice.)
//!
//! ## Errors
//! Typed ([`ServoError`]): recognition failure, command outside the servo range, target
//! outside the image, non-finite input, robot errors. A servo run that stops early returns
//! [`ServoAbort`] with the moves executed so far; learned models are updated only with
//! completed, recognised moves, so they stay intact on any error. A learned model read back
//! with serde ([`TipModel`], [`GripperModel`], [`TipCorrection`], [`TemporalCheck`],
//! [`InverseModel`], [`MotionCheck`]) passes the checks learning applies as it is read: a file
//! learning could not have written is an error then, not a recogniser that panics or misreads
//! later.
#![deny(missing_docs)]

pub mod approach;
mod error;
mod inverse;
mod learn;
mod motion;
mod plant;
pub mod recognition;
pub mod recovery;
mod robot;
mod servo;
pub mod stats;
mod target;
mod temporal;
mod visual;

pub use approach::{Approach, ApproachDirection, ApproachState};
pub use error::{Result, ServoError};
pub use inverse::{InverseModel, InverseModelConfig, InversePrediction};
pub use learn::{
    LearnConfig, LearnReport, RandomCommands, chain_order, learn_control, learn_control_chained,
};
pub use motion::{MotionCheck, MotionConfig};
pub use plant::{Observation, Plant, check_command, check_target};
pub use recognition::{
    CorrectedTip, CorrectionReport, CorrectionSample, EndEstimate, EpipolarGeometry,
    EpipolarReport, GripperModel, Localisation, PairChoice, PerceptUse, Recogniser,
    RecognitionConfig, SilhouetteConfig, SilhouetteReport, TipCorrection, TipModel, TipRule,
    choose_consistent,
};
pub use recovery::{Recovery, RefusedMove};
pub use robot::Robot;
pub use servo::{
    BroydenConfig, JacobianAt, RangePolicy, ServoAbort, ServoConfig, ServoResult, ServoRun,
    ServoStep, image_error, open_loop, open_loop_with, servo_broyden, servo_image_jacobian,
    servo_lwpr,
};
pub use target::check_image_target;
pub use temporal::{TemporalCheck, TemporalConfig, TemporalPlant, Verdict};
pub use visual::{
    ControlSpace, PerceptPolicy, VisualPlant, capture_training_views, learn_recognition,
    observe_averaged, observe_averaged_by, observe_checked,
};
