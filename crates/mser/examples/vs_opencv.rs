//! Times ours against OpenCV on the Oxford img1 images (feature `opencv`): both polarities,
//! default parameters, one thread, the two detectors alternating run by run so that both see the
//! same machine load.
//!
//! `VISGUIDE_DATA=... cargo run --release -p mser --features opencv --example vs_opencv [RUNS]`
//!
//! Prints the minimum and median of the wall-clock time and, on Linux, of the thread's CPU time
//! (`CLOCK_THREAD_CPUTIME_ID`), which leaves out the time the thread waits for a core while
//! other processes run: on a shared, loaded machine it is the steadier figure.

#[cfg(feature = "opencv")]
fn main() -> Result<(), Box<dyn std::error::Error>> {
    use std::time::Instant;
    let root = std::path::PathBuf::from(std::env::var("VISGUIDE_DATA")?).join("oxford-affine");
    let runs: usize = match std::env::args().nth(1) {
        Some(s) => s.parse()?,
        None => 31,
    };
    mser::set_opencv_threads(1)?;
    let p = mser::MserParams::default();
    println!(
        "OpenCV {}, {runs} runs each after one warm-up",
        mser::opencv_version()
    );
    for seq in ["graf", "boat", "leuven"] {
        let g = mser::load_gray(root.join(seq).join("img1.png"))?;
        let img = mser::GrayView::from_image(&g)?;
        let mut ours = mser::Mser::new(p.clone())?;
        let mut cv = mser::OpenCvMser::new(&p)?;
        let mat = mser::OpenCvMser::mat(&img)?;
        let (n1, n2) = (ours.detect(&img)?.len(), cv.detect_mat(&mat)?);
        // [ours wall, ours cpu, opencv wall, opencv cpu] in ms.
        let mut t: [Vec<f64>; 4] = Default::default();
        for _ in 0..runs {
            let (w0, c0) = (Instant::now(), cpu_ns());
            std::hint::black_box(ours.detect(&img)?);
            let (w1, c1) = (Instant::now(), cpu_ns());
            std::hint::black_box(cv.detect_mat(&mat)?);
            let (w2, c2) = (Instant::now(), cpu_ns());
            t[0].push((w1 - w0).as_secs_f64() * 1e3);
            t[1].push((c1 - c0) as f64 * 1e-6);
            t[2].push((w2 - w1).as_secs_f64() * 1e3);
            t[3].push((c2 - c1) as f64 * 1e-6);
        }
        let s = t.map(|mut v| {
            v.sort_by(f64::total_cmp);
            (v[0], v[v.len() / 2])
        });
        println!("{seq} ({n1} regions, OpenCV {n2}):");
        for (what, o, c) in [("wall", s[0], s[2]), ("cpu ", s[1], s[3])] {
            println!(
                "  {what}: ours min {:.2} med {:.2} ms | OpenCV min {:.2} med {:.2} ms | ratio min {:.2} med {:.2}",
                o.0,
                o.1,
                c.0,
                c.1,
                c.0 / o.0,
                c.1 / o.1
            );
        }
    }
    Ok(())
}

/// CPU time of the calling thread in ns (64-bit Linux), `0` elsewhere (the CPU rows then read 0/NaN).
#[cfg(all(feature = "opencv", target_os = "linux", target_pointer_width = "64"))]
fn cpu_ns() -> u64 {
    #[repr(C)]
    struct Timespec {
        sec: i64,
        nsec: i64,
    }
    unsafe extern "C" {
        fn clock_gettime(clock: i32, tp: *mut Timespec) -> i32;
    }
    const CLOCK_THREAD_CPUTIME_ID: i32 = 3;
    let mut t = Timespec { sec: 0, nsec: 0 };
    // SAFETY: `clock_gettime` from the C library (always linked on Linux) writes one `timespec`
    // (two 64-bit fields on 64-bit Linux, the only target this is compiled for) through a valid pointer.
    let rc = unsafe { clock_gettime(CLOCK_THREAD_CPUTIME_ID, &mut t) };
    if rc != 0 {
        return 0;
    }
    (t.sec as u64) * 1_000_000_000 + t.nsec as u64
}

#[cfg(all(
    feature = "opencv",
    not(all(target_os = "linux", target_pointer_width = "64"))
))]
fn cpu_ns() -> u64 {
    0
}

#[cfg(not(feature = "opencv"))]
fn main() {
    eprintln!("build with --features opencv");
}
