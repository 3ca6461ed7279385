//! `cargo xtask bench cli`: the `visguide regions` binary on a folder of 100 images against the
//! library call on the same images with the same parameters (#21: "per-image time within 1.2×
//! of the library call, every core used").
//!
//! The images: 100 crops of 640 × 480 pixels (six offsets in each of the 18 Oxford images of
//! graf, boat and leuven, the first 100), written as PNG to `target/bench/cli-images/`. The
//! setting: `--preset opencv --min-diversity 0`, i.e. the parameters of `bench mser` (asserted),
//! so that the OpenCV row does the same work.
//!
//! Checked in the same run, before timing: the binary's `.mser` files with `--threads 1` and
//! with every thread are byte-identical to `visguide::output::regions::write` of the library's
//! regions for every image.
//!
//! Rows:
//! - **the goal row:** binary `--threads 1`, CPU time per image (the child's user + system time
//!   from `getrusage(RUSAGE_CHILDREN)`, microseconds, so process start, decoding, writing and
//!   the file system calls are all counted) against the library doing the same job in this
//!   process, image after image: the library's `GrayReader` (file bytes and pixels kept),
//!   one `Mser` detector reused, the region file's text (`output::regions::write`), the
//!   file written and flushed under a staging name (`output::atomic::write_synced`) and renamed
//!   into place (thread CPU time, which counts the system calls too). Both sides read the same
//!   files and write the same bytes (the library's files are asserted equal to the expected
//!   ones in the run), so the ratio is what the command line costs over the library call;
//! - for information, **different work:** the same binary run against the bare detector
//!   `mser::detect` on the 100 images already decoded in memory (no file read, no decoding,
//!   no text, no file written); the library job's parts (decode, detect, text, file) are
//!   printed, with what the binary spends beyond them (process, threads);
//! - binary with every thread against `--threads 1`, wall time (the speed-up; on a loaded
//!   machine it shows the load, not the code: re-run on an idle one);
//! - with the xtask feature `opencv`: OpenCV 4.x `MSER::detectRegions` on the same decoded
//!   images, one thread, against the library call (`Mser::detect`, detector reused as OpenCV's
//!   is), interleaved, on the images where `bench mser`'s agreement check passes (identical
//!   region sets); the images where it fails are printed with the difference and not timed.
//!
//! The binary is built by this bench (`cargo build --release -p visguide`) into the same target
//! folder as the xtask.

use std::path::{Path, PathBuf};
use std::process::Command;

use image::GrayImage;
use mser::{GrayView, MserParams};
use visguide::output::atomic::write_synced;
use visguide::output::regions::{Format, write};
use visguide::{Features, MserSettings, Preset};

use super::BenchArgs;
use super::cpu::thread_seconds;
use crate::report::{BenchRow, median};
use crate::{Result, workspace_root};

const IMAGES: usize = 100;
const CROP: (u32, u32) = (640, 480);
const ROUNDS: usize = 3;
const SEQUENCES: [&str; 3] = ["graf", "boat", "leuven"];

/// The setting of every side: OpenCV's defaults with `min_diversity = 0`.
fn settings() -> MserSettings {
    MserSettings {
        preset: Preset::Opencv,
        min_diversity: Some(0.0),
        ..MserSettings::default()
    }
}

/// Runs the bench.
pub fn run(args: &BenchArgs) -> Result<Vec<BenchRow>> {
    let root = args.oxford_root()?;
    let bench_dir = workspace_root().join("target/bench");
    let img_dir = bench_dir.join("cli-images");
    let paths = make_images(&root, &img_dir)?;
    let grays: Vec<GrayImage> = paths
        .iter()
        .map(visguide::load_gray)
        .collect::<std::result::Result<_, _>>()?;
    let (w, h) = CROP;
    let params = settings().resolve(w, h)?;
    if params != super::mser::params() {
        return Err("the bench's setting is not bench mser's parameters".into());
    }
    let bin = build_binary()?;
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    println!(
        "{} images of {w}×{h} px in {}; binary {}; {cores} cores; load average {}",
        paths.len(),
        img_dir.display(),
        bin.display(),
        load_average()
    );

    // The library's files, and the binary's with one thread and with all: identical.
    let expected: Vec<Vec<u8>> = paths
        .iter()
        .zip(&grays)
        .map(|(p, g)| library_file(p, g, &params))
        .collect::<Result<_>>()?;
    let all = cores.to_string();
    for threads in ["1", all.as_str()] {
        let out = bench_dir.join(format!("cli-out-{threads}"));
        run_binary(&bin, &img_dir, &out, threads)?;
        for (p, want) in paths.iter().zip(&expected) {
            let got = std::fs::read(visguide_output(&out, p))?;
            if &got != want {
                return Err(format!(
                    "{}: the binary's region file ({threads} threads) differs from the library's",
                    p.display()
                )
                .into());
            }
        }
    }
    println!(
        "outputs agree: {} region files byte-identical to the library's, with 1 and {cores} threads",
        paths.len()
    );

    // Interleaved rounds: bare detect, the library doing the binary's job, binary 1 thread,
    // binary every thread.
    let views: Vec<GrayView> = grays
        .iter()
        .map(GrayView::from_image)
        .collect::<std::result::Result<_, _>>()?;
    let n = paths.len() as f64;
    let (mut lib, mut lib_job, mut bin_cpu, mut wall1, mut wall_all, mut cpu_all) =
        (vec![], vec![], vec![], vec![], vec![], vec![]);
    // The library job in its four parts.
    let mut parts: [Vec<f64>; 4] = Default::default();
    let out = bench_dir.join("cli-out-timed");
    let lib_out = bench_dir.join("cli-out-library");
    std::fs::create_dir_all(&lib_out)?;
    for _ in 0..ROUNDS {
        let t0 = clock()?;
        for v in &views {
            std::hint::black_box(mser::detect(v, &params)?.len());
        }
        let t1 = clock()?;
        lib.push((t1 - t0) / n);
        let t = library_job(&paths, &params, &lib_out)?;
        lib_job.push(t.iter().sum::<f64>() / n);
        for (all, part) in parts.iter_mut().zip(t) {
            all.push(part / n);
        }
        let (cpu, wall) = run_binary(&bin, &img_dir, &out, "1")?;
        bin_cpu.push(cpu / n);
        wall1.push(wall);
        let (cpu, wall) = run_binary(&bin, &img_dir, &out, &all)?;
        cpu_all.push(cpu / n);
        wall_all.push(wall);
    }
    for (p, want) in paths.iter().zip(&expected) {
        if &std::fs::read(visguide_output(&lib_out, p))? != want {
            return Err(format!(
                "{}: the library job's region file differs from the expected one",
                p.display()
            )
            .into());
        }
    }
    let (lib, lib_job, bin_cpu, cpu_all) = (
        median(&mut lib),
        median(&mut lib_job),
        median(&mut bin_cpu),
        median(&mut cpu_all),
    );
    let (wall1, wall_all) = (median(&mut wall1), median(&mut wall_all));
    let [decode, detect, text, file] = parts.map(|mut p| median(&mut p));
    println!(
        "per image, ms CPU: the library's job = decode (GrayReader) {:.3} + detect (Mser, reused) {:.3} + region text {:.3} + file (staged, fsync, rename) {:.3} = {:.3} (median {:.3}); the binary {:.3}, i.e. {:+.3} beyond it (process, clap, rayon); bare mser::detect on decoded pixels {:.3}",
        decode * 1e3,
        detect * 1e3,
        text * 1e3,
        file * 1e3,
        (decode + detect + text + file) * 1e3,
        lib_job * 1e3,
        bin_cpu * 1e3,
        (bin_cpu - lib_job) * 1e3,
        lib * 1e3
    );
    println!(
        "binary with {cores} threads: {:.2} ms CPU per image (all threads); wall {:.3} s vs {:.3} s with 1 thread ({:.2}× speed-up); times: median of {ROUNDS} interleaved rounds",
        cpu_all * 1e3,
        wall_all,
        wall1,
        wall1 / wall_all
    );
    let mut rows = vec![
        BenchRow::lower_is_better(
            format!(
                "visguide regions --threads 1 vs the library doing the same job (read, decode, detect, write the file), per image ({IMAGES} images)"
            ),
            bin_cpu * 1e3,
            lib_job * 1e3,
            "ms CPU",
        ),
        BenchRow::lower_is_better(
            "visguide regions --threads 1 vs bare mser::detect on decoded pixels, per image (for information: different work, no file read, decoded or written)",
            bin_cpu * 1e3,
            lib * 1e3,
            "ms CPU",
        ),
        BenchRow::lower_is_better(
            format!("visguide regions --threads {cores} vs --threads 1, whole folder"),
            wall_all,
            wall1,
            "s wall",
        ),
    ];
    print_rows(&rows);
    rows.extend(vlfeat_row(&bench_dir, &grays, &views)?);
    rows.extend(opencv_row(&paths, &views, &params)?);
    Ok(rows)
}

/// The C driver timing `vl_mser` (built in the run against the system's VLFeat).
const VL_DRIVER: &str = r#"/* Times vl_mser (VLFeat) on PGM (P5) files with VLFeat's defaults on both polarities (the image
   and its inverse, as vl_mser.m does); prints "regions cpu_seconds" for all files together. */
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include <vl/mser.h>
static unsigned char *read_pgm(const char *p, int *w, int *h) {
  FILE *f = fopen(p, "rb"); int maxv; if (!f) return NULL;
  if (fscanf(f, "P5 %d %d %d", w, h, &maxv) != 3 || maxv != 255) { fclose(f); return NULL; }
  fgetc(f);
  unsigned char *d = malloc((size_t)*w * *h);
  if (fread(d, 1, (size_t)*w * *h, f) != (size_t)*w * *h) { fclose(f); free(d); return NULL; }
  fclose(f); return d;
}
int main(int argc, char **argv) {
  long regions = 0; double cpu = 0;
  for (int i = 1; i < argc; i++) {
    int w, h; unsigned char *img = read_pgm(argv[i], &w, &h);
    if (!img) { fprintf(stderr, "%s: not an 8-bit P5 PGM\n", argv[i]); return 1; }
    unsigned char *inv = malloc((size_t)w * h);
    for (size_t k = 0; k < (size_t)w * h; k++) inv[k] = 255 - img[k];
    int dims[2] = {w, h};
    clock_t t0 = clock();
    VlMserFilt *f = vl_mser_new(2, dims);
    vl_mser_process(f, img); regions += vl_mser_get_regions_num(f);
    vl_mser_process(f, inv); regions += vl_mser_get_regions_num(f);
    vl_mser_delete(f);
    cpu += (double)(clock() - t0) / CLOCKS_PER_SEC;
    free(img); free(inv);
  }
  printf("%ld %.6f\n", regions, cpu);
  return 0;
}
"#;

/// VLFeat's `vl_mser` (system library, `libvlfeat-dev`) against `mser::detect` with the
/// `vlfeat` preset (VLFeat's defaults: Δ 5, areas 3e-5..0.75 of the image, max variation 0.25,
/// min diversity 0.2, both polarities) on the same images, process CPU time of the C driver
/// (`clock()` around the detection only) against our thread CPU time, interleaved. **For
/// information:** the region counts are printed, not asserted equal (the two detectors'
/// stability and duplicate tests differ in detail). Without a C compiler or VLFeat: a note and
/// no row.
fn vlfeat_row(bench_dir: &Path, grays: &[GrayImage], views: &[GrayView]) -> Result<Vec<BenchRow>> {
    let peers = workspace_root().join("target/peers");
    std::fs::create_dir_all(&peers)?;
    let src = peers.join("vl_mser_driver.c");
    let exe = peers.join("vl_mser_driver");
    std::fs::write(&src, VL_DRIVER)?;
    let built = Command::new("cc")
        .args(["-O3", "-o"])
        .arg(&exe)
        .arg(&src)
        .arg("-lvl")
        .output();
    if !built.as_ref().is_ok_and(|o| o.status.success()) {
        println!(
            "no vl_mser row: cannot build against VLFeat (apt install libvlfeat-dev): {}",
            built.map_or_else(
                |e| e.to_string(),
                |o| String::from_utf8_lossy(&o.stderr).into_owned()
            )
        );
        return Ok(Vec::new());
    }
    let dir = bench_dir.join("cli-pgm");
    std::fs::create_dir_all(&dir)?;
    let mut files = Vec::new();
    for (k, g) in grays.iter().enumerate() {
        let p = dir.join(format!("{k:03}.pgm"));
        let mut bytes = format!("P5\n{} {}\n255\n", g.width(), g.height()).into_bytes();
        bytes.extend_from_slice(g.as_raw());
        std::fs::write(&p, bytes)?;
        files.push(p);
    }
    let (w, h) = grays[0].dimensions();
    let params = Preset::Vlfeat.params(w, h);
    let n = views.len() as f64;
    let (mut ours, mut theirs, mut counts) = (Vec::new(), Vec::new(), (0, 0));
    for _ in 0..ROUNDS {
        let t0 = clock()?;
        let mut found = 0;
        for v in views {
            found += std::hint::black_box(mser::detect(v, &params)?.len());
        }
        ours.push((clock()? - t0) / n);
        let o = Command::new(&exe).args(&files).output()?;
        if !o.status.success() {
            return Err(format!("vl_mser driver: {}", String::from_utf8_lossy(&o.stderr)).into());
        }
        let text = String::from_utf8(o.stdout)?;
        let mut f = text.split_whitespace();
        let regions: usize = f.next().ok_or("vl_mser driver: no output")?.parse()?;
        let cpu: f64 = f.next().ok_or("vl_mser driver: no time")?.parse()?;
        theirs.push(cpu / n);
        counts = (found, regions);
    }
    println!(
        "vl_mser: {} regions on the {} images, ours (vlfeat preset) {} (not asserted equal)",
        counts.1,
        views.len(),
        counts.0
    );
    Ok(vec![BenchRow::lower_is_better(
        format!(
            "mser::detect (vlfeat preset) vs vl_mser 0.9.21, per image (for information: {} vs {} regions, not asserted equal)",
            counts.0, counts.1
        ),
        median(&mut ours) * 1e3,
        median(&mut theirs) * 1e3,
        "ms CPU",
    )])
}

/// OpenCV on the same decoded images, one thread, timed (with the library call, interleaved);
/// `bench mser`'s agreement check must pass on every image (it excuses, region by region, only
/// OpenCV's parent ties), else the bench fails naming the image.
#[cfg(feature = "opencv")]
fn opencv_row(paths: &[PathBuf], views: &[GrayView], params: &MserParams) -> Result<Vec<BenchRow>> {
    mser::set_opencv_threads(1)?;
    let mut cv = mser::OpenCvMser::new(params)?;
    let mut det = mser::Mser::new(params.clone())?;
    let mut same = Vec::new();
    let mut excused = 0;
    for (p, v) in paths.iter().zip(views) {
        let a = super::mser::check_agreement(v, &mut det, &mut cv)
            .map_err(|e| format!("{}: {e}", p.display()))?;
        excused += a.excused;
        same.push(v);
    }
    println!(
        "OpenCV row on all {} images: region sets agree up to {excused} regions of ours excused by OpenCV's parent-tie rule",
        same.len()
    );
    if same.is_empty() {
        return Err("no image where OpenCV's and our region sets agree".into());
    }
    let mats: Vec<_> = same
        .iter()
        .map(|v| mser::OpenCvMser::mat(v))
        .collect::<std::result::Result<_, _>>()?;
    let n = same.len() as f64;
    let (mut ours, mut theirs) = (Vec::new(), Vec::new());
    for _ in 0..ROUNDS {
        let t0 = clock()?;
        for v in &same {
            std::hint::black_box(det.detect(v)?.len());
        }
        let t1 = clock()?;
        for m in &mats {
            std::hint::black_box(cv.detect_mat(m)?);
        }
        ours.push((t1 - t0) / n);
        theirs.push((clock()? - t1) / n);
    }
    Ok(vec![BenchRow::lower_is_better(
        format!(
            "mser detect vs OpenCV {} detectRegions, per image ({} images, region sets asserted equal up to {excused} parent ties)",
            mser::opencv_version(),
            same.len()
        ),
        median(&mut ours) * 1e3,
        median(&mut theirs) * 1e3,
        "ms CPU",
    )])
}

#[cfg(not(feature = "opencv"))]
fn opencv_row(_: &[PathBuf], _: &[GrayView], _: &MserParams) -> Result<Vec<BenchRow>> {
    println!("no OpenCV row: run with --features opencv for it");
    Ok(Vec::new())
}

/// The rows so far, printed before the long OpenCV check.
fn print_rows(rows: &[BenchRow]) {
    for r in rows {
        println!(
            "{}: ours {:.3} {u}, peer {:.3} {u}, ratio {:.2}",
            r.case,
            r.ours,
            r.peer,
            r.ratio,
            u = r.unit
        );
    }
}

/// The library's Oxford region file of one image, as the binary writes it.
fn library_file(path: &Path, gray: &GrayImage, params: &MserParams) -> Result<Vec<u8>> {
    let regions = mser::detect(&GrayView::from_image(gray)?, params)?;
    let mut bytes = Vec::new();
    region_text(&mut bytes, path, gray.dimensions(), params, regions)?;
    Ok(bytes)
}

/// The binary's job done by the library in this thread: every image read and decoded by one
/// `GrayReader`, detected by one reused detector, its region file's text written into one
/// buffer, then written and flushed under a staging name and renamed into `out` (as the binary
/// stages and renames). Returns the thread CPU seconds of the four parts over all images:
/// decode, detect, text, file.
fn library_job(paths: &[PathBuf], params: &MserParams, out: &Path) -> Result<[f64; 4]> {
    let mut parts = [0.0; 4];
    let mut t = clock()?;
    let mut reader = visguide::GrayReader::new();
    let mut det = mser::Mser::new(params.clone())?;
    let mut text = Vec::new();
    let mut staged = Vec::new();
    for p in paths {
        let g = reader.read(p)?;
        let t_decoded = clock()?;
        let regions = det.detect(&GrayView::from_image(g)?)?;
        let t_detected = clock()?;
        text.clear();
        region_text(&mut text, p, g.dimensions(), params, regions)?;
        let t_text = clock()?;
        let target = visguide_output(out, p);
        let staging = target.with_extension("mser.staged");
        write_synced(&staging, &text)?;
        staged.push((staging, target));
        let t_file = clock()?;
        parts[0] += t_decoded - t;
        parts[1] += t_detected - t_decoded;
        parts[2] += t_text - t_detected;
        parts[3] += t_file - t_text;
        t = t_file;
    }
    for (from, to) in &staged {
        std::fs::rename(from, to)?;
    }
    parts[3] += clock()? - t;
    Ok(parts)
}

/// This thread's CPU time in seconds.
fn clock() -> Result<f64> {
    Ok(thread_seconds().ok_or("no thread CPU clock")?)
}

/// Appends the Oxford region file of detected regions to `bytes`.
fn region_text(
    bytes: &mut Vec<u8>,
    path: &Path,
    size: (u32, u32),
    params: &MserParams,
    regions: Vec<mser::Region>,
) -> Result<()> {
    let features = Features {
        regions,
        ..Features::default()
    };
    write(
        bytes,
        Format::Oxford,
        &path.display().to_string(),
        size,
        params,
        &features,
        false,
    )?;
    Ok(())
}

/// Where the binary writes the region file of `image`.
fn visguide_output(out: &Path, image: &Path) -> PathBuf {
    let stem = image
        .file_stem()
        .map_or_else(Default::default, |s| s.to_os_string());
    out.join(stem).with_extension("mser")
}

/// 100 crops of the Oxford images as PNG files (rewritten on every run, so they always match
/// the data).
fn make_images(root: &Path, dir: &Path) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir)?;
    let (cw, ch) = CROP;
    let mut out = Vec::new();
    'all: for seq in SEQUENCES {
        for i in 1..=6 {
            let src = root.join(seq).join(format!("img{i}.png"));
            let g = visguide::load_gray(&src)?;
            let (w, h) = g.dimensions();
            if w < cw || h < ch {
                return Err(format!("{}: smaller than {cw}×{ch}", src.display()).into());
            }
            for k in 0..6u32 {
                let (x, y) = ((w - cw) * (k % 3) / 2, (h - ch) * (k / 3));
                let crop = image::imageops::crop_imm(&g, x, y, cw, ch).to_image();
                let p = dir.join(format!("{seq}-img{i}-{k}.png"));
                crop.save(&p)?;
                out.push(p);
                if out.len() == IMAGES {
                    break 'all;
                }
            }
        }
    }
    Ok(out)
}

/// Builds the release binary next to the xtask and returns its path.
fn build_binary() -> Result<PathBuf> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let status = Command::new(cargo)
        .args([
            "build",
            "--release",
            "-q",
            "-p",
            "visguide",
            "--bin",
            "visguide",
        ])
        .current_dir(workspace_root())
        .status()?;
    if !status.success() {
        return Err("cargo build --release -p visguide failed".into());
    }
    let exe = std::env::current_exe()?;
    let bin = exe.with_file_name(format!("visguide{}", std::env::consts::EXE_SUFFIX));
    if !bin.is_file() {
        return Err(format!("{}: not found after the build", bin.display()).into());
    }
    Ok(bin)
}

/// Runs `visguide regions` on the folder; returns (CPU seconds of the child, wall seconds).
fn run_binary(bin: &Path, images: &Path, out: &Path, threads: &str) -> Result<(f64, f64)> {
    let before = children_cpu()?;
    let t0 = std::time::Instant::now();
    let o = Command::new(bin)
        .args([
            "regions",
            "-q",
            "--preset",
            "opencv",
            "--min-diversity",
            "0",
        ])
        .args(["--threads", threads, "--out"])
        .arg(out)
        .arg(images)
        .output()?;
    let wall = t0.elapsed().as_secs_f64();
    if !o.status.success() {
        return Err(format!(
            "visguide regions failed: {}",
            String::from_utf8_lossy(&o.stderr)
        )
        .into());
    }
    Ok((children_cpu()? - before, wall))
}

/// User + system CPU seconds of this process's waited-for children
/// (`getrusage(RUSAGE_CHILDREN)`, microseconds; `/proc/self/stat`'s children fields are whole
/// clock ticks of 10 ms, each truncated, up to 2 % of a 1 s run).
fn children_cpu() -> Result<f64> {
    // SAFETY: an all-zero `rusage` is a valid value of the plain C struct.
    let mut ru: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: `ru` is a valid, writable rusage for the duration of the call.
    if unsafe { libc::getrusage(libc::RUSAGE_CHILDREN, &mut ru) } != 0 {
        return Err(format!("getrusage: {}", std::io::Error::last_os_error()).into());
    }
    let secs = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    Ok(secs(ru.ru_utime) + secs(ru.ru_stime))
}

fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "unknown".into())
}
