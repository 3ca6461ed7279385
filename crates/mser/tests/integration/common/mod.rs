//! Shared test helpers: the brute-force reference detector and the contour checker.

use std::collections::{HashMap, HashSet, VecDeque};

use mser::{MserParams, Polarities, Polarity, Variation};

/// A region of the reference: polarity, level and its pixels `(x, y)` in raster order.
pub type RefRegion = (Polarity, u8, Vec<(u32, u32)>);

/// Components of `{I <= t}` (4-neighbourhood) as a label per pixel (`usize::MAX` = below).
fn label(img: &[u8], w: usize, h: usize, t: u8) -> Vec<usize> {
    let mut lab = vec![usize::MAX; w * h];
    let mut next = 0;
    for s in 0..w * h {
        if img[s] > t || lab[s] != usize::MAX {
            continue;
        }
        lab[s] = next;
        let mut q = VecDeque::from([s]);
        while let Some(p) = q.pop_front() {
            let (x, y) = (p % w, p / w);
            let mut nb = Vec::new();
            if x > 0 {
                nb.push(p - 1);
            }
            if x + 1 < w {
                nb.push(p + 1);
            }
            if y > 0 {
                nb.push(p - w);
            }
            if y + 1 < h {
                nb.push(p + w);
            }
            for n in nb {
                if img[n] <= t && lab[n] == usize::MAX {
                    lab[n] = next;
                    q.push_back(n);
                }
            }
        }
        next += 1;
    }
    lab
}

/// Dark regions of `img` by the definitions in the crate docs, computed by thresholding at every
/// level and labelling components: no flood, no stack, no incremental anything.
fn reference_dark(img: &[u8], w: usize, h: usize, p: &MserParams) -> Vec<(u8, Vec<usize>)> {
    reference_dark_detail(img, w, h, p)
        .into_iter()
        .map(|d| (d.level, d.pixels))
        .collect()
}

/// A region of the reference with its variation and its parent's, as exact ratios
/// `(numerator, denominator)` of pixel counts; levels on the dark scale until
/// [`reference_detail`] maps them back.
#[derive(Debug, Clone, PartialEq)]
pub struct RefDetail {
    pub polarity: Polarity,
    pub level: u8,
    /// Pixel indices `y * w + x`, in raster order.
    pub pixels: Vec<usize>,
    pub var: (u64, u64),
    pub parent_level: u8,
    pub parent_area: u64,
    pub parent_var: (u64, u64),
}

/// [`reference_dark`] with every selected region's variation and its parent's level, area and
/// variation.
fn reference_dark_detail(img: &[u8], w: usize, h: usize, p: &MserParams) -> Vec<RefDetail> {
    // Every extremal region (distinct component over all thresholds), keyed by its pixel set.
    let mut id_of: HashMap<Vec<usize>, usize> = HashMap::new();
    let mut sets: Vec<Vec<usize>> = Vec::new();
    // comp_at[t][pixel] = id of the component holding the pixel at threshold t.
    let mut comp_at: Vec<Vec<usize>> = Vec::with_capacity(256);
    for t in 0..=255u8 {
        let lab = label(img, w, h, t);
        let mut groups: HashMap<usize, Vec<usize>> = HashMap::new();
        for (px, &l) in lab.iter().enumerate() {
            if l != usize::MAX {
                groups.entry(l).or_default().push(px);
            }
        }
        let mut at = vec![usize::MAX; w * h];
        for (_, set) in groups {
            let n = sets.len();
            let id = *id_of.entry(set.clone()).or_insert(n);
            if id == n {
                sets.push(set.clone());
            }
            for &px in &set {
                at[px] = id;
            }
        }
        comp_at.push(at);
    }
    let n = sets.len();
    let level: Vec<u8> = sets
        .iter()
        .map(|s| s.iter().map(|&q| img[q]).max().unwrap())
        .collect();
    let area: Vec<usize> = sets.iter().map(|s| s.len()).collect();
    let first: Vec<usize> = sets.iter().map(|s| s[0]).collect(); // sets are in raster order
    let q_at = |s: usize, t: usize| comp_at[t.min(255)][first[s]];
    let parent: Vec<Option<usize>> = (0..n)
        .map(|s| {
            (level[s] as usize + 1..=255)
                .map(|t| q_at(s, t))
                .find(|&q| q != s)
        })
        .collect();
    let children: Vec<Vec<usize>> = (0..n)
        .map(|s| {
            if level[s] == 0 {
                return vec![];
            }
            let t = level[s] as usize - 1;
            let mut c: Vec<usize> = sets[s]
                .iter()
                .filter(|&&q| img[q] as usize <= t)
                .map(|&q| comp_at[t][q])
                .collect();
            c.sort();
            c.dedup();
            c
        })
        .collect();
    let main_child = |s: usize| -> Option<usize> {
        children[s]
            .iter()
            .copied()
            .max_by(|&a, &b| area[a].cmp(&area[b]).then(first[b].cmp(&first[a])))
    };
    let delta = p.delta as usize;
    let ratio = |s: usize| -> (u64, u64) {
        let g = level[s] as usize;
        let up = area[q_at(s, g + delta)];
        let lower = match p.variation {
            Variation::Upward => area[s],
            Variation::Symmetric => {
                // Walk down the largest children while they still exist at threshold g − Δ or
                // later; the last one reached stands for Q_{g−Δ}.
                let mut m = s;
                loop {
                    match main_child(m) {
                        Some(c) if level[c] as usize + delta >= g => m = c,
                        _ => break area[m],
                    }
                }
            }
        };
        ((up - lower) as u64, area[s] as u64)
    };
    let ratios: Vec<(u64, u64)> = (0..n).map(ratio).collect();
    let vars: Vec<f64> = ratios.iter().map(|&(a, b)| a as f64 / b as f64).collect();
    let cand: Vec<bool> = (0..n)
        .map(|s| {
            let Some(q) = parent[s] else { return false };
            area[s] >= p.min_area
                && area[s] <= p.max_area
                && vars[s] <= p.max_variation
                && vars[s] <= vars[q]
                && children[s]
                    .iter()
                    .all(|&c| area[c] < p.min_area || vars[s] <= vars[c])
        })
        .collect();
    let mut out = Vec::new();
    for s in 0..n {
        if !cand[s] {
            continue;
        }
        let set_s: HashSet<usize> = sets[s].iter().copied().collect();
        let similar = (0..n).any(|d| {
            d != s
                && cand[d]
                && area[d] < area[s]
                && sets[d].iter().all(|q| set_s.contains(q))
                && ((area[s] - area[d]) as f64 / area[s] as f64) < p.min_diversity
        });
        if !similar {
            let q = parent[s].expect("candidates have a parent");
            out.push(RefDetail {
                polarity: Polarity::Dark,
                level: level[s],
                pixels: sets[s].clone(),
                var: ratios[s],
                parent_level: level[q],
                parent_area: area[q] as u64,
                parent_var: ratios[q],
            });
        }
    }
    out.sort_by_key(|d| (d.level, d.pixels[0]));
    out
}

/// The reference detector with variations: all regions in the crate's order, levels on the
/// image's scale, pixels as indices `y * w + x` in raster order.
pub fn reference_detail(img: &[u8], w: usize, h: usize, p: &MserParams) -> Vec<RefDetail> {
    let mut out = Vec::new();
    if matches!(p.polarities, Polarities::Dark | Polarities::Both) {
        out.extend(reference_dark_detail(img, w, h, p));
    }
    if matches!(p.polarities, Polarities::Bright | Polarities::Both) {
        let inv: Vec<u8> = img.iter().map(|&g| 255 - g).collect();
        for mut d in reference_dark_detail(&inv, w, h, p) {
            d.polarity = Polarity::Bright;
            d.level = 255 - d.level;
            d.parent_level = 255 - d.parent_level;
            out.push(d);
        }
    }
    out
}

/// The pixels `(x, y)`, in raster order, of the 4-connected component through `seed` of the
/// pixels that pass `polarity`'s threshold at `level`: labels of the whole thresholded image,
/// no flood from the seed.
pub fn component(
    img: &[u8],
    w: usize,
    h: usize,
    seed: (u32, u32),
    level: u8,
    polarity: Polarity,
) -> Vec<(u32, u32)> {
    let (img, t): (Vec<u8>, u8) = match polarity {
        Polarity::Dark => (img.to_vec(), level),
        Polarity::Bright => (img.iter().map(|&g| 255 - g).collect(), 255 - level),
    };
    let lab = label(&img, w, h, t);
    let l = lab[seed.1 as usize * w + seed.0 as usize];
    assert_ne!(l, usize::MAX, "seed does not pass the threshold");
    (0..w * h)
        .filter(|&q| lab[q] == l)
        .map(|q| ((q % w) as u32, (q / w) as u32))
        .collect()
}

/// The reference detector: all regions in the crate's order, pixels in raster order.
pub fn reference(img: &[u8], w: usize, h: usize, p: &MserParams) -> Vec<RefRegion> {
    let to_xy = |s: Vec<usize>| {
        s.into_iter()
            .map(|q| ((q % w) as u32, (q / w) as u32))
            .collect()
    };
    let mut out = Vec::new();
    if matches!(p.polarities, Polarities::Dark | Polarities::Both) {
        for (l, s) in reference_dark(img, w, h, p) {
            out.push((Polarity::Dark, l, to_xy(s)));
        }
    }
    if matches!(p.polarities, Polarities::Bright | Polarities::Both) {
        let inv: Vec<u8> = img.iter().map(|&g| 255 - g).collect();
        for (l, s) in reference_dark(&inv, w, h, p) {
            out.push((Polarity::Bright, 255 - l, to_xy(s)));
        }
    }
    out
}

/// A region's pixels in a mask padded by one pixel on every side, and the outer background.
pub struct Padded {
    /// `m[(y + 1) · pw + x + 1]`: pixel `(x, y)` is in the region.
    pub m: Vec<bool>,
    /// The outer background: the complement's 8-connected component through the padding.
    pub out: Vec<bool>,
    /// Padded width and height (`w + 2`, `h + 2`).
    pub pw: usize,
    pub ph: usize,
}

/// [`Padded`] for `pixels` of a `w × h` image.
pub fn padded(pixels: &[(u32, u32)], w: usize, h: usize) -> Padded {
    let (pw, ph) = (w + 2, h + 2);
    let mut m = vec![false; pw * ph];
    for &(x, y) in pixels {
        m[(y as usize + 1) * pw + x as usize + 1] = true;
    }
    let mut out = vec![false; pw * ph];
    out[0] = true;
    let mut q = vec![0usize];
    while let Some(p) = q.pop() {
        let (x, y) = ((p % pw) as i64, (p / pw) as i64);
        for dy in -1..=1 {
            for dx in -1..=1 {
                let (nx, ny) = (x + dx, y + dy);
                if nx < 0 || ny < 0 || nx >= pw as i64 || ny >= ph as i64 {
                    continue;
                }
                let n = ny as usize * pw + nx as usize;
                if !m[n] && !out[n] {
                    out[n] = true;
                    q.push(n);
                }
            }
        }
    }
    Padded { m, out, pw, ph }
}

/// Checks every promise of `Region::contour` against the region's pixel set; panics with a
/// message on the first failure.
pub fn check_contour(contour: &[(u32, u32)], pixels: &[(u32, u32)], w: usize, h: usize) {
    assert!(!contour.is_empty(), "empty contour");
    let Padded { m, out, pw, .. } = padded(pixels, w, h);
    let outer_4nb = |x: u32, y: u32| {
        let p = (y as usize + 1) * pw + x as usize + 1;
        out[p - 1] || out[p + 1] || out[p - pw] || out[p + pw]
    };
    let expected: HashSet<(u32, u32)> = pixels
        .iter()
        .copied()
        .filter(|&(x, y)| outer_4nb(x, y))
        .collect();
    let got: HashSet<(u32, u32)> = contour.iter().copied().collect();
    for &(x, y) in contour {
        assert!(
            m[(y as usize + 1) * pw + x as usize + 1],
            "contour point ({x}, {y}) is not a region pixel"
        );
        assert!(
            outer_4nb(x, y),
            "contour point ({x}, {y}) has no outside 4-neighbour"
        );
    }
    assert_eq!(
        got, expected,
        "contour does not visit exactly the outer boundary"
    );
    assert_eq!(contour[0], pixels[0], "contour does not start at the seed");
    let n = contour.len();
    if n > 1 {
        for i in 0..n {
            let (a, b) = (contour[i], contour[(i + 1) % n]);
            let d = (a.0 as i64 - b.0 as i64)
                .abs()
                .max((a.1 as i64 - b.1 as i64).abs());
            assert_eq!(d, 1, "points {a:?} and {b:?} are not 8-adjacent");
        }
    }
    // Orientation: counter-clockwise on screen (y down) gives a non-positive shoelace sum.
    let s: i64 = (0..n)
        .map(|i| {
            let (a, b) = (contour[i], contour[(i + 1) % n]);
            a.0 as i64 * b.1 as i64 - b.0 as i64 * a.1 as i64
        })
        .sum();
    assert!(s <= 0, "contour runs clockwise on screen (shoelace {s})");
}
