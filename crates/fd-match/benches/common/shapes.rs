//! Random smooth closed contours for the speed measurements: shared by the criterion bench
//! (`benches/fd.rs`) and `cargo xtask bench fd` (included with `#[path]`, not part of the
//! library), so both time the same shapes.
#![allow(dead_code)]

use std::f64::consts::PI;

use fd_match::Complex64;
use rand::{RngExt, SeedableRng, rngs::StdRng, seq::SliceRandom};

/// A closed contour as `(x, y)` points.
pub type Contour = Vec<(f64, f64)>;

/// A random closed curve of 200 points: a Fourier series with a unit first harmonic, a random
/// elongation (harmonic −1) and random harmonics ±2..=8 decaying as `n^-1.3`, radius 30.
pub fn shape(rng: &mut StdRng) -> Contour {
    let mut coef = vec![(1isize, Complex64::new(1.0, 0.0))];
    coef.push((
        -1,
        Complex64::from_polar(rng.random_range(0.0..0.5), rng.random_range(0.0..2.0 * PI)),
    ));
    for n in 2..=8isize {
        for s in [n, -n] {
            let amp = rng.random_range(0.0..0.3) / (n as f64).powf(1.3);
            coef.push((
                s,
                Complex64::from_polar(amp, rng.random_range(0.0..2.0 * PI)),
            ));
        }
    }
    let m = 200;
    (0..m)
        .map(|j| {
            let t = 2.0 * PI * j as f64 / m as f64;
            let z: Complex64 = coef
                .iter()
                .map(|&(n, c)| c * Complex64::from_polar(30.0, n as f64 * t))
                .sum();
            (z.re, z.im)
        })
        .collect()
}

/// `n` random shapes from `seed`.
pub fn contours(n: usize, seed: u64) -> Vec<Contour> {
    let mut rng = StdRng::seed_from_u64(seed);
    (0..n).map(|_| shape(&mut rng)).collect()
}

/// The synthetic images of `cargo xtask bench fd` and of the instruction-count example: image A
/// holds `n` random curves; image B holds similarity-transformed, start-shifted, jittered copies
/// of the first `7n/10` of them and `n − 7n/10` unrelated curves, shuffled (fixed seed).
pub fn bench_images(n: usize) -> (Vec<Contour>, Vec<Contour>) {
    let mut rng = StdRng::seed_from_u64(20091201);
    let a: Vec<Contour> = (0..n).map(|_| shape(&mut rng)).collect();
    let copies = 7 * n / 10;
    let mut b: Vec<Contour> = Vec::with_capacity(n);
    for c in a.iter().take(copies) {
        let (phi, s) = (rng.random_range(-PI..PI), rng.random_range(0.5..2.0));
        let (tx, ty) = (rng.random_range(0.0..800.0), rng.random_range(0.0..600.0));
        let shift = rng.random_range(0..c.len());
        let mut t: Contour = (0..c.len())
            .map(|i| {
                let (x, y) = c[(i + shift) % c.len()];
                let (sx, sy) = (
                    s * (x * phi.cos() - y * phi.sin()),
                    s * (x * phi.sin() + y * phi.cos()),
                );
                (
                    sx + tx + rng.random_range(-0.3..0.3),
                    sy + ty + rng.random_range(-0.3..0.3),
                )
            })
            .collect();
        t.dedup();
        b.push(t);
    }
    for _ in copies..n {
        b.push(shape(&mut rng));
    }
    b.shuffle(&mut rng);
    (a, b)
}
