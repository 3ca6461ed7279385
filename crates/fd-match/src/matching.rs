//! Preselection (eq. 18) and the symmetric ratio test (eq. 19).

use serde::{Deserialize, Serialize};

use crate::correlation::Alignment;
use crate::descriptor::DescriptorSet;
use crate::error::FdError;
use crate::method::Method;
use crate::search::{BestTwo, best_two, check_pair_error};

/// Paper A's ratio threshold `T_r` (about 90 % correct matches for FD Corr).
pub const DEFAULT_RATIO_THRESHOLD: f64 = 0.5;

/// Indices of the descriptors kept by preselection (eq. 18): those whose minimum error against
/// the other descriptors of their own image is *not* below `t_err` (`e_min ≥ T_err`), in
/// ascending order. `min_errors` comes from [`crate::min_errors_within`]; build the reduced set
/// with [`DescriptorSet::select`].
///
/// # Errors
/// [`FdError::InvalidParameter`] when `t_err` is NaN or negative (a NaN threshold would keep
/// nothing, silently), and when a minimum error is NaN or negative (errors are squared distances,
/// `+∞` for a descriptor alone in its image).
pub fn preselect(min_errors: &[f64], t_err: f64) -> Result<Vec<usize>, FdError> {
    if t_err.is_nan() || t_err < 0.0 {
        return Err(FdError::InvalidParameter {
            name: "t_err",
            value: t_err,
            reason: "must be a number >= 0",
        });
    }
    if let Some(&e) = min_errors.iter().find(|e| e.is_nan() || **e < 0.0) {
        return Err(FdError::InvalidParameter {
            name: "min_errors",
            value: e,
            reason: "every minimum error must be a number >= 0 (from min_errors_within)",
        });
    }
    Ok(min_errors
        .iter()
        .enumerate()
        .filter(|(_, e)| **e >= t_err)
        .map(|(i, _)| i)
        .collect())
}

/// A mutual best match between descriptor `query` of set A and `target` of set B.
///
/// Deserialisation checks what [`mutual_matches`] produces from search results
/// ([`FdError::InvalidParameter`] otherwise): an error finite and `≥ 0`, a ratio in `[0, 1]`
/// (the best error over the second best), and the alignment's ranges ([`Alignment`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "MatchSpec")]
pub struct Match {
    /// Index in set A (use [`DescriptorSet::source`] for the contour index).
    pub query: usize,
    /// Index in set B.
    pub target: usize,
    /// Error of the pair.
    pub error: f64,
    /// The larger of the two error ratios `e_min / e_sec` (A→B and B→A), eq. 19.
    pub ratio: f64,
    /// Rotation and shift from A's contour to B's ([`Method::FdCorr`] only).
    pub alignment: Option<Alignment>,
}

/// The serialised form of a [`Match`], checked on deserialisation.
#[derive(Deserialize)]
struct MatchSpec {
    query: usize,
    target: usize,
    error: f64,
    ratio: f64,
    alignment: Option<Alignment>,
}

impl TryFrom<MatchSpec> for Match {
    type Error = FdError;
    fn try_from(s: MatchSpec) -> Result<Self, FdError> {
        check_pair_error(s.error)?;
        // NaN fails the range test.
        if !(0.0..=1.0).contains(&s.ratio) {
            return Err(FdError::InvalidParameter {
                name: "ratio",
                value: s.ratio,
                reason: "an error ratio e_min / e_sec lies in [0, 1]",
            });
        }
        Ok(Match {
            query: s.query,
            target: s.target,
            error: s.error,
            ratio: s.ratio,
            alignment: s.alignment,
        })
    }
}

impl Match {
    /// Whether the match passes the ratio test with threshold `t_r` (`ratio < T_r`).
    pub fn accepted(&self, t_r: f64) -> bool {
        self.ratio < t_r
    }
}

/// Symmetric matching: every pair `(i, j)` such that `j` is the best target of query `i`
/// (A→B) and `i` the best target of query `j` (B→A), with the larger of the two ratios, in
/// ascending `i`. No threshold is applied, so precision–recall curves follow by sweeping
/// [`Match::accepted`] over `T_r` without recomputation.
pub fn mutual_matches(a_to_b: &[BestTwo], b_to_a: &[BestTwo]) -> Vec<Match> {
    let mut out = Vec::new();
    for (i, ab) in a_to_b.iter().enumerate() {
        let Some(best) = ab.best else { continue };
        let Some(ba) = b_to_a.get(best.index) else {
            continue;
        };
        if ba.best.map(|c| c.index) != Some(i) {
            continue;
        }
        let (ra, rb) = (ab.ratio().unwrap_or(1.0), ba.ratio().unwrap_or(1.0));
        out.push(Match {
            query: i,
            target: best.index,
            error: best.error,
            ratio: ra.max(rb),
            alignment: best.alignment,
        });
    }
    out
}

/// Both searches and [`mutual_matches`]: all symmetric matches between sets A and B, unthresholded.
pub fn match_sets(
    a: &DescriptorSet,
    b: &DescriptorSet,
    method: Method,
) -> Result<Vec<Match>, FdError> {
    let ab = best_two(a, b, method)?;
    let ba = best_two(b, a, method)?;
    Ok(mutual_matches(&ab, &ba))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::search::Candidate;

    fn bt(best: (usize, f64), second: Option<(usize, f64)>) -> BestTwo {
        let c = |(index, error)| Candidate {
            index,
            error,
            alignment: None,
        };
        BestTwo {
            best: Some(c(best)),
            second: second.map(c),
        }
    }

    #[test]
    fn mutual_matches_keep_only_symmetric_pairs_with_the_larger_ratio() {
        let ab = vec![
            bt((1, 0.1), Some((0, 0.4))), // 0 -> 1, ratio .25
            bt((1, 0.2), Some((2, 0.3))), // 1 -> 1, not mutual
            bt((0, 0.3), None),           // 2 -> 0, ratio 0
        ];
        let ba = vec![
            bt((2, 0.3), Some((1, 0.6))), // 0 -> 2, ratio .5
            bt((0, 0.1), Some((1, 0.2))), // 1 -> 0, ratio .5
        ];
        let m = mutual_matches(&ab, &ba);
        assert_eq!(m.len(), 2);
        assert_eq!((m[0].query, m[0].target, m[0].ratio), (0, 1, 0.5));
        assert_eq!((m[1].query, m[1].target, m[1].ratio), (2, 0, 0.5));
        assert!(!m[0].accepted(0.5) && m[0].accepted(0.51));
    }

    #[test]
    fn preselection_drops_descriptors_below_t_err() {
        assert_eq!(
            preselect(&[1e-5, 2e-3, 1e-3, f64::INFINITY], 1e-3).unwrap(),
            vec![1, 2, 3]
        );
        // T_err = +inf keeps only descriptors alone in their image; 0 keeps everything.
        assert_eq!(
            preselect(&[0.0, f64::INFINITY], f64::INFINITY).unwrap(),
            [1]
        );
        assert_eq!(preselect(&[0.0, 1.0], 0.0).unwrap(), [0, 1]);
    }

    #[test]
    fn preselection_refuses_nan_and_negative_inputs() {
        for t in [f64::NAN, -1e-3] {
            assert!(matches!(
                preselect(&[1.0], t),
                Err(FdError::InvalidParameter { name: "t_err", .. })
            ));
        }
        for e in [f64::NAN, -1.0] {
            assert!(matches!(
                preselect(&[1.0, e], 1e-3),
                Err(FdError::InvalidParameter {
                    name: "min_errors",
                    ..
                })
            ));
        }
    }

    #[test]
    fn ratio_edge_cases() {
        assert_eq!(bt((0, 0.0), Some((1, 0.0))).ratio(), Some(1.0));
        assert_eq!(bt((0, 0.2), None).ratio(), Some(0.0));
        assert_eq!(BestTwo::default().ratio(), None);
    }
}
