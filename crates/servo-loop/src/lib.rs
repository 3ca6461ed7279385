//! # servo-loop: learn to recognise and control an arm, then servo it (Paper C)
//!
//! Paper C of F. Larsson's thesis (*Methods for Visually Guided Robotic Systems*, Linköping
//! 2009; thesis chapter 5, notes in `papers.md` §3) lets a low-cost arm without joint feedback
//! learn, from its own random actions, what its gripper looks like and how commands move it,
//! and then position it in closed loop. This crate is that method, for any [`Robot`] (send a
//! command, capture images); it knows nothing about a particular arm or simulator.
//!
//! ## 1. Recognition learned from action ([`GripperModel`], [`learn_recognition`])
//! Action precedes perception: the learner opens and closes the gripper servo at random poses
//! and takes the image difference; the pixels that change are the fingers, and the robust
//! centroid of the change is the *gripper point*. Around it, a **channel-coded feature map**
//! (spatial B-spline channels × cyclic cos² channels of the double-angle gradient orientation,
//! plus grey-level channels, built with `chan-repr`; papers.md §1.4) is sampled in every
//! training view; the samples are clustered into a few prototypes per camera, minus the mean
//! background descriptor. A new image is searched for the prototypes (normalised
//! cross-correlation, coarse-to-fine, sub-pixel peak), giving the gripper point and a
//! certainty. **Status:** the change detection is reliable (tests), the localisation in a
//! single new image is not yet (see `fixtures/paper-c/summary.md`: tens of pixels median error
//! in the default scene, whose striped table and similar-looking arm parts confuse it).

//! ## 2. Learning to control ([`learn_control`], [`InverseModel`])
//! `N` random commands `y` (the controlled servos; the redundant ones are held at fixed
//! set-points, see [`ControlSpace`]), the percept `x` each produces (the gripper point in every
//! camera), and LWPR trained incrementally on `x → y`: the learned inverse kinematics `f̂`, and
//! from LWPR's analytic derivative the inverse image Jacobian `J = ∂f̂/∂x` (eq. 5.2–5.3).
//!
//! ## 3. Servoing ([`servo_lwpr`])
//! `y₀ = f̂(x_w)`, then `y ← y − λ J (x − x_w)` (eq. 5.4 with the deviation taken as
//! `x − x_w`; papers.md §3.1 sign note), `J` at the target or at the current percept, until
//! the image error is below a tolerance or after `K` corrections, refining LWPR with every
//! executed move. Baselines: [`open_loop`], [`servo_broyden`] (uncalibrated, rank-one
//! updated image Jacobian) and [`servo_image_jacobian`] (a known analytic Jacobian).
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
//! completed, recognised moves, so they stay intact on any error.
#![deny(missing_docs)]

mod error;
mod inverse;
mod learn;
mod plant;
pub mod recognition;
mod robot;
mod servo;
mod visual;

pub use error::{Result, ServoError};
pub use inverse::{InverseModel, InverseModelConfig, InversePrediction};
pub use learn::{LearnConfig, LearnReport, RandomCommands, learn_control};
pub use plant::{Observation, Plant, check_command, check_target};
pub use recognition::{GripperModel, Localisation, RecognitionConfig};
pub use robot::Robot;
pub use servo::{
    BroydenConfig, JacobianAt, RangePolicy, ServoAbort, ServoConfig, ServoResult, ServoRun,
    ServoStep, image_error, open_loop, servo_broyden, servo_image_jacobian, servo_lwpr,
};
pub use visual::{ControlSpace, VisualPlant, learn_recognition};
