//! Oxford region files: exact round trip, the benchmark's header conventions, malformed files.

use mser::{Ellipse, MserError, read_regions, write_regions};

#[test]
fn round_trip_is_exact() {
    let es = vec![
        Ellipse {
            u: 1.5,
            v: 2.25,
            a: 0.1,
            b: -0.01,
            c: 0.2,
        },
        Ellipse {
            u: 300.123456789,
            v: 0.0,
            a: 1.0 / 3.0,
            b: 1e-17,
            c: 7.0,
        },
    ];
    let mut buf = Vec::new();
    write_regions(&mut buf, &es).unwrap();
    let text = String::from_utf8(buf.clone()).unwrap();
    assert!(text.starts_with("1.0\n2\n"), "{text}");
    let back = read_regions(&buf[..]).unwrap();
    assert_eq!(back.len(), 2);
    for (a, b) in es.iter().zip(&back) {
        assert_eq!(*a, b.ellipse);
        assert!(b.descriptor.is_empty());
    }
}

#[test]
fn reads_descriptors_and_zero_header() {
    let text = "3\n2\n10 20 0.01 0 0.02 1 2 3\n30 40 0.5 0.1 0.5 4 5 6\n";
    let r = read_regions(text.as_bytes()).unwrap();
    assert_eq!(r[1].descriptor, vec![4.0, 5.0, 6.0]);
    assert_eq!(r[0].ellipse.u, 10.0);
    let r = read_regions("0\n1\n1 2 1 0 1\n".as_bytes()).unwrap();
    assert_eq!(r.len(), 1);
}

#[test]
fn malformed_files_give_line_numbers() {
    let bad = [
        ("", 0),
        ("1.0\n", 0),
        ("x\n1\n1 2 1 0 1\n", 1),
        ("1.0\n2\n1 2 1 0 1\n", 0),
        ("1.0\n1\n1 2 1 0\n", 3),
        ("1.0\n1\n1 2 1 0 nan\n", 3),
        ("1.0\n1\n1 2 1 2 1\n", 3),
        ("1.0\n1\n1 2 -1 0 1\n", 3),
        ("1.0\n1\n1 2 1 0 1\n1 2 1 0 1\n", 4),
        ("1.0\n-1\n", 2),
        ("1.0\n1.5\n", 2),
    ];
    for (text, line) in bad {
        match read_regions(text.as_bytes()) {
            Err(MserError::Parse { line: l, .. }) => assert_eq!(l, line, "{text:?}"),
            other => panic!("{text:?}: expected a parse error, got {other:?}"),
        }
    }
}

#[test]
fn unreadable_file_is_an_io_error() {
    let err = mser::load_regions("/nonexistent/dir/file.mser").unwrap_err();
    assert!(matches!(err, MserError::Io(_)));
    // It names the file.
    assert!(
        err.to_string().contains("/nonexistent/dir/file.mser"),
        "{err}"
    );
}

/// Issue 24 #2: a header announcing a huge descriptor length or region count is a parse error
/// naming the limit (it used to overflow `5 + dim` and panic), before anything is allocated.
#[test]
fn huge_headers_are_rejected_with_the_limit() {
    let bad = [
        ("1e300\n1\n1 2 3 4\n", 1),
        ("18446744073709551616\n1\n1 2 1 0 1\n", 1),
        ("65537\n1\n1 2 1 0 1\n", 1),
        ("1\n1e300\n1 2 1 0 1\n", 2),
        ("1\n16777217\n1 2 1 0 1\n", 2),
    ];
    for (text, line) in bad {
        match read_regions(text.as_bytes()) {
            Err(MserError::Parse { line: l, reason }) => {
                assert_eq!(l, line, "{text:?}");
                assert!(reason.contains("limit"), "{text:?}: {reason}");
            }
            other => panic!("{text:?}: expected a parse error, got {other:?}"),
        }
    }
    // At the limits the header is accepted (the lines then decide).
    let text = format!("{}\n1\n1 2 1 0 1\n", mser::MAX_DESCRIPTOR_LEN);
    assert!(matches!(
        read_regions(text.as_bytes()),
        Err(MserError::Parse { line: 3, .. })
    ));
    let text = format!("1\n{}\n1 2 1 0 1\n", mser::MAX_REGIONS);
    assert!(matches!(
        read_regions(text.as_bytes()),
        Err(MserError::Parse { line: 0, .. })
    ));
}

/// `save_regions` writes under a temporary name and renames (it used to write the target in
/// place, so a failure part-way, a full disk say, left a truncated region file): a save that
/// fails after writing leaves no temporary file behind and keeps what was at the target.
#[test]
fn a_failed_save_leaves_no_partial_file() {
    let dir = std::env::temp_dir().join(format!("mser-save-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let es = [Ellipse {
        u: 1.5,
        v: 2.25,
        a: 0.1,
        b: -0.01,
        c: 0.2,
    }];
    let good = dir.join("good.mser");
    mser::save_regions(&good, &es).unwrap();
    let before = std::fs::read(&good).unwrap();
    assert_eq!(mser::load_regions(&good).unwrap()[0].ellipse, es[0]);
    // The target is a non-empty directory: everything is written, then the rename fails.
    let blocked = dir.join("blocked.mser");
    std::fs::create_dir_all(blocked.join("inside")).unwrap();
    assert!(matches!(
        mser::save_regions(&blocked, &es),
        Err(MserError::Io(_))
    ));
    assert!(blocked.join("inside").is_dir());
    // A file in a missing folder: nothing is created.
    assert!(mser::save_regions(dir.join("missing/x.mser"), &es).is_err());
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["blocked.mser", "good.mser"]);
    assert_eq!(std::fs::read(&good).unwrap(), before);
    // An ellipse the reader would refuse: nothing written (it used to replace the good file
    // with one `load_regions` refuses).
    let bad = Ellipse {
        u: f64::NAN,
        ..es[0]
    };
    assert!(matches!(
        mser::save_regions(&good, &[es[0], bad]),
        Err(MserError::InvalidParameter {
            name: "ellipses",
            ..
        })
    ));
    assert_eq!(std::fs::read(&good).unwrap(), before);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A valid ellipse (positive definite), the base of the refused ones.
const GOOD: Ellipse = Ellipse {
    u: 1.5,
    v: 2.25,
    a: 0.1,
    b: -0.01,
    c: 0.2,
};

/// The writer refuses exactly what the reader refuses, before writing a byte.
#[test]
fn unreadable_ellipses_are_not_written() {
    let good = GOOD;
    for bad in [
        Ellipse {
            u: f64::NAN,
            ..good
        },
        Ellipse {
            v: f64::INFINITY,
            ..good
        },
        Ellipse { a: -0.1, ..good },
        Ellipse { a: 0.0, ..good },
        Ellipse { b: 1.0, ..good },
        Ellipse {
            c: f64::NEG_INFINITY,
            ..good
        },
    ] {
        let mut buf = Vec::new();
        assert!(matches!(
            write_regions(&mut buf, &[good, bad]),
            Err(MserError::InvalidParameter {
                name: "ellipses",
                ..
            })
        ));
        assert!(buf.is_empty());
        // And the reader refuses what it would have written.
        let text = format!("0\n1\n{} {} {} {} {}\n", bad.u, bad.v, bad.a, bad.b, bad.c);
        assert!(matches!(
            read_regions(text.as_bytes()),
            Err(MserError::Parse { line: 3, .. })
        ));
    }
}

/// `save_regions` checked the ellipses only inside `write_regions`, after creating its
/// temporary file: a refused ellipse in a missing folder came back as an `Io` error instead of
/// the refusal, and a file already at the temporary name was truncated and deleted. The
/// ellipses are now checked before any file is touched.
#[test]
fn a_refused_save_touches_no_file() {
    let dir = std::env::temp_dir().join(format!("mser-refused-save-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let good = GOOD;
    let bad = Ellipse {
        a: f64::NAN,
        ..good
    };
    let refused = |r: mser::Result<()>| {
        matches!(
            r,
            Err(MserError::InvalidParameter {
                name: "ellipses",
                ..
            })
        )
    };
    // A missing folder: still the refusal, and nothing is created.
    assert!(refused(mser::save_regions(
        dir.join("missing/x.mser"),
        &[good, bad]
    )));
    // Whatever is in the folder, a file named like the first temporary file included, stays
    // as it was.
    let stale = dir.join(format!(".x.mser.partial-{}-0", std::process::id()));
    std::fs::write(&stale, b"someone else's").unwrap();
    let listing = |d: &std::path::Path| {
        let mut v: Vec<(String, Vec<u8>)> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| {
                let e = e.unwrap();
                (
                    e.file_name().to_string_lossy().into_owned(),
                    std::fs::read(e.path()).unwrap_or_default(),
                )
            })
            .collect();
        v.sort();
        v
    };
    let before = listing(&dir);
    assert!(refused(mser::save_regions(dir.join("x.mser"), &[bad])));
    assert_eq!(listing(&dir), before);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A fresh scratch folder for one test.
fn scratch_dir(what: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("mser-{what}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The names in `dir`, sorted.
fn names_in(dir: &std::path::Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// `n` distinct valid ellipses.
fn ellipses(n: usize) -> Vec<Ellipse> {
    (0..n)
        .map(|k| Ellipse {
            u: 1.5 + k as f64 / 7.0,
            v: 2.25 * k as f64,
            ..GOOD
        })
        .collect()
}

/// Set in the child process of [`in_child`]: the test runs its child part.
const CHILD: &str = "MSER_TEST_WRITE_CHILD";

/// Runs the test `test` of this binary alone in a child process whose working folder is `cwd`
/// (so the child can save to a bare file name), with [`CHILD`] set; with `limit`, under a file
/// size limit of one block (`ulimit -f 1`, 512 or 1024 bytes): a write past it fails with
/// `EFBIG`, like a full disk, even for root, with `SIGXFSZ` ignored so that it is an error
/// rather than the end of the process. Returns the child's standard output.
#[cfg(unix)]
fn in_child(test: &str, cwd: &std::path::Path, limit: bool) -> String {
    let run = r#"exec "$0" "$@""#;
    let script = if limit {
        format!("trap '' XFSZ; ulimit -f 1 && {run}")
    } else {
        run.to_string()
    };
    let out = std::process::Command::new("sh")
        .arg("-c")
        .arg(script)
        .arg(std::env::current_exe().unwrap())
        .args([test, "--exact", "--nocapture", "--test-threads=1"])
        .env(CHILD, "1")
        .current_dir(cwd)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success() && stdout.contains("1 passed"),
        "the child failed ({}): {stdout}\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
}

/// A bare file name (`Path::parent()` is `Some("")`) is saved into the working folder, with its
/// temporary file there too: nothing else is left behind.
#[cfg(unix)]
#[test]
fn a_save_to_a_bare_file_name_lands_in_the_working_folder() {
    if std::env::var_os(CHILD).is_some() {
        mser::save_regions("x.mser", &ellipses(3)).unwrap();
        return;
    }
    let dir = scratch_dir("bare");
    in_child(
        "oxford_io::a_save_to_a_bare_file_name_lands_in_the_working_folder",
        &dir,
        false,
    );
    assert_eq!(names_in(&dir), ["x.mser"]);
    let back = mser::load_regions(dir.join("x.mser")).unwrap();
    assert_eq!(
        back.iter().map(|r| r.ellipse).collect::<Vec<_>>(),
        ellipses(3)
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A save whose write fails part-way (a file size limit, as a full disk would) is an `Io`
/// error naming the file; the file already there keeps every byte, and no temporary file is
/// left. The text (a few kB) fits in the writer's buffer, so the failure shows only when the
/// buffer is flushed: a buffer dropped unflushed would swallow it and rename a truncated file
/// over the old one.
#[cfg(unix)]
#[test]
fn a_save_failing_part_way_keeps_the_old_file_and_leaves_nothing_else() {
    if std::env::var_os(CHILD).is_some() {
        match mser::save_regions("x.mser", &ellipses(60)) {
            Err(e @ MserError::Io(_)) => println!("refused: {e}"),
            other => panic!("expected an i/o error, got {other:?}"),
        }
        return;
    }
    let dir = scratch_dir("full");
    let path = dir.join("x.mser");
    mser::save_regions(&path, &ellipses(1)).unwrap();
    let before = std::fs::read(&path).unwrap();
    // Larger than the limit (at most 1024 bytes), smaller than the writer's 8 kB buffer.
    let mut text = Vec::new();
    write_regions(&mut text, &ellipses(60)).unwrap();
    assert!((2048..8192).contains(&text.len()), "{}", text.len());
    let out = in_child(
        "oxford_io::a_save_failing_part_way_keeps_the_old_file_and_leaves_nothing_else",
        &dir,
        true,
    );
    assert!(
        out.contains("refused: region file I/O: x.mser: File too large"),
        "{out}"
    );
    assert!(std::fs::read(&path).unwrap() == before, "x.mser changed");
    assert_eq!(names_in(&dir), ["x.mser"]);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Threads saving to one path at once all succeed and leave one whole file. The temporary name
/// was the process id only, so threads shared it: one renamed another's half-written file into
/// place, and the other's rename then failed (`No such file or directory`).
#[test]
fn concurrent_saves_to_one_path_all_succeed_and_leave_a_whole_file() {
    let dir = scratch_dir("concurrent");
    let path = dir.join("x.mser");
    let es = ellipses(2000);
    std::thread::scope(|s| {
        for _ in 0..4 {
            s.spawn(|| {
                for _ in 0..20 {
                    mser::save_regions(&path, &es).unwrap();
                }
            });
        }
    });
    assert_eq!(mser::load_regions(&path).unwrap().len(), es.len());
    assert_eq!(names_in(&dir), ["x.mser"]);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A failed save names the file: the target is a folder (the rename fails after everything
/// was written), the parent is a file, or missing. A path that names no file (`dir/..`, the
/// empty path) is refused before any file is created (a temporary file used to be written
/// under a made-up name and removed again).
#[test]
fn a_failed_save_names_the_path_and_leaves_no_temporary_file() {
    let dir = scratch_dir("failed");
    std::fs::create_dir_all(dir.join("x.mser").join("inside")).unwrap();
    std::fs::write(dir.join("file"), b"a file, not a folder").unwrap();
    for path in [
        dir.join("x.mser"),
        dir.join("file").join("x.mser"),
        dir.join("missing").join("x.mser"),
        dir.join("x.mser").join(".."),
        std::path::PathBuf::new(),
    ] {
        let e = mser::save_regions(&path, &ellipses(3)).unwrap_err();
        assert!(
            matches!(&e, MserError::Io(_)) && e.to_string().contains(&path.display().to_string()),
            "{}: {e}",
            path.display()
        );
    }
    assert_eq!(names_in(&dir), ["file", "x.mser"]);
    assert_eq!(names_in(&dir.join("x.mser")), ["inside"]);
    assert_eq!(
        std::fs::read(dir.join("file")).unwrap(),
        b"a file, not a folder"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
