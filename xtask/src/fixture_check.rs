//! Comparison of a freshly generated fixture tree with the committed one (`eval --check`).
//!
//! Tolerances: JSON files are compared structurally, numbers with
//! `|a − b| ≤ 1e-9 + 1e-6·max(|a|, |b|)` (floating-point summation order may differ between
//! machines); every other file must be byte-identical (SVG, Markdown and PNG outputs are written
//! deterministically, with numbers rounded before they are printed).

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use crate::Result;

/// Absolute tolerance for numbers in JSON fixtures.
pub const ABS_TOL: f64 = 1e-9;
/// Relative tolerance for numbers in JSON fixtures.
pub const REL_TOL: f64 = 1e-6;

/// Compares `expected/<name>` with each freshly generated `(name, folder)`; returns one line
/// per difference (missing, extra or differing files).
pub fn compare_folders(expected: &Path, actual: &[(String, PathBuf)]) -> Result<Vec<String>> {
    let mut diffs = Vec::new();
    for (t, actual_dir) in actual {
        let e = files_below(&expected.join(t))?;
        let a = files_below(actual_dir)?;
        for rel in e.union(&a) {
            let (ep, ap) = (expected.join(t).join(rel), actual_dir.join(rel));
            let shown = Path::new(t).join(rel);
            match (e.contains(rel), a.contains(rel)) {
                (true, false) => diffs.push(format!("{} is no longer produced", shown.display())),
                (false, true) => diffs.push(format!("{} is new (not committed)", shown.display())),
                _ => {
                    if let Some(why) = compare_files(&ep, &ap)? {
                        diffs.push(format!("{}: {why}", shown.display()));
                    }
                }
            }
        }
    }
    Ok(diffs)
}

fn files_below(dir: &Path) -> Result<BTreeSet<PathBuf>> {
    let mut out = BTreeSet::new();
    if !dir.is_dir() {
        return Ok(out);
    }
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d)? {
            let p = entry?.path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.insert(p.strip_prefix(dir)?.to_path_buf());
            }
        }
    }
    Ok(out)
}

/// `None` when the files agree within tolerance, otherwise a short reason.
pub fn compare_files(expected: &Path, actual: &Path) -> Result<Option<String>> {
    let (e, a) = (std::fs::read(expected)?, std::fs::read(actual)?);
    if e == a {
        return Ok(None);
    }
    if expected.extension().is_some_and(|x| x == "json") {
        let ev: serde_json::Value = serde_json::from_slice(&e)?;
        let av: serde_json::Value = serde_json::from_slice(&a)?;
        return Ok(compare_json(&ev, &av, "$"));
    }
    Ok(Some("contents differ".to_string()))
}

/// `None` when the two JSON values agree within the tolerances, otherwise the first difference.
pub fn compare_json(e: &serde_json::Value, a: &serde_json::Value, at: &str) -> Option<String> {
    use serde_json::Value::*;
    match (e, a) {
        (Number(x), Number(y)) => {
            let (x, y) = (x.as_f64()?, y.as_f64()?);
            let tol = ABS_TOL + REL_TOL * x.abs().max(y.abs());
            ((x - y).abs() > tol).then(|| format!("{at}: {x} != {y}"))
        }
        (Array(x), Array(y)) => {
            if x.len() != y.len() {
                return Some(format!("{at}: length {} != {}", x.len(), y.len()));
            }
            x.iter()
                .zip(y)
                .enumerate()
                .find_map(|(i, (x, y))| compare_json(x, y, &format!("{at}[{i}]")))
        }
        (Object(x), Object(y)) => {
            let keys: BTreeSet<&std::string::String> = x.keys().chain(y.keys()).collect();
            keys.into_iter().find_map(|k| match (x.get(k), y.get(k)) {
                (Some(x), Some(y)) => compare_json(x, y, &format!("{at}.{k}")),
                _ => Some(format!("{at}.{k}: present on one side only")),
            })
        }
        _ => (e != a).then(|| format!("{at}: {e} != {a}")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn numbers_within_tolerance_agree() {
        assert_eq!(
            compare_json(
                &json!({"a": [1.0, 2.0]}),
                &json!({"a": [1.0, 2.0000001]}),
                "$"
            ),
            None
        );
    }

    #[test]
    fn numbers_beyond_tolerance_differ() {
        let d = compare_json(&json!({"a": [1.0, 2.0]}), &json!({"a": [1.0, 2.01]}), "$");
        assert_eq!(d.as_deref(), Some("$.a[1]: 2 != 2.01"));
    }

    #[test]
    fn structure_must_match() {
        assert!(compare_json(&json!({"a": 1}), &json!({"b": 1}), "$").is_some());
        assert!(compare_json(&json!([1, 2]), &json!([1]), "$").is_some());
        assert!(compare_json(&json!("x"), &json!("y"), "$").is_some());
    }
}
