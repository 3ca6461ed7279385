//! Every parameter of the simulator, with realistic defaults, an [`SimConfig::ideal`] variant,
//! JSON (de)serialisation that rejects unknown keys, and validation that names the bad key.
//!
//! Units: millimetres, degrees, microseconds (µs) of servo pulse width, kilograms, newton-metres;
//! grey levels are on the 0–255 scale of the 8-bit images. The world frame has its origin where
//! the arm's base axis meets the table top, `z` up, `x` forward (the arm's home direction), `y`
//! to the arm's left; the table top is the plane `z = 0`.

use serde::{Deserialize, Serialize};

use crate::error::{ArmSimError, Result};

/// Number of servos: base yaw, shoulder, elbow, wrist pitch, wrist roll, gripper.
pub const NUM_SERVOS: usize = 6;
/// Number of arm joints (the servos without the gripper).
pub const NUM_JOINTS: usize = 5;
/// Names of the servos, in command order.
pub const SERVO_NAMES: [&str; NUM_SERVOS] = [
    "base_yaw",
    "shoulder",
    "elbow",
    "wrist_pitch",
    "wrist_roll",
    "gripper",
];

/// Largest accepted arm dimension (mm): link lengths, finger sizes and radii (10 m; sizes near
/// `f64::MAX` overflow the kinematics).
pub const MAX_ARM_SIZE_MM: f64 = 10_000.0;
/// Largest accepted distance (mm) of the table's edges from the base (1 km). The table's
/// texture hashes integer lattice coordinates of the table point, which overflowed for
/// tables reaching ~1e20 mm.
pub const MAX_TABLE_EXTENT_MM: f64 = 1e6;
/// Largest accepted gravity sag (degrees) of a pitch joint with the arm stretched out
/// horizontally, the pose of the largest torques (the default arm: under 2°).
pub const MAX_SAG_DEG: f64 = 45.0;

/// The whole simulator configuration. `SimConfig::default()` is the realistic low-cost arm;
/// [`SimConfig::ideal`] the same arm and cameras with every non-ideality switched off.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SimConfig {
    /// Seed of every random draw (move noise, lighting, sensor noise).
    pub seed: u64,
    /// Link lengths, joint limits and body sizes.
    pub arm: ArmGeometry,
    /// One entry per servo, in command order (base yaw … gripper).
    pub servos: [ServoConfig; NUM_SERVOS],
    /// Gravity sag of the pitch joints.
    pub sag: SagConfig,
    /// One or two cameras.
    pub cameras: Vec<CameraConfig>,
    /// Table, clutter, light and image noise.
    pub scene: SceneConfig,
}

/// Kinematic and body dimensions of the Lynx-6-like arm.
///
/// Defaults follow the Lynxmotion Lynx-6 kit as far as it is documented (two 4.75-inch
/// aluminium links, a base about 3 inches tall, a small two-finger gripper; none of these
/// figures were confirmed for Paper C's arm, see docs/methods.md § Simulated arm), rounded to
/// millimetres: shoulder axis 75 mm above the table, upper arm 120 mm, forearm 120 mm, wrist-pitch
/// axis to the tool point 100 mm. Reach from the base axis is therefore 340 mm.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ArmGeometry {
    /// Height of the shoulder pitch axis above the table (mm).
    pub base_height_mm: f64,
    /// Shoulder axis to elbow axis (mm).
    pub upper_arm_mm: f64,
    /// Elbow axis to wrist-pitch axis (mm).
    pub forearm_mm: f64,
    /// Wrist-pitch axis to the tool point (the gripper tip, between the finger pads) (mm).
    pub hand_mm: f64,
    /// Finger length (mm); the fingers end `finger_pad_mm` beyond the tool point.
    pub finger_length_mm: f64,
    /// How far the finger ends reach beyond the tool point (mm).
    pub finger_pad_mm: f64,
    /// Gap between the fingers with the gripper servo at its upper angle limit (mm).
    pub max_opening_mm: f64,
    /// Mechanical limits `[min, max]` (degrees) of base yaw, shoulder, elbow, wrist pitch, wrist
    /// roll. A joint driven beyond them stalls at the stop (clamped and reported).
    ///
    /// Defaults: the servos' own ±90° travel, except the elbow, whose bracket stops it folding
    /// further than 150° onto the upper arm nor bending backwards beyond −30°.
    pub joint_limits_deg: [[f64; 2]; NUM_JOINTS],
    /// Radii of the drawn (and collision) capsules: upper arm, forearm (mm).
    pub link_radius_mm: [f64; 2],
    /// Radius of the servo bodies drawn at the shoulder, elbow and wrist (mm).
    pub servo_radius_mm: f64,
}

/// One RC servo: how a pulse width becomes a joint angle, and what goes wrong on the way.
///
/// Model (module [`crate::servo`]): the controller quantises the set-point to `quantum_us`;
/// the servo's electronics see `offset_us + gain · (p − centre_us)` (calibration error); the
/// motor stops as soon as it is within ±`deadband_us`/2 of that target (so where it stops depends
/// on the direction it came from); the gear train adds ±`backlash_deg`/2, again by direction;
/// each move ends with Gaussian noise of `end_noise_deg`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ServoConfig {
    /// Lowest accepted pulse width (µs); commands below are an error.
    pub min_us: f64,
    /// Highest accepted pulse width (µs); commands above are an error.
    pub max_us: f64,
    /// Pulse width of the nominal centre (µs).
    pub centre_us: f64,
    /// Nominal joint angle at `centre_us` (degrees).
    pub centre_deg: f64,
    /// Nominal degrees per µs (sign = mounting direction). Hobby servos: ≈ 0.09 (180° over
    /// 2000 µs).
    pub deg_per_us: f64,
    /// Calibration error: offset of this servo's centre (µs). Hobby servos centre within about
    /// ±50 µs of nominal.
    pub offset_us: f64,
    /// Calibration error: gain multiplier of the travel (1 = nominal). Typically within ±5 %.
    pub gain: f64,
    /// Set-point quantisation step of the controller (µs; 0 = none). The SSC-32 controller
    /// shipped with Lynxmotion arms resolves 1 µs.
    pub quantum_us: f64,
    /// Deadband width (µs; 0 = none). Analog hobby servos specify 4–8 µs.
    pub deadband_us: f64,
    /// Gear backlash (degrees; 0 = none). Plastic-geared hobby servos: 0.2–1°.
    pub backlash_deg: f64,
    /// Standard deviation of where a move ends (degrees; 0 = none).
    pub end_noise_deg: f64,
}

/// Gravity sag: each pitch joint (shoulder, elbow, wrist pitch) yields by `compliance · τ`,
/// where τ is the gravity torque of everything beyond the joint (sum of mass × g × horizontal
/// lever). A weak servo's proportional controller behaves like a torsion spring, so the sag
/// grows with the torque, i.e. with the horizontal reach.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SagConfig {
    /// Compliance of shoulder, elbow, wrist pitch (degrees per N·m; 0 = rigid).
    pub compliance_deg_per_nm: [f64; 3],
    /// Masses (kg) of upper arm, forearm (links, at their middles), elbow servo, wrist servos
    /// (at the wrist) and hand with gripper (at the middle of the hand).
    pub masses_kg: [f64; 5],
}

/// A pinhole camera with two-term radial distortion (Brown): a world point `X` goes to the
/// camera frame `Xc = R (X − C)` (x right, y down, z forward), to the normalised point
/// `(x, y) = (Xc/Zc, Yc/Zc)`, is distorted by `d = 1 + k1 r² + k2 r⁴` (`r² = x² + y²`) and
/// mapped to pixels `u = fx·d·x + cx`, `v = fy·d·y + cy` (pixel centres at integers).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraConfig {
    /// Image width (pixels).
    pub width: u32,
    /// Image height (pixels).
    pub height: u32,
    /// Focal length in pixels, horizontal.
    pub fx: f64,
    /// Focal length in pixels, vertical.
    pub fy: f64,
    /// Principal point, column.
    pub cx: f64,
    /// Principal point, row.
    pub cy: f64,
    /// First radial distortion coefficient (negative = barrel, as in cheap webcams).
    pub k1: f64,
    /// Second radial distortion coefficient.
    pub k2: f64,
    /// Camera centre in the world (mm).
    pub position_mm: [f64; 3],
    /// The world point on the optical axis (mm).
    pub look_at_mm: [f64; 3],
    /// Rotation about the optical axis (degrees), 0 = image rows parallel to the table.
    pub roll_deg: f64,
}

/// Kind of a clutter object.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ClutterKind {
    /// A box standing on the table.
    Box,
    /// A vertical cylinder standing on the table.
    Cylinder,
}

/// A static object on the table (drawn, but not an obstacle for the arm).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClutterObject {
    /// Box or cylinder.
    pub kind: ClutterKind,
    /// Centre of the footprint on the table (mm).
    pub centre_mm: [f64; 2],
    /// Box: length, width, height; cylinder: diameter, (ignored), height (mm).
    pub size_mm: [f64; 3],
    /// Rotation about the vertical (degrees).
    pub yaw_deg: f64,
    /// Reflectance in (0, 1].
    pub albedo: f64,
}

/// The table.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TableConfig {
    /// Extent of the table top along x (mm).
    pub x_range_mm: [f64; 2],
    /// Extent of the table top along y (mm).
    pub y_range_mm: [f64; 2],
    /// Mean reflectance of the table top.
    pub albedo: f64,
    /// Relative amplitude of the wood-like texture (0 = plain).
    pub texture_contrast: f64,
    /// Seed of the texture (the table's pattern, independent of the simulation seed).
    pub texture_seed: u64,
}

/// Scene, light and image noise.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneConfig {
    /// The table.
    pub table: TableConfig,
    /// Static objects on the table.
    pub clutter: Vec<ClutterObject>,
    /// Direction towards the (distant) light, world frame; need not be normalised.
    pub light_direction: [f64; 3],
    /// Ambient share of the illumination in [0, 1]; the rest is Lambertian.
    pub ambient: f64,
    /// Grey level of a white Lambertian surface facing the light.
    pub exposure: f64,
    /// Grey level of whatever lies beyond the table.
    pub background_grey: f64,
    /// Reflectance of the arm's links and servos.
    pub arm_albedo: f64,
    /// Reflectance of the gripper (palm and fingers).
    pub gripper_albedo: f64,
    /// Std. dev. of the per-frame global brightness gain (relative; 0 = steady light).
    pub lighting_gain_sigma: f64,
    /// Std. dev. of the per-frame brightness gradient across the half-image (relative).
    pub lighting_gradient_sigma: f64,
    /// Std. dev. of the per-pixel sensor noise (grey levels; 0 = none).
    pub sensor_noise_sigma: f64,
    /// Opt-in: a second object that moves on the table by itself (off when absent; an absent
    /// key reads as off and off is not written, so existing files and fixtures are unchanged).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub distractor: Option<Distractor>,
    /// Opt-in: lighting that drifts slowly during a run, on top of the per-frame changes (off
    /// when absent, as `distractor`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lighting_drift: Option<LightingDrift>,
}

/// A box on the table that slides round a circle by itself, one step per captured frame: a
/// moving thing the learner did not cause (its pose depends only on the frame count).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Distractor {
    /// Length, width and height of the box (mm); it stands on the table.
    pub size_mm: [f64; 3],
    /// Reflectance in (0, 1] (the gripper's brightness: `gripper_albedo`).
    pub albedo: f64,
    /// Centre of its circular path on the table (mm).
    pub path_centre_mm: [f64; 2],
    /// Radius of the path (mm; 0 = it only turns on the spot).
    pub path_radius_mm: f64,
    /// Frames per turn round the path (its yaw turns with it); must be at least 1.
    pub period_frames: f64,
}

impl Distractor {
    /// The box's footprint centre (mm) and yaw (radians) at frame `frame` (0 = first capture).
    pub fn placement(&self, frame: u64) -> ([f64; 2], f64) {
        let phase = std::f64::consts::TAU * (frame as f64 / self.period_frames);
        let (s, c) = phase.sin_cos();
        let centre = [
            self.path_centre_mm[0] + self.path_radius_mm * c,
            self.path_centre_mm[1] + self.path_radius_mm * s,
        ];
        (centre, phase)
    }
}

/// A slow sinusoidal drift of the global brightness gain: at frame `f` the gain is multiplied
/// by `1 + amplitude · sin(2π f / period_frames)`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightingDrift {
    /// Relative amplitude of the drift, in [0, 0.5].
    pub amplitude: f64,
    /// Frames per period; must be at least 1.
    pub period_frames: f64,
}

impl LightingDrift {
    /// The gain factor at frame `frame`.
    pub fn factor(&self, frame: u64) -> f64 {
        1.0 + self.amplitude * (std::f64::consts::TAU * frame as f64 / self.period_frames).sin()
    }
}

impl Default for SimConfig {
    fn default() -> Self {
        // Calibration errors: fixed, plausible values (a user's own arm replaces them).
        let offsets = [22.0, -35.0, 18.0, -27.0, 12.0, 0.0];
        let gains = [1.03, 0.96, 1.05, 0.98, 1.02, 1.0];
        let centres = [0.0, 0.0, 90.0, 0.0, 0.0, 0.0];
        let servos = std::array::from_fn(|i| ServoConfig {
            min_us: 500.0,
            max_us: 2500.0,
            centre_us: 1500.0,
            centre_deg: centres[i],
            deg_per_us: 0.09,
            offset_us: offsets[i],
            gain: gains[i],
            quantum_us: 1.0,
            deadband_us: 4.0,
            backlash_deg: 0.3,
            end_noise_deg: 0.05,
        });
        SimConfig {
            seed: 2009,
            arm: ArmGeometry::default(),
            servos,
            sag: SagConfig {
                compliance_deg_per_nm: [4.0, 5.0, 6.0],
                masses_kg: [0.035, 0.030, 0.055, 0.060, 0.050],
            },
            cameras: vec![
                CameraConfig::looking_at([470.0, -290.0, 330.0], [130.0, 0.0, 110.0]),
                CameraConfig::looking_at([470.0, 290.0, 330.0], [130.0, 0.0, 110.0]),
            ],
            scene: SceneConfig::default(),
        }
    }
}

impl Default for ArmGeometry {
    fn default() -> Self {
        ArmGeometry {
            base_height_mm: 75.0,
            upper_arm_mm: 120.0,
            forearm_mm: 120.0,
            hand_mm: 100.0,
            finger_length_mm: 50.0,
            finger_pad_mm: 8.0,
            max_opening_mm: 32.0,
            joint_limits_deg: [
                [-90.0, 90.0],
                [-90.0, 90.0],
                [-30.0, 150.0],
                [-90.0, 90.0],
                [-90.0, 90.0],
            ],
            link_radius_mm: [11.0, 9.0],
            servo_radius_mm: 14.0,
        }
    }
}

impl Default for SceneConfig {
    fn default() -> Self {
        let object = |kind, centre_mm, size_mm, yaw_deg, albedo| ClutterObject {
            kind,
            centre_mm,
            size_mm,
            yaw_deg,
            albedo,
        };
        SceneConfig {
            table: TableConfig {
                x_range_mm: [-300.0, 700.0],
                y_range_mm: [-600.0, 600.0],
                albedo: 0.55,
                texture_contrast: 0.25,
                texture_seed: 7,
            },
            clutter: vec![
                object(
                    ClutterKind::Box,
                    [390.0, -250.0],
                    [70.0, 50.0, 40.0],
                    25.0,
                    0.8,
                ),
                object(
                    ClutterKind::Cylinder,
                    [360.0, 260.0],
                    [45.0, 0.0, 90.0],
                    0.0,
                    0.35,
                ),
                object(
                    ClutterKind::Box,
                    [-130.0, 250.0],
                    [90.0, 60.0, 60.0],
                    -15.0,
                    0.25,
                ),
                object(
                    ClutterKind::Box,
                    [150.0, -330.0],
                    [40.0, 40.0, 25.0],
                    40.0,
                    0.9,
                ),
            ],
            light_direction: [0.3, 0.4, 1.0],
            ambient: 0.35,
            exposure: 255.0,
            background_grey: 40.0,
            arm_albedo: 0.3,
            gripper_albedo: 0.75,
            lighting_gain_sigma: 0.02,
            lighting_gradient_sigma: 0.01,
            sensor_noise_sigma: 2.0,
            distractor: None,
            lighting_drift: None,
        }
    }
}

impl CameraConfig {
    /// The same camera with its image scaled by `factor` (size rounded; focal lengths and
    /// principal point scaled so that the view is unchanged, pixel centres at integers).
    pub fn scaled(&self, factor: f64) -> Self {
        let mut c = self.clone();
        c.width = (self.width as f64 * factor).round().max(1.0) as u32;
        c.height = (self.height as f64 * factor).round().max(1.0) as u32;
        let fu = c.width as f64 / self.width as f64;
        let fv = c.height as f64 / self.height as f64;
        c.fx = self.fx * fu;
        c.fy = self.fy * fv;
        c.cx = (self.cx + 0.5) * fu - 0.5;
        c.cy = (self.cy + 0.5) * fv - 0.5;
        c
    }

    /// A 640×480 webcam-like camera (fx = fy = 560 px, mild barrel distortion k1 = −0.10,
    /// k2 = 0.01) at `position_mm`, looking at `look_at_mm`.
    pub fn looking_at(position_mm: [f64; 3], look_at_mm: [f64; 3]) -> Self {
        CameraConfig {
            width: 640,
            height: 480,
            fx: 560.0,
            fy: 560.0,
            cx: 319.5,
            cy: 239.5,
            k1: -0.10,
            k2: 0.01,
            position_mm,
            look_at_mm,
            roll_deg: 0.0,
        }
    }
}

impl SimConfig {
    /// This configuration with every camera's image scaled by `factor` (e.g. 0.25 for 160×120):
    /// the same view at a lower resolution, for quick tests and previews.
    pub fn with_image_scale(mut self, factor: f64) -> Self {
        for c in &mut self.cameras {
            *c = c.scaled(factor);
        }
        self
    }

    /// The same arm, cameras and scene with every non-ideality off: no calibration error,
    /// quantisation, deadband, backlash, move noise or sag, no per-frame lighting change and no
    /// sensor noise. Lens distortion, clutter and the opt-in scene features (a
    /// [`Distractor`], a [`LightingDrift`]) stay: they are part of the scene, not faults of the
    /// arm or the camera (the default scene has neither feature, so `ideal()`'s light is steady).
    pub fn ideal() -> Self {
        SimConfig::default().into_ideal()
    }

    /// This configuration with every non-ideality switched off (see [`SimConfig::ideal`]; the
    /// scene, including a distractor or a lighting drift, is kept).
    pub fn into_ideal(mut self) -> Self {
        for s in &mut self.servos {
            s.offset_us = 0.0;
            s.gain = 1.0;
            s.quantum_us = 0.0;
            s.deadband_us = 0.0;
            s.backlash_deg = 0.0;
            s.end_noise_deg = 0.0;
        }
        self.sag.compliance_deg_per_nm = [0.0; 3];
        self.scene.lighting_gain_sigma = 0.0;
        self.scene.lighting_gradient_sigma = 0.0;
        self.scene.sensor_noise_sigma = 0.0;
        self
    }

    /// Parses and validates a JSON configuration. Unknown keys and impossible values are errors
    /// naming the key.
    pub fn from_json(text: &str) -> Result<Self> {
        let config: SimConfig =
            serde_json::from_str(text).map_err(|e| ArmSimError::ConfigParse(e.to_string()))?;
        config.validate()?;
        Ok(config)
    }

    /// The configuration as pretty JSON.
    pub fn to_json(&self) -> String {
        let mut text = serde_json::to_string_pretty(self).expect("plain data serialises");
        text.push('\n');
        text
    }

    /// Reads and validates a JSON configuration file.
    pub fn read_file(path: impl AsRef<std::path::Path>) -> Result<Self> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|e| ArmSimError::ConfigIo {
            path: path.display().to_string(),
            message: e.to_string(),
        })?;
        Self::from_json(&text)
    }

    /// Writes the configuration as JSON (e.g. `SimConfig::default()` as a starting point for a
    /// user's own arm model): into a temporary file beside `path`, flushed and renamed into
    /// place, so a failed write leaves neither a partial file nor a damaged old one, and a
    /// concurrent reader sees the old file or the new one, whole. A configuration that
    /// [`read_file`](Self::read_file) would refuse is refused here, with the same error (see
    /// [`validate`](Self::validate)), before any file is touched: what is written reads back.
    pub fn write_file(&self, path: impl AsRef<std::path::Path>) -> Result<()> {
        use std::io::Write;
        use std::sync::atomic::{AtomicU64, Ordering};
        static WRITES: AtomicU64 = AtomicU64::new(0);
        self.validate()?;
        let path = path.as_ref();
        let io_err = |e: std::io::Error| ArmSimError::ConfigIo {
            path: path.display().to_string(),
            message: e.to_string(),
        };
        let name = path.file_name().ok_or_else(|| ArmSimError::ConfigIo {
            path: path.display().to_string(),
            message: "not a file path".into(),
        })?;
        let mut tmp_name = std::ffi::OsString::from(".");
        tmp_name.push(name);
        tmp_name.push(format!(
            ".tmp-{}-{}",
            std::process::id(),
            WRITES.fetch_add(1, Ordering::Relaxed)
        ));
        let tmp = path.with_file_name(tmp_name);
        let result = std::fs::File::create(&tmp)
            .and_then(|mut f| {
                f.write_all(self.to_json().as_bytes())?;
                f.sync_all()
            })
            .and_then(|()| std::fs::rename(&tmp, path));
        if result.is_err() {
            let _ = std::fs::remove_file(&tmp);
        }
        result.map_err(io_err)
    }

    /// Checks every value; the error names the first impossible key.
    pub fn validate(&self) -> Result<()> {
        let a = &self.arm;
        for (key, v) in [
            ("arm.base_height_mm", a.base_height_mm),
            ("arm.upper_arm_mm", a.upper_arm_mm),
            ("arm.forearm_mm", a.forearm_mm),
            ("arm.hand_mm", a.hand_mm),
            ("arm.finger_length_mm", a.finger_length_mm),
            ("arm.finger_pad_mm", a.finger_pad_mm),
            ("arm.max_opening_mm", a.max_opening_mm),
            ("arm.link_radius_mm[0]", a.link_radius_mm[0]),
            ("arm.link_radius_mm[1]", a.link_radius_mm[1]),
            ("arm.servo_radius_mm", a.servo_radius_mm),
        ] {
            // Sizes near f64::MAX overflowed the kinematics to a NaN pose.
            if v > MAX_ARM_SIZE_MM {
                return invalid(
                    key,
                    &format!("unrealistically large (> {MAX_ARM_SIZE_MM} mm)"),
                );
            }
        }
        positive("arm.base_height_mm", a.base_height_mm)?;
        positive("arm.upper_arm_mm", a.upper_arm_mm)?;
        positive("arm.forearm_mm", a.forearm_mm)?;
        positive("arm.hand_mm", a.hand_mm)?;
        positive("arm.finger_length_mm", a.finger_length_mm)?;
        non_negative("arm.finger_pad_mm", a.finger_pad_mm)?;
        if a.finger_pad_mm >= a.finger_length_mm || a.finger_length_mm >= a.hand_mm {
            return invalid(
                "arm.finger_length_mm",
                "need finger_pad_mm < finger_length_mm < hand_mm",
            );
        }
        non_negative("arm.max_opening_mm", a.max_opening_mm)?;
        for (j, [lo, hi]) in a.joint_limits_deg.iter().enumerate() {
            let key = format!("arm.joint_limits_deg[{j}]");
            if !(lo.is_finite() && hi.is_finite() && lo < hi && *lo >= -180.0 && *hi <= 180.0) {
                return invalid(&key, "need finite -180 <= min < max <= 180");
            }
        }
        for (i, r) in a.link_radius_mm.iter().enumerate() {
            positive(&format!("arm.link_radius_mm[{i}]"), *r)?;
        }
        positive("arm.servo_radius_mm", a.servo_radius_mm)?;
        for (i, s) in self.servos.iter().enumerate() {
            let key = |k: &str| format!("servos[{i}].{k}");
            finite(&key("min_us"), s.min_us)?;
            finite(&key("max_us"), s.max_us)?;
            if !(s.min_us > 0.0 && s.min_us < s.max_us) {
                return invalid(&key("max_us"), "need 0 < min_us < max_us");
            }
            if !(s.centre_us >= s.min_us && s.centre_us <= s.max_us) {
                return invalid(&key("centre_us"), "must lie within [min_us, max_us]");
            }
            finite(&key("centre_deg"), s.centre_deg)?;
            finite(&key("deg_per_us"), s.deg_per_us)?;
            if s.deg_per_us == 0.0 || s.deg_per_us.abs() > 1.0 {
                return invalid(&key("deg_per_us"), "need 0 < |deg_per_us| <= 1");
            }
            finite(&key("offset_us"), s.offset_us)?;
            if s.offset_us.abs() > 0.25 * (s.max_us - s.min_us) {
                return invalid(&key("offset_us"), "more than a quarter of the servo range");
            }
            if !(s.gain.is_finite() && s.gain > 0.5 && s.gain < 2.0) {
                return invalid(&key("gain"), "need 0.5 < gain < 2");
            }
            for (k, v, max) in [
                ("quantum_us", s.quantum_us, 100.0),
                ("deadband_us", s.deadband_us, 100.0),
                ("backlash_deg", s.backlash_deg, 20.0),
                ("end_noise_deg", s.end_noise_deg, 10.0),
            ] {
                non_negative(&key(k), v)?;
                if v > max {
                    return invalid(&key(k), &format!("unrealistically large (> {max})"));
                }
            }
        }
        for (i, c) in self.sag.compliance_deg_per_nm.iter().enumerate() {
            non_negative(&format!("sag.compliance_deg_per_nm[{i}]"), *c)?;
            if *c > 100.0 {
                return invalid(
                    &format!("sag.compliance_deg_per_nm[{i}]"),
                    "unrealistically large (> 100)",
                );
            }
        }
        for (i, m) in self.sag.masses_kg.iter().enumerate() {
            non_negative(&format!("sag.masses_kg[{i}]"), *m)?;
        }
        // The sag is bounded by the torques of the arm stretched out horizontally (every lever
        // at its longest). Masses in grams instead of kilograms sagged joints by thousands of
        // degrees, far beyond any joint limit and beyond the small-sag model of `apply_sag`.
        let stretched = [0.0, 90.0, 0.0, 0.0, 0.0, 0.0];
        let worst = crate::kinematics::gravity_torques(&self.arm, &self.sag, &stretched);
        for (j, (&c, tau)) in self.sag.compliance_deg_per_nm.iter().zip(worst).enumerate() {
            let sag = c * tau;
            if c > 0.0 && (sag.is_nan() || sag.abs() > MAX_SAG_DEG) {
                return invalid(
                    "sag.masses_kg",
                    &format!(
                        "with compliance_deg_per_nm[{j}] = {c} joint {} would sag {sag:.3e}° \
                         at full horizontal reach (more than {MAX_SAG_DEG}°; masses in kg?)",
                        j + 1
                    ),
                );
            }
        }
        if self.cameras.is_empty() || self.cameras.len() > 2 {
            return invalid("cameras", "need one or two cameras");
        }
        for (i, c) in self.cameras.iter().enumerate() {
            c.validate(i)?;
        }
        self.scene.validate()
    }
}

impl CameraConfig {
    /// Checks the camera's values (`index` names it in errors) and that it sees the scene.
    pub fn validate(&self, index: usize) -> Result<()> {
        crate::camera::Camera::new(self, index).map(|_| ())
    }

    /// Checks the camera's own values (image size, intrinsics, an invertible lens over the
    /// image, finite pose), not yet where it looks: [`crate::Camera::new`] runs this first.
    pub(crate) fn validate_values(&self, index: usize) -> Result<()> {
        let key = |k: &str| format!("cameras[{index}].{k}");
        if !(16..=8192).contains(&self.width) {
            return invalid(&key("width"), "need 16..=8192 pixels");
        }
        if !(16..=8192).contains(&self.height) {
            return invalid(&key("height"), "need 16..=8192 pixels");
        }
        positive(&key("fx"), self.fx)?;
        positive(&key("fy"), self.fy)?;
        finite(&key("cx"), self.cx)?;
        finite(&key("cy"), self.cy)?;
        finite(&key("k1"), self.k1)?;
        finite(&key("k2"), self.k2)?;
        finite(&key("roll_deg"), self.roll_deg)?;
        for (k, v) in [
            ("position_mm", self.position_mm),
            ("look_at_mm", self.look_at_mm),
        ] {
            if v.iter().any(|x| !x.is_finite()) {
                return invalid(&key(k), "not finite");
            }
        }
        // The lens model must be invertible over the image: r·(1 + k1 r² + k2 r⁴) increasing
        // up to the radius of the farthest image corner.
        let corner = [
            (0.0, 0.0),
            (self.width as f64 - 1.0, 0.0),
            (0.0, self.height as f64 - 1.0),
            (self.width as f64 - 1.0, self.height as f64 - 1.0),
        ]
        .iter()
        .map(|(u, v)| {
            (((u - self.cx) / self.fx).powi(2) + ((v - self.cy) / self.fy).powi(2)).sqrt()
        })
        .fold(0.0f64, f64::max);
        let mut r = 0.0;
        loop {
            let r2 = r * r;
            let slope = 1.0 + 3.0 * self.k1 * r2 + 5.0 * self.k2 * r2 * r2;
            if slope <= 0.05 {
                return invalid(
                    &key("k1"),
                    "radial distortion folds over inside the image (not invertible)",
                );
            }
            if r * (1.0 + self.k1 * r2 + self.k2 * r2 * r2) >= corner {
                break;
            }
            r += 0.005;
            if r > 10.0 {
                return invalid(&key("fx"), "field of view too wide");
            }
        }
        Ok(())
    }
}

impl SceneConfig {
    fn validate(&self) -> Result<()> {
        let t = &self.table;
        for (k, r) in [("x_range_mm", t.x_range_mm), ("y_range_mm", t.y_range_mm)] {
            if !(r[0].is_finite() && r[1].is_finite() && r[0] <= 0.0 && r[1] > 0.0) {
                return invalid(
                    &format!("scene.table.{k}"),
                    "need finite min <= 0 < max (the base stands on the table)",
                );
            }
            if r[0] < -MAX_TABLE_EXTENT_MM || r[1] > MAX_TABLE_EXTENT_MM {
                return invalid(
                    &format!("scene.table.{k}"),
                    &format!("unrealistically large (beyond ±{MAX_TABLE_EXTENT_MM} mm)"),
                );
            }
        }
        unit_interval("scene.table.albedo", t.albedo)?;
        unit_interval("scene.table.texture_contrast", t.texture_contrast)?;
        for (i, o) in self.clutter.iter().enumerate() {
            let key = |k: &str| format!("scene.clutter[{i}].{k}");
            if o.centre_mm.iter().any(|v| !v.is_finite()) {
                return invalid(&key("centre_mm"), "not finite");
            }
            positive(&key("size_mm[0]"), o.size_mm[0])?;
            if o.kind == ClutterKind::Box {
                positive(&key("size_mm[1]"), o.size_mm[1])?;
            }
            positive(&key("size_mm[2]"), o.size_mm[2])?;
            finite(&key("yaw_deg"), o.yaw_deg)?;
            unit_interval(&key("albedo"), o.albedo)?;
        }
        let l = self.light_direction;
        if l.iter().any(|v| !v.is_finite()) || l[2] <= 0.0 {
            return invalid(
                "scene.light_direction",
                "need finite with z > 0 (light above)",
            );
        }
        unit_interval("scene.ambient", self.ambient)?;
        positive("scene.exposure", self.exposure)?;
        if !(0.0..=255.0).contains(&self.background_grey) {
            return invalid("scene.background_grey", "need 0..=255");
        }
        unit_interval("scene.arm_albedo", self.arm_albedo)?;
        unit_interval("scene.gripper_albedo", self.gripper_albedo)?;
        for (k, v, max) in [
            ("lighting_gain_sigma", self.lighting_gain_sigma, 0.5),
            ("lighting_gradient_sigma", self.lighting_gradient_sigma, 0.5),
            ("sensor_noise_sigma", self.sensor_noise_sigma, 64.0),
        ] {
            non_negative(&format!("scene.{k}"), v)?;
            if v > max {
                return invalid(&format!("scene.{k}"), &format!("too large (> {max})"));
            }
        }
        if let Some(d) = &self.distractor {
            for (k, v) in d.size_mm.iter().enumerate() {
                positive(&format!("scene.distractor.size_mm[{k}]"), *v)?;
            }
            if d.albedo <= 0.0 {
                return invalid("scene.distractor.albedo", "must lie in (0, 1]");
            }
            unit_interval("scene.distractor.albedo", d.albedo)?;
            if d.path_centre_mm.iter().any(|v| !v.is_finite()) {
                return invalid("scene.distractor.path_centre_mm", "not finite");
            }
            non_negative("scene.distractor.path_radius_mm", d.path_radius_mm)?;
            at_least_one_frame("scene.distractor.period_frames", d.period_frames)?;
        }
        if let Some(l) = &self.lighting_drift {
            non_negative("scene.lighting_drift.amplitude", l.amplitude)?;
            if l.amplitude > 0.5 {
                return invalid("scene.lighting_drift.amplitude", "too large (> 0.5)");
            }
            at_least_one_frame("scene.lighting_drift.period_frames", l.period_frames)?;
        }
        Ok(())
    }
}

fn invalid<T>(key: &str, reason: &str) -> Result<T> {
    Err(ArmSimError::InvalidConfig {
        key: key.to_string(),
        reason: reason.to_string(),
    })
}

fn finite(key: &str, v: f64) -> Result<()> {
    if v.is_finite() {
        Ok(())
    } else {
        invalid(key, "not finite")
    }
}

fn positive(key: &str, v: f64) -> Result<()> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        invalid(key, "must be finite and > 0")
    }
}

/// A period in frames: finite and at least 1 (a period below one frame is aliasing, and tiny
/// ones overflowed `frame / period` to +∞, making the phase NaN).
fn at_least_one_frame(key: &str, v: f64) -> Result<()> {
    if v.is_finite() && v >= 1.0 {
        Ok(())
    } else {
        invalid(key, "must be finite and >= 1 frame")
    }
}

fn non_negative(key: &str, v: f64) -> Result<()> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        invalid(key, "must be finite and >= 0")
    }
}

fn unit_interval(key: &str, v: f64) -> Result<()> {
    if v.is_finite() && (0.0..=1.0).contains(&v) {
        Ok(())
    } else {
        invalid(key, "must lie in [0, 1]")
    }
}
