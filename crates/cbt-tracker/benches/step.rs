//! Criterion bench of one CBT step (predict + update + estimate) against the particle filter
//! with 1,000 particles and the Kalman filter, on the same frames of a synthetic L2 sequence:
//! CBT in the stationary layout (the evaluation's image-tracking configuration) and in the
//! dense separable layout.

use cbt_tracker::sim::{Level, Scenario, generate};
use cbt_tracker::{
    Calibration, CbtConfig, CbtModel, CbtTracker, KalmanParams, KalmanTracker, Layout,
    ParticleFilter, PfModel, Scales, Space, Tracker, axis,
};
use criterion::{Criterion, criterion_group, criterion_main};

fn bench(c: &mut Criterion) {
    let sc = Scenario::default();
    let level = Level::preset(2);
    let train = generate(&sc, &level, 4, 300, 1).unwrap();
    let test = generate(&sc, &level, 1, 200, 2).unwrap().remove(0);
    let scales = Scales::estimate(&train, sc.width).unwrap();
    let spacing = scales.spacing(sc.height).unwrap();
    let space = Space::image(sc.width, sc.height, spacing).unwrap();
    let model = CbtModel::learn_sequences(space, CbtConfig::default(), &train).unwrap();
    let fine = scales.fine_spacing(sc.height).unwrap();
    let k = cbt_tracker::DEFAULT_KERNEL;
    let (bx, by) = (
        axis(0.0, sc.width, fine, k).unwrap(),
        axis(0.0, sc.height, fine, k).unwrap(),
    );
    let cfg = CbtConfig {
        layout: Layout::Stationary,
        ..CbtConfig::default()
    };
    let stat = CbtModel::learn_sequences(
        Space::new(vec![bx.clone(), by.clone()], vec![bx, by]).unwrap(),
        cfg,
        &train,
    )
    .unwrap();
    let cal = Calibration::estimate(&train, sc.width / 10.0).unwrap();
    let mut trackers: Vec<(&str, Box<dyn Tracker>)> = vec![
        ("cbt-2nd-stationary", Box::new(CbtTracker::new(stat))),
        ("cbt-2nd-separable-dense", Box::new(CbtTracker::new(model))),
        (
            "pf-1000",
            Box::new(
                ParticleFilter::new(
                    PfModel::from_calibration(&cal, sc.width * sc.height),
                    1000,
                    3,
                )
                .unwrap(),
            ),
        ),
        (
            "kalman-nn",
            Box::new(KalmanTracker::new(KalmanParams::from_calibration(&cal)).unwrap()),
        ),
    ];
    let mut group = c.benchmark_group("predict+update");
    for (name, t) in trackers.iter_mut() {
        let start = test.frames[0].truth.unwrap();
        t.reset(start).unwrap();
        let mut k = 1;
        // Steps through the sequence and restarts at its end (the restart's cost is spread
        // over the 199 steps), so every step tracks a target it has followed from the start.
        group.bench_function(*name, |b| {
            b.iter(|| {
                let e = t.step(&test.frames[k].detections).unwrap();
                k += 1;
                if k == test.frames.len() {
                    k = 1;
                    t.reset(start).unwrap();
                }
                e
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
