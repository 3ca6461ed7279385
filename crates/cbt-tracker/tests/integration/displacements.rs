//! How the stationary system model counts displacements ([`Displacements`]): the channel
//! products' errors-in-variables bias toward the bulk of the training velocities, its absence
//! with interpolated coordinates, the design bias that interpolation still has where the
//! training velocities thin out, its absence with aligned columns, the saved form, and typed
//! errors.

use cbt_tracker::{
    CbtConfig, CbtModel, Detection, Displacements, Layout, Space, TrackError, TrainingFrame,
};
use chan_repr::ChannelBasis;
use rand::RngExt;

/// A 2-D space with channel centres at the integers 1..=n on both axes.
fn integer_space(n: usize) -> Space {
    let b = ChannelBasis::integer(n, cbt_tracker::DEFAULT_KERNEL).unwrap();
    Space::new(vec![b.clone(), b.clone()], vec![b.clone(), b]).unwrap()
}

/// Constant-velocity runs along x from x ≈ 100, run `i` at `velocity(i, rng)` channels a
/// frame; detected exactly.
fn runs_with<R: rand::Rng>(
    n: usize,
    len: usize,
    mut rng: R,
    mut velocity: impl FnMut(usize, &mut R) -> f64,
) -> Vec<Vec<TrainingFrame>> {
    (0..n)
        .map(|i| {
            let v = velocity(i, &mut rng);
            let x0 = 100.0 + rng.random_range(0.0..1.0);
            (0..len)
                .map(|k| {
                    let p = [x0 + v * k as f64, 50.0];
                    TrainingFrame {
                        states: vec![p],
                        detections: vec![Detection::new(p[0], p[1])],
                    }
                })
                .collect()
        })
        .collect()
}

/// Constant-velocity runs along x: three in four nearly standing (|v| < 0.3 channels), the
/// others walking (|v| up to 3 channels), as in real walkers' training data.
fn runs(n: usize, len: usize, seed: u64) -> Vec<Vec<TrainingFrame>> {
    runs_with(n, len, cbt_tracker::sim::rng_for(seed, 0), |i, rng| {
        if i % 4 != 0 {
            rng.random_range(-0.3..0.3)
        } else {
            rng.random_range(-3.0..3.0)
        }
    })
}

/// Constant-velocity runs along x whose speeds thin out: seven in eight at 0.5–1.5 channels a
/// frame, the others at 1.5–3 (either direction), as along an axis few people walk.
fn thinning_runs(n: usize, len: usize, seed: u64) -> Vec<Vec<TrainingFrame>> {
    runs_with(n, len, cbt_tracker::sim::rng_for(seed, 0), |i, rng| {
        let speed: f64 = if i % 8 != 0 {
            rng.random_range(0.5..1.5)
        } else {
            rng.random_range(1.5..3.0)
        };
        if rng.random_bool(0.5) { speed } else { -speed }
    })
}

/// Runs along x whose velocity halves each frame toward zero from a start of 0.5–3 channels a
/// frame (either direction): a step keeps half the previous one, `E[δ | u] = u / 2`.
fn damped_runs(n: usize, len: usize, seed: u64) -> Vec<Vec<TrainingFrame>> {
    let mut rng = cbt_tracker::sim::rng_for(seed, 0);
    (0..n)
        .map(|_| {
            let speed: f64 = rng.random_range(0.5..3.0);
            let mut v = if rng.random_bool(0.5) { speed } else { -speed };
            let mut x = 100.0 + rng.random_range(0.0..1.0);
            (0..len)
                .map(|_| {
                    let p = [x, 50.0];
                    x += v;
                    v *= 0.5;
                    TrainingFrame {
                        states: vec![p],
                        detections: vec![Detection::new(p[0], p[1])],
                    }
                })
                .collect()
        })
        .collect()
}

/// The column `T[· | v]` of axis 0 at the integer velocity `v`: `(δ, p)` per displacement.
fn column(m: &CbtModel, v: i64) -> Vec<(f64, f64)> {
    let (s, t) = m.stationary_system(0).unwrap();
    let w = s.len();
    let r = (w / 2) as i64;
    t[(v + r) as usize * w..][..w]
        .iter()
        .enumerate()
        .map(|(i, &p)| ((i as i64 - r) as f64, p))
        .collect()
}

/// `E[δ | v]` of the learned `T` of axis 0 at the integer velocity `v`.
fn mean_step(m: &CbtModel, v: i64) -> f64 {
    let col = column(m, v);
    let mass: f64 = col.iter().map(|e| e.1).sum();
    col.iter().map(|&(d, p)| p * d).sum::<f64>() / mass
}

/// The standard deviation of `T[· | v]` of axis 0 (channels).
fn sd_step(m: &CbtModel, v: i64) -> f64 {
    let col = column(m, v);
    let mass: f64 = col.iter().map(|e| e.1).sum();
    let mean = mean_step(m, v);
    (col.iter()
        .map(|&(d, p)| p * (d - mean).powi(2))
        .sum::<f64>()
        / mass)
        .sqrt()
}

fn config(d: Displacements) -> CbtConfig {
    CbtConfig {
        displacements: d,
        // A small prior, so that the columns are the data's.
        prior_weight: 1e-3,
        ..CbtConfig::stationary()
    }
}

#[test]
fn interpolated_counts_keep_the_walking_velocity() {
    let train = runs(400, 20, 3);
    let space = integer_space(200);
    let chan = CbtModel::learn(space.clone(), config(Displacements::Channels), &train).unwrap();
    let interp = CbtModel::learn(space, config(Displacements::Interpolated), &train).unwrap();
    for v in [-2i64, 2] {
        let (c, i) = (mean_step(&chan, v), mean_step(&interp, v));
        // Channel products: a walker at 2 channels a frame is predicted far slower.
        assert!(c.abs() < 1.6, "channels: E[δ | v = {v}] = {c}");
        // Interpolated: within a quarter channel of constant velocity.
        assert!(
            (i - v as f64).abs() < 0.25,
            "interpolated: E[δ | v = {v}] = {i}"
        );
    }
    // The same mass per transition as the channel products (α keeps its meaning): one
    // pair of interior cos² vectors carries 1.5² = 2.25 per axis.
    let (s, _) = interp.stationary_system(0).unwrap();
    assert!((s.iter().sum::<f64>() - 1.0).abs() < 1e-9);
}

#[test]
fn aligned_columns_keep_the_velocity_where_interpolation_is_pulled_to_the_bulk() {
    let train = thinning_runs(400, 20, 5);
    let space = integer_space(200);
    let interp =
        CbtModel::learn(space.clone(), config(Displacements::Interpolated), &train).unwrap();
    let aligned = CbtModel::learn(space, config(Displacements::Aligned), &train).unwrap();
    for v in [-2i64, 2] {
        let (i, a) = (mean_step(&interp, v), mean_step(&aligned, v));
        // Column ±2 averages the steps of speeds in (1, 3), most of them below 2.
        assert!(
            i.abs() < 1.85,
            "interpolated: E[δ | v = {v}] = {i}, expected pulled toward the slower bulk"
        );
        // Every run keeps its velocity, so each aligned column holds its own velocity.
        assert!((a - v as f64).abs() < 0.01, "aligned: E[δ | v = {v}] = {a}");
    }
}

#[test]
fn fitted_columns_follow_the_fitted_slope() {
    // Constant velocity: the fitted slope is 1, so the columns are the aligned ones.
    let train = thinning_runs(400, 20, 5);
    let fitted =
        CbtModel::learn(integer_space(200), config(Displacements::Fitted), &train).unwrap();
    let aligned =
        CbtModel::learn(integer_space(200), config(Displacements::Aligned), &train).unwrap();
    for v in [-2i64, -1, 1, 2] {
        let (f, a) = (mean_step(&fitted, v), mean_step(&aligned, v));
        assert!((f - a).abs() < 0.01, "fitted {f}, aligned {a} at v = {v}");
    }
    // Velocity halving each frame: a step keeps half the previous one. The fitted slope is
    // about 1/2, and each step counted at `δ − (u − v)/2 ≈ v/2`: the column is nearly the
    // point v/2 (what spread is left comes from the states' channel coordinates, first moments
    // of cos² channel vectors, which are off by up to 0.04 channels). The aligned count
    // (slope 1) has about the right mean here, but keeps half the spread of the velocities
    // counted in the column.
    let train = damped_runs(400, 8, 6);
    let fitted =
        CbtModel::learn(integer_space(200), config(Displacements::Fitted), &train).unwrap();
    let aligned =
        CbtModel::learn(integer_space(200), config(Displacements::Aligned), &train).unwrap();
    for v in [-2i64, 2] {
        let (f, a) = (mean_step(&fitted, v), mean_step(&aligned, v));
        let (sf, sa) = (sd_step(&fitted, v), sd_step(&aligned, v));
        assert!(
            (f - v as f64 / 2.0).abs() < 0.05 && sf < 0.25,
            "fitted: E[δ | v = {v}] = {f}, s.d. {sf}"
        );
        assert!(
            sa > 1.5 * sf,
            "aligned: E[δ | v = {v}] = {a}, s.d. {sa} against the fitted {sf}"
        );
    }
    // The slopes are part of the saved model, and only a fitted model may hold them.
    let text = serde_json::to_string(&fitted).unwrap();
    assert!(text.contains("\"slope\""));
    let back: CbtModel = serde_json::from_str(&text).unwrap();
    assert_eq!(back.stationary_system(0), fitted.stationary_system(0));
    let relabelled = text.replace(
        "\"displacements\":\"fitted\"",
        "\"displacements\":\"aligned\"",
    );
    assert_ne!(relabelled, text);
    assert!(matches!(
        serde_json::from_str::<CbtModel>(&relabelled),
        Err(e) if e.to_string().contains("slope")
    ));
}

#[test]
fn saved_form_and_checks() {
    let train = runs(6, 10, 4);
    let space = integer_space(200);
    let chan = CbtConfig {
        displacements: Displacements::Channels,
        ..CbtConfig::stationary()
    };
    let m = CbtModel::learn(space.clone(), chan, &train).unwrap();
    let text = serde_json::to_string(&m).unwrap();
    assert!(!text.contains("\"displacements\""));
    assert_eq!(
        CbtConfig::stationary().displacements,
        Displacements::Interpolated
    );
    assert_eq!(CbtConfig::default().displacements, Displacements::Channels);
    let cfg = CbtConfig {
        displacements: Displacements::Interpolated,
        ..CbtConfig::stationary()
    };
    let m = CbtModel::learn(space, cfg, &train).unwrap();
    let text = serde_json::to_string(&m).unwrap();
    assert!(text.contains("\"displacements\":\"interpolated\""));
    let back: CbtModel = serde_json::from_str(&text).unwrap();
    assert_eq!(back.stationary_system(0), m.stationary_system(0));
    let cfg = CbtConfig {
        displacements: Displacements::Aligned,
        ..CbtConfig::stationary()
    };
    let m = CbtModel::learn(integer_space(200), cfg, &train).unwrap();
    let text = serde_json::to_string(&m).unwrap();
    assert!(text.contains("\"displacements\":\"aligned\""));
    let back: CbtModel = serde_json::from_str(&text).unwrap();
    assert_eq!(back.stationary_system(0), m.stationary_system(0));
    for d in [
        Displacements::Interpolated,
        Displacements::Aligned,
        Displacements::Selected,
        Displacements::Fitted,
    ] {
        let bad = CbtConfig {
            displacements: d,
            layout: Layout::Separable,
            ..CbtConfig::default()
        };
        assert!(matches!(
            bad.validate(),
            Err(TrackError::InvalidParameter {
                name: "displacements",
                ..
            })
        ));
    }
}
