//! `cargo xtask eval servo --diagnose-recognition`: the recogniser's tip candidates at the
//! recognition test poses of the development seeds, as JSON lines on stdout (development data
//! only; nothing is written). Per pose three captures: two at the pose (`a`, `b`: only sensor
//! noise differs) and one after a small move (`c`: ±4 µs per controlled joint). Per capture and
//! camera: the far end, the end-face tip, the learned tip with the 0.5 px clip and with the
//! model's gate, the correction's spread and the truth (the projected middle of the finger
//! ends); per capture the normalised Sampson distance `d / s` of every pair of the two cameras'
//! candidates (the 0.5 px learned tip or the end face). Rules are then compared offline (how the
//! learned tip's gate was chosen: docs/methods.md, *Gated learned tip*).

use arm_sim::{ArmSim, SimConfig};
use rand::rngs::Xoshiro256PlusPlus;
use rand::{RngExt, SeedableRng};
use serde::Serialize;
use servo_loop::RandomCommands;
use visguide::parallel;

use super::seeds::{DEVELOPMENT_SEEDS, RECOGNITION_TESTS, shipped_arms};
use super::{Protocol, learn_recogniser};
use crate::Result;

#[derive(Serialize)]
struct Capture {
    arm: String,
    seed: u64,
    pose: usize,
    tag: char,
    far: Vec<[f64; 2]>,
    face: Vec<Option<[f64; 2]>>,
    learned: Vec<[f64; 2]>,
    /// The learned tip as the model's settings give it (gate and spread,
    /// `servo_loop::SilhouetteConfig::face_gate`), and the correction's spread per camera.
    gated: Vec<[f64; 2]>,
    spread: Vec<f64>,
    truth: Vec<[f64; 2]>,
    certainty: Vec<f64>,
    /// `cost[i][j]`: `d / s` of camera 0's candidate `i` with camera 1's `j` (0 learned, 1
    /// end face; `None` where a camera has no end face).
    cost: [[Option<f64>; 2]; 2],
}

fn one(arm: &str, config: &SimConfig, seed: u64) -> Result<Vec<Capture>> {
    let mut p = Protocol::default_for(seed);
    p.cross_camera_choice = false;
    let (model, _, _) = learn_recogniser(config, &p)?;
    let correction = model.correction().ok_or("no correction")?.clone();
    let g = model.consistency().first().ok_or("no geometry")?.clone();
    let mut sim = ArmSim::new(config.clone())?;
    let mut commands = RandomCommands::new(&p.explore_us, seed ^ 0xFACE)?;
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed ^ 0xD1A6);
    let mut out = Vec::new();
    for pose in 0..RECOGNITION_TESTS {
        let y = commands.next_command();
        for tag in ['a', 'b', 'c'] {
            let mut c = p.rest_us;
            for (k, (&i, &v)) in p.controlled.iter().zip(&y).enumerate() {
                c[i] = v;
                if tag == 'c' {
                    let lim = p.explore_us[k];
                    c[i] = (v + rng.random_range(-4.0..4.0)).clamp(lim[0], lim[1]);
                }
            }
            if tag != 'b' {
                sim.command(&c)?;
            }
            let images = sim.capture();
            let mut ends = Vec::new();
            for (cam, img) in images.iter().enumerate().take(2) {
                match model.estimate_end(cam, img) {
                    Ok(e) => ends.push(e),
                    Err(_) => break,
                }
            }
            if ends.len() < 2 {
                continue;
            }
            let far: Vec<[f64; 2]> = ends.iter().map(|e| e.far_end).collect();
            let face: Vec<Option<[f64; 2]>> = ends.iter().map(|e| e.end_face).collect();
            let learned = correction.tips(&far, &face)?;
            let gated = correction.tips_gated(&far, &face, model.config().face_gate)?;
            let truth = sim.inspect().finger_middle_pixels()?;
            let cand = |cam: usize, i: usize| -> Option<[f64; 2]> {
                if i == 0 {
                    Some(learned[cam])
                } else {
                    face[cam]
                }
            };
            let mut cost = [[None; 2]; 2];
            for (i, row) in cost.iter_mut().enumerate() {
                for (j, v) in row.iter_mut().enumerate() {
                    if let (Some(a), Some(b)) = (cand(0, i), cand(1, j)) {
                        *v = Some(g.distance(a, b) / g.scale());
                    }
                }
            }
            out.push(Capture {
                arm: arm.into(),
                seed,
                pose,
                tag,
                far,
                face,
                learned,
                gated: gated.iter().map(|t| t.position).collect(),
                spread: gated.iter().map(|t| t.spread).collect(),
                truth,
                certainty: ends.iter().map(|e| e.certainty).collect(),
                cost,
            });
        }
    }
    Ok(out)
}

/// Prints every capture of every (arm, development seed) as one JSON line.
pub fn run() -> Result<()> {
    let mut jobs = Vec::new();
    for (name, path) in shipped_arms() {
        let config = match path {
            Some(p) => SimConfig::read_file(p)?,
            None => SimConfig::default(),
        };
        for s in DEVELOPMENT_SEEDS {
            jobs.push((name.clone(), config.clone(), s));
        }
    }
    let all = parallel::try_map(&jobs, |(n, c, s)| one(n, c, *s))?;
    for c in all.iter().flatten() {
        println!("{}", serde_json::to_string(c)?);
    }
    Ok(())
}
