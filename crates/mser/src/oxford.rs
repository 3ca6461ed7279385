//! The region files of the Oxford affine benchmark (Mikolajczyk's `repeatability.m`, VLBenchmarks):
//! a text file whose first line is the descriptor length (0 or 1 meaning none), the second the
//! number of regions, then one line `u v a b c [descriptor…]` per region, with the ellipse
//! `a (x−u)² + 2b (x−u)(y−v) + c (y−v)² = 1` in 0-based pixel coordinates.
//!
//! Sizes a file can request are bounded before anything is allocated: the descriptor length by
//! [`MAX_DESCRIPTOR_LEN`] and the region count by [`MAX_REGIONS`]; larger values are an
//! [`MserError::Parse`] naming the limit.
//!
//! Numbers are written by the standard library's `Display` (shortest round-trip digits, never
//! an exponent). zmij (Schubfach), about five times faster, was measured and not adopted: where
//! a value lies exactly halfway between two shortest 17-digit decimals it rounds to even where
//! `Display` rounds up (444 of 67,922 random bit patterns of the non-exponent range, e.g.
//! 274173172323848.625). A region's centre is a pixel sum over its area, so an area of 2¹⁵ or
//! 2¹⁶ pixels can give such a value (an odd sum over 2¹⁵ at a 3-digit coordinate has 18 exact
//! digits ending in 5), and the files would change, for 0.3 ms per 640×480 image.

use std::io::{BufRead, Write};
use std::path::Path;

use crate::error::{MserError, Result};
use crate::region::Ellipse;

/// Largest descriptor length a region file may announce (2¹⁶; SIFT has 128 values).
pub const MAX_DESCRIPTOR_LEN: usize = 1 << 16;

/// Largest region count a region file may announce (2²⁴, far above the few thousand regions
/// per image of the benchmark).
pub const MAX_REGIONS: usize = 1 << 24;

/// One region of a region file: its ellipse and (possibly empty) descriptor.
#[derive(Debug, Clone, PartialEq)]
pub struct OxfordRegion {
    /// The ellipse.
    pub ellipse: Ellipse,
    /// The descriptor (empty when the file has none).
    pub descriptor: Vec<f64>,
}

/// Why a region file may not hold this ellipse: every number finite, `a > 0` and
/// `ac − b² > 0`; `None` when it may. The one check of the reader and the writers.
fn ellipse_fault(e: &Ellipse) -> Option<&'static str> {
    if ![e.u, e.v, e.a, e.b, e.c].iter().all(|v| v.is_finite()) {
        Some("non-finite number")
    } else if !(e.a > 0.0 && e.a * e.c - e.b * e.b > 0.0) {
        Some("ellipse is not positive definite")
    } else {
        None
    }
}

/// The first ellipse a region file may not hold, as the writers' [`MserError::InvalidParameter`].
fn check_ellipses(ellipses: &[Ellipse]) -> Result<()> {
    for (i, e) in ellipses.iter().enumerate() {
        if let Some(fault) = ellipse_fault(e) {
            return Err(MserError::InvalidParameter {
                name: "ellipses",
                reason: format!("ellipse {i} {e:?}: {fault}"),
            });
        }
    }
    Ok(())
}

/// Writes ellipses without descriptors. The numbers are written with Rust's shortest
/// round-trip formatting, so [`read_regions`] gets the same `f64` values back. An ellipse
/// [`read_regions`] would refuse (a non-finite number, not positive definite) is an
/// [`MserError::InvalidParameter`] before anything is written.
pub fn write_regions<W: Write>(w: W, ellipses: &[Ellipse]) -> Result<()> {
    check_ellipses(ellipses)?;
    Ok(write_checked(w, ellipses)?)
}

/// [`write_regions`] of ellipses already checked ([`check_ellipses`]).
fn write_checked<W: Write>(mut w: W, ellipses: &[Ellipse]) -> std::io::Result<()> {
    writeln!(w, "1.0")?;
    writeln!(w, "{}", ellipses.len())?;
    for e in ellipses {
        writeln!(w, "{} {} {} {} {}", e.u, e.v, e.a, e.b, e.c)?;
    }
    w.flush()?;
    Ok(())
}

/// Writes ellipses to a file; see [`write_regions`]. An ellipse it refuses is refused before
/// any file is created, with the same [`MserError::InvalidParameter`] whatever the folder: no
/// file is touched; so is a path that names no file (`dir/..`). The file is written under a
/// temporary name beside `path` (unique per process and call, so concurrent saves to one path
/// do not share it), flushed to disk and renamed over `path` only when everything was written,
/// so a failed write leaves no partial file (and an existing file at `path` unchanged). An I/O
/// error is an [`MserError::Io`] whose message names `path`.
pub fn save_regions(path: impl AsRef<Path>, ellipses: &[Ellipse]) -> Result<()> {
    use std::sync::atomic::{AtomicU64, Ordering};
    static SAVES: AtomicU64 = AtomicU64::new(0);
    // Before the temporary file exists: a refused ellipse touches no file (and is reported as
    // such, not as whatever I/O error the folder would have given).
    check_ellipses(ellipses)?;
    let path = path.as_ref();
    let named = |e| io_naming(path, e);
    let name = path.file_name().ok_or_else(|| {
        named(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "not a file path",
        ))
    })?;
    let mut tmp_name = std::ffi::OsString::from(".");
    tmp_name.push(name);
    tmp_name.push(format!(
        ".partial-{}-{}",
        std::process::id(),
        SAVES.fetch_add(1, Ordering::Relaxed)
    ));
    let tmp = path.with_file_name(tmp_name);
    let result = (|| {
        let mut w = std::io::BufWriter::new(std::fs::File::create(&tmp)?);
        write_checked(&mut w, ellipses)?;
        // `into_inner` flushes and reports a failed flush (dropping the writer would not).
        let f = w.into_inner().map_err(|e| e.into_error())?;
        // On disk before the rename: a crash soon after must not leave `path` empty or partial.
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    result.map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        named(e)
    })
}

/// Reads a region file. Every ellipse must be finite and positive definite (`a > 0`,
/// `ac − b² > 0`); each line must hold `5 + descriptor length` numbers; the count must match.
/// The descriptor length may be at most [`MAX_DESCRIPTOR_LEN`] and the count at most
/// [`MAX_REGIONS`].
pub fn read_regions<R: BufRead>(r: R) -> Result<Vec<OxfordRegion>> {
    let mut lines = r.lines().enumerate().filter_map(|(i, l)| match l {
        Ok(s) if s.trim().is_empty() => None,
        other => Some((i + 1, other)),
    });
    let parse_err = |line, reason: String| MserError::Parse { line, reason };
    let mut header = |what: &str, limit: usize| -> Result<usize> {
        let (no, l) = lines
            .next()
            .ok_or_else(|| parse_err(0, format!("missing {what} line")))?;
        let l = l?;
        let v: f64 = l
            .trim()
            .parse()
            .map_err(|_| parse_err(no, format!("{what} `{}` is not a number", l.trim())))?;
        if !(v.is_finite() && v >= 0.0 && v.fract() == 0.0) {
            return Err(parse_err(no, format!("{what} {v} is not a whole number")));
        }
        if v > limit as f64 {
            return Err(parse_err(
                no,
                format!("{what} {v} exceeds the limit {limit}"),
            ));
        }
        Ok(v as usize)
    };
    let dim = header("descriptor length", MAX_DESCRIPTOR_LEN)?;
    let count = header("region count", MAX_REGIONS)?;
    let dim = if dim <= 1 { 0 } else { dim };
    let mut out = Vec::with_capacity(count.min(1 << 16));
    for (no, l) in lines {
        let l = l?;
        if out.len() == count {
            return Err(parse_err(
                no,
                format!("more than the announced {count} regions"),
            ));
        }
        let nums: Vec<f64> = l
            .split_whitespace()
            .map(|t| t.parse::<f64>())
            .collect::<std::result::Result<_, _>>()
            .map_err(|_| parse_err(no, "a field is not a number".into()))?;
        // `nums.len() - 5`, not `5 + dim`: a huge announced length must not overflow.
        if nums.len() < 5 || nums.len() - 5 != dim {
            return Err(parse_err(
                no,
                format!("{} fields, expected 5 + {dim}", nums.len()),
            ));
        }
        if nums.iter().any(|v| !v.is_finite()) {
            return Err(parse_err(no, "non-finite number".into()));
        }
        let e = Ellipse {
            u: nums[0],
            v: nums[1],
            a: nums[2],
            b: nums[3],
            c: nums[4],
        };
        if let Some(fault) = ellipse_fault(&e) {
            return Err(parse_err(no, fault.into()));
        }
        out.push(OxfordRegion {
            ellipse: e,
            descriptor: nums[5..].to_vec(),
        });
    }
    if out.len() != count {
        return Err(parse_err(
            0,
            format!("announced {count} regions, found {}", out.len()),
        ));
    }
    Ok(out)
}

/// An I/O error of the file `path` as an [`MserError::Io`] whose message names it (keeping the
/// error's kind).
fn io_naming(path: &Path, e: std::io::Error) -> MserError {
    MserError::Io(std::io::Error::new(
        e.kind(),
        format!("{}: {e}", path.display()),
    ))
}

/// Reads a region file from disk; see [`read_regions`]. A file that cannot be opened or read
/// is an [`MserError::Io`] whose message names `path` (as [`save_regions`]'s do).
pub fn load_regions(path: impl AsRef<Path>) -> Result<Vec<OxfordRegion>> {
    let path = path.as_ref();
    let named = |e| io_naming(path, e);
    let f = std::fs::File::open(path).map_err(named)?;
    read_regions(std::io::BufReader::new(f)).map_err(|e| match e {
        MserError::Io(e) => named(e),
        other => other,
    })
}
