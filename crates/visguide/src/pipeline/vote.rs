//! From votes to one percept: the weighted mode of a frame's tip votes.
//!
//! Every accepted descriptor match votes for a tip position with a weight. The FD-only percept
//! is the vote with the largest kernel support `s_i = Σ_j w_j exp(−d_ij² / 2σ²)`, refined to
//! the weighted mean of the votes within 3σ of it; its certainty is the share of the frame's
//! vote weight that agrees (within 3σ), in `[0, 1]`. Ties go to the lower index, so the result
//! does not depend on anything but the votes' order.

use serde::{Deserialize, Serialize};

/// One tip vote of one accepted match.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Vote {
    /// The voted tip position (full-resolution pixels `[u, v]`).
    pub position: [f64; 2],
    /// Weight in `(0, 1]`: `1 − ratio / T_r` of the match's ratio test.
    pub weight: f64,
    /// The match's error against the gripper model (eq. 10).
    pub error: f64,
    /// The recovered rotation from the model view to this region (radians, eq. 12).
    pub rotation: f64,
}

/// The mode of a frame's votes.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Mode {
    /// The refined position.
    pub position: [f64; 2],
    /// Share of the vote weight within 3σ of the mode, in `[0, 1]`.
    pub certainty: f64,
    /// Number of votes within 3σ.
    pub support: usize,
}

/// The weighted mode of `votes` with kernel width `sigma` (pixels); `None` without votes.
pub fn mode(votes: &[Vote], sigma: f64) -> Option<Mode> {
    let total: f64 = votes.iter().map(|v| v.weight).sum();
    let positive = |x: f64| x.partial_cmp(&0.0) == Some(std::cmp::Ordering::Greater);
    if votes.is_empty() || !positive(total) || !positive(sigma) {
        return None;
    }
    let inv = 1.0 / (2.0 * sigma * sigma);
    let d2 = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2);
    let mut best = (0, f64::NEG_INFINITY);
    for (i, a) in votes.iter().enumerate() {
        let s: f64 = votes
            .iter()
            .map(|b| b.weight * (-d2(a.position, b.position) * inv).exp())
            .sum();
        if s > best.1 {
            best = (i, s);
        }
    }
    let centre = votes[best.0].position;
    let reach = 9.0 * sigma * sigma;
    let (mut w, mut x, mut y, mut n) = (0.0, 0.0, 0.0, 0);
    for v in votes {
        if d2(v.position, centre) <= reach {
            w += v.weight;
            x += v.weight * v.position[0];
            y += v.weight * v.position[1];
            n += 1;
        }
    }
    Some(Mode {
        position: [x / w, y / w],
        certainty: (w / total).clamp(0.0, 1.0),
        support: n,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn vote(x: f64, y: f64, weight: f64) -> Vote {
        Vote {
            position: [x, y],
            weight,
            error: 0.1,
            rotation: 0.0,
        }
    }

    #[test]
    fn the_largest_agreeing_group_wins_over_scattered_clutter() {
        let votes = [
            vote(100.0, 50.0, 0.5),
            vote(101.0, 50.0, 0.5),
            vote(100.5, 51.0, 1.0),
            vote(300.0, 200.0, 0.9),
            vote(10.0, 400.0, 0.9),
        ];
        let m = mode(&votes, 2.0).unwrap();
        // The weighted mean of the three agreeing votes.
        assert!((m.position[0] - 100.5).abs() < 1e-12);
        assert!((m.position[1] - 50.5).abs() < 1e-12);
        assert_eq!(m.support, 3);
        assert!((m.certainty - 2.0 / 3.8).abs() < 1e-12);
        // Brute-force check of the mode: no vote has more kernel support.
        let support = |p: [f64; 2]| -> f64 {
            votes
                .iter()
                .map(|b| {
                    b.weight
                        * (-((p[0] - b.position[0]).powi(2) + (p[1] - b.position[1]).powi(2)) / 8.0)
                            .exp()
                })
                .sum()
        };
        let s = support([100.5, 51.0]);
        assert!(votes.iter().all(|v| support(v.position) <= s + 1e-12));
    }

    #[test]
    fn no_votes_no_mode_and_one_vote_is_certain() {
        assert!(mode(&[], 2.0).is_none());
        assert!(mode(&[vote(1.0, 2.0, 0.0)], 2.0).is_none());
        assert!(mode(&[vote(1.0, 2.0, 1.0)], 0.0).is_none());
        let m = mode(&[vote(1.0, 2.0, 0.3)], 2.0).unwrap();
        assert_eq!((m.position, m.certainty, m.support), ([1.0, 2.0], 1.0, 1));
    }
}
