//! The table's procedural wood-like texture: hashed lattice value noise (smooth, deterministic,
//! no tables) and a grain pattern warped by it.

/// A deterministic hash of a lattice point to `[-1, 1]` (SplitMix64 finaliser).
fn lattice(ix: i64, iy: i64, seed: u64) -> f64 {
    let mut z = seed
        .wrapping_add((ix as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15))
        .wrapping_add((iy as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F));
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 52) as f64 - 1.0
}

/// Smooth value noise in `[-1, 1]` at `(x, y)` (lattice spacing 1).
pub fn value_noise(x: f64, y: f64, seed: u64) -> f64 {
    let (fx, fy) = (x.floor(), y.floor());
    // Far inside i64, so `ix + 1` cannot overflow: table points lie within
    // ±`MAX_TABLE_EXTENT_MM` (checked by `SimConfig::validate`), scaled down here.
    let (ix, iy) = (fx as i64, fy as i64);
    let (tx, ty) = (x - fx, y - fy);
    let (sx, sy) = (tx * tx * (3.0 - 2.0 * tx), ty * ty * (3.0 - 2.0 * ty));
    let a = lattice(ix, iy, seed);
    let b = lattice(ix + 1, iy, seed);
    let c = lattice(ix, iy + 1, seed);
    let d = lattice(ix + 1, iy + 1, seed);
    let top = a + (b - a) * sx;
    let bottom = c + (d - c) * sx;
    top + (bottom - top) * sy
}

/// The table pattern at table coordinates `(x, y)` (mm), in `[-1, 1]`: wood grain running along
/// `x` (period about 9 mm, warped by low-frequency noise) mixed with blotchy mid-frequency noise.
pub fn table_pattern(x: f64, y: f64, seed: u64) -> f64 {
    let warp = 5.0 * value_noise(x / 160.0, y / 45.0, seed);
    let grain = (y / 9.0 * std::f64::consts::TAU / 1.0 + warp).sin();
    let blotch = value_noise(x / 28.0, y / 28.0, seed ^ 0x5555)
        + 0.5 * value_noise(x / 11.0, y / 11.0, seed ^ 0xAAAA);
    (0.55 * grain + 0.45 * blotch / 1.5).clamp(-1.0, 1.0)
}
