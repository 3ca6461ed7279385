//! Maximally Stable Extremal Regions (MSER, Matas et al., BMVC 2002), detected in linear time
//! with the component-tree flood of Nistér & Stewénius (ECCV 2008), for both polarities, with
//! exact moments, equivalent ellipses, pixel lists on demand, exact outer contours, and the region
//! files of the Oxford affine benchmark.
//!
//! Paper A of the thesis (Larsson, *Methods for Visually Guided Robotic Systems*, 2009; "Patch
//! Contour Matching by Correlating Fourier Descriptors", §5) extracts local regions with MSER and
//! describes each region's outer contour; this crate provides the regions and the contours that
//! `fd-match` consumes.
//!
//! ```
//! // A dark disk of radius 8 on a bright background.
//! let (w, h) = (40, 40);
//! let px: Vec<u8> = (0..w * h)
//!     .map(|i| {
//!         let (x, y) = ((i % w) as f64 - 20.0, (i / w) as f64 - 20.0);
//!         if x * x + y * y < 64.0 { 30 } else { 220 }
//!     })
//!     .collect();
//! let img = mser::GrayView::packed(&px, w, h).unwrap();
//! let params = mser::MserParams { polarities: mser::Polarities::Dark, ..Default::default() };
//! let regions = mser::detect(&img, &params).unwrap();
//! assert_eq!(regions.len(), 1);
//! let r = &regions[0];
//! let e = r.ellipse().unwrap(); // Oxford (u, v, a, b, c); area close to the region's
//! assert!((e.u - 20.0).abs() < 1e-9 && (e.area() / r.area as f64 - 1.0).abs() < 0.02);
//! let contour = r.contour(&img).unwrap(); // closed, counter-clockwise on screen
//! assert_eq!(contour[0], r.seed);
//! ```
//!
//! # Definitions
//!
//! Dark polarity (bright is the same on `255 − I`, with levels mapped back). For a threshold
//! `t ∈ 0..=255`, the *extremal regions* at `t` are the connected components (4-neighbourhood) of
//! `{p : I(p) ≤ t}`. Over all thresholds they form a tree: each distinct set `S` is a node, its
//! *level* `g(S)` is the largest grey value in it (the lowest threshold at which it exists), its
//! parent is the smallest strictly larger extremal region containing it, and the root is the
//! whole image. `Q_t(S)` for `t ≥ g(S)` is the ancestor that is the component at threshold `t`
//! (the root for `t ≥ 255`). The *main child* of a node is its largest child (ties: the child whose
//! first pixel in raster order comes first).
//!
//! **Variation** ([`Variation`]), with Δ = [`MserParams::delta`] and `g = g(S)`:
//!
//! - [`Variation::Symmetric`] (default; Matas et al.'s `q(i) = |Q_{i+Δ} \ Q_{i−Δ}| / |Q_i|`):
//!   `v(S) = (|Q_{g+Δ}(S)| − |L(S)|) / |S|`, where `L(S)` stands for `Q_{g−Δ}`: walking down
//!   from `S` through main children while the child's level is still `≥ g − Δ`, `L(S)` is the
//!   last node reached (`S` itself when `S`'s main child lies below `g − Δ` or `S` has no
//!   child). This is OpenCV's (3.x–5.x) lower end. The literal `Q_{g−Δ}` (the main-chain region at
//!   threshold `g − Δ`, empty for a region younger than Δ levels) would give every region born
//!   less than Δ levels ago a variation near 1, so a clean step-edge blob would never be stable;
//!   OpenCV measures such a region from its birth instead, and so do we.
//! - [`Variation::Upward`] (VLFeat): `v(S) = (|Q_{g+Δ}(S)| − |S|) / |S|`. It needs no choice of
//!   child and is therefore exactly invariant to rotations even when children tie in area.
//!
//! **Selection**, a region `S` is reported when
//!
//! 1. it is not the root, `min_area ≤ |S| ≤ max_area` and `v(S) ≤ max_variation`;
//! 2. it is a local minimum of `v` in the tree: `v(S) ≤ v(parent)` and `v(S) ≤ v(C)` for every
//!    child `C` with `|C| ≥ min_area` (children below `min_area` do not take part, as in
//!    OpenCV); ties keep both, so nested regions of zero variation (perfect step edges) are all
//!    found. Variations are compared with each other exactly, as ratios of pixel counts
//!    (cross-multiplied integers), so ties and order are exact on images of any size
//!    ([`Region::variation`] is the ratio rounded to `f64`, which is also what is compared with
//!    `max_variation`);
//! 3. diversity: among the regions passing 1–2, `S` is dropped when one of them, `D ⊊ S`, covers
//!    most of it, `(|S| − |D|) / |S| < min_diversity`. This keeps the smaller of two near-identical
//!    nested regions, as OpenCV 5 does; OpenCV 4.x ignores `min_diversity` on grey images. The
//!    test is against the set after steps 1–2, so the result does not depend on any visiting order.
//!
//! **Order**: dark regions, then bright; within a polarity by threshold on that polarity's scale
//! (dark: ascending level; bright: descending level), then by the row and column of the region's
//! first pixel. A region is identified by its polarity, level and [`Region::seed`] (first pixel in
//! raster order); its pixels are the component of the threshold set through the seed.
//!
//! These definitions are checked literally: `tests/integration/reference.rs` thresholds random
//! small images at every level, labels components, builds the tree from the sets and applies 1–3;
//! on 2,000 random images and parameter sets the detector returns exactly the same regions in the
//! same order, with the same areas, moments, bounding boxes and seeds.
//!
//! # Algorithm and cost
//!
//! [Nistér & Stewénius](https://doi.org/10.1007/978-3-540-88693-8_14): flood the image from a
//! pixel, always continuing at the lowest grey level reachable; the not yet flooded boundary pixels
//! wait in one stack per grey level, and a stack of open components tracks the nested extremal
//! regions. When the flood moves up to a higher level the top component is either raised to that
//! level or merged into the component below; each such event closes one tree node. There is no
//! union-find over the image and no sorting. Time is O(pixels · 4) plus O(nodes · Δ) for the
//! variation walks; memory is O(pixels) in flat arrays (padded grey levels, one byte per pixel,
//! the boundary stacks, the flood order, and four integers per node), allocated once per [`Mser`]
//! and reused. (With one byte per cell "reached" is the value 255, so pixels of level 255, which
//! all belong to the root, are never flooded: the pixels below 255 are flooded part by part and
//! their roots joined under the root; module `tree` has the details of the flood.) Since
//! open components only ever merge into the one directly below them, every node's pixels are one
//! contiguous run of the flood order; so the flood accumulates no moments at all, and the exact
//! integer moments and bounding boxes are summed afterwards over the runs of the selected regions
//! only, each pixel read at most once (nested selected regions reuse their inner sums). Pixel
//! lists come two ways: [`Mser::detect_with_pixels`] has that same summation pass also write the
//! coordinates of every pixel it reads at its flood position, so every region's pixel list is a
//! slice of one array per polarity (no second flood, no allocation per region, nested regions
//! share pixels; [`RegionsWithPixels`]); and for a single region [`Region::pixels`] refills
//! them from the seed in O(area). [`Region::contour`] follows the boundary in O(perimeter).
//!
//! Against OpenCV (`cargo xtask bench mser`; ratios in `docs/performance.md`, *mser*): our time
//! varies little between images, since most of it is the flood, which visits every pixel and is
//! bound by load latency and mispredicted branches, not by instructions (module `tree`); OpenCV's
//! grows with the regions it keeps and lists. So the images with the fewest regions give the
//! lowest ratios.
//!
//! # Regions, ellipses and contours
//!
//! [`Region`] carries polarity, level, seed, area, variation, inclusive bounding box and the raw
//! integer [`Moments`] (Σx, Σy, Σx², Σxy, Σy² over pixel centres, 0-based, x right, y down).
//!
//! **Ellipse** ([`Region::ellipse`]): Oxford `(u, v, a, b, c)` with
//! `a(x−u)² + 2b(x−u)(y−v) + c(y−v)² = 1` (docs/methods.md § MSER). Centre = centroid.
//! Shape: `M = (4Σ)⁻¹`
//! where Σ holds the second central moments of the region as a plane figure, i.e. of the union of
//! its unit pixel squares (pixel-centre covariance + 1/12 on the diagonal). `M = (4Σ)⁻¹` is the
//! uniformly filled ellipse with those moments, so the ellipse has about the region's area
//! (exactly, for an elliptical region) and its semi-axes are twice the standard deviations. This
//! is twice the linear size of VLFeat/VLBenchmarks MSER frames (`M = Σ⁻¹`, available as
//! [`Region::ellipse_scaled`]`(1.0)`); the `+1/12` makes Σ positive definite even for one-pixel-wide
//! regions. Both return a `Result`: a detected region always has its ellipse, but `Region`'s
//! fields are public, and a hand-built one with no pixels or with moments no pixel set has is an
//! [`MserError::InvalidParameter`], not a panic.
//!
//! **Contour** ([`Region::contour`]): the outer boundary as a closed list of integer pixel
//! coordinates `(x, y)`: every point is a region pixel with a non-region 4-neighbour (outside the
//! image counts as non-region), consecutive points (and last → first) are 8-adjacent, the chain
//! visits every region pixel that touches the outside (the 8-connected background component that
//! reaches the image border), and never a pixel that only touches a hole. It runs
//! **counter-clockwise as seen on screen** (y down; equivalently the shoelace sum
//! `Σ xᵢ yᵢ₊₁ − xᵢ₊₁ yᵢ` is ≤ 0) and starts at the seed; the first point is not repeated at the
//! end, a pixel is listed again where the boundary passes it twice (one-pixel-wide parts), and a
//! one-pixel region gives one point. Method: crack following (module `contour`), O(perimeter),
//! no mask.
//!
//! # The thesis setting ([`MserParams::larsson2009`])
//!
//! Paper A, footnote 3: "The parameters used for the MSER method were minimum margin = 30 and
//! minimum region size = 50. We used these values for all experiments." These are the parameter
//! names of the original MSER implementation of Matas et al. (`extrema`, also used through
//! Forssén's Linköping code), where the *margin* of a region is the number of grey levels over
//! which it stays (nearly) the same, and the region is placed in the middle of that range. In the
//! Δ formulation a region is tested over the window `[g − Δ, g + Δ]`, which is `2Δ` levels wide
//! and centred on the region. We therefore map a margin of 30 to **Δ = 15** with the symmetric
//! measure (a window of 30 grey levels centred on the region) and the minimum size to
//! **`min_area` = 50**. The paper names no maximum size, so `max_area` is unlimited (the whole
//! image is never reported); `max_variation` (0.25) and `min_diversity` (0.2) keep OpenCV's
//! defaults, since the paper does not mention them. This is a reasoned mapping, not a
//! reproduction of the original binary: the original's margin test (area growth below about one
//! boundary ring over the margin) is not implemented.
//!
//! # OpenCV
//!
//! [`MserParams::default`] has the meaning and values of OpenCV's `MSER::create(delta = 5,
//! min_area = 60, max_area = 14400, max_variation = 0.25, min_diversity = 0.2)`. With feature
//! `opencv`, `tests/integration/opencv_crosscheck.rs` compares pixel sets with OpenCV 4.6 on graf,
//! boat and leuven img1 (OpenCV linked here: 4.6.0). Systematic differences, all explained:
//!
//! - **Image border.** OpenCV 4.x marks the outermost pixel ring as a wall and never puts it into a
//!   region; we flood every pixel. Regions touching the border therefore differ. Every one of our
//!   regions that avoids the border is also an OpenCV region (100 % on all three images with
//!   `min_diversity` 0), and running ours on the image without its outer ring gives exactly
//!   OpenCV's set, both ways (100 %: graf 1899, boat 1477, leuven 1047 regions).
//! - **`min_diversity`.** OpenCV 4.x ignores it on grey images (graf: 1899 regions at any value
//!   here); we apply it as OpenCV 5 does, so with the default 0.2 we report fewer regions (graf
//!   294, boat 984, leuven 243), all of them OpenCV regions where they avoid the border.
//! - **Ties.** OpenCV picks the main child by merge order when two children have equal area; we
//!   pick by raster order, so results are deterministic and independent of scan order.
//! - **Ties with the parent.** OpenCV 4.x drops a region whose variation is positive and equal
//!   to its parent's (`var > 0 && var >= parent.var` in its `checkAndCapture`), while it keeps a
//!   region tied with a child; we keep ties on both sides (rule 2 above). This is the only
//!   difference on the 18 Oxford images (graf img2: 2 regions, graf img5: 1, boat img3: 1; with
//!   `min_diversity` 0, ours without the outer ring, checked by `cargo xtask bench mser`) and on
//!   the 100 crops of `cargo xtask bench cli` (13 regions on the 12 crops that differ): e.g.
//!   graf img2, crop at (0, 0), the bright region at level 113 with variation 42/294 under a
//!   parent of 43/301.
//!   [`variations_by_thresholds`] recomputes a region's and its parent's variation from the
//!   image by thresholding, as exact ratios; `cargo xtask bench mser` and `bench cli` excuse a
//!   region of ours that OpenCV lacks only when it shows such a tie, region by region, and fail
//!   on any other difference (`tests/integration/opencv_crosscheck.rs` does the same on two crops;
//!   `tests/integration/variation_ties.rs` builds a tie). OpenCV also computes variations in
//!   32-bit floats, so two different variations that round to the same float tie for it too
//!   (not seen in the images here). And it can report its root, the whole flooded image, when
//!   `max_area` allows; by definition 1 the root is never a region here.
//! - OpenCV 4.x finds dark regions by its first pass and bright regions by its second in one call;
//!   it cannot detect dark regions alone ([`Polarities::Dark`] has no OpenCV counterpart).
//!
//! # Features
//!
//! - `rayon`: `Mser::detect_parallel` and `Mser::detect_with_pixels_parallel` (the two
//!   polarities on two tasks) and `detect_many` (many images); results equal the sequential
//!   ones (`tests/integration/parallel.rs`, `tests/integration/pixels.rs`). Plain [`Mser::detect`]
//!   is single-threaded. Two tasks on one image gain little: the join waits for the later polarity,
//!   and a task may start late (the other core waking) or be held off its core (in one run of
//!   `bench mser` on the 2-core VM the second task started 2.3 ms after the first, and the first
//!   had 6.9 ms of CPU in 11.1 ms wall; the bench prints each task's start delay, CPU and wall
//!   time). A batch of images (`detect_many`) keeps every core busy, so image strips are not built.
//!   Speed-ups: `docs/performance.md`, *mser*.
//! - `opencv`: `OpenCvMser`, OpenCV's detector with our parameters, for cross-checks and
//!   benchmarks (needs libopencv-dev 4.x and libclang).
//!
//! Deterministic: no randomness, no dependence on thread count, nor on the CPU (the moment
//! summation has a version compiled for AVX2, chosen at run time; it sums the same integers,
//! module `stats`).
#![deny(missing_docs)]

mod contour;
mod detector;
mod error;
mod image;
mod layout;
mod oxford;
mod params;
mod pixels;
mod region;
mod region_pixels;
mod select;
mod stats;
mod thresholds;
mod tree;

pub use contour::trace_outer_contour;
#[cfg(feature = "rayon")]
pub use detector::detect_many;
pub use detector::{Mser, detect};
pub use error::{MserError, Result};
pub use image::{GrayView, load_gray, luminance, to_gray};
pub use oxford::{
    MAX_DESCRIPTOR_LEN, MAX_REGIONS, OxfordRegion, load_regions, read_regions, save_regions,
    write_regions,
};
pub use params::{MserParams, Polarities, Variation};
pub use pixels::flood_pixels;
pub use region::{BoundingBox, EXACT_CENTRING_FROM, Ellipse, Moments, Polarity, Region};
pub use region_pixels::RegionsWithPixels;
pub use thresholds::{Ratio, Variations, variations_by_thresholds};

#[cfg(feature = "opencv")]
mod opencv_peer;
#[cfg(feature = "opencv")]
pub use opencv_peer::{OpenCvMser, opencv_version, set_opencv_threads};
