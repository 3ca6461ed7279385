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

#[test]
fn a_sibling_is_staged_beside_the_staged_folder() {
    let pid = std::process::id();
    let staged = staging_path(Path::new("/x/fixtures/paper-b"));
    assert_eq!(
        staged,
        PathBuf::from(format!("/x/fixtures/.paper-b.partial-{pid}"))
    );
    assert_eq!(
        staged_sibling(&staged, "-pedestrians"),
        staging_path(Path::new("/x/fixtures/paper-b-pedestrians"))
    );
    // A plain folder (a test's own output folder): the sibling lies beside it.
    assert_eq!(
        staged_sibling(Path::new("/tmp/out"), "-more"),
        PathBuf::from("/tmp/out-more")
    );
}

#[test]
fn a_staged_folder_holding_only_the_marker_is_unused() {
    let d = scratch("unused");
    let stage = Staged::new(&Destination::check(&d.join("sib"), false).unwrap()).unwrap();
    assert!(stage.is_unused());
    std::fs::write(stage.path().join("table.json"), "{}").unwrap();
    assert!(!stage.is_unused());
    drop(stage);
    std::fs::remove_dir_all(&d).unwrap();
}

/// Threads writing one file at once each use a temporary file of their own: every write
/// succeeds and the file is one of the whole contents. (With one temporary name per process,
/// `PATH.partial-PID`, a thread renamed another's half-written file into place, or found its
/// own renamed away: "No such file or directory".)
#[test]
fn write_file_from_many_threads_at_once_gives_one_whole_content() {
    let d = scratch("file-threads");
    let p = d.join("bench/x.json");
    let contents: Vec<Vec<u8>> = (0..8u8).map(|k| vec![b'a' + k; 300_000]).collect();
    std::thread::scope(|s| {
        for c in &contents {
            let p = &p;
            s.spawn(move || {
                for _ in 0..5 {
                    write_file(p, c).unwrap();
                }
            });
        }
    });
    assert!(contents.contains(&std::fs::read(&p).unwrap()));
    assert_eq!(std::fs::read_dir(d.join("bench")).unwrap().count(), 1);
    std::fs::remove_dir_all(&d).unwrap();
}

/// A drawing that fails half-way leaves the old picture byte for byte and no other file
/// (plotters' file backend, dropped after the failure, wrote the part drawn so far over it);
/// one that succeeds replaces it with exactly what the file backend writes.
#[test]
fn write_svg_is_all_or_nothing_and_draws_what_the_file_backend_draws() {
    use plotters::prelude::*;
    let d = scratch("svg");
    let p = d.join("plot.svg");
    std::fs::write(&p, "old").unwrap();
    let e = write_svg(&p, (200, 100), |root| {
        root.fill(&WHITE)?;
        root.draw(&Circle::new((50, 50), 20, RED.filled()))?;
        Err("the drawing failed half-way".into())
    })
    .unwrap_err();
    assert!(e.to_string().contains("half-way"), "{e}");
    assert_eq!(std::fs::read_to_string(&p).unwrap(), "old");
    assert_eq!(std::fs::read_dir(&d).unwrap().count(), 1);
    let draw = |root: &DrawingArea<SVGBackend<'_>, plotters::coord::Shift>| -> Result<()> {
        root.fill(&WHITE)?;
        root.draw(&Circle::new((50, 50), 20, RED.filled()))?;
        root.draw(&Text::new("µs", (10, 10), ("sans-serif", 12)))?;
        Ok(())
    };
    write_svg(&p, (200, 100), draw).unwrap();
    let direct = d.join("direct.svg");
    {
        let root = SVGBackend::new(&direct, (200, 100)).into_drawing_area();
        draw(&root).unwrap();
        root.present().unwrap();
    }
    assert_eq!(std::fs::read(&p).unwrap(), std::fs::read(&direct).unwrap());
    std::fs::remove_dir_all(&d).unwrap();
}

/// `write_png` writes the very bytes `image`'s own `save` writes (the fixtures' pictures are
/// unchanged by using it), and a folder in the way is an error naming the path with nothing
/// left.
#[test]
fn write_png_writes_what_save_writes() {
    let d = scratch("png");
    let rgb = image::RgbImage::from_fn(37, 23, |x, y| image::Rgb([x as u8 * 7, y as u8 * 11, 99]));
    let grey = image::GrayImage::from_fn(19, 41, |x, y| image::Luma([(x * y) as u8]));
    rgb.save(d.join("rgb-save.png")).unwrap();
    grey.save(d.join("grey-save.png")).unwrap();
    write_png(&d.join("rgb.png"), &rgb).unwrap();
    write_png(&d.join("grey.png"), &grey).unwrap();
    for n in ["rgb", "grey"] {
        let ours = std::fs::read(d.join(format!("{n}.png"))).unwrap();
        assert_eq!(
            ours,
            std::fs::read(d.join(format!("{n}-save.png"))).unwrap(),
            "{n}"
        );
    }
    std::fs::create_dir(d.join("dir.png")).unwrap();
    let e = write_png(&d.join("dir.png"), &rgb).unwrap_err().to_string();
    assert!(e.contains("dir.png"), "{e}");
    assert_eq!(std::fs::read_dir(&d).unwrap().count(), 5);
    std::fs::remove_dir_all(&d).unwrap();
}

/// Why [`write_png`] exists: `image`'s own `save` reports success when the disk is full
/// (`/dev/full` refuses every write), because the end of the file is left to a dropped buffer.
/// If this starts failing, `image` checks its final write and `save` is safe to use again.
#[cfg(target_os = "linux")]
#[test]
fn image_save_ignores_a_failed_final_write() {
    let full = Path::new("/dev/full");
    if !full.exists() {
        return;
    }
    let tiny = image::RgbImage::new(2, 2);
    assert!(tiny.save_with_format(full, image::ImageFormat::Png).is_ok());
    assert!(std::fs::write(full, png_bytes(&tiny).unwrap()).is_err());
}
