//! A small, fast run of the servo study with an insta snapshot of its summary.

use arm_sim::SimConfig;

use super::{PerceptMode, Protocol, report, run_study};

/// A small study: `moves` training moves (learning curve at 100 and `moves`, 10 targets),
/// `targets` targets, control only (true tip + noise: the recognised pipeline runs in
/// `cargo xtask eval servo`).
fn small_protocol(seed: u64, moves: usize, targets: usize) -> Protocol {
    let mut p = Protocol::default_for(seed);
    p.training_moves = moves;
    p.curve_moves = vec![100, moves];
    p.curve_targets = 10;
    p.targets = targets;
    p.percept = PerceptMode::Simulated;
    p
}

#[test]
fn small_study_summary_snapshot() {
    let p = small_protocol(7, 300, 20);
    let study = run_study(&SimConfig::default(), &p, false, false, None).unwrap();
    let text = report::summary(&study);
    // The loop must improve on open loop.
    let stats = report::method_stats("lwpr", &study.per_method[0].1, &p);
    assert!(stats.per_iteration[5].median_px < stats.per_iteration[0].median_px);
    insta::assert_snapshot!("servo_small_summary", text);
}

/// The parallel jobs (methods × target chunks) give the same numbers on one thread as on many.
#[test]
fn study_is_independent_of_the_thread_count() {
    let p = small_protocol(11, 200, 60);
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let study = pool
            .install(|| run_study(&SimConfig::default(), &p, false, false, None))
            .unwrap();
        let per_method: Vec<(String, Vec<Vec<f64>>)> = study
            .per_method
            .iter()
            .map(|(m, r)| (m.clone(), r.iter().map(|t| t.px.clone()).collect()))
            .collect();
        let curve: Vec<(usize, Vec<Vec<f64>>)> = study
            .curve
            .iter()
            .map(|(k, r)| (*k, r.iter().map(|t| t.mm.clone()).collect()))
            .collect();
        (per_method, curve)
    };
    let one = run(1);
    assert_eq!(one.0.len(), 4);
    assert!(one.0.iter().all(|(_, r)| r.len() == 60));
    assert_eq!(one, run(3));
}

/// The committed summary's study over arms and seeds is what `report::seeds_section` writes
/// from the committed `seeds.json` (so a change of the section's text is applied to the
/// fixture exactly, without rerunning the study). On a mismatch the expected summary is
/// written to `target/paper-c-summary.expected.md`.
#[test]
fn committed_summary_matches_committed_seeds_json() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/paper-c");
    let st: super::seeds::SeedStudy =
        serde_json::from_str(&std::fs::read_to_string(dir.join("seeds.json")).unwrap()).unwrap();
    let summary = std::fs::read_to_string(dir.join("summary.md")).unwrap();
    let section = report::seeds_section(&st);
    let start = summary
        .find("\n## Several arms, several seeds")
        .expect("the summary has the study over arms and seeds");
    if summary[start..] != section {
        let expected = format!("{}{section}", &summary[..start]);
        let out = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../target/paper-c-summary.expected.md");
        std::fs::write(&out, expected).unwrap();
        panic!("summary.md differs from seeds.json's section; expected text in {out:?}");
    }
}

/// A study over seeds on the default arm, one seed per `p90s` entry (the recognition p90 per
/// camera), each method with `recovery` = (recovery moves, recovered runs) per seed, and the
/// study's recovery setting.
fn seed_study(
    p90s: &[[f64; 2]],
    recovery: (usize, usize),
    setting: Option<(f64, usize)>,
) -> super::seeds::SeedStudy {
    use super::seeds::{SeedRecognition, SeedResult, SeedStudy};
    let result = |arm: &str, seed: u64, p90: [f64; 2]| SeedResult {
        arm: arm.into(),
        seed,
        actions: super::Actions::default(),
        training_refused: 0,
        training_not_found: 0,
        consistency: vec![],
        recognition: SeedRecognition {
            tests: 40,
            refused: 0,
            not_found: 0,
            median_px: vec![0.5, 0.5],
            p90_px: p90.to_vec(),
        },
        methods: ["lwpr", "broyden", "true-jacobian"]
            .iter()
            .map(|m| super::seeds::SeedMethod {
                method: m.to_string(),
                median_px: 0.4,
                median_mm: 0.4,
                p90_px: 1.0,
                success: 0.9,
                median_px_after_corrections: None,
                refused_runs: 0,
                other_errors: 0,
                recovery_moves: recovery.0,
                recovered_runs: recovery.1,
            })
            .collect(),
        image_targets: 0,
        image_targets_refused: 0,
        image: None,
    };
    SeedStudy {
        seeds_role: "development".into(),
        seeds: (1..=p90s.len() as u64).collect(),
        targets_per_seed: 30,
        motion_factor: None,
        recovery: setting,
        jacobian_at: servo_loop::JacobianAt::Target,
        results: p90s
            .iter()
            .enumerate()
            .map(|(i, p)| result("default", i as u64 + 1, *p))
            .collect(),
    }
}

/// With the recovery on, the study names it and counts its moves and recovered runs; off, its
/// text and JSON are what they were before the recovery existed (the fixtures' bytes).
#[test]
fn the_recovery_is_reported_only_when_on() {
    let on = report::seeds_section(&seed_study(&[[1.0, 1.0]; 3], (2, 1), Some((20.0, 2))));
    assert!(on.contains("**Recovery:**") && on.contains("20 µs"), "{on}");
    // 3 seeds × 3 methods: 9 recovered runs, 18 recovery moves.
    assert!(on.contains("(recovered 9, 18 recovery moves)"), "{on}");
    let off = report::seeds_section(&seed_study(&[[1.0, 1.0]; 3], (0, 0), None));
    assert!(
        !off.contains("Recovery") && !off.contains("recovered"),
        "{off}"
    );
    let json = serde_json::to_string(&seed_study(&[[1.0, 1.0]; 3], (0, 0), None)).unwrap();
    assert!(!json.contains("recover"), "{json}");
}

/// The recognition goal line is judged on the seed median and names the worst seed.
#[test]
fn recognition_goal_is_judged_on_the_seed_median() {
    let study = |p90s: &[[f64; 2]]| seed_study(p90s, (0, 0), None);
    let goal = |text: String| -> String {
        text.lines()
            .find(|l| l.starts_with("- recognition p90"))
            .unwrap()
            .to_string()
    };
    // One bad seed of five: the median meets the goal, the worst seed is named.
    let line = goal(report::seeds_section(&study(&[
        [1.0, 1.5],
        [1.2, 1.1],
        [9.0, 1.3],
        [0.8, 1.4],
        [1.1, 1.2],
    ])));
    assert!(
        line.contains("largest seed median 1.30 px (default, camera 1) — met"),
        "{line}"
    );
    assert!(
        line.contains("worst seed 9.00 px (default, camera 0, seed 3)"),
        "{line}"
    );
    // A median above the limit misses, by how much.
    let line = goal(report::seeds_section(&study(&[
        [2.5, 1.0],
        [2.7, 1.0],
        [0.5, 1.0],
    ])));
    assert!(
        line.contains("largest seed median 2.50 px (default, camera 0) — MISSED by 0.50 px"),
        "{line}"
    );
    // A seed without accepted percepts on a camera (NaN) is a miss, not a seed left out.
    let line = goal(report::seeds_section(&study(&[
        [f64::NAN, 1.0],
        [1.0, 1.0],
        [1.0, 1.0],
    ])));
    assert!(
        line.contains("— MISSED (a seed without accepted percepts: default, camera 0)"),
        "{line}"
    );
}

/// Development runs refuse evaluation seeds and unknown arms before any work, and the study's
/// Jacobian setting is the one `--jacobian-at` overrides.
#[test]
fn development_options_are_checked() {
    let dev = |seeds: Vec<u64>, arms: Vec<&str>| super::ServoArgs {
        development: true,
        dev_seeds: seeds,
        only_arms: arms.into_iter().map(String::from).collect(),
        ..Default::default()
    };
    for seed in [7001, 8004, 9003] {
        let e = super::seeds::run_all(&dev(vec![1006, seed], vec![])).unwrap_err();
        assert!(
            e.to_string()
                .contains(&format!("seed {seed} is kept for evaluation")),
            "{e}"
        );
    }
    let e = super::seeds::run_all(&dev(vec![1006], vec!["default", "bent-arm"])).unwrap_err();
    assert!(e.to_string().contains("no shipped arm `bent-arm`"), "{e}");
    let missing = super::ServoArgs {
        dev_arms: vec!["/nonexistent/harsh-arm.json".into()],
        ..dev(vec![1006], vec!["default"])
    };
    let e = super::seeds::run_all(&missing).unwrap_err();
    assert!(e.to_string().contains("harsh-arm.json"), "{e}");

    let mut p = Protocol::default_for(1);
    assert_eq!(p.jacobian_at, super::STUDY_JACOBIAN_AT);
    let args = super::ServoArgs {
        jacobian_at: Some(servo_loop::JacobianAt::Current),
        ..Default::default()
    };
    args.apply_settings(&mut p);
    assert_eq!(p.jacobian_at, servo_loop::JacobianAt::Current);
    assert_eq!(
        super::servo_config(&p).jacobian_at,
        servo_loop::JacobianAt::Current
    );
    assert!(super::parse_jacobian_at("target").is_ok());
    assert!(super::parse_jacobian_at("middle").is_err());
}
