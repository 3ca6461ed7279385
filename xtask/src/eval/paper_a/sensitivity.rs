//! The delta × diversity sensitivity table: how the region counts, the existing matches and
//! FD Corr/Affine's precision and recall at `T_r = 0.5` move with the two MSER parameters that
//! Paper A does not pin down. Reported, never used to pick a setting.

use serde::Serialize;

use super::combination::Combination;
use super::evaluate::{Plan, evaluate};
use super::progress::Progress;
use super::sequence::Sequence;

/// The settings tried.
#[derive(Debug, Clone)]
pub struct Grid {
    /// Δ values.
    pub deltas: Vec<u8>,
    /// `min_diversity` values.
    pub diversities: Vec<f64>,
}

impl Default for Grid {
    /// Δ ∈ {5, 10, 15, 20} (OpenCV's default, two readings of "margin 30", a wider one) ×
    /// `min_diversity` ∈ {0, 0.2, 0.5} (no suppression, OpenCV's default, strong).
    fn default() -> Self {
        Grid {
            deltas: vec![5, 10, 15, 20],
            diversities: vec![0.0, 0.2, 0.5],
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

/// Evaluates every setting of `grid` on `sequences`.
pub fn run(sequences: &[Sequence], grid: &Grid, progress: &Progress) -> crate::Result<Table> {
    let chosen = mser::MserParams::larsson2009();
    let quiet = Progress::hidden();
    let bar = progress.bar(
        (grid.deltas.len() * grid.diversities.len() * sequences.len()) as u64,
        "sensitivity (delta x diversity)",
    );
    let mut rows = Vec::new();
    for &delta in &grid.deltas {
        for &min_diversity in &grid.diversities {
            let params = mser::MserParams {
                delta,
                min_diversity,
                ..chosen.clone()
            };
            let plan = Plan {
                mser: params.clone(),
                combinations: vec![Combination::SHOWN],
                preselected: Vec::new(),
            };
            let mut cells = Vec::new();
            for seq in sequences {
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
                chosen: params == chosen,
                cells,
            });
        }
    }
    bar.finish_and_clear();
    Ok(Table {
        combination: Combination::SHOWN.label(),
        rows,
    })
}
