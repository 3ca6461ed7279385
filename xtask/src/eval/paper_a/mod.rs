//! `cargo xtask eval paper-a`: Paper A's precision–recall study (Larsson, Felsberg & Forssén,
//! DICTA 2009, §5) on the Oxford affine benchmark; `cargo xtask eval paper-a-synthetic` runs the
//! same pipeline on generated scenes with known homographies, so that a machine without the data
//! still produces a (clearly labelled) result. A plain `cargo xtask eval` without data skips
//! `paper-a`, leaving its committed fixtures alone, and runs `paper-a-synthetic`.
//!
//! Pipeline per sequence ([`evaluate()`]): MSER regions of every image (crate `mser`), their moment
//! ellipses for the ground truth ([`visguide::features`]) and outer contours for the Fourier descriptors
//! (crate `fd-match`, both samplings); per pair img1–imgK the ground truth of the overlap
//! criterion in descriptor mode ([`visguide::scoring::overlap`], [`visguide::scoring::pair_truth`]); symmetric matches of the eight
//! combinations ([`visguide::combination`]) with and without preselection, scored and swept over the ratio
//! threshold ([`visguide::scoring::sweep`]); then JSON, SVG figures ([`plots`]), match pictures ([`pictures`]),
//! a delta × diversity sensitivity table ([`sensitivity`]) and `summary.md` ([`summary`]).
//!
//! # The MSER setting, chosen from the paper's words before any result was seen
//! Paper A, footnote 3: "minimum margin = 30 and minimum region size = 50", both polarities. We
//! read the margin as the width of the stability window: the symmetric variation
//! `(|Q_{g+Δ}| − |Q_{g−Δ}|)/|Q_g|` spans `2Δ` grey levels, so Δ = 15. Minimum area 50 pixels;
//! the paper names no maximum area, so there is none. It says nothing about the stability
//! threshold or duplicate suppression, so those keep the common defaults of OpenCV's MSER
//! (`max_variation` 0.25, `min_diversity` 0.2): `mser::MserParams::larsson2009()`. Duplicate
//! suppression: a region is dropped when a smaller selected region inside it covers more than
//! 80 % of it (`min_diversity` 0.2); nested twins that differ by more survive, pair up in the
//! ground truth and lower the recall (the ratio test sees the twin as second best), which is
//! why every table reports recall beside precision. The sensitivity table shows how the counts
//! move with Δ and `min_diversity`; nothing was tuned on the test pairs.
//!
//! # Ground truth
//! Moment ellipses `M = Σ⁻¹` (VLBenchmarks' MSER frames), mapped by the local affine
//! approximation of H, descriptor mode (×3, offset not scaled, no border crop), ε < 50 %
//! (docs/methods.md § Overlap error, step 6). A reported match is correct when its pair has ε < 50
//! %; the recall denominator is the number of greedy one-to-one correspondences ("existing
//! matches").

pub(crate) mod error;
mod evaluate;
pub(crate) mod image_io;
mod pictures;
mod plots;
mod progress;
mod report;
mod sensitivity;
pub(crate) mod sequence;
mod summary;
mod synthetic;
#[cfg(test)]
mod test_data;
#[cfg(test)]
mod tests;

use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::Args;

use super::EvalContext;
use crate::Result;
use evaluate::{Plan, evaluate};
use progress::Progress;
use sequence::{Sequence, Source};
use visguide::MserSettings;

/// The homography type, under the path `cargo xtask data fetch` uses; its one home is
/// `visguide::geometry`.
pub(crate) mod homography {
    pub use visguide::Homography;
}

/// Options of `cargo xtask eval paper-a`.
#[derive(Args, Clone, Debug, Default)]
pub struct PaperAArgs {
    /// Sequences to evaluate: folders `DATA/oxford-affine/NAME` or `DATA/NAME` in the Oxford
    /// layout (img1.png|ppm|pgm …, H1to2p …). Default: leuven,boat,graf.
    #[arg(long, value_delimiter = ',', value_name = "NAME[,NAME…]")]
    pub sequences: Vec<String>,
    /// Where the match pictures of real data go (they show the benchmark's images, which are
    /// never written into fixtures/). Default: target/paper-a-matches/. Unlike the staged
    /// output folder, each picture is written (atomically) as its sequence is evaluated: a run
    /// that fails later keeps the pictures already written, and older pictures stay.
    #[arg(long, value_name = "DIR")]
    pub matches_dir: Option<PathBuf>,
    /// Skip the sensitivity table (delta × diversity, and max variation).
    #[arg(long)]
    pub no_sensitivity: bool,
    /// The MSER setting (default: Paper A's, `larsson2009`).
    #[command(flatten)]
    pub mser: visguide::args::MserArgs,
}

/// The sequences of Paper A.
pub const PAPER_SEQUENCES: [&str; 3] = ["leuven", "boat", "graf"];

/// Finds a sequence folder: `DATA/oxford-affine/NAME`, else `DATA/NAME`.
fn sequence_dir(data: &Path, name: &str) -> Option<PathBuf> {
    [data.join("oxford-affine").join(name), data.join(name)]
        .into_iter()
        .find(|d| d.is_dir())
}

/// Why the study must be written to a folder the user names, if it must: other sequences
/// than Paper A's three, another MSER setting or no sensitivity table make a study other than
/// `fixtures/paper-a`'s, which it would replace (and `--check` fail).
pub fn needs_own_out(args: &PaperAArgs) -> Option<&'static str> {
    let other_sequences = !args.sequences.is_empty() && args.sequences != PAPER_SEQUENCES;
    let other_setting = args.mser.settings() != visguide::args::MserArgs::default().settings();
    (other_sequences || other_setting || args.no_sensitivity).then_some(
        "eval paper-a with --sequences, an MSER setting or --no-sensitivity writes a study of \
         its own: name a folder with --out (fixtures/paper-a holds Paper A's), and no --check",
    )
}

/// Why the real-data study cannot run with `data`, if it cannot: no data folder, or (without
/// `--sequences`) one lacking Paper A's three sequences.
pub fn missing_data(data: Option<&Path>, args: &PaperAArgs) -> Option<String> {
    let Some(data) = data else {
        return Some(
            "no data folder (--data DIR or VISGUIDE_DATA; `cargo xtask data fetch` downloads it)"
                .into(),
        );
    };
    let lacking = args.sequences.is_empty()
        && PAPER_SEQUENCES
            .iter()
            .any(|n| sequence_dir(data, n).is_none());
    lacking.then(|| {
        format!(
            "{} lacks oxford-affine/{{leuven,boat,graf}}",
            data.display()
        )
    })
}

/// Loads the sequences to evaluate from the data folder.
fn load_sequences(ctx: &EvalContext, args: &PaperAArgs) -> Result<Vec<Sequence>> {
    if let Some(why) = missing_data(ctx.data_dir.as_deref(), args) {
        return Err(format!("paper-a: {why}").into());
    }
    let data = ctx.data_dir.as_deref().expect("checked by missing_data");
    let names: Vec<String> = if args.sequences.is_empty() {
        PAPER_SEQUENCES.iter().map(|s| s.to_string()).collect()
    } else {
        args.sequences.clone()
    };
    names
        .iter()
        .map(|name| {
            let dir = sequence_dir(data, name).ok_or_else(|| {
                format!(
                    "sequence {name}: neither oxford-affine/{name} nor {name} in {}",
                    data.display()
                )
            })?;
            Ok(Sequence::load(name, &dir)?)
        })
        .collect()
}

/// Runs the study on the default synthetic sequence (`cargo xtask eval paper-a-synthetic`).
pub fn run_synthetic(ctx: &EvalContext) -> Result<()> {
    let start = Instant::now();
    eprintln!("paper-a-synthetic: evaluating SYNTHETIC scenes");
    let seq = synthetic::generate(&synthetic::SyntheticSpec::default());
    let unused = ctx.out_dir.join("matches");
    let paper = MserSettings::default();
    run_study(
        &[seq],
        &ctx.out_dir,
        &unused,
        false,
        &paper,
        Progress::stderr(),
    )?;
    eprintln!(
        "paper-a-synthetic: done in {:.1} s",
        start.elapsed().as_secs_f64()
    );
    Ok(())
}

/// Runs the whole study on `sequences`, writing into `out` (and real-data pictures into
/// `matches_dir`). Returns the summary text.
pub fn run_study(
    sequences: &[Sequence],
    out: &Path,
    matches_dir: &Path,
    with_sensitivity: bool,
    settings: &MserSettings,
    progress: Progress,
) -> Result<String> {
    let mut reports = Vec::new();
    for seq in sequences {
        let (w, h) = seq.images[0].dimensions();
        let plan = Plan::paper(settings.resolve(w, h)?);
        let result = evaluate(seq, &plan, &progress)?;
        let pictures_dir = match seq.source {
            Source::Synthetic => out.join("matches"),
            Source::Folder => matches_dir.to_path_buf(),
        };
        pictures::write_all(seq, &result, &pictures_dir)?;
        let report = report::SequenceReport::new(seq, &plan, &result);
        if progress.is_visible() {
            for g in &report.groups {
                let paper = g
                    .paper_existing
                    .map_or(String::new(), |p| format!(" (paper: {p})"));
                eprintln!(
                    "{} {}: existing matches {}{paper}",
                    seq.name, g.label, g.existing
                );
            }
        }
        super::write_json(out, &format!("{}.json", seq.name), &report)?;
        plots::write_all(seq, &report, out)?;
        reports.push(report);
    }
    let table = if with_sensitivity {
        let t = sensitivity::run(
            sequences,
            &sensitivity::Grid::default(),
            settings,
            &progress,
        )?;
        super::write_json(out, "sensitivity.json", &t)?;
        Some(t)
    } else {
        None
    };
    let synthetic = sequences.iter().any(|s| s.source == Source::Synthetic);
    let paper_setting = *settings == MserSettings::default();
    let text = summary::render(&reports, table.as_ref(), synthetic, paper_setting);
    std::fs::write(out.join("summary.md"), &text)?;
    Ok(text)
}

/// Runs the target.
pub fn run(ctx: &EvalContext, args: &PaperAArgs) -> Result<()> {
    let start = Instant::now();
    let sequences = load_sequences(ctx, args)?;
    let matches_dir = args.matches_dir.clone().unwrap_or_else(|| {
        crate::workspace_root()
            .join("target")
            .join("paper-a-matches")
    });
    run_study(
        &sequences,
        &ctx.out_dir,
        &matches_dir,
        !args.no_sensitivity,
        &args.mser.settings(),
        Progress::stderr(),
    )?;
    let real = sequences.iter().any(|s| s.source == Source::Folder);
    if real {
        eprintln!("paper-a: match pictures in {}", matches_dir.display());
    }
    eprintln!("paper-a: done in {:.1} s", start.elapsed().as_secs_f64());
    Ok(())
}
