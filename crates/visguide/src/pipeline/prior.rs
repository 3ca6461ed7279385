//! The forward model as a prior on where the tip can be: each vote's weight is multiplied by
//! how well its position agrees with the forward model's absolute prediction `g(y)` at the
//! last command ([`super::motion`]).
//!
//! The shape model's wrong votes come mostly from gripper regions voting with another part's
//! offset, 20–60 px from the tip; they move with the gripper, so the commanded-move
//! compensation cannot tell them from the tip. The forward model's absolute prediction is too
//! coarse to gate the votes at the percept's precision, but it tells a cluster near the tip
//! from one a part's length away. Per camera `c`,
//!
//! `w' = w · max(ε, exp(−d² / 2(kσ_c)²))`,
//!
//! `d` the vote's distance to `g(y)`, `σ_c` the forward model's error scale on that camera,
//! measured during learning on frames the model did not learn from, against the teacher: the
//! median distance divided by `√(2 ln 2) ≈ 1.1774`, the median of a Rayleigh distribution of unit
//! scale (an isotropic Gaussian error of s.d. `σ_c` per axis has that median distance; the median
//! ignores the teacher's own gross failures, and a teacher that fails most of the time makes
//! `σ_c` wide and the prior weak). `k = 2`, because the errors are heavy-tailed (p90 about twice
//! the median); the floor `ε = 10⁻³` keeps a frame whose votes all lie far from the prediction
//! decidable by the votes alone.
//!
//! A camera whose prior would be wider than [`MAX_WIDTH_PX`] (`kσ_c` above 20 px) gets none:
//! the wrong clusters lie a part's length from the tip (the stored offsets are 20–60 px), and a
//! prior wider than the shortest of them cannot tell such a cluster from the tip; it would
//! only tilt the votes toward the forward model's own error (on the hard scene, a teacher that
//! fails on camera 0 makes that error tens of pixels).
//!
//! Cost: the centre `g(y)` is the forward-model prediction that [`super::MoveNotifier`] makes
//! once per command for the tracks' shift anyway; per vote the prior adds one exponential.

use servo_loop::stats::median;

use super::error::{PipelineError, Result};
use super::vote::{Vote, check_votes};

/// Width multiplier `k` of the prior (module docs).
pub const WIDTH_FACTOR: f64 = 2.0;
/// Floor `ε` of the prior's factor (module docs).
pub const FLOOR: f64 = 1e-3;
/// The widest prior applied, `kσ_c` (px; module docs).
pub const MAX_WIDTH_PX: f64 = 20.0;

/// The median of a Rayleigh distribution of unit scale, `√(2 ln 2)`.
const RAYLEIGH_MEDIAN: f64 = 1.177_410_022_515_474_6;

/// The forward model's error scale per camera, and the vote weighting it gives.
#[derive(Debug, Clone, PartialEq)]
pub struct PositionPrior {
    sigma: Vec<f64>,
}

impl PositionPrior {
    /// The prior from per-camera distances (px) between the forward model's prediction and the
    /// teacher's tip on frames the model did not learn from: `σ_c` = their median / 1.1774.
    ///
    /// Errors: no camera, a camera without distances, a distance not finite and non-negative,
    /// or a median of zero, or one so small that the prior's squared width `2(kσ_c)²`
    /// underflows (below about 10⁻¹⁵⁴ px): a prior of zero width would refuse every vote, and
    /// one of numerically zero width weighed even a vote at the prediction down to the floor.
    /// Huge finite distances are fine: their `σ_c` is finite (the median of two huge middle
    /// values used to overflow to ∞) and the camera gets no prior ([`Self::applies`]).
    pub fn from_distances(distances: &[Vec<f64>]) -> Result<Self> {
        if distances.is_empty() {
            return Err(PipelineError::InvalidParameter {
                name: "distances",
                reason: "need at least one camera".into(),
            });
        }
        let sigma = distances
            .iter()
            .enumerate()
            .map(|(cam, d)| {
                if let Some(bad) = d.iter().find(|v| !(v.is_finite() && **v >= 0.0)) {
                    return Err(PipelineError::InvalidParameter {
                        name: "distances",
                        reason: format!("camera {cam}: {bad} is not a finite distance"),
                    });
                }
                if d.is_empty() {
                    return Err(PipelineError::NotEnoughData(format!(
                        "camera {cam}: no frame to measure the forward model's error on"
                    )));
                }
                let median = median(&mut d.clone());
                if median <= 0.0 {
                    return Err(PipelineError::InvalidParameter {
                        name: "distances",
                        reason: format!("camera {cam}: median distance 0"),
                    });
                }
                let sigma = median / RAYLEIGH_MEDIAN;
                // The factor's denominator, as `factor` computes it: zero or subnormal is a
                // width that underflowed (an overflow is a camera without a prior, fine).
                let s = WIDTH_FACTOR * sigma;
                if 2.0 * s * s < f64::MIN_POSITIVE {
                    return Err(PipelineError::InvalidParameter {
                        name: "distances",
                        reason: format!(
                            "camera {cam}: median distance {median:e} px, too small for a prior \
                             of non-zero width"
                        ),
                    });
                }
                Ok(sigma)
            })
            .collect::<Result<Vec<f64>>>()?;
        Ok(PositionPrior { sigma })
    }

    /// Cameras covered.
    pub fn num_cameras(&self) -> usize {
        self.sigma.len()
    }

    /// The error scale `σ_c` of every camera (px).
    pub fn sigmas(&self) -> &[f64] {
        &self.sigma
    }

    /// Whether camera `cam` gets the prior: its width `kσ_c` is at most [`MAX_WIDTH_PX`].
    pub fn applies(&self, cam: usize) -> bool {
        self.sigma
            .get(cam)
            .is_some_and(|s| WIDTH_FACTOR * s <= MAX_WIDTH_PX)
    }

    /// The distance from the prediction beyond which camera `cam`'s factor is the floor `ε`:
    /// `kσ_c √(2 ln(1/ε))` (px; `None` where the prior does not [apply](Self::applies)).
    pub fn support_px(&self, cam: usize) -> Option<f64> {
        self.applies(cam)
            .then(|| WIDTH_FACTOR * self.sigma[cam] * (2.0 * (1.0 / FLOOR).ln()).sqrt())
    }

    /// The factor `max(ε, exp(−d² / 2(kσ_c)²))` for a vote at `position` when the forward model
    /// predicts the tip of camera `cam` at `predicted` (1 where the prior does not
    /// [apply](Self::applies)).
    ///
    /// Errors ([`PipelineError::InvalidParameter`]), as [`Self::weigh`] refuses them: a camera
    /// the prior does not cover or a non-finite prediction (`predicted`), a non-finite
    /// `position` (`position`). (A NaN prediction or position used to give the floor `ε`, as
    /// if the vote lay far away, and an uncovered camera the factor 1.)
    pub fn factor(&self, cam: usize, predicted: [f64; 2], position: [f64; 2]) -> Result<f64> {
        self.check_predicted(cam, predicted)?;
        if !position.iter().all(|v| v.is_finite()) {
            return Err(PipelineError::InvalidParameter {
                name: "position",
                reason: format!("{position:?}: a finite position expected"),
            });
        }
        Ok(self.checked_factor(cam, predicted, position))
    }

    /// [`Self::factor`] of a covered camera, a finite prediction and a finite position.
    fn checked_factor(&self, cam: usize, predicted: [f64; 2], position: [f64; 2]) -> f64 {
        if !self.applies(cam) {
            return 1.0;
        }
        let s = WIDTH_FACTOR * self.sigma[cam];
        let d2 = (position[0] - predicted[0]).powi(2) + (position[1] - predicted[1]).powi(2);
        (-d2 / (2.0 * s * s)).exp().max(FLOOR)
    }

    /// `Ok` when the prior covers camera `cam` and `predicted` is finite, else
    /// [`PipelineError::InvalidParameter`] (`predicted`).
    fn check_predicted(&self, cam: usize, predicted: [f64; 2]) -> Result<()> {
        if cam >= self.sigma.len() || !predicted.iter().all(|v| v.is_finite()) {
            return Err(PipelineError::InvalidParameter {
                name: "predicted",
                reason: format!(
                    "camera {cam} of {} at {predicted:?}: a covered camera and a finite position expected",
                    self.sigma.len()
                ),
            });
        }
        Ok(())
    }

    /// Multiplies every vote's weight of camera `cam` by its [`factor`](Self::factor) (no change
    /// where the prior does not [apply](Self::applies)). A vote however far from the prediction
    /// keeps the floor `ε` of its weight.
    ///
    /// Errors ([`PipelineError::InvalidParameter`]; no vote is changed): a camera the prior
    /// does not cover, or a non-finite prediction (`predicted`); a vote with a non-finite
    /// position or a weight not finite and non-negative (`votes`, as [`super::mode`] refuses
    /// them; a NaN position used to be weighed down to the floor as if it were far away).
    pub fn weigh(&self, cam: usize, predicted: [f64; 2], votes: &mut [Vote]) -> Result<()> {
        self.check_predicted(cam, predicted)?;
        check_votes(votes)?;
        if self.applies(cam) {
            for v in votes {
                v.weight *= self.checked_factor(cam, predicted, v.position);
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn vote(position: [f64; 2]) -> Vote {
        Vote {
            position,
            weight: 0.5,
            error: 0.0,
            rotation: 0.0,
            region: 0,
        }
    }

    #[test]
    fn sigma_is_the_median_distance_over_the_rayleigh_median() {
        // Brute force: a Rayleigh sample of scale 3 has median 3·√(2 ln 2).
        let p = PositionPrior::from_distances(&[vec![1.0, 5.0, 2.0], vec![4.0, 2.0, 8.0, 6.0]])
            .unwrap();
        assert!((p.sigmas()[0] - 2.0 / (2.0 * 2f64.ln()).sqrt()).abs() < 1e-12);
        assert!((p.sigmas()[1] - 5.0 / (2.0 * 2f64.ln()).sqrt()).abs() < 1e-12);
        let q = PositionPrior::from_distances(&[vec![3.0 * RAYLEIGH_MEDIAN]]).unwrap();
        assert!((q.sigmas()[0] - 3.0).abs() < 1e-12);
    }

    #[test]
    fn votes_far_from_the_prediction_lose_weight_down_to_the_floor() {
        let p = PositionPrior::from_distances(&[vec![RAYLEIGH_MEDIAN * 5.0]]).unwrap();
        // σ = 5 px, k σ = 10 px.
        let at = [100.0, 50.0];
        let mut votes = vec![
            vote(at),
            vote([110.0, 50.0]),
            vote([100.0, 80.0]),
            vote([400.0, 50.0]),
        ];
        p.weigh(0, at, &mut votes).unwrap();
        assert_eq!(votes[0].weight, 0.5);
        assert!((votes[1].weight - 0.5 * (-0.5f64).exp()).abs() < 1e-12);
        assert!((votes[2].weight - 0.5 * (-4.5f64).exp()).abs() < 1e-12);
        assert_eq!(votes[3].weight, 0.5 * FLOOR);
        // The positions are not touched.
        assert_eq!(votes[3].position, [400.0, 50.0]);
    }

    #[test]
    fn a_prior_wider_than_the_limit_is_not_applied() {
        // kσ = 20 px exactly applies; just above does not.
        let at = [10.0, 10.0];
        let p = PositionPrior::from_distances(&[
            vec![RAYLEIGH_MEDIAN * MAX_WIDTH_PX / WIDTH_FACTOR],
            vec![RAYLEIGH_MEDIAN * MAX_WIDTH_PX / WIDTH_FACTOR * 1.01],
        ])
        .unwrap();
        assert!(p.applies(0) && !p.applies(1) && !p.applies(2));
        let mut votes = vec![vote([60.0, 10.0])];
        p.weigh(1, at, &mut votes).unwrap();
        assert_eq!(votes[0].weight, 0.5);
        assert_eq!(p.factor(1, at, [60.0, 10.0]).unwrap(), 1.0);
        p.weigh(0, at, &mut votes).unwrap();
        assert!((votes[0].weight - 0.5 * (-50.0f64 * 50.0 / 800.0).exp()).abs() < 1e-12);
    }

    /// Huge distances: the median of two huge middle values is finite (it used to overflow to
    /// σ = ∞), and the camera gets no prior (wider than the limit), the factor 1.
    #[test]
    fn huge_distances_give_a_finite_sigma_and_no_prior() {
        let p =
            PositionPrior::from_distances(&[vec![f64::MAX, f64::MAX], vec![1e300, 2e300]]).unwrap();
        assert_eq!(p.sigmas()[0], f64::MAX / RAYLEIGH_MEDIAN);
        assert_eq!(p.sigmas()[1], 1.5e300 / RAYLEIGH_MEDIAN);
        for cam in 0..2 {
            assert!(p.sigmas()[cam].is_finite() && !p.applies(cam));
            assert_eq!(p.support_px(cam), None);
            assert_eq!(p.factor(cam, [0.0, 0.0], [1e300, -1e300]).unwrap(), 1.0);
        }
        // Where the sum does not overflow, the median is the usual mean of the middle two.
        let q = PositionPrior::from_distances(&[vec![1.0, 2.0, 4.0, 8.0]]).unwrap();
        assert_eq!(q.sigmas()[0], 3.0 / RAYLEIGH_MEDIAN);
    }

    /// Far votes and a far prediction keep the floor of their weight (a finite factor, never
    /// NaN), and a median so small that the prior's squared width underflows is refused at
    /// learning: it used to give a prior under which a vote at the prediction itself was
    /// weighed down to the floor (`0 / 0`).
    #[test]
    fn far_votes_weigh_the_floor_and_a_numerically_zero_width_is_refused() {
        let p = PositionPrior::from_distances(&[vec![RAYLEIGH_MEDIAN * 5.0]]).unwrap();
        let mut votes = vec![vote([1e200, -1e200]), vote([f64::MAX, f64::MAX])];
        p.weigh(0, [0.0, 0.0], &mut votes).unwrap();
        assert!(votes.iter().all(|v| v.weight == 0.5 * FLOOR), "{votes:?}");
        let mut votes = vec![vote([10.0, 10.0])];
        p.weigh(0, [f64::MAX, -f64::MAX], &mut votes).unwrap();
        assert_eq!(votes[0].weight, 0.5 * FLOOR);

        for tiny in [1e-170, 1e-300, 5e-324] {
            assert!(
                matches!(
                    PositionPrior::from_distances(&[vec![tiny]]),
                    Err(PipelineError::InvalidParameter {
                        name: "distances",
                        ..
                    })
                ),
                "{tiny:e}"
            );
        }
        // A small median whose squared width is still a normal number is a prior, and a vote at
        // the prediction keeps its weight under it.
        let narrow = PositionPrior::from_distances(&[vec![1e-100]]).unwrap();
        let mut at = vec![vote([3.0, 4.0])];
        narrow.weigh(0, [3.0, 4.0], &mut at).unwrap();
        assert_eq!(at[0].weight, 0.5);
    }

    /// A vote with a non-finite position or a bad weight is refused and no vote is changed (a
    /// NaN position used to be weighed down to the floor, as if it lay far away).
    #[test]
    fn bad_votes_are_refused_and_no_vote_changes() {
        let p = PositionPrior::from_distances(&[vec![RAYLEIGH_MEDIAN * 5.0]]).unwrap();
        let bad = [
            Vote {
                position: [f64::NAN, 1.0],
                ..vote([0.0, 0.0])
            },
            Vote {
                position: [1.0, f64::INFINITY],
                ..vote([0.0, 0.0])
            },
            Vote {
                weight: f64::NAN,
                ..vote([0.0, 0.0])
            },
            Vote {
                weight: -1.0,
                ..vote([0.0, 0.0])
            },
        ];
        for b in bad {
            let mut votes = vec![vote([3.0, 0.0]), b];
            let before = votes.clone();
            assert!(
                matches!(
                    p.weigh(0, [0.0, 0.0], &mut votes),
                    Err(PipelineError::InvalidParameter { name: "votes", .. })
                ),
                "{b:?}"
            );
            // (By their debug text: a NaN is not equal to itself.)
            assert_eq!(format!("{votes:?}"), format!("{before:?}"));
        }
    }

    /// A non-finite prediction or position, or a camera the prior does not cover, is refused
    /// by `factor` as by `weigh` (a NaN prediction or position used to give the floor `ε`, a
    /// weight as if the vote lay far away); finite input gives the formula's factor.
    #[test]
    fn factor_refuses_a_non_finite_prediction_or_position() {
        let p = PositionPrior::from_distances(&[vec![RAYLEIGH_MEDIAN * 5.0]]).unwrap();
        for bad in [f64::NAN, f64::INFINITY, -f64::INFINITY] {
            for predicted in [[bad, 0.0], [0.0, bad]] {
                assert!(
                    matches!(
                        p.factor(0, predicted, [1.0, 2.0]),
                        Err(PipelineError::InvalidParameter {
                            name: "predicted",
                            ..
                        })
                    ),
                    "{predicted:?}"
                );
            }
            for position in [[bad, 0.0], [0.0, bad]] {
                assert!(
                    matches!(
                        p.factor(0, [0.0, 0.0], position),
                        Err(PipelineError::InvalidParameter {
                            name: "position",
                            ..
                        })
                    ),
                    "{position:?}"
                );
            }
        }
        assert!(matches!(
            p.factor(1, [0.0, 0.0], [1.0, 2.0]),
            Err(PipelineError::InvalidParameter {
                name: "predicted",
                ..
            })
        ));
        // σ = 5 px, kσ = 10 px: a vote 10 px away weighs exp(−1/2), one 400 px away the floor.
        assert_eq!(
            p.factor(0, [0.0, 0.0], [10.0, 0.0]).unwrap(),
            (-100.0f64 / 200.0).exp()
        );
        assert_eq!(p.factor(0, [0.0, 0.0], [400.0, 0.0]).unwrap(), FLOOR);
    }

    #[test]
    fn bad_input_is_refused_and_changes_nothing() {
        assert!(PositionPrior::from_distances(&[]).is_err());
        assert!(matches!(
            PositionPrior::from_distances(&[vec![1.0], vec![]]),
            Err(PipelineError::NotEnoughData(_))
        ));
        assert!(PositionPrior::from_distances(&[vec![1.0, f64::NAN]]).is_err());
        assert!(PositionPrior::from_distances(&[vec![-1.0, 2.0, 3.0]]).is_err());
        assert!(PositionPrior::from_distances(&[vec![0.0, 0.0, 1.0]]).is_err());
        let p = PositionPrior::from_distances(&[vec![2.0]]).unwrap();
        let mut votes = vec![vote([1.0, 2.0])];
        assert!(p.weigh(1, [0.0, 0.0], &mut votes).is_err());
        assert!(p.weigh(0, [f64::NAN, 0.0], &mut votes).is_err());
        assert_eq!(votes[0].weight, 0.5);
    }
}
