//! Moments and bounding boxes of the selected nodes, summed over their runs of the flood order.
//!
//! Every node's pixels are one contiguous run `order[start .. start + area]` (module `tree`), and
//! runs of distinct nodes are nested or disjoint. The selected nodes come in id order, which is
//! post-order, so when a node is reached every selected node inside it has been summed already and
//! the outermost of them sit on top of a stack: their sums are added and only the pixels between
//! their runs are read. Every pixel is therefore read at most once, whatever the nesting, and the
//! cost is O(pixels in selected nodes), at most O(pixels).
//!
//! On request the same pass also writes every pixel it reads, as image coordinates, at its flood
//! position in a second array: then every selected region's pixel list is the slice of that array
//! over its run (nested regions share their pixels), with no second flood and no per-region
//! allocation.
//!
//! The loop over a run is written so that the compiler can vectorise it: the row by the high half
//! of a 32 × 32-bit product where that is exact (`RowDiv32` of module `layout`; every image of
//! the Oxford sets), in the summation compiled a second time for AVX2 and chosen at run time when
//! the CPU has it (`is_x86_feature_detected`); otherwise the scalar loop with the 128-bit
//! product. Sums of integers in any order are the same integers, so every path gives the same
//! sums (the test below compares all three). Per pixel: 32 instructions with the 128-bit product
//! (whose fixed registers cost three copies and three reloads), 26.5 with the 32-bit one without
//! AVX2 (two pixels per SSE2 step, minima and maxima built from compares and masks), 6 with AVX2
//! (four pixels per step, native minima and maxima). One detection of both polarities under
//! callgrind, `min_diversity` 0 as in `bench mser`: the summation on boat img2 8.9 → 7.6 (SSE2)
//! → 2.0 M (AVX2) instructions, the detection 95.9 → 94.6 → 89.0 M; leuven img4 90.5 → 89.8 →
//! 87.1 M. Time (paired A/B of the two builds, alternating in random order, 20–30 pairs of 5
//! rounds on 8 Oxford images, pinned to one core at real-time priority, load 3–4; an A/A run of
//! one build against itself spread 0.99–1.02): with AVX2, `detect_with_pixels` 1.5–2.5 % faster,
//! `detect` unchanged within ±2 %; the SSE2 loop 1–3 % slower than the scalar one despite fewer
//! instructions, so it is not used. Also tried: the column as the fraction of the same product
//! times the row length (exact too, two products and no 32-bit multiplication): the compiler no
//! longer vectorised the SSE2 loop (30 instructions per pixel, leuven img4 90.2 M).

#[cfg(target_arch = "x86_64")]
use crate::layout::RowDiv32;
use crate::layout::{ColRow, RowDiv};
use crate::region::{BoundingBox, Moments};
use crate::tree::Tree;

/// Exact sums over a set of pixels in padded coordinates (`x`, and `y + 1` for image row `y`).
///
/// Extremes are kept as `i32` (padded indices are below 2^28), which vectorises better than
/// unsigned comparisons; the first and last pixel in raster order give the seed and the rows of
/// the bounding box, so only `x` needs its own minimum and maximum.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sums {
    sx: u64,
    sy: u64,
    sxx: u64,
    sxy: u64,
    syy: u64,
    first: i32,
    last: i32,
    x0: i32,
    x1: i32,
}

impl Sums {
    const EMPTY: Sums = Sums {
        sx: 0,
        sy: 0,
        sxx: 0,
        sxy: 0,
        syy: 0,
        first: i32::MAX,
        last: -1,
        x0: i32::MAX,
        x1: -1,
    };

    /// Adds one pixel: padded index `i` at padded column `x` and row `y`.
    #[inline(always)]
    fn add_pixel(&mut self, i: u32, x: u32, y: u32) {
        let (xl, yl) = (x as u64, y as u64);
        self.sx += xl;
        self.sy += yl;
        self.sxx += xl * xl;
        self.sxy += xl * yl;
        self.syy += yl * yl;
        self.first = self.first.min(i as i32);
        self.last = self.last.max(i as i32);
        self.x0 = self.x0.min(x as i32);
        self.x1 = self.x1.max(x as i32);
    }

    /// Adds the pixels with padded indices `idx`.
    fn add_run(&mut self, idx: &[u32], div: impl ColRow) {
        let mut s = *self;
        for &i in idx {
            let (x, y) = div.col_row(i);
            s.add_pixel(i, x, y);
        }
        *self = s;
    }

    /// [`add_run`](Self::add_run), also writing each pixel's image coordinates `(x, y)` into
    /// `xy` (same length as `idx`).
    fn add_run_xy(&mut self, idx: &[u32], div: impl ColRow, xy: &mut [(u32, u32)]) {
        let mut s = *self;
        for (&i, out) in idx.iter().zip(xy) {
            let (x, y) = div.col_row(i);
            *out = (x, y - 1);
            s.add_pixel(i, x, y);
        }
        *self = s;
    }

    fn absorb(&mut self, o: &Sums) {
        self.sx += o.sx;
        self.sy += o.sy;
        self.sxx += o.sxx;
        self.sxy += o.sxy;
        self.syy += o.syy;
        self.first = self.first.min(o.first);
        self.last = self.last.max(o.last);
        self.x0 = self.x0.min(o.x0);
        self.x1 = self.x1.max(o.x1);
    }

    /// The padded index of the first pixel in raster order.
    pub fn seed(&self) -> u32 {
        self.first as u32
    }

    /// The raw moments of these `n` pixels in image coordinates (`y` one less than padded).
    pub fn moments(&self, n: u32) -> Moments {
        let n = n as u64;
        Moments {
            n,
            sx: self.sx,
            sy: self.sy - n,
            sxx: self.sxx,
            sxy: self.sxy - self.sx,
            // Σ(y−1)² = Σy² − 2Σy + n, which is ≥ 0, so the sum first cannot underflow.
            syy: self.syy + n - 2 * self.sy,
        }
    }

    /// The inclusive bounding box in image coordinates.
    pub fn bbox(&self, div: RowDiv) -> BoundingBox {
        BoundingBox {
            x_min: self.x0 as u32,
            y_min: div.row(self.first as u32) - 1,
            x_max: self.x1 as u32,
            y_max: div.row(self.last as u32) - 1,
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
        self.sums_impl::<false>(tree, ids, out, &mut []);
    }

    /// As [`sums`](Self::sums), and writes the image coordinates of every pixel of the nodes at
    /// its flood position in `xy` (resized to the flood order's length; other entries are left
    /// as they were), so node `id`'s pixels are `xy[start .. start + area]`.
    pub fn sums_and_pixels(
        &mut self,
        tree: &Tree,
        ids: impl Iterator<Item = u32>,
        out: &mut Vec<Sums>,
        xy: &mut Vec<(u32, u32)>,
    ) {
        if xy.len() != tree.order.len() {
            xy.clear();
            xy.resize(tree.order.len(), (0, 0));
        }
        self.sums_impl::<true>(tree, ids, out, xy);
    }

    fn sums_impl<const PIXELS: bool>(
        &mut self,
        tree: &Tree,
        ids: impl Iterator<Item = u32>,
        out: &mut Vec<Sums>,
        xy: &mut [(u32, u32)],
    ) {
        match tree.div32 {
            #[cfg(target_arch = "x86_64")]
            Some(div) if std::is_x86_feature_detected!("avx2") => {
                // SAFETY: the CPU has AVX2 (checked at run time).
                unsafe { self.sums_avx2::<PIXELS>(tree, div, ids, out, xy) }
            }
            // Without AVX2, the 128-bit row division: the SSE2 loop that the 32-bit one gives
            // runs fewer instructions but measured no faster (module docs).
            _ => self.sums_by::<PIXELS>(tree, tree.div, ids, out, xy),
        }
    }

    /// [`sums_by`](Self::sums_by) compiled for AVX2: the loops over the runs vectorise four
    /// pixels wide, with native 32-bit minima and maxima (SSE2 has neither).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn sums_avx2<const PIXELS: bool>(
        &mut self,
        tree: &Tree,
        div: RowDiv32,
        ids: impl Iterator<Item = u32>,
        out: &mut Vec<Sums>,
        xy: &mut [(u32, u32)],
    ) {
        self.sums_by::<PIXELS>(tree, div, ids, out, xy);
    }

    #[inline(always)]
    fn sums_by<const PIXELS: bool>(
        &mut self,
        tree: &Tree,
        div: impl ColRow,
        ids: impl Iterator<Item = u32>,
        out: &mut Vec<Sums>,
        xy: &mut [(u32, u32)],
    ) {
        let mut add = |sums: &mut Sums, a: u32, b: u32| {
            let run = &tree.order[a as usize..b as usize];
            if PIXELS {
                sums.add_run_xy(run, div, &mut xy[a as usize..b as usize]);
            } else {
                sums.add_run(run, div);
            }
        };
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
                add(&mut sums, at, s);
                sums.absorb(&inner);
                at = e;
            }
            add(&mut sums, at, end);
            self.open.push((start, end, sums));
            out.push(sums);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::GrayView;
    use crate::params::MserParams;
    use crate::tree::{TreeBuilder, histogram};

    /// Every way of summing gives the same sums and pixel lists: the 128-bit and the 32-bit row
    /// division, portable and (where the CPU has it) compiled for AVX2, on images of several
    /// sizes, for every node of at least `min_area` pixels (nested runs and all).
    #[test]
    fn every_summation_path_agrees() {
        let mut builder = TreeBuilder::default();
        let mut tree = Tree::default();
        let mut summer = Summer::default();
        let params = MserParams {
            min_area: 3,
            ..Default::default()
        };
        for (w, h, seed) in [(37, 23, 1u32), (64, 48, 2), (131, 9, 3), (5, 200, 4)] {
            let px: Vec<u8> = (0..w * h)
                .map(|i| {
                    let (x, y) = ((i % w) as u32, (i / w) as u32);
                    let v = x
                        .wrapping_mul(2654435761)
                        .wrapping_add(y.wrapping_mul(40503) ^ seed);
                    ((v >> 13) % 7 * 30 + (x + y) % 5) as u8
                })
                .collect();
            let img = GrayView::packed(&px, w, h).unwrap();
            let hist = histogram(&img);
            for invert in [false, true] {
                builder.build(&img, &hist, invert, &params, &mut tree);
                let ids: Vec<u32> = tree.big.iter().map(|b| b.id).collect();
                assert!(ids.len() > 5, "{w}x{h}: {} nodes", ids.len());
                let div32 = tree.div32.expect("a small layout");
                let run = |summer: &mut Summer, how: u8| {
                    let (mut sums, mut xy) = (Vec::new(), vec![(0, 0); tree.order.len()]);
                    let it = ids.iter().copied();
                    match how {
                        0 => summer.sums_by::<true>(&tree, tree.div, it, &mut sums, &mut xy),
                        1 => summer.sums_by::<true>(&tree, div32, it, &mut sums, &mut xy),
                        _ => summer.sums_impl::<true>(&tree, it, &mut sums, &mut xy),
                    }
                    (sums, xy)
                };
                let wide = run(&mut summer, 0);
                assert_eq!(run(&mut summer, 1), wide, "{w}x{h}, 32-bit division");
                assert_eq!(run(&mut summer, 2), wide, "{w}x{h}, dispatched");
                let mut plain = Vec::new();
                summer.sums(&tree, ids.iter().copied(), &mut plain);
                assert_eq!(plain, wide.0, "{w}x{h}, without pixel lists");
            }
        }
    }
}
