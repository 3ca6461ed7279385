//! Cross-check against OpenCV's MSER (feature `opencv`) on graf, boat and leuven img1 with equal
//! parameters: the fraction of OpenCV's regions whose pixel set is identical to one of ours, and
//! vice versa (our pixel sets from `Region::pixels` on the full image and from the one-pass
//! `detect_with_pixels` on the image without its outer ring). The systematic differences are
//! explained in the crate docs ("OpenCV"). Without the Oxford data the test skips with a note,
//! and fails under `CI=true`.
#![cfg(feature = "opencv")]

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
    let Some(dir) = oxford_dir() else {
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

/// On two 640×480 crops of graf img2 (the crops of `cargo xtask bench cli`) OpenCV 4.x finds one
/// or two regions fewer than we do. The whole difference is OpenCV's parent-tie rule (crate docs,
/// "OpenCV"): every OpenCV region is ours, and every region of ours that OpenCV lacks has a
/// positive variation exactly equal to its parent's, checked here by thresholding.
#[test]
fn on_graf_img2_crops_the_only_difference_is_the_parent_tie_rule() {
    let Some(dir) = oxford_dir() else {
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
        let mut det = Mser::new(p.clone()).unwrap();
        let found = det.detect_with_pixels(&inner).unwrap();
        let mut ours = HashSet::new();
        let mut extra = 0;
        for (r, px) in found.iter() {
            let mut v: Set = px.iter().map(|&(x, y)| (x + 1, y + 1)).collect();
            v.sort_unstable_by_key(|&(x, y)| (y, x));
            if !theirs.contains(&v) {
                extra += 1;
                let v = mser::variations_by_thresholds(&inner, r, &p).unwrap();
                assert_eq!(v.region.den, r.area as u64);
                assert_eq!(v.region.value(), r.variation);
                let (num, den) = (v.region.num, v.region.den);
                let (pn, pd) = (v.parent.num, v.parent.den);
                println!(
                    "ours only: {:?} level {} area {} variation {num}/{den}; parent level {} variation {pn}/{pd}",
                    r.polarity, r.level, r.area, v.parent_level
                );
                assert!(
                    v.is_positive_parent_tie(),
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

/// The Oxford data folder, or `None` (with the reason printed) when it is not available; under
/// `CI=true` a missing folder fails the test instead, so CI cannot pass by skipping.
pub fn oxford_dir() -> Option<std::path::PathBuf> {
    let dir = std::env::var_os("VISGUIDE_DATA")
        .map(|root| std::path::PathBuf::from(root).join("oxford-affine"));
    if let Some(dir) = dir.filter(|d| d.join("graf/img1.png").exists()) {
        return Some(dir);
    }
    let why = "VISGUIDE_DATA/oxford-affine/graf/img1.png not found";
    assert!(
        std::env::var("CI").as_deref() != Ok("true"),
        "CI=true: {why}"
    );
    eprintln!("skipped: {why}");
    None
}
