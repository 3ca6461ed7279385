//! Development runs for UNGM's known input: how many phase channels (`PeriodicInput`) the
//! phase-conditioned CBT gets. Trained on the evaluation's training runs (seed 3000), scored
//! on development runs (seed 3002; the evaluation's test runs are seed 3001 and were not used
//! for this choice). `cargo run --release -p cbt-tracker --example ungm_phase`.

use cbt_tracker::sim::Ungm;
use cbt_tracker::{
    CbtConfig, CbtModel, CbtTracker, DEFAULT_KERNEL, LearnedParticleFilter, ObservationFallback,
    Order, PeriodicInput, Sequence, Space, TrackError, Tracker, axis, metrics,
};

fn rmse(t: &mut dyn Tracker, s: &Sequence) -> f64 {
    t.reset(s.frames[0].truth.unwrap()).unwrap();
    let mut est = vec![s.frames[0].truth.unwrap()];
    for f in &s.frames[1..] {
        let e = match t.step(&f.detections) {
            Err(TrackError::OutsideGrid { .. }) => t.step(&[]).unwrap(),
            r => r.unwrap(),
        };
        est.push(e.position);
    }
    let truths: Vec<_> = s.frames.iter().map(|f| f.truth).collect();
    metrics::score(&est, &truths, 1, 5.0).unwrap().rmse
}

/// CBT's RMSE with the posterior mean (`Σ_n q_n x̃_n / Σ_n q_n`) as its estimate instead of
/// the best mode: what the estimate, not the filter, costs on a bimodal posterior.
fn rmse_mean(t: &mut CbtTracker, s: &Sequence) -> f64 {
    t.reset(s.frames[0].truth.unwrap()).unwrap();
    let b = t.model().space().state_basis(0).clone();
    let mut est = vec![s.frames[0].truth.unwrap()];
    for f in &s.frames[1..] {
        if t.step(&f.detections).is_err() {
            t.step(&[]).unwrap();
        }
        let q = t.posterior();
        let m = q
            .iter()
            .enumerate()
            .map(|(i, v)| v * b.centre(i))
            .sum::<f64>()
            / q.iter().sum::<f64>();
        est.push([m, 0.0]);
    }
    let truths: Vec<_> = s.frames.iter().map(|f| f.truth).collect();
    metrics::score(&est, &truths, 1, 5.0).unwrap().rmse
}

fn main() {
    let u = Ungm::default();
    let train = u.generate(20, 100, 3000).unwrap();
    let dev = u.generate(10, 100, 3002).unwrap();
    // The evaluation's grid: the training extent +5 (state), +3 (measurement), spacing 1.
    let (mut xl, mut xh, mut zl, mut zh) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for s in &train {
        for f in &s.frames {
            let t = f.truth.unwrap()[0];
            (xl, xh) = (xl.min(t), xh.max(t));
            for d in &f.detections {
                (zl, zh) = (zl.min(d.pos[0]), zh.max(d.pos[0]));
            }
        }
    }
    let state = axis(xl - 5.0, xh + 5.0, 1.0, DEFAULT_KERNEL).unwrap();
    let meas = axis(zl - 3.0, zh + 3.0, 1.0, DEFAULT_KERNEL).unwrap();
    let space = Space::new(vec![state], vec![meas]).unwrap();
    let base = CbtConfig {
        order: Order::First,
        observation_fallback: ObservationFallback::Uniform,
        ..CbtConfig::default()
    };
    let mean = |f: &dyn Fn(&Sequence) -> f64| dev.iter().map(f).sum::<f64>() / dev.len() as f64;
    let m = CbtModel::learn_sequences(space.clone(), base, &train).unwrap();
    println!(
        "no input: CBT 1st {:.2}, PF 1000 learned {:.2}",
        mean(&|s| rmse(&mut CbtTracker::new(m.clone()), s)),
        mean(&|s| rmse(
            &mut LearnedParticleFilter::new(m.clone(), 1000, 1).unwrap(),
            s
        ))
    );
    for channels in [6, 8, 12, 16, 24] {
        let cfg = CbtConfig {
            input: Some(PeriodicInput {
                omega: 1.2,
                channels,
            }),
            ..base
        };
        let m = CbtModel::learn_sequences(space.clone(), cfg, &train).unwrap();
        println!(
            "{channels:>2} phase channels: CBT 1st + phase {:.2} (posterior mean as the \
             estimate: {:.2}), PF 1000 learned + phase {:.2}",
            mean(&|s| rmse(&mut CbtTracker::new(m.clone()), s)),
            mean(&|s| rmse_mean(&mut CbtTracker::new(m.clone()), s)),
            mean(&|s| rmse(
                &mut LearnedParticleFilter::new(m.clone(), 1000, 1).unwrap(),
                s
            ))
        );
    }
}
