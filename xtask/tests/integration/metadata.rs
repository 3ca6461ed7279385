//! The workspace's root folder, and its manifests as `cargo metadata --no-deps` reads them (for
//! the checks on the workspace's shape, `layering` and `test_targets`).

use std::path::Path;

/// `cargo metadata --no-deps --format-version 1` of the workspace at `root`, parsed.
pub fn cargo_metadata(root: &Path) -> serde_json::Value {
    let out = std::process::Command::new(env!("CARGO"))
        .args([
            "metadata",
            "--no-deps",
            "--format-version",
            "1",
            "--offline",
        ])
        .current_dir(root)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "cargo metadata in {}: {}",
        root.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

/// The workspace's root folder (the parent of `xtask/`).
pub fn workspace_root() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf()
}
