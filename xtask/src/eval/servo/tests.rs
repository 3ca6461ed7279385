//! A small, fast run of the servo study with an insta snapshot of its summary.

use arm_sim::SimConfig;

use super::{PerceptMode, Protocol, report, run_study};

#[test]
fn small_study_summary_snapshot() {
    let mut p = Protocol::default_for(7);
    p.training_moves = 300;
    p.curve_moves = vec![100, 300];
    p.curve_targets = 10;
    p.targets = 20;
    // Control only (true tip + noise): the recognised pipeline runs in `cargo xtask eval servo`.
    p.percept = PerceptMode::Simulated;
    let study = run_study(&SimConfig::default(), &p, false, false, None).unwrap();
    let text = report::summary(&study);
    // The loop must improve on open loop.
    let stats = report::method_stats("lwpr", &study.per_method[0].1, &p);
    assert!(stats.per_iteration[5].median_px < stats.per_iteration[0].median_px);
    insta::assert_snapshot!("servo_small_summary", text);
}
