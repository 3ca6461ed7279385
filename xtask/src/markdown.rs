//! Markdown tables for the evaluation targets' `summary.md` files: one builder, so that every
//! table is written the same way (`| a | b |` rows under a `|---|---:|` rule).

use std::fmt;

/// Column alignment, written into the rule line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Align {
    /// `---` (Markdown's default: left).
    Default,
    /// `---:`.
    Right,
}

/// A Markdown table: a header, one alignment per column and rows of cells.
#[derive(Debug, Clone)]
pub struct Table {
    header: Vec<String>,
    align: Vec<Align>,
    rows: Vec<Vec<String>>,
}

impl Table {
    /// A table with these column headings, every column with the default alignment.
    pub fn new<S: Into<String>>(header: impl IntoIterator<Item = S>) -> Self {
        let header: Vec<String> = header.into_iter().map(Into::into).collect();
        let align = vec![Align::Default; header.len()];
        Table {
            header,
            align,
            rows: Vec::new(),
        }
    }

    /// Right-aligns the columns with these indices (numbers).
    pub fn right(mut self, columns: impl IntoIterator<Item = usize>) -> Self {
        for c in columns {
            if let Some(a) = self.align.get_mut(c) {
                *a = Align::Right;
            }
        }
        self
    }

    /// Appends a row. Missing cells are written empty, surplus cells are dropped.
    pub fn row<S: Into<String>>(&mut self, cells: impl IntoIterator<Item = S>) -> &mut Self {
        let mut row: Vec<String> = cells.into_iter().map(Into::into).collect();
        row.resize(self.header.len(), String::new());
        self.rows.push(row);
        self
    }
}

/// A cell's text with `|` escaped and line breaks turned into spaces, so a cell never splits the
/// row.
fn cell(s: &str) -> String {
    s.replace('|', "\\|").replace(['\n', '\r'], " ")
}

fn line(f: &mut fmt::Formatter<'_>, cells: &[String]) -> fmt::Result {
    f.write_str("|")?;
    for c in cells {
        write!(f, " {} |", cell(c))?;
    }
    f.write_str("\n")
}

impl fmt::Display for Table {
    /// The table, every line (the last one too) ending in `\n`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        line(f, &self.header)?;
        f.write_str("|")?;
        for a in &self.align {
            f.write_str(match a {
                Align::Default => "---|",
                Align::Right => "---:|",
            })?;
        }
        f.write_str("\n")?;
        for r in &self.rows {
            line(f, r)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_header_rule_and_rows() {
        let mut t = Table::new(["tracker", "mean RMSE", "lost"]).right([1, 2]);
        t.row(["CBT", "1.29", "0.0 %"]).row(["PF 1000", "1.30"]);
        assert_eq!(
            t.to_string(),
            "| tracker | mean RMSE | lost |\n|---|---:|---:|\n| CBT | 1.29 | 0.0 % |\n\
             | PF 1000 | 1.30 |  |\n"
        );
    }

    #[test]
    fn a_cell_cannot_break_its_row() {
        let mut t = Table::new(["a"]);
        t.row(["x | y\nz"]);
        assert_eq!(t.to_string(), "| a |\n|---|\n| x \\| y z |\n");
    }
}
