//! Property tests: the posterior stays a probability vector after every step, in every
//! configuration; shifting all training and test data by whole channels shifts the estimates
//! by the same amount.

use cbt_tracker::sim::rng_for;
use cbt_tracker::{
    CbtConfig, CbtModel, CbtTracker, Clutter, Detection, Layout, Order, Space, Tracker,
    TrainingFrame,
};
use chan_repr::{ChannelBasis, Kernel};
use proptest::prelude::*;
use rand::RngExt;
use rand_distr::{Distribution, StandardNormal};

/// A 1-D random walk with noisy detections and uniform clutter on `[lo, hi]`, shifted by
/// `shift`.
fn walk(seed: u64, frames: usize, lo: f64, hi: f64, shift: f64) -> Vec<TrainingFrame> {
    let mut rng = rng_for(seed, 0);
    let mut x = 0.5 * (lo + hi);
    let mut v = 0.0;
    (0..frames)
        .map(|_| {
            let a: f64 = StandardNormal.sample(&mut rng);
            v = 0.8 * v + 0.3 * a;
            x = (x + v).clamp(lo, hi);
            let n: f64 = StandardNormal.sample(&mut rng);
            let mut dets = vec![Detection::new((x + 0.4 * n).clamp(lo, hi) + shift, 0.0)];
            if rng.random::<f64>() < 0.5 {
                dets.push(Detection::new(
                    lo + (hi - lo) * rng.random::<f64>() + shift,
                    0.0,
                ));
            }
            if rng.random::<f64>() < 0.1 {
                dets.clear();
            }
            TrainingFrame {
                states: vec![[x + shift, 0.0]],
                detections: dets,
            }
        })
        .collect()
}

fn config(order: bool, joint: bool, clutter: u8) -> CbtConfig {
    CbtConfig {
        order: if order { Order::Second } else { Order::First },
        layout: if joint {
            Layout::SparseJoint
        } else {
            Layout::Separable
        },
        clutter: match clutter {
            0 => Clutter::Model,
            1 => Clutter::Subtract,
            _ => Clutter::Uniform,
        },
        ..CbtConfig::default()
    }
}

proptest! {
    #![proptest_config(crate::seeded(24))]

    #[test]
    fn posterior_is_a_probability_vector(
        seed in 0u64..1000,
        order in any::<bool>(),
        joint in any::<bool>(),
        clutter in 0u8..3,
        two_d in any::<bool>(),
        weights in proptest::collection::vec(0.0f64..3.0, 30),
    ) {
        let cfg = config(order, joint, clutter);
        let (space, to2) = if two_d {
            (Space::image(40.0, 30.0, 2.5).unwrap(), true)
        } else {
            let b = ChannelBasis::covering(0.0, 30.0, 24, Kernel::Cos2 { m: 3 }).unwrap();
            (Space::new(vec![b.clone()], vec![b]).unwrap(), false)
        };
        let lift = |fs: Vec<TrainingFrame>, other: u64| -> Vec<TrainingFrame> {
            if !to2 { return fs; }
            let ys = walk(other, fs.len(), 2.0, 28.0, 0.0);
            fs.into_iter().zip(ys).map(|(f, g)| TrainingFrame {
                states: vec![[f.states[0][0], g.states[0][0]]],
                detections: f.detections.iter().zip(g.detections.iter().chain(std::iter::repeat(&Detection::new(15.0, 0.0))))
                    .map(|(a, b)| Detection::new(a.pos[0], b.pos[0])).collect(),
            }).collect()
        };
        let train = lift(walk(seed, 150, 2.0, 28.0, 0.0), seed + 7);
        let model = CbtModel::learn(space, cfg, &[train]).unwrap();
        let test = lift(walk(seed + 1, 30, 2.0, 28.0, 0.0), seed + 8);
        let mut t = CbtTracker::new(model);
        t.reset(test[0].states[0]).unwrap();
        for (f, w) in test.iter().zip(&weights) {
            let dets: Vec<Detection> = f.detections.iter().map(|d| Detection { pos: d.pos, weight: *w }).collect();
            t.step(&dets).unwrap();
            let q = t.posterior();
            prop_assert!(q.iter().all(|v| v.is_finite() && *v >= 0.0));
            let s: f64 = q.iter().sum();
            prop_assert!((s - 1.0).abs() < 1e-9, "sum {}", s);
        }
    }

    #[test]
    fn integer_channel_shifts_are_equivariant(
        seed in 0u64..1000,
        shift in 1usize..12,
        order in any::<bool>(),
    ) {
        // 48 channels of spacing 1 on [0, 46]; data on [12, 26], shifted by up to 11.
        let b = ChannelBasis::covering(0.0, 46.0, 48, Kernel::Cos2 { m: 3 }).unwrap();
        prop_assert!((b.spacing() - 1.0).abs() < 1e-12);
        let space = Space::new(vec![b.clone()], vec![b]).unwrap();
        let cfg = config(order, false, 0);
        let estimates = |s: f64| -> Vec<f64> {
            let train = walk(seed, 300, 12.0, 26.0, s);
            let model = CbtModel::learn(space.clone(), cfg, &[train]).unwrap();
            let test = walk(seed + 1, 40, 12.0, 26.0, s);
            let mut t = CbtTracker::new(model);
            t.reset(test[0].states[0]).unwrap();
            test[1..].iter().map(|f| t.step(&f.detections).unwrap().position[0]).collect()
        };
        let (a, b) = (estimates(0.0), estimates(shift as f64));
        for (x, y) in a.iter().zip(&b) {
            prop_assert!((y - x - shift as f64).abs() < 1e-6, "{} vs {} (shift {})", x, y, shift);
        }
    }
}
