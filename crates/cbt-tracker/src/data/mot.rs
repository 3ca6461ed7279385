//! MOTChallenge ground truth: rows `frame,id,left,top,width,height[,flag,…]` (no header;
//! frames usually from 1), read as **one single-target sequence per id** whose truth is the
//! box centre `(left + width/2, top + height/2)`. The sequences hold no detections: the
//! caller simulates them ([`crate::sim::observe`]) or adds its detector's.
//!
//! Rules, each a [`TrackError::Csv`] naming the file and the line when broken:
//! at least six comma-separated fields; integer frame ≥ 0 and id (an integral number such as
//! `3` or `3.0`); finite coordinates and box centre; width and height ≥ 0; one row per id and frame; every
//! id annotated in at least two frames (a track of one frame has nothing to track); an id's
//! frames span at most [`crate::csv::MAX_SPAN`]. A 7th field equal to `0` is MOTChallenge's
//! "ignore" flag (static objects, reflections): such rows are not annotations of a target
//! and are left out, as the benchmark's own scoring does. A UTF-8 byte-order mark and blank
//! lines are ignored. Sequence `i` of file `gt.txt` is named `gt-id<ID>`, in increasing id
//! order; its [`Sequence::first_frame`] is the id's first annotated frame.
//!
//! ```
//! use cbt_tracker::mot;
//! let text = "1,7,10,20,4,8,1\n2,7,12,20,4,8,1\n1,9,0,0,2,2,0\n";
//! let seqs = mot::parse(text, "gt", std::path::Path::new("gt.txt")).unwrap();
//! assert_eq!(seqs.len(), 1);
//! assert_eq!(seqs[0].name, "gt-id7");
//! assert_eq!(seqs[0].first_frame, 1);
//! assert_eq!(seqs[0].frames[1].truth, Some([14.0, 24.0]));
//! ```

use std::collections::BTreeMap;
use std::path::Path;

use crate::csv::{Span, files, frame_number, line_error, lines, number, read_text, stem};
use crate::{Frame, Sequence, TrackError};

/// One id's annotations: (line, frame, centre) in file order, and its span.
#[derive(Default)]
struct Track {
    rows: Vec<(usize, u64, [f64; 2])>,
    span: Span,
}

/// Parses the text of one ground-truth file; `name` prefixes the sequence names, `path` is
/// used in error messages.
pub fn parse(text: &str, name: &str, path: &Path) -> Result<Vec<Sequence>, TrackError> {
    let err = |line: usize, reason: String| line_error(path, line, reason);
    let mut tracks: BTreeMap<i64, Track> = BTreeMap::new();
    for (ln, line) in lines(text) {
        let f: Vec<&str> = line.split(',').map(str::trim).collect();
        if f.len() < 6 {
            return Err(err(
                ln,
                format!(
                    "expected at least 6 fields `frame,id,left,top,width,height`, found {}",
                    f.len()
                ),
            ));
        }
        let k = frame_number(path, ln, f[0])?;
        let id =
            id_number(f[1]).ok_or_else(|| err(ln, format!("id `{}` is not an integer", f[1])))?;
        let left = number(path, ln, f[2], "left")?;
        let top = number(path, ln, f[3], "top")?;
        let w = number(path, ln, f[4], "width")?;
        let h = number(path, ln, f[5], "height")?;
        if w < 0.0 || h < 0.0 {
            return Err(err(ln, format!("negative box size {w} × {h}")));
        }
        if f.get(6).is_some_and(|flag| flag.parse::<f64>() == Ok(0.0)) {
            continue;
        }
        let centre = [left + 0.5 * w, top + 0.5 * h];
        if !centre.iter().all(|c| c.is_finite()) {
            return Err(err(
                ln,
                format!(
                    "box centre {centre:?} overflows (left {left}, width {w}, top {top}, height {h})"
                ),
            ));
        }
        let t = tracks.entry(id).or_default();
        t.span.add(path, ln, k)?;
        t.rows.push((ln, k, centre));
    }
    let mut out = Vec::with_capacity(tracks.len());
    for (id, t) in tracks {
        let (first, n) = t.span.first_and_len();
        let first_line = t.rows[0].0;
        let mut frames = vec![Frame::default(); n];
        for (ln, k, c) in t.rows {
            let f = &mut frames[(k - first) as usize];
            if f.truth.is_some() {
                return Err(err(ln, format!("a second row for id {id} in frame {k}")));
            }
            f.truth = Some(c);
        }
        if n < 2 {
            return Err(err(
                first_line,
                format!("id {id} is annotated in a single frame: a track needs at least two"),
            ));
        }
        out.push(Sequence {
            name: format!("{name}-id{id}"),
            first_frame: first,
            frames,
        });
    }
    Ok(out)
}

/// An integral id (`3` or `3.0`).
fn id_number(s: &str) -> Option<i64> {
    if let Ok(v) = s.parse::<i64>() {
        return Some(v);
    }
    let v: f64 = s.parse().ok()?;
    (v.is_finite() && v.fract() == 0.0 && v.abs() < 9e15).then_some(v as i64)
}

/// Reads one ground-truth file (sequence names prefixed by its stem).
pub fn read(path: &Path) -> Result<Vec<Sequence>, TrackError> {
    let text = read_text(path)?;
    parse(&text, &stem(path), path)
}

/// Reads every `*.txt` file of a folder, sorted by file name, into one list of sequences;
/// an error if there is none.
pub fn read_dir(dir: &Path) -> Result<Vec<Sequence>, TrackError> {
    let mut out = Vec::new();
    for p in files(dir, "txt")? {
        out.extend(read(&p)?);
    }
    Ok(out)
}
