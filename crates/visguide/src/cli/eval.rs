//! `visguide eval`: Paper A's measurement on the user's own sequence folders.

use std::io::Write;
use std::path::PathBuf;

use clap::Args;
use serde::Serialize;
use visguide::output::atomic::write_atomic;
use visguide::scoring::score_matches;
use visguide::{Combination, Homography, MatchSettings, load_gray, match_images};

use super::CliResult;
use super::common::{MserArgs, Ui, check_outputs, files_in};

/// Score FD matching on sequence folders in the Oxford layout (img1…imgK, H1toKp).
///
/// For every pair img1–imgK and each of the eight method/sampling combinations of Paper A, the
/// regions are matched with the ratio test (--ratio) and scored against H1toKp (overlap error
/// < 50 % in descriptor mode): existing matches, accepted matches, precision and recall, plus
/// the corner error of the homography fitted to FD Corr/Affine's matches. This is the
/// measurement of `cargo xtask eval paper-a` (the same library calls); the xtask adds the full
/// precision–recall curves, figures and the sensitivity table for the repository's fixtures.
#[derive(Args, Debug)]
#[command(after_help = "Examples:
  visguide eval /data/oxford-affine/leuven
  visguide eval --preset opencv --out scores.json /data/oxford-affine/boat mine/")]
pub struct EvalArgs {
    /// Sequence folders.
    #[arg(required = true, value_name = "DIR")]
    pub sequences: Vec<PathBuf>,
    /// Ratio threshold T_r.
    #[arg(long, default_value_t = 0.5)]
    pub ratio: f64,
    /// Also write the numbers as JSON.
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    #[command(flatten)]
    pub mser: MserArgs,
}

#[derive(Serialize)]
struct Row {
    sequence: String,
    pair: String,
    combination: String,
    existing: usize,
    matches: usize,
    correct: usize,
    precision: Option<f64>,
    recall: Option<f64>,
    corner_error: Option<f64>,
}

fn image_in(dir: &std::path::Path, k: usize) -> Option<PathBuf> {
    ["png", "ppm", "pgm", "pnm"]
        .iter()
        .map(|e| dir.join(format!("img{k}.{e}")))
        .find(|p| p.is_file())
}

/// Runs the subcommand.
pub fn run(a: &EvalArgs, ui: Ui) -> CliResult {
    // The JSON file is checked before the (long) measurement; a sequence folder's files are
    // its inputs.
    let inputs: Vec<PathBuf> = a.sequences.iter().flat_map(|d| files_in(d)).collect();
    check_outputs(a.out.as_slice(), &inputs, false)?;
    let settings = a.mser.settings();
    let mut rows = Vec::new();
    for dir in &a.sequences {
        if !dir.is_dir() {
            return Err(format!(
                "{}: expected a sequence folder (img1.png, img2.png, H1to2p, …)",
                dir.display()
            )
            .into());
        }
        let name = dir
            .file_name()
            .map_or("sequence".into(), |n| n.to_string_lossy().into_owned());
        let first =
            image_in(dir, 1).ok_or_else(|| format!("{}: no img1.png/.ppm/.pgm", dir.display()))?;
        let img1 = load_gray(&first)?;
        let mut pairs = Vec::new();
        for k in 2.. {
            let (Some(p), h) = (image_in(dir, k), dir.join(format!("H1to{k}p"))) else {
                break;
            };
            if !h.is_file() {
                break;
            }
            let text = std::fs::read_to_string(&h).map_err(|e| format!("{}: {e}", h.display()))?;
            let hom = Homography::parse(&text).map_err(|e| format!("{}: {e}", h.display()))?;
            pairs.push((k, p, hom));
        }
        if pairs.is_empty() {
            return Err(format!("{}: no img2 with H1to2p", dir.display()).into());
        }
        let bar = ui.bar((pairs.len() * Combination::ALL.len()) as u64, &name);
        for (k, p, hom) in &pairs {
            let img2 = load_gray(p)?;
            for c in Combination::ALL {
                let s = MatchSettings {
                    mser: (
                        settings.resolve(img1.width(), img1.height())?,
                        settings.resolve(img2.width(), img2.height())?,
                    ),
                    combination: c,
                    ratio_threshold: a.ratio,
                    preselection: None,
                    ransac: (c == Combination::SHOWN).then(Default::default),
                };
                let pair = match_images(&img1, &img2, &s)?;
                let ij: Vec<(usize, usize)> =
                    pair.accepted.iter().map(|g| (g.m.i, g.m.j)).collect();
                let sc = score_matches(
                    &pair.features1.frames,
                    &pair.features2.frames,
                    &ij,
                    hom,
                    None,
                )?;
                rows.push(Row {
                    sequence: name.clone(),
                    pair: format!("img1-img{k}"),
                    combination: c.label(),
                    existing: sc.existing,
                    matches: sc.matches,
                    correct: sc.correct,
                    precision: sc.precision,
                    recall: sc.recall,
                    corner_error: pair
                        .homography
                        .map(|f| f.homography.corner_error(hom, img1.width(), img1.height())),
                });
                bar.inc(1);
            }
        }
        bar.finish_and_clear();
    }
    // The file first, then the table: standard output closed early (`| head`) must not lose
    // the file. An error on standard output names it.
    if let Some(p) = &a.out {
        let text = serde_json::to_string_pretty(&rows)?;
        write_atomic(p, |w| {
            w.write_all(text.as_bytes())
                .map_err(|e| visguide::VisguideError::Io {
                    path: p.clone(),
                    source: e,
                })
        })?;
    }
    let f3 = |v: Option<f64>| v.map_or("–".to_string(), |x| format!("{x:.3}"));
    let stdout = |e: std::io::Error| visguide::VisguideError::Io {
        path: "<stdout>".into(),
        source: e,
    };
    let mut out = std::io::stdout().lock();
    writeln!(
        out,
        "sequence\tpair\tcombination\texisting\tmatches\tprecision\trecall\tcorner error (px)"
    )
    .map_err(stdout)?;
    for r in &rows {
        writeln!(
            out,
            "{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}",
            r.sequence,
            r.pair,
            r.combination,
            r.existing,
            r.matches,
            f3(r.precision),
            f3(r.recall),
            r.corner_error.map_or(String::new(), |c| format!("{c:.2}"))
        )
        .map_err(stdout)?;
    }
    out.flush().map_err(stdout)?;
    Ok(())
}
