//! `arm-sim` connected to `servo-loop`: the evaluation plant (percept = servo-loop's own
//! `VisualPlant` with the learned recognition on rendered images, so the study does not repeat
//! its mapping of commands and percepts; or the simulator's true tip projection plus detection
//! noise; with a ground-truth log) and the analytic image Jacobian of the ideal arm. The robot
//! adapter is `visguide::SimRobot`, re-exported here.

use arm_sim::{ArmSim, NUM_SERVOS, forward_kinematics};
use nalgebra::{DMatrix, Vector3};
use rand::SeedableRng;
use rand::rngs::Xoshiro256PlusPlus;
use rand_distr::{Distribution, Normal};
use servo_loop::{
    ControlSpace, Observation, PerceptPolicy, Plant, Robot, ServoError, TipModel, VisualPlant,
};

/// `ArmSim` as a [`servo_loop::Robot`]: the one adapter, in the `visguide` crate.
pub use visguide::SimRobot;

/// Ground truth after one executed move.
#[derive(Debug, Clone, Copy)]
pub struct Truth {
    /// True tip per camera (pixels), at most two cameras.
    pub px: [[f64; 2]; 2],
    /// True tip (mm).
    pub mm: [f64; 3],
}

/// Ground truth of the simulator's current state.
pub fn truth(sim: &ArmSim) -> Truth {
    let tips = sim.inspect().tip_pixels().unwrap_or_default();
    let mut px = [[f64::NAN; 2]; 2];
    for (p, t) in px.iter_mut().zip(&tips) {
        *p = *t;
    }
    let tip = sim.inspect().tip();
    Truth {
        px,
        mm: [tip.x, tip.y, tip.z],
    }
}

/// One accepted percept with the command it was taken at, and the plant's observation count
/// then (1-based; a training move observes once, so it is the move's index).
#[derive(Debug, Clone)]
pub struct Sample {
    pub observation: usize,
    pub x: Vec<f64>,
    pub y: Vec<f64>,
}

/// How a [`SimPlant`] perceives.
enum Percept {
    /// The true tip projection plus Gaussian detection noise (a control-only check).
    Simulated {
        robot: Box<SimRobot>,
        noise: Normal<f64>,
        rng: Xoshiro256PlusPlus,
    },
    /// servo-loop's own visual plant ([`VisualPlant`]): the learned recogniser on the rendered
    /// images, averaged, re-captured and refused by its policy.
    Recognised(Box<VisualPlant<SimRobot, TipModel>>),
}

/// The evaluation plant: controlled servos `controlled`, the others held at `rest`
/// (servo_loop's [`ControlSpace`]); the percept is servo_loop's [`VisualPlant`] with the learned
/// recogniser ([`SimPlant::with_recogniser`]) or the true tip projection plus Gaussian
/// detection noise of `noise_px`; every observation's ground truth is logged.
pub struct SimPlant {
    space: ControlSpace,
    percept: Percept,
    pub cameras: usize,
    pub size: [u32; 2],
    pub log: Vec<Truth>,
    /// Every accepted percept with its command (the training samples, [`Sample`]).
    pub samples: Vec<Sample>,
    observations: usize,
    last_command: Option<Vec<f64>>,
}

impl SimPlant {
    /// The plant with the simulated percept (true projection + noise of `noise_px`, `seed`).
    pub fn new(
        sim: ArmSim,
        controlled: &[usize],
        rest: [f64; NUM_SERVOS],
        noise_px: f64,
        seed: u64,
    ) -> Self {
        let cameras = sim.num_cameras().min(2);
        let c = &sim.inspect().config().cameras[0];
        let size = [c.width, c.height];
        SimPlant {
            space: ControlSpace {
                controlled: controlled.to_vec(),
                rest: rest.to_vec(),
                gripper: None,
            },
            percept: Percept::Simulated {
                robot: Box::new(SimRobot::new(sim)),
                noise: Normal::new(0.0, noise_px.max(0.0)).expect("valid σ"),
                rng: Xoshiro256PlusPlus::seed_from_u64(seed),
            },
            cameras,
            size,
            log: Vec::new(),
            samples: Vec::new(),
            observations: 0,
            last_command: None,
        }
    }

    /// The same plant perceiving through servo_loop's [`VisualPlant`] with `model` under
    /// `policy` (commands sent so far are kept). Errors: a control space that does not fit the
    /// arm, a model that cannot locate, an invalid policy.
    pub fn with_recogniser(
        self,
        model: TipModel,
        policy: PerceptPolicy,
    ) -> servo_loop::Result<Self> {
        let robot = match self.percept {
            Percept::Simulated { robot, .. } => *robot,
            Percept::Recognised(v) => v.into_robot(),
        };
        let mut visual = VisualPlant::new(robot, self.space.clone(), model)?;
        visual.set_policy(policy)?;
        Ok(SimPlant {
            percept: Percept::Recognised(Box::new(visual)),
            ..self
        })
    }

    fn robot(&self) -> &SimRobot {
        match &self.percept {
            Percept::Simulated { robot, .. } => robot,
            Percept::Recognised(v) => v.robot(),
        }
    }

    /// The simulator (ground truth through `sim().inspect()`).
    pub fn sim(&self) -> &ArmSim {
        self.robot().sim()
    }

    /// The simulator, mutably (commands sent through it are not counted).
    pub fn sim_mut(&mut self) -> &mut ArmSim {
        match &mut self.percept {
            Percept::Simulated { robot, .. } => &mut robot.0,
            Percept::Recognised(v) => &mut v.robot_mut().0,
        }
    }

    /// Commands sent through the plant (every `act`, approach pre-positions included).
    pub fn commands(&self) -> usize {
        self.robot().commands()
    }

    /// The full command of the arm for the controlled set-points `y` (the held servos at
    /// their rest set-points; servo_loop's `ControlSpace::full_command`).
    pub fn full_command(&self, y: &[f64]) -> servo_loop::Result<[f64; NUM_SERVOS]> {
        let mut c = [0.0; NUM_SERVOS];
        c.copy_from_slice(&self.space.full_command(y)?);
        Ok(c)
    }

    /// Checks the recognised percept's servo percepts against the commanded move
    /// (`servo_loop::VisualPlant::set_motion_check`; nothing for the simulated percept).
    pub fn set_motion_check(
        &mut self,
        check: Option<servo_loop::MotionCheck>,
    ) -> servo_loop::Result<()> {
        match &mut self.percept {
            Percept::Recognised(v) => v.set_motion_check(check),
            Percept::Simulated { .. } => Ok(()),
        }
    }

    /// Percepts the recognised percept re-captured, refused for their certainty and refused by
    /// the motion check so far (zeros for the simulated percept).
    pub fn percept_counts(&self) -> [usize; 3] {
        match &self.percept {
            Percept::Recognised(v) => [v.recaptured(), v.refused(), v.inconsistent()],
            Percept::Simulated { .. } => [0; 3],
        }
    }

    /// Changes the recognised percept's policy (nothing for the simulated percept). Errors: an
    /// invalid policy.
    pub fn set_policy(
        &mut self,
        f: impl FnOnce(&PerceptPolicy) -> PerceptPolicy,
    ) -> servo_loop::Result<()> {
        match &mut self.percept {
            Percept::Recognised(v) => {
                let policy = f(v.policy());
                v.set_policy(policy)
            }
            Percept::Simulated { .. } => Ok(()),
        }
    }
}

impl Plant for SimPlant {
    fn percept_dim(&self) -> usize {
        2 * self.cameras
    }
    fn command_dim(&self) -> usize {
        self.space.controlled.len()
    }
    fn command_range(&self, j: usize) -> [f64; 2] {
        self.sim()
            .servo_range(self.space.controlled[j])
            .unwrap_or([0.0, 0.0])
    }
    fn act(&mut self, y: &[f64]) -> servo_loop::Result<()> {
        self.last_command = Some(y.to_vec());
        match &mut self.percept {
            Percept::Recognised(v) => v.act(y),
            Percept::Simulated { robot, .. } => robot
                .command(&self.space.full_command(y)?)
                .map_err(|e| ServoError::Robot {
                    during: "command",
                    message: e.to_string(),
                }),
        }
    }
    fn observe(&mut self) -> servo_loop::Result<Observation> {
        self.observations += 1;
        let obs = self.observe_now()?;
        if let Some(y) = &self.last_command {
            self.samples.push(Sample {
                observation: self.observations,
                x: obs.x.clone(),
                y: y.clone(),
            });
        }
        Ok(obs)
    }
    fn percept_bounds(&self) -> Option<Vec<[f64; 2]>> {
        let (w, h) = (f64::from(self.size[0]) - 1.0, f64::from(self.size[1]) - 1.0);
        Some(
            (0..self.cameras)
                .flat_map(|_| [[0.0, w], [0.0, h]])
                .collect(),
        )
    }
}

impl SimPlant {
    fn observe_now(&mut self) -> servo_loop::Result<Observation> {
        let t = truth(self.sim());
        self.log.push(t);
        let cams = self.cameras;
        let size = self.size;
        match &mut self.percept {
            Percept::Recognised(v) => {
                // The first `cameras` cameras of the visual plant's percept.
                v.observe()?;
                let locs = &v.last_localisations()[..cams];
                let certainty = locs.iter().map(|l| l.certainty).fold(1.0, f64::min);
                let x = locs.iter().flat_map(|l| l.position).collect();
                Ok(Observation { x, certainty })
            }
            Percept::Simulated { noise, rng, .. } => {
                let mut x = Vec::with_capacity(2 * cams);
                for (cam, p) in t.px.iter().take(cams).enumerate() {
                    let inside = p[0] >= 0.0
                        && p[1] >= 0.0
                        && p[0] < f64::from(size[0])
                        && p[1] < f64::from(size[1]);
                    if !inside {
                        return Err(ServoError::RecognitionFailed {
                            camera: cam,
                            certainty: 0.0,
                            min: 0.5,
                        });
                    }
                    x.push(p[0] + noise.sample(rng));
                    x.push(p[1] + noise.sample(rng));
                }
                Ok(Observation { x, certainty: 1.0 })
            }
        }
    }
}

/// The ideal arm's image position of the tip for a full command (nominal servo mapping, no
/// calibration error, backlash or sag), per camera.
fn ideal_pixels(sim: &ArmSim, c: &[f64; NUM_SERVOS], cameras: usize) -> Option<Vec<f64>> {
    let angles = sim.inspect().nominal_angles(c).ok()?;
    let pose = forward_kinematics(&sim.inspect().config().arm, &angles);
    let tip: Vector3<f64> = pose.tip;
    let mut x = Vec::with_capacity(2 * cameras);
    for cam in 0..cameras {
        let p = sim.inspect().project(cam, &tip).ok()?;
        x.extend(p);
    }
    Some(x)
}

/// The analytic image Jacobian `∂x/∂y` of the ideal arm at the controlled command `y`
/// (central differences of ±0.5 µs on the exact model: the upper-bound baseline).
pub fn ideal_image_jacobian(plant: &SimPlant, y: &[f64]) -> servo_loop::Result<DMatrix<f64>> {
    let n = 2 * plant.cameras;
    let m = y.len();
    let mut j = DMatrix::zeros(n, m);
    let h = 0.5;
    for k in 0..m {
        let (mut yp, mut ym) = (y.to_vec(), y.to_vec());
        yp[k] += h;
        ym[k] -= h;
        let xp = ideal_pixels(plant.sim(), &plant.full_command(&yp)?, plant.cameras);
        let xm = ideal_pixels(plant.sim(), &plant.full_command(&ym)?, plant.cameras);
        let (Some(xp), Some(xm)) = (xp, xm) else {
            return Err(ServoError::InvalidParameter {
                name: "ideal model",
                reason: "the tip is behind a camera".into(),
            });
        };
        for i in 0..n {
            j[(i, k)] = (xp[i] - xm[i]) / (2.0 * h);
        }
    }
    Ok(j)
}
