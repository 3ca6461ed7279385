//! Locating the benchmark data in tests: `$VISGUIDE_DATA/oxford-affine`, or a printed reason
//! for skipping (a failure under `CI=true`, see [`crate::strict_ci`]).

use std::path::PathBuf;

/// The `oxford-affine` folder below `$VISGUIDE_DATA`, or `None` after printing why the caller
/// skips. Panics with the reason when `CI=true`: there, a test that cannot run fails.
pub fn oxford_dir() -> Option<PathBuf> {
    let skip = |why: String| {
        crate::strict_ci::skip_or_fail(&format!("skipped: {why}"))
            .unwrap_or_else(|e| panic!("{e}"));
        None
    };
    let Some(root) = std::env::var_os("VISGUIDE_DATA") else {
        return skip("VISGUIDE_DATA is not set (it names a folder holding oxford-affine/)".into());
    };
    let mut dir = PathBuf::from(root);
    if dir.is_relative() && !dir.is_dir() {
        // Cargo runs tests in the crate folder; the path may be relative to the workspace.
        dir = crate::workspace_root().join(dir);
    }
    let dir = dir.join("oxford-affine");
    if !dir.is_dir() {
        return skip(format!("{} does not exist", dir.display()));
    }
    Some(dir)
}
