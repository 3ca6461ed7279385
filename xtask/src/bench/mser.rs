//! `cargo xtask bench mser`: our MSER against OpenCV 4.x's `MSER::detectRegions` on graf, boat
//! and leuven img1 (`$VISGUIDE_DATA/oxford-affine`), both polarities, OpenCV's default
//! parameters with `min_diversity = 0` on both sides (OpenCV 4.x ignores `min_diversity` on grey
//! images, so only then do both do the same work), one thread each.
//!
//! Two workloads per image, each against the same OpenCV call (it has no cheaper mode):
//! our summaries (`Mser::detect`: regions, moments, boxes), and summaries plus every region's
//! pixel list (`Mser::detect_with_pixels`), which is what `detectRegions` hands its user. Before
//! timing, the bench asserts that the region sets agree: ours on the image without its outermost
//! pixel ring (which OpenCV 4.x never floods; crate docs of `mser`, "OpenCV") must give exactly
//! OpenCV's pixel sets, both ways, and our pixel lists must equal `Region::pixels`. Times are the
//! calling thread's CPU time (scheduler run time, ns resolution), median of 15 interleaved
//! rounds after 3 warm-ups.
//!
//! Multi-core mode (rayon, wall time, as CPU time cannot show a speed-up): the two polarities on
//! two tasks (`detect_parallel`, `detect_with_pixels_parallel`) and a batch of the 18 images
//! (`detect_many`), each against the sequential run, whose result it must equal.
//!
//! Needs the xtask feature `opencv`:
//! `VISGUIDE_DATA=... cargo run -p xtask --release --features opencv -- bench mser`.

use mser::{GrayView, Mser, MserParams};

use super::BenchArgs;
use super::cpu::{Clock, interleaved, load_average};
use crate::Result;
use crate::report::BenchRow;

const WARMUP: usize = 3;
const ROUNDS: usize = 15;
const SEQUENCES: [&str; 3] = ["graf", "boat", "leuven"];

/// The parameters of both sides.
pub(super) fn params() -> MserParams {
    MserParams {
        min_diversity: 0.0,
        ..MserParams::default()
    }
}

/// Runs the bench.
pub fn run(args: &BenchArgs) -> Result<Vec<BenchRow>> {
    let root = args.oxford_root()?;
    println!(
        "load average at the start: {} ({} cores)",
        load_average(),
        std::thread::available_parallelism().map_or(0, |n| n.get())
    );
    let mut rows = single_core(&root)?;
    rows.extend(multi_core(&root)?);
    println!("load average at the end: {}", load_average());
    Ok(rows)
}

#[cfg(not(feature = "opencv"))]
fn single_core(_root: &std::path::Path) -> Result<Vec<BenchRow>> {
    Err(
        "bench mser needs OpenCV: cargo run -p xtask --release --features opencv -- bench mser"
            .into(),
    )
}

#[cfg(feature = "opencv")]
fn single_core(root: &std::path::Path) -> Result<Vec<BenchRow>> {
    let p = params();
    mser::set_opencv_threads(1)?;
    println!(
        "peer: OpenCV {} (one thread); times: {}",
        mser::opencv_version(),
        Clock::Thread.name()
    );
    let mut rows = Vec::new();
    for seq in SEQUENCES {
        let gray = mser::load_gray(root.join(seq).join("img1.png"))?;
        let img = GrayView::from_image(&gray)?;
        let mut det = Mser::new(p.clone())?;
        let mut cv = mser::OpenCvMser::new(&p)?;
        let n = check_agreement(&img, &mut det, &mut cv)?;
        let mat = mser::OpenCvMser::mat(&img)?;
        let mut peer = || {
            std::hint::black_box(cv.detect_mat(&mat).expect("OpenCV MSER runs"));
        };
        let (ours, theirs) = interleaved(
            Clock::Thread,
            WARMUP,
            ROUNDS,
            || {
                std::hint::black_box(det.detect(&img).expect("valid image").len());
            },
            &mut peer,
        )?;
        rows.push(BenchRow::lower_is_better(
            format!("{seq} img1: summaries vs detectRegions ({n} regions)"),
            ours * 1e3,
            theirs * 1e3,
            "ms CPU",
        ));
        let (ours, theirs) = interleaved(
            Clock::Thread,
            WARMUP,
            ROUNDS,
            || {
                let found = det.detect_with_pixels(&img).expect("valid image");
                std::hint::black_box(found.iter().map(|(_, px)| px.len()).sum::<usize>());
            },
            &mut peer,
        )?;
        rows.push(BenchRow::lower_is_better(
            format!("{seq} img1: summaries + pixel lists vs detectRegions"),
            ours * 1e3,
            theirs * 1e3,
            "ms CPU",
        ));
    }
    Ok(rows)
}

/// Asserts that both detectors find the same regions (see the module docs) and that our pixel
/// lists are the regions' pixels; returns the number of regions.
#[cfg(feature = "opencv")]
pub(super) fn check_agreement(
    img: &GrayView,
    det: &mut Mser,
    cv: &mut mser::OpenCvMser,
) -> Result<usize> {
    use std::collections::HashSet;
    let sorted = |px: &[(u32, u32)]| {
        let mut v = px.to_vec();
        v.sort_unstable_by_key(|&(x, y)| (y, x));
        v
    };
    // Ours: the pixel lists are the flooded pixels of each region.
    let plain = det.detect(img)?;
    let found = det.detect_with_pixels(img)?;
    if found.regions() != &plain[..] {
        return Err("detect_with_pixels returned other regions than detect".into());
    }
    for (r, px) in found.iter() {
        if sorted(px) != r.pixels(img)? {
            return Err(format!("pixel list of {r:?} differs from Region::pixels").into());
        }
    }
    // Against OpenCV: ours without the outer ring, in full-image coordinates.
    let (w, h) = (img.width(), img.height());
    let mut data = Vec::with_capacity(w * h);
    for y in 0..h {
        data.extend_from_slice(img.row(y));
    }
    let inner = GrayView::new(&data[w + 1..], w - 2, h - 2, w)?;
    let ours: Vec<Vec<(u32, u32)>> = det
        .detect_with_pixels(&inner)?
        .iter()
        .map(|(_, px)| {
            let mut v: Vec<(u32, u32)> = px.iter().map(|&(x, y)| (x + 1, y + 1)).collect();
            v.sort_unstable_by_key(|&(x, y)| (y, x));
            v
        })
        .collect();
    let theirs = cv.detect(img)?;
    let a: HashSet<&Vec<(u32, u32)>> = ours.iter().collect();
    let b: HashSet<&Vec<(u32, u32)>> = theirs.iter().collect();
    if ours.len() != theirs.len() || a != b {
        return Err(format!(
            "region sets differ: ours {} ({} distinct), OpenCV {} ({} distinct), common {}",
            ours.len(),
            a.len(),
            theirs.len(),
            b.len(),
            a.intersection(&b).count()
        )
        .into());
    }
    println!(
        "region sets agree: {} regions, identical pixel sets both ways (ours without the outer ring); ours on the full image: {}",
        ours.len(),
        plain.len()
    );
    Ok(plain.len())
}

/// The parallel modes against the sequential runs, wall time (speed-up on this machine's cores).
fn multi_core(root: &std::path::Path) -> Result<Vec<BenchRow>> {
    let p = params();
    let cores = rayon::current_num_threads();
    println!(
        "multi-core mode: rayon on {cores} threads, {}",
        Clock::Wall.name()
    );
    let mut rows = Vec::new();
    let gray = mser::load_gray(root.join("graf").join("img1.png"))?;
    let img = GrayView::from_image(&gray)?;
    let (mut seq, mut par) = (Mser::new(p.clone())?, Mser::new(p.clone())?);
    if par.detect_parallel(&img)? != seq.detect(&img)? {
        return Err("detect_parallel differs from detect".into());
    }
    {
        let a = seq.detect_with_pixels(&img)?;
        let b = par.detect_with_pixels_parallel(&img)?;
        if a.regions() != b.regions() || (0..a.len()).any(|i| a.pixels(i) != b.pixels(i)) {
            return Err("detect_with_pixels_parallel differs from detect_with_pixels".into());
        }
    }
    let (t_par, t_seq) = interleaved(
        Clock::Wall,
        WARMUP,
        ROUNDS,
        || {
            std::hint::black_box(par.detect_parallel(&img).expect("valid").len());
        },
        || {
            std::hint::black_box(seq.detect(&img).expect("valid").len());
        },
    )?;
    print_speedup("graf img1, polarities on 2 tasks", t_seq, t_par, cores);
    rows.push(BenchRow::lower_is_better(
        format!("graf img1: polarities on 2 tasks vs 1 thread ({cores} threads)"),
        t_par * 1e3,
        t_seq * 1e3,
        "ms wall",
    ));
    let (t_par, t_seq) = interleaved(
        Clock::Wall,
        WARMUP,
        ROUNDS,
        || {
            std::hint::black_box(par.detect_with_pixels_parallel(&img).expect("valid").len());
        },
        || {
            std::hint::black_box(seq.detect_with_pixels(&img).expect("valid").len());
        },
    )?;
    print_speedup(
        "graf img1 with pixel lists, polarities on 2 tasks",
        t_seq,
        t_par,
        cores,
    );
    rows.push(BenchRow::lower_is_better(
        format!("graf img1 with pixel lists: polarities on 2 tasks vs 1 thread ({cores} threads)"),
        t_par * 1e3,
        t_seq * 1e3,
        "ms wall",
    ));

    // A batch: all 18 images of the three sequences.
    let mut grays = Vec::new();
    for s in SEQUENCES {
        for i in 1..=6 {
            grays.push(mser::load_gray(root.join(s).join(format!("img{i}.png")))?);
        }
    }
    let imgs: Vec<GrayView> = grays
        .iter()
        .map(GrayView::from_image)
        .collect::<std::result::Result<_, _>>()?;
    let sequential = |det: &mut Mser| -> Vec<Vec<mser::Region>> {
        imgs.iter().map(|i| det.detect(i).expect("valid")).collect()
    };
    if mser::detect_many(&imgs, &p)? != sequential(&mut seq) {
        return Err("detect_many differs from the sequential run".into());
    }
    let (t_par, t_seq) = interleaved(
        Clock::Wall,
        1,
        5,
        || {
            std::hint::black_box(mser::detect_many(&imgs, &p).expect("valid").len());
        },
        || {
            std::hint::black_box(sequential(&mut seq).len());
        },
    )?;
    print_speedup(
        "batch of 18 Oxford images, detect_many",
        t_seq,
        t_par,
        cores,
    );
    rows.push(BenchRow::lower_is_better(
        format!("batch of 18 Oxford images: detect_many vs 1 thread ({cores} threads)"),
        t_par * 1e3,
        t_seq * 1e3,
        "ms wall",
    ));
    Ok(rows)
}

/// Prints a multi-core speed-up (sequential over parallel wall time) with the load it was
/// measured under: on a machine whose cores are busy with other work the figure understates
/// what the cores give when idle, so re-run on an idle machine for the real figure.
fn print_speedup(case: &str, t_seq: f64, t_par: f64, cores: usize) {
    println!(
        "{case}: speed-up {:.2}x on {cores} threads ({:.1} ms -> {:.1} ms wall, median), load average {}",
        t_seq / t_par,
        t_seq * 1e3,
        t_par * 1e3,
        load_average()
    );
}
