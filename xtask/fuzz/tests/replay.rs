//! Replays every file of `corpus/<target>/` through its target's body on a stable toolchain,
//! so an input that once crashed a loader keeps being checked: `cargo test --manifest-path
//! xtask/fuzz/Cargo.toml` (`.ci/run` runs it).

use std::path::PathBuf;

fn corpus_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("corpus")
}

#[test]
fn every_corpus_file_passes_its_target() {
    let mut replayed = 0;
    for (name, body) in visguide_fuzz::TARGETS {
        let dir = corpus_root().join(name);
        let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
            .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
            .map(|e| e.unwrap().path())
            .collect();
        files.sort();
        assert!(!files.is_empty(), "{}: no seed", dir.display());
        for f in files {
            let data = std::fs::read(&f).unwrap();
            // A panic names the file: catch it to say which.
            let r = std::panic::catch_unwind(|| body(&data));
            assert!(r.is_ok(), "{name}: {} crashes the target", f.display());
            replayed += 1;
        }
    }
    eprintln!("replayed {replayed} corpus files");
}

/// Every corpus folder belongs to a target, and every target has a fuzz binary.
#[test]
fn corpus_folders_and_binaries_match_the_targets() {
    let names: Vec<&str> = visguide_fuzz::TARGETS.iter().map(|(n, _)| *n).collect();
    for e in std::fs::read_dir(corpus_root()).unwrap() {
        let n = e.unwrap().file_name().to_string_lossy().into_owned();
        assert!(names.contains(&n.as_str()), "corpus/{n} has no target");
    }
    let bins = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fuzz_targets");
    for n in &names {
        let src = std::fs::read_to_string(bins.join(format!("{n}.rs"))).unwrap();
        assert!(
            src.contains(&format!("visguide_fuzz::{n}(")),
            "fuzz_targets/{n}.rs"
        );
    }
}
