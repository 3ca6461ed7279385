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
