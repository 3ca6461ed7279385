//! Precision–recall by sweeping the ratio threshold `T_r` (Paper A §5): a symmetric match with
//! error ratio `e_r` is reported when `e_r < T_r` (eq. 19, `fd_match::Match::accepted`);
//! precision = correct / reported, recall = correct / existing matches.
//!
//! Summary numbers, all computed from the exact (every distinct ratio) curve:
//! - **AUC**: `Σ precision · Δrecall` over the thresholds in ascending order (the step integral
//!   of the curve over the recall range it reaches; a method that reaches low recall has a
//!   small AUC even at high precision).
//! - **precision at recall R**: at the smallest threshold whose recall is at least R; absent
//!   when the curve never reaches R.
//! - the point at `T_r = 0.5`, Paper A's operating point.

use serde::Serialize;

/// One reported match: its ratio and whether ground truth calls it correct.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scored {
    /// `e_r` of the symmetric match.
    pub ratio: f64,
    /// Ground-truth verdict.
    pub correct: bool,
}

/// One point of a curve.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PrPoint {
    /// The ratio threshold `T_r` (matches with `e_r < T_r` are reported).
    pub t_r: f64,
    /// Reported matches.
    pub matches: usize,
    /// Correct among them.
    pub correct: usize,
    /// correct / matches (absent without matches).
    pub precision: Option<f64>,
    /// correct / existing (absent when nothing exists).
    pub recall: Option<f64>,
}

/// The recall levels of the summary tables.
pub const RECALL_LEVELS: [f64; 3] = [0.1, 0.2, 0.3];

/// Paper A's ratio threshold.
pub const PAPER_T_R: f64 = 0.5;

/// Summary of one curve.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PrSummary {
    /// Step-integral area under the precision–recall curve.
    pub auc: f64,
    /// Precision at recall 0.1, 0.2, 0.3.
    pub precision_at_recall: [Option<f64>; 3],
    /// The point at `T_r = 0.5`.
    pub at_paper_threshold: PrPoint,
    /// The largest recall reached (all mutual matches reported).
    pub max_recall: Option<f64>,
}

/// A precision–recall curve sampled on the `T_r` grid 0.01, 0.02, …, 1.00 (only the grid points
/// where the counts change, and 1.00), with its summary.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PrCurve {
    /// Existing matches (recall denominator).
    pub existing: usize,
    /// Mutual matches at any threshold.
    pub candidates: usize,
    /// Summary numbers.
    pub summary: PrSummary,
    /// Points on the threshold grid.
    pub points: Vec<PrPoint>,
}

/// Number of grid steps on `T_r ∈ (0, 1]`.
pub const GRID_STEPS: usize = 100;

fn point(t_r: f64, matches: usize, correct: usize, existing: usize) -> PrPoint {
    PrPoint {
        t_r,
        matches,
        correct,
        precision: (matches > 0).then(|| correct as f64 / matches as f64),
        recall: (existing > 0).then(|| correct as f64 / existing as f64),
    }
}

/// Counts of matches with ratio < `t`, from ratios sorted ascending with cumulative correct
/// counts.
fn counts_below(sorted: &[Scored], cum_correct: &[usize], t: f64) -> (usize, usize) {
    let n = sorted.partition_point(|s| s.ratio < t);
    (n, if n == 0 { 0 } else { cum_correct[n - 1] })
}

/// Sweeps `T_r` over `scored` (matches of one or several image pairs) with `existing`
/// ground-truth correspondences.
pub fn sweep(scored: &[Scored], existing: usize) -> PrCurve {
    let mut sorted: Vec<Scored> = scored.to_vec();
    sorted.sort_by(|a, b| a.ratio.total_cmp(&b.ratio));
    let cum: Vec<usize> = sorted
        .iter()
        .scan(0, |c, s| {
            *c += s.correct as usize;
            Some(*c)
        })
        .collect();
    // Grid points where the counts change (and the last), so flat stretches cost nothing.
    let mut points: Vec<PrPoint> = Vec::new();
    for k in 1..=GRID_STEPS {
        let t = k as f64 / GRID_STEPS as f64;
        let (m, c) = counts_below(&sorted, &cum, t);
        let same = points
            .last()
            .is_some_and(|p| (p.matches, p.correct) == (m, c));
        if !same || k == GRID_STEPS {
            points.push(point(t, m, c, existing));
        }
    }
    // Exact curve: one step per group of equal ratios.
    let mut auc = 0.0;
    let mut at_recall = [None; 3];
    let mut prev_recall = 0.0;
    let mut i = 0;
    while i < sorted.len() {
        let mut j = i + 1;
        while j < sorted.len() && sorted[j].ratio == sorted[i].ratio {
            j += 1;
        }
        if existing > 0 {
            let precision = cum[j - 1] as f64 / j as f64;
            let recall = cum[j - 1] as f64 / existing as f64;
            auc += precision * (recall - prev_recall);
            prev_recall = recall;
            for (slot, level) in at_recall.iter_mut().zip(RECALL_LEVELS) {
                if slot.is_none() && recall >= level {
                    *slot = Some(precision);
                }
            }
        }
        i = j;
    }
    let (m, c) = counts_below(&sorted, &cum, PAPER_T_R);
    let all = point(
        f64::INFINITY,
        sorted.len(),
        cum.last().copied().unwrap_or(0),
        existing,
    );
    PrCurve {
        existing,
        candidates: sorted.len(),
        summary: PrSummary {
            auc,
            precision_at_recall: at_recall,
            at_paper_threshold: point(PAPER_T_R, m, c, existing),
            max_recall: all.recall,
        },
        points,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn s(ratio: f64, correct: bool) -> Scored {
        Scored { ratio, correct }
    }

    #[test]
    fn hand_computed_curve() {
        // Sorted: 0.1 ✓, 0.2 ✓, 0.3 ✗, 0.45 ✓, 0.5 ✗ (not < 0.5), 0.9 ✗; 10 existing.
        let m = [
            s(0.3, false),
            s(0.1, true),
            s(0.9, false),
            s(0.2, true),
            s(0.45, true),
            s(0.5, false),
        ];
        let c = sweep(&m, 10);
        assert_eq!((c.existing, c.candidates), (10, 6));
        let half = c.summary.at_paper_threshold;
        assert_eq!((half.matches, half.correct), (4, 3));
        assert_eq!(half.precision, Some(0.75));
        assert_eq!(half.recall, Some(0.3));
        // AUC = 1·0.1 + 1·0.1 + (3/4)·0.1
        assert!((c.summary.auc - 0.275).abs() < 1e-12);
        assert_eq!(
            c.summary.precision_at_recall,
            [Some(1.0), Some(1.0), Some(0.75)]
        );
        assert_eq!(c.summary.max_recall, Some(0.3));
        // Counts change at 0.11, 0.21, 0.31, 0.46, 0.51, 0.91; plus the last point 1.00.
        let t: Vec<f64> = c.points.iter().map(|p| p.t_r).collect();
        assert_eq!(t, vec![0.01, 0.11, 0.21, 0.31, 0.46, 0.51, 0.91, 1.0]);
        let m: Vec<usize> = c.points.iter().map(|p| p.matches).collect();
        assert_eq!(m, vec![0, 1, 2, 3, 4, 5, 6, 6]);
    }

    #[test]
    fn ties_form_one_step_and_empty_inputs_have_no_precision() {
        let c = sweep(&[s(0.2, true), s(0.2, false)], 4);
        assert!((c.summary.auc - 0.5 * 0.25).abs() < 1e-12);
        assert_eq!(c.summary.precision_at_recall, [Some(0.5), Some(0.5), None]);
        let e = sweep(&[], 0);
        assert_eq!(e.summary.auc, 0.0);
        assert_eq!(e.summary.at_paper_threshold.precision, None);
        assert_eq!(e.summary.max_recall, None);
    }
}
