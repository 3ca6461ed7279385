//! Cross-check against OpenCV's MSER (feature `opencv`) on graf, boat and leuven img1 with equal
//! parameters: the fraction of OpenCV's regions whose pixel set is identical to one of ours, and
//! vice versa (our pixel sets from `Region::pixels` on the full image and from the one-pass
//! `detect_with_pixels` on the image without its outer ring). The systematic differences are
//! explained in the crate docs ("OpenCV"). Without the Oxford data the test skips with a note,
//! and fails under `CI=true`.
#![cfg(feature = "opencv")]

mod common;

use std::collections::HashSet;

use mser::{GrayView, Mser, MserParams, OpenCvMser};

type Set = Vec<(u32, u32)>;

struct Agreement {
    ours: usize,
    theirs: usize,
    theirs_in_ours: f64,
    ours_in_theirs: f64,
    ours_off_border_in_theirs: f64,
}

/// Our regions of `img`; with `inner_only`, of `img` without its outermost pixel ring (the part
/// OpenCV 4.x floods), mapped back to full-image coordinates.
fn ours(img: &GrayView, p: &MserParams, inner_only: bool) -> Vec<Set> {
    if !inner_only {
        let rs = Mser::new(p.clone()).unwrap().detect(img).unwrap();
        return rs.iter().map(|r| r.pixels(img).unwrap()).collect();
    }
    let (w, h) = (img.width(), img.height());
    let mut data = Vec::with_capacity(w * h);
    for y in 0..h {
        data.extend_from_slice(img.row(y));
    }
    let inner = GrayView::new(&data[w + 1..], w - 2, h - 2, w).unwrap();
    // Here through the one-pass pixel lists (flood order, so sorted to raster order).
    let mut det = Mser::new(p.clone()).unwrap();
    let found = det.detect_with_pixels(&inner).unwrap();
    found
        .iter()
        .map(|(_, px)| {
            let mut v: Set = px.iter().map(|&(x, y)| (x + 1, y + 1)).collect();
            v.sort_unstable_by_key(|&(x, y)| (y, x));
            v
        })
        .collect()
}

fn compare(img: &GrayView, p: &MserParams, inner_only: bool) -> Agreement {
    let ours = ours(img, p, inner_only);
    let theirs: Vec<Set> = OpenCvMser::new(p).unwrap().detect(img).unwrap();
    let ours_set: HashSet<&Set> = ours.iter().collect();
    let theirs_set: HashSet<&Set> = theirs.iter().collect();
    let frac = |num: usize, den: usize| {
        if den == 0 {
            1.0
        } else {
            num as f64 / den as f64
        }
    };
    let (w, h) = (img.width() as u32, img.height() as u32);
    let off_border: Vec<&Set> = ours
        .iter()
        .filter(|s| {
            s.iter()
                .all(|&(x, y)| x > 0 && y > 0 && x + 1 < w && y + 1 < h)
        })
        .collect();
    Agreement {
        ours: ours.len(),
        theirs: theirs.len(),
        theirs_in_ours: frac(
            theirs.iter().filter(|s| ours_set.contains(s)).count(),
            theirs.len(),
        ),
        ours_in_theirs: frac(
            ours.iter().filter(|s| theirs_set.contains(s)).count(),
            ours.len(),
        ),
        ours_off_border_in_theirs: frac(
            off_border
                .iter()
                .filter(|s| theirs_set.contains(*s))
                .count(),
            off_border.len(),
        ),
    }
}

#[test]
fn agrees_with_opencv_on_oxford_img1() {
    let Some(dir) = common::oxford_dir() else {
        return;
    };
    mser::set_opencv_threads(1).unwrap();
    let version = mser::opencv_version();
    // OpenCV 4.x ignores min_diversity on grey images, so "equal parameters" means 0 there.
    let cases = [
        ("OpenCV defaults", MserParams::default()),
        (
            "defaults, min_diversity 0",
            MserParams {
                min_diversity: 0.0,
                ..MserParams::default()
            },
        ),
    ];
    for seq in ["graf", "boat", "leuven"] {
        let g = mser::load_gray(dir.join(seq).join("img1.png")).unwrap();
        let img = GrayView::from_image(&g).unwrap();
        for ((name, p), inner) in cases.iter().flat_map(|c| [(c, false), (c, true)]) {
            let a = compare(&img, p, inner);
            let name = if inner {
                format!("{name}, ours without the outer pixel ring")
            } else {
                name.to_string()
            };
            println!(
                "{seq} img1, {name}, OpenCV {version}: ours {} regions, OpenCV {}; OpenCV's found in ours {:.1}%, ours found in OpenCV's {:.1}% ({:.1}% of ours off the image border)",
                a.ours,
                a.theirs,
                100.0 * a.theirs_in_ours,
                100.0 * a.ours_in_theirs,
                100.0 * a.ours_off_border_in_theirs,
            );
            if p.min_diversity == 0.0 {
                // Same parameters in effect: our regions that avoid the image border are OpenCV's.
                assert!(
                    a.ours_off_border_in_theirs > 0.95,
                    "{seq}: too little agreement"
                );
                if inner {
                    // Same pixels flooded too: the sets agree both ways.
                    assert!(
                        a.theirs_in_ours > 0.99 && a.ours_in_theirs > 0.99,
                        "{seq}: sets differ"
                    );
                }
            }
        }
    }
}

/// The 4-connected component through `seed` of the pixels `keep` accepts, by index.
fn component(img: &[u8], w: usize, h: usize, seed: usize, keep: impl Fn(u8) -> bool) -> Vec<usize> {
    let mut seen = vec![false; w * h];
    let (mut out, mut stack) = (Vec::new(), vec![seed]);
    seen[seed] = true;
    while let Some(p) = stack.pop() {
        out.push(p);
        let (x, y) = (p % w, p / w);
        let nbs = [
            (x > 0).then(|| p - 1),
            (x + 1 < w).then(|| p + 1),
            (y > 0).then(|| p - w),
            (y + 1 < h).then(|| p + w),
        ];
        for n in nbs.into_iter().flatten() {
            if !seen[n] && keep(img[n]) {
                seen[n] = true;
                stack.push(n);
            }
        }
    }
    out.sort_unstable();
    out
}

/// The variation of the crate docs, by thresholding (dark polarity of `img`): the region through
/// `seed` at `level`, as (numerator, denominator) = (|Q_{g+Δ}| − |L|, |S|).
fn variation_by_thresholds(
    img: &[u8],
    w: usize,
    h: usize,
    seed: usize,
    g: u8,
    delta: u8,
) -> (usize, usize) {
    let s = component(img, w, h, seed, |v| v <= g);
    let up = component(img, w, h, seed, |v| v <= g.saturating_add(delta)).len();
    // Walk down the main (largest, then first in raster order) children while their level is
    // at least g − Δ.
    let mut m = s.clone();
    let mut gm = g;
    while gm > 0 {
        let inside: std::collections::HashSet<usize> = m.iter().copied().collect();
        let mut done = std::collections::HashSet::new();
        let mut best: Option<Vec<usize>> = None;
        for &p in &m {
            if img[p] < gm && !done.contains(&p) {
                let c = component(img, w, h, p, |v| v < gm);
                assert!(c.iter().all(|q| inside.contains(q)));
                done.extend(c.iter().copied());
                if best
                    .as_ref()
                    .is_none_or(|b| c.len() > b.len() || (c.len() == b.len() && c[0] < b[0]))
                {
                    best = Some(c);
                }
            }
        }
        let Some(c) = best else { break };
        let gc = c.iter().map(|&q| img[q]).max().unwrap();
        if (gc as u32) + (delta as u32) < g as u32 {
            break;
        }
        (m, gm) = (c, gc);
    }
    (up - m.len(), s.len())
}

/// The region that contains `s` and is one level up the tree (its parent): (seed, level).
fn parent_by_thresholds(img: &[u8], w: usize, h: usize, seed: usize, g: u8, area: usize) -> u8 {
    (g + 1..=255)
        .find(|&t| component(img, w, h, seed, |v| v <= t).len() > area)
        .expect("not the root")
}

/// On two 640×480 crops of graf img2 (the crops of `cargo xtask bench cli`) OpenCV 4.x finds one
/// or two regions fewer than we do. The whole difference is OpenCV's parent-tie rule (crate docs,
/// "OpenCV"): every OpenCV region is ours, and every region of ours that OpenCV lacks has a
/// positive variation exactly equal to its parent's, checked here by thresholding.
#[test]
fn on_graf_img2_crops_the_only_difference_is_the_parent_tie_rule() {
    let Some(dir) = common::oxford_dir() else {
        return;
    };
    mser::set_opencv_threads(1).unwrap();
    let p = MserParams {
        min_diversity: 0.0,
        ..MserParams::default()
    };
    let g = mser::load_gray(dir.join("graf").join("img2.png")).unwrap();
    let (gw, gh) = (g.width() as usize, g.height() as usize);
    let (w, h) = (640, 480);
    let mut extra_total = 0;
    // Crops 0 and 3 of the bench: offsets (0, 0) and (0, gh − 480).
    for (x0, y0) in [(0, 0), (0, gh - h)] {
        assert!(gw >= w);
        let crop: Vec<u8> = (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .map(|(x, y)| g.get_pixel((x0 + x) as u32, (y0 + y) as u32)[0])
            .collect();
        let img = GrayView::packed(&crop, w, h).unwrap();
        let theirs: HashSet<Set> = OpenCvMser::new(&p)
            .unwrap()
            .detect(&img)
            .unwrap()
            .into_iter()
            .collect();
        let inner = GrayView::new(&crop[w + 1..], w - 2, h - 2, w).unwrap();
        let (iw, ih) = (w - 2, h - 2);
        let inner_px: Vec<u8> = (0..ih).flat_map(|y| inner.row(y).to_vec()).collect();
        let mut det = Mser::new(p.clone()).unwrap();
        let found = det.detect_with_pixels(&inner).unwrap();
        let mut ours = HashSet::new();
        let mut extra = 0;
        for (r, px) in found.iter() {
            let mut v: Set = px.iter().map(|&(x, y)| (x + 1, y + 1)).collect();
            v.sort_unstable_by_key(|&(x, y)| (y, x));
            if !theirs.contains(&v) {
                extra += 1;
                // On the polarity's own scale (bright: 255 − image).
                let (img_p, g): (Vec<u8>, u8) = match r.polarity {
                    mser::Polarity::Dark => (inner_px.clone(), r.level),
                    mser::Polarity::Bright => {
                        (inner_px.iter().map(|&v| 255 - v).collect(), 255 - r.level)
                    }
                };
                let seed = r.seed.1 as usize * iw + r.seed.0 as usize;
                let (num, den) = variation_by_thresholds(&img_p, iw, ih, seed, g, p.delta);
                assert_eq!(den, r.area as usize);
                assert_eq!(num as f64 / den as f64, r.variation);
                let gp = parent_by_thresholds(&img_p, iw, ih, seed, g, den);
                let (pn, pd) = variation_by_thresholds(&img_p, iw, ih, seed, gp, p.delta);
                println!(
                    "ours only: {:?} level {} area {} variation {num}/{den}; parent level {} variation {pn}/{pd}",
                    r.polarity,
                    r.level,
                    r.area,
                    if r.polarity == mser::Polarity::Bright {
                        255 - gp
                    } else {
                        gp
                    }
                );
                assert!(
                    num > 0 && num * pd == pn * den,
                    "{r:?}: not a positive tie with its parent"
                );
            }
            ours.insert(v);
        }
        assert!(
            theirs.iter().all(|s| ours.contains(s)),
            "an OpenCV region is not ours"
        );
        assert_eq!(theirs.len() + extra, ours.len());
        extra_total += extra;
    }
    // Measured: one region on crop 0, two on crop 3.
    assert_eq!(extra_total, 3);
}
