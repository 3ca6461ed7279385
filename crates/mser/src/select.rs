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
    /// Appends the ids of the selected nodes to `out` (in id order).
    pub fn select(&mut self, tree: &Tree, p: &MserParams, out: &mut Vec<(u32, f64)>) {
        let n = tree.len();
        let min_area = p.min_area.min(u32::MAX as usize) as u32;
        let max_area = p.max_area.min(u32::MAX as usize) as u32;
        let delta = p.delta as u32;
        let (level, area, parent) = (&tree.level, &tree.area, &tree.parent);

        // Main (largest, then first in raster order) child, for the downward part of the measure.
        let main = &mut self.main_child;
        main.clear();
        main.resize(n, NONE);
        if p.variation == Variation::Symmetric {
            for i in 0..n {
                let q = parent[i];
                if q == NONE {
                    continue;
                }
                let m = main[q as usize];
                if m == NONE
                    || area[i] > area[m as usize]
                    || (area[i] == area[m as usize] && tree.seed[i] < tree.seed[m as usize])
                {
                    main[q as usize] = i as u32;
                }
            }
        }

        // Variation of every node with area >= min_area.
        let var = &mut self.var;
        var.clear();
        var.resize(n, f64::NAN);
        for i in 0..n {
            if area[i] < min_area {
                continue;
            }
            let g = level[i] as u32;
            let mut up = i;
            while parent[up] != NONE && level[parent[up] as usize] as u32 <= g + delta {
                up = parent[up] as usize;
            }
            let lower = match p.variation {
                Variation::Upward => area[i],
                Variation::Symmetric => {
                    // The smallest region on the largest-child chain whose level is >= g − Δ.
                    let mut m = i;
                    loop {
                        let c = main[m];
                        if c == NONE || level[c as usize] as u32 + delta < g {
                            break area[m];
                        }
                        m = c as usize;
                    }
                }
            };
            var[i] = (area[up] - lower) as f64 / area[i] as f64;
        }

        // Maximally stable and admissible candidates.
        let cand = &mut self.cand;
        cand.clear();
        cand.resize(n, false);
        for i in 0..n {
            let a = area[i];
            let q = parent[i];
            if q == NONE || a < min_area || a > max_area || var[i] > p.max_variation {
                continue;
            }
            if var[i] > var[q as usize] {
                continue;
            }
            let mut c = tree.first_child[i];
            let mut ok = true;
            while c != NONE {
                if area[c as usize] >= min_area && var[i] > var[c as usize] {
                    ok = false;
                    break;
                }
                c = tree.next_sibling[c as usize];
            }
            cand[i] = ok;
        }

        // Diversity: drop a candidate that holds a smaller candidate covering most of it.
        let best = &mut self.best_desc;
        best.clear();
        best.resize(n, 0);
        for i in 0..n {
            let val = if cand[i] { area[i] } else { best[i] };
            let q = parent[i];
            if q != NONE && best[q as usize] < val {
                best[q as usize] = val;
            }
            if cand[i] {
                let a = area[i];
                let b = best[i];
                let similar = b > 0 && ((a - b) as f64 / a as f64) < p.min_diversity;
                if !similar {
                    out.push((i as u32, var[i]));
                }
            }
        }
    }
}
