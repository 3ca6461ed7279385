//! The study of one sequence: detect regions in every image, describe their contours with both
//! samplings, compute each pair's ground truth, match with every combination (with and
//! without preselection) and sweep the ratio threshold.

use fd_match::{DescriptorSet, Sampling};
use mser::MserParams;
use serde::Serialize;

use visguide::matching::{describe, match_regions, preselected};
use visguide::parallel;
use visguide::scoring::{PAPER_T_R, PairTruth, PrCurve, Scored, pair_truth, sweep};
use visguide::{Combination, Features};

use super::progress::Progress;
use super::sequence::{Protocol, Sequence};

/// What to evaluate.
#[derive(Debug, Clone)]
pub struct Plan {
    /// Detector setting.
    pub mser: MserParams,
    /// Combinations matched without preselection.
    pub combinations: Vec<Combination>,
    /// Combinations matched with preselection (each with its paper threshold).
    pub preselected: Vec<Combination>,
}

impl Plan {
    /// The paper's study: all eight combinations, the four preselected ones.
    pub fn paper(mser: MserParams) -> Self {
        Plan {
            mser,
            combinations: Combination::ALL.to_vec(),
            preselected: Combination::PRESELECTED.to_vec(),
        }
    }
}

/// Per-image counts.
#[derive(Debug, Clone, Serialize)]
pub struct ImageStats {
    /// 1-based image number.
    pub image: usize,
    /// Width and height.
    pub size: (u32, u32),
    /// MSER regions.
    pub regions: usize,
    /// Contours described with affine-arc-length sampling (the rest are degenerate); absent when
    /// not planned.
    pub described_affine: Option<usize>,
    /// Contours described with canonical sampling.
    pub described_canonical: Option<usize>,
}

/// Per-pair counts.
#[derive(Debug, Clone, Serialize)]
pub struct PairStats {
    /// The other image (img1 against imgK).
    pub image: usize,
    /// One-to-one correspondences (existing matches).
    pub existing: usize,
    /// All region pairs with overlap error below 50 % (correct matches possible).
    pub correct_pairs: usize,
}

/// One matched pair, as the pictures show it: region indices and the verdict.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShownMatch {
    /// Region of img1.
    pub i: usize,
    /// Region of imgK.
    pub j: usize,
    /// Ground truth says correct.
    pub correct: bool,
}

/// Everything about one pair.
#[derive(Debug, Clone)]
pub struct PairResult {
    /// Counts.
    pub stats: PairStats,
    /// Scored matches per plan combination.
    pub scored: Vec<Vec<Scored>>,
    /// Scored matches per preselected combination.
    pub scored_preselected: Vec<Vec<Scored>>,
    /// [`Combination::SHOWN`]'s accepted matches at `T_r = 0.5` (empty if it is not planned).
    pub shown: Vec<ShownMatch>,
}

/// A curve of one combination.
#[derive(Debug, Clone, Serialize)]
pub struct CombinationCurve {
    /// Legend label.
    pub combination: String,
    /// Preselection threshold, if preselected.
    pub t_err: Option<f64>,
    /// The curve.
    pub curve: PrCurve,
}

/// One figure's worth of results: one or several pairs pooled.
#[derive(Debug, Clone, Serialize)]
pub struct Group {
    /// E.g. `img1 vs img2..6` or `img1 vs img2`.
    pub label: String,
    /// The other images pooled.
    pub images: Vec<usize>,
    /// Existing matches (summed).
    pub existing: usize,
    /// Paper A's count of existing matches for this group, if it reports one.
    pub paper_existing: Option<usize>,
    /// Figures 4–6 style curves.
    pub curves: Vec<CombinationCurve>,
    /// Figures 7–9 style curves (precision against number of matches).
    pub preselection: Vec<CombinationCurve>,
}

/// The study of one sequence.
#[derive(Debug, Clone)]
pub struct SequenceResult {
    /// Per image.
    pub images: Vec<ImageStats>,
    /// Per pair.
    pub pairs: Vec<PairResult>,
    /// Per figure.
    pub groups: Vec<Group>,
    /// Regions of every image (for the pictures).
    pub features: Vec<Features>,
}

const SAMPLINGS: [Sampling; 2] = [Sampling::AffineArcLength, Sampling::Canonical];

fn sampling_index(s: Sampling) -> usize {
    SAMPLINGS
        .iter()
        .position(|&t| t == s)
        .expect("planned sampling")
}

/// Paper A's existing-match counts: Leuven 197 (img1 vs 2..6), Boat 399 (cumulative), Graf 80
/// (img1 vs img2).
pub fn paper_existing(sequence: &str, images: &[usize]) -> Option<usize> {
    match (sequence, images) {
        ("leuven", [2, 3, 4, 5, 6]) => Some(197),
        ("boat", [2, 3, 4, 5, 6]) => Some(399),
        ("graf", [2]) => Some(80),
        _ => None,
    }
}

/// Scores symmetric matches (set indices) against the ground truth (region indices).
fn score(
    a: &DescriptorSet,
    b: &DescriptorSet,
    combination: Combination,
    truth: &PairTruth,
) -> crate::Result<(Vec<Scored>, Vec<ShownMatch>)> {
    let matches = match_regions(a, b, combination.method)?;
    let mut scored = Vec::with_capacity(matches.len());
    let mut shown = Vec::new();
    for m in &matches {
        let (i, j) = (m.i, m.j);
        let correct = truth.is_correct(i as u32, j as u32);
        scored.push(Scored {
            ratio: m.ratio,
            correct,
        });
        if m.ratio < PAPER_T_R {
            shown.push(ShownMatch { i, j, correct });
        }
    }
    Ok((scored, shown))
}

/// Runs the plan on a sequence.
pub fn evaluate(seq: &Sequence, plan: &Plan, progress: &Progress) -> crate::Result<SequenceResult> {
    let n_img = seq.images.len();
    let bar = progress.bar(n_img as u64, &format!("{}: regions", seq.name));
    let features: Vec<Features> = parallel::try_map(&seq.images, |img| {
        let f = visguide::detect(img, &plan.mser);
        bar.inc(1);
        f
    })?;
    bar.finish_and_clear();

    let needed: Vec<bool> = SAMPLINGS
        .iter()
        .map(|&s| {
            plan.combinations
                .iter()
                .chain(&plan.preselected)
                .any(|c| c.sampling == s)
        })
        .collect();
    let n_needed = needed.iter().filter(|&&n| n).count();
    let bar = progress.bar(
        (n_img * n_needed) as u64,
        &format!("{}: descriptors", seq.name),
    );
    let mut sets: Vec<Vec<Option<DescriptorSet>>> = Vec::with_capacity(n_img);
    for f in &features {
        let mut per = Vec::with_capacity(2);
        for (s, &need) in SAMPLINGS.iter().zip(&needed) {
            per.push(if need {
                bar.inc(1);
                Some(describe(f, *s)?)
            } else {
                None
            });
        }
        sets.push(per);
    }
    bar.finish_and_clear();
    let set_of = |img: usize, s: Sampling| -> &DescriptorSet {
        sets[img][sampling_index(s)]
            .as_ref()
            .expect("described: the plan needs it")
    };

    // Preselected sets per image and preselected combination.
    let bar = progress.bar(
        (n_img * plan.preselected.len()) as u64,
        &format!("{}: preselection", seq.name),
    );
    let mut reduced: Vec<Vec<DescriptorSet>> = Vec::with_capacity(n_img);
    for img in 0..n_img {
        let mut per = Vec::new();
        for c in &plan.preselected {
            let set = set_of(img, c.sampling);
            let t_err = c
                .preselection_threshold()
                .ok_or("combination without T_err")?;
            per.push(preselected(set, c.method, t_err)?);
            bar.inc(1);
        }
        reduced.push(per);
    }
    bar.finish_and_clear();

    let images = seq
        .images
        .iter()
        .zip(&features)
        .zip(&sets)
        .enumerate()
        .map(|(k, ((img, f), s))| ImageStats {
            image: k + 1,
            size: img.dimensions(),
            regions: f.len(),
            described_affine: s[0].as_ref().map(DescriptorSet::len),
            described_canonical: s[1].as_ref().map(DescriptorSet::len),
        })
        .collect();

    let steps =
        (seq.pairs().count() * (1 + plan.combinations.len() + plan.preselected.len())) as u64;
    let bar = progress.bar(steps, &format!("{}: ground truth and matching", seq.name));
    let mut pairs = Vec::new();
    for k in seq.pairs() {
        let truth = pair_truth(
            &features[0].frames,
            &features[k - 1].frames,
            &seq.homographies[k - 2],
        );
        bar.inc(1);
        let mut scored = Vec::new();
        let mut shown = Vec::new();
        for &c in &plan.combinations {
            let (s, sh) = score(set_of(0, c.sampling), set_of(k - 1, c.sampling), c, &truth)?;
            if c == Combination::SHOWN {
                shown = sh;
            }
            scored.push(s);
            bar.inc(1);
        }
        let mut scored_preselected = Vec::new();
        for (ci, &c) in plan.preselected.iter().enumerate() {
            let (s, _) = score(&reduced[0][ci], &reduced[k - 1][ci], c, &truth)?;
            scored_preselected.push(s);
            bar.inc(1);
        }
        pairs.push(PairResult {
            stats: PairStats {
                image: k,
                existing: truth.existing(),
                correct_pairs: truth.correct.len(),
            },
            scored,
            scored_preselected,
            shown,
        });
    }
    bar.finish_and_clear();

    let groups = group_pairs(seq, plan, &pairs);
    Ok(SequenceResult {
        images,
        pairs,
        groups,
        features,
    })
}

/// Pools pairs into figures according to the sequence's protocol.
fn group_pairs(seq: &Sequence, plan: &Plan, pairs: &[PairResult]) -> Vec<Group> {
    let all: Vec<usize> = pairs.iter().map(|p| p.stats.image).collect();
    let sets: Vec<Vec<usize>> = match seq.protocol {
        Protocol::Accumulated => vec![all],
        Protocol::FirstPairThenEach => all.iter().map(|&k| vec![k]).collect(),
    };
    sets.into_iter()
        .map(|images| {
            let members: Vec<&PairResult> = pairs
                .iter()
                .filter(|p| images.contains(&p.stats.image))
                .collect();
            let existing = members.iter().map(|p| p.stats.existing).sum();
            let pooled = |pick: &dyn Fn(&PairResult) -> &Vec<Scored>| -> Vec<Scored> {
                members
                    .iter()
                    .flat_map(|p| pick(p).iter().copied())
                    .collect()
            };
            let curves = plan
                .combinations
                .iter()
                .enumerate()
                .map(|(ci, c)| CombinationCurve {
                    combination: c.label(),
                    t_err: None,
                    curve: sweep(&pooled(&|p| &p.scored[ci]), existing),
                })
                .collect();
            let preselection = plan
                .preselected
                .iter()
                .enumerate()
                .map(|(ci, c)| CombinationCurve {
                    combination: c.label(),
                    t_err: c.preselection_threshold(),
                    curve: sweep(&pooled(&|p| &p.scored_preselected[ci]), existing),
                })
                .collect();
            let label = match images.as_slice() {
                [k] => format!("img1 vs img{k}"),
                [first, .., last] => format!("img1 vs img{first}..{last}"),
                [] => "no pairs".to_string(),
            };
            Group {
                paper_existing: paper_existing(&seq.name, &images),
                label,
                images,
                existing,
                curves,
                preselection,
            }
        })
        .collect()
}
