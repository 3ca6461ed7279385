//! Moments and bounding boxes of the selected nodes, summed over their runs of the flood order.
//!
//! Every node's pixels are one contiguous run `order[start .. start + area]` (module `tree`), and
//! runs of distinct nodes are nested or disjoint. The selected nodes come in id order, which is
//! post-order, so when a node is reached every selected node inside it has been summed already and
//! the outermost of them sit on top of a stack: their sums are added and only the pixels between
//! their runs are read. Every pixel is therefore read at most once, whatever the nesting, and the
//! cost is O(pixels in selected nodes), at most O(pixels).

use crate::region::{BoundingBox, Moments};
use crate::tree::Tree;

/// Exact sums over a set of pixels, in image coordinates.
#[derive(Debug, Clone, Copy)]
pub struct Sums {
    /// Smallest padded index (the first pixel in raster order).
    pub seed: u32,
    sx: u64,
    sy: u64,
    sxx: u64,
    sxy: u64,
    syy: u64,
    x0: u32,
    x1: u32,
    y0: u32,
    y1: u32,
}

impl Sums {
    const EMPTY: Sums = Sums {
        seed: u32::MAX,
        sx: 0,
        sy: 0,
        sxx: 0,
        sxy: 0,
        syy: 0,
        x0: u32::MAX,
        x1: 0,
        y0: u32::MAX,
        y1: 0,
    };

    /// Adds the pixels with padded indices `idx`.
    fn add_run(&mut self, idx: &[u32], shift: u32) {
        let xmask = (1u32 << shift) - 1;
        let mut s = *self;
        for &i in idx {
            let x = i & xmask;
            let y = (i >> shift) - 1;
            let (xl, yl) = (x as u64, y as u64);
            s.seed = s.seed.min(i);
            s.sx += xl;
            s.sy += yl;
            s.sxx += xl * xl;
            s.sxy += xl * yl;
            s.syy += yl * yl;
            s.x0 = s.x0.min(x);
            s.x1 = s.x1.max(x);
            s.y0 = s.y0.min(y);
            s.y1 = s.y1.max(y);
        }
        *self = s;
    }

    fn absorb(&mut self, o: &Sums) {
        self.seed = self.seed.min(o.seed);
        self.sx += o.sx;
        self.sy += o.sy;
        self.sxx += o.sxx;
        self.sxy += o.sxy;
        self.syy += o.syy;
        self.x0 = self.x0.min(o.x0);
        self.x1 = self.x1.max(o.x1);
        self.y0 = self.y0.min(o.y0);
        self.y1 = self.y1.max(o.y1);
    }

    /// The raw moments of `n` pixels with these sums.
    pub fn moments(&self, n: u32) -> Moments {
        Moments {
            n: n as u64,
            sx: self.sx,
            sy: self.sy,
            sxx: self.sxx,
            sxy: self.sxy,
            syy: self.syy,
        }
    }

    /// The inclusive bounding box.
    pub fn bbox(&self) -> BoundingBox {
        BoundingBox {
            x_min: self.x0,
            y_min: self.y0,
            x_max: self.x1,
            y_max: self.y1,
        }
    }
}

/// Scratch space of the summation, reused between images.
#[derive(Debug, Default)]
pub struct Summer {
    /// Summed runs not yet inside a later one: `(start, end, sums)`.
    open: Vec<(u32, u32, Sums)>,
    /// The runs inside the current node, in flood order.
    inner: Vec<(u32, u32, Sums)>,
}

impl Summer {
    /// Writes the sums of the nodes `ids` (ascending) into `out`, in the same order.
    pub fn sums(&mut self, tree: &Tree, ids: impl Iterator<Item = u32>, out: &mut Vec<Sums>) {
        self.open.clear();
        for id in ids {
            let node = &tree.nodes[id as usize];
            let (start, end) = (node.start, node.start + node.area);
            // Selected runs inside this one are the latest summed ones.
            self.inner.clear();
            while let Some(&(s, e, sums)) = self.open.last() {
                if s < start {
                    break;
                }
                debug_assert!(e <= end);
                self.inner.push((s, e, sums));
                self.open.pop();
            }
            let mut sums = Sums::EMPTY;
            let mut at = start;
            for &(s, e, inner) in self.inner.iter().rev() {
                sums.add_run(&tree.order[at as usize..s as usize], tree.shift);
                sums.absorb(&inner);
                at = e;
            }
            sums.add_run(&tree.order[at as usize..end as usize], tree.shift);
            self.open.push((start, end, sums));
            out.push(sums);
        }
    }
}
