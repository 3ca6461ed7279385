//! Every entry below a folder, for the tests that look at folders as a whole (`eval_output`'s
//! byte-exact pictures of an output folder, `test_targets`' list of test files).

use std::path::{Path, PathBuf};

/// Every file and folder below `dir` (not `dir` itself), sorted. Panics if a folder cannot be
/// read, `dir` included.
pub fn entries_below(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap_or_else(|e| panic!("{}: {e}", d.display())) {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p.clone());
            }
            out.push(p);
        }
    }
    out.sort();
    out
}
