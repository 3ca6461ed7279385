//! Choosing each camera's tip among its candidates by consistency between the cameras.
//!
//! One image can offer more than one plausible tip: the silhouette recogniser's configured rule
//! gives one (for [`TipRule::Learned`](crate::TipRule::Learned), the far end corrected by an
//! offset learned at other poses), and the outline of the far end gives the middle of the end
//! face (the `EndFace` tip) where it shows one. They fail in different ways: the learned
//! correction is off by pixels at poses unlike the ones it was learned from; the end face
//! jumps where outline pixels come and go. A wrong tip in one camera is, unless its error lies
//! along the epipolar line, inconsistent with the other camera's tip, so the two views vote.
//!
//! **The choice.** Camera `c` offers candidates `p_{c,0}, p_{c,1}, …` in order of preference
//! (`p_{c,0}` the configured rule's tip). With the learned geometry of camera 0 with camera
//! `k` ([`EpipolarGeometry`], Sampson distance `d_k`, consistency scale `s_k`), every
//! candidate `i` of camera 0 is scored by
//! `E(i) = Σ_k min_j (d_k(p_{0,i}, p_{k,j}) / s_k)²`, the chosen `i*` minimises `E` and every
//! camera `k` takes its `j` that attains the minimum for `i*` (the joint minimum over all
//! combinations, since the terms of different cameras share only camera 0's candidate). Ties go
//! to the earlier candidate (strict comparisons), so with equally consistent candidates the
//! configured rule's tip is kept, and the choice is deterministic. The chosen pair's
//! consistency `exp(−½ (d/s)²)` then caps each camera's certainty, as for a single candidate:
//! when no candidate pair is consistent, the percept stays doubted and a
//! [`PerceptPolicy`](crate::PerceptPolicy) re-captures and then refuses it
//! ([`ServoError::PerceptRefused`], counted by the plant).
//!
//! **An opt-in** ([`SilhouetteConfig::cross_camera_choice`](crate::SilhouetteConfig::cross_camera_choice)).
//! On `arm-sim`'s development seeds 1001–1005 it lowered the 90th percentile of the accepted
//! percepts' error on every arm, but the servo on the default arm and the second rig ended
//! further from the target (`docs/methods.md`, *Cross-camera choice*), so the learned
//! recogniser does not choose by default. The measured cause: the choice is a hard switch that
//! sensor noise flips. At one pose, two captures differing only in noise chose different
//! candidates in 16–27 % of the pairs (development seeds, three arms), and where a camera
//! flipped its percept's error changed by a median 0.31–0.45 px (90th percentile 1.7–2.3 px)
//! against 0.05–0.11 px where it did not; the servo ends where the percept matches the
//! target's, so such a flip between the target's capture and the last one is the final error.
//! The learned tip's gate ([`SilhouetteConfig::face_gate`](crate::SilhouetteConfig::face_gate))
//! takes the end face where the correction is unsure, continuously, without a switch (also an
//! opt-in: docs/methods.md, *Gated learned tip*).
//!
//! **What it cannot catch.** A wrong tip whose error lies along the other view's epipolar line
//! is as consistent as the right one; the tie then keeps the configured rule's tip.
//! Candidates from other parts of the silhouette (the wrong end of the chain, a clutter blob)
//! are not generated: such gross errors stay inconsistent and are refused.

use crate::error::{Result, ServoError};
use crate::recognition::epipolar::EpipolarGeometry;

/// The candidate chosen in every camera (index into that camera's candidates), and the
/// consistency of every camera `k ≥ 1` with camera 0 at the chosen pair (entry `k − 1`).
#[derive(Debug, Clone, PartialEq)]
pub struct PairChoice {
    /// Per camera, the index of the chosen candidate.
    pub chosen: Vec<usize>,
    /// Per camera `k ≥ 1`, the consistency of its chosen tip with camera 0's (in `[0, 1]`).
    pub consistency: Vec<f64>,
}

/// Chooses every camera's tip among its `candidates` (per camera, in order of preference) by
/// the cross-camera consistency of `geometries` (camera 0 with camera `k`, entry `k − 1`; see
/// the module docs). Cameras beyond the geometries keep their first candidate. Errors: a
/// camera without candidates; non-finite candidates are never preferred (their distance is
/// infinite).
pub fn choose_consistent(
    candidates: &[Vec<[f64; 2]>],
    geometries: &[EpipolarGeometry],
) -> Result<PairChoice> {
    if candidates.is_empty() {
        return Err(ServoError::InvalidParameter {
            name: "candidates",
            reason: "no camera offers a tip candidate".into(),
        });
    }
    if let Some(cam) = candidates.iter().position(Vec::is_empty) {
        return Err(ServoError::InvalidParameter {
            name: "candidates",
            reason: format!("camera {cam} offers no tip candidate"),
        });
    }
    let pairs = geometries.len().min(candidates.len().saturating_sub(1));
    // Normalised squared distance, infinite for non-finite points or distances.
    let cost = |g: &EpipolarGeometry, a: [f64; 2], b: [f64; 2]| {
        let d = g.distance(a, b) / g.scale();
        if d.is_finite() { d * d } else { f64::INFINITY }
    };
    // For camera 0's candidate `i`: the best candidate of every other camera and the total.
    let best_others = |a: [f64; 2]| -> (f64, Vec<usize>) {
        let mut total = 0.0;
        let mut picks = Vec::with_capacity(pairs);
        for (k, g) in geometries.iter().take(pairs).enumerate() {
            let mut best = (f64::INFINITY, 0);
            for (j, &b) in candidates[k + 1].iter().enumerate() {
                let c = cost(g, a, b);
                if c < best.0 {
                    best = (c, j);
                }
            }
            total += best.0;
            picks.push(best.1);
        }
        (total, picks)
    };
    let mut choice: Option<(f64, usize, Vec<usize>)> = None;
    for (i, &a) in candidates[0].iter().enumerate() {
        let (total, picks) = best_others(a);
        if choice.as_ref().is_none_or(|(t, _, _)| total < *t) {
            choice = Some((total, i, picks));
        }
    }
    let (_, i, picks) = choice.expect("camera 0 has a candidate");
    let mut chosen = vec![0; candidates.len()];
    chosen[0] = i;
    for (k, j) in picks.into_iter().enumerate() {
        chosen[k + 1] = j;
    }
    let consistency = geometries
        .iter()
        .take(pairs)
        .enumerate()
        .map(|(k, g)| g.consistency(candidates[0][i], candidates[k + 1][chosen[k + 1]]))
        .collect();
    Ok(PairChoice {
        chosen,
        consistency,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::recognition::epipolar::tests::scene;
    use nalgebra::Vector3;

    /// `q` moved `by` pixels across the epipolar line of `p` (in the second view).
    fn across(g: &EpipolarGeometry, p: [f64; 2], q: [f64; 2], by: f64) -> [f64; 2] {
        let line = g.matrix() * Vector3::new(p[0], p[1], 1.0);
        let len = line[0].hypot(line[1]);
        [q[0] + by * line[0] / len, q[1] + by * line[1] / len]
    }

    #[test]
    fn the_consistent_candidate_wins_over_the_preferred_wrong_one() {
        let (a, b) = scene(200, 1);
        let (g, _) = EpipolarGeometry::fit(&a, &b, 7).unwrap();
        let (na, nb) = scene(10, 42);
        for (p, q) in na.iter().zip(&nb) {
            // Camera 1's preferred tip is 12 px off the epipolar line, its second is right;
            // camera 0's preferred tip is right, its second is 15 px off (in camera 0: moved
            // so that it lies off every line through camera 1's candidates).
            let wrong1 = across(&g, *p, *q, 12.0);
            let wrong0 = [p[0] + 15.0, p[1] - 11.0];
            let c = choose_consistent(
                &[vec![*p, wrong0], vec![wrong1, *q]],
                std::slice::from_ref(&g),
            )
            .unwrap();
            assert_eq!(c.chosen, vec![0, 1]);
            assert!(c.consistency[0] > 0.99, "{c:?}");
            // The single-camera preference alone would have been inconsistent.
            assert!(g.consistency(*p, wrong1) < 1e-6);
        }
    }

    #[test]
    fn ties_keep_the_preferred_candidate_and_nothing_consistent_stays_doubted() {
        let (a, b) = scene(200, 2);
        let (g, _) = EpipolarGeometry::fit(&a, &b, 3).unwrap();
        let (na, nb) = scene(5, 77);
        for (p, q) in na.iter().zip(&nb) {
            // Two identical right candidates: the first is kept.
            let c = choose_consistent(&[vec![*p], vec![*q, *q]], std::slice::from_ref(&g)).unwrap();
            assert_eq!(c.chosen, vec![0, 0]);
            // Every candidate of camera 1 far off the line: the least inconsistent one (the
            // smaller Sampson distance) is chosen, and its consistency stays below any sensible
            // threshold.
            let far = [across(&g, *p, *q, 30.0), across(&g, *p, *q, -20.0)];
            let c = choose_consistent(&[vec![*p], far.to_vec()], std::slice::from_ref(&g)).unwrap();
            let nearer = usize::from(g.distance(*p, far[1]) < g.distance(*p, far[0]));
            assert_eq!(c.chosen, vec![0, nearer]);
            assert!(c.consistency[0] < 1e-6, "{c:?}");
            // A non-finite candidate is never chosen.
            let c = choose_consistent(
                &[vec![*p], vec![[f64::NAN, 0.0], *q]],
                std::slice::from_ref(&g),
            )
            .unwrap();
            assert_eq!(c.chosen, vec![0, 1]);
        }
    }

    #[test]
    fn three_cameras_choose_jointly_and_bad_input_is_typed() {
        // Camera 2 sees the same scene as camera 1 (a copy of the geometry).
        let (a, b) = scene(200, 3);
        let (g, _) = EpipolarGeometry::fit(&a, &b, 5).unwrap();
        let (na, nb) = scene(3, 9);
        for (p, q) in na.iter().zip(&nb) {
            // Camera 0's first candidate is wrong for both other cameras.
            let wrong0 = [p[0] - 14.0, p[1] + 9.0];
            let candidates = [
                vec![wrong0, *p],
                vec![across(&g, *p, *q, 9.0), *q],
                vec![*q, across(&g, *p, *q, -9.0)],
            ];
            let geometries = [g.clone(), g.clone()];
            let c = choose_consistent(&candidates, &geometries).unwrap();
            assert_eq!(c.chosen, vec![1, 1, 0]);
            // Deterministic: the same input gives the same choice.
            assert_eq!(choose_consistent(&candidates, &geometries).unwrap(), c);
        }
        assert!(matches!(
            choose_consistent(&[vec![[1.0, 2.0]], vec![]], &[g]),
            Err(ServoError::InvalidParameter {
                name: "candidates",
                ..
            })
        ));
        assert!(matches!(
            choose_consistent(&[], &[]),
            Err(ServoError::InvalidParameter {
                name: "candidates",
                ..
            })
        ));
        // No geometry: every camera keeps its first candidate.
        let c = choose_consistent(&[vec![[1.0, 2.0], [3.0, 4.0]], vec![[5.0, 6.0]]], &[]).unwrap();
        assert_eq!((c.chosen, c.consistency), (vec![0, 0], vec![]));
    }
}
