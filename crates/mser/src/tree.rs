//! The component tree of one polarity, built in linear time by the flood-fill algorithm of Nistér
//! & Stewénius (ECCV 2008).
//!
//! The image is copied into a padded byte buffer with a frame of pixels marked as reached, so
//! the four neighbour steps never leave the buffer (module `layout`: row length an odd multiple
//! of 16, not a power of two, which keeps the rows of a column in different cache sets). A cell
//! holds its grey level until the pixel is reached, then the constant `REACHED` = 255, which is
//! never below the flood's level and is also the index of a *sink*. Bytes rather than wider cells
//! halve the flood's most randomly accessed memory (graf img1: 0.5 MB, within the L2 cache). The
//! price: pixels of grey level 255 look reached from the start and are never flooded. They are
//! not needed there: at level 255 the whole image is one component, the root. So the pixels
//! below 255 are flooded part by part (each 4-connected part of them from its first pixel in
//! raster order; one part when no pixel is 255), the roots of the parts become the children of
//! a root at level 255, and the level-255 pixels are appended to the flood order at the end.
//! That append scans the image in chunks of 32 pixels, each tested at once for a 255 (a test
//! the compiler vectorises), and stops after the last such pixel: a per-pixel filtered scan cost
//! 5.5 instructions per pixel and polarity whenever the image had one pixel at 0 or 255, about
//! 6 % of a detection on the leuven images, which have both (callgrind, one detection of both
//! polarities: leuven img6 96.9 → 91.1 M instructions, img1 110.2 → 104.1 M, img3 102.8 →
//! 96.8 M; graf img1 103.4 → 101.4 M, img5 105.7 → 103.6 M; boat img1 103.4 → 101.1 M, img3
//! 119.5 → 117.2 M).
//!
//! The flood keeps one "boundary heap" per grey level: 255 stacks carved out of one array and
//! sized by the grey-level histogram (a pixel waits at most once at a time). All waiting pixels
//! lie at or above the current level, so when the current level's stack runs empty the next one
//! is found by scanning upwards; the sink in place of level 255 stops the scan and ends a part.
//! Since the sink is also the scan's bound, the scan reads the stack tops without a bound check:
//! 4 instructions per level passed instead of 8, and this scan passes about a million levels per
//! detection on the boat images (callgrind, one detection of both polarities, `min_diversity`
//! 0 as in `bench mser`: boat img2 100.2 → 95.9 M instructions, img5 95.3 → 92.5 M; leuven img4
//! 93.1 → 90.5 M, img6 88.1 → 86.1 M; graf img1 98.6 → 95.8 M). Time: no measurable change
//! (paired A/B as in module `stats`, within ±2 %): the bound checks ran beside the scan's loads,
//! and the scan's cost is the mispredicted exit of the loop, not its instructions.
//!
//! A visit reads the four neighbours at once, and their minimum alone decides what follows (no
//! branch per neighbour):
//! - a lower neighbour: the flood descends into the lowest one (the others stay unreached) and
//!   pushes the pixel back on its own level, to be visited again when the flood returns to it
//!   (heap entries are bare pixel indices, with no "resume here" state);
//! - otherwise the pixel joins the component, and all four neighbours are marked and pushed onto
//!   the stack of their cell value without a branch: the pushes of neighbours reached before
//!   land in the sink, four slots reset after every visit and never read. If a neighbour has the
//!   current level, the last one pushed, the top of the current stack, is taken back at once and
//!   visited next from a register instead of a store and reload; which neighbour that is, is
//!   chosen with conditional moves (`select_unpredictable`), as it follows no pattern.
//!
//! The top of the current level's stack lives in a register (its memory copy is kept equal).
//! Most visits are dead ends whose next pixel is popped from that stack; read from memory, the
//! pop would wait until the visit's four pushes, whose slots depend on the neighbours' values,
//! are known not to write it, chaining every visit's cell loads to the next; from the register it
//! does not, and consecutive visits overlap (about 20 % faster on the Oxford images). The loop
//! keeps few values live so that they all stay in registers: stack tops are pointers into the
//! heap (a push needs no heap base), the flood order is written through a moving pointer (flood
//! positions are computed inside the out-of-line calls that need them), and the neighbour taken
//! next is selected only on the two rare paths that use it.
//!
//! A fixed stack of open components (at most 255, as their levels strictly decrease upwards, over
//! a sentinel) holds, for each, its grey level, the position in the flood order at which it
//! was opened and its main child so far. Per pixel the flood only appends the pixel to the flood
//! order; opening, raising and merging components are rare events handled out of line. The
//! commonest, a rise that closes one node below `min_area` and then raises its component or
//! merges it once, takes a short path with no loop, call or bound check (three registers saved
//! on entry instead of six); listing a node of at least `min_area` pixels is a cold call, and
//! anything else continues in a general loop (callgrind, one detection of both polarities, with
//! the row division of module `layout`: leuven img6 91.1 → 87.4 M instructions, img3 96.8 →
//! 91.8 M; boat img1 101.1 → 97.1 M, img3 117.1 → 110.1 M, img5 99.5 → 94.6 M; graf img1 101.3
//! → 95.9 M; same-process A/B on 8 Oxford images, load 3.5–5: 4–5 % less time). Raising a
//! component to a higher level or merging it into the one below closes the node: one record of
//! four integers (level, area, start, main child). Because components on the stack only ever
//! merge into the one directly below, **the pixels of every node are one contiguous run of the
//! flood order** (`order[start .. start + area]`), so neither moments, bounding boxes nor first
//! pixels are accumulated during the flood: moments and boxes are summed afterwards over the runs
//! of the few selected nodes (module `stats`).
//!
//! The selection needs only the nodes of at least `min_area` pixels (their ancestors are such
//! nodes too), and the flood lists them apart ([`Tree::big`]), with what the selection reads:
//! - *Main children* are decided when a child closes, against the main child so far of the
//!   component it belongs to (the one below when it merged, the raised one when it was raised):
//!   a larger child wins by conditional moves, and a child tied in area is put on a list
//!   ([`Tree::tie_next`]) that is resolved by first pixels (computed from the runs) only if a
//!   variation walk reads it.
//! - The *lower end of the symmetric variation* (walk down main children while their level is at
//!   least `g − Δ`) is walked when a listed node closes, while the nodes and runs on its main
//!   chain were written recently and are still in the caches.
//! - *Parents*: no children are tracked; a node's parent is the next node to close at its
//!   parent's place on the stack (the same place when raised, the one below when merged), and one
//!   backward pass over the listed nodes links them ([`Big::parent`]).
//!
//! So the selection runs over the listed nodes only (module `select`), and no pass over all the
//! nodes follows the flood (graf img1: 179 k nodes per polarity, of which the selection used to
//! read 24 bytes each twice and keep three per-node arrays; callgrind with a 48 KiB L1 and a
//! 1 MiB L2 cache: L2 misses 512 k → 255 k, L1 misses −18 %, for both polarities). No
//! per-region heap allocation happens in the loop, and memory is O(pixels).
//!
//! **Tried and dropped** (each in a same-process A/B against the code above, alternating run by
//! run, results asserted identical; the loop's speed depends on how the compiler allocates its
//! registers, so any change to it needs such an A/B): an exact bitmap of the non-empty levels
//! (fewer mispredicts, more instructions, slower); an eight-level scan of the stacks; four sinks;
//! reading four stack tops at once; a sink whose top never advances; `open` or `rise` inlined or
//! marked `#[cold]`; children as a pending stack instead of sibling links; software
//! prefetch and non-temporal stores; one branch-free path for "next pixel from the current
//! level's stack" after a visit (the last same-level neighbour or the entry below the visit's
//! pushes, chosen by conditional moves, the stack top advanced by the number of same-level
//! neighbours): it makes every visit's next pixel wait on the previous visit's neighbour loads,
//! which the predicted branches let the core run ahead of, and its extra live values spilled
//! (callgrind +40 % instructions; ratio to OpenCV graf 2.62 → 2.18, leuven 2.30 → 1.92, boat
//! 2.45 → 2.11 in alternating runs); the neighbour cells read and written through a pointer to
//! the pixel's own cell at fixed offsets, their indices recomputed at each push and the next
//! pixel chosen as an offset (to free the four index registers): the compiler spilled more, not
//! less (callgrind leuven img6 96.9 → 111.2 M instructions, graf img1 103.4 → 116.1 M); nodes
//! written without the `Vec` capacity check (an unsafe write into the reserved room): −0.05 %
//! instructions, not worth the unsafe (it is used now only to keep a call off `rise`'s short
//! path); the part-start scan (`position` of the next unreached cell, 5 instructions per cell,
//! about 3 % of a detection on the leuven images, which have pixels at 0 and 255) by 32 or 8
//! cells at a time, inline or out of line: each way the compiler then kept the flood order's
//! pointer on the stack (a store and reload per visit), callgrind leuven img6 +1 %, boat img1
//! +2 % instructions, about 5 % slower; the cell values and the current level as `usize` (to drop
//! three zero-extending copies per visit): the current level and the order pointer spilled, +6 %
//! instructions; the top component copied field by field in `open` (a 16-byte load of fields
//! just written by narrower stores cannot be forwarded): no measurable effect. What remains: the
//! loop waits mainly on the latency of the four neighbour loads, and the flood's data-dependent
//! branches carry most mispredicts. Untried: a tiled cell layout so that vertical neighbours
//! share a cache line. Against it (callgrind with a 32 KiB L1, leuven img6): the neighbour loads
//! miss L1 about 0.4 times per visit, nearly all hitting L2, while the loop runs at about 2.3
//! instructions per cycle on the Xeon of the bench (measured time × clock against callgrind's
//! count), so time follows instructions, and tiles make every vertical neighbour index
//! conditional (several more instructions per visit).
//!
//! Also tried and dropped (callgrind, both polarities, `min_diversity` 0, leuven img4, which has
//! pixels at 0 and 255, so that the search for the next part's first pixel reads nearly every
//! cell at 5 instructions each: 2.7 M of the 90.5 M of the code above with the moments of
//! module `stats` as they were, of 87.1 M with them as they are). Every restructuring that made
//! that search cheaper made the compiler keep the flood order's pointer on the stack (a load,
//! add and store per joined pixel: a dependence through memory from one join to the next), and
//! most also kept a second copy of the current level in a register: the search out of line, 32
//! cells at a time (90.1 of 90.5 M); the flood of a part as a function of its own, the search in
//! the caller (91.3 of 90.5 M with the stack bottoms passed by reference; 93.9 of 89.8 M with
//! its own copy of them and its own components); the start of a part as a rare event of the one
//! flood loop, out of line like `rise` (86.9 of 87.1 M); the search by 8-byte words inline,
//! ended by sentinel cells after the frame instead of a bound (86.9 of 87.1 M). And the test "a
//! neighbour is at the current level" taken from whether the pushes moved the current stack's
//! top, to free the register of the neighbours' minimum: 88.2 of 87.1 M (two instructions more
//! per join), and with the one-loop form above 88.0 M, the pointer still on the stack. The
//! upward scan four levels at a time (the four "not empty" tests combined without a branch, the
//! first found by `trailing_zeros`, so that the loop's exit, mispredicted in about two scans in
//! three by callgrind's branch simulation, is taken at the first step in most scans): 94.5 of 87.1 M, the pointer on the stack. None
//! was timed; each adds the dependence through memory that came with the measured 5 % loss
//! above.
//!
//! The build, too: the release profile with one codegen unit and fat LTO (`bench mser`, two runs
//! each alternating with the default profile, 2026-12-06): every image within ±3 %, in no
//! consistent direction (the flood is one function of this crate, so neither setting gives the
//! compiler anything it lacked).
//!
//! Where a detection's time goes (callgrind instructions, both polarities, one detection, default
//! parameters; leuven img6 83.2 M, graf img1 86.1 M; before the unchecked upward scan and the
//! AVX2 moments of module `stats`, 87.4 M and 95.9 M): the open/raise/merge events with the
//! listing of big nodes and their lower-end walks 10 % and 16 %, the selection 1 % and 3 %, the
//! histogram 2 %, the moments (module `stats`) 0.6 % and 2 % (were 3 % and 9 %); the rest, 85 %
//! and 77 %, is the flood itself, mostly its inner loop: per joined pixel 20 instructions to load
//! and compare the neighbours, 29 to mark and push them and append the pixel, 3 to 8 to take
//! the next one. The two polarities are balanced.

use crate::image::GrayView;
use crate::layout::{RowDiv, RowDiv32, padded_stride};
use crate::params::{MserParams, Variation};

/// Marks "no node".
pub const NONE: u32 = u32::MAX;

/// Flag on a child id in [`Node::main`] and [`Tree::tie_next`]: more children tied in area
/// follow in the list.
pub const TIED: u32 = 1 << 31;

/// One node of the component tree.
#[derive(Debug, Clone, Copy)]
pub struct Node {
    /// Grey level on the internal scale (the image, or 255 − image for bright).
    pub level: u32,
    /// Area in pixels.
    pub area: u32,
    /// Position of the node's first pixel in [`Tree::order`]; its pixels are
    /// `order[start .. start + area]`.
    pub start: u32,
    /// The main child (largest; [`NONE`] for a leaf), or, flagged [`TIED`], the last of the
    /// children tied for the largest area, heading their list in [`Tree::tie_next`]; see
    /// [`Tree::main_child`], which resolves such a list by first pixel on first use.
    pub main: u32,
}

/// A node of at least `min_area` pixels (the only ones the selection looks at, and whose
/// ancestors are all such nodes), with what the selection reads of it.
#[derive(Debug, Clone, Copy)]
pub struct Big {
    /// Node id.
    pub id: u32,
    /// Grey level (as [`Node::level`]).
    pub level: u32,
    /// Area in pixels.
    pub area: u32,
    /// The area of the lower end of the symmetric variation: the last node reached from this
    /// one by walking down main children while their level is at least `level − Δ` (this node
    /// when none is); with the upward variation, the node's own area.
    pub lower: u32,
    /// Index of the parent in [`Tree::big`] (the parent of a node of at least `min_area` pixels
    /// is one too), or [`NONE`] for the root. During the flood: where the node closed,
    /// `position << 1 | merged`, with `position` its component's place on the flood's stack of
    /// open components (1 = bottom; 0 for the root at level 255) and `merged` set when it merged
    /// into the component below (its parent then sits one place lower; otherwise the component
    /// was raised and its parent is the raised one, at the same place); [`link_parents`] turns
    /// places into parents.
    pub parent: u32,
}

/// The component tree as a flat array indexed by node id. Ids are given when a node closes, so
/// every child has a smaller id than its parent, the nodes are in post-order and the root is the
/// last node.
#[derive(Debug, Default)]
pub struct Tree {
    /// The nodes.
    pub nodes: Vec<Node>,
    /// The nodes of at least `min_area` pixels, in id order, with their parents.
    pub big: Vec<Big>,
    /// Per child tied in area for its parent's main child: the previous tied child (flagged
    /// [`TIED`] while the list goes on). Only the entries of such children are meaningful.
    pub tie_next: Vec<u32>,
    /// Padded pixel indices in flood order (every pixel once).
    pub order: Vec<u32>,
    /// Row and column of a padded index (module `layout`).
    pub div: RowDiv,
    /// The same by a 32-bit product, if exact for every padded index of the image (read by the
    /// AVX2 summation of module `stats`).
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    pub div32: Option<RowDiv32>,
}

impl Tree {
    /// Image coordinates of a padded index.
    #[inline]
    pub fn xy(&self, idx: u32) -> (u32, u32) {
        let (x, y) = self.div.col_row(idx);
        (x, y - 1)
    }
}

/// The padded index of the first pixel in raster order of a node (the smallest index in its run
/// of the flood order), in O(area).
fn seed(n: &Node, order: &[u32]) -> u32 {
    let run = &order[n.start as usize..(n.start + n.area) as usize];
    run.iter().fold(NONE, |a, &b| a.min(b))
}

/// The main child of node `id` ([`NONE`] for a leaf): its largest child, and among children
/// tied in area the one whose first pixel comes first in raster order. The flood records a tie
/// as a list; it is resolved here on first use (the seed of each tied child computed once) and
/// remembered. `order` holds at least the runs of the children.
fn main_child(nodes: &mut [Node], tie_next: &[u32], order: &[u32], id: u32) -> u32 {
    let head = nodes[id as usize].main;
    if head == NONE || head & TIED == 0 {
        return head;
    }
    let mut best = head & !TIED;
    let mut best_seed = seed(&nodes[best as usize], order);
    let mut next = tie_next[best as usize];
    loop {
        let c = next & !TIED;
        let s = seed(&nodes[c as usize], order);
        if s < best_seed {
            (best, best_seed) = (c, s);
        }
        if next & TIED == 0 {
            break;
        }
        next = tie_next[c as usize];
    }
    nodes[id as usize].main = best;
    best
}

/// An open component on the flood's stack (its grey level is the flood level while it is on top,
/// and kept on the stack below).
#[derive(Debug, Clone, Copy)]
struct Comp {
    level: u32,
    /// Position in the flood order at which the component was opened.
    start: u32,
    /// The main child's area (0 before the first child).
    main_area: u32,
    /// The main child so far, as [`Node::main`] ([`NONE`] before the first child). (Not next
    /// to `start`: the compiler would read the two as one 8-byte load, which cannot be forwarded
    /// from their separate stores and stalls.)
    main: u32,
}

impl Comp {
    /// A component without children at `level`, opened at flood position `start`.
    fn new(level: u32, start: u32) -> Self {
        Comp {
            level,
            start,
            main: NONE,
            main_area: 0,
        }
    }

    /// Child `id` of `area` pixels competes for the main child: a larger one takes it (without a
    /// branch), an equal one joins the list of tied children (a rare branch; writing `tie_next`
    /// for every child instead measured 3 % more L2 misses in callgrind).
    #[inline(always)]
    fn adopt(&mut self, id: u32, area: u32, tie_next: &mut [u32]) {
        if area == self.main_area {
            // SAFETY: every node has a pixel at its own level, so nodes are at most the pixels,
            // the length of `tie_next`, and `id` is below.
            unsafe { *tie_next.get_unchecked_mut(id as usize) = self.main };
            self.main = id | TIED;
        }
        self.main = std::hint::select_unpredictable(area > self.main_area, id, self.main);
        self.main_area = self.main_area.max(area);
    }
}

/// Reusable buffers for building trees of images of any size.
#[derive(Debug)]
pub struct TreeBuilder {
    /// Padded image: the grey level, or [`REACHED`] once the pixel has been reached (the frame
    /// from the start).
    cells: Vec<u8>,
    heap: Vec<u32>,
    stack: Box<[Comp; STACK_SLOTS]>,
}

impl Default for TreeBuilder {
    fn default() -> Self {
        TreeBuilder {
            cells: Vec::new(),
            heap: Vec::new(),
            stack: Box::new([Comp::new(u32::MAX, 0); STACK_SLOTS]),
        }
    }
}

/// The cell value of a reached pixel (and of the frame): 255, never below the flood (which
/// handles levels 0..=254), and the index of the sink "level" that swallows its pushes. Pixels of
/// grey level 255 look reached from the start; they are never flooded and join the root at the
/// end.
const REACHED: u8 = SINK as u8;
/// Index of the sink in the per-level stack tops (in place of level 255).
const SINK: usize = 255;
/// Slots of the sink: it is reset after the four pushes of every visited pixel.
const SINK_SLOTS: u32 = 4;
/// Slots of the component stack: open components have strictly decreasing levels from the
/// bottom up, so at most 256 are open, plus the sentinel in slot 0.
const STACK_SLOTS: usize = 258;

/// The open components and the closed nodes: the rare events of the flood, kept out of its hot
/// loop.
struct Components<'a> {
    /// `stack[1..=depth]` are the open components below the top one; `stack[0]` is a sentinel
    /// whose level is above every level, so it is never merged into.
    stack: &'a mut [Comp; STACK_SLOTS],
    depth: usize,
    /// The top (current) component.
    top: Comp,
    nodes: &'a mut Vec<Node>,
    big: &'a mut Vec<Big>,
    /// As [`Tree::tie_next`], one entry per image pixel (nodes are at most that many).
    tie_next: &'a mut [u32],
    min_area: u32,
    /// Δ, or `None` for the upward variation (no walk down).
    delta: Option<u32>,
    /// The flood order, whose next slot (passed to `open` and `rise`) gives the flood position.
    order: Order,
}

impl Components<'_> {
    /// The flood descends to a lower `level` with the flood order's next slot at `at`: open a
    /// component on top. (Positions are computed here, out of the flood's loop.)
    #[inline(never)]
    fn open(&mut self, level: u32, at: *mut u32) {
        let pos = self.order.pos(at);
        debug_assert!(level < self.top.level);
        self.depth += 1;
        // Levels strictly decrease up the stack, so depth <= 256 (the assert holds always).
        self.stack[self.depth.min(STACK_SLOTS - 1)] = self.top;
        self.top = Comp::new(level, pos);
    }

    /// The flood rises to level `next` with the flood order's next slot at `at`: raise the top
    /// component to it or merge it into the ones below, closing one node for each.
    ///
    /// The common event closes one node smaller than `min_area` and raises the component or
    /// merges it once; that case is done here without a loop, a call or a bound check, so it
    /// needs few registers (three saved on entry instead of six). Anything else, a node of at
    /// least `min_area` pixels to list or a further merge, continues in
    /// [`rise_listing`](Self::rise_listing).
    #[inline(never)]
    fn rise(&mut self, next: u32, at: *mut u32) {
        let pos = self.order.pos(at);
        let area = pos - self.top.start;
        if area >= self.min_area {
            return self.rise_listing(next, pos);
        }
        let id = self.nodes.len();
        debug_assert!(id < self.nodes.capacity() && self.depth < STACK_SLOTS);
        // SAFETY: `nodes` holds room for one node per pixel (reserved by `build`), and
        // every node has a pixel at its own level, so there is room for this one. Open
        // components have strictly decreasing levels, so `depth < STACK_SLOTS`.
        let below = unsafe {
            self.nodes.as_mut_ptr().add(id).write(Node {
                level: self.top.level,
                area,
                start: self.top.start,
                main: self.top.main,
            });
            self.nodes.set_len(id + 1);
            *self.stack.get_unchecked(self.depth)
        };
        let id = id as u32;
        if next < below.level {
            return self.raise(next, id, area);
        }
        let mut below = below;
        below.adopt(id, area, self.tie_next);
        self.top = below;
        self.depth -= 1;
        if next > self.top.level {
            self.rise_listing(next, pos);
        }
    }

    /// [`rise`](Self::rise) from flood position `pos` on, for any number of closed nodes of any
    /// size (listing those of at least `min_area` pixels).
    #[cold]
    #[inline(never)]
    fn rise_listing(&mut self, next: u32, pos: u32) {
        loop {
            if next < self.stack[self.depth].level {
                let (id, area) = self.close(pos, self.place() << 1);
                return self.raise(next, id, area);
            }
            self.merge(pos);
            if next <= self.top.level {
                return;
            }
        }
    }

    /// Raises the top component to `level` after closing it as node `id` of `area` pixels,
    /// which becomes the raised component's first child.
    #[inline(always)]
    fn raise(&mut self, level: u32, id: u32, area: u32) {
        self.top = Comp {
            level,
            start: self.top.start,
            main: id,
            main_area: area,
        };
    }

    /// Closes the top component and merges it into the one below, which becomes the top.
    fn merge(&mut self, pos: u32) {
        debug_assert!(self.depth > 0);
        let (id, area) = self.close(pos, self.place() << 1 | 1);
        let mut below = self.stack[self.depth];
        below.adopt(id, area, self.tie_next);
        self.top = below;
        self.depth -= 1;
    }

    /// The top component's place on the stack (1 = bottom).
    fn place(&self) -> u32 {
        self.depth as u32 + 1
    }

    /// The area of the lower end of the symmetric variation of node `id` at `level`, closed at
    /// flood position `pos` ([`Big::lower`]). Done when the node closes, while the runs and
    /// nodes on its main chain were written recently.
    fn lower_end(&mut self, id: u32, level: u32, delta: u32, pos: u32) -> u32 {
        // SAFETY: `order.ptr[..pos]` is written (the runs of every closed node), and nothing
        // writes the order while this slice lives.
        let order = unsafe { std::slice::from_raw_parts(self.order.ptr, pos as usize) };
        let mut m = id;
        loop {
            let ch = main_child(self.nodes, self.tie_next, order, m);
            if ch == NONE || self.nodes[ch as usize].level + delta < level {
                break self.nodes[m as usize].area;
            }
            m = ch;
        }
    }

    /// Lists node `id` (at `level`, of `area >= min_area` pixels, closed at flood position `pos`
    /// and at `slot`) in [`Tree::big`] with the lower end of its variation. Out of line and cold
    /// (few nodes are that large), so that the loops that close nodes keep few values live.
    #[cold]
    #[inline(never)]
    fn list_big(&mut self, id: u32, level: u32, area: u32, slot: u32, pos: u32) {
        let lower = match self.delta {
            Some(delta) => self.lower_end(id, level, delta, pos),
            None => area,
        };
        self.big.push(Big {
            id,
            level,
            area,
            lower,
            parent: slot,
        });
    }

    /// Closes the top component at flood position `pos` as a node that closed at `slot` (as
    /// [`Big::parent`] during the flood); returns its id and area.
    #[inline(always)]
    fn close(&mut self, pos: u32, slot: u32) -> (u32, u32) {
        let c = self.top;
        let id = self.nodes.len() as u32;
        let area = pos - c.start;
        self.nodes.push(Node {
            level: c.level,
            area,
            start: c.start,
            main: c.main,
        });
        if area >= self.min_area {
            self.list_big(id, c.level, area, slot, pos);
        }
        (id, area)
    }
}

impl TreeBuilder {
    /// Builds the component tree of `img` (of `255 − img` when `invert`) into `tree`, listing the
    /// nodes of at least `params.min_area` pixels in [`Tree::big`] with the lower ends of their
    /// variations; `hist` is the grey-level histogram of `img` (see [`histogram`]), shared by the
    /// two polarities.
    pub fn build(
        &mut self,
        img: &GrayView,
        hist: &[u32; 256],
        invert: bool,
        params: &MserParams,
        tree: &mut Tree,
    ) {
        let min_area = params.min_area.min(u32::MAX as usize) as u32;
        let delta = (params.variation == Variation::Symmetric).then_some(params.delta as u32);
        let (w, h) = (img.width(), img.height());
        let stride = padded_stride(w);
        let total = stride * (h + 2);
        let npix = w * h;
        tree.div = RowDiv::new(stride as u32);
        tree.div32 = tree.div.narrow((total - 1) as u32);
        tree.nodes.clear();
        tree.nodes.reserve(npix);
        tree.big.clear();
        // Entries are read only where written (nodes are at most the pixels).
        if tree.tie_next.len() < npix {
            tree.tie_next.resize(npix, NONE);
        }
        // Every slot is written before it is read, so old contents need no clearing.
        if tree.order.len() != npix {
            tree.order.clear();
            tree.order.resize(npix, 0);
        }

        // Padded copy with the frame marked as reached.
        if self.cells.len() != total {
            self.cells.clear();
            self.cells.resize(total, REACHED);
        }
        let flip = if invert { 255u8 } else { 0 };
        self.cells[..stride].fill(REACHED);
        for y in 0..h {
            let base = (y + 1) * stride;
            let (px, pad) = self.cells[base..base + stride].split_at_mut(w);
            // A plain copy, which the compiler vectorises.
            for (d, &g) in px.iter_mut().zip(img.row(y)) {
                *d = g ^ flip;
            }
            pad.fill(REACHED);
        }
        self.cells[(h + 1) * stride..].fill(REACHED);

        // Boundary heap: the sink first (slots 0..SINK_SLOTS, taking the pushes of reached
        // neighbours), then one stack per level below 255 (level g holds at most its hist[g]
        // pixels, each at most once). `bottom[g]..top_of[g]` are level g's entries, as
        // pointers into the heap, so that a push needs no heap base in a register; the sink's
        // `bottom` (null) never equals its top, so it stops the upward scan.
        let mut acc = SINK_SLOTS as usize;
        let mut starts = [0usize; SINK];
        for (g, st) in starts.iter_mut().enumerate() {
            *st = acc;
            acc += hist[g ^ flip as usize] as usize;
        }
        let heap_len = acc;
        if self.heap.len() < heap_len {
            self.heap.resize(heap_len, 0);
        }
        let heap = self.heap.as_mut_ptr();
        // SAFETY (of every `heap.add` here): `starts[g] <= heap_len <= self.heap.len()`.
        let mut bottom = [std::ptr::null_mut::<u32>(); SINK + 1];
        for (b, &st) in bottom.iter_mut().zip(&starts) {
            *b = unsafe { heap.add(st) };
        }
        let mut top_of = bottom;
        top_of[SINK] = heap;
        let cells = &mut self.cells[..];
        let order = Order {
            ptr: tree.order.as_mut_ptr(),
            len: npix,
        };

        let stride = stride as u32;
        // Push order, and so the preference among equal neighbours: the last one pushed is
        // visited next.
        let offs: [u32; 4] = [1, stride.wrapping_neg(), u32::MAX, stride];

        // The flood order's next slot; `pos` is its index, computed where needed.
        let mut at = order.ptr;
        let mut scan_from = stride as usize;
        let below_255 = (npix as u32) - hist[255 ^ flip as usize];
        // The root at level 255 (if any pixel is 255), whose children are the parts' roots.
        let mut root = Comp::new(255, 0);
        // One flood per connected part of the pixels below 255, each from its first pixel in
        // raster order (the cells below 255 are exactly the unreached pixels of those parts),
        // until all of them are in.
        while order.pos(at) < below_255 {
            let Some(skip) = cells[scan_from..].iter().position(|&c| c != REACHED) else {
                debug_assert!(
                    false,
                    "{} pixels below 255 not flooded",
                    below_255 - order.pos(at)
                );
                break;
            };
            let mut cur = (scan_from + skip) as u32;
            scan_from += skip + 1;
            let mut cur_level = cells[cur as usize] as u32;
            cells[cur as usize] = REACHED;
            let mut comps = Components {
                stack: &mut self.stack,
                depth: 0,
                top: Comp::new(cur_level, order.pos(at)),
                nodes: &mut tree.nodes,
                big: &mut tree.big,
                tie_next: &mut tree.tie_next,
                min_area,
                delta,
                order,
            };
            // The top of the current level's stack, kept in a register: the dead end's pop
            // reads it from here, so it does not wait for the visit's pushes (whose slots depend
            // on the neighbours' values) to rule out a store to it. The memory copy
            // `top_of[cur_level]` is kept equal to it at the start of every visit; only a visit
            // with a neighbour at the current level pushes there, and that path reloads it.
            // Every stack is empty when a part starts.
            let mut ct = bottom[cur_level as usize];
            loop {
                debug_assert_eq!(ct, top_of[cur_level as usize]);
                // `cur` is a pixel at `cur_level`, the level of the top component, either seen
                // for the first time or pushed back when the flood descended from it.
                let ns = offs.map(|o| cur.wrapping_add(o));
                // SAFETY: `cur` is an image pixel and the frame is one pixel wide (plus the
                // padding columns, which wrap to the next row's frame), so every neighbour is
                // `< total`.
                let vs = ns.map(|n| unsafe { *cells.get_unchecked(n as usize) } as u32);
                let low = vs[0].min(vs[1]).min(vs[2].min(vs[3]));
                if low < cur_level {
                    let next = last_at(ns, vs, low);
                    // Descend into a lower neighbour. The others stay unreached: `cur` waits
                    // at its level and is visited again when the flood comes back to it.
                    // SAFETY: as above.
                    unsafe { *cells.get_unchecked_mut(next as usize) = REACHED };
                    // SAFETY: level `cur_level`'s stack holds at most its hist entries.
                    unsafe {
                        *ct = cur;
                        *top_of.get_unchecked_mut(cur_level as usize) = ct.add(1);
                    }
                    comps.open(low, at);
                    cur_level = low;
                    // Every waiting pixel lies at or above the old level: the new one is empty.
                    // SAFETY: `low` is a grey level.
                    ct = unsafe { *bottom.get_unchecked(low as usize) };
                    cur = next;
                    continue;
                }
                // No lower neighbour: mark and push all four without a branch (the reached
                // ones, and those of level 255, go to the sink), and `cur` joins the top
                // component.
                for i in 0..4 {
                    // SAFETY: as above.
                    unsafe { *cells.get_unchecked_mut(ns[i] as usize) = REACHED };
                    push(&mut top_of, vs[i], ns[i]);
                }
                top_of[SINK] = heap;
                debug_assert!(order.pos(at) < npix as u32);
                // SAFETY: every image pixel is added once, so `pos < npix`.
                unsafe {
                    *at = cur;
                    at = at.add(1);
                }
                if low == cur_level {
                    // A neighbour at the same level is the next pixel: the last one pushed
                    // there, i.e. the top of the current stack. Take it back and keep it in a
                    // register instead of reloading it from the heap.
                    let next = last_at(ns, vs, low);
                    // SAFETY: `low` is a grey level and its stack is not empty.
                    unsafe {
                        let t = top_of.get_unchecked_mut(low as usize);
                        *t = t.sub(1);
                        ct = *t;
                    }
                    cur = next;
                    continue;
                }

                // Dead end: the next pixel comes from the current level's stack, else from the
                // lowest non-empty one. No push of this visit went to the current level.
                // SAFETY: `cur_level` is a grey level.
                if ct != unsafe { *bottom.get_unchecked(cur_level as usize) } {
                    // SAFETY: the stack is not empty, so `ct - 1` is its top entry.
                    unsafe {
                        ct = ct.sub(1);
                        *top_of.get_unchecked_mut(cur_level as usize) = ct;
                        cur = *ct;
                    }
                } else {
                    // Every entry lies at or above the current level: scan upwards.
                    let mut g = cur_level as usize + 1;
                    // SAFETY: `g <= SINK`: the sink's top never equals its bottom (null), so
                    // the scan stops there at the latest.
                    while unsafe { top_of.get_unchecked(g) == bottom.get_unchecked(g) } {
                        g += 1;
                    }
                    if g == SINK {
                        break;
                    }
                    // SAFETY: as above.
                    unsafe {
                        ct = top_of[g].sub(1);
                        top_of[g] = ct;
                        cur = *ct;
                    }
                    cur_level = g as u32;
                    comps.rise(cur_level, at);
                }
            }
            // The part is flooded; close its remaining components into its root, which merges
            // into the root at level 255 (place 0), if there is one.
            let pos = order.pos(at);
            while comps.depth > 0 {
                comps.merge(pos);
            }
            let (id, area) = comps.close(pos, 1 << 1 | 1);
            root.adopt(id, area, &mut tree.tie_next);
        }
        let mut pos = order.pos(at);

        if hist[255 ^ flip as usize] > 0 {
            // The pixels of level 255 were never flooded: they join the root, the whole image
            // at level 255, whose children are the roots of the floods.
            // In raster order, by chunks of 32 pixels tested at once (a test the compiler
            // vectorises), as most chunks hold none; the scan stops after the last one.
            let top = 255 ^ flip;
            for y in 0..h {
                if pos as usize == npix {
                    break;
                }
                let base = ((y + 1) * stride as usize) as u32;
                for (c, chunk) in img.row(y).chunks(32).enumerate() {
                    if !chunk.iter().fold(false, |any, &g| any | (g == top)) {
                        continue;
                    }
                    for (j, _) in chunk.iter().enumerate().filter(|&(_, &g)| g == top) {
                        debug_assert!((pos as usize) < npix);
                        // SAFETY: every image pixel is added once, so `pos < npix`.
                        unsafe { *order.ptr.add(pos as usize) = base + (c * 32 + j) as u32 };
                        pos += 1;
                    }
                }
            }
            let mut comps = Components {
                stack: &mut self.stack,
                depth: 0,
                top: root,
                nodes: &mut tree.nodes,
                big: &mut tree.big,
                tie_next: &mut tree.tie_next,
                min_area,
                delta,
                order,
            };
            comps.close(pos, 0);
        }
        // Otherwise the pixels below 255 are one 4-connected part, and its flood's root is
        // the tree's root.
        debug_assert_eq!(pos as usize, npix);
        link_parents(&mut tree.big);
    }
}

/// Sets every listed node's parent from the places where the nodes closed ([`Big::parent`]):
/// the parent is the next node (in id order) to close at the parent's place, found by one
/// backward pass that remembers the latest node seen at each place. (A raised component closes
/// again at its own place, a merged one's component below closes next at the place below, and
/// no other node closes at that place in between, as components above it are opened and closed
/// after it.) The parent of a node of at least `min_area` pixels is larger, so it is listed
/// too, and the pass needs only the listed nodes.
fn link_parents(big: &mut [Big]) {
    let mut last = [NONE; STACK_SLOTS];
    for (k, n) in big.iter_mut().enumerate().rev() {
        let place = (n.parent >> 1) as usize;
        // SAFETY: places are at most 257 (a depth of at most 256 below the top), and a
        // parent's place is one lower only when the node merged (place >= 1).
        unsafe {
            n.parent = *last.get_unchecked(place - (n.parent & 1) as usize);
            *last.get_unchecked_mut(place) = k as u32;
        }
    }
}

/// The grey-level histogram of `img`.
pub fn histogram(img: &GrayView) -> [u32; 256] {
    // Four partial histograms, so that runs of equal pixels do not make every increment wait on
    // the previous one's store.
    let mut part = [[0u32; 256]; 4];
    for y in 0..img.height() {
        let row = img.row(y);
        let mut quads = row.chunks_exact(4);
        for q in &mut quads {
            for (h, &g) in part.iter_mut().zip(q) {
                h[g as usize] += 1;
            }
        }
        for &g in quads.remainder() {
            part[0][g as usize] += 1;
        }
    }
    std::array::from_fn(|g| part.iter().map(|h| h[g]).sum())
}

/// The last of the neighbours `ns` whose value in `vs` is `low`, their minimum. Conditional
/// moves, not branches: which neighbour it is follows no pattern.
#[inline(always)]
fn last_at(ns: [u32; 4], vs: [u32; 4], low: u32) -> u32 {
    let mut next = ns[0];
    for i in 1..4 {
        next = std::hint::select_unpredictable(vs[i] == low, ns[i], next);
    }
    next
}

/// The flood order as a raw pointer: the flood writes it through a moving pointer.
#[derive(Clone, Copy)]
struct Order {
    ptr: *mut u32,
    len: usize,
}

impl Order {
    /// The index of the slot `at` points to.
    #[inline(always)]
    fn pos(&self, at: *mut u32) -> u32 {
        debug_assert!(at >= self.ptr && (at as usize - self.ptr as usize) / 4 <= self.len);
        ((at as usize - self.ptr as usize) / std::mem::size_of::<u32>()) as u32
    }
}

/// Pushes the padded index `e` on top of level `g`'s stack; `g` is [`SINK`] for a reached
/// pixel, whose entry is never read.
#[inline(always)]
fn push(top_of: &mut [*mut u32; SINK + 1], g: u32, e: u32) {
    debug_assert!(g as usize <= SINK);
    // SAFETY: `g` is a level or the sink (cells hold nothing else). Level g's stack holds at
    // most hist[g] entries, each a distinct pixel of level g waiting in the heap, so its top
    // stays below the next level's bottom; the sink takes at most the four pushes of one visit
    // before it is reset.
    unsafe {
        let t = top_of.get_unchecked_mut(g as usize);
        **t = e;
        *t = t.add(1);
    }
}
