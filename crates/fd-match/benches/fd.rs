//! Criterion benches: descriptor extraction per contour, one correlation, and a 300 × 300
//! best-two search (pruned against brute force). `cargo xtask bench fd` runs the 1,000 × 1,000
//! comparison against the naive method.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use fd_match::{
    Correlator, DescriptorConfig, DescriptorSet, Extractor, Method, Sampling, best_two,
    best_two_brute_force, describe_all,
};

#[path = "common/shapes.rs"]
mod shapes;

use shapes::contours;

fn extraction(c: &mut Criterion) {
    let cs = contours(100, 1);
    let mut g = c.benchmark_group("describe_contour");
    g.throughput(Throughput::Elements(cs.len() as u64));
    for sampling in [
        Sampling::ArcLength,
        Sampling::AffineArcLength,
        Sampling::Canonical,
    ] {
        let cfg = DescriptorConfig::with_sampling(sampling);
        let mut ex = Extractor::new(cfg).unwrap();
        let mut set = DescriptorSet::new(cfg).unwrap();
        g.bench_function(sampling.name(), |b| {
            b.iter(|| {
                set = DescriptorSet::new(cfg).unwrap();
                for (i, c) in cs.iter().enumerate() {
                    ex.describe_into(c, &mut set, i).unwrap();
                }
            })
        });
    }
    g.finish();
}

fn matching(c: &mut Criterion) {
    let cfg = DescriptorConfig::with_sampling(Sampling::Canonical);
    let a = describe_all(cfg, &contours(300, 2)).unwrap().set;
    let b = describe_all(cfg, &contours(300, 3)).unwrap().set;
    let mut cor = Correlator::new(cfg.max_frequency(), cfg.samples).unwrap();
    c.bench_function("correlate_pair", |bch| {
        bch.iter(|| cor.correlate(a.fd(0), b.fd(1)).unwrap())
    });
    let mut g = c.benchmark_group("best_two_300x300");
    g.throughput(Throughput::Elements((a.len() * b.len()) as u64));
    g.sample_size(10);
    g.bench_function("fd_corr_pruned", |bch| {
        bch.iter(|| best_two(&a, &b, Method::FdCorr).unwrap())
    });
    g.bench_function("fd_corr_brute_force", |bch| {
        bch.iter(|| best_two_brute_force(&a, &b, Method::FdCorr).unwrap())
    });
    g.bench_function("abs_fd_ssd", |bch| {
        bch.iter(|| best_two(&a, &b, Method::AbsFdSsd).unwrap())
    });
    g.finish();
}

criterion_group!(benches, extraction, matching);
criterion_main!(benches);
