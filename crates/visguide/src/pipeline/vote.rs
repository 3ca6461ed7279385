//! From votes to one percept: the weighted mode of a frame's tip votes.
//!
//! Every accepted descriptor match votes for a tip position with a weight. The FD-only percept
//! is the vote with the largest kernel support `s_i = Σ_j w_j exp(−d_ij² / 2σ²)`, refined to
//! the weighted mean of the votes within 3σ of it; its certainty is the share of the frame's
//! evidence that agrees, in `[0, 1]`: per voting region its heaviest vote within 3σ, summed,
//! over the sum of every region's heaviest vote (a region votes once per near-best gripper
//! view, and its views that point elsewhere do not make the frame less certain; with one vote
//! per region this is the share of the vote weight within 3σ). Ties go to the lower index, so
//! the result does not depend on anything but the votes' order.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::error::{PipelineError, Result};

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
    /// The voting region's index in its frame (the votes of one region share it).
    #[serde(default)]
    pub region: usize,
}

/// The mode of a frame's votes.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Mode {
    /// The refined position.
    pub position: [f64; 2],
    /// Share of the frame's evidence within 3σ of the mode (module docs), in `[0, 1]`.
    pub certainty: f64,
    /// Number of votes within 3σ.
    pub support: usize,
}

/// `Ok` when every vote has a finite position and a finite, non-negative weight; otherwise
/// [`PipelineError::InvalidParameter`] (`votes`) naming the first one that does not.
pub(crate) fn check_votes(votes: &[Vote]) -> Result<()> {
    match votes.iter().enumerate().find(|(_, v)| {
        !(v.position.iter().all(|c| c.is_finite()) && v.weight.is_finite() && v.weight >= 0.0)
    }) {
        None => Ok(()),
        Some((i, v)) => Err(PipelineError::InvalidParameter {
            name: "votes",
            reason: format!(
                "vote {i} at {:?} with weight {}: needs a finite position and a finite, \
                 non-negative weight",
                v.position, v.weight
            ),
        }),
    }
}

/// The weighted mode of `votes` with kernel width `sigma` (pixels); `None` without votes (or
/// with zero total weight).
///
/// Errors ([`PipelineError::InvalidParameter`]): `sigma` not finite and positive (`sigma`), a
/// vote with a non-finite position or a weight not finite and non-negative (`votes`). (They
/// used to give `None` for a bad `sigma`, and a NaN position or the first vote's for bad votes.)
/// Also `votes` whose sums overflow: positions near `f64::MAX`, whose weighted mean is not
/// finite, or weights near it, whose evidence is not (the mode used to be at infinity, or its
/// certainty NaN).
pub fn mode(votes: &[Vote], sigma: f64) -> Result<Option<Mode>> {
    if !(sigma.is_finite() && sigma > 0.0) {
        return Err(PipelineError::InvalidParameter {
            name: "sigma",
            reason: format!("{sigma} must be finite and positive"),
        });
    }
    check_votes(votes)?;
    let total: f64 = votes.iter().map(|v| v.weight).sum();
    if votes.is_empty() || total <= 0.0 {
        return Ok(None);
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
    // Per region (in index order, so the sums are deterministic): its heaviest vote, and its
    // heaviest vote within reach.
    let mut regions: BTreeMap<usize, (f64, f64)> = BTreeMap::new();
    for v in votes {
        let r = regions.entry(v.region).or_insert((0.0, 0.0));
        r.0 = r.0.max(v.weight);
        if d2(v.position, centre) <= reach {
            w += v.weight;
            x += v.weight * v.position[0];
            y += v.weight * v.position[1];
            n += 1;
            r.1 = r.1.max(v.weight);
        }
    }
    let evidence: f64 = regions.values().map(|r| r.0).sum();
    let agrees: f64 = regions.values().map(|r| r.1).sum();
    let m = Mode {
        position: [x / w, y / w],
        certainty: (agrees / evidence).clamp(0.0, 1.0),
        support: n,
    };
    if !(m.position.iter().all(|c| c.is_finite()) && m.certainty.is_finite()) {
        return Err(PipelineError::InvalidParameter {
            name: "votes",
            reason: format!(
                "the weighted mean of the votes near {centre:?} is {:?} with certainty {}: \
                 positions or weights so large that their sums overflow",
                m.position, m.certainty
            ),
        });
    }
    Ok(Some(m))
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
            region: 0,
        }
    }

    /// One vote per region, region `k` for the `k`-th.
    fn own_regions(mut votes: Vec<Vote>) -> Vec<Vote> {
        for (k, v) in votes.iter_mut().enumerate() {
            v.region = k;
        }
        votes
    }

    #[test]
    fn the_largest_agreeing_group_wins_over_scattered_clutter() {
        let votes = own_regions(vec![
            vote(100.0, 50.0, 0.5),
            vote(101.0, 50.0, 0.5),
            vote(100.5, 51.0, 1.0),
            vote(300.0, 200.0, 0.9),
            vote(10.0, 400.0, 0.9),
        ]);
        let m = mode(&votes, 2.0).unwrap().unwrap();
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
    fn a_region_counts_once_towards_the_certainty() {
        // Region 0 votes at the tip and, through two other views, elsewhere; region 1 agrees
        // at the tip; region 2 votes alone far away.
        let mut votes = vec![
            vote(50.0, 50.0, 0.8),
            vote(90.0, 10.0, 0.4),
            vote(10.0, 90.0, 0.4),
            vote(50.5, 50.0, 0.6),
            vote(200.0, 200.0, 0.2),
        ];
        for (v, r) in votes.iter_mut().zip([0, 0, 0, 1, 2]) {
            v.region = r;
        }
        let m = mode(&votes, 2.0).unwrap().unwrap();
        assert_eq!(m.support, 2);
        // (0.8 + 0.6) of the regions' heaviest votes (0.8 + 0.6 + 0.2).
        assert!((m.certainty - 1.4 / 1.6).abs() < 1e-12, "{}", m.certainty);
        // The weighted mean of the two agreeing votes.
        assert!((m.position[0] - (0.8 * 50.0 + 0.6 * 50.5) / 1.4).abs() < 1e-12);
    }

    #[test]
    fn no_votes_no_mode_and_one_vote_is_certain() {
        assert!(mode(&[], 2.0).unwrap().is_none());
        assert!(mode(&[vote(1.0, 2.0, 0.0)], 2.0).unwrap().is_none());
        let m = mode(&[vote(1.0, 2.0, 0.3)], 2.0).unwrap().unwrap();
        assert_eq!((m.position, m.certainty, m.support), ([1.0, 2.0], 1.0, 1));
    }

    #[test]
    fn bad_votes_or_kernel_widths_are_errors() {
        // A zero, negative, NaN or infinite width used to give `None`, as if there were no votes.
        for sigma in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(matches!(
                mode(&[vote(1.0, 2.0, 1.0)], sigma),
                Err(PipelineError::InvalidParameter { name: "sigma", .. })
            ));
        }
        // A NaN position used to become the mode; a negative or NaN weight skewed or hid it.
        for bad in [
            vote(f64::NAN, 2.0, 1.0),
            vote(1.0, f64::INFINITY, 1.0),
            vote(1.0, 2.0, -0.5),
            vote(1.0, 2.0, f64::NAN),
        ] {
            assert!(matches!(
                mode(&[vote(5.0, 5.0, 0.5), bad], 2.0),
                Err(PipelineError::InvalidParameter { name: "votes", .. })
            ));
        }
    }

    /// Finite votes whose weighted mean overflows (positions near `f64::MAX`) or whose
    /// evidence does (weights near it, in two regions) are refused naming `votes`; the mode
    /// used to be at infinity, or its certainty NaN.
    #[test]
    fn votes_whose_sums_overflow_are_refused() {
        let far = [vote(1e308, 0.0, 1.0), vote(1e308, 0.0, 1.0)];
        let heavy = own_regions(vec![vote(0.0, 0.0, 1e308), vote(0.0, 0.0, 1e308)]);
        for votes in [far.to_vec(), heavy] {
            match mode(&votes, 1.0) {
                Err(PipelineError::InvalidParameter { name: "votes", .. }) => {}
                other => panic!("{votes:?}: {other:?}"),
            }
        }
        // Large but summable: still a mode.
        let m = mode(&[vote(1e306, 0.0, 1.0), vote(1e306, 0.0, 1.0)], 1.0)
            .unwrap()
            .unwrap();
        assert_eq!(m.position, [1e306, 0.0]);
    }
}
