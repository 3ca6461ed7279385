//! Criterion benches of `update` and `predict` on the cross function (setting A of
//! docs/methods.md § LWPR) and on its 25-D embedding.

use criterion::{Criterion, criterion_group, criterion_main};
use lwpr::{Lwpr, LwprBuilder};
use std::hint::black_box;

fn cross(x1: f64, x2: f64) -> f64 {
    (-10.0 * x1 * x1)
        .exp()
        .max((-50.0 * x2 * x2).exp())
        .max(1.25 * (-5.0 * (x1 * x1 + x2 * x2)).exp())
}

/// splitmix64 uniform in [-1, 1).
fn samples(n: usize, dim: usize, seed: u64) -> Vec<f64> {
    let mut s = seed;
    (0..n * dim)
        .map(|_| {
            s = s.wrapping_add(0x9E3779B97F4A7C15);
            let mut z = s;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58476D1CE4E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D049BB133111EB);
            z ^= z >> 31;
            2.0 * ((z >> 11) as f64 / 9007199254740992.0) - 1.0
        })
        .collect()
}

fn trained_2d(xs: &[f64]) -> Lwpr {
    let mut m = LwprBuilder::new(2, 1)
        .init_d_spherical(50.0)
        .init_alpha(250.0)
        .w_gen(0.2)
        .build()
        .unwrap();
    for x in xs.chunks(2) {
        m.update(x, &[cross(x[0], x[1])]).unwrap();
    }
    m
}

fn embed(x: &[f64], dim: usize) -> Vec<f64> {
    // A fixed rotation mixing the first two coordinates into all `dim` (Householder reflection).
    let v: Vec<f64> = (0..dim).map(|i| ((i * 7 + 3) % 11) as f64 - 5.0).collect();
    let nv: f64 = v.iter().map(|a| a * a).sum();
    let mut e = vec![0.0; dim];
    e[0] = x[0];
    e[1] = x[1];
    let dotv: f64 = v.iter().zip(&e).map(|(a, b)| a * b).sum();
    e.iter()
        .zip(&v)
        .map(|(a, b)| a - 2.0 * dotv / nv * b)
        .collect()
}

fn bench(c: &mut Criterion) {
    let xs = samples(20_000, 2, 1);
    let model = trained_2d(&xs);
    let mut yp = [0.0];
    let mut g = c.benchmark_group("cross-2d");
    g.bench_function("update (grown model, 20k samples seen)", |b| {
        let mut m = model.clone();
        let mut i = 0;
        b.iter(|| {
            let x = &xs[2 * (i % 20_000)..2 * (i % 20_000) + 2];
            i += 1;
            m.update_into(black_box(x), &[cross(x[0], x[1])], &mut yp)
                .unwrap();
        })
    });
    g.bench_function("predict", |b| {
        let mut i = 0;
        b.iter(|| {
            let x = &xs[2 * (i % 20_000)..2 * (i % 20_000) + 2];
            i += 1;
            model.predict_into(black_box(x), 0.001, &mut yp).unwrap();
        })
    });
    g.finish();

    let dim = 25;
    let xs25: Vec<Vec<f64>> = samples(5_000, 2, 2)
        .chunks(2)
        .map(|x| embed(x, dim))
        .collect();
    let ys25: Vec<f64> = samples(5_000, 2, 2)
        .chunks(2)
        .map(|x| cross(x[0], x[1]))
        .collect();
    let mut m25 = LwprBuilder::new(dim, 1)
        .init_d_spherical(0.25)
        .diag_only(false)
        .w_gen(0.2)
        .w_prune(0.7)
        .meta(true)
        .build()
        .unwrap();
    for (x, y) in xs25.iter().zip(&ys25) {
        m25.update(x, &[*y]).unwrap();
    }
    let mut g = c.benchmark_group("cross-25d");
    g.sample_size(20);
    g.bench_function("update", |b| {
        let mut m = m25.clone();
        let mut i = 0;
        b.iter(|| {
            let k = i % xs25.len();
            i += 1;
            m.update_into(black_box(&xs25[k]), &[ys25[k]], &mut yp)
                .unwrap();
        })
    });
    g.bench_function("predict", |b| {
        let mut i = 0;
        b.iter(|| {
            let k = i % xs25.len();
            i += 1;
            m25.predict_into(black_box(&xs25[k]), 0.001, &mut yp)
                .unwrap();
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
