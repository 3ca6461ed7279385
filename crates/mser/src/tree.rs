//! The component tree of one polarity, built in linear time by the flood-fill algorithm of Nistér
//! & Stewénius (ECCV 2008).
//!
//! The image is copied into a padded `u16` buffer (grey level in the low byte, a "reached" bit
//! above it) whose row length is a power of two, so `x` and `y` of a pixel index are a mask and a
//! shift, with a frame of pixels marked as reached, so the four neighbour steps never leave the
//! buffer. The flood keeps one "boundary heap" per grey level: 256 stacks carved out of one array,
//! sized by the grey-level histogram plus one spare slot each (so a push can write before it knows
//! whether it counts). All waiting pixels lie at or above the current level, so when the current
//! level's stack runs empty the next one is found by scanning upwards. A pixel reached for the
//! first time reads its four neighbours at once and, when none is lower (the common case), marks
//! them and pushes all four without branching: a neighbour reached before lands in a spare slot
//! and is not counted.
//!
//! A stack of open components holds, for each, its grey level, the position in the flood order at
//! which it was opened, its first pixel in raster order and its closed children; the top component
//! lives in a local variable. Per pixel the flood only appends the pixel to the flood order and
//! updates the top component's first pixel. Raising a component to a higher level or merging it
//! into the one below closes the node: one record of six integers. Because components on the stack
//! only ever merge into the one directly below, **the pixels of every node are one contiguous run
//! of the flood order** (`order[start .. start + area]`), so moments and bounding boxes are not
//! accumulated during the flood at all: they are summed afterwards over the runs of the few
//! selected nodes (module `stats`). No per-region heap allocation happens in the loop, and memory
//! is O(pixels).

use crate::image::GrayView;

/// Marks "no node".
pub const NONE: u32 = u32::MAX;

/// One node of the component tree.
#[derive(Debug, Clone, Copy)]
pub struct Node {
    /// Grey level on the internal scale (the image, or 255 − image for bright).
    pub level: u32,
    /// Area in pixels.
    pub area: u32,
    /// Parent id or [`NONE`] for the root.
    pub parent: u32,
    /// Next sibling id or [`NONE`] (links the children while the parent is still open).
    pub next_sibling: u32,
    /// Padded index of the node's first pixel in raster order.
    pub seed: u32,
    /// Position of the node's first pixel in [`Tree::order`]; its pixels are
    /// `order[start .. start + area]`.
    pub start: u32,
}

/// The component tree as a flat array indexed by node id. Ids are given when a node closes, so
/// every child has a smaller id than its parent, the nodes are in post-order and the root is the
/// last node.
#[derive(Debug, Default)]
pub struct Tree {
    /// The nodes.
    pub nodes: Vec<Node>,
    /// Padded pixel indices in flood order (every pixel once).
    pub order: Vec<u32>,
    /// log2 of the padded row length.
    pub shift: u32,
}

impl Tree {
    /// Image coordinates of a padded index.
    #[inline]
    pub fn xy(&self, idx: u32) -> (u32, u32) {
        (idx & ((1 << self.shift) - 1), (idx >> self.shift) - 1)
    }
}

/// An open component on the flood's stack.
#[derive(Debug, Clone, Copy)]
struct Comp {
    level: u32,
    /// Position in the flood order at which the component was opened.
    start: u32,
    /// Smallest padded index among its pixels.
    seed: u32,
    /// Closed children, linked through [`Node::next_sibling`].
    children: u32,
}

/// Reusable buffers for building trees of images of any size.
#[derive(Debug, Default)]
pub struct TreeBuilder {
    /// Padded image: grey level in the low byte, bit 8 set once the pixel has been reached
    /// (the frame is set from the start).
    cells: Vec<u16>,
    heap: Vec<u32>,
    stack: Vec<Comp>,
}

/// Bit of a cell marking it as reached.
const SEEN: u16 = 0x100;

impl TreeBuilder {
    /// Builds the component tree of `img` (of `255 − img` when `invert`) into `tree`.
    pub fn build(&mut self, img: &GrayView, invert: bool, tree: &mut Tree) {
        let (w, h) = (img.width(), img.height());
        let stride = (w + 1).next_power_of_two();
        let shift = stride.trailing_zeros();
        let total = stride * (h + 2);
        let npix = w * h;
        tree.shift = shift;
        tree.nodes.clear();
        tree.nodes.reserve(npix);
        // Every slot is written before it is read, so old contents need no clearing.
        if tree.order.len() != npix {
            tree.order.clear();
            tree.order.resize(npix, 0);
        }

        // Padded copy with the frame marked as reached, and the grey-level histogram.
        if self.cells.len() != total {
            self.cells.clear();
            self.cells.resize(total, SEEN);
        }
        let mut hist = [0u32; 256];
        let flip = if invert { 255u8 } else { 0 };
        self.cells[..stride].fill(SEEN);
        for y in 0..h {
            let row = img.row(y);
            let base = (y + 1) * stride;
            let (px, pad) = self.cells[base..base + stride].split_at_mut(w);
            for (d, &g) in px.iter_mut().zip(row) {
                let v = g ^ flip;
                *d = v as u16;
                hist[v as usize] += 1;
            }
            pad.fill(SEEN);
        }
        self.cells[(h + 1) * stride..].fill(SEEN);

        // Boundary heap: one stack per level, carved from one array, each with one spare slot
        // so that a push can write unconditionally and only count when it is real.
        // `bottom[g]..top[g]` are level g's entries; a sentinel level 256 is never empty.
        let mut bottom = [0u32; 257];
        let mut top_of = [0u32; 257];
        let mut acc = 0u32;
        for g in 0..256 {
            bottom[g] = acc;
            top_of[g] = acc;
            acc += hist[g] + 1;
        }
        bottom[256] = acc;
        top_of[256] = acc + 1;
        if self.heap.len() < acc as usize + 1 {
            self.heap.resize(acc as usize + 1, 0);
        }
        let heap = &mut self.heap[..];
        let cells = &mut self.cells[..];
        let order = &mut tree.order[..];
        let nodes = &mut tree.nodes;
        let stack = &mut self.stack;
        stack.clear();

        let offs: [u32; 4] = [1, (stride as u32).wrapping_neg(), u32::MAX, stride as u32];

        let mut cur = stride as u32; // pixel (0, 0)
        cells[cur as usize] |= SEEN;
        let mut cur_level = (cells[cur as usize] & 0xff) as u32;
        let mut top = Comp {
            level: cur_level,
            start: 0,
            seed: u32::MAX,
            children: NONE,
        };
        let mut dir = 0u32;
        let mut pos = 0u32;
        loop {
            // Fast path for a pixel seen for the first time: read the four neighbours at once;
            // if none is lower, mark them all and push them all (those reached before only
            // write a spare slot).
            if dir == 0 {
                let ns = offs.map(|o| cur.wrapping_add(o));
                // SAFETY: as below, every neighbour of an image pixel lies in the buffer.
                let vs = ns.map(|n| unsafe { *cells.get_unchecked(n as usize) } as u32);
                if vs[0].min(vs[1]).min(vs[2].min(vs[3])) >= cur_level {
                    for i in 0..4 {
                        // SAFETY: as above.
                        unsafe { *cells.get_unchecked_mut(ns[i] as usize) = (vs[i] as u16) | SEEN };
                        push(heap, &mut top_of, vs[i], ns[i] << 3, (vs[i] >> 8) ^ 1);
                    }
                    dir = 4;
                }
            }
            // Explore the remaining neighbours of `cur`.
            while dir < 4 {
                // SAFETY: `cur` is an image pixel and the frame is one pixel wide (plus the
                // padding columns, which wrap to the next row's frame), so `n < total`.
                let n = cur.wrapping_add(unsafe { *offs.get_unchecked(dir as usize) });
                dir += 1;
                let cell = unsafe { cells.get_unchecked_mut(n as usize) };
                let v = *cell as u32;
                *cell |= SEEN;
                if v < cur_level {
                    // Unreached and lower: push `cur` back and descend.
                    push(heap, &mut top_of, cur_level, (cur << 3) | dir, 1);
                    cur = n;
                    cur_level = v;
                    stack.push(top);
                    top = Comp {
                        level: v,
                        start: pos,
                        seed: u32::MAX,
                        children: NONE,
                    };
                    dir = 0;
                } else {
                    // Unreached and not lower: a real push. Reached before (bit 8 set): the
                    // write lands in the spare slot and is not counted.
                    push(heap, &mut top_of, v, n << 3, (v >> 8) ^ 1);
                }
            }
            // `cur` joins the top component.
            debug_assert!((pos as usize) < order.len());
            // SAFETY: every image pixel is reached once and added once, so `pos < w * h`.
            unsafe { *order.get_unchecked_mut(pos as usize) = cur };
            pos += 1;
            top.seed = top.seed.min(cur);

            // Next pixel: from the current level's stack, else from the lowest non-empty one.
            let mut g = cur_level as usize;
            let e = if top_of[g] != bottom[g] {
                top_of[g] -= 1;
                // SAFETY: bottom[g] <= top_of[g] < bottom[g + 1] <= heap.len().
                unsafe { *heap.get_unchecked(top_of[g] as usize) }
            } else {
                // Every entry lies at or above the current level: scan upwards.
                g += 1;
                while top_of[g] == bottom[g] {
                    g += 1;
                }
                if g == 256 {
                    break;
                }
                top_of[g] -= 1;
                let e = heap[top_of[g] as usize];
                let next = g as u32;
                // Process the component stack: raise the top or merge it into the next.
                loop {
                    let below = stack.last().map_or(u32::MAX, |c| c.level);
                    if next < below {
                        let id = close(nodes, &top, pos);
                        top.children = id;
                        top.level = next;
                        break;
                    }
                    let mut b = stack.pop().expect("a component lies below");
                    let id = close(nodes, &top, pos);
                    nodes[id as usize].next_sibling = b.children;
                    b.children = id;
                    b.seed = b.seed.min(top.seed);
                    top = b;
                    if next <= top.level {
                        break;
                    }
                }
                cur_level = next;
                e
            };
            cur = e >> 3;
            dir = e & 7;
        }
        debug_assert_eq!(pos as usize, npix);
        // Every pixel is in; close the remaining components into the root.
        while let Some(mut b) = stack.pop() {
            let id = close(nodes, &top, pos);
            nodes[id as usize].next_sibling = b.children;
            b.children = id;
            b.seed = b.seed.min(top.seed);
            top = b;
        }
        close(nodes, &top, pos);
    }
}

/// Writes `e` on top of level `g`'s stack (low byte of `g`) and counts it when `real` is 1
/// (0: no-op push).
#[inline(always)]
fn push(heap: &mut [u32], top_of: &mut [u32; 257], g: u32, e: u32, real: u32) {
    let g = (g & 0xff) as usize;
    let slot = top_of[g] as usize;
    debug_assert!(slot < heap.len());
    // SAFETY: level g has hist[g] + 1 slots and at most hist[g] real entries, so the slot past
    // the top is in bounds.
    unsafe { *heap.get_unchecked_mut(slot) = e };
    top_of[g] += real;
}

/// Closes the open component `c` at flood position `pos` (its children are linked through
/// `c.children`) and returns the new node's id.
#[inline]
fn close(nodes: &mut Vec<Node>, c: &Comp, pos: u32) -> u32 {
    let id = nodes.len() as u32;
    let mut ch = c.children;
    while ch != NONE {
        let n = &mut nodes[ch as usize];
        n.parent = id;
        ch = n.next_sibling;
    }
    nodes.push(Node {
        level: c.level,
        area: pos - c.start,
        parent: NONE,
        next_sibling: NONE,
        seed: c.seed,
        start: c.start,
    });
    id
}
