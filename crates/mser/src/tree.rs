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
//! them and pushes the unreached ones without further branching on each.
//!
//! A stack of open components holds, for each, its grey level and its running area, moments,
//! bounding box and first pixel; the top component lives in a local variable. Raising a component
//! to a higher level or merging it into the one below it closes the node: one record of a few
//! integers in flat arrays (plus moments when the area is in the reportable range). No
//! per-region heap allocation happens in the loop, and memory is O(pixels).

use crate::image::GrayView;

/// Marks "no node".
pub const NONE: u32 = u32::MAX;

/// Moments and bounding box of a node, in padded coordinates (`y` is one more than in the image).
#[derive(Debug, Clone, Copy)]
pub struct NodeStats {
    pub sx: u64,
    pub sy: u64,
    pub sxx: u64,
    pub sxy: u64,
    pub syy: u64,
    pub x0: u32,
    pub x1: u32,
    pub y0: u32,
    pub y1: u32,
}

/// The component tree as flat arrays indexed by node id. Ids are given when a node closes, so
/// every child has a smaller id than its parent and the root is the last node.
#[derive(Debug, Default)]
pub struct Tree {
    /// Grey level of the node on the internal scale (the image, or 255 − image for bright).
    pub level: Vec<u8>,
    /// Area in pixels.
    pub area: Vec<u32>,
    /// Parent id or [`NONE`] for the root.
    pub parent: Vec<u32>,
    /// First child id or [`NONE`].
    pub first_child: Vec<u32>,
    /// Next sibling id or [`NONE`].
    pub next_sibling: Vec<u32>,
    /// Padded index of the node's first pixel in raster order.
    pub seed: Vec<u32>,
    /// Index into `stats` or [`NONE`] when the area is outside the reportable range.
    pub stat: Vec<u32>,
    /// Moments of nodes with a reportable area.
    pub stats: Vec<NodeStats>,
    /// log2 of the padded row length.
    pub shift: u32,
}

impl Tree {
    fn clear(&mut self, capacity: usize) {
        for v in [&mut self.area, &mut self.parent, &mut self.first_child] {
            v.clear();
            v.reserve(capacity);
        }
        for v in [&mut self.next_sibling, &mut self.seed, &mut self.stat] {
            v.clear();
            v.reserve(capacity);
        }
        self.level.clear();
        self.level.reserve(capacity);
        self.stats.clear();
    }

    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.level.len()
    }

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
    area: u32,
    seed: u32,
    children: u32,
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

impl Comp {
    #[inline]
    fn new(level: u32) -> Self {
        Comp {
            level,
            area: 0,
            seed: u32::MAX,
            children: NONE,
            sx: 0,
            sy: 0,
            sxx: 0,
            sxy: 0,
            syy: 0,
            x0: u32::MAX,
            x1: 0,
            y0: u32::MAX,
            y1: 0,
        }
    }

    #[inline(always)]
    fn add_pixel(&mut self, idx: u32, shift: u32, xmask: u32) {
        let x = idx & xmask;
        let y = idx >> shift;
        let (xl, yl) = (x as u64, y as u64);
        self.area += 1;
        self.sx += xl;
        self.sy += yl;
        self.sxx += xl * xl;
        self.sxy += xl * yl;
        self.syy += yl * yl;
        self.seed = self.seed.min(idx);
        self.x0 = self.x0.min(x);
        self.x1 = self.x1.max(x);
        self.y0 = self.y0.min(y);
        self.y1 = self.y1.max(y);
    }

    #[inline]
    fn absorb(&mut self, o: &Comp) {
        self.area += o.area;
        self.sx += o.sx;
        self.sy += o.sy;
        self.sxx += o.sxx;
        self.sxy += o.sxy;
        self.syy += o.syy;
        self.seed = self.seed.min(o.seed);
        self.x0 = self.x0.min(o.x0);
        self.x1 = self.x1.max(o.x1);
        self.y0 = self.y0.min(o.y0);
        self.y1 = self.y1.max(o.y1);
    }
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
    /// Builds the component tree of `img` (of `255 − img` when `invert`) into `tree`, keeping
    /// moments for nodes with `min_area <= area <= max_area`.
    pub fn build(
        &mut self,
        img: &GrayView,
        invert: bool,
        min_area: usize,
        max_area: usize,
        tree: &mut Tree,
    ) {
        let (w, h) = (img.width(), img.height());
        let stride = (w + 1).next_power_of_two();
        let shift = stride.trailing_zeros();
        let xmask = (stride - 1) as u32;
        let total = stride * (h + 2);
        tree.clear(w * h);
        tree.shift = shift;

        // Padded copy with the frame marked as reached, and the grey-level histogram.
        self.cells.clear();
        self.cells.resize(total, SEEN);
        let mut hist = [0u32; 256];
        let flip = if invert { 255u8 } else { 0 };
        for y in 0..h {
            let row = img.row(y);
            let base = (y + 1) * stride;
            for (d, &g) in self.cells[base..base + w].iter_mut().zip(row) {
                let v = g ^ flip;
                *d = v as u16;
                hist[v as usize] += 1;
            }
        }

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
        self.heap.clear();
        self.heap.resize(acc as usize + 1, 0);
        let heap = &mut self.heap[..];
        let cells = &mut self.cells[..];
        let stack = &mut self.stack;
        stack.clear();

        let offs: [u32; 4] = [1, (stride as u32).wrapping_neg(), u32::MAX, stride as u32];
        let area_ok = |a: u32| (a as usize) >= min_area && (a as usize) <= max_area;

        let mut cur = stride as u32; // pixel (0, 0)
        cells[cur as usize] |= SEEN;
        let mut cur_level = (cells[cur as usize] & 0xff) as u32;
        let mut top = Comp::new(cur_level);
        let mut dir = 0u32;
        loop {
            // Fast path for a pixel seen for the first time: read the four neighbours at once;
            // if none is lower, mark them all and push the unreached ones.
            if dir == 0 {
                let ns = offs.map(|o| cur.wrapping_add(o));
                // SAFETY: as below, every neighbour of an image pixel lies in the buffer.
                let vs = ns.map(|n| unsafe { *cells.get_unchecked(n as usize) } as u32);
                if vs[0].min(vs[1]).min(vs[2].min(vs[3])) >= cur_level {
                    let mut fresh = 0u32;
                    for i in 0..4 {
                        unsafe { *cells.get_unchecked_mut(ns[i] as usize) = (vs[i] as u16) | SEEN };
                        fresh |= ((vs[i] >> 8) ^ 1) << i;
                    }
                    while fresh != 0 {
                        let i = fresh.trailing_zeros() as usize;
                        fresh &= fresh - 1;
                        push(heap, &mut top_of, vs[i], ns[i] << 3, 1);
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
                    top = Comp::new(v);
                    dir = 0;
                } else {
                    // Unreached and not lower: a real push. Reached before (bit 8 set): the
                    // write lands in the spare slot and is not counted.
                    let fresh = (v >> 8) ^ 1;
                    push(heap, &mut top_of, v & 0xff, n << 3, fresh);
                }
            }
            top.add_pixel(cur, shift, xmask);

            // Next pixel: from the current level's stack, else from the lowest non-empty one.
            let mut g = cur_level as usize;
            let e = if top_of[g] != bottom[g] {
                top_of[g] -= 1;
                heap[top_of[g] as usize]
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
                        let id = close(tree, &top, area_ok);
                        top.children = id;
                        top.level = next;
                        break;
                    }
                    let mut b = stack.pop().expect("a component lies below");
                    let id = close(tree, &top, area_ok);
                    tree.next_sibling[id as usize] = b.children;
                    b.children = id;
                    b.absorb(&top);
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
        // Every pixel is in; close the remaining components into the root.
        while let Some(mut b) = stack.pop() {
            let id = close(tree, &top, area_ok);
            tree.next_sibling[id as usize] = b.children;
            b.children = id;
            b.absorb(&top);
            top = b;
        }
        close(tree, &top, |_| false);
    }
}

/// Writes `e` on top of level `g`'s stack and counts it when `real` is 1 (0: no-op push).
#[inline(always)]
fn push(heap: &mut [u32], top_of: &mut [u32; 257], g: u32, e: u32, real: u32) {
    let g = (g & 0xff) as usize;
    let slot = top_of[g] as usize;
    // SAFETY: level g has hist[g] + 1 slots and at most hist[g] real entries, so the slot past
    // the top is in bounds.
    unsafe { *heap.get_unchecked_mut(slot) = e };
    top_of[g] += real;
}

/// Closes the node `c` (its children are linked through `c.children`) and returns its id.
#[inline]
fn close(tree: &mut Tree, c: &Comp, area_ok: impl Fn(u32) -> bool) -> u32 {
    let id = tree.level.len() as u32;
    tree.level.push(c.level as u8);
    tree.area.push(c.area);
    tree.parent.push(NONE);
    tree.first_child.push(c.children);
    tree.next_sibling.push(NONE);
    tree.seed.push(c.seed);
    let mut ch = c.children;
    while ch != NONE {
        tree.parent[ch as usize] = id;
        ch = tree.next_sibling[ch as usize];
    }
    if area_ok(c.area) {
        tree.stat.push(tree.stats.len() as u32);
        tree.stats.push(NodeStats {
            sx: c.sx,
            sy: c.sy,
            sxx: c.sxx,
            sxy: c.sxy,
            syy: c.syy,
            x0: c.x0,
            x1: c.x1,
            y0: c.y0,
            y1: c.y1,
        });
    } else {
        tree.stat.push(NONE);
    }
    id
}
