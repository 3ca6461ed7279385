//! Criterion benches: encoding 1e6 scalars into a soft histogram, and decoding.

use chan_repr::{ChannelBasis, Kernel, SoftHistogram};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use rand::{RngExt, SeedableRng, rngs::StdRng};

fn samples(n: usize, lo: f64, hi: f64) -> Vec<f64> {
    let mut rng = StdRng::seed_from_u64(7);
    (0..n).map(|_| rng.random_range(lo..=hi)).collect()
}

fn encode(c: &mut Criterion) {
    let mut g = c.benchmark_group("soft_histogram_encode_1e6");
    g.throughput(Throughput::Elements(1_000_000));
    for (name, kernel) in [
        ("cos2_m3", Kernel::Cos2 { m: 3 }),
        ("bspline2", Kernel::BSpline2),
        ("gaussian_0.7", Kernel::Gaussian { sigma: 0.7 }),
    ] {
        let basis = ChannelBasis::covering(0.0, 1.0, 64, kernel).unwrap();
        let xs = samples(1_000_000, 0.0, 1.0);
        g.bench_function(name, |b| {
            b.iter(|| {
                let mut h = SoftHistogram::one_d(basis.clone());
                h.extend_1d(&xs).unwrap();
                h
            })
        });
    }
    g.finish();
}

fn decode(c: &mut Criterion) {
    let mut g = c.benchmark_group("decode");
    for (name, kernel) in [
        ("cos2_m3", Kernel::Cos2 { m: 3 }),
        ("bspline2", Kernel::BSpline2),
    ] {
        let basis = ChannelBasis::covering(0.0, 1.0, 64, kernel).unwrap();
        let mut h = SoftHistogram::one_d(basis.clone());
        h.extend_1d(&samples(1000, 0.2, 0.25)).unwrap();
        h.extend_1d(&samples(500, 0.7, 0.72)).unwrap();
        g.bench_function(format!("{name}_64_channels"), |b| {
            b.iter(|| basis.decode(h.counts()).unwrap())
        });
    }
    g.finish();
}

criterion_group!(benches, encode, decode);
criterion_main!(benches);
