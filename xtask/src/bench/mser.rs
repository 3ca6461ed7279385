//! `cargo xtask bench mser`: our MSER against OpenCV 4.x's `MSER::detectRegions` on all 18
//! images of graf, boat and leuven (img1-img6, `$VISGUIDE_DATA/oxford-affine`), both polarities, OpenCV's default
//! parameters with `min_diversity = 0` on both sides (OpenCV 4.x ignores `min_diversity` on grey
//! images, so only then do both do the same work), one thread each.
//!
//! Two workloads per image, each against the same OpenCV call (it has no cheaper mode):
//! our summaries (`Mser::detect`: regions, moments, boxes), and summaries plus every region's
//! pixel list (`Mser::detect_with_pixels`), which is what `detectRegions` hands its user. Before
//! timing, the bench asserts per image that the region sets agree: ours on the image without its
//! outermost pixel ring (which OpenCV 4.x never floods; crate docs of `mser`, "OpenCV") must
//! give exactly OpenCV's pixel sets, both ways, except for regions that OpenCV drops by its
//! parent-tie rule, each checked by thresholding and counted; and our pixel lists must equal
//! `Region::pixels`. Every image's two ratios are rows of `target/bench/mser.json`. Times are the
//! calling thread's CPU time (`CLOCK_THREAD_CPUTIME_ID`), median of 15 interleaved
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
/// Rounds of the single-core (OpenCV) rows.
#[cfg(feature = "opencv")]
const ROUNDS: usize = 15;
/// Rounds of the wall-time polarity rows (one call ~11 ms), and of the 18-image batch.
const WALL_ROUNDS: usize = 41;
const BATCH_ROUNDS: usize = 9;
const SEQUENCES: [&str; 3] = ["graf", "boat", "leuven"];
/// Images per sequence (img1 to img6).
const IMAGES: usize = 6;

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
    let mut ratios: Vec<(String, f64, f64)> = Vec::new();
    for seq in SEQUENCES {
        for i in 1..=IMAGES {
            let name = format!("{seq} img{i}");
            let gray = mser::load_gray(root.join(seq).join(format!("img{i}.png")))?;
            let img = GrayView::from_image(&gray)?;
            let mut det = Mser::new(p.clone())?;
            let mut cv = mser::OpenCvMser::new(&p)?;
            print!("{name}: ");
            let agreed = check_agreement(&img, &mut det, &mut cv)?;
            let n = agreed.regions;
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
            let excused = if agreed.excused > 0 {
                format!(", {} excused as parent ties", agreed.excused)
            } else {
                String::new()
            };
            let summaries = BenchRow::lower_is_better(
                format!("{name}: summaries vs detectRegions ({n} regions{excused})"),
                ours * 1e3,
                theirs * 1e3,
                "ms CPU",
            );
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
            let with_pixels = BenchRow::lower_is_better(
                format!("{name}: summaries + pixel lists vs detectRegions"),
                ours * 1e3,
                theirs * 1e3,
                "ms CPU",
            );
            println!(
                "{name}: summaries {:.2}x ({:.2} vs {:.2} ms), with pixel lists {:.2}x ({:.2} vs {:.2} ms)",
                summaries.ratio,
                summaries.ours,
                summaries.peer,
                with_pixels.ratio,
                with_pixels.ours,
                with_pixels.peer
            );
            ratios.push((name, summaries.ratio, with_pixels.ratio));
            rows.push(summaries);
            rows.push(with_pixels);
        }
    }
    println!("speed-up over OpenCV per set (min / median / max over img1-img{IMAGES}):");
    for seq in SEQUENCES {
        let of_set = |pick: fn(&(String, f64, f64)) -> f64| {
            let mut v: Vec<f64> = ratios
                .iter()
                .filter(|r| r.0.starts_with(seq))
                .map(pick)
                .collect();
            v.sort_by(f64::total_cmp);
            format!(
                "{:.2} / {:.2} / {:.2}",
                v[0],
                crate::report::median(&mut v.clone()),
                v[v.len() - 1]
            )
        };
        println!(
            "  {seq:<7} summaries {}   with pixel lists {}",
            of_set(|r| r.1),
            of_set(|r| r.2)
        );
    }
    Ok(rows)
}

/// What [`check_agreement`] found: the number of our regions on the full image, and how many
/// of ours on the inner image OpenCV lacks because of its parent-tie rule.
#[cfg(feature = "opencv")]
#[derive(Debug, Clone, Copy)]
pub(super) struct Agreement {
    pub regions: usize,
    pub excused: usize,
}

/// Asserts that both detectors find the same regions (see the module docs) and that our pixel
/// lists are the regions' pixels. The one difference allowed is OpenCV 4.x's parent-tie rule
/// (crate docs of `mser`, "OpenCV"): a region of ours that OpenCV lacks is excused only when
/// `mser::variations_by_thresholds` shows, by thresholding the image, that its positive
/// variation exactly equals its parent's; every OpenCV region must be ours.
#[cfg(feature = "opencv")]
pub(super) fn check_agreement(
    img: &GrayView,
    det: &mut Mser,
    cv: &mut mser::OpenCvMser,
) -> Result<Agreement> {
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
    let params = det.params().clone();
    let ours: Vec<(mser::Region, Vec<(u32, u32)>)> = det
        .detect_with_pixels(&inner)?
        .iter()
        .map(|(r, px)| {
            let mut v: Vec<(u32, u32)> = px.iter().map(|&(x, y)| (x + 1, y + 1)).collect();
            v.sort_unstable_by_key(|&(x, y)| (y, x));
            (r.clone(), v)
        })
        .collect();
    let theirs = cv.detect(img)?;
    let b: HashSet<&Vec<(u32, u32)>> = theirs.iter().collect();
    let a: HashSet<&Vec<(u32, u32)>> = ours.iter().map(|(_, v)| v).collect();
    if b.len() != theirs.len() || a.len() != ours.len() {
        return Err(format!(
            "repeated pixel sets: ours {} ({} distinct), OpenCV {} ({} distinct)",
            ours.len(),
            a.len(),
            theirs.len(),
            b.len()
        )
        .into());
    }
    if let Some(s) = theirs.iter().find(|s| !a.contains(s)) {
        return Err(format!(
            "an OpenCV region of {} pixels at {:?} is not ours",
            s.len(),
            s[0]
        )
        .into());
    }
    let mut excused = 0;
    for (r, v) in ours.iter().filter(|(_, v)| !b.contains(v)) {
        let t = mser::variations_by_thresholds(&inner, r, &params)?;
        if t.region.value() != r.variation || !t.is_positive_parent_tie() {
            return Err(format!(
                "region sets differ: ours only {r:?} ({} pixels), not a positive tie with its parent ({t:?})",
                v.len()
            )
            .into());
        }
        excused += 1;
    }
    debug_assert_eq!(ours.len(), theirs.len() + excused);
    println!(
        "region sets agree: {} regions, identical pixel sets both ways (ours without the outer ring){}; ours on the full image: {}",
        theirs.len(),
        if excused > 0 {
            format!(
                ", excused {excused} of ours that OpenCV drops by its parent-tie rule (positive variation equal to the parent's, checked by thresholding)"
            )
        } else {
            String::new()
        },
        plain.len()
    );
    Ok(Agreement {
        regions: plain.len(),
        excused,
    })
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
        WALL_ROUNDS,
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
        WALL_ROUNDS,
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
    polarity_split(&img, &p)?;

    // A batch: all 18 images of the three sequences.
    let mut grays = Vec::new();
    for s in SEQUENCES {
        for i in 1..=IMAGES {
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
        BATCH_ROUNDS,
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

/// Where the wall time of the two polarity tasks goes, on graf img1: each polarity on a
/// detector of its own, first alone on this thread, then both in one `rayon::join` as
/// `detect_parallel` does, with each task's start delay after the join began (waking a
/// worker), its thread CPU time and its wall time (CPU time plus time spent waiting for a core
/// that other processes held); medians over the rounds. Unequal halves show as unequal CPU
/// times, shared caches as task CPU times above the solo ones, a busy machine as task wall
/// above task CPU.
fn polarity_split(img: &GrayView, p: &MserParams) -> Result<()> {
    use super::cpu::thread_seconds;
    use crate::report::median;
    use std::time::Instant;
    let one = |polarities| {
        Mser::new(MserParams {
            polarities,
            ..p.clone()
        })
    };
    let mut dets = [one(mser::Polarities::Dark)?, one(mser::Polarities::Bright)?];
    let cpu = || thread_seconds().ok_or("no thread CPU clock");
    // (start delay, CPU, wall) of one task.
    let task = |det: &mut Mser, t0: Instant| -> (f64, f64, f64) {
        let start = t0.elapsed().as_secs_f64();
        let c0 = thread_seconds().unwrap_or(f64::NAN);
        std::hint::black_box(det.detect(img).expect("valid").len());
        let c = thread_seconds().unwrap_or(f64::NAN) - c0;
        (start, c, t0.elapsed().as_secs_f64() - start)
    };
    let mut solo = [Vec::new(), Vec::new()];
    let mut split: [[Vec<f64>; 3]; 2] = Default::default();
    let mut total = Vec::new();
    for round in 0..WARMUP + WALL_ROUNDS {
        let mut alone = [0.0; 2];
        for (a, d) in alone.iter_mut().zip(dets.iter_mut()) {
            let c0 = cpu()?;
            std::hint::black_box(d.detect(img)?.len());
            *a = cpu()? - c0;
        }
        let [dark, bright] = &mut dets;
        let t0 = Instant::now();
        let (a, b) = rayon::join(|| task(dark, t0), || task(bright, t0));
        let wall = t0.elapsed().as_secs_f64();
        if round >= WARMUP {
            for (k, t) in [a, b].into_iter().enumerate() {
                solo[k].push(alone[k]);
                split[k][0].push(t.0);
                split[k][1].push(t.1);
                split[k][2].push(t.2);
            }
            total.push(wall);
        }
    }
    let ms = |v: &mut Vec<f64>| median(v) * 1e3;
    println!(
        "graf img1, the two polarity tasks (medians of {WALL_ROUNDS} rounds, ms): join wall {:.2}; load average {}",
        ms(&mut total),
        load_average()
    );
    for (k, name) in ["dark", "bright"].into_iter().enumerate() {
        let [start, c, w] = &mut split[k];
        println!(
            "  {name:<6}: alone {:.2} CPU; in the join: start after {:.3}, {:.2} CPU, {:.2} wall",
            ms(&mut solo[k]),
            ms(start),
            ms(c),
            ms(w)
        );
    }
    Ok(())
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
