//! Data shared by the save-and-load tests (`corrupt`, `restore`, `saved_form`),
//! `per_position` and `rejected_input`.

use cbt_tracker::sim::{Level, Scenario, generate};
use cbt_tracker::{CbtConfig, CbtModel, Layout, Order, Scales, Sequence, Space};

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
#[allow(dead_code)] // Not every test binary that shares this module learns a model.
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
