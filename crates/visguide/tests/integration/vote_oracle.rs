//! The weighted mode of a frame's tip votes against its definition counted out naively: the
//! vote of largest kernel support (ties to the lower index), the weighted mean of the votes
//! within 3σ of it, the support count, and the certainty as the regions' heaviest agreeing votes
//! over the regions' heaviest votes. Random votes from a fixed seed, on a coarse lattice so that
//! positions coincide and supports tie, with zero weights, one region voting many times, and
//! single votes.

use visguide::pipeline::{Vote, mode};

use crate::common::cases;
use cases::Rng;

#[test]
fn mode_agrees_with_its_definition_counted_out() {
    let mut rng = Rng::seeded(0x0017_E503);
    let mut found = 0;
    for case in 0..400 {
        let n = 1 + rng.below(12) as usize;
        let sigma = [0.5, 2.0, 6.0][rng.below(3) as usize];
        let votes: Vec<Vote> = (0..n)
            .map(|_| Vote {
                position: [
                    100.0 + 2.0 * rng.below(8) as f64,
                    50.0 + 3.0 * rng.below(5) as f64,
                ],
                weight: [0.0, 0.25, 0.5, 1.0][rng.below(4) as usize],
                error: 0.1,
                rotation: 0.0,
                region: rng.below(4) as usize,
            })
            .collect();
        let got = mode(&votes, sigma).unwrap();
        let total: f64 = votes.iter().map(|v| v.weight).sum();
        if total == 0.0 {
            assert!(got.is_none(), "case {case}");
            continue;
        }
        let got = got.unwrap_or_else(|| panic!("case {case}: no mode"));
        let d2 = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2);
        let support: Vec<f64> = votes
            .iter()
            .map(|a| {
                votes
                    .iter()
                    .map(|b| b.weight * (-d2(a.position, b.position) / (2.0 * sigma * sigma)).exp())
                    .sum()
            })
            .collect();
        let best = support.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        // The expected mode around a centre: the weighted mean and count of the votes within
        // 3σ, and per region its heaviest vote within 3σ over its heaviest vote.
        let expect = |centre: [f64; 2]| -> ([f64; 2], usize, f64) {
            let near: Vec<&Vote> = votes
                .iter()
                .filter(|v| d2(v.position, centre) <= 9.0 * sigma * sigma)
                .collect();
            let w: f64 = near.iter().map(|v| v.weight).sum();
            let position = [
                near.iter().map(|v| v.weight * v.position[0]).sum::<f64>() / w,
                near.iter().map(|v| v.weight * v.position[1]).sum::<f64>() / w,
            ];
            let (mut agrees, mut evidence) = (0.0, 0.0);
            for region in 0..4 {
                let heaviest = |vs: &[&Vote]| {
                    vs.iter()
                        .filter(|v| v.region == region)
                        .map(|v| v.weight)
                        .fold(0.0, f64::max)
                };
                evidence += heaviest(&votes.iter().collect::<Vec<_>>());
                agrees += heaviest(&near);
            }
            (position, near.len(), agrees / evidence)
        };
        // The first vote of largest support; votes whose supports differ from it only in the
        // last bits (a symmetric configuration summed in another order) may take its place.
        let first = support.iter().position(|&s| s == best).unwrap();
        let candidates: Vec<usize> = (0..n)
            .filter(|&i| i == first || (i < first && support[i] >= best * (1.0 - 1e-12)))
            .collect();
        let matches = |(position, count, certainty): ([f64; 2], usize, f64)| {
            got.support == count
                && (got.position[0] - position[0]).abs() < 1e-9
                && (got.position[1] - position[1]).abs() < 1e-9
                && (got.certainty - certainty).abs() < 1e-12
        };
        assert!(
            candidates
                .iter()
                .any(|&i| matches(expect(votes[i].position))),
            "case {case}: {got:?} vs {:?} (σ {sigma}, votes {votes:?})",
            candidates
                .iter()
                .map(|&i| expect(votes[i].position))
                .collect::<Vec<_>>()
        );
        assert!((0.0..=1.0).contains(&got.certainty));
        found += 1;
    }
    assert!(found > 300, "{found} cases with a mode");
}
