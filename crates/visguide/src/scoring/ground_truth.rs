//! Ground truth of one image pair in descriptor mode (docs/methods.md § Overlap error, steps 5–6):
//! every pair of regions (A in img1, B in imgN mapped into img1 with H⁻¹) whose overlap error ε(A,
//! B) < 50% after the ×3 magnification is a *correct* match; the greedy one-to-one assignment over
//! those pairs (smallest ε first) gives the number of *existing matches*, the recall denominator.

use rayon::prelude::*;

use super::overlap::{
    DESCRIPTOR_THRESHOLD, Ellipse, Normalisation, Offset, map_linearised, may_overlap,
    overlap_error, radius,
};
use crate::geometry::Homography;

/// The ground truth of one image pair.
#[derive(Debug, Clone, PartialEq)]
pub struct PairTruth {
    /// Every pair `(i, j)` (region i of img1, region j of imgN) with ε < 50%, ascending.
    pub correct: Vec<(u32, u32)>,
    /// The greedy one-to-one correspondences among them, in the order chosen (smallest ε first).
    pub one_to_one: Vec<(u32, u32)>,
}

impl PairTruth {
    /// Whether `(i, j)` is a correct match (full pairwise criterion, not the one-to-one set).
    pub fn is_correct(&self, i: u32, j: u32) -> bool {
        self.correct.binary_search(&(i, j)).is_ok()
    }

    /// The number of existing matches (one-to-one correspondences).
    pub fn existing(&self) -> usize {
        self.one_to_one.len()
    }
}

/// Computes the ground truth of regions `e1` (img1) and `e2` (imgN), with `h` mapping img1 to
/// imgN. Regions of imgN whose centre maps to infinity take no part.
pub fn pair_truth(e1: &[Ellipse], e2: &[Ellipse], h: &Homography) -> PairTruth {
    let h_inv = h.inverse();
    // imgN regions in img1's frame, sorted by x for the distance gate.
    let mut mapped: Vec<(u32, Ellipse)> = e2
        .iter()
        .enumerate()
        // A region index beyond `u32` would need more than 2^32 ellipses in memory (160 GiB).
        .filter_map(|(j, e)| map_linearised(e, &h_inv).map(|m| (j as u32, m)))
        .collect();
    mapped.sort_by(|p, q| p.1.u.total_cmp(&q.1.u).then(p.0.cmp(&q.0)));
    let xs: Vec<f64> = mapped.iter().map(|p| p.1.u).collect();
    let scored: Vec<(f64, u32, u32)> = e1
        .par_iter()
        .enumerate()
        .flat_map_iter(|(i, a)| {
            let reach = 4.0 * radius(a);
            let lo = xs.partition_point(|&x| x <= a.u - reach);
            let hi = xs.partition_point(|&x| x < a.u + reach);
            // `lo > hi` only when `a.u ± reach` both round to `a.u` (a region so small against
            // its position that `reach` is below half an ulp of `u`, e.g. `a = c = 1e40`): the
            // open window is then empty in floating point, but the regions at exactly that `x`
            // lie within reach: the `lo − hi` regions between the two indices (the slice used
            // to be inverted, a panic).
            let (lo, hi) = (lo.min(hi), lo.max(hi));
            let mut out = Vec::new();
            for (j, b) in &mapped[lo..hi] {
                if !may_overlap(a, b, DESCRIPTOR_THRESHOLD) {
                    continue;
                }
                let eps = overlap_error(a, b, Normalisation::Descriptor, Offset::Faithful);
                if eps < DESCRIPTOR_THRESHOLD {
                    // `i < e1.len()`, as `j` above: within `u32` for any frames in memory.
                    out.push((eps, i as u32, *j));
                }
            }
            out.into_iter()
        })
        .collect();
    let mut correct: Vec<(u32, u32)> = scored.iter().map(|&(_, i, j)| (i, j)).collect();
    correct.sort_unstable();
    PairTruth {
        correct,
        one_to_one: greedy_one_to_one(scored),
    }
}

/// Greedy one-to-one assignment (docs/methods.md § Overlap error, step 5): repeatedly take the
/// smallest remaining ε (ties by indices, for determinism), record the pair and remove its row and
/// column.
pub fn greedy_one_to_one(mut scored: Vec<(f64, u32, u32)>) -> Vec<(u32, u32)> {
    scored.sort_by(|p, q| p.0.total_cmp(&q.0).then(p.1.cmp(&q.1)).then(p.2.cmp(&q.2)));
    let rows = scored.iter().map(|s| s.1 as usize + 1).max().unwrap_or(0);
    let cols = scored.iter().map(|s| s.2 as usize + 1).max().unwrap_or(0);
    let (mut row_used, mut col_used) = (vec![false; rows], vec![false; cols]);
    let mut out = Vec::new();
    for (_, i, j) in scored {
        if !row_used[i as usize] && !col_used[j as usize] {
            row_used[i as usize] = true;
            col_used[j as usize] = true;
            out.push((i, j));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scoring::overlap::tests::{circ, ellipse};

    fn identity() -> Homography {
        Homography::from_row_major(&[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]).unwrap()
    }

    #[test]
    fn greedy_takes_the_globally_best_pair_first() {
        // Row 0 prefers column 0 (0.1), but row 1 has the best pair (1, 0) at 0.05, so row 0
        // gets column 1.
        let pairs = vec![(0.1, 0, 0), (0.05, 1, 0), (0.3, 0, 1), (0.2, 1, 1)];
        assert_eq!(greedy_one_to_one(pairs), vec![(1, 0), (0, 1)]);
        assert!(greedy_one_to_one(Vec::new()).is_empty());
    }

    #[test]
    fn nested_twins_are_all_correct_but_count_once() {
        // One blob seen at two grey levels in each image: four correct pairs, two existing.
        let e1 = [circ(50.0, 50.0, 10.0), circ(50.0, 50.0, 11.0)];
        let e2 = [circ(51.0, 50.0, 10.0), circ(50.0, 51.0, 11.0)];
        let t = pair_truth(&e1, &e2, &identity());
        assert_eq!(t.correct, vec![(0, 0), (0, 1), (1, 0), (1, 1)]);
        assert_eq!(t.existing(), 2);
        assert!(t.is_correct(1, 0) && !t.is_correct(2, 0));
    }

    #[test]
    fn matches_brute_force_under_a_homography() {
        let h = Homography::from_row_major(&[0.9, 0.2, 10.0, -0.15, 1.1, 4.0, 1e-4, -5e-5, 1.0])
            .unwrap();
        // A deterministic scatter of ellipses, and their images under h with small errors.
        let mut e1 = Vec::new();
        let mut e2 = Vec::new();
        for k in 0..60u32 {
            let (x, y) = ((k * 37 % 300) as f64 + 20.0, (k * 53 % 200) as f64 + 20.0);
            let r = 3.0 + (k % 7) as f64;
            let e = ellipse(x, y, 1.0 / (r * r), 0.01 / (r * r), 0.8 / (r * r)).unwrap();
            e1.push(e);
            if k % 3 != 0 {
                let mut m = map_linearised(&e, &h).unwrap();
                m.u += (k % 5) as f64 * 0.7;
                e2.push(m);
            }
        }
        let t = pair_truth(&e1, &e2, &h);
        let hi = h.inverse();
        let mut brute = Vec::new();
        for (i, a) in e1.iter().enumerate() {
            for (j, b) in e2.iter().enumerate() {
                let b1 = map_linearised(b, &hi).unwrap();
                let eps = overlap_error(a, &b1, Normalisation::Descriptor, Offset::Faithful);
                if eps < 0.5 {
                    brute.push((i as u32, j as u32));
                }
            }
        }
        brute.sort_unstable();
        assert_eq!(t.correct, brute);
        assert!(t.existing() >= 35 && t.existing() <= 40, "{}", t.existing());
    }

    /// A region of img1 so small that `u ± 4 r` rounds to `u` (a valid, finite, positive
    /// definite ellipse) next to a region of imgN at that very `x`: the distance gate's window
    /// used to be inverted there (a slice index panic). The result is the brute-force one.
    #[test]
    fn a_point_sized_region_beside_one_at_its_x() {
        let tiny = ellipse(100.0, 100.0, 1e40, 0.0, 1e40).unwrap();
        let e1 = [tiny, circ(100.0, 100.0, 5.0)];
        let e2 = [circ(100.0, 100.0, 5.0), tiny, circ(100.0, 101.0, 5.0)];
        let t = pair_truth(&e1, &e2, &identity());
        let mut brute = Vec::new();
        for (i, a) in e1.iter().enumerate() {
            for (j, b) in e2.iter().enumerate() {
                if may_overlap(a, b, DESCRIPTOR_THRESHOLD)
                    && overlap_error(a, b, Normalisation::Descriptor, Offset::Faithful) < 0.5
                {
                    brute.push((i as u32, j as u32));
                }
            }
        }
        assert_eq!(t.correct, brute);
        assert!(t.correct.contains(&(1, 0)));
    }
}
