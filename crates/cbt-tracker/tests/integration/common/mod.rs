//! Data shared by the save-and-load tests (`corrupt`, `restore`, `saved_form`),
//! `per_position`, `rejected_input` and the oracles (`baselines`, `oracles`).

use cbt_tracker::sim::{Level, Scenario, generate, rng_for};
use cbt_tracker::{CbtConfig, CbtModel, Layout, Order, Scales, Sequence, Space};
use cbt_tracker::{Detection, Frame};
use rand::RngExt;

/// Image width and height of the shared data.
pub const W: f64 = 96.0;
pub const H: f64 = 72.0;

/// Two training sequences of 60 frames and one test sequence of 30 (level 2, seeds 41, 42).
pub fn data() -> (Vec<Sequence>, Sequence) {
    let sc = Scenario {
        width: W,
        height: H,
        ..Scenario::default()
    };
    let level = Level::preset(2);
    let train = generate(&sc, &level, 2, 60, 41).unwrap();
    let test = generate(&sc, &level, 1, 30, 42).unwrap().remove(0);
    (train, test)
}

/// The stationary layout's grid spacing for `train`: the estimated scales' fine spacing on
/// this image, at least 2 px.
pub fn stationary_spacing(train: &[Sequence]) -> f64 {
    Scales::estimate(train, W)
        .unwrap()
        .fine_spacing(W)
        .unwrap()
        .max(2.0)
}

/// A model of `layout` and `order` learned on `train`: the stationary layout with its own
/// defaults on the grid of [`stationary_spacing`], the dense layouts with the default
/// configuration on an 8 px grid.
pub fn model(train: &[Sequence], layout: Layout, order: Order) -> CbtModel {
    let (cfg, spacing) = if layout == Layout::Stationary {
        (CbtConfig::stationary(), stationary_spacing(train))
    } else {
        (CbtConfig::default(), 8.0)
    };
    let cfg = CbtConfig {
        layout,
        order,
        ..cfg
    };
    CbtModel::learn_sequences(Space::image(W, H, spacing).unwrap(), cfg, train).unwrap()
}

/// Random short sequences with gaps in the truth, empty frames, misses and clutter near and
/// far, on a coarse lattice (so residuals tie and the median's choice matters).
pub fn lattice_sequences(seed: u64, stream: u64) -> Vec<Sequence> {
    let mut rng = rng_for(seed, stream);
    (0..rng.random_range(1..4))
        .map(|_| {
            let mut p = [rng.random_range(0.0..50.0), rng.random_range(0.0..50.0)];
            let v = [rng.random_range(-2.0..2.0), rng.random_range(-2.0..2.0)];
            let frames = (0..rng.random_range(3..12))
                .map(|_| {
                    p[0] += v[0] + f64::from(rng.random_range(-3..=3i32)) * 0.5;
                    p[1] += v[1] + f64::from(rng.random_range(-3..=3i32)) * 0.5;
                    let truth = (rng.random_range(0..6) != 0).then_some(p);
                    let detections = (0..rng.random_range(0..4))
                        .map(|_| {
                            let r = if rng.random_range(0..3) == 0 {
                                40.0
                            } else {
                                3.0
                            };
                            Detection::new(
                                p[0] + (r * rng.random_range(-1.0..1.0f64)).round() * 0.5,
                                p[1] + (r * rng.random_range(-1.0..1.0f64)).round() * 0.5,
                            )
                        })
                        .collect();
                    Frame { truth, detections }
                })
                .collect();
            Sequence {
                frames,
                ..Default::default()
            }
        })
        .collect()
}
