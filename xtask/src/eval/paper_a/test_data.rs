//! Locating the benchmark data in tests: `$VISGUIDE_DATA/oxford-affine`, or a printed reason
//! for skipping.

use std::path::PathBuf;

/// The `oxford-affine` folder below `$VISGUIDE_DATA`, or `None` after printing why the caller
/// skips.
pub fn oxford_dir() -> Option<PathBuf> {
    let Some(root) = std::env::var_os("VISGUIDE_DATA") else {
        eprintln!("skipped: VISGUIDE_DATA is not set (it names a folder holding oxford-affine/)");
        return None;
    };
    let mut dir = PathBuf::from(root);
    if dir.is_relative() && !dir.is_dir() {
        // Cargo runs tests in the crate folder; the path may be relative to the workspace.
        dir = crate::workspace_root().join(dir);
    }
    let dir = dir.join("oxford-affine");
    if !dir.is_dir() {
        eprintln!("skipped: {} does not exist", dir.display());
        return None;
    }
    Some(dir)
}
