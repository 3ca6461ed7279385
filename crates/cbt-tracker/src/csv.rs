//! The plain sequence format: one CSV file per sequence, header `frame,kind,x,y`, rows
//! `FRAME,truth,X,Y` (at most one per frame: the true position) or `FRAME,det,X,Y` (zero or
//! more per frame: the detections, clutter included). Frames are non-negative integers; a
//! frame without rows is an empty frame (no truth, no detection). Blank lines are ignored.
//! Every malformed row is an error naming the file and the line; nothing is skipped silently.
//!
//! ```
//! use cbt_tracker::{csv, Detection, Frame, Sequence};
//! let s = Sequence {
//!     name: "demo".into(),
//!     frames: vec![Frame { truth: Some([1.5, 2.0]), detections: vec![Detection::new(1.0, 2.25)] }],
//! };
//! let text = csv::to_string(&s);
//! assert_eq!(text, "frame,kind,x,y\n0,truth,1.5,2\n0,det,1,2.25\n");
//! let back = csv::parse(&text, "demo", std::path::Path::new("demo.csv")).unwrap();
//! assert_eq!(back, s);
//! ```

use std::path::{Path, PathBuf};

use crate::{Detection, Frame, Sequence, TrackError};

/// The header line.
pub const HEADER: &str = "frame,kind,x,y";

/// Largest frame number accepted (guards against a typo allocating a huge sequence).
pub const MAX_FRAME: usize = 10_000_000;

/// Formats a sequence (numbers in Rust's shortest round-trip form, so reading gives back
/// exactly the same values; detection weights are not stored).
pub fn to_string(s: &Sequence) -> String {
    let mut out = String::from(HEADER);
    out.push('\n');
    for (k, f) in s.frames.iter().enumerate() {
        if let Some(t) = f.truth {
            out.push_str(&format!("{k},truth,{},{}\n", t[0], t[1]));
        }
        for d in &f.detections {
            out.push_str(&format!("{k},det,{},{}\n", d.pos[0], d.pos[1]));
        }
    }
    out
}

/// Parses the text of one sequence file; `path` is used in error messages.
pub fn parse(text: &str, name: &str, path: &Path) -> Result<Sequence, TrackError> {
    let err = |line: usize, reason: String| TrackError::Csv {
        path: path.to_path_buf(),
        line,
        reason,
    };
    let mut lines = text.lines().enumerate();
    let header = lines
        .by_ref()
        .find(|(_, l)| !l.trim().is_empty())
        .ok_or_else(|| {
            err(
                0,
                "empty file: the header `frame,kind,x,y` is missing".into(),
            )
        })?;
    let cols: Vec<&str> = header.1.split(',').map(str::trim).collect();
    if cols != ["frame", "kind", "x", "y"] {
        return Err(err(
            header.0 + 1,
            format!(
                "expected the header `{HEADER}`, found `{}`",
                header.1.trim()
            ),
        ));
    }
    let mut frames: Vec<Frame> = Vec::new();
    for (i, line) in lines {
        let ln = i + 1;
        if line.trim().is_empty() {
            continue;
        }
        let f: Vec<&str> = line.split(',').map(str::trim).collect();
        if f.len() != 4 {
            return Err(err(ln, format!("expected 4 fields, found {}", f.len())));
        }
        let k: usize = f[0].parse().map_err(|_| {
            err(
                ln,
                format!("frame `{}` is not a non-negative integer", f[0]),
            )
        })?;
        if k > MAX_FRAME {
            return Err(err(ln, format!("frame {k} exceeds the limit {MAX_FRAME}")));
        }
        let num = |s: &str, what: &str| -> Result<f64, TrackError> {
            let v: f64 = s
                .parse()
                .map_err(|_| err(ln, format!("{what} `{s}` is not a number")))?;
            if !v.is_finite() {
                return Err(err(ln, format!("{what} `{s}` is not finite")));
            }
            Ok(v)
        };
        let (x, y) = (num(f[2], "x")?, num(f[3], "y")?);
        if frames.len() <= k {
            frames.resize(k + 1, Frame::default());
        }
        match f[1] {
            "truth" => {
                if frames[k].truth.is_some() {
                    return Err(err(ln, format!("a second truth row for frame {k}")));
                }
                frames[k].truth = Some([x, y]);
            }
            "det" => frames[k].detections.push(Detection::new(x, y)),
            other => {
                return Err(err(
                    ln,
                    format!("kind `{other}` is neither `truth` nor `det`"),
                ));
            }
        }
    }
    Ok(Sequence {
        name: name.to_string(),
        frames,
    })
}

/// Reads one sequence file (name: the file stem).
pub fn read(path: &Path) -> Result<Sequence, TrackError> {
    let text = std::fs::read_to_string(path).map_err(|e| io(path, e))?;
    let name = path
        .file_stem()
        .map_or_else(String::new, |s| s.to_string_lossy().into_owned());
    parse(&text, &name, path)
}

/// Reads every `*.csv` file of a folder, sorted by file name; an error if there is none.
pub fn read_dir(dir: &Path) -> Result<Vec<Sequence>, TrackError> {
    let mut paths: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| io(dir, e))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "csv"))
        .collect();
    paths.sort();
    if paths.is_empty() {
        return Err(TrackError::Io {
            path: dir.to_path_buf(),
            reason: "no .csv sequence files in this folder".into(),
        });
    }
    paths.iter().map(|p| read(p)).collect()
}

/// Writes a sequence to `dir/<name>.csv`.
pub fn write(dir: &Path, s: &Sequence) -> Result<PathBuf, TrackError> {
    std::fs::create_dir_all(dir).map_err(|e| io(dir, e))?;
    let path = dir.join(format!("{}.csv", s.name));
    std::fs::write(&path, to_string(s)).map_err(|e| io(&path, e))?;
    Ok(path)
}

fn io(path: &Path, e: std::io::Error) -> TrackError {
    TrackError::Io {
        path: path.to_path_buf(),
        reason: e.to_string(),
    }
}
