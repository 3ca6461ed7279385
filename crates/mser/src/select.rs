//! Stability measure and selection of maximally stable regions on a component tree: two linear
//! passes over the nodes of at least `min_area` pixels ([`Tree::big`]), the only ones that can be
//! selected or take part in the comparisons (the variation walks at most Δ levels up and down).

use crate::params::MserParams;
use crate::tree::{NONE, Tree};

/// Scratch arrays of the selection, reused between images; indexed like [`Tree::big`].
#[derive(Debug, Default)]
pub struct Selector {
    var: Vec<f64>,
    best_desc: Vec<u32>,
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
        var.resize(n, 0.0);

        // Pass 1: the variations. The walk up follows parents (all listed) while their level is
        // within Δ; the lower end was found by the flood.
        for (k, var_k) in var.iter_mut().enumerate() {
            let c = tree.big[k];
            let g = c.level;
            let mut up = c;
            while up.parent != NONE && tree.big[up.parent as usize].level <= g + delta {
                up = tree.big[up.parent as usize];
            }
            *var_k = (up.area - c.lower) as f64 / c.area as f64;
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
                if vi < vq {
                    best[q as usize] |= BEATEN;
                }
                cand = b & BEATEN == 0 && c.area <= max_area && vi <= p.max_variation && vi <= vq;
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
                    out.push((c.id, var[k]));
                }
            }
        }
    }
}
