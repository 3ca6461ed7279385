//! The Rust side of `python/benchmarks/overhead.py`: the same MSER detection and LWPR batch
//! update as the Python calls, on the same bytes, timed in thread CPU time
//! (`/proc/thread-self/schedstat`, Linux) because the machine is shared.
//!
//! `cargo run --release -p visguide-py --example overhead -- IMAGE.raw WIDTH HEIGHT SAMPLES.f64 REPS`
//! (written by the Python script); prints one JSON line.

use std::time::Duration;

/// CPU time this thread has run.
fn thread_cpu() -> Duration {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").expect("Linux schedstat");
    let ns: u64 = s.split_whitespace().next().unwrap().parse().unwrap();
    Duration::from_nanos(ns)
}

/// Seconds of thread CPU time per run of `f`: the median over 5 blocks of the mean of `reps`
/// runs (schedstat advances in scheduler ticks, so single runs are too short to time).
fn median_cpu(reps: usize, mut f: impl FnMut()) -> f64 {
    let mut t: Vec<f64> = (0..5)
        .map(|_| {
            let t0 = thread_cpu();
            for _ in 0..reps {
                f();
            }
            (thread_cpu() - t0).as_secs_f64() / reps as f64
        })
        .collect();
    t.sort_by(f64::total_cmp);
    t[2]
}

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let [_, img, w, h, samples, reps] = &a[..] else {
        eprintln!("usage: overhead IMAGE.raw WIDTH HEIGHT SAMPLES.f64 REPS");
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
    let n_regions = mser::detect(&view, &params).unwrap().len();
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
    let mut digest = String::new();
    let lwpr_s = median_cpu(reps, || {
        let mut m = build();
        let mut out = [0.0];
        for r in v.chunks_exact(3) {
            m.update_into(&r[..2], &r[2..], &mut out).unwrap();
        }
        digest = format!("{:x}", m.to_binary().len() ^ m.num_rfs()[0]);
    });
    println!(
        "{{\"mser_regions\": {n_regions}, \"mser_cpu_s\": {mser_s}, \"lwpr_samples\": {}, \"lwpr_cpu_s\": {lwpr_s}, \"lwpr_check\": \"{digest}\"}}",
        v.len() / 3
    );
}
