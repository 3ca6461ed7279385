//! Recovery from a refused percept: a small known move and a fresh percept.
//!
//! A percept the plant refuses ([`ServoError::PerceptRefused`], [`ServoError::PerceptInconsistent`])
//! is, on the learned recogniser, mostly doubted *systematically* at that pose (the tip
//! correction's spread and the cross-camera consistency are functions of the pose), so a
//! re-capture at the same pose rarely helps (docs/methods.md, *Motion check*). With a
//! [`Recovery`] in [`crate::ServoConfig::recovery`] the servo loops answer a refusal with a small
//! move whose command does not depend on the refused percept: from the refused command `y_r`,
//! `y_r + s d_k` for a unit direction `d_k` in the controlled joints (seeded by the recovery's
//! seed and `y_r`, so deterministic), each component reflected back into the workspace box
//! where it would leave it, executed like every other move (the approach), then observed
//! afresh; up to [`Recovery::tries`] such moves per refusal. Every recovery move is a move
//! made: the loops record it ([`RefusedMove`], [`crate::ServoRun::recovery_moves`]) and count it
//! against the run's move budget. When every try is refused the run stops with
//! [`ServoError::RecoveryFailed`].

use rand::SeedableRng;
use rand::rngs::Xoshiro256PlusPlus;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

use crate::error::{Result, ServoError};

/// Settings of the recovery move after a refused percept (module doc).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Recovery {
    /// Length `s` of each recovery move in the controlled joints' command space (Euclidean,
    /// command units; > 0).
    pub step: f64,
    /// Recovery moves per refused percept, at most (≥ 1).
    pub tries: usize,
    /// The box the recovery moves stay in, one `[lo, hi]` per controlled joint (the learned
    /// workspace: the training moves' exploration ranges); empty: the plant's command range.
    #[serde(default)]
    pub workspace: Vec<[f64; 2]>,
    /// Seed of the directions.
    #[serde(default)]
    pub seed: u64,
}

impl Recovery {
    /// Checks `step` finite and positive, `tries ≥ 1` and every workspace range a finite
    /// interval.
    pub fn validate(&self) -> Result<()> {
        if !(self.step.is_finite() && self.step > 0.0) {
            return Err(ServoError::InvalidParameter {
                name: "recovery step",
                reason: format!("must be finite and positive, got {}", self.step),
            });
        }
        if self.tries == 0 {
            return Err(ServoError::invalid(
                "recovery tries",
                "at least one recovery move per refused percept",
            ));
        }
        for (j, &[lo, hi]) in self.workspace.iter().enumerate() {
            if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
                return Err(ServoError::InvalidParameter {
                    name: "recovery workspace",
                    reason: format!("range {j} = [{lo}, {hi}] is not a finite interval"),
                });
            }
        }
        Ok(())
    }

    /// The command of recovery move `attempt` (0-based) after the percept at `refused` was
    /// refused: `refused + step · d`, `d` a unit direction drawn from a generator seeded by
    /// [`Recovery::seed`], `refused` and `attempt`; a component that would leave its range (the
    /// workspace's, intersected with `range(j)`, the plant's command range) takes the opposite
    /// step, and is clamped into the range if that leaves it too. Errors: a workspace with
    /// another number of ranges than `refused` has components.
    pub fn command(
        &self,
        refused: &[f64],
        attempt: usize,
        range: impl Fn(usize) -> [f64; 2],
    ) -> Result<Vec<f64>> {
        if !self.workspace.is_empty() && self.workspace.len() != refused.len() {
            return Err(ServoError::DimensionMismatch {
                what: "recovery workspace",
                expected: refused.len(),
                got: self.workspace.len(),
            });
        }
        let d = self.direction(refused, attempt);
        Ok(refused
            .iter()
            .zip(&d)
            .enumerate()
            .map(|(j, (&y, &dj))| {
                let [mut lo, mut hi] = range(j);
                if let Some(&[wlo, whi]) = self.workspace.get(j) {
                    lo = lo.max(wlo);
                    hi = hi.min(whi);
                }
                let v = y + self.step * dj;
                let v = if v < lo || v > hi {
                    y - self.step * dj
                } else {
                    v
                };
                if lo <= hi { v.clamp(lo, hi) } else { v }
            })
            .collect())
    }

    /// A unit direction, from a generator seeded by the seed, the refused command's bits and
    /// the attempt (the first axis when the draw degenerates).
    fn direction(&self, refused: &[f64], attempt: usize) -> Vec<f64> {
        let mut h = splitmix(self.seed ^ 0x5EC0_7E11);
        for v in refused {
            h = splitmix(h ^ v.to_bits());
        }
        h = splitmix(h ^ attempt as u64);
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(h);
        let mut d: Vec<f64> = (0..refused.len())
            .map(|_| StandardNormal.sample(&mut rng))
            .collect();
        let norm = d.iter().map(|v| v * v).sum::<f64>().sqrt();
        if norm > 1e-12 && norm.is_finite() {
            d.iter_mut().for_each(|v| *v /= norm);
        } else {
            d.iter_mut()
                .enumerate()
                .for_each(|(j, v)| *v = f64::from(j == 0));
        }
        d
    }
}

/// SplitMix64's finaliser (a bijective mix of 64 bits).
fn splitmix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A move made whose percept was refused: nothing was learned from it and the loop did not
/// compute a command from it (the next move, if any, was a recovery move). The same record
/// holds the move a run ended on when its observation failed otherwise
/// ([`crate::ServoRun::failed_move`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RefusedMove {
    /// Index of the move among all moves made in the run (0 = the first guess).
    pub at_move: usize,
    /// The command sent (controlled set-points).
    pub command: Vec<f64>,
    /// The pre-position sent before it, with an approach (not observed).
    #[serde(default)]
    pub pre_position: Option<Vec<f64>>,
    /// Why the percept was refused, or the observation failed (the error's message).
    pub reason: String,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn recovery() -> Recovery {
        Recovery {
            step: 20.0,
            tries: 2,
            workspace: vec![[1000.0, 2000.0]; 3],
            seed: 7,
        }
    }

    #[test]
    fn a_recovery_move_has_the_step_length_and_is_deterministic() {
        let r = recovery();
        let y = [1500.0, 1400.0, 1300.0];
        let a = r.command(&y, 0, |_| [500.0, 2500.0]).unwrap();
        let len = a.iter().zip(&y).map(|(a, b)| (a - b).powi(2)).sum::<f64>();
        assert!((len.sqrt() - 20.0).abs() < 1e-9, "{a:?}");
        assert_eq!(a, r.command(&y, 0, |_| [500.0, 2500.0]).unwrap());
        let b = r.command(&y, 1, |_| [500.0, 2500.0]).unwrap();
        assert_ne!(a, b, "each try another direction");
        let other_seed = Recovery { seed: 8, ..r };
        assert_ne!(a, other_seed.command(&y, 0, |_| [500.0, 2500.0]).unwrap());
    }

    #[test]
    fn a_recovery_move_stays_in_the_workspace() {
        let r = recovery();
        for attempt in 0..50 {
            // At the workspace's corner: every component that would leave steps back in.
            let y = [1000.0, 2000.0, 1000.0];
            let c = r.command(&y, attempt, |_| [0.0, 3000.0]).unwrap();
            for v in &c {
                assert!((1000.0..=2000.0).contains(v), "{c:?}");
            }
            let len = c.iter().zip(&y).map(|(a, b)| (a - b).powi(2)).sum::<f64>();
            assert!((len.sqrt() - 20.0).abs() < 1e-9);
            // The plant's range narrower than the workspace: clamped into it.
            let c = r
                .command(&[1500.0; 3], attempt, |_| [1495.0, 1505.0])
                .unwrap();
            assert!(c.iter().all(|v| (1495.0..=1505.0).contains(v)), "{c:?}");
        }
    }

    #[test]
    fn bad_settings_are_typed_errors() {
        for bad in [
            Recovery {
                step: 0.0,
                ..recovery()
            },
            Recovery {
                step: f64::NAN,
                ..recovery()
            },
            Recovery {
                tries: 0,
                ..recovery()
            },
            Recovery {
                workspace: vec![[2.0, 1.0]],
                ..recovery()
            },
        ] {
            assert!(matches!(
                bad.validate(),
                Err(ServoError::InvalidParameter { .. })
            ));
        }
        assert!(recovery().validate().is_ok());
        assert!(matches!(
            recovery().command(&[1.0, 2.0], 0, |_| [0.0, 9.0]),
            Err(ServoError::DimensionMismatch { .. })
        ));
    }
}
