//! Options shared by several subcommands, progress bars and output helpers.

use std::path::{Path, PathBuf};

use clap::Args;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use visguide::MserSettings;
use visguide::preset::{Preset, parse_polarities, parse_variation};

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

    /// A line on stderr unless quiet.
    pub fn say(&self, text: impl AsRef<str>) {
        if !self.quiet {
            eprintln!("{}", text.as_ref());
        }
    }
}

/// The MSER setting: a preset and any parameter overridden.
#[derive(Args, Debug, Clone)]
#[command(next_help_heading = "MSER setting")]
pub struct MserArgs {
    /// Base setting: `opencv` (OpenCV MSER::create defaults: delta 5, areas 60..14400),
    /// `larsson2009` (Paper A: delta 15, min area 50, no max area) or `vlfeat` (vl_mser
    /// defaults: delta 5, upward variation, areas 3e-5..0.75 of the image).
    #[arg(long, default_value = "larsson2009", value_parser = parse_preset)]
    pub preset: Preset,
    /// Delta: grey levels between the regions compared by the stability test (≥ 1).
    #[arg(long, value_name = "LEVELS")]
    pub delta: Option<u8>,
    /// Smallest region, pixels (≥ 1).
    #[arg(long, value_name = "PIXELS")]
    pub min_area: Option<usize>,
    /// Largest region, pixels.
    #[arg(long, value_name = "PIXELS")]
    pub max_area: Option<usize>,
    /// Largest accepted area variation (≥ 0).
    #[arg(long, value_name = "V")]
    pub max_variation: Option<f64>,
    /// Duplicate suppression in [0, 1]: drop a region when a selected region inside it covers
    /// more than 1 − this of it.
    #[arg(long, value_name = "D")]
    pub min_diversity: Option<f64>,
    /// Which regions: dark, bright or both.
    #[arg(long, value_parser = parse_pol)]
    pub polarities: Option<mser::Polarities>,
    /// Variation measure: symmetric (Matas, OpenCV) or upward (VLFeat).
    #[arg(long, value_parser = parse_var)]
    pub variation: Option<mser::Variation>,
}

fn parse_preset(s: &str) -> Result<Preset, String> {
    s.parse()
        .map_err(|e: visguide::VisguideError| e.to_string())
}
fn parse_pol(s: &str) -> Result<mser::Polarities, String> {
    parse_polarities(s).map_err(|e| e.to_string())
}
fn parse_var(s: &str) -> Result<mser::Variation, String> {
    parse_variation(s).map_err(|e| e.to_string())
}

impl MserArgs {
    /// The settings.
    pub fn settings(&self) -> MserSettings {
        MserSettings {
            preset: self.preset,
            delta: self.delta,
            min_area: self.min_area,
            max_area: self.max_area,
            max_variation: self.max_variation,
            min_diversity: self.min_diversity,
            polarities: self.polarities,
            variation: self.variation,
        }
    }
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

/// Fails unless `dir` exists as a directory (creating it when missing).
pub fn ensure_dir(dir: &Path) -> CliResult {
    if dir.exists() && !dir.is_dir() {
        return Err(format!("{}: exists and is not a directory", dir.display()).into());
    }
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    Ok(())
}
