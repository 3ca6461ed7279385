//! The CSV sequence format: round trip of generated sequences, line-precise errors.

use std::path::{Path, PathBuf};

use cbt_tracker::sim::{Level, Scenario, Ungm, generate};
use cbt_tracker::{TrackError, csv};

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("cbt-io-{}-{name}", std::process::id()));
    std::fs::remove_dir_all(&d).ok();
    d
}

#[test]
fn generated_sequences_round_trip() {
    let dir = temp_dir("roundtrip");
    let mut seqs = generate(&Scenario::default(), &Level::preset(3), 3, 80, 4);
    seqs.extend(Ungm::default().generate(2, 50, 9));
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
    assert_eq!(err(&format!("{h}99999999999,det,1,2\n")).0, 2);
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
