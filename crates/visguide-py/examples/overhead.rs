//! The Rust side of `python/benchmarks/overhead.py`: the same MSER detection and LWPR batch
//! update as the Python calls, on the same bytes, timed in thread CPU time
//! (`clock_gettime(CLOCK_THREAD_CPUTIME_ID)`, the clock Python's `time.thread_time` reads)
//! because the machine is shared.
//!
//! `cargo run --release -p visguide-py --example overhead -- IMAGE.raw WIDTH HEIGHT SAMPLES.f64 REPS OUT_DIR`
//! (written by the Python script); prints one JSON line and writes what the script compares
//! with its own outputs: `OUT_DIR/regions.txt` (every region, one line, floats as their IEEE
//! bits) and `OUT_DIR/model.bin` (the trained LWPR model's binary form).

use std::fmt::Write as _;

/// Seconds of CPU time this thread has run.
fn thread_cpu() -> f64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec for the duration of the call.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    assert_eq!(rc, 0, "clock_gettime(CLOCK_THREAD_CPUTIME_ID) failed");
    ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9
}

/// Seconds of thread CPU time per run of `f`: the median over 5 blocks of the mean of `reps`
/// runs, as the Python side measures.
fn median_cpu(reps: usize, mut f: impl FnMut()) -> f64 {
    let mut t: Vec<f64> = (0..5)
        .map(|_| {
            let t0 = thread_cpu();
            for _ in 0..reps {
                f();
            }
            (thread_cpu() - t0) / reps as f64
        })
        .collect();
    t.sort_by(f64::total_cmp);
    t[2]
}

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let [_, img, w, h, samples, reps, out_dir] = &a[..] else {
        eprintln!("usage: overhead IMAGE.raw WIDTH HEIGHT SAMPLES.f64 REPS OUT_DIR");
        std::process::exit(2);
    };
    let (w, h, reps): (usize, usize, usize) = (
        w.parse().unwrap(),
        h.parse().unwrap(),
        reps.parse().unwrap(),
    );
    let px = std::fs::read(img).unwrap();
    let view = mser::GrayView::packed(&px, w, h).unwrap();
    let params = mser::MserParams::default();
    let regions = mser::detect(&view, &params).unwrap();
    let out_dir = std::path::Path::new(out_dir);
    std::fs::write(out_dir.join("regions.txt"), region_lines(&regions)).unwrap();
    let n_regions = regions.len();
    let mser_s = median_cpu(reps, || {
        std::hint::black_box(mser::detect(&view, &params).unwrap());
    });
    // Samples: rows of (x0, x1, y), little-endian f64.
    let raw = std::fs::read(samples).unwrap();
    let v: Vec<f64> = raw
        .chunks_exact(8)
        .map(|b| f64::from_le_bytes(b.try_into().unwrap()))
        .collect();
    let build = || {
        lwpr::LwprBuilder::new(2, 1)
            .init_d_spherical(50.0)
            .init_alpha(250.0)
            .build()
            .unwrap()
    };
    let mut model = Vec::new();
    let lwpr_s = median_cpu(reps, || {
        let mut m = build();
        let mut out = [0.0];
        for r in v.chunks_exact(3) {
            m.update_into(&r[..2], &r[2..], &mut out).unwrap();
        }
        model = m.to_binary();
    });
    std::fs::write(out_dir.join("model.bin"), &model).unwrap();
    println!(
        "{{\"mser_regions\": {n_regions}, \"mser_cpu_s\": {mser_s}, \"lwpr_samples\": {}, \"lwpr_cpu_s\": {lwpr_s}}}",
        v.len() / 3
    );
}

/// One line per region, every field the Python `Region` exposes (floats as their IEEE-754 bits,
/// so that equal lines mean bit-identical values): polarity, level, seed, area, variation,
/// bounding box, raw moments, centroid, ellipse.
fn region_lines(regions: &[mser::Region]) -> String {
    let mut s = String::new();
    for r in regions {
        let polarity = match r.polarity {
            mser::Polarity::Dark => "dark",
            mser::Polarity::Bright => "bright",
        };
        let (b, m, c, e) = (r.bbox, r.moments, r.centroid(), r.ellipse().unwrap());
        let bits = [r.variation, c.0, c.1, e.u, e.v, e.a, e.b, e.c].map(f64::to_bits);
        let bits: Vec<String> = bits.iter().map(u64::to_string).collect();
        writeln!(
            s,
            "{polarity} {} {} {} {} {} {} {} {} {} {} {} {} {} {} {}",
            r.level,
            r.seed.0,
            r.seed.1,
            r.area,
            b.x_min,
            b.y_min,
            b.x_max,
            b.y_max,
            m.n,
            m.sx,
            m.sy,
            m.sxx,
            m.sxy,
            m.syy,
            bits.join(" ")
        )
        .unwrap();
    }
    s
}
