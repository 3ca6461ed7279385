//! Precision and recall of one image pair's matches against a known homography `H` (img1 →
//! img2): a match `(i, j)` is correct when the overlap error of region i's frame and region j's
//! frame mapped back by `H⁻¹` is below 50 % in descriptor mode ([`super::ground_truth`]);
//! precision = correct / reported, recall = correct / existing (the greedy one-to-one
//! correspondences).

use serde::Serialize;

use super::ground_truth::{PairTruth, pair_truth};
use super::overlap::{Ellipse, Normalisation, Offset, map_linearised, overlap_error};
use crate::geometry::Homography;

/// One match's verdict.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct MatchScore {
    /// Overlap error ε in `[0, 1]` (1 when region j maps to infinity).
    pub overlap_error: f64,
    /// ε < 50 % (the full pairwise criterion).
    pub correct: bool,
}

/// A pair's score.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PairScore {
    /// Existing matches (one-to-one correspondences).
    pub existing: usize,
    /// Region pairs with ε < 50 %.
    pub correct_pairs: usize,
    /// Matches scored.
    pub matches: usize,
    /// Correct among them.
    pub correct: usize,
    /// correct / matches (absent without matches).
    pub precision: Option<f64>,
    /// correct / existing (absent when nothing exists).
    pub recall: Option<f64>,
    /// Per match, in the order given.
    pub per_match: Vec<MatchScore>,
}

/// Scores matches `(i, j)` of frames `f1` (img1) and `f2` (img2) against `h`; `truth` may be
/// passed when already computed.
pub fn score_matches(
    f1: &[Ellipse],
    f2: &[Ellipse],
    matches: &[(usize, usize)],
    h: &Homography,
    truth: Option<&PairTruth>,
) -> PairScore {
    let owned;
    let truth = match truth {
        Some(t) => t,
        None => {
            owned = pair_truth(f1, f2, h);
            &owned
        }
    };
    let hi = h.inverse();
    let per_match: Vec<MatchScore> = matches
        .iter()
        .map(|&(i, j)| {
            let eps = map_linearised(&f2[j], &hi).map_or(1.0, |b| {
                overlap_error(&f1[i], &b, Normalisation::Descriptor, Offset::Faithful)
            });
            MatchScore {
                overlap_error: eps,
                correct: truth.is_correct(i as u32, j as u32),
            }
        })
        .collect();
    let correct = per_match.iter().filter(|m| m.correct).count();
    let existing = truth.existing();
    PairScore {
        existing,
        correct_pairs: truth.correct.len(),
        matches: matches.len(),
        correct,
        precision: (!matches.is_empty()).then(|| correct as f64 / matches.len() as f64),
        recall: (existing > 0).then(|| correct as f64 / existing as f64),
        per_match,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scoring::overlap::tests::circ;

    #[test]
    fn hand_made_pair() {
        let h =
            Homography::from_row_major(&[1.0, 0.0, 10.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]).unwrap();
        let f1 = [
            circ(50.0, 50.0, 5.0),
            circ(150.0, 50.0, 5.0),
            circ(50.0, 150.0, 8.0),
        ];
        let f2 = [
            circ(60.0, 50.0, 5.0),
            circ(160.0, 50.0, 5.0),
            circ(300.0, 300.0, 8.0),
        ];
        let s = score_matches(&f1, &f2, &[(0, 0), (1, 0), (2, 2)], &h, None);
        assert_eq!(
            (s.existing, s.correct_pairs, s.matches, s.correct),
            (2, 2, 3, 1)
        );
        assert_eq!(s.precision, Some(1.0 / 3.0));
        assert_eq!(s.recall, Some(0.5));
        assert_eq!(s.per_match[0].overlap_error, 0.0);
        assert!(s.per_match[1].overlap_error == 1.0 && !s.per_match[2].correct);
        let none = score_matches(&f1, &f2, &[], &h, None);
        assert_eq!((none.precision, none.recall), (None, Some(0.0)));
    }

    /// A region of img2 whose centre `H⁻¹` maps to the line at infinity scores ε = 1 (not
    /// correct), and takes no part in the ground truth.
    #[test]
    fn a_region_mapped_to_infinity_has_overlap_error_one() {
        // H⁻¹ = [[1, 0, 0], [0, 1, 0], [0.01, 0, 1]]: w = 0 on x = −100.
        let h_inv =
            Homography::from_row_major(&[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.01, 0.0, 1.0]).unwrap();
        let h = h_inv.inverse();
        let f1 = [circ(50.0, 50.0, 5.0)];
        let f2 = [circ(-100.0, 50.0, 5.0)];
        let s = score_matches(&f1, &f2, &[(0, 0)], &h, None);
        assert_eq!(s.per_match[0].overlap_error, 1.0);
        assert!(!s.per_match[0].correct);
        assert_eq!(
            (s.correct_pairs, s.existing, s.precision),
            (0, 0, Some(0.0))
        );
    }
}
