//! Held-out observation smoothing (module `observation_smoothing`): the known answer on
//! generated detections, a wider kernel on noisier detections, determinism, the learned
//! model's choice, saved files, typed errors.

use cbt_tracker::observation_smoothing::{
    ObservationChoice, ObservationGrid, ObservationSelection, select_observation,
};
use cbt_tracker::{
    CbtConfig, CbtModel, Detection, Layout, ObservationSmoothing, Space, TrackError, TrainingFrame,
};
use chan_repr::ChannelBasis;
use rand::RngExt;
use rand_distr::{Distribution, Normal, Poisson};

/// A 2-D space with channel centres at the integers 1..=n on both axes.
fn integer_space(n: usize) -> Space {
    let b = ChannelBasis::integer(n, cbt_tracker::DEFAULT_KERNEL).unwrap();
    Space::new(vec![b.clone(), b.clone()], vec![b.clone(), b]).unwrap()
}

const N: f64 = 120.0;

/// `n` tracks of `len` frames (a slow random walk on a 120-channel grid), detected with
/// probability `pd` with Gaussian noise `sigma` (channels; kept if on the grid), plus
/// Poisson(`clutter`) uniform
/// clutter detections a frame on [2, 118]².
fn tracks(
    n: usize,
    len: usize,
    pd: f64,
    sigma: f64,
    clutter: f64,
    seed: u64,
) -> Vec<Vec<TrainingFrame>> {
    let mut rng = cbt_tracker::sim::rng_for(seed, 0);
    let noise = Normal::new(0.0, sigma).unwrap();
    let step = Normal::new(0.0, 1.0).unwrap();
    (0..n)
        .map(|_| {
            let mut p = [rng.random_range(30.0..90.0), rng.random_range(30.0..90.0)];
            (0..len)
                .map(|_| {
                    let mut dets = Vec::new();
                    if rng.random::<f64>() < pd {
                        let z = [p[0] + noise.sample(&mut rng), p[1] + noise.sample(&mut rng)];
                        if z.iter().all(|&v| (2.0..=N - 2.0).contains(&v)) {
                            dets.push(Detection::new(z[0], z[1]));
                        }
                    }
                    let k: f64 = if clutter > 0.0 {
                        Poisson::new(clutter).unwrap().sample(&mut rng)
                    } else {
                        0.0
                    };
                    for _ in 0..k as usize {
                        dets.push(Detection::new(
                            rng.random_range(2.0..N - 2.0),
                            rng.random_range(2.0..N - 2.0),
                        ));
                    }
                    let f = TrainingFrame {
                        states: vec![p],
                        detections: dets,
                    };
                    for x in &mut p {
                        *x = (*x + step.sample(&mut rng)).clamp(20.0, 100.0);
                    }
                    f
                })
                .collect()
        })
        .collect()
}

fn config() -> CbtConfig {
    CbtConfig::stationary()
}

fn pick(seqs: &[Vec<TrainingFrame>]) -> ObservationSelection {
    select_observation(
        &integer_space(N as usize),
        &config(),
        seqs,
        &ObservationGrid::default(),
    )
    .unwrap()
}

/// Standard deviation (channels, larger axis) of a learned model's kernel.
fn kernel_sd(model: &CbtModel) -> f64 {
    let (k, ra) = model.stationary_kernel().unwrap();
    let w = 2 * ra + 1;
    let (mut m, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    for i in 0..w {
        for j in 0..w {
            let (x, y) = (i as f64 - ra as f64, j as f64 - ra as f64);
            m += k[i * w + j];
            sxx += k[i * w + j] * x * x;
            syy += k[i * w + j] * y * y;
        }
    }
    (sxx / m).max(syy / m).sqrt()
}

fn learn(seqs: &[Vec<TrainingFrame>], o: ObservationSmoothing) -> CbtModel {
    CbtModel::learn(
        integer_space(N as usize),
        CbtConfig {
            observation_smoothing: o,
            ..config()
        },
        seqs,
    )
    .unwrap()
}

#[test]
fn finds_the_detection_probability_and_the_clutter_of_generated_detections() {
    // P_D 0.7, σ 1.5 channels, 6 clutter detections a frame on 120² cells.
    let seqs = tracks(20, 60, 0.7, 1.5, 6.0, 1);
    let s = pick(&seqs);
    assert_eq!(s.folds, 5);
    assert_eq!(s.held_out, 20 * 60);
    assert!((s.choice.p_detect - 0.7).abs() <= 0.1, "P_D {:?}", s.choice);
    assert!(
        (0.7..=1.4).contains(&s.choice.clutter_scale),
        "clutter {:?}",
        s.choice
    );
    // The learned model's detection probability is the chosen one, its clutter density
    // the chosen scale of the measured one, close to the true 6 / 120².
    let m = learn(&seqs, ObservationSmoothing::HeldOut);
    assert_eq!(m.observation_choice(), Some(s.choice));
    let (p_detect, background, _) = m.stationary_observation().unwrap();
    assert_eq!(p_detect, s.choice.p_detect);
    let truth = 6.0 / (N * N);
    assert!(
        (background / truth - 1.0).abs() < 0.35,
        "clutter {background} against {truth}"
    );
    // The chosen model explains held-out detections better than the one as counted: its
    // score is at least the candidate (s, P, c) = (1, P̂_D, 1) closest to the counted model.
    let counted = learn(&seqs, ObservationSmoothing::Counted);
    assert_eq!(counted.observation_choice(), None);
    let best = s
        .scores
        .iter()
        .map(|c| c.log_likelihood)
        .fold(f64::NEG_INFINITY, f64::max);
    let chosen = s.scores.iter().find(|c| c.choice == s.choice).unwrap();
    assert_eq!(chosen.log_likelihood, best);
}

#[test]
fn noisier_detections_get_a_wider_kernel() {
    let sharp = learn(
        &tracks(20, 60, 0.9, 1.0, 2.0, 2),
        ObservationSmoothing::HeldOut,
    );
    let noisy = learn(
        &tracks(20, 60, 0.9, 2.5, 2.0, 2),
        ObservationSmoothing::HeldOut,
    );
    let (a, b) = (kernel_sd(&sharp), kernel_sd(&noisy));
    assert!(b > a + 0.8, "kernel s.d. {a} (σ 1) against {b} (σ 2.5)");
}

#[test]
fn is_deterministic_and_ties_go_to_the_broad_candidate() {
    let seqs = tracks(6, 40, 0.8, 1.5, 3.0, 3);
    let a = pick(&seqs);
    let b = pick(&seqs);
    assert_eq!(a, b);
    assert_eq!(
        learn(&seqs, ObservationSmoothing::HeldOut),
        learn(&seqs, ObservationSmoothing::HeldOut)
    );
    // A grid whose candidates all score the same (one width, one P, duplicated clutter
    // scales): the first in the broad order wins.
    let grid = ObservationGrid {
        width_scales: vec![1.0],
        p_detects: vec![0.8],
        clutter_scales: vec![1.0, 1.0],
    };
    let s = select_observation(&integer_space(N as usize), &config(), &seqs, &grid).unwrap();
    assert_eq!(s.scores[0].log_likelihood, s.scores[1].log_likelihood);
    // Frames without a single detection: a held-out frame's likelihood does not depend on the
    // kernel width or the clutter scale, so every (s, c) ties, and the broadest candidate,
    // the largest s and then the largest c, is kept whatever the grid's order.
    let blind = tracks(6, 40, 0.0, 1.5, 0.0, 3);
    assert!(blind.iter().flatten().all(|f| f.detections.is_empty()));
    let grid = ObservationGrid {
        width_scales: vec![1.0, 2.0, 0.5],
        p_detects: vec![0.8],
        clutter_scales: vec![1.0, 3.0, 2.0],
    };
    let s = select_observation(&integer_space(N as usize), &config(), &blind, &grid).unwrap();
    let first = s.scores[0].log_likelihood;
    assert!(first.is_finite());
    assert!(
        s.scores.iter().all(|c| c.log_likelihood == first),
        "{:?}",
        s.scores
    );
    assert_eq!(
        (s.choice.width_scale, s.choice.clutter_scale),
        (2.0, 3.0),
        "{:?}",
        s.choice
    );
}

#[test]
fn one_long_sequence_is_split_too() {
    let seqs = tracks(1, 300, 0.8, 1.5, 3.0, 4);
    let s = pick(&seqs);
    assert_eq!(s.folds, 5);
    assert!((s.choice.p_detect - 0.8).abs() <= 0.15, "{:?}", s.choice);
}

#[test]
fn saved_models_keep_the_choice_and_old_files_load_as_counted() {
    let seqs = tracks(6, 40, 0.8, 1.5, 3.0, 5);
    let m = learn(&seqs, ObservationSmoothing::HeldOut);
    let text = serde_json::to_string(&m).unwrap();
    assert!(text.contains("\"observation_smoothing\":\"held_out\""));
    assert!(text.contains("\"choice\":"));
    let back: CbtModel = serde_json::from_str(&text).unwrap();
    assert_eq!(back, m);
    assert_eq!(serde_json::to_string(&back).unwrap(), text);
    // A counted model writes neither field.
    let c = serde_json::to_string(&learn(&seqs, ObservationSmoothing::Counted)).unwrap();
    assert!(!c.contains("observation_smoothing") && !c.contains("\"choice\""));
    // A corrupted choice is refused on load.
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    v["obs"]["Stationary"]["choice"]["p_detect"] = serde_json::json!(1.5);
    let e = serde_json::from_value::<CbtModel>(v)
        .unwrap_err()
        .to_string();
    assert!(e.contains("p_detect"), "{e}");
}

#[test]
fn degenerate_input_is_a_typed_error() {
    let space = integer_space(N as usize);
    let grid = ObservationGrid::default();
    let one = tracks(1, 1, 1.0, 1.0, 0.0, 6);
    assert!(matches!(
        select_observation(&space, &config(), &one, &grid),
        Err(TrackError::Selection { .. })
    ));
    let seqs = tracks(3, 20, 0.9, 1.0, 1.0, 6);
    let separable = CbtConfig::default();
    assert!(matches!(
        select_observation(&space, &separable, &seqs, &grid),
        Err(TrackError::Selection { .. })
    ));
    assert!(matches!(
        CbtConfig {
            observation_smoothing: ObservationSmoothing::HeldOut,
            ..CbtConfig::default()
        }
        .validate(),
        Err(TrackError::InvalidParameter {
            name: "observation_smoothing",
            ..
        })
    ));
    let empty = ObservationGrid {
        p_detects: vec![],
        ..ObservationGrid::default()
    };
    assert!(matches!(
        select_observation(&space, &config(), &seqs, &empty),
        Err(TrackError::Selection { .. })
    ));
    let bad = ObservationGrid {
        p_detects: vec![0.0],
        ..ObservationGrid::default()
    };
    assert!(matches!(
        select_observation(&space, &config(), &seqs, &bad),
        Err(TrackError::InvalidParameter {
            name: "p_detect",
            ..
        })
    ));
    let mut nan = seqs.clone();
    nan[1][3].detections.push(Detection::new(f64::NAN, 4.0));
    assert!(select_observation(&space, &config(), &nan, &grid).is_err());
    assert!(
        CbtModel::learn(
            space,
            CbtConfig {
                observation_smoothing: ObservationSmoothing::HeldOut,
                ..config()
            },
            &nan
        )
        .is_err()
    );
    assert!(
        ObservationChoice {
            width_scale: 1.0,
            p_detect: 0.5,
            clutter_scale: f64::INFINITY
        }
        .validate()
        .is_err()
    );
}

#[test]
fn configurations_saved_before_the_option_load_as_counted() {
    let held = CbtConfig {
        observation_smoothing: ObservationSmoothing::HeldOut,
        ..CbtConfig::stationary()
    };
    let mut v = serde_json::to_value(held).unwrap();
    assert_eq!(v["observation_smoothing"], "held_out");
    assert_eq!(
        serde_json::from_value::<CbtConfig>(v.clone()).unwrap(),
        held
    );
    v.as_object_mut().unwrap().remove("observation_smoothing");
    let old: CbtConfig = serde_json::from_value(v).unwrap();
    assert_eq!(old.observation_smoothing, ObservationSmoothing::Counted);
    assert_eq!(
        old,
        CbtConfig {
            observation_smoothing: ObservationSmoothing::Counted,
            ..held
        }
    );
    let _ = Layout::Stationary;
}
