//! # arm-sim: a simulated low-cost robotic arm, seen through rendered images
//!
//! Paper C of F. Larsson's thesis (*Methods for Visually Guided Robotic Systems*, Linköping
//! 2009, chapter 5) servos a cheap hobby arm: weak RC servos driven by pulse widths, no joint
//! feedback, hysteresis, a body that sags under its own weight, and a camera that sees it. This
//! crate is such an arm in software, so that a learner (`servo-loop`) must work from images and
//! commands alone, as the real system did (action precedes perception, thesis §5).
//!
//! ## The arm
//! A Lynx-6-like chain (base yaw, shoulder, elbow, wrist pitch, wrist roll) plus a two-finger
//! gripper; lengths and limits in [`ArmGeometry`], kinematics in [`kinematics`]. Commands are
//! servo set-points in µs (500–2500), never angles. Between set-point and pose sit, per servo
//! ([`servo`]): quantisation, a calibration offset and gain, a deadband and gear backlash (both
//! making the end angle depend on the direction of approach), move noise; then gravity sag of
//! the pitch joints, `Δq_j = c_j τ_j` with `τ_j = g Σ m_k (r_k − r_j)` (the torque of everything
//! beyond the joint, growing with the horizontal reach). Joint limits and the table stop the
//! arm (clamped and reported in [`MoveReport`]). [`SimConfig::ideal`] switches all of it off.
//!
//! ## The images
//! One or two pinhole cameras with radial distortion ([`Camera`]: `u = fx (1 + k1 r² + k2 r⁴)
//! x + cx`, likewise `v`) render 640×480 8-bit grey images: a ray-traced, anti-aliased static
//! background (textured table, clutter, the arm base) computed once, then per frame the arm as
//! shaded capsules and boxes with analytic anti-aliasing, a gripper of two box fingers, a
//! slight lighting change and sensor noise ([`render`]). Everything random comes from the
//! configuration's seed (xoshiro256++), so images are reproducible byte for byte.
//!
//! ## Two APIs
//! A learner uses [`ArmSim::command`] and [`ArmSim::capture`] only. Evaluation uses
//! [`ArmSim::inspect`] ([`Inspection`]): true joint angles, 3-D pose, projection of any point,
//! per-pixel part labels, and in every image the tool point ([`Inspection::tip_pixels`]) and the
//! middle of the finger ends ([`Inspection::finger_middle_pixels`], [`ArmPose::finger_middle`]:
//! the tip as a percept sees it, `finger_pad_mm` (8 mm) ahead of the tool point).
//!
//! ## Not modelled (by design or not yet)
//! Collisions other than with the table (links with each other or with the base, the arm with
//! clutter objects, which are scenery only); servo dynamics (a command returns the settled pose);
//! cast shadows, colour, motion blur and rolling shutter; a TOML configuration (JSON only).
//!
//! ```
//! use arm_sim::{ArmSim, SimConfig};
//! // (Quarter-size images keep this example quick; the default is 640×480.)
//! let mut sim = ArmSim::new(SimConfig::default().with_image_scale(0.25)).unwrap();
//! sim.command(&[1600.0, 1350.0, 1700.0, 1500.0, 1500.0, 1200.0]).unwrap();
//! let images = sim.capture();
//! let tip_px = sim.inspect().tip_pixels().unwrap();
//! assert_eq!(images.len(), tip_px.len());
//! ```
#![deny(missing_docs)]

pub mod camera;
pub mod config;
pub mod error;
pub mod kinematics;
pub mod render;
mod scene;
pub mod servo;
pub mod sim;
mod texture;

pub use camera::Camera;
pub use config::{
    ArmGeometry, CameraConfig, ClutterKind, ClutterObject, Distractor, LightingDrift, NUM_JOINTS,
    NUM_SERVOS, SERVO_NAMES, SagConfig, SceneConfig, ServoConfig, SimConfig, TableConfig,
};
pub use error::{ArmSimError, Result};
pub use kinematics::{ArmPose, JointAngles, apply_sag, forward_kinematics, gravity_torques};
pub use render::{LABEL_ARM, LABEL_DISTRACTOR, LABEL_FINGER_A, LABEL_FINGER_B, LABEL_PALM};
pub use sim::{ArmSim, Inspection, MoveReport, home_set_points};
