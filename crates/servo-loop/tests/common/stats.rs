//! Order statistics shared by servo-loop's tests and, on the simulator, visguide's (included
//! with `#[path]`, not part of the library).

/// Nearest-rank quantile: the value of rank `⌊q·n⌋` (0-based, at most `n − 1`) of the sorted
/// values, so `q = 0.5` is the upper median; NaN when there are none. Sorts `v` in place.
pub fn quantile(v: &mut [f64], q: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[((v.len() as f64 * q) as usize).min(v.len() - 1)]
}

/// The upper median (`quantile(v, 0.5)`).
#[allow(dead_code)] // not every includer needs it
pub fn median(v: &mut [f64]) -> f64 {
    quantile(v, 0.5)
}
