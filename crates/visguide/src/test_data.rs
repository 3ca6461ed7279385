//! Locating the benchmark data in tests: `$VISGUIDE_DATA/oxford-affine`. Without it a test is
//! skipped with a printed note, except under `CI=true`, where a missing data folder fails the
//! test with a message (CI must not silently skip a claim).

use std::path::PathBuf;

/// The `oxford-affine` folder below `$VISGUIDE_DATA`, or `None` after printing why the caller
/// skips. Panics under `CI=true` when the data is missing.
pub fn oxford_dir() -> Option<PathBuf> {
    let why = match std::env::var_os("VISGUIDE_DATA") {
        None => "VISGUIDE_DATA is not set (it names a folder holding oxford-affine/)".to_string(),
        Some(root) => {
            let mut dir = PathBuf::from(root);
            if dir.is_relative() && !dir.is_dir() {
                dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
                    .join("../..")
                    .join(dir);
            }
            let dir = dir.join("oxford-affine");
            if dir.is_dir() {
                return Some(dir);
            }
            format!("{} does not exist", dir.display())
        }
    };
    if std::env::var("CI").is_ok_and(|v| v == "true") {
        panic!("benchmark data needed under CI=true: {why}");
    }
    eprintln!("skipped: {why}");
    None
}
