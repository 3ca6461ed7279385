//! `visguide regions`: MSER regions of many images, in parallel.
//!
//! Where the time goes (`cargo xtask bench cli`, 100 crops of 640 × 480, `--threads 1`;
//! ratios in `docs/performance.md`, *visguide command line*): callgrind on the release binary
//! (Intel, commit 55f4711) counts 81.3 M instructions per image, of which detection 78 %, PNG
//! decoding 16 %, the region text 6 %, everything else under 0.1 %; the kernel's file system
//! calls add about 6 % of CPU time (perf). In CPU time (AMD, commit 244e3db, under load) the
//! library doing the same job spends per image decode 1.37 ms + detection 11.47 ms + region
//! text 0.63 ms + the staged, flushed file 0.51 ms; process start, argument parsing and the pool
//! amortise to nothing. Why grey PNGs are decoded directly: [`GrayReader`]; why numbers are
//! written by `Display`: `mser`'s `oxford` module docs.

use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};

use clap::{Args, ValueEnum};
use visguide::output::atomic::{encode_png, remove_staged, rename_staged, stage};
use visguide::output::draw;
use visguide::output::regions::{Format, write};
use visguide::{Features, GrayReader};

use super::CliResult;
use super::common::{
    MserArgs, Ui, check_outputs, ensure_dir, expand_images, output_for, remove_made,
};

/// The staged files of one image (staging name, final name) and its region count.
type Staged = (Vec<(PathBuf, PathBuf)>, usize);

/// Region file format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum FormatArg {
    /// Oxford affine benchmark region file (`.mser`): `1.0`, count, then `u v a b c` per region.
    Oxford,
    /// JSON with every region's level, seed, area, box, centroid, ellipse (and contour).
    Json,
    /// CSV, one row per region (contour as `x y;x y;…` in the last column).
    Csv,
}

impl From<FormatArg> for Format {
    fn from(f: FormatArg) -> Self {
        match f {
            FormatArg::Oxford => Format::Oxford,
            FormatArg::Json => Format::Json,
            FormatArg::Csv => Format::Csv,
        }
    }
}

/// Detect MSER regions in images and write one region file per image.
///
/// Each IMAGE (PNG, PGM or PPM; colour is converted to grey with BT.601 weights) gives
/// `OUT/<stem>.mser|.json|.csv`. A directory stands for all the images in it. Images are processed
/// in parallel (--threads); the files are identical whatever the number of threads. The
/// Oxford format writes the ellipse `a(x−u)² + 2b(x−u)(y−v) + c(y−v)² = 1` with about the
/// region's own area (M = (4Σ)⁻¹, Σ the region's second moments), 0-based pixel coordinates,
/// readable by the Oxford benchmark's repeatability.m and VLBenchmarks.
#[derive(Args, Debug)]
#[command(after_help = "Examples:
  visguide regions img1.png                        # writes ./img1.mser
  visguide regions --preset opencv --format json --contours --out regions/ photos/
  visguide regions --delta 10 --max-variation 0.5 --draw img1.png")]
pub struct RegionsArgs {
    /// Image files or directories of images.
    #[arg(required = true, value_name = "IMAGE")]
    pub images: Vec<PathBuf>,
    /// Output format.
    #[arg(long, value_enum, default_value = "oxford")]
    pub format: FormatArg,
    /// Output directory (created if missing).
    #[arg(long, default_value = ".", value_name = "DIR")]
    pub out: PathBuf,
    /// Include each region's outer contour (JSON and CSV).
    #[arg(long)]
    pub contours: bool,
    /// Also write `OUT/<stem>-regions.png`, the image with every region's ellipse drawn.
    #[arg(long)]
    pub draw: bool,
    #[command(flatten)]
    pub mser: MserArgs,
}

/// Runs the subcommand.
pub fn run(a: &RegionsArgs, ui: Ui) -> CliResult {
    if a.contours && a.format == FormatArg::Oxford {
        return Err(
            "--contours needs --format json or csv (Oxford region files hold ellipses only)".into(),
        );
    }
    let images = expand_images(&a.images)?;
    // Two images with the same stem would overwrite each other's output.
    let mut stems: Vec<PathBuf> = images.iter().map(|p| output_for(&a.out, p, "")).collect();
    stems.sort();
    if let Some(w) = stems.windows(2).find(|w| w[0] == w[1]) {
        return Err(format!(
            "two images would both write {}.*; give them different names",
            w[0].display()
        )
        .into());
    }
    // An output name taken by a directory, or naming one of the images (`a.png` drawn into
    // `a-regions.png`, itself an input), is refused before any work: the directory's rename
    // would fail only after the other images' files were in place, and the image would be
    // replaced.
    let format: Format = a.format.into();
    let mut targets = Vec::new();
    for path in &images {
        targets.push(output_for(
            &a.out,
            path,
            &format!(".{}", format.extension()),
        ));
        if a.draw {
            targets.push(output_for(&a.out, path, "-regions.png"));
        }
    }
    check_outputs(&targets, &images, true)?;
    // The output folder is made for the staged files; a run that fails takes away the
    // folders it made, as it leaves no file.
    let made = ensure_dir(&a.out)?;
    let result = detect_and_write(a, ui, &images);
    if result.is_err() {
        remove_made(&made);
    }
    result
}

/// [`run`] once the images are listed and the output folder exists.
fn detect_and_write(a: &RegionsArgs, ui: Ui, images: &[PathBuf]) -> CliResult {
    let format: Format = a.format.into();
    let settings = a.mser.settings();
    let bar = ui.bar(images.len() as u64, "regions");
    // Which threads processed an image.
    let workers = AtomicU64::new(0);
    // Every file is first written under a staging name and renamed only when all images
    // succeeded, so a failed run leaves no output at all. An image after a failed one is not
    // started, and the error reported is the first failing image's, at any thread count.
    let results = visguide::parallel::map_until_failure(images, |path| {
        // Bit i: pool thread i; bit 63: a thread outside the pool (rayon runs a
        // single-image job on the caller).
        let bit = rayon::current_thread_index().map_or(63, |i| i.min(62));
        workers.fetch_or(1 << bit, Ordering::Relaxed);
        let r = one(a, &settings, format, path);
        bar.inc(1);
        r
    });
    bar.finish_and_clear();
    let mut total = 0;
    let mut staged = Vec::new();
    let mut first_error = None;
    for r in results.into_iter().flatten() {
        match r {
            Ok((files, n)) => {
                total += n;
                staged.extend(files);
            }
            Err(e) => {
                first_error.get_or_insert(e);
            }
        }
    }
    if let Some(e) = first_error {
        remove_staged(&staged);
        return Err(e);
    }
    // No staging file outlives the run.
    rename_staged(&staged)?;
    let threads = |n: usize| match n {
        1 => String::from("1 thread"),
        n => format!("{n} threads"),
    };
    ui.say(format!(
        "{} regions in {} images → {} ({} in the pool, {} processed images)",
        total,
        images.len(),
        a.out.display(),
        threads(rayon::current_num_threads()),
        threads(workers.load(Ordering::Relaxed).count_ones() as usize)
    ));
    Ok(())
}

fn one(
    a: &RegionsArgs,
    settings: &visguide::MserSettings,
    format: Format,
    path: &std::path::Path,
) -> CliResult<Staged> {
    // This thread's buffers, taken out for the call (a nested call on this thread, should the
    // contour tracing's pool run another image here, starts with fresh ones).
    let mut worker = WORKER.take();
    let result = one_with(&mut worker, a, settings, format, path);
    WORKER.set(worker);
    result
}

fn one_with(
    worker: &mut Worker,
    a: &RegionsArgs,
    settings: &visguide::MserSettings,
    format: Format,
    path: &std::path::Path,
) -> CliResult<Staged> {
    let Worker {
        detector,
        reader,
        text,
    } = worker;
    let img = reader.read(path)?;
    let params = settings.resolve(img.width(), img.height())?;
    let features = if a.contours || a.draw {
        visguide::detect(img, &params)?
    } else {
        // Without contours the library's detector alone is called (no contour tracing), the
        // thread's own detector: a detector's output does not depend on what it detected
        // before, so the regions are `mser::detect`'s.
        let det = match detector {
            Some(d) if d.params() == &params => d,
            _ => detector.insert(mser::Mser::new(params.clone())?),
        };
        Features {
            regions: det.detect(&mser::GrayView::from_image(img)?)?,
            ..Features::default()
        }
    };
    // The drawing's ellipses before any file is staged: an error leaves nothing behind.
    let ellipses = if a.draw {
        features
            .regions
            .iter()
            .map(mser::Region::ellipse)
            .collect::<mser::Result<Vec<_>>>()?
    } else {
        Vec::new()
    };
    text.clear();
    write(
        text,
        format,
        &path.display().to_string(),
        img.dimensions(),
        &params,
        &features,
        a.contours,
    )?;
    // The picture is encoded before anything is staged: an error leaves nothing behind.
    let picture = if a.draw {
        let target = output_for(&a.out, path, "-regions.png");
        let pic = draw::ellipses(img, &ellipses, draw::YELLOW);
        Some((encode_png(&target, &pic)?, target))
    } else {
        None
    };
    let target = output_for(&a.out, path, &format!(".{}", format.extension()));
    let mut files = vec![(stage(&target, text)?, target)];
    if let Some((png, target)) = picture {
        match stage(&target, &png) {
            Ok(staged) => files.push((staged, target)),
            Err(e) => {
                remove_staged(&files);
                return Err(e.into());
            }
        }
    }
    Ok((files, features.regions.len()))
}

/// What a worker thread keeps between images, so that an image costs no allocation of the
/// detector's buffers (about 20 bytes per pixel), the file's bytes, the grey pixels or the
/// region file's text.
#[derive(Default)]
struct Worker {
    /// The detector, made anew when the parameters differ.
    detector: Option<mser::Mser>,
    /// File bytes and grey pixels.
    reader: GrayReader,
    /// The region file's text.
    text: Vec<u8>,
}

thread_local! {
    static WORKER: std::cell::Cell<Worker> = std::cell::Cell::new(Worker::default());
}
