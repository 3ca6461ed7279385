//! Writing a file so that a failure leaves no partial file: the content goes to a temporary
//! file beside the target (same folder, so the rename cannot cross file systems), which is
//! renamed over the target only after everything was written and flushed. On any error (or a
//! panic while the content is produced) the temporary file is removed and the target is
//! untouched.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use crate::error::{Result, VisguideError, io};

/// The counter of [`temp_path`].
static NEXT: AtomicU64 = AtomicU64::new(0);

/// How many taken names [`create_temp`] skips before giving up.
const TEMP_ATTEMPTS: u32 = 10_000;

/// A temporary name beside `target`, unique to this process and this call (process id and a
/// counter), so that threads saving to one path at once never write into each other's file.
fn temp_path(target: &Path) -> PathBuf {
    let name = target
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    let k = NEXT.fetch_add(1, Ordering::Relaxed);
    target.with_file_name(format!(".{name}.partial-{}-{k}", std::process::id()))
}

/// Creates a new temporary file beside `target` ([`temp_path`]). The file must not exist yet
/// (`create_new`): a name that is taken (left by a process that had the same id, e.g. in
/// another container writing to a shared folder, or a link someone put there) is skipped, never
/// truncated, written through or renamed away.
fn create_temp(target: &Path) -> std::io::Result<(PathBuf, File)> {
    let mut attempts = 0;
    loop {
        let tmp = temp_path(target);
        match File::options().write(true).create_new(true).open(&tmp) {
            Ok(file) => return Ok((tmp, file)),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                attempts += 1;
                if attempts >= TEMP_ATTEMPTS {
                    return Err(e);
                }
            }
            Err(e) => return Err(e),
        }
    }
}

/// A temporary file that is removed when dropped unless [`Temp::keep`] was called: on an
/// error and on a panic alike.
struct Temp(Option<PathBuf>);

impl Temp {
    /// The file's path.
    fn path(&self) -> &Path {
        self.0.as_deref().expect("not kept yet")
    }

    /// Keeps the file (it was renamed into place, or is handed on).
    fn keep(mut self) -> PathBuf {
        self.0.take().expect("not kept yet")
    }
}

impl Drop for Temp {
    fn drop(&mut self) {
        if let Some(p) = self.0.take() {
            let _ = std::fs::remove_file(p);
        }
    }
}

/// Refuses an output path that names an existing directory (its rename would fail only after
/// the work, or after other outputs were already in place).
pub fn check_file_target(target: &Path) -> Result<()> {
    if target.is_dir() {
        return Err(VisguideError::Io {
            path: target.to_path_buf(),
            source: std::io::Error::other("is a directory, expected a file name"),
        });
    }
    Ok(())
}

/// Removes staging files `(staging name, target)` that will not be renamed.
pub fn remove_staged<T>(staged: &[(PathBuf, T)]) {
    for (tmp, _) in staged {
        let _ = std::fs::remove_file(tmp);
    }
}

/// Renames every staging file over its target, in order. If a rename fails, the staging files
/// not yet renamed are removed (no staging file outlives the call) and the error names that
/// target; the files renamed before it stay in place.
pub fn rename_staged<T: AsRef<Path>>(staged: &[(PathBuf, T)]) -> Result<()> {
    for (k, (tmp, target)) in staged.iter().enumerate() {
        if let Err(e) = std::fs::rename(tmp, target) {
            remove_staged(&staged[k..]);
            return Err(io(target.as_ref())(e));
        }
    }
    Ok(())
}

/// Writes `target` with `fill`, atomically. The content is flushed (the error checked, not
/// left to a dropped buffer) and synced to disk before the rename; every error is
/// [`VisguideError::Io`] naming `target` (or `fill`'s own).
pub fn write_atomic<F>(target: &Path, fill: F) -> Result<()>
where
    F: FnOnce(&mut dyn Write) -> Result<()>,
{
    check_file_target(target)?;
    let (tmp, file) = create_temp(target).map_err(io(target))?;
    let tmp = Temp(Some(tmp));
    let mut w = BufWriter::new(file);
    fill(&mut w)?;
    w.flush().map_err(io(target))?;
    let file = w.into_inner().map_err(|e| VisguideError::Io {
        path: target.to_path_buf(),
        source: e.into_error(),
    })?;
    file.sync_all().map_err(io(target))?;
    drop(file);
    std::fs::rename(tmp.path(), target).map_err(io(target))?;
    tmp.keep();
    Ok(())
}

/// Writes `bytes` to a new temporary file beside `target` with one `write` and syncs it to disk;
/// returns its name, for [`rename_staged`] to move over `target` later (as `visguide regions`
/// does once every image succeeded). On any error nothing is left and the error names
/// `target`.
pub fn stage(target: &Path, bytes: &[u8]) -> Result<PathBuf> {
    let (tmp, mut file) = create_temp(target).map_err(io(target))?;
    let tmp = Temp(Some(tmp));
    file.write_all(bytes).map_err(io(target))?;
    file.sync_all().map_err(io(target))?;
    Ok(tmp.keep())
}

/// Writes `bytes` to the file `path` (created or truncated) with one `write` and flushes it to
/// disk (`fsync`); on any error the file is removed. For a staging file whose name the caller
/// chose and that is renamed into place later; [`stage`] picks a name that cannot collide, and
/// [`write_atomic`] writes a file in place.
pub fn write_synced(path: &Path, bytes: &[u8]) -> Result<()> {
    let result = (|| {
        let mut file = std::fs::File::create(path)?;
        file.write_all(bytes)?;
        file.sync_all()
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(path);
    }
    result.map_err(io(path))
}

/// Whether two output paths name the same file: equal file names in the same folder (the
/// folders compared after resolving `.`, `..` and links when they exist, so `out.json` and
/// `./out.json` are one file).
pub fn same_target(a: &Path, b: &Path) -> bool {
    if a == b {
        return true;
    }
    let folder = |p: &Path| {
        let dir = match p.parent() {
            Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
            _ => PathBuf::from("."),
        };
        std::fs::canonicalize(&dir).unwrap_or(dir)
    };
    a.file_name() == b.file_name() && folder(a) == folder(b)
}

/// Writes several files as one: each is written and flushed under a temporary name beside its
/// target, and the temporaries are renamed over the targets only once every one was written,
/// so a file that cannot be written (a missing folder, a directory in the way) leaves none of
/// them. Two entries naming the same file are an error before anything is written (the second
/// would silently replace the first).
pub fn write_all_atomic(files: &[(&Path, &[u8])]) -> Result<()> {
    for (k, (a, _)) in files.iter().enumerate() {
        if let Some((b, _)) = files[..k].iter().find(|(b, _)| same_target(a, b)) {
            return Err(VisguideError::Io {
                path: a.to_path_buf(),
                source: std::io::Error::other(format!(
                    "the same file as {}: two outputs cannot share a path",
                    b.display()
                )),
            });
        }
        check_file_target(a)?;
    }
    let mut staged: Vec<(PathBuf, &Path)> = Vec::with_capacity(files.len());
    for (target, bytes) in files {
        match stage(target, bytes) {
            Ok(tmp) => staged.push((tmp, target)),
            Err(e) => {
                remove_staged(&staged);
                return Err(e);
            }
        }
    }
    rename_staged(&staged)
}

/// Writes bytes atomically.
pub fn write_bytes(target: &Path, bytes: &[u8]) -> Result<()> {
    write_atomic(target, |w| w.write_all(bytes).map_err(io(target)))
}

/// The bytes of a PNG file of `img`; `target` names the file in errors.
pub fn encode_png(target: &Path, img: &image::RgbImage) -> Result<Vec<u8>> {
    let mut buf = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut buf), image::ImageFormat::Png)
        .map_err(|e| VisguideError::Image {
            path: target.to_path_buf(),
            reason: e.to_string(),
        })?;
    Ok(buf)
}

/// Saves a PNG atomically.
pub fn save_png(target: &Path, img: &image::RgbImage) -> Result<()> {
    write_bytes(target, &encode_png(target, img)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_failed_write_leaves_nothing_and_keeps_the_old_file() {
        let dir = std::env::temp_dir().join(format!("visguide-atomic-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let t = dir.join("out.txt");
        write_bytes(&t, b"old").unwrap();
        let e = write_atomic(&t, |w| {
            w.write_all(b"half").unwrap();
            Err(VisguideError::Invalid {
                name: "x",
                reason: "stop".into(),
            })
        });
        assert!(e.is_err());
        assert_eq!(std::fs::read(&t).unwrap(), b"old");
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        assert!(write_bytes(&dir, b"x").is_err());
        assert!(write_bytes(&dir.join("missing/out.txt"), b"x").is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// A rename that fails (a non-empty directory in the way) is an I/O error naming that
    /// target; the file renamed before it stays, and no staging file outlives the call (the
    /// failed one's and the later ones' are removed, their targets never created).
    #[test]
    fn a_failed_rename_removes_every_staging_file_left() {
        let dir = std::env::temp_dir().join(format!("visguide-staged-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(dir.join("b/inside")).unwrap();
        let staged: Vec<(PathBuf, PathBuf)> = ["a", "b", "c"]
            .iter()
            .map(|n| {
                let tmp = dir.join(format!(".{n}.staged"));
                write_synced(&tmp, n.as_bytes()).unwrap();
                (tmp, dir.join(n))
            })
            .collect();
        match rename_staged(&staged) {
            Err(VisguideError::Io { path, .. }) => assert_eq!(path, dir.join("b")),
            other => panic!("{other:?}"),
        }
        assert_eq!(std::fs::read(dir.join("a")).unwrap(), b"a");
        assert!(dir.join("b/inside").is_dir() && !dir.join("c").exists());
        for (tmp, _) in &staged {
            assert!(!tmp.exists(), "{tmp:?} left behind");
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// Several files written as one: all or nothing. A target in a missing folder, a
    /// directory in the way or the same path twice (also spelt differently) leaves no file and
    /// no temporary one, and the files that were there keep their contents.
    #[test]
    fn files_written_together_are_all_or_nothing() {
        let dir = std::env::temp_dir().join(format!("visguide-atomic-all-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("sub")).unwrap();
        let (a, b) = (dir.join("a.json"), dir.join("b.png"));
        write_bytes(&a, b"old").unwrap();
        let count = || std::fs::read_dir(&dir).unwrap().count();
        let missing = dir.join("missing/b.png");
        let dotted = dir.join("sub/../a.json");
        for second in [missing.as_path(), dir.join("sub").as_path(), &a, &dotted] {
            let e = write_all_atomic(&[(&a, b"new"), (second, b"png")]).unwrap_err();
            assert!(matches!(e, VisguideError::Io { .. }), "{e}");
            assert_eq!(std::fs::read(&a).unwrap(), b"old");
            assert_eq!(count(), 2, "{}", second.display());
        }
        let e = write_all_atomic(&[(&a, b"new"), (&dotted, b"png")]).unwrap_err();
        assert!(e.to_string().contains("the same file"), "{e}");
        write_all_atomic(&[(&a, b"new"), (&b, b"png")]).unwrap();
        assert_eq!(std::fs::read(&a).unwrap(), b"new");
        assert_eq!(std::fs::read(&b).unwrap(), b"png");
        assert_eq!(count(), 3);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// A temporary name that is already taken (a file left by a process that had the same id,
    /// e.g. in another container writing to a shared folder, or a link put there) is skipped:
    /// that file keeps its contents and the save succeeds under the next free name. (With
    /// `File::create` the file was truncated, written and renamed over the target.)
    #[test]
    fn a_taken_temporary_name_is_skipped_and_left_alone() {
        let dir =
            std::env::temp_dir().join(format!("visguide-atomic-taken-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let t = dir.join("out.txt");
        // The next names this process will try (other tests may take a few meanwhile).
        let next = NEXT.load(Ordering::Relaxed);
        let planted: Vec<PathBuf> = (next..next + 64)
            .map(|k| dir.join(format!(".out.txt.partial-{}-{k}", std::process::id())))
            .collect();
        for p in &planted {
            std::fs::write(p, b"someone else's").unwrap();
        }
        write_bytes(&t, b"new").unwrap();
        assert_eq!(std::fs::read(&t).unwrap(), b"new");
        let (tmp, staged) = (stage(&t, b"staged").unwrap(), dir.join("staged.txt"));
        rename_staged(&[(tmp, staged.clone())]).unwrap();
        assert_eq!(std::fs::read(&staged).unwrap(), b"staged");
        for p in &planted {
            assert_eq!(
                std::fs::read(p).unwrap(),
                b"someone else's",
                "{}",
                p.display()
            );
        }
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), planted.len() + 2);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// A panic while the content is produced (a bug in `fill`) leaves no temporary file and
    /// the old file as it was (the clean-up used to run on errors only).
    #[test]
    fn a_panic_while_writing_leaves_no_temporary_file() {
        let dir =
            std::env::temp_dir().join(format!("visguide-atomic-panic-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let t = dir.join("out.txt");
        write_bytes(&t, b"old").unwrap();
        let r = std::panic::catch_unwind(|| {
            write_atomic(&t, |w| {
                w.write_all(&[b'x'; 20_000]).unwrap();
                panic!("a bug while writing (expected by this test)")
            })
        });
        assert!(r.is_err());
        assert_eq!(std::fs::read(&t).unwrap(), b"old");
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// A staging file that cannot be made (its folder is missing, or is a file) is an error
    /// naming the target, and nothing is left.
    #[test]
    fn a_failed_stage_names_the_target_and_leaves_nothing() {
        let dir =
            std::env::temp_dir().join(format!("visguide-atomic-stage-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("file"), b"a file").unwrap();
        for t in [dir.join("missing/out.txt"), dir.join("file/out.txt")] {
            match stage(&t, b"x") {
                Err(VisguideError::Io { path, .. }) => assert_eq!(path, t),
                other => panic!("{other:?}"),
            }
        }
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        // A bare file name: the temporary file is beside it, in the current folder.
        let bare = temp_path(Path::new("out.txt"));
        assert_eq!(bare.parent(), Some(Path::new("")));
        assert!(bare.to_string_lossy().starts_with(".out.txt.partial-"));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// Threads saving to one path at once each write their own temporary file: every save
    /// succeeds and the file is one of the complete contents (with one temporary name per
    /// process, saves failed or renamed another thread's half-written file into place).
    #[test]
    fn concurrent_saves_to_one_path_each_succeed_whole() {
        let dir = std::env::temp_dir().join(format!("visguide-atomic-par-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let t = dir.join("out.txt");
        let contents: Vec<Vec<u8>> = (0..8u8).map(|k| vec![b'a' + k; 200_000]).collect();
        std::thread::scope(|s| {
            for c in &contents {
                let t = &t;
                s.spawn(move || {
                    for _ in 0..5 {
                        write_bytes(t, c).unwrap();
                    }
                });
            }
        });
        let got = std::fs::read(&t).unwrap();
        assert!(contents.contains(&got));
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
