//! Outputs written atomically: every folder the xtask writes is built in a temporary folder
//! beside its destination and renamed into place only when everything succeeded.
//!
//! - [`Destination::check`] validates a destination before anything is touched: it refuses a
//!   file, a symbolic link, the current folder, the repository folder and any folder above
//!   either, and a non-empty folder that does not carry our [`MARKER`] (a folder we did not
//!   write is never deleted). Every error names the path.
//! - [`Staged::new`] creates the temporary folder `PARENT/.NAME.partial-PID` (writing the marker
//!   into it first), [`Staged::path`] is where the command writes, and [`commit_all`] swaps the
//!   staged folders into place together: the old folder is renamed aside, the new one renamed
//!   in, the old one removed. A [`Staged`] dropped without a commit removes its folder.
//! - [`interrupt`] makes SIGINT, SIGTERM and SIGHUP remove every staged folder before the
//!   process exits; a commit in progress finishes first. So an interrupted command leaves each
//!   destination exactly as it was, or (when the signal came during the final swap) exactly as
//!   the complete new output.
//!
//! [`write_file`] is the same for a single file (temporary file, then rename); [`write_png`]
//! and [`write_svg`] encode or draw a picture in memory and write it with it.

pub mod interrupt;

use std::path::{Component, Path, PathBuf};

use crate::Result;

/// The file that marks a folder as an output of ours: `--out` replaces a non-empty folder only
/// when it carries this file.
pub const MARKER: &str = ".visguide-output";

/// The marker's text (the same in every output folder, so fixtures stay byte-identical).
const MARKER_TEXT: &str = "This folder is an output of visguide's `cargo xtask`. The xtask \
replaces it as a whole when it writes here again; files added here by hand are lost then.\n";

/// A validated destination folder (absolute), not yet touched.
#[derive(Debug, Clone)]
pub struct Destination {
    path: PathBuf,
}

impl Destination {
    /// Checks that `path` may be (re)written as a whole (see the module doc). `trusted` skips
    /// the marker check (the repository's own `fixtures/<target>/`, whose history is in git);
    /// the other checks always apply.
    pub fn check(path: &Path, trusted: bool) -> Result<Self> {
        let shown = path.display();
        let abs = normalise(path)
            .map_err(|e| format!("output folder {shown}: cannot resolve the path ({e})"))?;
        let Some(name) = abs.file_name() else {
            return Err(format!("output folder {shown}: refusing the file-system root").into());
        };
        if name.to_string_lossy().starts_with('.') && name.to_string_lossy().contains(".partial-") {
            return Err(format!("output folder {shown}: a temporary folder of the xtask").into());
        }
        let meta = std::fs::symlink_metadata(&abs);
        if let Ok(m) = &meta {
            if m.file_type().is_symlink() {
                return Err(format!(
                    "output folder {shown} is a symbolic link; name the folder itself"
                )
                .into());
            }
            if !m.is_dir() {
                return Err(format!("output folder {shown} exists and is not a folder").into());
            }
        }
        let resolved = resolve_existing(&abs);
        let cwd = std::env::current_dir().ok().map(|d| resolve_existing(&d));
        let repo = resolve_existing(&crate::workspace_root());
        for (what, protected) in [("the current folder", cwd), ("the repository", Some(repo))] {
            if let Some(p) = protected
                && p.starts_with(&resolved)
            {
                return Err(format!(
                    "output folder {shown} is {what} or holds it ({}); name a folder of its own",
                    p.display()
                )
                .into());
            }
        }
        if meta.is_ok() && !trusted && !is_empty_or_ours(&abs)? {
            return Err(format!(
                "output folder {shown} is not empty and is not an output of ours (no {MARKER} \
                 file): refusing to replace it; name a new or empty folder"
            )
            .into());
        }
        Ok(Destination { path: abs })
    }

    /// The destination's absolute path.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

/// Whether `dir` is empty or holds our marker.
fn is_empty_or_ours(dir: &Path) -> Result<bool> {
    if dir.join(MARKER).is_file() {
        return Ok(true);
    }
    let mut entries =
        std::fs::read_dir(dir).map_err(|e| format!("output folder {}: {e}", dir.display()))?;
    Ok(entries.next().is_none())
}

/// `path` made absolute (against the current folder) with `.` and `..` removed lexically.
fn normalise(path: &Path) -> std::io::Result<PathBuf> {
    let abs = std::path::absolute(path)?;
    let mut out = PathBuf::new();
    for c in abs.components() {
        match c {
            Component::ParentDir => {
                out.pop();
            }
            Component::CurDir => {}
            other => out.push(other),
        }
    }
    Ok(out)
}

/// `path` with its longest existing prefix canonicalised (symbolic links resolved), so that
/// two spellings of one folder compare equal.
fn resolve_existing(path: &Path) -> PathBuf {
    let mut head = path.to_path_buf();
    let mut tail = Vec::new();
    loop {
        if let Ok(c) = head.canonicalize() {
            let mut out = c;
            out.extend(tail.iter().rev());
            return out;
        }
        match (head.file_name().map(|n| n.to_os_string()), head.parent()) {
            (Some(n), Some(p)) => {
                tail.push(n);
                head = p.to_path_buf();
            }
            _ => return path.to_path_buf(),
        }
    }
}

/// Where a destination is staged: `PARENT/.NAME.partial-PID` (the one home of this naming).
pub fn staging_path(dest: &Path) -> PathBuf {
    let name = dest.file_name().unwrap_or_default().to_string_lossy();
    dest.with_file_name(format!(".{name}.partial-{}", std::process::id()))
}

/// The staged folder of the destination named like `staged`'s destination plus `suffix`
/// (`.NAME.partial-PID` → `.NAME{suffix}.partial-PID`, i.e. `NAME{suffix}` beside `NAME`). For a
/// folder that is not a staged one, `FOLDER{suffix}` beside it.
pub fn staged_sibling(staged: &Path, suffix: &str) -> PathBuf {
    let name = staged.file_name().unwrap_or_default().to_string_lossy();
    let tail = format!(".partial-{}", std::process::id());
    match name.strip_prefix('.').and_then(|n| n.strip_suffix(&tail)) {
        Some(dest) => staged.with_file_name(format!(".{dest}{suffix}{tail}")),
        None => staged.with_file_name(format!("{name}{suffix}")),
    }
}

/// A temporary folder beside a [`Destination`], registered with [`interrupt`]; removed when
/// dropped unless committed.
#[derive(Debug)]
pub struct Staged {
    dest: Destination,
    temp: PathBuf,
    /// Ancestors of the destination this staging created (removed again if never committed).
    created: Vec<PathBuf>,
    committed: bool,
}

impl Staged {
    /// Creates the temporary folder (and the destination's missing parents) and writes the
    /// marker into it.
    pub fn new(dest: &Destination) -> Result<Self> {
        let parent = dest.path.parent().expect("checked: not the root");
        let mut created = Vec::new();
        let mut missing = parent.to_path_buf();
        while !missing.exists() {
            created.push(missing.clone());
            if !missing.pop() {
                break;
            }
        }
        std::fs::create_dir_all(parent)
            .map_err(|e| format!("output folder {}: {e}", dest.path.display()))?;
        let temp = staging_path(&dest.path);
        let staged = Staged {
            dest: dest.clone(),
            temp: temp.clone(),
            created,
            committed: false,
        };
        interrupt::register(&temp);
        if temp.exists() {
            std::fs::remove_dir_all(&temp).map_err(|e| format!("{}: {e}", temp.display()))?;
        }
        std::fs::create_dir(&temp).map_err(|e| format!("{}: {e}", temp.display()))?;
        std::fs::write(temp.join(MARKER), MARKER_TEXT)
            .map_err(|e| format!("{}: {e}", temp.join(MARKER).display()))?;
        Ok(staged)
    }

    /// The folder to write into.
    pub fn path(&self) -> &Path {
        &self.temp
    }

    /// Whether nothing but the marker was written (an optional output that was not produced).
    pub fn is_unused(&self) -> bool {
        std::fs::read_dir(&self.temp)
            .map(|mut d| d.all(|e| e.is_ok_and(|e| e.file_name() == MARKER)))
            .unwrap_or(false)
    }
}

impl Drop for Staged {
    fn drop(&mut self) {
        if self.committed {
            return;
        }
        interrupt::discard(&self.temp);
        for d in &self.created {
            // Only folders that are still empty: never anything someone else put there.
            let _ = std::fs::remove_dir(d);
        }
    }
}

/// Moves every staged folder into place, with signals held off until all are done (a signal
/// that arrives meanwhile takes effect afterwards). The old contents of each destination are
/// renamed aside first and removed after the new folder is in place; if a rename fails, the
/// destination gets its old contents back and the error names it.
pub fn commit_all(staged: Vec<Staged>) -> Result<()> {
    let _hold = interrupt::hold();
    for mut s in staged {
        let dest = s.dest.path.clone();
        let name = dest.file_name().expect("checked").to_string_lossy();
        let aside = dest.with_file_name(format!(".{name}.old-{}", std::process::id()));
        let had_old = dest.exists();
        if had_old {
            std::fs::rename(&dest, &aside).map_err(|e| {
                format!(
                    "output folder {}: cannot move it aside ({e})",
                    dest.display()
                )
            })?;
        }
        if let Err(e) = std::fs::rename(&s.temp, &dest) {
            if had_old {
                let _ = std::fs::rename(&aside, &dest);
            }
            return Err(format!(
                "output folder {}: cannot move the new output in ({e})",
                dest.display()
            )
            .into());
        }
        s.committed = true;
        interrupt::forget(&s.temp);
        if had_old {
            std::fs::remove_dir_all(&aside)
                .map_err(|e| format!("{}: cannot remove the old output ({e})", aside.display()))?;
        }
    }
    Ok(())
}

/// Writes a file atomically with `visguide`'s writer ([`visguide::output::atomic::write_bytes`]):
/// into a new temporary file beside it (`.NAME.partial-PID-K`, unique per call, never an
/// existing file), flushed and synced, then renamed over `path`; creates the parent folder. A
/// failure leaves no partial file and the old file as it was; the error names `path`.
pub fn write_file(path: &Path, contents: impl AsRef<[u8]>) -> Result<()> {
    if path.file_name().is_none() {
        return Err(format!("{}: not a file name", path.display()).into());
    }
    if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).map_err(|e| format!("{}: {e}", parent.display()))?;
    }
    visguide::output::atomic::write_bytes(path, contents.as_ref())?;
    Ok(())
}

/// The bytes of a PNG file of `img`, encoded in memory: `image`'s own `save` leaves the end of
/// the file to a dropped buffer (and the PNG's last chunk to a dropped encoder), which ignore
/// a failed write, so a full disk gives a truncated file and `Ok`. The bytes are the same as
/// `save`'s.
pub fn png_bytes<P>(img: &image::ImageBuffer<P, Vec<P::Subpixel>>) -> Result<Vec<u8>>
where
    P: image::PixelWithColorType,
    [P::Subpixel]: image::EncodableLayout,
{
    let mut bytes = Vec::new();
    img.write_to(
        &mut std::io::Cursor::new(&mut bytes),
        image::ImageFormat::Png,
    )?;
    Ok(bytes)
}

/// Writes `img` as a PNG file: [`png_bytes`], then [`write_file`].
pub fn write_png<P>(path: &Path, img: &image::ImageBuffer<P, Vec<P::Subpixel>>) -> Result<()>
where
    P: image::PixelWithColorType,
    [P::Subpixel]: image::EncodableLayout,
{
    let bytes = png_bytes(img).map_err(|e| format!("{}: {e}", path.display()))?;
    write_file(path, bytes)
}

/// Draws an SVG picture of `size` with `draw` (which fills the drawing area it is given) and
/// writes it with [`write_file`]. The picture is drawn into memory: plotters' own file backend
/// creates the file as it saves and, when dropped after a failed drawing, writes the part
/// drawn so far to the path.
pub fn write_svg<F>(path: &Path, size: (u32, u32), draw: F) -> Result<()>
where
    F: FnOnce(
        &plotters::drawing::DrawingArea<plotters::prelude::SVGBackend<'_>, plotters::coord::Shift>,
    ) -> Result<()>,
{
    use plotters::prelude::IntoDrawingArea;
    let mut text = String::new();
    {
        let root = plotters::prelude::SVGBackend::with_string(&mut text, size).into_drawing_area();
        draw(&root)?;
        root.present()?;
    }
    write_file(path, text)
}

#[cfg(test)]
mod tests;
