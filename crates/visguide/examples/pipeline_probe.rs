//! Development probe of the FD + CBT pipeline (not part of the evaluation): learns it on the
//! simulator and prints, per test frame and camera, the votes against the true tip (the middle
//! of the finger ends), so the shape model's choices can be checked on development seeds.
//!
//! `cargo run -p visguide --example pipeline_probe -- [SIM_SEED] [hard]`

use arm_sim::{ArmSim, SimConfig};
use servo_loop::{ControlSpace, RandomCommands, SilhouetteConfig, learn_recognition};
use visguide::SimRobot;
use visguide::pipeline::{ActionProtocol, learn_by_action, mode};

const EXPLORE: [[f64; 2]; 3] = [[1167.0, 1833.0], [1389.0, 1833.0], [1111.0, 1611.0]];

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let seed: u64 = args.first().map_or(Ok(101), |a| a.parse())?;
    let mut config = if args.get(1).is_some_and(|a| a == "hard") {
        SimConfig::read_file(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../arm-sim/arms/hard-scene.json"),
        )?
    } else {
        SimConfig::default()
    };
    config.seed = seed;
    let space = ControlSpace {
        controlled: vec![0, 1, 2],
        rest: vec![1500.0, 1500.0, 1500.0, 1944.0, 1500.0, 1500.0],
        gripper: Some((5, [2100.0, 1000.0])),
    };
    let mut robot = SimRobot::new(ArmSim::new(config)?);
    let (heuristic, _) = learn_recognition(
        &mut robot,
        &space,
        &EXPLORE,
        30,
        seed ^ 0xBEEF,
        &SilhouetteConfig {
            correction_poses: 300,
            ..SilhouetteConfig::default()
        },
    )?;
    let mut protocol = ActionProtocol {
        views: 24,
        walks: 4,
        steps: 10,
        ..ActionProtocol::default()
    };
    // Development overrides: VG_TR (ratio threshold), VG_ROT (max rotation), VG_VIEWS.
    let env = |k: &str| std::env::var(k).ok().and_then(|v| v.parse::<f64>().ok());
    if let Some(v) = env("VG_TR") {
        protocol.shapes.ratio_threshold = v;
    }
    if let Some(v) = env("VG_ROT") {
        protocol.shapes.max_rotation = v;
    }
    if let Some(v) = env("VG_DELTA") {
        protocol.shapes.mser.delta = v as u8;
    }
    if let Some(v) = env("VG_MINAREA") {
        protocol.shapes.mser.min_area = v as usize;
    }
    if let Some(v) = env("VG_MAXERR") {
        protocol.shapes.max_error = v;
    }
    if let Some(v) = env("VG_VIEWS") {
        protocol.views = v as usize;
    }
    let (pipeline, report) = learn_by_action(&mut robot, &space, &EXPLORE, &heuristic, &protocol)?;
    println!("{report:?}");
    for cam in 0..2 {
        for v in pipeline.fd.shapes.views(cam).iter().take(8) {
            println!(
                "cam {cam} view: area {:.0} offset {:.1?} contour {}",
                v.area,
                v.offset,
                v.contour.len()
            );
        }
    }
    let mut commands = RandomCommands::new(&EXPLORE, seed ^ 0x5EE)?;
    let (mut errs, mut herrs, mut none) = (Vec::new(), Vec::new(), 0);
    for k in 0..20 {
        let y = commands.next_command();
        robot.0.command(&space.full_command(&y)?)?;
        let images = robot.0.capture();
        let truth = robot.0.inspect().finger_middle_pixels()?;
        let heur = servo_loop::Recogniser::locate_all(&heuristic, &images).ok();
        for (cam, &t) in truth.iter().enumerate() {
            let votes = pipeline.fd.shapes.votes(cam, &images[cam])?;
            let near = votes
                .iter()
                .filter(|v| (v.position[0] - t[0]).hypot(v.position[1] - t[1]) < 5.0)
                .count();
            let m = mode(&votes, 2.0)?;
            match m {
                Some(m) => errs.push((m.position[0] - t[0]).hypot(m.position[1] - t[1])),
                None => none += 1,
            }
            if let Some(h) = &heur {
                herrs.push((h[cam].position[0] - t[0]).hypot(h[cam].position[1] - t[1]));
            }
            if k >= 4 {
                continue;
            }
            println!(
                "cam {cam}: truth {t:.1?} heuristic {:.1?} votes {} near {near} mode {:.1?}",
                heur.as_ref().map(|h| h[cam].position),
                votes.len(),
                m.map(|m| (m.position, m.certainty, m.support))
            );
            for v in votes.iter().take(6) {
                println!(
                    "   vote {:.1?} w {:.2} e {:.3} rot {:.2}",
                    v.position, v.weight, v.error, v.rotation
                );
            }
        }
    }
    errs.sort_by(f64::total_cmp);
    herrs.sort_by(f64::total_cmp);
    let q = |v: &[f64], p: f64| {
        v.get(((v.len() as f64 * p) as usize).min(v.len().saturating_sub(1)))
            .copied()
    };
    println!(
        "FD mode: median {:?} p90 {:?} gross>5 {} of {}, none {none}; heuristic median {:?} p90 {:?} gross {}",
        q(&errs, 0.5),
        q(&errs, 0.9),
        errs.iter().filter(|&&e| e > 5.0).count(),
        errs.len(),
        q(&herrs, 0.5),
        q(&herrs, 0.9),
        herrs.iter().filter(|&&e| e > 5.0).count()
    );
    Ok(())
}
