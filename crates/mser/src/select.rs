//! Stability measure and selection of maximally stable regions on a component tree; every step
//! is one linear pass over the nodes (the variation walks at most Δ levels up and down).

use crate::params::{MserParams, Variation};
use crate::tree::{NONE, Tree};

/// Scratch arrays of the selection, reused between images.
#[derive(Debug, Default)]
pub struct Selector {
    /// Per node: its main child so far and that child's area (`(NONE, 0)` before the first).
    main_child: Vec<(u32, u32)>,
    var: Vec<f64>,
    best_desc: Vec<u32>,
}

/// Flag in `best_desc`: a child of at least `min_area` pixels has a smaller variation.
const BEATEN: u32 = 1 << 31;

impl Selector {
    /// Appends the ids of the selected nodes and their variations to `out` (in id order).
    pub fn select(&mut self, tree: &mut Tree, p: &MserParams, out: &mut Vec<(u32, f64)>) {
        let n = tree.nodes.len();
        let min_area = p.min_area.min(u32::MAX as usize) as u32;
        let max_area = p.max_area.min(u32::MAX as usize) as u32;
        let delta = p.delta as u32;
        let symmetric = p.variation == Variation::Symmetric;

        let main = &mut self.main_child;
        main.clear();
        main.resize(n, (NONE, 0));
        // Only entries of nodes with at least `min_area` pixels are written and read.
        let var = &mut self.var;
        if var.len() < n {
            var.resize(n, f64::NAN);
        }

        // Pass 1, children before parents: when node i is reached its main (largest, then first
        // in raster order) child is final, so its variation can be computed; then it competes
        // for its parent's main child. Seeds are needed only to break ties in area, so they are
        // computed only then.
        for (i, var_i) in var[..n].iter_mut().enumerate() {
            let c = tree.nodes[i];
            if c.area >= min_area {
                let g = c.level;
                let nodes = &tree.nodes[..];
                let mut up = c;
                while up.parent != NONE && nodes[up.parent as usize].level <= g + delta {
                    up = nodes[up.parent as usize];
                }
                let lower = if symmetric {
                    // The smallest region on the largest-child chain whose level is >= g − Δ.
                    let mut m = i;
                    loop {
                        let ch = main[m].0;
                        if ch == NONE || nodes[ch as usize].level + delta < g {
                            break nodes[m].area;
                        }
                        m = ch as usize;
                    }
                } else {
                    c.area
                };
                *var_i = (up.area - lower) as f64 / c.area as f64;
            }
            if symmetric && c.parent != NONE {
                // Every area is at least 1, so the first child always takes the empty slot; a
                // larger child takes it without a branch (conditional moves), and only a tie in
                // area branches to compare first pixels.
                let q = c.parent as usize;
                let (m, ma) = main[q];
                let mine = (i as u32, c.area);
                main[q] = std::hint::select_unpredictable(c.area > ma, mine, (m, ma));
                if c.area == ma && tree.seed(i as u32) < tree.seed(m) {
                    main[q] = mine;
                }
            }
        }

        // Pass 2, children before parents: a node is a candidate when its area is admissible,
        // its variation at most `max_variation`, at most its parent's and at most that of every
        // child of at least `min_area` pixels (children mark their parent BEATEN otherwise).
        // Diversity: `best_desc` carries the largest candidate below each node, and a candidate
        // holding a smaller candidate that covers most of it is dropped.
        let best = &mut self.best_desc;
        best.clear();
        best.resize(n, 0);
        for (i, c) in tree.nodes.iter().enumerate() {
            if c.area < min_area {
                // Nothing of `min_area` pixels lies inside, so there is nothing to mark, carry
                // up or select (and `best[i]` is 0): skip the parent's entries.
                continue;
            }
            let q = c.parent;
            let b = best[i];
            let mut cand = false;
            if q != NONE {
                let (vi, vq) = (var[i], var[q as usize]);
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
                    out.push((i as u32, var[i]));
                }
            }
        }
    }
}
