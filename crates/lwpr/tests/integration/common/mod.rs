//! Models and data that several of the integration tests train on, each written once here
//! (the cross-function stream and the reference's settings are in `peer/harness.rs`, which the
//! tests' `main.rs` includes as `harness`; `five_d.rs`, the 5-D model of the save/load tests, is
//! used by `xml.rs` and included by the unit tests of `src/io.rs`).

use crate::harness::{cross_samples, embed, random_rotation, setting_25d};
use lwpr::{Kernel, LwprBuilder, PruneRule};

/// Two-output samples: the cross function `y1` and `10 sin(x₁ + x₂)`, interleaved per sample.
pub fn two_outputs(x: &[f64], y1: &[f64]) -> Vec<f64> {
    y1.iter()
        .zip(x.chunks(2))
        .flat_map(|(a, p)| [*a, 10.0 * (p[0] + p[1]).sin()])
        .collect()
}

/// The two-output model: BiSquare kernel, `init_D = 10·I`, `w_gen = 0.2`, inputs and outputs
/// normalised (`norm_in = [2, 1]`, `norm_out = [1, 10]`).
pub fn two_output_builder() -> LwprBuilder {
    LwprBuilder::new(2, 2)
        .init_d_spherical(10.0)
        .w_gen(0.2)
        .norm_in(&[2.0, 1.0])
        .norm_out(&[1.0, 10.0])
        .kernel(Kernel::BiSquare)
}

/// The cross function rotated into 25 dimensions: 4 000 samples of seed 5 through the rotation
/// of seed 7 (`cargo xtask bench lwpr` streams 20 000).
pub struct Cross25 {
    /// Input dimension, 25.
    pub dim: usize,
    /// The rotation (`dim × dim`, row-major).
    pub q: Vec<f64>,
    /// Inputs (`dim` per sample) and targets.
    pub x: Vec<f64>,
    pub y: Vec<f64>,
}

impl Cross25 {
    pub fn new() -> Self {
        let dim = 25;
        let q = random_rotation(dim, 7);
        let (x2, y) = cross_samples(5, 4_000, 0.1);
        let x = embed(&x2, &q, dim);
        Cross25 { dim, q, x, y }
    }

    /// `setting_25d` with the reference's pruning rule, stated explicitly because pruning
    /// fires in this setting.
    pub fn builder(&self) -> LwprBuilder {
        setting_25d(self.dim).prune_rule(PruneRule::ReferenceC)
    }

    /// `points` (2-D, two per point) rotated like the samples.
    pub fn embed(&self, points: &[f64]) -> Vec<f64> {
        embed(points, &self.q, self.dim)
    }
}

pub mod five_d;
