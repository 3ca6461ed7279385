//! Diagnosis on validation seeds (7000 + level; the evaluation's test seeds are 2000 + level):
//! RMSE and time per frame of CBT (stationary layout, 2nd and 1st order) against the
//! 1,000-particle filter. `cargo run --release -p cbt-tracker --example diag [levels...]`.
//! Environment: `ROWS=1` prints every sequence; `SPF=f` scales the channel spacing by `f`;
//! `ONLY=cbt|pf|learn` runs only that part (for instruction counts with callgrind);
//! `DIGEST=1` prints a bit-exact fingerprint of every run's estimates.

use std::time::Instant;

/// RMSE and seconds per frame of CBT 2nd order, CBT 1st order and PF 1000 on one sequence.
type Row = ((f64, f64), (f64, f64), (f64, f64));

use cbt_tracker::metrics::score;
use cbt_tracker::sim::{Level, Scenario, generate};
use cbt_tracker::{
    Calibration, CbtConfig, CbtModel, CbtTracker, Layout, Order, ParticleFilter, PfModel, Point,
    Scales, Sequence, Space, Tracker, axis,
};

fn run(t: &mut dyn Tracker, s: &Sequence) -> (f64, f64) {
    let start = s.frames[0].truth.unwrap();
    t.reset(start).unwrap();
    let mut est = vec![start];
    let t0 = Instant::now();
    for f in &s.frames[1..] {
        let e = match t.step(&f.detections) {
            Ok(e) => e,
            Err(_) => t.step(&[]).unwrap(),
        };
        est.push(e.position);
    }
    let dt = t0.elapsed().as_secs_f64() / (s.frames.len() - 1) as f64;
    if std::env::var("DIGEST").is_ok() {
        // Bit-exact fingerprint of the estimates (to check that a speed-up changes nothing).
        let h = est.iter().fold(0u64, |h, p| {
            (h ^ p[0].to_bits() ^ p[1].to_bits().rotate_left(17)).wrapping_mul(0x100000001b3)
        });
        println!("   digest {} {h:016x}", t.name());
    }
    let truths: Vec<Option<Point>> = s.frames.iter().map(|f| f.truth).collect();
    (score(&est, &truths, 2, 20.0).unwrap().rmse, dt)
}

fn main() {
    let args: Vec<usize> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let levels = if args.is_empty() {
        vec![0, 1, 2, 3, 4]
    } else {
        args
    };
    let sc = Scenario::default();
    let extent = sc.width.min(sc.height);
    for &i in &levels {
        let lv = Level::preset(i);
        let train = generate(&sc, &lv, 4, 300, 1000 + i as u64).unwrap();
        let val = generate(&sc, &lv, 8, 150, 7000 + i as u64).unwrap();
        let scales = Scales::estimate(&train, extent).unwrap();
        let f: f64 = std::env::var("SPF")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(1.0);
        let sp = scales.fine_spacing(extent).unwrap() * f;
        let k = cbt_tracker::DEFAULT_KERNEL;
        let (bx, by) = (
            axis(0.0, sc.width, sp, k).unwrap(),
            axis(0.0, sc.height, sp, k).unwrap(),
        );
        let space = Space::new(vec![bx.clone(), by.clone()], vec![bx, by]).unwrap();
        let cfg = CbtConfig {
            layout: Layout::Stationary,
            ..CbtConfig::default()
        };
        let m2 = CbtModel::learn_sequences(space.clone(), cfg, &train).unwrap();
        let m1 = CbtModel::learn_sequences(
            space.clone(),
            CbtConfig {
                order: Order::First,
                ..cfg
            },
            &train,
        )
        .unwrap();
        println!(
            "L{i}: spacing {sp:.2}, stat obs {:?}",
            m2.stationary_observation()
        );
        let cal = Calibration::estimate(&train, extent / 10.0).unwrap();
        let pfm = PfModel::from_calibration(&cal, sc.width * sc.height);
        let mut rows = vec![];
        let only = std::env::var("ONLY").unwrap_or_default();
        if only == "learn" {
            continue;
        }
        for (si, s) in val.iter().enumerate() {
            let a = if only.is_empty() || only == "cbt" {
                run(&mut CbtTracker::new(m2.clone()), s)
            } else {
                (0.0, 0.0)
            };
            let b = if only.is_empty() {
                run(&mut CbtTracker::new(m1.clone()), s)
            } else {
                (0.0, 0.0)
            };
            let c = if only.is_empty() || only == "pf" {
                run(
                    &mut ParticleFilter::new(pfm, 1000, 5000 + si as u64).unwrap(),
                    s,
                )
            } else {
                (0.0, 0.0)
            };
            rows.push((a, b, c));
        }
        let n = rows.len() as f64;
        let mean = |f: &dyn Fn(&Row) -> f64| rows.iter().map(f).sum::<f64>() / n;
        let wins = rows.iter().filter(|r| r.0.0 <= r.2.0).count();
        for r in rows.iter().filter(|_| std::env::var("ROWS").is_ok()) {
            println!("   cbt2 {:6.2} cbt1 {:6.2} pf {:6.2}", r.0.0, r.1.0, r.2.0);
        }
        println!(
            "  mean RMSE cbt2 {:.2} cbt1 {:.2} pf1000 {:.2}; cbt2 wins {wins}/{}; time µs cbt2 {:.1} cbt1 {:.1} pf {:.1}",
            mean(&|r| r.0.0),
            mean(&|r| r.1.0),
            mean(&|r| r.2.0),
            rows.len(),
            mean(&|r| r.0.1) * 1e6,
            mean(&|r| r.1.1) * 1e6,
            mean(&|r| r.2.1) * 1e6
        );
    }
}
