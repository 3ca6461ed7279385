//! Learning to control (Paper C, "action precedes perception"): apply random commands, observe
//! the percept each one produces, and train the inverse model on the (percept → command)
//! pairs, one at a time (LWPR is incremental, so the model is usable after every move).

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use rand::SeedableRng;
use rand::rngs::Xoshiro256PlusPlus;
use rand_distr::{Distribution, StandardUniform};
use serde::{Deserialize, Serialize};

use crate::approach::{Approach, ApproachState};
use crate::error::{Result, ServoError};
use crate::inverse::InverseModel;
use crate::plant::{Plant, check_command};

/// Settings of a learning session.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LearnConfig {
    /// Number of random moves.
    pub moves: usize,
    /// Range `[min, max]` of each controlled set-point the random moves are drawn from
    /// (uniformly); must lie inside the plant's command range.
    pub explore: Vec<[f64; 2]>,
    /// Seed of the random moves.
    pub seed: u64,
    /// Draw a progress bar on stderr (indicatif; hidden when stderr is not a terminal).
    pub progress: bool,
    /// Execute every move with the unidirectional approach ([`crate::approach`]), as the
    /// servo loop will, so that the learned map describes where the joints end when
    /// approached that way (`None`: send each command as it is).
    #[serde(default)]
    pub approach: Option<Approach>,
}

/// What a learning session did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct LearnReport {
    /// Moves executed.
    pub executed: usize,
    /// Moves whose percept was recognised and used for training.
    pub used: usize,
    /// Moves skipped because the gripper was not recognised (e.g. out of view).
    pub not_recognised: usize,
    /// Moves skipped because the percept was refused ([`ServoError::PerceptRefused`]).
    #[serde(default)]
    pub refused: usize,
}

/// The random command generator of [`learn_control`] (uniform in the exploration box, seeded).
#[derive(Debug, Clone)]
pub struct RandomCommands {
    rng: Xoshiro256PlusPlus,
    explore: Vec<[f64; 2]>,
}

impl RandomCommands {
    /// Commands uniform in `explore`, from `seed`.
    pub fn new(explore: &[[f64; 2]], seed: u64) -> Result<Self> {
        for (j, &[lo, hi]) in explore.iter().enumerate() {
            if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
                return Err(ServoError::InvalidParameter {
                    name: "explore",
                    reason: format!("range {j} = [{lo}, {hi}] is not a finite interval"),
                });
            }
        }
        Ok(RandomCommands {
            rng: Xoshiro256PlusPlus::seed_from_u64(seed),
            explore: explore.to_vec(),
        })
    }

    /// The next command.
    pub fn next_command(&mut self) -> Vec<f64> {
        self.explore
            .iter()
            .map(|&[lo, hi]| {
                let u: f64 = StandardUniform.sample(&mut self.rng);
                lo + u * (hi - lo)
            })
            .collect()
    }
}

/// Applies `config.moves` random commands to `plant` and trains `model` on every recognised
/// (percept, command) pair. `on_move(k, model)` is called after move `k` (1-based) — e.g. to
/// keep snapshots of the model at chosen training sizes.
///
/// Recognition failures skip the move (counted in [`LearnReport::not_recognised`]); any other
/// error stops learning and is returned, with the model holding every completed move.
pub fn learn_control<P: Plant + ?Sized>(
    plant: &mut P,
    model: &mut InverseModel,
    config: &LearnConfig,
    mut on_move: impl FnMut(usize, &InverseModel),
) -> Result<LearnReport> {
    if config.explore.len() != plant.command_dim() {
        return Err(ServoError::DimensionMismatch {
            what: "explore ranges",
            expected: plant.command_dim(),
            got: config.explore.len(),
        });
    }
    if model.percept_dim() != plant.percept_dim() || model.command_dim() != plant.command_dim() {
        return Err(ServoError::DimensionMismatch {
            what: "inverse model (percept × command)",
            expected: plant.percept_dim() * plant.command_dim(),
            got: model.percept_dim() * model.command_dim(),
        });
    }
    let mut commands = RandomCommands::new(&config.explore, config.seed)?;
    for (j, &[lo, hi]) in config.explore.iter().enumerate() {
        let [min, max] = plant.command_range(j);
        if lo < min || hi > max {
            return Err(ServoError::InvalidParameter {
                name: "explore",
                reason: format!("range {j} = [{lo}, {hi}] leaves the servo range [{min}, {max}]"),
            });
        }
    }
    if let Some(a) = &config.approach {
        a.validate()?;
    }
    let bar = progress_bar(config.moves as u64, config.progress);
    let mut report = LearnReport::default();
    let mut state = ApproachState::new();
    for k in 1..=config.moves {
        let mut y = commands.next_command();
        match &config.approach {
            Some(a) => {
                y = a.round(&y);
                state.execute(&mut *plant, a, &y, false)?;
            }
            None => {
                check_command(&*plant, &y)?;
                plant.act(&y)?;
            }
        }
        report.executed += 1;
        match plant.observe() {
            Ok(obs) => {
                model.update(&obs.x, &y)?;
                report.used += 1;
            }
            Err(ServoError::RecognitionFailed { .. }) => report.not_recognised += 1,
            Err(ServoError::PerceptRefused { .. }) => report.refused += 1,
            Err(e) => return Err(e),
        }
        on_move(k, model);
        bar.inc(1);
    }
    bar.finish_and_clear();
    if report.used == 0 && config.moves > 0 {
        return Err(ServoError::NotEnoughData(
            "no move produced a recognised percept".into(),
        ));
    }
    Ok(report)
}

/// A progress bar on stderr, or a hidden one.
pub(crate) fn progress_bar(len: u64, visible: bool) -> ProgressBar {
    if !visible {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::with_draw_target(Some(len), ProgressDrawTarget::stderr());
    bar.set_style(
        ProgressStyle::with_template("{msg:>24} [{bar:30}] {pos}/{len} {elapsed}")
            .expect("valid template")
            .progress_chars("=> "),
    );
    bar.set_message("learning to control");
    bar
}
