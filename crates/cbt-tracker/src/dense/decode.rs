//! Decoding of a posterior over the joint grid with `chan-repr`'s local decoder, restricted to
//! the neighbourhoods of the heaviest windows.
//!
//! [`chan_repr::ChannelGrid::decode`] decodes every window of the grid (`O(G)` windows, each
//! with `W` complex exponentials per axis). A posterior has few modes, so this module first
//! finds the candidate windows — local maxima of the window mass `r_l` (eq. 2.5) holding at
//! least [`MIN_SHARE`] of the largest — and runs the same decoder on a patch of `W + 2`
//! channels per axis around each (the window and its neighbours). The best mode is the full
//! decoder's whenever the heaviest valid window lies next to a local maximum of the window
//! mass (tested against the full decoder).

use chan_repr::{ChannelBasis, ChannelGrid, ModeNd};

use crate::Space;

/// Smallest window mass (relative to the largest) considered as a candidate mode: a
/// runner-up with less than 1 % of the best mode's mass is not reported.
pub const MIN_SHARE: f64 = 1e-2;

/// The modes of `q` by decreasing certainty (at most `max_modes`).
pub(crate) fn decode_posterior(space: &Space, q: &[f64], max_modes: usize) -> Vec<ModeNd> {
    let dims = space.dims();
    let w: Vec<usize> = (0..dims)
        .map(|d| space.state_basis(d).kernel().window())
        .collect();
    let n: Vec<usize> = (0..dims).map(|d| space.axis_len(d)).collect();
    let nw: Vec<usize> = (0..dims).map(|d| n[d] - w[d] + 1).collect();
    // Window sums `r_l` (eq. 2.5), separably: along y (contiguous) first, then along x.
    let sums: Vec<f64> = if dims == 1 {
        box_sum(q, w[0]).collect()
    } else {
        let mut rows = Vec::with_capacity(n[0] * nw[1]);
        for row in q.chunks_exact(n[1]) {
            rows.extend(box_sum(row, w[1]));
        }
        let mut out = vec![0.0; nw[0] * nw[1]];
        for (i, dst) in out.chunks_exact_mut(nw[1]).enumerate() {
            for k in 0..w[0] {
                let src = &rows[(i + k) * nw[1]..(i + k + 1) * nw[1]];
                for (d, s) in dst.iter_mut().zip(src) {
                    *d += s;
                }
            }
        }
        out
    };
    let max = sums.iter().fold(0.0f64, |a, &b| a.max(b));
    if max <= 0.0 {
        return Vec::new();
    }
    let (wy, ny) = if dims == 2 { (nw[1], nw[1]) } else { (1, 1) };
    let _ = wy;
    let mut cands: Vec<(usize, f64)> = Vec::new();
    for (l, &v) in sums.iter().enumerate() {
        if v < MIN_SHARE * max {
            continue;
        }
        let (i, j) = if dims == 2 { (l / ny, l % ny) } else { (l, 0) };
        let mut is_max = true;
        'nb: for di in -1i64..=1 {
            for dj in -1i64..=1 {
                if (di, dj) == (0, 0) || (dims == 1 && dj != 0) {
                    continue;
                }
                let (a, b) = (i as i64 + di, j as i64 + dj);
                if a < 0 || b < 0 || a >= nw[0] as i64 || (dims == 2 && b >= ny as i64) {
                    continue;
                }
                let m = a as usize * if dims == 2 { ny } else { 1 } + b as usize;
                // Ties: the first window in scan order wins.
                if sums[m] > v || (sums[m] == v && m < l) {
                    is_max = false;
                    break 'nb;
                }
            }
        }
        if is_max {
            cands.push((l, v));
        }
    }
    cands.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
    cands.truncate(2 * max_modes.max(1));
    let mut modes: Vec<ModeNd> = Vec::new();
    for &(l, _) in &cands {
        let start = if dims == 2 { [l / ny, l % ny] } else { [l, 0] };
        for m in decode_patch(space, q, &start[..dims], &w, &n) {
            let dup = modes.iter().any(|k| {
                k.value
                    .iter()
                    .zip(&m.value)
                    .enumerate()
                    .all(|(d, (a, b))| (a - b).abs() <= 1e-6 * space.state_basis(d).spacing())
            });
            if !dup {
                modes.push(m);
            }
        }
    }
    modes.sort_by(|a, b| {
        b.certainty.total_cmp(&a.certainty).then_with(|| {
            a.value
                .partial_cmp(&b.value)
                .unwrap_or(std::cmp::Ordering::Equal)
        })
    });
    modes.truncate(max_modes);
    modes
}

/// Sums of `w` consecutive entries: `len − w + 1` values, each summed directly (no running
/// sum, so no rounding drift).
fn box_sum(x: &[f64], w: usize) -> impl Iterator<Item = f64> + '_ {
    x.windows(w).map(|win| win.iter().sum())
}

/// Decodes the patch of windows around window `start` with `chan-repr`'s n-D decoder.
fn decode_patch(
    space: &Space,
    q: &[f64],
    start: &[usize],
    w: &[usize],
    n: &[usize],
) -> Vec<ModeNd> {
    let dims = start.len();
    let mut lo = [0usize; 2];
    let mut len = [1usize; 2];
    let mut bases = Vec::with_capacity(dims);
    for d in 0..dims {
        lo[d] = start[d].saturating_sub(1);
        let hi = (start[d] + w[d] + 1).min(n[d]);
        len[d] = hi - lo[d];
        let b = space.state_basis(d);
        match ChannelBasis::new(b.centre(lo[d]), b.spacing(), len[d], b.kernel()) {
            Ok(sub) => bases.push(sub),
            Err(_) => return Vec::new(),
        }
    }
    let Ok(grid) = ChannelGrid::new(bases) else {
        return Vec::new();
    };
    let mut patch = Vec::with_capacity(len[0] * len[1]);
    if dims == 1 {
        patch.extend_from_slice(&q[lo[0]..lo[0] + len[0]]);
    } else {
        for i in lo[0]..lo[0] + len[0] {
            let row = i * n[1];
            patch.extend_from_slice(&q[row + lo[1]..row + lo[1] + len[1]]);
        }
    }
    grid.decode(&patch).unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::rng_for;
    use rand::RngExt;

    /// Random mixtures of one to three encoded points plus a floor: the best mode equals the
    /// full decoder's, and every mode found is one of the full decoder's modes.
    #[test]
    fn matches_the_full_decoder() {
        for (dims, case) in (0..200).map(|c| (1 + c % 2, c)) {
            let space = if dims == 2 {
                Space::image(60.0, 40.0, 2.0).unwrap()
            } else {
                let b = ChannelBasis::covering(0.0, 50.0, 40, crate::DEFAULT_KERNEL).unwrap();
                Space::new(vec![b.clone()], vec![b]).unwrap()
            };
            let mut rng = rng_for(77, case as u64);
            let grid = space.grid().clone();
            let mut q = vec![1e-6; grid.len()];
            for _ in 0..1 + case % 3 {
                let p: Vec<f64> = (0..dims)
                    .map(|d| {
                        let (lo, hi) = space.state_basis(d).representable_range();
                        lo + (hi - lo) * rng.random::<f64>()
                    })
                    .collect();
                grid.accumulate(&p, 0.2 + rng.random::<f64>(), &mut q)
                    .unwrap();
            }
            let full = grid.decode(&q).unwrap();
            let fast = decode_posterior(&space, &q, 4);
            // Equal up to rounding (the patch's basis starts at a shifted centre).
            let same = |a: &[f64], b: &[f64]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-9);
            assert!(same(&full[0].value, &fast[0].value), "case {case}");
            assert!((full[0].certainty - fast[0].certainty).abs() < 1e-12);
            for m in &fast {
                assert!(
                    full.iter().any(|f| same(&f.value, &m.value)),
                    "case {case}: {m:?}"
                );
            }
        }
    }
}
