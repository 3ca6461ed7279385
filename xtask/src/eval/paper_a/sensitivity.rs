//! The sensitivity table: how the region counts, the existing matches and FD Corr/Affine's
//! precision and recall at `T_r = 0.5` move with the MSER parameters that Paper A does not pin
//! down: Δ × `min_diversity` on a grid, then `max_variation` varied alone at the study's Δ and
//! diversity. Reported, never used to pick a setting.

use serde::Serialize;

use super::evaluate::{Plan, evaluate};
use super::progress::Progress;
use super::sequence::Sequence;
use visguide::{Combination, MserSettings};

/// The settings tried.
#[derive(Debug, Clone)]
pub struct Grid {
    /// Δ values.
    pub deltas: Vec<u8>,
    /// `min_diversity` values.
    pub diversities: Vec<f64>,
    /// `max_variation` values, each tried at the study's own Δ and `min_diversity`.
    pub max_variations: Vec<f64>,
}

impl Default for Grid {
    /// Δ ∈ {5, 10, 15, 20} (OpenCV's default, two readings of "margin 30", a wider one) ×
    /// `min_diversity` ∈ {0, 0.2, 0.5} (no suppression, OpenCV's default, strong); then
    /// `max_variation` ∈ {0.1, 0.5, 1.0} (strict, twice and four times OpenCV's 0.25).
    fn default() -> Self {
        Grid {
            deltas: vec![5, 10, 15, 20],
            diversities: vec![0.0, 0.2, 0.5],
            max_variations: vec![0.1, 0.5, 1.0],
        }
    }
}

/// One sequence's numbers for one setting (its first figure's pairs).
#[derive(Debug, Clone, Serialize)]
pub struct Cell {
    /// Sequence.
    pub sequence: String,
    /// The pairs pooled.
    pub group: String,
    /// Regions summed over the images of those pairs (img1 counted once).
    pub regions: usize,
    /// Existing matches.
    pub existing: usize,
    /// The paper's count, where it has one.
    pub paper_existing: Option<usize>,
    /// FD Corr/Affine matches at `T_r = 0.5`.
    pub matches: usize,
    /// Their precision.
    pub precision: Option<f64>,
    /// Their recall.
    pub recall: Option<f64>,
}

/// One setting.
#[derive(Debug, Clone, Serialize)]
pub struct Row {
    /// Δ.
    pub delta: u8,
    /// `min_diversity`.
    pub min_diversity: f64,
    /// `max_variation`.
    pub max_variation: f64,
    /// Whether this is the setting used for the figures.
    pub chosen: bool,
    /// Per sequence.
    pub cells: Vec<Cell>,
}

/// The table.
#[derive(Debug, Clone, Serialize)]
pub struct Table {
    /// The combination whose precision and recall are shown.
    pub combination: String,
    /// One row per setting, Δ-major.
    pub rows: Vec<Row>,
}

/// Evaluates every setting of `grid` on `sequences`, around the study's `settings`.
pub fn run(
    sequences: &[Sequence],
    grid: &Grid,
    settings: &MserSettings,
    progress: &Progress,
) -> crate::Result<Table> {
    let quiet = Progress::hidden();
    // The study's own setting per sequence (a relative-area preset depends on the image size).
    let bases: Vec<mser::MserParams> = sequences
        .iter()
        .map(|s| {
            let (w, h) = s.images[0].dimensions();
            settings.resolve(w, h)
        })
        .collect::<visguide::Result<_>>()?;
    let Some(chosen) = bases.first().cloned() else {
        return Ok(Table {
            combination: Combination::SHOWN.label(),
            rows: Vec::new(),
        });
    };
    let mut points: Vec<(u8, f64, f64)> = Vec::new();
    for &delta in &grid.deltas {
        for &min_diversity in &grid.diversities {
            points.push((delta, min_diversity, chosen.max_variation));
        }
    }
    for &v in &grid.max_variations {
        if v != chosen.max_variation {
            points.push((chosen.delta, chosen.min_diversity, v));
        }
    }
    let bar = progress.bar(
        (points.len() * sequences.len()) as u64,
        "sensitivity (delta x diversity, max variation)",
    );
    let mut rows = Vec::new();
    for &(delta, min_diversity, max_variation) in &points {
        let mut cells = Vec::new();
        for (seq, base) in sequences.iter().zip(&bases) {
            let params = mser::MserParams {
                delta,
                min_diversity,
                max_variation,
                ..base.clone()
            };
            let plan = Plan {
                mser: params,
                combinations: vec![Combination::SHOWN],
                preselected: Vec::new(),
            };
            let r = evaluate(seq, &plan, &quiet)?;
            let g = &r.groups[0];
            let at = g.curves[0].curve.summary.at_paper_threshold;
            let regions = r.images[0].regions
                + g.images
                    .iter()
                    .map(|&k| r.images[k - 1].regions)
                    .sum::<usize>();
            cells.push(Cell {
                sequence: seq.name.clone(),
                group: g.label.clone(),
                regions,
                existing: g.existing,
                paper_existing: g.paper_existing,
                matches: at.matches,
                precision: at.precision,
                recall: at.recall,
            });
            bar.inc(1);
        }
        rows.push(Row {
            delta,
            min_diversity,
            max_variation,
            chosen: (delta, min_diversity, max_variation)
                == (chosen.delta, chosen.min_diversity, chosen.max_variation),
            cells,
        });
    }
    bar.finish_and_clear();
    Ok(Table {
        combination: Combination::SHOWN.label(),
        rows,
    })
}
