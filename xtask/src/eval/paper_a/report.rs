//! The JSON report of one sequence (`<name>.json`): settings, per-image and per-pair counts and
//! every curve's points and summary.

use serde::Serialize;

use super::evaluate::{Group, ImageStats, PairStats, Plan, SequenceResult};
use super::sequence::{Protocol, Sequence, Source};

/// The detector setting as written to JSON.
#[derive(Debug, Clone, Serialize)]
pub struct MserSetting {
    /// Δ.
    pub delta: u8,
    /// Smallest region, pixels.
    pub min_area: usize,
    /// Largest region, pixels (absent: unlimited).
    pub max_area: Option<usize>,
    /// Largest variation.
    pub max_variation: f64,
    /// Duplicate suppression.
    pub min_diversity: f64,
    /// Polarities.
    pub polarities: String,
}

impl MserSetting {
    /// From the detector's parameters.
    pub fn new(p: &mser::MserParams) -> Self {
        MserSetting {
            delta: p.delta,
            min_area: p.min_area,
            max_area: (p.max_area != usize::MAX).then_some(p.max_area),
            max_variation: p.max_variation,
            min_diversity: p.min_diversity,
            polarities: format!("{:?}", p.polarities).to_lowercase(),
        }
    }
}

/// Everything written for one sequence.
#[derive(Debug, Clone, Serialize)]
pub struct SequenceReport {
    /// Sequence name.
    pub sequence: String,
    /// Folder or synthetic.
    pub source: Source,
    /// How pairs are pooled.
    pub protocol: Protocol,
    /// Detector setting.
    pub mser: MserSetting,
    /// Ground-truth convention.
    pub ground_truth: &'static str,
    /// Descriptor setting.
    pub descriptors: &'static str,
    /// Per image.
    pub images: Vec<ImageStats>,
    /// Per pair.
    pub pairs: Vec<PairStats>,
    /// Per figure.
    pub groups: Vec<Group>,
}

/// The ground-truth convention, as written into reports.
pub const GROUND_TRUTH: &str = "moment ellipses (M = inverse second-moment matrix), mapped by the local affine approximation of H, descriptor mode of Mikolajczyk et al. (x3, centre offset unscaled, no border crop), correct when overlap error < 50%, existing = greedy one-to-one correspondences";

/// The descriptor setting, as written into reports.
pub const DESCRIPTORS: &str = "fd-match defaults: 256 contour samples, 51 coefficients (DC dropped, unit norm), symmetric matching with the larger of the two ratios; FD Corr peak by zero-padded inverse FFT refined by Newton steps";

impl SequenceReport {
    /// Builds the report.
    pub fn new(seq: &Sequence, plan: &Plan, result: &SequenceResult) -> Self {
        SequenceReport {
            sequence: seq.name.clone(),
            source: seq.source,
            protocol: seq.protocol,
            mser: MserSetting::new(&plan.mser),
            ground_truth: GROUND_TRUTH,
            descriptors: DESCRIPTORS,
            images: result.images.clone(),
            pairs: result.pairs.iter().map(|p| p.stats.clone()).collect(),
            groups: result.groups.clone(),
        }
    }
}
