//! Held-out smoothing selection (module `smoothing`): the pick on generated cases whose answer
//! is known, determinism, the learned model's configuration, typed errors on degenerate input.

use cbt_tracker::smoothing::{SmoothingGrid, select};
use cbt_tracker::{
    CbtConfig, CbtModel, Detection, Layout, Smoothing, Space, SystemFallback, TrackError,
    TrainingFrame,
};
use chan_repr::ChannelBasis;
use rand::RngExt;
use rand_distr::{Distribution, Normal};

fn config() -> CbtConfig {
    CbtConfig {
        layout: Layout::Stationary,
        system_fallback: SystemFallback::ConstantVelocity,
        ..CbtConfig::default()
    }
}

/// A 2-D space with channel centres at the integers 1..=n on both axes.
fn integer_space(n: usize) -> Space {
    let b = ChannelBasis::integer(n, cbt_tracker::DEFAULT_KERNEL).unwrap();
    Space::new(vec![b.clone(), b.clone()], vec![b.clone(), b]).unwrap()
}

/// `n` constant-velocity tracks of `len` frames with white acceleration noise `sigma`
/// (channels) per axis, starting in the middle of a 200-channel grid with a velocity in
/// [−1, 1]; detected exactly.
fn tracks(n: usize, len: usize, sigma: f64, seed: u64) -> Vec<Vec<TrainingFrame>> {
    let mut rng = cbt_tracker::sim::rng_for(seed, 0);
    let acc = Normal::new(0.0, sigma).unwrap();
    (0..n)
        .map(|_| {
            let mut p = [100.0, 100.0];
            let mut v = [rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)];
            (0..len)
                .map(|_| {
                    let f = TrainingFrame {
                        states: vec![p],
                        detections: vec![Detection::new(p[0], p[1])],
                    };
                    for d in 0..2 {
                        v[d] += acc.sample(&mut rng);
                        p[d] = (p[d] + v[d]).clamp(5.0, 195.0);
                    }
                    f
                })
                .collect()
        })
        .collect()
}

/// Random walks: steps N(0, s²) per axis, independent of the previous step.
fn walks(n: usize, len: usize, s: f64, seed: u64) -> Vec<Vec<TrainingFrame>> {
    let mut rng = cbt_tracker::sim::rng_for(seed, 0);
    let step = Normal::new(0.0, s).unwrap();
    (0..n)
        .map(|_| {
            let mut p = [100.0, 100.0];
            (0..len)
                .map(|_| {
                    let f = TrainingFrame {
                        states: vec![p],
                        detections: vec![Detection::new(p[0], p[1])],
                    };
                    for x in &mut p {
                        *x = (*x + step.sample(&mut rng)).clamp(5.0, 195.0);
                    }
                    f
                })
                .collect()
        })
        .collect()
}

fn pick(seqs: &[Vec<TrainingFrame>]) -> cbt_tracker::smoothing::Selection {
    select(
        &integer_space(200),
        &config(),
        seqs,
        &SmoothingGrid::default(),
    )
    .unwrap()
}

#[test]
fn leans_on_a_broad_prior_with_few_data_and_on_the_data_with_many() {
    // Random walks with steps N(0, 2²) per axis: the true T[δ | v] = N(δ; 0, 4) does not
    // depend on v. The constant-velocity prior N(δ; v, σ²) is centred wrongly; the σ that
    // fits best is the spread of δ − v, √2·2 ≈ 2.8 channels. With three short tracks (27
    // held-out steps) the counts are thin and the pick leans on that broad prior; with 100
    // tracks of 100 frames the data fill the columns and the smallest prior weight wins.
    let (mut more, mut seeds) = (0, 0);
    for seed in 1..=6 {
        let few = pick(&walks(3, 10, 2.0, seed));
        let many = pick(&walks(100, 100, 2.0, seed));
        assert_eq!(many.prior_weight, 1.0, "seed {seed}: {many:?}");
        assert!(
            (2.0..=4.0).contains(&few.fallback_sigma),
            "seed {seed}: the broad prior's width, {}",
            few.fallback_sigma
        );
        assert!(few.prior_weight >= many.prior_weight);
        more += usize::from(few.prior_weight > many.prior_weight);
        seeds += 1;
    }
    assert!(
        more * 2 > seeds,
        "more prior weight with few data in {more} of {seeds} seeds"
    );
}

#[test]
fn finds_the_true_width_of_constant_velocity_motion() {
    // Constant velocity with white acceleration N(0, 2²) per axis: the prior with σ = 2 is
    // the true model; four tracks of 20 frames pick it (or a neighbouring grid value).
    for seed in 1..=6 {
        let s = pick(&tracks(4, 20, 2.0, seed));
        assert!(
            (1.5..=3.0).contains(&s.fallback_sigma),
            "seed {seed}: σ = {}",
            s.fallback_sigma
        );
    }
}

#[test]
fn scores_every_candidate_and_picks_the_best() {
    let s = pick(&tracks(4, 20, 2.0, 1));
    let grid = SmoothingGrid::default();
    assert_eq!(
        s.scores.len(),
        grid.prior_weights.len() * grid.fallback_sigmas.len()
    );
    assert_eq!((s.folds, s.held_out), (4, 4 * 19));
    // In the grid's order: `σ` outer, `α` inner.
    let na = grid.prior_weights.len();
    for (i, c) in s.scores.iter().enumerate() {
        assert_eq!(
            (c.fallback_sigma, c.prior_weight),
            (grid.fallback_sigmas[i / na], grid.prior_weights[i % na]),
            "score {i}"
        );
    }
    let best = s
        .scores
        .iter()
        .map(|c| c.log_likelihood)
        .fold(f64::NEG_INFINITY, f64::max);
    assert!(best.is_finite());
    let chosen = s
        .scores
        .iter()
        .find(|c| c.prior_weight == s.prior_weight && c.fallback_sigma == s.fallback_sigma)
        .unwrap();
    assert_eq!(chosen.log_likelihood, best);
}

/// Ties go to the broader candidate, larger `α` among equal `σ`: a held-out track scored
/// against a fold with no transitions reads the prior columns themselves, the same for every
/// `α` (powers of two, so exactly the same), and the largest `α` is picked.
#[test]
fn ties_go_to_the_larger_prior_weight() {
    let mut seqs = tracks(1, 12, 1.0, 3);
    // A second sequence of one frame: states to hold out, no transition to count.
    seqs.push(vec![seqs[0][0].clone()]);
    let grid = SmoothingGrid {
        prior_weights: vec![1.0, 4.0, 2.0],
        fallback_sigmas: vec![1.0, 2.0],
    };
    let s = select(&integer_space(200), &config(), &seqs, &grid).unwrap();
    assert_eq!(s.held_out, 11);
    for c in s.scores.chunks(3) {
        assert!(c[0].log_likelihood.is_finite());
        assert_eq!(c[0].log_likelihood, c[1].log_likelihood, "{c:?}");
        assert_eq!(c[0].log_likelihood, c[2].log_likelihood, "{c:?}");
    }
    assert_ne!(s.scores[0].log_likelihood, s.scores[3].log_likelihood);
    assert_eq!(s.prior_weight, 4.0, "{s:?}");
}

#[test]
fn is_deterministic_and_is_what_learning_uses() {
    let seqs = tracks(5, 15, 1.5, 9);
    let a = pick(&seqs);
    let b = pick(&seqs);
    assert_eq!(a, b);
    let cfg = CbtConfig {
        smoothing: Smoothing::HeldOut,
        ..config()
    };
    let learned = CbtModel::learn(integer_space(200), cfg, &seqs).unwrap();
    assert_eq!(learned.config().prior_weight, a.prior_weight);
    assert_eq!(learned.config().fallback_sigma, a.fallback_sigma);
    assert_eq!(learned.config().smoothing, Smoothing::HeldOut);
    // The same model as one learned with the chosen constants fixed.
    let fixed = CbtModel::learn(
        integer_space(200),
        CbtConfig {
            prior_weight: a.prior_weight,
            fallback_sigma: a.fallback_sigma,
            ..config()
        },
        &seqs,
    )
    .unwrap();
    for d in 0..2 {
        assert_eq!(learned.stationary_system(d), fixed.stationary_system(d));
    }
    assert_eq!(learned.stationary_kernel(), fixed.stationary_kernel());
    // Fixed smoothing keeps the configured constants.
    let kept = CbtModel::learn(integer_space(200), config(), &seqs).unwrap();
    assert_eq!(kept.config().prior_weight, config().prior_weight);
}

#[test]
fn degenerate_input_is_a_typed_error() {
    let space = integer_space(200);
    fn selection<T: std::fmt::Debug>(r: Result<T, TrackError>) {
        assert!(
            matches!(r, Err(TrackError::Selection { .. })),
            "expected a selection error, got {r:?}"
        )
    }
    // One sequence: nothing to hold out (also through learning).
    let one = tracks(1, 30, 1.0, 1);
    selection(select(&space, &config(), &one, &SmoothingGrid::default()));
    let held = CbtConfig {
        smoothing: Smoothing::HeldOut,
        ..config()
    };
    selection(CbtModel::learn(space.clone(), held, &one));
    // A second sequence without states does not count.
    let mut with_empty = one.clone();
    with_empty.push(vec![TrainingFrame::default(); 3]);
    selection(select(
        &space,
        &config(),
        &with_empty,
        &SmoothingGrid::default(),
    ));
    // Sequences of single frames: no held-out displacement.
    let singles: Vec<Vec<TrainingFrame>> = tracks(4, 1, 1.0, 1);
    selection(select(
        &space,
        &config(),
        &singles,
        &SmoothingGrid::default(),
    ));
    // Frames with two states each: no single displacement to score.
    let pairs: Vec<Vec<TrainingFrame>> = tracks(3, 5, 1.0, 1)
        .into_iter()
        .map(|s| {
            s.into_iter()
                .map(|mut f| {
                    f.states.push([50.0, 50.0]);
                    f
                })
                .collect()
        })
        .collect();
    selection(select(&space, &config(), &pairs, &SmoothingGrid::default()));
    // No candidates; bad candidates; the wrong layout.
    let seqs = tracks(3, 10, 1.0, 1);
    let empty = SmoothingGrid {
        prior_weights: vec![],
        fallback_sigmas: vec![1.0],
    };
    selection(select(&space, &config(), &seqs, &empty));
    let bad = SmoothingGrid {
        prior_weights: vec![1.0, f64::NAN],
        fallback_sigmas: vec![1.0],
    };
    assert!(matches!(
        select(&space, &config(), &seqs, &bad),
        Err(TrackError::InvalidParameter {
            name: "prior_weight",
            ..
        })
    ));
    let separable = CbtConfig {
        layout: Layout::Separable,
        ..config()
    };
    selection(select(&space, &separable, &seqs, &SmoothingGrid::default()));
    assert!(matches!(
        CbtModel::learn(
            space.clone(),
            CbtConfig {
                smoothing: Smoothing::HeldOut,
                ..separable
            },
            &seqs
        ),
        Err(TrackError::InvalidParameter {
            name: "smoothing",
            ..
        })
    ));
    // A state off the grid is learning's error.
    let mut off = seqs.clone();
    off[1][2].states[0] = [1e6, 1.0];
    assert!(matches!(
        select(&space, &config(), &off, &SmoothingGrid::default()),
        Err(TrackError::OutsideGrid { .. })
    ));
}

#[test]
fn configurations_saved_before_the_option_load_as_fixed() {
    let held = CbtConfig {
        smoothing: Smoothing::HeldOut,
        ..CbtConfig::stationary()
    };
    let mut v = serde_json::to_value(held).unwrap();
    assert_eq!(v["smoothing"], "held_out");
    assert_eq!(
        serde_json::from_value::<CbtConfig>(v.clone()).unwrap(),
        held
    );
    v.as_object_mut().unwrap().remove("smoothing");
    let old: CbtConfig = serde_json::from_value(v).unwrap();
    assert_eq!(old.smoothing, Smoothing::Fixed);
    assert_eq!(old, CbtConfig::stationary());
}
