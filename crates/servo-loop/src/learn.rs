//! Learning to control (Paper C, "action precedes perception"): apply random commands, observe
//! the percept each one produces, and train the inverse model on the (percept → command)
//! pairs, one at a time (LWPR is incremental, so the model is usable after every move).

use rand::SeedableRng;
use rand::rngs::Xoshiro256PlusPlus;
use rand_distr::{Distribution, StandardUniform};
use serde::{Deserialize, Serialize};

use crate::approach::{Approach, ApproachDirection, ApproachState};
use crate::error::{Result, ServoError};
use crate::inverse::InverseModel;
use crate::plant::{Plant, check_command, checked_range};

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
            // The width must be finite too: finite ends such as ±1e308 drew infinite commands.
            if !(lo.is_finite() && hi.is_finite() && lo <= hi && (hi - lo).is_finite()) {
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

/// `points` in the order of a minimum cover by chains that are monotone in the approach
/// `direction` (every joint moves that way from one point to the next, so the unidirectional
/// approach needs no pre-position within a chain): the chains of a maximum matching in the
/// bipartite graph of the order `p ≤ q` (Dilworth via Fulkerson; Kuhn's augmenting paths,
/// `O(n³)` for a block of `n`), each chain from its lowest point, chains by their first
/// point's coordinate sum. Deterministic for given points.
pub fn chain_order(points: Vec<Vec<f64>>, direction: ApproachDirection) -> Vec<Vec<f64>> {
    let s = match direction {
        ApproachDirection::Up => 1.0,
        ApproachDirection::Down => -1.0,
    };
    let n = points.len();
    let before = |i: usize, j: usize| {
        i != j
            && points[i]
                .iter()
                .zip(&points[j])
                .all(|(a, b)| s * (b - a) >= 0.0)
            && (points[i] != points[j] || i < j)
    };
    let succ: Vec<Vec<usize>> = (0..n)
        .map(|i| (0..n).filter(|&j| before(i, j)).collect())
        .collect();
    // pred[j] = i: j follows i in its chain.
    let mut pred: Vec<Option<usize>> = vec![None; n];
    fn augment(
        u: usize,
        succ: &[Vec<usize>],
        pred: &mut [Option<usize>],
        seen: &mut [bool],
    ) -> bool {
        for &v in &succ[u] {
            if !seen[v] {
                seen[v] = true;
                if pred[v].is_none_or(|w| augment(w, succ, pred, seen)) {
                    pred[v] = Some(u);
                    return true;
                }
            }
        }
        false
    }
    for u in 0..n {
        let mut seen = vec![false; n];
        augment(u, &succ, &mut pred, &mut seen);
    }
    let mut next: Vec<Option<usize>> = vec![None; n];
    for (v, p) in pred.iter().enumerate() {
        if let Some(u) = p {
            next[*u] = Some(v);
        }
    }
    let key = |i: usize| s * points[i].iter().sum::<f64>();
    let mut starts: Vec<usize> = (0..n).filter(|&i| pred[i].is_none()).collect();
    starts.sort_by(|&a, &b| key(a).total_cmp(&key(b)).then(a.cmp(&b)));
    let mut order = Vec::with_capacity(n);
    for start in starts {
        let mut at = Some(start);
        while let Some(i) = at {
            order.push(i);
            at = next[i];
        }
    }
    order.into_iter().map(|i| points[i].clone()).collect()
}

/// Applies `config.moves` random commands to `plant` and trains `model` on every recognised
/// (percept, command) pair. `on_move(k, model)` is called after move `k` (1-based) — e.g. to
/// keep snapshots of the model at chosen training sizes, or to draw the caller's progress bar
/// (the library draws none).
///
/// Recognition failures skip the move (counted in [`LearnReport::not_recognised`]), and so do
/// refused percepts ([`ServoError::PerceptRefused`], counted in [`LearnReport::refused`]); any
/// other error stops learning and is returned, with the model holding every completed move.
/// When no move gave a percept, [`ServoError::NotEnoughData`].
pub fn learn_control<P: Plant + ?Sized>(
    plant: &mut P,
    model: &mut InverseModel,
    config: &LearnConfig,
    on_move: impl FnMut(usize, &InverseModel),
) -> Result<LearnReport> {
    learn_control_chained(plant, model, config, 0, on_move)
}

/// As [`learn_control`], but with an approach the random commands are drawn in blocks of
/// `chain_block` and each block is executed in [`chain_order`], so that most moves already end
/// in the approach direction and need no pre-position (`chain_block ≤ 1`, or no approach: the
/// drawn order). The commands are the same as [`learn_control`]'s (rounded to the approach's
/// resolution); only their order within a block changes.
pub fn learn_control_chained<P: Plant + ?Sized>(
    plant: &mut P,
    model: &mut InverseModel,
    config: &LearnConfig,
    chain_block: usize,
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
            // Saturating: a plant's own dimensions may be absurd (this overflowed).
            expected: plant.percept_dim().saturating_mul(plant.command_dim()),
            got: model.percept_dim().saturating_mul(model.command_dim()),
        });
    }
    let mut commands = RandomCommands::new(&config.explore, config.seed)?;
    for (j, &[lo, hi]) in config.explore.iter().enumerate() {
        let [min, max] = checked_range(plant, j)?;
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
    let mut report = LearnReport::default();
    let mut state = ApproachState::new();
    let mut queue: std::collections::VecDeque<Vec<f64>> = Default::default();
    for k in 1..=config.moves {
        let mut y = match (&config.approach, chain_block) {
            (Some(a), block) if block > 1 => {
                if queue.is_empty() {
                    // The moves left, `k ≤ moves` (`moves + 1 − k` overflowed for usize::MAX).
                    let n = block.min(config.moves - k + 1);
                    let drawn = (0..n).map(|_| a.round(&commands.next_command())).collect();
                    queue = chain_order(drawn, a.direction).into();
                }
                queue.pop_front().expect("a non-empty block")
            }
            _ => commands.next_command(),
        };
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
    }
    if report.used == 0 && config.moves > 0 {
        return Err(ServoError::NotEnoughData(
            "no move produced a recognised percept".into(),
        ));
    }
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::approach::Approach;

    /// Pre-positions the unidirectional approach needs to visit `points` in order.
    fn pre_positions(points: &[Vec<f64>]) -> usize {
        1 + points
            .windows(2)
            .filter(|w| w[0].iter().zip(&w[1]).any(|(a, b)| b < a))
            .count()
    }

    /// The fewest monotone chains covering `points`, by brute force over every assignment of
    /// points to chains (small inputs only).
    fn brute_min_chains(points: &[Vec<f64>]) -> usize {
        let le = |a: &Vec<f64>, b: &Vec<f64>| a.iter().zip(b).all(|(x, y)| x <= y);
        let n = points.len();
        // Try k chains: every labelling of the points with 0..k, each chain totally ordered.
        for k in 1..=n {
            let mut labels = vec![0usize; n];
            loop {
                let ok = (0..k).all(|c| {
                    let members: Vec<&Vec<f64>> = (0..n)
                        .filter(|&i| labels[i] == c)
                        .map(|i| &points[i])
                        .collect();
                    members
                        .iter()
                        .all(|a| members.iter().all(|b| le(a, b) || le(b, a)))
                });
                if ok {
                    return k;
                }
                let mut i = 0;
                while i < n {
                    labels[i] += 1;
                    if labels[i] < k {
                        break;
                    }
                    labels[i] = 0;
                    i += 1;
                }
                if i == n {
                    break;
                }
            }
        }
        n
    }

    #[test]
    fn chain_order_is_a_minimum_monotone_cover_of_the_same_points() {
        for seed in 0..30 {
            let mut r = RandomCommands::new(&[[0.0, 4.0]; 3], seed).unwrap();
            let points: Vec<Vec<f64>> = (0..7)
                .map(|_| r.next_command().iter().map(|v| v.round()).collect())
                .collect();
            let ordered = chain_order(points.clone(), ApproachDirection::Up);
            let mut a = points.clone();
            let mut b = ordered.clone();
            a.sort_by(|x, y| x.partial_cmp(y).unwrap());
            b.sort_by(|x, y| x.partial_cmp(y).unwrap());
            assert_eq!(a, b, "a permutation");
            assert_eq!(
                pre_positions(&ordered),
                brute_min_chains(&points),
                "{points:?}"
            );
            // Down mirrors Up.
            let neg: Vec<Vec<f64>> = points
                .iter()
                .map(|p| p.iter().map(|v| -v).collect())
                .collect();
            assert_eq!(
                pre_positions(
                    &chain_order(neg, ApproachDirection::Down)
                        .iter()
                        .map(|p| p.iter().map(|v| -v).collect())
                        .collect::<Vec<_>>()
                ),
                brute_min_chains(&points)
            );
        }
    }

    /// A plant that counts its commands (percept = command).
    struct Counting(usize);
    impl Plant for Counting {
        fn command_dim(&self) -> usize {
            3
        }
        fn percept_dim(&self) -> usize {
            3
        }
        fn command_range(&self, _: usize) -> [f64; 2] {
            [0.0, 3000.0]
        }
        fn act(&mut self, _: &[f64]) -> Result<()> {
            self.0 += 1;
            Ok(())
        }
        fn observe(&mut self) -> Result<crate::plant::Observation> {
            Err(ServoError::RecognitionFailed {
                camera: 0,
                certainty: 0.0,
                min: 0.5,
            })
        }
    }

    /// A plant that records the command of every percept it gives (percept = command).
    #[derive(Default)]
    struct Recording {
        y: Vec<f64>,
        seen: Vec<Vec<f64>>,
    }
    impl Plant for Recording {
        fn command_dim(&self) -> usize {
            3
        }
        fn percept_dim(&self) -> usize {
            3
        }
        fn command_range(&self, _: usize) -> [f64; 2] {
            [0.0, 3000.0]
        }
        fn act(&mut self, y: &[f64]) -> Result<()> {
            self.y = y.to_vec();
            Ok(())
        }
        fn observe(&mut self) -> Result<crate::plant::Observation> {
            self.seen.push(self.y.clone());
            Ok(crate::plant::Observation {
                x: self.y.clone(),
                certainty: 1.0,
            })
        }
    }

    /// The commands `learn_control_chained` executes and observes, in order.
    fn learned_commands(config: &LearnConfig, chain_block: usize) -> Vec<Vec<f64>> {
        let mut plant = Recording::default();
        let mut model = InverseModel::new(3, 3, &Default::default()).unwrap();
        learn_control_chained(&mut plant, &mut model, config, chain_block, |_, _| {}).unwrap();
        plant.seen
    }

    #[test]
    fn chained_learning_reorders_the_same_commands_within_blocks() {
        let sorted = |mut v: Vec<Vec<f64>>| {
            v.sort_by(|a, b| a.partial_cmp(b).unwrap());
            v
        };
        for seed in 0..4 {
            let config = LearnConfig {
                moves: 40,
                explore: vec![[1000.0, 2000.0]; 3],
                seed,
                approach: Some(Approach::hobby_servo()),
            };
            let drawn = learned_commands(&config, 0);
            assert_eq!(drawn.len(), 40);
            // The same commands as `learn_control`'s (rounded), each block of 7 (the last one
            // 5) in its own chain order.
            let chained = learned_commands(&config, 7);
            assert_ne!(chained, drawn, "reordered");
            assert_eq!(chained.len(), 40);
            for (a, b) in drawn.chunks(7).zip(chained.chunks(7)) {
                assert_eq!(sorted(a.to_vec()), sorted(b.to_vec()), "seed {seed}");
            }
            // A block of one, or no approach: the drawn order.
            assert_eq!(learned_commands(&config, 1), drawn);
            let plain = LearnConfig {
                approach: None,
                ..config.clone()
            };
            assert_eq!(learned_commands(&plain, 7), learned_commands(&plain, 0));
        }
    }

    #[test]
    fn chained_learning_needs_far_fewer_pre_positions() {
        let config = LearnConfig {
            moves: 300,
            explore: vec![[1000.0, 2000.0]; 3],
            seed: 4,
            approach: Some(Approach::hobby_servo()),
        };
        let mut model = InverseModel::new(3, 3, &Default::default()).unwrap();
        let mut drawn = Counting(0);
        let _ = learn_control(&mut drawn, &mut model, &config, |_, _| {});
        let mut chained = Counting(0);
        let _ = learn_control_chained(&mut chained, &mut model, &config, 100, |_, _| {});
        // Random order: a joint moves down on 7 of 8 moves; chained: about a third.
        assert!(drawn.0 > 300 + 240, "{}", drawn.0);
        assert!(chained.0 < 300 + 130, "{}", chained.0);
    }
}
