//! Precision and recall of one image pair's matches against a known homography `H` (img1 →
//! img2): a match `(i, j)` is correct when the overlap error of region i's frame and region j's
//! frame mapped back by `H⁻¹` is below 50 % in descriptor mode ([`super::ground_truth`]);
//! precision = correct / reported, recall = correct / existing (the greedy one-to-one
//! correspondences).

use serde::Serialize;

use super::ground_truth::{PairTruth, pair_truth};
use super::overlap::{Ellipse, Normalisation, Offset, map_linearised, overlap_error};
use crate::error::VisguideError;
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
/// passed when already computed ([`pair_truth`] of the same frames and `h`).
///
/// Errors ([`VisguideError::Invalid`]): a match naming a region that is not in `f1` or `f2`
/// (`matches`; it used to panic indexing the frames), or a `truth` naming one (`truth`; a ground
/// truth of other frames, which used to be read silently).
pub fn score_matches(
    f1: &[Ellipse],
    f2: &[Ellipse],
    matches: &[(usize, usize)],
    h: &Homography,
    truth: Option<&PairTruth>,
) -> Result<PairScore, VisguideError> {
    let (n1, n2) = (f1.len(), f2.len());
    if let Some((k, (i, j))) = matches
        .iter()
        .enumerate()
        .find(|(_, (i, j))| *i >= n1 || *j >= n2)
    {
        return Err(VisguideError::Invalid {
            name: "matches",
            reason: format!(
                "match {k} pairs region {i} of image 1 with region {j} of image 2, which have \
                 {n1} and {n2} regions"
            ),
        });
    }
    if let Some(t) = truth
        && let Some((i, j)) = t
            .correct
            .iter()
            .chain(&t.one_to_one)
            .find(|(i, j)| *i as usize >= n1 || *j as usize >= n2)
    {
        return Err(VisguideError::Invalid {
            name: "truth",
            reason: format!(
                "it pairs region {i} of image 1 with region {j} of image 2, which have {n1} \
                 and {n2} regions: a ground truth of other frames"
            ),
        });
    }
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
                // `i < f1.len()`, checked above; a region index beyond `u32` would need more
                // than 2^32 frames in memory (`pair_truth` numbers regions as `u32`).
                correct: truth.is_correct(i as u32, j as u32),
            }
        })
        .collect();
    let correct = per_match.iter().filter(|m| m.correct).count();
    let existing = truth.existing();
    Ok(PairScore {
        existing,
        correct_pairs: truth.correct.len(),
        matches: matches.len(),
        correct,
        precision: (!matches.is_empty()).then(|| correct as f64 / matches.len() as f64),
        recall: (existing > 0).then(|| correct as f64 / existing as f64),
        per_match,
    })
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
        let s = score_matches(&f1, &f2, &[(0, 0), (1, 0), (2, 2)], &h, None).unwrap();
        assert_eq!(
            (s.existing, s.correct_pairs, s.matches, s.correct),
            (2, 2, 3, 1)
        );
        assert_eq!(s.precision, Some(1.0 / 3.0));
        assert_eq!(s.recall, Some(0.5));
        assert_eq!(s.per_match[0].overlap_error, 0.0);
        assert!(s.per_match[1].overlap_error == 1.0 && !s.per_match[2].correct);
        let none = score_matches(&f1, &f2, &[], &h, None).unwrap();
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
        let s = score_matches(&f1, &f2, &[(0, 0)], &h, None).unwrap();
        assert_eq!(s.per_match[0].overlap_error, 1.0);
        assert!(!s.per_match[0].correct);
        assert_eq!(
            (s.correct_pairs, s.existing, s.precision),
            (0, 0, Some(0.0))
        );
    }

    /// A match naming a region that is not in `f1` or `f2` (the arguments are independent
    /// slices) is refused, naming it; it used to panic indexing the frames.
    #[test]
    fn a_match_naming_a_missing_region_is_refused() {
        let h = Homography::from_row_major(&[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]).unwrap();
        let f1 = [circ(50.0, 50.0, 5.0)];
        let f2 = [circ(50.0, 50.0, 5.0)];
        for bad in [(0, 3), (1, 0)] {
            match score_matches(&f1, &f2, &[(0, 0), bad], &h, None) {
                Err(VisguideError::Invalid {
                    name: "matches",
                    reason,
                }) => {
                    assert!(reason.starts_with("match 1 "), "{reason}");
                }
                other => panic!("{bad:?}: {other:?}"),
            }
        }
        // A ground truth of more regions than these frames hold is refused too.
        let more = [circ(50.0, 50.0, 5.0), circ(80.0, 50.0, 5.0)];
        let truth = pair_truth(&more, &more, &h);
        assert!(truth.is_correct(1, 1));
        assert!(matches!(
            score_matches(&f1, &f2, &[(0, 0)], &h, Some(&truth)),
            Err(VisguideError::Invalid { name: "truth", .. })
        ));
        let own = pair_truth(&f1, &f2, &h);
        assert_eq!(
            score_matches(&f1, &f2, &[(0, 0)], &h, Some(&own)).unwrap(),
            score_matches(&f1, &f2, &[(0, 0)], &h, None).unwrap()
        );
    }
}
