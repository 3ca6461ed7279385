//! Benchmark reports: the table printed by `cargo xtask bench NAME` and `target/bench/NAME.json`.

use std::path::Path;

use serde::Serialize;

use crate::Result;
use crate::markdown::Table;
pub use crate::stats::median;

/// One measured case: our figure, the peer's, and their ratio (> 1 means we are faster or better).
#[derive(Debug, Clone, Serialize)]
pub struct BenchRow {
    /// What was measured, e.g. `graf img1, both polarities`.
    pub case: String,
    /// Our figure.
    pub ours: f64,
    /// The peer's figure in the same run.
    pub peer: f64,
    /// Unit of `ours` and `peer`, e.g. `ms` or `updates/s`.
    pub unit: String,
    /// > 1 means ours is faster or better.
    pub ratio: f64,
}

impl BenchRow {
    /// A row where smaller is better (times): ratio = peer / ours.
    pub fn lower_is_better(case: impl Into<String>, ours: f64, peer: f64, unit: &str) -> Self {
        BenchRow {
            case: case.into(),
            ours,
            peer,
            unit: unit.to_string(),
            ratio: peer / ours,
        }
    }

    /// A row where larger is better (rates, accuracy): ratio = ours / peer.
    #[allow(dead_code)] // for the benches measuring rates (lwpr, fd)
    pub fn higher_is_better(case: impl Into<String>, ours: f64, peer: f64, unit: &str) -> Self {
        BenchRow {
            case: case.into(),
            ours,
            peer,
            unit: unit.to_string(),
            ratio: ours / peer,
        }
    }
}

/// Prints the rows as a Markdown table (ready for `docs/performance.md`) and writes them to
/// `dir/NAME.json` (atomically: a failed write leaves the previous file).
pub fn publish(dir: &Path, name: &str, peer: &str, rows: &[BenchRow]) -> Result<()> {
    // The file first: a standard output closed early (`| head`) must not lose it.
    let path = dir.join(format!("{name}.json"));
    crate::output::write_file(&path, serde_json::to_string_pretty(rows)? + "\n")?;
    println!("{name}: ours against {peer} (ratio > 1: ours faster or better)\n");
    let mut table = Table::new(["case", "ours", "peer", "unit", "ratio"]).right([1, 2, 4]);
    for r in rows {
        table.row([
            r.case.clone(),
            format!("{:.4}", r.ours),
            format!("{:.4}", r.peer),
            r.unit.clone(),
            format!("{:.2}", r.ratio),
        ]);
    }
    print!("{table}");
    println!("wrote {}", path.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ratios_point_the_right_way() {
        assert_eq!(BenchRow::lower_is_better("t", 2.0, 6.0, "ms").ratio, 3.0);
        assert_eq!(BenchRow::higher_is_better("r", 6.0, 2.0, "1/s").ratio, 3.0);
    }
}
