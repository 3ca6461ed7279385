use super::*;

/// A fresh, empty scratch folder for one test.
fn scratch(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("visguide-output-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Every file below `dir` with its contents, sorted (a byte-exact picture of a folder).
fn snapshot(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                out.push((p.strip_prefix(dir).unwrap().to_path_buf(), Vec::new()));
                stack.push(p);
            } else {
                let bytes = std::fs::read(&p).unwrap();
                out.push((p.strip_prefix(dir).unwrap().to_path_buf(), bytes));
            }
        }
    }
    out.sort();
    out
}

fn refusal(path: &Path, trusted: bool) -> String {
    Destination::check(path, trusted).unwrap_err().to_string()
}

#[test]
fn refuses_the_current_folder_the_repository_and_folders_above() {
    let cwd = std::env::current_dir().unwrap();
    let repo = crate::workspace_root();
    for (p, trusted) in [
        (cwd.clone(), false),
        (cwd.clone(), true),
        (PathBuf::from("."), true),
        (PathBuf::from(".."), false),
        (repo.clone(), true),
        (repo.join("xtask").join(".."), true),
        (repo.parent().unwrap().to_path_buf(), true),
    ] {
        let e = refusal(&p, trusted);
        assert!(
            e.contains("the current folder") || e.contains("the repository"),
            "{}: {e}",
            p.display()
        );
        assert!(e.contains(&p.display().to_string()), "names the path: {e}");
    }
    assert!(refusal(Path::new("/"), true).contains("root"));
}

#[test]
fn refuses_a_non_empty_folder_that_is_not_ours_and_leaves_it_alone() {
    let d = scratch("foreign");
    let mine = d.join("mine");
    std::fs::create_dir_all(mine.join("sub")).unwrap();
    std::fs::write(mine.join("notes.txt"), "precious").unwrap();
    let before = snapshot(&d);
    let e = refusal(&mine, false);
    assert!(
        e.contains("not an output of ours") && e.contains(&mine.display().to_string()),
        "{e}"
    );
    assert_eq!(snapshot(&d), before);
    // A file, and a symbolic link to a folder, are refused too.
    std::fs::write(d.join("file"), "x").unwrap();
    assert!(refusal(&d.join("file"), true).contains("not a folder"));
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink(&mine, d.join("link")).unwrap();
        assert!(refusal(&d.join("link"), true).contains("symbolic link"));
    }
    // The repository's own fixtures folder is trusted without a marker; other checks still apply.
    Destination::check(&mine, true).unwrap();
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn accepts_a_new_an_empty_and_a_marked_folder() {
    let d = scratch("accept");
    Destination::check(&d.join("new/deeper"), false).unwrap();
    std::fs::create_dir(d.join("empty")).unwrap();
    Destination::check(&d.join("empty"), false).unwrap();
    std::fs::create_dir(d.join("ours")).unwrap();
    std::fs::write(d.join("ours").join(MARKER), "x").unwrap();
    std::fs::write(d.join("ours/result.json"), "{}").unwrap();
    Destination::check(&d.join("ours"), false).unwrap();
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn a_staged_folder_dropped_without_commit_leaves_nothing() {
    let d = scratch("drop");
    std::fs::create_dir(d.join("out")).unwrap();
    std::fs::write(d.join("out").join(MARKER), MARKER_TEXT).unwrap();
    std::fs::write(d.join("out/old.txt"), "old").unwrap();
    let before = snapshot(&d);
    for dest in [d.join("out"), d.join("a/b/c")] {
        let stage = Staged::new(&Destination::check(&dest, false).unwrap()).unwrap();
        std::fs::write(stage.path().join("half.txt"), "half").unwrap();
        assert!(stage.path().starts_with(&d) && stage.path() != dest);
        drop(stage);
        assert_eq!(snapshot(&d), before, "{}", dest.display());
    }
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn commit_replaces_the_old_output_as_a_whole() {
    let d = scratch("commit");
    let out = d.join("out");
    std::fs::create_dir(&out).unwrap();
    std::fs::write(out.join(MARKER), MARKER_TEXT).unwrap();
    std::fs::write(out.join("stale.txt"), "stale").unwrap();
    let fresh = d.join("fresh/deeper");
    let a = Staged::new(&Destination::check(&out, false).unwrap()).unwrap();
    std::fs::write(a.path().join("new.txt"), "new").unwrap();
    let b = Staged::new(&Destination::check(&fresh, false).unwrap()).unwrap();
    std::fs::write(b.path().join("b.txt"), "b").unwrap();
    commit_all(vec![a, b]).unwrap();
    let expect = |names: &[(&str, &str)]| -> Vec<(PathBuf, Vec<u8>)> {
        let mut v: Vec<(PathBuf, Vec<u8>)> = names
            .iter()
            .map(|(n, c)| (PathBuf::from(n), c.as_bytes().to_vec()))
            .collect();
        v.push((PathBuf::from(MARKER), MARKER_TEXT.as_bytes().to_vec()));
        v.sort();
        v
    };
    assert_eq!(snapshot(&out), expect(&[("new.txt", "new")]));
    assert_eq!(snapshot(&fresh), expect(&[("b.txt", "b")]));
    // No temporary or set-aside folder is left beside them.
    let mut beside: Vec<String> = std::fs::read_dir(&d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    beside.sort();
    assert_eq!(beside, ["fresh", "out"]);
    // Once committed, the folder is ours: it may be replaced again.
    Destination::check(&out, false).unwrap();
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn write_file_replaces_whole_files_and_names_the_path_on_failure() {
    let d = scratch("file");
    let p = d.join("bench/x.json");
    write_file(&p, "one").unwrap();
    write_file(&p, "two").unwrap();
    assert_eq!(std::fs::read_to_string(&p).unwrap(), "two");
    assert_eq!(std::fs::read_dir(d.join("bench")).unwrap().count(), 1);
    // A folder in the way: the error names the path, nothing partial remains.
    std::fs::create_dir(d.join("bench/dir.json")).unwrap();
    let e = write_file(&d.join("bench/dir.json"), "x")
        .unwrap_err()
        .to_string();
    assert!(e.contains("dir.json"), "{e}");
    assert_eq!(std::fs::read_dir(d.join("bench")).unwrap().count(), 2);
    std::fs::remove_dir_all(&d).unwrap();
}
