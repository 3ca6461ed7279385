//! The servo study over several arms and seeds: per (arm, seed) the whole pipeline (learn
//! recognition, learn control, servo to reachable targets), so the goals are judged on the
//! median over seeds with its spread and worst seed, not on one lucky run.
//!
//! **Seeds.** [`DEVELOPMENT_SEEDS`] are where settings are checked or chosen
//! (`cargo xtask eval servo --development` prints the study and writes nothing);
//! [`EVALUATION_SEEDS`] are scored once, by the fixtures (the summary says which seeds decided
//! what). The arms: the default arm and the arm files
//! shipped in `crates/arm-sim/arms/` (a worn arm; a second rig).

use std::path::{Path, PathBuf};

use arm_sim::SimConfig;
use serde::{Deserialize, Serialize};
use servo_loop::{EpipolarReport, PerceptPolicy, Plant, RandomCommands, ServoError};
use visguide::parallel;

use super::{
    Actions, Protocol, ServoArgs, Target, TargetResult, learn_motion, learn_recogniser,
    make_image_targets, make_plant, make_targets, run_method, train,
};
use crate::Result;

/// Seeds every setting was chosen on.
pub const DEVELOPMENT_SEEDS: [u64; 5] = [1001, 1002, 1003, 1004, 1005];
/// Seeds scored once for the fixtures.
pub const EVALUATION_SEEDS: [u64; 5] = [9001, 9002, 9003, 9004, 9005];
/// Seeds kept for evaluation, past and present (7001–7005 and 8001–8005 were scored by earlier
/// rounds, 9001–9005 by this one): never development data.
pub const EVALUATION_RANGE: std::ops::RangeInclusive<u64> = 7000..=9999;
/// Targets per (arm, seed).
pub const TARGETS: usize = 30;
/// Image targets per (arm, seed).
pub const IMAGE_TARGETS: usize = 20;
/// Least cross-camera consistency of an accepted image target.
pub const MIN_TARGET_CONSISTENCY: f64 = 0.05;
/// Recognition test poses per (arm, seed).
pub const RECOGNITION_TESTS: usize = 40;
/// The methods compared per seed.
pub const METHODS: [&str; 3] = ["lwpr", "broyden", "true-jacobian"];
/// Broyden's probe moves (one per controlled joint).
const PROBES: usize = 3;
/// The iteration (= executed corrections after the first guess) the goals are judged at.
pub const AT: usize = 5;

/// The arms of the study: the default and the shipped arm files.
pub fn shipped_arms() -> Vec<(String, Option<PathBuf>)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../crates/arm-sim/arms");
    vec![
        ("default".into(), None),
        ("worn-arm".into(), Some(dir.join("worn-arm.json"))),
        ("second-rig".into(), Some(dir.join("second-rig.json"))),
    ]
}

/// The name of an arm file in a study's tables: its file stem.
pub fn arm_name(path: &Path) -> Result<String> {
    path.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .ok_or_else(|| format!("arm file {} has no name", path.display()).into())
}

/// Recognition at random poses (single captures, the servo percept's policy otherwise).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SeedRecognition {
    pub tests: usize,
    /// Poses whose percept was refused (doubted after the re-capture).
    pub refused: usize,
    /// Poses where no gripper was found in some camera.
    pub not_found: usize,
    /// Per camera, over the accepted percepts: median and 90th percentile of the distance to
    /// the projected middle of the finger ends (px).
    pub median_px: Vec<f64>,
    pub p90_px: Vec<f64>,
}

/// One method's figures on one seed.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SeedMethod {
    pub method: String,
    /// Median true image error (px) and 3-D error (mm) after [`AT`] moves after the first
    /// guess (for Broyden: its probes included).
    pub median_px: f64,
    pub median_mm: f64,
    pub p90_px: f64,
    /// Share of targets within 1 px after [`AT`] moves.
    pub success: f64,
    /// For Broyden: the median after [`AT`] corrections after its probes (`AT + 3` moves).
    pub median_px_after_corrections: Option<f64>,
    /// Runs stopped because a percept was refused, and by any other typed error.
    pub refused_runs: usize,
    pub other_errors: usize,
    /// Recovery moves made after refused percepts, and runs that went on after one (written
    /// only when non-zero: the study without recovery writes what it wrote before).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub recovery_moves: usize,
    #[serde(default, skip_serializing_if = "is_zero")]
    pub recovered_runs: usize,
}

fn is_zero(n: &usize) -> bool {
    *n == 0
}

/// Everything one (arm, seed) gives.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SeedResult {
    pub arm: String,
    pub seed: u64,
    pub actions: Actions,
    /// Training moves skipped because their percept was refused or not found.
    pub training_refused: usize,
    pub training_not_found: usize,
    pub consistency: Vec<EpipolarReport>,
    pub recognition: SeedRecognition,
    pub methods: Vec<SeedMethod>,
    /// Image targets offered, and refused by `servo_loop::check_image_target` (inconsistent
    /// between the cameras, or outside the learned model).
    pub image_targets: usize,
    pub image_targets_refused: usize,
    /// LWPR on the accepted image targets (error against the target pose's tool point).
    pub image: Option<SeedMethod>,
}

/// The whole multi-seed study.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SeedStudy {
    /// `evaluation` or `development`.
    pub seeds_role: String,
    pub seeds: Vec<u64>,
    pub targets_per_seed: usize,
    /// The motion check's factor on the servo percepts (`servo_loop::MotionConfig::factor`;
    /// `None`: off).
    #[serde(default)]
    pub motion_factor: Option<f64>,
    /// The recovery move after a refused servo percept, `(step µs, tries)` (`None`: off; not
    /// written then).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub recovery: Option<(f64, usize)>,
    /// Where LWPR's learned Jacobian is evaluated.
    pub jacobian_at: servo_loop::JacobianAt,
    pub results: Vec<SeedResult>,
}

use crate::stats::quantile_linear as quantile;

/// Runs every (arm, seed) of `args` in parallel (one job each; results do not depend on the
/// thread count).
pub fn run_all(args: &ServoArgs) -> Result<SeedStudy> {
    let (role, seeds) = if !args.development {
        ("evaluation", EVALUATION_SEEDS.to_vec())
    } else if args.dev_seeds.is_empty() {
        ("development", DEVELOPMENT_SEEDS.to_vec())
    } else if let Some(s) = args.dev_seeds.iter().find(|s| EVALUATION_RANGE.contains(s)) {
        return Err(
            format!("seed {s} is kept for evaluation (7000–9999), not development data").into(),
        );
    } else {
        ("development", args.dev_seeds.clone())
    };
    let mut arms = shipped_arms();
    if !args.only_arms.is_empty() {
        if let Some(a) = args
            .only_arms
            .iter()
            .find(|a| !arms.iter().any(|(n, _)| n == *a))
        {
            return Err(format!("no shipped arm `{a}` (default, worn-arm, second-rig)").into());
        }
        arms.retain(|(n, _)| args.only_arms.contains(n));
    }
    for path in &args.dev_arms {
        arms.push((arm_name(path)?, Some(path.clone())));
    }
    let mut configs = Vec::new();
    for (name, path) in &arms {
        let config = match path {
            Some(p) => SimConfig::read_file(p)?,
            None => SimConfig::default(),
        };
        configs.push((name.clone(), config));
    }
    let jobs: Vec<(&str, &SimConfig, u64)> = configs
        .iter()
        .flat_map(|(n, c)| seeds.iter().map(move |&s| (n.as_str(), c, s)))
        .collect();
    let results = parallel::try_map(&jobs, |&(name, config, seed)| {
        run_seed(name, config, seed, args)
    })?;
    // The study's percept settings, as every seed's protocol has them.
    let mut p = Protocol::default_for(0);
    args.apply_settings(&mut p);
    Ok(SeedStudy {
        seeds_role: role.into(),
        seeds,
        targets_per_seed: TARGETS,
        motion_factor: p.motion.map(|m| m.factor),
        recovery: p.recovery.map(|r| (r.step, r.tries)),
        jacobian_at: p.jacobian_at,
        results,
    })
}

/// The whole pipeline on one arm and seed (the recogniser's settings from `args`,
/// [`ServoArgs::apply_settings`]).
pub fn run_seed(arm: &str, config: &SimConfig, seed: u64, args: &ServoArgs) -> Result<SeedResult> {
    let mut p = Protocol::default_for(seed);
    args.apply_settings(&mut p);
    p.curve_moves = vec![p.training_moves];
    p.targets = TARGETS;
    let (model, report, recognition_commands) = learn_recogniser(config, &p)?;
    p.recogniser = Some(model);
    let (snaps, training, samples) = train(config, &p, false)?;
    let main = &snaps.last().ok_or("no trained model")?.1;
    // The servo percepts (recognition tests, targets, servo runs) pass the motion check when
    // it is on, learned from the training moves.
    p.motion_check = learn_motion(&p, &samples, p.training_moves)?;
    let recognition = recognition(config, &p)?;
    let targets = make_targets(config, &p, p.targets, p.seed ^ 0x7A26)?;
    let mut methods = Vec::new();
    for (i, m) in METHODS.iter().enumerate() {
        let r = run_method(
            m,
            config,
            &p,
            main,
            &targets,
            p.iterations,
            seed ^ ((i as u64) << 24),
        )?;
        methods.push(method_figures(m, &r));
    }
    // Image targets: checked against the learned workspace before any move.
    let recogniser = p.recogniser.as_ref().ok_or("a recogniser")?;
    let offered = make_image_targets(config, &p, IMAGE_TARGETS, seed ^ 0x1A6E)?;
    let accepted: Vec<Target> = offered
        .iter()
        .filter(|t| {
            servo_loop::check_image_target(recogniser, main, &t.x_w, MIN_TARGET_CONSISTENCY).is_ok()
        })
        .cloned()
        .collect();
    let image = if accepted.is_empty() {
        None
    } else {
        let r = run_method(
            "lwpr",
            config,
            &p,
            main,
            &accepted,
            p.iterations,
            seed ^ 0x1A6F,
        )?;
        Some(method_figures("lwpr-image-targets", &r))
    };
    Ok(SeedResult {
        arm: arm.into(),
        seed,
        actions: Actions {
            recognition: recognition_commands,
            training: training.commands,
        },
        training_refused: training.learn.refused,
        training_not_found: training.learn.not_recognised,
        consistency: report.consistency,
        recognition,
        methods,
        image_targets: offered.len(),
        image_targets_refused: offered.len() - accepted.len(),
        image,
    })
}

fn method_figures(method: &str, r: &[TargetResult]) -> SeedMethod {
    let at = |k: usize| -> Vec<f64> { r.iter().map(|t| t.px[k.min(t.px.len() - 1)]).collect() };
    let px = at(AT);
    let mm: Vec<f64> = r.iter().map(|t| t.mm[AT.min(t.mm.len() - 1)]).collect();
    SeedMethod {
        method: method.into(),
        median_px: quantile(&px, 0.5),
        median_mm: quantile(&mm, 0.5),
        p90_px: quantile(&px, 0.9),
        success: px.iter().filter(|&&e| e <= 1.0).count() as f64 / px.len().max(1) as f64,
        median_px_after_corrections: (method == "broyden").then(|| quantile(&at(AT + PROBES), 0.5)),
        refused_runs: r.iter().filter(|t| t.refused).count(),
        other_errors: r.iter().filter(|t| t.error.is_some() && !t.refused).count(),
        recovery_moves: r.iter().map(|t| t.recovery_moves).sum(),
        recovered_runs: r.iter().filter(|t| t.recovered).count(),
    }
}

/// The servo percept (single captures) at random poses against the projected middle of the
/// finger ends.
fn recognition(config: &SimConfig, p: &Protocol) -> Result<SeedRecognition> {
    let mut plant = make_plant(config, p, p.seed ^ 0xFACE)?;
    plant.set_policy(|_| PerceptPolicy {
        captures: 1,
        ..p.policy()
    })?;
    let cams = plant.cameras;
    let mut commands = RandomCommands::new(&p.explore_us, p.seed ^ 0xFACE)?;
    let (mut refused, mut not_found) = (0, 0);
    let mut errors = vec![Vec::new(); cams];
    let diagnose = std::env::var_os("VISGUIDE_SERVO_DIAGNOSE").is_some();
    // Every move executed as the study executes moves (the approach), so a percept is judged
    // against the pose the learner's own moves show at that command.
    let mut state = servo_loop::ApproachState::new();
    for _ in 0..RECOGNITION_TESTS {
        let y = commands.next_command();
        match &p.approach {
            Some(a) => {
                state.execute(&mut plant, a, &a.round(&y), false)?;
            }
            None => plant.act(&y)?,
        }
        match plant.observe() {
            Ok(o) => {
                let truth = plant.sim().inspect().finger_middle_pixels()?;
                let mut line = Vec::new();
                for (cam, e) in errors.iter_mut().enumerate() {
                    let t = truth[cam];
                    e.push((o.x[2 * cam] - t[0]).hypot(o.x[2 * cam + 1] - t[1]));
                    line.push(format!("{:.2}", e[e.len() - 1]));
                }
                if diagnose {
                    eprintln!(
                        "recognition-test seed {} accepted errors {}",
                        p.seed,
                        line.join(" ")
                    );
                }
            }
            Err(ServoError::PerceptInconsistent {
                residual,
                threshold,
            }) => {
                if diagnose {
                    eprintln!(
                        "recognition-test seed {} inconsistent residual {residual:.2} threshold {threshold:.2}",
                        p.seed
                    );
                }
                refused += 1
            }
            Err(ServoError::PerceptRefused { .. }) => refused += 1,
            Err(ServoError::RecognitionFailed { .. }) => not_found += 1,
            Err(e) => return Err(e.into()),
        }
    }
    Ok(SeedRecognition {
        tests: RECOGNITION_TESTS,
        refused,
        not_found,
        median_px: errors.iter().map(|e| quantile(e, 0.5)).collect(),
        p90_px: errors.iter().map(|e| quantile(e, 0.9)).collect(),
    })
}

/// A value over seeds: the median of the per-seed values, their min and max, and the worst
/// seed (the largest value).
#[derive(Debug, Clone, Serialize)]
pub struct OverSeeds {
    pub median: f64,
    pub min: f64,
    pub max: f64,
    pub worst_seed: u64,
}

pub fn over_seeds(values: &[(u64, f64)]) -> OverSeeds {
    let v: Vec<f64> = values.iter().map(|x| x.1).collect();
    let (worst_seed, max) = values
        .iter()
        .copied()
        .fold((0, f64::NEG_INFINITY), |a, b| if b.1 > a.1 { b } else { a });
    OverSeeds {
        median: quantile(&v, 0.5),
        min: v.iter().copied().fold(f64::INFINITY, f64::min),
        max,
        worst_seed,
    }
}

/// Per-seed values of `f` for `arm`.
pub fn per_seed(study: &SeedStudy, arm: &str, f: impl Fn(&SeedResult) -> f64) -> Vec<(u64, f64)> {
    study
        .results
        .iter()
        .filter(|r| r.arm == arm)
        .map(|r| (r.seed, f(r)))
        .collect()
}

/// The figure of `method` in a seed's result.
pub fn method<'a>(r: &'a SeedResult, name: &str) -> &'a SeedMethod {
    r.methods
        .iter()
        .find(|m| m.method == name)
        .expect("every method runs on every seed")
}

#[cfg(test)]
mod tests {
    use super::*;
    use arm_sim::ArmSim;

    #[test]
    fn every_shipped_arm_builds_a_simulator() {
        for (name, path) in shipped_arms() {
            let config = match path {
                Some(p) => SimConfig::read_file(p).unwrap(),
                None => SimConfig::default(),
            };
            assert!(ArmSim::new(config).is_ok(), "{name}");
        }
    }

    #[test]
    fn over_seeds_names_the_worst_seed() {
        let o = over_seeds(&[(1, 0.4), (2, 0.9), (3, 0.5)]);
        assert_eq!((o.median, o.min, o.max, o.worst_seed), (0.5, 0.4, 0.9, 2));
    }
}
