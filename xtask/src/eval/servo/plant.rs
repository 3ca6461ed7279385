//! `arm-sim` connected to `servo-loop`: the evaluation plant (percept = the learned recognition
//! on rendered images, or the simulator's true tip projection plus detection noise; with a
//! ground-truth log) and the analytic image Jacobian of the ideal arm. The robot adapter is
//! `visguide::SimRobot`, re-exported here.

use arm_sim::{ArmSim, NUM_SERVOS, forward_kinematics};
use nalgebra::{DMatrix, Vector3};
use rand::SeedableRng;
use rand::rngs::Xoshiro256PlusPlus;
use rand_distr::{Distribution, Normal};
use rayon::prelude::*;
use servo_loop::{
    Localisation, Observation, PerceptPolicy, Plant, ServoError, TipModel, observe_checked,
};

/// The learned recognition as the percept of a [`SimPlant`]: the mean of `policy.captures`
/// localisations per camera (the arm stands still between the captures), cameras located in
/// parallel, re-captured and refused by the policy (servo_loop's `observe_checked`, as its
/// `VisualPlant` does).
pub struct Recogniser {
    pub model: TipModel,
    pub policy: PerceptPolicy,
    /// Percepts refused and doubted attempts re-captured so far.
    pub refused: usize,
    pub recaptured: usize,
}

impl Recogniser {
    pub fn new(model: TipModel, policy: PerceptPolicy) -> Self {
        Recogniser {
            model,
            policy,
            refused: 0,
            recaptured: 0,
        }
    }

    /// Per camera (the first `cameras`): the averaged localisation (servo_loop's
    /// `observe_checked`, every camera of the model located in parallel).
    pub fn observe(
        &mut self,
        sim: &mut ArmSim,
        cameras: usize,
    ) -> servo_loop::Result<Vec<Localisation>> {
        let model = &self.model;
        let recaptured = &mut self.recaptured;
        let result = observe_checked(
            model,
            &self.policy,
            || Ok(sim.capture()),
            |images| {
                // Every camera of the model (the learned rule's correction takes them all);
                // collected per camera first, so the error reported is the first camera's
                // whatever the thread count.
                let ends: Vec<servo_loop::Result<_>> = images
                    .par_iter()
                    .enumerate()
                    .map(|(cam, img)| model.estimate_end(cam, img))
                    .collect();
                model.tips(&ends.into_iter().collect::<servo_loop::Result<Vec<_>>>()?)
            },
            || *recaptured += 1,
        );
        if let Err(ServoError::PerceptRefused { .. }) = &result {
            self.refused += 1;
        }
        let (mut locs, _) = result?;
        locs.truncate(cameras);
        Ok(locs)
    }
}

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

/// The evaluation plant: controlled servos `controlled`, the others held at `rest`; the
/// percept is the true tip projection plus Gaussian detection noise of `noise_px`; every
/// observation's ground truth is logged.
pub struct SimPlant {
    pub sim: ArmSim,
    pub controlled: Vec<usize>,
    pub rest: [f64; NUM_SERVOS],
    pub cameras: usize,
    pub size: [u32; 2],
    noise: Normal<f64>,
    rng: Xoshiro256PlusPlus,
    pub log: Vec<Truth>,
    /// With a recogniser the percept comes from rendered images, not from the projection.
    pub recogniser: Option<Recogniser>,
    /// Commands sent (every `act`, approach pre-positions included).
    pub commands: usize,
}

impl SimPlant {
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
            sim,
            controlled: controlled.to_vec(),
            rest,
            cameras,
            size,
            noise: Normal::new(0.0, noise_px.max(0.0)).expect("valid σ"),
            rng: Xoshiro256PlusPlus::seed_from_u64(seed),
            log: Vec::new(),
            recogniser: None,
            commands: 0,
        }
    }

    pub fn full_command(&self, y: &[f64]) -> [f64; NUM_SERVOS] {
        let mut c = self.rest;
        for (&i, &v) in self.controlled.iter().zip(y) {
            c[i] = v;
        }
        c
    }
}

impl Plant for SimPlant {
    fn percept_dim(&self) -> usize {
        2 * self.cameras
    }
    fn command_dim(&self) -> usize {
        self.controlled.len()
    }
    fn command_range(&self, j: usize) -> [f64; 2] {
        self.sim
            .servo_range(self.controlled[j])
            .unwrap_or([0.0, 0.0])
    }
    fn act(&mut self, y: &[f64]) -> servo_loop::Result<()> {
        self.commands += 1;
        let c = self.full_command(y);
        self.sim.command(&c).map_err(|e| ServoError::Robot {
            during: "command",
            message: e.to_string(),
        })
    }
    fn observe(&mut self) -> servo_loop::Result<Observation> {
        let t = truth(&self.sim);
        self.log.push(t);
        let cams = self.cameras;
        if let Some(r) = self.recogniser.as_mut() {
            let locs = r.observe(&mut self.sim, cams)?;
            let certainty = locs.iter().map(|l| l.certainty).fold(1.0, f64::min);
            let x = locs.iter().flat_map(|l| l.position).collect();
            return Ok(Observation { x, certainty });
        }
        let mut x = Vec::with_capacity(2 * self.cameras);
        for (cam, p) in t.px.iter().take(self.cameras).enumerate() {
            let inside = p[0] >= 0.0
                && p[1] >= 0.0
                && p[0] < f64::from(self.size[0])
                && p[1] < f64::from(self.size[1]);
            if !inside {
                return Err(ServoError::RecognitionFailed {
                    camera: cam,
                    certainty: 0.0,
                    min: 0.5,
                });
            }
            x.push(p[0] + self.noise.sample(&mut self.rng));
            x.push(p[1] + self.noise.sample(&mut self.rng));
        }
        Ok(Observation { x, certainty: 1.0 })
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

/// The ideal arm's image position of the tip for a full command (nominal servo mapping, no
/// calibration error, backlash or sag), per camera.
fn ideal_pixels(sim: &ArmSim, c: &[f64; NUM_SERVOS], cameras: usize) -> Option<Vec<f64>> {
    let angles = sim.inspect().nominal_angles(c);
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
        let xp = ideal_pixels(&plant.sim, &plant.full_command(&yp), plant.cameras);
        let xm = ideal_pixels(&plant.sim, &plant.full_command(&ym), plant.cameras);
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
