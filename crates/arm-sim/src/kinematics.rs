//! Forward kinematics of the Lynx-6-like chain and the gravity torques that make it sag.
//!
//! Joint conventions (all angles in degrees):
//! - `q0` base yaw about the vertical: the arm plane points along `f = (cos q0, sin q0, 0)`;
//! - `q1` shoulder, `q2` elbow, `q3` wrist pitch, about the horizontal axis `p = (−sin q0,
//!   cos q0, 0)`; the link directions make the cumulative angles `φ1 = q1`, `φ2 = q1 + q2`,
//!   `φ3 = q1 + q2 + q3` with the vertical, leaning forward for positive angles:
//!   `dir(φ) = sin φ · f + cos φ · ẑ`;
//! - `q4` wrist roll about the hand's approach direction `a = dir(φ3)`;
//! - servo 5 drives the gripper: opening `w = max_opening · (q5 + 90°) / 180°`.
//!
//! Points: shoulder `S = (0, 0, h0)`, elbow `E = S + L1 dir(φ1)`, wrist `W = E + L2 dir(φ2)`,
//! tool point (gripper tip) `T = W + L3 dir(φ3)`.

use nalgebra::Vector3;

use crate::config::{ArmGeometry, NUM_SERVOS, SagConfig};

/// Thickness of a finger along the opening direction (mm).
pub const FINGER_THICKNESS_MM: f64 = 7.0;
/// Width of a finger across the opening direction (mm).
pub const FINGER_WIDTH_MM: f64 = 14.0;
/// Standard gravity (m/s²).
pub const GRAVITY: f64 = 9.81;

/// Joint angles in degrees: base yaw, shoulder, elbow, wrist pitch, wrist roll, gripper servo.
pub type JointAngles = [f64; NUM_SERVOS];

/// The 3-D pose of the arm: joint positions and the hand frame (world frame, mm).
#[derive(Clone, Debug, PartialEq)]
pub struct ArmPose {
    /// Shoulder pitch axis centre.
    pub shoulder: Vector3<f64>,
    /// Elbow axis centre.
    pub elbow: Vector3<f64>,
    /// Wrist pitch axis centre.
    pub wrist: Vector3<f64>,
    /// Tool point: the gripper tip, between the finger pads, `finger_pad_mm` behind the finger
    /// ends (not their middle: that is [`ArmPose::finger_middle`]).
    pub tip: Vector3<f64>,
    /// Unit direction along the hand, from wrist to tip.
    pub approach: Vector3<f64>,
    /// Unit direction across the finger gap (rotated about `approach` by the wrist roll).
    pub opening_axis: Vector3<f64>,
    /// Unit pitch axis of shoulder, elbow and wrist (horizontal, perpendicular to the arm plane).
    pub pitch_axis: Vector3<f64>,
    /// Gap between the fingers (mm).
    pub opening_mm: f64,
    /// Centres of the two finger ends (mm).
    pub finger_ends: [Vector3<f64>; 2],
}

impl ArmPose {
    /// The middle of the finger ends (mm): the mean of the two [`finger_ends`](Self::finger_ends),
    /// `(e₀ + e₁) / 2`, the middle of the gripper's far end, between the fingers.
    ///
    /// This is the point a system that sees the arm can call its tip: the heuristic percepts
    /// (`servo-loop`'s tip rules) define the tip as the middle of the gripper's far end, between
    /// the finger ends, so studies and tests measure them against this point's projection
    /// ([`Inspection::finger_middle_pixels`](crate::Inspection::finger_middle_pixels)). It is
    /// not the tool point [`tip`](Self::tip), which lies `finger_pad_mm` (8 mm by default)
    /// behind the finger ends along [`approach`](Self::approach), where nothing marks it.
    ///
    /// ```
    /// use arm_sim::{ArmGeometry, forward_kinematics};
    /// let g = ArmGeometry::default();
    /// let pose = forward_kinematics(&g, &[0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
    /// // Upright: 8 mm above the tool point at 415 mm.
    /// assert!((pose.finger_middle().z - 423.0).abs() < 1e-9);
    /// ```
    pub fn finger_middle(&self) -> Vector3<f64> {
        (self.finger_ends[0] + self.finger_ends[1]) * 0.5
    }
}

fn rad(deg: f64) -> f64 {
    deg.to_radians()
}

/// Forward kinematics: the pose for `angles` (degrees).
///
/// ```
/// use arm_sim::{ArmGeometry, forward_kinematics};
/// let g = ArmGeometry::default();
/// // Everything upright: the tip is straight above the base at 75 + 120 + 120 + 100 mm.
/// let pose = forward_kinematics(&g, &[0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
/// assert!((pose.tip.z - 415.0).abs() < 1e-9 && pose.tip.x.abs() < 1e-9);
/// ```
pub fn forward_kinematics(g: &ArmGeometry, angles: &JointAngles) -> ArmPose {
    let (sy, cy) = rad(angles[0]).sin_cos();
    let f = Vector3::new(cy, sy, 0.0);
    let p = Vector3::new(-sy, cy, 0.0);
    let up = Vector3::z();
    let dir = |phi_deg: f64| {
        let (s, c) = rad(phi_deg).sin_cos();
        f * s + up * c
    };
    let phi1 = angles[1];
    let phi2 = phi1 + angles[2];
    let phi3 = phi2 + angles[3];
    let shoulder = Vector3::new(0.0, 0.0, g.base_height_mm);
    let elbow = shoulder + dir(phi1) * g.upper_arm_mm;
    let wrist = elbow + dir(phi2) * g.forearm_mm;
    let approach = dir(phi3);
    let tip = wrist + approach * g.hand_mm;
    let b = approach.cross(&p);
    let (sr, cr) = rad(angles[4]).sin_cos();
    let opening_axis = p * cr + b * sr;
    let opening_mm = gripper_opening(g, angles[5]);
    let end = tip + approach * g.finger_pad_mm;
    let off = opening_axis * (0.5 * opening_mm + 0.5 * FINGER_THICKNESS_MM);
    ArmPose {
        shoulder,
        elbow,
        wrist,
        tip,
        approach,
        opening_axis,
        pitch_axis: p,
        opening_mm,
        finger_ends: [end + off, end - off],
    }
}

/// Gap between the fingers (mm) for the gripper servo angle `q5` (degrees). NaN for a
/// geometry with a negative or NaN `max_opening_mm` (which [`crate::SimConfig::validate`]
/// refuses).
pub fn gripper_opening(g: &ArmGeometry, q5_deg: f64) -> f64 {
    let max = g.max_opening_mm;
    if max.is_nan() || max < 0.0 {
        // `clamp(0, max)` panics for such a bound.
        return f64::NAN;
    }
    (max * (q5_deg + 90.0) / 180.0).clamp(0.0, max)
}

/// Gravity torques (N·m) on shoulder, elbow and wrist pitch for the pose `angles`; positive
/// torques pull the distal links forward and down (they increase `φ`).
///
/// `τ_j = g Σ_k m_k (r_k − r_j)` over the masses beyond joint `j`, where `r` is the horizontal
/// distance from the base axis in the arm plane (the lever arm of gravity).
pub fn gravity_torques(g: &ArmGeometry, sag: &SagConfig, angles: &JointAngles) -> [f64; 3] {
    let pose = forward_kinematics(g, angles);
    let f = Vector3::new(rad(angles[0]).cos(), rad(angles[0]).sin(), 0.0);
    let r = |v: &Vector3<f64>| v.dot(&f) * 1e-3;
    let [m_upper, m_fore, m_elbow_servo, m_wrist_servo, m_hand] = sag.masses_kg;
    let upper_mid = r(&((pose.shoulder + pose.elbow) * 0.5));
    let fore_mid = r(&((pose.elbow + pose.wrist) * 0.5));
    let hand_mid = r(&((pose.wrist + pose.tip) * 0.5));
    let (rs, re, rw) = (r(&pose.shoulder), r(&pose.elbow), r(&pose.wrist));
    let wrist_t = m_hand * (hand_mid - rw);
    let elbow_t = m_fore * (fore_mid - re) + m_wrist_servo * (rw - re) + m_hand * (hand_mid - re);
    let shoulder_t = m_upper * (upper_mid - rs)
        + m_elbow_servo * (re - rs)
        + m_fore * (fore_mid - rs)
        + m_wrist_servo * (rw - rs)
        + m_hand * (hand_mid - rs);
    [shoulder_t * GRAVITY, elbow_t * GRAVITY, wrist_t * GRAVITY]
}

/// The joint angles after gravity sag: `q_j + c_j τ_j(q)` for the pitch joints, solved by two
/// fixed-point steps (the sag itself changes the levers only by a second-order amount).
pub fn apply_sag(g: &ArmGeometry, sag: &SagConfig, angles: &JointAngles) -> JointAngles {
    let c = sag.compliance_deg_per_nm;
    if c.iter().all(|&v| v == 0.0) {
        return *angles;
    }
    let mut out = *angles;
    for _ in 0..2 {
        let tau = gravity_torques(g, sag, &out);
        for j in 0..3 {
            out[j + 1] = angles[j + 1] + c[j] * tau[j];
        }
    }
    out
}

/// Whether the pose touches or enters the table (`z = 0`): elbow and wrist servos, the tool
/// point and the finger ends, with their radii.
pub fn below_table(g: &ArmGeometry, pose: &ArmPose) -> bool {
    let finger_r = 0.5 * FINGER_WIDTH_MM.hypot(FINGER_THICKNESS_MM);
    pose.elbow.z < g.servo_radius_mm
        || pose.wrist.z < g.servo_radius_mm
        || pose.tip.z < 0.5 * FINGER_WIDTH_MM
        || pose.finger_ends.iter().any(|e| e.z < finger_r)
}
