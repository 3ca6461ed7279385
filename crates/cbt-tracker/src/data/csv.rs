//! The plain sequence format: one CSV file per sequence, header `frame,kind,x,y`, rows
//! `FRAME,truth,X,Y` (at most one per frame: the true position) or `FRAME,det,X,Y` (zero or
//! more per frame: the detections, clutter included). Frames are non-negative integers in any
//! order; the sequence runs from the smallest frame number in the file
//! ([`Sequence::first_frame`]) to the largest, and a frame without rows is an empty frame (no
//! truth, no detection), so a file may start at frame 1 (as MOTChallenge files do) or at
//! frame 10,000,000 and have gaps. A track starts at its first frame with a truth row
//! ([`Sequence::start`]); detections before it are kept and not scored. A UTF-8 byte-order
//! mark and blank lines are ignored.
//!
//! **Limits.** A file may span at most [`MAX_SPAN`] frames (largest minus smallest frame
//! number plus one): the check runs on the rows before any frame is allocated, so a typo in a
//! frame number is a typed error, never a huge allocation. Every malformed row is an error
//! naming the file and the line; nothing is skipped silently. MOTChallenge ground truth is
//! read by [`crate::mot`].
//!
//! ```
//! use cbt_tracker::{csv, Detection, Frame, Sequence};
//! let s = Sequence {
//!     name: "demo".into(),
//!     first_frame: 3,
//!     frames: vec![Frame { truth: Some([1.5, 2.0]), detections: vec![Detection::new(1.0, 2.25)] }],
//! };
//! let text = csv::to_string(&s);
//! assert_eq!(text, "frame,kind,x,y\n3,truth,1.5,2\n3,det,1,2.25\n");
//! let back = csv::parse(&text, "demo", std::path::Path::new("demo.csv")).unwrap();
//! assert_eq!(back, s);
//! ```

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use crate::{Detection, Frame, Sequence, TrackError};

/// The header line.
pub const HEADER: &str = "frame,kind,x,y";

/// Largest number of frames one sequence file may span (largest frame number − smallest + 1):
/// a million frames, over nine hours at 30 Hz.
pub const MAX_SPAN: u64 = 1_000_000;

/// Formats a sequence (numbers in Rust's shortest round-trip form, so reading gives back
/// exactly the same values; detection weights are not stored). A frame without truth or
/// detections has no row: inside the sequence it reads back as an empty frame, but empty
/// frames at its start or end are not stored, so reading gives the frames from the first to
/// the last with a row ([`Sequence::first_frame`] moved to the first).
pub fn to_string(s: &Sequence) -> String {
    let mut out = String::from(HEADER);
    out.push('\n');
    for (k, f) in s.frames.iter().enumerate() {
        // Widened: a frame number past u64::MAX is written as it is (and refused on reading)
        // rather than overflowing.
        let k = u128::from(s.first_frame) + k as u128;
        if let Some(t) = f.truth {
            out.push_str(&format!("{k},truth,{},{}\n", t[0], t[1]));
        }
        for d in &f.detections {
            out.push_str(&format!("{k},det,{},{}\n", d.pos[0], d.pos[1]));
        }
    }
    out
}

/// An error at `line` (1-based; 0: the file as a whole) of `path`.
pub(crate) fn line_error(path: &Path, line: usize, reason: String) -> TrackError {
    TrackError::Csv {
        path: path.to_path_buf(),
        line,
        reason,
    }
}

/// The non-blank lines of a text with their 1-based numbers, a leading UTF-8 byte-order mark
/// removed.
pub(crate) fn lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    text.lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l))
        .filter(|(_, l)| !l.trim().is_empty())
}

/// A frame number field: a non-negative integer.
pub(crate) fn frame_number(path: &Path, line: usize, s: &str) -> Result<u64, TrackError> {
    s.parse().map_err(|_| {
        line_error(
            path,
            line,
            format!("frame `{s}` is not a non-negative integer"),
        )
    })
}

/// A finite number field.
pub(crate) fn number(path: &Path, line: usize, s: &str, what: &str) -> Result<f64, TrackError> {
    let v: f64 = s
        .parse()
        .map_err(|_| line_error(path, line, format!("{what} `{s}` is not a number")))?;
    if !v.is_finite() {
        return Err(line_error(
            path,
            line,
            format!("{what} `{s}` is not finite"),
        ));
    }
    Ok(v)
}

/// Tracks the smallest and largest frame number of a file and refuses a span beyond
/// [`MAX_SPAN`] at the row that causes it.
#[derive(Debug, Default, Clone, Copy)]
pub(crate) struct Span {
    range: Option<(u64, u64)>,
}

impl Span {
    /// Adds frame `k` of row `line`.
    pub fn add(&mut self, path: &Path, line: usize, k: u64) -> Result<(), TrackError> {
        let (lo, hi) = self.range.map_or((k, k), |(a, b)| (a.min(k), b.max(k)));
        if hi - lo >= MAX_SPAN {
            return Err(line_error(
                path,
                line,
                format!(
                    "frame {k} makes the sequence span frames {lo}..={hi}, more than the \
                     limit of {MAX_SPAN} frames"
                ),
            ));
        }
        self.range = Some((lo, hi));
        Ok(())
    }

    /// Smallest frame number and number of frames spanned (`(0, 0)` when empty).
    pub fn first_and_len(&self) -> (u64, usize) {
        self.range
            .map_or((0, 0), |(lo, hi)| (lo, (hi - lo + 1) as usize))
    }
}

/// One parsed row of the plain format.
struct Row {
    line: usize,
    frame: u64,
    truth: bool,
    pos: [f64; 2],
}

/// Parses the text of one sequence file; `path` is used in error messages.
pub fn parse(text: &str, name: &str, path: &Path) -> Result<Sequence, TrackError> {
    let err = |line: usize, reason: String| line_error(path, line, reason);
    let mut lines = lines(text);
    let (hl, header) = lines.next().ok_or_else(|| {
        err(
            0,
            "empty file: the header `frame,kind,x,y` is missing".into(),
        )
    })?;
    let cols: Vec<&str> = header.split(',').map(str::trim).collect();
    if cols != ["frame", "kind", "x", "y"] {
        return Err(err(
            hl,
            format!("expected the header `{HEADER}`, found `{}`", header.trim()),
        ));
    }
    let mut rows = Vec::new();
    let mut span = Span::default();
    for (ln, line) in lines {
        let f: Vec<&str> = line.split(',').map(str::trim).collect();
        if f.len() != 4 {
            return Err(err(ln, format!("expected 4 fields, found {}", f.len())));
        }
        let k = frame_number(path, ln, f[0])?;
        let truth = match f[1] {
            "truth" => true,
            "det" => false,
            other => {
                return Err(err(
                    ln,
                    format!("kind `{other}` is neither `truth` nor `det`"),
                ));
            }
        };
        let pos = [number(path, ln, f[2], "x")?, number(path, ln, f[3], "y")?];
        span.add(path, ln, k)?;
        rows.push(Row {
            line: ln,
            frame: k,
            truth,
            pos,
        });
    }
    let (first, n) = span.first_and_len();
    let mut frames = vec![Frame::default(); n];
    for r in rows {
        let f = &mut frames[(r.frame - first) as usize];
        if r.truth {
            if f.truth.is_some() {
                return Err(err(
                    r.line,
                    format!("a second truth row for frame {}", r.frame),
                ));
            }
            f.truth = Some(r.pos);
        } else {
            f.detections.push(Detection::new(r.pos[0], r.pos[1]));
        }
    }
    Ok(Sequence {
        name: name.to_string(),
        first_frame: first,
        frames,
    })
}

/// Reads one sequence file (name: the file stem).
pub fn read(path: &Path) -> Result<Sequence, TrackError> {
    let text = read_text(path)?;
    parse(&text, &stem(path), path)
}

/// The text of a file (an I/O error naming it).
pub(crate) fn read_text(path: &Path) -> Result<String, TrackError> {
    std::fs::read_to_string(path).map_err(|e| io(path, e))
}

/// A file's stem as a sequence name.
pub(crate) fn stem(path: &Path) -> String {
    path.file_stem()
        .map_or_else(String::new, |s| s.to_string_lossy().into_owned())
}

/// Reads every `*.csv` file of a folder, sorted by file name; an error if there is none.
pub fn read_dir(dir: &Path) -> Result<Vec<Sequence>, TrackError> {
    files(dir, "csv")?.iter().map(|p| read(p)).collect()
}

/// The files of a folder with the extension `ext`, sorted; an error if there is none.
pub(crate) fn files(dir: &Path, ext: &str) -> Result<Vec<PathBuf>, TrackError> {
    let mut paths: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| io(dir, e))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == ext))
        .collect();
    paths.sort();
    if paths.is_empty() {
        return Err(TrackError::Io {
            path: dir.to_path_buf(),
            reason: format!("no .{ext} sequence files in this folder"),
        });
    }
    Ok(paths)
}

/// Writes a sequence to `dir/<name>.csv`, atomically: the text goes to a temporary file beside
/// it (named by process id and a per-process counter), flushed and renamed over the target, so a
/// failed write leaves no partial file and an existing file unchanged. The text is
/// [`to_string`]'s (empty frames at either end of the sequence are not stored). A sequence [`read`]
/// would refuse (a non-finite coordinate, frame numbers beyond `u64` or spanning more than
/// [`MAX_SPAN`] frames), or a name that is not a plain file name (`../x`, `a/b`), is an error
/// before anything is written.
pub fn write(dir: &Path, s: &Sequence) -> Result<PathBuf, TrackError> {
    static NEXT: AtomicU64 = AtomicU64::new(0);
    check_name(dir, &s.name)?;
    check_readable(s)?;
    std::fs::create_dir_all(dir).map_err(|e| io(dir, e))?;
    let path = dir.join(format!("{}.csv", s.name));
    let k = NEXT.fetch_add(1, Ordering::Relaxed);
    let tmp = dir.join(format!(
        ".{}.csv.partial-{}-{k}",
        s.name,
        std::process::id()
    ));
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(to_string(s).as_bytes())?;
        f.sync_all()?;
        std::fs::rename(&tmp, &path)
    })();
    if let Err(e) = result {
        let _ = std::fs::remove_file(&tmp);
        return Err(io(&path, e));
    }
    Ok(path)
}

/// The sequence's name is its file's stem in `dir`: one plain file name (not empty, `.` or
/// `..`, no folder separator), so that the file lands in `dir` and nowhere else.
fn check_name(dir: &Path, name: &str) -> Result<(), TrackError> {
    let plain =
        !name.is_empty() && name != "." && name != ".." && !name.contains(['/', '\\', '\0']);
    if plain {
        return Ok(());
    }
    Err(TrackError::Io {
        path: dir.join(format!("{name}.csv")),
        reason: format!(
            "the sequence name {name:?} is not a plain file name (not empty, `.` or `..`, no \
             folder separator)"
        ),
    })
}

/// Checks that [`read`] would accept what [`to_string`] writes of `s` (and give it back up to
/// detection weights and empty frames at either end, which are not stored): finite
/// coordinates ([`TrackError::NonFinite`]) and frame numbers that are `u64` and span at most
/// [`MAX_SPAN`] frames ([`TrackError::InvalidParameter`]).
fn check_readable(s: &Sequence) -> Result<(), TrackError> {
    let n = s.frames.len() as u64;
    if n > MAX_SPAN {
        return Err(TrackError::InvalidParameter {
            name: "frames",
            value: n as f64,
            reason: "a sequence file spans at most MAX_SPAN (1,000,000) frames",
        });
    }
    if n > 0 && s.first_frame.checked_add(n - 1).is_none() {
        return Err(TrackError::InvalidParameter {
            name: "first_frame",
            value: s.first_frame as f64,
            reason: "the last frame number exceeds u64::MAX",
        });
    }
    crate::data::check_sequences(std::slice::from_ref(s))
}

fn io(path: &Path, e: std::io::Error) -> TrackError {
    TrackError::Io {
        path: path.to_path_buf(),
        reason: e.to_string(),
    }
}
