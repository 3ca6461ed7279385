//! Synthetic contours and the list of every matching method, for the tests.

use std::f64::consts::PI;

use fd_match::Method;
use rand::{RngExt, SeedableRng, rngs::StdRng};

/// Every matching method: the paper's four and plain `FD SSD`.
pub const ALL: [Method; 5] = [
    Method::FdCorr,
    Method::AbsFdSsd,
    Method::Afd0Ssd,
    Method::Afd1Ssd,
    Method::FdSsd,
];

/// A smooth random star-shaped polygon with `n` vertices around the origin: radius
/// `1 + Σ_{k=2..=6} a_k cos(k·α + p_k)` with `Σ|a_k| ≤ 0.6`, mean radius `r0`.
pub fn star(seed: u64, n: usize, r0: f64) -> Vec<(f64, f64)> {
    let mut rng = StdRng::seed_from_u64(seed);
    let terms: Vec<(f64, f64, f64)> = (2..=6)
        .map(|k| {
            (
                k as f64,
                rng.random_range(0.02..0.12),
                rng.random_range(0.0..2.0 * PI),
            )
        })
        .collect();
    (0..n)
        .map(|i| {
            let a = 2.0 * PI * i as f64 / n as f64;
            let r = r0
                * (1.0
                    + terms
                        .iter()
                        .map(|(k, amp, p)| amp * (k * a + p).cos())
                        .sum::<f64>());
            (r * a.cos(), r * a.sin())
        })
        .collect()
}

/// `p ↦ A p + t` applied to every point.
pub fn affine(pts: &[(f64, f64)], a: [[f64; 2]; 2], t: (f64, f64)) -> Vec<(f64, f64)> {
    pts.iter()
        .map(|&(x, y)| {
            (
                a[0][0] * x + a[0][1] * y + t.0,
                a[1][0] * x + a[1][1] * y + t.1,
            )
        })
        .collect()
}

/// Rotation by `phi`, scaling by `s`, translation by `t`.
pub fn similarity(pts: &[(f64, f64)], phi: f64, s: f64, t: (f64, f64)) -> Vec<(f64, f64)> {
    let (c, si) = (s * phi.cos(), s * phi.sin());
    affine(pts, [[c, -si], [si, c]], t)
}

/// Cyclic start shift by `m` vertices.
pub fn rotate_start(pts: &[(f64, f64)], m: usize) -> Vec<(f64, f64)> {
    let m = m % pts.len();
    pts[m..].iter().chain(&pts[..m]).copied().collect()
}

/// Perimeter and arc length from vertex 0 to vertex `m`.
pub fn arc_to(pts: &[(f64, f64)], m: usize) -> (f64, f64) {
    let n = pts.len();
    let d = |i: usize| {
        let (a, b) = (pts[i], pts[(i + 1) % n]);
        ((b.0 - a.0).powi(2) + (b.1 - a.1).powi(2)).sqrt()
    };
    let per: f64 = (0..n).map(d).sum();
    let s: f64 = (0..m % n).map(d).sum();
    (per, s)
}

/// Wraps an angle difference into (−π, π].
pub fn wrap(a: f64) -> f64 {
    let w = a.rem_euclid(2.0 * PI);
    if w > PI { w - 2.0 * PI } else { w }
}

/// Cyclic distance of two shifts on a period `l`.
pub fn cyclic(a: f64, b: f64, l: f64) -> f64 {
    let d = (a - b).rem_euclid(l);
    d.min(l - d)
}
