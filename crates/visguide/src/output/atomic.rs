//! Writing a file so that a failure leaves no partial file: the content goes to a temporary
//! file beside the target (same folder, so the rename cannot cross file systems), which is
//! renamed over the target only after everything was written and flushed. On any error the
//! temporary file is removed and the target is untouched.

use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use crate::error::{Result, VisguideError, io};

/// A temporary name beside `target`, unique to this process and this call (process id and a
/// counter), so that threads saving to one path at once never write into each other's file.
fn temp_path(target: &Path) -> PathBuf {
    static NEXT: AtomicU64 = AtomicU64::new(0);
    let name = target
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    let k = NEXT.fetch_add(1, Ordering::Relaxed);
    target.with_file_name(format!(".{name}.partial-{}-{k}", std::process::id()))
}

/// Writes `target` with `fill`, atomically.
pub fn write_atomic<F>(target: &Path, fill: F) -> Result<()>
where
    F: FnOnce(&mut dyn Write) -> Result<()>,
{
    if target.is_dir() {
        return Err(VisguideError::Io {
            path: target.to_path_buf(),
            source: std::io::Error::other("is a directory, expected a file name"),
        });
    }
    let tmp = temp_path(target);
    let result = (|| {
        let file = std::fs::File::create(&tmp).map_err(io(target))?;
        let mut w = BufWriter::new(file);
        fill(&mut w)?;
        w.flush().map_err(io(target))?;
        let file = w.into_inner().map_err(|e| VisguideError::Io {
            path: target.to_path_buf(),
            source: e.into_error(),
        })?;
        file.sync_all().map_err(io(target))?;
        std::fs::rename(&tmp, target).map_err(io(target))
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// Writes `bytes` to a new file `path` with one `write` and flushes it to disk (`fsync`); on
/// any error the file is removed. For a staging file that is renamed into place later (as
/// `visguide regions` does once every image succeeded), so it needs no temporary file of its
/// own; [`write_atomic`] writes a file in place.
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

/// Writes bytes atomically.
pub fn write_bytes(target: &Path, bytes: &[u8]) -> Result<()> {
    write_atomic(target, |w| w.write_all(bytes).map_err(io(target)))
}

/// Saves a PNG atomically.
pub fn save_png(target: &Path, img: &image::RgbImage) -> Result<()> {
    let mut buf = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut buf), image::ImageFormat::Png)
        .map_err(|e| VisguideError::Image {
            path: target.to_path_buf(),
            reason: e.to_string(),
        })?;
    write_bytes(target, &buf)
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
