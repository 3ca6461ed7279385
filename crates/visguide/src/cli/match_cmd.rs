//! `visguide match`: Fourier-descriptor matches of two images, with geometry and a score.

use std::io::Write;
use std::path::{Path, PathBuf};

use clap::{Args, ValueEnum};
use fd_match::{Method, Sampling};
use serde::Serialize;
use visguide::geometry::RansacConfig;
use visguide::output::atomic::{encode_png, same_target, write_all_atomic, write_bytes};
use visguide::output::draw;
use visguide::scoring::{PairScore, score_matches};
use visguide::{Combination, Homography, MatchSettings, PairMatches, load_gray, match_images};

use super::CliResult;
use super::common::{MserArgs, Ui, check_outputs};

/// Descriptor and error.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum MethodArg {
    /// FDs with phase matched by correlation (Paper A's method; gives rotation and start shift).
    FdCorr,
    /// SSD of FD magnitudes (phase neglected).
    AbsFdSsd,
    /// SSD of affine-invariant FDs of order 0.
    Afd0Ssd,
    /// SSD of affine-invariant FDs of order 1.
    Afd1Ssd,
}

/// Contour sampling.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum SamplingArg {
    /// Uniform in affine arc length (Paper A's "Affine").
    Affine,
    /// Uniform arc length in the similarity-normalised canonical frame ("Canonical").
    Canonical,
}

/// Output format of the matches.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum MatchFormat {
    /// One JSON document: settings, counts, matches with geometry, homography, score.
    Json,
    /// CSV, one row per accepted match.
    Csv,
}

/// Match two images by the Fourier descriptors of their MSER contours (Paper A).
///
/// Regions of both images are described (any of the eight method/sampling combinations of the
/// paper's figures), matched symmetrically with the ratio test e_min/e_sec < --ratio (eq. 19),
/// and every accepted match is given the rotation between the two contours (FD correlation,
/// eq. 12), its start shift (FD Corr) and a local affine map of the two region ellipses. A
/// homography is fitted to all accepted matches (seeded RANSAC, then least squares on the
/// inliers). With --homography, the matches are scored against a known homography as in the
/// Oxford benchmark (overlap error < 50 % in descriptor mode): precision, recall, and the
/// corner error of the fitted homography.
#[derive(Args, Debug)]
#[command(after_help = "Examples:
  visguide match img1.png img2.png                       # JSON on stdout
  visguide match img1.png img3.png --method abs-fd-ssd --sampling canonical --ratio 0.7
  visguide match img1.png img2.png --homography H1to2p --picture pair.png --out m.json")]
pub struct MatchArgs {
    /// First image.
    pub image1: PathBuf,
    /// Second image.
    pub image2: PathBuf,
    /// Descriptor and error.
    #[arg(long, value_enum, default_value = "fd-corr")]
    pub method: MethodArg,
    /// Contour sampling.
    #[arg(long, value_enum, default_value = "affine")]
    pub sampling: SamplingArg,
    /// Ratio threshold T_r: a symmetric match is kept when e_min/e_sec < T_r.
    #[arg(long, default_value_t = 0.5, value_name = "T_R")]
    pub ratio: f64,
    /// Preselection (eq. 18): drop descriptors whose best match within their own image has an
    /// error below T_ERR (ambiguous shapes). `paper` uses Paper A's value for the combination.
    #[arg(long, value_name = "T_ERR|paper")]
    pub preselect: Option<String>,
    /// A known homography (Oxford H1toNp format) to score the matches against.
    #[arg(long, value_name = "FILE")]
    pub homography: Option<PathBuf>,
    /// Inlier threshold of the homography fit, pixels.
    #[arg(long, default_value_t = 3.0, value_name = "PX")]
    pub ransac_threshold: f64,
    /// Seed of the RANSAC sampler.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Output file (default: standard output).
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Output format.
    #[arg(long, value_enum, default_value = "json")]
    pub format: MatchFormat,
    /// Write a side-by-side picture: accepted matches as lines between the ellipses (green:
    /// homography inlier, or correct with --homography; red otherwise).
    #[arg(long, value_name = "PNG")]
    pub picture: Option<PathBuf>,
    #[command(flatten)]
    pub mser: MserArgs,
}

/// One accepted match as written.
#[derive(Debug, Serialize)]
pub struct MatchRow {
    /// Region of image 1 (index in `visguide regions` output with the same setting).
    pub i: usize,
    /// Region of image 2.
    pub j: usize,
    /// Centre in image 1.
    pub x1: f64,
    /// Centre in image 1.
    pub y1: f64,
    /// Centre in image 2.
    pub x2: f64,
    /// Centre in image 2.
    pub y2: f64,
    /// Pair error.
    pub error: f64,
    /// Error ratio.
    pub ratio: f64,
    /// Rotation from contour 1 to contour 2, radians (image coordinates).
    pub rotation: Option<f64>,
    /// Start shift in contour samples (FD Corr).
    pub shift: Option<f64>,
    /// Local similarity scale.
    pub scale: Option<f64>,
    /// Local affine map `[a11, a12, a21, a22]`.
    pub affine: Option<[f64; 4]>,
    /// Inlier of the fitted homography.
    pub inlier: Option<bool>,
    /// Overlap error against the known homography.
    pub overlap_error: Option<f64>,
    /// Correct against the known homography.
    pub correct: Option<bool>,
}

/// The fitted homography as written.
#[derive(Debug, Serialize)]
pub struct FitOut {
    /// Row-major entries.
    pub matrix: [f64; 9],
    /// Inliers.
    pub inliers: usize,
    /// RMS transfer error of the inliers, pixels.
    pub rms: f64,
    /// Corner error against the known homography, pixels.
    pub corner_error: Option<f64>,
}

/// The score as written.
#[derive(Debug, Serialize)]
pub struct ScoreOut {
    /// Existing matches.
    pub existing: usize,
    /// Accepted matches.
    pub matches: usize,
    /// Correct among them.
    pub correct: usize,
    /// Precision.
    pub precision: Option<f64>,
    /// Recall.
    pub recall: Option<f64>,
}

/// The JSON document.
#[derive(Debug, Serialize)]
pub struct MatchOut {
    /// Image 1.
    pub image1: String,
    /// Image 2.
    pub image2: String,
    /// `FD Corr/Affine` etc.
    pub combination: String,
    /// T_r.
    pub ratio_threshold: f64,
    /// T_err.
    pub preselection: Option<f64>,
    /// Regions per image.
    pub regions: (usize, usize),
    /// Described (after preselection).
    pub described: (usize, usize),
    /// Symmetric matches before the ratio test.
    pub symmetric_matches: usize,
    /// Accepted.
    pub matches: Vec<MatchRow>,
    /// Fitted homography.
    pub homography: Option<FitOut>,
    /// Score against the known homography.
    pub score: Option<ScoreOut>,
}

fn combination(a: &MatchArgs) -> Combination {
    let method = match a.method {
        MethodArg::FdCorr => Method::FdCorr,
        MethodArg::AbsFdSsd => Method::AbsFdSsd,
        MethodArg::Afd0Ssd => Method::Afd0Ssd,
        MethodArg::Afd1Ssd => Method::Afd1Ssd,
    };
    let sampling = match a.sampling {
        SamplingArg::Affine => Sampling::AffineArcLength,
        SamplingArg::Canonical => Sampling::Canonical,
    };
    Combination::new(method, sampling)
}

/// The settings of a `match` run (also used by the tests to call the library alike).
pub fn settings(a: &MatchArgs, size1: (u32, u32), size2: (u32, u32)) -> CliResult<MatchSettings> {
    let c = combination(a);
    if !(a.ratio.is_finite() && a.ratio > 0.0) {
        return Err(format!("--ratio {}: expected a positive number", a.ratio).into());
    }
    let preselection = match a.preselect.as_deref() {
        None => None,
        Some("paper") => Some(c.preselection_threshold().ok_or_else(|| {
            format!(
                "--preselect paper: Paper A gives no T_err for {}",
                c.label()
            )
        })?),
        Some(t) => Some(
            t.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite() && *v >= 0.0)
                .ok_or_else(|| format!("--preselect `{t}`: expected a number ≥ 0 or `paper`"))?,
        ),
    };
    let m = a.mser.settings();
    Ok(MatchSettings {
        mser: (m.resolve(size1.0, size1.1)?, m.resolve(size2.0, size2.1)?),
        combination: c,
        ratio_threshold: a.ratio,
        preselection,
        ransac: Some(RansacConfig {
            threshold: a.ransac_threshold,
            seed: a.seed,
            ..RansacConfig::default()
        }),
    })
}

fn rows(p: &PairMatches, score: Option<&PairScore>) -> Vec<MatchRow> {
    p.accepted
        .iter()
        .enumerate()
        .map(|(k, g)| {
            let (e1, e2) = (&p.features1.frames[g.m.i], &p.features2.frames[g.m.j]);
            MatchRow {
                i: g.m.i,
                j: g.m.j,
                x1: e1.u,
                y1: e1.v,
                x2: e2.u,
                y2: e2.v,
                error: g.m.error,
                ratio: g.m.ratio,
                rotation: g.rotation,
                shift: g.m.alignment.map(|a| a.shift),
                scale: g.local.map(|l| l.scale()),
                affine: g
                    .local
                    .map(|l| [l.a[(0, 0)], l.a[(0, 1)], l.a[(1, 0)], l.a[(1, 1)]]),
                inlier: p.homography.as_ref().map(|h| h.inliers[k]),
                overlap_error: score.map(|s| s.per_match[k].overlap_error),
                correct: score.map(|s| s.per_match[k].correct),
            }
        })
        .collect()
}

fn opt(v: Option<impl ToString>) -> String {
    v.map_or(String::new(), |x| x.to_string())
}

/// Runs the subcommand.
pub fn run(a: &MatchArgs, ui: Ui) -> CliResult {
    // Refused before any work: the picture would silently replace the matches.
    if let (Some(out), Some(pic)) = (&a.out, &a.picture)
        && same_target(out, pic)
    {
        return Err(format!(
            "--out {} and --picture {} are the same file; give them different names",
            out.display(),
            pic.display()
        )
        .into());
    }
    let outputs: Vec<&PathBuf> = a.out.iter().chain(&a.picture).collect();
    let inputs: Vec<&PathBuf> = [&a.image1, &a.image2]
        .into_iter()
        .chain(&a.homography)
        .collect();
    check_outputs(&outputs, &inputs, false)?;
    let known = match &a.homography {
        Some(p) => {
            if p.is_dir() {
                return Err(format!(
                    "{}: is a directory, expected a homography file",
                    p.display()
                )
                .into());
            }
            let text = std::fs::read_to_string(p).map_err(|e| format!("{}: {e}", p.display()))?;
            Some(Homography::parse(&text).map_err(|e| format!("{}: {e}", p.display()))?)
        }
        None => None,
    };
    let (img1, img2) = (load_gray(&a.image1)?, load_gray(&a.image2)?);
    let s = settings(a, img1.dimensions(), img2.dimensions())?;
    let bar = ui.bar(1, "matching");
    let pair = match_images(&img1, &img2, &s)?;
    bar.finish_and_clear();
    let score = known
        .as_ref()
        .map(|h| {
            let ij: Vec<(usize, usize)> = pair.accepted.iter().map(|g| (g.m.i, g.m.j)).collect();
            score_matches(&pair.features1.frames, &pair.features2.frames, &ij, h, None)
        })
        .transpose()?;
    let out = MatchOut {
        image1: a.image1.display().to_string(),
        image2: a.image2.display().to_string(),
        combination: s.combination.label(),
        ratio_threshold: s.ratio_threshold,
        preselection: s.preselection,
        regions: (pair.features1.len(), pair.features2.len()),
        described: pair.described,
        symmetric_matches: pair.all.len(),
        matches: rows(&pair, score.as_ref()),
        homography: pair.homography.as_ref().map(|f| FitOut {
            matrix: f.homography.to_row_major(),
            inliers: f.inlier_count,
            rms: f.rms,
            corner_error: known
                .as_ref()
                .map(|h| f.homography.corner_error(h, img1.width(), img1.height())),
        }),
        score: score.as_ref().map(|s| ScoreOut {
            existing: s.existing,
            matches: s.matches,
            correct: s.correct,
            precision: s.precision,
            recall: s.recall,
        }),
    };
    let fill = |w: &mut dyn Write| -> visguide::Result<()> {
        let io = |e: std::io::Error| visguide::VisguideError::Io {
            path: a.out.clone().unwrap_or_else(|| "<stdout>".into()),
            source: e,
        };
        match a.format {
            MatchFormat::Json => {
                serde_json::to_writer_pretty(&mut *w, &out).map_err(|e| io(e.into()))?;
                writeln!(w).map_err(io)?;
            }
            MatchFormat::Csv => {
                writeln!(w, "i,j,x1,y1,x2,y2,error,ratio,rotation,shift,scale,a11,a12,a21,a22,inlier,overlap_error,correct").map_err(io)?;
                for r in &out.matches {
                    let aff = r.affine.map_or(",,,".to_string(), |m| {
                        format!("{},{},{},{}", m[0], m[1], m[2], m[3])
                    });
                    writeln!(
                        w,
                        "{},{},{},{},{},{},{},{},{},{},{},{aff},{},{},{}",
                        r.i,
                        r.j,
                        r.x1,
                        r.y1,
                        r.x2,
                        r.y2,
                        r.error,
                        r.ratio,
                        opt(r.rotation),
                        opt(r.shift),
                        opt(r.scale),
                        opt(r.inlier),
                        opt(r.overlap_error),
                        opt(r.correct)
                    )
                    .map_err(io)?;
                }
            }
        }
        Ok(())
    };
    // The picture is drawn before anything is written, and it and the output file are
    // written as one: a picture that cannot be saved leaves no output file either.
    let picture = a
        .picture
        .as_ref()
        .map(|pic| -> CliResult<(&Path, Vec<u8>)> {
            let pairs: Vec<_> = out
                .matches
                .iter()
                .map(|r| {
                    let good = r.correct.or(r.inlier).unwrap_or(true);
                    (
                        pair.features1.frames[r.i],
                        pair.features2.frames[r.j],
                        if good { draw::GREEN } else { draw::RED },
                    )
                })
                .collect();
            // Wrong matches first, so correct ones are drawn on top.
            let mut pairs = pairs;
            pairs.sort_by_key(|p| p.2 == draw::GREEN);
            let png = encode_png(pic, &draw::matches(&img1, &img2, &pairs, 1600))?;
            Ok((pic.as_path(), png))
        })
        .transpose()?;
    match &a.out {
        Some(p) => {
            let mut text = Vec::new();
            fill(&mut text)?;
            let mut files = vec![(p.as_path(), text.as_slice())];
            if let Some((pic, png)) = &picture {
                files.push((pic, png.as_slice()));
            }
            write_all_atomic(&files)?;
        }
        None => {
            if let Some((pic, png)) = &picture {
                write_bytes(pic, png)?;
            }
            let stdout = std::io::stdout();
            let mut lock = stdout.lock();
            fill(&mut lock)?;
        }
    }
    let h = out
        .homography
        .as_ref()
        .map_or("no homography".to_string(), |f| {
            let ce = f
                .corner_error
                .map_or(String::new(), |c| format!(", corner error {c:.2} px"));
            format!(
                "homography with {} inliers (rms {:.2} px{ce})",
                f.inliers, f.rms
            )
        });
    let sc = out.score.as_ref().map_or(String::new(), |s| {
        format!(
            "; precision {}, recall {} ({} existing)",
            s.precision.map_or("–".into(), |v| format!("{v:.3}")),
            s.recall.map_or("–".into(), |v| format!("{v:.3}")),
            s.existing
        )
    });
    ui.say(format!(
        "{} and {} regions, {} symmetric matches, {} accepted ({}); {h}{sc}",
        out.regions.0,
        out.regions.1,
        out.symmetric_matches,
        out.matches.len(),
        out.combination
    ));
    Ok(())
}
