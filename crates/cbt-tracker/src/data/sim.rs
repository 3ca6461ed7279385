//! Synthetic data: the RC-car-following generator (docs/methods.md § Tracking) and the univariate
//! non-stationary growth model (UNGM) of Arulampalam et al. (docs/methods.md § Tracking). Every
//! draw comes from a seeded `Xoshiro256++`; sequence `i` of a call uses its own stream derived from
//! `(seed, i)`, so sequences do not depend on how many others are generated.

use rand::rngs::Xoshiro256PlusPlus;
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Poisson, StandardNormal};
use serde::{Deserialize, Serialize};

use crate::error::{non_negative, positive, unit};
use crate::{Detection, Frame, Sequence, TrackError};

/// Largest clutter rate ([`Level::clutter_rate`], detections per frame) the generators accept:
/// 10⁴, a thousand times the hardest preset's. Larger rates are refused before anything is
/// drawn (a rate of 10³⁰ used to panic in the Poisson sampler, and one of 10¹⁸ would allocate
/// that many detections a frame).
pub const MAX_CLUTTER_RATE: f64 = 1e4;

/// Most frames one call of a generator ([`generate`], [`generate_one`], [`Ungm::generate`])
/// makes: `count × frames`, a sequence without frames counting as one. Ten million frames
/// (a few GB with clutter); more is refused before anything is drawn (a count of
/// `usize::MAX` used to panic with "capacity overflow", and a huge frame count ran until
/// memory ran out).
pub const MAX_FRAMES: usize = 10_000_000;

/// Checks that `count` sequences of `frames` frames are at most [`MAX_FRAMES`].
fn check_frames(count: usize, frames: usize) -> Result<(), TrackError> {
    match count.checked_mul(frames.max(1)) {
        Some(n) if n <= MAX_FRAMES => Ok(()),
        _ => Err(TrackError::InvalidParameter {
            name: "frames",
            value: count as f64 * frames.max(1) as f64,
            reason: "count × frames exceeds MAX_FRAMES (10,000,000) frames in one call",
        }),
    }
}

/// The camera and car dynamics of the RC-car-following scenario: a car seen from a following
/// vehicle's uncalibrated camera, in image coordinates (pixels, origin top-left).
///
/// Per frame: an occasional turn (a lateral acceleration held for 15–40 frames), smooth random
/// acceleration, damping and a weak pull to the image centre (the follower keeps the car in
/// view); the car bounces off a margin; camera shake is an AR(1) offset added to the car's
/// image position. The truth is the shaken position.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Scenario {
    /// Image width (px).
    pub width: f64,
    /// Image height (px).
    pub height: f64,
    /// Random acceleration σ (px/frame²) per axis.
    pub accel_sigma: f64,
    /// Velocity damping per frame (the follower matches the car's speed).
    pub damping: f64,
    /// Pull towards the image centre (1/frame²).
    pub centre_pull: f64,
    /// Probability per frame that a turn starts.
    pub turn_rate: f64,
    /// Lateral acceleration during a turn (px/frame²).
    pub turn_accel: f64,
    /// Camera-shake σ (px) of the AR(1) innovation.
    pub shake_sigma: f64,
    /// AR(1) coefficient of the shake.
    pub shake_memory: f64,
    /// Margin (px) the car keeps from the image border.
    pub margin: f64,
}

impl Scenario {
    /// Checks the scenario: `width` and `height` finite and at least 2 px, `margin` finite,
    /// non-negative and at most half of each side, the σs and `centre_pull` finite and
    /// non-negative, `damping` and `turn_rate` in `[0, 1]`, `shake_memory` in `[0, 1)`,
    /// `turn_accel` finite. [`TrackError::InvalidParameter`] names the first field that is not.
    pub fn validate(&self) -> Result<(), TrackError> {
        for (name, side) in [("width", self.width), ("height", self.height)] {
            positive(name, side)?;
            if side < 2.0 {
                return Err(TrackError::InvalidParameter {
                    name,
                    value: side,
                    reason: "must be at least 2 px",
                });
            }
        }
        non_negative("margin", self.margin)?;
        if 2.0 * self.margin > self.width.min(self.height) {
            return Err(TrackError::InvalidParameter {
                name: "margin",
                value: self.margin,
                reason: "must be at most half the image's smaller side",
            });
        }
        non_negative("accel_sigma", self.accel_sigma)?;
        non_negative("shake_sigma", self.shake_sigma)?;
        non_negative("centre_pull", self.centre_pull)?;
        unit("damping", self.damping, false)?;
        unit("turn_rate", self.turn_rate, false)?;
        unit("shake_memory", self.shake_memory, true)?;
        if !self.turn_accel.is_finite() {
            return Err(TrackError::NonFinite {
                what: "turn_accel",
                value: self.turn_accel,
            });
        }
        Ok(())
    }
}

impl Default for Scenario {
    fn default() -> Self {
        Scenario {
            width: 320.0,
            height: 240.0,
            accel_sigma: 0.3,
            damping: 0.97,
            centre_pull: 0.002,
            turn_rate: 1.0 / 60.0,
            turn_accel: 0.25,
            shake_sigma: 1.0,
            shake_memory: 0.7,
            margin: 12.0,
        }
    }
}

/// Difficulty of the detector: clutter, detection probability, detection noise.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Level {
    /// Label, e.g. `L2`.
    pub name: String,
    /// Mean number of clutter detections per frame (Poisson), uniform over the image.
    pub clutter_rate: f64,
    /// Probability that the car is detected in a frame.
    pub p_detect: f64,
    /// Detection noise σ (px) per axis.
    pub noise_sigma: f64,
}

impl Level {
    /// The five difficulty levels of the evaluation, from `L0` (clean: no clutter,
    /// `P_D = 1`, σ = 1 px) to `L4` (10 clutter detections a frame, `P_D = 0.6`, σ = 8 px).
    /// Indices above 4 give `L4`.
    pub fn preset(i: usize) -> Level {
        const P: [(f64, f64, f64); 5] = [
            (0.0, 1.0, 1.0),
            (1.0, 0.95, 2.0),
            (3.0, 0.9, 4.0),
            (6.0, 0.8, 6.0),
            (10.0, 0.6, 8.0),
        ];
        let i = i.min(4);
        Level {
            name: format!("L{i}"),
            clutter_rate: P[i].0,
            p_detect: P[i].1,
            noise_sigma: P[i].2,
        }
    }

    /// All five presets.
    pub fn presets() -> Vec<Level> {
        (0..5).map(Level::preset).collect()
    }

    /// Checks the level: `clutter_rate` finite, non-negative and at most
    /// [`MAX_CLUTTER_RATE`], `p_detect` in `[0, 1]`, `noise_sigma` finite and non-negative.
    /// [`TrackError::InvalidParameter`] names the first field that is not.
    pub fn validate(&self) -> Result<(), TrackError> {
        non_negative("clutter_rate", self.clutter_rate)?;
        if self.clutter_rate > MAX_CLUTTER_RATE {
            return Err(TrackError::InvalidParameter {
                name: "clutter_rate",
                value: self.clutter_rate,
                reason: "exceeds MAX_CLUTTER_RATE (1e4 detections a frame)",
            });
        }
        unit("p_detect", self.p_detect, false)?;
        non_negative("noise_sigma", self.noise_sigma)
    }

    /// The clutter-count distribution (`None` without clutter); the level is valid.
    fn clutter(&self) -> Option<Poisson<f64>> {
        (self.clutter_rate > 0.0).then(|| {
            Poisson::new(self.clutter_rate).expect("validated: 0 < clutter rate ≤ MAX_CLUTTER_RATE")
        })
    }
}

/// A per-sequence generator from `(seed, index)`.
pub fn rng_for(seed: u64, index: u64) -> Xoshiro256PlusPlus {
    // SplitMix64-style mixing of the pair.
    let mut z = seed ^ index.wrapping_add(1).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    Xoshiro256PlusPlus::seed_from_u64(z ^ (z >> 31))
}

fn normal(rng: &mut Xoshiro256PlusPlus) -> f64 {
    StandardNormal.sample(rng)
}

/// `count` sequences of `frames` frames each.
///
/// Errors: an invalid scenario or level ([`Scenario::validate`], [`Level::validate`]), or more
/// than [`MAX_FRAMES`] frames in all ([`TrackError::InvalidParameter`] `frames`), checked
/// before anything is generated.
pub fn generate(
    scenario: &Scenario,
    level: &Level,
    count: usize,
    frames: usize,
    seed: u64,
) -> Result<Vec<Sequence>, TrackError> {
    scenario.validate()?;
    level.validate()?;
    check_frames(count, frames)?;
    Ok((0..count)
        .map(|i| simulate(scenario, level, frames, seed, i as u64))
        .collect())
}

/// Sequence `index` of the stream `seed`. Errors as [`generate`].
pub fn generate_one(
    sc: &Scenario,
    level: &Level,
    frames: usize,
    seed: u64,
    index: u64,
) -> Result<Sequence, TrackError> {
    sc.validate()?;
    level.validate()?;
    check_frames(1, frames)?;
    Ok(simulate(sc, level, frames, seed, index))
}

/// [`generate_one`] on a validated scenario and level.
fn simulate(sc: &Scenario, level: &Level, frames: usize, seed: u64, index: u64) -> Sequence {
    let mut rng = rng_for(seed, index);
    let (w, h) = (sc.width, sc.height);
    let centre = [w / 2.0, h / 2.0];
    let lo = [sc.margin, sc.margin];
    let hi = [w - sc.margin, h - sc.margin];
    let mut p = [
        centre[0] + (rng.random::<f64>() - 0.5) * w / 2.0,
        centre[1] + (rng.random::<f64>() - 0.5) * h / 2.0,
    ];
    let mut v = [normal(&mut rng), normal(&mut rng)];
    let mut shake = [0.0; 2];
    let mut turn_left = 0usize;
    let mut turn = [0.0; 2];
    let poisson = level.clutter();
    let mut out = Vec::new();
    for _ in 0..frames {
        if turn_left == 0 && rng.random::<f64>() < sc.turn_rate {
            turn_left = 15 + (rng.random::<f64>() * 26.0) as usize;
            let sign = if rng.random::<bool>() { 1.0 } else { -1.0 };
            turn = [
                sign * sc.turn_accel,
                0.3 * sign * sc.turn_accel * normal(&mut rng),
            ];
        }
        for d in 0..2 {
            let mut a = sc.accel_sigma * normal(&mut rng) - sc.centre_pull * (p[d] - centre[d]);
            if turn_left > 0 {
                a += turn[d];
            }
            v[d] = sc.damping * v[d] + a;
            p[d] += v[d];
            if p[d] < lo[d] {
                p[d] = 2.0 * lo[d] - p[d];
                v[d] = v[d].abs();
            } else if p[d] > hi[d] {
                p[d] = 2.0 * hi[d] - p[d];
                v[d] = -v[d].abs();
            }
            p[d] = p[d].clamp(lo[d], hi[d]);
            shake[d] = sc.shake_memory * shake[d] + sc.shake_sigma * normal(&mut rng);
        }
        turn_left = turn_left.saturating_sub(1);
        let truth = [
            (p[0] + shake[0]).clamp(1.0, w - 1.0),
            (p[1] + shake[1]).clamp(1.0, h - 1.0),
        ];
        let mut dets = Vec::new();
        let n_clutter = poisson.as_ref().map_or(0, |d| d.sample(&mut rng) as usize);
        for _ in 0..n_clutter {
            dets.push(Detection::new(
                rng.random::<f64>() * w,
                rng.random::<f64>() * h,
            ));
        }
        if rng.random::<f64>() < level.p_detect {
            let z = [
                truth[0] + level.noise_sigma * normal(&mut rng),
                truth[1] + level.noise_sigma * normal(&mut rng),
            ];
            // A detection outside the image cannot be seen.
            if (0.0..=w).contains(&z[0]) && (0.0..=h).contains(&z[1]) {
                let at = (rng.random::<f64>() * (dets.len() + 1) as f64) as usize;
                dets.insert(at.min(dets.len()), Detection::new(z[0], z[1]));
            }
        }
        out.push(Frame {
            truth: Some(truth),
            detections: dets,
        });
    }
    Sequence {
        name: format!("{}-{seed}-{index}", level.name),
        first_frame: 0,
        frames: out,
    }
}

/// Simulated detections on a given trajectory (e.g. real motion): per frame, Poisson clutter
/// uniform over `[x_lo, x_hi] × [y_lo, y_hi]` (`area`), and for a frame with a truth a
/// detection with probability `P_D` at the truth plus Gaussian noise, dropped when it falls
/// outside the area; detections are in random order. The truths are kept; the sequence's
/// own detections are replaced. Stream `(seed, index)` as [`generate`] uses.
///
/// Errors ([`TrackError::InvalidParameter`]): an invalid level ([`Level::validate`]), or an
/// `area` that is not finite with `x_lo < x_hi` and `y_lo < y_hi` and finite widths; checked
/// before anything is drawn.
///
/// ```
/// use cbt_tracker::sim::{observe, Level};
/// use cbt_tracker::{Frame, Sequence};
/// let track = Sequence {
///     name: "walk".into(),
///     first_frame: 1,
///     frames: (0..5).map(|k| Frame { truth: Some([10.0 + k as f64, 20.0]), detections: vec![] }).collect(),
/// };
/// let s = observe(&track, &Level::preset(0), [0.0, 100.0, 0.0, 100.0], 7, 0).unwrap();
/// assert_eq!(s.frames.len(), 5);
/// assert!(s.frames.iter().all(|f| f.detections.len() == 1));
/// ```
pub fn observe(
    track: &Sequence,
    level: &Level,
    area: [f64; 4],
    seed: u64,
    index: u64,
) -> Result<Sequence, TrackError> {
    level.validate()?;
    let [x_lo, x_hi, y_lo, y_hi] = area;
    for (lo, hi) in [(x_lo, x_hi), (y_lo, y_hi)] {
        // The width too: clutter is drawn at `lo + u·(hi − lo)`, which an overflowing width
        // (`[-1e308, 1e308]`) put at ±∞.
        if !(lo.is_finite() && hi.is_finite() && lo < hi && (hi - lo).is_finite()) {
            return Err(TrackError::InvalidParameter {
                name: "area",
                value: if lo.is_finite() { hi } else { lo },
                reason: "must be finite with x_lo < x_hi and y_lo < y_hi, and finite widths",
            });
        }
    }
    let mut rng = rng_for(seed, index);
    let poisson = level.clutter();
    let frames = track
        .frames
        .iter()
        .map(|f| {
            let mut dets = Vec::new();
            let n_clutter = poisson.as_ref().map_or(0, |d| d.sample(&mut rng) as usize);
            for _ in 0..n_clutter {
                dets.push(Detection::new(
                    x_lo + rng.random::<f64>() * (x_hi - x_lo),
                    y_lo + rng.random::<f64>() * (y_hi - y_lo),
                ));
            }
            if let Some(t) = f.truth
                && rng.random::<f64>() < level.p_detect
            {
                let z = [
                    t[0] + level.noise_sigma * normal(&mut rng),
                    t[1] + level.noise_sigma * normal(&mut rng),
                ];
                if (x_lo..=x_hi).contains(&z[0]) && (y_lo..=y_hi).contains(&z[1]) {
                    let at = (rng.random::<f64>() * (dets.len() + 1) as f64) as usize;
                    dets.insert(at.min(dets.len()), Detection::new(z[0], z[1]));
                }
            }
            Frame {
                truth: f.truth,
                detections: dets,
            }
        })
        .collect();
    Ok(Sequence {
        name: track.name.clone(),
        first_frame: track.first_frame,
        frames,
    })
}

/// The UNGM benchmark (Arulampalam et al. 2002, docs/methods.md § Tracking):
/// `x_k = x_{k−1}/2 + 25 x_{k−1}/(1 + x_{k−1}²) + 8 cos(1.2 k) + v_{k−1}`,
/// `z_k = x_k²/20 + n_k`, `v ~ N(0, 10)`, `n ~ N(0, 1)`, `x_0 = 0.1`; one detection per
/// frame, stored as `[z, 0]`; the truth as `[x, 0]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Ungm {
    /// Process noise variance (10).
    pub process_var: f64,
    /// Measurement noise variance (1).
    pub meas_var: f64,
    /// Initial state (0.1).
    pub x0: f64,
}

impl Default for Ungm {
    fn default() -> Self {
        Ungm {
            process_var: 10.0,
            meas_var: 1.0,
            x0: 0.1,
        }
    }
}

impl Ungm {
    /// The deterministic part of the transition at time `k` from `x`.
    pub fn transition(x: f64, k: u64) -> f64 {
        0.5 * x + 25.0 * x / (1.0 + x * x) + 8.0 * (1.2 * k as f64).cos()
    }

    /// `count` sequences of `frames` frames (frame 0 holds `x_0` and its measurement).
    ///
    /// Errors: a variance that is not finite and non-negative or more than [`MAX_FRAMES`]
    /// frames in all ([`TrackError::InvalidParameter`]), or a non-finite `x0`
    /// ([`TrackError::NonFinite`]), checked before anything is drawn (they used to give NaN
    /// sequences).
    pub fn generate(
        &self,
        count: usize,
        frames: usize,
        seed: u64,
    ) -> Result<Vec<Sequence>, TrackError> {
        non_negative("process_var", self.process_var)?;
        non_negative("meas_var", self.meas_var)?;
        check_frames(count, frames)?;
        if !self.x0.is_finite() {
            return Err(TrackError::NonFinite {
                what: "UNGM initial state x0",
                value: self.x0,
            });
        }
        Ok((0..count)
            .map(|i| {
                let mut rng = rng_for(seed, i as u64);
                let (sv, sn) = (self.process_var.sqrt(), self.meas_var.sqrt());
                let mut x = self.x0;
                let mut out = Vec::new();
                for k in 0..frames as u64 {
                    if k > 0 {
                        x = Ungm::transition(x, k) + sv * normal(&mut rng);
                    }
                    let z = x * x / 20.0 + sn * normal(&mut rng);
                    out.push(Frame {
                        truth: Some([x, 0.0]),
                        detections: vec![Detection::new(z, 0.0)],
                    });
                }
                Sequence {
                    name: format!("ungm-{seed}-{i}"),
                    first_frame: 0,
                    frames: out,
                }
            })
            .collect())
    }
}
