//! Stability measure and selection of maximally stable regions on a component tree; every step
//! is one linear pass over the nodes (the variation walks at most Δ levels up and down).

use crate::params::{MserParams, Variation};
use crate::tree::{NONE, Tree};

/// Scratch arrays of the selection, reused between images.
#[derive(Debug, Default)]
pub struct Selector {
    main_child: Vec<u32>,
    var: Vec<f64>,
    cand: Vec<bool>,
    best_desc: Vec<u32>,
}

impl Selector {
    /// Appends the ids of the selected nodes and their variations to `out` (in id order).
    pub fn select(&mut self, tree: &mut Tree, p: &MserParams, out: &mut Vec<(u32, f64)>) {
        let n = tree.nodes.len();
        let min_area = p.min_area.min(u32::MAX as usize) as u32;
        let max_area = p.max_area.min(u32::MAX as usize) as u32;
        let delta = p.delta as u32;

        // Main (largest, then first in raster order) child, for the downward part of the measure.
        // Seeds are needed only to break ties in area, so they are computed only then.
        let main = &mut self.main_child;
        main.clear();
        main.resize(n, NONE);
        if p.variation == Variation::Symmetric {
            for i in 0..n {
                let c = tree.nodes[i];
                if c.parent == NONE {
                    continue;
                }
                let m = main[c.parent as usize];
                let better = m == NONE || {
                    let ma = tree.nodes[m as usize].area;
                    c.area > ma || (c.area == ma && tree.seed(i as u32) < tree.seed(m))
                };
                if better {
                    main[c.parent as usize] = i as u32;
                }
            }
        }
        let nodes = &tree.nodes[..];

        // Variation of every node with area >= min_area.
        let var = &mut self.var;
        var.clear();
        var.resize(n, f64::NAN);
        for (i, c) in nodes.iter().enumerate() {
            if c.area < min_area {
                continue;
            }
            let g = c.level;
            let mut up = c;
            while up.parent != NONE && nodes[up.parent as usize].level <= g + delta {
                up = &nodes[up.parent as usize];
            }
            let lower = match p.variation {
                Variation::Upward => c.area,
                Variation::Symmetric => {
                    // The smallest region on the largest-child chain whose level is >= g − Δ.
                    let mut m = i;
                    loop {
                        let ch = main[m];
                        if ch == NONE || nodes[ch as usize].level + delta < g {
                            break nodes[m].area;
                        }
                        m = ch as usize;
                    }
                }
            };
            var[i] = (up.area - lower) as f64 / c.area as f64;
        }

        // Maximally stable and admissible candidates: no larger variation than the parent and
        // than any child of at least `min_area` pixels.
        let cand = &mut self.cand;
        cand.clear();
        cand.resize(n, true); // until a child beats it; children come before their parent
        for (i, c) in nodes.iter().enumerate() {
            let q = c.parent;
            if q == NONE || c.area < min_area {
                cand[i] = false;
                continue;
            }
            let q = q as usize;
            if var[q] > var[i] {
                cand[q] = false;
            }
            cand[i] =
                cand[i] && c.area <= max_area && var[i] <= p.max_variation && var[i] <= var[q];
        }

        // Diversity: drop a candidate that holds a smaller candidate covering most of it.
        let best = &mut self.best_desc;
        best.clear();
        best.resize(n, 0);
        for (i, c) in nodes.iter().enumerate() {
            let val = if cand[i] { c.area } else { best[i] };
            let q = c.parent;
            if q != NONE && best[q as usize] < val {
                best[q as usize] = val;
            }
            if cand[i] {
                let a = c.area;
                let b = best[i];
                let similar = b > 0 && ((a - b) as f64 / a as f64) < p.min_diversity;
                if !similar {
                    out.push((i as u32, var[i]));
                }
            }
        }
    }
}
