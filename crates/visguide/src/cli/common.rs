//! Options shared by several subcommands, progress bars and output helpers.

use std::collections::HashSet;
use std::ffi::OsString;
use std::io::Write;
use std::path::{Path, PathBuf};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
pub use visguide::args::MserArgs;

use super::CliResult;

/// Progress and summaries.
#[derive(Debug, Clone, Copy)]
pub struct Ui {
    /// `--quiet`.
    pub quiet: bool,
}

impl Ui {
    /// A progress bar of `len` steps on stderr (hidden with `--quiet`; indicatif also hides it
    /// when stderr is not a terminal).
    pub fn bar(&self, len: u64, message: &str) -> ProgressBar {
        if self.quiet {
            return ProgressBar::hidden();
        }
        let bar = ProgressBar::with_draw_target(Some(len), ProgressDrawTarget::stderr());
        bar.set_style(
            ProgressStyle::with_template("{msg:>12} [{bar:30}] {pos}/{len} {elapsed} (eta {eta})")
                .expect("valid template")
                .progress_chars("=> "),
        );
        bar.set_message(message.to_string());
        bar
    }

    /// A line on stderr unless quiet. A stderr that cannot be written (a closed pipe) is
    /// ignored: `eprintln!` would panic, turning a successful run into exit code 101.
    pub fn say(&self, text: impl AsRef<str>) {
        if !self.quiet {
            say_on_stderr(text.as_ref());
        }
    }
}

/// Writes one line on stderr, ignoring a failure (see [`Ui::say`]).
pub fn say_on_stderr(line: &str) {
    let _ = writeln!(std::io::stderr().lock(), "{line}");
}

/// A file's identity for comparing paths: its folder resolved (`.`, `..`, links) and its name.
/// A path without a file name (`..`) or whose folder does not exist is taken as written.
fn file_key(p: &Path) -> (PathBuf, Option<OsString>) {
    let folder = match p.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    (
        std::fs::canonicalize(&folder).unwrap_or(folder),
        p.file_name().map(OsString::from),
    )
}

/// The output files of a run, checked before any work and before any file is touched, so a
/// run that cannot write its output fails at once and does not write part of it: each must
/// not be a directory, its folder must exist (unless `creates_folders`), and none may be one
/// of `inputs` (its contents would be silently replaced by the output; also when spelt
/// differently, `./a.csv` for `a.csv`).
pub fn check_outputs(
    outputs: &[impl AsRef<Path>],
    inputs: &[impl AsRef<Path>],
    creates_folders: bool,
) -> CliResult {
    let inputs: HashSet<_> = inputs.iter().map(|p| file_key(p.as_ref())).collect();
    for out in outputs {
        let out = out.as_ref();
        visguide::output::atomic::check_file_target(out)?;
        if !creates_folders {
            let folder = out.parent().filter(|d| !d.as_os_str().is_empty());
            if let Some(d) = folder.filter(|d| !d.is_dir()) {
                return Err(format!(
                    "{}: the folder {} does not exist",
                    out.display(),
                    d.display()
                )
                .into());
            }
        }
        if inputs.contains(&file_key(out)) {
            return Err(format!(
                "{}: is also an input of this run, and writing it would replace that input; \
                 give the output another name",
                out.display()
            )
            .into());
        }
    }
    Ok(())
}

/// The files directly in `dir` (for [`check_outputs`]: a folder's files are inputs).
pub fn files_in(dir: &Path) -> Vec<PathBuf> {
    std::fs::read_dir(dir)
        .map(|d| d.filter_map(|e| e.ok().map(|e| e.path())).collect())
        .unwrap_or_default()
}

/// Image files of the arguments: files as given, directories expanded to their image files
/// (`.png`, `.pgm`, `.ppm`, `.pnm`, sorted by name).
pub fn expand_images(args: &[PathBuf]) -> CliResult<Vec<PathBuf>> {
    let mut out = Vec::new();
    for a in args {
        if a.is_dir() {
            let mut found: Vec<PathBuf> = std::fs::read_dir(a)
                .map_err(|e| format!("{}: {e}", a.display()))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| {
                    p.is_file()
                        && p.extension().and_then(|e| e.to_str()).is_some_and(|e| {
                            matches!(
                                e.to_ascii_lowercase().as_str(),
                                "png" | "pgm" | "ppm" | "pnm"
                            )
                        })
                })
                .collect();
            if found.is_empty() {
                return Err(
                    format!("{}: a directory without .png/.pgm/.ppm images", a.display()).into(),
                );
            }
            found.sort();
            out.extend(found);
        } else {
            out.push(a.clone());
        }
    }
    Ok(out)
}

/// `dir/stem.ext` for an image.
pub fn output_for(dir: &Path, image: &Path, suffix: &str) -> PathBuf {
    let stem = image
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "image".into());
    dir.join(format!("{stem}{suffix}"))
}

/// Fails unless `dir` exists as a directory (creating it when missing). Returns the folders it
/// made, outermost first, for [`remove_made`] to take away when the run fails; on an error it
/// leaves none of them.
pub fn ensure_dir(dir: &Path) -> CliResult<Vec<PathBuf>> {
    if dir.exists() && !dir.is_dir() {
        return Err(format!("{}: exists and is not a directory", dir.display()).into());
    }
    let mut made: Vec<PathBuf> = dir
        .ancestors()
        .filter(|d| !d.as_os_str().is_empty())
        .take_while(|d| !d.exists())
        .map(Path::to_path_buf)
        .collect();
    made.reverse();
    if let Err(e) = std::fs::create_dir_all(dir) {
        remove_made(&made);
        return Err(format!("{}: {e}", dir.display()).into());
    }
    Ok(made)
}

/// Removes the folders [`ensure_dir`] made, innermost first, each only if it is empty (a
/// failed run leaves no folder it made; anything written into one keeps it).
pub fn remove_made(made: &[PathBuf]) {
    for d in made.iter().rev() {
        let _ = std::fs::remove_dir(d);
    }
}
