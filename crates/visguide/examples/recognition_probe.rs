//! Development probe (not part of the evaluation): learns the gripper recogniser on `arm-sim`
//! with a chosen protocol seed and reports, for the two single-image tip rules on the same images,
//! - the tip's error against the projected middle of the finger ends, and for the tips within
//!   6 px of it the signed components along and across the projected gripper axis;
//! - the *step inconsistency*: for small moves (3 µs on one joint, 5 steps from each of the
//!   test poses) the distance between the tip's change and the true change, among tips within
//!   6 px of the truth. A rough tip (one that jumps as the outline it reads changes) shows a
//!   long tail here, and a servo loop cannot settle closer than that.
//!
//! `cargo run --release -p visguide --example recognition_probe -- [SEED] [SIM_SEED] [TESTS]`
//! (use seeds the evaluation does not use: its protocol seed is 2009, its simulator's 2009).

use arm_sim::{ArmSim, SimConfig};
use image::GrayImage;
use servo_loop::{
    ControlSpace, RandomCommands, SilhouetteConfig, TipModel, TipRule, learn_recognition,
};
use visguide::SimRobot;

use servo_loop::stats::quantile_rank as quantile;

/// Per rule and camera: errors, along/across components and step inconsistencies.
#[derive(Default, Clone)]
struct Tally {
    err: Vec<f64>,
    along: Vec<f64>,
    across: Vec<f64>,
    steps: Vec<f64>,
}

/// One camera's truth and, per rule, its tip (if found).
type Seen = ([f64; 2], Vec<Option<[f64; 2]>>);

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<u64> = std::env::args()
        .skip(1)
        .map(|a| a.parse().expect("a number"))
        .collect();
    let seed = args.first().copied().unwrap_or(424_242);
    let sim_seed = args.get(1).copied().unwrap_or(31_337);
    let tests = args.get(2).copied().unwrap_or(80) as usize;
    let config = SimConfig {
        seed: sim_seed,
        ..SimConfig::default()
    };
    let space = ControlSpace {
        controlled: vec![0, 1, 2],
        rest: vec![1500.0, 1500.0, 1500.0, 1944.0, 1500.0, 1500.0],
        gripper: Some((5, [2100.0, 1000.0])),
    };
    let explore = [[1167.0, 1833.0], [1389.0, 1833.0], [1111.0, 1611.0]];
    let mut robot = SimRobot::new(ArmSim::new(config.clone())?);
    let (model, report) = learn_recognition(
        &mut robot,
        &space,
        &explore,
        30,
        seed ^ 0xBEEF,
        &SilhouetteConfig {
            correction_poses: 0,
            ..SilhouetteConfig::default()
        },
    )?;
    eprintln!("learned: {report:?}");
    let rules = [TipRule::FarEnd, TipRule::EndFace];
    let models: Vec<TipModel> = rules.iter().map(|&r| model.with_tip_rule(r)).collect();
    let cams = model.num_cameras().min(2);
    let mut tally = vec![vec![Tally::default(); cams]; rules.len()];
    let mut sim = ArmSim::new(config)?;
    // (truth, per rule: tip) of camera `cam` in the current image.
    let observe = |sim: &ArmSim, imgs: &[GrayImage], cam: usize| {
        let pose = sim.inspect().pose().clone();
        let mid = pose.finger_middle();
        let back = mid - pose.approach * 20.0;
        let t = sim.inspect().project(cam, &mid).expect("in front");
        let b = sim.inspect().project(cam, &back).expect("in front");
        let tips: Vec<Option<[f64; 2]>> = models
            .iter()
            .map(|m| m.locate(cam, &imgs[cam]).ok().map(|l| l.position))
            .collect();
        (t, b, tips)
    };
    let mut commands = RandomCommands::new(&explore, seed ^ 0xFACE)?;
    for k in 0..tests {
        let y = commands.next_command();
        let mut prev: Option<Vec<Seen>> = None;
        for step in 0..6 {
            let mut yy = y.clone();
            yy[k % 3] += 3.0 * step as f64;
            sim.command(&space.full_command(&yy)?)?;
            let imgs = sim.capture();
            let now: Vec<_> = (0..cams)
                .map(|cam| {
                    let (t, b, tips) = observe(&sim, &imgs, cam);
                    if step == 0 {
                        let (dx, dy) = (t[0] - b[0], t[1] - b[1]);
                        let n = dx.hypot(dy).max(1e-9);
                        let d = [dx / n, dy / n];
                        for (r, tip) in tips.iter().enumerate() {
                            let Some(l) = tip else { continue };
                            let (ex, ey) = (l[0] - t[0], l[1] - t[1]);
                            let e = ex.hypot(ey);
                            let tl = &mut tally[r][cam];
                            tl.err.push(e);
                            if e < 6.0 {
                                tl.along.push(ex * d[0] + ey * d[1]);
                                tl.across.push(-ex * d[1] + ey * d[0]);
                            }
                        }
                    }
                    (t, tips)
                })
                .collect();
            if let Some(p) = &prev {
                for cam in 0..cams {
                    let ((t0, l0), (t1, l1)) = (&p[cam], &now[cam]);
                    for r in 0..rules.len() {
                        let (Some(a), Some(b)) = (l0[r], l1[r]) else {
                            continue;
                        };
                        let near =
                            |l: [f64; 2], t: [f64; 2]| (l[0] - t[0]).hypot(l[1] - t[1]) < 6.0;
                        if near(a, *t0) && near(b, *t1) {
                            let jx = (b[0] - a[0]) - (t1[0] - t0[0]);
                            let jy = (b[1] - a[1]) - (t1[1] - t0[1]);
                            tally[r][cam].steps.push(jx.hypot(jy));
                        }
                    }
                }
            }
            prev = Some(now);
        }
    }
    for (r, rule) in rules.iter().enumerate() {
        for (cam, tl) in tally[r].iter_mut().enumerate() {
            let wrong = tl.err.iter().filter(|&&e| e >= 6.0).count();
            let over = tl.steps.iter().filter(|&&e| e > 0.5).count();
            let n = tl.steps.len();
            println!(
                "{rule:?} cam {cam}: median {:.2} p90 {:.2} px, {wrong}/{} ≥ 6 px; along {:+.2}, across {:+.2} (medians within 6 px); step inconsistency median {:.3} p90 {:.3} px, > 0.5 px {over}/{n}",
                quantile(&mut tl.err, 0.5),
                quantile(&mut tl.err, 0.9),
                tl.err.len(),
                quantile(&mut tl.along, 0.5),
                quantile(&mut tl.across, 0.5),
                quantile(&mut tl.steps, 0.5),
                quantile(&mut tl.steps, 0.9),
            );
        }
    }
    Ok(())
}
