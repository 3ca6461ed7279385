//! The CSV sequence format: round trip of generated sequences, line-precise errors.

use std::path::{Path, PathBuf};

use cbt_tracker::sim::observe;
use cbt_tracker::sim::{Level, Scenario, Ungm, generate};
use cbt_tracker::{Frame, Sequence, TrackError, csv, mot};

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("cbt-io-{}-{name}", std::process::id()));
    std::fs::remove_dir_all(&d).ok();
    d
}

#[test]
fn generated_sequences_round_trip() {
    let dir = temp_dir("roundtrip");
    let mut seqs = generate(&Scenario::default(), &Level::preset(3), 3, 80, 4).unwrap();
    seqs.extend(Ungm::default().generate(2, 50, 9).unwrap());
    for s in &seqs {
        csv::write(&dir, s).unwrap();
    }
    let mut back = csv::read_dir(&dir).unwrap();
    back.sort_by(|a, b| a.name.cmp(&b.name));
    seqs.sort_by(|a, b| a.name.cmp(&b.name));
    assert_eq!(back, seqs);
    std::fs::remove_dir_all(&dir).ok();
}

fn err(text: &str) -> (usize, String) {
    match csv::parse(text, "s", Path::new("s.csv")) {
        Err(TrackError::Csv { line, reason, path }) => {
            assert_eq!(path, Path::new("s.csv"));
            (line, reason)
        }
        other => panic!("expected a CSV error, got {other:?}"),
    }
}

#[test]
fn malformed_rows_name_their_line() {
    let h = "frame,kind,x,y\n";
    assert_eq!(err("").0, 0);
    assert_eq!(err("frame,kind,x\n").0, 1);
    assert_eq!(err(&format!("{h}0,truth,1,2\n0,det,1\n")).0, 3);
    assert_eq!(err(&format!("{h}0,truth,1,2\n-1,det,1,2\n")).0, 3);
    assert_eq!(err(&format!("{h}\n0,truth,1,2\n0,truth,1,2\n")).0, 4);
    let (line, reason) = err(&format!("{h}0,ghost,1,2\n"));
    assert_eq!(line, 2);
    assert!(reason.contains("ghost"));
    assert_eq!(err(&format!("{h}0,det,nan,2\n")).0, 2);
    assert_eq!(err(&format!("{h}0,det,1,abc\n")).0, 2);
    // A frame span beyond the limit is refused at the row that causes it, before any frame
    // is allocated.
    assert_eq!(err(&format!("{h}0,truth,1,2\n99999999999,det,1,2\n")).0, 3);
    assert_eq!(err(&format!("{h}10000000,truth,1,2\n0,det,1,2\n")).0, 3);
    // The error message shows file and line.
    let e = csv::parse(&format!("{h}0,det,1\n"), "s", Path::new("dir/s.csv")).unwrap_err();
    assert!(e.to_string().starts_with("dir/s.csv:2:"), "{e}");
}

#[test]
fn sparse_frames_and_blank_lines() {
    let s = csv::parse(
        "frame , kind, x, y\n\n2,det,1.5,2\n0,truth,3,4\n",
        "s",
        Path::new("s.csv"),
    )
    .unwrap();
    assert_eq!(s.frames.len(), 3);
    assert_eq!(s.frames[0].truth, Some([3.0, 4.0]));
    assert!(s.frames[1].truth.is_none() && s.frames[1].detections.is_empty());
    assert_eq!(s.frames[2].detections[0].pos, [1.5, 2.0]);
}

/// A frame without rows is stored only inside the sequence: empty frames at its start or end
/// are not written, so reading gives the frames from the first to the last with a row, with
/// `first_frame` moved to the first (as `csv::to_string` documents); no row at all reads as
/// an empty sequence from frame 0.
#[test]
fn empty_frames_at_either_end_are_not_stored() {
    let f = |x: Option<f64>| Frame {
        truth: x.map(|x| [x, 1.0]),
        detections: Vec::new(),
    };
    let s = Sequence {
        name: "e".into(),
        first_frame: 10,
        frames: vec![
            f(None),
            f(Some(2.0)),
            f(None),
            f(Some(3.0)),
            f(None),
            f(None),
        ],
    };
    let text = csv::to_string(&s);
    assert_eq!(text, "frame,kind,x,y\n11,truth,2,1\n13,truth,3,1\n");
    let back = csv::parse(&text, "e", Path::new("e.csv")).unwrap();
    assert_eq!(back.first_frame, 11);
    assert_eq!(back.frames, s.frames[1..4]);
    let dir = temp_dir("ends");
    let path = csv::write(&dir, &s).unwrap();
    assert_eq!(csv::read(&path).unwrap(), back);
    std::fs::remove_dir_all(&dir).ok();
    let blank = Sequence {
        name: "b".into(),
        first_frame: 7,
        frames: vec![f(None); 3],
    };
    let back = csv::parse(&csv::to_string(&blank), "b", Path::new("b.csv")).unwrap();
    assert_eq!((back.first_frame, back.frames.len()), (0, 0));
}

#[test]
fn unreadable_folders_are_errors() {
    assert!(matches!(
        csv::read_dir(Path::new("/nonexistent/cbt")),
        Err(TrackError::Io { .. })
    ));
    let dir = temp_dir("empty");
    std::fs::create_dir_all(&dir).unwrap();
    assert!(matches!(csv::read_dir(&dir), Err(TrackError::Io { .. })));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn files_start_at_any_frame_and_may_have_a_byte_order_mark() {
    // MOTChallenge-style numbering from 1, a gap, a BOM.
    let text = "\u{feff}frame,kind,x,y\n1,det,0.5,0.5\n2,truth,3,4\n2,det,3,4\n5,truth,6,7\n";
    let s = csv::parse(text, "s", Path::new("s.csv")).unwrap();
    assert_eq!(s.first_frame, 1);
    assert_eq!(s.frames.len(), 5);
    assert_eq!(s.start(), Some(1));
    assert_eq!(s.frames[1].truth, Some([3.0, 4.0]));
    assert!(s.frames[2].truth.is_none() && s.frames[3].detections.is_empty());
    assert_eq!(s.frames[4].truth, Some([6.0, 7.0]));
    // Written back with the same frame numbers (the BOM is not written).
    assert_eq!(
        csv::parse(&csv::to_string(&s), "s", Path::new("s.csv")).unwrap(),
        s
    );
    assert!(csv::to_string(&s).starts_with("frame,kind,x,y\n1,det,0.5,0.5\n"));
    // Frame ten million alone is one frame, not ten million.
    let far = csv::parse(
        "frame,kind,x,y\n10000000,truth,1,2\n",
        "f",
        Path::new("f.csv"),
    )
    .unwrap();
    assert_eq!((far.first_frame, far.frames.len()), (10_000_000, 1));
    // The span limit itself: exactly MAX_SPAN frames is accepted.
    let last = csv::MAX_SPAN - 1;
    let ok = format!("frame,kind,x,y\n0,truth,1,2\n{last},det,1,2\n");
    assert_eq!(
        csv::parse(&ok, "m", Path::new("m.csv"))
            .unwrap()
            .frames
            .len() as u64,
        csv::MAX_SPAN
    );
    // A file without truth has no start.
    let none = csv::parse("frame,kind,x,y\n3,det,1,2\n", "n", Path::new("n.csv")).unwrap();
    assert_eq!(none.start(), None);
}

fn mot_err(text: &str) -> (usize, String) {
    match mot::parse(text, "gt", Path::new("dir/gt.txt")) {
        Err(e @ TrackError::Csv { .. }) => {
            let TrackError::Csv {
                line,
                ref reason,
                ref path,
            } = e
            else {
                unreachable!()
            };
            assert_eq!(path, Path::new("dir/gt.txt"));
            assert!(
                e.to_string().starts_with(&format!("dir/gt.txt:{line}:")),
                "{e}"
            );
            (line, reason.clone())
        }
        other => panic!("expected a CSV error, got {other:?}"),
    }
}

#[test]
fn mot_ground_truth_is_one_sequence_per_id() {
    let text = "\u{feff}1,2,10,20,4,6,1,1,1\n2,2,12,20,4,6,1,1,1\n\n4,2,16,20,4,6,1,1,1\n\
                3,1.0,0,0,2,2,-1,-1,-1\n4,1,2,0,2,2,-1,-1,-1\n1,9,0,0,2,2,0,3,1\n";
    let seqs = mot::parse(text, "gt", Path::new("gt.txt")).unwrap();
    // Ids in increasing order; the ignored (flag 0) row of id 9 is no track.
    let names: Vec<&str> = seqs.iter().map(|s| s.name.as_str()).collect();
    assert_eq!(names, ["gt-id1", "gt-id2"]);
    assert_eq!(seqs[0].first_frame, 3);
    assert_eq!(seqs[0].frames[0].truth, Some([1.0, 1.0]));
    assert_eq!(seqs[0].frames[1].truth, Some([3.0, 1.0]));
    let s = &seqs[1];
    assert_eq!((s.first_frame, s.frames.len()), (1, 4));
    assert_eq!(s.frames[0].truth, Some([12.0, 23.0]));
    assert_eq!(s.frames[2].truth, None);
    assert_eq!(s.frames[3].truth, Some([18.0, 23.0]));
    assert!(s.frames.iter().all(|f| f.detections.is_empty()));
}

#[test]
fn bad_mot_rows_name_file_and_line() {
    let ok = "1,1,0,0,2,2\n2,1,1,0,2,2\n";
    // An id annotated in one frame: the line of its row.
    let (line, reason) = mot_err(&format!("{ok}5,3,0,0,2,2\n"));
    assert_eq!(line, 3);
    assert!(
        reason.contains("id 3") && reason.contains("single frame"),
        "{reason}"
    );
    // NaN, infinite, negative sizes, too few fields, bad frame or id.
    assert_eq!(mot_err(&format!("{ok}3,1,NaN,0,2,2\n")).0, 3);
    assert_eq!(mot_err(&format!("{ok}3,1,0,inf,2,2\n")).0, 3);
    let (line, reason) = mot_err(&format!("{ok}3,1,0,0,-2,2\n"));
    assert_eq!(line, 3);
    assert!(reason.contains("negative"), "{reason}");
    assert_eq!(mot_err(&format!("{ok}3,1,0,0,2,-0.5\n")).0, 3);
    // Finite fields whose box centre overflows (fuzz target `tracking_mot`).
    let (line, reason) = mot_err(&format!("{ok}3,1,1e308,0,1.7e308,1\n"));
    assert_eq!(line, 3);
    assert!(reason.contains("overflows"), "{reason}");
    assert_eq!(mot_err(&format!("{ok}3,1,0,1.7e308,1,1.7e308\n")).0, 3);
    assert_eq!(mot_err(&format!("{ok}3,1,0,0,2\n")).0, 3);
    assert_eq!(mot_err(&format!("{ok}-3,1,0,0,2,2\n")).0, 3);
    assert_eq!(mot_err(&format!("{ok}3,1.5,0,0,2,2\n")).0, 3);
    // A duplicate row of an id in a frame: the second row's line.
    let (line, reason) = mot_err(&format!("{ok}\n2,1,5,5,2,2\n"));
    assert_eq!(line, 4);
    assert!(reason.contains("second row"), "{reason}");
    // A duplicate of a single frame is a duplicate, not a one-frame track.
    assert!(
        mot_err("7,4,0,0,1,1\n7,4,0,0,1,1\n")
            .1
            .contains("second row")
    );
    // Huge frame numbers: refused by span at the row, never allocated.
    assert_eq!(mot_err(&format!("{ok}10000001,1,0,0,2,2\n")).0, 3);
    let far = mot::parse(
        "10000000,1,0,0,2,2\n10000001,1,0,0,2,2\n",
        "g",
        Path::new("g.txt"),
    );
    assert_eq!(far.unwrap()[0].frames.len(), 2);
}

#[test]
fn mot_folders_read_every_txt_file() {
    let dir = temp_dir("mot");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("a.txt"), "1,1,0,0,2,2\n2,1,1,0,2,2\n").unwrap();
    std::fs::write(dir.join("b.txt"), "1,4,0,0,2,2\n2,4,1,0,2,2\n").unwrap();
    std::fs::write(dir.join("notes.md"), "not a sequence").unwrap();
    let seqs = mot::read_dir(&dir).unwrap();
    let names: Vec<&str> = seqs.iter().map(|s| s.name.as_str()).collect();
    assert_eq!(names, ["a-id1", "b-id4"]);
    std::fs::write(dir.join("c.txt"), "1,4,0,0,2,2\n").unwrap();
    match mot::read_dir(&dir) {
        Err(TrackError::Csv { path, line, .. }) => {
            assert_eq!(path, dir.join("c.txt"));
            assert_eq!(line, 1);
        }
        other => panic!("expected a CSV error, got {other:?}"),
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn simulated_detections_follow_the_level() {
    let track = Sequence {
        name: "t".into(),
        first_frame: 4,
        frames: (0..400)
            .map(|k| Frame {
                truth: (k % 50 != 7).then_some([100.0 + 0.1 * k as f64, 80.0]),
                detections: Vec::new(),
            })
            .collect(),
    };
    let area = [0.0, 300.0, 0.0, 200.0];
    let level = Level {
        name: "x".into(),
        clutter_rate: 2.0,
        p_detect: 0.8,
        noise_sigma: 3.0,
    };
    let s = observe(&track, &level, area, 5, 1).unwrap();
    assert_eq!(s, observe(&track, &level, area, 5, 1).unwrap());
    assert_ne!(s, observe(&track, &level, area, 5, 2).unwrap());
    assert_eq!((s.first_frame, s.frames.len()), (4, 400));
    let (mut near, mut total, mut truths) = (0usize, 0usize, 0usize);
    for (f, t) in s.frames.iter().zip(&track.frames) {
        assert_eq!(f.truth, t.truth);
        total += f.detections.len();
        for d in &f.detections {
            assert!(d.pos[0] >= 0.0 && d.pos[0] <= 300.0 && d.pos[1] >= 0.0 && d.pos[1] <= 200.0);
        }
        if let Some(t) = t.truth {
            truths += 1;
            if f.detections
                .iter()
                .any(|d| (d.pos[0] - t[0]).hypot(d.pos[1] - t[1]) < 12.0)
            {
                near += 1;
            }
        }
    }
    // About P_D of the truth frames have a detection near the truth (clutter adds a little);
    // about clutter + P_D detections a frame.
    let rate = near as f64 / truths as f64;
    assert!((0.74..0.88).contains(&rate), "{rate}");
    let per_frame = total as f64 / 400.0;
    assert!((2.5..3.1).contains(&per_frame), "{per_frame}");
}

/// `csv::write` replaces a file whole (it used to write in place, so a failure part-way left a
/// truncated sequence): a write whose rename fails leaves no temporary file, and what was in the
/// folder stays as it was.
#[test]
fn a_failed_write_leaves_no_partial_file() {
    let dir = temp_dir("atomic");
    let seqs = generate(&Scenario::default(), &Level::preset(1), 2, 20, 5).unwrap();
    let first = csv::write(&dir, &seqs[0]).unwrap();
    let before = std::fs::read(&first).unwrap();
    // The second sequence's target is a non-empty folder: the text is written, the rename fails.
    let blocked = dir.join(format!("{}.csv", seqs[1].name));
    std::fs::create_dir_all(blocked.join("inside")).unwrap();
    assert!(matches!(
        csv::write(&dir, &seqs[1]),
        Err(TrackError::Io { .. })
    ));
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    let mut want = vec![
        first.file_name().unwrap().to_string_lossy().into_owned(),
        blocked.file_name().unwrap().to_string_lossy().into_owned(),
    ];
    want.sort();
    assert_eq!(names, want);
    assert_eq!(std::fs::read(&first).unwrap(), before);
    std::fs::remove_dir_all(&dir).ok();
}

/// A sequence `read` would refuse is refused by `write`, before anything is written (not even
/// the folder is created); a frame number past `u64::MAX` used to overflow in `to_string` (a
/// panic, or frame 0 in release).
#[test]
fn unreadable_sequences_are_not_written() {
    let dir = temp_dir("unreadable");
    let one = |first_frame: u64, truth: [f64; 2], n: usize| Sequence {
        name: "bad".into(),
        first_frame,
        frames: vec![
            Frame {
                truth: Some(truth),
                detections: Vec::new(),
            };
            n
        ],
    };
    for (s, what) in [
        (one(0, [f64::NAN, 1.0], 2), "NonFinite"),
        (one(0, [1.0, f64::INFINITY], 2), "NonFinite"),
        (one(u64::MAX, [1.0, 2.0], 2), "InvalidParameter"),
        (
            one(0, [1.0, 2.0], csv::MAX_SPAN as usize + 1),
            "InvalidParameter",
        ),
    ] {
        let e = csv::write(&dir, &s).unwrap_err();
        assert!(format!("{e:?}").starts_with(what), "{e:?}");
        // Nothing at all: not even the folder, which a valid write creates.
        assert!(!dir.exists(), "{what}: a refused write created {dir:?}");
    }
    // The text of an overflowing sequence names the true frame numbers, which reading refuses.
    let text = csv::to_string(&one(u64::MAX, [1.0, 2.0], 2));
    assert!(text.ends_with("18446744073709551615,truth,1,2\n18446744073709551616,truth,1,2\n"));
    assert!(matches!(
        csv::parse(&text, "bad", Path::new("bad.csv")),
        Err(TrackError::Csv { line: 3, .. })
    ));
    // The last frame number u64::MAX itself is fine.
    let s = one(u64::MAX - 1, [1.0, 2.0], 2);
    assert_eq!(csv::read(&csv::write(&dir, &s).unwrap()).unwrap(), s);
    // A name is a file stem in `dir`: one that would land elsewhere (or nowhere) is refused.
    let inner = dir.join("inner");
    for name in ["../escaped", "a/b", "a\\b", "", ".", ".."] {
        let s = Sequence {
            name: name.into(),
            ..one(0, [1.0, 2.0], 2)
        };
        let e = csv::write(&inner, &s).unwrap_err();
        assert!(matches!(e, TrackError::Io { .. }), "{name:?}: {e:?}");
    }
    assert!(!inner.exists() && !dir.join("escaped.csv").exists());
    std::fs::remove_dir_all(&dir).ok();
}

/// The names in `dir`, sorted.
fn names_in(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// Set in the child process of [`in_child`]: the test runs its child part.
const CHILD: &str = "CBT_TRACKER_TEST_WRITE_CHILD";

/// Runs the test `test` of this binary alone in a child process whose working folder is `cwd`
/// (so the child can write to the working folder, `""`), with [`CHILD`] set; with `limit`,
/// under a file size limit of one block (`ulimit -f 1`, 512 or 1024 bytes): a write past it
/// fails with `EFBIG`, like a full disk, even for root, with `SIGXFSZ` ignored so that it is an
/// error rather than the end of the process. Returns the child's standard output.
#[cfg(unix)]
fn in_child(test: &str, cwd: &Path, limit: bool) -> String {
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

/// Two generated sequences of `frames` frames each.
fn two_sequences(frames: usize) -> Vec<Sequence> {
    generate(&Scenario::default(), &Level::preset(1), 2, frames, 5).unwrap()
}

/// The folder `""` (and `.`) is the working folder: the file lands there, with its temporary
/// file there too, and nothing else is left behind.
#[cfg(unix)]
#[test]
fn a_write_to_the_working_folder_lands_there() {
    let seqs = two_sequences(20);
    if std::env::var_os(CHILD).is_some() {
        let first = csv::write(Path::new(""), &seqs[0]).unwrap();
        let second = csv::write(Path::new("."), &seqs[1]).unwrap();
        println!("wrote {first:?} and {second:?}");
        return;
    }
    let dir = temp_dir("working-folder");
    std::fs::create_dir_all(&dir).unwrap();
    in_child("io::a_write_to_the_working_folder_lands_there", &dir, false);
    let mut want: Vec<String> = seqs.iter().map(|s| format!("{}.csv", s.name)).collect();
    want.sort();
    assert_eq!(names_in(&dir), want);
    for s in &seqs {
        assert_eq!(csv::read(&dir.join(format!("{}.csv", s.name))).unwrap(), *s);
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A write that fails part-way (a file size limit, as a full disk would) is an `Io` error
/// naming the file; the file already there keeps every byte, and no temporary file is left.
#[cfg(unix)]
#[test]
fn a_write_failing_part_way_keeps_the_old_file_and_leaves_nothing_else() {
    let long = two_sequences(300).remove(0);
    if std::env::var_os(CHILD).is_some() {
        match csv::write(Path::new(""), &long) {
            Err(TrackError::Io { path, reason }) => println!("refused: {path:?}, {reason}"),
            other => panic!("expected an i/o error, got {other:?}"),
        }
        return;
    }
    let dir = temp_dir("full");
    let short = Sequence {
        frames: long.frames[..3].to_vec(),
        ..long.clone()
    };
    let path = csv::write(&dir, &short).unwrap();
    let before = std::fs::read(&path).unwrap();
    // Larger than the limit (at most 1024 bytes).
    assert!(csv::to_string(&long).len() > 4096);
    let out = in_child(
        "io::a_write_failing_part_way_keeps_the_old_file_and_leaves_nothing_else",
        &dir,
        true,
    );
    assert!(
        out.contains(&format!("refused: \"{}.csv\", File too large", long.name)),
        "{out}"
    );
    assert!(std::fs::read(&path).unwrap() == before, "{path:?} changed");
    assert_eq!(names_in(&dir), [format!("{}.csv", long.name)]);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A write that fails after everything was written (the target is a folder, so the rename
/// fails) or before (the folder is a file) is an `Io` error naming the path, and leaves
/// nothing behind.
#[test]
fn a_failed_write_names_the_path_and_leaves_no_temporary_file() {
    let dir = temp_dir("failed-names");
    let s = two_sequences(20).remove(0);
    let target = dir.join(format!("{}.csv", s.name));
    std::fs::create_dir_all(target.join("inside")).unwrap();
    std::fs::write(dir.join("file"), b"a file, not a folder").unwrap();
    for (folder, named) in [
        (dir.clone(), target.clone()),
        (dir.join("file"), dir.join("file")),
    ] {
        match csv::write(&folder, &s) {
            Err(TrackError::Io { path, .. }) => assert_eq!(path, named),
            other => panic!("{folder:?}: expected an i/o error, got {other:?}"),
        }
    }
    let mut want = ["file".to_string(), format!("{}.csv", s.name)];
    want.sort();
    assert_eq!(names_in(&dir), want);
    assert_eq!(names_in(&target), ["inside"]);
    assert_eq!(
        std::fs::read(dir.join("file")).unwrap(),
        b"a file, not a folder"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
