//! The simulator: the learner's two calls ([`ArmSim::command`], [`ArmSim::capture`]) and the
//! evaluation-only ground truth ([`ArmSim::inspect`]).

use image::GrayImage;
use nalgebra::Vector3;
use rand::SeedableRng;
use rand::rngs::Xoshiro256PlusPlus;
use rand_distr::{Distribution, StandardNormal};

use crate::camera::Camera;
use crate::config::{NUM_JOINTS, NUM_SERVOS, SimConfig};
use crate::error::{ArmSimError, Result};
use crate::kinematics::{ArmPose, JointAngles, apply_sag, below_table, forward_kinematics};
use crate::render::{CameraView, Lighting};
use crate::servo::{ServoState, nominal_angle};

/// Servo set-points (µs) of the home pose: every servo at its centre.
pub fn home_set_points(config: &SimConfig) -> [f64; NUM_SERVOS] {
    std::array::from_fn(|i| config.servos[i].centre_us)
}

/// What happened during the last command (ground truth, for evaluation).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MoveReport {
    /// Servos whose motor moved (outside the deadband).
    pub moved: [bool; NUM_SERVOS],
    /// Joints stopped by their mechanical limit.
    pub limited: [bool; NUM_SERVOS],
    /// Whether the move was stopped by the table: the arm stalls where it first touches it.
    pub table_contact: bool,
    /// Fraction of the joint-space move executed before the table stopped it (1 = all; 0 in
    /// the report before the first command, when no move was made).
    pub executed_fraction: f64,
}

/// The simulated arm with its cameras.
///
/// ```
/// use arm_sim::{ArmSim, SimConfig};
/// // Quarter-size images (160×120) keep the example quick; the default is 640×480.
/// let mut sim = ArmSim::new(SimConfig::default().with_image_scale(0.25)).unwrap();
/// sim.command(&[1500.0, 1300.0, 1600.0, 1400.0, 1500.0, 1000.0]).unwrap();
/// let images = sim.capture();
/// assert_eq!((images.len(), images[0].width(), images[0].height()), (2, 160, 120));
/// // Out of the servo range: a typed error, and the arm does not move.
/// assert!(sim.command(&[1500.0, 2600.0, 1500.0, 1500.0, 1500.0, 1500.0]).is_err());
/// ```
pub struct ArmSim {
    config: SimConfig,
    views: Vec<CameraView>,
    servos: [ServoState; NUM_SERVOS],
    angles: JointAngles,
    pose: ArmPose,
    last_move: MoveReport,
    last_set_points: [f64; NUM_SERVOS],
    arm_rng: Xoshiro256PlusPlus,
    image_rng: Xoshiro256PlusPlus,
    frames: u64,
}

impl ArmSim {
    /// Validates the configuration, sets up each camera's renderer (its static background is
    /// ray-traced once, on the first [`capture`](Self::capture)) and puts the arm at rest in its
    /// home pose (every servo at its centre pulse).
    pub fn new(config: SimConfig) -> Result<Self> {
        config.validate()?;
        let mut views = Vec::with_capacity(config.cameras.len());
        for (i, c) in config.cameras.iter().enumerate() {
            views.push(CameraView::new(Camera::new(c, i)?, &config.scene));
        }
        let home = home_set_points(&config);
        let servos = std::array::from_fn(|i| ServoState::at_rest(&config.servos[i], home[i]));
        let arm_rng = Xoshiro256PlusPlus::seed_from_u64(config.seed);
        let image_rng = Xoshiro256PlusPlus::seed_from_u64(config.seed ^ 0x001A_6E5E_ED0F_1A6E);
        let mut sim = ArmSim {
            angles: [0.0; NUM_SERVOS],
            pose: forward_kinematics(&config.arm, &[0.0; NUM_SERVOS]),
            config,
            views,
            servos,
            last_move: MoveReport::default(),
            last_set_points: home,
            arm_rng,
            image_rng,
            frames: 0,
        };
        let outputs = sim.limited_outputs(&mut [false; NUM_SERVOS]);
        sim.settle(&outputs);
        if below_table(&sim.config.arm, &sim.pose) {
            return Err(ArmSimError::InvalidConfig {
                key: "servos".into(),
                reason: "the home pose (all servos centred) is below the table".into(),
            });
        }
        Ok(sim)
    }

    /// Number of servos (commands hold one set-point each): 6.
    pub fn num_servos(&self) -> usize {
        NUM_SERVOS
    }

    /// Number of cameras (images per capture).
    pub fn num_cameras(&self) -> usize {
        self.views.len()
    }

    /// The accepted pulse-width range `[min, max]` (µs) of servo `i` (public servo data, not
    /// ground truth).
    pub fn servo_range(&self, i: usize) -> Option<[f64; 2]> {
        self.config.servos.get(i).map(|s| [s.min_us, s.max_us])
    }

    /// Sends one set-point per servo (µs, order: base yaw, shoulder, elbow, wrist pitch, wrist
    /// roll, gripper). The arm moves through its servo model; joints that reach a mechanical
    /// stop or a pose that would enter the table stall there (see [`Inspection::last_move`]).
    ///
    /// Errors (nothing moves): wrong length, non-finite or out-of-range set-points.
    pub fn command(&mut self, set_points: &[f64]) -> Result<()> {
        check_set_points(&self.config, set_points)?;
        let before = self.servos.clone();
        let previous: [f64; NUM_SERVOS] = std::array::from_fn(|i| before[i].output_deg);
        let mut report = MoveReport {
            executed_fraction: 1.0,
            ..MoveReport::default()
        };
        for (i, &p) in set_points.iter().enumerate() {
            // Cannot fail: the set-points were checked above and the configuration when the
            // simulator was built, so no servo changes before a refusal.
            report.moved[i] = self.servos[i].step(&self.config.servos[i], p, &mut self.arm_rng)?;
        }
        let target = self.limited_outputs(&mut report.limited);
        let g = &self.config.arm;
        let pose_of =
            |out: &[f64; NUM_SERVOS]| forward_kinematics(g, &apply_sag(g, &self.config.sag, out));
        if below_table(g, &pose_of(&target)) {
            // Stall where the straight joint-space path first touches the table.
            let (mut lo, mut hi) = (0.0f64, 1.0f64);
            for _ in 0..30 {
                let mid = 0.5 * (lo + hi);
                if below_table(g, &pose_of(&lerp(&previous, &target, mid))) {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            let stalled = lerp(&previous, &target, lo);
            for (i, s) in self.servos.iter_mut().enumerate() {
                s.stall_at_checked(&self.config.servos[i], stalled[i]);
            }
            report.table_contact = true;
            report.executed_fraction = lo;
            self.settle(&stalled);
        } else {
            self.settle(&target);
        }
        self.last_move = report;
        self.last_set_points.copy_from_slice(set_points);
        Ok(())
    }

    /// One 8-bit image per camera of the current scene, with this frame's lighting change and
    /// sensor noise. Deterministic: the same seed, commands and captures give the same bytes.
    pub fn capture(&mut self) -> Vec<GrayImage> {
        let scene = &self.config.scene;
        let drift = scene
            .lighting_drift
            .as_ref()
            .map_or(1.0, |d| d.factor(self.frames));
        let gain = drift * (1.0 + scene.lighting_gain_sigma * normal(&mut self.image_rng));
        let distractor = scene
            .distractor
            .as_ref()
            .map(|d| (d, d.placement(self.frames)));
        let mut images = Vec::with_capacity(self.views.len());
        for view in &mut self.views {
            let lighting = Lighting {
                gain: gain as f32,
                grad_x: (scene.lighting_gradient_sigma * normal(&mut self.image_rng)) as f32,
                grad_y: (scene.lighting_gradient_sigma * normal(&mut self.image_rng)) as f32,
            };
            images.push(view.render(
                &self.config.arm,
                scene,
                &self.pose,
                distractor,
                lighting,
                &mut self.image_rng,
            ));
        }
        self.frames += 1;
        images
    }

    /// Evaluation-only access to the ground truth. A learner must not use it.
    pub fn inspect(&self) -> Inspection<'_> {
        Inspection { sim: self }
    }

    /// Servo outputs clamped to the joint limits (marks `limited`), stalling clamped servos.
    fn limited_outputs(&mut self, limited: &mut [bool; NUM_SERVOS]) -> [f64; NUM_SERVOS] {
        let limits = self.config.arm.joint_limits_deg;
        std::array::from_fn(|i| {
            let out = self.servos[i].output_deg;
            let [lo, hi] = if i < NUM_JOINTS {
                limits[i]
            } else {
                [-90.0, 90.0]
            };
            // `clamp` cannot panic: the configuration's limits were validated finite with
            // lo < hi (`SimConfig::validate`, in `new`), the gripper's are constants.
            let clamped = out.clamp(lo, hi);
            if clamped != out {
                limited[i] = true;
                self.servos[i].stall_at_checked(&self.config.servos[i], clamped);
            }
            clamped
        })
    }

    fn settle(&mut self, outputs: &[f64; NUM_SERVOS]) {
        self.angles = apply_sag(&self.config.arm, &self.config.sag, outputs);
        self.pose = forward_kinematics(&self.config.arm, &self.angles);
    }
}

fn normal(rng: &mut Xoshiro256PlusPlus) -> f64 {
    StandardNormal.sample(rng)
}

fn lerp(a: &[f64; NUM_SERVOS], b: &[f64; NUM_SERVOS], t: f64) -> [f64; NUM_SERVOS] {
    std::array::from_fn(|i| a[i] + t * (b[i] - a[i]))
}

/// Ground truth of an [`ArmSim`], for tests and evaluation only.
pub struct Inspection<'a> {
    sim: &'a ArmSim,
}

impl<'a> Inspection<'a> {
    /// The configuration in use, including the calibration errors a learner must not know.
    pub fn config(&self) -> &'a SimConfig {
        &self.sim.config
    }

    /// True joint angles (degrees) after every non-ideality, including sag.
    pub fn joint_angles(&self) -> JointAngles {
        self.sim.angles
    }

    /// The servos' output angles before gravity sag (degrees).
    pub fn unloaded_angles(&self) -> JointAngles {
        std::array::from_fn(|i| self.sim.servos[i].output_deg)
    }

    /// The true 3-D pose.
    pub fn pose(&self) -> &ArmPose {
        &self.sim.pose
    }

    /// The true gripper tip (tool point) in the world (mm).
    pub fn tip(&self) -> Vector3<f64> {
        self.sim.pose.tip
    }

    /// The last accepted set-points (µs).
    pub fn last_set_points(&self) -> [f64; NUM_SERVOS] {
        self.sim.last_set_points
    }

    /// What happened during the last command.
    pub fn last_move(&self) -> &MoveReport {
        &self.sim.last_move
    }

    /// Camera `i`.
    pub fn camera(&self, i: usize) -> Result<&Camera> {
        self.sim
            .views
            .get(i)
            .map(|v| &v.camera)
            .ok_or(ArmSimError::NoSuchCamera {
                camera: i,
                count: self.sim.views.len(),
            })
    }

    /// Projects a world point (mm) into camera `i` (pixels `[u, v]`).
    pub fn project(&self, i: usize, p: &Vector3<f64>) -> Result<[f64; 2]> {
        self.camera(i)?.project(p)
    }

    /// The true gripper tip (the tool point, [`ArmPose::tip`]) in every camera's image.
    ///
    /// Nothing in the image marks this point: it lies `finger_pad_mm` behind the finger ends.
    /// The tip a percept finds is [`Inspection::finger_middle_pixels`].
    pub fn tip_pixels(&self) -> Result<Vec<[f64; 2]>> {
        self.pixels_of(&self.sim.pose.tip)
    }

    /// The middle of the finger ends ([`ArmPose::finger_middle`]) in every camera's image: the
    /// true tip as the heuristic percepts define it (the middle of the gripper's far end), the
    /// point studies and tests measure percepts against. Unlike [`Inspection::tip_pixels`]
    /// (the tool point, `finger_pad_mm` further back) it is a point the images show.
    pub fn finger_middle_pixels(&self) -> Result<Vec<[f64; 2]>> {
        self.pixels_of(&self.sim.pose.finger_middle())
    }

    /// Projects the world point `p` (mm) into every camera.
    fn pixels_of(&self, p: &Vector3<f64>) -> Result<Vec<[f64; 2]>> {
        (0..self.sim.views.len())
            .map(|i| self.project(i, p))
            .collect()
    }

    /// The part label of every pixel of camera `i`'s last capture (0 background,
    /// [`crate::LABEL_ARM`], [`crate::LABEL_PALM`], [`crate::LABEL_FINGER_A`],
    /// [`crate::LABEL_FINGER_B`]); all zero before the first capture.
    pub fn labels(&self, i: usize) -> Result<GrayImage> {
        let camera = self.camera(i)?;
        let v = &self.sim.views[i];
        if v.labels.is_empty() {
            // No capture yet: the label buffer is allocated with the first frame.
            return Ok(GrayImage::new(camera.width, camera.height));
        }
        Ok(
            GrayImage::from_raw(v.camera.width, v.camera.height, v.labels.clone())
                .expect("buffer matches size"),
        )
    }

    /// The joint angles (degrees) a perfect arm would take for `set_points`: the nominal servo
    /// mapping, no calibration error, backlash or sag (for the upper-bound baseline).
    ///
    /// # Errors
    /// As [`ArmSim::command`]: a set-point that is not finite or outside its servo's range.
    pub fn nominal_angles(&self, set_points: &[f64; NUM_SERVOS]) -> Result<JointAngles> {
        check_set_points(&self.sim.config, set_points)?;
        Ok(std::array::from_fn(|i| {
            nominal_angle(&self.sim.config.servos[i], set_points[i])
        }))
    }

    /// Number of frames captured so far.
    pub fn frames(&self) -> u64 {
        self.sim.frames
    }
}

/// One set-point per servo, each finite and inside its servo's range.
fn check_set_points(config: &SimConfig, set_points: &[f64]) -> Result<()> {
    if set_points.len() != NUM_SERVOS {
        return Err(ArmSimError::WrongCommandLength {
            expected: NUM_SERVOS,
            got: set_points.len(),
        });
    }
    for (i, (&p, s)) in set_points.iter().zip(&config.servos).enumerate() {
        if !p.is_finite() {
            return Err(ArmSimError::NonFiniteCommand { servo: i, value: p });
        }
        if p < s.min_us || p > s.max_us {
            return Err(ArmSimError::CommandOutOfRange {
                servo: i,
                value: p,
                min: s.min_us,
                max: s.max_us,
            });
        }
    }
    Ok(())
}
