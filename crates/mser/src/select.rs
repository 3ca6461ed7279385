//! Stability measure and selection of maximally stable regions on a component tree: two linear
//! passes over the nodes of at least `min_area` pixels ([`Tree::big`]), the only ones that can be
//! selected or take part in the comparisons (the variation walks at most Δ levels up and down).
//!
//! Variations are kept as exact ratios ([`Frac`]) and compared with one another by
//! cross-multiplication. This replaced a comparison of `f64` quotients; the two give the same
//! order on every image of fewer than 2^26 pixels (proof at [`Frac`]), so no output changed.
//! Cost: nothing measurable (callgrind, one detection of both polarities: −0.02 % instructions on
//! leuven img6, −0.03 % on graf img1, −0.02 % on boat img3), as the quotient for the
//! `max_variation` test is computed only for local minima.

use crate::params::MserParams;
use crate::tree::{NONE, Tree};

/// Scratch arrays of the selection, reused between images; indexed like [`Tree::big`].
#[derive(Debug, Default)]
pub struct Selector {
    var: Vec<Frac>,
    best_desc: Vec<u32>,
}

/// A variation as the exact ratio `num / den` of pixel counts (both below 2^32).
///
/// Variations are compared with one another exactly, by cross-multiplication (products below
/// 2^64), and reported as `num as f64 / den as f64`. For images of fewer than 2^26 pixels the
/// two orders coincide: if `a/b < c/d` the gap is at least `1/(bd)`, and as each quotient is
/// rounded with a relative error of at most 2^-53, `fl(a/b) < fl(c/d)` whenever
/// `2^-53 (ad + bc) < 1`, which holds for `a, b, c, d < 2^26`; equal ratios round equally. On
/// larger images the rounded quotients can tie where the ratios differ (never invert: rounding is
/// monotone); the exact comparison then decides as the definition does.
#[derive(Debug, Clone, Copy, Default)]
struct Frac {
    num: u32,
    den: u32,
}

impl Frac {
    /// `self < o` as rational numbers.
    #[inline]
    fn lt(self, o: Frac) -> bool {
        (self.num as u64) * (o.den as u64) < (o.num as u64) * (self.den as u64)
    }

    /// The variation as reported.
    #[inline]
    fn value(self) -> f64 {
        self.num as f64 / self.den as f64
    }
}

/// Flag in `best_desc`: a child of at least `min_area` pixels has a smaller variation.
const BEATEN: u32 = 1 << 31;

impl Selector {
    /// Appends the ids of the selected nodes and their variations to `out` (in id order).
    pub fn select(&mut self, tree: &Tree, p: &MserParams, out: &mut Vec<(u32, f64)>) {
        let n = tree.big.len();
        let max_area = p.max_area.min(u32::MAX as usize) as u32;
        let delta = p.delta as u32;
        let var = &mut self.var;
        var.clear();
        var.resize(n, Frac::default());

        // Pass 1: the variations. The walk up follows parents (all listed) while their level is
        // within Δ; the lower end was found by the flood.
        for (k, var_k) in var.iter_mut().enumerate() {
            let c = tree.big[k];
            let g = c.level;
            let mut up = c;
            while up.parent != NONE && tree.big[up.parent as usize].level <= g + delta {
                up = tree.big[up.parent as usize];
            }
            *var_k = Frac {
                num: up.area - c.lower,
                den: c.area,
            };
        }

        // Pass 2, children before parents: a node is a candidate when its area is admissible,
        // its variation at most `max_variation`, at most its parent's and at most that of every
        // child of at least `min_area` pixels (children mark their parent BEATEN otherwise).
        // Diversity: `best_desc` carries the largest candidate below each node, and a candidate
        // holding a smaller candidate that covers most of it is dropped.
        let best = &mut self.best_desc;
        best.clear();
        best.resize(n, 0);
        for (k, c) in tree.big.iter().enumerate() {
            let q = c.parent;
            let b = best[k];
            let mut cand = false;
            if q != NONE {
                let (vi, vq) = (var[k], var[q as usize]);
                if vi.lt(vq) {
                    best[q as usize] |= BEATEN;
                }
                cand = b & BEATEN == 0
                    && c.area <= max_area
                    && !vq.lt(vi)
                    && vi.value() <= p.max_variation;
            }
            let below = b & !BEATEN;
            let val = if cand { c.area } else { below };
            if q != NONE && best[q as usize] & !BEATEN < val {
                best[q as usize] = (best[q as usize] & BEATEN) | val;
            }
            if cand {
                let a = c.area;
                let similar = below > 0 && ((a - below) as f64 / a as f64) < p.min_diversity;
                if !similar {
                    out.push((c.id, var[k].value()));
                }
            }
        }
    }
}
