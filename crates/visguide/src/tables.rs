//! Numeric CSV tables (the `lwpr` subcommands' input): comma-separated finite numbers, one
//! sample per line, every row as wide as the first; an optional first line of column names
//! (recognised by a field that is not a number); blank lines and lines starting with `#` are
//! ignored; a UTF-8 byte order mark (as spreadsheet programs write) and CRLF line ends are
//! accepted. Every malformed row is an error naming the file, the line and what was expected.

use std::path::Path;

use crate::error::{Result, VisguideError, io};

/// A table of numbers with its column names.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    /// Column names (from the header, or `c1`, `c2`, …).
    pub columns: Vec<String>,
    /// The rows, each `columns.len()` wide.
    pub rows: Vec<Vec<f64>>,
    /// The 1-based line of each row in the file.
    pub lines: Vec<usize>,
}

/// Parses the text of a table; `path` names the file in errors.
pub fn parse(text: &str, path: &Path) -> Result<Table> {
    let err = |line: usize, reason: String| VisguideError::Table {
        path: path.to_path_buf(),
        line,
        reason,
    };
    let mut columns: Option<Vec<String>> = None;
    let mut rows = Vec::new();
    let mut lines = Vec::new();
    for (k, raw) in text.lines().enumerate() {
        let no = k + 1;
        let mut l = raw.trim();
        if columns.is_none() && rows.is_empty() {
            // Byte order marks before the first field are not part of it: left in, one made a
            // first row of numbers look like a header (`\u{feff}1` is no number), silently
            // dropping that sample, and a header name starting with one would not read back
            // as written.
            l = l.trim_start_matches(|c: char| c == '\u{feff}' || c.is_whitespace());
        }
        if l.is_empty() || l.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = l.split(',').map(str::trim).collect();
        let numbers: Vec<Option<f64>> = fields.iter().map(|f| f.parse::<f64>().ok()).collect();
        if columns.is_none() && rows.is_empty() && numbers.iter().any(Option::is_none) {
            columns = Some(fields.iter().map(|s| s.to_string()).collect());
            continue;
        }
        let width = columns.as_ref().map_or(fields.len(), Vec::len);
        if fields.len() != width {
            return Err(err(
                no,
                format!(
                    "expected {width} comma-separated numbers, found {} fields",
                    fields.len()
                ),
            ));
        }
        let mut row = Vec::with_capacity(width);
        for (c, (f, n)) in fields.iter().zip(&numbers).enumerate() {
            match n {
                Some(v) if v.is_finite() => row.push(*v),
                _ => {
                    return Err(err(
                        no,
                        format!("column {}: expected a finite number, found `{f}`", c + 1),
                    ));
                }
            }
        }
        if columns.is_none() {
            columns = Some((1..=width).map(|c| format!("c{c}")).collect());
        }
        rows.push(row);
        lines.push(no);
    }
    let Some(columns) = columns else {
        return Err(err(
            0,
            "empty file: expected rows of comma-separated numbers".into(),
        ));
    };
    if rows.is_empty() {
        return Err(err(0, "no data rows after the header".into()));
    }
    Ok(Table {
        columns,
        rows,
        lines,
    })
}

/// Reads a table file (a directory or a missing file is an error naming it).
pub fn read(path: &Path) -> Result<Table> {
    if path.is_dir() {
        return Err(VisguideError::Table {
            path: path.to_path_buf(),
            line: 0,
            reason: "is a directory, expected a CSV file".into(),
        });
    }
    let text = std::fs::read_to_string(path).map_err(io(path))?;
    parse(&text, path)
}

/// Formats a number for a CSV cell (shortest round trip; `inf`/`NaN` as Rust writes them).
pub fn cell(v: f64) -> String {
    format!("{v}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_blank_lines_and_comments() {
        let t = parse(
            "# data\nx1,x2,y\n\n1,2,3\n4, 5.5 ,-6e-1\n",
            Path::new("d.csv"),
        )
        .unwrap();
        assert_eq!(t.columns, vec!["x1", "x2", "y"]);
        assert_eq!(t.rows, vec![vec![1.0, 2.0, 3.0], vec![4.0, 5.5, -0.6]]);
        assert_eq!(t.lines, vec![4, 5]);
        let n = parse("1,2\n3,4\n", Path::new("d.csv")).unwrap();
        assert_eq!(n.columns, vec!["c1", "c2"]);
    }

    /// A UTF-8 byte order mark does not turn the first row of numbers into a header (it used
    /// to: `\u{feff}1` is no number, so a headerless table silently lost its first sample),
    /// nor end up in the first column's name.
    #[test]
    fn a_byte_order_mark_is_not_part_of_the_first_field() {
        let p = Path::new("d.csv");
        let t = parse("\u{feff}1,2\r\n3,4\r\n", p).unwrap();
        assert_eq!(t.columns, vec!["c1", "c2"]);
        assert_eq!(t.rows, vec![vec![1.0, 2.0], vec![3.0, 4.0]]);
        assert_eq!(t.lines, vec![1, 2]);
        let h = parse("\u{feff}x,y\n1,2\n", p).unwrap();
        assert_eq!(h.columns, vec!["x", "y"]);
        // Several marks, or one after blanks (found by the `visguide_table` fuzz target: a
        // header name `\u{feff}1` was written back and read as a row).
        for text in [
            "\u{feff}\u{feff}1\n1\n2",
            " \u{feff}1\n1\n2",
            "\u{feff}\n1\n1\n2",
            " \u{feff} \u{feff}1\n1\n2",
        ] {
            let t = parse(text, p).unwrap();
            assert_eq!(t.columns, vec!["c1"], "{text:?}");
            assert_eq!(t.rows, vec![vec![1.0], vec![1.0], vec![2.0]], "{text:?}");
        }
    }

    /// A cell is the shortest text that reads back to the same number, bit for bit (tiny,
    /// huge, subnormal, negative zero), so a table written with `cell` parses back to the
    /// same rows; `inf` and `NaN` are spelt as Rust writes them.
    #[test]
    fn cells_read_back_bit_for_bit() {
        let values = [
            0.1,
            1.0 / 3.0,
            -2.0 / 7.0,
            1e-300,
            5e-324,
            f64::MAX,
            -0.0,
            123_456_789.123_456_78,
            1.0,
        ];
        for &v in &values {
            let c = cell(v);
            assert_eq!(c.parse::<f64>().unwrap().to_bits(), v.to_bits(), "{c}");
        }
        assert_eq!(cell(0.1), "0.1");
        assert_eq!(cell(1.0), "1");
        let text: String = values
            .chunks(3)
            .map(|r| r.iter().map(|&v| cell(v)).collect::<Vec<_>>().join(",") + "\n")
            .collect();
        let t = parse(&text, Path::new("d.csv")).unwrap();
        let got: Vec<u64> = t.rows.concat().iter().map(|v| v.to_bits()).collect();
        assert_eq!(got, values.map(f64::to_bits));
        assert_eq!(
            (cell(f64::INFINITY), cell(f64::NAN)),
            ("inf".into(), "NaN".into())
        );
    }

    #[test]
    fn bad_rows_name_the_line() {
        let p = Path::new("d.csv");
        for (text, line, what) in [
            ("x,y\n1,2\n3\n", 3, "expected 2"),
            ("1,2\n3,oops\n", 2, "column 2"),
            ("1,2\n3,inf\n", 2, "finite"),
            ("x,y\n", 0, "no data"),
            ("", 0, "empty"),
        ] {
            let e = parse(text, p).unwrap_err().to_string();
            assert!(
                e.starts_with(&format!("d.csv:{line}:")) && e.contains(what),
                "{e}"
            );
        }
    }
}
