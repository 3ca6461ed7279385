//! A linear two-joint plant seen by `cams` rectified cameras: camera `c` sees the point at
//! `(100 + 20c + 200 y₀, 100 + 150 y₁)`, every camera in the same image row; commands in
//! `[0, 1]` (a test module, not part of the library).

use servo_loop::{
    InverseModel, InverseModelConfig, LearnConfig, Observation, Plant, learn_control,
};

pub struct Rectified {
    pub cams: usize,
    /// The last command.
    pub y: Vec<f64>,
    /// What `percept_bounds` reports.
    pub bounds: Option<Vec<[f64; 2]>>,
}

impl Rectified {
    /// `cams` cameras, the arm at `y`, no percept bounds.
    pub fn at(cams: usize, y: [f64; 2]) -> Self {
        Rectified {
            cams,
            y: y.to_vec(),
            bounds: None,
        }
    }

    /// The percept at command `y`.
    pub fn percept(&self, y: &[f64]) -> Vec<f64> {
        (0..self.cams)
            .flat_map(|c| [100.0 + 20.0 * c as f64 + 200.0 * y[0], 100.0 + 150.0 * y[1]])
            .collect()
    }
}

impl Plant for Rectified {
    fn percept_dim(&self) -> usize {
        2 * self.cams
    }
    fn command_dim(&self) -> usize {
        2
    }
    fn command_range(&self, _: usize) -> [f64; 2] {
        [0.0, 1.0]
    }
    fn act(&mut self, y: &[f64]) -> servo_loop::Result<()> {
        self.y = y.to_vec();
        Ok(())
    }
    fn observe(&mut self) -> servo_loop::Result<Observation> {
        Ok(Observation {
            x: self.percept(&self.y),
            certainty: 1.0,
        })
    }
    fn percept_bounds(&self) -> Option<Vec<[f64; 2]>> {
        self.bounds.clone()
    }
}

/// The inverse model's settings for this plant (percepts in hundreds of pixels).
pub fn model_config() -> InverseModelConfig {
    InverseModelConfig {
        percept_scale: 100.0,
        command_scale: 1.0,
        ..InverseModelConfig::default()
    }
}

/// The inverse model of a `cams`-camera plant learned from `moves` random moves (seed `seed`)
/// over the whole command range, starting at `(0.5, 0.5)`.
pub fn learned(cams: usize, moves: usize, seed: u64) -> InverseModel {
    let mut plant = Rectified::at(cams, [0.5, 0.5]);
    let mut model = InverseModel::new(2 * cams, 2, &model_config()).unwrap();
    let learn = LearnConfig {
        moves,
        explore: vec![[0.0, 1.0]; 2],
        seed,
        approach: None,
    };
    learn_control(&mut plant, &mut model, &learn, |_, _| {}).unwrap();
    model
}
